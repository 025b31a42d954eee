// The model in the 3D view: one merged mesh (a colour per vertex, each element owning its vertices) drawn twice, the
// solid elements opaque and the ghost ones (x-ray, not yet built at a date, occluders) see-through, the grid under
// it, and the selected element outlined. The geometry comes from the geometry endpoint (parseGeometry).
import * as THREE from 'three';
import { HIGHLIGHT, dispose, srgbToLinear } from './draw3d.js';

const SOLID = 0;
const GHOST = 1;
const HIDDEN = 2;
export const MODES = { solid: SOLID, ghost: GHOST, hidden: HIDDEN };

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

export class ModelLayer {
  // viewer: the Viewer of viewer3d.js (its scene, its requestRender)
  constructor(viewer) {
    this.viewer = viewer;
    this.helpers = new THREE.Group();
    this.group = new THREE.Group();
    viewer.scene.add(this.helpers, this.group);
    this.model = null;
    this.highlight = null;
    this.selectedElement = null;
  }

  // the model of a parsed geometry drawn (the one before removed by clear())
  set(geo) {
    const { header } = geo;
    const z = header.elements;
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
    this.model.position = position;
    this.model.colour = colour;
    this.model.box = box;
    this.model.sphere = sphere;
    this.model.solidMesh = new THREE.Mesh(solid, new THREE.MeshLambertMaterial({
      vertexColors: true, side: THREE.DoubleSide, flatShading: true }));
    this.model.ghostMesh = new THREE.Mesh(ghost, new THREE.MeshLambertMaterial({
      vertexColors: true, side: THREE.DoubleSide, flatShading: true, transparent: true, opacity: 0.22,
      depthWrite: false }));
    this.model.ghostMesh.renderOrder = 2;
    this.group.add(this.model.solidMesh, this.model.ghostMesh);
    this._grid(box);
    return this.model;
  }

  clear() {
    this.highlightElement(null);
    if (!this.model) return;
    for (const m of [this.model.solidMesh, this.model.ghostMesh]) {
      m.geometry.dispose();
      m.material.dispose();
    }
    this.group.clear();
    dispose(this.helpers);
    this.helpers.clear();
    this.model = null;
    this.viewer.requestRender();
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
    this.viewer.requestRender();
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

  // the selected element: its triangles tinted and its edges drawn on top, in the selection colour of frames
  highlightElement(e) {
    const { scene } = this.viewer;
    if (this.highlight) {
      scene.remove(this.highlight);
      dispose(this.highlight);
      this.highlight = null;
    }
    this.selectedElement = e;
    const m = this.model;
    if (e === null || e === undefined || !m || e < 0 || e >= m.z || m.triStart[e + 1] === m.triStart[e]) {
      this.viewer.requestRender();
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
    scene.add(group);
    this.viewer.requestRender();
  }
}
