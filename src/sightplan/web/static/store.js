// The page's state, in one place. Every change goes through set(patch); render functions subscribe
// to the keys they read and run after a change of any of them.
//
//   import { set, state, subscribe } from './store.js';
//   subscribe(['plans', 'plan'], renderPlans);     // runs after each change of state.plans or state.plan
//   set({ plans: [...state.plans, plan] });        // a new value: never change one in place
//
// `state` is a read-only view: an assignment through it throws. A change is seen when a key gets
// another value (Object.is), so arrays, sets and objects are replaced, not changed in place. A set() made while
// subscribers run is applied at once; its subscribers run after the current ones, once each.

const S = {
  share: null,  // the token of a share view (/shared/{token}), else null
  info: null, cameras: [], templates: [], me: null, projects: [], project: null, members: [], links: [],
  models: [], model: null, elements: null, geometryModel: null, fitted: null,
  plans: [], plan: null, version: null, saved: null, draft: null, dirty: false, geom: null, checks: null,
  undo: [], redo: [],  // the frame edits of the draft to undo and to redo (frameedit.js), the latest last
  northOffset: null,  // degrees from a model heading to the true heading (the plan's georeference), or null
  evaluations: [], evaluation: null, feedback: null, colourer: null, compareChosen: false,
  metric: 'visibility', bounds: {}, frameColourChosen: false, selectedFrame: null, selectedElement: null,
  site: null,  // where the model shown stands (GET …/models/{id}/site), for the map
  background: null,  // the project's own map background (GET …/basemap), or null
  allSchedules: [], dateStates: null, realities: [], realityHidden: new Set(), pick: null,
};

const refuse = (key) => {
  throw new TypeError(`state.${String(key)} is read-only: change it with set({ ${String(key)}: … })`);
};

export const state = new Proxy(S, {
  set: (_, key) => refuse(key),
  deleteProperty: (_, key) => refuse(key),
  defineProperty: (_, key) => refuse(key),
});

const subscribers = [];
let pending = null;  // keys changed while subscribers run

function known(key) {
  if (!Object.hasOwn(S, key)) throw new Error(`the page's state has no ${key}`);
}

export function set(patch) {
  const changed = [];
  for (const [key, value] of Object.entries(patch)) {
    known(key);
    if (!Object.is(S[key], value)) {
      S[key] = value;
      changed.push(key);
    }
  }
  if (changed.length) notify(changed);
}

// fn(state) after every change of one of keys; returns a function that ends the subscription
export function subscribe(keys, fn) {
  keys.forEach(known);
  const sub = { keys: new Set(keys), fn };
  subscribers.push(sub);
  return () => {
    const k = subscribers.indexOf(sub);
    if (k >= 0) subscribers.splice(k, 1);
  };
}

// every subscriber once: the page's first render
export function renderAll() {
  notify([], true);
}

function notify(keys, all = false) {
  if (pending) {
    for (const key of keys) pending.add(key);
    return;
  }
  pending = new Set(keys);
  let first = all;
  try {
    while (first || pending.size) {
      const changed = pending;
      pending = new Set();
      run(first ? () => true : (sub) => [...sub.keys].some((key) => changed.has(key)));
      first = false;
    }
  } finally {
    pending = null;
  }
}

// the subscribers chosen, each once; one that fails does not stop the others (the first error is thrown after)
function run(chosen) {
  let failure = null;
  for (const sub of [...subscribers]) {
    if (!chosen(sub)) continue;
    try {
      sub.fn(state);
    } catch (err) {
      failure ??= err;
    }
  }
  if (failure) throw failure;
}
