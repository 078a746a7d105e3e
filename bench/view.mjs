// bench/view.mjs: `gshell view` latency and page load, measured in a real browser (Debian's chromium,
// headless, WebGL on SwiftShader) driven by puppeteer-core, as a user drags.
//
//   node bench/view.mjs [bowl] [bunny] [--runs R] [--events N] [--interval MS] [--loads L] [--no-pose] [--server-only]
//                       [--gshell build/bin/gshell] [--out out/bench-view] [--models models]
//
// Shells: bowl = `gshell generate builtin:bowl --thickness-ratio 0.02`, bunny = models/bunny00.off at
// ratio 0.01 (scripts/fetch-models; --models DIR reads bunny00.off from DIR); made once into --out. Handles as bench_pose's: the bowl's rim
// held on one side and pulled on the other by R (0.8, 0.2, 0.5); other models: the lowest 8% along y
// held, the highest 8% pulled by R (0.5, 0.1, 0.3) (R = bounding radius).
//
// A run: the pull group is dragged in a straight line in N drag messages sent every MS
// milliseconds (a mouse; default 60 events at 60 Hz), then released, and the shell settles.
// Messages that arrive while the server solves coalesce: only answered events have latencies.
//  - server: a WebSocket client without a browser (npm ws) sends the drags; per answered event the
//    server's message-in to positions-out milliseconds (frame header) and the client's
//    send-to-receive time, and the server process's CPU time per answered event (all threads,
//    from /proc: little changed by other load). No browser competes for the 2 cores.
//  - browser: the page itself sends them (window.gshellView.scriptedDrag) and records when the
//    positions arrived and when the frame showing them was drawn (a pixel read back, so the GPU,
//    here SwiftShader's software rasteriser on the same 2 cores, has finished), with the page's
//    apply (scatter into the vertex buffers) and render times. Drawn without multisampling
//    (?antialias=0), as software WebGL is what headless has.
// After the browser runs the viewer's settled shell is saved and compared with `gshell pose
// --steps N` with the saved handle file -- the same targets in the same steps.
//
// Page load: navigation start to the first frame drawn with the shell (median of L loads).
// A screenshot of the page after the drags: --out/MODEL-view.png.
// Prints sizes, medians and the machine's load average (2 shared cores: compare medians).
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { launchBrowser, readObj, startViewer } from '../tests/support/view_browser.mjs';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const WebSocket = createRequire(path.join(root, 'web/package.json'))('ws');
const opts = { runs: 3, events: 60, interval: 1000 / 60, loads: 5, pose: true, browser: true, gshell: path.join(root, 'build/bin/gshell'), out: path.join(root, 'out/bench-view'), models: path.join(root, 'models') };
const models = [];
for (let i = 2; i < process.argv.length; ++i) {
  const a = process.argv[i];
  if (a === '--runs') opts.runs = +process.argv[++i];
  else if (a === '--events') opts.events = +process.argv[++i];
  else if (a === '--interval') opts.interval = +process.argv[++i];
  else if (a === '--loads') opts.loads = +process.argv[++i];
  else if (a === '--no-pose') opts.pose = false;
  else if (a === '--server-only') opts.browser = opts.pose = false; // no drags in the page, no pose comparison
  else if (a === '--gshell') opts.gshell = process.argv[++i];
  else if (a === '--out') opts.out = process.argv[++i];
  else if (a === '--models') opts.models = process.argv[++i];
  else models.push(a);
}
if (!models.length) models.push('bowl', 'bunny');
fs.mkdirSync(opts.out, { recursive: true });

const median = (v) => {
  const s = v.filter(Number.isFinite).sort((a, b) => a - b);
  if (!s.length) return NaN;
  const h = Math.floor(s.length / 2);
  return s.length % 2 ? s[h] : (s[h - 1] + s[h]) / 2;
};
const f1 = (x) => (Number.isFinite(x) ? x.toFixed(1) : '-');
const load = () => os.loadavg().map((x) => x.toFixed(1)).join(' ');

function shellOf(model) {
  const dir = path.join(opts.out, model);
  if (fs.existsSync(path.join(dir, 'top.obj'))) return dir;
  const [input, ratio] = model === 'bowl' ? ['builtin:bowl', '0.02'] : model === 'bunny' ? [path.join(opts.models, 'bunny00.off'), '0.01'] : [model, '0.01'];
  console.log(`generating ${dir} from ${input} (ratio ${ratio})`);
  execFileSync(opts.gshell, ['generate', input, '--thickness-ratio', ratio, '-o', dir, '-q'], { stdio: ['ignore', 'ignore', 'inherit'] });
  return dir;
}

// bench_pose's handles, as vertex ids of the shell's 2n vertices (flat positions).
function handles(P, bowl) {
  const count = P.length / 3, lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let v = 0; v < count; ++v) for (let k = 0; k < 3; ++k) { lo[k] = Math.min(lo[k], P[3 * v + k]); hi[k] = Math.max(hi[k], P[3 * v + k]); }
  const R = 0.5 * Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  const hold = [], pull = [];
  for (let v = 0; v < count; ++v) {
    const [x, y, z] = [P[3 * v], P[3 * v + 1], P[3 * v + 2]];
    if (bowl) {
      if (z > -0.15 * R && x < -0.5 * R) hold.push(v);
      if (z > -0.15 * R && x > 0.7 * R) pull.push(v);
    } else {
      const t = (y - lo[1]) / (hi[1] - lo[1]);
      if (t < 0.08) hold.push(v);
      if (t > 0.92) pull.push(v);
    }
  }
  const move = (bowl ? [0.8, 0.2, 0.5] : [0.5, 0.1, 0.3]).map((c) => c * R);
  return { hold, pull, move, R };
}

// A WebSocket client as a page without a browser: JSON text parsed, binary frames' headers read.
function connect(url) {
  return new Promise((resolve, reject) => {
    const ws = new WebSocket(url.replace('http://', 'ws://') + 'ws');
    const c = { ws, listeners: [], stats: null, hello: null };
    // The server's first messages can arrive in the same tick as 'open', before anyone listens.
    c.helloArrived = new Promise((done) => { c.gotHello = done; });
    ws.on('message', (data, binary) => {
      const m = binary ? { kind: data.readUInt32LE(0), seq: data.readUInt32LE(4), a: data.readFloatLE(8), b: data.readFloatLE(12), at: performance.now() } : JSON.parse(data);
      if (!binary && m.type === 'stats') c.stats = m;
      if (!binary && m.type === 'hello') c.gotHello(m);
      for (const l of c.listeners) l(m, binary);
    });
    ws.on('open', () => resolve(c));
    ws.on('error', reject);
    c.send = (m) => ws.send(JSON.stringify(m));
    c.until = (pred, ms = 300000) => new Promise((done, fail) => {
      const timer = setTimeout(() => fail(new Error('timeout')), ms);
      const l = (m, binary) => { if (pred(m, binary)) { clearTimeout(timer); c.listeners.splice(c.listeners.indexOf(l), 1); done(m); } };
      c.listeners.push(l);
    });
  });
}

// CPU milliseconds the process has used, all threads (Linux /proc; 10 ms ticks): per answered event
// it is a figure the other work on a shared machine does not inflate (about the wall time on one
// quiet core; less wall time when the solver's parallel parts use both).
function cpuMs(pid) {
  const f = fs.readFileSync(`/proc/${pid}/stat`, 'utf8').split(') ')[1].split(' ');
  return (Number(f[11]) + Number(f[12])) * (1000 / 100);
}

async function serverRuns(url, h, pid) {
  const c = await connect(url);
  await c.helloArrived;
  const runs = [];
  for (let r = 0; r < opts.runs; ++r) {
    c.send({ type: 'reset' });
    await c.until((m) => m.type === 'stats' && m.phase === 'rest');
    const sent = new Map(), answers = [];
    const listener = (m, binary) => { if (binary && m.kind === 2 && m.b > 0 && sent.has(m.seq)) answers.push(m); };
    c.listeners.push(listener);
    const cpu0 = cpuMs(pid);
    c.send({ type: 'grab', handle: 1 });
    const first = 1000000 * (r + 1);
    for (let k = 1; k <= opts.events; ++k) {
      const t = h.move.map((x) => (x * k) / opts.events);
      sent.set(first + k, performance.now());
      c.send({ type: 'drag', seq: first + k, handle: 1, translate: t });
      await new Promise((done) => setTimeout(done, opts.interval));
    }
    const last = first + opts.events;
    if (!answers.some((a) => a.seq === last)) await c.until((m, binary) => binary && m.kind === 2 && m.seq === last && m.b > 0);
    const cpu = (cpuMs(pid) - cpu0) / answers.length;
    c.listeners.splice(c.listeners.indexOf(listener), 1);
    c.send({ type: 'release' });
    const settled = await c.until((m) => m.type === 'stats' && m.phase === 'settled');
    const span = (Math.max(...answers.map((a) => a.at)) - sent.get(first + 1)) / 1000;
    const run = {
      answered: answers.length,
      solve: median(answers.map((a) => a.a)),
      inOut: median(answers.map((a) => a.b)),
      roundTrip: median(answers.map((a) => a.at - sent.get(a.seq))),
      rate: answers.length / span,
      settle: settled.step,
      cpu,
    };
    runs.push(run);
    console.log(`  server run ${r + 1}: ${run.answered}/${opts.events} events answered (${f1(run.rate)}/s); medians: solve ${f1(run.solve)} ms, ` +
      `message in -> positions out ${f1(run.inOut)} ms, client send -> positions received ${f1(run.roundTrip)} ms; ` +
      `process CPU per answered event ${f1(run.cpu)} ms; ` +
      `settle ${run.settle.iterations} iterations, ${f1(run.settle.seconds * 1000)} ms; load ${load()}`);
  }
  c.ws.close();
  return runs;
}

async function benchModel(model) {
  const shell = shellOf(model);
  const viewer = await startViewer(opts.gshell, [shell, '--output-dir', opts.out, '-q']);
  const browser = await launchBrowser();
  const result = { model };
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1280, height: 800 });
    page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
    // Page load: navigation to the first frame with the shell drawn.
    const loads = [];
    for (let k = 0; k < opts.loads; ++k) {
      await page.goto(viewer.url);
      await page.waitForFunction(() => window.gshellView && window.gshellView.loadMs !== null, { timeout: 120000 });
      loads.push(await page.evaluate(() => window.gshellView.loadMs));
    }
    const hello = await page.evaluate(() => window.gshellView.hello);
    result.size = `${2 * hello.vertices} shell vertices, ${hello.faces} faces, ${hello.tets} tets`;
    result.load = median(loads);
    console.log(`${model}: ${result.size}; page load ${loads.map(f1).join(', ')} ms (median ${f1(result.load)}); load average ${load()}`);

    const P = await page.evaluate(() => window.gshellView.positions());
    const h = handles(P, model === 'bowl');
    await page.evaluate((h) => {
      window.gshellView.send(JSON.stringify({ type: 'add_handle', name: 'hold', vertices: h.hold }));
      window.gshellView.send(JSON.stringify({ type: 'add_handle', name: 'pull', vertices: h.pull }));
    }, h);
    await page.waitForFunction(() => window.gshellView.groups.length === 2, { timeout: 60000 });
    await page.evaluate(() => window.gshellView.waitFor('settled', 600000)); // the solver is built
    console.log(`  handles: hold ${h.hold.length}, pull ${h.pull.length} vertices, pull by (${h.move.map((x) => x.toFixed(3)).join(', ')})`);
    // Without a browser drawing on the same cores first.
    await page.goto('about:blank');
    const serverRuns_ = await serverRuns(viewer.url, h, viewer.process.pid);
    for (const [key, name] of [['solve', 'serverSolve'], ['inOut', 'serverInOut'], ['roundTrip', 'serverRoundTrip'], ['rate', 'serverRate'], ['cpu', 'serverCpu']])
      result[name] = median(serverRuns_.map((r) => r[key]));
    console.log(`  server: median of ${serverRuns_.length} runs: message in -> positions out ${f1(result.serverInOut)} ms, ` +
      `send -> received ${f1(result.serverRoundTrip)} ms, solve ${f1(result.serverSolve)} ms, ${f1(result.serverRate)} updates/s, ` +
      `process CPU per answered event ${f1(result.serverCpu)} ms`);
    if (!opts.browser) return result;
    await page.goto(viewer.url + '?antialias=0');
    await page.waitForFunction(() => window.gshellView && window.gshellView.loadMs !== null && window.gshellView.groups.length === 2, { timeout: 120000 });

    const runs = [];
    for (let r = 0; r < opts.runs; ++r) {
      await page.evaluate(() => window.gshellView.send(JSON.stringify({ type: 'reset' })));
      await page.evaluate(() => window.gshellView.waitFor('rest', 60000));
      const t0 = Date.now();
      const d = await page.evaluate((a) => window.gshellView.scriptedDrag(a), { handle: 1, translate: h.move, events: opts.events, interval: opts.interval, settle: true });
      const sentAt = new Map(d.sent);
      const answered = d.answers.filter((a) => sentAt.has(a.seq));
      const drawn = d.draws.filter((x) => sentAt.has(x.seq));
      const span = (Math.max(...answered.map((a) => a.at)) - sentAt.get(d.first)) / 1000;
      const run = {
        answered: answered.length,
        solve: median(answered.map((a) => a.solveMs)),
        serverInOut: median(answered.map((a) => a.latencyMs)),
        pageToArrived: median(answered.map((a) => a.at - sentAt.get(a.seq))),
        pageToDrawn: median(drawn.map((x) => x.at - sentAt.get(x.seq))),
        apply: median(drawn.map((x) => x.applyMs)),
        render: median(drawn.map((x) => x.renderMs)),
        rate: answered.length / span,
        settle: d.settled.step,
        seconds: (Date.now() - t0) / 1000,
      };
      runs.push(run);
      console.log(`  browser run ${r + 1}: ${run.answered}/${opts.events} events answered (${f1(run.rate)}/s); medians: solve ${f1(run.solve)} ms, ` +
        `message in -> positions out ${f1(run.serverInOut)} ms, page send -> positions ${f1(run.pageToArrived)} ms, send -> drawn ${f1(run.pageToDrawn)} ms ` +
        `(apply ${f1(run.apply)} + render ${f1(run.render)}); settle ${run.settle.iterations} iterations, ${f1(run.settle.seconds * 1000)} ms; load ${load()}`);
    }
    // The page after the last drag (README's screenshot of the viewer).
    await page.evaluate(() => window.gshellView.send(JSON.stringify({ type: 'certify' })));
    await page.waitForFunction(() => window.gshellView.stats && window.gshellView.stats.validity, { timeout: 300000 }).catch(() => {});
    await page.screenshot({ path: path.join(opts.out, `${model}-view.png`) });
    for (const key of ['solve', 'pageToArrived', 'pageToDrawn', 'render', 'rate']) result[key] = median(runs.map((r) => r[key]));
    result.inOut = median(runs.map((r) => r.serverInOut));
    console.log(`  browser: median of ${runs.length} runs: message in -> positions out ${f1(result.inOut)} ms, send -> drawn ${f1(result.pageToDrawn)} ms ` +
      `(render ${f1(result.render)} ms), solve ${f1(result.solve)} ms, ${f1(result.rate)} updates/s`);

    if (opts.pose) {
      // The settled shell against gshell pose with the same handle file, the same N steps.
      await page.evaluate(() => window.gshellView.send(JSON.stringify({ type: 'save_handles' })));
      await page.waitForFunction(() => window.gshellView.handlesFile, { timeout: 60000 });
      const file = path.join(opts.out, `${model}-handles.json`);
      fs.writeFileSync(file, JSON.stringify(await page.evaluate(() => window.gshellView.handlesFile), null, 1));
      const saved = `${model}-viewer-${process.pid}`;
      await page.evaluate((folder) => window.gshellView.send(JSON.stringify({ type: 'save_shell', folder })), saved);
      const mine = path.join(opts.out, saved);
      for (let t = 0; t < 600 && !fs.existsSync(path.join(mine, 'report.json')); ++t) await new Promise((r) => setTimeout(r, 100));
      const posed = path.join(opts.out, `${model}-pose`);
      const t0 = Date.now();
      execFileSync(opts.gshell, ['pose', '--shell', shell, '--handles', file, '--steps', String(opts.events), '-o', posed, '-q'], { stdio: ['ignore', 'ignore', 'inherit'] });
      const poseSeconds = (Date.now() - t0) / 1000;
      const a = [...readObj(path.join(mine, 'base.obj')), ...readObj(path.join(mine, 'top.obj'))];
      const b = [...readObj(path.join(posed, 'base.obj')), ...readObj(path.join(posed, 'top.obj'))];
      let worst = 0, sum = 0;
      for (let v = 0; v < a.length / 3; ++v) {
        const d = Math.hypot(a[3 * v] - b[3 * v], a[3 * v + 1] - b[3 * v + 1], a[3 * v + 2] - b[3 * v + 2]);
        worst = Math.max(worst, d);
        sum += d;
      }
      const ea = JSON.parse(fs.readFileSync(path.join(mine, 'report.json'))).steps.at(-1).energy;
      const eb = JSON.parse(fs.readFileSync(path.join(posed, 'report.json'))).steps.at(-1).energy;
      result.pose = { worst: worst / h.R, mean: sum / (a.length / 3) / h.R, energy: (ea - eb) / eb };
      console.log(`  settled vs gshell pose --steps ${opts.events} (${f1(poseSeconds)} s): largest vertex distance ${result.pose.worst.toExponential(2)} R, ` +
        `mean ${result.pose.mean.toExponential(2)} R; energy ${ea.toPrecision(8)} vs ${eb.toPrecision(8)} (relative ${result.pose.energy.toExponential(2)})`);
      fs.rmSync(mine, { recursive: true, force: true });
    }
  } finally {
    await browser.close();
    await viewer.stop();
  }
  return result;
}

console.log(`bench/view.mjs: ${opts.events} drag events every ${opts.interval.toFixed(1)} ms, ${opts.runs} runs; ${os.cpus().length} cores; load average ${load()}`);
for (const m of models) await benchModel(m);
