// Not a test: the README's picture of the view's Stiffness tab (docs/images/view_stiffness_ribbed_panel.png).
// Serves a basis with `modal-rt view`, opens the Stiffness tab in Debian's chromium, points at a
// display vertex (the value under the pointer is shown) and writes a screenshot.
// Usage: node screenshot_stiffness.mjs --modal-rt BIN --basis FILE --vertex V --screenshot PNG
import { spawn } from 'node:child_process';
import { args, launchChromium, VIEW_URL } from './browser_support.mjs';

const server = spawn(args['modal-rt'], ['view', '--basis', args.basis, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve, reject) => {
  let out = '';
  server.stdout.on('data', (d) => { out += d; const m = out.match(VIEW_URL); if (m) resolve(m[0]); });
  server.on('exit', (code) => reject(new Error(`modal-rt view exited with ${code}: ${out}`)));
});
const browser = await launchChromium();
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  await page.goto(url);
  await page.waitForFunction(() => window.viewState?.ready, null, { timeout: 60000 });
  await page.click('#tab-stiffness');
  await page.waitForTimeout(500);
  const at = await page.evaluate((v) => window.viewDebug.project(v), Number(args.vertex));
  await page.mouse.move(at.x + 1, at.y);
  await page.mouse.move(at.x, at.y);
  await page.waitForTimeout(500);
  const shown = await page.evaluate(() => [document.getElementById('stiffness-vertex').textContent, document.getElementById('stiffness-value').textContent]);
  console.log(`under the pointer: vertex ${shown[0]}, ${shown[1]}`);
  await page.screenshot({ path: args.screenshot });
  console.log(`screenshot ${args.screenshot}`);
} finally {
  await browser.close();
  server.kill('SIGINT');
}
