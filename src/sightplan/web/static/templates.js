// The "New plan from a template" form (#plan-form): the fields of the template chosen, the request body they make,
// the points picked in the 3D view for it (a bridge's axis, a route's points, the ground stations) and drawn there
// while the form is open, and the plan it creates.
//
// Interface, all it shares with the rest of the page:
//   bindTemplateForm({ planCreated })  wires the form once; planCreated(plan) (async) is given each plan created
//   it reads the store's cameras and info (the camera and aircraft choices), model (the plan's model) and pick;
//   it draws its points with viewer.setMarkers and picks them with picking.js.
import * as api from './api.js';
import { $, $$, act, fillSelect, showMessage } from './dom.js';
import { projectUrl, viewer } from './context.js';
import { startPicking, stopPicking } from './picking.js';
import { state, subscribe } from './store.js';

function templateBody() {
  const template = $('#plan-template').value;
  const num = (sel) => ($(sel).value === '' ? null : Number($(sel).value));
  const list = (sel) => $(sel).value.split(/[,\s]+/).filter(Boolean).map(Number);
  if (!state.model || state.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const body = {
    model_id: state.model.id, template, name: $('#plan-name').value.trim(), camera: $('#plan-camera').value,
    safety_distance: num('#plan-safety'), overlap: num('#plan-overlap'), split: $('#plan-split').checked,
  };
  if (template === 'facade') body.footprint = $('#plan-footprint').value;
  if (template === 'orbit') {
    Object.assign(body, { radius: list('#plan-radius'), height: list('#plan-height'), aim: $('#plan-aim').value });
    if (num('#plan-step') !== null) body.step = num('#plan-step');
  }
  if (template === 'lawnmower') {
    Object.assign(body, { side_overlap: num('#plan-side-overlap') });
    if (num('#plan-gsd') !== null) body.gsd = num('#plan-gsd');
    else body.altitude = num('#plan-altitude');
    if (num('#plan-oblique') !== null) body.oblique_pitch = num('#plan-oblique');
  }
  if (template === 'bridge') {
    body.axis = parsePoints($('#plan-axis').value, 2, 'axis point');
    if (body.axis.length < 2) throw new Error('the bridge axis needs at least two points x, y (typed, or picked in 3D)');
    if (list('#plan-bridge-height').length) body.height = list('#plan-bridge-height');
    if (num('#plan-deck-z') !== null) body.deck_z = num('#plan-deck-z');
    body.under_deck = $('#plan-under-deck').checked;
  }
  if (template === 'route') {
    body.points = parsePoints($('#plan-points').value, 3, 'route point');
    if (body.points.length < 2) throw new Error('a route needs at least two points x, y, z (typed, or picked in 3D)');
    body.step = num('#plan-route-step');
  }
  // the flight settings every template takes; left empty, the server's defaults (a walker's for a route)
  if ($('#plan-aircraft').value) body.aircraft = $('#plan-aircraft').value;
  body.vlos_radius = num('#plan-vlos');
  body.altitude_limit = num('#plan-alt-limit');
  const stations = parsePoints($('#plan-stations').value, 3, 'ground station');
  if (stations.length) body.ground_station = stations;
  for (const [k, v] of Object.entries(body)) if (v === null || Number.isNaN(v)) delete body[k];
  return body;
}

// "x, y[, z]" a line (or separated by ";"): a list of points of n coordinates each
function parsePoints(text, n, what) {
  const lines = text.split(/[\n;]+/).map((l) => l.trim()).filter(Boolean);
  return lines.map((line, k) => {
    const v = line.replace(/^\[|\]$/g, '').split(/[,\s]+/).filter(Boolean).map(Number);
    if (v.length !== n || v.some((x) => !Number.isFinite(x))) {
      throw new Error(`${what} ${k + 1} (“${line}”) must be ${n} numbers: ${n === 2 ? 'x, y' : 'x, y, z'} in metres`);
    }
    return v;
  });
}

const fmt2 = (v) => String(Math.round(v * 100) / 100);

// the camera catalogue and the aircraft presets of /api/info
function fillChoices() {
  fillSelect($('#plan-camera'), state.cameras.map((c) => [c.id, `${c.name} (${c.width}×${c.height})`]), 'p4p');
  fillSelect($('#plan-aircraft'), [['', 'default (p4p; a walker for a route)'],
    ...Object.entries((state.info && state.info.aircraft) || {}).map(([id, name]) => [id, `${name} (${id})`]),
    ['none', 'none: no battery check']], '');
}

// ---------------------------------------------------------------------------------------------- points picked in 3D
const PICK = {
  axis: { field: '#plan-axis', button: '#pick-axis', what: 'an axis point', colour: 0xe67e22, line: true },
  points: { field: '#plan-points', button: '#pick-points', what: 'a route point', colour: 0x8e44ad, line: true },
  stations: { field: '#plan-stations', button: '#pick-stations', what: 'a ground station', colour: 0x0b7a3e, line: false },
};

// a point picked: appended to its field (an axis point without its z; a route point at the height typed above it)
function addPickedPoint(kind, [x, y, z]) {
  let coords;
  if (kind === 'axis') coords = [x, y];
  else if (kind === 'points') coords = [x, y, z + (Number($('#plan-route-eye').value) || 0)];
  else coords = [x, y, z];
  const field = $(PICK[kind].field);
  const text = field.value.replace(/\s+$/, '');
  field.value = `${text ? `${text}\n` : ''}${coords.map(fmt2).join(', ')}`;
  field.dataset.picked = String(Number(field.dataset.picked || 0) + 1);
  updateMarkers();
}

// the form's points in the 3D view while the form is open (axis points at the ground's level)
function updateMarkers() {
  if (!viewer) return;
  if (!$('#plan-new').open) {
    viewer.setMarkers([]);
    return;
  }
  const t = $('#plan-template').value;
  const sets = [];
  const safe = (fn) => {
    try {
      return fn();
    } catch {
      return [];  // a line being typed: shown once it parses
    }
  };
  const ground = viewer.groundZ();
  if (t === 'bridge') {
    sets.push({ ...PICK.axis, points: safe(() => parsePoints($('#plan-axis').value, 2, 'axis point')).map(([x, y]) => [x, y, ground]) });
  }
  if (t === 'route') sets.push({ ...PICK.points, points: safe(() => parsePoints($('#plan-points').value, 3, 'route point')) });
  sets.push({ ...PICK.stations, points: safe(() => parsePoints($('#plan-stations').value, 3, 'ground station')) });
  viewer.setMarkers(sets);
}

async function createPlan(planCreated) {
  const body = templateBody();
  const button = $('#plan-create');
  button.disabled = true;
  button.textContent = 'Planning…';
  try {
    const plan = await api.post(projectUrl('/plans'), body);
    showMessage(`Plan “${plan.name}”: ${plan.versions[0].frames} frames in ${plan.versions[0].missions} mission(s).`, 'ok');
    await planCreated(plan);
    $('#plan-new').open = false;
  } finally {
    button.disabled = false;
    button.textContent = 'Create plan';
  }
}

const SAFETY_DEFAULT = { route: '' };  // empty: the server's default (0.3 m for a walker)
function updateTemplateFields() {
  const t = $('#plan-template').value;
  for (const label of $$('#plan-form [data-template]')) label.hidden = label.dataset.template !== t;
  // the safety distance follows the template unless it was typed
  const safety = $('#plan-safety');
  const before = safety.dataset.defaultOf || 'facade';
  if (safety.value === (SAFETY_DEFAULT[before] ?? '10')) safety.value = SAFETY_DEFAULT[t] ?? '10';
  safety.placeholder = t === 'route' ? '0.3 (walker)' : '';
  safety.dataset.defaultOf = t;
  if (state.pick && state.pick !== 'stations' && !$(PICK[state.pick].button).closest('[data-template]').dataset.template.includes(t)) {
    stopPicking();
  }
  updateMarkers();
}

export function bindTemplateForm({ planCreated }) {
  subscribe(['cameras', 'info'], fillChoices);
  $('#plan-template').addEventListener('change', updateTemplateFields);
  updateTemplateFields();
  $('#plan-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating the plan', () => createPlan(planCreated));
  });
  // points of the form picked in the 3D view
  for (const b of $$('button[data-pick]')) {
    const kind = b.dataset.pick;
    b.addEventListener('click', () => act('Picking points', async () => startPicking(kind, {
      button: b, what: PICK[kind].what, onPoint: (point) => addPickedPoint(kind, point) })));
  }
  for (const sel of ['#plan-axis', '#plan-points', '#plan-stations']) $(sel).addEventListener('input', updateMarkers);
  $('#plan-new').addEventListener('toggle', () => {
    if (!$('#plan-new').open) stopPicking();
    updateMarkers();
  });
}
