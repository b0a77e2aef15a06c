// grid_mcl on real buildings: the CARMEN logs of ../shared/realdata/carmen (Freiburg building
// 079, Intel Research Lab), replayed offline through the grid_mcl plugin loaded from the plugin
// directory as the server's worker loads it (PluginCatalog, configure with the shipped config,
// only `map` set), scored like evo's APE against the logs' corrected poses.
//
// Inputs, as ../shared/realdata/carmen/README.md prescribes:
//   reference   the corrected pose of every FLASER line at its stamp
//   odometry    at the log's non-zero ODOM stamps, the reference interpolated there with seeded
//               noise composed step after step: translation ds (1 + N(0, 0.05)), rotation
//               dth + N(0, 1 deg/m * ds + 0.02 |dth|) (std::mt19937_64 seeded with the seed)
//   scans       FLASER, 180 deg, readings at or above 81 m as no return
//   start       near: the reference at the first scan, 0.3 m off in a direction drawn from the
//               seed and 10 deg off (sign from the seed), with the config's initial covariance;
//               global: a covariance above global_localization_stddev (a uniform start)
//
// Every pose the plugin returns is scored against the reference interpolated at its stamp
// (poses outside the reference's time span are not scored).
//
//   realdata_bench [--data DIR] [--logs freiburg-079,intel] [--seeds 1-5] [--start near|global|both]
//                  [--config FILE] [--plugin-dir DIR] [--set key=value ...] [--no-mrpt]
//
// MRPT's pf-localization is not run by this program (a run took more than 10 min per log and
// seed); its figures on the same inputs are quoted from the data's README.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "locd/logs/carmen_log.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sdk/pose_history.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/sim/evaluator.hpp"

namespace {

using namespace locd;
namespace fs = std::filesystem;

struct LogSpec {
  std::string name;  // the log's base name: NAME.log.gz, NAME.yaml
  std::string map;   // map YAML in the data directory
  // MRPT pf-localization on the same inputs, from the data's README (seed 1, started near).
  std::string mrpt;
};

const std::vector<LogSpec> kLogs = {
    {"freiburg-079", "freiburg-079.yaml", "APE RMSE 0.052 m, max 0.19 m, 0 % > 0.5 m"},
    {"intel", "intel.yaml", "APE RMSE 0.171 m, max 1.32 m, 2.3 % > 0.5 m"},
};

struct Options {
  fs::path data = fs::path(LOCD_SOURCE_DIR) / ".." / "shared" / "realdata" / "carmen";
  std::vector<std::string> logs = {"freiburg-079", "intel"};
  std::vector<uint64_t> seeds = {1, 2, 3, 4, 5};
  std::vector<std::string> starts = {"near"};
  fs::path config = fs::path(LOCD_SOURCE_DIR) / "config" / "plugins" / "grid_mcl.yaml";
  fs::path plugin_dir = LOCD_PLUGIN_DIR;
  std::vector<std::pair<std::string, std::string>> overrides;
  bool verbose = false;
  double noise_scale = 1.0;  // the odometry noise model's deviations times this (1: the README's)
};

struct Event {
  int64_t stamp_ns = 0;
  Measurement measurement;
};

struct Inputs {
  std::vector<Event> events;  // odometry and scans in stamp order (odometry first on a tie)
  PoseHistory reference{1u << 20};
  PoseHistory odometry{1u << 20};  // the noisy odometry made (odom frame)
  int64_t first_scan_ns = 0, last_scan_ns = 0;
  Pose2 start;  // the reference at the first scan
  size_t scans = 0, odometry_samples = 0;
};

Pose2 reference_at(const PoseHistory& reference, int64_t stamp_ns) {
  return Pose2::from_isometry(*reference.at(std::max(stamp_ns, reference.oldest_stamp())));
}

// The README's noise model, composed step after step from the reference at the ODOM stamps.
Inputs make_inputs(const logs::CarmenLog& log, uint64_t seed, double noise_scale) {
  Inputs in;
  for (const logs::CarmenScan& s : log.scans) in.reference.add(s.scan.header.stamp_ns, s.laser_pose.to_isometry());
  if (in.reference.size() < 2) throw std::runtime_error("the log has fewer than 2 scans");
  in.first_scan_ns = log.scans.front().scan.header.stamp_ns;
  in.last_scan_ns = log.scans.back().scan.header.stamp_ns;
  in.start = log.scans.front().laser_pose;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Pose2 previous_reference, odometry;
  bool first = true;
  for (const logs::CarmenOdometry& o : log.odometry) {
    const Pose2 r = reference_at(in.reference, o.stamp_ns);
    if (first) {
      odometry = Pose2();  // the odom frame starts where the robot is
      first = false;
    } else {
      const Pose2 step = previous_reference.inverse() * r;
      const double ds = std::hypot(step.x, step.y), dth = step.theta;
      const double scale = 1.0 + noise_scale * 0.05 * normal(rng);
      const double rotation_stddev = noise_scale * ((M_PI / 180.0) * ds + 0.02 * std::abs(dth));
      odometry = odometry * Pose2(scale * step.x, scale * step.y, dth + rotation_stddev * normal(rng));
      odometry.theta = normalize_angle(odometry.theta);
    }
    previous_reference = r;
    Odometry m;
    m.header.stamp_ns = o.stamp_ns;
    m.header.frame_id = "odom";
    m.pose = odometry.to_isometry();
    in.odometry.add(o.stamp_ns, m.pose);
    in.events.push_back({o.stamp_ns, m});
    ++in.odometry_samples;
  }
  for (const logs::CarmenScan& s : log.scans) {
    LaserScan scan = s.scan;
    in.events.push_back({s.scan.header.stamp_ns, scan});
    ++in.scans;
  }
  std::stable_sort(in.events.begin(), in.events.end(), [](const Event& a, const Event& b) {
    if (a.stamp_ns != b.stamp_ns) return a.stamp_ns < b.stamp_ns;
    return a.measurement.index() < b.measurement.index();  // Odometry is the variant's first
  });
  return in;
}

struct RunFigures {
  std::string log, start;
  uint64_t seed = 0;
  size_t poses = 0;
  double rmse = 0, mean = 0, median = 0, max = 0;
  double over_half_share = 0;          // poses > 0.5 m off
  double confidently_wrong_share = 0;  // outside the 99 % ellipse while tracking (or no state)
  double tracking_share = 0, uncertain_share = 0, lost_share = 0;
  double tracking_while_over_half_share = 0;  // of all poses: tracking while > 0.5 m off
  double false_alarm_share = 0;               // of poses within 0.5 m: uncertain or lost
  std::optional<double> settled_s;            // from then on always within 0.5 m (log time)
  size_t filter_updates = 0;
  double update_ms_mean = 0, update_ms_p50 = 0, update_ms_p99 = 0;
  double wall_s = 0;
};

std::string fixed_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", v);
  return text;
}

Params load_params(const Options& options, const std::string& map) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(options.config.string());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(options.config.string() + ": " + e.what());
  }
  YAML::Node params = root["params"] ? YAML::Clone(root["params"]) : YAML::Node(YAML::NodeType::Map);
  params["map"] = map;
  for (const auto& [key, value] : options.overrides) {
    // "a.b=value" sets a nested key (localization_state.tracking_max_see_through=1).
    const auto dot = key.find('.');
    if (dot == std::string::npos) {
      params[key] = YAML::Load(value);
    } else {
      params[key.substr(0, dot)][key.substr(dot + 1)] = YAML::Load(value);
    }
  }
  return Params(params, options.config.string());
}

RunFigures run(const Options& options, const LogSpec& spec, const Inputs& in, const std::string& start, uint64_t seed) {
  RunFigures f;
  f.log = spec.name;
  f.start = start;
  f.seed = seed;
  const PluginCatalog catalog({options.plugin_dir});
  PluginContext context;
  context.robot_id = "realdata";
  context.maps = MapResolver({options.data});
  const Params params = load_params(options, spec.map);
  LocalizerPtr localizer = create_configured(catalog, "grid_mcl", context, params);

  PoseEstimate initial;
  initial.header.stamp_ns = in.first_scan_ns;
  initial.header.frame_id = "map";
  std::mt19937_64 rng(seed ^ 0x5eedULL);
  const double direction = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
  const double sign = std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0;
  const Pose2 near(in.start.x + 0.3 * std::cos(direction), in.start.y + 0.3 * std::sin(direction),
                   normalize_angle(in.start.theta + sign * 10.0 * M_PI / 180.0));
  initial.pose = near.to_isometry();
  initial.covariance = pose_covariance(Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal());
  if (start == "global") initial.covariance = pose_covariance(Eigen::Vector3d(1e12, 1e12, 10.0).asDiagonal());
  localizer->set_pose(initial);

  sim::TrajectoryEvaluator evaluator(0.5);
  LocalizationState state = LocalizationState::kUnknown;
  std::vector<double> filter_ms;
  const auto wall_begin = std::chrono::steady_clock::now();
  for (const Event& e : in.events) {
    validate(e.measurement);
    const auto begin = std::chrono::steady_clock::now();
    const UpdateResult r = localizer->update(e.measurement);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
    if (!r.diagnostics.values.empty()) filter_ms.push_back(ms);
    if (r.localization) state = r.localization->state;
    if (!r.estimate) continue;
    const int64_t stamp = r.estimate->header.stamp_ns;
    if (stamp < in.first_scan_ns || stamp > in.last_scan_ns) continue;
    if (options.verbose && !r.diagnostics.values.empty()) {  // one line per filter update
      const Pose2 e = Pose2::from_isometry(r.estimate->pose), truth = reference_at(in.reference, stamp);
      std::cerr << fixed_text(static_cast<double>(stamp - in.first_scan_ns) * 1e-9) << " error "
                << fixed_text(std::hypot(e.x - truth.x, e.y - truth.y)) << " at " << fixed_text(truth.x) << ","
                << fixed_text(truth.y) << " heading error " << fixed_text(normalize_angle(e.theta - truth.theta) * 180.0 / M_PI) << " deg odom yaw " << fixed_text(Pose2::from_isometry(*in.odometry.at(stamp)).theta * 180 / M_PI)  << " truth yaw " << fixed_text(truth.theta * 180 / M_PI) << " yaw std " << fixed_text(std::sqrt(r.estimate->covariance(5, 5)) * 180 / M_PI) << " " << localization_state_name(state);
      for (const auto& [k, v] : r.diagnostics.values) {
        if (k == "particles" || k == "scan_fit" || k == "see_through" || k == "cluster_mass") std::cerr << " " << k << " " << v;
      }
      std::cerr << " | " << (r.localization ? r.localization->reason : std::string()) << "\n";
    }
    evaluator.add(static_cast<double>(stamp - in.first_scan_ns) * 1e-9, *r.estimate, reference_at(in.reference, stamp),
                  state, ms);
  }
  f.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_begin).count();
  const sim::EvaluationSummary s = evaluator.summary();
  const auto& scored = evaluator.estimates();
  f.poses = scored.size();
  if (scored.empty()) return f;
  std::vector<double> errors;
  size_t over = 0, tracking_over = 0;
  for (const auto& e : scored) {
    errors.push_back(e.position_error_m);
    if (e.position_error_m > 0.5) {
      ++over;
      if (e.state == LocalizationState::kTracking) ++tracking_over;
    }
  }
  const double n = static_cast<double>(scored.size());
  f.rmse = s.rmse_m;
  f.mean = s.mean_error_m;
  f.median = sim::percentile(errors, 50);
  f.max = s.max_error_m;
  f.over_half_share = over / n;
  f.confidently_wrong_share = s.consistency.confidently_wrong_share;
  f.tracking_share = s.localization.tracking / n;
  f.uncertain_share = s.localization.uncertain / n;
  f.lost_share = s.localization.lost / n;
  f.tracking_while_over_half_share = tracking_over / n;
  f.false_alarm_share = s.localization.false_alarm_share;
  f.settled_s = s.convergence_time_s;
  f.filter_updates = filter_ms.size();
  if (!filter_ms.empty()) {
    double sum = 0;
    for (double v : filter_ms) sum += v;
    f.update_ms_mean = sum / static_cast<double>(filter_ms.size());
    f.update_ms_p50 = sim::percentile(filter_ms, 50);
    f.update_ms_p99 = sim::percentile(filter_ms, 99);
  }
  return f;
}

std::string fixed(double v, int decimals) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", decimals, v);
  return text;
}
std::string pct(double share) { return fixed(100.0 * share, 1) + " %"; }

void print_row(const RunFigures& f) {
  std::cout << "| " << f.log << " | " << f.start << " | " << f.seed << " | " << fixed(f.rmse, 3) << " | "
            << fixed(f.mean, 3) << " | " << fixed(f.median, 3) << " | " << fixed(f.max, 2) << " | "
            << pct(f.over_half_share) << " | " << pct(f.confidently_wrong_share) << " | "
            << pct(f.tracking_while_over_half_share) << " | " << pct(f.tracking_share) << " / "
            << pct(f.uncertain_share) << " / " << pct(f.lost_share) << " | "
            << (f.settled_s ? fixed(*f.settled_s, 1) + " s" : std::string("never")) << " | "
            << fixed(f.update_ms_mean, 2) << " (p99 " << fixed(f.update_ms_p99, 2) << ") |" << std::endl;
}

std::vector<std::string> split(const std::string& text, char by) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, by);) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

[[noreturn]] void usage(const std::string& problem) {
  std::cerr << "realdata_bench: " << problem << "\n"
            << "usage: realdata_bench [--data DIR] [--logs freiburg-079,intel] [--seeds 1-5 | 1,3] "
               "[--start near|global|both] [--config FILE] [--plugin-dir DIR] [--set key=value ...] [--no-mrpt] "
               "[--noise-scale X] [--verbose]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--data") {
      o.data = value();
    } else if (a == "--logs") {
      o.logs = split(value(), ',');
    } else if (a == "--seeds") {
      const std::string v = value();
      o.seeds.clear();
      try {
        if (const auto dash = v.find('-'); dash != std::string::npos) {
          for (uint64_t s = std::stoull(v.substr(0, dash)); s <= std::stoull(v.substr(dash + 1)); ++s) o.seeds.push_back(s);
        } else {
          for (const std::string& s : split(v, ',')) o.seeds.push_back(std::stoull(s));
        }
      } catch (const std::exception&) {
        usage("--seeds '" + v + "': expected FIRST-LAST or a comma-separated list of whole numbers");
      }
      if (o.seeds.empty()) usage("--seeds '" + v + "' names no seed");
    } else if (a == "--start") {
      const std::string v = value();
      if (v == "both") {
        o.starts = {"near", "global"};
      } else if (v == "near" || v == "global") {
        o.starts = {v};
      } else {
        usage("--start '" + v + "': allowed near, global, both");
      }
    } else if (a == "--config") {
      o.config = value();
    } else if (a == "--plugin-dir") {
      o.plugin_dir = value();
    } else if (a == "--set") {
      const std::string v = value();
      const auto eq = v.find('=');
      if (eq == std::string::npos || eq == 0) usage("--set '" + v + "': expected key=value");
      o.overrides.emplace_back(v.substr(0, eq), v.substr(eq + 1));
    } else if (a == "--no-mrpt") {
      // MRPT is never run by this program (see the header); accepted for the documented command.
    } else if (a == "--noise-scale") {
      try {
        o.noise_scale = std::stod(value());
      } catch (const std::exception&) {
        usage("--noise-scale needs a number");
      }
    } else if (a == "--verbose") {
      o.verbose = true;
    } else {
      usage("unknown argument '" + a + "'");
    }
  }
  for (const std::string& name : o.logs) {
    if (std::none_of(kLogs.begin(), kLogs.end(), [&](const LogSpec& l) { return l.name == name; })) {
      usage("--logs: unknown log '" + name + "'; allowed freiburg-079, intel");
    }
  }
  if (!fs::is_directory(o.data)) usage("data directory '" + o.data.string() + "' not found; give it with --data");
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  std::cout << "grid_mcl on real logs (" << options.data.string() << "), config " << options.config.string();
  for (const auto& [k, v] : options.overrides) std::cout << ", " << k << "=" << v;
  std::cout << "\n\n| log | start | seed | APE RMSE m | mean | median | max | > 0.5 m | confidently wrong | "
               "tracking while > 0.5 m | tracking / uncertain / lost | within 0.5 m from | filter update ms |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
            << std::endl;
  std::map<std::string, std::vector<RunFigures>> by_group;
  int failures = 0;
  for (const std::string& name : options.logs) {
    const LogSpec& spec = *std::find_if(kLogs.begin(), kLogs.end(), [&](const LogSpec& l) { return l.name == name; });
    logs::CarmenLog log;
    try {
      logs::CarmenReadOptions read;
      read.skip_going_backwards = true;  // the data README: increasing stamps only
      log = logs::read_carmen_log(options.data / (spec.name + ".log.gz"), read);
      std::cerr << spec.name << ": " << log.scans.size() << " scans, " << log.odometry.size()
                << " odometry stamps; skipped going backwards: " << log.scans_going_backwards << " scans, "
                << log.odometry_going_backwards << " ODOM\n";
    } catch (const logs::LogError& e) {
      std::cerr << "realdata_bench: " << e.what() << "\n";
      return 1;
    }
    for (const std::string& start : options.starts) {
      for (uint64_t seed : options.seeds) {
        try {
          const Inputs in = make_inputs(log, seed, options.noise_scale);
          const RunFigures f = run(options, spec, in, start, seed);
          print_row(f);
          by_group[spec.name + " " + start].push_back(f);
        } catch (const std::exception& e) {
          std::cerr << "realdata_bench: " << spec.name << " seed " << seed << ": " << e.what() << "\n";
          ++failures;
        }
      }
    }
  }
  std::cout << "\n| log, start | seeds | APE RMSE m, mean (worst seed) | max m | > 0.5 m, worst seed | confidently wrong, "
               "worst | tracking while > 0.5 m, worst | filter update ms, mean | MRPT pf-localization (data README, not run) |\n"
               "|---|---|---|---|---|---|---|---|---|"
            << std::endl;
  for (const auto& [group, runs] : by_group) {
    double rmse = 0, worst_rmse = 0, max = 0, over = 0, wrong = 0, tracking_over = 0, ms = 0;
    for (const RunFigures& f : runs) {
      rmse += f.rmse / static_cast<double>(runs.size());
      ms += f.update_ms_mean / static_cast<double>(runs.size());
      worst_rmse = std::max(worst_rmse, f.rmse);
      max = std::max(max, f.max);
      over = std::max(over, f.over_half_share);
      wrong = std::max(wrong, f.confidently_wrong_share);
      tracking_over = std::max(tracking_over, f.tracking_while_over_half_share);
    }
    const std::string log_name = group.substr(0, group.find(' '));
    const LogSpec& spec = *std::find_if(kLogs.begin(), kLogs.end(), [&](const LogSpec& l) { return l.name == log_name; });
    std::cout << "| " << group << " | " << runs.size() << " | " << fixed(rmse, 3) << " (" << fixed(worst_rmse, 3) << ") | "
              << fixed(max, 2) << " | " << pct(over) << " | " << pct(wrong) << " | " << pct(tracking_over) << " | "
              << fixed(ms, 2) << " | " << (group.find("near") != std::string::npos ? spec.mrpt : "-") << " |"
              << std::endl;
  }
  return failures == 0 ? 0 : 1;
}
