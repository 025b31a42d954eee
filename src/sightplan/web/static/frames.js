// The frames of the plan version shown: the frame list, the selected frame (in the list, in 3D, its values in the
// inspector) and the simulated view from it (coloured by the metric shown once the version is evaluated), and which
// of the inspector's cards (the frame's, the element's) shows.
import * as api from './api.js';
import { formatNumber } from './charts.js';
import { $, $$, el, errorText } from './dom.js';
import { currentBounds, feedbackMatchesPlan, missionOf, projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { headingPitch } from './planedit.js';

let viewToken = null;  // the simulated view asked last: an older one is dropped

// heading (true, on a georeferenced plan: the exports' number; else from model +Y) and pitch of a rotation
const headingPitchOf = (R) => {
  const hp = headingPitch([[R[0], R[1], R[2]], [R[3], R[4], R[5]], [R[6], R[7], R[8]]]);
  return state.northOffset === null ? hp : { ...hp, heading: (hp.heading + state.northOffset + 360) % 360 };
};
const headingLabel = () => (state.northOffset === null ? 'heading (from model +Y)' : 'heading (true)');

function renderFrameList() {
  const tbody = $('#frame-list tbody');
  if (!state.geom) {
    tbody.replaceChildren();
    return;
  }
  const g = state.geom;
  const nu = feedbackMatchesPlan() ? state.feedback.frames.nu : null;
  const stable = nu ? state.feedback.frames.stable : null;
  const clearance = state.checks && !state.dirty ? state.checks.clearance_m : null;
  const unsafe = new Set(state.checks && !state.dirty ? state.checks.unsafe_frames : []);
  const rows = g.position.map((p, i) => {
    const hp = headingPitchOf(g.rotation[i]);
    const k = missionOf(i);
    return el('tr', { dataset: { frame: i }, class: i === state.selectedFrame ? 'selected' : '' },
      el('td', {}, String(i)), el('td', { class: 'text' }, g.name[i]),
      el('td', { class: 'text' }, k === null ? '—' : g.missions[k].name),
      ...p.map((v) => el('td', {}, v.toFixed(2))), el('td', {}, `${hp.heading.toFixed(1)}°`),
      el('td', {}, `${hp.pitch.toFixed(1)}°`),
      el('td', { class: unsafe.has(i) ? 'bad' : '' }, clearance ? `${formatNumber(clearance[i], 3)} m` : '—'),
      el('td', { class: stable ? (stable[i] ? 'good' : 'bad') : '' }, nu ? String(nu[i]) : '—'));
  });
  tbody.replaceChildren(...rows);
}

export function selectFrame(i, { scroll = false } = {}) {
  if (!state.geom || i === null || i < 0 || i >= state.geom.position.length) return;
  set({ selectedFrame: i });
  viewer.select(i);
  for (const tr of $$('#frame-list tr.selected')) tr.classList.remove('selected');
  const row = $(`#frame-list tr[data-frame="${i}"]`);
  if (row) {
    row.classList.add('selected');
    if (scroll) row.scrollIntoView({ block: 'nearest' });
  }
  showFrameView();
  showSelection('frame');
}

function renderFrameInfo() {
  const i = state.selectedFrame;
  if (i === null || !state.geom) return;
  const g = state.geom;
  const hp = headingPitchOf(g.rotation[i]);
  const k = missionOf(i);
  const rows = [
    ['frame', `${i} — ${g.name[i]}`, i], ['mission', k === null ? '—' : g.missions[k].name, k],
    ['camera', g.camera[i], g.camera[i]],
    ['position (m)', g.position[i].map((v) => v.toFixed(2)).join(', '), g.position[i]],
    [headingLabel(), `${hp.heading.toFixed(1)}°`, hp.heading], ['pitch', `${hp.pitch.toFixed(1)}°`, hp.pitch],
  ];
  const { checks } = state;
  if (checks && !state.dirty) {
    const c = checks.clearance_m[i];
    rows.push(['clearance', `${formatNumber(c, 3)} m${checks.unsafe_frames.includes(i) ? ' — too close' : ''}`, c]);
    rows.push(['in sight of pilot', checks.in_sight[i] ? 'yes' : 'NO', checks.in_sight[i]]);
  }
  if (feedbackMatchesPlan()) {
    const f = state.feedback.frames;
    rows.push(['ν_f', `${f.nu[i]} (${f.stable[i] ? 'stable' : 'not stable'}, Λ = ${state.feedback.params.min_features})`, f.nu[i]],
      ['elements ≥ Ω px', String(f.elements_visible[i]), f.elements_visible[i]]);
  }
  if (state.dirty) rows.push(['note', 'edited: save to check and evaluate it', '']);
  $('#frame-info').replaceChildren(...rows.flatMap(([key, v, raw]) => [el('dt', {}, key),
    el('dd', { dataset: { field: key, value: JSON.stringify(raw ?? null) }, class: v.includes('NO') || v.includes('too close') ? 'bad' : '' }, v)]));
  $('#edit-frame-label').textContent = `— ${i}: ${g.name[i]}`;
}

// the simulated view from the selected frame: the engine's element-id image, coloured by the metric shown
export async function showFrameView() {
  const i = state.selectedFrame;
  const img = $('#frame-view');
  const caption = $('#frame-view-caption');
  if (i === null) return;
  const token = Symbol('view');
  viewToken = token;
  if (state.dirty) {
    img.removeAttribute('src');
    caption.textContent = 'Save the edited plan to see the simulated view from this frame.';
    return;
  }
  let url;
  if (feedbackMatchesPlan()) {
    const q = new URLSearchParams({ metric: state.metric, width: '480' });
    if (state.metric !== 'visibility') {
      const [lo, hi] = currentBounds();
      q.set('lo', String(lo));
      q.set('hi', String(hi));
    }
    url = projectUrl(`/evaluations/${state.feedback.evaluation_id}/frames/${i}/view.png?${q}`);
    caption.textContent = `Simulated view, coloured by ${state.colourer.label(state.metric).label}.`;
  } else if (state.model && state.model.status === 'ready') {
    url = projectUrl(`/plans/${state.plan.id}/versions/${state.version}/frames/${i}/view.png?model_id=${state.model.id}&width=480`);
    caption.textContent = 'Simulated view (not evaluated yet).';
  } else return;
  try {
    const response = await api.request('GET', url, undefined, { raw: true });
    const blob = await response.blob();
    if (viewToken !== token) return;
    if (img.src && img.src.startsWith('blob:')) URL.revokeObjectURL(img.src);
    img.src = URL.createObjectURL(blob);
    img.dataset.frame = String(i);
    img.dataset.url = url;
    if (response.headers.get('x-sightplan-elements-seen') === '0') {
      caption.textContent += ' Nothing of the model is in view from this frame.';
    }
  } catch (err) {
    if (viewToken !== token) return;
    img.removeAttribute('src');
    caption.textContent = `No simulated view: ${errorText(err)}`;
  }
}

// which cards show: 'frame' or 'element' just selected (on top), or, with none, those of what is selected
export function showSelection(which) {
  const elementCard = $('#element-card');
  const frameCard = $('#frame-card');
  if (which === 'frame') frameCard.hidden = false;
  if (which === 'element') elementCard.hidden = false;
  if (!which) {
    elementCard.hidden = state.selectedElement === null;
    frameCard.hidden = state.selectedFrame === null;
  }
  $('#inspector-hint').hidden = !elementCard.hidden || !frameCard.hidden;
  // the latest selection on top
  if (which === 'frame') $('#inspector').prepend(frameCard);
  if (which === 'element') $('#inspector').prepend(elementCard);
}

export function bindFrames() {
  subscribe(['geom', 'feedback', 'checks', 'dirty'], renderFrameList);
  subscribe(['selectedFrame', 'geom', 'feedback', 'checks', 'dirty'], renderFrameInfo);
  // another metric or other bounds: the view of the evaluated frame in their colours
  subscribe(['metric', 'bounds'], () => {
    if (state.selectedFrame !== null && feedbackMatchesPlan()) showFrameView();
  });
  $('#frame-list tbody').addEventListener('click', (ev) => {
    const tr = ev.target.closest('tr');
    if (tr) selectFrame(Number(tr.dataset.frame));
  });
}
