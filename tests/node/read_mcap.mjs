// Reads MCAP files with the npm MCAP reader (@mcap/core, decompression by @mcap/support) and
// decodes every message with Foxglove's OMG IDL deserializer from the schema the file carries.
// A file with a footer is opened with the indexed reader (summary, chunk indexes); a file without
// one (a killed recorder) with the streaming reader. Prints one JSON line per file.
//   node read_mcap.mjs FILE.mcap...
import fs from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";

const decompressHandlers = await loadDecompressHandlers();

function decoderCache() {
  const cache = new Map();
  return (schema) => {
    if (!cache.has(schema.id)) {
      const text = new TextDecoder().decode(schema.data);
      cache.set(schema.id, new MessageReader(schema.name, parseIDL(text)));
    }
    return cache.get(schema.id);
  };
}

function summarize(result, channel, schema, data, decoder) {
  result.messages += 1;
  result.topics[channel.topic] = (result.topics[channel.topic] ?? 0) + 1;
  if (schema.encoding !== "omgidl" || channel.messageEncoding !== "cdr") return;
  const msg = decoder(schema).readMessage(data);
  result.decoded += 1;
  if (schema.name === "locd::msg::PoseEstimate" && result.poses.length < 1000) {
    result.poses.push({ topic: channel.topic, robot_id: msg.robot_id, stamp_ns: String(msg.header.stamp_ns),
                        x: msg.pose.position.x, y: msg.pose.position.y });
  }
}

async function readIndexed(file, result) {
  const fd = await fs.promises.open(file, "r");
  const size = (await fd.stat()).size;
  const readable = {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const buffer = new Uint8Array(Number(length));
      await fd.read(buffer, 0, Number(length), Number(offset));
      return buffer;
    },
  };
  try {
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    result.reader = "indexed";
    result.chunks = reader.chunkIndexes.length;
    result.statistics_messages = Number(reader.statistics?.messageCount ?? -1n);
    const decoder = decoderCache();
    for await (const m of reader.readMessages()) {
      const channel = reader.channelsById.get(m.channelId);
      summarize(result, channel, reader.schemasById.get(channel.schemaId), m.data, decoder);
    }
  } finally {
    await fd.close();
  }
}

function readStream(file, result) {
  const reader = new McapStreamReader({ decompressHandlers });
  reader.append(fs.readFileSync(file));
  result.reader = "stream";
  const schemas = new Map(), channels = new Map();
  const decoder = decoderCache();
  for (let r; (r = reader.nextRecord()) !== undefined;) {
    if (r.type === "Schema") schemas.set(r.id, r);
    else if (r.type === "Channel") channels.set(r.id, r);
    else if (r.type === "Message") {
      const channel = channels.get(r.channelId);
      summarize(result, channel, schemas.get(channel.schemaId), r.data, decoder);
    }
  }
  result.stream_done = reader.done();
}

for (const file of process.argv.slice(2)) {
  const result = { file, messages: 0, decoded: 0, topics: {}, poses: [] };
  try {
    try {
      await readIndexed(file, result);
    } catch (e) {
      result.indexed_error = String(e.message ?? e);
      Object.assign(result, { messages: 0, decoded: 0, topics: {}, poses: [] });
      readStream(file, result);
    }
    result.ok = true;
  } catch (e) {
    result.ok = false;
    result.error = String(e.message ?? e);
  }
  console.log(JSON.stringify(result));
}
