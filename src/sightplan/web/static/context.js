// What the areas of the page share beyond the store: the 3D viewer, the URLs of the project shown, the user's role
// in it, and values derived from the state (which feedback applies to what is shown, the colour bounds).
import { state } from './store.js';

export let viewer = null;  // the Viewer of viewer3d.js, made once by app.js

export function setViewer(v) {
  viewer = v;
}

// a project's URLs; in a share view, the same paths below the share link
export const projectUrl = (path = '') => (state.share ? `/api/shared/${state.share}${path}`
  : `/api/projects/${state.project.id}${path}`);

// the user's role in the project shown; null in single-user mode, where everyone may do everything
export function projectRole() {
  if (!state.info || !state.info.login || !state.project) return null;
  return state.project.role || (state.me && state.me.projects && state.me.projects[state.project.id]) || null;
}

export const canEdit = () => !state.share && (!(state.info && state.info.login) || ['editor', 'owner'].includes(projectRole()));
export const isOwner = () => !state.share && (!(state.info && state.info.login) || projectRole() === 'owner');

// the feedback shown is of the plan version shown, unedited
export function feedbackMatchesPlan() {
  const { feedback, plan } = state;
  return Boolean(feedback && plan && !state.dirty && feedback.plan_id === plan.id && feedback.plan_version === state.version);
}

// the feedback shown, when it is of the model selected
export function feedbackOfModel() {
  const { feedback, model } = state;
  return feedback && model && feedback.model_id === model.id ? feedback : null;
}

// the mission of frame i of the plan shown (its index), or null
export function missionOf(i) {
  const missions = state.geom ? state.geom.missions : [];
  const k = missions.findIndex((m) => i >= m.start && i < m.stop);
  return k < 0 ? null : k;
}

// the bounds of the metric the model is coloured by: set by the user, else the feedback's
export function currentBounds() {
  if (state.metric === 'visibility' || !state.colourer) return [null, null];
  return state.bounds[state.metric] || state.colourer.defaultBounds(state.metric);
}
