// The map beside the 3D view (MapLibre GL JS, loaded the first time the map is shown): the model's footprint where it
// stands on the earth, the plan's frames and paths by mission, each pilot with the line-of-sight circle, the checked
// flights out and home, and the pointer's latitude/longitude. True north is up. The background is the project's own
// (an orthomosaic GeoTIFF or MBTiles uploaded from the map's bar: GET …/basemap), else the tiles the server is
// configured with (GET /api/info: basemap), else a plain grid; with a scale bar and a north arrow.
// A pilot can be placed by a click: for a mission of the plan shown (an edit, saved as a new version like any other)
// or as a ground station of the new-plan form.
//
// Model x, y become latitude/longitude through the affine map the server fits over the site
// (GET …/models/{id}/site: to_lat_lon, with its largest error, centimetres over a kilometre).
import * as api from './api.js';
import { MISSION_PALETTE } from './colours.js';
import { canEdit, projectUrl } from './context.js';
import { $, act, el, fillSelect, showMessage } from './dom.js';
import { TAKEOFF_COLOUR, RETURN_COLOUR } from './flight3d.js';
import { selectFrame } from './frames.js';
import { editDraft } from './frameedit.js';
import { set, state, subscribe } from './store.js';

const STATION_HEIGHT_M = 1.5;  // a pilot's station above the ground, as the server places a latitude/longitude one
const hex = (c) => `#${c.toString(16).padStart(6, '0')}`;
const EMPTY = { type: 'FeatureCollection', features: [] };

let gl = null;        // the MapLibre module
let map = null;
let loaded = false;
let drawn = {};       // what each source holds now (GeoJSON), for the test hook
let siteToken = null;

// ---------------------------------------------------------------------------------------------- coordinates
export function toLatLon([x, y]) {
  const f = state.site.to_lat_lon;
  const dx = x - f.origin_xy[0];
  const dy = y - f.origin_xy[1];
  return [f.origin_lat_lon[0] + f.matrix[0][0] * dx + f.matrix[0][1] * dy,
    f.origin_lat_lon[1] + f.matrix[1][0] * dx + f.matrix[1][1] * dy];
}

export function fromLatLon(lat, lon) {
  const f = state.site.to_lat_lon;
  const [[a, b], [c, d]] = f.matrix;
  const u = lat - f.origin_lat_lon[0];
  const v = lon - f.origin_lat_lon[1];
  const det = a * d - b * c;
  return [f.origin_xy[0] + (d * u - b * v) / det, f.origin_xy[1] + (-c * u + a * v) / det];
}

const lngLat = (p) => {
  const [lat, lon] = toLatLon(p);
  return [lon, lat];
};
const feature = (type, coordinates, properties = {}) => ({ type: 'Feature', properties, geometry: { type, coordinates } });
const collection = (features) => ({ type: 'FeatureCollection', features });

// ---------------------------------------------------------------------------------------------- the map's content
function gridLines(site) {
  const [lat0, lon0] = site.centre_lat_lon;
  const [lo, hi] = site.bounds;
  const extent = Math.max(hi[0] - lo[0], hi[1] - lo[1], 20) + 2 * 300;
  const step = [10, 20, 50, 100, 200, 500].find((s) => extent / s <= 40) || 1000;
  const mLat = 111320;
  const mLon = 111320 * Math.cos((lat0 * Math.PI) / 180);
  const n = Math.ceil(extent / 2 / step);
  const lines = [];
  for (let k = -n; k <= n; k++) {
    const e = lon0 + (k * step) / mLon;
    const no = lat0 + (k * step) / mLat;
    lines.push(feature('LineString', [[e, lat0 - (n * step) / mLat], [e, lat0 + (n * step) / mLat]]));
    lines.push(feature('LineString', [[lon0 - (n * step) / mLon, no], [lon0 + (n * step) / mLon, no]]));
  }
  return collection(lines);
}

function siteData(site) {
  return {
    grid: gridLines(site),
    footprint: collection(site.footprint_lat_lon.map((ring) => feature('Polygon', [ring.map(([la, lo]) => [lo, la])]))),
  };
}

function circle([x, y], r) {
  const ring = [];
  for (let k = 0; k <= 96; k++) ring.push(lngLat([x + r * Math.cos((k / 96) * 2 * Math.PI), y + r * Math.sin((k / 96) * 2 * Math.PI)]));
  return ring;
}

function planData() {
  const g = state.geom;
  if (!g || !state.site) return { frames: EMPTY, paths: EMPTY, pilots: EMPTY, vlos: EMPTY, flight: EMPTY };
  const colour = (k) => MISSION_PALETTE[k % MISSION_PALETTE.length];
  const frames = g.position.map((p, i) => {
    const k = g.missions.findIndex((m) => i >= m.start && i < m.stop);
    return feature('Point', lngLat(p), { frame: i, colour: colour(Math.max(k, 0)), selected: i === state.selectedFrame });
  });
  const paths = g.missions.filter((m) => m.stop - m.start > 1)
    .map((m) => feature('LineString', g.position.slice(m.start, m.stop).map(lngLat), { colour: colour(g.missions.indexOf(m)) }));
  const stations = new Map();
  g.missions.forEach((m, k) => {
    if (m.ground_station) stations.set(m.ground_station.slice(0, 2).join(','), { p: m.ground_station, k });
  });
  const vlos = state.checks && state.checks.vlos_radius_m;
  const pilots = [...stations.values()].map(({ p, k }) => feature('Point', lngLat(p), { mission: k }));
  const circles = vlos ? [...stations.values()].map(({ p }) => feature('LineString', circle(p, vlos))) : [];
  const flight = [];
  for (const t of (state.checks && state.checks.trajectory) || []) {
    flight.push(feature('LineString', t.out.map(lngLat), { colour: hex(TAKEOFF_COLOUR) }));
    flight.push(feature('LineString', t.home.map(lngLat), { colour: hex(RETURN_COLOUR) }));
  }
  return { frames: collection(frames), paths: collection(paths), pilots: collection(pilots), vlos: collection(circles),
    flight: collection(flight) };
}

function style() {
  const base = state.info && state.info.basemap;
  const own = state.background;
  const sources = {};
  const layers = [{ id: 'background', type: 'background', paint: { 'background-color': '#f3f1ec' } }];
  if (own && own.kind === 'image') {
    sources.basemap = { type: 'image', url: own.url, coordinates: own.corners };
    layers.push({ id: 'basemap', type: 'raster', source: 'basemap' });
  } else if (own) {
    sources.basemap = { type: 'raster', tiles: [own.url], tileSize: 256, minzoom: own.min_zoom ?? 0,
      maxzoom: own.max_zoom ?? 22, attribution: own.attribution || '', ...(own.bounds ? { bounds: own.bounds } : {}) };
    layers.push({ id: 'basemap', type: 'raster', source: 'basemap' });
  } else if (base && state.site && state.site.georeferenced) {
    const tms = base.url.includes('{-y}');
    sources.basemap = { type: 'raster', tiles: [base.url.replace('{-y}', '{y}')], tileSize: 256, scheme: tms ? 'tms' : 'xyz',
      attribution: base.attribution || '', maxzoom: 22 };
    layers.push({ id: 'basemap', type: 'raster', source: 'basemap' });
  }
  for (const name of ['grid', 'footprint', 'vlos', 'flight', 'paths', 'frames', 'pilots']) {
    sources[name] = { type: 'geojson', data: drawn[name] || EMPTY };
  }
  if (!sources.basemap) layers.push({ id: 'grid', type: 'line', source: 'grid', paint: { 'line-color': '#c9c4b8', 'line-width': 1 } });
  layers.push(
    { id: 'footprint-fill', type: 'fill', source: 'footprint', paint: { 'fill-color': '#5b6b82', 'fill-opacity': 0.35 } },
    { id: 'footprint', type: 'line', source: 'footprint', paint: { 'line-color': '#2f3b4d', 'line-width': 1.5 } },
    { id: 'vlos', type: 'line', source: 'vlos', paint: { 'line-color': hex(TAKEOFF_COLOUR), 'line-width': 1.5, 'line-dasharray': [3, 2] } },
    { id: 'flight', type: 'line', source: 'flight', paint: { 'line-color': ['get', 'colour'], 'line-width': 2 } },
    { id: 'paths', type: 'line', source: 'paths', paint: { 'line-color': ['get', 'colour'], 'line-width': 1.5, 'line-opacity': 0.8 } },
    { id: 'frames', type: 'circle', source: 'frames', paint: {
      'circle-color': ['get', 'colour'], 'circle-radius': ['case', ['get', 'selected'], 7, 3.5],
      'circle-stroke-color': ['case', ['get', 'selected'], '#ffd400', '#ffffff'], 'circle-stroke-width': ['case', ['get', 'selected'], 3, 1] } },
    { id: 'pilots', type: 'circle', source: 'pilots', paint: {
      'circle-color': hex(TAKEOFF_COLOUR), 'circle-radius': 7, 'circle-stroke-color': '#ffffff', 'circle-stroke-width': 2 } },
  );
  return { version: 8, sources, layers };
}

function setData(data) {
  for (const [name, value] of Object.entries(data)) {
    drawn[name] = value;
    if (map && loaded) map.getSource(name).setData(value);
  }
}

function drawPlan() {
  if (state.site) setData(planData());
}

function fitSite() {
  if (!map || !state.site) return;
  const rings = state.site.footprint_lat_lon.flat();
  const lats = rings.map((p) => p[0]);
  const lons = rings.map((p) => p[1]);
  if (!lats.length) return;
  const pad = 0.0006;
  map.fitBounds([[Math.min(...lons) - pad, Math.min(...lats) - pad], [Math.max(...lons) + pad, Math.max(...lats) + pad]],
    { padding: 30, bearing: 0, duration: 0 });
}

// ---------------------------------------------------------------------------------------------- the panel
async function ensureMap() {
  if (map) return;
  if (!document.querySelector('link[data-maplibre]')) {
    document.head.append(el('link', { rel: 'stylesheet', href: '/vendor/maplibre-gl/dist/maplibre-gl.css', 'data-maplibre': '' }));
  }
  gl = await import('maplibre-gl');
  map = new gl.Map({ container: $('#map-canvas'), style: style(), center: [0, 0], zoom: 1, attributionControl: { compact: true },
    dragRotate: true, maxPitch: 0 });
  map.addControl(new gl.NavigationControl({ showZoom: true, visualizePitch: false }), 'top-right');
  map.addControl(new gl.ScaleControl({ unit: 'metric', maxWidth: 120 }), 'bottom-left');
  map.on('load', () => {
    loaded = true;
    map.setStyle(style());  // the site and the server's basemap may have arrived while the map loaded
    setData(drawn);
    fitSite();
  });
  map.on('mousemove', (e) => showReadout(e.lngLat.lat, e.lngLat.lng));
  map.on('click', (e) => act('Placing on the map', () => onClick(e)));
  map.on('mouseenter', 'frames', () => { map.getCanvas().style.cursor = 'pointer'; });
  map.on('mouseleave', 'frames', () => { map.getCanvas().style.cursor = ''; });
}

function showReadout(lat, lon) {
  if (!state.site) return;
  const [x, y] = fromLatLon(lat, lon);
  const geo = state.site.georeferenced
    ? `${Math.abs(lat).toFixed(6)}° ${lat >= 0 ? 'N' : 'S'}, ${Math.abs(lon).toFixed(6)}° ${lon >= 0 ? 'E' : 'W'} · ` : '';
  $('#map-readout').textContent = `${geo}x ${x.toFixed(1)}, y ${y.toFixed(1)} m`;
}

function onClick(e) {
  const place = $('#map-place').value;
  if (!place) {
    const hit = map.queryRenderedFeatures(e.point, { layers: ['frames'] })[0];
    if (hit) selectFrame(hit.properties.frame, { scroll: true });
    return;
  }
  const { lat, lng } = e.lngLat;
  const [x, y] = fromLatLon(lat, lng);
  const ground = state.checks && state.checks.ground ? state.checks.ground.level_m : state.site.bounds[0][2];
  const z = ground + STATION_HEIGHT_M;
  if (place === 'form') {
    const line = state.site.georeferenced ? `${lat.toFixed(7)}, ${lng.toFixed(7)}` : `${x.toFixed(2)}, ${y.toFixed(2)}, ${z.toFixed(2)}`;
    const box = $('#plan-stations');
    box.value = box.value.trim() ? `${box.value.trim()}\n${line}` : line;
    showMessage(`Ground station ${line} added to the new-plan form.`, 'ok');
  } else {
    const k = Number(place);
    editDraft((draft) => {
      if (!draft.missions || !draft.missions[k]) throw new Error(`the plan has no mission ${k + 1}`);
      draft.missions[k].ground_station = [x, y, z].map((v) => Math.round(v * 1000) / 1000);
    });
    showMessage(`The pilot of mission ${k + 1} moved: save the plan to check the flight from there.`, 'info');
  }
  $('#map-place').value = '';
}

function renderPlaceOptions() {
  const missions = (state.draft && state.draft.missions) || [];
  const options = [['', 'select frames (click)']];
  if (canEdit()) options.push(['form', 'a ground station of the new-plan form']);
  if (canEdit()) missions.forEach((m, k) => options.push([k, `the pilot of mission ${k + 1}: ${m.name}`]));
  fillSelect($('#map-place'), options, $('#map-place').value);
}

async function loadSite() {
  const token = Symbol('site');
  siteToken = token;
  if (!state.model || state.model.status !== 'ready') {
    set({ site: null });
    return;
  }
  const site = await api.get(projectUrl(`/models/${state.model.id}/site`));
  if (siteToken !== token) return;
  set({ site });
}

function renderSite() {
  const site = state.site;
  $('#map-note').textContent = !site ? 'The map shows a loaded model.' : site.georeferenced
    ? `${site.centre_lat_lon[0].toFixed(6)}°, ${site.centre_lat_lon[1].toFixed(6)}° · model +Y at ${site.north_offset_deg.toFixed(1)}° true`
    : `Not georeferenced: model +Y is drawn as north. ${site.note}`;
  if (!site) return;
  setData({ ...siteData(site), ...planData() });
  if (map && loaded) map.setStyle(style());
  if (map && loaded) fitSite();
}

// the project's own background: read when a project opens, uploaded or removed from the map's bar
async function loadBackground() {
  set({ background: state.project ? (await api.get(projectUrl('/basemap'))).basemap : null });
}

async function uploadBackground() {
  const file = $('#map-bg-file').files[0];
  if (!file) throw new Error('choose a GeoTIFF orthomosaic or an MBTiles file first');
  const form = new FormData();
  form.append('file', file);
  set({ background: await api.upload(projectUrl('/basemap'), form) });
  $('#map-bg-file').value = '';
  showMessage(`Map background “${state.background.name}” uploaded.`, 'ok');
}

function renderBackground() {
  $('#map-bg-remove').hidden = !state.background;
  if (map && loaded) map.setStyle(style());
}

async function showMap(on) {
  $('#view').classList.toggle('with-map', on);
  $('#map-box').hidden = !on;
  localStorage.setItem('sightplan.map', on ? '1' : '');
  if (on) {
    await ensureMap();
    map.resize();
  }
}

export function bindMap() {
  $('#layer-map').checked = Boolean(localStorage.getItem('sightplan.map'));
  $('#layer-map').addEventListener('change', () => act('Opening the map', () => showMap($('#layer-map').checked)));
  $('#map-fit').addEventListener('click', fitSite);
  // the phone layout's 3D | Map switch: the map shown full screen there
  $('#view-switch [data-view=map]')?.addEventListener('click', () => act('Opening the map', async () => {
    $('#layer-map').checked = true;
    await showMap(true);
  }));
  subscribe(['model'], () => act('Reading where the model stands', loadSite));
  subscribe(['site', 'info'], renderSite);
  subscribe(['project'], () => act('Reading the map background', loadBackground));
  subscribe(['background'], renderBackground);
  $('#map-bg-upload').addEventListener('click', () => act('Uploading the map background', uploadBackground));
  $('#map-bg-remove').addEventListener('click', () => act('Removing the map background', async () => {
    await api.del(projectUrl('/basemap'));
    set({ background: null });
  }));
  subscribe(['geom', 'checks', 'selectedFrame'], drawPlan);
  subscribe(['draft'], renderPlaceOptions);
  if ($('#layer-map').checked) act('Opening the map', () => showMap(true));
}

// the test hook's view of the map
export const mapHook = Object.freeze({
  ready: () => Boolean(map && loaded && map.loaded()),
  // loaded and not moving (a fit to the site animates): what is on screen is where it stays
  still: () => Boolean(map && loaded && map.loaded() && !map.isMoving()),
  site: () => (state.site ? JSON.parse(JSON.stringify(state.site)) : null),
  drawn: (name) => (drawn[name] ? JSON.parse(JSON.stringify(drawn[name])) : null),
  // where a latitude/longitude is on screen (client pixels)
  screenPoint: (lat, lon) => {
    const p = map.project([lon, lat]);
    const r = map.getCanvas().getBoundingClientRect();
    return { x: r.left + p.x, y: r.top + p.y };
  },
  toLatLon: (p) => toLatLon(p),
  basemap: () => (map && map.getSource('basemap') ? map.getSource('basemap').type : null),
});
