// The plan in the 3D view: each frame's frustum (line segments) and camera centre (a point), the path through the
// consecutive frames of each mission, the pilots' stations and the checked flight out and home (flight3d.js), the
// frames and segments too close to the model (red), and the selected frame drawn on top.
import * as THREE from 'three';
import { HIGHLIGHT, dispose, srgbToLinear } from './draw3d.js';
import { flightGroup } from './flight3d.js';

export class FramesLayer {
  // viewer: the Viewer of viewer3d.js (its scene, frame size, coordinates, origin and requestRender)
  constructor(viewer) {
    this.viewer = viewer;
    this.group = new THREE.Group();
    viewer.scene.add(this.group);
    this.plan = null;
    this.selection = null;
    this.selectedFrame = null;
  }

  // plan: {position: [[x, y, z]], rotation: [[9]], camera: [id], cameras: {id: {...}}, missions: [{start, stop,
  // ground_station}]}; frameColours: (n) sRGB; checks: the checks endpoint's answer or null
  set(plan, frameColours, checks = null) {
    this.clear();
    if (!plan) return;
    const v = this.viewer;
    const n = plan.position.length;
    this.plan = { plan, n, checks };
    if (!v.model && n) v.setOrigin([0, 1, 2].map((k) => plan.position.reduce((s, p) => s + p[k], 0) / n));
    const centres = new Float32Array(3 * n);
    plan.position.forEach((p, i) => centres.set(v.toViewer(p), 3 * i));
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
    this.group.add(this.plan.path, this.plan.frustums, this.plan.points);
    this._stations(plan, checks);
    this._violations(checks);
    this.setFrameColours(frameColours);
    this.select(this.selectedFrame !== null && this.selectedFrame < n ? this.selectedFrame : null);
  }

  _frustum(plan, i) {
    const v = this.viewer;
    const cam = plan.cameras[plan.camera[i]];
    const R = plan.rotation[i];
    const C = v.toViewer(plan.position[i]);
    const d = v.frameSize;
    let corners;
    if (cam && cam.model === 'pinhole') {
      corners = [[0, 0], [cam.width, 0], [cam.width, cam.height], [0, cam.height]]
        .map(([u, w]) => [(u - cam.cx) / cam.fx, (w - cam.cy) / cam.fy, 1]);
    } else {
      corners = [[-1, -0.6, 1], [1, -0.6, 1], [1, 0.6, 1], [-1, 0.6, 1]];  // a 360° frame: a wide marker
    }
    const world = corners.map(([x, y, zc]) => v.dirToViewer([
      R[0] * x + R[1] * y + R[2] * zc, R[3] * x + R[4] * y + R[5] * zc, R[6] * x + R[7] * y + R[8] * zc]));
    const pts = world.map((w) => [C[0] + d * w[0], C[1] + d * w[1], C[2] + d * w[2]]);
    const out = [];
    for (const p of pts) out.push(...C, ...p);
    for (let k = 0; k < 4; k++) out.push(...pts[k], ...pts[(k + 1) % 4]);
    return out;
  }

  _stations(plan, checks) {
    this.plan.stations = flightGroup(plan, checks, this.viewer.frameSize, (p) => this.viewer.toViewer(p));
    this.group.add(this.plan.stations);
  }

  _violations(checks) {
    if (!checks) return;
    const group = new THREE.Group();
    const frames = checks.unsafe_frames || [];
    if (frames.length) {
      const mesh = new THREE.InstancedMesh(new THREE.SphereGeometry(0.35 * this.viewer.frameSize, 12, 8),
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
    this.group.add(group);
  }

  setChecks(checks) {
    if (!this.plan) return;
    this.plan.checks = checks;
    for (const key of ['stations', 'violations']) {
      if (this.plan[key]) {
        this.group.remove(this.plan[key]);
        dispose(this.plan[key]);
        this.plan[key] = null;
      }
    }
    this._stations(this.plan.plan, checks);
    this._violations(checks);
    this.viewer.requestRender();
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
    this.viewer.requestRender();
  }

  setLayers({ frustums = true, path = true, stations = true } = {}) {
    if (!this.plan) return;
    this.plan.frustums.visible = frustums;
    this.plan.points.visible = frustums || path;
    this.plan.path.visible = path;
    if (this.plan.stations) this.plan.stations.visible = stations;
  }

  clear() {
    dispose(this.group);
    this.group.clear();
    this.plan = null;
    this.selection = null;
    this.viewer.requestRender();
  }

  // the selected frame: its frustum drawn on top in a strong colour, with a marker at its centre
  select(frame) {
    if (this.selection) {
      this.group.remove(this.selection);
      dispose(this.selection);
      this.selection = null;
    }
    this.selectedFrame = frame;
    if (frame === null || !this.plan) {
      this.viewer.requestRender();
      return;
    }
    const size = this.viewer.frameSize;
    const group = new THREE.Group();
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(this._frustum(this.plan.plan, frame), 3));
    const lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: HIGHLIGHT, depthTest: false }));
    lines.renderOrder = 10;
    const c = this.plan.centres.subarray(3 * frame, 3 * frame + 3);
    const dot = new THREE.Mesh(new THREE.SphereGeometry(0.22 * size, 16, 12),
      new THREE.MeshBasicMaterial({ color: HIGHLIGHT, depthTest: false }));
    dot.position.set(c[0], c[1], c[2]);
    dot.renderOrder = 10;
    group.add(lines, dot);
    this.selection = group;
    this.group.add(group);
    this.viewer.requestRender();
  }
}
