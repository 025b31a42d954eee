// Models: the model list, uploading an IFC or a mesh (its tessellation followed as a job), the load report, deleting
// one, and showing one in the 3D view.
import * as api from './api.js';
import { $, act, el, fillSelect, setProgress, showMessage } from './dom.js';
import { projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { barProgress, onJob, trackJob, uploadInto } from './jobs.js';
import { loadSchedules } from './schedule.js';
import { frameColours } from './view.js';
import { parseGeometry } from './model3d.js';

function renderModels() {
  fillSelect($('#model-select'), state.models.map((m) => [m.id, `${m.original_name}${m.status === 'ready' ? '' : ` (${m.status})`}`]),
    state.model && state.model.id);
}

async function refreshModels() {
  set({ models: await api.get(projectUrl('/models')) });
}

export async function selectModel(id) {
  const detail = await api.get(projectUrl(`/models/${id}`));
  set({ model: detail });
  localStorage.setItem(`sightplan.${state.project.id}.model`, String(id));
  renderLoadReport(detail);
  if (detail.status !== 'ready') {
    viewer.clearModel();
    set({ geometryModel: null });
    return;
  }
  if (state.geometryModel === id) return;
  const [buffer, elements] = await Promise.all([api.getBinary(projectUrl(`/models/${id}/geometry`)),
    api.get(projectUrl(`/models/${id}/elements`))]);
  viewer.setModel(parseGeometry(buffer));
  if (state.selectedElement !== null) viewer.highlightElement(state.selectedElement);
  set({ elements, geometryModel: id });  // the model's colours follow
  document.body.dataset.model = String(id);
  if (state.geom) viewer.setPlan(state.geom, frameColours(), state.dirty ? null : state.checks);
  viewer.fit();
  set({ fitted: id });
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
  if (!state.project) throw new Error('create or choose a project first');
  if (!file) throw new Error('choose an IFC or mesh file first');
  const form = new FormData();
  form.append('file', file);
  const bar = $('#upload-progress');
  setProgress(bar, 0, `uploading ${file.name}…`);
  const res = await uploadInto(bar, projectUrl('/models'), form);
  $('#model-file').value = '';
  set({ models: [...state.models, res.model], model: res.model });
  renderLoadReport(res.model);
  setProgress(bar, 0, 'queued for tessellation');
  trackJob(res.job);
}

// reopenProject(): opens the project shown afresh (after a model is deleted)
export function bindModels({ reopenProject }) {
  subscribe(['models', 'model'], renderModels);
  onJob('load_model', {
    name: (job) => `model ${job.model_id}`,
    box: '#upload-progress',
    progress: barProgress('#upload-progress', 'queued for tessellation', 'loading'),
    done: async (done) => {
      setProgress($('#upload-progress'), 1, done.message);
      showMessage(`Model loaded: ${done.message}.`, 'ok');
      await act('Showing the model', async () => {
        await refreshModels();
        if (state.project && done.project_id === state.project.id) await selectModel(done.model_id);
      });
    },
    failed: (job) => act('Listing the models', async () => {
      await refreshModels();
      if (state.model && state.model.id === job.model_id) renderLoadReport(await api.get(projectUrl(`/models/${job.model_id}`)));
    }),
  });
  $('#model-upload').addEventListener('click', () => act('Uploading the model', uploadModel));
  $('#model-select').addEventListener('change', (ev) => act('Showing the model', () => selectModel(Number(ev.target.value))));
  let armed = null;
  $('#model-delete').addEventListener('click', (ev) => act('Deleting the model', async () => {
    if (!state.model) throw new Error('no model is selected');
    if (armed !== state.model.id) {
      armed = state.model.id;
      ev.target.textContent = 'delete?';
      setTimeout(() => { armed = null; ev.target.textContent = '✕'; }, 3000);
      return;
    }
    await api.del(projectUrl(`/models/${state.model.id}`));
    armed = null;
    ev.target.textContent = '✕';
    showMessage(`Model ${state.model.original_name} deleted.`, 'ok');
    await reopenProject();
  }));
}
