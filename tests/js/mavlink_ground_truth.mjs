// What the flight controller receives, decoded by node-mavlink (a MAVLink
// implementation nobody on this project wrote) and checked against the flight's
// ground truth: the daemon replays a generated flight at camera rate and sends
// OBSTACLE_DISTANCE, OBSTACLE_DISTANCE_3D and HEARTBEAT to a UDP socket of ours.
//
//   node mavlink_ground_truth.mjs DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed
// (npm unreachable when the tests were set up): skipped, with the reason.
import { spawn } from 'node:child_process';
import dgram from 'node:dgram';
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
let mavlink;
try {
  mavlink = require('node-mavlink');
} catch (e) {
  console.log('SKIP: node-mavlink is not installed (npm unreachable when tools/test set up tests/js)');
  process.exit(77);
}
const { MavLinkPacketSplitter, MavLinkPacketParser, minimal, common, ardupilotmega } = mavlink;
const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY, ...ardupilotmega.REGISTRY };

const [daemon, sequence, mappingConfig, workDir] = process.argv.slice(2);
if (!workDir) {
  console.error('usage: node mavlink_ground_truth.mjs DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR');
  process.exit(2);
}
fs.mkdirSync(workDir, { recursive: true });

const RATE_HZ = 10;
const DEG = Math.PI / 180;
const SECTOR = 5 * DEG;
const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
  return ok;
};

// ---- ground truth: objects.yaml (as zonemap-sim writes it) and groundtruth.txt
function readObjects(file) {
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
function readPoses(file) {
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
const poseAt = (poses, t) =>
  poses.reduce((best, p) => (Math.abs(p.t - t) < Math.abs(best.t - t) ? p : best), poses[0]);

// Horizontal geometry about the vehicle (world z up).
function horizontalAxes(pose) {
  const f = [pose.forward[0], pose.forward[1]];
  const n = Math.hypot(f[0], f[1]);
  const fwd = [f[0] / n, f[1] / n];
  return { fwd, right: [fwd[1], -fwd[0]] }; // right = down x forward with down = -z
}
// Nearest point of an object's footprint to (x, y), and its distance.
function nearestOnObject(o, x, y) {
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
function bearingOf(pose, wx, wy) {
  const a = horizontalAxes(pose);
  const v = [wx - pose.p[0], wy - pose.p[1]];
  let b = Math.atan2(v[0] * a.right[0] + v[1] * a.right[1], v[0] * a.fwd[0] + v[1] * a.fwd[1]);
  if (b < 0) b += 2 * Math.PI;
  return b;
}
const sectorOf = (bearing) => Math.floor(bearing / SECTOR + 0.5) % 72;
const sectorGap = (a, b) => Math.min((a - b + 72) % 72, (b - a + 72) % 72);

// ---- run the daemon against a socket of ours
const objects = readObjects(path.join(sequence, 'objects.yaml'));
const poses = readPoses(path.join(sequence, 'groundtruth.txt'));
const camera = fs.readFileSync(path.join(sequence, 'camera.yaml'), 'utf8');
const fx = Number(/fx: ([0-9.]+)/.exec(camera)[1]);
const width = Number(/width: ([0-9]+)/.exec(camera)[1]);
const halfFov = Math.atan(width / 2 / fx);
const cell = Number(/cell_size_m: ([0-9.]+)/.exec(fs.readFileSync(mappingConfig, 'utf8'))[1]);

const socket = dgram.createSocket('udp4');
const datagrams = []; // [bytes, arrival time in s], decoded after the run
socket.on('message', (msg) => datagrams.push([msg, Number(process.hrtime.bigint()) / 1e9]));
await new Promise((resolve) => socket.bind(0, '127.0.0.1', resolve));
const port = socket.address().port;

const vehicleYaml = path.join(workDir, 'vehicle.yaml');
fs.writeFileSync(vehicleYaml, [
  `mapping: ${path.resolve(mappingConfig)}`,
  'live: true',
  `frames: {source: replay, sequence: ${path.resolve(sequence)}, rate_hz: ${RATE_HZ}}`,
  'poses: {source: sequence}',
  'outputs:',
  `  directory: ${path.resolve(workDir, 'out')}`,
  `  mavlink: {host: 127.0.0.1, port: ${port}, rate_hz: ${RATE_HZ}, system_id: 42, component_id: 195}`,
  '',
].join('\n'));
const child = spawn(daemon, ['--config', vehicleYaml], { stdio: ['ignore', 'inherit', 'pipe'] });
let daemonLog = '';
child.stderr.on('data', (d) => { daemonLog += d; });
const exitCode = await new Promise((resolve) => child.on('exit', (code) => resolve(code)));
if (!check(exitCode === 0, `daemon exited ${exitCode}: ${daemonLog}`)) {
  console.log(failures.join('\n'));
  process.exit(1);
}
// Synchronise on what the daemon says it sent (stats.json), not on time.
const stats = JSON.parse(fs.readFileSync(path.join(workDir, 'out', 'stats.json'), 'utf8'));
const sent = stats.links.mavlink_out_sent;
const deadline = Date.now() + 10000;
while (datagrams.length < sent && Date.now() < deadline) {
  await new Promise((resolve) => setImmediate(resolve));
}
socket.close();
check(datagrams.length === sent, `received ${datagrams.length} datagrams, the daemon sent ${sent}`);
let invalid = 0;
const splitter = new MavLinkPacketSplitter({}, { onCrcError: () => { invalid += 1; } });
const reader = splitter.pipe(new MavLinkPacketParser());
const packets = [];
reader.on('data', (packet) => packets.push(packet));
const ended = new Promise((resolve) => reader.on('end', resolve));
for (const [bytes] of datagrams) splitter.write(bytes);
splitter.end();
await ended;
check(invalid === 0, `${invalid} packets with a bad CRC`);
check(splitter.unknownPackagesCount === 0, `${splitter.unknownPackagesCount} unknown packets`);
check(packets.length === datagrams.length, `${packets.length} packets in ${datagrams.length} datagrams`);

// ---- decode
const byName = { HEARTBEAT: [], OBSTACLE_DISTANCE: [], OBSTACLE_DISTANCE_3D: [] };
packets.forEach((packet, i) => {
  const clazz = REGISTRY[packet.header.msgid];
  if (!clazz) return;
  const data = packet.protocol.data(packet.payload, clazz);
  const list = byName[clazz.MSG_NAME];
  if (list) list.push({ data, header: packet.header, at: datagrams[i][1] });
});
console.log(`node-mavlink: ${packets.length} packets (${sent} sent), ${invalid} bad CRC; ` +
  `HEARTBEAT ${byName.HEARTBEAT.length}, OBSTACLE_DISTANCE ${byName.OBSTACLE_DISTANCE.length}, ` +
  `OBSTACLE_DISTANCE_3D ${byName.OBSTACLE_DISTANCE_3D.length}`);
for (const { header } of packets) {
  check(header.sysid === 42 && header.compid === 195, `ids ${header.sysid}/${header.compid}`);
}

// ---- HEARTBEAT at 1 Hz, as an onboard controller
const beats = byName.HEARTBEAT;
const od = byName.OBSTACLE_DISTANCE;
const span = od.length > 1 ? od[od.length - 1].at - od[0].at : 0;
check(beats.length >= Math.floor(span) - 1, `${beats.length} heartbeats over ${span.toFixed(1)} s`);
for (const b of beats) {
  check(b.data.type === 18 && b.data.autopilot === 8, `heartbeat type ${b.data.type} autopilot ${b.data.autopilot}`);
}
const gaps = (list) => list.slice(1).map((m, i) => m.at - list[i].at);
const beatGap = Math.max(0, ...gaps(beats));
check(beatGap < 1.3, `heartbeat gap ${beatGap.toFixed(2)} s`);

// ---- OBSTACLE_DISTANCE: rate, frame, and every obstacle in view in its sector
const odRate = (od.length - 1) / span;
const odGap = Math.max(0, ...gaps(od));
console.log(`OBSTACLE_DISTANCE: ${odRate.toFixed(2)} Hz over ${span.toFixed(1)} s, largest gap ${(odGap * 1000).toFixed(0)} ms; ` +
  `HEARTBEAT largest gap ${beatGap.toFixed(2)} s`);
check(odRate >= 0.9 * RATE_HZ, `OBSTACLE_DISTANCE at ${odRate.toFixed(2)} Hz, configured ${RATE_HZ}`);
check(odGap <= 0.35, `OBSTACLE_DISTANCE gap ${(odGap * 1000).toFixed(0)} ms (autopilots time out at 500 ms)`);

const tolerance = 2 * cell + 0.5; // the box's inflation: blur and cell rounding on each side
let expectations = 0;
let met = 0;
let unknownBehind = 0;
let freeInView = 0;
let inViewSectors = 0;
const table = [];
const firstSeen = new Map();
for (const m of od) {
  const d = m.data;
  check(d.frame === 12, `frame ${d.frame}, not BODY_FRD`);
  check(Math.abs(d.angleOffset) < 1e-6 && Math.abs(d.incrementF - 5) < 1e-6, 'sector layout');
  const t = Number(d.timeUsec) / 1e6;
  const pose = poseAt(poses, t);
  const inView = (b) => Math.min(b, 2 * Math.PI - b) < halfFov - 2 * DEG;
  // Sectors in view and not holding an object: seen, so free (max+1) or an obstacle.
  for (let s = 0; s < 72; s += 1) {
    if (!inView(s * SECTOR)) continue;
    inViewSectors += 1;
    if (d.distances[s] !== 65535) freeInView += 1;
  }
  if (d.distances[36] === 65535) unknownBehind += 1;
  for (const o of objects) {
    const near = nearestOnObject(o, pose.p[0], pose.p[1]);
    const bearing = bearingOf(pose, near.x, near.y);
    const visible = inView(bearing) && near.d > 2 && near.d < 35;
    if (!visible) continue;
    if (!firstSeen.has(o.name)) firstSeen.set(o.name, t);
    if (t - firstSeen.get(o.name) < 1.0) continue; // the map needs a moment to build the box
    const expected = sectorOf(bearing);
    let best = null;
    for (let s = 0; s < 72; s += 1) {
      if (sectorGap(s, expected) > 1 || d.distances[s] > d.maxDistance) continue;
      const got = d.distances[s] / 100;
      if (best === null || Math.abs(got - near.d) < Math.abs(best.got - near.d)) best = { s, got };
    }
    expectations += 1;
    const ok = best !== null && Math.abs(best.got - near.d) <= tolerance;
    if (ok) met += 1;
    if (table.length < 400) {
      table.push({ t: t.toFixed(1), object: o.name, expected_sector: expected,
        expected_m: near.d.toFixed(2), got_sector: best ? best.s : '-', got_m: best ? best.got.toFixed(2) : '-',
        ok });
    }
  }
}
// The sector-by-sector table, every tenth row (the whole one goes to WORK_DIR).
fs.writeFileSync(path.join(workDir, 'sectors.json'), JSON.stringify(table, null, 1));
console.log('time  object   expected sector/m   received sector/m');
table.filter((_, i) => i % 10 === 0).forEach((r) => console.log(
  `${r.t.padStart(5)} ${r.object.padEnd(8)} ${String(r.expected_sector).padStart(4)} ${r.expected_m.padStart(7)}` +
  `      ${String(r.got_sector).padStart(4)} ${String(r.got_m).padStart(7)}  ${r.ok ? 'ok' : 'MISS'}`));
console.log(`obstacles in view in their sector (+-1) within ${tolerance.toFixed(1)} m: ${met} of ${expectations}; ` +
  `sector 36 (behind) unknown in ${unknownBehind} of ${od.length} messages; ` +
  `sectors in view read seen: ${freeInView} of ${inViewSectors}`);
check(expectations > 20, `only ${expectations} obstacle sightings to check`);
check(met >= 0.95 * expectations, `${met} of ${expectations} obstacle sightings in the right sector and range`);
check(od.length > 0 && od[0].data.distances[36] === 65535, 'the first message calls the sector behind the vehicle known');
check(unknownBehind >= 0.9 * od.length, 'the sector behind the vehicle (never seen) read as known');
check(freeInView >= 0.8 * inViewSectors, `only ${freeInView} of ${inViewSectors} sectors in view read as seen`);

// ---- OBSTACLE_DISTANCE_3D: BODY_FRD points on real obstacles, one scan per update, stable ids
const o3 = byName.OBSTACLE_DISTANCE_3D;
let onObject = 0;
const idToObject = new Map();
const scans = new Map();
for (const m of o3) {
  const d = m.data;
  check(d.frame === 12, `3-D frame ${d.frame}, not BODY_FRD`);
  const scan = scans.get(d.timeBootMs) ?? new Set();
  check(!scan.has(d.obstacleId), `obstacle id ${d.obstacleId} twice in one scan`);
  scan.add(d.obstacleId);
  scans.set(d.timeBootMs, scan);
  // Body FRD -> world with the pose of the OBSTACLE_DISTANCE sent just before it.
  const before = od.filter((x) => x.at <= m.at).pop();
  if (!before) continue;
  const pose = poseAt(poses, Number(before.data.timeUsec) / 1e6);
  const w = [0, 1, 2].map((k) => pose.p[k] + pose.forward[k] * d.x + pose.right[k] * d.y + pose.down[k] * d.z);
  let best = null;
  for (const o of objects) {
    const near = nearestOnObject(o, w[0], w[1]);
    const dz = Math.max(0, o.z0 - w[2], w[2] - o.z1);
    const dist = Math.hypot(near.d, dz);
    if (best === null || dist < best.dist) best = { o, dist };
  }
  if (best && best.dist <= tolerance) {
    onObject += 1;
    const names = idToObject.get(d.obstacleId) ?? new Set();
    names.add(best.o.name);
    idToObject.set(d.obstacleId, names);
  }
}
const mixedIds = [...idToObject.values()].filter((s) => s.size > 1).length;
console.log(`OBSTACLE_DISTANCE_3D: ${o3.length} points in ${scans.size} scans; ${onObject} within ` +
  `${tolerance.toFixed(1)} m of a real obstacle; ids ${[...idToObject.keys()].join(',')}; ids naming two objects: ${mixedIds}`);
check(o3.length > 0, 'no OBSTACLE_DISTANCE_3D');
check(onObject >= 0.95 * o3.length, `${onObject} of ${o3.length} 3-D points on a real obstacle`);
check(mixedIds === 0, 'an obstacle id moved from one object to another');

if (failures.length) {
  console.log(`FAILED (${failures.length}):\n  ` + [...new Set(failures)].slice(0, 20).join('\n  '));
  process.exit(1);
}
console.log('PASSED: MAVLink decoded by node-mavlink agrees with the ground truth');
