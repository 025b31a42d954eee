// Projects: the list in the top bar, creating one, and opening one: everything of the previous project cleared,
// then its models, plans, evaluations, reality captures, members, schedules and running jobs read.
import * as api from './api.js';
import { $, act, el, fillSelect, showMessage } from './dom.js';
import { projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { showSelection } from './frames.js';
import { trackJob } from './jobs.js';
import { selectModel } from './models.js';
import { selectPlan } from './plans.js';
import { loadRealities } from './reality.js';
import { loadSchedules } from './schedule.js';
import { loadMembers } from './team.js';

export async function loadProjects(wanted) {
  await act('Listing the projects', async () => {
    const projects = await api.get('/api/projects');
    set({ projects });
    const id = projects.some((p) => p.id === wanted) ? wanted : projects.length ? projects.at(-1).id : null;
    if (id !== null) await selectProject(id);
    else {
      set({ project: null });
      loadMembers();
      $('#view-empty').textContent = 'Create a project (top bar), then upload an IFC model or a mesh.';
    }
  });
}

function renderProjects() {
  fillSelect($('#project-select'), state.projects.map((p) => [p.id, p.name]), state.project && state.project.id);
}

export async function selectProject(id) {
  const project = state.projects.find((p) => p.id === id) || null;
  localStorage.setItem('sightplan.project', String(id));
  viewer.clearModel();
  viewer.clearPlan();
  viewer.clearRealities();
  set({ project, models: [], model: null, elements: null, geometryModel: null, plans: [], plan: null, version: null,
    saved: null, draft: null, dirty: false, geom: null, checks: null, evaluations: [], evaluation: null, feedback: null,
    colourer: null, compareChosen: false, frameColourChosen: false, selectedFrame: null, selectedElement: null,
    dateStates: null, fitted: null, realities: [], realityHidden: new Set(), allSchedules: [],
    members: [], links: [] });
  delete document.body.dataset.model;
  resetPanels();
  if (!project) return;
  const [models, plans, evaluations, jobs] = await Promise.all([
    api.get(projectUrl('/models')), api.get(projectUrl('/plans')), api.get(projectUrl('/evaluations')),
    api.get(`/api/jobs?project_id=${id}`)]);
  set({ models, plans, evaluations });
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
}

// a project opened afresh: nothing of the previous one stays on screen (what the state draws follows the state)
function resetPanels() {
  for (const sel of ['#load-report', '#plan-summary', '#missions-table tbody', '#violations', '#element-info',
    '#frame-info', '#element-frames tbody', '#eval-status', '#checks-summary']) $(sel).replaceChildren();
  for (const sel of ['#upload-progress', '#eval-progress', '#element-card', '#frame-card', '#date-panel',
    '#schedule-progress', '#schedule-report', '#reality-progress', '#share-new']) $(sel).hidden = true;
  for (const sel of ['#share-links', '#eval-site']) $(sel).replaceChildren();
  fillSelect($('#eval-reality'), [['', 'none']], '');
  $('#frame-view').removeAttribute('src');
  $('#export-mission').replaceChildren(el('option', { value: '' }, 'all'));
  $('#frame-colour').value = 'mission';
  showSelection();
}

// what to do first, over the empty 3D view
function updateEmptyHint() {
  const empty = $('#view-empty');
  if (!state.project) empty.textContent = 'Create a project (top bar) to start.';
  else if (!state.models.length) empty.textContent = 'Upload an IFC model or a mesh (left) to start.';
  else if (!state.model || state.model.status !== 'ready') empty.textContent = 'The model is being loaded…';
  else empty.textContent = '';
  empty.hidden = !empty.textContent;
}

export function bindProjects() {
  subscribe(['projects', 'project'], renderProjects);
  subscribe(['project', 'models', 'model'], updateEmptyHint);
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
}

