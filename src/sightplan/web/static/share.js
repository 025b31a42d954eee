// The share view: a share link opened in a browser (/shared/{token}). The same page, read-only and without an
// account: the shared plan's model, map, versions, flight checks, evaluations with their metrics and feedback, and
// exports, read from /api/shared/{token}/… (context.js points every project URL there). Nothing that changes
// anything is offered (canEdit() is false), and nothing of the project beyond the plan is read.
import * as api from './api.js';
import { $ } from './dom.js';
import { selectModel } from './models.js';
import { selectPlan } from './plans.js';
import { set } from './store.js';

// the token of a share view's address, or null on the ordinary page
export function shareToken() {
  const m = /^\/shared\/([A-Za-z0-9_-]+)\/?$/.exec(window.location.pathname);
  return m ? m[1] : null;
}

export async function openShared(token) {
  document.body.dataset.shared = '';
  set({ share: token });
  const info = await api.get('/api/info');
  set({ info });
  const badge = $('#mode-badge');
  badge.textContent = 'shared · read-only';
  badge.title = 'A plan shared by a link: anyone with the link sees it; nothing can be changed here.';
  let shared;
  try {
    shared = await api.get(`/api/shared/${token}`);
  } catch (err) {
    if (err.status === 404) {
      $('#view-empty').textContent = 'This share link does not exist or was revoked: ask whoever sent it for a new one.';
      return false;
    }
    throw err;
  }
  const { plan, model, evaluations } = shared;
  document.title = `${plan.name} — sightplan (shared)`;
  set({ project: { id: 0, name: plan.name, role: 'viewer' }, projects: [], models: model ? [model] : [],
    plans: [plan], evaluations });
  $('#shared-title').textContent = `Shared plan “${plan.name}”`;
  if (model && model.status === 'ready') await selectModel(model.id);
  await selectPlan(plan.id);
  return true;
}
