// The HTML report's 3D view: the model's GLB (inlined as base64), coloured per element by a
// chosen metric, with the plan's camera positions. three.js comes from the modules inlined
// in the same page (see html.py); nothing is fetched.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { Colourer } from 'sightplan/colours';

const data = JSON.parse(document.getElementById('sightplan-data').textContent);
const root = document.getElementById('viewer');
const canvasBox = document.getElementById('viewer-canvas');
const select = document.getElementById('metric');
const loInput = document.getElementById('bound-lo');
const hiInput = document.getElementById('bound-hi');
const legend = document.getElementById('legend');
const info = document.getElementById('element-info');
const xrayInput = document.getElementById('xray');

const colourer = new Colourer(data);  // the traffic light of the glTF's colours, as the web page colours
const { stops: STOPS, classes: CLASSES, unseen: UNSEEN, occluder: OCCLUDER } = colourer;
const colourOf = (metric, i, lo, hi) => colourer.colourOf(metric, i, lo, hi);

function fmt(v, digits) {
  if (v === null || v === undefined) return '—';
  return Number(v).toPrecision(digits);
}

function showError(message) {
  canvasBox.textContent = message;
  canvasBox.classList.add('viewer-error');
  root.dataset.state = 'error';
}

function decodeBase64(text) {
  const raw = atob(text.trim());
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  return bytes.buffer;
}

let renderer;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
} catch (err) {
  showError('The 3D view needs WebGL, which this browser does not offer: ' + err.message);
  throw err;
}
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setClearColor(0xffffff);
canvasBox.appendChild(renderer.domElement);

const scene = new THREE.Scene();
scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(0.6, 1.0, 0.8);
scene.add(sun);

const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 1000);
const controls = new OrbitControls(camera, renderer.domElement);
const meshes = [];  // [mesh, element index]

function render() {
  renderer.render(scene, camera);
}

function resize() {
  const w = canvasBox.clientWidth;
  const h = canvasBox.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  render();
}

function recolour() {
  const metric = select.value;
  const lo = parseFloat(loInput.value);
  const hi = parseFloat(hiInput.value);
  const xray = xrayInput.checked;
  for (const [mesh, i] of meshes) {
    const m = mesh.material;
    m.color.setRGB(...colourOf(metric, i, lo, hi), THREE.SRGBColorSpace);
    if (!data.elements.target[i]) continue;
    // x-ray: elements the plan sees turn faint so that the unseen ones inside show
    const faint = xray && data.metrics.visibility[i] === 0;
    m.transparent = faint;
    m.opacity = faint ? 0.12 : 1;
    m.depthWrite = !faint;
    m.needsUpdate = true;
  }
  drawLegend(metric, lo, hi);
  render();
}

function swatch(rgb, label) {
  const item = document.createElement('span');
  item.className = 'swatch';
  const box = document.createElement('i');
  box.style.background = `rgb(${rgb.map((c) => Math.round(c * 255)).join(',')})`;
  item.append(box, label);
  return item;
}

function drawLegend(metric, lo, hi) {
  legend.replaceChildren();
  if (metric === 'visibility') {
    data.labels.visibility.classes.forEach((label, k) => legend.append(swatch(CLASSES[k], label)));
    return;
  }
  const meta = data.labels[metric];
  const bar = document.createElement('span');
  bar.className = 'gradient';
  const stops = meta.higher_better ? [...STOPS].reverse() : STOPS;
  bar.style.background = `linear-gradient(to right, ${stops.map((s) => `rgb(${s.map((c) => Math.round(c * 255)).join(',')})`).join(', ')})`;
  legend.append(`${fmt(lo, 3)} ${meta.unit}`, bar, `${fmt(hi, 3)} ${meta.unit}`,
    swatch(UNSEEN, 'not seen by ≥ Ω px'), swatch(OCCLUDER, 'occluder'));
}

function setMetric(metric) {
  const b = data.labels[metric].bounds;
  const disabled = metric === 'visibility';
  loInput.disabled = hiInput.disabled = disabled;
  loInput.value = disabled ? '' : String(Number(b[0].toPrecision(4)));
  hiInput.value = disabled ? '' : String(Number(b[1].toPrecision(4)));
  recolour();
}

function describe(i) {
  const e = data.elements;
  const m = data.metrics;
  const rows = [
    ['GlobalId', e.global_id[i]], ['name', e.name[i]], ['class', e.ifc_class[i]], ['storey', e.storey[i] || '—'],
    ['visibility', e.target[i] ? data.labels.visibility.classes[m.visibility[i]] : 'occluder'],
    ['VR_i', e.target[i] ? String(m.vr[i] ?? 0) : '—'], ['R_i (m/px)', fmt(m.ssd[i], 4)], ['O_i (°)', fmt(m.orientation[i], 3)],
  ];
  info.replaceChildren();
  for (const [k, v] of rows) {
    const dt = document.createElement('dt');
    dt.textContent = k;
    const dd = document.createElement('dd');
    dd.textContent = v;
    info.append(dt, dd);
  }
}

function addCameras(group) {
  const positions = data.cameras.flat();
  if (!positions.length) return;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  group.add(new THREE.Points(geometry, new THREE.PointsMaterial({ color: 0x1f4e9e, size: 6, sizeAttenuation: false })));
  for (const [start, stop] of data.missions) {
    if (stop - start < 2) continue;
    const path = new THREE.BufferGeometry();
    path.setAttribute('position', new THREE.Float32BufferAttribute(positions.slice(3 * start, 3 * stop), 3));
    group.add(new THREE.Line(path, new THREE.LineBasicMaterial({ color: 0x1f4e9e, transparent: true, opacity: 0.35 })));
  }
}

// Frame the model (the cameras may lie outside; zoom out to see them all).
function frame(object) {
  const sphere = new THREE.Box3().setFromObject(object).getBoundingSphere(new THREE.Sphere());
  const r = Math.max(sphere.radius, 0.5);
  const dir = new THREE.Vector3(0.8, 0.75, 1.0).normalize();
  camera.position.copy(sphere.center).addScaledVector(dir, 2.6 * r);
  camera.near = r / 100;
  camera.far = r * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(sphere.center);
  controls.update();
}

const raycaster = new THREE.Raycaster();
let down = null;
renderer.domElement.addEventListener('pointerdown', (ev) => { down = [ev.clientX, ev.clientY]; });
renderer.domElement.addEventListener('pointerup', (ev) => {
  if (!down || Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 4) return;
  const rect = renderer.domElement.getBoundingClientRect();
  const ndc = new THREE.Vector2(((ev.clientX - rect.left) / rect.width) * 2 - 1, -((ev.clientY - rect.top) / rect.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  const hits = raycaster.intersectObjects(meshes.map(([m]) => m), false);
  const target = (h) => data.elements.target[h.object.userData.element];
  // through occluders and x-rayed elements
  const hit = hits.find((h) => target(h) && h.object.material.opacity === 1) || hits.find(target) || hits[0];
  if (hit) describe(hit.object.userData.element);
});

new GLTFLoader().parse(decodeBase64(document.getElementById('sightplan-glb').textContent), '', (gltf) => {
  const world = new THREE.Group();
  world.add(gltf.scene);
  gltf.scene.traverse((o) => {
    if (!o.isMesh) return;
    let i = o.userData.element;
    if (i === undefined && o.parent) i = o.parent.userData.element;
    if (i === undefined) return;
    o.userData.element = i;
    o.material = o.material.clone();  // elements of one colour share a material in the file
    meshes.push([o, i]);
  });
  scene.add(world);
  frame(gltf.scene);
  addCameras(world);
  controls.addEventListener('change', render);
  select.addEventListener('change', () => setMetric(select.value));
  loInput.addEventListener('change', recolour);
  xrayInput.addEventListener('change', recolour);
  hiInput.addEventListener('change', recolour);
  document.getElementById('bound-reset').addEventListener('click', () => setMetric(select.value));
  new ResizeObserver(resize).observe(canvasBox);
  select.value = data.colour_by;
  setMetric(data.colour_by);
  resize();
  root.dataset.state = 'ready';
  root.dataset.meshes = String(meshes.length);
}, (err) => showError('The model could not be read: ' + (err.message || err)));
