// The page's test hook: window.sightplanTest, what the browser tests (tests/test_web_browser*.py) read of the page
// beyond what it shows. Read-only: named getters that return values or copies, never the store or the viewer's
// own objects (the one exception, view.viewer(), is for a test that drives the camera to time frames).
//
//   dirty()              the plan version shown has unsaved edits
//   planId(), planName(), planVersion()
//                        the plan and version shown (null without one)
//   frameCount()         frames of the plan version shown, edits included (null before one is read)
//   selectedFrame()      the frame selected (an index), or null
//   framePose(i)         frame i of the version shown, edits included: { position, rotation (row-major, 9) }, or null
//   flightChecked()      the flight checks of the version shown have arrived
//   evaluationId()       the evaluation whose feedback colours the page, or null
//   evaluation()         that evaluation: { id, planId, planVersion, modelId, settings } (a copy), or null
//   siteAtDate()         the element states at the date slider's date are read (the model is shown at a date)
//   elementColour(e)     element e's look in the 3D view: { rgb: [r, g, b] (sRGB, 0–1), mode: 'solid'|'ghost'|… }
//   view.modelTriangles()          triangles of the model drawn, or null
//   view.planFrames()              frames drawn, or null
//   view.markers()                 the points drawn for the plan form: [{ points, colour, line }]
//   view.screenPoint([x, y, z])    where a model point is on screen: { x, y, inView } (client pixels)
//   view.frameScreenPoint(i), view.elementScreenPoint(e)
//                                  where frame i's centre is; a point where element e is the first thing hit (or null)
//   view.flightLines()             the take-off and return lines drawn: [{ name, segments }]
//   view.highlightedElement()      the element outlined, or null
//   view.realityInfo()             each reality capture drawn: { id, kind, shown, box, triangles, pointsVisible, … }
//   view.toViewer([x, y, z])       a model point in the viewer's frame
//   view.viewer()                  the Viewer itself
//   map.ready(), map.site(), map.drawn(source), map.screenPoint(lat, lon), map.toLatLon([x, y])
//                                  the map: loaded, the site answer, a source's GeoJSON, where a point is on screen
import { viewer } from './context.js';
import { mapHook } from './map.js';
import { state } from './store.js';

const copy = (v) => (v === undefined || v === null ? null : JSON.parse(JSON.stringify(v)));

export function installTestHook() {
  const view = Object.freeze({
    modelTriangles: () => (viewer.model ? viewer.model.geo.header.triangles : null),
    planFrames: () => (viewer.plan ? viewer.plan.n : null),
    markers: () => copy(viewer.markers),
    screenPoint: (p) => viewer.screenPoint(p),
    frameScreenPoint: (i) => viewer.frameScreenPoint(i),
    elementScreenPoint: (e) => viewer.elementScreenPoint(e),
    flightLines: () => (viewer.plan && viewer.plan.stations ? viewer.plan.stations.children.filter((o) => o.isLineSegments)
      .map((o) => ({ name: o.name, segments: o.geometry.getAttribute('position').count / 2 })) : []),
    highlightedElement: () => (viewer.highlight ? viewer.highlight.userData.element : null),
    realityInfo: () => viewer.realityInfo(),
    toViewer: (p) => viewer.toViewer(p),
    viewer: () => viewer,
  });
  window.sightplanTest = Object.freeze({
    dirty: () => state.dirty,
    planId: () => (state.plan ? state.plan.id : null),
    planName: () => (state.plan ? state.plan.name : null),
    planVersion: () => (state.plan ? state.version : null),
    frameCount: () => (state.geom ? state.geom.position.length : null),
    selectedFrame: () => state.selectedFrame,
    framePose: (i) => (state.geom && i >= 0 && i < state.geom.position.length
      ? { position: copy(state.geom.position[i]), rotation: copy(state.geom.rotation[i]) } : null),
    flightChecked: () => state.checks !== null,
    evaluationId: () => (state.evaluation && state.feedback ? state.evaluation.id : null),
    evaluation: () => {
      const e = state.feedback && state.evaluation;
      return e ? { id: e.id, planId: e.plan_id, planVersion: e.plan_version, modelId: e.model_id, settings: copy(e.settings) }
        : null;
    },
    siteAtDate: () => state.dateStates !== null,
    elementColour: (e) => viewer.elementAppearance(e),
    view,
    map: mapHook,
  });
}
