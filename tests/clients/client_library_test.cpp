// locd::Client over real Cyclone DDS on loopback: every sensor type survives the wire exactly,
// poses reach callbacks filtered by robot, a session request is answered only by the status
// carrying its request_id, server info and session states are converted. A raw locd::dds
// reader/writer plays the server in each test.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <future>
#include <limits>
#include <mutex>
#include <thread>

#include "locd/client/client.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/dds.hpp"
#include "locd/dds/topics.hpp"
#include "test_env.hpp"

namespace locd {
namespace {

using namespace std::chrono_literals;

constexpr uint32_t kDomainSensors = 40;
constexpr uint32_t kDomainPoses = 41;
constexpr uint32_t kDomainRequests = 42;
constexpr uint32_t kDomainServerInfo = 43;
constexpr uint32_t kDomainOwnPoses = 192;

// Polls `condition` until it holds or `timeout` passes.
template <typename Condition>
bool eventually(Condition condition, std::chrono::milliseconds timeout = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

// A raw reader whose callback copies each sample into an owned value while the loan is valid
// (sequence buffers of a taken sample die with the loan).
template <typename T, typename Owned>
class Inbox {
 public:
  Inbox(const dds::Participant& p, const char* topic, dds::QosProfile qos, std::function<Owned(const T&)> copy,
        const dds::Partitions& partitions)
      : reader_(p, topic, qos, [this, copy](const T& s) {
          std::lock_guard<std::mutex> l(mutex_);
          items_.push_back(copy(s));
        }, 8, partitions) {}
  uint32_t matched() const { return reader_.matched(); }
  Owned take_one() {
    std::vector<Owned> got;
    const bool arrived = eventually([&] {
      std::lock_guard<std::mutex> l(mutex_);
      got.swap(items_);
      return !got.empty();
    });
    if (!arrived) throw std::runtime_error("nothing received on " + reader_.topic());
    EXPECT_EQ(got.size(), 1u) << reader_.topic();
    return got.front();
  }

 private:
  std::mutex mutex_;
  std::vector<Owned> items_;
  dds::Reader<T> reader_;
};

template <typename Seq>
auto owned(const Seq& seq) {
  using Element = std::remove_pointer_t<decltype(seq._buffer)>;
  return std::vector<Element>(seq._buffer, seq._buffer + seq._length);
}

// Takes from a raw reader (fixed-size types only) until one sample arrives.
template <typename T>
T take_one(dds::Reader<T>& reader) {
  std::vector<T> got;
  EXPECT_TRUE(eventually([&] {
    reader.take([&](const T& sample) { got.push_back(sample); });  // fixed-size T: a copy owns all
    return !got.empty();
  })) << "nothing received on " << reader.topic();
  if (got.empty()) throw std::runtime_error("nothing received on " + reader.topic());
  EXPECT_EQ(got.size(), 1u) << reader.topic();
  return got.front();
}

// A SessionRequest taken, with its config_yaml (an octet sequence) copied out of the loan.
struct TakenRequest {
  std::string robot_id, plugin, config_yaml;
  uint64_t request_id = 0;
  locd_msg_SessionAction action = locd_msg_SESSION_START;
};
TakenRequest take_request(dds::Reader<locd_msg_SessionRequest>& reader) {
  std::vector<TakenRequest> got;
  EXPECT_TRUE(eventually([&] {
    reader.take([&](const locd_msg_SessionRequest& m) {
      got.push_back({dds::to_string(m.robot_id), dds::to_string(m.plugin), dds::to_string(m.config_yaml), m.request_id,
                     m.action});
    });
    return !got.empty();
  })) << "nothing received on " << reader.topic();
  if (got.empty()) throw std::runtime_error("nothing received on " + reader.topic());
  EXPECT_EQ(got.size(), 1u) << reader.topic();
  return got.front();
}

Eigen::Isometry3d some_pose(double x, double y, double z, double yaw, double pitch) {
  return Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY());
}

// The wire pose is the position and Eigen's quaternion of the rotation, bit for bit.
void expect_wire_pose(const locd_msg_Pose3D& wire, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  EXPECT_EQ(wire.position.x, T.translation().x());
  EXPECT_EQ(wire.position.y, T.translation().y());
  EXPECT_EQ(wire.position.z, T.translation().z());
  EXPECT_EQ(wire.orientation.x, q.x());
  EXPECT_EQ(wire.orientation.y, q.y());
  EXPECT_EQ(wire.orientation.z, q.z());
  EXPECT_EQ(wire.orientation.w, q.w());
  EXPECT_TRUE(dds::from_wire(wire).isApprox(T, 1e-12));
}

void expect_header(const locd_msg_MessageHeader& wire, const Header& h) {
  EXPECT_EQ(wire.stamp_ns, h.stamp_ns);
  EXPECT_EQ(dds::to_string(wire.frame_id), h.frame_id);
}

TEST(ClientLibrary, EverySensorTypeSurvivesTheWireExactly) {
  Client client({kDomainSensors, "robot_wire", 8});
  dds::Participant p(kDomainSensors);
  using dds::QosProfile;
  // A server's readers: in every robot's partition; the client writes in robot.robot_wire.
  const dds::Partitions all{topics::kAllRobotsPartition};
  dds::Reader<locd_msg_Odometry> odometry(p, topics::kOdometry, QosProfile::kSensor, nullptr, 8, all);
  dds::Reader<locd_msg_Imu> imu(p, topics::kImu, QosProfile::kSensor, nullptr, 8, all);
  struct ScanCopy { locd_msg_LaserScan wire; std::vector<float> ranges, intensities; };
  Inbox<locd_msg_LaserScan, ScanCopy> scan(p, topics::kScan, QosProfile::kSensor, [](const locd_msg_LaserScan& m) {
    return ScanCopy{m, owned(m.ranges), owned(m.intensities)};
  }, all);
  struct CloudCopy { locd_msg_PointCloud wire; std::vector<float> xyz, intensity; };
  Inbox<locd_msg_PointCloud, CloudCopy> cloud(p, topics::kCloud, QosProfile::kSensor, [](const locd_msg_PointCloud& m) {
    return CloudCopy{m, owned(m.xyz), owned(m.intensity)};
  }, all);
  struct ImageCopy { locd_msg_Image wire; std::vector<uint8_t> data; };
  Inbox<locd_msg_Image, ImageCopy> image(p, topics::kImage, QosProfile::kSensor, [](const locd_msg_Image& m) {
    return ImageCopy{m, owned(m.data)};
  }, all);
  struct DetectionsCopy { locd_msg_LandmarkDetections wire; std::vector<locd_msg_LandmarkDetection> items; };
  Inbox<locd_msg_LandmarkDetections, DetectionsCopy> detections(
      p, topics::kDetections, QosProfile::kSensor,
      [](const locd_msg_LandmarkDetections& m) { return DetectionsCopy{m, owned(m.detections)}; }, all);
  dds::Reader<locd_msg_PoseEstimate> truth(p, topics::kGroundTruth, QosProfile::kSensor, nullptr, 8, all);
  dds::Reader<locd_msg_InitialPose> initial(p, topics::kInitialPose, QosProfile::kState, nullptr, 8, all);
  ASSERT_TRUE(eventually([&] {
    return odometry.matched() && imu.matched() && scan.matched() && cloud.matched() && image.matched() &&
           detections.matched() && truth.matched() && initial.matched();
  })) << "the client's writers were not discovered on domain " << kDomainSensors;

  Odometry odo;
  odo.header = {1'700'000'000'123'456'789, "odom"};
  odo.pose = some_pose(1.25, -3.5, 0.01, 0.7, 0.02);
  odo.linear_velocity = {0.9, -0.01, 0.0};
  odo.angular_velocity = {0.0, 0.0, -0.3141592653589793};
  client.publish(odo);
  const auto w_odo = take_one(odometry);
  EXPECT_EQ(dds::to_string(w_odo.robot_id), "robot_wire");
  expect_header(w_odo.header, odo.header);
  expect_wire_pose(w_odo.pose, odo.pose);
  EXPECT_EQ(w_odo.linear_velocity.x, 0.9);
  EXPECT_EQ(w_odo.linear_velocity.y, -0.01);
  EXPECT_EQ(w_odo.angular_velocity.z, -0.3141592653589793);
  EXPECT_EQ(w_odo.header.sequence_number, 1u);  // the client numbers each sensor stream from 1
  client.publish(odo);
  EXPECT_EQ(take_one(odometry).header.sequence_number, 2u);
  odo.header.sequence = 77;  // numbered by the caller: left as it is
  client.publish(odo);
  EXPECT_EQ(take_one(odometry).header.sequence_number, 77u);

  Imu m_imu;
  m_imu.header = {42, "imu_link"};
  m_imu.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  m_imu.angular_velocity = {0.1, 0.2, 0.3};
  m_imu.linear_acceleration = {-9.0e-3, 1.5, 7.25};
  m_imu.orientation_stddev = 0.0175;
  m_imu.acceleration_stddev = -1.0;
  client.publish(m_imu);
  const auto w_imu = take_one(imu);
  expect_header(w_imu.header, m_imu.header);
  EXPECT_EQ(w_imu.orientation.x, m_imu.orientation.x());
  EXPECT_EQ(w_imu.orientation.y, m_imu.orientation.y());
  EXPECT_EQ(w_imu.orientation.z, m_imu.orientation.z());
  EXPECT_EQ(w_imu.orientation.w, m_imu.orientation.w());
  EXPECT_EQ(w_imu.angular_velocity.y, 0.2);
  EXPECT_EQ(w_imu.linear_acceleration.x, -9.0e-3);
  EXPECT_EQ(w_imu.linear_acceleration.z, 7.25);
  EXPECT_EQ(w_imu.orientation_stddev, 0.0175);
  EXPECT_EQ(w_imu.acceleration_stddev, -1.0);

  LaserScan m_scan;
  m_scan.header = {1'000'000'001, "laser"};
  m_scan.sensor_pose = some_pose(0.2, 0.0, 0.3, 0.0, 0.1);
  m_scan.angle_min = -1.5707964f;
  m_scan.angle_increment = 0.008726646f;
  m_scan.range_min = 0.05f;
  m_scan.range_max = 30.0f;
  for (int i = 0; i < 361; ++i) {
    m_scan.ranges.push_back(1.0f + 0.0137f * static_cast<float>(i));
    m_scan.intensities.push_back(static_cast<float>(i % 7));
  }
  m_scan.ranges[5] = std::numeric_limits<float>::infinity();  // no return, sent as is
  client.publish(m_scan);
  const ScanCopy got_scan = scan.take_one();
  const auto& w_scan = got_scan.wire;
  EXPECT_EQ(dds::to_string(w_scan.robot_id), "robot_wire");
  expect_header(w_scan.header, m_scan.header);
  expect_wire_pose(w_scan.sensor_pose, m_scan.sensor_pose);
  EXPECT_EQ(w_scan.angle_min, m_scan.angle_min);
  EXPECT_EQ(w_scan.angle_increment, m_scan.angle_increment);
  EXPECT_EQ(w_scan.range_min, m_scan.range_min);
  EXPECT_EQ(w_scan.range_max, m_scan.range_max);
  EXPECT_EQ(got_scan.ranges, m_scan.ranges);
  EXPECT_EQ(got_scan.intensities, m_scan.intensities);

  PointCloud m_cloud;
  m_cloud.header = {7, "velodyne"};
  m_cloud.sensor_pose = some_pose(0.0, 0.1, 1.2, 3.0, 0.0);
  for (int i = 0; i < 1000; ++i) {
    m_cloud.points.emplace_back(0.01f * i, -0.5f * i, 3.25f);
    m_cloud.intensity.push_back(0.25f * i);
  }
  client.publish(m_cloud);
  const CloudCopy got_cloud = cloud.take_one();
  expect_header(got_cloud.wire.header, m_cloud.header);
  expect_wire_pose(got_cloud.wire.sensor_pose, m_cloud.sensor_pose);
  ASSERT_EQ(got_cloud.xyz.size(), 3000u);
  for (int i = 0; i < 1000; ++i) {
    EXPECT_EQ(got_cloud.xyz[3 * i], m_cloud.points[i].x());
    EXPECT_EQ(got_cloud.xyz[3 * i + 1], m_cloud.points[i].y());
    EXPECT_EQ(got_cloud.xyz[3 * i + 2], m_cloud.points[i].z());
  }
  EXPECT_EQ(got_cloud.intensity, m_cloud.intensity);

  Image m_image;
  m_image.header = {99, "camera"};
  m_image.width = 5;
  m_image.height = 3;
  m_image.channels = 3;
  for (int i = 0; i < 5 * 3 * 3; ++i) m_image.data.push_back(static_cast<uint8_t>(i * 5));
  client.publish(m_image);
  const ImageCopy got_image = image.take_one();
  const auto& w_image = got_image.wire;
  expect_header(w_image.header, m_image.header);
  EXPECT_EQ(w_image.width, 5u);
  EXPECT_EQ(w_image.height, 3u);
  EXPECT_EQ(w_image.step, 15u);
  EXPECT_EQ(dds::to_string(w_image.encoding), "bgr8");
  EXPECT_EQ(got_image.data, m_image.data);
  Image inconsistent = m_image;
  inconsistent.data.pop_back();
  EXPECT_THROW(client.publish(inconsistent), std::invalid_argument);

  LandmarkDetections m_det;
  m_det.header = {123, "base_link"};
  for (int i = 0; i < 3; ++i) {
    LandmarkDetection d;
    d.class_label = "sign_" + std::to_string(i);
    d.position = {1.0 + i, -2.0 * i, 0.5};
    d.covariance << 0.01, 0.001 * i, 0, 0.001 * i, 0.02, 0, 0, 0, 0.03 + i;
    m_det.detections.push_back(d);
  }
  client.publish(m_det);
  const DetectionsCopy got_det = detections.take_one();
  expect_header(got_det.wire.header, m_det.header);
  ASSERT_EQ(got_det.items.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const auto& w = got_det.items[i];
    EXPECT_EQ(dds::to_string(w.class_label), m_det.detections[i].class_label);
    EXPECT_EQ(w.position.x, m_det.detections[i].position.x());
    EXPECT_EQ(w.position.y, m_det.detections[i].position.y());
    for (int k = 0; k < 9; ++k) EXPECT_EQ(w.covariance[k], m_det.detections[i].covariance(k / 3, k % 3));
  }

  PoseEstimate m_truth;
  m_truth.header = {555, "map"};
  m_truth.pose = some_pose(10.5, 4.25, 0.0, -2.5, 0.0);
  for (int k = 0; k < 36; ++k) m_truth.covariance(k / 6, k % 6) = 0.001 * (k + 1);
  m_truth.linear_velocity = {0.5, 0.25, 0.0};
  client.publish_ground_truth(m_truth);
  const auto w_truth = take_one(truth);
  EXPECT_EQ(dds::to_string(w_truth.robot_id), "robot_wire");
  expect_header(w_truth.header, m_truth.header);
  expect_wire_pose(w_truth.pose, m_truth.pose);
  for (int k = 0; k < 36; ++k) EXPECT_EQ(w_truth.covariance[k], m_truth.covariance(k / 6, k % 6));
  EXPECT_EQ(w_truth.linear_velocity.x, 0.5);

  PoseEstimate m_initial = m_truth;
  m_initial.header.stamp_ns = 556;
  client.set_initial_pose(m_initial);
  const auto w_initial = take_one(initial);
  EXPECT_EQ(dds::to_string(w_initial.robot_id), "robot_wire");
  expect_header(w_initial.header, m_initial.header);
  expect_wire_pose(w_initial.pose, m_initial.pose);
  for (int k = 0; k < 36; ++k) EXPECT_EQ(w_initial.covariance[k], m_initial.covariance(k / 6, k % 6));
  EXPECT_TRUE(client.wait_for_delivery(10s));
}

TEST(ClientLibrary, PosesReachCallbacksFilteredByRobot) {
  dds::Participant server(kDomainPoses);
  // A fake server writing both robots' poses (a real one writes each in its own partition).
  const dds::Partitions both{topics::robot_partition("robot_a"), topics::robot_partition("robot_b")};
  dds::Writer<locd_msg_PoseEstimate> poses(server, topics::kPose, dds::QosProfile::kPose, 8, both);

  Client client({kDomainPoses, "", 8});
  std::mutex mutex;
  std::vector<PoseUpdate> only_a, every_robot;
  // A callback that throws is reported and does not stop delivery to the others.
  client.on_pose([](const PoseUpdate&) { throw std::runtime_error("callback failure on purpose"); });
  client.on_pose([&](const PoseUpdate& p) { std::lock_guard<std::mutex> l(mutex); only_a.push_back(p); }, "robot_a");
  client.on_pose([&](const PoseUpdate& p) { std::lock_guard<std::mutex> l(mutex); every_robot.push_back(p); });
  ASSERT_TRUE(eventually([&] { return poses.matched() > 0; }));

  PoseEstimate estimate;
  estimate.header = {1'000, "map"};
  estimate.pose = some_pose(3.0, 4.0, 0.0, 1.0, 0.0);
  estimate.covariance = Matrix6d::Identity() * 0.04;
  dds::write(poses, "robot_a", estimate, "feature_ekf", 0.375);
  ASSERT_TRUE(eventually([&] { std::lock_guard<std::mutex> l(mutex); return every_robot.size() == 1; }));
  estimate.header.stamp_ns = 2'000;
  dds::write(poses, "robot_b", estimate, "ceiling_pf", 1.5);
  ASSERT_TRUE(eventually([&] { std::lock_guard<std::mutex> l(mutex); return every_robot.size() == 2; }));

  // A pose with NaN is dropped by the client; the next good one still arrives. (A stronger writer:
  // poses are exclusively owned, and DDS takes a robot's poses from the strongest writer only.)
  auto broken = dds::Writer<locd_msg_PoseEstimate>(server, topics::kPose, dds::QosProfile::kPose, 8, both, 1);
  ASSERT_TRUE(eventually([&] { return broken.matched() > 0; }));
  locd_msg_PoseEstimate nan_pose{};
  dds::copy_string(nan_pose.robot_id, "robot_a");
  nan_pose.pose.position.x = std::numeric_limits<double>::quiet_NaN();
  nan_pose.pose.orientation.w = 1.0;
  broken.write(nan_pose);
  estimate.header.stamp_ns = 3'000;
  dds::write(broken, "robot_a", estimate, "feature_ekf", 0.25);
  ASSERT_TRUE(eventually([&] { std::lock_guard<std::mutex> l(mutex); return every_robot.size() == 3; }));
  std::this_thread::sleep_for(100ms);

  std::lock_guard<std::mutex> l(mutex);
  ASSERT_EQ(every_robot.size(), 3u);
  ASSERT_EQ(only_a.size(), 2u);
  EXPECT_EQ(only_a[0].robot_id, "robot_a");
  EXPECT_EQ(only_a[0].plugin, "feature_ekf");
  EXPECT_EQ(only_a[0].update_ms, 0.375);
  EXPECT_EQ(only_a[0].estimate.header.stamp_ns, 1'000);
  EXPECT_EQ(only_a[0].estimate.header.frame_id, "map");
  EXPECT_TRUE(only_a[0].estimate.pose.isApprox(estimate.pose, 1e-12));
  EXPECT_EQ(only_a[0].estimate.covariance, estimate.covariance);
  EXPECT_GT(only_a[0].received_wall_ns, 0);
  EXPECT_EQ(only_a[1].estimate.header.stamp_ns, 3'000);
  EXPECT_EQ(every_robot[1].robot_id, "robot_b");
  EXPECT_EQ(every_robot[1].plugin, "ceiling_pf");
}

// A robot's client reads only its own robot's partition: another robot's poses never reach it,
// so N robots watching themselves cost O(N) pose traffic. A watcher of {"*"} gets every robot.
TEST(ClientLibrary, ARobotsClientReceivesOnlyItsOwnPoses) {
  dds::Participant server(kDomainOwnPoses);
  dds::Writer<locd_msg_PoseEstimate> poses_a(server, topics::kPose, dds::QosProfile::kPose, 8,
                                             {topics::robot_partition("robot_a")});
  dds::Writer<locd_msg_PoseEstimate> poses_b(server, topics::kPose, dds::QosProfile::kPose, 8,
                                             {topics::robot_partition("robot_b")});
  Client robot_a({kDomainOwnPoses, "robot_a", 8});
  Client operator_view({.domain_id = kDomainOwnPoses, .robot_id = "", .sensor_depth = 8, .watch = {"*"}});
  std::atomic<int> a_seen{0}, a_foreign{0}, operator_seen{0};
  robot_a.on_pose([&](const PoseUpdate& p) { p.robot_id == "robot_a" ? ++a_seen : ++a_foreign; });
  operator_view.on_pose([&](const PoseUpdate&) { ++operator_seen; });
  ASSERT_TRUE(eventually([&] { return poses_a.matched() == 2 && poses_b.matched() == 1; }))
      << "robot_a's reader must match only robot_a's writer: a " << poses_a.matched() << ", b " << poses_b.matched();
  PoseEstimate estimate;
  estimate.header = {1'000, "map"};
  dds::write(poses_b, "robot_b", estimate, "feature_ekf", 0.1);
  dds::write(poses_a, "robot_a", estimate, "feature_ekf", 0.1);
  ASSERT_TRUE(eventually([&] { return a_seen.load() == 1 && operator_seen.load() == 2; }));
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(a_foreign.load(), 0);
}

locd_msg_SessionStatus make_status(const std::string& robot, uint64_t request_id, locd_msg_SessionState state,
                                   bool ok, const std::string& message) {
  locd_msg_SessionStatus s{};
  dds::copy_string(s.robot_id, robot);
  dds::copy_string(s.server_id, "fake_server");
  dds::copy_string(s.header.frame_id, "");
  dds::copy_string(s.plugin, "feature_ekf");
  dds::copy_string(s.message, message);
  dds::copy_string(s.last_error, "");
  s.state = state;
  s.request_id = request_id;
  s.request_ok = ok;
  s.received = 11;
  s.used = 10;
  s.dropped = 1;
  s.rejected = 2;
  s.updates = 9;
  s.last_update_ms = 0.5;
  return s;
}

TEST(ClientLibrary, RequestIsAnsweredOnlyByTheStatusWithItsRequestId) {
  dds::Participant server(kDomainRequests);
  const dds::Partitions all{topics::kAllRobotsPartition};
  const dds::Partitions robot{topics::robot_partition("robot_req")};
  dds::Reader<locd_msg_SessionRequest> requests(server, topics::kSessionRequest, dds::QosProfile::kState, nullptr, 8, all);
  dds::Writer<locd_msg_SessionStatus> statuses(server, topics::kSessionStatus, dds::QosProfile::kState, 8, robot);
  dds::Reader<locd_msg_MapSaveRequest> saves(server, topics::kMapSaveRequest, dds::QosProfile::kSensor, nullptr, 8, all);

  Client client({kDomainRequests, "robot_req", 8});
  ASSERT_TRUE(eventually([&] { return requests.matched() > 0 && statuses.matched() > 0; }));

  // A config near the 256 KiB bound travels whole.
  std::string yaml = "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n#";
  yaml.append(200'000, 'x');
  auto pending = std::async(std::launch::async, [&] { return client.request_session("feature_ekf", yaml, 10s); });
  const auto request = take_request(requests);
  EXPECT_EQ(request.robot_id, "robot_req");
  EXPECT_EQ(request.action, locd_msg_SESSION_START);
  EXPECT_EQ(request.plugin, "feature_ekf");
  EXPECT_EQ(request.config_yaml, yaml);
  EXPECT_NE(request.request_id, 0u);

  // None of these answers the request: another robot, a stale id, a "starting" without outcome.
  statuses.write(make_status("robot_other", request.request_id, locd_msg_STATE_RUNNING, true, "other robot"));
  statuses.write(make_status("robot_req", request.request_id + 1, locd_msg_STATE_ERROR, false, "stale"));
  statuses.write(make_status("robot_req", request.request_id, locd_msg_STATE_STARTING, false, "configuring"));
  EXPECT_EQ(pending.wait_for(300ms), std::future_status::timeout);
  statuses.write(make_status("robot_req", request.request_id, locd_msg_STATE_RUNNING, true, "started feature_ekf"));
  ASSERT_EQ(pending.wait_for(10s), std::future_status::ready);
  const auto answer = pending.get();
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->request_id, request.request_id);
  EXPECT_TRUE(answer->request_ok);
  EXPECT_EQ(answer->state, "running");
  EXPECT_EQ(answer->message, "started feature_ekf");
  EXPECT_EQ(answer->server_id, "fake_server");
  EXPECT_EQ(answer->plugin, "feature_ekf");
  EXPECT_EQ(answer->received, 11u);
  EXPECT_EQ(answer->used, 10u);
  EXPECT_EQ(answer->dropped, 1u);
  EXPECT_EQ(answer->rejected, 2u);
  EXPECT_EQ(answer->updates, 9u);
  EXPECT_EQ(answer->last_update_ms, 0.5);

  // A refused request comes back with request_ok false and the server's message.
  auto refused = std::async(std::launch::async, [&] { return client.request_session("nope", "plugin: nope\n", 10s); });
  const auto second = take_request(requests);
  EXPECT_NE(second.request_id, request.request_id);
  statuses.write(make_status("robot_req", second.request_id, locd_msg_STATE_RUNNING, false,
                             "unknown plugin 'nope'; known: feature_ekf"));
  const auto refusal = refused.get();
  ASSERT_TRUE(refusal.has_value());
  EXPECT_FALSE(refusal->request_ok);
  EXPECT_EQ(refusal->message, "unknown plugin 'nope'; known: feature_ekf");

  // Stop: action STOP, empty plugin and config.
  auto stopping = std::async(std::launch::async, [&] { return client.stop_session(10s); });
  const auto stop = take_request(requests);
  EXPECT_EQ(stop.action, locd_msg_SESSION_STOP);
  EXPECT_EQ(stop.plugin, "");
  EXPECT_EQ(stop.config_yaml, "");
  statuses.write(make_status("robot_req", stop.request_id, locd_msg_STATE_STOPPED, true, "session stopped"));
  const auto stopped = stopping.get();
  ASSERT_TRUE(stopped.has_value());
  EXPECT_EQ(stopped->state, "stopped");

  // A map save: the robot and a fresh id, no path; answered by the status carrying that id.
  auto saving = std::async(std::launch::async, [&] { return client.save_map(10s); });
  const auto save = take_one(saves);
  EXPECT_EQ(dds::to_string(save.robot_id), "robot_req");
  EXPECT_NE(save.request_id, stop.request_id);
  statuses.write(make_status("robot_req", save.request_id, locd_msg_STATE_RUNNING, true, "map saved to /srv/m.pcd"));
  const auto saved = saving.get();
  ASSERT_TRUE(saved.has_value());
  EXPECT_EQ(saved->message, "map saved to /srv/m.pcd");

  // Nobody answers: nullopt after the timeout.
  EXPECT_FALSE(client.request_session("feature_ekf", "plugin: feature_ekf\n", 200ms).has_value());
  // Too big for the wire: refused before sending, naming the bound.
  try {
    client.request_session("feature_ekf", std::string(262'145, 'x'), 1s);
    FAIL() << "an oversized config was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("at most 262144"), std::string::npos) << e.what();
  }
}

TEST(ClientLibrary, ServerInfoAndSessionStatesAreConvertedForLateJoiners) {
  dds::Participant server(kDomainServerInfo);
  dds::Writer<locd_msg_ServerInfo> info_writer(server, topics::kServerInfo, dds::QosProfile::kState);
  dds::Partitions robots;
  for (int i = 0; i < 10; ++i) robots.push_back(topics::robot_partition("robot_" + std::to_string(i)));
  dds::Writer<locd_msg_SessionStatus> status_writer(server, topics::kSessionStatus, dds::QosProfile::kState, 8, robots);

  EXPECT_THROW(Client({kDomainServerInfo, std::string(65, 'r'), 8}), std::invalid_argument);
  EXPECT_THROW(Client({kDomainServerInfo, "robot*", 8}), std::invalid_argument);  // would be a wildcard partition
  EXPECT_THROW(Client({kDomainServerInfo, "robot 1", 8}), std::invalid_argument);
  EXPECT_THROW(Client({kDomainServerInfo, "robot", 0}), std::invalid_argument);
  EXPECT_THROW(Client({233, "robot", 8}), std::invalid_argument);
  {
    Client early({kDomainServerInfo, "", 8});
    EXPECT_FALSE(early.wait_for_server(200ms));
    EXPECT_TRUE(early.servers().empty());
    EXPECT_THROW(early.publish(Odometry{}), std::logic_error);
    EXPECT_THROW(early.request_session("feature_ekf", "plugin: feature_ekf\n", 1ms), std::logic_error);
  }

  locd_msg_PluginInfo plugins[2]{};
  dds::copy_string(plugins[0].name, "feature_ekf");
  dds::copy_string(plugins[0].version, "0.1.0");
  dds::copy_string(plugins[0].description, "EKF on 2D laser features");
  char consumes[2][33]{};
  dds::copy_string(consumes[0], "odometry");
  dds::copy_string(consumes[1], "scan");
  plugins[0].consumed_kinds = {2, 2, consumes, false};
  dds::copy_string(plugins[1].name, "ceiling_pf");
  dds::copy_string(plugins[1].version, "0.2.0");
  dds::copy_string(plugins[1].description, "particle filter");
  char rejected[1][257]{};
  dds::copy_string(rejected[0], "/plugins/liblocd_broken.so: no entry point locd_plugin_descriptor");
  locd_msg_ServerInfo info{};
  dds::copy_string(info.server_id, "host-1234");
  info.started_ns = 5;
  info.plugins = {2, 2, plugins, false};
  info.rejected_plugins = {1, 1, rejected, false};
  info_writer.write(info);

  const std::pair<locd_msg_SessionState, const char*> states[] = {
      {locd_msg_STATE_STARTING, "starting"}, {locd_msg_STATE_RUNNING, "running"}, {locd_msg_STATE_STOPPED, "stopped"},
      {locd_msg_STATE_ERROR, "error"},       {locd_msg_STATE_NO_SESSION, "no_session"}};
  for (size_t i = 0; i < 5; ++i) {
    auto s = make_status("robot_" + std::to_string(i), 77, states[i].first, true, "m");
    dds::copy_string(s.last_error, "error " + std::to_string(i));
    s.header.stamp_ns = 1000 + static_cast<int64_t>(i);
    status_writer.write(s);
  }

  // Written before this client existed: transient-local delivers it on discovery.
  Client late({kDomainServerInfo, "", 8});
  ASSERT_TRUE(late.wait_for_server(10s));
  const auto servers = late.servers();
  ASSERT_EQ(servers.size(), 1u);
  EXPECT_EQ(servers[0].server_id, "host-1234");
  ASSERT_EQ(servers[0].plugins.size(), 2u);
  EXPECT_EQ(servers[0].plugins[0].name, "feature_ekf");
  EXPECT_EQ(servers[0].plugins[0].version, "0.1.0");
  EXPECT_EQ(servers[0].plugins[0].description, "EKF on 2D laser features");
  EXPECT_EQ(servers[0].plugins[0].consumes, (std::vector<std::string>{"odometry", "scan"}));
  EXPECT_TRUE(servers[0].plugins[1].consumes.empty());
  EXPECT_EQ(servers[0].rejected_plugins,
            std::vector<std::string>{"/plugins/liblocd_broken.so: no entry point locd_plugin_descriptor"});

  ASSERT_TRUE(eventually([&] { return late.statuses().size() == 5; }));
  for (const auto& s : late.statuses()) {
    const size_t i = static_cast<size_t>(std::stoul(s.robot_id.substr(6)));
    EXPECT_EQ(s.state, states[i].second) << s.robot_id;
    EXPECT_EQ(s.last_error, "error " + std::to_string(i));
    EXPECT_EQ(s.stamp_ns, 1000 + static_cast<int64_t>(i));
    EXPECT_EQ(s.request_id, 77u);
  }

  // A status published after registration reaches on_status, filtered by robot.
  std::atomic<int> seen{0};
  late.on_status([&](const SessionStatus& s) { if (s.state == "error") ++seen; }, "robot_9");
  status_writer.write(make_status("robot_8", 1, locd_msg_STATE_ERROR, false, "not for the filter"));
  status_writer.write(make_status("robot_9", 1, locd_msg_STATE_ERROR, false, "for the filter"));
  ASSERT_TRUE(eventually([&] { return late.statuses().size() == 7; }));
  EXPECT_EQ(seen.load(), 1);
}

}  // namespace
}  // namespace locd
