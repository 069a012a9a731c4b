// A generated flight's ground truth as zonemap-sim writes it (objects.yaml,
// groundtruth.txt), read independently of the project's C++ code, and the
// horizontal geometry of obstacles about the vehicle (world z up, body FRD).
import fs from 'node:fs';
import path from 'node:path';

export const DEG = Math.PI / 180;

export function readObjects(file) {
  const objects = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    const name = /name: ([^,}]+)/.exec(line);
    if (!name) continue;
    const nums = (key) => {
      const m = new RegExp(key + ': \\[([^\\]]+)\\]').exec(line);
      return m ? m[1].split(',').map(Number) : null;
    };
    if (/type: cylinder/.test(line)) {
      const c = nums('center');
      const z = nums('z');
      objects.push({ name: name[1].trim(), kind: 'cylinder', cx: c[0], cy: c[1],
        r: Number(/radius: ([0-9.]+)/.exec(line)[1]), z0: z[0], z1: z[1] });
    } else if (/type: box/.test(line)) {
      const lo = nums('min');
      const hi = nums('max');
      objects.push({ name: name[1].trim(), kind: 'box', lo, hi, z0: lo[2], z1: hi[2] });
    }
  }
  return objects;
}

export function readPoses(file) {
  const poses = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    if (!line.trim() || line.startsWith('#')) continue;
    const [t, x, y, z, qx, qy, qz, qw] = line.trim().split(/\s+/).map(Number);
    // Rotation world <- camera (optical: x right, y down, z forward).
    const R = [
      [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
      [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
      [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ];
    const col = (j) => [R[0][j], R[1][j], R[2][j]];
    // No mount in camera.yaml: the camera looks along the nose, so body FRD axes
    // are the optical z (forward), x (right) and y (down).
    poses.push({ t, p: [x, y, z], forward: col(2), right: col(0), down: col(1), opticalX: col(0) });
  }
  return poses;
}

export const poseAt = (poses, t) =>
  poses.reduce((best, p) => (Math.abs(p.t - t) < Math.abs(best.t - t) ? p : best), poses[0]);

// Horizontal geometry about the vehicle (world z up).
export function horizontalAxes(pose) {
  const f = [pose.forward[0], pose.forward[1]];
  const n = Math.hypot(f[0], f[1]);
  const fwd = [f[0] / n, f[1] / n];
  return { fwd, right: [fwd[1], -fwd[0]] }; // right = down x forward with down = -z
}

// Nearest point of an object's footprint to (x, y), and its distance.
export function nearestOnObject(o, x, y) {
  if (o.kind === 'cylinder') {
    const dx = x - o.cx;
    const dy = y - o.cy;
    const d = Math.hypot(dx, dy);
    return { x: o.cx + (dx / d) * o.r, y: o.cy + (dy / d) * o.r, d: Math.max(0, d - o.r) };
  }
  const qx = Math.min(Math.max(x, o.lo[0]), o.hi[0]);
  const qy = Math.min(Math.max(y, o.lo[1]), o.hi[1]);
  return { x: qx, y: qy, d: Math.hypot(qx - x, qy - y) };
}

// Bearing of a world point from the vehicle, clockwise from its nose, in [0, 2 pi).
export function bearingOf(pose, wx, wy) {
  const a = horizontalAxes(pose);
  const v = [wx - pose.p[0], wy - pose.p[1]];
  let b = Math.atan2(v[0] * a.right[0] + v[1] * a.right[1], v[0] * a.fwd[0] + v[1] * a.fwd[1]);
  if (b < 0) b += 2 * Math.PI;
  return b;
}

// A daemon's vehicle.yaml replaying SEQUENCE live at rateHz with the sequence's
// poses, its outputs in outDir, and the given MAVLink output line (or none).
export function writeReplayVehicleYaml(file, { mapping, sequence, rateHz, outDir, mavlink, poses }) {
  fs.writeFileSync(file, [
    `mapping: ${path.resolve(mapping)}`,
    'live: true',
    `frames: {source: replay, sequence: ${path.resolve(sequence)}, rate_hz: ${rateHz}}`,
    `poses: ${poses ?? '{source: sequence}'}`,
    'outputs:',
    `  directory: ${path.resolve(outDir)}`,
    ...(mavlink ? [`  mavlink: ${mavlink}`] : []),
    '',
  ].join('\n'));
  return file;
}
