// Picking in the 3D view: what a click hits (a frame's camera centre within a few pixels, else the element under the
// pointer, found by raycasting a bounding volume hierarchy of the model's triangles, built on the first pick), where
// frames, elements and model points are on screen, the model point under the pointer for a plan form, and the points
// a plan form picked, drawn over everything.
import * as THREE from 'three';
import { MeshBVH } from 'three-mesh-bvh/core/MeshBVH.js';
import { acceleratedRaycast } from 'three-mesh-bvh/utils/ExtensionUtilities.js';
import { dispose } from './draw3d.js';
import { MODES } from './model3d.js';

export class PickLayer {
  // viewer: the Viewer of viewer3d.js (its canvas, camera, model, plan and coordinates); onClick(hit, event) after a
  // click (a press and release within 4 px) with what pickAt found there
  constructor(viewer, onClick) {
    this.viewer = viewer;
    this.onClick = onClick;
    this.raycaster = new THREE.Raycaster();
    this.pickMesh = null;
    this.markerGroup = new THREE.Group();
    viewer.scene.add(this.markerGroup);
    this.markers = [];
    let down = null;
    const el = viewer.renderer.domElement;
    el.addEventListener('pointerdown', (ev) => { down = [ev.clientX, ev.clientY]; });
    el.addEventListener('pointerup', (ev) => {
      if (!down || Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 4) return;
      down = null;
      if (this.onClick) this.onClick(this.pickAt(ev.clientX, ev.clientY), ev);
    });
  }

  // the model drawn (model3d.js's record): a mesh of every triangle to pick (its own index: the BVH reorders it),
  // never drawn
  setModel(model) {
    this.clearModel();
    const pick = new THREE.BufferGeometry();
    pick.setAttribute('position', model.position);
    pick.setIndex(new THREE.BufferAttribute(new Uint32Array(model.geo.index), 1));
    this.pickMesh = new THREE.Mesh(pick, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
    this.pickMesh.raycast = acceleratedRaycast;
  }

  clearModel() {
    if (!this.pickMesh) return;
    this.pickMesh.geometry.dispose();
    this.pickMesh.material.dispose();
    this.pickMesh = null;
  }

  ensureBVH() {
    const g = this.viewer.model && this.pickMesh && this.pickMesh.geometry;
    if (g && !g.boundsTree) g.boundsTree = new MeshBVH(g);
  }

  ndc(clientX, clientY) {
    const rect = this.viewer.renderer.domElement.getBoundingClientRect();
    return new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
  }

  // a point in the camera's normalised device coordinates → client pixels, and whether it is in view
  _toScreen(v) {
    const rect = this.viewer.renderer.domElement.getBoundingClientRect();
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height,
      inView: Math.abs(v.x) < 1 && Math.abs(v.y) < 1 && v.z < 1 };
  }

  // {frame} when a camera centre is within 9 px, else {element} under the pointer, else {}
  pickAt(clientX, clientY) {
    const frame = this.pickFrame(clientX, clientY);
    if (frame !== null) return { frame };
    const element = this.pickElement(this.ndc(clientX, clientY));
    return element === null ? {} : { element };
  }

  pickFrame(clientX, clientY, within = 9) {
    const { plan, camera, renderer } = this.viewer;
    if (!plan || !plan.frustums.visible) return null;
    const rect = renderer.domElement.getBoundingClientRect();
    const v = new THREE.Vector3();
    let best = null;
    let bestD = within * within;
    const c = plan.centres;
    for (let i = 0; i < plan.n; i++) {
      v.set(c[3 * i], c[3 * i + 1], c[3 * i + 2]).project(camera);
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

  // the model's triangles along the ray of the raycaster, nearest first
  _hits() {
    this.ensureBVH();
    return this.raycaster.intersectObject(this.pickMesh, false);
  }

  pickElement(ndc) {
    const m = this.viewer.model;
    if (!m || !this.viewer.modelLayer.group.visible) return null;
    this.raycaster.setFromCamera(ndc, this.viewer.camera);
    const hits = this._hits();
    const ve = m.geo.vertexElement;
    const solid = hits.find((h) => m.modes[ve[h.face.a]] === MODES.solid);
    const ghost = hits.find((h) => m.modes[ve[h.face.a]] === MODES.ghost);
    const hit = solid || ghost;
    return hit ? ve[hit.face.a] : null;
  }

  // screen point (client pixels) of frame i's centre
  frameScreenPoint(i) {
    const c = this.viewer.plan.centres;
    return this._toScreen(new THREE.Vector3(c[3 * i], c[3 * i + 1], c[3 * i + 2]).project(this.viewer.camera));
  }

  // a screen point (client pixels) where element e is the first thing picked, or null
  elementScreenPoint(e) {
    const m = this.viewer.model;
    if (!m) return null;
    const rect = this.viewer.renderer.domElement.getBoundingClientRect();
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
      v.project(this.viewer.camera);
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
    return this._toScreen(new THREE.Vector3(...this.viewer.toViewer(p)).project(this.viewer.camera));
  }

  // the model point [x, y, z] under the pointer: the first surface of the model drawn there, else the ground (the
  // level of the model's lowest point, where the grid lies); null when the ray misses both
  pickPoint(clientX, clientY) {
    const v = this.viewer;
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), v.camera);
    const ray = this.raycaster.ray;
    const groundY = v.model ? v.model.box.min.y : 0;
    const at = ray.intersectPlane(new THREE.Plane(new THREE.Vector3(0, 1, 0), -groundY), new THREE.Vector3());
    const groundDistance = at ? at.distanceTo(ray.origin) : Infinity;
    if (v.model && v.modelLayer.group.visible) {
      const m = v.model;
      const ve = m.geo.vertexElement;
      const hit = this._hits().find((h) => m.modes[ve[h.face.a]] !== MODES.hidden);
      if (hit && hit.distance <= groundDistance) {
        return { point: v.fromViewer(hit.point.toArray()), on: 'model', element: ve[hit.face.a] };
      }
    }
    return at ? { point: v.fromViewer(at.toArray()), on: 'ground' } : null;
  }

  // sets: [{points: [[x, y, z]], colour: 0xrrggbb, line: whether consecutive points are joined}]; drawn over
  // everything, a fixed size on screen
  setMarkers(sets) {
    dispose(this.markerGroup);
    this.markerGroup.clear();
    this.markers = sets.map((set) => ({ points: set.points.map((q) => [...q]), colour: set.colour, line: !!set.line }));
    for (const set of this.markers) {
      if (!set.points.length) continue;
      const flat = new Float32Array(set.points.flatMap((q) => this.viewer.toViewer(q)));
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
    this.viewer.requestRender();
  }
}

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
