// The view's figures (benchmarks/view/README.md): frames drawn per second, bytes per frame, frame age
// from the haptic tick to the screen, and the haptic tick with and without a browser attached.
// Usage: node bench_view.mjs --modal-rt BIN --basis FILE --vertex V [--seconds S] [--screenshot PNG] [--csv FILE --label NAME]
import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';
import fs from 'node:fs';
import path from 'node:path';

const args = Object.fromEntries(process.argv.slice(2).reduce((a, x, i, all) => (x.startsWith('--') ? [...a, [x.slice(2), all[i + 1]]] : a), []));
const here = path.dirname(fileURLToPath(import.meta.url));
const { chromium } = createRequire(path.join(here, '../../view/web/package.json'))('playwright-core');
const seconds = Number(args.seconds ?? 10);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const server = spawn(args['modal-rt'], ['view', '--basis', args.basis, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve, reject) => {
  let out = '';
  server.stdout.on('data', (d) => { out += d; const m = out.match(/http:\/\/[^\s/]+:[0-9]+\/\?token=[0-9a-f]{64}/); if (m) resolve(m[0]); });
  server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}`)));
});

// Tick statistics: the server's per-second windows, sampled `n` times.
async function tickWindows(n) {
  const rows = [];
  for (let k = 0; k < n; ++k) { await sleep(1100); rows.push(await (await fetch(`${new URL(url).origin}/api/state`, { headers: { 'X-Modal-RT-Token': new URL(url).searchParams.get('token') } })).json()); }
  const median = (xs) => xs.sort((a, b) => a - b)[Math.floor(xs.length / 2)];
  return { tick_p50_us: median(rows.map((r) => r.tick_us.p50)), tick_p99_us: median(rows.map((r) => r.tick_us.p99)),
    tick_max_us: Math.max(...rows.map((r) => r.tick_us.max)), late_p99_us: median(rows.map((r) => r.lateness_us.p99)),
    late_max_us: Math.max(...rows.map((r) => r.lateness_us.max)) };
}

const without = await tickWindows(seconds);
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  args: ['--use-angle=swiftshader', '--use-gl=angle', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'] });
const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
const t0 = Date.now();
await page.goto(url);
await page.waitForFunction(() => window.viewState?.ready && window.viewState.frames > 0, null, { timeout: 300000 });
const loadSeconds = (Date.now() - t0) / 1000;
const at = await page.evaluate((v) => window.viewDebug.project(v), Number(args.vertex));
await page.mouse.move(at.x, at.y);
await page.mouse.down();
for (let k = 1; k <= 10; ++k) await page.mouse.move(at.x, at.y + 10 * k);
const fps = [];
for (let k = 0; k < Math.max(3, Math.floor(seconds / 2)); ++k) { await sleep(1000); fps.push(await page.evaluate(() => window.viewState.fps)); }
const withViewer = await tickWindows(seconds);
const s = await page.evaluate(() => ({ bytes: window.viewState.bytesPerFrame, basis: window.viewState.basisBytes,
  p50: window.viewState.ageP50, p95: window.viewState.ageP95, hip: window.viewState.hips[0], received: window.viewState.receivedFps }));
if (args.screenshot) await page.screenshot({ path: args.screenshot });
await browser.close();
server.kill('SIGINT');

const info = await Promise.resolve(null);
const fpsMedian = [...fps].sort((a, b) => a - b)[Math.floor(fps.length / 2)];
const row = { label: args.label ?? path.basename(args.basis), fps: fpsMedian, bytes_per_frame: s.bytes, basis_bytes: s.basis,
  page_load_s: loadSeconds, frame_age_p50_ms: s.p50, frame_age_p95_ms: s.p95, in_contact: s.hip?.inContact ?? 0,
  tick_p50_us_without: without.tick_p50_us, tick_p99_us_without: without.tick_p99_us, tick_max_us_without: without.tick_max_us,
  late_p99_us_without: without.late_p99_us, late_max_us_without: without.late_max_us,
  tick_p50_us_with: withViewer.tick_p50_us, tick_p99_us_with: withViewer.tick_p99_us, tick_max_us_with: withViewer.tick_max_us,
  late_p99_us_with: withViewer.late_p99_us, late_max_us_with: withViewer.late_max_us };
console.log(JSON.stringify(row, null, 1));
if (args.csv) {
  const header = Object.keys(row).join(',');
  const exists = fs.existsSync(args.csv);
  fs.appendFileSync(args.csv, (exists ? '' : header + '\n') + Object.values(row).map((x) => (typeof x === 'number' ? +x.toPrecision(6) : x)).join(',') + '\n');
}
