// Points picked in the 3D view: while picking, a click on the model or the ground hands its point [x, y, z] (model
// frame, metres) to whoever started it. One kind of point at a time; Esc, the same button again, or a role that
// may not edit stops it. state.pick is the kind being picked (also body[data-picking]).
import { $, showMessage } from './dom.js';
import { canEdit, viewer } from './context.js';
import { set, state, subscribe } from './store.js';

let active = null;  // { button, onPoint } of the picking under way

// pick points of this kind (a name, e.g. 'stations'): button shows "done picking" meanwhile, what names a point
// in the hint, onPoint(point) takes each one; started again, it stops
export function startPicking(kind, { button, what, onPoint }) {
  if (state.pick === kind) {
    stopPicking();
    return;
  }
  stopPicking();
  if (!viewer.model) throw new Error('pick points once the model is shown');
  active = { button, onPoint };
  set({ pick: kind });
  button.classList.add('active');
  button.textContent = 'done picking';
  document.body.dataset.picking = kind;
  $('#view-status').textContent = `Click the model or the ground to add ${what} (Esc or “done picking” to stop).`;
}

export function stopPicking() {
  if (!state.pick) return;
  active.button.classList.remove('active');
  active.button.textContent = 'pick in 3D';
  active = null;
  delete document.body.dataset.picking;
  set({ pick: null });
}

// a click in the 3D view while picking
export function pickAt(ev) {
  const hit = viewer.pickPoint(ev.clientX, ev.clientY);
  if (!hit) {
    showMessage('Nothing there: click the model or the ground.', 'info');
    return;
  }
  active.onPoint(hit.point);
}

export function bindPicking() {
  subscribe(['info', 'me', 'project'], () => {
    if (!canEdit()) stopPicking();
  });
  window.addEventListener('keydown', (ev) => {
    if (ev.key === 'Escape' && state.pick) stopPicking();
  });
}
