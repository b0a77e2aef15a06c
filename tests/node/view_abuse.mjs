// What a misbehaving client does to the live view: garbage text, unknown ops, subscriptions to
// channels that do not exist or with bad fields, binary frames, a frame larger than the view
// accepts, and CONNECTIONS connections at once; then a well-behaved client checks the view still
// serves. Prints one JSON object.
//   node view_abuse.mjs ws://127.0.0.1:PORT ROBOT CONNECTIONS
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, robot, connections] = process.argv.slice(2);
const result = { statuses: [], oversized_closed_with: null, opened: 0, refused: 0, after: null };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// 1. Garbage on one raw connection, reading the status answers.
await new Promise((resolve) => {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  ws.on("message", (data, binary) => {
    if (binary) return;
    const m = JSON.parse(data.toString());
    if (m.op === "status") result.statuses.push(m.message);
  });
  ws.on("open", async () => {
    ws.send("this is not json {");
    ws.send(JSON.stringify([1, 2, 3]));
    ws.send(JSON.stringify({ op: "publishEverything\u0007" }));
    ws.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 1, channelId: 999999 }] }));
    ws.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: -4, channelId: "x" }] }));
    ws.send(JSON.stringify({ op: "subscribe" }));
    ws.send(JSON.stringify({ op: "unsubscribe", subscriptionIds: [12345] }));
    ws.send(Buffer.from([1, 2, 3, 4]));
    await sleep(500);
    ws.close();
    resolve();
  });
});

// 2. A frame beyond the view's message limit: the view closes that connection (1009).
await new Promise((resolve) => {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  ws.on("open", () => ws.send("x".repeat(1 << 20)));
  ws.on("close", (code) => { result.oversized_closed_with = code; resolve(); });
  ws.on("error", () => {});
});

// 3. Many connections at once.
const sockets = [];
await Promise.all(Array.from({ length: Number(connections) }, () => new Promise((resolve) => {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  sockets.push(ws);
  ws.on("open", () => { result.opened += 1; resolve(); });
  ws.on("unexpected-response", (req, res) => { if (res.statusCode === 503) result.refused += 1; resolve(); });
  ws.on("error", () => resolve());
})));
for (const ws of sockets) ws.terminate();
await sleep(500);

// 4. A well-behaved client afterwards gets the fleet and the robot's poses.
result.after = await new Promise((resolve) => {
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const after = { server: null, poses: 0 };
  client.on("serverInfo", (info) => { after.server = info.name; });
  client.on("advertise", (channels) => {
    for (const c of channels) if (c.topic === `/${robot}/pose`) client.subscribe(c.id);
  });
  client.on("message", () => { after.poses += 1; });
  setTimeout(() => resolve(after), 3000);
});
console.log(JSON.stringify(result));
process.exit(0);
