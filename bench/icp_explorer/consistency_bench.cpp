// icp_explorer's consistency: is the reported covariance to be believed, and the localization
// state? The real plugin (the .so), full-size scans, odometry off by up to 0.5 m and 10 degrees
// per leg, many seeds:
// - corridor: the two-rooms-and-corridor world (config/maps/two_rooms_corridor_3d.yaml), the robot
//   stopping every 4.5 m along the 60 m corridor (sim::two_rooms_corridor_stops), exploration
//   off; with the poorly constrained directions held to odometry (the default) and without
//   (hold_to_prior: false, every direction follows the data, as before issue 15);
// - four_rooms: the shipped exploration mission (config/scenarios/four_rooms.yaml), the robot
//   driving to the goals the plugin picks, people walking, until 95 % coverage.
// Per scan after the first: the error along x (the corridor's axis) against the reported sigma,
// the NEES of (x, y, yaw) against the reported covariance (3 expected), the share of scans outside
// the 99 % ellipse ("confidently wrong"), and the states the plugin reported.
//
//   build/bin/icp_explorer_consistency_bench [--seeds 20] [--scenario corridor|four_rooms|all] [--coarse-scanner]
//                                            [--set icp.coarse_stage.enabled=false ...]
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sim_icp_explorer/exploration_mission.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_path.hpp"

namespace fs = std::filesystem;

namespace {

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}

// chi-square quantile 0.99 for 3 degrees of freedom.
constexpr double kChi2_3_99 = 11.345;

struct Tally {
  int scans = 0, within_3_sigma = 0, outside_99 = 0, degenerate_scans = 0;
  int tracking = 0, uncertain = 0, lost = 0;
  double nees_sum = 0, max_axis_error = 0, max_axis_ratio = 0, max_lateral_error = 0, max_yaw_error_deg = 0;
  double max_axis_sigma = 0;

  void add(const locd::sim::PathScanRecord& r) {
    if (!r.estimate) return;
    const auto e = locd::sim::pose_error(*r.estimate, r.truth);
    const auto& C = r.estimate->covariance;
    Eigen::Matrix3d S;
    const int idx[3] = {0, 1, 5};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) S(a, b) = C(idx[a], idx[b]);
    const Eigen::Vector3d d(e[0], e[1], e[5]);
    const double nees = d.dot(S.ldlt().solve(d));
    const double sigma_x = std::sqrt(C(0, 0));
    ++scans;
    within_3_sigma += std::abs(e[0]) <= 3.0 * sigma_x;
    outside_99 += nees > kChi2_3_99;
    nees_sum += nees;
    max_axis_error = std::max(max_axis_error, std::abs(e[0]));
    max_axis_ratio = std::max(max_axis_ratio, std::abs(e[0]) / sigma_x);
    max_axis_sigma = std::max(max_axis_sigma, sigma_x);
    max_lateral_error = std::max(max_lateral_error, std::abs(e[1]));
    max_yaw_error_deg = std::max(max_yaw_error_deg, std::abs(e[5]) * 180 / M_PI);
    for (const auto& [name, value] : r.diagnostics.values)
      if (name == "degenerate_directions") degenerate_scans += value > 0;
    if (r.localization) {
      tracking += r.localization->state == locd::LocalizationState::kTracking;
      uncertain += r.localization->state == locd::LocalizationState::kUncertain;
      lost += r.localization->state == locd::LocalizationState::kLost;
    }
  }

  void print(const std::string& variant) const {
    std::printf("| %s | %d | %.1f %% | %.3f m | %.1f | %.3f m | %.2f | %.1f %% | %.3f m | %.2f deg | %d | %d / %d / %d |\n",
                variant.c_str(), scans, 100.0 * within_3_sigma / scans, max_axis_error, max_axis_ratio, max_axis_sigma,
                nees_sum / scans, 100.0 * outside_99 / scans, max_lateral_error, max_yaw_error_deg, degenerate_scans,
                tracking, uncertain, lost);
    std::fflush(stdout);
  }
};

// The plugin with a record of what each cloud gave: the exploration mission keeps only errors.
class Recording : public locd::Localizer {
 public:
  explicit Recording(locd::LocalizerPtr inner) : inner_(std::move(inner)) {}
  void configure(const locd::PluginContext& c, const locd::Params& p) override { inner_->configure(c, p); }
  void set_pose(const locd::PoseEstimate& pose) override { inner_->set_pose(pose); }
  locd::UpdateResult update(const locd::Measurement& m) override {
    locd::UpdateResult r = inner_->update(m);
    if (std::holds_alternative<locd::PointCloud>(m)) records.push_back({{}, r.estimate, r.localization, r.diagnostics});
    return r;
  }
  std::vector<locd::sim::PathScanRecord> records;

 private:
  locd::LocalizerPtr inner_;
};

// --set icp.coarse_stage.enabled=false: a parameter of the plugin changed for every run.
void apply_settings(YAML::Node params, const std::vector<std::string>& settings) {
  for (const std::string& setting : settings) {
    const auto equals = setting.find('=');
    if (equals == std::string::npos) throw std::runtime_error("--set wants key.path=value, not " + setting);
    std::vector<std::string> keys;
    std::stringstream path(setting.substr(0, equals));
    for (std::string key; std::getline(path, key, '.');) keys.push_back(key);
    YAML::Node node = params;
    for (size_t k = 0; k + 1 < keys.size(); ++k) node.reset(node[keys[k]]);
    node[keys.back()] = YAML::Load(setting.substr(equals + 1));
  }
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

int main(int argc, char** argv) try {
  int seeds = 20;
  bool coarse_scanner = false;
  std::string scenario = "all";
  std::vector<std::string> settings;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::stoi(argv[++i]);
    } else if (a == "--scenario" && i + 1 < argc) {
      scenario = argv[++i];
    } else if (a == "--set" && i + 1 < argc) {
      settings.push_back(argv[++i]);
    } else if (a == "--coarse-scanner") {
      coarse_scanner = true;
    } else {
      throw std::runtime_error("unknown option " + a);
    }
  }
  const fs::path source = env_or("LOCD_SOURCE_DIR", LOCD_SOURCE_DIR_DEFAULT);
  const auto library =
      locd::PluginLibrary::open(fs::path(env_or("LOCD_PLUGIN_DIR", LOCD_PLUGIN_DIR_DEFAULT)) / "liblocd_icp_explorer.so");
  std::printf("| scenario, variant | scans | x error within 3 sigma | max x error | max x error / sigma | "
              "max x sigma | mean NEES (x, y, yaw; 3 expected) | outside 99 %% ellipse | max y error | "
              "max yaw error | scans with a degenerate direction | tracking / uncertain / lost |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|\n");

  if (scenario == "corridor" || scenario == "all") {
    const locd::sim::IndoorWorld world = locd::sim::IndoorWorld::load(source / "config/maps/two_rooms_corridor_3d.yaml");
    const std::string text = read_text(source / "config/plugins/icp_explorer_corridor.yaml");
    locd::sim::Scanner3DConfig scanner;
    if (coarse_scanner) {
      scanner.azimuth_steps = 360;
      scanner.elevation_steps = 70;
    }
    const auto stops = locd::sim::two_rooms_corridor_stops();
    for (const bool hold : {true, false}) {
      Tally t;
      for (int seed = 1; seed <= seeds; ++seed) {
        const locd::PluginConfig config = locd::split_plugin_config(text, "icp_explorer_corridor.yaml");
        YAML::Node params = YAML::Clone(config.params.node());
        params["exploration"]["enabled"] = false;
        params["icp"]["degeneracy"]["hold_to_prior"] = hold;
        apply_settings(params, settings);
        const auto localizer =
            locd::create_configured(*library, locd::PluginContext{}, locd::Params(params, "icp_explorer"));
        const auto records = locd::sim::run_stop_and_scan_path(world, scanner, locd::sim::StopAndScanOdometryConfig{},
                                                                stops, static_cast<uint64_t>(seed), *localizer);
        for (size_t k = 1; k < records.size(); ++k) {
          t.add(records[k]);
        }
      }
      t.print(hold ? "corridor, held to odometry (default)" : "corridor, not held (hold_to_prior: false)");
    }
  }

  if (scenario == "four_rooms" || scenario == "all") {
    locd::sim::ExplorationScenario s = locd::sim::load_exploration_scenario(source / "config/scenarios/four_rooms.yaml");
    if (coarse_scanner) {
      s.scanner.azimuth_steps = 360;
      s.scanner.elevation_steps = 70;
    }
    for (const bool hold : {true, false}) {
      Tally t;
      for (int seed = 1; seed <= seeds; ++seed) {
        const locd::PluginConfig config = locd::split_plugin_config(s.localizer_config, s.localizer_config_file.string());
        YAML::Node params = YAML::Clone(config.params.node());
        params["icp"]["degeneracy"]["hold_to_prior"] = hold;
        apply_settings(params, settings);
        Recording localizer(locd::create_configured(*library, locd::PluginContext{}, locd::Params(params, "icp_explorer")));
        const auto mission = locd::sim::run_exploration_mission(s, static_cast<uint64_t>(seed), localizer);
        for (size_t k = 1; k < mission.scans.size() && k < localizer.records.size(); ++k) {
          localizer.records[k].truth = mission.scans[k].truth;
          t.add(localizer.records[k]);
        }
      }
      t.print(hold ? "four_rooms exploration, held to odometry (default)" : "four_rooms exploration, not held");
    }
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "consistency_bench: " << e.what() << "\n";
  return 1;
}
