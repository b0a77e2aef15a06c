// `locsim replay IN.mcap`: a recording (locctl record, locsim run --mcap) fed again.
//  - into a running locd over DDS: the robots' own messages (sensors, session requests, initial
//    poses, map-save requests) are written in their partitions in recorded order, paced by
//    their recorded times; like the robot did live, each session request and initial pose waits
//    for the server's answer before the sensors that follow it;
//  - offline (--offline): straight through the plugin each recorded session request names, as
//    the server would run it, no DDS.
// Either way the poses it gets are compared, stamp by stamp, with the poses in the recording.
//
// `locsim replay BAG.mcap --config ROBOT.yaml`: a ROS 2 bag (ros2 bag record -s mcap, read by
// ros2_bag.hpp) fed the same two ways. The bag holds no session: --config is the plugin config
// (as a robot would send it, optionally with a ros2: section mapping the topics), sent as the
// session request of robot --robot (default robot1); --initial-pose gives a start. The whole bag
// (and the reference) is checked before anything is sent. With --reference (TUM), the poses are
// scored against it (APE, reference_trajectory.hpp).
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
  // A ROS 2 bag (config_file set).
  std::string config_file;                   // plugin config YAML: plugin, params, optional ros2
  std::string topics_file;                   // a YAML whose ros2: section maps the topics
  std::vector<std::string> topic_overrides;  // KEY=NAME (KEY of kBagTopicKeys; NAME "none" drops it)
  std::string base_frame;                    // overrides ros2.base_frame
  std::string initial_pose;                  // "X,Y,YAW" or "reference"; empty: none (global localization)
  std::string initial_offset;                // "DX,DY,DYAW" in the robot's frame, added to --initial-pose reference
  std::string reference_file;                // TUM
};

// The process exit code: 0 replayed, 1 failed (file, plugin, no pose), 2 no server.
int run_replay(const ReplayOptions& options);

}  // namespace locd::sim
