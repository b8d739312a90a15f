// `modal-rt run --view P` and `modal-rt serve --view P` in a real browser (Debian's chromium,
// headless, driven by playwright-core). A two-HIP scripted session is played on the lattice fixture
// while the page watches; the test checks that
//   - the page receives frames while the session runs, and every frame's HIP forces equal the run's
//     own record of that tick (trace.csv at one row per tick, 9 significant digits) within 1e-8
//     relative; so do the forces the page shows;
//   - the haptic thread, with the view's device wrapper in it, allocates nothing (stats.json);
//   - the page is watch-only: it says so, a mouse drag sends nothing, and a press sent by hand on the
//     WebSocket is refused by the server;
//   - `modal-rt serve --view P` serves the page and a watch-only session description, and ends cleanly.
// Usage: node test_run_view.mjs --modal-rt BIN --basis FILE --work DIR
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { args, check, fail, finish, launchChromium, VIEW_URL, viewAddress } from './browser_support.mjs';

// Starts `modal-rt ARGS`; resolves with the view's address and a promise of the exit code.
function start(commandArgs) {
  const child = spawn(args['modal-rt'], commandArgs, { stdio: ['ignore', 'pipe', 'inherit'] });
  let out = '';
  const exited = new Promise((resolve) => child.on('exit', (code) => resolve(code)));
  const url = new Promise((resolve, reject) => {
    child.stdout.on('data', (d) => { out += d; const m = out.match(new RegExp(`view: (${VIEW_URL.source})`)); if (m) resolve(m[1]); });
    exited.then((code) => reject(new Error(`modal-rt ${commandArgs[0]} exited with ${code} before printing the view's address: ${out}`)));
    setTimeout(() => reject(new Error(`modal-rt ${commandArgs[0]} printed no view address in 20 s`)), 20000);
  });
  return { child, url, exited, output: () => out };
}

// The HIP forces of one binary frame (view/README.md, "Frame"): haptic tick (statistics[0]) and per
// HIP in-contact and force.
function parseFrame(buffer) {
  const dv = new DataView(buffer.buffer, buffer.byteOffset, buffer.byteLength);
  if (dv.getUint32(0, true) !== 0x4654524d) return null;
  const r = dv.getUint32(44, true), hips = dv.getUint32(48, true), contacts = dv.getUint32(52, true);
  const frame = { tick: dv.getFloat64(56, true), hips: [] };
  const perHip = dv.getUint32(4, true) >= 2 ? 104 : 96; // version 2 added each HIP's validity force
  for (let h = 0, o = 120 + 8 * r + 32 * contacts; h < hips; ++h, o += perHip)
    frame.hips.push({ inContact: dv.getUint32(o, true), force: [0, 1, 2].map((c) => dv.getFloat64(o + 16 + 8 * c, true)) });
  return frame;
}

const work = args.work;
fs.mkdirSync(work, { recursive: true });
// HIP 0 comes down on the tip from 0.5 s, HIP 1 on the middle from 2 s; both keep pushing deeper.
const sessionFile = path.join(work, 'run_view_session.csv');
fs.writeFileSync(sessionFile, `time,hip,event,x,y,z
0,0,target,0.15,0.0166667,0.03
0,1,target,0.1,0.0333333,0.03
0.5,0,target,0.15,0.0166667,0.012
2,1,target,0.1,0.0333333,0.012
9,0,target,0.15,0.0166667,0.0
9,1,target,0.1,0.0333333,0.002
9,-,end
`);
const rate = 1000;
const outDir = path.join(work, 'run_view_out');

const browser = await launchChromium();
try {
  const run = start(['run', '--basis', args.basis, '--session', sessionFile, '--output-dir', outDir, '--rate', String(rate),
    '--trace-rate', String(rate), '--no-plot', '--quiet', '--view', '0']);
  const url = await run.url;
  console.log(`run's view ${url}`);
  const view = viewAddress(url);
  const page = await browser.newPage({ viewport: { width: 900, height: 560 } });
  page.on('pageerror', (e) => { console.log(`page error: ${e.message}`); fail(); });
  const frames = [];
  let sent = 0, firstFrameMs = 0, lastFrameMs = 0;
  page.on('websocket', (ws) => {
    ws.on('framereceived', (event) => {
      if (typeof event.payload === 'string') return;
      const f = parseFrame(event.payload);
      if (!f) return;
      frames.push(f);
      lastFrameMs = Date.now(); if (!firstFrameMs) firstFrameMs = lastFrameMs;
    });
    ws.on('framesent', () => { sent += 1; });
  });
  await page.goto(url);
  await page.waitForFunction(() => window.viewState?.ready && window.viewState.frames > 5, null, { timeout: 30000 });

  const info = await (await view.api(`api/info`)).json();
  check(info.session?.driver === 'run' && info.session.watch_only === true && info.session.hips === 2,
    `/api/info: session ${JSON.stringify(info.session)}`);
  const status = await page.evaluate(() => ({ watchOnly: window.viewState.watchOnly, status: document.getElementById('status').textContent,
    title: document.getElementById('contacts-title').textContent }));
  check(status.watchOnly === true && /watch-only/.test(status.status) && /watch-only/.test(status.title),
    `the page says it is watch-only: "${status.status}", "${status.title}"`);

  // A mouse drag on the part presses nothing; a press sent by hand is refused (first, while the
  // session surely runs: on a loaded machine the page's load takes seconds of its 9).
  const box = await page.evaluate(() => { const r = window.viewDebug.canvas.getBoundingClientRect(); return { x: r.left + r.width / 2, y: r.top + r.height / 2 }; });
  await page.mouse.move(box.x, box.y); await page.mouse.down();
  for (let k = 1; k <= 5; ++k) await page.mouse.move(box.x, box.y + 10 * k);
  await page.mouse.up();
  await page.waitForTimeout(200);
  check(sent === 0, `a mouse drag sent ${sent} WebSocket messages (watch-only: none)`);
  const reply = await page.evaluate((wsUrl) => new Promise((resolve) => {
    const ws = new WebSocket(wsUrl);
    ws.onopen = () => ws.send('press 0 0 5');
    ws.onmessage = (e) => { if (typeof e.data === 'string') { resolve(e.data); ws.close(); } };
    setTimeout(() => resolve('(no reply)'), 3000);
  }), view.socket);
  check(reply.startsWith('error: watch-only'), `a press sent on the WebSocket is refused: "${reply}"`);

  // Wait for both contacts, then sample what the page shows.
  await page.waitForFunction(() => window.viewState.hips?.[0]?.inContact === 1 && window.viewState.hips?.[1]?.inContact === 1, null, { timeout: 20000 });
  const shown = [];
  for (let k = 0; k < 8; ++k) {
    shown.push(await page.evaluate(() => window.viewState.hips.map((h) => ({ inContact: h.inContact, tick: h.tick, force: h.force }))));
    await page.waitForTimeout(150);
  }

  const code = await run.exited;
  check(code === 0, `modal-rt run --view exited with ${code}`);
  // The view's wrapper of the device runs in the haptic thread: it must not allocate there.
  const stats = JSON.parse(fs.readFileSync(path.join(outDir, 'stats.json'), 'utf8'));
  check(stats.allocations_after_start === 0, `the haptic thread allocated ${stats.allocations_after_start} times with the view attached`);

  // The run's own record: trace.csv, one row per tick (row n is tick n, after which the kernel has
  // done n + 1 ticks: the frame's haptic tick).
  const lines = fs.readFileSync(path.join(outDir, 'trace.csv'), 'utf8').split('\n').filter((l) => l && !l.startsWith('#'));
  const header = lines[0].split(','), col = (name) => header.indexOf(name);
  const trace = new Map();
  for (const line of lines.slice(1)) {
    const v = line.split(',').map(Number);
    trace.set(Math.round(v[0] * rate), [0, 1].map((h) => ({ inContact: v[col(`hip${h}_contact`)],
      force: ['fx', 'fy', 'fz'].map((c) => v[col(`hip${h}_${c}`)]) })));
  }
  const same = (a, b) => Math.hypot(...a.map((x, i) => x - b[i])) <= 1e-8 * Math.max(Math.hypot(...b), 1e-9);
  const compare = (tick, hips) => {
    const row = trace.get(tick - 1);
    return row !== undefined && hips.every((h, i) => h.inContact === row[i].inContact && same(h.force, row[i].force));
  };
  const inContact = frames.filter((f) => f.hips.every((h) => h.inContact === 1));
  const matched = frames.filter((f) => compare(f.tick, f.hips)).length;
  const seconds = (lastFrameMs - firstFrameMs) / 1000;
  check(inContact.length >= 50, `${frames.length} frames received in ${seconds.toFixed(1)} s (${(frames.length / seconds).toFixed(1)}/s), ${inContact.length} with both HIPs pressing`);
  check(matched === frames.length && frames.length > 0, `every frame's HIP forces = trace.csv's at its tick within 1e-8 (${matched} of ${frames.length})`);
  const maxForce = Math.max(...inContact.map((f) => Math.hypot(...f.hips[0].force)));
  check(maxForce > 0.1, `HIP 0 pressed with up to ${maxForce.toFixed(4)} N`);
  const shownMatched = shown.filter((s) => compare(s[0].tick, s.map((h) => ({ inContact: h.inContact, force: h.force })))).length;
  check(shownMatched === shown.length, `the forces the page shows = trace.csv's at their tick (${shownMatched} of ${shown.length} samples)`);
  await page.close();

  // serve --view: the page and a watch-only session, then a clean end.
  const serve = start(['serve', '--basis', args.basis, '--output-dir', path.join(work, 'serve_view_out'), '--duration', '3',
    '--port', String(47000 + (process.pid % 1000)), '--no-plot', '--quiet', '--view', '0']);
  const serveUrl = await serve.url;
  const pageHtml = await (await fetch(serveUrl)).text();
  const serveInfo = await (await viewAddress(serveUrl).api('api/info')).json();
  check(pageHtml.includes('modal-rt view') && serveInfo.session?.driver === 'serve' && serveInfo.session.watch_only === true,
    `serve --view serves the page at ${serveUrl}, session ${JSON.stringify(serveInfo.session)}`);
  const serveCode = await serve.exited;
  check(serveCode === 0, `modal-rt serve --view exited with ${serveCode}`);
} finally {
  await browser.close();
}
finish();
