// Read an MCAP file with Foxglove's own reader (@mcap/core, what the Foxglove app uses) and print, as
// JSON: the header, schemas, channels, message counts per channel, the first messages of every json
// channel, and Foxglove's published JSON schemas (@foxglove/schemas) for LocationFix and GeoJSON.
//   node check_mcap.mjs FILE.mcap
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import fox from "@foxglove/schemas/jsonschema.js";
import { open } from "node:fs/promises";

const fh = await open(process.argv[2], "r");
const size = BigInt((await fh.stat()).size);
const readable = {
  size: async () => size,
  read: async (offset, length) => {
    const b = Buffer.alloc(Number(length));
    await fh.read(b, 0, Number(length), Number(offset));
    return new Uint8Array(b.buffer, b.byteOffset, b.length);
  },
};
const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers: await loadDecompressHandlers() });
const text = new TextDecoder();
const out = {
  header: reader.header,
  schemas: [...reader.schemasById.values()].map((s) => ({ id: s.id, name: s.name, encoding: s.encoding, data: text.decode(s.data) })),
  channels: [...reader.channelsById.values()].map((c) => ({ id: c.id, topic: c.topic, messageEncoding: c.messageEncoding,
    schemaId: c.schemaId, metadata: Object.fromEntries(c.metadata) })),
  counts: {}, samples: {}, metadata: [],
  foxglove: { "foxglove.LocationFix": fox.LocationFix, "foxglove.GeoJSON": fox.GeoJSON },
};
for await (const m of reader.readMessages()) {
  const ch = reader.channelsById.get(m.channelId);
  out.counts[ch.topic] = (out.counts[ch.topic] ?? 0) + 1;
  if (ch.messageEncoding === "json") {
    const s = (out.samples[ch.topic] ??= []);
    if (s.length < 3) s.push(JSON.parse(text.decode(m.data)));
  }
}
for await (const md of reader.readMetadata()) out.metadata.push({ name: md.name, keys: [...md.metadata.keys()] });
await fh.close();
console.log(JSON.stringify(out, (k, v) => (typeof v === "bigint" ? v.toString() : v)));
