// Reality captures in the 3D view: a point cloud streamed as OGC 3D Tiles 1.1 (tileset.json and .glb point
// tiles written by sightplan's web/pointtiles.py), loaded tile by tile with level of detail, so that a cloud of
// 100 million points draws only the points the camera can tell apart.
//
// Importmap entries the page needs (/vendor/<package>/ serves web/node_modules/<package>/):
//
//   <script type="importmap">{"imports": {
//     "three": "/vendor/three/build/three.module.js",
//     "three/addons/": "/vendor/three/examples/jsm/",
//     "3d-tiles-renderer": "/vendor/3d-tiles-renderer/build/index.three.js"
//   }}</script>
//
// 3d-tiles-renderer's build/index.three.js imports its own chunks by relative paths (build/renderer-*.js)
// and three.js through "three", "three/addons/loaders/GLTFLoader.js" and
// "three/addons/utils/BufferGeometryUtils.js", which the two three.js entries cover; no other bare specifier.
//
// Usage, once per cloud:
//   const cloud = addPointCloud(scene, camera, renderer, '/…/tileset.json', { pointSize: 2 });
//   function frame() { cloud.update(); renderer.render(scene, camera); requestAnimationFrame(frame); }
//   …
//   cloud.dispose();
import { Color, PointsMaterial } from 'three';
import { TilesRenderer } from '3d-tiles-renderer';

export const POINT_CLOUD_DEFAULTS = Object.freeze({
  pointSize: 2, // pixels on screen, whatever the distance
  errorTarget: 4, // refine a tile while its points would lie more than this many pixels apart
  pointBudget: 3_000_000, // most points drawn: above it the error target grows until the drawn points fit
  upAxis: 'y', // 'y': the page's Y-up frame (model (x, y, z) drawn at (x, z, −y)); 'z': model coordinates as they are
  origin: [0, 0, 0], // model coordinates subtracted first (the page's origin)
  color: 0xc8ccd2, // the points' colour when the tiles carry none
});

const MAX_ERROR_SCALE = 64; // the budget may coarsen the level of detail up to this factor

// The tiles' COLOR_0 holds the capture's colours as stored (sRGB-encoded bytes); three.js takes vertex colours as
// linear, so they are decoded in the vertex shader.
function pointMaterial(size, vertexColors, color) {
  const material = new PointsMaterial({ size, sizeAttenuation: false, vertexColors, color: new Color(color) });
  if (vertexColors) {
    material.onBeforeCompile = (shader) => {
      shader.vertexShader = shader.vertexShader.replace('#include <color_vertex>', `#include <color_vertex>
#ifdef USE_COLOR
  vColor.rgb = mix(vColor.rgb * 0.0773993808, pow(vColor.rgb * 0.9478672986 + 0.0521327014, vec3(2.4)),
                   step(vec3(0.04045), vColor.rgb));
#endif`);
    };
    material.customProgramCacheKey = () => 'sightplan-srgb-points';
  }
  return material;
}

function countPoints(object) {
  let n = 0;
  object.traverse((o) => {
    if (o.isPoints && o.geometry.attributes.position) n += o.geometry.attributes.position.count;
  });
  return n;
}

/**
 * Stream the point cloud tileset at `tilesetUrl` into `scene`.
 *
 * Call `update()` once per animation frame before rendering: it picks the tiles for the camera's view and queues
 * their downloads. Returns { group, tiles, ready, update, dispose, stats, setPointSize, setErrorTarget }:
 * `group` holds the drawn tiles; `tiles` is the 3d-tiles-renderer TilesRenderer; `ready` resolves with the
 * root tileset when it has loaded (rejects when it cannot); `stats()` gives tilesLoaded, tilesVisible,
 * pointsLoaded, pointsVisible (drawn), pointsSelected (in the tiles the level of detail chose, before the
 * budget), downloading, parsing, queued, failed, loading (tiles still to come for this view), errorTarget (the
 * one in use) and frames (updates so far).
 */
export function addPointCloud(scene, camera, renderer, tilesetUrl, options = {}) {
  const opts = { ...POINT_CLOUD_DEFAULTS, ...options };
  if (opts.upAxis !== 'y' && opts.upAxis !== 'z') throw new Error(`upAxis must be 'y' or 'z', got ${opts.upAxis}`);
  const tiles = new TilesRenderer(tilesetUrl);
  tiles.errorTarget = opts.errorTarget;
  tiles.setCamera(camera);
  tiles.setResolutionFromRenderer(camera, renderer);

  const group = tiles.group;
  group.name = 'point cloud';
  const [ox, oy, oz] = opts.origin;
  if (opts.upAxis === 'y') {
    group.rotation.x = -Math.PI / 2;
    group.position.set(-ox, -oz, oy);
  } else {
    group.position.set(-ox, -oy, -oz);
  }
  scene.add(group);

  const coloured = pointMaterial(opts.pointSize, true, 0xffffff);
  const plain = pointMaterial(opts.pointSize, false, opts.color);
  const pointsOf = new Map(); // tile → number of points in its content
  let pointsLoaded = 0;
  let pointsVisible = 0; // drawn
  let pointsSelected = 0; // in the tiles the level of detail chose
  let baseError = opts.errorTarget;
  let errorScale = 1;
  let frames = 0;
  let failed = 0;

  const onLoad = ({ scene: content, tile }) => {
    content.traverse((o) => {
      if (o.isPoints) o.material = o.geometry.attributes.color ? coloured : plain; // the loader's own ones are freed with the tile
    });
    const n = countPoints(content);
    pointsOf.set(tile, n);
    pointsLoaded += n;
  };
  const onDispose = ({ tile }) => {
    pointsLoaded -= pointsOf.get(tile) || 0;
    pointsOf.delete(tile);
  };
  const onError = () => { failed++; };
  tiles.addEventListener('load-model', onLoad);
  tiles.addEventListener('dispose-model', onDispose);
  tiles.addEventListener('load-error', onError);

  const ready = new Promise((resolve, reject) => {
    tiles.addEventListener('load-root-tileset', ({ tileset }) => resolve(tileset));
    tiles.addEventListener('load-error', ({ tile, error, url }) => {
      if (!tile) reject(error || new Error(`cannot load ${url}`));
    });
  });
  ready.catch(() => {}); // a page that never awaits it still sees the failure in stats().failed

  const hidden = new Set(); // visible tiles left undrawn this frame to keep within the point budget

  function update() {
    camera.updateMatrixWorld();
    tiles.setResolutionFromRenderer(camera, renderer);
    tiles.update();
    frames++;
    for (const tile of hidden) if (tile.engineData.scene) tile.engineData.scene.visible = true;
    hidden.clear();
    let selected = 0;
    for (const tile of tiles.visibleTiles) selected += pointsOf.get(tile) || 0;
    // The budget is kept two ways: while over it the error target grows (coarser tiles are chosen from the next
    // update on), back towards the asked one when well under; and, as tiles arrive before that takes effect, the
    // finest of the selected tiles are left undrawn so the drawn points never exceed it.
    if (selected > opts.pointBudget && errorScale < MAX_ERROR_SCALE) errorScale = Math.min(MAX_ERROR_SCALE, errorScale * 1.25);
    else if (selected < 0.6 * opts.pointBudget && errorScale > 1) errorScale = Math.max(1, errorScale / 1.05);
    tiles.errorTarget = baseError * errorScale;
    let drawn = selected;
    if (selected > opts.pointBudget) {
      const finestFirst = [...tiles.visibleTiles].sort((a, b) => a.geometricError - b.geometricError);
      for (const tile of finestFirst) {
        if (drawn <= opts.pointBudget) break;
        const n = pointsOf.get(tile) || 0;
        if (n && tile.engineData.scene) {
          tile.engineData.scene.visible = false;
          hidden.add(tile);
          drawn -= n;
        }
      }
    }
    pointsSelected = selected;
    pointsVisible = drawn;
  }

  function stats() {
    const s = tiles.stats;
    return {
      tilesLoaded: pointsOf.size,
      tilesVisible: tiles.visibleTiles.size,
      pointsLoaded,
      pointsVisible,
      pointsSelected,
      downloading: s.downloading,
      parsing: s.parsing,
      queued: s.queued,
      failed,
      loading: s.downloading + s.parsing + s.queued,
      errorTarget: tiles.errorTarget,
      frames,
    };
  }

  function setPointSize(px) {
    coloured.size = px;
    plain.size = px;
  }

  function setErrorTarget(px) {
    baseError = px;
    tiles.errorTarget = baseError * errorScale;
  }

  function dispose() {
    tiles.removeEventListener('load-model', onLoad);
    tiles.removeEventListener('dispose-model', onDispose);
    tiles.removeEventListener('load-error', onError);
    scene.remove(group);
    tiles.dispose();
    coloured.dispose();
    plain.dispose();
    pointsOf.clear();
    hidden.clear();
    pointsLoaded = pointsVisible = pointsSelected = 0;
  }

  return { group, tiles, ready, update, dispose, stats, setPointSize, setErrorTarget };
}
