// emoi_shape_residual_eval SCENARIO.yaml [--runs N] [--first-seed S] [--no-odometry-error]: where the shape residual
// (masked_emoi.hpp) has its minimum relative to the truth, with and without the DSM's object
// edges left out (shape_edge_step_m), at every sensor update of the four-position experiment.
// At each update the robot's patch is rebuilt from the filter's local map as odometry placed it
// (no distortion hypothesis: hence --no-odometry-error, which zeroes the scenario's odometry scale
// and direction errors), matched at the
// matching cells within 3 m of the truth by both matchers, and the minimum's distance from the
// truth printed; also how many observed cells differ from the DSM at the truth by more than 1 m
// (robot below / above) and their share of the residual.
#include <algorithm>
#include <cstring>
#include <iomanip>
#include <iostream>

#include "localizer.hpp"
#include "params.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"

namespace {

using namespace locd;
namespace simulator = locd::sim::emoi;

constexpr int kSearchCells = 6;  // +-3 m on the 0.5 m matching grid

// Distance from the truth of the listed cell with the smallest residual.
double minimum_offset(const emoi::MaskedEmoiMatcher& matcher, const cv::Mat_<float>& patch,
                      const std::vector<cv::Point>& cells, const Eigen::Vector2d& truth) {
  const auto match = matcher.match_at(patch, cells, true);
  int best = -1;
  for (int i = 0; i < static_cast<int>(cells.size()); ++i) {
    const float r = match.shape_residual(0, i);
    if (std::isfinite(r) && (best < 0 || r < match.shape_residual(0, best))) best = i;
  }
  if (best < 0) return std::nan("");
  return (matcher.surface().geometry.center_of(cells[best].y, cells[best].x) - truth).norm();
}

void print_quantiles(const char* what, std::vector<double> values) {
  std::sort(values.begin(), values.end());
  if (values.empty()) return;
  const auto at = [&](double q) { return values[std::min(values.size() - 1, static_cast<size_t>(q * values.size()))]; };
  std::cout << what << ": median " << at(0.5) << " m, 90th percentile " << at(0.9) << " m, above 0.5 m in "
            << std::count_if(values.begin(), values.end(), [](double v) { return v > 0.5; }) << " of "
            << values.size() << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string file = "config/scenarios/emoi_random_paths.yaml";
  int runs = 8;
  long first_seed = 1;
  bool exact_odometry = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) {
      runs = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--first-seed") && i + 1 < argc) {
      first_seed = std::atol(argv[++i]);
    } else if (!std::strcmp(argv[i], "--no-odometry-error")) {
      exact_odometry = true;
    } else {
      file = argv[i];
    }
  }
  try {
    simulator::FourPositionsScenario scenario = simulator::load_four_positions(file);
    if (exact_odometry) scenario.odometry.scale_stddev = scenario.odometry.drift_stddev_rad = 0.0;
    const PluginConfig plugin = split_plugin_config(scenario.localizer_config_text, scenario.localizer_config_file.string());
    emoi::EmoiMarkovConfig config = emoi::parse_config(plugin.params);
    config.cache = false;
    std::vector<double> plain_offsets, masked_offsets;
    std::cout << std::fixed << std::setprecision(2);
    for (int k = 0; k < runs; ++k) {
      const uint64_t seed = static_cast<uint64_t>(first_seed + k);
      const simulator::SimulatedRun run = simulator::build_run(scenario, seed);
      emoi::EmoiMarkovLocalizer localizer;
      localizer.configure(PluginContext{}, config, run.dsm);
      const emoi::MaskedEmoiMatcher plain(run.dsm, config.radii_m, config.match_resolution_m, 0.0);
      const emoi::MaskedEmoiMatcher masked(run.dsm, config.radii_m, config.match_resolution_m,
                                           config.sensor.shape_edge_step_m);
      std::optional<Odometry> odometry;
      std::optional<Imu> imu;
      double travelled = 0.0;
      simulator::simulate_measurements(scenario, run, seed, [&](const Measurement& m, const Eigen::Isometry3d& truth) {
        if (const auto* o = std::get_if<Odometry>(&m)) {
          if (odometry) travelled += (o->pose.translation() - odometry->pose.translation()).head<2>().norm();
          odometry = *o;
        }
        if (const auto* i = std::get_if<Imu>(&m)) imu = *i;
        const size_t before = localizer.filter().sensor_updates();
        try {
          localizer.update(m);
        } catch (const InputError&) {
          return false;
        }
        if (localizer.filter().sensor_updates() == before || !imu) return false;
        // The patch as the filter built it (identity hypothesis), map-aligned by the IMU heading.
        const double heading_offset =
            normalize_angle(yaw_of(imu->orientation.toRotationMatrix()) - yaw_of(odometry->pose.linear()));
        const Eigen::Vector3d position = odometry->pose.translation();
        const cv::Mat_<float> patch = localizer.filter().local_map().robot_patch(
            position.head<2>(), heading_offset, plain.cell_m(), plain.patch_radius(), position.z() - config.base_height_m,
            travelled);
        const Eigen::Vector2d t = truth.translation().head<2>();
        int row = 0, col = 0;
        if (!plain.surface().geometry.index_of(t, row, col)) return false;
        std::vector<cv::Point> cells;
        for (int dr = -kSearchCells; dr <= kSearchCells; ++dr)
          for (int dc = -kSearchCells; dc <= kSearchCells; ++dc) cells.emplace_back(col + dc, row + dr);
        const double plain_offset = minimum_offset(plain, patch, cells, t);
        const double masked_offset = minimum_offset(masked, patch, cells, t);
        plain_offsets.push_back(plain_offset);
        masked_offsets.push_back(masked_offset);
        // Outliers at the truth's cell: observed cells more than 1 m from the DSM (median offset).
        const cv::Mat_<float>& surface = plain.surface().elevation;
        const int half = plain.patch_radius();
        std::vector<double> differences;
        for (int dr = -half; dr <= half; ++dr)
          for (int dc = -half; dc <= half; ++dc) {
            const int r = row + dr, c = col + dc;
            if (dr * dr + dc * dc >= half * half || r < 0 || c < 0 || r >= surface.rows || c >= surface.cols) continue;
            const float robot = patch(half + dr, half + dc), dsm = surface(r, c) - surface(row, col);
            if (std::isfinite(robot) && std::isfinite(dsm)) differences.push_back(robot - dsm);
          }
        std::vector<double> sorted = differences;
        std::sort(sorted.begin(), sorted.end());
        const double offset = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
        int below = 0, above = 0;
        double outlier_square = 0.0, total_square = 0.0;
        for (double d : differences) {
          const double e = d - offset;
          total_square += e * e;
          if (std::abs(e) > 1.0) {
            (e < 0 ? below : above) += 1;
            outlier_square += e * e;
          }
        }
        std::cout << "seed " << seed << " update " << localizer.filter().sensor_updates() << ": minimum "
                  << plain_offset << " m from the truth (edges kept), " << masked_offset
                  << " m (edges left out); at the truth " << differences.size() << " cells, " << below
                  << " more than 1 m below the DSM, " << above << " above, "
                  << (total_square > 0 ? 100.0 * outlier_square / total_square : 0.0) << " % of the squared residual\n";
        return localizer.filter().sensor_updates() >= static_cast<size_t>(scenario.updates);
      });
    }
    print_quantiles("edges kept", plain_offsets);
    print_quantiles("edges left out", masked_offsets);
  } catch (const std::exception& e) {
    std::cerr << "emoi_shape_residual_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
