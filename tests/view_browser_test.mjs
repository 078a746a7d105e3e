// End to end in a real browser (Debian's chromium, driven by npm puppeteer-core; WebGL by
// SwiftShader, no GPU): `gshell view` on a plate it generates itself; the page loads and shows the
// mesh; two handle groups are selected with the box tool and made with the page's button; one is
// dragged with the mouse; after the rest the page's geometry has moved and equals the server's state
// (the folder its "save shell" button makes); a screenshot of the dragged shell goes to OUT.
// --scale S: the same on the plate scaled by S (e.g. 1e45, beyond float32's range): the page
// works in page units, (x - hello.origin) * hello.unit, and every check reads them so.
//
//   node tests/view_browser_test.mjs --gshell build/bin/gshell --out build/test-output [--scale S]
//
// Run by ctest (CMakeLists.txt). Exit code 0 = pass.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { launchBrowser, readObj, startViewer } from './support/view_browser.mjs';

const args = Object.fromEntries(process.argv.slice(2).reduce((pairs, a, i, all) => (a.startsWith('--') ? [...pairs, [a.slice(2), all[i + 1]]] : pairs), []));
const gshell = args.gshell || path.join(path.dirname(fileURLToPath(import.meta.url)), '../build/bin/gshell');
const outDir = args.out || path.join(os.tmpdir(), 'gshell-view-test-output');
const scale = Number(args.scale || 1);
fs.mkdirSync(outDir, { recursive: true });

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) ++failures;
}

const work = fs.mkdtempSync(path.join(os.tmpdir(), 'gshell-view-test-'));
let input = 'builtin:plane:12';
if (scale !== 1) { // the plate's OBJ with every coordinate times the scale
  input = path.join(work, 'plate.obj');
  const converted = spawnSync(gshell, ['convert', 'builtin:plane:12', input, '-q'], { encoding: 'utf8' });
  if (converted.status !== 0) throw new Error(`gshell convert failed: ${converted.stderr}`);
  const lines = fs.readFileSync(input, 'utf8').split('\n');
  fs.writeFileSync(input, lines.map((l) => (l.startsWith('v ') ? 'v ' + l.slice(2).trim().split(/\s+/).map((x) => Number(x) * scale).join(' ') : l)).join('\n'));
}
const viewer = await startViewer(gshell, [input, '--thickness', String(0.1 * scale), '--output-dir', work]);
const browser = await launchBrowser();
try {
  const page = await browser.newPage();
  await page.setViewport({ width: 1280, height: 800 });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto(viewer.url);
  await page.waitForFunction(() => window.gshellView && window.gshellView.loadMs !== null, { timeout: 60000 });
  const hello = await page.evaluate(() => window.gshellView.hello);
  check(hello.posable && hello.vertices === 169 && hello.faces === 288, `page got the 13 x 13 plate shell (${hello.vertices} base vertices, ${hello.faces} faces)`);
  const unit = hello.unit;
  const size = scale * unit; // the 2 x 2 plate's half width in page units
  // The unit brings the shell's box diagonal (the plate's, 2 sqrt 2, and its 0.1 thickness) into [0.5, 1).
  const diagonal = Math.hypot(2, 2, 0.1) * size;
  check(scale === 1 ? unit === 1 : diagonal >= 0.5 && diagonal < 1, `page units: unit ${unit}, the plate's diagonal ${diagonal.toPrecision(3)}`);
  const rest = await page.evaluate(() => window.gshellView.positions());
  check(rest.length === 6 * 169 && rest.every(Number.isFinite), 'the mesh is drawn from the server\'s positions');

  // Box-select each end of the plate (both surfaces) and make a group of it.
  const n = hello.vertices;
  const endOf = (sign) => [...Array(2 * n).keys()].filter((v) => sign * rest[3 * v] > 0.8 * size);
  await page.click('input[name=mode][value=box]');
  async function boxAround(ids) {
    const points = await page.evaluate((ids) => ids.map((v) => window.gshellView.screenOf(v)), ids);
    const xs = points.map((p) => p.x), ys = points.map((p) => p.y);
    const pad = 4;
    await page.mouse.move(Math.min(...xs) - pad, Math.min(...ys) - pad);
    await page.mouse.down();
    await page.mouse.move((Math.min(...xs) + Math.max(...xs)) / 2, (Math.min(...ys) + Math.max(...ys)) / 2, { steps: 3 });
    await page.mouse.move(Math.max(...xs) + pad, Math.max(...ys) + pad, { steps: 3 });
    await page.mouse.up();
  }
  for (const [name, sign] of [['hold', -1], ['pull', 1]]) {
    await boxAround(endOf(sign));
    const selected = await page.evaluate(() => window.gshellView.selected);
    check(selected >= endOf(sign).length, `box selected the ${name} end (${selected} vertices)`);
    await page.type('#group-name', name);
    await page.click('#make-group');
    await page.waitForFunction((count) => window.gshellView.groups.length === count, { timeout: 10000 }, name === 'hold' ? 1 : 2);
  }
  const groups = await page.evaluate(() => window.gshellView.groups);
  check(groups.length === 2 && groups[0].name === 'hold' && groups[1].name === 'pull', `the server made the groups ${JSON.stringify(groups)}`);
  // A group the server refuses (it overlaps 'pull') leaves the selection and the name to mend.
  await boxAround(endOf(1));
  await page.type('#group-name', 'again');
  await page.click('#make-group');
  await page.waitForFunction(() => [...document.querySelectorAll('#status .error')].some((e) => /overlap/.test(e.textContent)), { timeout: 10000 });
  const refused = await page.evaluate(() => ({
    selected: window.gshellView.selected, name: document.getElementById('group-name').value, groups: window.gshellView.groups.length,
    error: [...document.querySelectorAll('#status .error')].map((e) => e.textContent).join(' | '),
  }));
  check(refused.selected >= endOf(1).length && refused.name === 'again' && refused.groups === 2 && /'pull'/.test(refused.error),
    `a refused group keeps the selection and the name, and the error names the group (${JSON.stringify(refused)})`);
  await page.click('#clear-selection');
  await page.$eval('#group-name', (el) => { el.value = ''; });

  // Drag the pull group up the screen with the mouse, in many small moves, then let go.
  await page.click('input[name=mode][value=drag]');
  const pullVertex = endOf(1).find((v) => v >= n && Math.abs(rest[3 * v + 1]) < 0.1 * size); // a top vertex mid-edge
  const grip = await page.evaluate((v) => window.gshellView.screenOf(v), pullVertex);
  await page.mouse.move(grip.x, grip.y);
  await page.mouse.down();
  await page.mouse.move(grip.x - 20, grip.y - 160, { steps: 30 });
  await page.mouse.up();
  // The settle of the last drag: on a loaded machine the mouse can rest mid-drag long enough for
  // an earlier settle, whose state the later drags then change.
  const settled = await page.evaluate(() => window.gshellView.waitFor('settled', 120000, window.gshellView.sentSeq));
  check(settled.phase === 'settled', `the shell settled after the release (${settled.step && settled.step.iterations} iterations)`);

  const moved = await page.evaluate(() => window.gshellView.positions());
  let lift = 0;
  for (let v = 0; v < 2 * n; ++v) lift = Math.max(lift, Math.hypot(moved[3 * v] - rest[3 * v], moved[3 * v + 1] - rest[3 * v + 1], moved[3 * v + 2] - rest[3 * v + 2]));
  check(lift > 0.3 * size, `the page's geometry moved (largest displacement ${(lift / size).toFixed(3)} on a 2 x 2 plate)`);

  // The server's state: the folder its "save shell" button writes.
  await page.type('#shell-name', 'dragged');
  await page.click('#save-shell');
  const folder = path.join(work, 'dragged');
  for (let t = 0; t < 200 && !fs.existsSync(path.join(folder, 'top.obj')); ++t) await new Promise((r) => setTimeout(r, 50));
  const base = readObj(path.join(folder, 'base.obj')), top = readObj(path.join(folder, 'top.obj'));
  const server = [...base, ...top];
  const origin = await page.evaluate(() => window.gshellView.hello.origin); // what the page draws relative to
  let difference = 0;
  for (let i = 0; i < server.length; ++i) difference = Math.max(difference, Math.abs((server[i] - origin[i % 3]) * unit - moved[i]) / size);
  check(server.length === moved.length && difference < 1e-5, `the page's geometry equals the server's state (largest difference ${difference.toExponential(2)} of the plate's size, float32 rounding)`);

  const stats = await page.evaluate(() => window.gshellView.stats);
  check(stats.handles === 2 && stats.stretch && stats.stretch.against === 'rest shell', 'the stats panel shows the posed shell');
  // The exact certificate runs off the interactive path once the shell rests; the panel shows it.
  await page.waitForFunction(() => window.gshellView.stats.validity, { timeout: 60000 });
  const validity = await page.evaluate(() => window.gshellView.stats.validity);
  const panel = await page.$eval('#stats-body', (el) => el.textContent);
  // The solver's bookkeeping of a step is not shown under its raw names.
  check(!/drag start|rest faults only|base self intersections/.test(panel), `the stats show no internal step fields (${panel})`);
  check(validity.certificate && validity.certificate.exact === true && validity.valid === true && validity.certificate.inverted_tets === 0 &&
        /valid \(exact\)yes/.test(panel), `the panel shows the certificate of the dragged shell (${JSON.stringify(validity.certificate)})`);
  // Nothing is drawn over the shell: the panels lie beside the canvas, not on it, and the shell
  // keeps a usable part of narrow windows (at 500 px wide the three fixed columns left it none).
  for (const [width, height] of [[1280, 800], [800, 600], [500, 400]]) {
    await page.setViewport({ width, height });
    const layout = await page.evaluate(() => {
      const canvas = document.querySelector('#view canvas').getBoundingClientRect();
      const overlaps = ['panel', 'stats', 'colorbar'].filter((id) => {
        const r = document.getElementById(id).getBoundingClientRect();
        return r.width > 0 && r.left < canvas.right - 0.5 && r.right > canvas.left + 0.5 && r.top < canvas.bottom - 0.5 && r.bottom > canvas.top + 0.5;
      });
      return { overlaps, width: canvas.width, height: canvas.height }; // CSS pixels, laid out at once
    });
    check(layout.overlaps.length === 0, `${width} x ${height}: no panel covers the shell's canvas${layout.overlaps.length ? ': ' + layout.overlaps.join(', ') + ' do' : ''}`);
    check(layout.width >= 0.3 * width && layout.height >= 0.5 * height, `${width} x ${height}: the shell's canvas is ${Math.round(layout.width)} x ${Math.round(layout.height)}`);
  }
  await page.setViewport({ width: 1280, height: 800 });
  const shot = path.join(outDir, scale === 1 ? 'view_browser_dragged.png' : `view_browser_dragged_${scale}.png`);
  await page.screenshot({ path: shot });
  check(fs.statSync(shot).size > 10000, `screenshot of the dragged shell: ${shot}`);
  check(errors.length === 0, `no errors in the page${errors.length ? ': ' + errors.join('; ') : ''}`);
} finally {
  await browser.close();
  await viewer.stop();
  fs.rmSync(work, { recursive: true, force: true });
}
console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
process.exit(failures ? 1 : 0);
