// The 3D view: the shell drawn as gshell render draws it (an opaque base under a translucent top,
// both colored per face by stretch or per vertex by thickness, or cut away by a plane through the
// middle facing the eye), handle groups and the selection as points, orbit/pan/zoom.
import * as THREE from './three/three.module.js';
import { OrbitControls } from './three/OrbitControls.js';

// The greys and the cut's inside color of gshell render (src/render/shell_render.cpp).
const BASE_GREY = [0.72, 0.76, 0.84];
const TOP_GREY = [0.88, 0.88, 0.9];
const CUT_INSIDE = [0.55, 0.68, 0.92];
const TOP_OPACITY = 0.35;
export const GROUP_COLORS = ['#d62728', '#1f77b4', '#2ca02c', '#9467bd', '#ff7f0e', '#17becf', '#e377c2', '#8c564b'];

function srgb(rgb) {
  return new THREE.Color().setRGB(rgb[0], rgb[1], rgb[2], THREE.SRGBColorSpace);
}

export class ShellView {
  constructor(container) {
    this.container = container;
    // ?antialias=0 in the URL: no multisampling (software WebGL, e.g. the headless benchmark).
    const antialias = new URLSearchParams(location.search).get('antialias') !== '0';
    this.renderer = new THREE.WebGLRenderer({ antialias });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.localClippingEnabled = true;
    this.renderer.setClearColor(0xf4f5f7);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(30, 1, 0.01, 100);
    this.scene.add(this.camera);
    this.scene.add(new THREE.AmbientLight(0xffffff, 1.1));
    const headlight = new THREE.DirectionalLight(0xffffff, 1.9);
    headlight.position.set(0.3, 0.5, 1); // from over the viewer's shoulder
    this.camera.add(headlight);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.requestRender());
    this.clipPlane = new THREE.Plane();
    this.cut = false;
    this.showTop = true;
    this.dirty = true;
    this.pending = null; // the newest positions not drawn yet
    this.drawnListeners = [];
    this.framesDrawn = 0; // frames rendered so far (the page turns them into frames per second)
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    const loop = () => {
      this.draw();
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  resize() {
    const w = Math.max(1, this.container.clientWidth), h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    this.dirty = true;
  }

  /** The shell's faces (Uint32Array 3m) over n base vertices: builds the meshes. */
  setShell(n, faces) {
    this.n = n;
    this.faces = faces;
    const corners = faces.length;
    this.positions = new Float32Array(6 * n);
    this.basePosition = new THREE.BufferAttribute(new Float32Array(3 * corners), 3).setUsage(THREE.DynamicDrawUsage);
    this.topPosition = new THREE.BufferAttribute(new Float32Array(3 * corners), 3).setUsage(THREE.DynamicDrawUsage);
    this.color = new THREE.BufferAttribute(new Float32Array(3 * corners), 3).setUsage(THREE.DynamicDrawUsage);
    this.color.array.fill(0.7);
    const geometry = (position) => {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', position);
      g.setAttribute('color', this.color);
      return g;
    };
    this.baseGeometry = geometry(this.basePosition);
    this.topGeometry = geometry(this.topPosition);
    const planes = [this.clipPlane];
    this.baseMaterial = new THREE.MeshPhongMaterial({ vertexColors: true, flatShading: true, side: THREE.DoubleSide, shininess: 12, specular: 0x181818 });
    this.topMaterial = new THREE.MeshPhongMaterial({ vertexColors: true, flatShading: true, side: THREE.DoubleSide, transparent: true,
      opacity: TOP_OPACITY, depthWrite: false, shininess: 12, specular: 0x181818 });
    this.topFront = new THREE.MeshPhongMaterial({ color: srgb(TOP_GREY), flatShading: true, side: THREE.FrontSide, clippingPlanes: planes });
    this.topBack = new THREE.MeshPhongMaterial({ color: srgb(CUT_INSIDE), flatShading: true, side: THREE.BackSide, clippingPlanes: planes });
    this.base = new THREE.Mesh(this.baseGeometry, this.baseMaterial);
    this.top = new THREE.Mesh(this.topGeometry, this.topMaterial);
    this.top.renderOrder = 1;
    this.topCutBack = new THREE.Mesh(this.topGeometry, this.topBack);
    for (const m of [this.base, this.top, this.topCutBack]) m.frustumCulled = false;
    this.scene.add(this.base, this.top, this.topCutBack);
    // Handle groups and the selection: points drawn over everything.
    this.handlePoints = this.makePoints(7);
    this.selectionPoints = this.makePoints(5);
    this.groups = [];
    this.selection = new Set();
    this.applyStyle();
  }

  makePoints(size) {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3), 3));
    g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3), 3));
    g.setDrawRange(0, 0);
    const p = new THREE.Points(g, new THREE.PointsMaterial({ size, sizeAttenuation: false, vertexColors: true, depthTest: false, transparent: true }));
    p.renderOrder = 2;
    p.frustumCulled = false;
    this.scene.add(p);
    return p;
  }

  /** New 2n x 3 positions (Float32Array, base rows then top rows); drawn at the next frame. */
  setPositions(positions, seq) {
    this.pending = { positions, seq };
    this.dirty = true;
  }

  onDrawn(listener) {
    this.drawnListeners.push(listener);
  }

  applyPositions(P) {
    this.positions.set(P);
    const F = this.faces, n3 = 3 * this.n;
    const b = this.basePosition.array, t = this.topPosition.array;
    for (let c = 0; c < F.length; ++c) {
      const v = 3 * F[c], o = 3 * c;
      b[o] = P[v]; b[o + 1] = P[v + 1]; b[o + 2] = P[v + 2];
      t[o] = P[n3 + v]; t[o + 1] = P[n3 + v + 1]; t[o + 2] = P[n3 + v + 2];
    }
    this.basePosition.needsUpdate = true;
    this.topPosition.needsUpdate = true;
    this.updatePoints();
    if (!this.framed) this.home();
  }

  /** Colors: 'stretch' (per face), 'thickness' (per vertex), 'none'; scale {min, max, ramp, nan}. */
  setColors(mode, scale, faceValues, vertexValues) {
    this.colorMode = mode;
    if (mode !== 'none' && scale) {
      const ramp = scale.ramp, samples = ramp.length / 3;
      // The ramp is sampled from gshell render's: interpolate it linearly, in sRGB, as render does.
      const rampLinear = new Float32Array(ramp.length);
      const c = new THREE.Color();
      for (let k = 0; k < samples; ++k) {
        c.setRGB(ramp[3 * k], ramp[3 * k + 1], ramp[3 * k + 2], THREE.SRGBColorSpace);
        rampLinear[3 * k] = c.r; rampLinear[3 * k + 1] = c.g; rampLinear[3 * k + 2] = c.b;
      }
      c.setRGB(scale.nan[0], scale.nan[1], scale.nan[2], THREE.SRGBColorSpace);
      const nan = [c.r, c.g, c.b];
      const span = scale.max - scale.min;
      const colorOf = (value, out, o) => {
        if (!Number.isFinite(value)) { out[o] = nan[0]; out[o + 1] = nan[1]; out[o + 2] = nan[2]; return; }
        let t = span > 0 ? (value - scale.min) / span : value > scale.min ? 1 : 0;
        t = Math.min(1, Math.max(0, t)) * (samples - 1);
        const k = Math.min(samples - 2, Math.floor(t)), f = t - k;
        for (let i = 0; i < 3; ++i) out[o + i] = rampLinear[3 * k + i] + f * (rampLinear[3 * k + 3 + i] - rampLinear[3 * k + i]);
      };
      const out = this.color.array, F = this.faces;
      if (mode === 'stretch' && faceValues) {
        const tmp = [0, 0, 0];
        for (let f = 0; f < F.length / 3; ++f) {
          colorOf(faceValues[f], tmp, 0);
          for (let k = 0; k < 3; ++k) { out[9 * f + 3 * k] = tmp[0]; out[9 * f + 3 * k + 1] = tmp[1]; out[9 * f + 3 * k + 2] = tmp[2]; }
        }
      } else if (mode === 'thickness' && vertexValues) {
        for (let c2 = 0; c2 < F.length; ++c2) colorOf(vertexValues[F[c2]], out, 3 * c2);
      }
      this.color.needsUpdate = true;
    }
    this.applyStyle();
  }

  setCut(on) { this.cut = on; this.applyStyle(); }
  setShowTop(on) { this.showTop = on; this.applyStyle(); }

  applyStyle() {
    if (!this.base) return;
    const colored = this.colorMode && this.colorMode !== 'none';
    this.baseMaterial.vertexColors = colored;
    this.topMaterial.vertexColors = colored;
    this.baseMaterial.color = colored ? new THREE.Color(1, 1, 1) : srgb(BASE_GREY);
    this.topMaterial.color = colored ? new THREE.Color(1, 1, 1) : srgb(TOP_GREY);
    this.baseMaterial.needsUpdate = this.topMaterial.needsUpdate = true;
    // Cut: both surfaces opaque and clipped; the top neutral outside, blue inside (the layer shows
    // between the two cut rims), as gshell render --style cut.
    this.baseMaterial.clippingPlanes = this.cut ? [this.clipPlane] : [];
    this.top.material = this.cut ? this.topFront : this.topMaterial;
    this.top.visible = this.showTop;
    this.topCutBack.visible = this.showTop && this.cut;
    this.requestRender();
  }

  /** Handle groups [{vertices, color}] and the selected vertex ids, drawn as points. */
  setGroups(groups) { this.groups = groups; this.updatePoints(); }
  setSelection(selection) { this.selection = selection; this.updatePoints(); }

  updatePoints() {
    if (!this.handlePoints) return;
    const fill = (points, items) => {
      const g = points.geometry;
      let pos = g.attributes.position, col = g.attributes.color;
      if (pos.count < items.length) {
        pos = new THREE.BufferAttribute(new Float32Array(3 * items.length), 3);
        col = new THREE.BufferAttribute(new Float32Array(3 * items.length), 3);
        g.setAttribute('position', pos);
        g.setAttribute('color', col);
      }
      const P = this.positions;
      items.forEach(([v, c], i) => {
        pos.array[3 * i] = P[3 * v]; pos.array[3 * i + 1] = P[3 * v + 1]; pos.array[3 * i + 2] = P[3 * v + 2];
        col.array[3 * i] = c.r; col.array[3 * i + 1] = c.g; col.array[3 * i + 2] = c.b;
      });
      pos.needsUpdate = col.needsUpdate = true;
      g.setDrawRange(0, items.length);
    };
    const handles = [];
    for (const g of this.groups) {
      const c = new THREE.Color(g.color);
      for (const v of g.vertices) handles.push([v, c]);
    }
    fill(this.handlePoints, handles);
    const yellow = new THREE.Color('#f2c200');
    fill(this.selectionPoints, [...this.selection].map((v) => [v, yellow]));
    this.requestRender();
  }

  /** Frames the shell from gshell render's iso direction (azimuth 30, elevation 20, y up). */
  home() {
    const P = this.positions;
    const box = new THREE.Box3();
    const p = new THREE.Vector3();
    for (let i = 0; i < P.length; i += 3) box.expandByPoint(p.set(P[i], P[i + 1], P[i + 2]));
    const centre = box.getCenter(new THREE.Vector3());
    let radius = 0;
    for (let i = 0; i < P.length; i += 3) radius = Math.max(radius, p.set(P[i], P[i + 1], P[i + 2]).distanceTo(centre));
    radius = Math.max(radius, 1e-9);
    this.radius = radius;
    const az = (30 * Math.PI) / 180, el = (20 * Math.PI) / 180;
    const eye = new THREE.Vector3(Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az));
    const distance = (1.15 * radius) / Math.sin(((this.camera.fov / 2) * Math.PI) / 180) / Math.min(1, this.camera.aspect);
    this.camera.position.copy(centre).addScaledVector(eye, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.centre = centre;
    this.framed = true;
    this.requestRender();
  }

  draw() {
    if (!this.dirty || !this.base) return;
    this.dirty = false;
    const drawn = this.pending;
    const t0 = performance.now();
    if (drawn) {
      this.applyPositions(drawn.positions);
      this.pending = null;
    }
    const t1 = performance.now();
    if (this.cut && this.centre) {
      // Keep the half beyond the plane through the middle, facing the eye.
      const towardsEye = this.camera.position.clone().sub(this.controls.target).normalize();
      this.clipPlane.set(towardsEye.clone().negate(), towardsEye.dot(this.controls.target));
    }
    this.renderer.render(this.scene, this.camera);
    ++this.framesDrawn;
    const now = performance.now();
    if (drawn) for (const l of this.drawnListeners) l(drawn.seq, now, t1 - t0, now - t1);
  }

  /** Screen position (CSS pixels in the canvas) and view depth of every vertex; clipped ones get NaN. */
  project() {
    const m = new THREE.Matrix4().multiplyMatrices(this.camera.projectionMatrix, this.camera.matrixWorldInverse).elements;
    const P = this.positions, count = P.length / 3;
    const out = new Float32Array(3 * count);
    const w = this.container.clientWidth, h = this.container.clientHeight;
    const plane = this.clipPlane, cut = this.cut;
    for (let i = 0; i < count; ++i) {
      const x = P[3 * i], y = P[3 * i + 1], z = P[3 * i + 2];
      const cw = m[3] * x + m[7] * y + m[11] * z + m[15];
      if (cut && plane.normal.x * x + plane.normal.y * y + plane.normal.z * z + plane.constant < 0) {
        out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = NaN;
        continue;
      }
      out[3 * i] = ((((m[0] * x + m[4] * y + m[8] * z + m[12]) / cw) + 1) / 2) * w;
      out[3 * i + 1] = ((1 - (m[1] * x + m[5] * y + m[9] * z + m[13]) / cw) / 2) * h;
      out[3 * i + 2] = cw; // distance along the view direction
    }
    return out;
  }

  /** A point in the plane through `point` facing the camera, under the mouse (CSS pixels). */
  pointInViewPlane(point, x, y) {
    const ndc = new THREE.Vector2((x / this.container.clientWidth) * 2 - 1, 1 - (y / this.container.clientHeight) * 2);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const normal = this.camera.getWorldDirection(new THREE.Vector3());
    const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, point);
    return ray.ray.intersectPlane(plane, new THREE.Vector3());
  }

  viewDirection() { return this.camera.getWorldDirection(new THREE.Vector3()); }
}
