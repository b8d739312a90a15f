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
//   - the address without its token: refused in a browser without the cookie (the page says so), live
//     in the browser whose load with the token set it;
// and what a user sees (docs/reliability.md, "What a user sees"):
//   - the part at rest is visible: the mean luminance of its pixels >= PART_LUMA_MIN;
//   - no request of the page is answered 404 (the favicon; report.json is written beside the basis);
//   - a click says where the vertex is (mm, region) and the hint says how to turn the view;
//   - |u| (magnitude) and u·n (along the surface normal) are labelled, tiny lengths print as 0;
//   - the force-displacement plot keeps the press's points after the release;
//   - Live -> Modes (space, mode, amplification changed) -> Validation -> Live leaves the live
//     amplification, colour scale, active space and status word as they were; each tab has its own
//     legend; the validation table follows the modal-only/corrected switch.
//   - the Stiffness tab: hovering a vertex shows the felt-stiffness map's value there, equal to what
//     the kernel reads from the .mrt (`modal-rt info --vertex V`, modalrt_basis_felt_stiffness) within
//     float32's 1e-6; the legend's ends are the map's smallest and largest values (info's ranges per
//     space); a vertex of the clamped edge says "not computed";
//   - the validity map (the fixture has one): a light press is within its validity force, the full
//     press beyond it; each time the page's flag, the HIP's colour (white beyond), the panel's validity
//     force and the plot's dashed line equal the kernel's (GET /api/state: flags & 256, validity_force_n);
//   - on Ctrl-C it exits 0 and its haptic thread (the run loop with the mouse device) allocated nothing.
// Usage: node test_view_browser.mjs --modal-rt BIN --basis FILE [--screenshot PNG]
import { execFileSync, spawn } from 'node:child_process';
import { writeFileSync } from 'node:fs';
import path from 'node:path';
import { args, check, fail, finish, launchChromium, VIEW_URL, viewAddress } from './browser_support.mjs';
const relative = (a, b) => Math.hypot(...a.map((x, i) => x - b[i])) / Math.max(Math.hypot(...b), 1e-300);

// Rec. 709 luma of an sRGB pixel, 0..255. The background (#1d2026) has 31; the part at rest drawn at
// turbo's near-black end would have 22; the threshold leaves room below the blue it has now.
const PART_LUMA_MIN = 70;

// A report.json beside the basis, with distinct modal-only and corrected errors for the global
// space's validation cases (vertices 1, 16, 31 of the lattice, x y z), so that the Validation tab
// has both kinds to show (and GET /api/report is not a 404).
const reportCases = [1, 16, 31].flatMap((vertex) => ['x', 'y', 'z'].map((direction) => ({ vertex, direction })));
const report = {
  spaces: [{ name: 'global', n_dofs: 1, validation: reportCases.map((c, k) => ({ ...c, contact_rel_error_modal: 0.01 * (k + 1), contact_rel_error_corrected: 1e-13 * (k + 1) })) }],
};
writeFileSync(path.join(path.dirname(args.basis), 'report.json'), JSON.stringify(report));

// The canvas's pixels: how many colours, the background's share, and the part's pixels (those more
// than 12 away from the background in a channel): their share and mean luma.
function measureCanvas() {
  const c = window.viewDebug.canvas, g = document.createElement('canvas');
  g.width = c.width; g.height = c.height;
  const x = g.getContext('2d'); x.drawImage(c, 0, 0);
  const d = x.getImageData(0, 0, g.width, g.height).data;
  const colors = new Set(); let background = 0, part = 0, partLuma = 0;
  for (let i = 0; i < d.length; i += 4) {
    colors.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    const distance = Math.max(Math.abs(d[i] - 0x1d), Math.abs(d[i + 1] - 0x20), Math.abs(d[i + 2] - 0x26));
    if (distance < 3) background += 1;
    if (distance > 12) { part += 1; partLuma += 0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2]; }
  }
  const pixels = d.length / 4;
  return { colors: colors.size, background: background / pixels, part: part / pixels, partLuma: partLuma / Math.max(part, 1) };
}

const server = spawn(args['modal-rt'], ['view', '--basis', args.basis, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
let serverOut = '';
server.stdout.on('data', (d) => { serverOut += d; });
const serverExit = new Promise((resolve) => server.on('exit', (code) => resolve(code)));
const url = await new Promise((resolve, reject) => {
  let out = '';
  server.stdout.on('data', (d) => { out += d; const m = out.match(VIEW_URL); if (m) resolve(m[0]); });
  server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}: ${out}`)));
  setTimeout(() => reject(new Error('modal-rt view printed no address in 10 s')), 10000);
});
console.log(`server ${url}`);
const view = viewAddress(url);

const browser = await launchChromium();
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 620 } });
  page.on('pageerror', (e) => { console.log(`page error: ${e.message}`); fail(); });
  const notFound = [];
  page.on('response', (r) => { if (r.status() === 404) notFound.push(r.url()); });
  await page.goto(url);
  await page.waitForFunction(() => window.viewState?.ready && window.viewState.frames > 5, null, { timeout: 30000 });

  await page.waitForTimeout(300);
  const rest = await page.evaluate(measureCanvas);
  check(rest.part > 0.05 && rest.partLuma >= PART_LUMA_MIN,
    `the part at rest is visible: ${(100 * rest.part).toFixed(1)} % of the canvas, mean luma ${rest.partLuma.toFixed(1)} >= ${PART_LUMA_MIN} (background 31)`);
  check(notFound.length === 0, `no request answered 404 while loading (${notFound.join(', ') || 'none'})`);
  check((await page.textContent('#hint')).includes('drag the background: rotate'), `the hint says how to turn the view: "${await page.textContent('#hint')}"`);

  // Press the tip of the cantilever (display vertex 24 of the lattice fixture, next to the tip: a candidate of the
  // tip space, so the static correction and a space switch are part of the check).
  const vertex = Number(args.vertex ?? 24);
  const at = await page.evaluate((v) => window.viewDebug.project(v), vertex);
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  await page.mouse.move(at.x, at.y + 8);
  await page.waitForTimeout(600); // a light press first: within its validity force (about 0.6 N < F5 = 1.92 N)
  const light = await checkValidity(page, url, 'a light press');
  for (let k = 2; k <= 10; ++k) await page.mouse.move(at.x, at.y + 8 * k);
  await page.waitForTimeout(2500); // hold: frames keep arriving while the part rings down

  const shown = await page.evaluate(() => {
    const s = window.viewState;
    const force = document.getElementById('hip0-force'), u = document.getElementById('hip0-u');
    return { fps: s.fps, receivedFps: s.receivedFps, frames: s.frames, bytes: s.bytesPerFrame, basisBytes: s.basisBytes, ageP50: s.ageP50, ageP95: s.ageP95,
      pressed: s.pressed, hip: s.hips[0], forceShown: force ? Number(force.dataset.value) : NaN,
      uShown: u ? u.dataset.value.split(',').map(Number) : [NaN, NaN, NaN] };
  });
  const kernel = await (await view.api(`api/state`)).json();
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
  const where = await page.evaluate(() => ({ at: document.getElementById('hip0-at')?.textContent, region: document.getElementById('hip0-region')?.textContent,
    labels: [...document.querySelectorAll('#hips .row span:first-child')].map((e) => e.textContent) }));
  const info = await (await view.api(`api/info`)).json();
  const restMm = await page.evaluate((v) => window.viewDebug.restMm(v), vertex);
  check(where.at === `(${restMm.join(', ')}) mm` && /VOI '|outside every VOI/.test(where.region ?? '') && (where.region ?? '').includes(`kernel's space ${kernel.space} '${info.spaces[kernel.space].name}'`),
    `the click says where vertex ${vertex} is: ${where.at}, ${where.region}`);
  check(where.labels.includes('|u| (magnitude)') && where.labels.includes('u·n (along the surface normal)'), `the two displacements are labelled: ${where.labels.join(' | ')}`);
  const formatted = await page.evaluate(() => [window.viewDebug.formatMm(2.218542e-96, 8e-3), window.viewDebug.formatMm(1.100891e-4, 8e-3)]);
  check(formatted[0] === '0 mm' && formatted[1] === '0.1101 mm', `lengths: 2.2e-96 m prints as ${formatted[0]}, 1.100891e-4 m as ${formatted[1]} (4 digits)`);
  check(shown.receivedFps >= 30, `frames arriving per second ${shown.receivedFps.toFixed(1)} >= 30 (drawn: ${shown.fps.toFixed(1)})`);
  console.log(`figures: ${shown.bytes} bytes/frame, basis ${shown.basisBytes} bytes once, frame age tick->screen p50 ${shown.ageP50} ms p95 ${shown.ageP95} ms`);

  const hard = await checkValidity(page, url, 'the press');
  check(!light && hard, `the light press was within its validity force, the full press beyond it (the HIP white while beyond)`);

  // Not blank: the canvas has many colors and few background pixels dominate less than 99 %.
  const pixels = await page.evaluate(measureCanvas);
  check(pixels.colors > 50 && pixels.background < 0.99, `screenshot not blank: ${pixels.colors} colors, ${(100 * pixels.background).toFixed(1)} % background`);
  if (args.screenshot) { await page.screenshot({ path: args.screenshot }); console.log(`screenshot ${args.screenshot}`); }

  // A second browser watches the same session.
  const second = await browser.newPage({ viewport: { width: 640, height: 400 } });
  await second.goto(url);
  await second.waitForFunction(() => window.viewState?.frames > 5 && window.viewState.hips?.[0]?.inContact === 1, null, { timeout: 30000 });
  check(true, 'a second browser sees the same contact');

  // The token: the bare address in a browser without the cookie is refused, and the page says so;
  // the second browser, whose load with the token set the cookie, reloads the bare address live.
  const bare = url.split('?')[0];
  const stranger = await browser.newPage();
  await stranger.goto(bare);
  await stranger.waitForFunction(() => /refused/.test(document.getElementById('status').textContent), null, { timeout: 10000 }).catch(() => {});
  const refusal = await stranger.evaluate(() => document.getElementById('status').textContent);
  check(/refused: no token/.test(refusal), `the address without the token, no cookie: "${refusal}"`);
  await stranger.close();
  await second.goto(bare);
  const reloaded = await second.waitForFunction(() => window.viewState?.frames > 5, null, { timeout: 30000 }).then(() => true, () => false);
  check(reloaded, 'the address without the token, with the cookie of its load with the token: frames arrive');

  await page.mouse.up();
  await page.waitForTimeout(300);
  const after = await (await view.api(`api/state`)).json();
  check(after.hips[0].in_contact === 0, 'releasing the mouse releases the HIP');
  await checkPlotKept(page);
  await checkTabsOwnTheirState(page);
  await checkValidationTable(page);
  await checkStiffnessMode(page, vertex);

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

// The validity map (the fixture's: F1, F5, F10 = 0.2, 1, 2 N x (1 + x / 0.2 m) at the candidates): the
// page's HIP 0 against the kernel's output (GET /api/state): the BEYOND_VALIDITY flag (256), the sphere's
// colour (white beyond, its own colour within), the panel's validity force and state, and the plot's
// dashed line at the kernel's validity force. Returns whether the kernel said beyond.
async function checkValidity(page, url, what) {
  await page.waitForTimeout(200);
  const shown = await page.evaluate(() => {
    const s = window.viewState, cell = document.getElementById('hip0-validity');
    return { hip: s.hips[0], line: s.plotValidity?.[0] ?? null, value: cell ? Number(cell.dataset.value) : NaN,
      beyondShown: cell ? cell.dataset.beyond === '1' : null, text: cell?.textContent };
  });
  const kernel = (await (await view.api(`api/state`)).json()).hips[0];
  const beyond = (kernel.flags & 256) !== 0, F = Math.hypot(...kernel.force), Fv = kernel.validity_force_n;
  check(Fv > 0 && shown.value === Fv && shown.hip.validityForce === Fv && shown.line === Fv,
    `${what}: the kernel's validity force F5 ${Fv} N is the panel's (${shown.value}) and the plot's dashed line (${shown.line})`);
  check(shown.hip.beyond === beyond && shown.beyondShown === beyond && beyond === F > Fv
    && shown.hip.sphereColor === (beyond ? 0xffffff : 0xff4fd8),
    `${what}: ${F.toFixed(4)} N ${beyond ? '>' : '<='} ${Fv.toFixed(4)} N: the kernel's flag ${beyond ? 'BEYOND' : 'within'}, the page's the same, sphere #${shown.hip.sphereColor.toString(16)} ("${shown.text}")`);
  return beyond;
}

// After the release the force-displacement plot still holds the press's curve.
async function checkPlotKept(page) {
  await page.waitForFunction(() => window.viewState.hips[0]?.inContact === 0, null, { timeout: 10000 }); // the page saw the release
  const atRelease = await page.evaluate(() => window.viewState.plotPoints[0]);
  await page.waitForTimeout(1000);
  const later = await page.evaluate(() => ({ points: window.viewState.plotPoints[0], hip: window.viewState.hips[0].inContact }));
  check(later.hip === 0 && atRelease >= 10 && later.points === atRelease,
    `the plot keeps the released press: ${later.points} points 1 s after the release (${atRelease} at the release)`);
}

// What the Live tab shows of its own display state.
function liveDisplay(page) {
  return page.evaluate(() => Object.fromEntries(['exaggeration-value', 'live-legend-high', 'space', 'status']
    .map((id) => [id, document.getElementById(id).textContent])));
}

async function checkTabsOwnTheirState(page) {
  const before = await liveDisplay(page);
  await page.click('#tab-modes');
  await page.selectOption('#mode-space', '1');
  await page.$eval('#mode-index', (e) => { e.value = '3'; e.dispatchEvent(new Event('input')); });
  await page.$eval('#mode-amplification', (e) => { e.value = '0.5'; e.dispatchEvent(new Event('input')); });
  await page.waitForTimeout(300);
  const modes = await page.evaluate(() => ({ status: document.getElementById('status').textContent, legend: document.getElementById('modes-legend').textContent }));
  check(modes.status.startsWith('modes (offline): mode 4') && modes.legend.includes('|φ|'), `Modes says what it shows: "${modes.status}", legend "${modes.legend.replace(/\s+/g, ' ').trim()}"`);
  await page.click('#tab-validation');
  await page.selectOption('#validation-kind', 'corrected');
  await page.waitForTimeout(300);
  await page.click('#tab-live');
  await page.waitForTimeout(300);
  const back = await liveDisplay(page);
  check(JSON.stringify(back) === JSON.stringify(before), `Live -> Modes -> Validation -> Live leaves the live display as it was: ${JSON.stringify(back)}`);
}

// The table shows the error the switch selects, the report's numbers for each case.
async function checkValidationTable(page) {
  await page.click('#tab-validation');
  await page.selectOption('#validation-space', '0');
  const column = async (kind) => {
    await page.selectOption('#validation-kind', kind);
    return page.$$eval('#validation-cases td[data-value]', (cells) => cells.map((c) => Number(c.dataset.value)));
  };
  const expect = (key) => report.spaces[0].validation.map((row) => row[key]);
  const modal = await column('modal'), corrected = await column('corrected');
  check(JSON.stringify(modal) === JSON.stringify(expect('contact_rel_error_modal')) && JSON.stringify(corrected) === JSON.stringify(expect('contact_rel_error_corrected')),
    `the validation table follows the modal-only/corrected switch (${modal.length} cases: ${modal[0]} ... then ${corrected[0]} ...)`);
  const legend = await page.textContent('#validation-legend');
  check(legend.includes('contact error') && await page.isHidden('#live-legend'), 'Validation shows its own legend (the error scale), not the |u| bar');
  await page.click('#tab-live');
}

// The Stiffness tab against the kernel's reading of the same .mrt (modal-rt info): the value under the
// pointer at `vertex` (the map's, its region's space), the legend's range, a vertex without a value.
async function checkStiffnessMode(page, vertex) {
  const info = (...extra) => execFileSync(args['modal-rt'], ['info', '--basis', args.basis, ...extra], { encoding: 'utf8' });
  const mapAt = (v) => Number(info('--vertex', String(v)).match(/felt-stiffness map: ([0-9.eE+-]+) N\/mm/)?.[1]);
  const ranges = [...info().matchAll(/: min ([0-9.eE+-]+) \/ median [0-9.eE+-]+ \/ max ([0-9.eE+-]+) N\/mm/g)];
  const low = Math.min(...ranges.map((m) => Number(m[1]))), high = Math.max(...ranges.map((m) => Number(m[2])));
  await page.click('#tab-stiffness');
  await page.waitForTimeout(300);
  const range = await page.evaluate(() => { const t = document.getElementById('stiffness-range').textContent; return t.slice(t.indexOf(', ') + 2); });
  const hover = async (v, toward) => {
    const a = await page.evaluate((x) => window.viewDebug.project(x), v);
    const b = await page.evaluate((x) => window.viewDebug.project(x), toward);
    await page.mouse.move(a.x + 0.2 * (b.x - a.x) + 1, a.y + 0.2 * (b.y - a.y)); // just inside the part, nearest to v
    await page.mouse.move(a.x + 0.2 * (b.x - a.x), a.y + 0.2 * (b.y - a.y));
    return page.evaluate(() => ({ vertex: Number(document.getElementById('stiffness-vertex').dataset.value),
      value: Number(document.getElementById('stiffness-value').dataset.value), text: document.getElementById('stiffness-value').textContent }));
  };
  const expected = mapAt(vertex);
  const shown = await hover(vertex, vertex - 1);
  check(shown.vertex === vertex && expected > 0 && Math.abs(shown.value - expected) <= 1e-6 * expected,
    `Stiffness: under the pointer vertex ${shown.vertex}, ${shown.value} N/mm ("${shown.text}") = the map's ${expected} N/mm (modal-rt info --vertex) within 1e-6`);
  const edge = 13; // lattice node (0, 1): on the clamped edge, no correction, no value
  const grey = await hover(edge, edge + 1);
  check(grey.vertex === edge && grey.value === 0 && grey.text === 'not computed' && !(mapAt(edge) > 0),
    `Stiffness: vertex ${grey.vertex} of the clamped edge says "${grey.text}"`);
  const legend = await page.evaluate(() => [document.getElementById('stiffness-legend-low')?.textContent, document.getElementById('stiffness-legend-high')?.textContent]);
  const near = (text, x) => Math.abs(parseFloat(text) - x) <= 1e-3 * x;
  // The colours span the smallest value to the 95th percentile (a clamp's vertices are almost rigid).
  const top = parseFloat(legend[1]?.replace('≥ ', ''));
  check(legend.every((t) => t?.endsWith(' N/mm')) && near(legend[0], low) && top > low && top <= high * (1 + 1e-3)
    && range.split(' – ').map(parseFloat).every((x, i) => near(`${x}`, [low, high][i])),
    `Stiffness: legend ${legend.join(' .. ')} from the map's smallest value; the map ${range} = info's range ${low} .. ${high} N/mm`);
  const status = await page.textContent('#status');
  check(status.startsWith('stiffness (offline)') && await page.isHidden('#live-legend'), `Stiffness says what it shows: "${status}"`);
  if (args.screenshot) await page.screenshot({ path: args.screenshot.replace(/\.png$/, '_stiffness.png') });
  await page.click('#tab-live');
}
