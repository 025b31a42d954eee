// The Edit frame card: the selected frame of the plan version shown moved, turned, deleted or copied (planedit.js's
// edits of a copy of state.draft, drawn at once, checked once saved), those edits undone and redone (the buttons,
// Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y, ⌘ on a Mac), the Delete key, and the edits saved as a new version or discarded.
// The history keeps what each edit replaced: the draft, its geometry, the frame selected and whether it was edited;
// another plan or version opened (saving and discarding open one) empties it.
import * as api from './api.js';
import { $, $$, act, showMessage } from './dom.js';
import { canEdit, projectUrl, viewer } from './context.js';
import { set, state, subscribe } from './store.js';
import { selectFrame, showFrameView } from './frames.js';
import { loadChecks, loadVersion, selectPlan } from './plans.js';
import { frameColours } from './view.js';
import { clonePlan, copyFrame, deleteFrame, moveFrame, planGeometry, turnFrame } from './planedit.js';

const HISTORY = 100;  // the most edits kept to undo
const MAC = /Mac|iPhone|iPad/.test(navigator.platform);

function updateEditState() {
  const hasFrame = state.selectedFrame !== null && state.draft;
  $('#sec-edit').classList.toggle('disabled', !hasFrame);
  $('#plan-save').disabled = !state.dirty;
  $('#plan-discard').disabled = !state.dirty;
  $('#edit-undo').disabled = !state.undo.length;
  $('#edit-redo').disabled = !state.redo.length;
  $('#edit-status').textContent = state.dirty ? 'Edited: save as a new version, then evaluate it.'
    : hasFrame ? '' : 'Select a frame (click a camera in the 3D view or a row of the frame list).';
  if (!hasFrame) $('#edit-frame-label').textContent = '';
}

// what an edit replaces, and what undoing it brings back
const snapshot = () => ({ draft: state.draft, geom: state.geom, selectedFrame: state.selectedFrame, dirty: state.dirty });

// a draft drawn with the frame selected: an edited one is not checked until saved, the saved one is checked again
function show({ draft, geom, selectedFrame, dirty }) {
  set({ draft, selectedFrame, dirty, checks: null, geom });
  viewer.setPlan(geom, frameColours(), null);
  viewer.select(state.selectedFrame);
  showFrameView();
  if (!dirty) {
    loadChecks();
    return;
  }
  $('#checks-summary').textContent = 'The plan is edited: save it to check the flight again.';
  $('#missions-table tbody').replaceChildren();
  $('#violations').replaceChildren();
}

// an edited copy of the draft (and the frame selected after the edit)
function edited(draft, selectedFrame = state.selectedFrame) {
  set({ undo: [...state.undo, snapshot()].slice(-HISTORY), redo: [] });
  show({ draft, geom: planGeometry(draft), selectedFrame, dirty: true });
}

function undo() {
  const back = state.undo.at(-1);
  if (!back) return;
  set({ undo: state.undo.slice(0, -1), redo: [...state.redo, snapshot()] });
  show(back);
}

function redo() {
  const forward = state.redo.at(-1);
  if (!forward) return;
  set({ undo: [...state.undo, snapshot()].slice(-HISTORY), redo: state.redo.slice(0, -1) });
  show(forward);
}

// an edit of the draft by another area of the page (the map places a pilot): change(draft) on a copy, then drawn,
// undone like the card's own
export function editDraft(change) {
  if (!state.draft) throw new Error('open a plan first');
  const draft = clonePlan(state.draft);
  change(draft);
  edited(draft);
}

function needFrame() {
  if (state.selectedFrame === null || !state.draft) throw new Error('select a frame first');
  return state.selectedFrame;
}

function move(delta) {
  const i = needFrame();
  const draft = clonePlan(state.draft);
  moveFrame(draft, i, delta);
  edited(draft);
}

function turn(yaw, pitch) {
  const i = needFrame();
  const draft = clonePlan(state.draft);
  turnFrame(draft, i, yaw, pitch);
  edited(draft);
}

async function removeFrame() {
  const i = needFrame();
  const draft = clonePlan(state.draft);
  deleteFrame(draft, i);
  edited(draft, Math.min(i, draft.frames.length - 1));
}

async function savePlan() {
  if (!state.dirty) throw new Error('nothing to save: the plan is not edited');
  const plan = await api.put(projectUrl(`/plans/${state.plan.id}?note=${encodeURIComponent('edited in the viewer')}`), state.draft);
  set({ plans: state.plans.map((p) => (p.id === plan.id ? plan : p)), dirty: false });
  showMessage(`Saved as version ${plan.latest_version} of “${plan.name}”.`, 'ok');
  await selectPlan(plan.id, plan.latest_version);
  if (state.selectedFrame !== null) selectFrame(state.selectedFrame);
}

// the card's keys: not while typing in a field or with a dialog open, nor for a role that may not edit
function onKey(ev) {
  if (ev.defaultPrevented || ev.altKey || !state.draft || !canEdit()) return;
  const t = ev.target;
  if (t instanceof Element && (t.closest('input, select, textarea') || t.isContentEditable)) return;
  if ($('dialog[open]')) return;
  const key = ev.key.toLowerCase();
  const command = ev.ctrlKey || ev.metaKey;
  let action = null;
  if (command && key === 'z') action = ev.shiftKey ? ['Redoing the edit', redo] : ['Undoing the edit', undo];
  else if (command && !ev.shiftKey && key === 'y') action = ['Redoing the edit', redo];
  else if (!command && !ev.shiftKey && (ev.key === 'Delete' || (MAC && ev.key === 'Backspace'))
    && state.selectedFrame !== null) action = ['Deleting the frame', removeFrame];
  if (!action) return;
  ev.preventDefault();
  act(action[0], async () => action[1]());
}

export function bindFrameEdit() {
  subscribe(['selectedFrame', 'draft', 'dirty', 'undo', 'redo'], updateEditState);
  subscribe(['saved'], () => set({ undo: [], redo: [] }));  // another version opened (or none)
  for (const b of $$('[data-move]')) {
    b.addEventListener('click', () => act('Moving the frame', async () => {
      const step = Number($('#move-step').value) || 1;
      const bearing = { 'y+': 0, 'x+': 90, 'y-': 180, 'x-': 270 }[b.dataset.move];
      if (bearing !== undefined && state.northOffset !== null) {  // N, E, S, W: true directions on a georeferenced plan
        const a = ((bearing - state.northOffset) * Math.PI) / 180;
        move([step * Math.sin(a), step * Math.cos(a), 0]);
        return;
      }
      const axis = 'xyz'.indexOf(b.dataset.move[0]);
      const d = [0, 0, 0];
      d[axis] = b.dataset.move[1] === '+' ? step : -step;
      move(d);
    }));
  }
  $('#move-apply').addEventListener('click', () => act('Moving the frame', async () => {
    const d = ['#move-dx', '#move-dy', '#move-dz'].map((s) => Number($(s).value) || 0);
    if (d.every((v) => v === 0)) throw new Error('give dx, dy or dz in metres');
    move(d);
  }));
  for (const b of $$('[data-rotate]')) {
    b.addEventListener('click', () => act('Turning the frame', async () => {
      const step = Number($('#rot-step').value) || 5;
      const sign = b.dataset.rotate.endsWith('+') ? 1 : -1;
      if (b.dataset.rotate.startsWith('yaw')) turn(sign * step, 0);
      else turn(0, sign * step);
    }));
  }
  $('#frame-delete').addEventListener('click', () => act('Deleting the frame', removeFrame));
  $('#frame-copy').addEventListener('click', () => act('Copying the frame', async () => {
    const i = needFrame();
    const draft = clonePlan(state.draft);
    edited(draft, copyFrame(draft, i));
  }));
  $('#frame-look').addEventListener('click', () => act('Looking through the frame', async () => viewer.lookThrough(needFrame())));
  $('#edit-undo').addEventListener('click', () => act('Undoing the edit', async () => undo()));
  $('#edit-redo').addEventListener('click', () => act('Redoing the edit', async () => redo()));
  window.addEventListener('keydown', onKey);
  $('#plan-save').addEventListener('click', () => act('Saving the plan', savePlan));
  $('#plan-discard').addEventListener('click', () => act('Discarding the edits', () => loadVersion(state.version)));
}
