// The worker protocol: every request and reply survives a round trip bit for bit, and a frame a
// broken worker could send (truncated, oversized, a count beyond its limit, leftover bytes, an
// unknown op or outcome) is a ProtocolError, raised before anything is allocated for it.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "locd/server/worker_protocol.hpp"

namespace {

using namespace locd;
using namespace locd::server::worker;

// Splits one frame into its header and payload, as the reader does.
std::pair<FrameHeader, std::string> split(const std::string& frame, uint64_t max_payload = 1u << 30) {
  EXPECT_GE(frame.size(), kFrameHeaderBytes);
  const FrameHeader header = parse_header(frame.data(), max_payload);
  EXPECT_EQ(frame.size(), kFrameHeaderBytes + header.length);
  return {header, frame.substr(kFrameHeaderBytes)};
}

Eigen::Isometry3d some_pose(double a) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d(0.2, -0.3, 1.0).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(a, -2.0 * a, 0.5);
  return T;
}

TEST(WorkerProtocol, EveryMeasurementKindRoundTrips) {
  Odometry odometry;
  odometry.header = {11, "odom"};
  odometry.pose = some_pose(0.3);
  odometry.linear_velocity = {0.5, 0.1, 0.0};
  odometry.angular_velocity = {0.0, 0.0, 0.2};
  Imu imu;
  imu.header = {12, "imu"};
  imu.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  imu.orientation_stddev = 0.01;
  LaserScan scan;
  scan.header = {13, "laser"};
  scan.sensor_pose = some_pose(0.1);
  scan.angle_min = -1.5f;
  scan.angle_increment = 0.01f;
  scan.range_min = 0.1f;
  scan.range_max = 30.0f;
  scan.ranges = {1.0f, 2.0f, std::numeric_limits<float>::quiet_NaN()};
  scan.intensities = {0.1f, 0.2f, 0.3f};
  PointCloud cloud;
  cloud.header = {14, "lidar"};
  cloud.points = {{1, 2, 3}, {4, 5, 6}};
  cloud.intensity = {7, 8};
  Image image;
  image.header = {15, "camera"};
  image.width = 2;
  image.height = 1;
  image.channels = 3;
  image.data = {1, 2, 3, 4, 5, 6};
  LandmarkDetections detections;
  detections.header = {16, "base_link"};
  detections.detections.push_back({"sign", {1, 2, 3}, Eigen::Matrix3d::Identity() * 0.5});

  for (const Measurement& m : {Measurement(odometry), Measurement(imu), Measurement(scan), Measurement(cloud),
                               Measurement(image), Measurement(detections)}) {
    std::string frame;
    append_update(frame, 42, m);
    const auto [header, payload] = split(frame);
    EXPECT_EQ(header.op, static_cast<uint32_t>(Op::kUpdate));
    EXPECT_EQ(header.instance, 42u);
    const Measurement back = decode_update(payload, Limits{});
    ASSERT_EQ(back.index(), m.index());
    EXPECT_EQ(header_of(back).stamp_ns, header_of(m).stamp_ns);
    EXPECT_EQ(header_of(back).frame_id, header_of(m).frame_id);
    // Re-encoding the decoded message gives the same bytes: nothing was lost or changed.
    std::string again;
    append_update(again, 42, back);
    EXPECT_EQ(again, frame);
  }
}

UpdateResult full_result() {
  UpdateResult u;
  PoseEstimate e;
  e.header = {99, "map"};
  e.pose = some_pose(1.2);
  e.covariance = Matrix6d::Identity() * 0.04;
  e.covariance(0, 1) = e.covariance(1, 0) = 0.01;
  u.estimate = e;
  u.diagnostics.values = {{"ess", 0.7}, {"clusters", 2}};
  u.diagnostics.particles = {{1, 2, 0.3, 0.5}, {2, 3, 0.4, 0.5}};
  u.diagnostics.associations = {{3, "lm7", 2, 1.5}};
  GridLayer grid;
  grid.layer = "belief";
  grid.resolution = 0.5;
  grid.origin = {-1, -2};
  grid.width = 2;
  grid.height = 2;
  grid.cells = {0.1f, 0.2f, std::numeric_limits<float>::quiet_NaN(), 0.4f};
  u.grid = grid;
  PointCloud map;
  map.points = {{1, 1, 1}};
  u.map_cloud = map;
  u.landmark_map = std::vector<MapFeature>{{"w1", "line", {0, 0, 0}, {1, 0, 0}}};
  ExplorationGoal goal;
  goal.header = {100, "map"};
  goal.pose = some_pose(0.7);
  goal.score = 3.5;
  goal.done = true;
  u.exploration_goal = goal;
  u.localization = LocalizationAssessment{LocalizationState::kUncertain, "2 modes 4.1 m apart"};
  return u;
}

TEST(WorkerProtocol, AReplyWithEveryOutputRoundTrips) {
  Reply reply;
  reply.request = Op::kUpdate;
  reply.outcome = Outcome::kOk;
  reply.message = "fine";
  reply.compute_ms = 1.25;
  reply.result = full_result();
  std::string frame;
  append_reply(frame, 7, reply);
  const auto [header, payload] = split(frame);
  const Reply back = decode_reply(payload, Limits{});
  EXPECT_EQ(back.request, Op::kUpdate);
  EXPECT_EQ(back.message, "fine");
  EXPECT_DOUBLE_EQ(back.compute_ms, 1.25);
  ASSERT_TRUE(back.result.estimate);
  EXPECT_TRUE(back.result.estimate->pose.isApprox(reply.result.estimate->pose, 0.0));
  EXPECT_EQ(back.result.estimate->covariance, reply.result.estimate->covariance);
  EXPECT_EQ(back.result.diagnostics.particles.size(), 2u);
  EXPECT_EQ(back.result.diagnostics.associations[0].feature_id, "lm7");
  ASSERT_TRUE(back.result.grid);
  EXPECT_TRUE(std::isnan(back.result.grid->cells[2]));
  ASSERT_TRUE(back.result.localization);
  EXPECT_EQ(back.result.localization->state, LocalizationState::kUncertain);
  EXPECT_EQ(back.result.localization->reason, "2 modes 4.1 m apart");
  std::string again;
  append_reply(again, 7, back);
  EXPECT_EQ(again, frame);
}

TEST(WorkerProtocol, AConfigureRequestRoundTrips) {
  ConfigureRequest c;
  c.robot_id = "r1";
  c.limits.max_particles = 1234;
  c.map_directories = {"/maps", "/more maps"};
  c.output_directory = "/out";
  c.config = {"sessions:\n  - config: {plugin: x}\n", "locd.yaml", {"sessions", "0", "config"}};
  std::string frame;
  append_configure(frame, 3, c);
  const auto [header, payload] = split(frame);
  const ConfigureRequest back = decode_configure(payload, Limits{});
  EXPECT_EQ(back.robot_id, "r1");
  EXPECT_EQ(back.limits.max_particles, 1234u);
  EXPECT_EQ(back.map_directories, c.map_directories);
  EXPECT_EQ(back.config.yaml, c.config.yaml);
  EXPECT_EQ(back.config.path, c.config.path);
}

TEST(WorkerProtocol, BrokenHeadersAreRefused) {
  std::string frame;
  append_request(frame, 1, Op::kSaveMap);
  std::string bad_magic = frame;
  bad_magic[0] = 'X';
  EXPECT_THROW(parse_header(bad_magic.data(), 1000), ProtocolError);
  FrameHeader h;
  h.op = 55;
  std::string unknown_op(reinterpret_cast<const char*>(&h), sizeof h);
  EXPECT_THROW(parse_header(unknown_op.data(), 1000), ProtocolError);
  h.op = static_cast<uint32_t>(Op::kReply);
  h.length = 1001;
  std::string too_long(reinterpret_cast<const char*>(&h), sizeof h);
  EXPECT_THROW(parse_header(too_long.data(), 1000), ProtocolError);
}

TEST(WorkerProtocol, TruncatedOrPaddedPayloadsAreRefused) {
  Reply reply;
  reply.request = Op::kUpdate;
  reply.result = full_result();
  std::string frame;
  append_reply(frame, 7, reply);
  const std::string payload = frame.substr(kFrameHeaderBytes);
  for (size_t cut = 0; cut < payload.size(); cut += 7) {
    EXPECT_THROW(decode_reply(std::string_view(payload).substr(0, cut), Limits{}), ProtocolError) << cut;
  }
  EXPECT_THROW(decode_reply(payload + "x", Limits{}), ProtocolError);
}

TEST(WorkerProtocol, ACountBeyondItsLimitIsRefusedBeforeAllocating) {
  Reply reply;
  reply.request = Op::kUpdate;
  reply.result.diagnostics.particles.resize(11);
  std::string frame;
  append_reply(frame, 7, reply);
  Limits limits;
  limits.max_particles = 10;
  try {
    decode_reply(frame.substr(kFrameHeaderBytes), limits);
    FAIL() << "11 particles passed a limit of 10";
  } catch (const ProtocolError& e) {
    EXPECT_STREQ(e.what(), "particles: 11 exceed the bound 10");
  }
  // A count far beyond the bytes of the frame (a worker writing garbage) never allocates.
  std::string payload = frame.substr(kFrameHeaderBytes);
  const size_t particles_count_at = sizeof(uint32_t) + 1 + 8 + reply.message.size() + 8 + 1 + 8;
  const uint64_t huge = uint64_t{1} << 40;
  std::memcpy(&payload[particles_count_at], &huge, sizeof huge);
  limits.max_particles = std::numeric_limits<size_t>::max();
  EXPECT_THROW(decode_reply(payload, limits), ProtocolError);
}

TEST(WorkerProtocol, UnknownOutcomesAndStatesAreRefused) {
  Reply reply;
  reply.request = Op::kUpdate;
  reply.result.localization = LocalizationAssessment{LocalizationState::kLost, "x"};
  std::string frame;
  append_reply(frame, 7, reply);
  std::string payload = frame.substr(kFrameHeaderBytes);
  std::string bad_outcome = payload;
  bad_outcome[sizeof(uint32_t)] = 9;
  EXPECT_THROW(decode_reply(bad_outcome, Limits{}), ProtocolError);
  std::string bad_state = payload;
  bad_state[bad_state.size() - 1 - 8 - 1] = 9;  // the state byte before the reason's length and text
  EXPECT_THROW(decode_reply(bad_state, Limits{}), ProtocolError);
  std::string bad_request = payload;
  bad_request[0] = 100;
  EXPECT_THROW(decode_reply(bad_request, Limits{}), ProtocolError);
}

}  // namespace
