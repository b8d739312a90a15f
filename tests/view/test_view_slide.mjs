// Sliding with the mouse in a real browser (Debian's chromium through playwright-core): `modal-rt view
// --contact proxy` serves the lattice cantilever (the fixture's beam stands in for a rib: a long narrow
// part pressed on its top face); the test presses its top face at x = 50 mm with the page's slide
// force, drags the pointer along the beam to x = 150 mm (across the tip VOI's boundary at x = 120 mm)
// and holds still. It checks that
//   - the proxy slid: frames flagged SLIDING during the drag, its position now more than 60 mm along
//     x from where it started, the kernel's space switched into the tip VOI;
//   - the proxy's position the page draws equals the kernel's output (GET /api/state, the same haptic
//     tick) within 1e-7 m (the page's rest positions are float32),
//     and the force the page shows equals the kernel's within 1e-6 relative, its normal part the
//     slide force within 5 % (the mouse servoes its depth to it);
//   - while it slid, the friction force over the normal one was mu_d (0.2) within 5 %;
//   - the page draws the proxy's path: its points start where the press began and end at the proxy;
//   - the static stiffness the page shows is the kernel's at the proxy's point;
//   - releasing the mouse releases the HIP; Ctrl-C exits 0 with no allocation in the haptic thread.
// Usage: node test_view_slide.mjs --modal-rt BIN --basis FILE
import { spawn } from 'node:child_process';
import { args, check, fail, finish, launchChromium, VIEW_URL, viewAddress } from './browser_support.mjs';

const mu_d = 0.2, slideForce = 0.5;
const server = spawn(args['modal-rt'], ['view', '--basis', args.basis, '--port', '0', '--contact', 'proxy', '--friction', `0.3,${mu_d}`],
  { stdio: ['ignore', 'pipe', 'inherit'] });
let serverOut = '';
server.stdout.on('data', (d) => { serverOut += d; });
const serverExit = new Promise((resolve) => server.on('exit', (code) => resolve(code)));
const url = await new Promise((resolve, reject) => {
  server.stdout.on('data', () => { const m = serverOut.match(VIEW_URL); if (m) resolve(m[0]); });
  server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}: ${serverOut}`)));
  setTimeout(() => reject(new Error('modal-rt view printed no address in 10 s')), 10000);
});
console.log(`server ${url}`);
const view = viewAddress(url);
const kernelState = async () => (await view.api(`api/state`)).json();

const browser = await launchChromium();
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 620 } });
  page.on('pageerror', (e) => { console.log(`page error: ${e.message}`); fail(); });
  await page.goto(`${url}&force=${slideForce}`);
  await page.waitForFunction(() => window.viewState?.ready && window.viewState.frames > 5, null, { timeout: 30000 });
  check((await page.textContent('#hint')).includes('drag over the part: it slides'), `the hint says a drag slides: "${await page.textContent('#hint')}"`);

  // The fixture's top face: 13 x 4 vertices, vertex j * 13 + i at x = i / 12 * 0.2 m, y = j / 3 * 0.05 m.
  const from = 13 + 3, to = 13 + 9; // x = 50 mm and 150 mm, y = 16.7 mm
  const start = await page.evaluate((v) => window.viewDebug.project(v), from);
  const end = await page.evaluate((v) => window.viewDebug.project(v), to);
  const restFrom = await page.evaluate((v) => window.viewDebug.restMm(v).map(Number), from);
  await page.mouse.move(start.x, start.y);
  await page.mouse.down();
  await page.waitForTimeout(800); // pressed in: the servo reaches the slide force
  const samples = [];
  const steps = 60;
  for (let k = 1; k <= steps; ++k) { // about 3 s: some 33 mm/s along the beam
    await page.mouse.move(start.x + (end.x - start.x) * k / steps, start.y + (end.y - start.y) * k / steps);
    await page.waitForTimeout(50);
    samples.push(await page.evaluate(() => window.viewState.hips[0]));
  }
  await page.waitForTimeout(2500); // hold still: the proxy sticks where the slide left it, the part rings down

  const sliding = samples.filter((h) => h?.inContact === 1 && h.sliding);
  const ratios = sliding.map((h) => {
    const n = [0, 0, 1]; // the top face's outward normal
    const along = h.force.reduce((s, f, d) => s + f * n[d], 0);
    return Math.hypot(h.force[0], h.force[1]) / along;
  });
  const worstRatio = Math.max(...ratios.map((r) => Math.abs(r - mu_d) / mu_d));
  check(sliding.length >= 10 && worstRatio <= 0.05,
    `${sliding.length} of ${samples.length} sampled frames sliding, friction / normal force within ${(100 * worstRatio).toFixed(2)} % of mu_d = ${mu_d}`);

  // The page's HIP and the kernel's state of the same haptic tick (the page fetches both).
  const { shown, kernel } = await page.evaluate(async () => {
    for (let attempt = 0; attempt < 200; ++attempt) {
      const state = await (await fetch('/api/state')).json();
      const hip = window.viewState.hips[0];
      if (hip?.tick === state.haptic_tick)
        return { kernel: state, shown: { hip, forceShown: Number(document.getElementById('hip0-force')?.dataset.value),
          proxyText: document.getElementById('hip0-proxy')?.textContent, path: window.viewDebug.path(0) } };
      await new Promise((resolve) => setTimeout(resolve, 3));
    }
    return { kernel: null, shown: null };
  });
  check(kernel !== null, 'the page and GET /api/state showed the same haptic tick');
  const k = kernel.hips[0];
  check(k.in_contact === 1 && shown.hip.inContact === 1, 'the HIP is in contact after the drag');
  const gap = Math.hypot(...shown.hip.position.map((x, d) => x - k.position[d]));
  // The page adds the frame's felt offset to its rest positions, which the basis sends as float32.
  check(gap <= 1e-7, `the proxy the page draws [${shown.hip.position.map((x) => (1e3 * x).toFixed(3))}] mm is the kernel's, ${gap.toExponential(2)} m apart`);
  const travel = 1e3 * k.position[0] - restFrom[0];
  check(travel > 60 && Math.abs(1e3 * k.position[2] - 10) < 1, `the proxy slid ${travel.toFixed(1)} mm along the beam from vertex ${from}, on its top face (z ${(1e3 * k.position[2]).toFixed(3)} mm)`);
  check(kernel.space === 1, `the kernel switched into the tip VOI's space while sliding (space ${kernel.space})`);
  const kernelForce = Math.hypot(...k.force);
  check(Math.abs(shown.forceShown - kernelForce) <= 1e-6 * kernelForce, `force shown ${shown.forceShown} N = kernel's ${kernelForce} N`);
  check(Math.abs(k.force[2] - slideForce) <= 0.05 * slideForce, `normal force ${k.force[2].toFixed(4)} N is the slide force ${slideForce} N within 5 %`);
  check(Math.abs(shown.hip.staticStiffness - k.static_stiffness_n_per_m) <= 1e-9 * k.static_stiffness_n_per_m && k.static_stiffness_n_per_m > 0,
    `static stiffness at the proxy: page ${shown.hip.staticStiffness} N/m, kernel ${k.static_stiffness_n_per_m} N/m`);
  const first = shown.path.first, last = shown.path.last;
  check(shown.path.points > 50 && Math.abs(1e3 * first[0] - restFrom[0]) < 5 && Math.hypot(...last.map((x, d) => x - k.position[d])) < 1e-6,
    `the path is drawn: ${shown.path.points} points from x = ${(1e3 * first[0]).toFixed(1)} mm to the proxy at ${(1e3 * last[0]).toFixed(1)} mm`);
  check(/stuck|sliding/.test(shown.proxyText ?? ''), `the panel says what the proxy does: "${shown.proxyText}"`);

  await page.mouse.up();
  await page.waitForTimeout(500);
  check((await kernelState()).hips[0].in_contact === 0, 'releasing the mouse releases the HIP');
  server.kill('SIGINT');
  const code = await serverExit;
  const loop = serverOut.match(/modal-rt view: (\d+) ticks .* (\d+) allocations in the haptic thread/);
  check(code === 0 && loop !== null && Number(loop[2]) === 0, `modal-rt view exits 0, no allocation in the haptic thread: ${loop ? loop[0] : serverOut}`);
} finally {
  await browser.close();
  server.kill('SIGINT');
}
finish();
