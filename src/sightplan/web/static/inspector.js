// The element card of the inspector on the right: the element clicked, its values (from the evaluation shown when
// there is one) and the frames that see it best.
import * as api from './api.js';
import { formatNumber } from './charts.js';
import { $, el, showMessage } from './dom.js';
import { metricHelp } from './glossary.js';
import { feedbackMatchesPlan, feedbackOfModel, projectUrl, viewer } from './context.js';
import { set, state } from './store.js';
import { selectFrame, showSelection } from './frames.js';

export async function selectElement(e) {
  set({ selectedElement: e });
  viewer.highlightElement(e);
  const card = $('#element-card');
  const info = $('#element-info');
  const fb = feedbackOfModel();
  let rows;
  let frames = [];
  if (fb) {
    const d = await api.get(projectUrl(`/evaluations/${fb.evaluation_id}/elements/${e}?limit=6`));
    if (state.selectedElement !== e) return;
    const r = d.element;
    rows = [['index', r.index, r.index], ['global_id', r.global_id, r.global_id], ['name', r.name, r.name],
      ['ifc_class', r.ifc_class, r.ifc_class], ['storey', r.storey || '—', r.storey],
      ['visibility', r.visibility, r.visibility], ['VR_i', r.VR_i === null ? '—' : `${r.VR_i} frames`, r.VR_i],
      ['R_i_m_per_px', r.R_i_m_per_px === null ? '—' : `${formatNumber(r.R_i_m_per_px, 4)} m/px`, r.R_i_m_per_px],
      ['O_i_deg', r.O_i_deg === null ? '—' : `${formatNumber(r.O_i_deg, 4)}°`, r.O_i_deg],
      ['frames_observed', r.frames_observed === null ? '—' : String(r.frames_observed), r.frames_observed],
      ['pixels_total', r.pixels_total === null ? '—' : Math.round(r.pixels_total).toLocaleString('en'), r.pixels_total]];
    frames = d.best_frames;
  } else if (state.elements) {
    const t = state.elements;
    rows = [['index', e, e], ['global_id', t.global_id[e], t.global_id[e]], ['name', t.name[e], t.name[e]],
      ['ifc_class', t.ifc_class[e], t.ifc_class[e]], ['storey', t.storey[e] || '—', t.storey[e]],
      ['target', t.target[e] ? 'yes' : 'no (occluder)', t.target[e]], ['triangles', String(t.triangles[e]), t.triangles[e]],
      ['metrics', 'evaluate a plan to see them', null]];
  } else return;
  const labels = { global_id: 'GlobalId', ifc_class: 'IFC class', R_i_m_per_px: 'R_i (SSD)', O_i_deg: 'O_i',
    frames_observed: 'frames observed', pixels_total: 'pixels' };
  info.replaceChildren(...rows.flatMap(([k, v, raw]) => [el('dt', { title: metricHelp(k) }, labels[k] || k),
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
