// Reality captures in the 3D view: a point cloud streamed as 3D Tiles (pointcloud.js; while one is shown the viewer's
// loop lets it pick its tiles every animation frame) or a mesh as GLB, both in the model's frame, moved or streamed
// again when the model's origin moves.
import * as THREE from 'three';
import { dispose } from './draw3d.js';

const REALITY_MESH = 0xc9a25e;

export class RealityLayer {
  // viewer: the Viewer of viewer3d.js (its scene, camera, renderer, origin, requestRender and loop)
  constructor(viewer) {
    this.viewer = viewer;
    this.group = new THREE.Group();  // reality meshes (point clouds add their own groups to the scene)
    viewer.scene.add(this.group);
    this.realities = new Map();  // capture id → {id, kind, url, visible, object, cloud, triangles}
  }

  // the captures whose point cloud is shown
  shownClouds() {
    const out = [];
    for (const r of this.realities.values()) if (r.cloud && r.visible) out.push(r);
    return out;
  }

  // capture: {id, kind: 'points' | 'mesh', view_url, name}; resolves once it is shown (a cloud: its root tileset)
  async add(capture, visible = true) {
    const have = this.realities.get(capture.id);
    if (have) {
      this.setVisible(capture.id, visible);
      return have;
    }
    const entry = { id: capture.id, kind: capture.kind, url: capture.view_url, name: capture.name, visible,
      object: null, cloud: null, triangles: 0 };
    this.realities.set(capture.id, entry);
    await this._show(entry);
    return entry;
  }

  async _show(entry) {
    const v = this.viewer;
    if (entry.kind === 'points') {
      const { addPointCloud } = await import('./pointcloud.js');
      if (this.realities.get(entry.id) !== entry) return;
      // the same frame as the model: Y up, the model's origin subtracted
      entry.cloud = addPointCloud(v.scene, v.camera, v.renderer, entry.url,
        { upAxis: 'y', origin: [...v.origin], pointSize: 2 });
      entry.origin = [...v.origin];
      entry.object = entry.cloud.group;
      entry.object.visible = entry.visible;
      entry.cloud.tiles.addEventListener('needs-update', () => v.requestRender());
      v.loop();
      await entry.cloud.ready;
    } else {
      const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
      const gltf = await new GLTFLoader().loadAsync(entry.url);
      if (this.realities.get(entry.id) !== entry) {
        dispose(gltf.scene);
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
      this.group.add(group);
      v.requestRender();
    }
  }

  // glTF's Y up stores model (x, y, z) as (x, z, −y): the viewer frame is that, less the origin
  _placeMesh(entry) {
    const [ox, oy, oz] = this.viewer.origin;
    entry.object.position.set(-ox, -oz, oy);
    entry.object.updateMatrixWorld(true);
  }

  // the model's origin moved: meshes move with it, clouds are streamed again in the new frame
  originMoved() {
    const { origin } = this.viewer;
    for (const entry of this.realities.values()) {
      if (entry.kind === 'mesh' && entry.object) this._placeMesh(entry);
      else if (entry.cloud && entry.origin.some((v, k) => v !== origin[k])) {
        entry.cloud.dispose();
        entry.cloud = null;
        entry.object = null;
        this._show(entry).catch((err) => console.error('reality capture', entry.id, err));
      }
    }
    this.viewer.requestRender();
  }

  setVisible(id, visible) {
    const entry = this.realities.get(id);
    if (!entry) return;
    entry.visible = visible;
    if (entry.object) entry.object.visible = visible;
    if (entry.cloud && visible) this.viewer.loop();
    this.viewer.requestRender();
  }

  remove(id) {
    const entry = this.realities.get(id);
    if (!entry) return;
    this.realities.delete(id);
    if (entry.cloud) entry.cloud.dispose();
    else if (entry.object) {
      this.group.remove(entry.object);
      dispose(entry.object);
    }
    this.viewer.requestRender();
  }

  clear() {
    for (const id of [...this.realities.keys()]) this.remove(id);
  }

  // what each capture shows: a cloud's streaming statistics, a mesh's triangles, and the box it occupies in the
  // viewer frame
  info() {
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
