#include "locd/sim_emoi_markov/four_positions.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "localizer.hpp"
#include "params.hpp"
#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sim/evaluation_report.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

namespace locd::sim::emoi {
namespace fs = std::filesystem;

FourPositionsScenario load_four_positions(const fs::path& file) {
  const Params root = Params::load_file(file.string());
  root.expect_only({"kind", "name", "seed", "runs", "world", "robot", "sensors", "localizer", "evaluation"});
  const std::string kind = root.text("kind", "emoi_four_positions", {"emoi_four_positions"});
  FourPositionsScenario s;
  s.name = root.text("name", "emoi_four_positions");
  s.seed = static_cast<uint64_t>(root.integer("seed", 1, 0, 1L << 40));
  s.runs = static_cast<int>(root.integer("runs", 20, 1, 10000));
  const Params world = root.child("world");
  s.world = parse_world(world);
  s.dsm_noise_m = world.number("dsm_noise_m", s.dsm_noise_m, Range::closed(0.0, 10.0));
  s.dsm_nodata_fraction = world.number("dsm_nodata_fraction", 0.0, Range::closed(0.0, 0.5));

  const Params robot = root.child("robot");
  robot.expect_only({"id", "path", "random_path", "speed_mps", "base_height_m"});
  s.robot_id = robot.text("id", s.robot_id);
  if (robot.node()["random_path"]) {
    const Params random = robot.child("random_path");
    random.expect_only({"legs", "leg_m", "max_turn_deg", "margin_m"});
    s.random_path.legs = static_cast<int>(random.integer("legs", 5, 1, 1000));
    s.random_path.leg_m = random.number("leg_m", s.random_path.leg_m, Range::open(0.0, 1000.0));
    s.random_path.max_turn_rad = random.number("max_turn_deg", 90.0, Range::closed(0.0, 180.0)) * M_PI / 180.0;
    s.random_path.margin_m = random.number("margin_m", s.random_path.margin_m, Range::closed(0.0, 1000.0));
    if (2 * s.random_path.margin_m + s.random_path.leg_m > std::min(s.world.size_x_m, s.world.size_y_m)) {
      random.fail("margin_m", "leaves no room for a leg of " + std::to_string(s.random_path.leg_m) +
                                  " m in the world; allowed: 2 margin_m + leg_m <= the world's shorter side");
    }
  }
  const YAML::Node path = robot.node()["path"];
  if (s.random_path.legs > 0 && path) robot.fail("random_path", "is given with path; allowed: one of path and random_path");
  if (s.random_path.legs == 0) {
    if (!path || !path.IsSequence() || path.size() < 2) robot.fail("path", "must be a list of at least two [x, y] points");
    for (const auto& point : path) {
      if (!point.IsSequence() || point.size() != 2) robot.fail("path", "holds an entry that is not [x, y]");
      const Eigen::Vector2d p(point[0].as<double>(), point[1].as<double>());
      if (p.x() < 0 || p.y() < 0 || p.x() > s.world.size_x_m || p.y() > s.world.size_y_m) {
        robot.fail("path", "point [" + std::to_string(p.x()) + ", " + std::to_string(p.y()) +
                               "] lies outside the world [0, size_m]");
      }
      s.path.push_back(p);
    }
  }
  s.speed_mps = robot.number("speed_mps", s.speed_mps, Range::open(0.0, 50.0));
  s.base_height_m = robot.number("base_height_m", s.base_height_m, Range::closed(0.0, 5.0));

  const Params sensors = root.child("sensors");
  sensors.expect_only({"laser", "odometry", "imu"});
  s.laser = parse_laser(sensors.child("laser"));
  const Params odometry = sensors.child("odometry");
  odometry.expect_only({"rate_hz", "scale_stddev", "drift_stddev_rad", "yaw_rate_stddev"});
  s.odometry_rate_hz = odometry.number("rate_hz", s.odometry_rate_hz, Range::open(0.0, 1000.0));
  s.odometry.scale_stddev = odometry.number("scale_stddev", s.odometry.scale_stddev, Range::closed(0.0, 1.0));
  s.odometry.drift_stddev_rad = odometry.number("drift_stddev_rad", s.odometry.drift_stddev_rad, Range::closed(0.0, 1.0));
  s.odometry.yaw_rate_stddev = odometry.number("yaw_rate_stddev", s.odometry.yaw_rate_stddev, Range::closed(0.0, 1.0));
  const Params imu = sensors.child("imu");
  imu.expect_only({"rate_hz", "yaw_stddev_rad", "tilt_stddev_rad"});
  s.imu_rate_hz = imu.number("rate_hz", s.imu_rate_hz, Range::open(0.0, 1000.0));
  s.imu.yaw_stddev_rad = imu.number("yaw_stddev_rad", s.imu.yaw_stddev_rad, Range::closed(0.0, 1.0));
  s.imu.tilt_stddev_rad = imu.number("tilt_stddev_rad", s.imu.tilt_stddev_rad, Range::closed(0.0, 1.0));

  const Params localizer = root.child("localizer");
  localizer.expect_only({"config_file"});
  const std::string config_name = localizer.required_text("config_file");
  s.localizer_config_file = fs::path(config_name).is_absolute() ? fs::path(config_name) : file.parent_path() / config_name;
  std::ifstream in(s.localizer_config_file);
  if (!in) localizer.fail("config_file", "'" + s.localizer_config_file.string() + "' cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  s.localizer_config_text = text.str();

  const Params evaluation = root.child("evaluation");
  evaluation.expect_only({"updates", "success_radius_m"});
  s.updates = static_cast<int>(evaluation.integer("updates", s.updates, 1, 1000));
  s.success_radius_m = evaluation.number("success_radius_m", s.success_radius_m, Range::positive());
  return s;
}

std::vector<Eigen::Vector2d> path_for_seed(const FourPositionsScenario& scenario, uint64_t seed) {
  const RandomPathConfig& random = scenario.random_path;
  if (random.legs <= 0) return scenario.path;
  std::mt19937_64 rng(seed * 15485863 + 11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double margin = random.margin_m;
  const Eigen::Vector2d low(margin, margin), high(scenario.world.size_x_m - margin, scenario.world.size_y_m - margin);
  auto inside = [&](const Eigen::Vector2d& p) { return (p.array() >= low.array()).all() && (p.array() <= high.array()).all(); };
  constexpr int kAttempts = 1000;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    std::vector<Eigen::Vector2d> path{low + (high - low).cwiseProduct(Eigen::Vector2d(unit(rng), unit(rng)))};
    double heading = (2.0 * unit(rng) - 1.0) * M_PI;
    for (int leg = 0; leg < random.legs; ++leg) {
      if (leg > 0) heading += (2.0 * unit(rng) - 1.0) * random.max_turn_rad;
      const Eigen::Vector2d next = path.back() + random.leg_m * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      if (!inside(next)) break;
      path.push_back(next);
    }
    if (static_cast<int>(path.size()) == random.legs + 1) return path;
  }
  throw ConfigError("random_path: no path of " + std::to_string(random.legs) + " legs of " +
                    std::to_string(random.leg_m) + " m stays " + std::to_string(margin) + " m inside the world");
}

SimulatedRun build_run(const FourPositionsScenario& scenario, uint64_t seed) {
  SimulatedRun run;
  run.path = path_for_seed(scenario, seed);
  std::vector<Eigen::Vector2d> keep_clear;
  for (size_t i = 0; i + 1 < run.path.size(); ++i) {
    const Eigen::Vector2d a = run.path[i], b = run.path[i + 1];
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm())));
    for (int k = 0; k <= steps; ++k) keep_clear.push_back(a + (b - a) * (static_cast<double>(k) / steps));
  }
  run.world = generate_world(scenario.world, seed, keep_clear);
  run.dsm = noisy_dsm(run.world.surface, scenario.dsm_noise_m, scenario.dsm_nodata_fraction, seed);
  return run;
}

void simulate_measurements(const FourPositionsScenario& scenario, const SimulatedRun& run, uint64_t seed,
                           const std::function<bool(const Measurement&, const Eigen::Isometry3d&)>& sink) {
  TerrainRobot robot(run.world.terrain, run.path, scenario.speed_mps, scenario.base_height_m, scenario.odometry,
                     scenario.imu, seed * 7919 + 1);
  std::mt19937_64 laser_rng(seed * 104729 + 3);
  const double dt = 0.01;
  double next_odometry = 0.0, next_imu = 0.0, next_scan = 0.0;
  while (!robot.finished()) {
    const double t = robot.time_s();
    const int64_t stamp = static_cast<int64_t>(std::llround(t * 1e9));
    const Eigen::Isometry3d truth = robot.true_pose();
    if (t >= next_odometry - 1e-9) {
      next_odometry += 1.0 / scenario.odometry_rate_hz;
      if (sink(robot.odometry(stamp), truth)) return;
    }
    if (t >= next_imu - 1e-9) {
      next_imu += 1.0 / scenario.imu_rate_hz;
      if (sink(robot.imu(stamp), truth)) return;
    }
    if (t >= next_scan - 1e-9) {
      next_scan += 1.0 / scenario.laser.rate_hz;
      if (sink(simulate_scan(scenario.laser, run.world.surface, truth, t, stamp, laser_rng), truth)) return;
    }
    robot.step(dt);
  }
}

namespace {

// NEES of one estimate against the truth (the shared measure, locd/sim/consistency.hpp).
Nees nees_of(const PoseEstimate& estimate, const Eigen::Isometry3d& truth) {
  return nees(Pose2::from_isometry(estimate.pose), Pose2::from_isometry(truth), planar_covariance(estimate.covariance));
}

RunResult drive(const FourPositionsScenario& scenario, const SimulatedRun& run, uint64_t seed, Localizer& localizer,
                const locd::emoi::EmoiMarkovFilter* core) {
  RunResult result;
  result.seed = seed;
  double update_ms_total = 0.0;
  LocalizationState state = LocalizationState::kUnknown;  // the plugin's last judgement
  simulate_measurements(scenario, run, seed, [&](const Measurement& m, const Eigen::Isometry3d& truth) {
    const auto t0 = std::chrono::steady_clock::now();
    UpdateResult out;
    try {
      out = localizer.update(m);
    } catch (const InputError&) {
      return false;
    }
    const double elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (out.localization) state = out.localization->state;
    if (!out.estimate) return false;
    const Nees n = nees_of(*out.estimate, truth);
    const ConsistencyBounds& bound = ConsistencyBounds::get();
    if (!result.updates.empty() || out.grid) {
      PoseConsistency& c = result.consistency;
      ++c.poses;
      c.nees_position_sum += n.position;
      c.nees_heading_sum += n.heading.value_or(0.0);
      c.outside_99_position += n.position > bound.position_99 ? 1 : 0;
      c.outside_99_heading += n.heading.value_or(0.0) > bound.heading_99 ? 1 : 0;
      c.samples.push_back({n, state});
      const bool confident = state == LocalizationState::kTracking || state == LocalizationState::kUnknown;
      c.confidently_wrong += confident && n.position > bound.position_99 ? 1 : 0;
      if (state == LocalizationState::kTracking) {
        ++c.tracking;
        c.nees_position_tracking_sum += n.position;
      }
    }
    // A sensor update is the one that publishes the belief grid.
    if (!out.grid) return false;
    update_ms_total += elapsed_ms;
    UpdateRecord record;
    record.update = static_cast<int>(result.updates.size()) + 1;
    record.time_s = static_cast<double>(header_of(m).stamp_ns) * 1e-9;
    record.truth = truth.translation().head<2>();
    record.mode = out.estimate->pose.translation().head<2>();
    record.error_m = (record.mode - record.truth).norm();
    record.nees_position = n.position;
    record.nees_heading = n.heading.value_or(0.0);
    if (out.localization) {
      record.state = out.localization->state;
      record.reason = out.localization->reason;
    }
    for (const auto& [name, value] : out.diagnostics.values) {
      if (name.rfind("coverage_r", 0) == 0) record.coverage.push_back(value);
      if (name.rfind("emoi_r", 0) == 0) record.robot_emoi.push_back(value);
      if (name == "peak_mass") record.peak_mass = value;
      if (name == "modes") record.modes = static_cast<int>(value);
      if (name == "belief_area_m2") record.area_m2 = value;
      if (name == "fit_rms_m") record.fit_rms_m = value;
    }
    if (core) {
      const auto& grid = core->grid();
      record.truth_mass = locd::emoi::mass_within(grid.belief(), grid.occupied(), grid.geometry(), record.truth,
                                                  scenario.success_radius_m);
      record.cell_maximum_error_m = (core->summary().mode - record.truth).norm();
      const auto& assessment = core->assessment();
      if (!assessment.modes.empty()) {
        const auto& mode = assessment.modes.front();
        const Eigen::Vector2d e = record.mode - record.truth, d = mode.mean - record.mode;
        const Eigen::Matrix2d P = mode.covariance + d * d.transpose();
        record.nees_main_mode = e.dot(P.ldlt().solve(e));
      }
    }
    int row = 0, col = 0;
    if (core && core->full_disk_layers()) {
      if (core->grid().geometry().index_of(record.truth, row, col)) {
        for (const auto& layer : core->full_disk_layers()->layers) record.dsm_emoi.push_back(layer(row, col));
      }
    } else if (core && core->last_match() && core->matcher()->surface().geometry.index_of(record.truth, row, col)) {
      for (const auto& layer : core->last_match()->dsm_emoi) record.dsm_emoi.push_back(layer(row, col));
    }
    result.updates.push_back(record);
    return static_cast<int>(result.updates.size()) >= scenario.updates;
  });
  if (!result.updates.empty()) result.mean_update_ms = update_ms_total / static_cast<double>(result.updates.size());
  result.success = static_cast<int>(result.updates.size()) >= scenario.updates &&
                   result.updates.back().error_m <= scenario.success_radius_m;
  return result;
}

PluginConfig scenario_plugin_config(const FourPositionsScenario& scenario) {
  const PluginConfig plugin = split_plugin_config(scenario.localizer_config_text, scenario.localizer_config_file.string());
  if (plugin.plugin != "emoi_markov") {
    throw ConfigError("scenario localizer runs plugin '" + plugin.plugin + "'; this scenario needs emoi_markov");
  }
  return plugin;
}

}  // namespace

RunResult run_four_positions(const FourPositionsScenario& scenario, uint64_t seed,
                             const std::function<void(LogLevel, const std::string&)>& log) {
  const SimulatedRun run = build_run(scenario, seed);
  locd::emoi::EmoiMarkovConfig config = locd::emoi::parse_config(scenario_plugin_config(scenario).params);
  config.cache = false;  // every seed is a new world
  PluginContext context;
  context.robot_id = scenario.robot_id;
  if (log) context.log = log;
  locd::emoi::EmoiMarkovLocalizer localizer;
  const auto start = std::chrono::steady_clock::now();
  localizer.configure(context, config, run.dsm);
  const double layers_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RunResult result = drive(scenario, run, seed, localizer, &localizer.filter());
  result.layers_seconds = layers_seconds;
  return result;
}

RunResult run_four_positions_with(const FourPositionsScenario& scenario, uint64_t seed, const LocalizerMaker& make) {
  const SimulatedRun run = build_run(scenario, seed);
  const fs::path directory =
      fs::temp_directory_path() / ("locsim_emoi_" + std::to_string(::getpid()) + "_" + std::to_string(seed));
  fs::create_directories(directory);
  locd::emoi::write_dsm_geotiff(run.dsm, directory / "world.tif");
  YAML::Node document = YAML::Load(scenario.localizer_config_text);
  document["params"]["map"] = "world.tif";
  document["params"]["cache"] = false;  // every seed is a new world
  YAML::Emitter emitter;
  emitter << document;
  const PluginConfig plugin = split_plugin_config(emitter.c_str(), scenario.localizer_config_file.string());
  RunResult result;
  try {
    const auto start = std::chrono::steady_clock::now();
    std::shared_ptr<Localizer> localizer = make(directory, plugin.params);
    const double layers_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result = drive(scenario, run, seed, *localizer, nullptr);
    result.layers_seconds = layers_seconds;
  } catch (...) {
    fs::remove_all(directory);
    throw;
  }
  fs::remove_all(directory);
  return result;
}

bool is_four_positions_scenario(const fs::path& file) {
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    return root.IsMap() && root["kind"] && root["kind"].as<std::string>() == "emoi_four_positions";
  } catch (const std::exception&) {
    return false;
  }
}

int locsim_run_four_positions(const fs::path& file, const std::vector<fs::path>& plugin_directories,
                              std::optional<uint64_t> seed, bool json, std::ostream& out) {
  const FourPositionsScenario scenario = load_four_positions(file);
  const PluginCatalog catalog(plugin_directories);
  const std::vector<uint64_t> seeds = [&] {
    std::vector<uint64_t> s;
    if (seed) return std::vector<uint64_t>{*seed};
    for (int k = 0; k < scenario.runs; ++k) s.push_back(scenario.seed + static_cast<uint64_t>(k));
    return s;
  }();
  int successes = 0;
  bool complete = true;
  std::vector<RunResult> results;
  for (uint64_t s : seeds) {
    RunResult r = run_four_positions_with(scenario, s, [&](const fs::path& directory, const Params& params) {
      PluginContext context;
      context.robot_id = scenario.robot_id;
      context.maps = MapResolver({directory});
      return std::shared_ptr<Localizer>(create_configured(catalog, "emoi_markov", context, params));
    });
    successes += r.success ? 1 : 0;
    complete = complete && static_cast<int>(r.updates.size()) >= scenario.updates;
    if (!json) {
      out << "seed " << r.seed << (r.success ? "  ok  " : "  FAIL") << "  error after each update [m]:";
      for (const auto& u : r.updates) out << " " << u.error_m;
      if (!r.updates.empty()) {
        out << "  state: " << localization_state_name(r.updates.back().state) << " (" << r.updates.back().reason << ")";
      }
      out << "\n" << std::flush;
    }
    results.push_back(std::move(r));
  }
  const double rate = seeds.empty() ? 0.0 : static_cast<double>(successes) / static_cast<double>(seeds.size());
  // The state after the last update against the outcome; NEES over every pose after the first update.
  int wrong = 0, wrong_flagged = 0, right_flagged = 0;
  PoseConsistency poses;
  for (const RunResult& r : results) {
    const bool flagged = !r.updates.empty() && (r.updates.back().state == LocalizationState::kUncertain ||
                                                r.updates.back().state == LocalizationState::kLost);
    wrong += r.success ? 0 : 1;
    wrong_flagged += !r.success && flagged ? 1 : 0;
    right_flagged += r.success && flagged ? 1 : 0;
    poses.poses += r.consistency.poses;
    poses.nees_position_sum += r.consistency.nees_position_sum;
    poses.outside_99_position += r.consistency.outside_99_position;
    poses.confidently_wrong += r.consistency.confidently_wrong;
    poses.samples.insert(poses.samples.end(), r.consistency.samples.begin(), r.consistency.samples.end());
  }
  const ConsistencySummary consistency = summarize_consistency(poses.samples);
  if (json) {
    std::vector<std::vector<double>> errors;
    std::vector<std::string> states;
    for (const RunResult& r : results) {
      errors.emplace_back();
      for (const auto& u : r.updates) errors.back().push_back(u.error_m);
      states.push_back(r.updates.empty() ? "unknown" : localization_state_name(r.updates.back().state));
    }
    const nlohmann::ordered_json summary = {{"scenario", scenario.name},
                                            {"plugin", "emoi_markov"},
                                            {"runs", seeds.size()},
                                            {"successes", successes},
                                            {"success_rate", rate},
                                            {"success_radius_m", scenario.success_radius_m},
                                            {"updates", scenario.updates},
                                            {"errors_m", errors},
                                            {"final_states", states},
                                            {"wrong_flagged", wrong_flagged},
                                            {"right_flagged", right_flagged},
                                            {"consistency", consistency_json(consistency)}};
    out << summary.dump() << "\n";
  } else {
    out << "success: " << successes << " / " << seeds.size() << " (belief maximum within " << scenario.success_radius_m
        << " m of the truth after update " << scenario.updates << ")\n";
    out << "state after the last update: uncertain or lost in " << wrong_flagged << " of " << wrong
        << " wrong runs, in " << right_flagged << " of " << successes << " right runs (false alarms)\n";
    out << "every pose after the first update:\n";
    write_consistency_summary(out, consistency);
  }
  return complete ? 0 : 1;
}

}  // namespace locd::sim::emoi
