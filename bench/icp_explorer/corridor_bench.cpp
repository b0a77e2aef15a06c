// icp_explorer's degeneracy in the two-rooms-and-corridor world (config/maps/two_rooms_corridor_3d.yaml):
// the robot stops every 4.5 m along the 60 m corridor (sim::two_rooms_corridor_stops), odometry
// off by up to 0.5 m and 10 degrees per leg, full-size scans; the real plugin (the .so) with the
// corridor config, exploration off. Over many seeds, with the poorly constrained directions held
// to odometry (the default) and without (every direction follows the data, as before issue 15):
// the error along the corridor's axis (x) against the reported sigma, the NEES of (x, y, yaw)
// against the reported covariance, and the share of scans outside the 99 % ellipse.
//
//   build/bin/icp_explorer_corridor_bench [--seeds 20] [--coarse-scanner]
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
};

}  // namespace

int main(int argc, char** argv) try {
  int seeds = 20;
  bool coarse_scanner = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::stoi(argv[++i]);
    } else if (a == "--coarse-scanner") {
      coarse_scanner = true;
    } else {
      throw std::runtime_error("unknown option " + a);
    }
  }
  const fs::path source = env_or("LOCD_SOURCE_DIR", LOCD_SOURCE_DIR_DEFAULT);
  const auto library =
      locd::PluginLibrary::open(fs::path(env_or("LOCD_PLUGIN_DIR", LOCD_PLUGIN_DIR_DEFAULT)) / "liblocd_icp_explorer.so");
  const locd::sim::IndoorWorld world = locd::sim::IndoorWorld::load(source / "config/maps/two_rooms_corridor_3d.yaml");
  std::ifstream file(source / "config/plugins/icp_explorer_corridor.yaml");
  std::stringstream text;
  text << file.rdbuf();
  locd::sim::Scanner3DConfig scanner;
  if (coarse_scanner) {
    scanner.azimuth_steps = 360;
    scanner.elevation_steps = 70;
  }
  const auto stops = locd::sim::two_rooms_corridor_stops();

  std::printf("two rooms and a 60 m corridor: %zu stops, %d seeds, scanner %d x %d rays\n", stops.size(), seeds,
              scanner.azimuth_steps, scanner.elevation_steps);
  std::printf("| variant | scans | axis error within 3 sigma | max axis error | max axis error / sigma | "
              "max axis sigma | mean NEES (x, y, yaw; 3 expected) | outside 99 %% ellipse | max lateral error | "
              "max yaw error | scans with a degenerate direction | tracking / uncertain / lost |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const bool hold : {true, false}) {
    Tally t;
    for (int seed = 1; seed <= seeds; ++seed) {
      const locd::PluginConfig config = locd::split_plugin_config(text.str(), "icp_explorer_corridor.yaml");
      YAML::Node params = YAML::Clone(config.params.node());
      params["exploration"]["enabled"] = false;
      params["icp"]["degeneracy"]["hold_to_prior"] = hold;
      locd::PluginContext context;
      context.robot_id = "corridor";
      const auto localizer = locd::create_configured(*library, context, locd::Params(params, "icp_explorer"));
      const auto records = locd::sim::run_stop_and_scan_path(world, scanner, locd::sim::StopAndScanOdometryConfig{},
                                                              stops, static_cast<uint64_t>(seed), *localizer);
      for (size_t k = 1; k < records.size(); ++k) {
        const auto& r = records[k];
        if (!r.estimate) continue;
        const auto e = locd::sim::pose_error(*r.estimate, r.truth);
        const auto& C = r.estimate->covariance;
        Eigen::Matrix3d S;
        const int idx[3] = {0, 1, 5};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) S(a, b) = C(idx[a], idx[b]);
        const Eigen::Vector3d d(e[0], e[1], e[5]);
        const double nees = d.dot(S.ldlt().solve(d));
        const double sigma_x = std::sqrt(C(0, 0));
        ++t.scans;
        t.within_3_sigma += std::abs(e[0]) <= 3.0 * sigma_x;
        t.outside_99 += nees > kChi2_3_99;
        t.nees_sum += nees;
        t.max_axis_error = std::max(t.max_axis_error, std::abs(e[0]));
        t.max_axis_ratio = std::max(t.max_axis_ratio, std::abs(e[0]) / sigma_x);
        t.max_axis_sigma = std::max(t.max_axis_sigma, sigma_x);
        t.max_lateral_error = std::max(t.max_lateral_error, std::abs(e[1]));
        t.max_yaw_error_deg = std::max(t.max_yaw_error_deg, std::abs(e[5]) * 180 / M_PI);
        for (const auto& [name, value] : r.diagnostics.values)
          if (name == "degenerate_directions") t.degenerate_scans += value > 0;
        if (r.localization) {
          t.tracking += r.localization->state == locd::LocalizationState::kTracking;
          t.uncertain += r.localization->state == locd::LocalizationState::kUncertain;
          t.lost += r.localization->state == locd::LocalizationState::kLost;
        }
      }
    }
    std::printf("| %s | %d | %.1f %% | %.3f m | %.1f | %.3f m | %.2f | %.1f %% | %.3f m | %.2f deg | %d | %d / %d / %d |\n",
                hold ? "held to odometry (default)" : "not held (hold_to_prior: false)", t.scans,
                100.0 * t.within_3_sigma / t.scans, t.max_axis_error, t.max_axis_ratio, t.max_axis_sigma,
                t.nees_sum / t.scans, 100.0 * t.outside_99 / t.scans, t.max_lateral_error, t.max_yaw_error_deg,
                t.degenerate_scans, t.tracking, t.uncertain, t.lost);
    std::fflush(stdout);
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "corridor_bench: " << e.what() << "\n";
  return 1;
}
