// The "Optimised plan" form (#optimize-form): POST /plans/optimize with the targets and budget typed here and the
// camera, safety distance and flight settings (aircraft, VLOS radius, altitude limit, ground stations) of the
// template form; the job runs on the server (progress in the jobs tray) and the plan it makes is listed and opened
// when it is done.
//
// Interface: bindOptimize({ planCreated }) wires the form once; planCreated(plan) (async) is given the new plan.
import * as api from './api.js';
import { $, act, showMessage } from './dom.js';
import { projectUrl } from './context.js';
import { onJob, trackJob } from './jobs.js';
import { state } from './store.js';
import { flightBody } from './templates.js';

/** @typedef {import('./api-types.js').OptimizeIn} OptimizeIn */

/** @returns {OptimizeIn} the request the two forms make */
function optimizeBody() {
  if (!state.model || state.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const num = (sel) => ($(sel).value === '' ? null : Number($(sel).value));
  const body = {
    model_id: state.model.id, camera: $('#plan-camera').value, safety_distance_m: num('#plan-safety') ?? 10,
    k: num('#optimize-k') ?? 3, max_angle_deg: num('#optimize-angle') ?? 45, budget_minutes: num('#optimize-minutes'),
    budget_frames: num('#optimize-frames'), scale: num('#optimize-scale') ?? 0.25, ...flightBody(),
  };
  for (const [k, v] of Object.entries(body)) if (v === null || Number.isNaN(v)) delete body[k];
  return body;
}

export function bindOptimize({ planCreated }) {
  onJob('optimize', {
    name: () => 'optimising a plan',
    done: async (job) => {
      const plan = await api.get(projectUrl(`/plans/${job.plan_id}`));
      showMessage(`Optimised plan “${plan.name}”: ${job.message}.`, 'ok');
      await planCreated(plan);
    },
  });
  $('#optimize-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Optimising the plan', async () => {
      const job = await api.post(projectUrl('/plans/optimize'), optimizeBody());
      trackJob(job);
      $('#plan-optimize').open = false;
    });
  });
}
