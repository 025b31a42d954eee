// The "New plan from a template" form (#plan-form), built from the server's description of every template
// (GET /api/templates: each parameter's name with its unit, kind, bounds, default and help, declared once in the
// library), the request body it makes, the points picked in the 3D view for it (a bridge's axis, a route's points,
// the ground stations) and drawn there while the form is open, and the plan it creates. An overlap is typed in
// percent and sent as the fraction the API takes; lists the server pairs index by index (an orbit's ring radii and
// heights) are typed as the rows of one table.
//
// Interface, all it shares with the rest of the page:
//   bindTemplateForm({ planCreated })  wires the form once; planCreated(plan) (async) is given each plan created
//   it reads the store's templates (the form's fields), cameras and info (the camera and aircraft choices), model
//   (the plan's model) and pick; it draws its points with viewer.setMarkers and picks them with picking.js.
import * as api from './api.js';
import { $, $$, act, el, fillSelect, showMessage } from './dom.js';
import { projectUrl, viewer } from './context.js';
import { startPicking, stopPicking } from './picking.js';
import { state, subscribe } from './store.js';

/** @typedef {import('./api-types.js').TemplateOut} TemplateOut */
/** @typedef {import('./api-types.js').TemplateFieldOut} TemplateFieldOut */

/** @returns {TemplateOut | undefined} the template chosen in the form */
const chosen = () => state.templates.find((t) => t.name === $('#plan-template').value);
const typed = new Map();  // template → field → text typed, kept while the user looks at another template

function templateBody() {
  const t = chosen();
  if (!t) throw new Error('the templates are not loaded yet');
  const num = (node) => (node.value === '' ? null : Number(node.value));
  if (!state.model || state.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const body = {
    model_id: state.model.id, template: t.name, name: $('#plan-name').value.trim(), camera: $('#plan-camera').value,
    safety_distance_m: num($('#plan-safety')), split: $('#plan-split').checked,
  };
  for (const f of t.fields) {
    if (f.kind === 'numbers' && f.pair) continue;  // below, with the lists it is paired with
    const node = $(`#plan-${f.name}`);
    if (f.kind === 'number') body[f.name] = percent(f) && node.value !== '' ? Number(node.value) / 100 : num(node);
    else if (f.kind === 'numbers') body[f.name] = node.value.split(/[,;\s]+/).filter(Boolean).map(Number);
    else if (f.kind === 'choice') body[f.name] = node.value;
    else if (f.kind === 'flag') body[f.name] = node.checked;
    else body[f.name] = parsePoints(node.value, f.kind === 'points2' ? 2 : 3, f.label.toLowerCase());
    if (Array.isArray(body[f.name]) && !body[f.name].length) delete body[f.name];
  }
  for (const [pair, fields] of pairs(t)) Object.assign(body, pairedBody(pair, fields));
  Object.assign(body, flightBody());
  for (const [k, v] of Object.entries(body)) if (v === null || Number.isNaN(v)) delete body[k];
  return body;
}

/** The flight settings of the form's fieldset, which every plan request takes (a template's, an optimisation's):
 * the aircraft, VLOS radius, altitude limit and ground stations; a field left empty is null or absent (the server's
 * defaults, a walker's for a walked route). */
export function flightBody() {
  const num = (node) => (node.value === '' ? null : Number(node.value));
  const body = { vlos_radius_m: num($('#plan-vlos')), altitude_limit_m: num($('#plan-alt-limit')) };
  if ($('#plan-aircraft').value) body.aircraft = $('#plan-aircraft').value;
  if ($('#plan-position-error').value) body.position_error = $('#plan-position-error').value;
  const { model, geodetic } = parseStations($('#plan-stations').value);
  if (model.length) body.ground_station = model;
  if (geodetic.length) body.ground_station_geo = geodetic;
  return body;
}

/** The ground stations typed, one a line: 'x, y, z' in metres (model frame), or 'lat, lon' in degrees (WGS 84)
 * or a phone map's 'geo:lat,lon' link, which the server places on the model's ground by its georeference. */
export function parseStations(text) {
  const model = [];
  const geodetic = [];
  text.split(/[\n;]+/).map((l) => l.trim()).filter(Boolean).forEach((line, k) => {
    const uri = /^geo:/i.test(line);
    const body = uri ? line.slice(4).split(';')[0] : line.replace(/^\[|\]$/g, '');
    const v = body.split(/[,\s]+/).filter(Boolean).map(Number);
    if (v.some((x) => !Number.isFinite(x))) v.length = 0;
    if (v.length === 2 || (uri && v.length === 3)) geodetic.push(v.slice(0, 2));
    else if (v.length === 3) model.push(v);
    else throw new Error(`ground station ${k + 1} (“${line}”) must be x, y, z in metres or lat, lon in degrees`);
  });
  return { model, geodetic };
}

// the pilot's own position from the phone's or laptop's location, as a 'lat, lon' line of the stations
function addMyPosition() {
  if (!navigator.geolocation) throw new Error('this browser gives no location');
  return new Promise((resolve, reject) => navigator.geolocation.getCurrentPosition((pos) => {
    const { latitude, longitude, accuracy } = pos.coords;
    const box = $('#plan-stations');
    box.value = `${box.value.trim() ? `${box.value.trim()}\n` : ''}${latitude.toFixed(7)}, ${longitude.toFixed(7)}`;
    showMessage(`Your position (±${Math.round(accuracy)} m) is a ground station; the server places it on the `
      + 'model’s ground.', 'ok');
    updateMarkers();
    resolve();
  }, (err) => reject(new Error(`no location: ${err.message}${window.isSecureContext ? ''
    : ' (a browser gives it only to https pages and localhost)'}`)), { enableHighAccuracy: true, timeout: 20000 }));
}

// an overlap is a fraction to the API and a percentage on the form
const percent = (f) => f.kind === 'number' && /(^|_)overlap$/.test(f.name);
const shown = (f, v) => (v === null || v === undefined || !percent(f) ? v : Number((v * 100).toPrecision(12)));
const bounds = (f) => [f.ge !== null ? `≥ ${shown(f, f.ge)}` : '', f.gt !== null ? `> ${shown(f, f.gt)}` : '',
  f.le !== null ? `≤ ${shown(f, f.le)}` : '', f.lt !== null ? `< ${shown(f, f.lt)}` : ''].filter(Boolean).join(', ');

/** One field of the form for a template parameter. @param {TemplateFieldOut} f */
function paramField(f) {
  const id = `plan-${f.name}`;
  const unit = percent(f) ? '%' : f.unit;
  const label = unit ? `${f.label} (${unit})` : f.label;
  const title = [f.help, bounds(f)].filter(Boolean).join('; ');
  if (f.kind === 'points2' || f.kind === 'points3') {
    const xyz = f.kind === 'points2' ? 'x, y' : 'x, y, z';
    return el('div', { class: 'points-field', dataset: { kind: f.kind } },
      el('label', { for: id }, `${f.label} ${xyz} (m), in order, one a line`),
      el('textarea', { id, rows: '3', spellcheck: 'false', title, oninput: updateMarkers }),
      el('button', { id: `pick-${f.name}`, type: 'button', class: 'pick', dataset: { pick: f.name }, onclick: (ev) => act(
        'Picking points', async () => startPicking(f.name, { button: ev.currentTarget, what: `a point of the ${f.label
          .toLowerCase()}`, onPoint: (point) => addPickedPoint(f, point) })) }, 'pick in 3D'));
  }
  if (f.kind === 'flag') {
    return el('label', { class: 'check', title }, el('input', { id, type: 'checkbox', checked: f.default === true }), ` ${f.help}`);
  }
  let input;
  if (f.kind === 'choice') {
    input = el('select', { id });
    fillSelect(input, f.choices.map((c) => [c, c]), f.default);
  } else if (f.kind === 'numbers') {
    input = el('input', { id, placeholder: 'default; or values, comma-separated' });
  } else {
    const min = shown(f, f.ge ?? f.gt);
    const max = shown(f, f.le ?? f.lt);
    input = el('input', { id, type: 'number', step: 'any', min: min ?? undefined, max: max ?? undefined,
      placeholder: f.default === null ? 'default' : undefined, value: shown(f, f.default) ?? undefined });
  }
  input.title = title;
  return el('label', {}, `${label} `, input);
}

// ------------------------------------------------------------------------------------- lists paired index by index
/** The template's paired lists: pair name → its fields, in declaration order. @param {TemplateOut} t */
function pairs(t) {
  const out = new Map();
  for (const f of t.fields.filter((g) => g.kind === 'numbers' && g.pair)) out.set(f.pair, [...(out.get(f.pair) || []), f]);
  return out;
}

const bare = (name) => name.replace(/_(m_px|deg|m)$/, '').replace(/_/g, ' ');  // "radius_m" → "radius"
const column = (f) => `${bare(f.name)}${f.unit ? ` (${f.unit})` : ''}`;

// one row of a paired table: a number for each list (ids plan-<field>-<row>, from 1)
function pairRow(fields) {
  return el('tr', {}, el('th', {}),
    ...fields.map((f) => el('td', {}, el('input', { type: 'number', step: 'any', placeholder: 'default', title: f.help,
      min: f.ge ?? f.gt ?? undefined, max: f.le ?? f.lt ?? undefined, dataset: { field: f.name } }))),
    el('td', {}, el('button', { type: 'button', class: 'icon', title: 'remove this row', onclick: (ev) => {
      const table = ev.currentTarget.closest('table');
      ev.currentTarget.closest('tr').remove();
      numberRows(table);
    } }, '✕')));
}

// rows numbered 1, 2, …; each input's id names its field and row
function numberRows(table) {
  table.querySelectorAll('tbody tr').forEach((tr, k) => {
    tr.firstChild.textContent = String(k + 1);
    for (const input of tr.querySelectorAll('input')) {
      input.id = `plan-${input.dataset.field}-${k + 1}`;
      input.setAttribute('aria-label', `${table.dataset.pair} ${k + 1} ${bare(input.dataset.field)}`);
    }
  });
}

/** A table of paired lists (an orbit's rings: radius and height), a row each, with add and remove buttons. */
function pairTable(pair, fields, rows = 1) {
  const table = el('table', { id: `plan-rows-${pair}`, class: 'table compact pair-rows', dataset: { pair } },
    el('thead', {}, el('tr', {}, el('th', {}, pair), ...fields.map((f) => el('th', { title: f.help }, column(f))),
      el('th', {}))),
    el('tbody', {}, ...Array.from({ length: rows }, () => pairRow(fields))));
  numberRows(table);
  const add = el('button', { type: 'button', id: `plan-add-${pair}`, onclick: () => {
    table.tBodies[0].append(pairRow(fields));
    numberRows(table);
  } }, `+ ${pair}`);
  return el('div', { class: 'pair-field' },
    el('span', {}, `${pair[0].toUpperCase()}${pair.slice(1)}s, one a row; a column left empty takes the default`), table, add);
}

// the paired lists typed: each field's column, rows left empty skipped; a column left empty is the server's default
function pairedBody(pair, fields) {
  const rows = $$(`#plan-rows-${pair} tbody tr`).map((tr, k) => ({ k, v: fields.map((f) => {
    const input = tr.querySelector(`input[data-field="${f.name}"]`);
    return input.value === '' ? null : Number(input.value);
  }) })).filter((row) => row.v.some((v) => v !== null));
  const body = {};
  fields.forEach((f, j) => {
    if (rows.every((row) => row.v[j] === null)) return;
    const gap = rows.find((row) => row.v[j] === null);
    if (gap) throw new Error(`${pair} ${gap.k + 1} has no ${column(f)}: give one, or leave the column empty for the default`);
    body[f.name] = rows.map((row) => row.v[j]);
  });
  return body;
}

// --------------------------------------------------------------------------------------------------------- the form
// the chosen template's fields, a paired table in place of its first list (what was typed for it before, back in place)
function renderParams() {
  const t = chosen();
  const box = $('#plan-params');
  const previous = box.dataset.template;
  if (previous) {
    const values = $$('#plan-params :is(input, select, textarea)[id^="plan-"]')
      .map((n) => [n.id, n.type === 'checkbox' ? n.checked : n.value]);
    const rows = $$('#plan-params table.pair-rows').map((n) => [`rows:${n.dataset.pair}`, n.tBodies[0].rows.length]);
    typed.set(previous, new Map([...rows, ...values]));
  }
  const fields = [];
  if (t) {
    const paired = pairs(t);
    for (const f of t.fields) {
      if (!(f.kind === 'numbers' && f.pair)) fields.push(paramField(f));
      else if (paired.get(f.pair)[0] === f) {
        fields.push(pairTable(f.pair, paired.get(f.pair), (typed.get(t.name) || new Map()).get(`rows:${f.pair}`)));
      }
    }
  }
  box.replaceChildren(...fields);
  box.dataset.template = t ? t.name : '';
  for (const [id, v] of (t && typed.get(t.name)) || []) {
    const node = document.getElementById(id);
    if (node && node.type === 'checkbox') node.checked = v;
    else if (node) node.value = v;
  }
  $('#plan-eye-field').hidden = !(t && t.fields.some((f) => f.kind === 'points3'));
}

function fillTemplates() {
  const select = $('#plan-template');
  fillSelect(select, state.templates.map((t) => [t.name, `${t.name} (${t.summary})`]), select.value || 'facade');
  updateTemplateFields();
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
const COLOURS = { points2: 0xe67e22, points3: 0x8e44ad, stations: 0x0b7a3e };

// a point picked: appended to its field (a 2D point without its z; a walked point at the height typed above it)
function addPickedPoint(f, [x, y, z]) {
  let coords;
  if (f.kind === 'points2') coords = [x, y];
  else if (f.kind === 'points3') coords = [x, y, z + (Number($('#plan-route-eye').value) || 0)];
  else coords = [x, y, z];
  const field = f.kind === 'stations' ? $('#plan-stations') : $(`#plan-${f.name}`);
  const text = field.value.replace(/\s+$/, '');
  field.value = `${text ? `${text}\n` : ''}${coords.map(fmt2).join(', ')}`;
  field.dataset.picked = String(Number(field.dataset.picked || 0) + 1);
  updateMarkers();
}

// the form's points in the 3D view while the form is open (2D points at the ground's level)
function updateMarkers() {
  if (!viewer) return;
  if (!$('#plan-new').open) {
    viewer.setMarkers([]);
    return;
  }
  const safe = (fn) => {
    try {
      return fn();
    } catch {
      return [];  // a line being typed: shown once it parses
    }
  };
  const ground = viewer.groundZ();
  const sets = [];
  for (const f of (chosen() || { fields: [] }).fields.filter((g) => g.kind.startsWith('points'))) {
    const n = f.kind === 'points2' ? 2 : 3;
    const points = safe(() => parsePoints($(`#plan-${f.name}`).value, n, f.label));
    sets.push({ colour: COLOURS[f.kind], line: true, points: n === 2 ? points.map(([x, y]) => [x, y, ground]) : points });
  }
  sets.push({ colour: COLOURS.stations, line: false, points: safe(() => parseStations($('#plan-stations').value).model) });
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

// the safety distance follows the template (a walker's is the server's default) unless it was typed
function updateTemplateFields() {
  const t = chosen();
  renderParams();
  const safety = $('#plan-safety');
  const before = state.templates.find((x) => x.name === safety.dataset.defaultOf);
  const shown = (x) => (x && x.walked ? '' : String(x ? x.safety_distance_m : 10));
  if (safety.value === shown(before)) safety.value = shown(t);
  safety.placeholder = t && t.walked ? `${t.safety_distance_m} (walker)` : '';
  safety.dataset.defaultOf = t ? t.name : '';
  if (state.pick && state.pick !== 'stations' && !(t && t.fields.some((f) => f.name === state.pick))) stopPicking();
  updateMarkers();
}

export function bindTemplateForm({ planCreated }) {
  subscribe(['cameras', 'info'], fillChoices);
  subscribe(['templates'], fillTemplates);
  $('#plan-template').addEventListener('change', updateTemplateFields);
  $('#plan-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating the plan', () => createPlan(planCreated));
  });
  // the ground stations, the one points field every template has
  const stations = { name: 'stations', kind: 'stations', label: 'ground station' };
  $('#pick-stations').addEventListener('click', (ev) => act('Picking points', async () => startPicking('stations', {
    button: ev.currentTarget, what: 'a ground station', onPoint: (point) => addPickedPoint(stations, point) })));
  $('#plan-stations').addEventListener('input', updateMarkers);
  $('#my-position').addEventListener('click', () => act('Reading your position', addMyPosition));
  $('#plan-new').addEventListener('toggle', () => {
    if (!$('#plan-new').open) stopPicking();
    updateMarkers();
  });
}
