// Mouse tools: box and brush selection of shell vertices, and dragging handle groups in the view
// plane (Shift: turning them about the view axis). Every drag move goes to the server at once; the
// server coalesces moves that arrive while it solves.
import * as THREE from './three/three.module.js';
import { dragMessage } from './protocol.js';

const PICK_PIXELS = 14; // how near the cursor a handle vertex must be to grab its group

export class Tools {
  /** view: ShellView; app: {send(text), groups(), activeGroup(), selectionChanged(set), surface()} */
  constructor(view, app) {
    this.view = view;
    this.app = app;
    this.mode = 'orbit';
    this.brushPixels = 24;
    this.selection = new Set();
    this.seq = 0;
    this.box = document.getElementById('selection-box');
    this.ring = document.getElementById('brush-ring');
    const el = view.renderer.domElement;
    el.addEventListener('pointerdown', (e) => this.down(e));
    el.addEventListener('pointermove', (e) => this.move(e));
    el.addEventListener('pointerup', (e) => this.up(e));
    el.addEventListener('pointercancel', (e) => this.up(e));
    el.addEventListener('pointerleave', () => { this.ring.hidden = true; });
  }

  setMode(mode) {
    this.mode = mode;
    // Outside orbit mode the left button is the tool's; orbit moves to the middle button.
    const M = THREE.MOUSE;
    this.view.controls.mouseButtons = mode === 'orbit' ? { LEFT: M.ROTATE, MIDDLE: M.DOLLY, RIGHT: M.PAN } : { LEFT: null, MIDDLE: M.ROTATE, RIGHT: M.PAN };
    this.ring.hidden = true;
  }

  local(e) {
    const r = this.view.renderer.domElement.getBoundingClientRect();
    return { x: e.clientX - r.left, y: e.clientY - r.top };
  }

  // Vertex ids of the chosen surface(s).
  surfaceRange() {
    const n = this.view.n, s = this.app.surface();
    return s === 'base' ? [0, n] : s === 'top' ? [n, 2 * n] : [0, 2 * n];
  }

  down(e) {
    if (e.button !== 0 || this.mode === 'orbit' || !this.view.n) return;
    const p = this.local(e);
    this.view.renderer.domElement.setPointerCapture(e.pointerId);
    if (this.mode === 'box') {
      this.gesture = { kind: 'box', start: p, op: this.op(e) };
      this.showBox(p, p);
    } else if (this.mode === 'brush') {
      this.gesture = { kind: 'brush', op: this.op(e), picked: this.op(e) === 'replace' ? new Set() : new Set(this.selection) };
      this.paint(p);
    } else if (this.mode === 'drag') {
      this.grab(p, e.shiftKey);
    }
  }

  move(e) {
    const p = this.local(e);
    if (this.mode === 'brush') this.showRing(p);
    const g = this.gesture;
    if (!g) return;
    if (g.kind === 'box') this.showBox(g.start, p);
    else if (g.kind === 'brush') this.paint(p);
    else if (g.kind === 'drag') this.dragTo(p, e.shiftKey);
  }

  up(e) {
    const g = this.gesture;
    if (!g) return;
    this.gesture = null;
    const p = this.local(e);
    if (g.kind === 'box') {
      this.box.hidden = true;
      this.boxSelect(g.start, p, g.op);
    } else if (g.kind === 'drag') {
      this.app.send(JSON.stringify({ type: 'release' }));
    }
  }

  op(e) { return e.altKey ? 'remove' : e.shiftKey ? 'add' : 'replace'; }

  setSelection(set) {
    this.selection = set;
    this.view.setSelection(set);
    this.app.selectionChanged(set);
  }

  showBox(a, b) {
    const r = this.view.renderer.domElement.getBoundingClientRect();
    Object.assign(this.box.style, { left: `${r.left + Math.min(a.x, b.x)}px`, top: `${r.top + Math.min(a.y, b.y)}px`,
      width: `${Math.abs(a.x - b.x)}px`, height: `${Math.abs(a.y - b.y)}px` });
    this.box.hidden = false;
  }

  showRing(p) {
    const r = this.view.renderer.domElement.getBoundingClientRect(), d = 2 * this.brushPixels;
    Object.assign(this.ring.style, { left: `${r.left + p.x - this.brushPixels}px`, top: `${r.top + p.y - this.brushPixels}px`, width: `${d}px`, height: `${d}px` });
    this.ring.hidden = false;
  }

  /** Every vertex of the chosen surface(s) whose screen position lies in the rectangle (through the shell). */
  boxSelect(a, b, op) {
    const x0 = Math.min(a.x, b.x), x1 = Math.max(a.x, b.x), y0 = Math.min(a.y, b.y), y1 = Math.max(a.y, b.y);
    const S = this.view.project();
    const [lo, hi] = this.surfaceRange();
    const hit = [];
    for (let v = lo; v < hi; ++v) {
      const x = S[3 * v], y = S[3 * v + 1];
      if (x >= x0 && x <= x1 && y >= y0 && y <= y1) hit.push(v);
    }
    this.combine(op, hit);
  }

  /** The brush takes the vertices under the cursor's disk that lie near the front-most one (the
   *  surface under the cursor, not the far side of the model). */
  paint(p) {
    const S = this.view.project();
    const [lo, hi] = this.surfaceRange();
    const r2 = this.brushPixels * this.brushPixels;
    const inside = [];
    let front = Infinity;
    for (let v = 0; v < S.length / 3; ++v) {
      const dx = S[3 * v] - p.x, dy = S[3 * v + 1] - p.y;
      if (dx * dx + dy * dy <= r2) {
        front = Math.min(front, S[3 * v + 2]);
        if (v >= lo && v < hi) inside.push(v);
      }
    }
    if (!inside.length) return;
    // Depth window: the brush's own width in model units at that depth, and a few shell thicknesses.
    const fovScale = 2 * Math.tan(((this.view.camera.fov / 2) * Math.PI) / 180) / this.view.container.clientHeight;
    const window = Math.max(2 * this.brushPixels * fovScale * front, 4 * (this.app.thickness() || 0));
    const g = this.gesture;
    for (const v of inside)
      if (S[3 * v + 2] <= front + window) {
        if (g.op === 'remove') g.picked.delete(v);
        else g.picked.add(v);
      }
    this.setSelection(new Set(g.picked));
  }

  combine(op, hit) {
    const s = op === 'replace' ? new Set() : new Set(this.selection);
    for (const v of hit) {
      if (op === 'remove') s.delete(v);
      else s.add(v);
    }
    this.setSelection(s);
  }

  /** Grabs the group with a vertex nearest the cursor (front-most), else the active group. */
  grab(p, turning) {
    const groups = this.app.groups();
    if (!groups.length) return this.app.status('make a handle group first (select vertices, then "make group")', true);
    const S = this.view.project();
    let best = null;
    groups.forEach((g, k) => {
      for (const v of g.vertices) {
        const dx = S[3 * v] - p.x, dy = S[3 * v + 1] - p.y, d2 = dx * dx + dy * dy;
        if (d2 <= PICK_PIXELS * PICK_PIXELS && (!best || S[3 * v + 2] < best.depth - 1e-9 || (Math.abs(S[3 * v + 2] - best.depth) <= 1e-9 && d2 < best.d2)))
          best = { k, v, depth: S[3 * v + 2], d2 };
      }
    });
    let k = best ? best.k : this.app.activeGroup();
    if (k == null || k < 0 || k >= groups.length) return this.app.status('no handle group under the mouse: click one of the colored points, or pick a group in the list', true);
    this.app.setActiveGroup(k);
    const P = this.view.positions;
    const g = groups[k];
    const anchor = best ? new THREE.Vector3(P[3 * best.v], P[3 * best.v + 1], P[3 * best.v + 2]) : g.currentCenter(P);
    this.gesture = { kind: 'drag', k };
    this.anchor(p, anchor, turning);
    this.app.send(JSON.stringify({ type: 'grab', handle: k }));
  }

  // A drag is measured from an anchor: the motion of the group then, the mouse and the grabbed point.
  anchor(p, point, turning) {
    const g = this.app.groups()[this.gesture.k];
    Object.assign(this.gesture, { mouse: p, point, turning, translate: g.translate.clone(), rotation: g.rotation.clone() });
  }

  dragTo(p, turning) {
    const d = this.gesture;
    const g = this.app.groups()[d.k];
    if (turning !== d.turning) this.anchor(p, d.point, turning); // switching between moving and turning
    if (turning) {
      // Turn about the view axis through the group's current center: the translation stays.
      const angle = ((p.x - d.mouse.x) * Math.PI) / 240;
      const turn = new THREE.Quaternion().setFromAxisAngle(this.view.viewDirection().negate(), angle);
      g.rotation.copy(turn.multiply(d.rotation));
      g.translate.copy(d.translate);
    } else {
      const now = this.view.pointInViewPlane(d.point, p.x, p.y);
      const then = this.view.pointInViewPlane(d.point, d.mouse.x, d.mouse.y);
      if (!now || !then) return;
      g.translate.copy(d.translate).add(now.sub(then));
      g.rotation.copy(d.rotation);
    }
    this.app.send(dragMessage(++this.seq, d.k, g.translate, g.rotation));
    this.app.dragSent(this.seq);
  }
}
