// modal-rt view --compare B.mrt in a real browser (Debian's chromium, headless, software GL): the
// lattice fixture as A (--basis), the same lattice with its felt-stiffness map 1.3 times A's as B.
//   - GET /api/info names B; GET /api/comparison has the identity rule, every compared vertex at
//     +30 % (1e-9) and null at the clamped edge (not computed in A), ratio 1.3;
//   - the Stiffness tab's "show" switch appears; on the difference map, hovering a vertex shows A, B
//     and +30.000 %, the legend's top is +30 % (the 95th percentile of |%|), and the part is drawn in
//     the warm end of the scale (B stiffer): red well above blue under the pointer; back on the map,
//     the vertex shows A's value alone;
//   - without --compare, /api/comparison is a 404 and the switch stays hidden; --compare with a file
//     without a map exits 1 naming it, --noise without --compare exits 2.
// Usage: node test_view_compare.mjs --modal-rt BIN --basis LATTICE --maker FIXTURE_MAKER --work DIR [--screenshot PNG]
import { execFileSync, spawn, spawnSync } from 'node:child_process';
import { mkdirSync } from 'node:fs';
import path from 'node:path';
import { args, check, finish, launchChromium, VIEW_URL, viewAddress } from './browser_support.mjs';

mkdirSync(args.work, { recursive: true });
const a = args.basis, b = path.join(args.work, 'design_b.mrt');
execFileSync(args.maker, ['lattice', b, '1.3']);

// Starts `modal-rt view` with `options`; resolves to the server and its address.
function startView(options) {
  const server = spawn(args['modal-rt'], ['view', '--port', '0', ...options], { stdio: ['ignore', 'pipe', 'inherit'] });
  const url = new Promise((resolve, reject) => {
    let out = '';
    server.stdout.on('data', (d) => { out += d; const m = out.match(VIEW_URL); if (m) resolve(m[0]); });
    server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}: ${out}`)));
    setTimeout(() => reject(new Error('modal-rt view printed no address in 20 s')), 20000);
  });
  return { server, url };
}

// The canvas's pixel (r, g, b) at client position (x, y) (run in the page).
function pixelAt([x, y]) {
  const c = window.viewDebug.canvas, rect = c.getBoundingClientRect();
  const g = document.createElement('canvas');
  g.width = c.width; g.height = c.height;
  const context = g.getContext('2d'); context.drawImage(c, 0, 0);
  const px = Math.round((x - rect.left) * c.width / rect.width), py = Math.round((y - rect.top) * c.height / rect.height);
  return Array.from(context.getImageData(px, py, 1, 1).data.slice(0, 3));
}

const browser = await launchChromium();
const withB = startView(['--basis', a, '--compare', b]);
try {
  const view = viewAddress(await withB.url);
  const info = await (await view.api('api/info')).json();
  check(info.comparison === b, `/api/info names design B (${info.comparison})`);
  const c = await (await view.api('api/comparison')).json();
  const compared = c.percent.filter((p) => p !== null);
  check(c.rule === 'identity', `rule ${c.rule}`);
  check(compared.length === c.compared && c.compared > 0 && c.percent.length === info.vertices,
    `${c.compared} of ${info.vertices} vertices compared`);
  check(compared.every((p) => Math.abs(p - 30) <= 1e-9), `every compared vertex +30 % (${Math.min(...compared)} .. ${Math.max(...compared)})`);
  check(c.percent[0] === null, 'vertex 0 (the clamped edge) is not compared');
  check(Math.abs(c.ratio.median - 1.3) <= 1e-12 && c.beyond_noise === c.compared, `ratio ${c.ratio.median}, ${c.beyond_noise} beyond the floor`);

  const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  await page.goto(view.page);
  await page.waitForFunction(() => window.viewState?.ready, null, { timeout: 60000 });
  await page.click('#tab-stiffness');
  check(await page.isVisible('#stiffness-show'), 'the Stiffness tab has the show switch');
  await page.selectOption('#stiffness-show', 'difference');
  await page.waitForTimeout(500);
  const vertex = c.percent.findIndex((p, v) => p !== null && v > info.vertices / 2); // inside, not an edge
  const at = await page.evaluate((v) => window.viewDebug.project(v), vertex);
  await page.mouse.move(at.x + 1, at.y);
  await page.mouse.move(at.x, at.y);
  await page.waitForTimeout(500);
  const shown = await page.textContent('#stiffness-value');
  check(shown.includes('+30.000 %') && shown.includes('A ') && shown.includes('B '), `vertex ${vertex}: ${shown}`);
  const high = await page.textContent('#stiffness-legend-high');
  check(high.startsWith('+30.0 %'), `legend top ${high}`);
  await page.mouse.move(10, 10); // the label off the part
  await page.waitForTimeout(300);
  const warm = await page.evaluate(pixelAt, [at.x, at.y]);
  check(warm[0] > 2 * warm[2], `the part under vertex ${vertex} is warm (B stiffer): rgb ${warm}`);
  if (args.screenshot) await page.screenshot({ path: args.screenshot });
  await page.selectOption('#stiffness-show', 'map');
  await page.mouse.move(at.x + 1, at.y);
  await page.mouse.move(at.x, at.y);
  await page.waitForTimeout(500);
  const mapText = await page.textContent('#stiffness-value');
  check(mapText.endsWith('N/mm') && !mapText.includes('%'), `on the map: ${mapText}`);
  await page.mouse.move(10, 10);
  await page.waitForTimeout(300);
  const mapColour = await page.evaluate(pixelAt, [at.x, at.y]);
  check(mapColour.some((x, i) => Math.abs(x - warm[i]) > 20), `the map's colour there is another: rgb ${mapColour}`);
} finally {
  withB.server.kill('SIGINT');
}

// Without --compare: no comparison, no switch.
const alone = startView(['--basis', a]);
try {
  const view = viewAddress(await alone.url);
  check((await view.api('api/comparison')).status === 404, '/api/comparison without --compare: 404');
  const page = await browser.newPage();
  await page.goto(view.page);
  await page.waitForFunction(() => window.viewState?.ready, null, { timeout: 60000 });
  await page.click('#tab-stiffness');
  check(!(await page.isVisible('#stiffness-show')), 'no show switch without --compare');
} finally {
  alone.server.kill('SIGINT');
  await browser.close();
}

// Refusals: a design without a map, --noise alone.
const noMap = path.join(args.work, 'design_no_map.mrt');
execFileSync(args.maker, ['plate', noMap, '8', '8', '4']);
const refused = spawnSync(args['modal-rt'], ['view', '--basis', a, '--compare', noMap, '--port', '0', '--duration', '5'], { encoding: 'utf8' });
check(refused.status === 1 && refused.stderr.includes(`'${noMap}' has no felt-stiffness map`), `--compare without a map: exit ${refused.status}, ${refused.stderr.trim()}`);
const noise = spawnSync(args['modal-rt'], ['view', '--basis', a, '--noise', '2'], { encoding: 'utf8' });
check(noise.status === 2 && noise.stderr.includes('--noise is an option of --compare'), `--noise alone: exit ${noise.status}`);
finish();
