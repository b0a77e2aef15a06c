// `locsim replay IN.mcap`: a recording (locctl record, locsim run --mcap) fed again.
//  - into a running locd over DDS: the robots' own messages (sensors, session requests, initial
//    poses, map-save requests) are written in their partitions in recorded order, paced by
//    their recorded times; like the robot did live, each session request and initial pose waits
//    for the server's answer before the sensors that follow it;
//  - offline (--offline): straight through the plugin each recorded session request names, as
//    the server would run it, no DDS.
// Either way the poses it gets are compared, stamp by stamp, with the poses in the recording.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locd::sim {

struct ReplayOptions {
  std::string file;
  bool offline = false;
  std::optional<double> rate;  // multiple of real time; 0 = as fast as possible. Default: DDS 1, offline 0
  uint32_t domain_id = 0;
  double server_timeout_s = 10.0;
  std::vector<std::string> robots;  // only these robots (default every robot in the file)
  std::vector<std::filesystem::path> plugin_directories;  // offline
  std::vector<std::filesystem::path> map_directories;     // offline
  bool json = false;
};

// The process exit code: 0 replayed, 1 failed (file, plugin, no pose), 2 no server.
int run_replay(const ReplayOptions& options);

}  // namespace locd::sim
