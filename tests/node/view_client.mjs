// A Foxglove WebSocket client (@foxglove/ws-protocol over the ws package) as Foxglove itself
// connects: it reads serverInfo and the advertised channels, subscribes to a robot's pose and
// ground truth, decodes the JSON messages and prints one JSON line per message, then a summary;
// every message of the robot's channels with a Foxglove schema is checked against Foxglove's own
// JSON schema (summary.validated, summary.invalid).
//   node view_client.mjs ws://127.0.0.1:PORT ROBOT SECONDS
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { foxgloveErrors } from "./foxglove_schemas.mjs";

const { FoxgloveClient } = wsProtocol;
const [url, robot, seconds] = process.argv.slice(2);
const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
const wanted = new Set([`/${robot}/pose`, `/${robot}/ground_truth`, `/${robot}/status`]);
const subscriptions = new Map();
const summary = { server: null, channels: [], messages: 0, statuses: [], validated: {}, invalid: [] };

client.on("serverInfo", (info) => { summary.server = info.name; });
client.on("status", (s) => summary.statuses.push(s.message));
client.on("error", (e) => { console.log(JSON.stringify({ error: String(e.message ?? e) })); process.exit(1); });
client.on("advertise", (channels) => {
  for (const c of channels) {
    summary.channels.push({ topic: c.topic, schemaName: c.schemaName, encoding: c.encoding });
    const foxglove = c.topic.startsWith(`/${robot}/`) && c.schemaName.startsWith("foxglove.");
    if (wanted.has(c.topic) || foxglove) subscriptions.set(client.subscribe(c.id), c);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const channel = subscriptions.get(subscriptionId);
  const message = JSON.parse(new TextDecoder().decode(data));
  summary.messages += 1;
  if (channel.schemaName.startsWith("foxglove.")) {
    const errors = foxgloveErrors(channel.schemaName, message);
    if (errors && summary.invalid.length < 10) summary.invalid.push({ topic: channel.topic, errors: errors.slice(0, 5) });
    if (!errors) summary.validated[channel.schemaName] = (summary.validated[channel.schemaName] ?? 0) + 1;
  }
  if (!wanted.has(channel.topic)) return;
  if (channel.schemaName === "foxglove.PoseInFrame") {
    const ns = BigInt(message.timestamp.sec) * 1000000000n + BigInt(message.timestamp.nsec);
    console.log(JSON.stringify({ topic: channel.topic, log_time: String(timestamp), stamp_ns: String(ns),
                                 frame_id: message.frame_id, x: message.pose.position.x, y: message.pose.position.y }));
  } else {
    console.log(JSON.stringify({ topic: channel.topic, state: message.state, localization: message.localization }));
  }
});
setTimeout(() => {
  console.log(JSON.stringify({ summary }));
  process.exit(0);
}, Number(seconds) * 1000);
