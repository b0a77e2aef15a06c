#include "locd/sim_icp_explorer/scanner3d.hpp"

#include <algorithm>
#include <cmath>

namespace locd::sim {

Scanner3DConfig Scanner3DConfig::from_params(const Params& p) {
  p.expect_only({"azimuth_steps", "elevation_steps", "elevation_min_deg", "elevation_max_deg", "max_range",
                 "range_stddev", "intensity_stddev", "incidence_shading", "sensor_height", "with_intensity"});
  Scanner3DConfig c;
  c.azimuth_steps = static_cast<int>(p.integer("azimuth_steps", c.azimuth_steps, 8, 8192));
  c.elevation_steps = static_cast<int>(p.integer("elevation_steps", c.elevation_steps, 1, 4096));
  c.elevation_min_deg = p.number("elevation_min_deg", c.elevation_min_deg, Range::closed(-89.0, 89.0));
  c.elevation_max_deg = p.number("elevation_max_deg", c.elevation_max_deg, Range::closed(-89.0, 89.0));
  if (c.elevation_max_deg <= c.elevation_min_deg)
    p.fail("elevation_max_deg", "must exceed elevation_min_deg (" + std::to_string(c.elevation_min_deg) + ")");
  c.max_range = p.number("max_range", c.max_range, Range{0.0, 1000.0, true, false});
  c.range_stddev = p.number("range_stddev", c.range_stddev, Range::closed(0.0, 1.0));
  c.intensity_stddev = p.number("intensity_stddev", c.intensity_stddev, Range::closed(0.0, 1.0));
  c.incidence_shading = p.number("incidence_shading", c.incidence_shading, Range::closed(0.0, 1.0));
  c.sensor_height = p.number("sensor_height", c.sensor_height, Range::closed(0.0, 10.0));
  c.with_intensity = p.flag("with_intensity", c.with_intensity);
  return c;
}

Scanner3D::Scanner3D(const Scanner3DConfig& config) : config_(config) {
  directions_.reserve(static_cast<size_t>(config.azimuth_steps) * config.elevation_steps);
  for (int e = 0; e < config.elevation_steps; ++e) {
    const double elevation = config.elevation_steps == 1
                                 ? config.elevation_min_deg * M_PI / 180
                                 : (config.elevation_min_deg + (config.elevation_max_deg - config.elevation_min_deg) *
                                                                   e / (config.elevation_steps - 1)) *
                                       M_PI / 180;
    for (int a = 0; a < config.azimuth_steps; ++a) {
      const double azimuth = 2.0 * M_PI * a / config.azimuth_steps;
      directions_.emplace_back(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                               std::sin(elevation));
    }
  }
}

double Scanner3D::azimuth_step() const { return 2.0 * M_PI / config_.azimuth_steps; }
double Scanner3D::elevation_step() const {
  return config_.elevation_steps > 1
             ? (config_.elevation_max_deg - config_.elevation_min_deg) * M_PI / 180 / (config_.elevation_steps - 1)
             : azimuth_step();
}

Eigen::Isometry3d Scanner3D::sensor_in_base() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0, 0, config_.sensor_height);
  return T;
}

SimulatedScan Scanner3D::scan(const IndoorWorld& world, const Eigen::Isometry3d& robot_in_world, double t,
                              int64_t stamp_ns, std::mt19937_64& rng) const {
  const Eigen::Isometry3d sensor_in_world = robot_in_world * sensor_in_base();
  const Eigen::Matrix3d R = sensor_in_world.linear();
  const Eigen::Vector3d origin = sensor_in_world.translation();
  std::normal_distribution<double> normal(0.0, 1.0);
  SimulatedScan out;
  out.cloud.header.stamp_ns = stamp_ns;
  out.cloud.header.frame_id = "scanner";
  out.cloud.sensor_pose = sensor_in_base();
  out.sensor_in_world = origin.cast<float>();
  out.cloud.points.reserve(directions_.size());
  if (config_.with_intensity) out.cloud.intensity.reserve(directions_.size());
  out.hit_object.reserve(directions_.size());
  out.points_in_world.reserve(directions_.size());
  for (const Eigen::Vector3d& d_sensor : directions_) {
    const Eigen::Vector3d d = R * d_sensor;
    const auto hit = world.cast(origin, d, config_.max_range, t);
    if (!hit) continue;
    const double range = hit->range + config_.range_stddev * normal(rng);
    out.cloud.points.push_back((d_sensor * range).cast<float>());
    out.points_in_world.push_back((origin + d * hit->range).cast<float>());
    out.hit_object.push_back(hit->object);
    if (config_.with_intensity) {
      const double shade = 1.0 - config_.incidence_shading + config_.incidence_shading * std::abs(hit->normal.dot(d));
      const double intensity = hit->reflectivity * shade + config_.intensity_stddev * normal(rng);
      out.cloud.intensity.push_back(static_cast<float>(std::clamp(intensity, 0.0, 1.0)));
    }
  }
  return out;
}

}  // namespace locd::sim
