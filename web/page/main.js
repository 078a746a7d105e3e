// The page of `gshell view`: connects to the server's WebSocket, shows what it sends, and sends what
// the user does (docs/viewer.md). The server holds the one truth: this page draws the positions it
// streams and never moves the shell itself.
import * as THREE from './three/three.module.js';
import { ShellView, GROUP_COLORS } from './scene.js';
import { Tools } from './tools.js';
import { decodeFrame, FrameKind } from './protocol.js';

const $ = (id) => document.getElementById(id);

const state = {
  hello: null,
  n: 0,
  faceValues: null,
  vertexValues: null,
  groups: [],
  active: -1,
  addingGroup: undefined, // groups.length when "make group" was sent, until the server answers
  stats: null,
  answered: 0,
  solveMs: NaN,
  latencyMs: NaN,
  updates: 0,
  updateRate: 0,
  updatesSince: performance.now(),
  fps: 0,
  framesSeen: 0,
  frame: 0,
  playing: false,
  loadMs: null,
};

const view = new ShellView($('view'));
let socket = null;
let resolveReady;
const ready = new Promise((resolve) => { resolveReady = resolve; });

// ---- messages ----------------------------------------------------------------------------------

function status(text, error = false, seconds = error ? 8 : 4) {
  const div = document.createElement('div');
  div.className = error ? 'error' : 'ok';
  div.textContent = text;
  $('status').appendChild(div);
  while ($('status').children.length > 4) $('status').firstChild.remove();
  setTimeout(() => div.remove(), seconds * 1000);
}

function send(text) {
  const limit = state.hello ? state.hello.max_message_bytes : Infinity;
  if (text.length > limit) return status(`not sent: the message is longer than the server takes (${limit} bytes)`, true);
  if (!socket || socket.readyState !== WebSocket.OPEN) return status('not connected to the server', true);
  socket.send(text);
}

function connect() {
  socket = new WebSocket(`ws://${location.host}/ws`);
  socket.binaryType = 'arraybuffer';
  socket.onmessage = (event) => (typeof event.data === 'string' ? onText(JSON.parse(event.data)) : onFrame(decodeFrame(event.data)));
  socket.onclose = (event) => {
    // 1013 (try again later): the server runs but has its most pages open; it said so just before.
    const full = event.code === 1013;
    const why = event.code === 1009 ? 'a message was too big' : event.code === 1001 ? 'the server stopped' : full ? 'too many pages open' : event.reason || `code ${event.code}`;
    status(`disconnected from gshell view (${why}); ${full ? 'close another page of it, then reload this one' : 'reload the page once it runs again'}`, true, 3600);
    $('input-name').textContent = 'disconnected';
  };
}

function onText(m) {
  switch (m.type) {
    case 'hello': return onHello(m);
    case 'handles': return onHandles(m.handles);
    case 'stats': state.stats = m; return showStats();
    case 'error':
      if (m.request === 'add_handle') state.addingGroup = undefined; // refused: the selection stays
      return status(m.message, true);
    case 'saved': return status(`saved ${m.path}`);
    case 'handles_file':
      state.handlesFile = m.handles;
      return download('handles.json', JSON.stringify(m.handles, null, 2));
    case 'pages': $('pages').textContent = m.count > 1 ? `${m.count} pages share this session (each sees and drags the same shell)` : ''; return;
    default: console.warn('gshell view: unknown message', m.type);
  }
}

function onHello(m) {
  state.hello = m;
  state.n = m.vertices;
  document.title = `gshell view: ${m.name}`;
  $('input-name').textContent = `${m.name} (${m.made_by || m.kind}): ${2 * m.vertices} vertices, ${m.tets} tets`;
  $('posing').hidden = !m.posable;
  $('sequence').hidden = m.posable;
  $('output-dir').textContent = m.posable ? `saves into ${m.output_dir}` : '';
  if (!m.posable) {
    $('frame').max = m.frames.length - 1;
    $('frame-name').textContent = m.frames[0] || '';
  }
  setColorMax();
}

function onFrame(f) {
  if (f.kind === FrameKind.Faces) {
    view.setShell(state.n, f.data.slice());
  } else if (f.kind === FrameKind.Positions || f.kind === FrameKind.Frame) {
    const positions = f.data.slice(); // the buffer is the socket's; keep a copy
    if (f.kind === FrameKind.Positions) {
      state.answered = f.seq;
      if (f.a > 0) state.solveMs = f.a;
      if (f.b > 0) state.latencyMs = f.b;
      bench.arrived(f.seq, f.a, f.b);
    } else {
      state.frame = f.seq;
      $('frame').value = f.seq;
      $('frame-name').textContent = state.hello.frames[f.seq] || '';
      framesArrived();
    }
    ++state.updates;
    view.setPositions(positions, f.seq);
  } else if (f.kind === FrameKind.Values) {
    const m = f.a, n = f.b;
    state.faceValues = f.data.slice(0, m);
    state.vertexValues = f.data.slice(m, m + n);
    applyColors();
  }
}

view.onDrawn((seq, now, applyMs, renderMs) => {
  if (state.loadMs === null && view.framed) {
    state.loadMs = now; // since navigation started: the page's load time
    resolveReady();
  }
  bench.drawn(seq, now, applyMs, renderMs);
  // Flow control: the server sends the next positions only once these are drawn, so a page that
  // draws slowly gets the latest shell rather than a backlog.
  if (socket && socket.readyState === WebSocket.OPEN) socket.send('{"type":"drawn"}');
});

// ---- display -------------------------------------------------------------------------------------

// What the shown stretch is measured against (the server's stats.stretch.against).
function stretchAgainst(against) {
  return { input: 'the ideal prisms, as stored in the input', 'input rest shell': 'the rest shell, as stored in the input' }[against] ?? 'the loaded shell';
}

function colorScale() {
  const mode = $('color-by').value;
  if (!state.hello || mode === 'none') return null;
  const scale = { ...state.hello.scales[mode] };
  const red = parseFloat($('color-max').value);
  if (red > 0) {
    if (mode === 'stretch') scale.max = red;
    else { scale.min = 1 - red; scale.max = 1 + red; }
  }
  return scale;
}

function setColorMax() {
  const mode = $('color-by').value;
  if (!state.hello || mode === 'none') return;
  const s = state.hello.scales[mode];
  $('color-max').value = mode === 'stretch' ? s.max : (s.max - s.min) / 2;
}

function applyColors() {
  const mode = $('color-by').value, scale = colorScale();
  view.setColors(mode, scale, state.faceValues, state.vertexValues);
  $('colorbar').hidden = !scale;
  if (!scale) return;
  const canvas = $('colorbar-ramp'), g = canvas.getContext('2d'), ramp = scale.ramp, k = ramp.length / 3;
  for (let x = 0; x < canvas.width; ++x) {
    const t = (x / (canvas.width - 1)) * (k - 1), i = Math.min(k - 2, Math.floor(t)), f = t - i;
    const c = [0, 1, 2].map((j) => Math.round(255 * (ramp[3 * i + j] + f * (ramp[3 * i + 3 + j] - ramp[3 * i + j]))));
    g.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
    g.fillRect(x, 0, 1, canvas.height);
  }
  const fmt = (v) => Number(v.toPrecision(4)).toString();
  applyColorbarLabel();
  $('colorbar-min').textContent = fmt(scale.min);
  $('colorbar-mid').textContent = fmt((scale.min + scale.max) / 2);
  $('colorbar-max').textContent = `${fmt(scale.max)}+`;
  $('colorbar-note').textContent = scale.footnote;
}

function showStats() {
  const s = state.stats;
  if (!s) return;
  const rows = [];
  const num = (v, digits = 4) => (v === null || v === undefined || Number.isNaN(v) ? '–' : Number(v.toPrecision(digits)).toString());
  rows.push(['vertices', s.vertices], ['tets', s.tets]);
  if (s.handles !== undefined) rows.push(['handles', `${s.handles} groups, ${s.handle_vertices} vertices`]);
  // Over the prisms' means (what the faces are colored by), not over single tets as report.json's
  // stretch: its max is the largest prism mean, below the largest tet's.
  if (s.stretch) rows.push([`prism stretch (${s.stretch.against.startsWith('input') ? 'input' : 'vs loaded'})`, `mean ${num(s.stretch.mean)}, max ${num(s.stretch.max)}`]);
  const v = s.validity;
  if (v && !v.error) {
    // The exact shell certificate (docs/validity.md): counts decided by exact predicates.
    const c = v.certificate || {};
    rows.push(['inverted tets', c.inverted_tets, c.inverted_tets ? 'bad' : 'good']);
    const crossing = (c.top_self_intersections || 0) + (c.top_base_intersections || 0) + (c.wall_intersections || 0);
    rows.push(['intersections', `top/top ${c.top_self_intersections}, top/base ${c.top_base_intersections}, wall ${c.wall_intersections}`, crossing ? 'bad' : 'good']);
    if (c.nested_parts) rows.push(['parts inside another layer', `${c.nested_parts} sheet${c.nested_parts === 1 ? '' : 's'}`, 'bad']);
    if (v.base_self_intersections) rows.push(['base intersects itself', `${v.base_self_intersections} face pairs`, 'bad']);
    rows.push(['valid (exact)', v.valid === null ? 'unknown' : v.valid ? 'yes' : 'no', v.valid ? 'good' : 'bad']);
  } else {
    if (s.inverted_tets !== null && s.inverted_tets !== undefined) rows.push(['inverted tets', `${s.inverted_tets} (det F)`, s.inverted_tets ? 'bad' : '']);
    rows.push(['intersections', v && v.error ? `check failed: ${v.error}` : 'checked when the shell rests']);
    rows.push(['valid', '–']);
  }
  rows.push(['state', s.phase + (s.step ? `, ${s.step.iterations} iterations${s.step.converged ? '' : ''}` : '')]);
  rows.push(['solve ms / step', num(state.solveMs, 3)], ['latency ms', num(state.latencyMs, 3)]);
  rows.push(['updates / s', num(state.updateRate, 3)], ['frames drawn / s', num(state.fps, 3)]);
  // Whatever else a step reports (e.g. contact warnings from later solvers) is shown as is.
  // (The guard's fields of a settled step are shown by the certificate rows above; contact is news.)
  if (s.step) for (const [key, value] of Object.entries(s.step))
    if (!['fraction', 'iterations', 'energy', 'seconds', 'converged', 'seq', 'latency_ms', 'guarded', 'valid', 'method', 'guarded_iterations', 'certificate', 'drag_start', 'base_self_intersections', 'rest_faults_only'].includes(key) && (key !== 'blocked_by_contact' || value))
      rows.push([key.replaceAll('_', ' '), typeof value === 'object' ? JSON.stringify(value) : String(value), value ? 'bad' : '']);
  if (s.solver) rows.push(['solver', s.solver, 'bad']);
  const body = $('stats-body');
  body.replaceChildren(...rows.map(([k, val, cls]) => {
    const tr = document.createElement('tr');
    const a = document.createElement('td'), b = document.createElement('td');
    a.textContent = k;
    b.textContent = val;
    if (cls) b.className = cls;
    tr.append(a, b);
    return tr;
  }));
  if ($('color-by').value === 'stretch') applyColorbarLabel();
}

function applyColorbarLabel() {
  const stretch = state.stats?.stretch, scale = colorScale();
  if (!scale) return;
  const against = $('color-by').value === 'stretch' && stretch ? ` (against ${stretchAgainst(stretch.against)})` : '';
  $('colorbar-label').textContent = scale.label + against;
}

setInterval(() => {
  const now = performance.now();
  state.updateRate = (1000 * state.updates) / (now - state.updatesSince);
  state.fps = (1000 * (view.framesDrawn - state.framesSeen)) / (now - state.updatesSince);
  state.framesSeen = view.framesDrawn;
  state.updates = 0;
  state.updatesSince = now;
  showStats();
}, 1000);

// ---- handle groups -------------------------------------------------------------------------------

function onHandles(file) {
  state.groups = (file.handles || []).map((h, k) => {
    const rotate = h.rotate || { axis: [0, 0, 1], degrees: 0, center: [0, 0, 0] };
    const axis = new THREE.Vector3(...rotate.axis).normalize();
    const group = {
      name: h.name || `group ${k + 1}`,
      vertices: h.vertices,
      color: GROUP_COLORS[k % GROUP_COLORS.length],
      translate: new THREE.Vector3(...(h.translate || [0, 0, 0])),
      rotation: new THREE.Quaternion().setFromAxisAngle(axis, (rotate.degrees * Math.PI) / 180),
      center: new THREE.Vector3(...rotate.center),
      // Turns happen about the group's center where it is now.
      currentCenter() { return this.center.clone().add(this.translate); },
    };
    return group;
  });
  if (state.addingGroup !== undefined && state.groups.length > state.addingGroup) {
    state.active = state.addingGroup; // the new group
    state.addingGroup = undefined;
    $('group-name').value = '';
    tools.setSelection(new Set());
  }
  if (state.active >= state.groups.length) state.active = state.groups.length - 1;
  view.setGroups(state.groups);
  renderGroups();
}

function renderGroups() {
  const list = $('groups');
  list.replaceChildren(...state.groups.map((g, k) => {
    const li = document.createElement('li');
    if (k === state.active) li.className = 'active';
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = g.color;
    const name = document.createElement('span');
    name.className = 'name';
    name.textContent = `${g.name} (${g.vertices.length})`;
    const replace = document.createElement('button');
    replace.textContent = '=sel';
    replace.title = 'give this group the selected vertices';
    replace.onclick = (e) => {
      e.stopPropagation();
      if (!tools.selection.size) return status('select vertices first', true);
      send(JSON.stringify({ type: 'set_handle_vertices', handle: k, vertices: [...tools.selection] }));
    };
    const remove = document.createElement('button');
    remove.textContent = '×';
    remove.title = 'remove this group';
    remove.onclick = (e) => {
      e.stopPropagation();
      send(JSON.stringify({ type: 'remove_handle', handle: k }));
    };
    li.append(swatch, name, replace, remove);
    li.onclick = () => app.setActiveGroup(k);
    return li;
  }));
}

function download(name, text) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([text], { type: 'application/json' }));
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

// ---- the app the tools talk to -------------------------------------------------------------------

const app = {
  send,
  status,
  groups: () => state.groups,
  activeGroup: () => state.active,
  setActiveGroup(k) { state.active = k; renderGroups(); },
  surface: () => $('surface').value,
  // In page units, as positions are: (x - hello.origin) * hello.unit.
  thickness: () => state.hello && state.hello.thickness * (state.hello.unit || 1),
  selectionChanged(set) { $('selected').textContent = `${set.size} vertices selected`; },
  dragSent(seq) { bench.sent(seq); },
};
const tools = new Tools(view, app);

// ---- controls ------------------------------------------------------------------------------------

$('color-by').onchange = () => { setColorMax(); applyColors(); };
$('color-max').onchange = applyColors;
$('cut').onchange = () => view.setCut($('cut').checked);
$('show-top').onchange = () => view.setShowTop($('show-top').checked);
$('home').onclick = () => view.home();
for (const radio of document.querySelectorAll('input[name=mode]')) radio.onchange = () => tools.setMode(radio.value);
$('brush').oninput = () => { tools.brushPixels = +$('brush').value; $('brush-px').textContent = `${tools.brushPixels} px`; };
$('clear-selection').onclick = () => tools.setSelection(new Set());
$('make-group').onclick = () => {
  if (!tools.selection.size) return status('select vertices first (box or brush mode)', true);
  send(JSON.stringify({ type: 'add_handle', name: $('group-name').value.trim(), vertices: [...tools.selection] }));
  // The selection and the name stay until the server has the group: a refused one (overlapping
  // another group) is then mended, not selected again from scratch.
  state.addingGroup = state.groups.length;
};
$('undo').onclick = () => send(JSON.stringify({ type: 'undo' }));
$('reset').onclick = () => send(JSON.stringify({ type: 'reset' }));
$('save-handles').onclick = () => send(JSON.stringify({ type: 'save_handles' }));
$('load-handles').onchange = async () => {
  const file = $('load-handles').files[0];
  if (!file) return;
  send(JSON.stringify({ type: 'load_handles', name: file.name, text: await file.text() }));
  $('load-handles').value = '';
};
$('save-shell').onclick = () => {
  const folder = $('shell-name').value.trim();
  if (!folder) return status('name the folder to write (letters, digits, . _ -)', true);
  send(JSON.stringify({ type: 'save_shell', folder }));
};

// Frames of a sequence: the slider asks for a frame; play asks for the next one when the last arrived.
$('frame').oninput = () => send(JSON.stringify({ type: 'frame', index: +$('frame').value }));
let playTimer = null;
function framesArrived() {
  if (!state.playing) return;
  clearTimeout(playTimer);
  const fps = Math.min(60, Math.max(1, +$('fps').value || 10));
  playTimer = setTimeout(() => send(JSON.stringify({ type: 'frame', index: (state.frame + 1) % state.hello.frames.length })), 1000 / fps);
}
$('play').onclick = () => {
  state.playing = !state.playing;
  $('play').textContent = state.playing ? 'pause' : 'play';
  if (state.playing) framesArrived();
};

window.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'radio' && e.target.type !== 'checkbox') return;
  if ((e.ctrlKey || e.metaKey) && e.key === 'z') {
    if (state.hello && state.hello.posable) send(JSON.stringify({ type: 'undo' })); // a sequence has nothing to undo
    e.preventDefault();
    return;
  }
  const modes = { o: 'orbit', b: 'box', p: 'brush', d: 'drag' };
  if (modes[e.key] && state.hello && state.hello.posable) {
    document.querySelector(`input[name=mode][value=${modes[e.key]}]`).checked = true;
    tools.setMode(modes[e.key]);
  }
  if (e.key === 'f') view.home();
});

// ---- for tests and the benchmark (tests/view_browser_test.mjs, bench/view.mjs) ---------------------

const bench = {
  record: false,
  syncDraw: false, // read a pixel back after drawing, so "drawn" means the GPU finished
  sentAt: new Map(),
  answers: [],
  draws: [],
  sent(seq) { if (this.record) this.sentAt.set(seq, performance.now()); },
  // Frames answering a drag carry its in->out milliseconds (> 0); settle progress and jumps carry 0.
  arrived(seq, solveMs, latencyMs) { if (this.record && latencyMs > 0) this.answers.push({ seq, at: performance.now(), solveMs, latencyMs }); },
  drawn(seq, now, applyMs, renderMs) {
    if (!this.record || !this.sentAt.has(seq) || this.draws.some((d) => d.seq === seq)) return;
    if (this.syncDraw) {
      const gl = view.renderer.getContext();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
      const finished = performance.now();
      renderMs += finished - now;
      now = finished;
    }
    this.draws.push({ seq, at: now, applyMs, renderMs });
  },
};

window.gshellView = {
  ready,
  get loadMs() { return state.loadMs; },
  get hello() { return state.hello; },
  get stats() { return state.stats; },
  get groups() { return state.groups.map((g) => ({ name: g.name, vertices: g.vertices.length })); },
  get selected() { return tools.selection.size; },
  get answered() { return state.answered; },
  /** The last handle file the server sent (after a save_handles). */
  get handlesFile() { return state.handlesFile; },
  send,
  /** The positions drawn last (2n x 3, flat), in page units as the server sends them: (x - hello.origin) * hello.unit. */
  positions() { return Array.from(view.positions); },
  /** Where vertex v is on the screen (page coordinates), or null when cut away. */
  screenOf(v) {
    const S = view.project(), r = view.renderer.domElement.getBoundingClientRect();
    return Number.isNaN(S[3 * v]) ? null : { x: r.left + S[3 * v], y: r.top + S[3 * v + 1] };
  },
  /** The seq of the last drag message the page sent (mouse or scripted). */
  get sentSeq() { return tools.seq; },
  /** Resolves when the stats say `phase` (e.g. 'settled') for a step that has taken in the drag
   *  `seq` or a later one, or rejects after `ms`. Without `seq` an earlier settle (the mouse
   *  rested mid-drag on a slow machine) would do. */
  waitFor(phase, ms = 60000, seq = 0) {
    return new Promise((resolve, reject) => {
      const t0 = performance.now();
      const poll = () => {
        const stepSeq = (state.stats && state.stats.step && state.stats.step.seq) || 0;
        if (state.stats && state.stats.phase === phase && stepSeq >= seq && !view.pending) return resolve(state.stats);
        if (performance.now() - t0 > ms) return reject(new Error(`no ${phase} within ${ms} ms (${state.stats && state.stats.phase})`));
        setTimeout(poll, 20);
      };
      poll();
    });
  },
  /** Bench: `events` drag messages moving group `handle` in a straight line to `translate`, one
   *  every `interval` ms (a mouse at that rate); then release and wait for the settle. Returns
   *  per event what the page saw: when it was sent, answered (with the server's solve and in->out
   *  milliseconds) and drawn. */
  async scriptedDrag({ handle, translate, events = 60, interval = 1000 / 60, syncDraw = true, settle = true }) {
    Object.assign(bench, { record: true, syncDraw, answers: [], draws: [] });
    bench.sentAt.clear();
    send(JSON.stringify({ type: 'grab', handle }));
    const g = state.groups[handle];
    const t0 = g.translate.clone(), t1 = new THREE.Vector3(...translate);
    const first = tools.seq + 1;
    for (let k = 1; k <= events; ++k) {
      const t = t0.clone().lerp(t1, k / events);
      g.translate.copy(t);
      send(JSON.stringify({ type: 'drag', seq: ++tools.seq, handle, translate: [t.x, t.y, t.z] }));
      bench.sent(tools.seq);
      await new Promise((r) => setTimeout(r, interval));
    }
    const last = tools.seq;
    await new Promise((resolve) => { const poll = () => (state.answered >= last && !view.pending ? resolve() : setTimeout(poll, 5)); poll(); });
    await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
    bench.record = false;
    const result = { first, last, sent: [...bench.sentAt.entries()], answers: bench.answers, draws: bench.draws };
    if (settle) {
      send(JSON.stringify({ type: 'release' }));
      result.settled = await this.waitFor('settled', 600000, last);
    }
    return result;
  },
};

connect();
