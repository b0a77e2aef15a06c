// locd_latency_probe DOMAIN COUNT [PERIOD_MS [ROBOT]]: asks a running locd for the fixture_odometry
// plugin (tests/broken_plugins; its compute time is a few microseconds), publishes COUNT odometry
// messages PERIOD_MS apart as robot ROBOT (default latency_probe), and prints the time from
// publishing to receiving the pose over DDS: p50/p99 end to end, and the part above the plugin's
// own compute time (PoseEstimate.update_ms). Also how long the robot took to join (participant
// created until the server matched its writers and readers: discovery, and with DDS Security the
// handshake) and to start its session (request written until the status says running).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"

namespace {

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double percentile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * static_cast<double>(values.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  using namespace std::chrono_literals;
  if (argc < 3) {
    std::fprintf(stderr, "usage: locd_latency_probe DOMAIN COUNT [PERIOD_MS [ROBOT]]\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const int count = std::max(1, std::atoi(argv[2]));
  const int period_ms = argc > 3 ? std::atoi(argv[3]) : 5;
  const std::string robot = argc > 4 ? argv[4] : "latency_probe";

  const int64_t joining_ns = steady_ns();
  locd::dds::Participant participant(domain);
  const locd::dds::Partitions own{locd::topics::robot_partition(robot)};
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest,
                                                      locd::dds::QosProfile::kState, 8, own);
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, locd::dds::QosProfile::kSensor, 8,
                                                own);
  std::mutex mutex;
  std::vector<int64_t> sent_ns(static_cast<size_t>(count) + 1, 0);
  std::vector<double> end_to_end_us, above_plugin_us;
  int64_t running_ns = 0;  // when the status first said running
  locd::dds::Reader<locd_msg_SessionStatus> statuses(
      participant, locd::topics::kSessionStatus, locd::dds::QosProfile::kState, [&](const locd_msg_SessionStatus& s) {
        std::lock_guard<std::mutex> lock(mutex);
        if (running_ns == 0 && s.state == locd_msg_STATE_RUNNING) running_ns = steady_ns();
      },
      8, own);
  locd::dds::Reader<locd_msg_PoseEstimate> poses(
      participant, locd::topics::kPose, locd::dds::QosProfile::kPose, [&](const locd_msg_PoseEstimate& pose) {
        const int64_t now = steady_ns();
        std::lock_guard<std::mutex> lock(mutex);
        const int64_t k = pose.header.stamp_ns;
        if (locd::dds::to_string(pose.robot_id) != robot || k < 1 || k > count || sent_ns[k] == 0) return;
        const double total = static_cast<double>(now - sent_ns[k]) / 1e3;
        end_to_end_us.push_back(total);
        above_plugin_us.push_back(total - pose.update_ms * 1e3);
      },
      8, own);
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (requests.matched() == 0 || odometry.matched() == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "no locd on domain %d\n", domain);
      return 1;
    }
    std::this_thread::sleep_for(10ms);
  }
  const double join_ms = static_cast<double>(steady_ns() - joining_ns) / 1e6;
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, robot);
  request->request_id = static_cast<uint64_t>(steady_ns());
  const std::string config = "plugin: fixture_odometry\n";
  locd::dds::borrow_text(request->config_yaml, config, locd::topics::kMaxConfigYamlBytes);
  const int64_t requested_ns = steady_ns();
  requests.write(*request);
  // The session runs, and the server's pose writer for this robot (made with the session) matched.
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (running_ns != 0 && poses.matched() > 0) break;
    }
    if (std::chrono::steady_clock::now() > deadline + 20s) {
      std::fprintf(stderr, "the session for %s did not start\n", robot.c_str());
      return 1;
    }
    std::this_thread::sleep_for(1ms);
  }
  const double session_ms = static_cast<double>(running_ns - requested_ns) / 1e6;
  std::this_thread::sleep_for(200ms);

  for (int k = 1; k <= count; ++k) {
    locd::Odometry o;
    o.header = {k, "odom"};
    o.pose.translation().x() = 0.001 * k;
    {
      std::lock_guard<std::mutex> lock(mutex);
      sent_ns[k] = steady_ns();
    }
    locd::dds::write(odometry, robot, o);
    std::this_thread::sleep_for(std::chrono::milliseconds(period_ms));
  }
  std::this_thread::sleep_for(500ms);
  std::lock_guard<std::mutex> lock(mutex);
  if (end_to_end_us.empty()) {
    std::fprintf(stderr, "no pose received (is fixture_odometry in the server's plugin directories?)\n");
    return 1;
  }
  std::printf("poses %zu/%d  end to end: p50 %.0f us, p99 %.0f us  above plugin compute: p50 %.0f us, p99 %.0f us  "
              "join %.1f ms  session start %.1f ms\n",
              end_to_end_us.size(), count, percentile(end_to_end_us, 0.5), percentile(end_to_end_us, 0.99),
              percentile(above_plugin_us, 0.5), percentile(above_plugin_us, 0.99), join_ms, session_ms);
  return 0;
}
