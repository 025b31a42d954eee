// Background jobs (a model's tessellation, an evaluation, a schedule's linking, a reality capture's preparation)
// followed in the top bar's tray with a progress bar and a cancel button. Each area says what a job of its kind
// shows and does when it ends: onJob(kind, { name, box, progress, finished, done, failed }).
import * as api from './api.js';
import { $, act, el, errorText, markFailed, setProgress, showMessage } from './dom.js';

const kinds = {};
const tracked = new Map();  // job id → its item in the tray

// name(job): its label; box: the selector of the area's progress bar, marked failed when the job fails;
// progress(job, fraction), finished(job): on each update and when it ends; done(job), failed(job, err): async
export function onJob(kind, handlers) {
  kinds[kind] = handlers;
}

// progress(job, fraction) for an area's bar (selector box): `queued` while the job waits, then its message (else
// `working`) and the percentage
export const barProgress = (box, queued, working) => (j, frac) => setProgress($(box), frac,
  j.status === 'queued' ? queued : `${j.message || working} — ${Math.round(frac * 100)} %`);

// a file sent with its progress in an area's bar (the job it starts follows); the bar says `refused` if refused
export async function uploadInto(bar, url, form, refused = 'upload refused') {
  try {
    return await api.upload(url, form, (f) => setProgress(bar, f, `uploading ${Math.round(f * 100)} %`));
  } catch (err) {
    markFailed(bar, refused);
    throw err;
  }
}

export function trackJob(job) {
  if (tracked.has(job.id)) return;
  const kind = kinds[job.kind] || {};
  const name = kind.name ? kind.name(job) : job.kind;
  const label = el('span', {}, name);
  const bar = el('div', { class: 'progress', role: 'progressbar', 'aria-valuemin': '0', 'aria-valuemax': '100' },
    el('div', { class: 'bar' }), el('span', { class: 'label' }));
  const cancel = el('button', { type: 'button', class: 'icon', title: 'cancel this job',
    onclick: () => act('Cancelling the job', () => api.post(`/api/jobs/${job.id}/cancel`)) }, '×');
  const item = el('div', { class: 'job', dataset: { job: job.id } }, label, bar, cancel);
  $('#jobs-tray').append(item);
  tracked.set(job.id, item);
  const update = (j) => {
    const frac = j.progress_total > 0 ? j.progress_done / j.progress_total : 0;
    setProgress(bar, frac);
    item.title = j.message;
    if (kind.progress) kind.progress(j, frac);
  };
  update(job);
  const finished = () => {
    item.remove();
    tracked.delete(job.id);
    if (kind.finished) kind.finished(job);
  };
  api.followJob(job.id, update).then(async (done) => {
    finished();
    if (kind.done) await kind.done(done);
  }).catch(async (err) => {
    finished();
    const box = kind.box && $(kind.box);
    if (box) markFailed(box, /cancel/i.test(errorText(err)) ? 'cancelled' : 'failed');
    showMessage(`${name} failed: ${errorText(err)}`, 'error');
    if (kind.failed) await kind.failed(job, err);
  });
}
