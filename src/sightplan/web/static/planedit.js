// Edits of a plan JSON (sightplan plan format, version 1) before it is saved as a new version: move, turn, delete or
// copy one frame. Missions stay consecutive frame ranges; waypoints that mirror the frames follow them.
// Rotations are R_world_camera (columns: the camera's right, down and forward axes in the model frame, Z up).

const DEG = Math.PI / 180;

export function clonePlan(plan) {
  return JSON.parse(JSON.stringify(plan));
}

function mul(A, B) {
  return [0, 1, 2].map((r) => [0, 1, 2].map((c) => A[r][0] * B[0][c] + A[r][1] * B[1][c] + A[r][2] * B[2][c]));
}

// heading clockwise from north (+Y) seen from above, pitch up from the horizon, both in degrees
export function headingPitch(R) {
  const f = [R[0][2], R[1][2], R[2][2]];
  const heading = (Math.atan2(f[0], f[1]) / DEG + 360) % 360;
  const pitch = Math.asin(Math.max(-1, Math.min(1, f[2]))) / DEG;
  return { heading, pitch };
}

function waypointsFollow(plan) {
  return Array.isArray(plan.waypoints) && plan.waypoints.length === plan.frames.length;
}

export function moveFrame(plan, i, [dx, dy, dz]) {
  const f = plan.frames[i];
  f.position = [f.position[0] + dx, f.position[1] + dy, f.position[2] + dz];
  if (waypointsFollow(plan)) plan.waypoints[i] = [...f.position];
}

// turn the heading clockwise by yawDeg (about the vertical), then tilt the camera up by pitchDeg (about its own
// right axis); refused past straight up or straight down
export function turnFrame(plan, i, yawDeg, pitchDeg) {
  const f = plan.frames[i];
  if (!f.rotation) throw new Error(`frame ${i} gives no rotation matrix`);
  let R = f.rotation;
  if (yawDeg) {
    const a = -yawDeg * DEG;  // clockwise seen from above = negative about +Z
    const Rz = [[Math.cos(a), -Math.sin(a), 0], [Math.sin(a), Math.cos(a), 0], [0, 0, 1]];
    R = mul(Rz, R);
  }
  if (pitchDeg) {
    const before = headingPitch(R).pitch;
    if (before + pitchDeg > 90 + 1e-9 || before + pitchDeg < -90 - 1e-9) {
      throw new Error(`the camera would pitch to ${(before + pitchDeg).toFixed(1)}°, past ±90°`);
    }
    const b = pitchDeg * DEG;  // about the camera's x (right): forward tilts towards −y (up in the image)
    const Rx = [[1, 0, 0], [0, Math.cos(b), -Math.sin(b)], [0, Math.sin(b), Math.cos(b)]];
    R = mul(R, Rx);
  }
  f.rotation = R;
}

export function deleteFrame(plan, i) {
  if (plan.frames.length <= 1) throw new Error('a plan needs at least one frame');
  plan.frames.splice(i, 1);
  if (Array.isArray(plan.waypoints) && plan.waypoints.length === plan.frames.length + 1) plan.waypoints.splice(i, 1);
  if (Array.isArray(plan.missions)) {
    for (const m of plan.missions) {
      const [a, b] = m.frames;
      m.frames = [i < a ? a - 1 : a, i < b ? b - 1 : b];
    }
    plan.missions = plan.missions.filter((m) => m.frames[1] > m.frames[0]);
  }
}

// a copy of frame i right after it, in the same mission
export function copyFrame(plan, i) {
  const f = JSON.parse(JSON.stringify(plan.frames[i]));
  const names = new Set(plan.frames.map((x) => x.name));
  let k = 2;
  while (names.has(`${plan.frames[i].name} copy ${k}`)) k++;
  f.name = names.has(`${plan.frames[i].name} copy`) ? `${plan.frames[i].name} copy ${k}` : `${plan.frames[i].name} copy`;
  const follow = waypointsFollow(plan);
  plan.frames.splice(i + 1, 0, f);
  if (follow) plan.waypoints.splice(i + 1, 0, [...f.position]);
  if (Array.isArray(plan.missions)) {
    for (const m of plan.missions) {
      const [a, b] = m.frames;
      m.frames = [a > i ? a + 1 : a, b > i ? b + 1 : b];
    }
  }
  return i + 1;
}

// the viewer's form of a plan JSON: positions, row-major rotations, cameras with their fields of view
export function planGeometry(plan) {
  const cameras = {};
  for (const [id, c] of Object.entries(plan.cameras)) {
    cameras[id] = c.model === 'pinhole'
      ? { ...c, hfov_deg: (2 * Math.atan(c.width / (2 * c.fx))) / DEG, vfov_deg: (2 * Math.atan(c.height / (2 * c.fy))) / DEG }
      : { ...c };
  }
  const only = Object.keys(plan.cameras).length === 1 ? Object.keys(plan.cameras)[0] : null;
  const n = plan.frames.length;
  return {
    position: plan.frames.map((f) => f.position),
    rotation: plan.frames.map((f) => f.rotation.flat()),
    camera: plan.frames.map((f) => f.camera || only),
    name: plan.frames.map((f, i) => f.name || `frame_${String(i).padStart(5, '0')}`),
    cameras,
    missions: (plan.missions || [{ name: 'mission 1', frames: [0, n] }]).map((m) => ({
      name: m.name, start: m.frames[0], stop: m.frames[1], ground_station: m.ground_station || null })),
  };
}
