// fleet_generator: the DDS traffic of N localized robots, for measuring locctl record and locview
// under a fleet. Each robot, in its own partition robot.fleet_<i>, publishes odometry at 50 Hz, a
// 361-beam scan at 25 Hz, and (standing in for locd) a pose and diagnostics with 200 particles at
// 25 Hz, all times --rate. It prints what it published as one JSON line.
//   fleet_generator --domain N --robots 100 --seconds 20 [--rate 1]
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "locd/dds/convert.hpp"
#include "locd/dds/dds.hpp"

using namespace locd;

int main(int argc, char** argv) {
  uint32_t domain = 0;
  int robots = 100;
  double seconds = 20, rate = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--domain") domain = static_cast<uint32_t>(std::atoi(argv[i + 1]));
    else if (a == "--robots") robots = std::atoi(argv[i + 1]);
    else if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    else if (a == "--rate") rate = std::atof(argv[i + 1]);
    else { std::cerr << "unknown option " << a << "\n"; return 2; }
  }
  dds::Participant participant(domain);
  struct Robot {
    std::string id;
    dds::Writer<locd_msg_Odometry> odometry;
    dds::Writer<locd_msg_LaserScan> scan;
    dds::Writer<locd_msg_PoseEstimate> pose;
    dds::Writer<locd_msg_Diagnostics> diagnostics;
  };
  std::vector<Robot> fleet;
  for (int r = 0; r < robots; ++r) {
    const std::string id = "fleet_" + std::to_string(r);
    const dds::Partitions p = {topics::robot_partition(id)};
    fleet.push_back({id, dds::Writer<locd_msg_Odometry>(participant, topics::kOdometry, dds::QosProfile::kSensor, 8, p),
                     dds::Writer<locd_msg_LaserScan>(participant, topics::kScan, dds::QosProfile::kSensor, 8, p),
                     dds::Writer<locd_msg_PoseEstimate>(participant, topics::kPose, dds::QosProfile::kPose, 8, p),
                     dds::Writer<locd_msg_Diagnostics>(participant, topics::kDiagnostics, dds::QosProfile::kOutput, 8, p)});
  }
  std::this_thread::sleep_for(std::chrono::seconds(2));  // discovery
  LaserScan scan;
  scan.header.frame_id = "laser";
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 360;
  scan.range_min = 0.1f;
  scan.range_max = 30.0f;
  scan.ranges.assign(361, 5.0f);
  Diagnostics diagnostics;
  diagnostics.values = {{"neff", 150.0}, {"associations", 12.0}};
  diagnostics.particles.resize(200);
  uint64_t messages = 0, bytes = 0;
  const auto start = std::chrono::steady_clock::now();
  const double tick = 0.02 / rate;  // 50 Hz at rate 1
  for (long k = 0;; ++k) {
    const double t = k * 0.02;
    if (k * tick >= seconds) break;
    std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                              std::chrono::duration<double>(k * tick)));
    const int64_t stamp = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::system_clock::now().time_since_epoch()).count();
    for (int r = 0; r < robots; ++r) {
      Robot& robot = fleet[r];
      const double x = r + 0.5 * t, y = std::sin(0.2 * t + r);
      Odometry odometry;
      odometry.header = {stamp, "odom"};
      odometry.pose = Eigen::Isometry3d(Eigen::Translation3d(x, y, 0));
      dds::write(robot.odometry, robot.id, odometry);
      ++messages;
      bytes += 200;
      if (k % 2) continue;  // 25 Hz
      scan.header.stamp_ns = stamp;
      dds::write(robot.scan, robot.id, scan);
      PoseEstimate pose;
      pose.header = {stamp, "map"};
      pose.pose = odometry.pose;
      pose.covariance = Matrix6d::Identity() * 0.01;
      dds::write(robot.pose, robot.id, pose, "generator", 0.1);
      for (size_t i = 0; i < diagnostics.particles.size(); ++i) {
        diagnostics.particles[i] = {x + 0.01 * (i % 20), y + 0.01 * (i / 20), 0.0, 1.0 / 200};
      }
      dds::write(robot.diagnostics, robot.id, {stamp, "map"}, "generator", diagnostics);
      messages += 3;
      bytes += 1560 + 420 + 6500;
    }
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "{\"robots\":" << robots << ",\"seconds\":" << elapsed << ",\"messages\":" << messages
            << ",\"messages_per_s\":" << messages / elapsed << ",\"approx_mb_per_s\":" << bytes / elapsed / 1e6 << "}"
            << std::endl;
  return 0;
}
