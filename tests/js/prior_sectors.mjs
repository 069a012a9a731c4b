// A prior map reaches the flight controller from the first message: the posts
// flight replayed with its camera turned backwards (it never sees the posts) and
// the two posts given as a prior map; zonemap-replay --links's PX4 telemetry log,
// decoded by node-mavlink, must hold each post in its sector (+-1) at its range in
// every OBSTACLE_DISTANCE from the first, and the map must end with them still
// marked prior (no view confirmed or removed them).
//
//   node prior_sectors.mjs TLOG SEQUENCE BOXES_CSV STATS_JSON
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed.
import fs from 'node:fs';
import { REGISTRY, mavlink } from './node_mavlink.mjs';
import { DEG, bearingOf, nearestOnObject, poseAt, readObjects, readPoses } from './ground_truth.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser } = mavlink;
const [tlog, sequence, boxesCsv, statsJson] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

// The tlog: 8-byte big-endian microseconds, then one MAVLink 2 frame.
const bytes = fs.readFileSync(tlog);
const frames = [];
for (let at = 0; at + 20 <= bytes.length;) {
  const size = 12 + bytes[at + 9] + ((bytes[at + 10] & 1) ? 13 : 0);
  frames.push(bytes.subarray(at + 8, at + 8 + size));
  at += 8 + size;
}
const splitter = new MavLinkPacketSplitter();
const reader = splitter.pipe(new MavLinkPacketParser());
const od = [];
reader.on('data', (p) => {
  const clazz = REGISTRY[p.header.msgid];
  if (clazz?.MSG_NAME === 'OBSTACLE_DISTANCE') od.push(p.protocol.data(p.payload, clazz));
});
const ended = new Promise((resolve) => reader.on('end', resolve));
for (const f of frames) splitter.write(f);
splitter.end();
await ended;

const objects = readObjects(`${sequence}/objects.yaml`);
const poses = readPoses(`${sequence}/groundtruth.txt`);
const SECTOR = 5 * DEG;
const sectorOf = (b) => Math.floor(b / SECTOR + 0.5) % 72;
const TOLERANCE_M = 1.0; // the prior box is the post's box rounded out to 0.5 m cells
let held = 0;
let expected = 0;
for (const m of od) {
  const pose = poseAt(poses, Number(m.timeUsec) / 1e6);
  for (const o of objects) {
    const near = nearestOnObject(o, pose.p[0], pose.p[1]);
    if (near.d > m.maxDistance / 100 - 1) continue;
    expected += 1;
    const s = sectorOf(bearingOf(pose, near.x, near.y));
    const hit = [s, (s + 1) % 72, (s + 71) % 72].some((k) =>
      m.distances[k] <= m.maxDistance && Math.abs(m.distances[k] / 100 - near.d) <= TOLERANCE_M);
    if (hit) held += 1;
  }
}
const stats = JSON.parse(fs.readFileSync(statsJson, 'utf8')).feature_counters;
const rows = fs.readFileSync(boxesCsv, 'utf8').trim().split('\n').slice(1).map((l) => l.split(','));
const priorObstacles = rows.filter((r) => r[1] === 'obstacle' && r[10] === '1').length;
console.log(`node-mavlink: ${od.length} OBSTACLE_DISTANCE; the prior posts in their sector within ` +
  `${TOLERANCE_M} m: ${held} of ${expected}, the first message ${od.length ? 'included' : 'missing'}; ` +
  `priors added ${stats.priors_added}, confirmed ${stats.priors_confirmed}, removed ${stats.priors_removed}; ` +
  `obstacle rows still prior at the end: ${priorObstacles}`);
check(od.length >= 5, `only ${od.length} OBSTACLE_DISTANCE`);
check(expected >= 2 * od.length, 'a post out of range: the check would say nothing');
check(held === expected, `${expected - held} of ${expected} post sightings missing`);
check(stats.priors_confirmed === 0 && stats.priors_removed === 0, 'the camera saw a prior post');
check(priorObstacles === 2, `${priorObstacles} obstacle rows still prior at the end, not 2`);
if (failures.length) {
  console.log(`FAILED:\n  ${failures.join('\n  ')}`);
  process.exit(1);
}
console.log('PASSED: the prior map reaches the flight controller from the first message');
