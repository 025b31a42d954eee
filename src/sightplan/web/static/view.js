// The 3D view's surroundings: the model's colours (by the metric and bounds chosen, the site at a date, x-ray), the
// frames' colours (by mission or by ν_f), the legend, the layer toolbar, the frame size, "fit", and the status line.
import { formatNumber } from './charts.js';
import { $, act, el, showMessage } from './dom.js';
import {
  IN_PROGRESS, MISSION_PALETTE, NEUTRAL_OCCLUDER, NEUTRAL_TARGET, NOT_YET, STABLE, UNSTABLE, rgbCss,
} from './colours.js';
import { currentBounds, feedbackMatchesPlan, feedbackOfModel, missionOf, viewer } from './context.js';
import { set, state, subscribe } from './store.js';

// the frames' colours: by ν_f (stable or not) once the version shown is evaluated and that is chosen, else by mission
export function frameColours() {
  const n = state.geom ? state.geom.position.length : 0;
  const byStability = $('#frame-colour').value === 'stability' && feedbackMatchesPlan();
  const out = new Array(n);
  for (let i = 0; i < n; i++) {
    if (byStability) out[i] = state.feedback.frames.stable[i] ? STABLE : UNSTABLE;
    else out[i] = MISSION_PALETTE[(missionOf(i) ?? 0) % MISSION_PALETTE.length];
  }
  return out;
}

// each element's colour and mode (solid or ghost): the site at the date shown, else the metric chosen, else
// target or occluder
function refreshModelColours() {
  if (!viewer.model || !state.elements || !state.model || state.geometryModel !== state.model.id) return;
  const fb = feedbackOfModel();
  const { colourer, metric } = state;
  const target = state.elements.target;
  const xray = $('#layer-xray').checked;
  const [lo, hi] = currentBounds();
  const states = $('#date-on').checked && !$('#date-panel').hidden ? state.dateStates : null;
  viewer.setAppearance((e) => {
    const st = states ? states[e] : null;
    if (st === 'in_progress') return IN_PROGRESS;
    if (st === 'not_yet') return NOT_YET;
    if (fb) return colourer.colourOf(metric, e, lo, hi);
    return target[e] ? NEUTRAL_TARGET : NEUTRAL_OCCLUDER;
  }, (e) => {
    const st = states ? states[e] : null;
    if (st === 'not_yet') return 'ghost';
    if (!target[e]) return 'ghost';
    if (xray && fb && fb.metrics.visibility[e] === 0) return 'ghost';
    return 'solid';
  });
}

// the colour-by toolbar: the metric, and its bounds when it is a gradient
function renderColourBy() {
  const { metric } = state;
  $('#colour-by').value = metric;
  const gradient = metric !== 'visibility' && state.colourer;
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
}

function readBounds() {
  const lo = Number($('#bound-lo').value);
  const hi = Number($('#bound-hi').value);
  if (!Number.isFinite(lo) || !Number.isFinite(hi) || $('#bound-lo').value === '' || $('#bound-hi').value === '') {
    throw new Error('the bounds must be two numbers');
  }
  if (lo >= hi) throw new Error(`the lower bound (${lo}) must be below the upper bound (${hi})`);
  set({ bounds: { ...state.bounds, [state.metric]: [lo, hi] } });
}

function renderLegend() {
  const legend = $('#legend');
  const swatch = (rgb, label) => el('span', { class: 'swatch' }, el('i', { style: `background:${rgbCss(rgb)}` }), label);
  const c = state.colourer;
  if (!c) {
    legend.replaceChildren(swatch(NEUTRAL_TARGET, 'target'), swatch(NEUTRAL_OCCLUDER, 'occluder'),
      el('span', { class: 'hint' }, 'evaluate a plan to colour the model'));
    return;
  }
  if (state.metric === 'visibility') {
    legend.replaceChildren(...c.label('visibility').classes.map((label, k) => swatch(c.classes[k], label)));
    return;
  }
  const meta = c.label(state.metric);
  const [lo, hi] = currentBounds();
  const stops = meta.higher_better ? [...c.stops].reverse() : c.stops;
  const bar = el('span', { class: 'gradient', style: `background:linear-gradient(to right, ${stops.map(rgbCss).join(', ')})` });
  legend.replaceChildren(`${formatNumber(lo, 3)} ${meta.unit}`, bar, `${formatNumber(hi, 3)} ${meta.unit}`,
    swatch(c.unseen, 'not seen by ≥ Ω px'), swatch(c.occluder, 'occluder'));
}

// below the view: the model, the plan version (* when edited) and the evaluation shown; while points are picked,
// the picking's hint stays
function updateStatus() {
  if (state.pick) return;
  const { model, plan, geom, evaluation } = state;
  const bits = [];
  if (model) bits.push(`${model.original_name}${model.elements ? ` — ${model.elements} elements, ${(model.triangles || 0).toLocaleString('en')} triangles` : ''}`);
  if (plan && geom) bits.push(`${plan.name} v${state.version}${state.dirty ? '*' : ''}: ${geom.position.length} frames`);
  if (evaluation && evaluation.metrics) bits.push(`evaluation #${evaluation.id}: VC ${formatNumber(evaluation.metrics.VC_pct, 3)} %`);
  $('#view-status').textContent = bits.join(' · ');
}

export function bindView() {
  subscribe(['model', 'elements', 'geometryModel', 'feedback', 'colourer', 'metric', 'bounds', 'dateStates'], refreshModelColours);
  subscribe(['metric', 'colourer', 'bounds'], renderColourBy);
  subscribe(['metric', 'colourer', 'bounds'], renderLegend);
  subscribe(['pick', 'model', 'plan', 'version', 'dirty', 'geom', 'evaluation'], updateStatus);
  $('#colour-by').addEventListener('change', (ev) => set({ metric: ev.target.value }));
  for (const s of ['#bound-lo', '#bound-hi']) $(s).addEventListener('change', () => act('Setting the bounds', async () => readBounds()));
  $('#bound-reset').addEventListener('click', () => {
    const { [state.metric]: _, ...bounds } = state.bounds;
    set({ bounds });
  });
  const layers = () => viewer.setLayers({ model: $('#layer-model').checked, frustums: $('#layer-frustums').checked,
    path: $('#layer-path').checked, stations: $('#layer-stations').checked });
  for (const s of ['#layer-model', '#layer-frustums', '#layer-path', '#layer-stations']) $(s).addEventListener('change', layers);
  $('#layer-xray').addEventListener('change', refreshModelColours);
  $('#frame-colour').addEventListener('change', () => {
    set({ frameColourChosen: true });
    if (state.geom) viewer.setFrameColours(frameColours());
    if ($('#frame-colour').value === 'stability' && !feedbackMatchesPlan()) {
      showMessage('Frames are coloured by ν_f once this plan version is evaluated.', 'info');
    }
  });
  $('#frame-size').addEventListener('change', (ev) => {
    viewer.frameScale = Number(ev.target.value);
    viewer.frameSize = viewer.baseFrameSize * viewer.frameScale;
    if (state.geom) {
      viewer.setPlan(state.geom, frameColours(), state.dirty ? null : state.checks);
      layers();
    }
  });
  $('#view-fit').addEventListener('click', () => viewer.fit());
}
