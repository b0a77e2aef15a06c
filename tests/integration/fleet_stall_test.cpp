// Two servers, one robot, on one host (loopback, domain 228; 230 for the DDS property below): the server that serves the robot is
// stopped for 3 s (SIGSTOP, a stall) while the robot drives on, then resumes. The other server
// takes the robot over meanwhile; the stalled one, resumed, still holds the messages of the
// stall and works through them, and must not reach the robot: a robot gets at most one pose per
// stamp, whichever servers wrote one (README "Many servers": exclusive ownership at the claim's
// strength, and the stalled server withholding its outputs until it has heard the fleet again).
// In the end exactly one server serves the robot, the one that took it over.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "eventually.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

using namespace std::chrono_literals;
using locd::test::RobotSide;
using locd::test::TestServer;
using locd::test::TestServerOptions;

constexpr int kDomain = 228;
constexpr int64_t kPeriodNs = 50'000'000;  // 20 Hz odometry

TestServerOptions options() {
  TestServerOptions o;
  o.extra_plugin_directory = LOCD_BROKEN_PLUGIN_DIR;
  return o;
}

// Every pose that reaches the robot, kept (a history deep enough for the whole test, taken at the
// end): a keep-last-1 reader with a listener could let a burst of poses overwrite each other
// before it saw them, and so hide a duplicate.
class EveryPose {
 public:
  EveryPose(const locd::dds::Participant& p, const locd::dds::Partitions& partitions) {
    topic_ = locd::dds::Entity(locd::dds::create_topic(p, locd_msg_PoseEstimate_desc, locd::topics::kPose));
    subscriber_ = locd::dds::subscriber_for(p, partitions);
    auto qos = locd::dds::make_qos(locd::dds::QosProfile::kPose);
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 100000);
    dds_qset_resource_limits(qos.get(), DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
    reader_ = locd::dds::Entity(
        locd::dds::check(dds_create_reader(subscriber_.handle(), topic_.handle(), qos.get(), nullptr), "every pose"));
  }
  // Stamps of all poses received so far, in arrival order.
  std::vector<int64_t> take() {
    std::vector<int64_t> stamps;
    void* samples[256] = {};
    dds_sample_info_t infos[256];
    for (;;) {
      const dds_return_t n = dds_take(reader_.handle(), samples, infos, 256, 256);
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        if (infos[i].valid_data) stamps.push_back(static_cast<const locd_msg_PoseEstimate*>(samples[i])->header.stamp_ns);
      }
      dds_return_loan(reader_.handle(), samples, n);
    }
    return stamps;
  }
  uint32_t matched() const {
    dds_subscription_matched_status_t status{};
    dds_get_subscription_matched_status(reader_.handle(), &status);
    return status.current_count;
  }

 private:
  locd::dds::Entity topic_, subscriber_, reader_;
};

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// What the fleet relies on, checked against this machine's Cyclone DDS (domain 230): a reader of
// locd/pose takes each robot's poses from its strongest live writer only; a weaker writer's
// samples are dropped while the stronger lives, also while it is silent; once the stronger writer
// is deleted (a server hands the robot over), the weaker one's reach the reader again.
TEST(ExclusiveOwnership, AReaderTakesARobotsPosesFromItsStrongestLiveWriterOnly) {
  constexpr int kOwnershipDomain = 230;
  const locd::dds::Partitions partition{locd::topics::robot_partition("robot_own")};
  locd::dds::Participant robot(kOwnershipDomain), server(kOwnershipDomain);
  std::mutex mutex;
  std::vector<int64_t> stamps;
  locd::dds::Reader<locd_msg_PoseEstimate> poses(
      robot, locd::topics::kPose, locd::dds::QosProfile::kPose,
      [&](const locd_msg_PoseEstimate& m) {
        std::lock_guard<std::mutex> lock(mutex);
        stamps.push_back(m.header.stamp_ns);
      },
      8, partition);
  auto weak = std::make_unique<locd::dds::Writer<locd_msg_PoseEstimate>>(server, locd::topics::kPose,
                                                                         locd::dds::QosProfile::kPose, 8, partition, 100);
  auto strong = std::make_unique<locd::dds::Writer<locd_msg_PoseEstimate>>(
      server, locd::topics::kPose, locd::dds::QosProfile::kPose, 8, partition, 200);
  ASSERT_TRUE(locd::test::eventually([&] { return weak->matched() == 1 && strong->matched() == 1; }));
  auto write = [](const locd::dds::Writer<locd_msg_PoseEstimate>& w, int64_t stamp) {
    locd::PoseEstimate p;
    p.header = {stamp, "map"};
    locd::dds::write(w, "robot_own", p, "test", 0.0);
  };
  auto received = [&](size_t n) {
    return locd::test::eventually([&] {
      std::lock_guard<std::mutex> lock(mutex);
      return stamps.size() >= n;
    });
  };
  write(*weak, 1);  // the only writer so far: taken
  ASSERT_TRUE(received(1));
  write(*strong, 2);  // stronger: taken, and owns the robot's poses from now on
  ASSERT_TRUE(received(2));
  write(*weak, 3);  // weaker, the stronger alive (and silent): dropped
  write(*weak, 4);
  write(*strong, 5);
  ASSERT_TRUE(received(3));
  strong.reset();  // the stronger writer goes: the weaker one's poses are taken again
  ASSERT_TRUE(locd::test::eventually([&] {
    write(*weak, 6);
    std::this_thread::sleep_for(20ms);
    std::lock_guard<std::mutex> lock(mutex);
    return !stamps.empty() && stamps.back() == 6;
  }));
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(std::vector<int64_t>(stamps.begin(), stamps.begin() + 3), (std::vector<int64_t>{1, 2, 5}));
  for (const int64_t stamp : stamps) EXPECT_TRUE(stamp != 3 && stamp != 4) << "a weaker writer's pose got through";
}

TEST(FleetStall, AServerStalledForThreeSecondsNeverSendsAPoseTwice) {
  TestServer a("locd_stall_a", kDomain, options());
  TestServer b("locd_stall_b", kDomain, options());
  ASSERT_TRUE(locd::test::eventually([&] {
    return count(a.process().output(), "joined the fleet") >= 1 && count(b.process().output(), "joined the fleet") >= 1;
  })) << "the servers did not see each other:\n"
      << a.process().output() << b.process().output();

  RobotSide robot(kDomain, "robot_stall", a.process());
  locd::dds::Writer<locd_msg_Odometry> odometry(robot.participant(), locd::topics::kOdometry,
                                                locd::dds::QosProfile::kSensor, 64, robot.partition());
  EveryPose every_pose(robot.participant(), robot.partition());
  ASSERT_TRUE(robot.wait_matched(odometry));
  ASSERT_TRUE(robot.start("", "plugin: fixture_odometry\n"));
  const std::string id_a = "locd_stall_a-" + std::to_string(kDomain), id_b = "locd_stall_b-" + std::to_string(kDomain);
  const bool a_serves = robot.status_now().server_id == id_a;
  TestServer& stalled = a_serves ? a : b;
  TestServer& other = a_serves ? b : a;
  robot.set_server(other.process());

  int k = 0;
  auto drive_for = [&](std::chrono::milliseconds how_long) {
    const auto end = std::chrono::steady_clock::now() + how_long;
    while (std::chrono::steady_clock::now() < end) {
      locd::Odometry o;
      o.header = {++k * kPeriodNs, "odom"};
      o.pose.translation() = Eigen::Vector3d(0.01 * k, 0.0, 0.0);
      locd::dds::write(odometry, robot.robot_id(), o);
      std::this_thread::sleep_for(std::chrono::nanoseconds(kPeriodNs));
    }
  };
  drive_for(1s);
  stalled.process().signal(SIGSTOP);
  drive_for(3s);
  stalled.process().signal(SIGCONT);
  drive_for(3s);
  const int last = k;
  ASSERT_TRUE(robot.wait_pose(last * kPeriodNs)) << "the robot is not served after the stall";
  // The stalled server hands the robot over.
  ASSERT_TRUE(locd::test::eventually([&] {
    return stalled.process().output().find("handed over") != std::string::npos;
  })) << stalled.process().output();
  std::this_thread::sleep_for(1s);  // anything still in flight from either server arrives

  std::map<int64_t, int> poses_per_stamp;
  for (const int64_t stamp : every_pose.take()) ++poses_per_stamp[stamp];
  int duplicates = 0;
  for (const auto& [stamp, n] : poses_per_stamp) duplicates += n - 1;
  std::cout << "poses received " << poses_per_stamp.size() << " stamps of " << last << ", duplicates " << duplicates
            << "\n";
  EXPECT_EQ(duplicates, 0);
  EXPECT_EQ(robot.status_now().server_id, a_serves ? id_b : id_a);
  EXPECT_EQ(robot.status_now().state, "running");
}

}  // namespace
