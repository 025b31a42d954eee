// The flight around a plan in the 3D view, and its compass: the pilots' stations (a cone each, with the line-of-sight circle) and each
// mission's checked flight out (take-off climb, flight over to the first waypoint, descent to it; green) and home
// (climb from the last waypoint, flight back, landing; amber), as the flight checks found them.
import * as THREE from 'three';

export const TAKEOFF_COLOUR = 0x0b7a3e;
export const RETURN_COLOUR = 0xd97706;

// line segments along the (n, 3) model-frame polylines
function polylines(lines, colour, opacity, toViewer) {
  const seg = [];
  for (const line of lines) {
    for (let k = 0; k + 1 < line.length; k++) seg.push(...toViewer(line[k]), ...toViewer(line[k + 1]));
  }
  if (!seg.length) return null;
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(seg, 3));
  return new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: colour, transparent: true, opacity }));
}

/** A group of the plan's stations and trajectory. plan: the geometry endpoint's; checks: the checks endpoint's answer
 * or null (then a line from each mission's pilot to its first frame); size: the frames' drawing size; toViewer:
 * model point → viewer point. */
export function flightGroup(plan, checks, size, toViewer) {
  const group = new THREE.Group();
  const seen = new Map();
  plan.missions.forEach((ms) => {
    if (ms.ground_station) seen.set(ms.ground_station.join(','), ms.ground_station);
  });
  const vlos = checks && checks.vlos_radius_m;
  for (const gs of seen.values()) {
    const p = toViewer(gs);
    const cone = new THREE.Mesh(new THREE.ConeGeometry(0.45 * size, 1.3 * size, 16),
      new THREE.MeshLambertMaterial({ color: TAKEOFF_COLOUR }));
    cone.position.set(p[0], p[1] + 0.65 * size, p[2]);
    group.add(cone);
    if (vlos) {
      const ring = [];
      for (let k = 0; k <= 128; k++) {
        const a = (k / 128) * Math.PI * 2;
        ring.push(p[0] + vlos * Math.cos(a), p[1], p[2] + vlos * Math.sin(a));
      }
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(ring, 3));
      group.add(new THREE.Line(g, new THREE.LineDashedMaterial({ color: TAKEOFF_COLOUR, dashSize: vlos / 40,
        gapSize: vlos / 60 })).computeLineDistances());
    }
  }
  const trajectory = (checks && checks.trajectory) || [];
  const parts = trajectory.length
    ? [['flight out', trajectory.map((t) => t.out), TAKEOFF_COLOUR, 0.85],
      ['flight home', trajectory.map((t) => t.home), RETURN_COLOUR, 0.85]]
    : [['to the first frame', plan.missions.filter((ms) => ms.ground_station && ms.stop > ms.start)
      .map((ms) => [ms.ground_station, plan.position[ms.start]]), TAKEOFF_COLOUR, 0.5]];
  for (const [name, lines, colour, opacity] of parts) {
    const drawn = polylines(lines, colour, opacity, toViewer);
    if (drawn) {
      drawn.name = name;
      group.add(drawn);
    }
  }
  return group;
}

/** The compass needle's CSS rotation (degrees): the screen direction of north at the orbit target, true north when
 * ``northOffset`` (degrees from a model heading to the true heading) is known, else model +Y (viewer −Z). */
export function compassAngle(camera, target, radius, northOffset, box) {
  const a = target.clone().project(camera);
  const n = -((northOffset || 0) * Math.PI) / 180;  // true north's model heading
  const r = Math.max(radius || 1, 1);
  const b = target.clone().add(new THREE.Vector3(r * Math.sin(n), 0, -r * Math.cos(n))).project(camera);
  const angle = Math.atan2(-(b.y - a.y) * box.clientHeight, (b.x - a.x) * box.clientWidth);
  return 90 - (angle * 180) / Math.PI;
}
