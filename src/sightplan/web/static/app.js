// sightplan's web page: projects, model upload, plans from templates, frame editing, evaluation with live progress,
// feedback coloured by metric, simulated views, comparisons and flight-app exports, on top of the REST API.
import * as api from './api.js';
import { drawHistogram, drawStability, formatNumber } from './charts.js';
import {
  Colourer, IN_PROGRESS, MISSION_PALETTE, NEUTRAL_OCCLUDER, NEUTRAL_TARGET, NOT_YET, STABLE, UNSTABLE, rgbCss,
} from './colours.js';
import { clonePlan, copyFrame, deleteFrame, headingPitch, moveFrame, planGeometry, turnFrame } from './planedit.js';
import { Viewer, parseGeometry } from './viewer3d.js';

const $ = (sel) => document.querySelector(sel);
const $$ = (sel) => [...document.querySelectorAll(sel)];
const el = (tag, attrs = {}, ...children) => {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else if (v !== undefined && v !== null && v !== false) node.setAttribute(k, v === true ? '' : v);
  }
  node.append(...children.filter((c) => c !== null && c !== undefined));
  return node;
};

// ---------------------------------------------------------------------------------------------- state
const S = {
  info: null, cameras: [], projects: [], project: null,
  models: [], model: null, elements: null, geometryModel: null,
  plans: [], plan: null, version: null, saved: null, draft: null, dirty: false, geom: null, checks: null,
  evaluations: [], evaluation: null, feedback: null, colourer: null,
  metric: 'visibility', bounds: {}, selectedFrame: null, selectedElement: null,
  schedules: [], dateStates: null, jobs: new Map(), fitted: null,
};
const METRIC_COLUMNS = [
  ['VC_pct', 'VC', '%', 2, true], ['VC_bar_pct', 'V̄C', '%', 2, true], ['VR', 'VR', 'frames', 2, true],
  ['R_m_per_px', 'R', 'm/px', 4, false], ['O_deg', 'O', '°', 2, false], ['T', 'T', 'features', 1, true],
  ['stable_frames_pct', 'stable', '%', 1, true],
];
const projectUrl = (path = '') => `/api/projects/${S.project.id}${path}`;
let viewer = null;

// ---------------------------------------------------------------------------------------------- messages
function showMessage(text, kind = 'info') {
  const box = $('#messages');
  const close = el('button', { type: 'button', title: 'close', onclick: () => msg.remove() }, '×');
  const msg = el('div', { class: `msg ${kind}`, role: kind === 'error' ? 'alert' : 'status' }, text, close);
  box.append(msg);
  while (box.children.length > 5) box.firstChild.remove();
  if (kind !== 'error') setTimeout(() => msg.remove(), 5000);
  return msg;
}

const errorText = (err) => (err && (err.detail || err.message)) || String(err);

// run a user action: any failure becomes one readable message
async function act(what, fn) {
  try {
    return await fn();
  } catch (err) {
    console.error(what, err);
    showMessage(`${what}: ${errorText(err)}`, 'error');
    return undefined;
  }
}

function setProgress(box, fraction, label) {
  box.hidden = false;
  const pct = Math.max(0, Math.min(100, Math.round(fraction * 100)));
  box.setAttribute('aria-valuenow', String(pct));
  box.querySelector('.bar').style.width = `${pct}%`;
  box.querySelector('.label').textContent = label ?? `${pct} %`;
  box.classList.remove('failed');
}

// ---------------------------------------------------------------------------------------------- start
async function init() {
  viewer = new Viewer($('#canvas-box'), { onClick: onViewClick });
  viewer.setCompass($('#compass'));
  window.sightplan = { state: S, viewer, selectFrame, selectElement, elementColour: (e) => viewer.elementAppearance(e) };
  api.setUnauthorizedHandler(() => {
    if (!$('#login-dialog').open) $('#login-dialog').showModal();
  });
  bindUi();
  await act('Reading the server information', async () => {
    S.info = await api.get('/api/info');
    const badge = $('#mode-badge');
    if (S.info.login) {
      badge.textContent = 'team mode';
      badge.classList.add('team');
      try {
        const me = await api.get('/api/auth/me');
        badge.textContent = `team · ${me.username}`;
      } catch {
        // the login dialog is open
      }
    } else {
      badge.textContent = 'single-user · no login';
    }
    badge.title = S.info.message;
    S.cameras = await api.get('/api/cameras');
    fillSelect($('#plan-camera'), S.cameras.map((c) => [c.id, `${c.name} (${c.width}×${c.height})`]), 'p4p');
  });
  await loadProjects(Number(localStorage.getItem('sightplan.project')) || null);
  document.body.dataset.state = 'ready';
}

function fillSelect(select, options, value) {
  select.replaceChildren(...options.map(([v, label]) => el('option', { value: String(v) }, label)));
  if (value !== undefined && value !== null && options.some(([v]) => String(v) === String(value))) {
    select.value = String(value);
  }
}

// ---------------------------------------------------------------------------------------------- projects
async function loadProjects(wanted) {
  await act('Listing the projects', async () => {
    S.projects = await api.get('/api/projects');
    const id = S.projects.some((p) => p.id === wanted) ? wanted : S.projects.length ? S.projects.at(-1).id : null;
    fillSelect($('#project-select'), S.projects.map((p) => [p.id, p.name]), id);
    if (id !== null) await selectProject(id);
    else $('#view-empty').textContent = 'Create a project (top bar), then upload an IFC model or a mesh.';
  });
}

async function selectProject(id) {
  S.project = S.projects.find((p) => p.id === id) || null;
  localStorage.setItem('sightplan.project', String(id));
  Object.assign(S, { models: [], model: null, elements: null, plans: [], plan: null, version: null, saved: null,
    draft: null, dirty: false, geom: null, checks: null, evaluations: [], evaluation: null, feedback: null,
    colourer: null, selectedFrame: null, selectedElement: null, dateStates: null, fitted: null });
  viewer.clearModel();
  viewer.clearPlan();
  S.geometryModel = null;
  delete document.body.dataset.model;
  resetPanels();
  if (!S.project) return;
  const [models, plans, evaluations, jobs] = await Promise.all([
    api.get(projectUrl('/models')), api.get(projectUrl('/plans')), api.get(projectUrl('/evaluations')),
    api.get(`/api/jobs?project_id=${id}`)]);
  Object.assign(S, { models, plans, evaluations });
  renderModels();
  renderPlans();
  renderEvaluations();
  // background work a previous page (or another client) started: show it again
  for (const job of jobs.reverse()) if (job.status === 'queued' || job.status === 'running') trackJob(job);
  const storedModel = Number(localStorage.getItem(`sightplan.${id}.model`));
  const model = models.find((m) => m.id === storedModel) || models.filter((m) => m.status === 'ready').at(-1)
    || models.at(-1);
  if (model) await selectModel(model.id);
  const storedPlan = Number(localStorage.getItem(`sightplan.${id}.plan`));
  const plan = plans.find((p) => p.id === storedPlan) || plans.at(-1);
  if (plan) await selectPlan(plan.id);
  loadSchedules();
  updateEmptyHint();
}

// a project opened afresh: nothing of the previous one stays on screen
function resetPanels() {
  for (const sel of ['#load-report', '#plan-summary', '#frame-list tbody', '#missions-table tbody', '#violations',
    '#metrics-table tbody', '#compare-table tbody', '#element-info', '#frame-info', '#element-frames tbody',
    '#edit-status', '#eval-status', '#checks-summary', '#view-status']) $(sel).replaceChildren();
  for (const sel of ['#upload-progress', '#eval-progress', '#element-card', '#frame-card', '#date-panel']) $(sel).hidden = true;
  $('#frame-view').removeAttribute('src');
  $('#version-select').replaceChildren();
  $('#export-mission').replaceChildren(el('option', { value: '' }, 'all'));
  S.compareChosen = false;
  S.frameColourChosen = false;
  $('#frame-colour').value = 'mission';
  renderLegend();
  updateEditState();
  showSelection();
  renderHistogram();
  renderStability();
}

function updateEmptyHint() {
  const empty = $('#view-empty');
  if (!S.project) empty.textContent = 'Create a project (top bar) to start.';
  else if (!S.models.length) empty.textContent = 'Upload an IFC model or a mesh (left) to start.';
  else if (!S.model || S.model.status !== 'ready') empty.textContent = 'The model is being loaded…';
  else if (!S.plans.length) empty.textContent = '';
  else empty.textContent = '';
  empty.hidden = !empty.textContent;
}

// ---------------------------------------------------------------------------------------------- models
function renderModels() {
  fillSelect($('#model-select'), S.models.map((m) => [m.id, `${m.original_name}${m.status === 'ready' ? '' : ` (${m.status})`}`]),
    S.model && S.model.id);
}

async function refreshModels() {
  S.models = await api.get(projectUrl('/models'));
  renderModels();
}

async function selectModel(id) {
  const detail = await api.get(projectUrl(`/models/${id}`));
  S.model = detail;
  localStorage.setItem(`sightplan.${S.project.id}.model`, String(id));
  renderModels();
  renderLoadReport(detail);
  updateEmptyHint();
  if (detail.status !== 'ready') {
    viewer.clearModel();
    S.geometryModel = null;
    return;
  }
  if (S.geometryModel === id) return;
  const [buffer, elements] = await Promise.all([api.getBinary(projectUrl(`/models/${id}/geometry`)),
    api.get(projectUrl(`/models/${id}/elements`))]);
  S.elements = elements;
  viewer.setModel(parseGeometry(buffer));
  S.geometryModel = id;
  document.body.dataset.model = String(id);
  if (S.geom) viewer.setPlan(S.geom, frameColours(), S.dirty ? null : S.checks);
  refreshModelColours();
  viewer.fit();
  S.fitted = id;
  updateStatus();
  loadSchedules();
}

function renderLoadReport(m) {
  const dl = $('#load-report');
  const rows = [['status', m.status + (m.error ? `: ${m.error}` : '')]];
  if (m.status === 'ready') {
    const r = m.load_report || {};
    rows.push(['elements', `${m.elements} (${m.targets} targets)`], ['triangles', (m.triangles || 0).toLocaleString('en')],
      ['skipped', String(m.skipped ?? 0) + (r.skipped && r.skipped.length ? ` — ${r.skipped.slice(0, 3).map((s) => s.class || s.ifc_class || s.name || JSON.stringify(s)).join(', ')}` : '')]);
    if (r.schema) rows.push(['schema', r.schema]);
    if (r.excluded && Object.keys(r.excluded).length) {
      rows.push(['not targets', Object.entries(r.excluded).map(([k, v]) => `${k} ${v}`).join(', ')]);
    }
    rows.push(['georeferenced', m.georeferenced ? 'yes' : 'no (exports need a georeference)']);
    if (r.warnings && r.warnings.length) rows.push(['warnings', r.warnings.slice(0, 3).join('; ')]);
  }
  dl.replaceChildren(...rows.flatMap(([k, v]) => [el('dt', {}, k), el('dd', { dataset: { field: k } }, v)]));
  dl.dataset.status = m.status;
}

async function uploadModel() {
  const file = $('#model-file').files[0];
  if (!S.project) throw new Error('create or choose a project first');
  if (!file) throw new Error('choose an IFC or mesh file first');
  const form = new FormData();
  form.append('file', file);
  const bar = $('#upload-progress');
  setProgress(bar, 0, `uploading ${file.name}…`);
  let res;
  try {
    res = await api.upload(projectUrl('/models'), form, (f) => setProgress(bar, f, `uploading ${Math.round(f * 100)} %`));
  } catch (err) {
    bar.classList.add('failed');
    bar.querySelector('.label').textContent = 'upload refused';
    throw err;
  }
  $('#model-file').value = '';
  S.models.push(res.model);
  S.model = res.model;
  renderModels();
  renderLoadReport(res.model);
  setProgress(bar, 0, 'queued for tessellation');
  trackJob(res.job);
}

// ---------------------------------------------------------------------------------------------- jobs
function trackJob(job) {
  if (S.jobs.has(job.id)) return;
  const names = { evaluate: `evaluation ${job.evaluation_id}`, load_model: `model ${job.model_id}`,
    link_schedule: 'schedule', prep_reality: 'reality capture' };
  const label = el('span', {}, names[job.kind] || job.kind);
  const bar = el('div', { class: 'progress', role: 'progressbar', 'aria-valuemin': '0', 'aria-valuemax': '100' },
    el('div', { class: 'bar' }), el('span', { class: 'label' }));
  const cancel = el('button', { type: 'button', class: 'icon', title: 'cancel this job',
    onclick: () => act('Cancelling the job', () => api.post(`/api/jobs/${job.id}/cancel`)) }, '×');
  const item = el('div', { class: 'job', dataset: { job: job.id } }, label, bar, cancel);
  $('#jobs-tray').append(item);
  const entry = { job, item };
  S.jobs.set(job.id, entry);
  const update = (j) => {
    entry.job = j;
    const frac = j.progress_total > 0 ? j.progress_done / j.progress_total : 0;
    setProgress(bar, frac);
    item.title = j.message;
    if (j.kind === 'evaluate') {
      setProgress($('#eval-progress'), frac, j.status === 'queued' ? 'queued'
        : `${Math.round(j.progress_done)} of ${Math.round(j.progress_total)} frames — ${Math.round(frac * 100)} %`);
      $('#eval-status').textContent = j.message;
      $('#eval-cancel').hidden = false;
      $('#eval-cancel').dataset.job = String(j.id);
    } else if (j.kind === 'load_model') {
      setProgress($('#upload-progress'), frac, j.status === 'queued' ? 'queued for tessellation'
        : `${j.message || 'loading'} — ${Math.round(frac * 100)} %`);
    }
  };
  update(job);
  const finished = () => {
    item.remove();
    S.jobs.delete(job.id);
    if (job.kind === 'evaluate' && $('#eval-cancel').dataset.job === String(job.id)) $('#eval-cancel').hidden = true;
  };
  api.followJob(job.id, update).then(async (done) => {
    finished();
    if (done.kind === 'link_schedule') {
      showMessage(`Schedule linked: ${done.message}.`, 'ok');
      await loadSchedules();
    } else if (done.kind === 'prep_reality') {
      showMessage(`Reality capture ready: ${done.message}.`, 'ok');
    } else if (done.kind === 'evaluate') {
      $('#eval-status').textContent = `evaluation ${done.evaluation_id} done: ${done.message}`;
      setProgress($('#eval-progress'), 1, `done — ${done.message}`);
      showMessage(`Evaluation ${done.evaluation_id} is done (${done.message}).`, 'ok');
      await act('Reading the evaluation', async () => {
        await refreshEvaluations();
        if (!S.project || done.project_id !== S.project.id) return;
        await selectEvaluation(done.evaluation_id);
      });
    } else {
      setProgress($('#upload-progress'), 1, done.message);
      showMessage(`Model loaded: ${done.message}.`, 'ok');
      await act('Showing the model', async () => {
        await refreshModels();
        if (S.project && done.project_id === S.project.id) await selectModel(done.model_id);
      });
    }
  }).catch(async (err) => {
    finished();
    const box = job.kind === 'evaluate' ? $('#eval-progress') : job.kind === 'load_model' ? $('#upload-progress') : null;
    if (box) {
      box.classList.add('failed');
      box.querySelector('.label').textContent = /cancel/i.test(errorText(err)) ? 'cancelled' : 'failed';
    }
    showMessage(`${names[job.kind] || job.kind} failed: ${errorText(err)}`, 'error');
    if (job.kind === 'evaluate') await act('Listing the evaluations', refreshEvaluations);
    else if (job.kind === 'load_model') await act('Listing the models', async () => {
      await refreshModels();
      if (S.model && S.model.id === job.model_id) renderLoadReport(await api.get(projectUrl(`/models/${job.model_id}`)));
    });
  });
}

// ---------------------------------------------------------------------------------------------- plans
function renderPlans() {
  fillSelect($('#plan-select'), S.plans.map((p) => [p.id, `${p.name} — ${p.source}`]), S.plan && S.plan.id);
  if (S.plan) {
    fillSelect($('#version-select'), S.plan.versions.map((v) => [v.number, `v${v.number}`]), S.version);
  } else {
    $('#version-select').replaceChildren();
  }
}

function templateBody() {
  const template = $('#plan-template').value;
  const num = (sel) => ($(sel).value === '' ? null : Number($(sel).value));
  const list = (sel) => $(sel).value.split(/[,\s]+/).filter(Boolean).map(Number);
  if (!S.model || S.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const body = {
    model_id: S.model.id, template, name: $('#plan-name').value.trim(), camera: $('#plan-camera').value,
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
  for (const [k, v] of Object.entries(body)) if (v === null || Number.isNaN(v)) delete body[k];
  return body;
}

async function createPlan() {
  const body = templateBody();
  const button = $('#plan-create');
  button.disabled = true;
  button.textContent = 'Planning…';
  try {
    const plan = await api.post(projectUrl('/plans'), body);
    S.plans.push(plan);
    showMessage(`Plan “${plan.name}”: ${plan.versions[0].frames} frames in ${plan.versions[0].missions} mission(s).`, 'ok');
    await selectPlan(plan.id);
    $('#plan-new').open = false;
  } finally {
    button.disabled = false;
    button.textContent = 'Create plan';
  }
}

async function uploadPlan() {
  const file = $('#plan-file').files[0];
  if (!file) throw new Error('choose a plan file first');
  const form = new FormData();
  form.append('file', file);
  if (S.model && S.model.status === 'ready') form.append('model_id', String(S.model.id));
  const plan = await api.upload(projectUrl('/plans/upload'), form);
  S.plans.push(plan);
  $('#plan-file').value = '';
  showMessage(`Plan “${plan.name}” uploaded: ${plan.versions[0].frames} frames.`, 'ok');
  await selectPlan(plan.id);
}

async function selectPlan(id, version = null, { keepEvaluation = false } = {}) {
  S.plan = S.plans.find((p) => p.id === id) || null;
  if (!S.plan) return;
  localStorage.setItem(`sightplan.${S.project.id}.plan`, String(id));
  const number = version ?? S.plan.latest_version;
  renderPlans();
  await loadVersion(number, { keepEvaluation });
}

async function loadVersion(number, { keepEvaluation = false } = {}) {
  if (S.dirty) showMessage('The unsaved edits were discarded.', 'info');
  S.version = number;
  renderPlans();
  const base = projectUrl(`/plans/${S.plan.id}/versions/${number}`);
  const [json, geom] = await Promise.all([api.get(base), api.get(`${base}/geometry`)]);
  Object.assign(S, { saved: json, draft: clonePlan(json), dirty: false, geom, checks: null });
  if (S.plan.model_id && (!S.model || S.model.id !== S.plan.model_id) && S.models.some((m) => m.id === S.plan.model_id)) {
    await selectModel(S.plan.model_id);
  }
  if (S.selectedFrame !== null && S.selectedFrame >= geom.position.length) S.selectedFrame = null;
  viewer.setPlan(geom, frameColours(), null);
  if (S.fitted !== `plan${S.plan.id}`) {
    viewer.fit();
    S.fitted = `plan${S.plan.id}`;
  }
  renderPlanSummary();
  renderFrameList();
  renderExportMissions();
  updateEditState();
  loadChecks();
  if (!keepEvaluation) {
    const match = S.evaluations.filter((e) => e.status === 'done' && e.plan_id === S.plan.id && e.plan_version === number);
    if (S.evaluation && match.some((e) => e.id === S.evaluation.id)) {
      // keep it
    } else if (match.length) await selectEvaluation(match.at(-1).id, { fromPlan: true });
    else clearFeedback();
  }
  showSelection();
  updateStatus();
}

function renderPlanSummary() {
  const v = S.plan.versions.find((x) => x.number === S.version);
  const p = S.saved.parameters || {};
  const bits = [`${S.draft.frames.length} frames`, `${(S.draft.missions || []).length || 1} mission(s)`];
  if (p.template) bits.push(`template ${p.template}`);
  if (p.safety_distance_m) bits.push(`g = ${p.safety_distance_m} m`);
  if (v && v.note) bits.push(`“${v.note}”`);
  $('#plan-summary').textContent = bits.join(' · ') + (S.dirty ? ' — edited, not saved' : '');
}

function renderExportMissions() {
  const missions = (S.draft && S.draft.missions) || [];
  fillSelect($('#export-mission'), [['', 'all'], ...missions.map((m, k) => [k + 1, `${k + 1}: ${m.name}`])], '');
}

async function loadChecks() {
  const token = Symbol('checks');
  S.checksToken = token;
  $('#checks-summary').textContent = 'Checking the flight (safety distance, line of sight, altitude, battery)…';
  $('#missions-table tbody').replaceChildren();
  $('#violations').replaceChildren();
  if (!S.plan || !(S.plan.model_id || S.model)) return;
  const modelId = S.model && S.model.status === 'ready' ? S.model.id : S.plan.model_id;
  try {
    const checks = await api.get(projectUrl(`/plans/${S.plan.id}/versions/${S.version}/checks?model_id=${modelId}`));
    if (S.checksToken !== token || S.dirty) return;
    S.checks = checks;
    viewer.setChecks(checks);
    renderChecks();
    renderFrameList();
    if (S.selectedFrame !== null) renderFrameInfo();
  } catch (err) {
    if (S.checksToken !== token) return;
    $('#checks-summary').textContent = `The flight checks could not run: ${errorText(err)}`;
  }
}

function renderChecks() {
  const c = S.checks;
  if (!c) return;
  const unsafe = c.unsafe_frames.length + c.unsafe_segments.length;
  const time = c.total_time_s !== null ? `, ${(c.total_time_s / 60).toFixed(1)} min of flight` : '';
  $('#checks-summary').textContent = (c.ok ? 'The plan can be flown' : `${c.violations.length} violation(s)`)
    + ` — safety distance ${c.safety_distance_m} m, VLOS radius ${c.vlos_radius_m ?? '—'} m${time}; `
    + `least clearance ${formatNumber(Math.min(...c.clearance_m.filter((x) => x !== null)), 3)} m`
    + (unsafe ? `; ${c.unsafe_frames.length} frame(s) and ${c.unsafe_segments.length} segment(s) too close (red)` : '');
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

// ---------------------------------------------------------------------------------------------- frames
function missionOf(i) {
  const missions = S.geom ? S.geom.missions : [];
  const k = missions.findIndex((m) => i >= m.start && i < m.stop);
  return k < 0 ? null : k;
}

function feedbackMatchesPlan() {
  return Boolean(S.feedback && S.plan && !S.dirty && S.feedback.plan_id === S.plan.id
    && S.feedback.plan_version === S.version);
}

function frameColours() {
  const n = S.geom ? S.geom.position.length : 0;
  const byStability = $('#frame-colour').value === 'stability' && feedbackMatchesPlan();
  const out = new Array(n);
  for (let i = 0; i < n; i++) {
    if (byStability) out[i] = S.feedback.frames.stable[i] ? STABLE : UNSTABLE;
    else out[i] = MISSION_PALETTE[(missionOf(i) ?? 0) % MISSION_PALETTE.length];
  }
  return out;
}

function renderFrameList() {
  const tbody = $('#frame-list tbody');
  if (!S.geom) {
    tbody.replaceChildren();
    return;
  }
  const g = S.geom;
  const nu = feedbackMatchesPlan() ? S.feedback.frames.nu : null;
  const stable = nu ? S.feedback.frames.stable : null;
  const clearance = S.checks && !S.dirty ? S.checks.clearance_m : null;
  const unsafe = new Set(S.checks && !S.dirty ? S.checks.unsafe_frames : []);
  const rows = g.position.map((p, i) => {
    const R = g.rotation[i];
    const hp = headingPitch([[R[0], R[1], R[2]], [R[3], R[4], R[5]], [R[6], R[7], R[8]]]);
    const k = missionOf(i);
    return el('tr', { dataset: { frame: i }, class: i === S.selectedFrame ? 'selected' : '' },
      el('td', {}, String(i)), el('td', { class: 'text' }, g.name[i]),
      el('td', { class: 'text' }, k === null ? '—' : g.missions[k].name),
      ...p.map((v) => el('td', {}, v.toFixed(2))), el('td', {}, `${hp.heading.toFixed(1)}°`),
      el('td', {}, `${hp.pitch.toFixed(1)}°`),
      el('td', { class: unsafe.has(i) ? 'bad' : '' }, clearance ? `${formatNumber(clearance[i], 3)} m` : '—'),
      el('td', { class: stable ? (stable[i] ? 'good' : 'bad') : '' }, nu ? String(nu[i]) : '—'));
  });
  tbody.replaceChildren(...rows);
}

function selectFrame(i, { scroll = false } = {}) {
  if (!S.geom || i === null || i < 0 || i >= S.geom.position.length) return;
  S.selectedFrame = i;
  viewer.select(i);
  for (const tr of $$('#frame-list tr.selected')) tr.classList.remove('selected');
  const row = $(`#frame-list tr[data-frame="${i}"]`);
  if (row) {
    row.classList.add('selected');
    if (scroll) row.scrollIntoView({ block: 'nearest' });
  }
  renderFrameInfo();
  showFrameView();
  updateEditState();
  if (!$('[data-panel="stability"]').hidden) renderStability();
  showSelection('frame');
}

function renderFrameInfo() {
  const i = S.selectedFrame;
  if (i === null || !S.geom) return;
  const g = S.geom;
  const R = g.rotation[i];
  const hp = headingPitch([[R[0], R[1], R[2]], [R[3], R[4], R[5]], [R[6], R[7], R[8]]]);
  const k = missionOf(i);
  const rows = [
    ['frame', `${i} — ${g.name[i]}`, i], ['mission', k === null ? '—' : g.missions[k].name, k],
    ['camera', g.camera[i], g.camera[i]],
    ['position (m)', g.position[i].map((v) => v.toFixed(2)).join(', '), g.position[i]],
    ['heading', `${hp.heading.toFixed(1)}°`, hp.heading], ['pitch', `${hp.pitch.toFixed(1)}°`, hp.pitch],
  ];
  if (S.checks && !S.dirty) {
    const c = S.checks.clearance_m[i];
    rows.push(['clearance', `${formatNumber(c, 3)} m${S.checks.unsafe_frames.includes(i) ? ' — too close' : ''}`, c]);
    rows.push(['in sight of pilot', S.checks.in_sight[i] ? 'yes' : 'NO', S.checks.in_sight[i]]);
  }
  if (feedbackMatchesPlan()) {
    const f = S.feedback.frames;
    rows.push(['ν_f', `${f.nu[i]} (${f.stable[i] ? 'stable' : 'not stable'}, Λ = ${S.feedback.params.min_features})`, f.nu[i]],
      ['elements ≥ Ω px', String(f.elements_visible[i]), f.elements_visible[i]]);
  }
  if (S.dirty) rows.push(['note', 'edited: save to check and evaluate it', '']);
  $('#frame-info').replaceChildren(...rows.flatMap(([k, v, raw]) => [el('dt', {}, k),
    el('dd', { dataset: { field: k, value: JSON.stringify(raw ?? null) }, class: v.includes('NO') || v.includes('too close') ? 'bad' : '' }, v)]));
  $('#edit-frame-label').textContent = `— ${i}: ${g.name[i]}`;
}

async function showFrameView() {
  const i = S.selectedFrame;
  const img = $('#frame-view');
  const caption = $('#frame-view-caption');
  if (i === null) return;
  const token = Symbol('view');
  S.viewToken = token;
  if (S.dirty) {
    img.removeAttribute('src');
    caption.textContent = 'Save the edited plan to see the simulated view from this frame.';
    return;
  }
  let url;
  if (feedbackMatchesPlan()) {
    const q = new URLSearchParams({ metric: S.metric, width: '480' });
    if (S.metric !== 'visibility') {
      const [lo, hi] = currentBounds();
      q.set('lo', String(lo));
      q.set('hi', String(hi));
    }
    url = projectUrl(`/evaluations/${S.feedback.evaluation_id}/frames/${i}/view.png?${q}`);
    caption.textContent = `Simulated view, coloured by ${S.colourer.label(S.metric).label}.`;
  } else if (S.model && S.model.status === 'ready') {
    url = projectUrl(`/plans/${S.plan.id}/versions/${S.version}/frames/${i}/view.png?model_id=${S.model.id}&width=480`);
    caption.textContent = 'Simulated view (not evaluated yet).';
  } else return;
  try {
    const response = await api.request('GET', url, undefined, { raw: true });
    const blob = await response.blob();
    if (S.viewToken !== token) return;
    if (img.src && img.src.startsWith('blob:')) URL.revokeObjectURL(img.src);
    img.src = URL.createObjectURL(blob);
    img.dataset.frame = String(i);
    img.dataset.url = url;
    if (response.headers.get('x-sightplan-elements-seen') === '0') {
      caption.textContent += ' Nothing of the model is in view from this frame.';
    }
  } catch (err) {
    if (S.viewToken !== token) return;
    img.removeAttribute('src');
    caption.textContent = `No simulated view: ${errorText(err)}`;
  }
}

// ---------------------------------------------------------------------------------------------- editing
function updateEditState() {
  const hasFrame = S.selectedFrame !== null && S.draft;
  $('#sec-edit').classList.toggle('disabled', !hasFrame);
  $('#plan-save').disabled = !S.dirty;
  $('#plan-discard').disabled = !S.dirty;
  $('#edit-status').textContent = S.dirty ? 'Edited: save as a new version, then evaluate it.'
    : hasFrame ? '' : 'Select a frame (click a camera in the 3D view or a row of the frame list).';
  if (!hasFrame) $('#edit-frame-label').textContent = '';
}

function edited() {
  S.dirty = true;
  S.checks = null;
  S.checksToken = null;
  S.geom = planGeometry(S.draft);
  viewer.setPlan(S.geom, frameColours(), null);
  renderFrameList();
  renderPlanSummary();
  renderExportMissions();
  if (S.selectedFrame !== null) {
    viewer.select(S.selectedFrame);
    renderFrameInfo();
    showFrameView();
    const row = $(`#frame-list tr[data-frame="${S.selectedFrame}"]`);
    if (row) row.classList.add('selected');
  }
  $('#checks-summary').textContent = 'The plan is edited: save it to check the flight again.';
  $('#missions-table tbody').replaceChildren();
  $('#violations').replaceChildren();
  updateEditState();
  updateStatus();
}

function needFrame() {
  if (S.selectedFrame === null || !S.draft) throw new Error('select a frame first');
  return S.selectedFrame;
}

function move(delta) {
  const i = needFrame();
  moveFrame(S.draft, i, delta);
  edited();
}

function turn(yaw, pitch) {
  const i = needFrame();
  turnFrame(S.draft, i, yaw, pitch);
  edited();
}

async function savePlan() {
  if (!S.dirty) throw new Error('nothing to save: the plan is not edited');
  const plan = await api.put(projectUrl(`/plans/${S.plan.id}?note=${encodeURIComponent('edited in the viewer')}`), S.draft);
  const k = S.plans.findIndex((p) => p.id === plan.id);
  S.plans[k] = plan;
  S.dirty = false;
  showMessage(`Saved as version ${plan.latest_version} of “${plan.name}”.`, 'ok');
  await selectPlan(plan.id, plan.latest_version);
  if (S.selectedFrame !== null) selectFrame(S.selectedFrame);
}

// ---------------------------------------------------------------------------------------------- evaluations
function renderEvaluations() {
  const done = S.evaluations.filter((e) => e.status === 'done');
  const planName = (id) => (S.plans.find((p) => p.id === id) || { name: `plan ${id}` }).name;
  const label = (e) => `#${e.id} ${planName(e.plan_id)} v${e.plan_version} · s ${e.settings.scale}`
    + (e.metrics ? ` · VC ${formatNumber(e.metrics.VC_pct, 3)} %` : '');
  fillSelect($('#evaluation-select'), [['', '— none —'], ...done.map((e) => [e.id, label(e)])],
    S.evaluation ? S.evaluation.id : '');
  // unless the user chose: B is the evaluation shown, A the one before it (same plan first)
  let a = $('#compare-a').value;
  let b = $('#compare-b').value;
  if (!S.compareChosen && done.length) {
    const shown = S.evaluation && done.find((e) => e.id === S.evaluation.id) ? S.evaluation : done.at(-1);
    const before = done.filter((e) => e.id < shown.id);
    const prior = before.filter((e) => e.plan_id === shown.plan_id).at(-1) || before.at(-1)
      || done.find((e) => e.id !== shown.id) || shown;
    [a, b] = [prior.id, shown.id];
  }
  fillSelect($('#compare-a'), done.map((e) => [e.id, label(e)]), a);
  fillSelect($('#compare-b'), done.map((e) => [e.id, label(e)]), b);
  renderMetricsTable();
  renderCompare();
}

async function refreshEvaluations() {
  S.evaluations = await api.get(projectUrl('/evaluations'));
  renderEvaluations();
}

async function startEvaluation() {
  if (!S.plan) throw new Error('create or choose a plan first');
  if (S.dirty) throw new Error('the plan is edited: save it as a new version first, then evaluate that version');
  if (!S.model || S.model.status !== 'ready') throw new Error('the model is not loaded yet');
  const int = (sel) => Number($(sel).value);
  const settings = { scale: Number($('#eval-scale').value), engine: $('#eval-engine').value, omega: int('#eval-omega'),
    k: int('#eval-k'), min_track: int('#eval-min-track'), min_features: int('#eval-min-features') };
  const res = await api.post(projectUrl('/evaluations'), { plan_id: S.plan.id, version: S.version,
    model_id: S.model.id, settings });
  S.evaluations.push(res.evaluation);
  setProgress($('#eval-progress'), 0, 'queued');
  $('#eval-status').textContent = `evaluating ${S.plan.name} v${S.version} (${res.evaluation.progress_total} frames)…`;
  trackJob(res.job);
}

function clearFeedback() {
  S.evaluation = null;
  S.feedback = null;
  S.colourer = null;
  $('#evaluation-select').value = '';
  refreshModelColours();
  if (S.geom) viewer.setFrameColours(frameColours());
  renderLegend();
  renderMetricsTable();
  renderHistogram();
  renderStability();
}

async function selectEvaluation(id, { fromPlan = false } = {}) {
  const ev = S.evaluations.find((e) => e.id === id) || await api.get(projectUrl(`/evaluations/${id}`));
  const feedback = await api.get(projectUrl(`/evaluations/${id}/feedback`));
  S.evaluation = ev;
  S.feedback = feedback;
  S.colourer = new Colourer(feedback);
  if (!fromPlan && (!S.plan || S.plan.id !== ev.plan_id || S.version !== ev.plan_version || S.dirty)) {
    await selectPlan(ev.plan_id, ev.plan_version, { keepEvaluation: true });
  }
  if (!S.model || S.model.id !== ev.model_id) await selectModel(ev.model_id);
  $('#evaluation-select').value = String(id);
  if (!S.frameColourChosen) $('#frame-colour').value = 'stability';
  setMetric(S.metric);
  if (S.geom) viewer.setFrameColours(frameColours());
  renderFrameList();
  renderEvaluations();
  renderStability();
  if (S.selectedFrame !== null) {
    renderFrameInfo();
    showFrameView();
  }
  if (S.selectedElement !== null) await selectElement(S.selectedElement);
  updateStatus();
}

// ---------------------------------------------------------------------------------------------- colours
function currentBounds() {
  if (S.metric === 'visibility' || !S.colourer) return [null, null];
  return S.bounds[S.metric] || S.colourer.defaultBounds(S.metric);
}

function setMetric(metric) {
  S.metric = metric;
  $('#colour-by').value = metric;
  const gradient = metric !== 'visibility' && S.colourer;
  $('#bound-lo').disabled = $('#bound-hi').disabled = !gradient;
  $('#bound-reset').disabled = !gradient;
  if (gradient) {
    const [lo, hi] = currentBounds();
    $('#bound-lo').value = String(Number(lo.toPrecision(4)));
    $('#bound-hi').value = String(Number(hi.toPrecision(4)));
  } else {
    $('#bound-lo').value = '';
    $('#bound-hi').value = '';
  }
  refreshModelColours();
  renderLegend();
  renderHistogram();
  if (S.selectedFrame !== null && feedbackMatchesPlan()) showFrameView();
}

function readBounds() {
  const lo = Number($('#bound-lo').value);
  const hi = Number($('#bound-hi').value);
  if (!Number.isFinite(lo) || !Number.isFinite(hi) || $('#bound-lo').value === '' || $('#bound-hi').value === '') {
    throw new Error('the bounds must be two numbers');
  }
  if (lo >= hi) throw new Error(`the lower bound (${lo}) must be below the upper bound (${hi})`);
  S.bounds[S.metric] = [lo, hi];
  setMetric(S.metric);
}

function refreshModelColours() {
  if (!viewer.model || !S.elements) return;
  const fb = S.feedback && S.model && S.feedback.model_id === S.model.id ? S.feedback : null;
  const target = S.elements.target;
  const xray = $('#layer-xray').checked;
  const [lo, hi] = currentBounds();
  const states = $('#date-on').checked && !$('#date-panel').hidden ? S.dateStates : null;
  const metric = S.metric;
  viewer.setAppearance((e) => {
    const st = states ? states[e] : null;
    if (st === 'in_progress') return IN_PROGRESS;
    if (st === 'not_yet') return NOT_YET;
    if (fb) return S.colourer.colourOf(metric, e, lo, hi);
    return target[e] ? NEUTRAL_TARGET : NEUTRAL_OCCLUDER;
  }, (e) => {
    const st = states ? states[e] : null;
    if (st === 'not_yet') return 'ghost';
    if (!target[e]) return 'ghost';
    if (xray && fb && fb.metrics.visibility[e] === 0) return 'ghost';
    return 'solid';
  });
}

function renderLegend() {
  const legend = $('#legend');
  const swatch = (rgb, label) => el('span', { class: 'swatch' }, el('i', { style: `background:${rgbCss(rgb)}` }), label);
  if (!S.colourer) {
    legend.replaceChildren(swatch(NEUTRAL_TARGET, 'target'), swatch(NEUTRAL_OCCLUDER, 'occluder'),
      el('span', { class: 'hint' }, 'evaluate a plan to colour the model'));
    return;
  }
  const c = S.colourer;
  if (S.metric === 'visibility') {
    legend.replaceChildren(...c.label('visibility').classes.map((label, k) => swatch(c.classes[k], label)));
    return;
  }
  const meta = c.label(S.metric);
  const [lo, hi] = currentBounds();
  const stops = meta.higher_better ? [...c.stops].reverse() : c.stops;
  const bar = el('span', { class: 'gradient', style: `background:linear-gradient(to right, ${stops.map(rgbCss).join(', ')})` });
  legend.replaceChildren(`${formatNumber(lo, 3)} ${meta.unit}`, bar, `${formatNumber(hi, 3)} ${meta.unit}`,
    swatch(c.unseen, 'not seen by ≥ Ω px'), swatch(c.occluder, 'occluder'));
}

// ---------------------------------------------------------------------------------------------- tables and charts
function metricCells(metrics) {
  return METRIC_COLUMNS.map(([key, , , digits]) => {
    const v = metrics ? metrics[key] : null;
    return v === null || v === undefined ? '—' : Number(v).toFixed(digits);
  });
}

function renderMetricsTable() {
  const done = S.evaluations.filter((e) => e.status === 'done' && e.metrics);
  $('#metrics-empty').hidden = done.length > 0;
  const planName = (id) => (S.plans.find((p) => p.id === id) || { name: `plan ${id}` }).name;
  $('#metrics-table thead').replaceChildren(el('tr', {}, el('th', {}, 'plan'), el('th', {}, 'eval.'),
    el('th', {}, 'frames'), ...METRIC_COLUMNS.map(([, head, unit]) => el('th', {}, `${head} (${unit})`)),
    el('th', {}, 'visible / z'), el('th', {}, 'scale')));
  $('#metrics-table tbody').replaceChildren(...done.map((e) => el('tr', {
    dataset: { evaluation: e.id }, class: S.evaluation && S.evaluation.id === e.id ? 'current' : '',
    onclick: () => act('Showing the evaluation', () => selectEvaluation(e.id)),
  }, el('td', {}, `${planName(e.plan_id)} v${e.plan_version}`), el('td', {}, `#${e.id}`),
  el('td', {}, String(e.metrics.frames)),
  ...metricCells(e.metrics).map((v, k) => el('td', { dataset: { metric: METRIC_COLUMNS[k][0] } }, v)),
  el('td', {}, `${e.metrics.visible} / ${e.metrics.z}`), el('td', {}, String(e.settings.scale)))));
}

function renderCompare() {
  const a = S.evaluations.find((e) => String(e.id) === $('#compare-a').value);
  const b = S.evaluations.find((e) => String(e.id) === $('#compare-b').value);
  const head = $('#compare-table thead');
  const body = $('#compare-table tbody');
  if (!a || !b) {
    head.replaceChildren();
    body.replaceChildren(el('tr', {}, el('td', {}, 'Evaluate two plans (or two versions) to compare them.')));
    return;
  }
  const planName = (e) => `${(S.plans.find((p) => p.id === e.plan_id) || { name: `plan ${e.plan_id}` }).name} v${e.plan_version} (#${e.id})`;
  head.replaceChildren(el('tr', {}, el('th', {}, 'metric'), el('th', {}, `A: ${planName(a)}`),
    el('th', {}, `B: ${planName(b)}`), el('th', {}, 'B − A')));
  const rows = [...METRIC_COLUMNS, ['frames', 'frames', '', 0, null], ['visible', 'visible elements', '', 0, true]];
  body.replaceChildren(...rows.map(([key, name, unit, digits, higherBetter]) => {
    const va = a.metrics ? a.metrics[key] : null;
    const vb = b.metrics ? b.metrics[key] : null;
    const d = va !== null && vb !== null && va !== undefined && vb !== undefined ? vb - va : null;
    const tol = 0.5 * 10 ** -digits;
    const cls = d === null || higherBetter === null || Math.abs(d) < tol ? '' : (d > 0) === higherBetter ? 'good' : 'bad';
    const fmt = (v) => (v === null || v === undefined ? '—' : Number(v).toFixed(digits));
    return el('tr', { dataset: { metric: key } }, el('td', {}, `${name}${unit ? ` (${unit})` : ''}`), el('td', {}, fmt(va)),
      el('td', {}, fmt(vb)), el('td', { class: cls }, d === null ? '—' : `${d > 0 ? '+' : ''}${d.toFixed(digits)}`));
  }));
}

function renderHistogram() {
  const canvas = $('#histogram');
  if ($('[data-panel="histogram"]').hidden) return;
  const ctx = canvas.getContext('2d');
  if (!S.feedback) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.fillText('Evaluate a plan to see the distribution of the per-element metrics.', 20, 30);
    return;
  }
  const fb = S.feedback;
  const targets = fb.elements.target;
  if (S.metric === 'visibility') {
    const counts = [0, 0, 0];
    fb.metrics.visibility.forEach((v, i) => { if (targets[i] && v < 3) counts[v]++; });
    drawHistogram(canvas, { metric: 'visibility', classes: { counts, colours: S.colourer.classes.slice(0, 3),
      labels: ['visible', 'observed only', 'unseen'] } });
    return;
  }
  const [lo, hi] = currentBounds();
  const values = fb.metrics[S.metric].filter((v, i) => targets[i] && fb.metrics.visibility[i] === 0);
  const meta = S.colourer.label(S.metric);
  drawHistogram(canvas, { metric: S.metric, values, lo, hi, label: meta.label, unit: meta.unit,
    colourAt: (v) => S.colourer.gradient(S.colourer.badness(S.metric, v, lo, hi)) });
}

let stabilityChart = null;
function renderStability() {
  const canvas = $('#nu-chart');
  if ($('[data-panel="stability"]').hidden) return;
  const ctx = canvas.getContext('2d');
  if (!S.feedback) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.fillText('Evaluate a plan to see ν_f, its stable features per frame, along the path.', 20, 30);
    stabilityChart = null;
    return;
  }
  const f = S.feedback.frames;
  stabilityChart = drawStability(canvas, { nu: f.nu, stable: f.stable, lambda: S.feedback.params.min_features,
    missions: S.feedback.missions, selected: feedbackMatchesPlan() ? S.selectedFrame : null,
    colours: { stable: STABLE, unstable: UNSTABLE } });
}

function showTab(name) {
  for (const b of $$('.tabs button')) b.setAttribute('aria-selected', String(b.dataset.tab === name));
  for (const p of $$('.tab-panel')) p.hidden = p.dataset.panel !== name;
  if (name === 'histogram') renderHistogram();
  if (name === 'stability') renderStability();
}

// ---------------------------------------------------------------------------------------------- elements
async function selectElement(e) {
  S.selectedElement = e;
  const card = $('#element-card');
  const info = $('#element-info');
  const fb = S.feedback && S.model && S.feedback.model_id === S.model.id ? S.feedback : null;
  let rows;
  let frames = [];
  if (fb) {
    const d = await api.get(projectUrl(`/evaluations/${fb.evaluation_id}/elements/${e}?limit=6`));
    if (S.selectedElement !== e) return;
    const r = d.element;
    rows = [['index', r.index, r.index], ['global_id', r.global_id, r.global_id], ['name', r.name, r.name],
      ['ifc_class', r.ifc_class, r.ifc_class], ['storey', r.storey || '—', r.storey],
      ['visibility', r.visibility, r.visibility], ['VR_i', r.VR_i === null ? '—' : `${r.VR_i} frames`, r.VR_i],
      ['R_i_m_per_px', r.R_i_m_per_px === null ? '—' : `${formatNumber(r.R_i_m_per_px, 4)} m/px`, r.R_i_m_per_px],
      ['O_i_deg', r.O_i_deg === null ? '—' : `${formatNumber(r.O_i_deg, 4)}°`, r.O_i_deg],
      ['frames_observed', r.frames_observed === null ? '—' : String(r.frames_observed), r.frames_observed],
      ['pixels_total', r.pixels_total === null ? '—' : Math.round(r.pixels_total).toLocaleString('en'), r.pixels_total]];
    frames = d.best_frames;
  } else if (S.elements) {
    const t = S.elements;
    rows = [['index', e, e], ['global_id', t.global_id[e], t.global_id[e]], ['name', t.name[e], t.name[e]],
      ['ifc_class', t.ifc_class[e], t.ifc_class[e]], ['storey', t.storey[e] || '—', t.storey[e]],
      ['target', t.target[e] ? 'yes' : 'no (occluder)', t.target[e]], ['triangles', String(t.triangles[e]), t.triangles[e]],
      ['metrics', 'evaluate a plan to see them', null]];
  } else return;
  const labels = { global_id: 'GlobalId', ifc_class: 'IFC class', R_i_m_per_px: 'R_i (SSD)', O_i_deg: 'O_i',
    frames_observed: 'frames observed', pixels_total: 'pixels' };
  info.replaceChildren(...rows.flatMap(([k, v, raw]) => [el('dt', {}, labels[k] || k),
    el('dd', { dataset: { field: k, value: JSON.stringify(raw ?? null) } }, String(v))]));
  const matches = feedbackMatchesPlan();
  $('#element-frames tbody').replaceChildren(...frames.map((f) => el('tr', {
    dataset: { frame: f.frame }, title: f.counts ? 'seen by ≥ Ω px' : 'seen by fewer than Ω px',
    onclick: () => (matches ? selectFrame(f.frame, { scroll: true })
      : showMessage('Show the evaluated plan version to select its frames.', 'info')),
  }, el('td', {}, `${f.frame} ${f.name}`), el('td', {}, Math.round(f.pixels).toLocaleString('en')),
  el('td', { class: f.counts ? '' : 'bad' }, formatNumber(f.ssd_m_per_px, 3)), el('td', {}, `${f.angle_deg.toFixed(1)}°`))));
  $('#element-frames').hidden = !fb;
  card.hidden = false;
  card.dataset.element = String(e);
  showSelection('element');
}

function showSelection(which) {
  const el2 = $('#element-card');
  const fr = $('#frame-card');
  if (which === 'frame') fr.hidden = false;
  if (which === 'element') el2.hidden = false;
  if (!which) {
    el2.hidden = S.selectedElement === null;
    fr.hidden = S.selectedFrame === null;
  }
  $('#inspector-hint').hidden = !el2.hidden || !fr.hidden;
  // the latest selection on top
  if (which === 'frame') $('#inspector').prepend(fr);
  if (which === 'element') $('#inspector').prepend(el2);
}

function onViewClick(hit) {
  if (hit.frame !== undefined) selectFrame(hit.frame, { scroll: true });
  else if (hit.element !== undefined) act('Reading the element', () => selectElement(hit.element));
}

// ---------------------------------------------------------------------------------------------- the date
async function loadSchedules() {
  const panel = $('#date-panel');
  if (!S.project) {
    panel.hidden = true;
    return;
  }
  let schedules = [];
  try {
    schedules = await api.get(projectUrl('/schedules'));
  } catch {
    schedules = [];  // no schedule support on this server, or none readable: no slider
  }
  // a linked schedule of the model shown, with its first and last date
  const span = (s) => ({ ...s, start: s.start || s.first_date, finish: s.finish || s.last_date });
  S.schedules = (Array.isArray(schedules) ? schedules : []).map(span).filter((s) => s.start && s.finish
    && (s.status === undefined || s.status === 'ready') && (s.model_id === undefined || !S.model || s.model_id === S.model.id));
  panel.hidden = !S.schedules.length || !S.model;
  if (panel.hidden) {
    S.dateStates = null;
    return;
  }
  const current = $('#schedule-select').value;
  fillSelect($('#schedule-select'), S.schedules.map((s) => [s.id, s.name]), current || S.schedules[0].id);
  setDateRange();
  await applyDate();
}

const DAY = 86400000;
function setDateRange() {
  const s = S.schedules.find((x) => String(x.id) === $('#schedule-select').value) || S.schedules[0];
  const start = Date.parse(s.start.slice(0, 10));
  const finish = Date.parse(s.finish.slice(0, 10));
  const slider = $('#date-slider');
  slider.dataset.start = String(start);
  slider.max = String(Math.max(0, Math.round((finish - start) / DAY)));
  const today = Math.round((Date.now() - start) / DAY);
  slider.value = String(Math.min(Number(slider.max), Math.max(0, today)));
  updateDateLabel();
}

function dateValue() {
  const slider = $('#date-slider');
  return new Date(Number(slider.dataset.start) + Number(slider.value) * DAY).toISOString().slice(0, 10);
}

function updateDateLabel() { $('#date-label').textContent = dateValue(); }

async function applyDate() {
  if ($('#date-panel').hidden || !S.model) return;
  if (!$('#date-on').checked) {
    S.dateStates = null;
    refreshModelColours();
    return;
  }
  const date = dateValue();
  const token = Symbol('date');
  S.dateToken = token;
  try {
    const res = await api.get(projectUrl(`/models/${S.model.id}/states?date=${date}&schedule_id=${$('#schedule-select').value}`));
    if (S.dateToken !== token) return;
    S.dateStates = res.states;
    const counts = { built: 0, in_progress: 0, not_yet: 0 };
    for (const v of Object.values(res.states)) counts[v] = (counts[v] || 0) + 1;
    $('#date-label').textContent = `${res.date || date}: ${counts.built} built, ${counts.in_progress} in progress, ${counts.not_yet} not yet`;
    refreshModelColours();
  } catch (err) {
    if (err.status === 404) {
      $('#date-panel').hidden = true;
      S.dateStates = null;
      refreshModelColours();
    } else showMessage(`The site at ${date}: ${errorText(err)}`, 'error');
  }
}

// ---------------------------------------------------------------------------------------------- status and export
function updateStatus() {
  const bits = [];
  if (S.model) bits.push(`${S.model.original_name}${S.model.elements ? ` — ${S.model.elements} elements, ${(S.model.triangles || 0).toLocaleString('en')} triangles` : ''}`);
  if (S.plan && S.geom) bits.push(`${S.plan.name} v${S.version}${S.dirty ? '*' : ''}: ${S.geom.position.length} frames`);
  if (S.evaluation && S.evaluation.metrics) bits.push(`evaluation #${S.evaluation.id}: VC ${formatNumber(S.evaluation.metrics.VC_pct, 3)} %`);
  $('#view-status').textContent = bits.join(' · ');
}

async function exportPlan(format) {
  if (!S.plan) throw new Error('create or choose a plan first');
  if (S.dirty) throw new Error('the plan is edited: save it first (exports are of saved versions)');
  const q = new URLSearchParams({ format, speed: $('#export-speed').value || '5' });
  if ($('#export-mission').value) q.set('mission', $('#export-mission').value);
  if (S.model && S.model.status === 'ready') q.set('model_id', String(S.model.id));
  const file = await api.download(projectUrl(`/plans/${S.plan.id}/versions/${S.version}/export?${q}`));
  showMessage(`Downloaded ${file.name} (${(file.size / 1024).toFixed(1)} kB).`, 'ok');
}

// ---------------------------------------------------------------------------------------------- wiring
function bindUi() {
  $('#project-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating the project', async () => {
      const name = $('#project-name').value.trim();
      if (!name) throw new Error('give the project a name');
      const p = await api.post('/api/projects', { name });
      $('#project-name').value = '';
      showMessage(`Project “${p.name}” created.`, 'ok');
      await loadProjects(p.id);
    });
  });
  $('#project-select').addEventListener('change', (ev) => act('Opening the project', () => selectProject(Number(ev.target.value))));
  $('#model-upload').addEventListener('click', () => act('Uploading the model', uploadModel));
  $('#model-select').addEventListener('change', (ev) => act('Showing the model', () => selectModel(Number(ev.target.value))));
  let armed = null;
  $('#model-delete').addEventListener('click', (ev) => act('Deleting the model', async () => {
    if (!S.model) throw new Error('no model is selected');
    if (armed !== S.model.id) {
      armed = S.model.id;
      ev.target.textContent = 'delete?';
      setTimeout(() => { armed = null; ev.target.textContent = '✕'; }, 3000);
      return;
    }
    await api.del(projectUrl(`/models/${S.model.id}`));
    armed = null;
    ev.target.textContent = '✕';
    showMessage(`Model ${S.model.original_name} deleted.`, 'ok');
    await selectProject(S.project.id);
  }));
  $('#plan-template').addEventListener('change', updateTemplateFields);
  updateTemplateFields();
  $('#plan-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating the plan', createPlan);
  });
  $('#plan-upload').addEventListener('click', () => act('Uploading the plan', uploadPlan));
  $('#plan-select').addEventListener('change', (ev) => act('Opening the plan', () => selectPlan(Number(ev.target.value))));
  $('#version-select').addEventListener('change', (ev) => act('Opening the version', () => loadVersion(Number(ev.target.value))));
  for (const b of $$('[data-move]')) {
    b.addEventListener('click', () => act('Moving the frame', async () => {
      const step = Number($('#move-step').value) || 1;
      const axis = 'xyz'.indexOf(b.dataset.move[0]);
      const d = [0, 0, 0];
      d[axis] = b.dataset.move[1] === '+' ? step : -step;
      move(d);
    }));
  }
  $('#move-apply').addEventListener('click', () => act('Moving the frame', async () => {
    const d = ['#move-dx', '#move-dy', '#move-dz'].map((s) => Number($(s).value) || 0);
    if (d.every((v) => v === 0)) throw new Error('give dx, dy or dz in metres');
    move(d);
  }));
  for (const b of $$('[data-rotate]')) {
    b.addEventListener('click', () => act('Turning the frame', async () => {
      const step = Number($('#rot-step').value) || 5;
      const sign = b.dataset.rotate.endsWith('+') ? 1 : -1;
      if (b.dataset.rotate.startsWith('yaw')) turn(sign * step, 0);
      else turn(0, sign * step);
    }));
  }
  $('#frame-delete').addEventListener('click', () => act('Deleting the frame', async () => {
    const i = needFrame();
    deleteFrame(S.draft, i);
    S.selectedFrame = Math.min(i, S.draft.frames.length - 1);
    edited();
  }));
  $('#frame-copy').addEventListener('click', () => act('Copying the frame', async () => {
    const i = needFrame();
    S.selectedFrame = copyFrame(S.draft, i);
    edited();
  }));
  $('#frame-look').addEventListener('click', () => act('Looking through the frame', async () => viewer.lookThrough(needFrame())));
  $('#plan-save').addEventListener('click', () => act('Saving the plan', savePlan));
  $('#plan-discard').addEventListener('click', () => act('Discarding the edits', () => loadVersion(S.version)));
  $('#eval-start').addEventListener('click', () => act('Starting the evaluation', startEvaluation));
  $('#eval-cancel').addEventListener('click', (ev) => act('Cancelling the evaluation',
    () => api.post(`/api/jobs/${ev.target.dataset.job}/cancel`)));
  $('#evaluation-select').addEventListener('change', (ev) => act('Showing the evaluation', async () => {
    if (ev.target.value) await selectEvaluation(Number(ev.target.value));
    else clearFeedback();
  }));
  $('#colour-by').addEventListener('change', (ev) => setMetric(ev.target.value));
  for (const s of ['#bound-lo', '#bound-hi']) $(s).addEventListener('change', () => act('Setting the bounds', async () => readBounds()));
  $('#bound-reset').addEventListener('click', () => {
    delete S.bounds[S.metric];
    setMetric(S.metric);
  });
  const layers = () => viewer.setLayers({ model: $('#layer-model').checked, frustums: $('#layer-frustums').checked,
    path: $('#layer-path').checked, stations: $('#layer-stations').checked });
  for (const s of ['#layer-model', '#layer-frustums', '#layer-path', '#layer-stations']) $(s).addEventListener('change', layers);
  $('#layer-xray').addEventListener('change', refreshModelColours);
  $('#frame-colour').addEventListener('change', () => {
    S.frameColourChosen = true;
    if (S.geom) viewer.setFrameColours(frameColours());
    if ($('#frame-colour').value === 'stability' && !feedbackMatchesPlan()) {
      showMessage('Frames are coloured by ν_f once this plan version is evaluated.', 'info');
    }
  });
  $('#frame-size').addEventListener('change', (ev) => {
    viewer.frameScale = Number(ev.target.value);
    viewer.frameSize = viewer.baseFrameSize * viewer.frameScale;
    if (S.geom) {
      viewer.setPlan(S.geom, frameColours(), S.dirty ? null : S.checks);
      layers();
    }
  });
  $('#view-fit').addEventListener('click', () => viewer.fit());
  for (const b of $$('.tabs button')) b.addEventListener('click', () => showTab(b.dataset.tab));
  $('#frame-list tbody').addEventListener('click', (ev) => {
    const tr = ev.target.closest('tr');
    if (tr) selectFrame(Number(tr.dataset.frame));
  });
  $('#nu-chart').addEventListener('click', (ev) => {
    const i = stabilityChart && stabilityChart.frameAt(ev.clientX);
    if (i !== null && i !== undefined && feedbackMatchesPlan()) selectFrame(i, { scroll: true });
  });
  for (const s of ['#compare-a', '#compare-b']) {
    $(s).addEventListener('change', () => {
      S.compareChosen = true;
      renderCompare();
    });
  }
  $('#export-wpml').addEventListener('click', () => act('Exporting for DJI Pilot 2', () => exportPlan('wpml')));
  $('#export-qgc').addEventListener('click', () => act('Exporting for QGroundControl', () => exportPlan('qgc')));
  $('#export-other').addEventListener('change', (ev) => {
    const fmt = ev.target.value;
    ev.target.value = '';
    if (fmt) act(`Exporting as ${fmt}`, () => exportPlan(fmt));
  });
  $('#schedule-select').addEventListener('change', () => act('Changing the schedule', async () => {
    setDateRange();
    await applyDate();
  }));
  let dateTimer = null;
  $('#date-slider').addEventListener('input', () => {
    updateDateLabel();
    clearTimeout(dateTimer);
    dateTimer = setTimeout(() => applyDate(), 150);
  });
  $('#date-on').addEventListener('change', () => applyDate());
  $('#login-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Logging in', async () => {
      await api.post('/api/auth/login', { username: $('#login-user').value, password: $('#login-password').value });
      $('#login-dialog').close();
      window.location.reload();
    });
  });
  window.addEventListener('resize', () => {
    renderHistogram();
    renderStability();
  });
}

function updateTemplateFields() {
  const t = $('#plan-template').value;
  for (const label of $$('#plan-form [data-template]')) label.hidden = label.dataset.template !== t;
}

init().catch((err) => {
  document.body.dataset.state = 'error';
  showMessage(`The page could not start: ${errorText(err)}`, 'error');
});
