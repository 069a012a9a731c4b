// A run's recording (OUT/run.mcap) read by readers nobody on the project wrote:
// @mcap/core's stream reader checks every record and chunk CRC, its indexed
// reader the summary, chunk indexes and message indexes; every message is
// validated against @foxglove/schemas' JSON Schema for its schema name (and
// against the schema stored in the file); the last /zonemap/boxes SceneUpdate,
// and the scene its updates and deletions build, must equal OUT/boxes.csv.
//   node mcap_check.mjs OUT_DIR
// Exit 0: every check passed; 1: a check failed; 77: a module is missing.
import { readFileSync } from "node:fs";

let McapStreamReader, McapIndexedReader, fzstd, foxgloveSchemas, Ajv, crc32;
try {
  ({ McapStreamReader, McapIndexedReader } = await import("@mcap/core"));
  fzstd = await import("fzstd");
  foxgloveSchemas = (await import("@foxglove/schemas/jsonschema.js")).default;
  Ajv = (await import("ajv")).default;
  ({ crc32 } = await import("@foxglove/crc"));
} catch (e) {
  console.log(`SKIP: npm modules missing (tools/test installs them into tests/js): ${e.message}`);
  process.exit(77);
}

const out = process.argv[2];
const bytes = new Uint8Array(readFileSync(`${out}/run.mcap`));
const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
};
const decompressHandlers = {
  zstd: (buffer, size) => fzstd.decompress(buffer, new Uint8Array(Number(size))),
};

// 1. Every record, in file order, with CRCs.
const stream = new McapStreamReader({ validateCrcs: true, decompressHandlers });
stream.append(bytes);
const recordCounts = {};
const streamed = [];
let footer, dataEnd, statistics;
const storedSchemas = new Map();
const channels = new Map();
for (let record; (record = stream.nextRecord()); ) {
  recordCounts[record.type] = (recordCounts[record.type] ?? 0) + 1;
  if (record.type === "Message") streamed.push(record);
  if (record.type === "Schema") storedSchemas.set(record.id, record);
  if (record.type === "Channel") channels.set(record.id, record);
  if (record.type === "Footer") footer = record;
  if (record.type === "DataEnd") dataEnd = record;
  if (record.type === "Statistics") statistics = record;
}
check(stream.done(), "the stream reader did not reach the trailing magic");
check(footer && footer.summaryStart > 0n, "no summary section");

// 2. The data section CRC (the readers do not check it): every byte before Data End.
const dataEndOffset = Number(footer.summaryStart) - (1 + 8 + 4);
check(bytes[dataEndOffset] === 0x0f, `no Data End record right before the summary`);
check(
  dataEnd && dataEnd.dataSectionCrc === crc32(bytes.subarray(0, dataEndOffset)),
  "data section CRC does not match",
);

// 3. The summary and indexes: the indexed reader seeks by them.
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, length) => bytes.subarray(Number(offset), Number(offset + length)),
};
const indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers });
const viaIndex = [];
for await (const m of indexed.readMessages()) viaIndex.push(m);
check(viaIndex.length === streamed.length, `index reads ${viaIndex.length} of ${streamed.length} messages`);
check(
  statistics && Number(statistics.messageCount) === streamed.length,
  "statistics' message count differs from the messages",
);
for (let i = 1; i < viaIndex.length; ++i) {
  if (viaIndex[i].logTime < viaIndex[i - 1].logTime) {
    failures.push("the indexed reader's messages are not in log-time order");
    break;
  }
}
check(indexed.chunkIndexes.length === Number(statistics.chunkCount), "chunk index count");
const perChannel = new Map();
for (const m of streamed) perChannel.set(m.channelId, (perChannel.get(m.channelId) ?? 0) + 1);
for (const [id, n] of statistics.channelMessageCounts) {
  check(perChannel.get(id) === Number(n), `statistics count of channel ${id}`);
}
// A seek: the messages of the second half of the flight, through the index only.
const mid = statistics.messageStartTime + (statistics.messageEndTime - statistics.messageStartTime) / 2n;
let later = 0;
for await (const m of indexed.readMessages({ startTime: mid })) later += m.logTime >= mid ? 1 : 0;
check(later === streamed.filter((m) => m.logTime >= mid).length, "a seek by time misses messages");

// 4. Every message against its schema: Foxglove's own, and the one stored with it.
const ajv = new Ajv({ strict: false, allErrors: false });
const validators = new Map();
const validatorsFor = (schema) => {
  if (!validators.has(schema.id)) {
    const stored = ajv.compile(JSON.parse(new TextDecoder().decode(schema.data)));
    const upstream = foxgloveSchemas[schema.name.replace(/^foxglove\./, "")];
    validators.set(schema.id, {
      stored,
      upstream: schema.name.startsWith("foxglove.") && upstream ? ajv.compile(upstream) : null,
    });
  }
  return validators.get(schema.id);
};
const byTopic = new Map();
let invalid = 0;
for (const m of streamed) {
  const channel = channels.get(m.channelId);
  const schema = storedSchemas.get(channel.schemaId);
  check(channel.messageEncoding === "json" && schema.encoding === "jsonschema", "encodings");
  const message = JSON.parse(new TextDecoder().decode(m.data));
  const v = validatorsFor(schema);
  if (!v.stored(message) || (v.upstream && !v.upstream(message))) {
    if (invalid++ < 3) {
      failures.push(
        `${channel.topic} message invalid: ${ajv.errorsText(v.stored.errors ?? v.upstream.errors)}`,
      );
    }
  }
  check(!schema.name.startsWith("foxglove.") || v.upstream, `no upstream schema ${schema.name}`);
  if (!byTopic.has(channel.topic)) byTopic.set(channel.topic, []);
  byTopic.get(channel.topic).push({ logTime: m.logTime, message });
}
for (const topic of [
  "/zonemap/boxes",
  "/zonemap/sectors",
  "/zonemap/occupied",
  "/zonemap/pose",
  "/zonemap/trajectory",
  "/zonemap/depth",
  "/zonemap/health",
]) {
  check((byTopic.get(topic) ?? []).length > 0, `no message on ${topic}`);
}

// 5. Content: sizes that must agree, the final scene against boxes.csv.
for (const { message: img } of byTopic.get("/zonemap/depth") ?? []) {
  check(Buffer.from(img.data, "base64").length === img.step * img.height, "depth image size");
}
for (const { message: cloud } of byTopic.get("/zonemap/occupied") ?? []) {
  check(Buffer.from(cloud.data, "base64").length % cloud.point_stride === 0, "cloud size");
}
for (const { message: s } of byTopic.get("/zonemap/sectors") ?? []) {
  const sent = s.entities[0].metadata.find((kv) => kv.key === "distances_cm").value.split(",");
  check(sent.length === 72 && s.entities[0].triangles[0].points.length === 216, "72 sectors");
}
// The sky filter's counters ride on every health message, cumulative ones never
// falling and never past stats.json's totals.
const stats = JSON.parse(readFileSync(`${out}/stats.json`, "utf8"));
let skySeen = 0;
for (const { message: h } of byTopic.get("/zonemap/health") ?? []) {
  const c = h.counters;
  for (const key of ["pixels_sky", "pixels_sky_refused", "sky_last_frame", "sky_refused_last_frame"]) {
    check(Number.isInteger(c[key]) && c[key] >= 0, `health without ${key}`);
  }
  check(c.pixels_sky >= skySeen && c.pixels_sky <= stats.pixels_sky, "health pixels_sky against stats.json");
  check(c.pixels_sky_refused <= stats.pixels_sky_refused, "health pixels_sky_refused against stats.json");
  check(c.sky_refused_last_frame <= stats.sky_refused_max_frame, "sky_refused_last_frame over the run's most");
  skySeen = c.pixels_sky;
}
const csv = readFileSync(`${out}/boxes.csv`, "utf8").trim().split("\n").slice(1);
const rows = new Map(
  csv.map((line) => {
    const f = line.split(",");
    return [`box-${f[0]}`, { kind: f[1], min: f.slice(2, 5).map(Number), max: f.slice(5, 8).map(Number) }];
  }),
);
const sameAsCsv = (entities, what) => {
  check(entities.size === rows.size, `${what}: ${entities.size} entities, boxes.csv ${rows.size} rows`);
  for (const [id, e] of entities) {
    const row = rows.get(id);
    if (!row) {
      failures.push(`${what}: ${id} is not in boxes.csv`);
      continue;
    }
    const cube = e.cubes[0];
    const c = [cube.pose.position.x, cube.pose.position.y, cube.pose.position.z];
    const s = [cube.size.x, cube.size.y, cube.size.z];
    for (let k = 0; k < 3; ++k) {
      check(Math.abs(c[k] - s[k] / 2 - row.min[k]) < 2e-3, `${what}: ${id} min`);
      check(Math.abs(c[k] + s[k] / 2 - row.max[k]) < 2e-3, `${what}: ${id} max`);
    }
    check(e.metadata.find((kv) => kv.key === "kind").value === row.kind, `${what}: ${id} kind`);
  }
};
const updates = byTopic.get("/zonemap/boxes") ?? [];
const last = updates.length ? updates[updates.length - 1].message : { entities: [] };
sameAsCsv(new Map(last.entities.map((e) => [e.id, e])), "the last SceneUpdate");
// The scene a viewer holds after every update and deletion, in log-time order.
const scene = new Map();
for (const { message: u } of [...updates].sort((a, b) => (a.logTime < b.logTime ? -1 : 1))) {
  for (const d of u.deletions) scene.delete(d.id);
  for (const e of u.entities) scene.set(e.id, e);
}
sameAsCsv(scene, "the scene after all updates");

const topics = [...byTopic].map(([t, v]) => `${t} ${v.length}`).join(", ");
console.log(
  `run.mcap: ${bytes.length} bytes; records ${JSON.stringify(recordCounts)}; ` +
    `${streamed.length} messages (${topics}); ${indexed.chunkIndexes.length} chunks ` +
    `(${indexed.chunkIndexes.filter((c) => c.compression === "zstd").length} zstd); ` +
    `boxes.csv ${rows.size} rows = last SceneUpdate ${last.entities.length} entities`,
);
if (failures.length) {
  for (const f of failures.slice(0, 20)) console.log(`FAIL: ${f}`);
  process.exit(1);
}
console.log("PASS: every record, CRC, index and message checked by @mcap/core, @foxglove/schemas");
