#include "locd/sim_icp_explorer/exploration_mission.hpp"

#include <nlohmann/json.hpp>

#include "locd/sim/evaluation_report.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <random>
#include <sstream>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sim_icp_explorer/surface_coverage.hpp"

namespace locd::sim {

namespace fs = std::filesystem;

bool is_exploration_scenario(const fs::path& file) {
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    return root["kind"] && root["kind"].as<std::string>() == "icp_explorer_exploration";
  } catch (const std::exception&) {
    return false;
  }
}

ExplorationScenario load_exploration_scenario(const fs::path& file) {
  const Params p = Params::load_file(file.string());
  p.expect_only({"kind", "name", "seed", "world", "robot", "sensors", "mission", "localizer"});
  ExplorationScenario s;
  s.file = file;
  s.name = p.text("name", file.stem().string());
  s.seed = static_cast<uint64_t>(p.integer("seed", 1, 0, 1L << 40));
  const fs::path base = file.parent_path();
  s.world_file = base / p.required_text("world");
  const Params robot = p.child("robot");
  robot.expect_only({"id", "start", "radius"});
  s.robot_id = robot.text("id", s.robot_id);
  const auto start = robot.numbers("start", {1.0, 1.0, 0.0}, 3);
  s.start = Pose2(start[0], start[1], start[2]);
  s.robot_radius = robot.number("radius", s.robot_radius, Range::closed(0.05, 2.0));
  const Params sensors = p.child("sensors");
  sensors.expect_only({"scanner3d", "odometry"});
  s.scanner = Scanner3DConfig::from_params(sensors.child("scanner3d"));
  const Params odometry = sensors.child("odometry");
  odometry.expect_only({"max_translation_error", "max_rotation_error_deg"});
  s.odometry.max_translation_error = odometry.number("max_translation_error", 0.5, Range::closed(0.0, 5.0));
  s.odometry.max_rotation_error = odometry.number("max_rotation_error_deg", 10.0, Range::closed(0.0, 90.0)) * M_PI / 180;
  const Params mission = p.child("mission");
  mission.expect_only({"max_scans", "target_coverage", "coverage_voxel", "coverage_grid"});
  s.max_scans = static_cast<int>(mission.integer("max_scans", s.max_scans, 1, 1000));
  s.target_coverage = mission.number("target_coverage", s.target_coverage, Range{0.0, 1.0, true, false});
  s.coverage_voxel = mission.number("coverage_voxel", s.coverage_voxel, Range::closed(0.05, 2.0));
  s.coverage_grid = mission.number("coverage_grid", s.coverage_grid, Range::closed(0.1, 5.0));
  const Params localizer = p.child("localizer");
  localizer.expect_only({"config_file"});
  s.localizer_config_file = base / localizer.required_text("config_file");
  std::ifstream in(s.localizer_config_file);
  if (!in) localizer.fail("config_file", "cannot be read (" + s.localizer_config_file.string() + ")");
  std::stringstream text;
  text << in.rdbuf();
  s.localizer_config = text.str();
  return s;
}

ExplorationMissionResult run_exploration_mission(const ExplorationScenario& scenario, uint64_t seed,
                                                 Localizer& localizer) {
  const IndoorWorld world = IndoorWorld::load(scenario.world_file);
  const Scanner3D scanner(scenario.scanner);
  SurfaceCoverage coverage(world, scenario.scanner, scenario.coverage_voxel, scenario.coverage_grid,
                           scenario.robot_radius, Eigen::Vector2d(scenario.start.x, scenario.start.y), 2);
  StopAndScanOdometry odometry(scenario.odometry);
  std::mt19937_64 rng(seed);
  ExplorationMissionResult result;
  result.reference_voxels = coverage.reference_voxels();
  Pose2 truth = scenario.start;
  PoseEstimate start;
  start.header = {1, "map"};  // before the first scan, stamped so a remote localizer can acknowledge it
  start.pose = truth.to_isometry();
  localizer.set_pose(start);
  LocalizationState state = LocalizationState::kUnknown;
  for (int k = 0; k < scenario.max_scans; ++k) {
    const int64_t stamp = (k + 1) * 30'000'000'000LL;
    localizer.update(odometry.arrive(truth, stamp - 1'000'000, rng));
    const SimulatedScan scan = scanner.scan(world, truth.to_isometry(), k * 30.0, stamp, rng);
    coverage.add(scan, world);
    const auto begin = std::chrono::steady_clock::now();
    const UpdateResult out = localizer.update(scan.cloud);
    ExplorationScanRecord record;
    record.update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
    record.truth = truth;
    record.coverage = coverage.ratio();
    if (out.localization) state = out.localization->state;
    record.state = state;
    if (out.estimate) {
      record.nees = nees(Pose2::from_isometry(out.estimate->pose), truth, planar_covariance(out.estimate->covariance));
      record.error_m = (out.estimate->pose.translation() - truth.to_isometry().translation()).norm();
      record.error_deg =
          Eigen::AngleAxisd(out.estimate->pose.linear().transpose() * truth.to_isometry().linear()).angle() * 180 / M_PI;
    }
    record.done = !out.exploration_goal || out.exploration_goal->done;
    result.scans.push_back(record);
    result.coverage = record.coverage;
    if (result.scans_to_target < 0 && record.coverage >= scenario.target_coverage) {
      result.scans_to_target = k + 1;
      break;
    }
    if (record.done) {
      result.done = true;
      break;
    }
    const Eigen::Vector3d goal = out.exploration_goal->pose.translation();
    const Eigen::Vector2d here = out.estimate ? Eigen::Vector2d(out.estimate->pose.translation().head<2>())
                                              : Eigen::Vector2d(truth.x, truth.y);
    const Eigen::Vector2d step = goal.head<2>() - here;
    result.path_length += step.norm();
    truth = Pose2(goal.x(), goal.y(), std::atan2(step.y(), step.x()));
  }
  return result;
}

namespace {
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * (v.size() - 1) + 0.5)))];
}
// An error below it is "small" for the state's false alarms (registration accuracy is centimetres).
constexpr double kSmallErrorM = 0.1;

struct Summary {
  double max_error_m = 0, max_error_deg = 0, mean_error_m = 0, update_p50 = 0, update_p99 = 0;
  ConsistencySummary consistency;
  StateSummary localization;
};
Summary summarize(const ExplorationMissionResult& r) {
  Summary s;
  std::vector<double> ms;
  std::vector<ConsistencySample> consistency;
  std::vector<StateSample> states;
  for (const auto& scan : r.scans) {
    if (scan.nees) consistency.push_back({*scan.nees, scan.state});
    states.push_back({static_cast<double>(states.size()), scan.error_m, scan.state});
    s.max_error_m = std::max(s.max_error_m, scan.error_m);
    s.max_error_deg = std::max(s.max_error_deg, scan.error_deg);
    s.mean_error_m += scan.error_m / r.scans.size();
    ms.push_back(scan.update_ms);
  }
  s.update_p50 = percentile(ms, 0.5);
  s.update_p99 = percentile(ms, 0.99);
  s.consistency = summarize_consistency(consistency);
  s.localization = evaluate_states(states, {kSmallErrorM, std::nullopt});
  return s;
}
}  // namespace

// One JSON object on one line (nlohmann-json: strings escaped, a non-finite number written as null).
void write_exploration_json(std::ostream& out, const ExplorationScenario& scenario, const ExplorationMissionResult& r) {
  const Summary s = summarize(r);
  std::vector<double> coverage_per_scan;
  for (const auto& scan : r.scans) coverage_per_scan.push_back(scan.coverage);
  const nlohmann::ordered_json json = {
      {"scenario", scenario.name},          {"scans", r.scans.size()},
      {"scans_to_target", r.scans_to_target}, {"target_coverage", scenario.target_coverage},
      {"coverage", r.coverage},             {"done", r.done},
      {"path_length_m", r.path_length},     {"reference_voxels", r.reference_voxels},
      {"max_error_m", s.max_error_m},       {"mean_error_m", s.mean_error_m},
      {"max_error_deg", s.max_error_deg},   {"update_ms_p50", s.update_p50},
      {"update_ms_p99", s.update_p99},      {"coverage_per_scan", coverage_per_scan},
      {"consistency", consistency_json(s.consistency)}, {"localization", state_json(s.localization)}};
  out << json.dump() << "\n";
}

void write_exploration_summary(std::ostream& out, const ExplorationScenario& scenario,
                               const ExplorationMissionResult& r) {
  const Summary s = summarize(r);
  out << std::fixed << std::setprecision(3) << "scenario " << scenario.name << ": " << r.scans.size() << " scans, coverage "
      << r.coverage << " (target " << scenario.target_coverage << (r.scans_to_target > 0 ? ", reached" : ", not reached")
      << (r.done ? "; explorer done" : "") << "), path " << r.path_length << " m\n"
      << "registration error: max " << s.max_error_m << " m / " << s.max_error_deg << " deg, mean " << s.mean_error_m
      << " m; update p50 " << s.update_p50 << " ms, p99 " << s.update_p99 << " ms\n";
  write_consistency_summary(out, s.consistency);
  write_state_summary(out, s.localization);
}

int locsim_run_exploration(const fs::path& file, const std::vector<fs::path>& plugin_directories,
                           std::optional<uint64_t> seed, bool json, std::ostream& out) {
  const ExplorationScenario scenario = load_exploration_scenario(file);
  const PluginConfig config = split_plugin_config(scenario.localizer_config, scenario.localizer_config_file.string());
  const PluginCatalog catalog(plugin_directories);
  PluginContext context;
  context.robot_id = scenario.robot_id;
  context.maps = MapResolver({scenario.file.parent_path() / "../maps"});
  LocalizerPtr localizer = create_configured(catalog, config.plugin, context, config.params);
  const ExplorationMissionResult result = run_exploration_mission(scenario, seed.value_or(scenario.seed), *localizer);
  if (json)
    write_exploration_json(out, scenario, result);
  else
    write_exploration_summary(out, scenario, result);
  return result.scans.empty() ? 1 : 0;
}

}  // namespace locd::sim
