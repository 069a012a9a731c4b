// What a real autopilot makes of zonemap's obstacles: ArduPilot's ArduCopter in
// software-in-the-loop (../shared/sitl, PRX1_TYPE 2, OA_TYPE 1, OA_DB_OUTPUT 3)
// takes the daemon's OBSTACLE_DISTANCE_3D scans, bridged from its UDP output to
// ArduPilot's TCP port as a router would, and the test reads back what ArduPilot
// holds: its proximity sectors (DISTANCE_SENSOR, 8 of 45 degrees) and its
// object database (ADSB_VEHICLE, callsign OA_DB), decoded by node-mavlink and
// checked against the flight's ground truth relative to the vehicle's heading.
// Run it in a private network namespace (ArduPilot listens on every interface).
//
// Then the other way round: a second daemon takes its poses from ArduPilot's EKF
// (poses.source mavlink: TIMESYNC, ATTITUDE_QUATERNION + LOCAL_POSITION_NED asked
// for by the daemon) while replaying NED_SEQUENCE's frames; its counters say what
// it got.
//
//   node sitl_proximity.mjs ARDUCOPTER_DIR DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR NED_SEQUENCE [2d]
//
// With 2d the daemon sends OBSTACLE_DISTANCE's 72 sectors instead (messages: 2d,
// what PX4 reads too), each message a scan, and the second daemon is left out.
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed.
import { spawn } from 'node:child_process';
import dgram from 'node:dgram';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';
import { REGISTRY, mavlink } from './node_mavlink.mjs';
import {
  DEG, bearingOf, nearestOnObject, poseAt, readObjects, readPoses, writeReplayVehicleYaml,
} from './ground_truth.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, send, minimal, common } = mavlink;

const [sitlDir, daemon, sequence, mappingConfig, workDir, nedSequence, messages = '3d'] =
  process.argv.slice(2);
const SECTORS_2D = messages === '2d';
if (!nedSequence) {
  console.error('usage: node sitl_proximity.mjs ARDUCOPTER_DIR DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR ' +
    'NED_SEQUENCE');
  process.exit(2);
}
fs.mkdirSync(workDir, { recursive: true });
const RATE_HZ = 10;
const EKF_TIMEOUT_S = 150;
const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
  return ok;
};
const now = () => Number(process.hrtime.bigint()) / 1e9;
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// ---- ArduPilot, in a scratch folder (it writes eeprom.bin, logs/, terrain/)
const apDir = path.join(workDir, 'arducopter');
fs.rmSync(apDir, { recursive: true, force: true });
fs.mkdirSync(apDir, { recursive: true });
const defaults = ['copter.parm', 'proximity.parm'].map((f) => path.join(sitlDir, f)).join(',');
const ardupilot = spawn(path.join(sitlDir, 'arducopter'),
  ['--model', '+', '--speedup', '1', '-I0', '--defaults', defaults],
  { cwd: apDir, stdio: ['ignore', 'ignore', 'pipe'] });
let apLog = '';
ardupilot.stderr.on('data', (d) => { apLog += d; });
let apExited = false;
ardupilot.on('exit', () => { apExited = true; });
const stopAll = () => { if (!apExited) ardupilot.kill('SIGKILL'); };
process.on('exit', stopAll);

const socket = dgram.createSocket('udp4'); // the daemon's MAVLink peer
const insSocket = dgram.createSocket('udp4'); // the second daemon's INS peer
let insPort = null;
let tcp = null;
for (const start = now(); tcp === null && now() - start < 20 && !apExited;) {
  tcp = await new Promise((resolve) => {
    const s = net.connect(5760, '127.0.0.1');
    s.once('connect', () => resolve(s));
    s.once('error', () => resolve(null));
  });
  if (tcp === null) await sleep(200);
}
if (!tcp) {
  console.log(`FAILED: no MAVLink from ArduPilot on TCP 5760: ${apLog.slice(-500)}`);
  process.exit(1);
}
const received = []; // { name, data, at }
// ArduPilot's messages go back to the daemon as a router's would, but for a
// stretch of the flight they are held back: the daemon must notice the silence.
let daemonAddress = null;
let relayedBack = 0;
let daemonRunning = false;
const SILENT_FROM_S = 5.0;
const SILENT_TO_S = 9.5;
let flightStart = Infinity;
const splitter = new MavLinkPacketSplitter();
tcp.pipe(splitter).pipe(new MavLinkPacketParser()).on('data', (packet) => {
  const sinceStart = now() - flightStart;
  if (daemonAddress && daemonRunning && !(sinceStart >= SILENT_FROM_S && sinceStart < SILENT_TO_S)) {
    socket.send(packet.buffer, daemonAddress.port, daemonAddress.address);
    relayedBack += 1;
  }
  if (insPort !== null) insSocket.send(packet.buffer, insPort, '127.0.0.1');
  const clazz = REGISTRY[packet.header.msgid];
  if (!clazz || packet.header.sysid !== 1 || packet.header.compid !== 1) return;
  received.push({ name: clazz.MSG_NAME, data: packet.protocol.data(packet.payload, clazz), at: now() });
});
const gcs = new MavLinkProtocolV2(255, 190);
const heartbeat = () => {
  const hb = new minimal.Heartbeat();
  hb.type = 6; // GCS
  hb.autopilot = 8;
  hb.mavlinkVersion = 3;
  send(tcp, hb, gcs);
};
heartbeat();
const gcsBeat = setInterval(heartbeat, 1000);
// What ArduPilot holds, at 10 Hz: its proximity sectors, its attitude and position
// (its streams, then the messages the streams leave out), asked again once it runs.
const requestStreams = () => {
  const r = new common.RequestDataStream();
  r.targetSystem = 1;
  r.targetComponent = 1;
  r.reqStreamId = 0; // MAV_DATA_STREAM_ALL
  r.reqMessageRate = RATE_HZ;
  r.startStop = 1;
  send(tcp, r, gcs);
  for (const id of [132, 30, 33, 246]) { // DISTANCE_SENSOR, ATTITUDE, GLOBAL_POSITION_INT, ADSB_VEHICLE
    const c = new common.CommandLong();
    c.targetSystem = 1;
    c.targetComponent = 1;
    c.command = 511; // MAV_CMD_SET_MESSAGE_INTERVAL
    c._param1 = id;
    c._param2 = 1e6 / RATE_HZ;
    send(tcp, c, gcs);
  }
};
requestStreams();

// ---- Wait for the EKF to use GPS (the object database needs an origin).
const ekfStart = now();
const usingGps = () => received.some((m) => m.name === 'STATUSTEXT' && /using GPS/i.test(m.data.text));
while (!usingGps() && now() - ekfStart < EKF_TIMEOUT_S && !apExited) await sleep(250);
console.log(`ArduPilot: EKF using GPS after ${(now() - ekfStart).toFixed(1)} s`);
if (!usingGps()) {
  console.log(`FAILED: ArduPilot's EKF did not use GPS within ${EKF_TIMEOUT_S} s`);
  process.exit(1);
}
requestStreams();
await sleep(2000);

// ---- The daemon, its MAVLink bridged to ArduPilot (and the scans kept)
const scans = []; // { timeBootMs, at, points: [{x, y, z, id}] } or { sceneT, at, points }
// OBSTACLE_DISTANCE (2d): one message a scan, time_usec the replay's frame time it
// is for; a point stands for "some sector holds an obstacle".
const keepSectors = (msg, at) => {
  if (msg[0] !== 0xfd || (msg[7] | (msg[8] << 8) | (msg[9] << 16)) !== 330) return;
  const p = Buffer.alloc(167);
  msg.subarray(10, 10 + msg[1]).copy(p); // trailing zeros truncated
  const distances = Array.from({ length: 72 }, (_, s) => p.readUInt16LE(8 + 2 * s));
  const max = p.readUInt16LE(154);
  const any = distances.some((d) => d <= max);
  scans.push({ sceneT: Number(p.readBigUInt64LE(0)) / 1e6, at, points: [{ id: any ? 0 : 65535 }], distances });
};
let relayed = 0;
socket.on('message', (msg, from) => {
  daemonAddress = from;
  tcp.write(msg);
  relayed += 1;
  const at = now();
  if (SECTORS_2D) {
    keepSectors(msg, at);
    return;
  }
  if (msg[0] !== 0xfd || (msg[7] | (msg[8] << 8) | (msg[9] << 16)) !== 11037) return;
  const p = msg.subarray(10);
  const point = { timeBootMs: p.readUInt32LE(0), x: p.readFloatLE(4), y: p.readFloatLE(8),
    z: p.readFloatLE(12), id: p.readUInt16LE(24) };
  const last = scans.at(-1);
  if (last && last.timeBootMs === point.timeBootMs) last.points.push(point);
  else scans.push({ timeBootMs: point.timeBootMs, at, points: [point] });
});
await new Promise((resolve) => socket.bind(0, '127.0.0.1', resolve));
const vehicleYaml = writeReplayVehicleYaml(path.join(workDir, 'vehicle.yaml'), {
  mapping: mappingConfig, sequence, rateHz: RATE_HZ, outDir: path.join(workDir, 'out'),
  mavlink: `{autopilot: ardupilot, messages: ${messages}, host: 127.0.0.1, ` +
    `port: ${socket.address().port}, rate_hz: ${RATE_HZ}, system_id: 1, component_id: 195}`,
});
flightStart = now();
daemonRunning = true;
const child = spawn(daemon, ['--config', vehicleYaml], { stdio: ['ignore', 'inherit', 'pipe'] });
let daemonLog = '';
child.stderr.on('data', (d) => { daemonLog += d; });
const exitCode = await new Promise((resolve) => child.on('exit', (code) => resolve(code)));
daemonRunning = false;
const flightEnd = now();
await sleep(1500);
if (!check(exitCode === 0, `daemon exited ${exitCode}: ${daemonLog}`)) {
  console.log(failures.join('\n'));
  process.exit(1);
}

// ---- The second daemon: its INS is ArduPilot's EKF, over MAVLink
// (left out with 2d: the link from ArduPilot is the same)
const checkInsFromArduPilot = async () => {
  const freePort = await new Promise((resolve) => {
    const probe = dgram.createSocket('udp4');
    probe.bind(0, '127.0.0.1', () => { const { port } = probe.address(); probe.close(() => resolve(port)); });
  });
  let insAsked = 0;
  insSocket.on('message', (msg) => { tcp.write(msg); insAsked += 1; }); // its TIMESYNC, requests
  await new Promise((resolve) => insSocket.bind(0, '127.0.0.1', resolve));
  const insYaml = writeReplayVehicleYaml(path.join(workDir, 'vehicle-ins.yaml'), {
    mapping: mappingConfig, sequence: nedSequence, rateHz: RATE_HZ, outDir: path.join(workDir, 'out-ins'),
    poses: `{source: mavlink, mavlink_listen: "127.0.0.1:${freePort}", rate_hz: 50}`,
  });
  insPort = freePort;
  const insStart = now();
  const insDaemon = spawn(daemon, ['--config', insYaml], { stdio: ['ignore', 'inherit', 'pipe'] });
  let insLog = '';
  insDaemon.stderr.on('data', (d) => { insLog += d; });
  const insExit = await new Promise((resolve) => insDaemon.on('exit', (code) => resolve(code)));
  const insSpan = now() - insStart;
  insPort = null;
  check(insExit === 0, `the INS daemon exited ${insExit}: ${insLog.slice(-800)}`);
  const ins = insExit === 0
    ? JSON.parse(fs.readFileSync(path.join(workDir, 'out-ins', 'stats.json'), 'utf8')).links : {};
  const rejected = Object.entries(ins).filter(([k, v]) => k.startsWith('ins_rejected_') && v > 0);
  // A solution stamped no later than the one before is refused and counted (the
  // gate's job): seen once in 294 solutions with four processes on two cores, a
  // repeated or late solution (not traced further). Any other refusal, or more
  // than 1% of those, is a fault.
  const repeatedTimes = ins.ins_rejected_time ?? 0;
  const refused = rejected.filter(([k]) => k !== 'ins_rejected_time');
  console.log(`INS from ArduPilot over ${insSpan.toFixed(1)} s: ${ins.ins_messages} messages, ` +
    `${ins.ins_solutions} solutions, ${ins.ins_poses_out} poses, ${ins.ins_incomplete} incomplete, ` +
    `${ins.ins_time_syncs} time syncs (${ins.ins_time_sync_steps} steps), malformed ${ins.ins_malformed}, ` +
    `rejected ${JSON.stringify(Object.fromEntries(rejected))}; ${insAsked} datagrams asked of ArduPilot`);
  check(ins.ins_time_syncs >= insSpan - 3, `${ins.ins_time_syncs} time syncs in ${insSpan.toFixed(1)} s`);
  check(ins.ins_time_sync_steps === 0, `${ins.ins_time_sync_steps} clock steps`);
  check(ins.ins_poses_out >= 30 * (insSpan - 3), `${ins.ins_poses_out} poses in ${insSpan.toFixed(1)} s (asked 50 Hz)`);
  check(ins.ins_malformed === 0 && refused.length === 0, 'ArduPilot\'s EKF solutions malformed or refused');
  check(repeatedTimes <= 0.01 * ins.ins_solutions,
    `${repeatedTimes} of ${ins.ins_solutions} solutions stamped no later than the one before`);
};
if (!SECTORS_2D) await checkInsFromArduPilot();
clearInterval(gcsBeat);
socket.close();
insSocket.close();
tcp.destroy();
stopAll();

fs.writeFileSync(path.join(workDir, 'received.json'), JSON.stringify({ flightStart, flightEnd, scans, received },
  (k, v) => (typeof v === 'bigint' ? Number(v) : v)));
console.log(`relayed ${relayed} datagrams in ${(flightEnd - flightStart).toFixed(1)} s, ${scans.length} scans; ` +
  `received ${received.length} messages from ArduPilot`);

// ---- Ground truth at the scan ArduPilot holds. A report arriving at time T shows
// the scan before the newest one relayed by T (ArduPilot commits a scan's points
// when the next time_boot_ms comes); the scan's time_boot_ms is the daemon's
// clock, which the replay's frame times follow (offset measured 0.00 s by
// Independent.MavlinkDecodedByNodeMavlinkMatchesGroundTruth).
const objects = readObjects(path.join(sequence, 'objects.yaml'));
const poses = readPoses(path.join(sequence, 'groundtruth.txt'));
const cell = Number(/cell_size_m: ([0-9.]+)/.exec(fs.readFileSync(mappingConfig, 'utf8'))[1]);
// OBSTACLE_DISTANCE's time_usec is the time its sectors are for, by the daemon's
// own account; ArduPilot holds them from when they come, so the sectors are judged
// at their arrival on the replay's clock (the first one's time and the time since).
const sceneTime = (scan) => (SECTORS_2D ? scans[0].sceneT + (scan.at - scans[0].at)
  : poses[0].t + scan.timeBootMs / 1000);
const heldScanIndex = (at) => {
  let newest = -1;
  while (newest + 1 < scans.length && scans[newest + 1].at <= at) newest += 1;
  return SECTORS_2D ? newest : newest - 1; // OBSTACLE_DISTANCE is taken whole at once
};
const SECTOR = 45 * DEG;
const sectorOf = (bearing) => Math.floor(bearing / SECTOR + 0.5) % 8;
const sectorGap = (a, b) => Math.min((a - b + 8) % 8, (b - a + 8) % 8);
const MAX_M = 50;
// Each object's nearest point about the vehicle at a scene time: sector, metres.
const truthAt = (t) => {
  const pose = poseAt(poses, t);
  return objects.map((o) => {
    const near = nearestOnObject(o, pose.p[0], pose.p[1]);
    return { name: o.name, sector: sectorOf(bearingOf(pose, near.x, near.y)), m: near.d };
  });
};
// A reading may be nearer than the object by the box's inflation (blur and cell
// rounding, 2 cells + 0.5 m) and by twice the stereo range error there (eq. 1:
// sigma = d^2 sigma_px / (f b)): on the safe side; never farther by over 1 m.
const camera = fs.readFileSync(path.join(sequence, 'camera.yaml'), 'utf8');
const cameraValue = (key) => Number(new RegExp(`${key}: ([0-9.]+)`).exec(camera)[1]);
const rangeSigma = (m) => (m * m * cameraValue('match_sigma_px')) / (cameraValue('fx') * cameraValue('baseline_m'));
const NEARER_M = 2 * cell + 0.5;
const FARTHER_M = 1.0;
const nearerBy = (truth) => NEARER_M + 2 * rangeSigma(truth);
const rangeOk = (got, truth) => got >= truth - nearerBy(truth) && got <= truth + FARTHER_M;
// ArduPilot keeps a sector 1.2-1.8 s after the last point in it (measured; its
// faces time out): a reading is right when an object stood there, at that
// range, at some scan of the last 2 s.
const HOLD_S = 2.0;
const recentScans = (k) => {
  const list = [];
  for (let j = k; j >= 0 && sceneTime(scans[j]) >= sceneTime(scans[k]) - HOLD_S; j -= 1) list.push(j);
  return list;
};
const explainedBy = (k, sector, metres) => recentScans(k).some((j) =>
  truthAt(sceneTime(scans[j])).some((o) => sectorGap(o.sector, sector) <= 1 && rangeOk(metres, o.m)));
// A sector holds its nearest object when the reading is never farther than the
// object stands now, and nearer only by the inflation below the nearest any
// object stood in that sector in the last HOLD_S.
const heldAt = (k, sector, nowM, metres) => {
  const nearest = Math.min(...recentScans(k).flatMap((j) =>
    truthAt(sceneTime(scans[j])).filter((o) => o.sector === sector).map((o) => o.m)));
  return metres <= nowM + FARTHER_M && metres >= nearest - nearerBy(nearest);
};
// The map needs a moment to build a box: judged from 1 s after the first point.
const firstPoint = scans.find((sc) => sc.points.some((p) => p.id !== 65535));
check(firstPoint !== undefined, 'the daemon sent no obstacle point');
const judgedFrom = firstPoint ? firstPoint.at + 1.0 : Infinity;

// ---- DISTANCE_SENSOR: ArduPilot's eight sectors, sent together under one
// time_boot_ms (a sector it does not send holds nothing)
const rounds = new Map();
for (const m of received.filter((x) => x.name === 'DISTANCE_SENSOR' && x.at >= judgedFrom && x.at <= flightEnd)) {
  const round = rounds.get(m.data.timeBootMs) ?? { at: m.at, metres: new Array(8).fill(Infinity) };
  if (m.data.currentDistance < m.data.maxDistance) round.metres[m.data.orientation] = m.data.currentDistance / 100;
  rounds.set(m.data.timeBootMs, round);
}
let expected = 0;
let held = 0;
let readings = 0;
let right = 0;
let flickers = 0;
const rangeErrors = []; // a reading in an object's own sector minus where it stands, near it
const misses = [];
const wrong = [];
for (const round of rounds.values()) {
  const k = heldScanIndex(round.at);
  if (k < 0) continue;
  const t = sceneTime(scans[k]);
  // Each object in range, in its sector or one beside it (+-1 sector): at least
  // as near as it stands (a nearer object in that sector hides it), and nearer
  // only by the inflation below what stood in that sector of late.
  for (const o of truthAt(t).filter((x) => x.m <= MAX_M - 1)) {
    expected += 1;
    const own = round.metres[o.sector];
    if (Number.isFinite(own) && Math.abs(own - o.m) < 3) rangeErrors.push(own - o.m);
    const sectors = [o.sector, (o.sector + 1) % 8, (o.sector + 7) % 8];
    if (sectors.some((c) => heldAt(k, c, o.m, round.metres[c]))) held += 1;
    else misses.push(`${t.toFixed(1)} s: ${o.name} in sector ${o.sector} at ${o.m.toFixed(1)} m, ArduPilot ` +
      sectors.map((c) => `${c}: ${round.metres[c].toFixed(1)}`).join(', '));
    if (sectors.every((c) => round.metres[c] === Infinity)) flickers += 1;
  }
  round.metres.forEach((metres, sector) => {
    if (metres === Infinity) return;
    readings += 1;
    if (explainedBy(k, sector, metres)) right += 1;
    else wrong.push(`${t.toFixed(1)} s: sector ${sector} ${metres.toFixed(1)} m, nothing there`);
  });
}
console.log(`DISTANCE_SENSOR, ${rounds.size} reports: objects in their sector (+-1) within ` +
  `-(${NEARER_M.toFixed(1)} m + 2 sigma)/+${FARTHER_M.toFixed(1)} m: ` +
  `${held} of ${expected} (${flickers} read nothing); readings on an object: ${right} of ${readings}`);
for (const line of [...misses.slice(0, 8), ...wrong.slice(0, 8)]) console.log(`  ${line}`);
const sortedErrors = [...rangeErrors].sort((a, b) => a - b);
console.log(`readings in an object's own sector within 3 m of it: ${rangeErrors.length}, median ` +
  `${(sortedErrors[Math.floor(sortedErrors.length / 2)] ?? NaN).toFixed(2)} m, farther by over 0.5 m: ` +
  `${rangeErrors.filter((e) => e > 0.5).length}, the farthest +${(sortedErrors.at(-1) ?? NaN).toFixed(2)} m`);
check(expected > 100, `only ${expected} object sightings to judge`);
check(held >= 0.97 * expected, `${held} of ${expected} reports hold the object in its sector at its range`);
check(flickers === 0, `${flickers} times an object in range read nothing in its sector and those beside it`);
check(right >= 0.97 * readings, `${readings - right} of ${readings} sector readings where nothing stands`);

// ---- A steady scene (the flight's hover, posts ahead): ArduPilot's boundary holds
// still over it: no sector drops to "nothing" and back, none moves over 2 cells.
let hoverFrom = 0;
let hoverTo = -1;
for (let i = 0, run = 0; i < poses.length; i += 1) {
  run = i > 0 && poses[i].p.every((v, k) => v === poses[i - 1].p[k]) ? run + 1 : 0;
  if (run > 0 && poses[i].t - poses[i - run].t > hoverTo - hoverFrom) {
    hoverFrom = poses[i - run].t;
    hoverTo = poses[i].t;
  }
}
const steady = Array.from({ length: 8 }, () => ({ held: [], nothing: 0 }));
let steadyRounds = 0;
for (const round of rounds.values()) {
  const k = heldScanIndex(round.at);
  if (k < 0) continue;
  const t = sceneTime(scans[k]);
  // Settled a second after ArduPilot let go of what came before the stop: it
  // keeps a sector up to HOLD_S after its last point, and the scans sent as the
  // vehicle stopped dead from 4 m/s were for where it would have flown on (the
  // sink's points move on with the vehicle between map updates).
  if (t < hoverFrom + HOLD_S + 1.0 || t > hoverTo) continue;
  steadyRounds += 1;
  round.metres.forEach((m, sector) => {
    if (m === Infinity) steady[sector].nothing += 1;
    else steady[sector].held.push(m);
  });
}
const flickering = steady.filter((s) => s.held.length > 0 && s.nothing > 0).length;
const spread = Math.max(0, ...steady.filter((s) => s.held.length > 0)
  .map((s) => Math.max(...s.held) - Math.min(...s.held)));
console.log(`steady scene (hover ${hoverFrom.toFixed(1)}-${hoverTo.toFixed(1)} s): ${steadyRounds} reports, ` +
  `sectors holding a post ${steady.filter((s) => s.held.length > 0).length}, flickering ${flickering}, ` +
  `largest spread ${spread.toFixed(2)} m`);
check(hoverTo - hoverFrom >= 9.5 && steadyRounds >= 60, `only ${steadyRounds} reports over a steady scene`);
check(flickering === 0, `${flickering} sectors flickered over a steady scene`);
check(spread <= 2 * cell, `a sector moved ${spread.toFixed(2)} m over a steady scene`);

// ---- ADSB_VEHICLE "OA_DB": the object database, about ArduPilot's own position and heading
const EARTH_M = 6378137;
let position = null;
let yaw = null;
let items = 0;
let itemsRight = 0;
const itemsWrong = [];
const lastItemNear = new Map(); // object -> scene time of the last item on it
const longestWithout = new Map(); // object -> seconds
const ITEM_GAP_S = 3.0;
const itemsJudged = new Set();
let itemsBehind = 0;
let hoverItems = 0;
let hoverItemsRight = 0;
for (const m of received.filter((x) => x.at <= flightEnd)) {
  if (m.name === 'GLOBAL_POSITION_INT') position = m.data;
  if (m.name === 'ATTITUDE') yaw = m.data.yaw;
  if (m.at < judgedFrom || position === null || yaw === null) continue;
  const k = heldScanIndex(m.at);
  if (k < 0) continue;
  const t = sceneTime(scans[k]);
  if (m.name === 'ADSB_VEHICLE' && m.data.callsign === 'OA_DB') {
    // ArduPilot sends an item again while it lives: judged once, when first sent.
    const key = `${m.data.ICAOAddress}:${m.data.lat}:${m.data.lon}`;
    const north = (m.data.lat - position.lat) * 1e-7 * DEG * EARTH_M;
    const east = (m.data.lon - position.lon) * 1e-7 * DEG * EARTH_M * Math.cos(position.lat * 1e-7 * DEG);
    const bearing = (((Math.atan2(east, north) - yaw) % (2 * Math.PI)) + 2 * Math.PI) % (2 * Math.PI);
    const metres = Math.hypot(north, east);
    if (!itemsJudged.has(key) && sectorGap(sectorOf(bearing), 0) > 2) {
      // Behind the vehicle ArduPilot was seen to place items nearer than the points
      // sent (2.1-3.5 m for a post sent at 4.9 m): counted, not judged.
      itemsJudged.add(key);
      itemsBehind += 1;
    }
    if (!itemsJudged.has(key) && t >= hoverFrom && t <= hoverTo) {
      // Over the hover ArduPilot was seen to add items drifting away from the points
      // sent (9-12 m at 318-330 deg for a post sent steadily at 7.1 m, 309 deg; 2 m
      // to the right where nothing was sent): counted, judged apart, not gated.
      itemsJudged.add(key);
      hoverItems += 1;
      if (explainedBy(k, sectorOf(bearing), metres)) hoverItemsRight += 1;
    }
    if (!itemsJudged.has(key)) {
      itemsJudged.add(key);
      items += 1;
      if (explainedBy(k, sectorOf(bearing), metres)) itemsRight += 1;
      else itemsWrong.push(`${t.toFixed(1)} s: item ${m.data.ICAOAddress} at ${(bearing / DEG).toFixed(0)} deg ${metres.toFixed(1)} m, nothing there`);
    }
    for (const o of truthAt(t)) {
      if (sectorGap(o.sector, sectorOf(bearing)) <= 1 && rangeOk(metres, o.m)) lastItemNear.set(o.name, t);
    }
  }
  // The longest stretch each object in range ahead or beside (where the vehicle
  // goes: sectors 6-2) went without an item on it, while the vehicle moved (an item
  // that stays where it was is not sent again). Behind, ArduPilot was seen to send
  // none for a post 5-20 m back for 3.8 s while its sector held the post.
  const hovering = t >= hoverFrom && t <= hoverTo + 1.0;
  for (const o of truthAt(t)) {
    if (!lastItemNear.has(o.name) || sectorGap(o.sector, 0) > 2 || hovering) lastItemNear.set(o.name, t);
    if (o.m <= MAX_M - 1) longestWithout.set(o.name, Math.max(longestWithout.get(o.name) ?? 0, t - lastItemNear.get(o.name)));
  }
}
const longestGap = Math.max(...longestWithout.values());
console.log(`OA_DB: ${itemsRight} of ${items} items ahead or beside (when first sent) on an object ` +
  `(${itemsBehind} behind, not judged; over the hover ${hoverItemsRight} of ${hoverItems}); ` +
  'longest without an item: ' +
  [...longestWithout].map(([name, gap]) => `${name} ${gap.toFixed(1)} s`).join(', '));
for (const line of itemsWrong.slice(0, 8)) console.log(`  ${line}`);
check(items > 20, `only ${items} OA_DB items`);
check(itemsRight >= 0.95 * items, `${items - itemsRight} of ${items} OA_DB items where nothing stood`);
// With 2d ArduPilot puts a point of every 5-degree sector into its database and
// sends the items round by round, a few a tick: an object went 1.1-4.8 s without
// one in three runs sending the update's sectors as they were, 3.5-5.5 s in four
// sending them for where the vehicle is (2026-12-07). Said, not gated there.
if (!SECTORS_2D) {
  check(longestGap <= ITEM_GAP_S, `an object in range went ${longestGap.toFixed(1)} s without an OA_DB item`);
}

// ---- The daemon's view of ArduPilot (stats.json): its heartbeats, its proximity
// health, the silence noticed
const links = JSON.parse(fs.readFileSync(path.join(workDir, 'out', 'stats.json'), 'utf8')).links;
const flightS = flightEnd - flightStart;
const silentS = SILENT_TO_S - SILENT_FROM_S;
console.log(`daemon: ArduPilot heartbeats ${links.mavlink_autopilot_heartbeats} over ${flightS.toFixed(1)} s ` +
  `(${silentS} s held back), lost ${links.mavlink_autopilot_lost}, present ${links.mavlink_autopilot_present}, ` +
  `proximity ${links.mavlink_autopilot_proximity} (lost ${links.mavlink_autopilot_proximity_lost}); ` +
  `frames ${links.mavlink_in_frames} of ${relayedBack} relayed, rejected ${links.mavlink_in_rejected}`);
check(links.mavlink_autopilot_heartbeats >= Math.floor(flightS - silentS) - 2,
  `${links.mavlink_autopilot_heartbeats} ArduPilot heartbeats over ${flightS.toFixed(1)} s`);
check(links.mavlink_autopilot_lost === 1, `ArduPilot's ${silentS} s silence counted ${links.mavlink_autopilot_lost} times`);
check(links.mavlink_autopilot_present === 1, 'ArduPilot not present at the end');
check(links.mavlink_autopilot_proximity === 1, `ArduPilot's proximity health ${links.mavlink_autopilot_proximity} at the end`);
check(links.mavlink_in_rejected === 0, `${links.mavlink_in_rejected} of ArduPilot's datagrams rejected`);
check(links.mavlink_in_frames >= 0.9 * relayedBack, `the daemon read ${links.mavlink_in_frames} of ${relayedBack} frames`);

// ---- Its health: no "No Data" while the daemon sent
const noData = received.filter((m) => m.name === 'STATUSTEXT' && /PRX1: No Data/i.test(m.data.text) &&
  m.at > flightStart + 2 && m.at < flightEnd);
check(noData.length === 0, `ArduPilot said "${noData[0]?.data.text}" during the flight`);

if (failures.length) {
  console.log(`FAILED (${failures.length}):\n  ` + failures.join('\n  '));
  process.exit(1);
}
console.log('PASSED: ArduPilot holds zonemap\'s obstacles where they stand');
