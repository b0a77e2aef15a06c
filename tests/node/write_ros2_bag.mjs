// An independent ROS 2 bag writer for the bag replay test: reads a simulator run that locsim
// recorded (locsim run --mcap: locd's own topics, decoded with Foxglove's OMG IDL deserializer
// from the schema the file carries) and writes it as `ros2 bag record -s mcap` would: the npm
// MCAP writer (@mcap/core), profile ros2, schemas in ros2msg (the .msg text of the ROS 2 types,
// dependencies after "MSG:" separators), messages CDR-encoded by Foxglove's ROS 2 serializer
// (@foxglove/rosmsg2-serialization). Topics: /scan (sensor_msgs/msg/LaserScan, frame laser),
// /odom (nav_msgs/msg/Odometry, odom -> base_link), /tf (odom -> base_link) and /tf_static
// (base_link -> laser, from the scans' sensor pose). Stamps are the simulated ones plus 1.7e9 s
// (an epoch clock, as a real robot's). Also writes the ground truth as a TUM trajectory.
//   node write_ros2_bag.mjs SIM.mcap OUT.mcap OUT.tum [--compression zstd|none] [--variant V]
// Variants: renamed (/front_scan, /wheel_odom), wrong-type (/scan declared as my_msgs/msg/Scan),
// backwards (the 20th scan stamped before the one before it), late-static (/tf_static written
// after the 9th scan, as a recorder that subscribed to it late).
// Prints one JSON line: what it wrote.
import fs from "node:fs";
import { McapIndexedReader, McapWriter } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";
import { parse as parseMsg } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";

const [input, output, tumFile, ...rest] = process.argv.slice(2);
const option = (name, fallback) => {
  const i = rest.indexOf(name);
  return i >= 0 ? rest[i + 1] : fallback;
};
const compression = option("--compression", "zstd");
const variant = option("--variant", "good");
const kEpochOffsetNs = 1_700_000_000n * 1_000_000_000n;
const separator = "\n" + "=".repeat(80) + "\n";

// The .msg definitions (ros2/common_interfaces, ros2/rcl_interfaces, ros2/geometry2).
const msg = {
  "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
  "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
  "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
  "geometry_msgs/Pose": "Point position\nQuaternion orientation",
  "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
  "geometry_msgs/Twist": "Vector3 linear\nVector3 angular",
  "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
  "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation",
  "geometry_msgs/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform",
  "sensor_msgs/LaserScan":
    "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\nfloat32 time_increment\n" +
    "float32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities",
  "nav_msgs/Odometry":
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n" +
    "geometry_msgs/TwistWithCovariance twist",
  "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
};
const deps = {
  "sensor_msgs/LaserScan": ["std_msgs/Header", "builtin_interfaces/Time"],
  "nav_msgs/Odometry": ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance",
    "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion", "geometry_msgs/TwistWithCovariance",
    "geometry_msgs/Twist", "geometry_msgs/Vector3"],
  "tf2_msgs/TFMessage": ["geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time",
    "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"],
};
function schemaText(type) {
  return [msg[type], ...deps[type].map((d) => `MSG: ${d}\n${msg[d]}`)].join(separator) + "\n";
}

const time = (ns) => ({ sec: Number(ns / 1_000_000_000n), nanosec: Number(ns % 1_000_000_000n) });
const quaternion = (q) => ({ x: q.x, y: q.y, z: q.z, w: q.w });

// ------------------------------------------------------------------ read the simulator's run
const decompressHandlers = await loadDecompressHandlers();
const fd = await fs.promises.open(input, "r");
const size = (await fd.stat()).size;
const reader = await McapIndexedReader.Initialize({
  readable: {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const buffer = new Uint8Array(Number(length));
      await fd.read(buffer, 0, Number(length), Number(offset));
      return buffer;
    },
  },
  decompressHandlers,
});
const decoders = new Map();
const sim = [];  // { kind, msg } in log-time order
for await (const m of reader.readMessages()) {
  const channel = reader.channelsById.get(m.channelId);
  const kind = channel.metadata.get("dds_topic");
  if (!["locd/scan", "locd/odometry", "locd/ground_truth"].includes(kind)) continue;
  const schema = reader.schemasById.get(channel.schemaId);
  if (!decoders.has(schema.id)) {
    decoders.set(schema.id, new MessageReader(schema.name, parseIDL(new TextDecoder().decode(schema.data))));
  }
  sim.push({ kind, msg: decoders.get(schema.id).readMessage(m.data) });
}
await fd.close();

// ------------------------------------------------------------------ write the bag
await zstd.isLoaded;
const out = fs.openSync(output, "w");
let position = 0n;
const writer = new McapWriter({
  writable: {
    position: () => position,
    write: async (buffer) => {
      fs.writeSync(out, buffer);
      position += BigInt(buffer.byteLength);
    },
  },
  useStatistics: true,
  useChunks: true,
  chunkSize: 64 * 1024,
  compressChunk: compression === "zstd" ? (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }) : undefined,
});
await writer.start({ profile: "ros2", library: "write_ros2_bag.mjs (@mcap/core)" });

const channels = {};
async function channel(topic, type, schemaName = type.replace("/", "/msg/")) {
  const schemaId = await writer.registerSchema({ name: schemaName, encoding: "ros2msg",
                                                 data: new TextEncoder().encode(schemaText(type)) });
  const id = await writer.registerChannel({ topic, schemaId, messageEncoding: "cdr",
                                            metadata: new Map([["offered_qos_profiles", ""]]) });
  channels[topic] = { id, writer: new MessageWriter(parseMsg(schemaText(type), { ros2: true })), sequence: 0 };
}
const scanTopic = variant === "renamed" ? "/front_scan" : "/scan";
const odomTopic = variant === "renamed" ? "/wheel_odom" : "/odom";
await channel(scanTopic, "sensor_msgs/LaserScan", variant === "wrong-type" ? "my_msgs/msg/Scan" : undefined);
await channel(odomTopic, "nav_msgs/Odometry");
await channel("/tf", "tf2_msgs/TFMessage");
await channel("/tf_static", "tf2_msgs/TFMessage");

const counts = {};
async function write(topic, stampNs, message) {
  const c = channels[topic];
  const data = c.writer.writeMessage(message);
  await writer.addMessage({ channelId: c.id, sequence: c.sequence++, logTime: stampNs, publishTime: stampNs, data });
  counts[topic] = (counts[topic] ?? 0) + 1;
}

const zero36 = new Array(36).fill(0);
const tum = ["# ground truth of the simulated robot: t x y z qx qy qz qw"];
let wroteStatic = false, scans = 0;
let previousScanStamp = 0n;
for (const { kind, msg: m } of sim) {
  const stamp = BigInt(m.header.stamp_ns) + kEpochOffsetNs;
  if (kind === "locd/ground_truth") {
    const p = m.pose.position, q = m.pose.orientation;
    const t = `${stamp / 1_000_000_000n}.${String(stamp % 1_000_000_000n).padStart(9, "0")}`;
    tum.push(`${t} ${p.x} ${p.y} ${p.z} ${q.x} ${q.y} ${q.z} ${q.w}`);
  } else if (kind === "locd/odometry") {
    await write(odomTopic, stamp, {
      header: { stamp: time(stamp), frame_id: "odom" },
      child_frame_id: "base_link",
      pose: { pose: { position: m.pose.position, orientation: quaternion(m.pose.orientation) }, covariance: zero36 },
      twist: { twist: { linear: m.linear_velocity, angular: m.angular_velocity }, covariance: zero36 },
    });
    await write("/tf", stamp, { transforms: [{
      header: { stamp: time(stamp), frame_id: "odom" }, child_frame_id: "base_link",
      transform: { translation: m.pose.position, rotation: quaternion(m.pose.orientation) } }] });
  } else if (kind === "locd/scan") {
    const frame = m.header.frame_id || "laser";
    ++scans;
    if (!wroteStatic && (variant !== "late-static" || scans === 10)) {  // the laser's mount, latched
      wroteStatic = true;
      await write("/tf_static", stamp, { transforms: [{
        header: { stamp: time(stamp), frame_id: "base_link" }, child_frame_id: frame,
        transform: { translation: m.sensor_pose.position, rotation: quaternion(m.sensor_pose.orientation) } }] });
    }
    let scanStamp = stamp;
    if (variant === "backwards" && scans === 20) scanStamp = previousScanStamp - 50_000_000n;
    previousScanStamp = scanStamp;
    const n = m.ranges.length;
    await write(scanTopic, stamp, {
      header: { stamp: time(scanStamp), frame_id: frame },
      angle_min: m.angle_min,
      angle_max: m.angle_min + (n - 1) * m.angle_increment,
      angle_increment: m.angle_increment,
      time_increment: 0,
      scan_time: 0.1,
      range_min: m.range_min,
      range_max: m.range_max,
      ranges: Float32Array.from(m.ranges),
      intensities: Float32Array.from(m.intensities),
    });
  }
}
await writer.end();
fs.closeSync(out);
fs.writeFileSync(tumFile, tum.join("\n") + "\n");
console.log(JSON.stringify({ ok: true, output, compression, variant, counts, reference_poses: tum.length - 1 }));
