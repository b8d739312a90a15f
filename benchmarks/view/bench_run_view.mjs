// `modal-rt run` with and without `--view` and a browser watching (benchmarks/view/README.md): the
// same session twice; the haptic tick's latency and period jitter from each run's stats.json, and
// with the view the frames the page received and drew per second.
// Usage: node bench_run_view.mjs --modal-rt BIN --basis MRT --session CSV --work DIR --label NAME [--csv FILE]
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { args, launchChromium } from '../../tests/view/browser_support.mjs';

function run(dir, extra) {
  const child = spawn(args['modal-rt'], ['run', '--basis', args.basis, '--session', args.session, '--output-dir', dir,
    '--no-plot', '--quiet', ...extra], { stdio: ['ignore', 'pipe', 'inherit'] });
  let out = '';
  const exited = new Promise((resolve) => child.on('exit', resolve));
  const url = new Promise((resolve) => child.stdout.on('data', (d) => { out += d; const m = out.match(/view: (http:\/\/[0-9.:]+\/)/); if (m) resolve(m[1]); }));
  return { exited, url };
}
const stats = (dir) => JSON.parse(fs.readFileSync(path.join(dir, 'stats.json'), 'utf8'));
const row = (s) => `${s.tick_latency_us.p50.toFixed(2)} / ${s.tick_latency_us.p99.toFixed(2)} / ${s.tick_latency_us.max.toFixed(0)} µs, ` +
  `period jitter p99 ${s.period_jitter_us.p99.toFixed(1)} µs max ${s.period_jitter_us.max.toFixed(0)} µs, overruns ${s.overruns}`;

const alone = path.join(args.work, 'run_alone');
const code = await run(alone, []).exited;
if (code !== 0) throw new Error(`modal-rt run exited with ${code}`);
const without = stats(alone);

const watched = path.join(args.work, 'run_view');
const browser = await launchChromium();
const r = run(watched, ['--view', '0']);
const page = await browser.newPage({ viewport: { width: 1000, height: 620 } });
let received = 0, first = 0, last = 0;
page.on('websocket', (ws) => ws.on('framereceived', (e) => {
  if (typeof e.payload === 'string') return;
  ++received; last = Date.now(); if (!first) first = last;
}));
await page.goto(await r.url);
const drawn = [];
const sampler = setInterval(async () => { try { drawn.push(await page.evaluate(() => window.viewState.fps)); } catch (e) { /* page closing */ } }, 1000);
const watchedCode = await r.exited;
clearInterval(sampler);
await browser.close();
if (watchedCode !== 0) throw new Error(`modal-rt run --view exited with ${watchedCode}`);
const withView = stats(watched);
const receivedRate = received / ((last - first) / 1000);
const live = drawn.filter((x) => x > 0).sort((a, b) => a - b);
const drawnMedian = live.length ? live[Math.floor(live.length / 2)] : NaN;
console.log(`${args.label}: tick p50 / p99 / max without the view ${row(without)}`);
console.log(`${args.label}: with the view and a browser           ${row(withView)}`);
console.log(`${args.label}: frames received ${receivedRate.toFixed(1)}/s, drawn ${drawnMedian.toFixed(1)}/s (median of 1 s samples); allocations in the haptic thread ${withView.allocations_after_start}`);
if (args.csv) {
  if (!fs.existsSync(args.csv)) fs.writeFileSync(args.csv, 'label,view,tick_p50_us,tick_p99_us,tick_max_us,jitter_p99_us,jitter_max_us,overruns,frames_received_per_s,frames_drawn_per_s\n');
  for (const [view, s] of [[0, without], [1, withView]])
    fs.appendFileSync(args.csv, [args.label, view, s.tick_latency_us.p50, s.tick_latency_us.p99, s.tick_latency_us.max, s.period_jitter_us.p99,
      s.period_jitter_us.max, s.overruns, view ? receivedRate : '', view ? drawnMedian : ''].join(',') + '\n');
}
