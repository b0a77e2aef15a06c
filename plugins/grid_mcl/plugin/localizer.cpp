#include "localizer.hpp"

#include <cmath>
#include <filesystem>
#include <limits>

#include "locd/sdk/initial_pose.hpp"
#include "params.hpp"

namespace locd::grid_mcl {
namespace {

// The largest grid the grid topic carries (idl/locd.idl, GridMap.cells).
constexpr size_t kMaxGridCells = 16'777'216;

// The published covariance is the cluster's, but never below these stddevs: a converged set
// shrinks to a few millimetres while the estimate carries the map's cell-size error (issue 15:
// without the floor 45 % of the warehouse estimates lay outside their 99 % ellipse, mean NEES 91).
// One cell (issue 21): a real map is no finer than its cells and never matches its building; at
// 0.4 cells (chosen on the simulator's worlds) 3.8-4.5 % of the poses on freiburg-079 lay outside
// their 99 % ellipse while tracking, at 1 cell none (bench/realdata, seeds 1-5).
constexpr double kPositionStddevFloorCells = 1.0;  // of the map's resolution: 5 cm at 5 cm cells
constexpr double kHeadingStddevFloor = 0.005;      // rad

Eigen::Matrix3d diagonal_variance(const Eigen::Vector3d& stddev) { return stddev.cwiseAbs2().asDiagonal(); }

}  // namespace

void GridMclLocalizer::configure(const PluginContext& context, const Params& params) {
  std::vector<std::string> ignored;
  config_ = parse_config(params, context.limits, &ignored);
  if (!ignored.empty()) {
    std::string list;
    for (const std::string& key : ignored) list += (list.empty() ? "" : ", ") + key;
    context.log(LogLevel::kInfo, "grid_mcl: AMCL beam skipping settings ignored (do_beamskip is false): " + list);
  }
  std::filesystem::path yaml_file;
  try {
    yaml_file = context.maps.resolve(config_.map);
  } catch (const ConfigError& e) {
    params.fail("map", "= '" + config_.map + "' cannot be used: " + e.what());
  }
  // The image a map YAML names is relative to the YAML, and must lie in the map directories too.
  const std::filesystem::path folder = std::filesystem::path(config_.map).parent_path();
  const MapResolver& maps = context.maps;
  auto map = load_shared_map(
      yaml_file, [&](const std::string& image) { return maps.resolve((folder / image).lexically_normal().string()); },
      context.limits.max_map_cells);
  if (config_.publish_map && map->map.geometry().size() > kMaxGridCells) {
    context.log(LogLevel::kWarning, "grid_mcl: map '" + config_.map + "' has more cells than the grid topic carries (" +
                                        std::to_string(kMaxGridCells) + "); it is not published");
  }
  filter_ = std::make_unique<GridParticleFilter>(config_, std::move(map));
  if (config_.initial_pose) {
    filter_->set_pose(*config_.initial_pose, diagonal_variance(config_.initial_stddev));
  } else {
    filter_->set_global();
  }
  odometry_ = PoseHistory();
  waiting_.reset();
}

void GridMclLocalizer::set_pose(const PoseEstimate& pose) {
  const PlanarInitialPose start = planar_initial_pose(pose, "grid_mcl");
  const Eigen::Matrix3d& cov = start.covariance;
  const double global = config_.global_localization_stddev * config_.global_localization_stddev;
  if (start.covariance_finite && std::max(cov(0, 0), cov(1, 1)) >= global) {
    filter_->set_global();
    waiting_.reset();
    state_reported_ = false;
    return;
  }
  filter_->set_pose(start.mean, start.covariance_positive_definite ? cov : diagonal_variance(config_.initial_stddev));
  waiting_.reset();
  state_reported_ = false;
}

UpdateResult GridMclLocalizer::update(const Measurement& measurement) {
  if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    odometry_.add(odometry->header.stamp_ns, odometry->pose);
    UpdateResult result;
    if (waiting_ && odometry->header.stamp_ns >= waiting_->header.stamp_ns) {
      const LaserScan scan = std::move(*waiting_);
      waiting_.reset();
      correct(scan, result);
    }
    result.estimate = make_estimate(odometry->header);
    // The first pose after a start (a global one included) carries its state.
    if (!state_reported_ && result.estimate) result.localization = filter_->assessment();
    state_reported_ = state_reported_ || result.localization.has_value();
    return result;
  }
  if (const auto* scan = std::get_if<LaserScan>(&measurement)) return on_scan(*scan);
  throw InputError(std::string("grid_mcl consumes odometry and scans only, not ") + kind_name(kind_of(measurement)));
}

UpdateResult GridMclLocalizer::on_scan(const LaserScan& scan) {
  UpdateResult result;
  if (waiting_) {  // no odometry came after it: the newest
    const LaserScan earlier = std::move(*waiting_);
    waiting_.reset();
    correct(earlier, result);
  }
  if (odometry_.size() > 0 && odometry_.newest_stamp() < scan.header.stamp_ns) {
    waiting_ = scan;
  } else {
    correct(scan, result);
  }
  result.estimate = make_estimate(scan.header);
  result.localization = filter_->assessment();
  state_reported_ = true;
  return result;
}

Pose2 GridMclLocalizer::odometry_at(int64_t stamp_ns) const {
  if (odometry_.size() == 0) return Pose2();
  // Older than every sample kept: the oldest (the history holds hundreds of samples).
  const auto pose = odometry_.at(std::max(stamp_ns, odometry_.oldest_stamp()));
  return Pose2::from_isometry(*pose);
}

void GridMclLocalizer::correct(const LaserScan& scan, UpdateResult& result) {
  const CorrectionReport report = filter_->correct(scan, odometry_at(scan.header.stamp_ns));
  result.localization = filter_->assessment();
  if (!report.updated) return;
  Diagnostics& d = result.diagnostics;
  d.values = {{"particles", static_cast<double>(filter_->particles().size())},
              {"beams", static_cast<double>(report.beams)},
              {"effective_sample_size", report.effective_sample_size},
              {"average_likelihood", report.average_likelihood},
              {"likelihood_slow", filter_->recovery().slow()},
              {"likelihood_fast", filter_->recovery().fast()},
              {"injection_probability", report.injection_probability},
              {"injected", static_cast<double>(report.injected)},
              {"scan_fit", report.fit},
              {"scan_known", report.known},
              {"see_through", report.see_through}};
  if (const auto e = filter_->estimate()) d.values.push_back({"cluster_mass", e->mass});
  d.particles = diagnostic_particles(filter_->particles(), config_.diagnostics_particles);
}

std::optional<PoseEstimate> GridMclLocalizer::make_estimate(const Header& header) const {
  const auto e = filter_->estimate_at(odometry_at(header.stamp_ns));
  if (!e) return std::nullopt;
  PoseEstimate out;
  out.header.stamp_ns = header.stamp_ns;
  out.header.frame_id = "map";
  out.pose = e->pose.to_isometry();
  const double resolution = filter_->map().map.geometry().resolution;
  const Eigen::Matrix3d covariance =
      floor_covariance(e->covariance, kPositionStddevFloorCells * resolution, kHeadingStddevFloor);
  out.covariance = pose_covariance(covariance);
  return out;
}

UpdateResult GridMclLocalizer::initial_outputs() const {
  UpdateResult result;
  if (!config_.publish_map || !filter_) return result;
  const OccupancyMap& map = filter_->map().map;
  const GridGeometry& g = map.geometry();
  if (g.size() > kMaxGridCells) return result;
  GridLayer layer;
  layer.layer = "occupancy";
  layer.resolution = g.resolution;
  layer.origin = g.origin;
  layer.width = g.width;
  layer.height = g.height;
  layer.cells.resize(g.size());
  for (size_t i = 0; i < g.size(); ++i) {
    const int8_t v = map.cells()[i];
    layer.cells[i] = v < 0 ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(v) / 100.0f;
  }
  result.grid = std::move(layer);
  result.localization = filter_->assessment();
  return result;
}

}  // namespace locd::grid_mcl
