#!/usr/bin/env node
// Decode every message of an MCAP file with Foxglove's own readers, the way the Foxglove app
// does: @mcap/core reads the records (zstd/lz4 chunks through @mcap/support's handlers),
// @foxglove/rosmsg parses each `ros2msg` schema (`parse(text, { ros2: true })`) and
// @foxglove/rosmsg2-serialization's MessageReader decodes the CDR.
//
//     node tests/peers/foxglove/decode.mjs FILE
//
// Reads the file twice: linearly (McapStreamReader, every record in file order) and, when the
// file has a summary, through its indexes (McapIndexedReader, as the app opens files). Prints
// JSON: per topic the schema name and message count, the totals of both passes, and the first
// and last decoded value of a few fields (an action's feedback, its statuses, a service
// event's request or response). Exits 1 (message
// on stderr) when a schema does not parse, a message does not decode or leaves bytes over, or
// the two passes disagree.
import { readFileSync } from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";

function fail(msg) {
  process.stderr.write(`foxglove decode: ${msg}\n`);
  process.exit(1);
}

const path = process.argv[2];
if (!path) fail("usage: decode.mjs FILE");
let bytes;
try {
  bytes = readFileSync(path);
} catch (e) {
  fail(`${path}: ${e.message}`);
}
const decompressHandlers = await loadDecompressHandlers();

// one MessageReader per schema id, built as the Foxglove app builds it
function readerFor(schema) {
  if (schema.encoding !== "ros2msg") {
    throw new Error(`schema ${schema.name}: encoding ${schema.encoding} is not ros2msg`);
  }
  const text = new TextDecoder().decode(schema.data);
  return new MessageReader(parse(text, { ros2: true }));
}

// a decoded value as JSON: int64 as a string, uint8 arrays (ids) as hex
function plain(v) {
  if (v === undefined || v === null) return null;
  if (typeof v === "bigint") return String(v);
  if (v instanceof Uint8Array) return Buffer.from(v).toString("hex");
  if (Array.isArray(v)) return v.map(plain);
  if (typeof v === "object") return Object.fromEntries(Object.entries(v).map(([k, x]) => [k, plain(x)]));
  return v;
}

function sample(topic, m) {
  if (m == null || typeof m !== "object") return null;
  if ("seq" in m && "mass_position" in m) return { seq: String(m.seq), mass_position: m.mass_position };
  if ("state_seq" in m) return { state_seq: String(m.state_seq), force: m.force };
  if ("clock" in m) return { sec: m.clock.sec, nanosec: m.clock.nanosec };
  if ("info" in m) {
    return {
      event_type: m.info.event_type,
      requests: m.request.length,
      request: plain(m.request[0]),
      response: plain(m.response[0]),
    };
  }
  if ("commands_sent" in m) return { mode: m.mode, commands_sent: String(m.commands_sent) };
  if ("goal_id" in m && "feedback" in m) return { feedback: m.feedback };
  if (Array.isArray(m.status_list)) return { statuses: m.status_list.map((s) => s.status) };
  if (Array.isArray(m.status) && m.status.length > 0) {
    const s = m.status[0];
    return { level: s.level, message: s.message, values: s.values.map((v) => `${v.key}=${v.value}`) };
  }
  return null;
}

function decodeAll(schemas, channels, messages, topics) {
  const readers = new Map();
  let n = 0;
  for (const msg of messages) {
    const channel = channels.get(msg.channelId);
    if (!channel) throw new Error(`message on unknown channel ${msg.channelId}`);
    let reader = readers.get(channel.schemaId);
    if (!reader) {
      const schema = schemas.get(channel.schemaId);
      if (!schema) throw new Error(`${channel.topic}: unknown schema ${channel.schemaId}`);
      try {
        reader = readerFor(schema);
      } catch (e) {
        throw new Error(`${channel.topic}: schema ${schema.name}: ${e.message}`);
      }
      readers.set(channel.schemaId, reader);
    }
    let value;
    try {
      value = reader.readMessage(msg.data);
    } catch (e) {
      throw new Error(`${channel.topic} message ${msg.sequence}: ${e.message}`);
    }
    if (reader.lastReadHadTrailingBytes()) {
      throw new Error(
        `${channel.topic} message ${msg.sequence}: ${msg.data.byteLength - reader.lastReadByteLength()} bytes left over`,
      );
    }
    if (topics) {
      const t = topics[channel.topic] ?? (topics[channel.topic] = {
        schema: schemas.get(channel.schemaId).name,
        count: 0,
        first: sample(channel.topic, value),
        last: null,
      });
      t.count += 1;
      t.last = sample(channel.topic, value);
    }
    n += 1;
  }
  return n;
}

// pass 1: every record in file order
function* streamMessages(schemas, channels) {
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(bytes);
  for (let rec; (rec = stream.nextRecord()); ) {
    if (rec.type === "Schema") schemas.set(rec.id, rec);
    else if (rec.type === "Channel") channels.set(rec.id, rec);
    else if (rec.type === "Message") yield rec;
  }
  if (!stream.done()) throw new Error(`the file ends early (${stream.bytesRemaining()} bytes unread)`);
}

const out = { topics: {}, messages: 0, indexed_messages: null };
try {
  const schemas = new Map();
  const channels = new Map();
  out.messages = decodeAll(schemas, channels, streamMessages(schemas, channels), out.topics);
} catch (e) {
  fail(`${path}: ${e.message}`);
}

// pass 2: through the summary's indexes, as the app opens a file
try {
  const readable = {
    size: async () => BigInt(bytes.byteLength),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
  const indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const collected = [];
  for await (const m of indexed.readMessages()) collected.push(m);
  out.indexed_messages = decodeAll(indexed.schemasById, indexed.channelsById, collected, null);
} catch (e) {
  fail(`${path}: indexed read: ${e.message}`);
}
if (out.indexed_messages !== out.messages) {
  fail(`${path}: ${out.messages} messages in file order but ${out.indexed_messages} through the indexes`);
}
process.stdout.write(JSON.stringify(out) + "\n");
