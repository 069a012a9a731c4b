// What the flight controller receives, decoded by node-mavlink (a MAVLink
// implementation nobody on this project wrote) and checked against the flight's
// ground truth: the daemon replays a generated flight at camera rate twice, as
// for PX4 (OBSTACLE_DISTANCE) and as for ArduPilot (OBSTACLE_DISTANCE_3D scans),
// with HEARTBEAT, to a UDP socket of ours.
//
//   node mavlink_ground_truth.mjs DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed
// (npm unreachable when the tests were set up): skipped, with the reason.
import { spawn } from 'node:child_process';
import dgram from 'node:dgram';
import fs from 'node:fs';
import path from 'node:path';
import { REGISTRY, mavlink } from './node_mavlink.mjs';
import {
  DEG, bearingOf, nearestOnObject, poseAt, readObjects, readPoses, writeReplayVehicleYaml,
} from './ground_truth.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser } = mavlink;

const [daemon, sequence, mappingConfig, workDir] = process.argv.slice(2);
if (!workDir) {
  console.error('usage: node mavlink_ground_truth.mjs DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR');
  process.exit(2);
}
fs.mkdirSync(workDir, { recursive: true });

const RATE_HZ = 10;
const SECTOR = 5 * DEG;
const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
  return ok;
};

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

// One live run of the daemon sending to a socket of ours, as the given autopilot
// reads it; the packets decoded by node-mavlink, grouped by message.
async function runDaemon(autopilot) {
  const runDir = path.join(workDir, autopilot);
  fs.mkdirSync(runDir, { recursive: true });
  const socket = dgram.createSocket('udp4');
  const datagrams = []; // [bytes, arrival time in s], decoded after the run
  socket.on('message', (msg) => datagrams.push([msg, Number(process.hrtime.bigint()) / 1e9]));
  await new Promise((resolve) => socket.bind(0, '127.0.0.1', resolve));
  const port = socket.address().port;
  const vehicleYaml = writeReplayVehicleYaml(path.join(runDir, 'vehicle.yaml'), {
    mapping: mappingConfig, sequence, rateHz: RATE_HZ, outDir: path.join(runDir, 'out'),
    mavlink: `{autopilot: ${autopilot}, host: 127.0.0.1, port: ${port}, rate_hz: ${RATE_HZ}, ` +
      'system_id: 42, component_id: 195}',
  });
  const child = spawn(daemon, ['--config', vehicleYaml], { stdio: ['ignore', 'inherit', 'pipe'] });
  let daemonLog = '';
  child.stderr.on('data', (d) => { daemonLog += d; });
  const exitCode = await new Promise((resolve) => child.on('exit', (code) => resolve(code)));
  if (!check(exitCode === 0, `${autopilot}: daemon exited ${exitCode}: ${daemonLog}`)) {
    console.log(failures.join('\n'));
    process.exit(1);
  }
  // Synchronise on what the daemon says it sent (stats.json), not on time.
  const stats = JSON.parse(fs.readFileSync(path.join(runDir, 'out', 'stats.json'), 'utf8'));
  const sent = stats.links.mavlink_out_sent;
  const deadline = Date.now() + 10000;
  while (datagrams.length < sent && Date.now() < deadline) {
    await new Promise((resolve) => setImmediate(resolve));
  }
  socket.close();
  check(datagrams.length === sent, `${autopilot}: received ${datagrams.length} datagrams, the daemon sent ${sent}`);
  let invalid = 0;
  const splitter = new MavLinkPacketSplitter({}, { onCrcError: () => { invalid += 1; } });
  const reader = splitter.pipe(new MavLinkPacketParser());
  const packets = [];
  reader.on('data', (packet) => packets.push(packet));
  const ended = new Promise((resolve) => reader.on('end', resolve));
  for (const [bytes] of datagrams) splitter.write(bytes);
  splitter.end();
  await ended;
  check(invalid === 0, `${autopilot}: ${invalid} packets with a bad CRC`);
  check(splitter.unknownPackagesCount === 0, `${autopilot}: ${splitter.unknownPackagesCount} unknown packets`);
  check(packets.length === datagrams.length, `${autopilot}: ${packets.length} packets in ${datagrams.length} datagrams`);
  const byName = { HEARTBEAT: [], OBSTACLE_DISTANCE: [], OBSTACLE_DISTANCE_3D: [] };
  packets.forEach((packet, i) => {
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz) return;
    const data = packet.protocol.data(packet.payload, clazz);
    const list = byName[clazz.MSG_NAME];
    if (list) list.push({ data, header: packet.header, at: datagrams[i][1] });
  });
  console.log(`${autopilot}: node-mavlink ${packets.length} packets (${sent} sent), ${invalid} bad CRC; ` +
    `HEARTBEAT ${byName.HEARTBEAT.length}, OBSTACLE_DISTANCE ${byName.OBSTACLE_DISTANCE.length}, ` +
    `OBSTACLE_DISTANCE_3D ${byName.OBSTACLE_DISTANCE_3D.length}`);
  for (const { header } of packets) {
    check(header.sysid === 42 && header.compid === 195, `ids ${header.sysid}/${header.compid}`);
  }
  return { byName, stats };
}

const gaps = (list) => list.slice(1).map((m, i) => m.at - list[i].at);
// HEARTBEAT at 1 Hz, as an onboard controller, over the span of the obstacle messages.
function checkHeartbeats(autopilot, beats, obstacleMessages) {
  const span = obstacleMessages.length > 1 ? obstacleMessages.at(-1).at - obstacleMessages[0].at : 0;
  check(beats.length >= Math.floor(span) - 1, `${autopilot}: ${beats.length} heartbeats over ${span.toFixed(1)} s`);
  for (const b of beats) {
    check(b.data.type === 18 && b.data.autopilot === 8, `heartbeat type ${b.data.type} autopilot ${b.data.autopilot}`);
  }
  const beatGap = Math.max(0, ...gaps(beats));
  check(beatGap < 1.3, `${autopilot}: heartbeat gap ${beatGap.toFixed(2)} s`);
  return beatGap;
}

// ---- PX4: OBSTACLE_DISTANCE alone (PX4 reads no 3-D message)
const px4 = await runDaemon('px4');
check(px4.byName.OBSTACLE_DISTANCE_3D.length === 0,
  `PX4 got ${px4.byName.OBSTACLE_DISTANCE_3D.length} OBSTACLE_DISTANCE_3D`);
const od = px4.byName.OBSTACLE_DISTANCE;
const beatGap = checkHeartbeats('px4', px4.byName.HEARTBEAT, od);
const span = od.length > 1 ? od.at(-1).at - od[0].at : 0;

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

// ---- ArduPilot: OBSTACLE_DISTANCE_3D alone (it replaces its whole boundary on
// each OBSTACLE_DISTANCE), scans of BODY_FRD points on real obstacles, stable ids
const ardupilot = await runDaemon('ardupilot');
check(ardupilot.byName.OBSTACLE_DISTANCE.length === 0,
  `ArduPilot got ${ardupilot.byName.OBSTACLE_DISTANCE.length} OBSTACLE_DISTANCE besides the 3-D points`);
const o3 = ardupilot.byName.OBSTACLE_DISTANCE_3D;
checkHeartbeats('ardupilot', ardupilot.byName.HEARTBEAT, o3);
// A scan: consecutive messages sharing a time_boot_ms, each scan's newer.
const scans = [];
for (const m of o3) {
  const d = m.data;
  check(d.frame === 12, `3-D frame ${d.frame}, not BODY_FRD`);
  const last = scans.at(-1);
  if (last && last.timeBootMs === d.timeBootMs) {
    check(!last.points.some((p) => p.obstacleId === d.obstacleId), `obstacle id ${d.obstacleId} twice in one scan`);
    last.points.push(d);
    continue;
  }
  check(!last || d.timeBootMs > last.timeBootMs, `scan time_boot_ms ${d.timeBootMs} after ${last?.timeBootMs}`);
  scans.push({ timeBootMs: d.timeBootMs, at: m.at, points: [d] });
}
const isEmptyMark = (p) => p.obstacleId === 65535 && p.x === 0 && p.y === 0 && p.z === 0;
const emptyScans = scans.filter((sc) => sc.points.some(isEmptyMark));
for (const sc of emptyScans) check(sc.points.length === 1, 'an empty scan with points besides its zero vector');
const scanSpan = scans.length > 1 ? scans.at(-1).at - scans[0].at : 0;
const scanRate = (scans.length - 1) / Math.max(scanSpan, 1e-9);
const scanGap = Math.max(0, ...gaps(scans));
check(scanRate >= 0.9 * RATE_HZ, `3-D scans at ${scanRate.toFixed(2)} Hz, configured ${RATE_HZ}`);
check(scanGap <= 0.35, `3-D scan gap ${(scanGap * 1000).toFixed(0)} ms (ArduPilot times out at 500 ms)`);

// time_boot_ms is the daemon's clock since it started; the frame it maps is a
// latency earlier. One offset for the whole run, the one that puts most points
// on an object (a clock offset, not a per-point fit).
const toWorld = (pose, d) =>
  [0, 1, 2].map((k) => pose.p[k] + pose.forward[k] * d.x + pose.right[k] * d.y + pose.down[k] * d.z);
function nearestObject(w) {
  let best = null;
  for (const o of objects) {
    const near = nearestOnObject(o, w[0], w[1]);
    const dist = Math.hypot(near.d, Math.max(0, o.z0 - w[2], w[2] - o.z1));
    if (best === null || dist < best.dist) best = { o, dist };
  }
  return best;
}
const points = scans.flatMap((sc) => sc.points.filter((p) => !isEmptyMark(p)).map((p) => ({ sc, p })));
const onObjectWith = (offset) => points.filter(({ sc, p }) =>
  nearestObject(toWorld(poseAt(poses, poses[0].t + sc.timeBootMs / 1000 + offset), p)).dist <= tolerance).length;
let offset = 0;
for (let o = -0.6; o <= 0.2001; o += 0.02) if (onObjectWith(o) > onObjectWith(offset)) offset = o;
const sceneTime = (sc) => poses[0].t + sc.timeBootMs / 1000 + offset;
let onObject = 0;
const idToObject = new Map();
for (const { sc, p } of points) {
  const best = nearestObject(toWorld(poseAt(poses, sceneTime(sc)), p));
  if (best.dist > tolerance) continue;
  onObject += 1;
  const names = idToObject.get(p.obstacleId) ?? new Set();
  names.add(best.o.name);
  idToObject.set(p.obstacleId, names);
}
const mixedIds = [...idToObject.values()].filter((n) => n.size > 1).length;
console.log(`OBSTACLE_DISTANCE_3D: ${o3.length} messages in ${scans.length} scans at ${scanRate.toFixed(2)} Hz ` +
  `(largest gap ${(scanGap * 1000).toFixed(0)} ms), ${emptyScans.length} empty; clock offset ${offset.toFixed(2)} s; ` +
  `${onObject} of ${points.length} points within ${tolerance.toFixed(1)} m of a real obstacle; ` +
  `${idToObject.size} ids, ids naming two objects: ${mixedIds}`);
check(points.length > 0, 'no OBSTACLE_DISTANCE_3D point');
check(offset > -0.6 && offset < 0.2, `clock offset ${offset.toFixed(2)} s at the end of its search`);
check(onObject >= 0.95 * points.length, `${onObject} of ${points.length} 3-D points on a real obstacle`);
check(mixedIds === 0, 'an obstacle id moved from one object to another');

// Every obstacle in view in a scan, in its ArduPilot sector (45 degrees, +-1) at its range.
const AP_SECTOR = 45 * DEG;
const apSectorOf = (bearing) => Math.floor(bearing / AP_SECTOR + 0.5) % 8;
const apSectorGap = (a, b) => Math.min((a - b + 8) % 8, (b - a + 8) % 8);
const inView = (b) => Math.min(b, 2 * Math.PI - b) < halfFov - 2 * DEG;
let expected3d = 0;
let met3d = 0;
const seen3d = new Map();
for (const sc of scans) {
  const pose = poseAt(poses, sceneTime(sc));
  for (const o of objects) {
    const near = nearestOnObject(o, pose.p[0], pose.p[1]);
    const bearing = bearingOf(pose, near.x, near.y);
    if (!(inView(bearing) && near.d > 2 && near.d < 35)) continue;
    if (!seen3d.has(o.name)) seen3d.set(o.name, sc.at);
    if (sc.at - seen3d.get(o.name) < 1.0) continue; // the map needs a moment to build the box
    expected3d += 1;
    const hit = sc.points.some((p) => {
      if (isEmptyMark(p)) return false;
      let b = Math.atan2(p.y, p.x);
      if (b < 0) b += 2 * Math.PI;
      return apSectorGap(apSectorOf(b), apSectorOf(bearing)) <= 1 &&
        Math.abs(Math.hypot(p.x, p.y) - near.d) <= tolerance;
    });
    if (hit) met3d += 1;
  }
}
console.log(`obstacles in view in their ArduPilot sector (+-1) within ${tolerance.toFixed(1)} m: ${met3d} of ${expected3d}`);
check(expected3d > 20, `only ${expected3d} obstacle sightings to check in 3-D`);
check(met3d >= 0.95 * expected3d, `${met3d} of ${expected3d} obstacle sightings in a 3-D scan`);

if (failures.length) {
  console.log(`FAILED (${failures.length}):\n  ` + [...new Set(failures)].slice(0, 20).join('\n  '));
  process.exit(1);
}
console.log('PASSED: MAVLink decoded by node-mavlink agrees with the ground truth');
