// The 3D view: the renderer, the scene, the camera with its orbit controls, the compass, and the layers drawn in it:
// the model (model3d.js), the plan's frames, path and stations (frames3d.js), picking and the points a plan form
// picks (pick3d.js), and reality captures (reality3d.js). The page calls the Viewer; it hands each call to its layer.
// Rendering happens on demand (camera moves, data changes); only while a point cloud is shown does a loop run,
// which lets the cloud pick its tiles every animation frame.
//
// Coordinates are the viewer frame of the geometry endpoint: Y up, centred on the model's box;
// a model point (x, y, z) is drawn at (x − ox, z − oz, −(y − oy)).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { compassAngle } from './flight3d.js';
import { FramesLayer } from './frames3d.js';
import { ModelLayer } from './model3d.js';
import { PickLayer } from './pick3d.js';
import { RealityLayer } from './reality3d.js';

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
    this.baseFrameSize = 1.5;  // metres from a camera's centre to its drawn image plane
    this.frameScale = 1;
    this.frameSize = 1.5;
    this.compass = null;
    this.northOffset = null;
    this._looping = false;
    this._pending = false;
    this.modelLayer = new ModelLayer(this);
    this.framesLayer = new FramesLayer(this);
    this.pickLayer = new PickLayer(this, onClick);
    this.realityLayer = new RealityLayer(this);
    new ResizeObserver(() => this.resize()).observe(box);
    this.resize();
  }

  // what the layers draw, as the page and the test hook read it
  get model() { return this.modelLayer.model; }
  get plan() { return this.framesLayer.plan; }
  get highlight() { return this.modelLayer.highlight; }
  get markers() { return this.pickLayer.markers; }
  get realities() { return this.realityLayer.realities; }

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
    for (const r of this.realityLayer.shownClouds()) r.cloud.update();
    this._draw();
  }

  _draw() {
    this._dirty = false;
    this.renderer.render(this.scene, this.camera);
    this.renders++;
    if (this.compass) this._updateCompass();
  }

  // While a point cloud is shown: every animation frame it picks its tiles for the camera (and queues their
  // downloads); the view is drawn again when the camera moved or the drawn tiles changed.
  loop() {
    if (this._looping) return;
    this._looping = true;
    const step = () => {
      const clouds = this.realityLayer.shownClouds();
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

  // ------------------------------------------------------------------ coordinates
  toViewer(p) {
    const o = this.origin;
    return [p[0] - o[0], p[2] - o[2], -(p[1] - o[1])];
  }

  fromViewer(v) {
    const o = this.origin;
    return [v[0] + o[0], -v[2] + o[1], v[1] + o[2]];
  }

  dirToViewer(d) { return [d[0], d[2], -d[1]]; }

  // the model point drawn at the viewer's (0, 0, 0); reality captures follow it
  setOrigin(origin) {
    const moved = origin.some((v, k) => v !== this.origin[k]);
    this.origin = origin;
    if (moved) this.realityLayer.originMoved();
  }

  // ------------------------------------------------------------------ the model (model3d.js)
  setModel(geo) {
    this.clearModel();
    const model = this.modelLayer.set(geo);
    this.pickLayer.setModel(model);
    this.radius = model.sphere.radius;
    this.baseFrameSize = Math.min(Math.max(model.sphere.radius * 0.05, 0.4), 6);
    this.frameSize = this.baseFrameSize * this.frameScale;
    this.setOrigin(geo.header.origin_m);
    this.requestRender();
  }

  clearModel() {
    this.modelLayer.clear();
    this.pickLayer.clearModel();
  }

  setAppearance(colourOf, modeOf) { this.modelLayer.setAppearance(colourOf, modeOf); }

  elementAppearance(e) { return this.modelLayer.elementAppearance(e); }

  highlightElement(e) { this.modelLayer.highlightElement(e); }

  // the model's lowest level (m, model z), where picked plan points without a height are drawn
  groundZ() {
    return this.model ? this.model.box.min.y + this.origin[2] : 0;
  }

  // ------------------------------------------------------------------ the plan (frames3d.js)
  setPlan(plan, frameColours, checks = null) { this.framesLayer.set(plan, frameColours, checks); }

  setChecks(checks) { this.framesLayer.setChecks(checks); }

  setFrameColours(colours) { this.framesLayer.setFrameColours(colours); }

  clearPlan() { this.framesLayer.clear(); }

  select(frame) { this.framesLayer.select(frame); }

  setLayers({ model = true, frustums = true, path = true, stations = true } = {}) {
    this.modelLayer.group.visible = model;
    this.framesLayer.setLayers({ frustums, path, stations });
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

  // ------------------------------------------------------------------ picking (pick3d.js)
  pickAt(clientX, clientY) { return this.pickLayer.pickAt(clientX, clientY); }

  pickFrame(clientX, clientY, within = 9) { return this.pickLayer.pickFrame(clientX, clientY, within); }

  pickElement(ndc) { return this.pickLayer.pickElement(ndc); }

  pickPoint(clientX, clientY) { return this.pickLayer.pickPoint(clientX, clientY); }

  frameScreenPoint(i) { return this.pickLayer.frameScreenPoint(i); }

  elementScreenPoint(e) { return this.pickLayer.elementScreenPoint(e); }

  screenPoint(p) { return this.pickLayer.screenPoint(p); }

  setMarkers(sets) { this.pickLayer.setMarkers(sets); }

  // ------------------------------------------------------------------ reality captures (reality3d.js)
  addReality(capture, visible = true) { return this.realityLayer.add(capture, visible); }

  setRealityVisible(id, visible) { this.realityLayer.setVisible(id, visible); }

  removeReality(id) { this.realityLayer.remove(id); }

  clearRealities() { this.realityLayer.clear(); }

  realityInfo() { return this.realityLayer.info(); }
}
