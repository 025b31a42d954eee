// 4D: the schedules linked to the model shown (adding one is a job; its link report), the date slider that shows the
// site at a date (built, in progress, not yet), and the site an evaluation runs on (a capture date, a reality
// capture as occluders).
import * as api from './api.js';
import { $, act, el, errorText, fillSelect, setProgress, showMessage } from './dom.js';
import { canEdit, projectUrl } from './context.js';
import { set, state, subscribe } from './store.js';
import { barProgress, onJob, trackJob, uploadInto } from './jobs.js';

const DAY = 86400000;
let schedulesToken = null;  // the schedules asked last: an older answer is dropped
let dateToken = null;  // the states asked last

// the linked schedules of the model shown that are ready, with their first and last date: the slider's
function datedSchedules() {
  return state.allSchedules.map((s) => ({ ...s, start: s.start || s.first_date, finish: s.finish || s.last_date }))
    .filter((s) => s.start && s.finish && (s.status === undefined || s.status === 'ready'));
}

export async function loadSchedules({ prefer = null } = {}) {
  const panel = $('#date-panel');
  if (!state.project || state.share) {  // a share view shows the plan, not the project's schedules
    panel.hidden = true;
    return;
  }
  const token = Symbol('schedules');
  schedulesToken = token;
  let rows = [];
  try {
    rows = await api.get(projectUrl('/schedules'));
  } catch {
    rows = [];  // no schedule support on this server, or none readable: no slider
  }
  if (schedulesToken !== token) return;
  const ofModel = (s) => s.model_id === undefined || !state.model || s.model_id === state.model.id;
  const allSchedules = (Array.isArray(rows) ? rows : []).filter(ofModel);
  set({ allSchedules });
  const schedules = datedSchedules();
  panel.hidden = !schedules.length || !state.model;
  if (panel.hidden) {
    set({ dateStates: null });
    updateEvalSite();
    return;
  }
  const current = $('#schedule-select').value;
  const pick = [prefer, current].find((v) => v !== null && v !== '' && schedules.some((x) => String(x.id) === String(v)));
  fillSelect($('#schedule-select'), schedules.map((s) => [s.id, s.name]), pick ?? schedules.at(-1).id);
  if (pick === undefined || prefer !== null || String(pick) !== current) setDateRange();
  await applyDate();
}

function renderScheduleList() {
  const items = state.allSchedules.map((s) => {
    const status = s.status === 'ready' ? (s.first_date ? `${s.first_date} → ${s.last_date}` : 'no element dated')
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
      } }, s.name), el('span', { class: 'hint' }, ` ${status}`), remove);
  });
  $('#schedule-list').replaceChildren(...items);
  if (!items.length && state.model) {
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
  if (!state.model || state.model.status !== 'ready') throw new Error('upload a model and wait until it is loaded');
  const own = $('#schedule-own').checked;
  const file = $('#schedule-file').files[0];
  if (!own && !file) throw new Error('choose a schedule file (MS Project .xml, Primavera .xer, .csv, .ifc), or use the model’s own');
  const form = new FormData();
  form.append('model_id', String(state.model.id));
  if (!own) form.append('file', file);
  const rules = $('#schedule-rules').files[0];
  if (rules) form.append('rules', rules);
  form.append('prefer_actual', $('#schedule-actual').checked ? 'true' : 'false');
  const bar = $('#schedule-progress');
  setProgress(bar, 0, own ? 'asking for the model’s work schedule…' : `uploading ${file.name}…`);
  $('#schedule-report').hidden = true;
  const res = await uploadInto(bar, projectUrl('/schedules'), form, 'refused');
  for (const sel of ['#schedule-file', '#schedule-rules']) $(sel).value = '';
  $('#schedule-new').open = false;
  setProgress(bar, 0, 'queued for linking');
  await loadSchedules();
  trackJob(res.job);
}

// ---------------------------------------------------------------------------------------------- the date slider
function setDateRange() {
  const schedules = datedSchedules();
  const s = schedules.find((x) => String(x.id) === $('#schedule-select').value) || schedules[0];
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

const scheduleShown = () => !$('#date-panel').hidden && $('#date-on').checked && datedSchedules().length > 0;

// the element states at the slider's date, which colour the model
async function applyDate() {
  if ($('#date-panel').hidden || !state.model) return;
  updateEvalSite();
  if (!$('#date-on').checked) {
    set({ dateStates: null });
    return;
  }
  const date = dateValue();
  const token = Symbol('date');
  dateToken = token;
  try {
    const res = await api.get(projectUrl(`/models/${state.model.id}/states?date=${date}&schedule_id=${$('#schedule-select').value}`));
    if (dateToken !== token) return;
    let counts = res.counts;
    if (!counts) {
      counts = { built: 0, in_progress: 0, not_yet: 0 };
      for (const v of Object.values(res.states)) counts[v] = (counts[v] || 0) + 1;
    }
    set({ dateStates: res.states });
    const label = $('#date-label');
    label.textContent = `${res.date || date}: ${counts.built} built, ${counts.in_progress} in progress, ${counts.not_yet} not yet`;
    Object.assign(label.dataset, { date: res.date || date, built: counts.built, inProgress: counts.in_progress,
      notYet: counts.not_yet });
  } catch (err) {
    if (err.status === 404) {
      $('#date-panel').hidden = true;
      set({ dateStates: null });
    } else showMessage(`The site at ${date}: ${errorText(err)}`, 'error');
  }
}

// ---------------------------------------------------------------------------------------------- the site evaluated
// the site an evaluation will run on: a capture date (typed, else the slider's) and a reality capture
export function evalSite() {
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

export function updateEvalSite() {
  const site = evalSite();
  const bits = [];
  if (site.date) {
    const sched = datedSchedules().find((x) => x.id === site.schedule_id);
    bits.push(`at ${site.date}${sched ? ` (schedule ${sched.name})` : ''}`);
  }
  if (site.reality_id) {
    const r = state.realities.find((x) => x.id === site.reality_id);
    bits.push(`with ${r ? r.name : `capture ${site.reality_id}`} as occluders`);
  }
  $('#eval-site').textContent = bits.length ? `Evaluates the site ${bits.join(', ')}.` : '';
  $('#eval-site').dataset.date = site.date || '';
}

export function bindSchedule() {
  subscribe(['allSchedules', 'info', 'me', 'project'], renderScheduleList);
  onJob('link_schedule', {
    name: () => 'schedule',
    box: '#schedule-progress',
    progress: barProgress('#schedule-progress', 'queued for linking', 'linking'),
    done: async (done) => {
      setProgress($('#schedule-progress'), 1, done.message);
      showMessage(`Schedule linked: ${done.message}.`, 'ok');
      await act('Reading the schedule', async () => {
        if (!state.project || done.project_id !== state.project.id) return;
        await loadSchedules({ prefer: done.schedule_id });
        await showScheduleReport(done.schedule_id);
      });
    },
    failed: (job) => act('Listing the schedules', async () => {
      await loadSchedules();
      if (job.schedule_id) await showScheduleReport(job.schedule_id);
    }),
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
  $('#schedule-own').addEventListener('change', (ev) => { $('#schedule-file').disabled = ev.target.checked; });
  $('#schedule-add').addEventListener('click', () => act('Adding the schedule', addSchedule));
  $('#eval-date').addEventListener('change', updateEvalSite);
  $('#eval-reality').addEventListener('change', updateEvalSite);
}
