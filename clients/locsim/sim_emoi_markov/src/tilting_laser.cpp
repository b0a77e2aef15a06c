#include "locd/sim_emoi_markov/tilting_laser.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace locd::sim::emoi {

TiltingLaserConfig parse_laser(const Params& laser) {
  laser.expect_only({"rate_hz", "beams", "fov_deg", "range_max_m", "range_min_m", "range_stddev_m", "tilt_deg",
                     "tilt_period_s", "mount"});
  TiltingLaserConfig c;
  c.rate_hz = laser.number("rate_hz", c.rate_hz, Range::open(0.0, 1000.0));
  c.beams = static_cast<int>(laser.integer("beams", c.beams, 2, 8192));
  c.fov_rad = laser.number("fov_deg", 180.0, Range::open(0.0, 360.0)) * M_PI / 180.0;
  c.range_max_m = laser.number("range_max_m", c.range_max_m, Range::open(0.0, 1000.0));
  c.range_min_m = laser.number("range_min_m", c.range_min_m, Range::closed(0.0, c.range_max_m));
  c.range_stddev_m = laser.number("range_stddev_m", c.range_stddev_m, Range::closed(0.0, 10.0));
  const auto tilt = laser.numbers("tilt_deg", {0.0, 20.0}, 2, Range::closed(-90.0, 90.0));
  c.tilt_min_rad = tilt[0] * M_PI / 180.0;
  c.tilt_max_rad = tilt[1] * M_PI / 180.0;
  c.tilt_period_s = laser.number("tilt_period_s", c.tilt_period_s, Range::open(0.0, 1000.0));
  const Params mount = laser.child("mount");
  mount.expect_only({"x_tilt", "z_tilt", "x_laser", "z_laser"});
  c.x_tilt = mount.number("x_tilt", c.x_tilt, Range::closed(-10, 10));
  c.z_tilt = mount.number("z_tilt", c.z_tilt, Range::closed(-10, 10));
  c.x_laser = mount.number("x_laser", c.x_laser, Range::closed(-10, 10));
  c.z_laser = mount.number("z_laser", c.z_laser, Range::closed(-10, 10));
  return c;
}

double tilt_at(const TiltingLaserConfig& config, double time_s) {
  const double phase = std::fmod(time_s, config.tilt_period_s) / config.tilt_period_s;
  const double triangle = phase < 0.5 ? 2.0 * phase : 2.0 - 2.0 * phase;
  return config.tilt_min_rad + (config.tilt_max_rad - config.tilt_min_rad) * triangle;
}

std::optional<double> cast_heightfield(const locd::emoi::ElevationMap& surface, const Eigen::Vector3d& origin,
                                       const Eigen::Vector3d& direction, double max_range) {
  const auto& g = surface.geometry;
  const double res = g.resolution;
  const double gx = (origin.x() - g.origin.x()) / res, gy = (origin.y() - g.origin.y()) / res;
  int cx = static_cast<int>(std::floor(gx)), cy = static_cast<int>(std::floor(gy));
  if (!g.contains(cy, cx)) return std::nullopt;
  const double dx = direction.x(), dy = direction.y(), dz = direction.z();
  const int step_x = dx > 0 ? 1 : -1, step_y = dy > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double delta_x = dx != 0 ? res / std::abs(dx) : inf, delta_y = dy != 0 ? res / std::abs(dy) : inf;
  double next_x = dx != 0 ? ((dx > 0 ? (cx + 1 - gx) : (gx - cx)) * res) / std::abs(dx) : inf;
  double next_y = dy != 0 ? ((dy > 0 ? (cy + 1 - gy) : (gy - cy)) * res) / std::abs(dy) : inf;
  double t_enter = 0.0;
  while (t_enter < max_range) {
    const double t_exit = std::min({next_x, next_y, max_range});
    const double h = surface.elevation(cy, cx);
    if (std::isfinite(h)) {
      const double z_enter = origin.z() + dz * t_enter, z_exit = origin.z() + dz * t_exit;
      if (z_enter <= h) return t_enter;  // a vertical face (or the ground under the sensor)
      if (z_exit <= h) return t_enter + (z_enter - h) / (z_enter - z_exit) * (t_exit - t_enter);
    }
    if (t_exit >= max_range) break;
    if (next_x < next_y) {
      cx += step_x;
      t_enter = next_x;
      next_x += delta_x;
    } else {
      cy += step_y;
      t_enter = next_y;
      next_y += delta_y;
    }
    if (!g.contains(cy, cx)) return std::nullopt;
  }
  return std::nullopt;
}

LaserScan simulate_scan(const TiltingLaserConfig& config, const locd::emoi::ElevationMap& surface,
                        const Eigen::Isometry3d& T_map_base, double time_s, int64_t stamp_ns, std::mt19937_64& rng) {
  LaserScan scan;
  scan.header.stamp_ns = stamp_ns;
  scan.header.frame_id = "laser";
  // The mount, composed here rather than by the plugin's tilting_laser_pose (the truth must not
  // share the plugin's kinematics): the tilt axis at (x_tilt, 0, z_tilt), turned about y by the
  // tilt angle, the sensing point at (x_laser, 0, z_laser) in the tilting frame.
  scan.sensor_pose = Eigen::Translation3d(config.x_tilt, 0.0, config.z_tilt) *
                     Eigen::AngleAxisd(tilt_at(config, time_s), Eigen::Vector3d::UnitY()) *
                     Eigen::Translation3d(config.x_laser, 0.0, config.z_laser);
  scan.angle_min = static_cast<float>(-config.fov_rad / 2);
  scan.angle_increment = static_cast<float>(config.fov_rad / (config.beams - 1));
  scan.range_min = static_cast<float>(config.range_min_m);
  scan.range_max = static_cast<float>(config.range_max_m);
  scan.ranges.resize(config.beams);
  const Eigen::Isometry3d T_map_laser = T_map_base * scan.sensor_pose;
  std::normal_distribution<double> noise(0.0, config.range_stddev_m);
  for (int i = 0; i < config.beams; ++i) {
    const double alpha = scan.angle(i);
    const Eigen::Vector3d direction = T_map_laser.linear() * Eigen::Vector3d(std::cos(alpha), std::sin(alpha), 0.0);
    const auto range = cast_heightfield(surface, T_map_laser.translation(), direction, config.range_max_m);
    const double measured = range ? *range + (config.range_stddev_m > 0 ? noise(rng) : 0.0) : 0.0;
    scan.ranges[i] = (range && measured <= config.range_max_m) ? static_cast<float>(measured) : 0.0f;
  }
  return scan;
}

}  // namespace locd::sim::emoi
