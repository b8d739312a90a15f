// The view in a real browser (Debian's chromium, headless, software GL), driven by playwright-core:
// `modal-rt view` serves a synthetic basis; the test presses a vertex with the mouse, holds, and
// checks that
//   - the force the page shows equals the kernel's (GET /api/state) within 1e-6 relative, and the
//     mouse spring's F = k s;
//   - the pressed vertex's displacement the page computes (from the basis it received, q and the
//     contacts' corrections, as its shader does) equals the kernel's own reconstruction of that vertex
//     (modalrt_display_reconstruct_f64 on the same snapshot) within 1e-6 relative;
//   - frames arrive at >= 30 per second (the figure; how many of them software GL draws on a
//     loaded 2-core machine is printed, not asserted: it measures the machine, see benchmarks/view);
//   - a screenshot is not blank (it is written to --screenshot for the README);
//   - on Ctrl-C it exits 0 and its haptic thread (the run loop with the mouse device) allocated nothing.
// Usage: node test_view_browser.mjs --modal-rt BIN --basis FILE [--screenshot PNG]
import { spawn } from 'node:child_process';
import { args, check, fail, finish, launchChromium } from './browser_support.mjs';
const relative = (a, b) => Math.hypot(...a.map((x, i) => x - b[i])) / Math.max(Math.hypot(...b), 1e-300);

const server = spawn(args['modal-rt'], ['view', '--basis', args.basis, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
let serverOut = '';
server.stdout.on('data', (d) => { serverOut += d; });
const serverExit = new Promise((resolve) => server.on('exit', (code) => resolve(code)));
const url = await new Promise((resolve, reject) => {
  let out = '';
  server.stdout.on('data', (d) => { out += d; const m = out.match(/http:\/\/[0-9.]+:[0-9]+\//); if (m) resolve(m[0]); });
  server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}: ${out}`)));
  setTimeout(() => reject(new Error('modal-rt view printed no address in 10 s')), 10000);
});
console.log(`server ${url}`);

const browser = await launchChromium();
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 620 } });
  page.on('pageerror', (e) => { console.log(`page error: ${e.message}`); fail(); });
  await page.goto(url);
  await page.waitForFunction(() => window.viewState?.ready && window.viewState.frames > 5, null, { timeout: 30000 });

  // Press the tip of the cantilever (display vertex 24 of the lattice fixture, next to the tip: a candidate of the
  // tip space, so the static correction and a space switch are part of the check).
  const vertex = Number(args.vertex ?? 24);
  const at = await page.evaluate((v) => window.viewDebug.project(v), vertex);
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  for (let k = 1; k <= 10; ++k) await page.mouse.move(at.x, at.y + 8 * k);
  await page.waitForTimeout(2500); // hold: frames keep arriving while the part rings down

  const shown = await page.evaluate(() => {
    const s = window.viewState;
    const force = document.getElementById('hip0-force'), u = document.getElementById('hip0-u');
    return { fps: s.fps, receivedFps: s.receivedFps, frames: s.frames, bytes: s.bytesPerFrame, basisBytes: s.basisBytes, ageP50: s.ageP50, ageP95: s.ageP95,
      pressed: s.pressed, hip: s.hips[0], forceShown: force ? Number(force.dataset.value) : NaN,
      uShown: u ? u.dataset.value.split(',').map(Number) : [NaN, NaN, NaN] };
  });
  const kernel = await (await fetch(`${url}api/state`)).json();
  const k = kernel.hips[0];
  check(k.in_contact === 1 && k.vertex === vertex, `the kernel's HIP 0 is in contact at vertex ${vertex} (vertex ${k.vertex})`);
  const kernelForce = Math.hypot(...k.force);
  check(Math.abs(shown.forceShown - kernelForce) <= 1e-6 * kernelForce && kernelForce > 0.1,
    `force shown ${shown.forceShown} N = kernel's ${kernelForce} N within 1e-6 relative`);
  check(Math.abs(shown.pressed.force - kernelForce) <= 1e-6 * kernelForce,
    `mouse spring F = k s = ${shown.pressed.force} N (drag ${(shown.pressed.travel * 1000).toFixed(3)} mm) is what the kernel got`);
  const e = relative(shown.uShown, shown.hip.kernelDisplacement);
  check(e <= 1e-6 && Math.hypot(...shown.uShown) > 0,
    `displacement of vertex ${vertex} on the page [${shown.uShown.map((x) => x.toExponential(6))}] m = kernel's reconstruction, relative difference ${e.toExponential(2)}`);
  check(shown.receivedFps >= 30, `frames arriving per second ${shown.receivedFps.toFixed(1)} >= 30 (drawn: ${shown.fps.toFixed(1)})`);
  console.log(`figures: ${shown.bytes} bytes/frame, basis ${shown.basisBytes} bytes once, frame age tick->screen p50 ${shown.ageP50} ms p95 ${shown.ageP95} ms`);

  // Not blank: the canvas has many colors and few background pixels dominate less than 99 %.
  const pixels = await page.evaluate(() => {
    const c = window.viewDebug.canvas, g = document.createElement('canvas');
    g.width = c.width; g.height = c.height;
    const x = g.getContext('2d'); x.drawImage(c, 0, 0);
    const d = x.getImageData(0, 0, g.width, g.height).data;
    const colors = new Set(); let background = 0;
    for (let i = 0; i < d.length; i += 4) {
      colors.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
      if (Math.abs(d[i] - 0x1d) < 3 && Math.abs(d[i + 1] - 0x20) < 3 && Math.abs(d[i + 2] - 0x26) < 3) background += 1;
    }
    return { colors: colors.size, background: background / (d.length / 4) };
  });
  check(pixels.colors > 50 && pixels.background < 0.99, `screenshot not blank: ${pixels.colors} colors, ${(100 * pixels.background).toFixed(1)} % background`);
  if (args.screenshot) { await page.screenshot({ path: args.screenshot }); console.log(`screenshot ${args.screenshot}`); }

  // A second browser watches the same session.
  const second = await browser.newPage({ viewport: { width: 640, height: 400 } });
  await second.goto(url);
  await second.waitForFunction(() => window.viewState?.frames > 5 && window.viewState.hips?.[0]?.inContact === 1, null, { timeout: 30000 });
  check(true, 'a second browser sees the same contact');

  await page.mouse.up();
  await page.waitForTimeout(300);
  const after = await (await fetch(`${url}api/state`)).json();
  check(after.hips[0].in_contact === 0, 'releasing the mouse releases the HIP');

  // Ctrl-C: the run loop stops cleanly and says how it ran; the mouse device, like every device of
  // the loop, allocated nothing in the haptic thread.
  server.kill('SIGINT');
  const code = await serverExit;
  const loop = serverOut.match(/modal-rt view: (\d+) ticks .* (\d+) allocations in the haptic thread/);
  check(code === 0 && loop !== null && Number(loop[1]) > 1000 && Number(loop[2]) === 0,
    `modal-rt view exits 0 on SIGINT, no allocation in the haptic thread: ${loop ? loop[0] : serverOut}`);
} finally {
  await browser.close();
  server.kill('SIGINT');
}
finish();
