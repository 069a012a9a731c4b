// What a real autopilot makes of zonemap's obstacles: ArduPilot's ArduCopter in
// software-in-the-loop (../shared/sitl, PRX1_TYPE 2, OA_TYPE 1, OA_DB_OUTPUT 3)
// takes the daemon's OBSTACLE_DISTANCE_3D scans, bridged from its UDP output to
// ArduPilot's TCP port as a router would, and the test reads back what ArduPilot
// holds: its proximity sectors (DISTANCE_SENSOR, 8 of 45 degrees) and its
// object database (ADSB_VEHICLE, callsign OA_DB), decoded by node-mavlink and
// checked against the flight's ground truth relative to the vehicle's heading.
// Run it in a private network namespace (ArduPilot listens on every interface).
//
//   node sitl_proximity.mjs ARDUCOPTER_DIR DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed.
import { spawn } from 'node:child_process';
import dgram from 'node:dgram';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';
import { createRequire } from 'node:module';
import { DEG, bearingOf, nearestOnObject, poseAt, readObjects, readPoses } from './ground_truth.mjs';

const require = createRequire(import.meta.url);
let mavlink;
try {
  mavlink = require('node-mavlink');
} catch (e) {
  console.log('SKIP: node-mavlink is not installed (npm unreachable when tools/test set up tests/js)');
  process.exit(77);
}
const { MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, send, minimal, common,
  ardupilotmega } = mavlink;
const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY, ...ardupilotmega.REGISTRY };

const [sitlDir, daemon, sequence, mappingConfig, workDir] = process.argv.slice(2);
if (!workDir) {
  console.error('usage: node sitl_proximity.mjs ARDUCOPTER_DIR DAEMON SEQUENCE MAPPING_CONFIG WORK_DIR');
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
const splitter = new MavLinkPacketSplitter();
tcp.pipe(splitter).pipe(new MavLinkPacketParser()).on('data', (packet) => {
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
const socket = dgram.createSocket('udp4');
const scans = []; // { timeBootMs, at, points: [{x, y, z, id}] }
let relayed = 0;
socket.on('message', (msg) => {
  tcp.write(msg);
  relayed += 1;
  const at = now();
  if (msg[0] !== 0xfd || (msg[7] | (msg[8] << 8) | (msg[9] << 16)) !== 11037) return;
  const p = msg.subarray(10);
  const point = { timeBootMs: p.readUInt32LE(0), x: p.readFloatLE(4), y: p.readFloatLE(8),
    z: p.readFloatLE(12), id: p.readUInt16LE(24) };
  const last = scans.at(-1);
  if (last && last.timeBootMs === point.timeBootMs) last.points.push(point);
  else scans.push({ timeBootMs: point.timeBootMs, at, points: [point] });
});
await new Promise((resolve) => socket.bind(0, '127.0.0.1', resolve));
const vehicleYaml = path.join(workDir, 'vehicle.yaml');
fs.writeFileSync(vehicleYaml, [
  `mapping: ${path.resolve(mappingConfig)}`,
  'live: true',
  `frames: {source: replay, sequence: ${path.resolve(sequence)}, rate_hz: ${RATE_HZ}}`,
  'poses: {source: sequence}',
  'outputs:',
  `  directory: ${path.resolve(workDir, 'out')}`,
  `  mavlink: {autopilot: ardupilot, host: 127.0.0.1, port: ${socket.address().port}, ` +
    `rate_hz: ${RATE_HZ}, system_id: 1, component_id: 195}`,
  '',
].join('\n'));
const flightStart = now();
const child = spawn(daemon, ['--config', vehicleYaml], { stdio: ['ignore', 'inherit', 'pipe'] });
let daemonLog = '';
child.stderr.on('data', (d) => { daemonLog += d; });
const exitCode = await new Promise((resolve) => child.on('exit', (code) => resolve(code)));
const flightEnd = now();
await sleep(1500);
clearInterval(gcsBeat);
socket.close();
tcp.destroy();
stopAll();
if (!check(exitCode === 0, `daemon exited ${exitCode}: ${daemonLog}`)) {
  console.log(failures.join('\n'));
  process.exit(1);
}
fs.writeFileSync(path.join(workDir, 'received.json'), JSON.stringify({ flightStart, flightEnd, scans, received },
  (k, v) => (typeof v === 'bigint' ? Number(v) : v)));
console.log(`relayed ${relayed} datagrams, ${scans.length} scans; received ${received.length} messages`);
