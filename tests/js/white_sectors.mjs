// A white, textureless object (stereo matches none of it) must never read "free"
// to the flight controller: zonemap-replay --links's MAVLink log decoded by
// node-mavlink (an implementation nobody on this project wrote), and for every
// OBSTACLE_DISTANCE the sectors whose centre line meets a white object's footprint
// within 80% of max_distance (what "free" promises: docs/links.md), from the
// vehicle's ground-truth pose at the message's stamp. Such a sector may read an
// obstacle or unknown (UINT16_MAX), never max_distance + 1.
//
//   node white_sectors.mjs TLOG SEQUENCE [BAND_M]
//
// Only objects reaching into the sectors' vertical band (the vehicle's height
// +- BAND_M, 5 m as the links ship) count: a van under the band is not in the way.
// Prints one JSON line {messages, toward, free, unknown, obstacle, last_toward};
// exit 0: no sector toward a white object read free; 1: one did; 77: node-mavlink
// is not installed.
import fs from 'node:fs';
import path from 'node:path';
import { REGISTRY, mavlink } from './node_mavlink.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser } = mavlink;
const [tlog, sequence, bandArg] = process.argv.slice(2);
const band = bandArg === undefined ? 5 : Number(bandArg);

// White boxes of objects.yaml (zonemap-sim marks them `white: true`).
const whites = [];
for (const line of fs.readFileSync(path.join(sequence, 'objects.yaml'), 'utf8').split('\n')) {
  if (!/type: box/.test(line) || !/white: true/.test(line)) continue;
  const nums = (key) => new RegExp(key + ': \\[([^\\]]+)\\]').exec(line)[1].split(',').map(Number);
  whites.push({ name: /name: ([^,]+)/.exec(line)[1], lo: nums('min'), hi: nums('max') });
}
if (whites.length === 0) {
  console.log(`no white object in ${sequence}/objects.yaml`);
  process.exit(1);
}

// Camera poses (world <- optical, z up): the nose is the optical axis.
const poses = [];
for (const line of fs.readFileSync(path.join(sequence, 'groundtruth.txt'), 'utf8').split('\n')) {
  if (!line.trim() || line.startsWith('#')) continue;
  const [t, x, y, z, qx, qy, qz, qw] = line.trim().split(/\s+/).map(Number);
  const fx = 2 * (qx * qz + qy * qw);
  const fy = 2 * (qy * qz - qx * qw);
  const n = Math.hypot(fx, fy);
  poses.push({ t, x, y, z, fwd: [fx / n, fy / n], right: [fy / n, -fx / n] });
}
const poseAt = (t) => poses.reduce((b, p) => (Math.abs(p.t - t) < Math.abs(b.t - t) ? p : b));

// Distance along a horizontal ray to a box's footprint (slabs), Infinity when missed.
function rayToBox(x, y, dx, dy, box) {
  let near = 0;
  let far = Infinity;
  for (const [o, d, lo, hi] of [[x, dx, box.lo[0], box.hi[0]], [y, dy, box.lo[1], box.hi[1]]]) {
    if (Math.abs(d) < 1e-12) {
      if (o < lo || o > hi) return Infinity;
      continue;
    }
    const a = (lo - o) / d;
    const b = (hi - o) / d;
    near = Math.max(near, Math.min(a, b));
    far = Math.min(far, Math.max(a, b));
  }
  return near <= far ? near : Infinity;
}

const bytes = fs.readFileSync(tlog);
const stamps = [];
const splitter = new MavLinkPacketSplitter();
const reader = splitter.pipe(new MavLinkPacketParser());
const packets = [];
reader.on('data', (p) => packets.push(p));
const ended = new Promise((resolve) => reader.on('end', resolve));
for (let at = 0; at + 20 <= bytes.length;) {
  const size = 12 + bytes[at + 9] + ((bytes[at + 10] & 1) ? 13 : 0);
  stamps.push(Number(bytes.readBigUInt64BE(at)) / 1e6);
  splitter.write(bytes.subarray(at + 8, at + 8 + size));
  at += 8 + size;
}
splitter.end();
await ended;

const result = { messages: 0, toward: 0, free: 0, unknown: 0, obstacle: 0, last_toward: [], free_at: [] };
packets.forEach((p, i) => {
  const clazz = REGISTRY[p.header.msgid];
  if (!clazz || clazz.MSG_NAME !== 'OBSTACLE_DISTANCE') return;
  const d = p.protocol.data(p.payload, clazz);
  const pose = poseAt(stamps[i]);
  const maxM = d.maxDistance / 100;
  const increment = d.incrementF > 0 ? d.incrementF : d.increment;
  result.messages += 1;
  const toward = [];
  d.distances.forEach((cm, j) => {
    const bearing = ((j * increment + d.angleOffset) * Math.PI) / 180;
    const dx = pose.fwd[0] * Math.cos(bearing) + pose.right[0] * Math.sin(bearing);
    const dy = pose.fwd[1] * Math.cos(bearing) + pose.right[1] * Math.sin(bearing);
    const inBand = whites.filter((w) => w.hi[2] >= pose.z - band && w.lo[2] <= pose.z + band);
    const range = Math.min(...inBand.map((w) => rayToBox(pose.x, pose.y, dx, dy, w)));
    if (range > 0.8 * maxM) return;
    result.toward += 1;
    if (cm === 65535) result.unknown += 1;
    else if (cm > d.maxDistance) {
      result.free += 1;
      result.free_at.push(`t=${stamps[i].toFixed(1)} s sector ${j} (wall at ${range.toFixed(1)} m)`);
    }
    else result.obstacle += 1;
    toward.push(`${j}:${cm}`);
  });
  if (toward.length > 0) result.last_toward = toward;
});
console.log(JSON.stringify(result));
process.exit(result.messages > 0 && result.free === 0 ? 0 : 1);
