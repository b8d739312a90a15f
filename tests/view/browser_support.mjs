// What the view's browser tests share: the command line (--name value pairs), Debian's chromium
// (headless, software GL) through playwright-core from view/web/node_modules, and the checks.
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

export const args = Object.fromEntries(process.argv.slice(2).reduce((a, x, i, all) => (x.startsWith('--') ? [...a, [x.slice(2), all[i + 1]]] : a), []));
const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '../../view/web/package.json'));
const { chromium } = require('playwright-core');

export const launchChromium = () => chromium.launch({
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  args: ['--use-angle=swiftshader', '--use-gl=angle', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
});

let failures = 0;
export function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}
export const fail = () => { failures += 1; };

// Prints the verdict and exits with it.
export function finish() {
  console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
  process.exit(failures ? 1 : 0);
}

// The view's address as modal-rt prints it: http://HOST:PORT/?token=HEX (the run's token, 64 hex digits).
export const VIEW_URL = /http:\/\/[^\s/]+:[0-9]+\/\?token=[0-9a-f]{64}/;
// Of such an address: the page to open, the API fetched with the token (the X-Modal-RT-Token header,
// as a client that is no browser must), and the live socket's address with it.
export function viewAddress(page) {
  const { origin, searchParams } = new URL(page);
  const token = searchParams.get('token');
  return {
    page,
    token,
    api: (route) => fetch(`${origin}/${route}`, { headers: { 'X-Modal-RT-Token': token } }),
    socket: `${origin.replace('http', 'ws')}/ws?token=${token}`,
  };
}
