// Evaluations: starting one (its progress followed as a job), the list of those done, showing one (its feedback
// colours the model and the frames), the plan metrics table, the comparison of two, and the charts of the bottom
// tabs (the histogram of the metric shown, ν_f along the path).
import * as api from './api.js';
import { drawHistogram, drawStability, formatNumber } from './charts.js';
import { metricHelp } from './glossary.js';
import { Colourer, STABLE, UNSTABLE } from './colours.js';
import { $, $$, act, el, fillSelect, setProgress, showMessage } from './dom.js';
import { currentBounds, feedbackMatchesPlan, projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { selectFrame, showFrameView } from './frames.js';
import { selectElement } from './inspector.js';
import { onJob, trackJob } from './jobs.js';
import { selectModel } from './models.js';
import { evalSite } from './schedule.js';
import { frameColours } from './view.js';

let openVersion = null;  // bindEvaluations's: opens a plan version, keeping the evaluation shown

const METRIC_COLUMNS = [
  ['VC_pct', 'VC', '%', 2, true], ['VC_bar_pct', 'V̄C', '%', 2, true], ['VR', 'VR', 'frames', 2, true],
  ['R_m_per_px', 'R', 'm/px', 4, false], ['O_deg', 'O', '°', 2, false], ['T', 'T', 'features', 1, true],
  ['stable_frames_pct', 'stable', '%', 1, true],
];

// where an evaluation ran: at a capture date, with a reality capture as occluders ('' for the model as built)
function siteLabel(e) {
  const s = e.settings || {};
  const bits = [];
  if (s.as_flown) bits.push(` as flown (${s.as_flown === 'px4' ? 'PX4' : 'ArduPilot'})`);
  if (s.fourd && s.fourd.date) bits.push(` at ${s.fourd.date}`);
  if (s.reality_id) {
    const r = state.realities.find((x) => x.id === s.reality_id);
    bits.push(` + ${r ? r.name : `capture ${s.reality_id}`}`);
  }
  return bits.join('');
}

const planName = (id) => (state.plans.find((p) => p.id === id) || { name: `plan ${id}` }).name;

function renderEvaluations() {
  const done = state.evaluations.filter((e) => e.status === 'done');
  const label = (e) => `#${e.id} ${planName(e.plan_id)} v${e.plan_version}${siteLabel(e)} · s ${e.settings.scale}`
    + (e.metrics ? ` · VC ${formatNumber(e.metrics.VC_pct, 3)} %` : '');
  fillSelect($('#evaluation-select'), [['', '— none —'], ...done.map((e) => [e.id, label(e)])],
    state.evaluation ? state.evaluation.id : '');
  // unless the user chose: B is the evaluation shown, A the one before it (same plan first)
  let a = $('#compare-a').value;
  let b = $('#compare-b').value;
  if (!state.compareChosen && done.length) {
    const shown = state.evaluation && done.find((e) => e.id === state.evaluation.id) ? state.evaluation : done.at(-1);
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
  set({ evaluations: await api.get(projectUrl('/evaluations')) });
}

async function startEvaluation() {
  if (!state.plan) throw new Error('create or choose a plan first');
  if (state.dirty) throw new Error('the plan is edited: save it as a new version first, then evaluate that version');
  if (!state.model || state.model.status !== 'ready') throw new Error('the model is not loaded yet');
  const int = (sel) => Number($(sel).value);
  const settings = { scale: Number($('#eval-scale').value), engine: $('#eval-engine').value, omega: int('#eval-omega'),
    k: int('#eval-k'), min_track: int('#eval-min-track'), min_features: int('#eval-min-features') };
  const site = evalSite();
  const flown = {};
  if ($('#eval-as-flown').value) flown.as_flown = $('#eval-as-flown').value;
  if ($('#eval-error').value) Object.assign(flown, { position_error: $('#eval-error').value, draws: int('#eval-draws') });
  const res = await api.post(projectUrl('/evaluations'), { plan_id: state.plan.id, version: state.version,
    model_id: state.model.id, settings, ...site, ...flown });
  set({ evaluations: [...state.evaluations, res.evaluation] });
  setProgress($('#eval-progress'), 0, 'queued');
  $('#eval-status').textContent = `evaluating ${state.plan.name} v${state.version}${siteLabel(res.evaluation)} `
    + `(${res.evaluation.progress_total} frames)…`;
  trackJob(res.job);
}

export function clearFeedback() {
  set({ evaluation: null, feedback: null, colourer: null });
  $('#evaluation-select').value = '';
  if (state.geom) viewer.setFrameColours(frameColours());
}

export async function selectEvaluation(id, { fromPlan = false } = {}) {
  const ev = state.evaluations.find((e) => e.id === id) || await api.get(projectUrl(`/evaluations/${id}`));
  const feedback = await api.get(projectUrl(`/evaluations/${id}/feedback`));
  set({ evaluation: ev, feedback, colourer: new Colourer(feedback) });
  if (!fromPlan && (!state.plan || state.plan.id !== ev.plan_id || state.version !== ev.plan_version || state.dirty)) {
    await openVersion(ev.plan_id, ev.plan_version);
  }
  if (!state.model || state.model.id !== ev.model_id) await selectModel(ev.model_id);
  $('#evaluation-select').value = String(id);
  if (!state.frameColourChosen) $('#frame-colour').value = 'stability';
  if (state.geom) viewer.setFrameColours(frameColours());
  if (state.selectedFrame !== null) showFrameView();
  if (state.selectedElement !== null) await selectElement(state.selectedElement);
}

// ---------------------------------------------------------------------------------------------- tables
function metricCells(metrics) {
  return METRIC_COLUMNS.map(([key, , , digits]) => {
    const v = metrics ? metrics[key] : null;
    return v === null || v === undefined ? '—' : Number(v).toFixed(digits);
  });
}

function renderMetricsTable() {
  const done = state.evaluations.filter((e) => e.status === 'done' && e.metrics);
  $('#metrics-empty').hidden = done.length > 0;
  $('#metrics-table thead').replaceChildren(el('tr', {}, el('th', {}, 'plan'), el('th', {}, 'eval.'),
    el('th', {}, 'frames'), ...METRIC_COLUMNS.map(([key, head, unit]) => el('th', { title: metricHelp(key),
      dataset: { metric: key } }, `${head} (${unit})`)),
    el('th', { title: metricHelp('visible'), dataset: { metric: 'visible' } }, 'visible / z'), el('th', {}, 'scale'),
    el('th', {}, 'site')));
  $('#metrics-table tbody').replaceChildren(...done.flatMap((e) => [el('tr', {
    dataset: { evaluation: e.id }, class: state.evaluation && state.evaluation.id === e.id ? 'current' : '',
    onclick: () => act('Showing the evaluation', () => selectEvaluation(e.id)),
  }, el('td', {}, `${planName(e.plan_id)} v${e.plan_version}`), el('td', {}, `#${e.id}`),
  el('td', {}, String(e.metrics.frames)),
  ...metricCells(e.metrics).map((v, k) => el('td', { dataset: { metric: METRIC_COLUMNS[k][0] } }, v)),
  el('td', {}, `${e.metrics.visible} / ${e.metrics.z}`), el('td', {}, String(e.settings.scale)),
  el('td', { class: 'text', dataset: { site: siteLabel(e).trim() } }, siteLabel(e).trim() || 'as built')),
  ...(e.metrics.robustness ? [bandRow(e)] : [])]));
}

// the 5th–95th percentile of each metric over the draws under a position error, below its evaluation's row
function bandRow(e) {
  const r = e.metrics.robustness;
  const cells = METRIC_COLUMNS.map(([key, , , digits]) => {
    const m = r.metrics[key];
    const text = !m || m.p5 === null || m.p95 === null ? '—'
      : `${Number(m.p5).toFixed(digits)}–${Number(m.p95).toFixed(digits)}`;
    return el('td', { dataset: { band: key } }, text);
  });
  const safety = r.safety ? `; ${formatNumber(r.safety.draws_too_close_pct, 3)} % of draws come within `
    + `${r.safety.minimum_m} m` : '';
  return el('tr', { class: 'band', dataset: { bandOf: e.id } },
    el('td', { colspan: 3, class: 'text' }, `5–95 % of ${r.draws} draws, ${r.label}`), ...cells,
    el('td', { colspan: 3, class: 'text' }, `p5–p95${safety}`));
}

function renderCompare() {
  const a = state.evaluations.find((e) => String(e.id) === $('#compare-a').value);
  const b = state.evaluations.find((e) => String(e.id) === $('#compare-b').value);
  const head = $('#compare-table thead');
  const body = $('#compare-table tbody');
  if (!a || !b) {
    head.replaceChildren();
    body.replaceChildren(el('tr', {}, el('td', {}, 'Evaluate two plans (or two versions) to compare them.')));
    return;
  }
  const name = (e) => `${planName(e.plan_id)} v${e.plan_version} (#${e.id})`;
  head.replaceChildren(el('tr', {}, el('th', {}, 'metric'), el('th', {}, `A: ${name(a)}`),
    el('th', {}, `B: ${name(b)}`), el('th', {}, 'B − A')));
  const rows = [...METRIC_COLUMNS, ['frames', 'frames', '', 0, null], ['visible', 'visible elements', '', 0, true]];
  body.replaceChildren(...rows.map(([key, label, unit, digits, higherBetter]) => {
    const va = a.metrics ? a.metrics[key] : null;
    const vb = b.metrics ? b.metrics[key] : null;
    const d = va !== null && vb !== null && va !== undefined && vb !== undefined ? vb - va : null;
    const tol = 0.5 * 10 ** -digits;
    const cls = d === null || higherBetter === null || Math.abs(d) < tol ? '' : (d > 0) === higherBetter ? 'good' : 'bad';
    const fmt = (v) => (v === null || v === undefined ? '—' : Number(v).toFixed(digits));
    return el('tr', { dataset: { metric: key } }, el('td', { title: metricHelp(key) }, `${label}${unit ? ` (${unit})` : ''}`),
      el('td', {}, fmt(va)),
      el('td', {}, fmt(vb)), el('td', { class: cls }, d === null ? '—' : `${d > 0 ? '+' : ''}${d.toFixed(digits)}`));
  }));
}

// ---------------------------------------------------------------------------------------------- charts
// a chart's canvas when its tab is shown (else null); with no feedback it only says what it will show
function chartCanvas(sel, panel, empty) {
  if ($(`[data-panel="${panel}"]`).hidden) return null;
  const canvas = $(sel);
  if (!state.feedback) {
    const ctx = canvas.getContext('2d');
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.fillText(empty, 20, 30);
  }
  return canvas;
}

function renderHistogram() {
  const canvas = chartCanvas('#histogram', 'histogram', 'Evaluate a plan to see the distribution of the per-element metrics.');
  const fb = state.feedback;
  if (!canvas || !fb) return;
  const { colourer, metric } = state;
  const targets = fb.elements.target;
  if (metric === 'visibility') {
    const counts = [0, 0, 0];
    fb.metrics.visibility.forEach((v, i) => { if (targets[i] && v < 3) counts[v]++; });
    drawHistogram(canvas, { metric: 'visibility', classes: { counts, colours: colourer.classes.slice(0, 3),
      labels: ['visible', 'observed only', 'unseen'] } });
    return;
  }
  const [lo, hi] = currentBounds();
  const values = fb.metrics[metric].filter((v, i) => targets[i] && fb.metrics.visibility[i] === 0);
  const meta = colourer.label(metric);
  drawHistogram(canvas, { metric, values, lo, hi, label: meta.label, unit: meta.unit,
    colourAt: (v) => colourer.gradient(colourer.badness(metric, v, lo, hi)) });
}

let stabilityChart = null;
function renderStability() {
  const canvas = chartCanvas('#nu-chart', 'stability', 'Evaluate a plan to see ν_f, its stable features per frame, along the path.');
  const fb = state.feedback;
  if (!canvas) return;
  if (!fb) {
    stabilityChart = null;
    return;
  }
  const f = fb.frames;
  stabilityChart = drawStability(canvas, { nu: f.nu, stable: f.stable, lambda: fb.params.min_features,
    missions: fb.missions, selected: feedbackMatchesPlan() ? state.selectedFrame : null,
    colours: { stable: STABLE, unstable: UNSTABLE } });
}

function showTab(name) {
  for (const b of $$('.tabs button')) b.setAttribute('aria-selected', String(b.dataset.tab === name));
  for (const p of $$('.tab-panel')) p.hidden = p.dataset.panel !== name;
  if (name === 'histogram') renderHistogram();
  if (name === 'stability') renderStability();
}

// openVersion(planId, version): opens a plan version and keeps the evaluation shown
export function bindEvaluations(callbacks) {
  openVersion = callbacks.openVersion;
  subscribe(['evaluations', 'evaluation', 'plans', 'realities'], renderEvaluations);
  subscribe(['feedback', 'colourer', 'metric', 'bounds'], renderHistogram);
  subscribe(['feedback', 'selectedFrame', 'geom', 'dirty'], renderStability);
  onJob('evaluate', {
    name: (job) => `evaluation ${job.evaluation_id}`,
    box: '#eval-progress',
    progress: (j, frac) => {
      setProgress($('#eval-progress'), frac, j.status === 'queued' ? 'queued'
        : `${Math.round(j.progress_done)} of ${Math.round(j.progress_total)} frames — ${Math.round(frac * 100)} %`);
      $('#eval-status').textContent = j.message;
      $('#eval-cancel').hidden = false;
      $('#eval-cancel').dataset.job = String(j.id);
    },
    finished: (job) => {
      if ($('#eval-cancel').dataset.job === String(job.id)) $('#eval-cancel').hidden = true;
    },
    done: async (done) => {
      $('#eval-status').textContent = `evaluation ${done.evaluation_id} done: ${done.message}`;
      setProgress($('#eval-progress'), 1, `done — ${done.message}`);
      showMessage(`Evaluation ${done.evaluation_id} is done (${done.message}).`, 'ok');
      await act('Reading the evaluation', async () => {
        await refreshEvaluations();
        if (!state.project || done.project_id !== state.project.id) return;
        await selectEvaluation(done.evaluation_id);
      });
    },
    failed: () => act('Listing the evaluations', refreshEvaluations),
  });
  $('#eval-start').addEventListener('click', () => act('Starting the evaluation', startEvaluation));
  $('#eval-cancel').addEventListener('click', (ev) => act('Cancelling the evaluation',
    () => api.post(`/api/jobs/${ev.target.dataset.job}/cancel`)));
  $('#evaluation-select').addEventListener('change', (ev) => act('Showing the evaluation', async () => {
    if (ev.target.value) await selectEvaluation(Number(ev.target.value));
    else clearFeedback();
  }));
  for (const s of ['#compare-a', '#compare-b']) {
    $(s).addEventListener('change', () => {
      set({ compareChosen: true });
      renderCompare();
    });
  }
  for (const b of $$('.tabs button')) b.addEventListener('click', () => showTab(b.dataset.tab));
  $('#nu-chart').addEventListener('click', (ev) => {
    const i = stabilityChart && stabilityChart.frameAt(ev.clientX);
    if (i !== null && i !== undefined && feedbackMatchesPlan()) selectFrame(i, { scroll: true });
  });
  window.addEventListener('resize', () => {
    renderHistogram();
    renderStability();
  });
}
