// A Foxglove client for the live view's CPU figure: connects, subscribes to every advertised
// channel ("all") or to none ("none"), and after SECONDS prints how many messages and bytes it got.
//   node view_subscribe.mjs ws://127.0.0.1:PORT all|none SECONDS
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, mode, seconds] = process.argv.slice(2);
const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
const result = { mode, channels: 0, subscribed: 0, messages: 0, bytes: 0 };
client.on("advertise", (channels) => {
  result.channels += channels.length;
  if (mode !== "all") return;
  for (const c of channels) {
    client.subscribe(c.id);
    result.subscribed += 1;
  }
});
client.on("message", ({ data }) => {
  result.messages += 1;
  result.bytes += data.byteLength;
});
setTimeout(() => {
  console.log(JSON.stringify(result));
  process.exit(0);
}, Number(seconds) * 1000);
