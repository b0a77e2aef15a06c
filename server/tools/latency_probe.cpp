// locd_latency_probe DOMAIN COUNT [PERIOD_MS]: asks a running locd for the fixture_odometry
// plugin (tests/broken_plugins; its compute time is a few microseconds), publishes COUNT odometry
// messages PERIOD_MS apart, and prints the time from publishing to receiving the pose over DDS:
// p50/p99 end to end, and the part above the plugin's own compute time (PoseEstimate.update_ms).
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
    std::fprintf(stderr, "usage: locd_latency_probe DOMAIN COUNT [PERIOD_MS]\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const int count = std::max(1, std::atoi(argv[2]));
  const int period_ms = argc > 3 ? std::atoi(argv[3]) : 5;
  const std::string robot = "latency_probe";

  locd::dds::Participant participant(domain);
  const locd::dds::Partitions own{locd::topics::robot_partition(robot)};
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest,
                                                      locd::dds::QosProfile::kState, 8, own);
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, locd::dds::QosProfile::kSensor, 8,
                                                own);
  std::mutex mutex;
  std::vector<int64_t> sent_ns(static_cast<size_t>(count) + 1, 0);
  std::vector<double> end_to_end_us, above_plugin_us;
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
  while (requests.matched() == 0 || odometry.matched() == 0 || poses.matched() == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "no locd on domain %d\n", domain);
      return 1;
    }
    std::this_thread::sleep_for(10ms);
  }
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, robot);
  request->request_id = static_cast<uint64_t>(steady_ns());
  locd::dds::copy_string(request->config_yaml, "plugin: fixture_odometry\n");
  requests.write(*request);
  std::this_thread::sleep_for(500ms);

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
  std::printf("poses %zu/%d  end to end: p50 %.0f us, p99 %.0f us  above plugin compute: p50 %.0f us, p99 %.0f us\n",
              end_to_end_us.size(), count, percentile(end_to_end_us, 0.5), percentile(end_to_end_us, 0.99),
              percentile(above_plugin_us, 0.5), percentile(above_plugin_us, 0.99));
  return 0;
}
