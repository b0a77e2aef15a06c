// A DDS participant that tries to steer or feed a robot, for the security tests: it joins the
// domain with whatever CYCLONEDDS_URI (and so whatever identity) it is given, publishes in the
// partition robot.<PARTITION_ROBOT> samples naming robot SAMPLE_ROBOT, and keeps writing for a
// while whether or not anyone listens, as an intruder would.
//
//   security_peer DOMAIN PARTITION_ROBOT SAMPLE_ROBOT initial-pose|stop|odometry SECONDS
//
// Prints "matched N" (the most readers its writer ever matched: the server's, if it accepted this
// participant) and exits 0; exits 3 when DDS Security refused the writer, 4 when it refused the
// participant itself (its own certificate or permissions), 2 on wrong usage.
#include <chrono>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include "locd/dds/convert.hpp"
#include "locd/dds/dds.hpp"
#include "locd/dds/topics.hpp"

namespace {

using namespace locd;
using Clock = std::chrono::steady_clock;

template <typename T>
int keep_writing(const dds::Participant& participant, const char* topic, dds::QosProfile profile,
                 const dds::Partitions& partitions, double seconds, const T& sample) {
  std::unique_ptr<dds::Writer<T>> writer;
  try {
    writer = std::make_unique<dds::Writer<T>>(participant, topic, profile, 8, partitions);
  } catch (const dds::Error& e) {
    std::cout << "refused: " << e.what() << std::endl;
    return dds::refused_by_security(e) ? 3 : 1;
  }
  uint32_t most = 0;
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    writer->write(sample);
    most = std::max(most, writer->matched());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::cout << "matched " << most << std::endl;
  return 0;
}

int run(int argc, char** argv) {
  if (argc != 6) {
    std::cerr << "usage: security_peer DOMAIN PARTITION_ROBOT SAMPLE_ROBOT initial-pose|stop|odometry SECONDS\n";
    return 2;
  }
  const auto domain = static_cast<dds_domainid_t>(std::stoul(argv[1]));
  const dds::Partitions partitions{topics::robot_partition(argv[2])};
  const std::string robot = argv[3];
  const std::string action = argv[4];
  const double seconds = std::stod(argv[5]);
  std::unique_ptr<dds::Participant> participant;
  try {
    participant = std::make_unique<dds::Participant>(domain);
  } catch (const dds::Error& e) {
    std::cout << "participant refused: " << e.what() << std::endl;
    return 4;
  }
  const int64_t stamp = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch()).count();
  if (action == "initial-pose") {
    // The pose of the report: 30 m away from where the robot is.
    locd_msg_InitialPose pose;
    std::memset(&pose, 0, sizeof pose);
    dds::copy_string(pose.robot_id, robot);
    dds::to_wire(Header{stamp, "map"}, pose.header);
    dds::to_wire(Eigen::Isometry3d(Eigen::Translation3d(30.0, 15.0, 0.0)), pose.pose);
    for (int i = 0; i < 6; ++i) pose.covariance[i * 7] = 0.01;
    return keep_writing(*participant, topics::kInitialPose, dds::QosProfile::kState, partitions, seconds, pose);
  }
  if (action == "stop") {
    auto request = std::make_unique<locd_msg_SessionRequest>();
    std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
    dds::copy_string(request->robot_id, robot);
    request->request_id = 777;
    request->action = locd_msg_SESSION_STOP;
    return keep_writing(*participant, topics::kSessionRequest, dds::QosProfile::kState, partitions, seconds, *request);
  }
  if (action == "odometry") {
    locd_msg_Odometry odometry;
    std::memset(&odometry, 0, sizeof odometry);
    dds::copy_string(odometry.robot_id, robot);
    dds::to_wire(Header{stamp, "odom"}, odometry.header);
    dds::to_wire(Eigen::Isometry3d(Eigen::Translation3d(30.0, 15.0, 0.0)), odometry.pose);
    return keep_writing(*participant, topics::kOdometry, dds::QosProfile::kSensor, partitions, seconds, odometry);
  }
  std::cerr << "unknown action '" << action << "'; allowed: initial-pose, stop, odometry\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cout << "error: " << e.what() << std::endl;
    return 1;
  }
}
