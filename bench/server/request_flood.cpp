// request_flood: one robot's identity asking the server for a session again and again, for
// measuring what that costs the other robots (bench/server/request_flood.sh). It writes session
// requests (start, a fresh id each) for robot --robot in its own partition, as that robot may,
// --rate a second (0: as fast as it can) for --seconds, and prints one JSON line.
// With --robots K > 1 it names robots <robot>_0 .. <robot>_(K-1) in turn, from one writer in all
// their partitions (as a fleet generator or an operator's identity may).
//   request_flood --domain N --robot flooder --rate 10000 --seconds 20 [--robots 1]
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "locd/dds/convert.hpp"
#include "locd/dds/dds.hpp"
#include "locd/dds/topics.hpp"

using namespace locd;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  uint32_t domain = 0;
  std::string robot = "flooder";
  double rate = 10000, seconds = 20;
  int robots = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--domain") domain = static_cast<uint32_t>(std::atoi(argv[i + 1]));
    else if (a == "--robot") robot = argv[i + 1];
    else if (a == "--rate") rate = std::atof(argv[i + 1]);
    else if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    else if (a == "--robots") robots = std::max(1, std::atoi(argv[i + 1]));
    else { std::cerr << "unknown option " << a << "\n"; return 2; }
  }
  dds::Participant participant(domain);
  std::vector<std::string> ids;
  dds::Partitions partitions;
  for (int r = 0; r < robots; ++r) {
    ids.push_back(robots == 1 ? robot : robot + "_" + std::to_string(r));
    partitions.push_back(topics::robot_partition(ids.back()));
  }
  dds::Writer<locd_msg_SessionRequest> requests(participant, topics::kSessionRequest, dds::QosProfile::kState, 8,
                                                partitions);
  const auto matched_by = Clock::now() + std::chrono::seconds(10);
  while (requests.matched() == 0 && Clock::now() < matched_by) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  dds::copy_string(request->robot_id, robot);
  const std::string config = "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n";
  dds::borrow_text(request->config_yaml, config, topics::kMaxConfigYamlBytes);
  request->action = locd_msg_SESSION_START;
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  uint64_t written = 0;
  for (auto now = start; now < end; now = Clock::now()) {
    if (rate > 0) {
      const auto due = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(written / rate));
      if (due > now) std::this_thread::sleep_until(due);
    }
    dds::copy_string(request->robot_id, ids[written % ids.size()]);
    request->request_id = ++written;
    requests.write(*request);
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::cout << "{\"written\":" << written << ",\"seconds\":" << elapsed << ",\"per_s\":" << written / elapsed << "}\n";
  return 0;
}
