#include "locd/emoi_markov/emoi_markov_localizer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "locd/emoi_markov/emoi_cache.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::emoi {
namespace {

bool finite_pose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

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

}  // namespace

EmoiMarkovConfig parse_config(const Params& params) {
  params.expect_only({"map", "radii_m", "sigma_m", "min_likelihood", "min_coverage", "full_coverage",
                      "odometry_error", "min_blur_m", "update_distance_m", "heading_source", "use_initial_pose",
                      "base_height_m", "local_map_size_m", "local_map_memory_m", "local_map_refresh_m", "min_point_range_m", "cache",
                      "belief_output_max_cells", "sensor_model", "match_resolution_m", "ground_offset_stddev_m",
                      "odometry_direction_error_rad", "distortion_nodes", "distortion_max_cells",
                      "distortion_support_mass", "shape_sigma_m"});
  EmoiMarkovConfig config;
  config.map = params.required_text("map");
  config.radii_m = params.numbers("radii_m", config.radii_m, 0, Range::open(0.0, 1000.0));
  if (config.radii_m.empty() || config.radii_m.size() > 8) {
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
  const double default_size = std::max(4.0 * max_radius, 40.0) + 20.0;
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
  return config;
}

void EmoiMarkovLocalizer::configure(const PluginContext& context, const Params& params) {
  EmoiMarkovConfig config = parse_config(params);
  const auto file = context.maps.resolve(config.map);
  ElevationMap dsm = load_dsm(file, context.limits.max_map_cells);
  configure(context, config, std::move(dsm));
}

void EmoiMarkovLocalizer::configure(const PluginContext& context, const EmoiMarkovConfig& config, ElevationMap dsm) {
  if (dsm.geometry.size() > context.limits.max_map_cells) {
    throw ConfigError("DSM '" + config.map + "' has " + std::to_string(dsm.geometry.size()) +
                      " cells; allowed: at most limits.max_map_cells = " + std::to_string(context.limits.max_map_cells));
  }
  context_ = context;
  config_ = config;
  int last_decile = -1;
  const ProgressCallback progress = [&](double fraction, const std::string& stage) {
    const int decile = static_cast<int>(fraction * 10.0);
    if (decile == last_decile) return;
    last_decile = decile;
    context_.log(LogLevel::kInfo, "emoi_markov: EMOI layers " + std::to_string(decile * 10) + "% (" + stage + ")");
  };
  layers_.reset();
  matcher_.reset();
  if (config.sensor_model == "full_disk") {
    const std::optional<std::filesystem::path> cache_directory =
        config.cache ? std::optional<std::filesystem::path>(default_cache_directory()) : std::nullopt;
    LayersSource source = load_or_compute_layers(dsm, config.radii_m, cache_directory, progress);
    layers_from_cache_ = source.from_cache;
    context_.log(LogLevel::kInfo, std::string("emoi_markov: EMOI layers ") +
                                      (source.from_cache ? "read from the cache" : "computed") + " (key " +
                                      source.key.substr(0, 12) + ")");
    layers_ = std::move(source.layers);
    grid_ = std::make_unique<MarkovGrid>(dsm.geometry, layers_support(*layers_));
  } else {
    matcher_ = std::make_unique<MaskedEmoiMatcher>(dsm, config.radii_m, config.match_resolution_m);
    cv::Mat_<uchar> support(dsm.elevation.size(), uchar(0));
    for (int r = 0; r < support.rows; ++r) {
      for (int c = 0; c < support.cols; ++c) support(r, c) = std::isfinite(dsm.elevation(r, c)) ? 1 : 0;
    }
    grid_ = std::make_unique<MarkovGrid>(dsm.geometry, support);
  }
  config_.distortion.scale_stddev = config.odometry_error;
  hypotheses_ = distortion_hypotheses(config_.distortion.scale_stddev, config_.distortion.direction_stddev_rad,
                                      config_.distortion.nodes);
  dsm_elevation_ = dsm.elevation;
  config_.local_map.resolution = dsm.geometry.resolution;
  local_map_ = std::make_unique<LocalElevationMap>(config_.local_map);
  last_odometry_.reset();
  imu_orientation_.reset();
  yaw_offset_ = 0.0;
  pending_set_pose_yaw_.reset();
  pending_shift_.setZero();
  pending_travel_m_ = travelled_m_ = 0.0;
  summary_ = grid_->summary();
  sensor_updates_ = rejected_points_ = belief_resets_ = 0;
}

void EmoiMarkovLocalizer::set_pose(const PoseEstimate& pose) {
  if (!grid_) throw InputError("set_pose before configure");
  if (!finite_pose(pose.pose) || !pose.covariance.allFinite()) {
    throw InputError("initial pose has a NaN or infinite value");
  }
  const Eigen::Vector2d xy = pose.pose.translation().head<2>();
  int row = 0, col = 0;
  const GridGeometry& g = grid_->geometry();
  if (!g.index_of(xy, row, col)) {
    throw InputError("initial pose (" + format_number(xy.x()) + ", " + format_number(xy.y()) +
                     ") lies outside the DSM [" + format_number(g.origin.x()) + ", " +
                     format_number(g.origin.x() + g.width * g.resolution) + "] x [" + format_number(g.origin.y()) +
                     ", " + format_number(g.origin.y() + g.height * g.resolution) + "]");
  }
  const double yaw = yaw_of(pose.pose.linear());
  if (last_odometry_) {
    yaw_offset_ = normalize_angle(yaw - yaw_of(last_odometry_->pose.linear()));
  } else {
    pending_set_pose_yaw_ = yaw;
  }
  if (config_.use_initial_pose) {
    const double stddev = std::sqrt(std::max({pose.covariance(0, 0), pose.covariance(1, 1), 0.0}));
    grid_->set_gaussian(xy, stddev);
    summary_ = grid_->summary();
    pending_shift_.setZero();
    pending_travel_m_ = 0.0;
  }
}

Eigen::Isometry3d EmoiMarkovLocalizer::base_in_odom() const {
  Eigen::Isometry3d T = last_odometry_->pose;
  if (imu_orientation_) {
    // Attitude (roll, pitch) from the IMU, as the paper's inclinometer; yaw from odometry.
    const Eigen::Vector3d rpy = roll_pitch_yaw(imu_orientation_->toRotationMatrix());
    T.linear() = rpy_rotation(yaw_of(last_odometry_->pose.linear()), rpy.y(), rpy.x());
  }
  return T;
}

double EmoiMarkovLocalizer::map_heading() const {
  if (config_.heading_source == "imu" && imu_orientation_) return yaw_of(imu_orientation_->toRotationMatrix());
  const double odom_yaw = last_odometry_ ? yaw_of(last_odometry_->pose.linear()) : 0.0;
  return normalize_angle(odom_yaw + yaw_offset_);
}

UpdateResult EmoiMarkovLocalizer::update(const Measurement& measurement) {
  if (!grid_) throw InputError("measurement before configure");
  return std::visit(
      [&](const auto& m) -> UpdateResult {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, Odometry>) {
          return on_odometry(m);
        } else if constexpr (std::is_same_v<T, Imu>) {
          return on_imu(m);
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          return on_scan(m);
        } else if constexpr (std::is_same_v<T, PointCloud>) {
          return on_cloud(m);
        } else {
          throw InputError(std::string("emoi_markov does not consume '") + kind_name(kind_of(measurement)) +
                           "' measurements; it consumes odometry, imu, scan and cloud");
        }
      },
      measurement);
}

UpdateResult EmoiMarkovLocalizer::on_odometry(const Odometry& odometry) {
  if (!finite_pose(odometry.pose)) throw InputError("odometry pose has a NaN or infinite value");
  if (last_odometry_ && odometry.header.stamp_ns < last_odometry_->header.stamp_ns) {
    throw InputError("odometry stamp " + std::to_string(odometry.header.stamp_ns) + " ns goes back from " +
                     std::to_string(last_odometry_->header.stamp_ns) + " ns");
  }
  if (last_odometry_) {
    const double heading_offset = normalize_angle(map_heading() - yaw_of(last_odometry_->pose.linear()));
    const Eigen::Vector2d step =
        (odometry.pose.translation() - last_odometry_->pose.translation()).head<2>();
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
  last_stamp_ns_ = odometry.header.stamp_ns;
  UpdateResult result;
  result.estimate = estimate(odometry.header.stamp_ns);
  return result;
}

UpdateResult EmoiMarkovLocalizer::on_imu(const Imu& imu) {
  const Eigen::Vector4d q = imu.orientation.coeffs();
  if (!q.allFinite() || std::abs(q.norm() - 1.0) > 1e-3) {
    throw InputError("imu orientation is not a unit quaternion (norm " + format_number(q.norm()) + ")");
  }
  imu_orientation_ = imu.orientation.normalized();
  return {};
}

UpdateResult EmoiMarkovLocalizer::on_scan(const LaserScan& scan) {
  if (!last_odometry_) throw InputError("scan before any odometry: the local elevation map needs the robot's pose");
  if (scan.ranges.size() > context_.limits.max_scan_beams) {
    throw InputError("scan has " + std::to_string(scan.ranges.size()) + " beams; allowed: at most " +
                     std::to_string(context_.limits.max_scan_beams) + " (limits.max_scan_beams)");
  }
  if (!finite_pose(scan.sensor_pose) || !std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment)) {
    throw InputError("scan sensor_pose, angle_min or angle_increment is NaN or infinite");
  }
  local_map_->follow(last_odometry_->pose.translation().head<2>());
  const InsertStatistics stats = local_map_->insert_scan(scan, base_in_odom(), travelled_m_);
  rejected_points_ += stats.invalid;
  return after_insert(scan.header.stamp_ns);
}

UpdateResult EmoiMarkovLocalizer::on_cloud(const PointCloud& cloud) {
  if (!last_odometry_) throw InputError("cloud before any odometry: the local elevation map needs the robot's pose");
  if (cloud.points.size() > context_.limits.max_cloud_points) {
    throw InputError("cloud has " + std::to_string(cloud.points.size()) + " points; allowed: at most " +
                     std::to_string(context_.limits.max_cloud_points) + " (limits.max_cloud_points)");
  }
  if (!finite_pose(cloud.sensor_pose)) throw InputError("cloud sensor_pose is NaN or infinite");
  local_map_->follow(last_odometry_->pose.translation().head<2>());
  const InsertStatistics stats = local_map_->insert_cloud(cloud, base_in_odom(), travelled_m_);
  rejected_points_ += stats.invalid;
  return after_insert(cloud.header.stamp_ns);
}

UpdateResult EmoiMarkovLocalizer::after_insert(int64_t stamp_ns) {
  UpdateResult result;
  if (pending_travel_m_ < config_.update_distance_m) return result;
  // Table 1, action: shift by the odometry, blur by its error.
  const bool hypotheses = matcher_ && hypotheses_.size() > 1;  // odometry_distortion.hpp
  const cv::Mat_<float> previous_coarse =
      hypotheses ? matcher_->pool(grid_->belief(), grid_->occupied()) : cv::Mat_<float>();
  const Eigen::Vector2d shift = pending_shift_;
  const double travel = pending_travel_m_;
  const double blur = std::hypot(config_.odometry_error * pending_travel_m_, config_.min_blur_m);
  const MotionUpdateReport motion = grid_->motion_update(pending_shift_, blur);
  if (motion.reset) ++belief_resets_;
  last_mass_lost_ = motion.mass_lost;
  pending_shift_.setZero();
  pending_travel_m_ = 0.0;
  // Table 1, perception: the robot's EMOI over its observed cells, eq. 8, normalise.
  const Eigen::Vector3d position = last_odometry_->pose.translation();
  const double ground = position.z() - config_.base_height_m;
  std::vector<double> weights;
  last_robot_emoi_.clear();
  cv::Mat_<float> log_likelihood;
  WindowLikelihood likelihood;
  if (matcher_) {
    likelihood = masked_likelihood(previous_coarse, shift, travel, blur, weights);
  } else {
    last_robot_emoi_ = local_map_->emoi(position.head<2>(), ground, config_.radii_m, travelled_m_);
    EmoiObservation z;
    for (const auto& e : last_robot_emoi_) {
      z.emoi.push_back(e.emoi);
      z.coverage.push_back(e.coverage);
    }
    log_likelihood = full_disk_log_likelihood(*layers_, z, config_.sensor, &weights);
  }
  SensorUpdateReport sensor;
  sensor.evidence = 1.0;
  if (std::any_of(weights.begin(), weights.end(), [](double w) { return w > 0.0; })) {
    sensor = matcher_ ? grid_->sensor_update_likelihood(likelihood.values, likelihood.window, likelihood.outside)
                      : grid_->sensor_update(log_likelihood, config_.sensor.min_likelihood);
  }
  summary_ = grid_->summary();
  ++sensor_updates_;

  result.estimate = estimate(stamp_ns);
  result.grid = belief_layer();
  auto& values = result.diagnostics.values;
  for (size_t i = 0; i < config_.radii_m.size(); ++i) {
    const std::string r = std::to_string(static_cast<int>(std::lround(config_.radii_m[i])));
    values.emplace_back("emoi_r" + r, last_robot_emoi_[i].emoi);
    values.emplace_back("coverage_r" + r, last_robot_emoi_[i].coverage);
    values.emplace_back("weight_r" + r, weights[i]);
  }
  values.emplace_back("distortion_cells", static_cast<double>(distortion_.cells));
  values.emplace_back("distortion_scale", distortion_.scale);
  values.emplace_back("distortion_direction_rad", distortion_.direction_rad);
  values.emplace_back("sensor_update_applied", sensor.applied ? 1.0 : 0.0);
  values.emplace_back("evidence", sensor.evidence);
  values.emplace_back("mass_lost", motion.mass_lost);
  values.emplace_back("belief_resets", static_cast<double>(belief_resets_));
  values.emplace_back("max_probability", summary_.max_probability);
  values.emplace_back("effective_cells", summary_.effective_cells);
  values.emplace_back("sensor_updates", static_cast<double>(sensor_updates_));
  values.emplace_back("rejected_points", static_cast<double>(rejected_points_));
  return result;
}

EmoiMarkovLocalizer::WindowLikelihood EmoiMarkovLocalizer::masked_likelihood(const cv::Mat_<float>& previous_coarse,
                                                                             const Eigen::Vector2d& shift,
                                                                             double travel, double blur,
                                                                             std::vector<double>& weights) {
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
  last_match_ = matcher_->match(patch_under(Eigen::Matrix2d::Identity()));
  keep_robot_side(*last_match_);
  cv::Mat_<float> coarse = matcher_->coarse_log_likelihood(*last_match_, config_.sensor, &weights);
  cv::exp(coarse, coarse);
  out.values = matcher_->to_fine(coarse, fine_rows, fine_cols);
  out.window = cv::Rect(0, 0, fine_cols, fine_rows);
  return out;
}

PoseEstimate EmoiMarkovLocalizer::estimate(int64_t stamp_ns) const {
  PoseEstimate out;
  out.header.stamp_ns = stamp_ns;
  out.header.frame_id = "map";
  const Eigen::Vector2d xy = summary_.mode + pending_shift_;
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
  out.covariance.block<2, 2>(0, 0) = summary_.covariance + Eigen::Matrix2d::Identity() * drift * drift;
  out.covariance(2, 2) = 1.0;
  out.covariance(3, 3) = out.covariance(4, 4) = 0.01;
  out.covariance(5, 5) = 0.05 * 0.05;
  return out;
}

GridLayer EmoiMarkovLocalizer::belief_layer() const {
  return pooled_layer(grid_->belief(), grid_->geometry(), config_.belief_output_max_cells, "belief", true);
}

UpdateResult EmoiMarkovLocalizer::initial_outputs() const {
  UpdateResult result;
  if (!grid_) return result;
  result.grid = belief_layer();
  return result;
}

}  // namespace locd::emoi
