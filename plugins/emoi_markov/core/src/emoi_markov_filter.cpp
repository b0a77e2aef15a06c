#include "locd/emoi_markov/emoi_markov_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "locd/emoi_markov/emoi_cache.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/initial_pose.hpp"

namespace locd::emoi {
namespace {

// The estimate's spread on what the belief grid does not hold: height (m^2, the DSM's cell plus
// the base height's error), roll and pitch (rad^2, the IMU's), heading (the odometry's, rad).
constexpr double kHeightVariance = 1.0;
constexpr double kTiltVariance = 0.01;
constexpr double kHeadingStddev = 0.05;

std::string format_number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

GridLayer pooled_layer(const cv::Mat_<float>& cells, const GridGeometry& geometry, size_t max_cells,
                       const std::string& name, bool keep_mass) {
  const size_t total = static_cast<size_t>(cells.rows) * static_cast<size_t>(cells.cols);
  int factor = 1;
  while (total / (static_cast<size_t>(factor) * factor) > max_cells) ++factor;
  cv::Mat_<float> pooled = cells;
  if (factor > 1) {
    const int rows = cells.rows / factor, cols = cells.cols / factor;
    cv::resize(cells(cv::Rect(0, 0, cols * factor, rows * factor)), pooled, cv::Size(cols, rows), 0, 0,
               cv::INTER_AREA);
    if (keep_mass) pooled *= static_cast<double>(factor) * factor;
  }
  GridLayer layer;
  layer.layer = name;
  layer.resolution = geometry.resolution * factor;
  layer.origin = geometry.origin;
  layer.width = pooled.cols;
  layer.height = pooled.rows;
  layer.cells.assign(pooled.begin(), pooled.end());
  return layer;
}

cv::Mat_<uchar> cells_with_data(const ElevationMap& dsm) {
  cv::Mat_<uchar> support(dsm.elevation.size(), uchar(0));
  for (int r = 0; r < support.rows; ++r) {
    for (int c = 0; c < support.cols; ++c) support(r, c) = std::isfinite(dsm.elevation(r, c)) ? 1 : 0;
  }
  return support;
}

}  // namespace

EmoiMarkovFilter::EmoiMarkovFilter(const EmoiMarkovConfig& config, ElevationMap dsm, size_t max_map_cells,
                                   const ProgressCallback& progress)
    : config_(config) {
  if (dsm.geometry.size() > max_map_cells) {
    throw ConfigError("DSM '" + config.map + "' has " + std::to_string(dsm.geometry.size()) +
                      " cells; allowed: at most limits.max_map_cells = " + std::to_string(max_map_cells));
  }
  if (config.sensor_model == "full_disk") {
    const std::optional<std::filesystem::path> cache_directory =
        config.cache ? std::optional<std::filesystem::path>(default_cache_directory()) : std::nullopt;
    LayersSource source = load_or_compute_layers(dsm, config.radii_m, cache_directory, progress);
    layers_from_cache_ = source.from_cache;
    layers_key_ = source.key;
    layers_ = std::move(source.layers);
    grid_ = std::make_unique<MarkovGrid>(dsm.geometry, layers_support(*layers_));
  } else {
    matcher_ = std::make_unique<MaskedEmoiMatcher>(dsm, config.radii_m, config.match_resolution_m,
                                                   config.sensor.shape_edge_step_m);
    grid_ = std::make_unique<MarkovGrid>(dsm.geometry, cells_with_data(dsm));
  }
  config_.distortion.scale_stddev = config.odometry_error;
  hypotheses_ = distortion_hypotheses(config_.distortion.scale_stddev, config_.distortion.direction_stddev_rad,
                                      config_.distortion.nodes);
  dsm_elevation_ = dsm.elevation;
  config_.local_map.resolution = dsm.geometry.resolution;
  local_map_ = std::make_unique<LocalElevationMap>(config_.local_map);
  summary_ = grid_->summary();
  assessment_.estimate = summary_.mode;
  assessment_.localization = {LocalizationState::kLost, "no sensor update yet"};
}

void EmoiMarkovFilter::set_pose(const PoseEstimate& pose) {
  const PlanarInitialPose start = planar_initial_pose(pose, "emoi_markov");
  if (!start.covariance_finite) throw InputError("emoi_markov: initial covariance (x, y, yaw entries) is not finite");
  const Eigen::Vector2d xy(start.mean.x, start.mean.y);
  int row = 0, col = 0;
  const GridGeometry& g = grid_->geometry();
  if (!g.index_of(xy, row, col)) {
    throw InputError("initial pose (" + format_number(xy.x()) + ", " + format_number(xy.y()) +
                     ") lies outside the DSM [" + format_number(g.origin.x()) + ", " +
                     format_number(g.origin.x() + g.width * g.resolution) + "] x [" + format_number(g.origin.y()) +
                     ", " + format_number(g.origin.y() + g.height * g.resolution) + "]");
  }
  const double yaw = start.mean.theta;
  if (last_odometry_) {
    yaw_offset_ = normalize_angle(yaw - yaw_of(last_odometry_->pose.linear()));
  } else {
    pending_set_pose_yaw_ = yaw;
  }
  if (config_.use_initial_pose) {
    const double stddev = std::sqrt(std::max({start.covariance(0, 0), start.covariance(1, 1), 0.0}));
    grid_->set_gaussian(xy, stddev);
    summary_ = grid_->summary();
    assessment_ = assess_belief(grid_->belief(), grid_->occupied(), grid_->geometry(), config_.assessment);
    fit_cells_.clear();
    fit_residual_.clear();
    apply_fit(assessment_, fit_at(assessment_.estimate), config_.assessment);
    pending_shift_.setZero();
    pending_travel_m_ = 0.0;
  }
}

double EmoiMarkovFilter::fit_at(const Eigen::Vector2d& position) const {
  int row = 0, col = 0;
  if (fit_residual_.empty() || !matcher_->surface().geometry.index_of(position, row, col)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const auto at = std::find(fit_cells_.begin(), fit_cells_.end(), cv::Point(col, row));
  if (at == fit_cells_.end()) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(static_cast<double>(fit_residual_[static_cast<size_t>(at - fit_cells_.begin())]));
}

Eigen::Isometry3d EmoiMarkovFilter::base_in_odom() const {
  Eigen::Isometry3d T = last_odometry_->pose;
  if (imu_orientation_) {
    // Attitude (roll, pitch) from the IMU, as the paper's inclinometer; yaw from odometry.
    const Eigen::Vector3d rpy = roll_pitch_yaw(imu_orientation_->toRotationMatrix());
    T.linear() = rpy_rotation(yaw_of(last_odometry_->pose.linear()), rpy.y(), rpy.x());
  }
  return T;
}

double EmoiMarkovFilter::map_heading() const {
  if (config_.heading_source == "imu" && imu_orientation_) return yaw_of(imu_orientation_->toRotationMatrix());
  const double odom_yaw = last_odometry_ ? yaw_of(last_odometry_->pose.linear()) : 0.0;
  return normalize_angle(odom_yaw + yaw_offset_);
}

void EmoiMarkovFilter::add_odometry(const Odometry& odometry) {
  if (last_odometry_) {
    const double heading_offset = normalize_angle(map_heading() - yaw_of(last_odometry_->pose.linear()));
    const Eigen::Vector2d step = (odometry.pose.translation() - last_odometry_->pose.translation()).head<2>();
    pending_shift_ += Eigen::Rotation2Dd(heading_offset) * step;
    pending_travel_m_ += step.norm();
    travelled_m_ += step.norm();
  }
  last_odometry_ = odometry;
  local_map_->record_pose(travelled_m_, odometry.pose.translation().head<2>());
  if (pending_set_pose_yaw_) {
    yaw_offset_ = normalize_angle(*pending_set_pose_yaw_ - yaw_of(odometry.pose.linear()));
    pending_set_pose_yaw_.reset();
  }
}

void EmoiMarkovFilter::add_imu(const Imu& imu) { imu_orientation_ = imu.orientation.normalized(); }

std::optional<FilterUpdateReport> EmoiMarkovFilter::add_scan(const LaserScan& scan) {
  return insert("scan", [&](const Eigen::Isometry3d& base) { return local_map_->insert_scan(scan, base, travelled_m_); });
}

std::optional<FilterUpdateReport> EmoiMarkovFilter::add_cloud(const PointCloud& cloud) {
  return insert("cloud", [&](const Eigen::Isometry3d& base) { return local_map_->insert_cloud(cloud, base, travelled_m_); });
}

std::optional<FilterUpdateReport> EmoiMarkovFilter::insert(
    const char* what, const std::function<InsertStatistics(const Eigen::Isometry3d& base_in_odom)>& into_local_map) {
  if (!last_odometry_) {
    throw InputError(std::string(what) + " before any odometry: the local elevation map needs the robot's pose");
  }
  local_map_->follow(last_odometry_->pose.translation().head<2>());
  rejected_points_ += into_local_map(base_in_odom()).invalid;
  return after_insert();
}

std::optional<FilterUpdateReport> EmoiMarkovFilter::after_insert() {
  if (pending_travel_m_ < config_.update_distance_m) return std::nullopt;
  FilterUpdateReport report;
  // Table 1, action: shift by the odometry, blur by its error.
  const bool hypotheses = matcher_ && hypotheses_.size() > 1;  // odometry_distortion.hpp
  const cv::Mat_<float> previous_coarse =
      hypotheses ? matcher_->pool(grid_->belief(), grid_->occupied()) : cv::Mat_<float>();
  const Eigen::Vector2d shift = pending_shift_;
  const double travel = pending_travel_m_;
  const double blur = std::hypot(config_.odometry_error * pending_travel_m_, config_.min_blur_m);
  report.motion = grid_->motion_update(pending_shift_, blur);
  if (report.motion.reset) ++belief_resets_;
  pending_shift_.setZero();
  pending_travel_m_ = 0.0;
  // Table 1, perception: the robot's EMOI over its observed cells, eq. 8, normalise.
  last_robot_emoi_.clear();
  report.sensor.evidence = 1.0;
  const auto any_weight = [&] {
    return std::any_of(report.weights.begin(), report.weights.end(), [](double w) { return w > 0.0; });
  };
  if (matcher_) {
    const WindowLikelihood likelihood = masked_likelihood(previous_coarse, shift, travel, blur, report.weights);
    if (any_weight()) report.sensor = grid_->sensor_update_likelihood(likelihood.values, likelihood.window, likelihood.outside);
  } else {
    const cv::Mat_<float> log_likelihood = full_disk_log_likelihood_now(report.weights);
    if (any_weight()) report.sensor = grid_->sensor_update(log_likelihood, config_.sensor.min_likelihood);
  }
  summary_ = grid_->summary();
  ++sensor_updates_;
  assessment_ = assess_belief(grid_->belief(), grid_->occupied(), grid_->geometry(), config_.assessment);
  apply_fit(assessment_, fit_at(assessment_.estimate), config_.assessment);
  if (report.motion.reset || (report.sensor.applied && !(report.sensor.evidence > 0.0))) {
    assessment_.localization = {LocalizationState::kLost, "belief reset to uniform: no mass left after the update"};
  }
  report.robot_emoi = last_robot_emoi_;
  report.distortion = distortion_;
  return report;
}

cv::Mat_<float> EmoiMarkovFilter::full_disk_log_likelihood_now(std::vector<double>& weights) {
  const Eigen::Vector3d position = last_odometry_->pose.translation();
  const double ground = position.z() - config_.base_height_m;
  last_robot_emoi_ = local_map_->emoi(position.head<2>(), ground, config_.radii_m, travelled_m_);
  EmoiObservation z;
  for (const auto& e : last_robot_emoi_) {
    z.emoi.push_back(e.emoi);
    z.coverage.push_back(e.coverage);
  }
  return full_disk_log_likelihood(*layers_, z, config_.sensor, &weights);
}

EmoiMarkovFilter::WindowLikelihood EmoiMarkovFilter::masked_likelihood(const cv::Mat_<float>& previous_coarse,
                                                                       const Eigen::Vector2d& shift, double travel,
                                                                       double blur, std::vector<double>& weights) {
  const Eigen::Vector3d position = last_odometry_->pose.translation();
  const double ground = position.z() - config_.base_height_m;
  const double heading_offset = normalize_angle(map_heading() - yaw_of(last_odometry_->pose.linear()));
  // The remembered cells once, far enough for the largest hypothesis; binned per hypothesis.
  double max_correction = 0.0;
  for (const DistortionHypothesis& h : hypotheses_) {
    max_correction = std::max(max_correction, (h.transform - Eigen::Matrix2d::Identity()).norm());
  }
  if (previous_coarse.empty()) max_correction = 0.0;
  const LocalElevationMap::PatchCells cells = local_map_->patch_cells(
      position.head<2>(),
      local_map_->patch_reach_m(position.head<2>(), matcher_->cell_m(), matcher_->patch_radius(), max_correction),
      travelled_m_);
  const PatchBinner binner(cells, heading_offset, matcher_->cell_m(), matcher_->patch_radius(), ground, max_correction);
  auto patch_under = [&](const Eigen::Matrix2d& distortion) { return binner.patch(distortion); };
  auto keep_robot_side = [&](const MaskedEmoiMatcher::Match& match) {
    for (size_t i = 0; i < match.robot_emoi.size(); ++i) {
      last_robot_emoi_.push_back({match.robot_emoi[i], match.coverage[i], match.observed[i]});
    }
  };
  const int fine_rows = grid_->geometry().height, fine_cols = grid_->geometry().width;
  distortion_ = DistortionReport{};
  WindowLikelihood out;
  if (!previous_coarse.empty()) {
    // Where the prior holds (nearly) all its mass, marginalise the odometry's distortion since
    // the last update (the local map rebuilt and the belief shifted under each hypothesis B),
    // on those cells only: the sparse sensor model, no whole-map match.
    const double residual = residual_blur_m(config_.distortion, blur, travel, config_.min_blur_m);
    SupportLikelihood sparse =
        support_likelihood(*matcher_, patch_under, hypotheses_, config_.distortion, config_.sensor, previous_coarse,
                           matcher_->pool(grid_->belief(), grid_->occupied()), shift, residual);
    if (!sparse.cells.empty()) {
      fit_cells_ = sparse.cells;
      fit_residual_ = sparse.best_shape_residual;
      distortion_ = sparse.report;
      weights = sparse.weights;
      keep_robot_side(sparse.identity);
      // The diagnostics' match on the matching grid: the support's values, NaN elsewhere.
      const int rows = matcher_->surface().geometry.height, cols = matcher_->surface().geometry.width;
      MaskedEmoiMatcher::Match match = sparse.identity;
      for (size_t k = 0; k < match.dsm_emoi.size(); ++k) {
        cv::Mat_<float> layer(rows, cols, std::numeric_limits<float>::quiet_NaN());
        for (size_t i = 0; i < sparse.cells.size(); ++i) {
          layer(sparse.cells[i]) = sparse.identity.dsm_emoi[k](0, static_cast<int>(i));
        }
        match.dsm_emoi[k] = layer;
      }
      last_match_ = std::move(match);
      out.values = support_likelihood_on_grid(*matcher_, sparse, fine_rows, fine_cols, out.window);
      out.outside = sparse.outside;
      return out;
    }
  }
  fit_cells_.clear();
  fit_residual_.clear();
  last_match_ = matcher_->match(patch_under(Eigen::Matrix2d::Identity()));
  keep_robot_side(*last_match_);
  cv::Mat_<float> coarse = matcher_->coarse_log_likelihood(*last_match_, config_.sensor, &weights);
  cv::exp(coarse, coarse);
  out.values = matcher_->to_fine(coarse, fine_rows, fine_cols);
  out.window = cv::Rect(0, 0, fine_cols, fine_rows);
  return out;
}

PoseEstimate EmoiMarkovFilter::estimate(int64_t stamp_ns) const {
  PoseEstimate out;
  out.header.stamp_ns = stamp_ns;
  out.header.frame_id = "map";
  const Eigen::Vector2d xy = assessment_.estimate + pending_shift_;
  double z = 0.0;
  int row = 0, col = 0;
  if (grid_->geometry().index_of(xy, row, col) && std::isfinite(dsm_elevation_(row, col))) {
    z = dsm_elevation_(row, col) + config_.base_height_m;
  }
  double roll = 0.0, pitch = 0.0;
  if (imu_orientation_) {
    const Eigen::Vector3d rpy = roll_pitch_yaw(imu_orientation_->toRotationMatrix());
    roll = rpy.x();
    pitch = rpy.y();
  }
  out.pose = isometry_from_xyz_rpy(xy.x(), xy.y(), z, roll, pitch, map_heading());
  out.covariance = Matrix6d::Zero();
  const double drift = config_.odometry_error * pending_travel_m_;
  // The belief's second moment about the estimate (the summary's is about the maximum cell).
  const Eigen::Vector2d from_mode = summary_.mean - summary_.mode, from_estimate = summary_.mean - assessment_.estimate;
  // About the mean first; its eigenvalues kept at least the cell's own extent (the subtraction
  // rounds in float for a wide belief).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> about_mean(summary_.covariance -
                                                                  from_mode * from_mode.transpose());
  const double cell_variance = grid_->geometry().resolution * grid_->geometry().resolution / 12.0;
  const Eigen::Matrix2d about_estimate =
      about_mean.eigenvectors() * about_mean.eigenvalues().cwiseMax(cell_variance).asDiagonal() *
          about_mean.eigenvectors().transpose() +
      from_estimate * from_estimate.transpose();
  out.covariance.block<2, 2>(0, 0) = about_estimate + Eigen::Matrix2d::Identity() * drift * drift;
  out.covariance(2, 2) = kHeightVariance;
  out.covariance(3, 3) = out.covariance(4, 4) = kTiltVariance;
  out.covariance(5, 5) = kHeadingStddev * kHeadingStddev;
  return out;
}

GridLayer EmoiMarkovFilter::belief_layer() const {
  return pooled_layer(grid_->belief(), grid_->geometry(), config_.belief_output_max_cells, "belief", true);
}

}  // namespace locd::emoi
