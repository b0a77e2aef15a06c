#include "locd/sim_emoi_markov/synthetic_dsm.hpp"

#include <cmath>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

namespace locd::sim::emoi {
namespace {

using locd::emoi::ElevationMap;

std::array<double, 2> interval(const Params& p, const std::string& key, std::array<double, 2> fallback,
                               Range range) {
  const auto v = p.numbers(key, {fallback[0], fallback[1]}, 2, range);
  if (v[1] < v[0]) p.fail(key, "is [" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + "]; allowed: [min, max] with min <= max");
  return {v[0], v[1]};
}

double uniform(std::mt19937_64& rng, const std::array<double, 2>& range) {
  return std::uniform_real_distribution<double>(range[0], range[1])(rng);
}

// Corners of a rotated rectangle in cell coordinates (x = column, y = row).
std::vector<cv::Point> rectangle_cells(const Eigen::Vector2d& centre, double length, double width, double angle,
                                       double resolution) {
  const Eigen::Vector2d u(std::cos(angle), std::sin(angle)), v(-std::sin(angle), std::cos(angle));
  std::vector<cv::Point> corners;
  for (const auto& [a, b] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, std::pair{-1, 1}}) {
    const Eigen::Vector2d p = centre + u * (a * length / 2) + v * (b * width / 2);
    corners.emplace_back(static_cast<int>(std::lround(p.x() / resolution)), static_cast<int>(std::lround(p.y() / resolution)));
  }
  return corners;
}

bool clear_of(const std::vector<Eigen::Vector2d>& keep, const Eigen::Vector2d& centre, double extent, double radius) {
  for (const auto& p : keep) {
    if ((p - centre).norm() < extent + radius) return false;
  }
  return true;
}

}  // namespace

SyntheticDsmConfig parse_world(const Params& world) {
  world.expect_only({"size_m", "resolution", "hills", "buildings", "walls", "trees", "dsm_noise_m", "dsm_nodata_fraction",
                     "keep_clear_radius_m"});
  SyntheticDsmConfig c;
  const auto size = world.numbers("size_m", {c.size_x_m, c.size_y_m}, 2, Range::closed(10.0, 2000.0));
  c.size_x_m = size[0];
  c.size_y_m = size[1];
  c.resolution_m = world.number("resolution", c.resolution_m, Range::closed(0.01, 10.0));
  const Params hills = world.child("hills");
  hills.expect_only({"amplitude_m", "wavelength_m", "octaves", "roughness"});
  c.hill_amplitude_m = hills.number("amplitude_m", c.hill_amplitude_m, Range::closed(0.0, 500.0));
  c.hill_wavelength_m = hills.number("wavelength_m", c.hill_wavelength_m, Range::closed(1.0, 10000.0));
  c.hill_octaves = static_cast<int>(hills.integer("octaves", c.hill_octaves, 1, 12));
  c.hill_roughness = hills.number("roughness", c.hill_roughness, Range::closed(0.0, 1.0));
  const Params buildings = world.child("buildings");
  buildings.expect_only({"count", "size_m", "height_m"});
  c.buildings = static_cast<int>(buildings.integer("count", c.buildings, 0, 100000));
  c.building_size_m = interval(buildings, "size_m", c.building_size_m, Range::closed(0.5, 500.0));
  c.building_height_m = interval(buildings, "height_m", c.building_height_m, Range::closed(0.1, 500.0));
  const Params walls = world.child("walls");
  walls.expect_only({"count", "length_m", "height_m", "thickness_m"});
  c.walls = static_cast<int>(walls.integer("count", c.walls, 0, 100000));
  c.wall_length_m = interval(walls, "length_m", c.wall_length_m, Range::closed(0.5, 1000.0));
  c.wall_height_m = interval(walls, "height_m", c.wall_height_m, Range::closed(0.1, 100.0));
  c.wall_thickness_m = walls.number("thickness_m", c.wall_thickness_m, Range::closed(0.01, 10.0));
  const Params trees = world.child("trees");
  trees.expect_only({"count", "radius_m", "height_m"});
  c.trees = static_cast<int>(trees.integer("count", c.trees, 0, 1000000));
  c.tree_radius_m = interval(trees, "radius_m", c.tree_radius_m, Range::closed(0.1, 50.0));
  c.tree_height_m = interval(trees, "height_m", c.tree_height_m, Range::closed(0.1, 100.0));
  c.keep_clear_radius_m = world.number("keep_clear_radius_m", 3.0, Range::closed(0.0, 100.0));
  return c;
}

SyntheticWorld generate_world(const SyntheticDsmConfig& config, uint64_t seed,
                              const std::vector<Eigen::Vector2d>& keep_clear) {
  std::mt19937_64 rng(seed);
  const double res = config.resolution_m;
  const int width = static_cast<int>(std::lround(config.size_x_m / res));
  const int height = static_cast<int>(std::lround(config.size_y_m / res));
  ElevationMap terrain;
  terrain.geometry.resolution = res;
  terrain.geometry.origin = Eigen::Vector2d::Zero();
  terrain.geometry.width = width;
  terrain.geometry.height = height;
  terrain.elevation = cv::Mat_<float>(height, width, 0.0f);

  // Fractal hills: octaves of bicubically interpolated random grids.
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  double spacing = config.hill_wavelength_m, amplitude = config.hill_amplitude_m;
  for (int octave = 0; octave < config.hill_octaves; ++octave) {
    const int nodes_x = std::max(2, static_cast<int>(std::ceil(config.size_x_m / spacing)) + 1);
    const int nodes_y = std::max(2, static_cast<int>(std::ceil(config.size_y_m / spacing)) + 1);
    cv::Mat_<float> nodes(nodes_y, nodes_x);
    for (auto& v : nodes) v = unit(rng) * static_cast<float>(amplitude);
    cv::Mat_<float> fine;
    cv::resize(nodes, fine, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
    terrain.elevation += fine;
    spacing /= 2.0;
    amplitude *= config.hill_roughness;
  }
  SyntheticWorld world;
  world.terrain = terrain;
  world.surface = terrain;
  world.surface.elevation = terrain.elevation.clone();
  cv::Mat_<float>& surface = world.surface.elevation;

  const Eigen::Vector2d extent(config.size_x_m, config.size_y_m);
  auto random_centre = [&] {
    return Eigen::Vector2d(std::uniform_real_distribution<double>(0, extent.x())(rng),
                           std::uniform_real_distribution<double>(0, extent.y())(rng));
  };
  auto place = [&](double reach) {  // a centre whose object stays clear of the path
    for (int attempt = 0; attempt < 50; ++attempt) {
      const Eigen::Vector2d c = random_centre();
      if (clear_of(keep_clear, c, reach, config.keep_clear_radius_m)) return std::optional<Eigen::Vector2d>(c);
    }
    return std::optional<Eigen::Vector2d>();
  };
  // Buildings: flat roofs above the highest ground under them.
  for (int i = 0; i < config.buildings; ++i) {
    const double length = uniform(rng, config.building_size_m), breadth = uniform(rng, config.building_size_m);
    const double angle = std::uniform_real_distribution<double>(0, M_PI)(rng);
    const double tall = uniform(rng, config.building_height_m);
    const auto centre = place(0.5 * std::hypot(length, breadth));
    if (!centre) continue;
    cv::Mat_<uchar> mask(height, width, uchar(0));
    cv::fillConvexPoly(mask, rectangle_cells(*centre, length, breadth, angle, res), cv::Scalar(1));
    double ground = 0.0;
    cv::minMaxLoc(terrain.elevation, nullptr, &ground, nullptr, nullptr, mask);
    const float roof = static_cast<float>(ground + tall);
    const cv::Mat raised = cv::max(surface, static_cast<double>(roof));
    raised.copyTo(surface, mask);
  }
  // Walls: thin, following the ground.
  for (int i = 0; i < config.walls; ++i) {
    const double length = uniform(rng, config.wall_length_m);
    const double angle = std::uniform_real_distribution<double>(0, M_PI)(rng);
    const float tall = static_cast<float>(uniform(rng, config.wall_height_m));
    const auto centre = place(0.5 * length);
    if (!centre) continue;
    cv::Mat_<uchar> mask(height, width, uchar(0));
    cv::fillConvexPoly(mask, rectangle_cells(*centre, length, std::max(config.wall_thickness_m, res), angle, res),
                       cv::Scalar(1));
    for (int r = 0; r < height; ++r) {
      const uchar* m = mask.ptr<uchar>(r);
      if (!cv::countNonZero(mask.row(r))) continue;
      for (int c = 0; c < width; ++c) {
        if (m[c]) surface(r, c) = std::max(surface(r, c), terrain.elevation(r, c) + tall);
      }
    }
  }
  // Trees: domes.
  for (int i = 0; i < config.trees; ++i) {
    const double radius = uniform(rng, config.tree_radius_m);
    const double tall = uniform(rng, config.tree_height_m);
    const auto centre = place(radius);
    if (!centre) continue;
    const int cr = static_cast<int>(centre->y() / res), cc = static_cast<int>(centre->x() / res);
    const int reach = static_cast<int>(std::ceil(radius / res));
    for (int r = std::max(0, cr - reach); r <= std::min(height - 1, cr + reach); ++r) {
      for (int c = std::max(0, cc - reach); c <= std::min(width - 1, cc + reach); ++c) {
        const double d = std::hypot((c + 0.5) * res - centre->x(), (r + 0.5) * res - centre->y());
        if (d >= radius) continue;
        const float top = terrain.elevation(r, c) + static_cast<float>(tall * std::sqrt(1.0 - (d / radius) * (d / radius)));
        surface(r, c) = std::max(surface(r, c), top);
      }
    }
  }
  return world;
}

ElevationMap noisy_dsm(const ElevationMap& surface, double noise_stddev_m, double nodata_fraction, uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x5eed5eedULL);
  ElevationMap dsm = surface;
  dsm.elevation = surface.elevation.clone();
  if (noise_stddev_m > 0) {
    std::normal_distribution<float> noise(0.0f, static_cast<float>(noise_stddev_m));
    for (auto& v : dsm.elevation) v += noise(rng);
  }
  if (nodata_fraction > 0) {
    const int patch = std::max(1, static_cast<int>(std::lround(2.0 / surface.geometry.resolution)));
    const size_t wanted = static_cast<size_t>(nodata_fraction * static_cast<double>(surface.geometry.size()));
    size_t holes = 0;
    std::uniform_int_distribution<int> row(0, dsm.geometry.height - patch), col(0, dsm.geometry.width - patch);
    while (holes < wanted) {
      const cv::Rect box(col(rng), row(rng), patch, patch);
      dsm.elevation(box).setTo(std::numeric_limits<float>::quiet_NaN());
      holes += static_cast<size_t>(patch) * patch;
    }
  }
  return dsm;
}

double elevation_at(const ElevationMap& map, const Eigen::Vector2d& position) {
  const double res = map.geometry.resolution;
  const double fx = (position.x() - map.geometry.origin.x()) / res - 0.5;
  const double fy = (position.y() - map.geometry.origin.y()) / res - 0.5;
  const int c0 = static_cast<int>(std::floor(fx)), r0 = static_cast<int>(std::floor(fy));
  if (c0 < 0 || r0 < 0 || c0 + 1 >= map.geometry.width || r0 + 1 >= map.geometry.height) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double ax = fx - c0, ay = fy - r0;
  const auto& e = map.elevation;
  return (1 - ay) * ((1 - ax) * e(r0, c0) + ax * e(r0, c0 + 1)) + ay * ((1 - ax) * e(r0 + 1, c0) + ax * e(r0 + 1, c0 + 1));
}

}  // namespace locd::sim::emoi
