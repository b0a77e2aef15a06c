#include "params.hpp"

#include <algorithm>
#include <sstream>
#include <string>

namespace locd::emoi {
namespace {

std::string format_number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// Radii per config, and the local map's smallest side: room for the largest disk and this margin.
constexpr int kMaxRadii = 8;
constexpr double kLocalMapMinimumSide = 40.0;  // m
constexpr double kLocalMapMargin = 20.0;       // m

}  // namespace

EmoiMarkovConfig parse_config(const Params& params) {
  params.expect_only({"map", "radii_m", "sigma_m", "min_likelihood", "min_coverage", "full_coverage",
                      "odometry_error", "min_blur_m", "update_distance_m", "heading_source", "use_initial_pose",
                      "base_height_m", "local_map_size_m", "local_map_memory_m", "local_map_refresh_m", "min_point_range_m", "cache",
                      "belief_output_max_cells", "sensor_model", "match_resolution_m", "ground_offset_stddev_m",
                      "odometry_direction_error_rad", "distortion_nodes", "distortion_max_cells",
                      "distortion_support_mass", "shape_sigma_m", "shape_edge_step_m", "tracking_radius_m", "tracking_mass",
                      "min_mode_mass", "lost_area_m2", "max_fit_rms_m"});
  EmoiMarkovConfig config;
  config.map = params.required_text("map");
  config.radii_m = params.numbers("radii_m", config.radii_m, 0, Range::open(0.0, 1000.0));
  if (config.radii_m.empty() || config.radii_m.size() > kMaxRadii) {
    params.fail("radii_m", "has " + std::to_string(config.radii_m.size()) + " radii; allowed: 1 to 8 radii in (0, 1000) m");
  }
  config.sensor.sigma_m = params.number("sigma_m", config.sensor.sigma_m, Range::positive());
  config.sensor.min_likelihood = params.number("min_likelihood", config.sensor.min_likelihood, Range::open(0.0, 1.0));
  config.sensor.min_coverage = params.number("min_coverage", config.sensor.min_coverage, {0.0, 1.0, true, false});
  config.sensor.full_coverage = params.number("full_coverage", config.sensor.full_coverage, {0.0, 1.0, true, false});
  if (config.sensor.full_coverage < config.sensor.min_coverage) {
    params.fail("full_coverage", "= " + format_number(config.sensor.full_coverage) + " is below min_coverage = " +
                                     format_number(config.sensor.min_coverage) + "; allowed: [min_coverage, 1]");
  }
  config.sensor.ground_offset_stddev_m =
      params.number("ground_offset_stddev_m", config.sensor.ground_offset_stddev_m, Range::closed(0.0, 100.0));
  config.sensor.shape_sigma_m = params.number("shape_sigma_m", config.sensor.shape_sigma_m, Range::closed(0.0, 100.0));
  config.sensor.shape_edge_step_m =
      params.number("shape_edge_step_m", config.sensor.shape_edge_step_m, Range::closed(0.0, 1000.0));
  config.sensor_model = params.text("sensor_model", config.sensor_model, {"masked", "full_disk"});
  config.match_resolution_m = params.number("match_resolution_m", config.match_resolution_m, Range::open(0.0, 100.0));
  config.odometry_error = params.number("odometry_error", config.odometry_error, Range::closed(0.0, 1.0));
  DistortionConfig& distortion = config.distortion;
  distortion.scale_stddev = config.odometry_error;
  distortion.direction_stddev_rad =
      params.number("odometry_direction_error_rad", distortion.direction_stddev_rad, Range::closed(0.0, 1.0));
  distortion.nodes = static_cast<int>(params.integer("distortion_nodes", distortion.nodes, 1, 15));
  if (distortion.nodes % 2 == 0) {
    params.fail("distortion_nodes", "= " + std::to_string(distortion.nodes) + " is even; allowed: odd, 1 to 15");
  }
  distortion.support_mass = params.number("distortion_support_mass", distortion.support_mass, {0.0, 1.0, true, false});
  distortion.max_cells = static_cast<size_t>(
      params.integer("distortion_max_cells", static_cast<long>(distortion.max_cells), 1, 1'000'000));
  config.min_blur_m = params.number("min_blur_m", config.min_blur_m, Range::closed(0.0, 100.0));
  config.update_distance_m = params.number("update_distance_m", config.update_distance_m, Range::open(0.0, 10000.0));
  config.heading_source = params.text("heading_source", config.heading_source, {"odometry", "imu"});
  config.use_initial_pose = params.flag("use_initial_pose", config.use_initial_pose);
  config.base_height_m = params.number("base_height_m", config.base_height_m, Range::closed(-10.0, 10.0));
  const double max_radius = *std::max_element(config.radii_m.begin(), config.radii_m.end());
  const double default_size = std::max(4.0 * max_radius, kLocalMapMinimumSide) + kLocalMapMargin;
  config.local_map.size_m = params.number("local_map_size_m", default_size, Range::closed(4.0 * max_radius, 2000.0));
  config.local_map.memory_distance_m =
      params.number("local_map_memory_m", config.local_map.memory_distance_m, Range::positive());
  config.local_map.refresh_distance_m =
      params.number("local_map_refresh_m", config.local_map.refresh_distance_m, Range::positive());
  config.local_map.min_point_range_m =
      params.number("min_point_range_m", config.local_map.min_point_range_m, Range::closed(0.0, 100.0));
  config.cache = params.flag("cache", config.cache);
  config.belief_output_max_cells = static_cast<size_t>(
      params.integer("belief_output_max_cells", static_cast<long>(config.belief_output_max_cells), 1, 16'777'216));
  AssessmentConfig& assessment = config.assessment;
  assessment.tracking_radius_m = params.number("tracking_radius_m", assessment.tracking_radius_m, Range::open(0.0, 1000.0));
  assessment.tracking_mass = params.number("tracking_mass", assessment.tracking_mass, Range::open(0.0, 1.0));
  assessment.min_mode_mass = params.number("min_mode_mass", assessment.min_mode_mass, Range::open(0.0, 0.5));
  assessment.lost_area_m2 = params.number("lost_area_m2", assessment.lost_area_m2, Range::positive());
  assessment.max_fit_rms_m = params.number("max_fit_rms_m", assessment.max_fit_rms_m, Range::positive());
  return config;
}

}  // namespace locd::emoi
