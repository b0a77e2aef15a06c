// Who gets into the live view, as Foxglove's own client library connects: without a token, with a
// wrong one, with a token in the URL and in an Authorization header, with a token bound to another
// robot (it must see none of ROBOT's channels and cannot subscribe to them by id), and from a
// browser page of a foreign origin and of Foxglove's. Prints one JSON object.
//   node view_access.mjs ws://127.0.0.1:PORT ROBOT ALL_TOKEN ROBOT_TOKEN OTHER_TOKEN
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, robot, allToken, robotToken, otherToken] = process.argv.slice(2);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Connects, collects for `ms` what the server says, subscribes to the robot's pose (or to
// `subscribeId`), and reports the HTTP status of a refusal.
function attempt(target, { headers = {}, origin, subscribeId, ms = 3000 } = {}) {
  return new Promise((resolve) => {
    const ws = new WebSocket(target, [FoxgloveClient.SUPPORTED_SUBPROTOCOL], { headers, origin });
    const r = { opened: false, refused_status: null, refused_body: "", channels: [], statuses: [], poses: 0 };
    ws.on("unexpected-response", (req, res) => {
      r.refused_status = res.statusCode;
      res.on("data", (d) => { r.refused_body += d.toString(); });
      res.on("end", () => resolve(r));
    });
    ws.on("error", () => {});
    const client = new FoxgloveClient({ ws });
    client.on("error", () => {});
    client.on("open", () => { r.opened = true; });
    client.on("status", (s) => r.statuses.push(s.message));
    const subscriptions = new Map();
    client.on("advertise", (channels) => {
      for (const c of channels) {
        r.channels.push({ id: c.id, topic: c.topic });
        if (subscribeId === undefined && c.topic === `/${robot}/pose`) subscriptions.set(client.subscribe(c.id), c);
      }
    });
    client.on("message", () => { r.poses += 1; });
    if (subscribeId !== undefined) {
      client.on("serverInfo", () => { setTimeout(() => client.subscribe(subscribeId), 300); });
    }
    setTimeout(() => { ws.terminate(); resolve(r); }, ms);
  });
}

const result = {};
result.no_token = await attempt(url, { ms: 1500 });
result.wrong_token = await attempt(`${url}/?token=${"x".repeat(32)}`, { ms: 1500 });
result.all_in_query = await attempt(`${url}/?token=${allToken}`);
result.robot_in_header = await attempt(url, { headers: { Authorization: `Bearer ${robotToken}` } });
const pose = result.all_in_query.channels.find((c) => c.topic === `/${robot}/pose`);
result.other_robot = await attempt(`${url}/?token=${otherToken}`, { subscribeId: pose ? pose.id : 1 });
result.foreign_origin = await attempt(`${url}/?token=${allToken}`, { origin: "https://attacker.example", ms: 1500 });
result.foxglove_origin = await attempt(`${url}/?token=${allToken}`, { origin: "https://app.foxglove.dev", ms: 1500 });
console.log(JSON.stringify(result));
process.exit(0);
