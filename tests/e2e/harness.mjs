// Plumbing for the end-to-end test: the static server, Chromium, time limits.

import { spawn } from 'node:child_process';
import { createServer } from 'node:net';
import { chromium } from 'playwright-core';

export const ROOT = new URL('../../', import.meta.url).pathname;
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';

/** Chromium switches: headless, no network chatter, WebGL2 in software (SwiftShader). */
export const BASE_ARGS = [
  '--headless=new',
  '--no-sandbox',
  '--disable-dev-shm-usage',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-sync',
  '--no-first-run',
  '--enable-unsafe-swiftshader',
  '--ignore-gpu-blocklist',
];

/** Reject after `ms` with a message naming what took too long. */
export function withTimeout(promise, ms, what) {
  let timer;
  const limit = new Promise((_, reject) => {
    timer = setTimeout(() => reject(new Error(`${what} took longer than ${ms / 1000} s`)), ms);
  });
  return Promise.race([promise, limit]).finally(() => clearTimeout(timer));
}

function freePort() {
  return new Promise((resolve, reject) => {
    const srv = createServer();
    srv.unref();
    srv.on('error', reject);
    srv.listen(0, '127.0.0.1', () => {
      const { port } = srv.address();
      srv.close(() => resolve(port));
    });
  });
}

/** Start scripts/serve.py on a free port; resolves to {url, stop}. */
export async function startServer() {
  const port = await freePort();
  const child = spawn('python3', ['scripts/serve.py', String(port)], { cwd: ROOT, stdio: ['ignore', 'pipe', 'pipe'] });
  let stderr = '';
  child.stderr.on('data', (d) => (stderr += d));
  const stop = () => {
    if (child.exitCode === null && !child.killed) child.kill('SIGTERM');
  };
  const base = `http://127.0.0.1:${port}`;
  const deadline = Date.now() + 15_000;
  for (;;) {
    if (child.exitCode !== null) throw new Error(`scripts/serve.py exited: ${stderr.trim()}`);
    try {
      const res = await fetch(`${base}/www/index.html`);
      if (res.ok) break;
    } catch {
      // not listening yet
    }
    if (Date.now() > deadline) {
      stop();
      throw new Error('scripts/serve.py did not answer within 15 s');
    }
    await new Promise((r) => setTimeout(r, 100));
  }
  return { base, url: `${base}/www/`, stop };
}

/** Launch Debian's Chromium with the base switches plus `extra`. */
export async function launch(extra = []) {
  return withTimeout(
    chromium.launch({ executablePath: CHROMIUM, headless: true, args: [...BASE_ARGS, ...extra], timeout: 30_000 }),
    40_000,
    'starting Chromium',
  );
}

/** Open the page and collect its console errors and uncaught exceptions; `route`:
 * [URL pattern, handler] for the context's requests (to block a file, say). */
export async function openPage(browser, url, { initScript, route } = {}) {
  const context = await browser.newContext({ viewport: { width: 1360, height: 1000 }, acceptDownloads: true });
  // [pattern, handler]: requests of the page and its workers to intercept.
  if (route) await context.route(...route);
  const page = await context.newPage();
  page.setDefaultTimeout(30_000);
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => {
    if (m.type() === 'error') problems.push(`console: ${m.text()}`);
  });
  if (initScript) await page.addInitScript(initScript);
  await page.goto(url, { waitUntil: 'load' });
  return { context, page, problems };
}
