// Shared by the browser test and the viewer benchmark: start `gshell view`, launch Debian's
// chromium headless through puppeteer-core (installed by scripts/setup into web/node_modules; it
// downloads nothing), read OBJ vertices.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const require = createRequire(path.join(root, 'web/package.json'));
const puppeteer = require('puppeteer-core');

/** The flags that work here (root, no GPU, no network): headless, WebGL on SwiftShader. */
export const CHROMIUM_FLAGS = [
  '--headless=new', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
  '--disable-component-update', '--disable-sync', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-timer-throttling', '--disable-renderer-backgrounding', '--window-size=1280,800',
];

/** Chromium with a fresh profile (removed when the browser closes). */
export async function launchBrowser() {
  const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
  if (!fs.existsSync(executablePath)) throw new Error(`no chromium at ${executablePath} (Debian package chromium; or set CHROMIUM)`);
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'gshell-chromium-'));
  const browser = await puppeteer.launch({ executablePath, userDataDir: profile, args: CHROMIUM_FLAGS, protocolTimeout: 600000 });
  const close = browser.close.bind(browser);
  browser.close = async () => {
    await close();
    fs.rmSync(profile, { recursive: true, force: true });
  };
  return browser;
}

/** Starts `gshell view ARGS --port 0`; resolves with {url, process, stderr(), stop()} once the URL is printed. */
export function startViewer(gshell, args) {
  return new Promise((resolve, reject) => {
    const child = spawn(gshell, ['view', ...args, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '', err = '';
    child.stderr.on('data', (d) => { err += d; });
    child.on('exit', (code) => reject(new Error(`gshell view exited (${code}) before printing its URL: ${err}`)));
    child.stdout.on('data', (d) => {
      out += d;
      const line = out.split('\n');
      if (line.length > 1) {
        child.removeAllListeners('exit');
        resolve({
          url: line[0].trim(),
          process: child,
          stderr: () => err,
          /** SIGTERM; resolves with {code, signal, ms} when it has exited. */
          stop: () => new Promise((done) => {
            if (child.exitCode !== null) return done({ code: child.exitCode, signal: null, ms: 0 });
            const t0 = Date.now();
            child.on('exit', (code, signal) => done({ code, signal, ms: Date.now() - t0 }));
            child.kill('SIGTERM');
          }),
        });
      }
    });
  });
}

/** The vertex coordinates of an OBJ file, flat [x0, y0, z0, x1, ...]. */
export function readObj(file) {
  const out = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n'))
    if (line.startsWith('v ')) out.push(...line.trim().split(/\s+/).slice(1, 4).map(Number));
  return out;
}
