// A closed loop on a desk: ArduPilot's ArduCopter in software-in-the-loop flies
// an AUTO mission from A (home) to B, 60 m north at 10 m, across the
// `sitl-course` scene (two posts and a wall, all taller than the flight) with
// BendyRuler on. In the run "with", zonemap-sitl-camera renders the scene at
// ArduPilot's pose (its EKF over MAVLink), maps it and sends the obstacles; in
// the run "without" nothing does (the control: it flies through them). This
// script is the ground station and the MAVLink router between them (ArduPilot's
// TCP port; UDP to zonemap's pose sources and sink). Per run it writes the track
// (track-<run>.csv: t, north, east, down), what ArduPilot held (oa-db-<run>.csv)
// and prints one JSON line:
//   {"run": "with" | "without", "closest_m": {"<obstacle>": metres, ...}, "margin_m": m, ...}
// Run it in a private network namespace (ArduPilot listens on every interface).
//
//   node sitl_flight.mjs ARDUCOPTER_DIR CAMERA_BIN SIM_BIN SOURCE_DIR WORK_DIR [RUN...]
//
// Exit 0: both runs flew (whatever they came close to); 1: a run could not fly;
// 77: node-mavlink is not installed.
import { spawn, execFileSync } from 'node:child_process';
import dgram from 'node:dgram';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';
import { REGISTRY, mavlink } from './node_mavlink.mjs';
import { readObjects } from './ground_truth.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, send, minimal, common } = mavlink;
const [sitlDir, cameraBin, simBin, sourceDir, workDir, ...runsAsked] =
  process.argv.slice(2).map((a, i) => (i < 5 ? path.resolve(a) : a));
if (process.argv.length < 7) {
  console.error('usage: node sitl_flight.mjs ARDUCOPTER_DIR CAMERA_BIN SIM_BIN SOURCE_DIR WORK_DIR [RUN...]');
  process.exit(2);
}
const runs = runsAsked.length ? runsAsked : ['with', 'without'];
const now = () => Number(process.hrtime.bigint()) / 1e9;
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const B_NORTH_M = 60;
const ALTITUDE_M = 10;
const OA_MARGIN_MAX_M = 5; // ArduPilot's default
const SPEED_MPS = 3;
fs.mkdirSync(workDir, { recursive: true });

// The course's obstacles (zonemap-sim's objects.yaml: x north, y west, z up).
const courseDir = path.join(workDir, 'course');
execFileSync(simBin, ['sitl-course', courseDir, '--width', '160', '--frames', '2']);
const obstacles = readObjects(path.join(courseDir, 'objects.yaml'));

// Horizontal distance from (north, east) to an obstacle's surface (0 inside).
function distanceTo(o, north, east) {
  const west = -east;
  if (o.kind === 'cylinder') return Math.max(0, Math.hypot(north - o.cx, west - o.cy) - o.r);
  const dx = Math.max(o.lo[0] - north, 0, north - o.hi[0]);
  const dy = Math.max(o.lo[1] - west, 0, west - o.hi[1]);
  return Math.hypot(dx, dy);
}

async function connect(port) {
  for (const start = now(); now() - start < 20;) {
    const s = await new Promise((resolve) => {
      const c = net.connect(port, '127.0.0.1');
      c.once('connect', () => resolve(c));
      c.once('error', () => resolve(null));
    });
    if (s) return s;
    await sleep(200);
  }
  return null;
}

async function fly(run) {
  const runDir = path.join(workDir, run);
  fs.rmSync(runDir, { recursive: true, force: true });
  fs.mkdirSync(runDir, { recursive: true });
  // ArduPilot with the course's parameters; without zonemap no proximity sensor.
  const parm = path.join(runDir, 'course.parm');
  fs.writeFileSync(parm, [
    `PRX1_TYPE ${run === 'with' ? 2 : 0}`, 'OA_TYPE 1', `OA_MARGIN_MAX ${OA_MARGIN_MAX_M}`,
    'OA_DB_OUTPUT 3', `WPNAV_SPEED ${SPEED_MPS * 100}`, 'ARMING_CHECK 0', 'AUTO_OPTIONS 0', '',
  ].join('\n'));
  const defaults = [path.join(sitlDir, 'copter.parm'), path.join(sitlDir, 'proximity.parm'), parm].join(',');
  const apDir = path.join(runDir, 'arducopter');
  fs.mkdirSync(apDir);
  const ardupilot = spawn(path.join(sitlDir, 'arducopter'),
    ['--model', '+', '--speedup', '1', '-I0', '--defaults', defaults],
    { cwd: apDir, stdio: ['ignore', 'ignore', 'ignore'] });
  let camera = null;
  const stop = () => {
    if (camera && camera.exitCode === null) camera.kill('SIGTERM');
    if (ardupilot.exitCode === null) ardupilot.kill('SIGKILL');
  };
  process.on('exit', stop);
  const tcp = await connect(5760);
  if (!tcp) { stop(); return { run, error: 'no MAVLink from ArduPilot on TCP 5760' }; }

  // The router: ArduPilot's packets to every UDP peer of zonemap's, theirs to ArduPilot.
  const router = dgram.createSocket('udp4');
  await new Promise((resolve) => router.bind(0, '127.0.0.1', resolve));
  const peers = new Map(); // "addr:port" -> {address, port}: each gets every packet once
  router.on('message', (msg, from) => {
    peers.set(`${from.address}:${from.port}`, from);
    tcp.write(msg);
  });
  const latest = {};
  const received = [];
  const track = [];
  const oaDb = [];
  tcp.pipe(new MavLinkPacketSplitter()).pipe(new MavLinkPacketParser()).on('data', (packet) => {
    for (const p of peers.values()) router.send(packet.buffer, p.port, p.address);
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz || packet.header.sysid !== 1 || packet.header.compid !== 1) return;
    const data = packet.protocol.data(packet.payload, clazz);
    latest[clazz.MSG_NAME] = data;
    received.push({ name: clazz.MSG_NAME, data, at: now() });
    if (clazz.MSG_NAME === 'LOCAL_POSITION_NED') track.push({ t: now(), n: data.x, e: data.y, d: data.z });
    if (clazz.MSG_NAME === 'ADSB_VEHICLE' && /OA_DB/.test(data.callsign)) {
      oaDb.push({ t: now(), lat: data.lat / 1e7, lon: data.lon / 1e7 });
    }
  });
  const gcs = new MavLinkProtocolV2(255, 190);
  const beat = () => {
    const hb = new minimal.Heartbeat();
    hb.type = 6;
    hb.autopilot = 8;
    hb.mavlinkVersion = 3;
    send(tcp, hb, gcs);
  };
  beat();
  const beating = setInterval(beat, 1000);
  const command = (id, ...params) => {
    const c = new common.CommandLong();
    c.targetSystem = 1;
    c.targetComponent = 1;
    c.command = id;
    params.forEach((v, i) => { c[`_param${i + 1}`] = v; });
    send(tcp, c, gcs);
  };
  const streams = () => {
    for (const id of [32, 33, 30, 132, 246, 242]) command(511, id, 1e5); // 10 Hz
  };
  streams();
  const said = (re) => received.some((m) => m.name === 'STATUSTEXT' && re.test(m.data.text));
  const until = async (ok, seconds) => {
    for (const start = now(); !ok() && now() - start < seconds && ardupilot.exitCode === null;) await sleep(100);
    return ok();
  };
  const result = { run, margin_m: OA_MARGIN_MAX_M };
  let homeAt = null;
  let legFlown = [];
  try {
    if (!await until(() => said(/using GPS/i), 150)) throw new Error("ArduPilot's EKF never used GPS");
    streams();
    // zonemap: its INS and its camera on ArduPilot's EKF, its obstacles to ArduPilot.
    if (run === 'with') {
      const port = () => new Promise((resolve) => {
        const probe = dgram.createSocket('udp4');
        probe.bind(0, '127.0.0.1', () => { const p = probe.address().port; probe.close(() => resolve(p)); });
      });
      const insPort = await port();
      const cameraPort = await port();
      for (const port of [insPort, cameraPort]) peers.set(`127.0.0.1:${port}`, { address: '127.0.0.1', port });
      const yaml = path.join(runDir, 'vehicle.yaml');
      fs.writeFileSync(yaml, [
        `mapping: ${path.join(sourceDir, 'config/outdoor-0.5m.yaml')}`,
        'live: true',
        'frames: {source: replay, sequence: unused}',
        `poses: {source: mavlink, mavlink_listen: "127.0.0.1:${insPort}", rate_hz: 50}`,
        'outputs:',
        `  directory: ${path.join(runDir, 'zonemap')}`,
        `  record: {path: ${path.join(runDir, 'zonemap', 'run.mcap')}, depth_every: 10}`,
        `  mavlink: {autopilot: ardupilot, host: 127.0.0.1, port: ${router.address().port}, rate_hz: 10,`,
        '            system_id: 1, component_id: 195}',
        '',
      ].join('\n'));
      camera = spawn(cameraBin, ['--config', yaml, '--scene', 'sitl-course',
        '--camera-listen', `127.0.0.1:${cameraPort}`, '--rate', '10', '--width', '320'],
      { stdio: ['ignore', 'ignore', fs.openSync(path.join(runDir, 'zonemap.log'), 'w')] });
      await sleep(3000);
    }
    // The mission: home, take-off to 10 m, B, land there.
    if (!await until(() => latest.GLOBAL_POSITION_INT, 20)) throw new Error('no GLOBAL_POSITION_INT');
    const home = latest.GLOBAL_POSITION_INT;
    homeAt = home;
    const mPerDegLat = 111320;
    const items = [
      { command: 16, x: home.lat, y: home.lon, z: 0 },
      { command: 22, x: home.lat, y: home.lon, z: ALTITUDE_M },
      { command: 16, x: home.lat + Math.round((B_NORTH_M / mPerDegLat) * 1e7), y: home.lon, z: ALTITUDE_M },
      { command: 21, x: home.lat + Math.round((B_NORTH_M / mPerDegLat) * 1e7), y: home.lon, z: 0 },
    ];
    const count = new common.MissionCount();
    count.targetSystem = 1;
    count.targetComponent = 1;
    count.count = items.length;
    count.missionType = 0;
    send(tcp, count, gcs);
    for (const start = now(); now() - start < 20;) {
      const asked = received.filter((m) => (m.name === 'MISSION_REQUEST_INT' || m.name === 'MISSION_REQUEST') && !m.done);
      for (const m of asked) {
        m.done = true;
        const it = items[m.data.seq];
        const item = new common.MissionItemInt();
        Object.assign(item, { targetSystem: 1, targetComponent: 1, seq: m.data.seq, frame: 6,
          command: it.command, current: 0, autocontinue: 1, param1: 0, param2: 0, param3: 0,
          param4: 0, x: it.x, y: it.y, z: it.z, missionType: 0 });
        send(tcp, item, gcs);
      }
      if (received.some((m) => m.name === 'MISSION_ACK')) break;
      await sleep(50);
    }
    if (!received.some((m) => m.name === 'MISSION_ACK' && m.data.type === 0)) throw new Error('mission not accepted');
    // GUIDED, armed, in the air; then AUTO (its take-off item is done at once).
    command(176, 1, 4); // GUIDED
    await sleep(1000);
    command(400, 1, 21196); // arm
    await sleep(1000);
    command(22, 0, 0, 0, 0, 0, 0, ALTITUDE_M); // take off
    if (!await until(() => latest.LOCAL_POSITION_NED && -latest.LOCAL_POSITION_NED.z > ALTITUDE_M - 1, 60)) {
      throw new Error('did not climb to the mission altitude');
    }
    const flown = track.length;
    command(176, 1, 3); // AUTO
    command(300, 0, 0); // mission start
    const atB = () => latest.LOCAL_POSITION_NED && Math.abs(latest.LOCAL_POSITION_NED.x - B_NORTH_M) < 2 &&
      Math.abs(latest.LOCAL_POSITION_NED.y) < 3;
    result.reached_b = await until(atB, 120);
    const leg = track.slice(flown);
    legFlown = leg;
    result.closest_m = {};
    for (const o of obstacles) {
      result.closest_m[o.name] = Number(Math.min(...leg.map((p) => distanceTo(o, p.n, p.e))).toFixed(2));
    }
    result.max_east_m = Number(Math.max(...leg.map((p) => Math.abs(p.e))).toFixed(2));
    result.seconds = Number((leg.at(-1).t - leg[0].t).toFixed(1));
    result.oa_db_items = oaDb.length;
    fs.writeFileSync(path.join(runDir, 'track.csv'),
      't,north,east,down\n' + leg.map((p) => `${(p.t - leg[0].t).toFixed(2)},${p.n},${p.e},${p.d}`).join('\n') + '\n');
    fs.writeFileSync(path.join(runDir, 'oa-db.csv'),
      't,lat,lon\n' + oaDb.map((p) => `${p.t.toFixed(2)},${p.lat},${p.lon}`).join('\n') + '\n');
  } catch (e) {
    result.error = e.message;
  }
  clearInterval(beating);
  if (camera && camera.exitCode === null) {
    camera.kill('SIGTERM');
    await new Promise((resolve) => camera.on('exit', resolve));
  }
  if (run === 'with' && result.closest_m && homeAt) {
    const mPerDegLon = 111320 * Math.cos((homeAt.lat / 1e7) * Math.PI / 180);
    const oaNed = oaDb.map((o) => ({ t: o.t, n: (o.lat - homeAt.lat / 1e7) * 111320,
      e: (o.lon - homeAt.lon / 1e7) * mPerDegLon, d: -ALTITUDE_M }));
    try {
      await addAutopilotView(runDir, result, oaNed, legFlown);
    } catch (e) {
      result.report_error = e.message;
    }
  }
  stop();
  tcp.destroy();
  router.close();
  return result;
}

// ---- ArduPilot's view beside zonemap's: into run.mcap (topics /ardupilot/objects: its
// object database as it reported it, /ardupilot/track: the leg flown; SceneUpdate in
// the recording's NED "world", times on the same CLOCK_MONOTONIC) and report.html.
const seconds = (t) => ({ sec: Math.floor(t), nsec: Math.round((t - Math.floor(t)) * 1e9) % 1e9 });
function entity(t, id, prims) {
  return { timestamp: seconds(t), frame_id: 'world', id, lifetime: { sec: 0, nsec: 0 }, frame_locked: false,
    metadata: [], arrows: [], cubes: [], spheres: [], cylinders: [], lines: [], triangles: [], texts: [],
    models: [], ...prims };
}
const at = (p) => ({ position: { x: p.n, y: p.e, z: p.d }, orientation: { x: 0, y: 0, z: 0, w: 1 } });

async function addAutopilotView(runDir, result, oaNed, leg) {
  const mcapPath = path.join(runDir, 'zonemap', 'run.mcap');
  if (!fs.existsSync(mcapPath) || leg.length === 0) return;
  const { McapIndexedReader, McapWriter } = await import('@mcap/core');
  const fzstd = await import('fzstd');
  const bytes = fs.readFileSync(mcapPath);
  const reader = await McapIndexedReader.Initialize({
    readable: { size: async () => BigInt(bytes.length),
      read: async (offset, length) => bytes.subarray(Number(offset), Number(offset + length)) },
    decompressHandlers: { zstd: (data, size) => fzstd.decompress(data, new Uint8Array(Number(size))) },
  });
  const parts = [];
  let written = 0n;
  const writer = new McapWriter({ writable: { position: () => written,
    write: async (b) => { parts.push(Buffer.from(b)); written += BigInt(b.length); } } });
  await writer.start({ profile: reader.header.profile, library: 'zonemap tests/js/sitl_flight.mjs' });
  const schemas = new Map();
  let scene = null;
  for (const [id, sc] of reader.schemasById) {
    schemas.set(id, await writer.registerSchema({ name: sc.name, encoding: sc.encoding, data: sc.data }));
    if (sc.name === 'foxglove.SceneUpdate') scene = schemas.get(id);
  }
  const channels = new Map();
  for (const [id, c] of reader.channelsById) {
    channels.set(id, await writer.registerChannel({ schemaId: schemas.get(c.schemaId) ?? 0, topic: c.topic,
      messageEncoding: c.messageEncoding, metadata: c.metadata }));
  }
  for await (const m of reader.readMessages()) {
    await writer.addMessage({ channelId: channels.get(m.channelId), sequence: m.sequence, logTime: m.logTime,
      publishTime: m.publishTime, data: m.data });
  }
  const json = (o) => new TextEncoder().encode(JSON.stringify(o));
  const objects = await writer.registerChannel({ schemaId: scene, topic: '/ardupilot/objects',
    messageEncoding: 'json', metadata: new Map() });
  const trackChannel = await writer.registerChannel({ schemaId: scene, topic: '/ardupilot/track',
    messageEncoding: 'json', metadata: new Map() });
  let sequence = 0;
  const addScene = async (channelId, t, entities) => {
    const time = BigInt(Math.round(t * 1e9));
    await writer.addMessage({ channelId, sequence: sequence++, logTime: time, publishTime: time,
      data: json({ deletions: [], entities }) });
  };
  // Each half second, the items ArduPilot reported in the second before (orange).
  for (let t = leg[0].t; t <= leg.at(-1).t; t += 0.5) {
    const recent = oaNed.filter((o) => o.t > t - 1 && o.t <= t);
    await addScene(objects, t, [entity(t, 'oa-db', { spheres: recent.map((o) => ({ pose: at(o),
      size: { x: 0.8, y: 0.8, z: 0.8 }, color: { r: 1, g: 0.5, b: 0, a: 0.9 } })) })]);
  }
  const end = leg.at(-1).t;
  await addScene(trackChannel, end, [entity(end, 'track', { lines: [{ type: 0, pose: at({ n: 0, e: 0, d: 0 }),
    thickness: 0.2, scale_invariant: false, points: leg.map((p) => ({ x: p.n, y: p.e, z: p.d })),
    color: { r: 0.2, g: 0.6, b: 1, a: 1 }, colors: [], indices: [] }] })]);
  await writer.end();
  fs.writeFileSync(mcapPath, Buffer.concat(parts));
  // report.html: the run's figures beside zonemap's page.
  const reportPath = path.join(runDir, 'zonemap', 'report.html');
  if (fs.existsSync(reportPath)) {
    const rows = Object.entries(result.closest_m).map(([name, m]) =>
      `<tr><td>${name}</td><td>${m.toFixed(2)}</td><td>${m >= result.margin_m ? 'yes' : 'NO'}</td></tr>`).join('');
    // What ArduPilot held: its database items by the obstacle they stood on (within 2 m).
    const on = Object.fromEntries(obstacles.map((o) => [o.name, 0]));
    let onNothing = 0;
    for (const item of oaNed) {
      const near = obstacles.find((o) => distanceTo(o, item.n, item.e) <= 2);
      if (near) on[near.name] += 1;
      else onNothing += 1;
    }
    result.oa_db_on = { ...on, nothing: onNothing };
    const held = Object.entries(on).map(([name, k]) => `<tr><td>${name}</td><td>${k}</td></tr>`).join('') +
      `<tr><td>(on no obstacle)</td><td>${onNothing}</td></tr>`;
    const section = `<section id="autopilot"><h2>ArduPilot in the loop (${result.run})</h2>` +
      `<p>OA_MARGIN_MAX ${result.margin_m} m; B reached: ${result.reached_b}; ${leg.length} track points ` +
      `over ${result.seconds} s, at most ${result.max_east_m} m off the track; ${oaNed.length} object-database ` +
      'items reported (in run.mcap: /ardupilot/objects, /ardupilot/track).</p>' +
      `<table><tr><th>obstacle</th><th>closest approach m</th><th>past the margin</th></tr>${rows}</table>` +
      `<h3>Its object database (items within 2 m of each obstacle)</h3><table><tr><th>obstacle</th>` +
      `<th>items</th></tr>${held}</table></section>`;
    const html = fs.readFileSync(reportPath, 'utf8');
    fs.writeFileSync(reportPath, html.replace('</body>', `${section}</body>`));
  }
}

let failed = false;
for (const run of runs) {
  const r = await fly(run);
  console.log(JSON.stringify(r));
  if (r.error) failed = true;
}
process.exit(failed ? 1 : 0);
