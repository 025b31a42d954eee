// Reality captures: point clouds and meshes of the site uploaded (their preparation is a job), listed with a toggle
// each, drawn beside the model, and offered as occluders for an evaluation.
import * as api from './api.js';
import { $, act, el, errorText, fillSelect, setProgress, showMessage } from './dom.js';
import { canEdit, projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { barProgress, onJob, trackJob, uploadInto } from './jobs.js';
import { updateEvalSite } from './schedule.js';

export async function loadRealities() {
  if (!state.project) return;
  const project = state.project.id;
  const rows = await api.get(projectUrl('/reality'));
  if (!state.project || state.project.id !== project) return;
  set({ realities: rows });
  for (const id of [...viewer.realities.keys()]) if (!rows.some((r) => r.id === id && r.status === 'ready')) viewer.removeReality(id);
  const ready = rows.filter((r) => r.status === 'ready');
  fillSelect($('#eval-reality'), [['', 'none'], ...ready.map((r) => [r.id, `${r.name} (${r.kind})`])], $('#eval-reality').value);
  updateEvalSite();
  for (const r of rows) {
    if (r.status !== 'ready' || !r.view_url) continue;
    viewer.addReality(r, !state.realityHidden.has(r.id)).catch((err) => {
      showMessage(`The reality capture ${r.name} cannot be shown: ${errorText(err)}`, 'error');
    });
  }
}

function renderRealityList() {
  const list = $('#reality-list');
  if (!state.project) {
    list.replaceChildren();
    return;
  }
  const items = state.realities.map((r) => {
    const size = r.kind === 'points' ? `${(r.points || 0).toLocaleString('en')} points`
      : `${(r.triangles || 0).toLocaleString('en')} triangles`;
    const status = r.status === 'ready' ? size : r.status === 'failed' ? `failed: ${r.error || ''}` : `${r.status}…`;
    const toggle = el('input', { type: 'checkbox', 'aria-label': `show ${r.name}`, checked: !state.realityHidden.has(r.id),
      disabled: r.status !== 'ready', onchange: (ev) => {
        const hidden = new Set(state.realityHidden);
        if (ev.target.checked) hidden.delete(r.id);
        else hidden.add(r.id);
        set({ realityHidden: hidden });
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
      el('label', { class: 'check' }, toggle, ` ${r.name}`), el('span', { class: 'hint' }, ` ${r.kind} · ${status}`), remove);
  });
  list.replaceChildren(...items);
  if (!items.length) {
    list.append(el('li', { class: 'hint' }, 'No capture of the site yet'
      + (canEdit() ? ': upload a point cloud or a mesh in the model’s frame.' : '.')));
  }
}

async function uploadReality() {
  if (!state.project) throw new Error('create or choose a project first');
  const file = $('#reality-file').files[0];
  if (!file) throw new Error('choose a point cloud (.las, .laz, .ply) or a mesh (.obj, .ply, .stl, .gltf, .glb) first');
  const form = new FormData();
  form.append('file', file);
  const bar = $('#reality-progress');
  setProgress(bar, 0, `uploading ${file.name}…`);
  const res = await uploadInto(bar, projectUrl('/reality'), form);
  $('#reality-file').value = '';
  set({ realities: [...state.realities, res.reality] });
  setProgress(bar, 0, 'queued for preparation');
  trackJob(res.job);
}

export function bindReality() {
  subscribe(['realities', 'info', 'me', 'project'], renderRealityList);
  onJob('prep_reality', {
    name: () => 'reality capture',
    box: '#reality-progress',
    progress: barProgress('#reality-progress', 'queued for preparation', 'preparing'),
    done: async (done) => {
      setProgress($('#reality-progress'), 1, `ready — ${done.message}`);
      showMessage(`Reality capture ready: ${done.message}.`, 'ok');
      await act('Showing the reality capture', async () => {
        if (state.project && done.project_id === state.project.id) await loadRealities();
      });
    },
    failed: () => act('Listing the reality captures', loadRealities),
  });
  $('#reality-upload').addEventListener('click', () => act('Uploading the reality capture', uploadReality));
}
