// sightplan's web page: projects, model upload, plans from templates (with points picked in the 3D view), frame
// editing, evaluation with live progress (at a capture date, with a reality capture as occluders), feedback coloured
// by metric, simulated views, comparisons and flight-app exports, 4D schedules with the date slider, reality captures,
// and in team mode the login, members, roles and share links, on top of the REST API.
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
    else if (k === 'style') node.style.cssText = v;  // through the CSSOM: the page's policy forbids style attributes
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
  schedules: [], allSchedules: [], dateStates: null, jobs: new Map(), fitted: null,
  realities: [], realityHidden: new Set(), me: null, pick: null, members: [], links: [],
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
  installTestHook();
  api.setUnauthorizedHandler(showLogin);
  bindUi();
  let loggedIn = true;
  await act('Reading the server information', async () => {
    S.info = await api.get('/api/info');
    const badge = $('#mode-badge');
    if (S.info.login) {
      badge.textContent = 'team mode';
      badge.classList.add('team');
      try {
        S.me = await api.get('/api/auth/me');
      } catch (err) {
        if (err.status !== 401) throw err;
        loggedIn = false;  // the login dialog is open
      }
    } else {
      badge.textContent = 'single-user · no login';
    }
    badge.title = S.info.message;
    renderUser();
    S.cameras = await api.get('/api/cameras');
    fillSelect($('#plan-camera'), S.cameras.map((c) => [c.id, `${c.name} (${c.width}×${c.height})`]), 'p4p');
    fillSelect($('#plan-aircraft'), [['', 'default (p4p; a walker for a route)'],
      ...Object.entries(S.info.aircraft || {}).map(([id, name]) => [id, `${name} (${id})`]),
      ['none', 'none: no battery check']], '');
  });
  if (!loggedIn) {
    document.body.dataset.state = 'login';
    return;
  }
  await loadProjects(Number(localStorage.getItem('sightplan.project')) || null);
  document.body.dataset.state = 'ready';
}

// ---------------------------------------------------------------------------------------------- test hook
// The page's test hook: window.sightplanTest, what the browser tests (tests/test_web_browser*.py) read of the page
// beyond what it shows. Read-only: named getters that return values or copies, never the store or the viewer's
// own objects (the one exception, view.viewer(), is for a test that drives the camera to time frames).
//
//   dirty()              the plan version shown has unsaved edits
//   planId(), planName(), planVersion()
//                        the plan and version shown (null without one)
//   frameCount()         frames of the plan version shown, edits included (null before one is read)
//   selectedFrame()      the frame selected (an index), or null
//   flightChecked()      the flight checks of the version shown have arrived
//   evaluationId()       the evaluation whose feedback colours the page, or null
//   evaluation()         that evaluation: { id, planId, planVersion, modelId, settings } (a copy), or null
//   siteAtDate()         the element states at the date slider's date are read (the model is shown at a date)
//   elementColour(e)     element e's look in the 3D view: { rgb: [r, g, b] (sRGB, 0–1), mode: 'solid'|'ghost'|… }
//   view.modelTriangles()          triangles of the model drawn, or null
//   view.planFrames()              frames drawn, or null
//   view.markers()                 the points drawn for the plan form: [{ points, colour, line }]
//   view.screenPoint([x, y, z])    where a model point is on screen: { x, y, inView } (client pixels)
//   view.frameScreenPoint(i), view.elementScreenPoint(e)
//                                  where frame i's centre is; a point where element e is the first thing hit (or null)
//   view.highlightedElement()      the element outlined, or null
//   view.realityInfo()             each reality capture drawn: { id, kind, shown, box, triangles, pointsVisible, … }
//   view.toViewer([x, y, z])       a model point in the viewer's frame
//   view.viewer()                  the Viewer itself
const copy = (v) => (v === undefined || v === null ? null : JSON.parse(JSON.stringify(v)));

function installTestHook() {
  const view = Object.freeze({
    modelTriangles: () => (viewer.model ? viewer.model.geo.header.triangles : null),
    planFrames: () => (viewer.plan ? viewer.plan.n : null),
    markers: () => copy(viewer.markers),
    screenPoint: (p) => viewer.screenPoint(p),
    frameScreenPoint: (i) => viewer.frameScreenPoint(i),
    elementScreenPoint: (e) => viewer.elementScreenPoint(e),
    highlightedElement: () => (viewer.highlight ? viewer.highlight.userData.element : null),
    realityInfo: () => viewer.realityInfo(),
    toViewer: (p) => viewer.toViewer(p),
    viewer: () => viewer,
  });
  window.sightplanTest = Object.freeze({
    dirty: () => S.dirty,
    planId: () => (S.plan ? S.plan.id : null),
    planName: () => (S.plan ? S.plan.name : null),
    planVersion: () => (S.plan ? S.version : null),
    frameCount: () => (S.geom ? S.geom.position.length : null),
    selectedFrame: () => S.selectedFrame,
    flightChecked: () => S.checks !== null,
    evaluationId: () => (S.evaluation && S.feedback ? S.evaluation.id : null),
    evaluation: () => {
      const e = S.feedback && S.evaluation;
      return e ? { id: e.id, planId: e.plan_id, planVersion: e.plan_version, modelId: e.model_id, settings: copy(e.settings) }
        : null;
    },
    siteAtDate: () => S.dateStates !== null,
    elementColour: (e) => viewer.elementAppearance(e),
    view,
  });
}

// ---------------------------------------------------------------------------------------------- accounts and roles
function showLogin() {
  const dialog = $('#login-dialog');
  if (dialog.open) return;
  $('#login-error').hidden = true;
  dialog.showModal();
  $('#login-user').focus();
}

async function logIn() {
  const username = $('#login-user').value.trim();
  const password = $('#login-password').value;
  if (!username || !password) {
    $('#login-error').textContent = 'Give your user name and password.';
    $('#login-error').hidden = false;
    return;
  }
  $('#login-submit').disabled = true;
  try {
    await api.post('/api/auth/login', { username, password });
  } catch (err) {
    $('#login-error').textContent = errorText(err);
    $('#login-error').hidden = false;
    return;
  } finally {
    $('#login-submit').disabled = false;
  }
  $('#login-password').value = '';
  $('#login-dialog').close();
  window.location.reload();  // everything read again, as this user
}

// the account dialog: password change and API tokens
async function openAccount() {
  $('#pw-error').hidden = true;
  $('#token-new').hidden = true;
  $('#account-dialog').showModal();
  await loadTokens();
}

async function loadTokens() {
  const tokens = await api.get('/api/auth/tokens');
  const rows = tokens.map((t) => {
    const li = el('li', { 'data-token': String(t.id) });
    const used = t.last_used_at ? `last used ${new Date(t.last_used_at).toLocaleString()}` : 'never used';
    li.append(el('span', {}, `${t.name || '(no name)'} · created ${new Date(t.created_at).toLocaleDateString()} · ${used} `));
    const revoke = el('button', { type: 'button' }, 'Revoke');
    revoke.addEventListener('click', () => act('Revoking the token', async () => {
      await api.del(`/api/auth/tokens/${t.id}`);
      await loadTokens();
    }));
    li.append(revoke);
    return li;
  });
  if (!rows.length) rows.push(el('li', { class: 'hint' }, 'No API tokens.'));
  $('#token-list').replaceChildren(...rows);
}

async function createToken() {
  const t = await api.post('/api/auth/tokens', { name: $('#token-name').value.trim() });
  $('#token-secret').value = t.token;
  $('#token-secret').dataset.token = String(t.id);
  $('#token-new').hidden = false;
  $('#token-name').value = '';
  await loadTokens();
}

async function changePassword() {
  const body = { old_password: $('#pw-old').value, new_password: $('#pw-new').value };
  try {
    await api.post('/api/auth/password', body);
  } catch (err) {
    $('#pw-error').textContent = errorText(err);
    $('#pw-error').hidden = false;
    return;
  }
  $('#pw-old').value = '';
  $('#pw-new').value = '';
  $('#account-dialog').close();
  window.location.reload();  // the sessions ended: log in again with the new password
}

async function logOut() {
  await api.post('/api/auth/logout');
  S.me = null;
  window.location.reload();
}

// in team mode: who is logged in, and their role in the project shown
function renderUser() {
  const box = $('#user-box');
  box.hidden = !(S.info && S.info.login && S.me);
  if (box.hidden) return;
  $('#user-name').textContent = S.me.username;
  const role = projectRole();
  $('#user-role').textContent = role || 'no project';
  $('#user-role').dataset.role = role || '';
}

// the user's role in the project shown; null in single-user mode, where everyone may do everything
function projectRole() {
  if (!S.info || !S.info.login || !S.project) return null;
  return S.project.role || (S.me && S.me.projects && S.me.projects[S.project.id]) || null;
}

const canEdit = () => !(S.info && S.info.login) || ['editor', 'owner'].includes(projectRole());
const isOwner = () => !(S.info && S.info.login) || projectRole() === 'owner';

// a viewer is not offered what the server would refuse: controls disabled, editing panels hidden
function applyRole() {
  const allowed = { editor: canEdit(), owner: isOwner() };
  document.body.dataset.role = projectRole() || (S.info && S.info.login ? 'none' : 'single-user');
  for (const node of $$('[data-needs]')) {
    const ok = allowed[node.dataset.needs];
    if (node.matches('button, input, select, textarea')) {
      if (node.dataset.title === undefined) node.dataset.title = node.title;
      node.disabled = !ok;
      node.title = ok ? node.dataset.title : `your role in this project (${projectRole()}) cannot do this`;
    } else node.hidden = !ok;
  }
  if (!allowed.editor) stopPicking();
  renderUser();
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
    else {
      S.project = null;
      applyRole();
      loadMembers();
      $('#view-empty').textContent = 'Create a project (top bar), then upload an IFC model or a mesh.';
    }
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
  viewer.clearRealities();
  S.geometryModel = null;
  S.realities = [];
  S.realityHidden = new Set();
  S.allSchedules = [];
  S.schedules = [];
  delete document.body.dataset.model;
  resetPanels();
  applyRole();
  if (!S.project) return;
  const [models, plans, evaluations, jobs] = await Promise.all([
    api.get(projectUrl('/models')), api.get(projectUrl('/plans')), api.get(projectUrl('/evaluations')),
    api.get(`/api/jobs?project_id=${id}`)]);
  Object.assign(S, { models, plans, evaluations });
  renderModels();
  renderPlans();
  renderEvaluations();
  loadRealities();
  loadMembers();
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
  for (const sel of ['#upload-progress', '#eval-progress', '#element-card', '#frame-card', '#date-panel',
    '#schedule-progress', '#schedule-report', '#reality-progress', '#share-new']) $(sel).hidden = true;
  for (const sel of ['#schedule-list', '#reality-list', '#share-links', '#members-table tbody', '#eval-site']) {
    $(sel).replaceChildren();
  }
  fillSelect($('#eval-reality'), [['', 'none']], '');
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
  if (S.selectedElement !== null) viewer.highlightElement(S.selectedElement);
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
    } else if (j.kind === 'link_schedule') {
      setProgress($('#schedule-progress'), frac, j.status === 'queued' ? 'queued for linking'
        : `${j.message || 'linking'} — ${Math.round(frac * 100)} %`);
    } else if (j.kind === 'prep_reality') {
      setProgress($('#reality-progress'), frac, j.status === 'queued' ? 'queued for preparation'
        : `${j.message || 'preparing'} — ${Math.round(frac * 100)} %`);
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
      setProgress($('#schedule-progress'), 1, done.message);
      showMessage(`Schedule linked: ${done.message}.`, 'ok');
      await act('Reading the schedule', async () => {
        if (!S.project || done.project_id !== S.project.id) return;
        await loadSchedules({ prefer: done.schedule_id });
        await showScheduleReport(done.schedule_id);
      });
    } else if (done.kind === 'prep_reality') {
      setProgress($('#reality-progress'), 1, `ready — ${done.message}`);
      showMessage(`Reality capture ready: ${done.message}.`, 'ok');
      await act('Showing the reality capture', async () => {
        if (S.project && done.project_id === S.project.id) await loadRealities();
      });
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
    const box = { evaluate: $('#eval-progress'), load_model: $('#upload-progress'), link_schedule: $('#schedule-progress'),
      prep_reality: $('#reality-progress') }[job.kind];
    if (box) {
      box.classList.add('failed');
      box.querySelector('.label').textContent = /cancel/i.test(errorText(err)) ? 'cancelled' : 'failed';
    }
    showMessage(`${names[job.kind] || job.kind} failed: ${errorText(err)}`, 'error');
    if (job.kind === 'evaluate') await act('Listing the evaluations', refreshEvaluations);
    else if (job.kind === 'link_schedule') await act('Listing the schedules', async () => {
      await loadSchedules();
      if (job.schedule_id) await showScheduleReport(job.schedule_id);
    });
    else if (job.kind === 'prep_reality') await act('Listing the reality captures', loadRealities);
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

// ---------------------------------------------------------------------------------------------- points picked in 3D
const PICK = {
  axis: { field: '#plan-axis', button: '#pick-axis', what: 'an axis point', colour: 0xe67e22, line: true },
  points: { field: '#plan-points', button: '#pick-points', what: 'a route point', colour: 0x8e44ad, line: true },
  stations: { field: '#plan-stations', button: '#pick-stations', what: 'a ground station', colour: 0x0b7a3e, line: false },
};

function startPicking(kind) {
  if (S.pick === kind) {
    stopPicking();
    return;
  }
  stopPicking();
  if (!viewer.model) throw new Error('pick points once the model is shown');
  S.pick = kind;
  const b = $(PICK[kind].button);
  b.classList.add('active');
  b.textContent = 'done picking';
  document.body.dataset.picking = kind;
  $('#view-status').textContent = `Click the model or the ground to add ${PICK[kind].what} (Esc or “done picking” to stop).`;
}

function stopPicking() {
  if (!S.pick) return;
  const b = $(PICK[S.pick].button);
  b.classList.remove('active');
  b.textContent = 'pick in 3D';
  S.pick = null;
  delete document.body.dataset.picking;
  updateStatus();
}

function addPickedPoint(ev) {
  const hit = viewer.pickPoint(ev.clientX, ev.clientY);
  if (!hit) {
    showMessage('Nothing there: click the model or the ground.', 'info');
    return;
  }
  const [x, y, z] = hit.point;
  let coords;
  if (S.pick === 'axis') coords = [x, y];
  else if (S.pick === 'points') coords = [x, y, z + (Number($('#plan-route-eye').value) || 0)];
  else coords = [x, y, z];
  const field = $(PICK[S.pick].field);
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
  $('#share-new').hidden = true;
  $('#share-url').value = '';
  act('Listing the share links', loadLinks);
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
// where an evaluation ran: at a capture date, with a reality capture as occluders ('' for the model as built)
function siteLabel(e) {
  const s = e.settings || {};
  const bits = [];
  if (s.fourd && s.fourd.date) bits.push(` at ${s.fourd.date}`);
  if (s.reality_id) {
    const r = S.realities.find((x) => x.id === s.reality_id);
    bits.push(` + ${r ? r.name : `capture ${s.reality_id}`}`);
  }
  return bits.join('');
}

function renderEvaluations() {
  const done = S.evaluations.filter((e) => e.status === 'done');
  const planName = (id) => (S.plans.find((p) => p.id === id) || { name: `plan ${id}` }).name;
  const label = (e) => `#${e.id} ${planName(e.plan_id)} v${e.plan_version}${siteLabel(e)} · s ${e.settings.scale}`
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
  const site = evalSite();
  const res = await api.post(projectUrl('/evaluations'), { plan_id: S.plan.id, version: S.version,
    model_id: S.model.id, settings, ...site });
  S.evaluations.push(res.evaluation);
  setProgress($('#eval-progress'), 0, 'queued');
  $('#eval-status').textContent = `evaluating ${S.plan.name} v${S.version}${siteLabel(res.evaluation)} `
    + `(${res.evaluation.progress_total} frames)…`;
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
    el('th', {}, 'visible / z'), el('th', {}, 'scale'), el('th', {}, 'site')));
  $('#metrics-table tbody').replaceChildren(...done.map((e) => el('tr', {
    dataset: { evaluation: e.id }, class: S.evaluation && S.evaluation.id === e.id ? 'current' : '',
    onclick: () => act('Showing the evaluation', () => selectEvaluation(e.id)),
  }, el('td', {}, `${planName(e.plan_id)} v${e.plan_version}`), el('td', {}, `#${e.id}`),
  el('td', {}, String(e.metrics.frames)),
  ...metricCells(e.metrics).map((v, k) => el('td', { dataset: { metric: METRIC_COLUMNS[k][0] } }, v)),
  el('td', {}, `${e.metrics.visible} / ${e.metrics.z}`), el('td', {}, String(e.settings.scale)),
  el('td', { class: 'text', dataset: { site: siteLabel(e).trim() } }, siteLabel(e).trim() || 'as built'))));
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
  viewer.highlightElement(e);
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

function onViewClick(hit, ev) {
  if (S.pick) addPickedPoint(ev);
  else if (hit.frame !== undefined) selectFrame(hit.frame, { scroll: true });
  else if (hit.element !== undefined) act('Reading the element', () => selectElement(hit.element));
}

// ---------------------------------------------------------------------------------------------- the date
async function loadSchedules({ prefer = null } = {}) {
  const panel = $('#date-panel');
  if (!S.project) {
    panel.hidden = true;
    return;
  }
  const token = Symbol('schedules');
  S.schedulesToken = token;
  let schedules = [];
  try {
    schedules = await api.get(projectUrl('/schedules'));
  } catch {
    schedules = [];  // no schedule support on this server, or none readable: no slider
  }
  if (S.schedulesToken !== token) return;
  const ofModel = (s) => s.model_id === undefined || !S.model || s.model_id === S.model.id;
  S.allSchedules = (Array.isArray(schedules) ? schedules : []).filter(ofModel);
  renderScheduleList();
  // a linked schedule of the model shown, with its first and last date
  const span = (s) => ({ ...s, start: s.start || s.first_date, finish: s.finish || s.last_date });
  S.schedules = S.allSchedules.map(span).filter((s) => s.start && s.finish
    && (s.status === undefined || s.status === 'ready'));
  panel.hidden = !S.schedules.length || !S.model;
  if (panel.hidden) {
    S.dateStates = null;
    refreshModelColours();
    updateEvalSite();
    return;
  }
  const current = $('#schedule-select').value;
  const pick = [prefer, current].find((v) => v !== null && v !== '' && S.schedules.some((x) => String(x.id) === String(v)));
  fillSelect($('#schedule-select'), S.schedules.map((s) => [s.id, s.name]), pick ?? S.schedules.at(-1).id);
  if (pick === undefined || prefer !== null || String(pick) !== current) setDateRange();
  await applyDate();
}

function renderScheduleList() {
  const items = S.allSchedules.map((s) => {
    const state = s.status === 'ready' ? (s.first_date ? `${s.first_date} → ${s.last_date}` : 'no element dated')
      : s.status === 'failed' ? `failed: ${s.error || ''}` : `${s.status}…`;
    const remove = el('button', { type: 'button', class: 'icon', title: 'delete this schedule', 'data-needs': 'editor',
      disabled: !canEdit(), onclick: () => act('Deleting the schedule', async () => {
        await api.del(projectUrl(`/schedules/${s.id}`));
        showMessage(`Schedule ${s.name} deleted.`, 'ok');
        $('#schedule-report').hidden = true;
        await loadSchedules();
      }) }, '✕');
    return el('li', { dataset: { schedule: s.id, status: s.status }, class: s.status === 'failed' ? 'failed' : '' },
      el('a', { href: '#', title: 'show the link report', onclick: (ev) => {
        ev.preventDefault();
        act('Reading the link report', () => showScheduleReport(s.id));
      } }, s.name), el('span', { class: 'hint' }, ` ${state}`), remove);
  });
  $('#schedule-list').replaceChildren(...items);
  if (!items.length && S.model) {
    $('#schedule-list').append(el('li', { class: 'hint' }, canEdit() ? 'No schedule: add one to see the site at a date.'
      : 'No schedule is linked to this model.'));
  }
}

// the link report of a schedule (as sightplan evaluate --schedule prints it), or why it failed
async function showScheduleReport(id) {
  const s = await api.get(projectUrl(`/schedules/${id}`));
  const box = $('#schedule-report');
  box.hidden = false;
  box.dataset.schedule = String(s.id);
  box.dataset.status = s.status;
  box.classList.toggle('failed', s.status === 'failed');
  $('#schedule-report-title').textContent = s.status === 'failed' ? `${s.name}: linking failed` : `Link report: ${s.name}`;
  $('#schedule-report-lines').textContent = s.status === 'failed' ? (s.error || 'failed')
    : ((s.report && s.report.lines) || []).join('\n') || s.status;
}

async function addSchedule() {
  if (!S.model || S.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const own = $('#schedule-own').checked;
  const file = $('#schedule-file').files[0];
  if (!own && !file) throw new Error('choose a schedule file (MS Project .xml, Primavera .xer, .csv, .ifc), or use the model’s own');
  const form = new FormData();
  form.append('model_id', String(S.model.id));
  if (!own) form.append('file', file);
  const rules = $('#schedule-rules').files[0];
  if (rules) form.append('rules', rules);
  form.append('prefer_actual', $('#schedule-actual').checked ? 'true' : 'false');
  const bar = $('#schedule-progress');
  setProgress(bar, 0, own ? 'asking for the model’s work schedule…' : `uploading ${file.name}…`);
  $('#schedule-report').hidden = true;
  let res;
  try {
    res = await api.upload(projectUrl('/schedules'), form, (f) => setProgress(bar, f, `uploading ${Math.round(f * 100)} %`));
  } catch (err) {
    bar.classList.add('failed');
    bar.querySelector('.label').textContent = 'refused';
    throw err;
  }
  for (const sel of ['#schedule-file', '#schedule-rules']) $(sel).value = '';
  $('#schedule-new').open = false;
  setProgress(bar, 0, 'queued for linking');
  await loadSchedules();
  trackJob(res.job);
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

function updateDateLabel() {
  $('#date-label').textContent = dateValue();
  updateEvalSite();
}

const scheduleShown = () => !$('#date-panel').hidden && $('#date-on').checked && S.schedules.length > 0;

async function applyDate() {
  if ($('#date-panel').hidden || !S.model) return;
  updateEvalSite();
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
    let counts = res.counts;
    if (!counts) {
      counts = { built: 0, in_progress: 0, not_yet: 0 };
      for (const v of Object.values(res.states)) counts[v] = (counts[v] || 0) + 1;
    }
    const label = $('#date-label');
    label.textContent = `${res.date || date}: ${counts.built} built, ${counts.in_progress} in progress, ${counts.not_yet} not yet`;
    Object.assign(label.dataset, { date: res.date || date, built: counts.built, inProgress: counts.in_progress,
      notYet: counts.not_yet });
    refreshModelColours();
  } catch (err) {
    if (err.status === 404) {
      $('#date-panel').hidden = true;
      S.dateStates = null;
      refreshModelColours();
    } else showMessage(`The site at ${date}: ${errorText(err)}`, 'error');
  }
}

// the site an evaluation will run on: a capture date (typed, else the slider's) and a reality capture
function evalSite() {
  const typed = $('#eval-date').value;
  const shown = scheduleShown();
  const site = {};
  if (typed || shown) {
    site.date = typed || dateValue();
    if (shown) site.schedule_id = Number($('#schedule-select').value);
  }
  if ($('#eval-reality').value) site.reality_id = Number($('#eval-reality').value);
  return site;
}

function updateEvalSite() {
  const site = evalSite();
  const bits = [];
  if (site.date) {
    const sched = S.schedules.find((x) => x.id === site.schedule_id);
    bits.push(`at ${site.date}${sched ? ` (schedule ${sched.name})` : ''}`);
  }
  if (site.reality_id) {
    const r = S.realities.find((x) => x.id === site.reality_id);
    bits.push(`with ${r ? r.name : `capture ${site.reality_id}`} as occluders`);
  }
  $('#eval-site').textContent = bits.length ? `Evaluates the site ${bits.join(', ')}.` : '';
  $('#eval-site').dataset.date = site.date || '';
}

// ---------------------------------------------------------------------------------------------- reality captures
async function loadRealities() {
  if (!S.project) return;
  const project = S.project.id;
  const rows = await api.get(projectUrl('/reality'));
  if (!S.project || S.project.id !== project) return;
  S.realities = rows;
  for (const id of [...viewer.realities.keys()]) if (!rows.some((r) => r.id === id && r.status === 'ready')) viewer.removeReality(id);
  renderRealityList();
  const ready = rows.filter((r) => r.status === 'ready');
  fillSelect($('#eval-reality'), [['', 'none'], ...ready.map((r) => [r.id, `${r.name} (${r.kind})`])], $('#eval-reality').value);
  updateEvalSite();
  for (const r of rows) {
    if (r.status !== 'ready' || !r.view_url) continue;
    viewer.addReality(r, !S.realityHidden.has(r.id)).catch((err) => {
      showMessage(`The reality capture ${r.name} cannot be shown: ${errorText(err)}`, 'error');
    });
  }
}

function renderRealityList() {
  const items = S.realities.map((r) => {
    const size = r.kind === 'points' ? `${(r.points || 0).toLocaleString('en')} points`
      : `${(r.triangles || 0).toLocaleString('en')} triangles`;
    const state = r.status === 'ready' ? size : r.status === 'failed' ? `failed: ${r.error || ''}` : `${r.status}…`;
    const toggle = el('input', { type: 'checkbox', 'aria-label': `show ${r.name}`, checked: !S.realityHidden.has(r.id),
      disabled: r.status !== 'ready', onchange: (ev) => {
        if (ev.target.checked) S.realityHidden.delete(r.id);
        else S.realityHidden.add(r.id);
        viewer.setRealityVisible(r.id, ev.target.checked);
      } });
    const remove = el('button', { type: 'button', class: 'icon', title: 'delete this capture', 'data-needs': 'editor',
      disabled: !canEdit(), onclick: () => act('Deleting the reality capture', async () => {
        await api.del(projectUrl(`/reality/${r.id}`));
        viewer.removeReality(r.id);
        showMessage(`Reality capture ${r.name} deleted.`, 'ok');
        await loadRealities();
      }) }, '✕');
    return el('li', { dataset: { reality: r.id, kind: r.kind, status: r.status }, class: r.status === 'failed' ? 'failed' : '' },
      el('label', { class: 'check' }, toggle, ` ${r.name}`), el('span', { class: 'hint' }, ` ${r.kind} · ${state}`), remove);
  });
  $('#reality-list').replaceChildren(...items);
  if (!items.length) {
    $('#reality-list').append(el('li', { class: 'hint' }, 'No capture of the site yet'
      + (canEdit() ? ': upload a point cloud or a mesh in the model’s frame.' : '.')));
  }
}

async function uploadReality() {
  if (!S.project) throw new Error('create or choose a project first');
  const file = $('#reality-file').files[0];
  if (!file) throw new Error('choose a point cloud (.las, .laz, .ply) or a mesh (.obj, .ply, .stl, .gltf, .glb) first');
  const form = new FormData();
  form.append('file', file);
  const bar = $('#reality-progress');
  setProgress(bar, 0, `uploading ${file.name}…`);
  let res;
  try {
    res = await api.upload(projectUrl('/reality'), form, (f) => setProgress(bar, f, `uploading ${Math.round(f * 100)} %`));
  } catch (err) {
    bar.classList.add('failed');
    bar.querySelector('.label').textContent = 'upload refused';
    throw err;
  }
  $('#reality-file').value = '';
  S.realities.push(res.reality);
  renderRealityList();
  setProgress(bar, 0, 'queued for preparation');
  trackJob(res.job);
}

// ---------------------------------------------------------------------------------------------- members and share links
async function loadMembers() {
  const card = $('#sec-team');
  card.hidden = !(S.info && S.info.login && S.project);
  if (card.hidden) return;
  const project = S.project.id;
  const members = await act('Listing the members', () => api.get(projectUrl('/members')));
  if (!members || !S.project || S.project.id !== project) return;
  S.members = members;
  renderMembers();
}

function renderMembers() {
  const owner = isOwner();
  const rows = S.members.map((m) => {
    const self = S.me && m.username === S.me.username;
    const role = owner ? el('select', { 'aria-label': `role of ${m.username}`, onchange: (ev) => act('Changing the role', async () => {
      await api.request('PATCH', projectUrl(`/members/${m.user_id}`), { role: ev.target.value });
      showMessage(`${m.username} is now ${ev.target.value}.`, 'ok');
      await afterMembership();
    }) }, ...['viewer', 'editor', 'owner'].map((r) => el('option', { value: r, selected: r === m.role }, r)))
      : el('span', {}, m.role);
    const remove = owner || self ? el('button', { type: 'button', class: 'icon', title: self ? 'leave the project' : `remove ${m.username}`,
      onclick: () => act('Removing the member', async () => {
        await api.del(projectUrl(`/members/${m.user_id}`));
        showMessage(self ? 'You left the project.' : `${m.username} removed.`, 'ok');
        if (self) await loadProjects(null);
        else await afterMembership();
      }) }, self ? 'leave' : '✕') : '';
    return el('tr', { dataset: { member: m.username, role: m.role } }, el('td', {}, m.username + (self ? ' (you)' : '')),
      el('td', {}, role), el('td', {}, remove));
  });
  $('#members-table tbody').replaceChildren(...rows);
}

// a role changed: my own may have too
async function afterMembership() {
  const [project, members] = await Promise.all([api.get(projectUrl('')), api.get(projectUrl('/members'))]);
  Object.assign(S.project, project);
  S.members = members;
  applyRole();
  renderMembers();
  renderRealityList();
  renderScheduleList();
}

async function addMember() {
  const username = $('#member-name').value.trim();
  if (!username) throw new Error('give the user name of an account (made with sightplan users add)');
  const m = await api.post(projectUrl('/members'), { username, role: $('#member-role').value });
  $('#member-name').value = '';
  showMessage(`${m.username} is a ${m.role} of this project now.`, 'ok');
  await afterMembership();
}

async function loadLinks() {
  const list = $('#share-links');
  if (!S.plan || !canEdit() || !$('#share-box').open) {
    list.replaceChildren();
    return;
  }
  const plan = S.plan.id;
  const links = await api.get(projectUrl('/links'));
  if (!S.plan || S.plan.id !== plan) return;
  S.links = links.filter((l) => l.plan_id === plan);
  const when = (t) => new Date(t).toLocaleString('en-GB', { dateStyle: 'short', timeStyle: 'short' });
  list.replaceChildren(...S.links.map((l) => el('li', { dataset: { link: l.id, state: l.revoked_at ? 'revoked' : 'active' } },
    el('span', {}, `link #${l.id}, made ${when(l.created_at)}`),
    l.revoked_at ? el('span', { class: 'hint' }, ` revoked ${when(l.revoked_at)}`)
      : el('button', { type: 'button', class: 'danger', onclick: () => act('Revoking the link', async () => {
        await api.del(projectUrl(`/links/${l.id}`));
        showMessage(`Link #${l.id} revoked: it answers 404 from now on.`, 'ok');
        await loadLinks();
      }) }, 'Revoke'))));
  if (!S.links.length) list.append(el('li', { class: 'hint' }, 'No link to this plan yet.'));
}

async function createLink() {
  if (!S.plan) throw new Error('create or choose a plan first');
  const link = await api.post(projectUrl(`/plans/${S.plan.id}/links`), {});
  $('#share-new').hidden = false;
  $('#share-url').value = link.url;
  $('#share-url').dataset.link = String(link.id);
  $('#share-url').select();
  showMessage(`Share link #${link.id} made: copy it now, it is shown only once.`, 'ok');
  await loadLinks();
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
  if (format === 'wpml' && $('#export-aircraft').value) q.set('aircraft', $('#export-aircraft').value);
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
  $('#date-on').addEventListener('change', () => {
    updateEvalSite();
    applyDate();
  });
  $('#login-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Logging in', logIn);
  });
  // the dialog stays until a login succeeds: every request would be refused without one
  $('#login-dialog').addEventListener('cancel', (ev) => ev.preventDefault());
  $('#logout').addEventListener('click', () => act('Logging out', logOut));
  $('#account').addEventListener('click', () => act('Reading your API tokens', openAccount));
  $('#token-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating an API token', createToken);
  });
  $('#password-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Changing the password', changePassword);
  });
  // points of the plan form picked in the 3D view
  for (const b of $$('button[data-pick]')) b.addEventListener('click', () => act('Picking points', async () => startPicking(b.dataset.pick)));
  for (const sel of ['#plan-axis', '#plan-points', '#plan-stations']) $(sel).addEventListener('input', updateMarkers);
  $('#plan-new').addEventListener('toggle', () => {
    if (!$('#plan-new').open) stopPicking();
    updateMarkers();
  });
  window.addEventListener('keydown', (ev) => {
    if (ev.key === 'Escape' && S.pick) stopPicking();
  });
  $('#schedule-own').addEventListener('change', (ev) => { $('#schedule-file').disabled = ev.target.checked; });
  $('#schedule-add').addEventListener('click', () => act('Adding the schedule', addSchedule));
  $('#reality-upload').addEventListener('click', () => act('Uploading the reality capture', uploadReality));
  $('#member-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Adding the member', addMember);
  });
  $('#share-box').addEventListener('toggle', () => act('Listing the share links', loadLinks));
  $('#share-create').addEventListener('click', () => act('Making a share link', createLink));
  $('#eval-date').addEventListener('change', updateEvalSite);
  $('#eval-reality').addEventListener('change', updateEvalSite);
  window.addEventListener('resize', () => {
    renderHistogram();
    renderStability();
  });
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
  if (S.pick && S.pick !== 'stations' && !$(PICK[S.pick].button).closest('[data-template]').dataset.template.includes(t)) {
    stopPicking();
  }
  updateMarkers();
}

init().catch((err) => {
  document.body.dataset.state = 'error';
  showMessage(`The page could not start: ${errorText(err)}`, 'error');
});
