// The 3D view: the model as one merged mesh (a colour per vertex, each element owning its vertices), the plan as
// line segments (frustums, path), points (camera centres) and instanced spheres (safety violations), ground stations
// with their line-of-sight circle, the selected element outlined, the points a plan form picks, and reality captures
// (a point cloud streamed as 3D Tiles, a mesh as GLB). Rendering happens on demand (camera moves, data changes);
// only while a point cloud is shown does a loop run, which lets the cloud pick its tiles every animation frame.
//
// Coordinates are the viewer frame of the geometry endpoint: Y up, centred on the model's box;
// a model point (x, y, z) is drawn at (x − ox, z − oz, −(y − oy)).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { MeshBVH } from 'three-mesh-bvh/core/MeshBVH.js';
import { acceleratedRaycast } from 'three-mesh-bvh/utils/ExtensionUtilities.js';
import { compassAngle, flightGroup } from './flight3d.js';

const SOLID = 0;
const GHOST = 1;
const HIDDEN = 2;
export const MODES = { solid: SOLID, ghost: GHOST, hidden: HIDDEN };

const srgbToLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);

export function parseGeometry(buffer) {
  const magic = new TextDecoder().decode(new Uint8Array(buffer, 0, 4));
  if (magic !== 'SPG1') throw new Error('the model geometry is not in the expected format');
  const n = new DataView(buffer).getUint32(4, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 8, n)));
  const base = 8 + n;
  const arr = (name, Type) => {
    const a = header.arrays[name];
    return new Type(buffer, base + a.offset, a.bytes / Type.BYTES_PER_ELEMENT);
  };
  return {
    header,
    position: arr('position', Float32Array),
    index: arr('index', Uint32Array),
    vertexElement: arr('vertex_element', Uint32Array),
    triangleElement: arr('triangle_element', Uint32Array),
  };
}

// Contiguous [start[e], start[e + 1]) ranges of a sorted element column.
function ranges(sortedElements, z) {
  const start = new Int32Array(z + 1);
  for (let k = 0; k < sortedElements.length; k++) start[sortedElements[k] + 1]++;
  for (let e = 0; e < z; e++) start[e + 1] += start[e];
  return start;
}

// the name of the WebGL implementation (a GPU's, or a software rasteriser such as SwiftShader or llvmpipe)
function glRendererName() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2');
    if (!gl) return '';
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const lose = gl.getExtension('WEBGL_lose_context');
    if (lose) lose.loseContext();
    return name;
  } catch {
    return '';
  }
}

export class Viewer {
  constructor(box, { onClick } = {}) {
    this.box = box;
    this.onClick = onClick;
    this.glRenderer = glRendererName();
    // multisampling halves the frame rate of a software rasteriser: smooth edges only on a GPU
    this.software = /swiftshader|llvmpipe|softpipe|software/i.test(this.glRenderer);
    this.renderer = new THREE.WebGLRenderer({ antialias: !this.software });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(0xeef1f5);
    box.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.5);
    sun.position.set(0.6, 1.0, 0.8);
    this.scene.add(sun);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.1, 1000);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.requestRender());
    this.origin = [0, 0, 0];
    this.renders = 0;
    this.modelGroup = new THREE.Group();
    this.planGroup = new THREE.Group();
    this.helpers = new THREE.Group();
    this.markerGroup = new THREE.Group();  // points picked for a plan form
    this.realityGroup = new THREE.Group();  // reality meshes (point clouds add their own groups to the scene)
    this.scene.add(this.helpers, this.modelGroup, this.planGroup, this.markerGroup, this.realityGroup);
    this.realities = new Map();  // capture id → {id, kind, url, visible, object, cloud, triangles}
    this.highlight = null;
    this.markers = [];
    this._looping = false;
    this.raycaster = new THREE.Raycaster();
    this.baseFrameSize = 1.5;  // metres from a camera's centre to its drawn image plane
    this.frameScale = 1;
    this.frameSize = 1.5;
    this.plan = null;
    this.model = null;
    this.selectedFrame = null;
    this.selectedElement = null;
    this.compass = null;
    this.northOffset = null;
    this._pending = false;
    this._bindPointer();
    new ResizeObserver(() => this.resize()).observe(box);
    this.resize();
  }

  // ------------------------------------------------------------------ rendering
  requestRender() {
    this._dirty = true;
    if (this._pending || this._looping) return;  // the point cloud loop draws on its next frame
    this._pending = true;
    requestAnimationFrame(() => {
      this._pending = false;
      this.render();
    });
  }

  render() {
    for (const r of this._shownClouds()) r.cloud.update();
    this._draw();
  }

  _draw() {
    this._dirty = false;
    this.renderer.render(this.scene, this.camera);
    this.renders++;
    if (this.compass) this._updateCompass();
  }

  _shownClouds() {
    const out = [];
    for (const r of this.realities.values()) if (r.cloud && r.visible) out.push(r);
    return out;
  }

  // While a point cloud is shown: every animation frame it picks its tiles for the camera (and queues their
  // downloads); the view is drawn again when the camera moved or the drawn tiles changed.
  _loop() {
    if (this._looping) return;
    this._looping = true;
    const step = () => {
      const clouds = this._shownClouds();
      if (!clouds.length) {
        this._looping = false;
        if (this._dirty) this.requestRender();
        return;
      }
      let changed = this._dirty;
      for (const r of clouds) {
        r.cloud.update();
        const st = r.cloud.stats();
        const key = `${st.tilesLoaded}/${st.tilesVisible}/${st.pointsVisible}`;
        if (key !== r.key) {
          r.key = key;
          changed = true;
        }
      }
      if (changed) this._draw();
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }

  resize() {
    const w = Math.max(this.box.clientWidth, 1);
    const h = Math.max(this.box.clientHeight, 1);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  setCompass(el) { this.compass = el; }

  // degrees from a model heading to the true heading: the compass points to true north (null: model +Y)
  setNorthOffset(deg) { this.northOffset = deg; if (this.compass) this._updateCompass(); }

  _updateCompass() {
    this.compass.style.transform = `rotate(${compassAngle(this.camera, this.controls.target, this.radius,
      this.northOffset, this.box)}deg)`;
  }

  toViewer(p) {
    const o = this.origin;
    return [p[0] - o[0], p[2] - o[2], -(p[1] - o[1])];
  }

  fromViewer(v) {
    const o = this.origin;
    return [v[0] + o[0], -v[2] + o[1], v[1] + o[2]];
  }

  dirToViewer(d) { return [d[0], d[2], -d[1]]; }

  // ------------------------------------------------------------------ the model
  setModel(geo) {
    this.clearModel();
    const { header } = geo;
    const z = header.elements;
    const moved = header.origin_m.some((v, k) => v !== this.origin[k]);
    this.origin = header.origin_m;
    this.model = {
      geo,
      z,
      triStart: ranges(geo.triangleElement, z),
      vertStart: ranges(geo.vertexElement, z),
      modes: new Uint8Array(z).fill(255),
      colours: new Float32Array(z * 3),
    };
    const position = new THREE.BufferAttribute(geo.position, 3);
    const colour = new THREE.BufferAttribute(new Float32Array(geo.position.length), 3);
    const solid = new THREE.BufferGeometry();
    solid.setAttribute('position', position);
    solid.setAttribute('color', colour);
    const ghost = new THREE.BufferGeometry();
    ghost.setAttribute('position', position);
    ghost.setAttribute('color', colour);
    const box = new THREE.Box3(new THREE.Vector3(...header.bounds[0]), new THREE.Vector3(...header.bounds[1]));
    const sphere = box.getBoundingSphere(new THREE.Sphere());
    for (const g of [solid, ghost]) {
      g.boundingBox = box.clone();
      g.boundingSphere = sphere.clone();
    }
    this.model.colour = colour;
    this.model.box = box;
    this.model.solidMesh = new THREE.Mesh(solid, new THREE.MeshLambertMaterial({
      vertexColors: true, side: THREE.DoubleSide, flatShading: true }));
    this.model.ghostMesh = new THREE.Mesh(ghost, new THREE.MeshLambertMaterial({
      vertexColors: true, side: THREE.DoubleSide, flatShading: true, transparent: true, opacity: 0.22,
      depthWrite: false }));
    this.model.ghostMesh.renderOrder = 2;
    this.modelGroup.add(this.model.solidMesh, this.model.ghostMesh);
    // picking: a mesh of every triangle (its own index: the BVH reorders it), never drawn
    const pick = new THREE.BufferGeometry();
    pick.setAttribute('position', position);
    pick.setIndex(new THREE.BufferAttribute(new Uint32Array(geo.index), 1));
    this.model.pickMesh = new THREE.Mesh(pick, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
    this.model.pickMesh.raycast = acceleratedRaycast;
    this.radius = sphere.radius;
    this.baseFrameSize = Math.min(Math.max(sphere.radius * 0.05, 0.4), 6);
    this.frameSize = this.baseFrameSize * this.frameScale;
    this._grid(box);
    if (moved) this._replaceRealities();
    this.requestRender();
  }

  clearModel() {
    this.highlightElement(null);
    if (!this.model) return;
    for (const m of [this.model.solidMesh, this.model.ghostMesh, this.model.pickMesh]) {
      m.geometry.dispose();
      m.material.dispose();
    }
    this.modelGroup.clear();
    this._dispose(this.helpers);
    this.helpers.clear();
    this.model = null;
    this.requestRender();
  }

  _grid(box) {
    this.helpers.clear();
    const size = box.getSize(new THREE.Vector3());
    const extent = Math.max(size.x, size.z, 10) * 3;
    const cell = [1, 2, 5, 10, 20, 50, 100].find((c) => extent / c <= 60) || 200;
    const span = Math.ceil(extent / cell) * cell;
    const grid = new THREE.GridHelper(span, span / cell, 0xb8c0cc, 0xd5dae2);
    grid.position.set(0, box.min.y - 0.01, 0);
    this.helpers.add(grid);
  }

  ensureBVH() {
    const g = this.model && this.model.pickMesh.geometry;
    if (g && !g.boundsTree) g.boundsTree = new MeshBVH(g);
  }

  // colourOf(e) → sRGB [r, g, b]; modeOf(e) → 'solid' | 'ghost' | 'hidden'
  setAppearance(colourOf, modeOf) {
    const m = this.model;
    if (!m) return;
    const col = m.colour.array;
    let modesChanged = false;
    for (let e = 0; e < m.z; e++) {
      const v0 = m.vertStart[e];
      const v1 = m.vertStart[e + 1];
      const mode = MODES[modeOf(e)];
      if (mode !== m.modes[e]) {
        m.modes[e] = mode;
        modesChanged = true;
      }
      const rgb = colourOf(e);
      m.colours.set(rgb, 3 * e);
      if (v1 === v0) continue;
      const r = srgbToLinear(rgb[0]);
      const g = srgbToLinear(rgb[1]);
      const b = srgbToLinear(rgb[2]);
      for (let k = 3 * v0; k < 3 * v1; k += 3) {
        col[k] = r;
        col[k + 1] = g;
        col[k + 2] = b;
      }
    }
    m.colour.needsUpdate = true;
    if (modesChanged) this._rebuildIndices();
    this.requestRender();
  }

  _rebuildIndices() {
    const m = this.model;
    const full = m.geo.index;
    let nSolid = 0;
    let nGhost = 0;
    for (let e = 0; e < m.z; e++) {
      const n = m.triStart[e + 1] - m.triStart[e];
      if (m.modes[e] === SOLID) nSolid += n;
      else if (m.modes[e] === GHOST) nGhost += n;
    }
    const solid = new Uint32Array(3 * nSolid);
    const ghost = new Uint32Array(3 * nGhost);
    let s = 0;
    let g = 0;
    for (let e = 0; e < m.z; e++) {
      const a = 3 * m.triStart[e];
      const b = 3 * m.triStart[e + 1];
      if (a === b) continue;
      if (m.modes[e] === SOLID) {
        solid.set(full.subarray(a, b), s);
        s += b - a;
      } else if (m.modes[e] === GHOST) {
        ghost.set(full.subarray(a, b), g);
        g += b - a;
      }
    }
    m.solidMesh.geometry.setIndex(new THREE.BufferAttribute(solid, 1));
    m.ghostMesh.geometry.setIndex(new THREE.BufferAttribute(ghost, 1));
  }

  // the sRGB colour element e is drawn in, and how
  elementAppearance(e) {
    const m = this.model;
    const mode = Object.keys(MODES).find((k) => MODES[k] === m.modes[e]);
    return { rgb: Array.from(m.colours.subarray(3 * e, 3 * e + 3)), mode };
  }

  // ------------------------------------------------------------------ the plan
  // plan: {position: [[x, y, z]], rotation: [[9]], camera: [id], cameras: {id: {...}}, missions: [{start, stop,
  // ground_station}]}; frameColours: (n) sRGB; checks: the checks endpoint's answer or null
  setPlan(plan, frameColours, checks = null) {
    this.clearPlan();
    if (!plan) return;
    const n = plan.position.length;
    this.plan = { plan, n, checks };
    if (!this.model && n) {
      const mean = [0, 1, 2].map((k) => plan.position.reduce((s, p) => s + p[k], 0) / n);
      const moved = mean.some((v, k) => v !== this.origin[k]);
      this.origin = mean;
      if (moved) this._replaceRealities();
    }
    const centres = new Float32Array(3 * n);
    plan.position.forEach((p, i) => centres.set(this.toViewer(p), 3 * i));
    this.plan.centres = centres;
    // frustums: apex to 4 corners and the rectangle, 8 segments a frame
    const frustum = new Float32Array(n * 16 * 3);
    for (let i = 0; i < n; i++) frustum.set(this._frustum(plan, i), i * 48);
    const fg = new THREE.BufferGeometry();
    fg.setAttribute('position', new THREE.BufferAttribute(frustum, 3));
    fg.setAttribute('color', new THREE.BufferAttribute(new Float32Array(n * 48), 3));
    this.plan.frustums = new THREE.LineSegments(fg, new THREE.LineBasicMaterial({ vertexColors: true }));
    const pg = new THREE.BufferGeometry();
    pg.setAttribute('position', new THREE.BufferAttribute(centres, 3));
    pg.setAttribute('color', new THREE.BufferAttribute(new Float32Array(n * 3), 3));
    this.plan.points = new THREE.Points(pg, new THREE.PointsMaterial({ size: 5, sizeAttenuation: false,
      vertexColors: true }));
    // the path: consecutive frames of one mission
    const path = [];
    for (const ms of plan.missions) for (let i = ms.start; i < ms.stop - 1; i++) path.push(i, i + 1);
    const lg = new THREE.BufferGeometry();
    lg.setAttribute('position', new THREE.BufferAttribute(centres, 3));
    lg.setIndex(path);
    this.plan.path = new THREE.LineSegments(lg, new THREE.LineBasicMaterial({ color: 0x2b3a55, transparent: true,
      opacity: 0.45 }));
    this.planGroup.add(this.plan.path, this.plan.frustums, this.plan.points);
    this._stations(plan, checks);
    this._violations(checks);
    this.setFrameColours(frameColours);
    this.select(this.selectedFrame !== null && this.selectedFrame < n ? this.selectedFrame : null);
  }

  _frustum(plan, i) {
    const cam = plan.cameras[plan.camera[i]];
    const R = plan.rotation[i];
    const C = this.toViewer(plan.position[i]);
    const d = this.frameSize;
    let corners;
    if (cam && cam.model === 'pinhole') {
      corners = [[0, 0], [cam.width, 0], [cam.width, cam.height], [0, cam.height]]
        .map(([u, v]) => [(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1]);
    } else {
      corners = [[-1, -0.6, 1], [1, -0.6, 1], [1, 0.6, 1], [-1, 0.6, 1]];  // a 360° frame: a wide marker
    }
    const world = corners.map(([x, y, zc]) => this.dirToViewer([
      R[0] * x + R[1] * y + R[2] * zc, R[3] * x + R[4] * y + R[5] * zc, R[6] * x + R[7] * y + R[8] * zc]));
    const pts = world.map((w) => [C[0] + d * w[0], C[1] + d * w[1], C[2] + d * w[2]]);
    const out = [];
    for (const p of pts) out.push(...C, ...p);
    for (let k = 0; k < 4; k++) out.push(...pts[k], ...pts[(k + 1) % 4]);
    return out;
  }

  _stations(plan, checks) {
    this.plan.stations = flightGroup(plan, checks, this.frameSize, (p) => this.toViewer(p));
    this.planGroup.add(this.plan.stations);
  }

  _violations(checks) {
    if (!checks) return;
    const group = new THREE.Group();
    const frames = checks.unsafe_frames || [];
    if (frames.length) {
      const mesh = new THREE.InstancedMesh(new THREE.SphereGeometry(0.35 * this.frameSize, 12, 8),
        new THREE.MeshBasicMaterial({ color: 0xe0201b }), frames.length);
      const m = new THREE.Matrix4();
      frames.forEach((f, k) => {
        const c = this.plan.centres;
        mesh.setMatrixAt(k, m.makeTranslation(c[3 * f], c[3 * f + 1], c[3 * f + 2]));
      });
      group.add(mesh);
    }
    const segs = checks.unsafe_segments || [];
    if (segs.length) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(this.plan.centres, 3));
      g.setIndex(segs.flatMap((s) => [s, s + 1]));
      group.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xe0201b })));
    }
    this.plan.violations = group;
    this.planGroup.add(group);
  }

  setChecks(checks) {
    if (!this.plan) return;
    this.plan.checks = checks;
    for (const key of ['stations', 'violations']) {
      if (this.plan[key]) {
        this.planGroup.remove(this.plan[key]);
        this._dispose(this.plan[key]);
        this.plan[key] = null;
      }
    }
    this._stations(this.plan.plan, checks);
    this._violations(checks);
    this.requestRender();
  }

  setFrameColours(colours) {
    if (!this.plan) return;
    const n = this.plan.n;
    const fc = this.plan.frustums.geometry.getAttribute('color');
    const pc = this.plan.points.geometry.getAttribute('color');
    for (let i = 0; i < n; i++) {
      const lin = colours[i].map(srgbToLinear);
      for (let k = 0; k < 16; k++) fc.array.set(lin, i * 48 + 3 * k);
      pc.array.set(lin, 3 * i);
    }
    this.plan.frameColours = colours;
    fc.needsUpdate = true;
    pc.needsUpdate = true;
    this.requestRender();
  }

  setLayers({ model = true, frustums = true, path = true, stations = true } = {}) {
    this.modelGroup.visible = model;
    if (this.plan) {
      this.plan.frustums.visible = frustums;
      this.plan.points.visible = frustums || path;
      this.plan.path.visible = path;
      if (this.plan.stations) this.plan.stations.visible = stations;
    }
    this.requestRender();
  }

  _dispose(object) {
    object.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) o.material.dispose();
    });
  }

  clearPlan() {
    this._dispose(this.planGroup);
    this.planGroup.clear();
    this.plan = null;
    this.selection = null;
    this.requestRender();
  }

  // the selected frame: its frustum drawn on top in a strong colour, with a marker at its centre
  select(frame) {
    if (this.selection) {
      this.planGroup.remove(this.selection);
      this._dispose(this.selection);
      this.selection = null;
    }
    this.selectedFrame = frame;
    if (frame === null || !this.plan) {
      this.requestRender();
      return;
    }
    const group = new THREE.Group();
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(this._frustum(this.plan.plan, frame), 3));
    const lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xff00aa, depthTest: false }));
    lines.renderOrder = 10;
    const c = this.plan.centres.subarray(3 * frame, 3 * frame + 3);
    const dot = new THREE.Mesh(new THREE.SphereGeometry(0.22 * this.frameSize, 16, 12),
      new THREE.MeshBasicMaterial({ color: 0xff00aa, depthTest: false }));
    dot.position.set(c[0], c[1], c[2]);
    dot.renderOrder = 10;
    group.add(lines, dot);
    this.selection = group;
    this.planGroup.add(group);
    this.requestRender();
  }

  // ------------------------------------------------------------------ camera
  fit({ withPlan = true } = {}) {
    const box = new THREE.Box3();
    if (this.model) box.union(this.model.box);
    if (withPlan && this.plan && this.plan.n) {
      const pts = new THREE.Box3().setFromArray(this.plan.centres);
      box.union(pts);
    }
    if (box.isEmpty()) return;
    const sphere = box.getBoundingSphere(new THREE.Sphere());
    const r = Math.max(sphere.radius, 0.5);
    const dir = new THREE.Vector3(0.8, 0.75, 1.0).normalize();
    const dist = r / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2)) * 1.05;
    this.camera.position.copy(sphere.center).addScaledVector(dir, dist);
    this.camera.near = Math.max(r / 500, 0.02);
    this.camera.far = r * 60 + 2000;
    this.camera.fov = 45;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(sphere.center);
    this.controls.update();
    this.requestRender();
  }

  // put the 3D camera where frame i is, looking where it looks
  lookThrough(i) {
    if (!this.plan) return;
    const plan = this.plan.plan;
    const R = plan.rotation[i];
    const fwd = this.dirToViewer([R[2], R[5], R[8]]);
    const down = this.dirToViewer([R[1], R[4], R[7]]);
    const c = this.plan.centres.subarray(3 * i, 3 * i + 3);
    const cam = plan.cameras[plan.camera[i]];
    this.camera.position.set(c[0], c[1], c[2]);
    this.camera.up.set(-down[0], -down[1], -down[2]);
    if (cam && cam.vfov_deg) this.camera.fov = cam.vfov_deg;
    this.camera.updateProjectionMatrix();
    const reach = Math.max(this.radius || 10, 1);
    this.controls.target.set(c[0] + fwd[0] * reach, c[1] + fwd[1] * reach, c[2] + fwd[2] * reach);
    this.controls.update();
    this.camera.up.set(0, 1, 0);
    this.requestRender();
  }

  // ------------------------------------------------------------------ picking
  _bindPointer() {
    let down = null;
    const el = this.renderer.domElement;
    el.addEventListener('pointerdown', (ev) => { down = [ev.clientX, ev.clientY]; });
    el.addEventListener('pointerup', (ev) => {
      if (!down || Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 4) return;
      down = null;
      if (this.onClick) this.onClick(this.pickAt(ev.clientX, ev.clientY), ev);
    });
  }

  ndc(clientX, clientY) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    return new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
  }

  // {frame} when a camera centre is within 9 px, else {element} under the pointer, else {}
  pickAt(clientX, clientY) {
    const frame = this.pickFrame(clientX, clientY);
    if (frame !== null) return { frame };
    const element = this.pickElement(this.ndc(clientX, clientY));
    return element === null ? {} : { element };
  }

  pickFrame(clientX, clientY, within = 9) {
    if (!this.plan || !this.plan.frustums.visible) return null;
    const rect = this.renderer.domElement.getBoundingClientRect();
    const v = new THREE.Vector3();
    let best = null;
    let bestD = within * within;
    const c = this.plan.centres;
    for (let i = 0; i < this.plan.n; i++) {
      v.set(c[3 * i], c[3 * i + 1], c[3 * i + 2]).project(this.camera);
      if (v.z > 1 || v.z < -1) continue;
      const dx = rect.left + ((v.x + 1) / 2) * rect.width - clientX;
      const dy = rect.top + ((1 - v.y) / 2) * rect.height - clientY;
      const d = dx * dx + dy * dy;
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    }
    return best;
  }

  pickElement(ndc) {
    if (!this.model || !this.modelGroup.visible) return null;
    this.ensureBVH();
    this.raycaster.setFromCamera(ndc, this.camera);
    const hits = this.raycaster.intersectObject(this.model.pickMesh, false);
    const m = this.model;
    const ve = m.geo.vertexElement;
    const solid = hits.find((h) => m.modes[ve[h.face.a]] === SOLID);
    const ghost = hits.find((h) => m.modes[ve[h.face.a]] === GHOST);
    const hit = solid || ghost;
    return hit ? ve[hit.face.a] : null;
  }

  // screen point (client pixels) of frame i's centre
  frameScreenPoint(i) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const c = this.plan.centres;
    const v = new THREE.Vector3(c[3 * i], c[3 * i + 1], c[3 * i + 2]).project(this.camera);
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height,
      inView: Math.abs(v.x) < 1 && Math.abs(v.y) < 1 && v.z < 1 };
  }

  // a screen point (client pixels) where element e is the first thing picked, or null
  elementScreenPoint(e) {
    const m = this.model;
    if (!m) return null;
    const rect = this.renderer.domElement.getBoundingClientRect();
    const idx = m.geo.index;
    const pos = m.geo.position;
    const v = new THREE.Vector3();
    for (let t = m.triStart[e]; t < m.triStart[e + 1]; t++) {
      v.set(0, 0, 0);
      for (let k = 0; k < 3; k++) {
        const a = idx[3 * t + k];
        v.x += pos[3 * a] / 3;
        v.y += pos[3 * a + 1] / 3;
        v.z += pos[3 * a + 2] / 3;
      }
      v.project(this.camera);
      if (Math.abs(v.x) > 0.95 || Math.abs(v.y) > 0.95 || v.z > 1) continue;
      const x = rect.left + ((v.x + 1) / 2) * rect.width;
      const y = rect.top + ((1 - v.y) / 2) * rect.height;
      if (this.pickFrame(x, y, 12) !== null) continue;
      if (this.pickElement(this.ndc(x, y)) === e) return { x, y };
    }
    return null;
  }

  // screen point (client pixels) of a model point [x, y, z]
  screenPoint(p) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const v = new THREE.Vector3(...this.toViewer(p)).project(this.camera);
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height,
      inView: Math.abs(v.x) < 1 && Math.abs(v.y) < 1 && v.z < 1 };
  }

  // the model point [x, y, z] under the pointer: the first surface of the model drawn there, else the ground (the
  // level of the model's lowest point, where the grid lies); null when the ray misses both
  pickPoint(clientX, clientY) {
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    const ray = this.raycaster.ray;
    const groundY = this.model ? this.model.box.min.y : 0;
    const at = ray.intersectPlane(new THREE.Plane(new THREE.Vector3(0, 1, 0), -groundY), new THREE.Vector3());
    const groundDistance = at ? at.distanceTo(ray.origin) : Infinity;
    if (this.model && this.modelGroup.visible) {
      this.ensureBVH();
      const m = this.model;
      const ve = m.geo.vertexElement;
      const hit = this.raycaster.intersectObject(m.pickMesh, false).find((h) => m.modes[ve[h.face.a]] !== HIDDEN);
      if (hit && hit.distance <= groundDistance) {
        return { point: this.fromViewer(hit.point.toArray()), on: 'model', element: ve[hit.face.a] };
      }
    }
    return at ? { point: this.fromViewer(at.toArray()), on: 'ground' } : null;
  }

  // the model's lowest level (m, model z), where picked plan points without a height are drawn
  groundZ() {
    return this.model ? this.model.box.min.y + this.origin[2] : 0;
  }

  // ------------------------------------------------------------------ picked points of a plan form
  // sets: [{points: [[x, y, z]], colour: 0xrrggbb, line: whether consecutive points are joined}]; drawn over
  // everything, a fixed size on screen
  setMarkers(sets) {
    this._dispose(this.markerGroup);
    this.markerGroup.clear();
    this.markers = sets.map((set) => ({ points: set.points.map((q) => [...q]), colour: set.colour, line: !!set.line }));
    for (const set of this.markers) {
      if (!set.points.length) continue;
      const flat = new Float32Array(set.points.flatMap((q) => this.toViewer(q)));
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(flat, 3));
      const dots = new THREE.Points(g, new THREE.PointsMaterial({ color: set.colour, size: 11, sizeAttenuation: false,
        depthTest: false, map: dotTexture(), alphaTest: 0.5, transparent: true }));
      dots.renderOrder = 12;
      this.markerGroup.add(dots);
      if (set.line && set.points.length > 1) {
        const lg = new THREE.BufferGeometry();
        lg.setAttribute('position', new THREE.BufferAttribute(flat.slice(), 3));
        const line = new THREE.Line(lg, new THREE.LineBasicMaterial({ color: set.colour, depthTest: false }));
        line.renderOrder = 11;
        this.markerGroup.add(line);
      }
    }
    this.requestRender();
  }

  // ------------------------------------------------------------------ the selected element
  // its triangles tinted and its edges drawn on top, in the selection colour of frames
  highlightElement(e) {
    if (this.highlight) {
      this.scene.remove(this.highlight);
      this._dispose(this.highlight);
      this.highlight = null;
    }
    this.selectedElement = e;
    const m = this.model;
    if (e === null || e === undefined || !m || e < 0 || e >= m.z || m.triStart[e + 1] === m.triStart[e]) {
      this.requestRender();
      return;
    }
    const idx = m.geo.index.subarray(3 * m.triStart[e], 3 * m.triStart[e + 1]);
    const pos = m.geo.position;
    const flat = new Float32Array(idx.length * 3);
    for (let k = 0; k < idx.length; k++) flat.set(pos.subarray(3 * idx[k], 3 * idx[k] + 3), 3 * k);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(flat, 3));
    const tint = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color: HIGHLIGHT, transparent: true, opacity: 0.6,
      side: THREE.DoubleSide, depthWrite: false, polygonOffset: true, polygonOffsetFactor: -2, polygonOffsetUnits: -2 }));
    tint.renderOrder = 5;
    const edges = new THREE.LineSegments(new THREE.EdgesGeometry(g, 25), new THREE.LineBasicMaterial({
      color: HIGHLIGHT, depthTest: false, transparent: true, opacity: 0.9 }));
    edges.renderOrder = 10;
    const group = new THREE.Group();
    group.add(tint, edges);
    group.userData.element = e;
    this.highlight = group;
    this.scene.add(group);
    this.requestRender();
  }

  // ------------------------------------------------------------------ reality captures
  // capture: {id, kind: 'points' | 'mesh', view_url, name}; resolves once it is shown (a cloud: its root tileset)
  async addReality(capture, visible = true) {
    const have = this.realities.get(capture.id);
    if (have) {
      this.setRealityVisible(capture.id, visible);
      return have;
    }
    const entry = { id: capture.id, kind: capture.kind, url: capture.view_url, name: capture.name, visible,
      object: null, cloud: null, triangles: 0 };
    this.realities.set(capture.id, entry);
    await this._showReality(entry);
    return entry;
  }

  async _showReality(entry) {
    if (entry.kind === 'points') {
      const { addPointCloud } = await import('./pointcloud.js');
      if (this.realities.get(entry.id) !== entry) return;
      // the same frame as the model: Y up, the model's origin subtracted
      entry.cloud = addPointCloud(this.scene, this.camera, this.renderer, entry.url,
        { upAxis: 'y', origin: [...this.origin], pointSize: 2 });
      entry.origin = [...this.origin];
      entry.object = entry.cloud.group;
      entry.object.visible = entry.visible;
      entry.cloud.tiles.addEventListener('needs-update', () => this.requestRender());
      this._loop();
      await entry.cloud.ready;
    } else {
      const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
      const gltf = await new GLTFLoader().loadAsync(entry.url);
      if (this.realities.get(entry.id) !== entry) {
        this._dispose(gltf.scene);
        return;
      }
      const group = new THREE.Group();
      group.name = `reality ${entry.id}`;
      group.add(gltf.scene);
      let triangles = 0;
      gltf.scene.traverse((o) => {
        if (!o.isMesh) return;
        o.material.dispose();
        o.material = new THREE.MeshLambertMaterial({ color: REALITY_MESH, side: THREE.DoubleSide, flatShading: true });
        const g = o.geometry;
        triangles += (g.index ? g.index.count : g.getAttribute('position').count) / 3;
      });
      entry.triangles = triangles;
      entry.object = group;
      this._placeMesh(entry);
      group.visible = entry.visible;
      this.realityGroup.add(group);
      this.requestRender();
    }
  }

  // glTF's Y up stores model (x, y, z) as (x, z, −y): the viewer frame is that, less the origin
  _placeMesh(entry) {
    const [ox, oy, oz] = this.origin;
    entry.object.position.set(-ox, -oz, oy);
    entry.object.updateMatrixWorld(true);
  }

  // the model's origin moved: meshes move with it, clouds are streamed again in the new frame
  _replaceRealities() {
    for (const entry of this.realities.values()) {
      if (entry.kind === 'mesh' && entry.object) this._placeMesh(entry);
      else if (entry.cloud && entry.origin.some((v, k) => v !== this.origin[k])) {
        entry.cloud.dispose();
        entry.cloud = null;
        entry.object = null;
        this._showReality(entry).catch((err) => console.error('reality capture', entry.id, err));
      }
    }
    this.requestRender();
  }

  setRealityVisible(id, visible) {
    const entry = this.realities.get(id);
    if (!entry) return;
    entry.visible = visible;
    if (entry.object) entry.object.visible = visible;
    if (entry.cloud && visible) this._loop();
    this.requestRender();
  }

  removeReality(id) {
    const entry = this.realities.get(id);
    if (!entry) return;
    this.realities.delete(id);
    if (entry.cloud) entry.cloud.dispose();
    else if (entry.object) {
      this.realityGroup.remove(entry.object);
      this._dispose(entry.object);
    }
    this.requestRender();
  }

  clearRealities() {
    for (const id of [...this.realities.keys()]) this.removeReality(id);
  }

  // what each capture shows: a cloud's streaming statistics, a mesh's triangles, and the box it occupies in the
  // viewer frame
  realityInfo() {
    return [...this.realities.values()].map((r) => {
      const out = { id: r.id, kind: r.kind, visible: r.visible, shown: Boolean(r.object), triangles: r.triangles };
      if (r.cloud) Object.assign(out, r.cloud.stats());
      if (r.object) {
        r.object.updateMatrixWorld(true);
        const box = new THREE.Box3().setFromObject(r.object);
        if (!box.isEmpty()) out.box = [box.min.toArray(), box.max.toArray()];
      }
      return out;
    });
  }
}

const HIGHLIGHT = 0xff00aa;
const REALITY_MESH = 0xc9a25e;
let dotSprite = null;

// a round dot for point markers
function dotTexture() {
  if (dotSprite) return dotSprite;
  const c = document.createElement('canvas');
  c.width = c.height = 32;
  const ctx = c.getContext('2d');
  ctx.beginPath();
  ctx.arc(16, 16, 13, 0, Math.PI * 2);
  ctx.fillStyle = '#fff';
  ctx.fill();
  dotSprite = new THREE.CanvasTexture(c);
  return dotSprite;
}
