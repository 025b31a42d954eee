// sightplan's web page: projects, model upload, plans from templates (with points picked in the 3D view), frame
// editing with undo and redo, evaluation with live progress (at a capture date, with a reality capture as
// occluders), feedback coloured by metric, simulated views, comparisons and flight-app exports, 4D schedules with the
// date slider, reality captures, and in team mode the login, members, roles and share links, on top of the REST API;
// a map of the site; a plan shared by a link, read-only; on a phone or a tablet, the panels as sheets over the view.
//
// The entry point: it makes the 3D viewer, wires each area of the page (one module each, around the state of
// store.js), draws the page once, then reads the server, the user and the project last opened.
import * as api from './api.js';
import { bindAuth, readSession, showLogin } from './auth.js';
import { setViewer, viewer } from './context.js';
import { $, act, errorText, showMessage } from './dom.js';
import { bindEvaluations } from './evaluations.js';
import { bindFrameEdit } from './frameedit.js';
import { bindFrames, selectFrame } from './frames.js';
import { selectElement } from './inspector.js';
import { bindMap } from './map.js';
import { bindModels } from './models.js';
import { bindPicking, pickAt } from './picking.js';
import { addPlan, bindPlans, selectPlan } from './plans.js';
import { bindProjects, loadProjects, selectProject } from './projects.js';
import { bindReality } from './reality.js';
import { bindSchedule } from './schedule.js';
import { renderAll, set, state } from './store.js';
import { openShared, shareToken } from './share.js';
import { bindTeam } from './team.js';
import { bindOptimize } from './optimize.js';
import { bindPhoneLayout } from './phone.js';
import { bindTemplateForm } from './templates.js';
import { installTestHook } from './testhook.js';
import { bindView } from './view.js';
import { Viewer } from './viewer3d.js';

// a click in the 3D view: a point while picking, else a frame's camera, else an element
function onViewClick(hit, ev) {
  if (state.pick) pickAt(ev);
  else if (hit.frame !== undefined) selectFrame(hit.frame, { scroll: true });
  else if (hit.element !== undefined) act('Reading the element', () => selectElement(hit.element));
}

async function init() {
  setViewer(new Viewer($('#canvas-box'), { onClick: onViewClick }));
  viewer.setCompass($('#compass'));
  installTestHook();
  // each area's subscriptions and listeners; the callbacks are what an area asks of one that depends on it
  bindAuth();
  bindProjects();
  bindModels({ reopenProject: () => selectProject(state.project.id) });
  bindPlans();
  bindFrameEdit();
  bindFrames();
  bindView();
  bindEvaluations({ openVersion: (plan, version) => selectPlan(plan, version, { keepEvaluation: true }) });
  bindSchedule();
  bindReality();
  bindTeam({ projectLeft: () => loadProjects(null) });
  bindPicking();
  bindTemplateForm({ planCreated: addPlan });
  bindOptimize({ planCreated: addPlan });
  bindMap();
  bindPhoneLayout();
  renderAll();
  const token = shareToken();
  if (token) {
    api.setUnauthorizedHandler(showLogin);
    await act('Opening the shared plan', () => openShared(token));
    document.body.dataset.state = 'ready';
    return;
  }
  // the session, the cameras and the templates first; the login dialog opens once the page has settled, with its
  // state 'login' at the same moment (a request refused later opens it too)
  let loggedIn = true;
  await act('Reading the server information', async () => {
    loggedIn = await readSession();
    set({ cameras: await api.get('/api/cameras'), templates: await api.get('/api/templates') });
  });
  api.setUnauthorizedHandler(showLogin);
  if (!loggedIn) {
    showLogin();
    document.body.dataset.state = 'login';
    return;
  }
  await loadProjects(Number(localStorage.getItem('sightplan.project')) || null);
  document.body.dataset.state = 'ready';
}

init().catch((err) => {
  document.body.dataset.state = 'error';
  showMessage(`The page could not start: ${errorText(err)}`, 'error');
});
