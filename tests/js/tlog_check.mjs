// zonemap-replay --links's telemetry log (.tlog: each MAVLink message after its
// time, 8 bytes big-endian microseconds) read by node-mavlink, an implementation
// nobody on this project wrote: every packet's CRC good, the ids of the default
// link, HEARTBEAT every second of flight time (or at the next map update: the
// replay ticks the link only then), stamps in time order; for PX4
// OBSTACLE_DISTANCE alone, in the body frame with an obstacle in it; for
// ArduPilot OBSTACLE_DISTANCE_3D alone, scans under rising times, points in range.
//
//   node tlog_check.mjs TLOG [px4|ardupilot]
//
// Exit 0: every check passed; 1: a check failed; 77: node-mavlink is not installed.
import fs from 'node:fs';
import { REGISTRY, mavlink } from './node_mavlink.mjs';

const { MavLinkPacketSplitter, MavLinkPacketParser } = mavlink;

const bytes = fs.readFileSync(process.argv[2]);
const autopilot = process.argv[3] ?? 'px4';
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

// The tlog's framing: stamp, then one MAVLink v2 frame (STX 0xFD, its length in byte 1).
const stamps = [];
const frames = [];
for (let at = 0; at < bytes.length;) {
  if (at + 8 + 12 > bytes.length) { check(false, `a truncated entry at byte ${at}`); break; }
  stamps.push(Number(bytes.readBigUInt64BE(at)) / 1e6);
  const stx = bytes[at + 8];
  check(stx === 0xfd, `entry at byte ${at} is not MAVLink 2 (0x${stx.toString(16)})`);
  const size = 12 + bytes[at + 9] + ((bytes[at + 10] & 1) ? 13 : 0);
  frames.push(bytes.subarray(at + 8, at + 8 + size));
  at += 8 + size;
}
let invalid = 0;
const splitter = new MavLinkPacketSplitter({}, { onCrcError: () => { invalid += 1; } });
const reader = splitter.pipe(new MavLinkPacketParser());
const packets = [];
reader.on('data', (p) => packets.push(p));
const ended = new Promise((resolve) => reader.on('end', resolve));
for (const f of frames) splitter.write(f);
splitter.end();
await ended;
check(invalid === 0, `${invalid} packets with a bad CRC`);
check(packets.length === frames.length, `${packets.length} packets in ${frames.length} entries`);
check(stamps.every((t, i) => i === 0 || t >= stamps[i - 1]), 'stamps out of time order');

const counts = { HEARTBEAT: 0, OBSTACLE_DISTANCE: 0, OBSTACLE_DISTANCE_3D: 0 };
let withObstacle = 0;
let points3d = 0;
let scans3d = 0;
let lastScanMs = -1;
const beats = [];
packets.forEach((p, i) => {
  check(p.header.sysid === 1 && p.header.compid === 195, `ids ${p.header.sysid}/${p.header.compid}`);
  const clazz = REGISTRY[p.header.msgid];
  if (!clazz) { check(false, `unknown message ${p.header.msgid}`); return; }
  counts[clazz.MSG_NAME] = (counts[clazz.MSG_NAME] ?? 0) + 1;
  if (clazz.MSG_NAME === 'HEARTBEAT') beats.push(stamps[i]);
  if (clazz.MSG_NAME === 'OBSTACLE_DISTANCE_3D') {
    const d = p.protocol.data(p.payload, clazz);
    check(d.frame === 12, `OBSTACLE_DISTANCE_3D frame ${d.frame} (MAV_FRAME_BODY_FRD is 12)`);
    if (d.timeBootMs !== lastScanMs) {
      check(d.timeBootMs > lastScanMs, `scan time ${d.timeBootMs} ms after ${lastScanMs} ms`);
      lastScanMs = d.timeBootMs;
      scans3d += 1;
    }
    const range = Math.hypot(d.x, d.y, d.z);
    if (d.obstacleId !== 65535) {
      check(range >= d.minDistance && range <= d.maxDistance, `a 3-D point at ${range.toFixed(1)} m out of range`);
      points3d += 1;
    }
    return;
  }
  if (clazz.MSG_NAME !== 'OBSTACLE_DISTANCE') return;
  const d = p.protocol.data(p.payload, clazz);
  check(d.frame === 12, `OBSTACLE_DISTANCE frame ${d.frame} (MAV_FRAME_BODY_FRD is 12)`);
  const near = d.distances.filter((cm) => cm >= d.minDistance && cm <= d.maxDistance);
  if (near.length > 0) withObstacle += 1;
});
const span = stamps.length > 1 ? stamps[stamps.length - 1] - stamps[0] : 0;
const beatGap = Math.max(0, ...beats.slice(1).map((t, i) => t - beats[i]));
check(beats.length > 0 && beatGap <= 1.35, `heartbeat gap ${beatGap.toFixed(2)} s (updates every 0.3 s)`);
if (autopilot === 'px4') {
  check(counts.OBSTACLE_DISTANCE >= 5, `${counts.OBSTACLE_DISTANCE} OBSTACLE_DISTANCE`);
  check(withObstacle > 0, 'no OBSTACLE_DISTANCE with an obstacle in range');
  check(counts.OBSTACLE_DISTANCE_3D === 0, `${counts.OBSTACLE_DISTANCE_3D} OBSTACLE_DISTANCE_3D to PX4`);
} else {
  check(scans3d >= 5, `${scans3d} OBSTACLE_DISTANCE_3D scans`);
  check(points3d > 0, 'no OBSTACLE_DISTANCE_3D point');
  check(counts.OBSTACLE_DISTANCE === 0, `${counts.OBSTACLE_DISTANCE} OBSTACLE_DISTANCE to ArduPilot`);
}
console.log(`node-mavlink: ${packets.length} packets, ${invalid} bad CRC over ${span.toFixed(1)} s; ` +
  `HEARTBEAT ${counts.HEARTBEAT}, OBSTACLE_DISTANCE ${counts.OBSTACLE_DISTANCE} ` +
  `(${withObstacle} with an obstacle), OBSTACLE_DISTANCE_3D ${counts.OBSTACLE_DISTANCE_3D} ` +
  `(${points3d} points in ${scans3d} scans)`);
if (failures.length > 0) {
  console.log(failures.join('\n'));
  process.exit(1);
}
