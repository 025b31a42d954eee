// Plans: the plan list and its versions, uploading a plan file, opening a version (its geometry drawn, its flight
// checked, its evaluation shown), and the flight-app exports. New plans from a template are templates.js's; the
// edits of a version's frames (saved as a new version) are frameedit.js's.
import * as api from './api.js';
import { formatNumber } from './charts.js';
import { $, act, el, errorText, fillSelect, showMessage } from './dom.js';
import { projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { clearFeedback, selectEvaluation } from './evaluations.js';
import { selectFrame, showSelection } from './frames.js';
import { selectModel } from './models.js';
import { loadLinks } from './team.js';
import { frameColours } from './view.js';
import { clonePlan } from './planedit.js';

let checksToken = null;  // the flight checks asked last: an older answer is dropped

function renderPlans() {
  fillSelect($('#plan-select'), state.plans.map((p) => [p.id, `${p.name} — ${p.source}`]), state.plan && state.plan.id);
  if (state.plan) {
    fillSelect($('#version-select'), state.plan.versions.map((v) => [v.number, `v${v.number}`]), state.version);
  } else {
    $('#version-select').replaceChildren();
  }
}

// a plan made on the server (from a template, or uploaded): listed and opened
export async function addPlan(plan) {
  set({ plans: [...state.plans, plan] });
  await selectPlan(plan.id);
}

async function uploadPlan() {
  const file = $('#plan-file').files[0];
  if (!file) throw new Error('choose a plan file first');
  const form = new FormData();
  form.append('file', file);
  if (state.model && state.model.status === 'ready') form.append('model_id', String(state.model.id));
  const plan = await api.upload(projectUrl('/plans/upload'), form);
  $('#plan-file').value = '';
  showMessage(`Plan “${plan.name}” uploaded: ${plan.versions[0].frames} frames.`, 'ok');
  await addPlan(plan);
}

export async function selectPlan(id, version = null, { keepEvaluation = false } = {}) {
  set({ plan: state.plans.find((p) => p.id === id) || null });
  if (!state.plan) return;
  localStorage.setItem(`sightplan.${state.project.id}.plan`, String(id));
  const number = version ?? state.plan.latest_version;
  $('#share-new').hidden = true;
  $('#share-url').value = '';
  act('Listing the share links', loadLinks);
  await loadVersion(number, { keepEvaluation });
}

export async function loadVersion(number, { keepEvaluation = false } = {}) {
  if (state.dirty) showMessage('The unsaved edits were discarded.', 'info');
  set({ version: number });
  const base = projectUrl(`/plans/${state.plan.id}/versions/${number}`);
  const [json, geom] = await Promise.all([api.get(base), api.get(`${base}/geometry`)]);
  const selectedFrame = state.selectedFrame !== null && state.selectedFrame >= geom.position.length ? null
    : state.selectedFrame;
  set({ saved: json, draft: clonePlan(json), dirty: false, geom, checks: null, selectedFrame,
    northOffset: geom.north_offset_deg ?? null });
  viewer.setNorthOffset(state.northOffset);
  const plan = state.plan;
  if (plan.model_id && (!state.model || state.model.id !== plan.model_id) && state.models.some((m) => m.id === plan.model_id)) {
    await selectModel(plan.model_id);
  }
  viewer.setPlan(geom, frameColours(), null);
  if (state.fitted !== `plan${state.plan.id}`) {
    viewer.fit();
    set({ fitted: `plan${state.plan.id}` });
  }
  loadChecks();
  if (!keepEvaluation) {
    const match = state.evaluations.filter((e) => e.status === 'done' && e.plan_id === state.plan.id && e.plan_version === number);
    if (state.evaluation && match.some((e) => e.id === state.evaluation.id)) {
      // keep it
    } else if (match.length) await selectEvaluation(match.at(-1).id, { fromPlan: true });
    else clearFeedback();
  }
  showSelection();
}

function renderPlanSummary() {
  if (!state.plan || !state.saved || !state.draft) return;
  const v = state.plan.versions.find((x) => x.number === state.version);
  const p = state.saved.parameters || {};
  const bits = [`${state.draft.frames.length} frames`, `${(state.draft.missions || []).length || 1} mission(s)`];
  if (p.template) bits.push(`template ${p.template}`);
  if (p.safety_distance_m) bits.push(`g = ${p.safety_distance_m} m`);
  if (v && v.note) bits.push(`“${v.note}”`);
  $('#plan-summary').textContent = bits.join(' · ') + (state.dirty ? ' — edited, not saved' : '');
}

function renderExportMissions() {
  const missions = (state.draft && state.draft.missions) || [];
  fillSelect($('#export-mission'), [['', 'all'], ...missions.map((m, k) => [k + 1, `${k + 1}: ${m.name}`])], '');
}

// ---------------------------------------------------------------------------------------------- flight checks
// the flight checks of the version shown (dropped if it is edited meanwhile)
export async function loadChecks() {
  const token = Symbol('checks');
  checksToken = token;
  $('#checks-summary').textContent = 'Checking the flight (safety distance, line of sight, altitude, battery)…';
  $('#missions-table tbody').replaceChildren();
  $('#violations').replaceChildren();
  if (!state.plan || !(state.plan.model_id || state.model)) return;
  const modelId = state.model && state.model.status === 'ready' ? state.model.id : state.plan.model_id;
  try {
    const checks = await api.get(projectUrl(`/plans/${state.plan.id}/versions/${state.version}/checks?model_id=${modelId}`));
    if (checksToken !== token || state.dirty) return;
    viewer.setChecks(checks);
    set({ checks });
  } catch (err) {
    if (checksToken !== token || state.dirty) return;
    $('#checks-summary').textContent = `The flight checks could not run: ${errorText(err)}`;
  }
}

function renderChecks() {
  const c = state.checks;
  if (!c) return;
  const unsafe = c.unsafe_frames.length + c.unsafe_segments.length;
  const time = c.total_time_s !== null ? `, ${(c.total_time_s / 60).toFixed(1)} min of flight` : '';
  $('#checks-summary').textContent = (c.ok ? 'The plan can be flown' : `${c.violations.length} violation(s)`)
    + ` — safety distance ${c.safety_distance_m} m, VLOS radius ${c.vlos_radius_m ?? '—'} m${time}; `
    + `least clearance ${formatNumber(Math.min(...c.clearance_m.filter((x) => x !== null)), 3)} m`
    + (unsafe ? `; ${c.unsafe_frames.length} frame(s) and ${c.unsafe_segments.length} segment(s) too close (red)` : '')
    + (c.ground ? `. Ground z ${formatNumber(c.ground.level_m, 2)} m (${c.ground.source})` : '')
    + (c.position_error_m && c.position_error_m.length
      ? `; checked at ±${c.position_error_m[0]} m horizontal, ±${c.position_error_m[1]} m vertical position error` : '')
    + (c.trajectory && c.trajectory.length ? '; take-off and return drawn green and amber' : '');
  const yes = (v) => (v === null ? '—' : v ? 'ok' : 'NO');
  $('#missions-table tbody').replaceChildren(...c.missions.map((m) => el('tr', {},
    el('td', {}, m.name), el('td', {}, `${m.frames[0]}–${m.frames[1] - 1}`),
    el('td', {}, m.ground_station.slice(0, 2).map((v) => v.toFixed(0)).join(', ')),
    el('td', {}, m.time_s === null ? '—' : `${(m.time_s / 60).toFixed(1)} min`),
    el('td', {}, m.distance_m === null ? '—' : (m.distance_m / 1000).toFixed(2)),
    ...[m.battery_ok, m.line_of_sight_ok, m.safety_ok, m.altitude_ok].map((v) => el('td', { class: v === false ? 'bad' : '' }, yes(v))))));
  $('#violations').replaceChildren(...c.violations.slice(0, 200).map((text) => {
    const m = /waypoints? (\d+)/.exec(text);
    return el('li', { onclick: () => m && selectFrame(Number(m[1]), { scroll: true }) }, text);
  }));
}

// ---------------------------------------------------------------------------------------------- exports
async function exportPlan(format) {
  if (!state.plan) throw new Error('create or choose a plan first');
  if (state.dirty) throw new Error('the plan is edited: save it first (exports are of saved versions)');
  const q = new URLSearchParams({ format, speed: $('#export-speed').value || '5' });
  if ($('#export-mission').value) q.set('mission', $('#export-mission').value);
  if (format === 'wpml' && $('#export-aircraft').value) q.set('aircraft', $('#export-aircraft').value);
  if (state.model && state.model.status === 'ready') q.set('model_id', String(state.model.id));
  const url = (force) => projectUrl(`/plans/${state.plan.id}/versions/${state.version}/export?${q}${force ? '&force=true' : ''}`);
  let file;
  try {
    file = await api.download(url(false));
  } catch (err) {
    if (!(err.status === 409 && err.violations)) throw err;
    if (!(await confirmForce(format, err.violations))) {
      showMessage(`Not exported: the plan fails ${err.violations.length} flight check(s).`, 'info');
      return;
    }
    file = await api.download(url(true));
    showMessage(`Exported ${file.name} despite ${err.violations.length} flight-check violation(s): fly it only `
      + 'after checking them on site.', 'error');
    return;
  }
  showMessage(`Downloaded ${file.name} (${(file.size / 1024).toFixed(1)} kB).`, 'ok');
}

// the violations that refused an export, and the choice to export anyway: true when chosen
function confirmForce(format, violations) {
  const dialog = $('#force-dialog');
  $('#force-summary').textContent = `The ${format} export was refused: ${violations.length} violation(s).`;
  $('#force-violations').replaceChildren(...violations.slice(0, 50).map((v) => el('li', {}, v)),
    ...(violations.length > 50 ? [el('li', {}, `… and ${violations.length - 50} more`)] : []));
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => resolve(dialog.returnValue === 'force'), { once: true });
    dialog.returnValue = '';
    dialog.showModal();
    $('#force-cancel').focus();
  });
}

export function bindPlans() {
  subscribe(['plans', 'plan', 'version'], renderPlans);
  subscribe(['saved', 'draft', 'dirty'], renderPlanSummary);
  subscribe(['draft'], renderExportMissions);
  subscribe(['checks'], renderChecks);
  $('#plan-upload').addEventListener('click', () => act('Uploading the plan', uploadPlan));
  $('#plan-select').addEventListener('change', (ev) => act('Opening the plan', () => selectPlan(Number(ev.target.value))));
  $('#version-select').addEventListener('change', (ev) => act('Opening the version', () => loadVersion(Number(ev.target.value))));
  $('#export-wpml').addEventListener('click', () => act('Exporting for DJI Pilot 2', () => exportPlan('wpml')));
  $('#export-qgc').addEventListener('click', () => act('Exporting for QGroundControl', () => exportPlan('qgc')));
  subscribe(['info'], () => {  // the formats the server writes, besides the two with buttons of their own
    const help = (state.info && state.info.export_format_help) || {};
    fillSelect($('#export-other'), [['', 'other…'], ...Object.entries(help)
      .filter(([name]) => name !== 'wpml' && name !== 'qgc').map(([name, what]) => [name, `${name}: ${what}`])], '');
  });
  $('#export-other').addEventListener('change', (ev) => {
    const fmt = ev.target.value;
    ev.target.value = '';
    if (fmt) act(`Exporting as ${fmt}`, () => exportPlan(fmt));
  });
}
