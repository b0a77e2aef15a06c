// locsim's icp_explorer scenario (`kind: icp_explorer_exploration`, config/scenarios/four_rooms.yaml):
// a robot in an indoor box world stops, scans with the 3D scanner, sends odometry (off by up to
// the configured bounds per leg) and the cloud to the localizer, and drives to the exploration
// goal the localizer returns, until the localizer says done, the target coverage is reached or
// max_scans. Offline (`locsim run`): the real plugin loaded from the plugin directories, no DDS.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sim/consistency.hpp"
#include "locd/sim_icp_explorer/indoor_world.hpp"
#include "locd/sim_icp_explorer/scanner3d.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_odometry.hpp"

namespace locd::sim {

struct ExplorationScenario {
  std::filesystem::path file;
  std::string name;
  uint64_t seed = 1;
  std::string robot_id = "explorer";
  std::filesystem::path world_file;
  Pose2 start;
  Scanner3DConfig scanner;
  StopAndScanOdometryConfig odometry;
  int max_scans = 40;
  double target_coverage = 0.95;
  double coverage_voxel = 0.2;       // m
  double coverage_grid = 0.5;        // m, reference scan positions (every other one scanned)
  double robot_radius = 0.3;         // m
  std::string localizer_config;      // plugin config text (plugin + params)
  std::filesystem::path localizer_config_file;
};

bool is_exploration_scenario(const std::filesystem::path& file);
ExplorationScenario load_exploration_scenario(const std::filesystem::path& file);

struct ExplorationScanRecord {
  Pose2 truth;
  double error_m = 0.0, error_deg = 0.0;
  std::optional<Nees> nees;  // planar (x, y, yaw) against the reported covariance, when estimated
  LocalizationState state = LocalizationState::kUnknown;  // the plugin's last judgement
  double update_ms = 0.0;
  double coverage = 0.0;
  bool done = false;
};

struct ExplorationMissionResult {
  std::vector<ExplorationScanRecord> scans;
  int scans_to_target = -1;
  double coverage = 0.0;
  double path_length = 0.0;
  bool done = false;
  size_t reference_voxels = 0;
};

// Runs the mission with `localizer` (configured by the caller): scan, odometry, update, drive
// to the goal; coverage and registration error are measured against the truth.
ExplorationMissionResult run_exploration_mission(const ExplorationScenario& scenario, uint64_t seed,
                                                 Localizer& localizer);

void write_exploration_json(std::ostream& out, const ExplorationScenario& scenario, const ExplorationMissionResult& r);
void write_exploration_summary(std::ostream& out, const ExplorationScenario& scenario, const ExplorationMissionResult& r);

// locsim's hook for `locsim run`: loads the plugin named in the localizer config from the plugin
// directories, runs the mission and prints the result. Returns the process exit code.
int locsim_run_exploration(const std::filesystem::path& file, const std::vector<std::filesystem::path>& plugin_directories,
                           std::optional<uint64_t> seed, bool json, std::ostream& out);

}  // namespace locd::sim
