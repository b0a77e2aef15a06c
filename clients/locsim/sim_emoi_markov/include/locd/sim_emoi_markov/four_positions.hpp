// The paper's four-position experiment (section VI, Fig. 14-15), replicated: a robot with a
// tilting laser drives through a synthetic world; emoi_markov localizes it globally (uniform
// initial belief) and after each sensor update the belief's maximum is compared with the truth.
// Parsed from config/scenarios/emoi_four_positions.yaml; runs in-process (no DDS).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "locd/emoi_markov/emoi_markov_filter.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sim/consistency.hpp"
#include "locd/sim_emoi_markov/synthetic_dsm.hpp"
#include "locd/sim_emoi_markov/terrain_robot.hpp"
#include "locd/sim_emoi_markov/tilting_laser.hpp"

namespace locd::sim::emoi {

// A new path per seed instead of the fixed one (`robot.random_path`): `legs` straight legs of
// `leg_m`, the first in a random direction from a random start, each next one turned by a random
// angle in [-max_turn, max_turn]; every waypoint at least `margin_m` inside the world.
struct RandomPathConfig {
  int legs = 0;                 // 0: off, the scenario's fixed path
  double leg_m = 15.0;
  double max_turn_rad = M_PI / 2;
  double margin_m = 30.0;
};

struct FourPositionsScenario {
  std::string name;
  uint64_t seed = 1;
  int runs = 20;
  SyntheticDsmConfig world;
  double dsm_noise_m = 0.05;
  double dsm_nodata_fraction = 0.0;
  std::string robot_id = "robot1";
  std::vector<Eigen::Vector2d> path;   // start, then the way through positions 1..4
  RandomPathConfig random_path;        // when on, replaces `path` by a path drawn per seed
  double speed_mps = 1.0;
  double base_height_m = 0.4;
  TiltingLaserConfig laser;
  double odometry_rate_hz = 20.0;
  OdometryErrorConfig odometry;
  double imu_rate_hz = 20.0;
  ImuConfig imu;
  std::filesystem::path localizer_config_file;
  std::string localizer_config_text;
  int updates = 4;
  double success_radius_m = 1.0;
};

FourPositionsScenario load_four_positions(const std::filesystem::path& file);

struct UpdateRecord {
  int update = 0;
  double time_s = 0.0;
  Eigen::Vector2d truth = Eigen::Vector2d::Zero();
  Eigen::Vector2d mode = Eigen::Vector2d::Zero();
  double error_m = 0.0;
  std::vector<double> coverage;
  std::vector<double> robot_emoi;     // per radius, from the local map
  std::vector<double> dsm_emoi;       // per radius, the DSM layer at the true position
  // The plugin's own judgement (UpdateResult::localization) and its criteria.
  LocalizationState state = LocalizationState::kUnknown;
  std::string reason;
  double peak_mass = 0.0;             // belief within the tracking radius of the estimate
  int modes = 0;
  double area_m2 = 0.0;               // exp(entropy) * cell area
  double fit_rms_m = -1.0;            // the local map against the DSM at the estimate (-1: not computed)
  // Consistency: the error against the reported covariance.
  double nees_position = 0.0;         // e^T P^-1 e over (x, y)
  double nees_heading = 0.0;
  double truth_mass = -1.0;           // belief within success_radius_m of the truth (in-process runs only)
  double cell_maximum_error_m = -1.0; // error of the belief grid's most probable cell (in-process runs only)
  double nees_main_mode = -1.0;       // against the heaviest mode's covariance (in-process runs only)
};

// Every pose after the first sensor update (odometry poses between updates included): NEES of
// position (2 dof) and heading (1 dof) against the reported covariance. "Confidently wrong":
// outside the 99 % ellipse while the plugin's last state was tracking (or unknown): nothing
// warned the user.
struct PoseConsistency {
  size_t poses = 0;
  double nees_position_sum = 0.0, nees_heading_sum = 0.0;
  size_t outside_99_position = 0;     // NEES above the chi-square 99 % point (2 dof: 9.21)
  size_t outside_99_heading = 0;      // (1 dof: 6.63)
  size_t confidently_wrong = 0;       // outside_99_position while tracking or unknown
  size_t tracking = 0;                // poses while the state was tracking
  double nees_position_tracking_sum = 0.0;  // over those
  std::vector<sim::ConsistencySample> samples;  // every pose, for the shared summary (locd/sim/consistency.hpp)
};

struct RunResult {
  uint64_t seed = 0;
  std::vector<UpdateRecord> updates;
  bool success = false;          // maximum within success_radius_m after the last counted update
  double layers_seconds = 0.0;   // EMOI precompute (or cache read)
  double mean_update_ms = 0.0;   // localizer time per sensor update
  PoseConsistency consistency;
};

// The robot's path for one seed: the scenario's fixed path, or with random_path one drawn from
// the seed (deterministic).
std::vector<Eigen::Vector2d> path_for_seed(const FourPositionsScenario& scenario, uint64_t seed);

// Everything one seed needs: world, the DSM the localizer gets, and the measurement stream.
struct SimulatedRun {
  std::vector<Eigen::Vector2d> path;   // path_for_seed
  SyntheticWorld world;
  locd::emoi::ElevationMap dsm;
};
SimulatedRun build_run(const FourPositionsScenario& scenario, uint64_t seed);

// Streams the run's measurements (odometry, imu, scan in time order) with the true pose, until
// the robot finishes its path or `stop` returns true.
void simulate_measurements(const FourPositionsScenario& scenario, const SimulatedRun& run, uint64_t seed,
                           const std::function<bool(const Measurement&, const Eigen::Isometry3d& truth)>& sink);

// One seeded run through EmoiMarkovLocalizer in-process (the DSM handed over in memory).
RunResult run_four_positions(const FourPositionsScenario& scenario, uint64_t seed,
                             const std::function<void(LogLevel, const std::string&)>& log = {});

// One seeded run through a localizer made by `make` (e.g. the emoi_markov plugin loaded by name):
// make(map_directory, map_name, plugin_params) gets the run's DSM written as a GeoTIFF in a fresh
// map directory and the scenario's plugin parameters with `map` pointing at it.
using LocalizerMaker = std::function<std::shared_ptr<Localizer>(const std::filesystem::path& map_directory,
                                                                const Params& params)>;
RunResult run_four_positions_with(const FourPositionsScenario& scenario, uint64_t seed, const LocalizerMaker& make);

// locsim's hook: true when the scenario file says `kind: emoi_four_positions`.
bool is_four_positions_scenario(const std::filesystem::path& file);

// `locsim run` for this scenario: every seed (or only `seed`) through the plugin loaded by name
// from plugin_directories; a summary (or JSON) on out. Exit code 0 when every run produced its
// updates, 1 otherwise.
int locsim_run_four_positions(const std::filesystem::path& file, const std::vector<std::filesystem::path>& plugin_directories,
                              std::optional<uint64_t> seed, bool json, std::ostream& out);

}  // namespace locd::sim::emoi
