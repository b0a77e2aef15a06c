#include "localizer.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>

#include "locd/ceiling_pf/velocity_motion_model.hpp"
#include "locd/sdk/initial_pose.hpp"
#include "params.hpp"

namespace locd::ceiling_pf {
namespace {

// The localization state (README "Localization state"), judged after every correction:
//   lost       the frames fit the map far worse than the filter is used to: w_fast below
//              kLostLikelihoodRatio of w_slow (augmented MCL's kidnap signal), or the last
//              kExplainedFrames frames with detections explained less than kLostExplained of
//              their detections on average; or no particles yet
//   uncertain  several modes: the cluster around the mode holds less than kMinClusterMass of the
//              weight; or the cluster's position stddev exceeds kMaxClusterStddev; or the weights
//              rest on few particles: effective sample size below kMinEssShare of the set
//   tracking   otherwise
constexpr double kLostLikelihoodRatio = 0.5;
constexpr size_t kExplainedFrames = 5;
constexpr double kLostExplained = 0.2;
constexpr double kMinClusterMass = 0.5;
constexpr double kMaxClusterStddev = 0.5;  // m
constexpr double kMinEssShare = 0.1;

// The published covariance is the cluster's, but never below these stddevs (the position along
// every direction, the heading): once KLD sampling has shrunk the set to its minimum after a
// recovery, the particles' spread falls below the error they carry (sample impoverishment).
constexpr double kPositionStddevFloor = 0.01;  // m
constexpr double kHeadingStddevFloor = 0.005;  // rad

std::string number(double v, int digits = 2) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, v);
  return text;
}


Eigen::Matrix3d diagonal_variance(const Eigen::Vector3d& stddev) { return stddev.cwiseAbs2().asDiagonal(); }

}  // namespace

void CeilingPfLocalizer::configure(const PluginContext& context, const Params& params) {
  config_ = parse_config(params, context.limits, [&](const std::string& map) {
    map_ = load_landmark_map(context.maps.resolve(map).string(), context.limits.max_map_cells);
    return map_.ceiling_height;
  });
  camera_ = std::make_unique<CeilingCamera>(config_.camera, config_.mounting, *config_.ceiling_height);
  detector_ = std::make_unique<CeilingDetector>(config_.detector);
  ParticleFilterConfig filter = config_.filter;
  filter.max_range = camera_->max_view_range() + config_.view_range_margin;
  auto index = std::make_shared<const NearestLandmarkIndex>(map_.landmarks, filter.candidates, config_.index_cell_size,
                                                            filter.max_range + config_.index_margin,
                                                            context.limits.max_map_cells);
  filter_ = std::make_unique<CeilingParticleFilter>(filter, index, VelocityMotionModel(config_.motion_noise));
  if (config_.initial_pose) filter_->set_pose(*config_.initial_pose, diagonal_variance(config_.initial_stddev));
  last_odometry_.reset();
  rejected_ = 0;
  explained_.clear();
}

void CeilingPfLocalizer::set_pose(const PoseEstimate& pose) {
  const PlanarInitialPose start = planar_initial_pose(pose, "ceiling_pf");
  filter_->set_pose(start.mean, start.covariance_positive_definite ? start.covariance
                                                                   : diagonal_variance(config_.initial_stddev));
  explained_.clear();
}

UpdateResult CeilingPfLocalizer::update(const Measurement& measurement) {
  try {
    if (const auto* odometry = std::get_if<Odometry>(&measurement)) return on_odometry(*odometry);
    if (const auto* image = std::get_if<Image>(&measurement)) return on_image(*image);
    if (const auto* frame = std::get_if<LandmarkDetections>(&measurement)) return on_detections(*frame);
    throw InputError("ceiling_pf consumes odometry, image and landmark detections only");
  } catch (const InputError&) {
    ++rejected_;
    throw;
  }
}

UpdateResult CeilingPfLocalizer::initial_outputs() const {
  UpdateResult r;
  std::vector<MapFeature> features;
  for (size_t i = 0; i < map_.landmarks.size(); ++i) {
    MapFeature f;
    f.id = map_.id(i);
    f.kind = "ceiling_landmark";
    f.a = Eigen::Vector3d(map_.landmarks[i].x(), map_.landmarks[i].y(),
                          camera_ ? camera_->lens_to_ceiling() + camera_->mounting().height : map_.ceiling_height);
    f.b = f.a;
    features.push_back(f);
  }
  r.landmark_map = std::move(features);
  return r;
}

// Stamps arrive in order (the session sees to it); a repeated stamp predicts nothing.
UpdateResult CeilingPfLocalizer::on_odometry(const Odometry& odom) {
  const Pose2 pose = Pose2::from_isometry(odom.pose);
  if (last_odometry_) {
    const double dt = 1e-9 * static_cast<double>(odom.header.stamp_ns - last_odometry_stamp_);
    filter_->predict(velocity_between(*last_odometry_, pose, dt));
  }
  last_odometry_ = pose;
  last_odometry_stamp_ = odom.header.stamp_ns;
  UpdateResult result;
  result.estimate = make_estimate(odom.header);
  return result;
}

UpdateResult CeilingPfLocalizer::on_image(const Image& image) {
  if (image.channels != 1) {
    throw InputError("image: encoding with " + std::to_string(image.channels) +
                     " channels is not accepted; ceiling_pf expects mono8 (1 channel)");
  }
  const CameraIntrinsics& in = camera_->intrinsics();
  if (image.width != in.width || image.height != in.height) {
    throw InputError("image: size " + std::to_string(image.width) + " x " + std::to_string(image.height) +
                     " does not match ceiling_pf.camera width x height = " + std::to_string(in.width) + " x " +
                     std::to_string(in.height));
  }
  const cv::Mat mono(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data.data()));
  std::vector<Detection> detections;
  for (const Eigen::Vector2d& p : detector_->detect_points(mono, *camera_)) detections.push_back(Detection::from_point(p));
  return correct(image.header, detections);
}

UpdateResult CeilingPfLocalizer::on_detections(const LandmarkDetections& frame) {
  std::vector<Detection> detections;
  for (const LandmarkDetection& d : frame.detections) {
    if (!config_.detection_label.empty() && d.class_label != config_.detection_label) continue;
    detections.push_back(Detection::from_point(d.position.head<2>()));
  }
  return correct(frame.header, detections);
}

LocalizationAssessment CeilingPfLocalizer::assess(const CorrectionReport& report, size_t weighted_particles) {
  if (report.detections > 0) {
    explained_.push_back(report.mean_likelihood);
    while (explained_.size() > kExplainedFrames) explained_.pop_front();
  }
  const std::optional<FilterEstimate> e = filter_->estimate();
  if (!e) return {LocalizationState::kLost, "no particles yet: waiting for a frame with detections"};
  const double slow = filter_->slow_average(), fast = filter_->fast_average();
  if (slow > 0.0 && fast < kLostLikelihoodRatio * slow) {
    return {LocalizationState::kLost, "frames fit the map far worse than usual: w_fast " + number(fast, 3) + " < " +
                                          number(kLostLikelihoodRatio) + " w_slow (" + number(slow, 3) + ")"};
  }
  if (explained_.size() == kExplainedFrames) {
    double sum = 0.0;
    for (double v : explained_) sum += v;
    const double mean = sum / static_cast<double>(kExplainedFrames);
    if (mean < kLostExplained) {
      return {LocalizationState::kLost, "the last " + std::to_string(kExplainedFrames) + " frames explained " +
                                            number(100.0 * mean, 0) + " % of their detections < " +
                                            number(100.0 * kLostExplained, 0) + " %"};
    }
  }
  if (e->mass < kMinClusterMass) {
    return {LocalizationState::kUncertain, "several modes: the cluster around the mode holds " +
                                               number(100.0 * e->mass, 0) + " % of the weight < " +
                                               number(100.0 * kMinClusterMass, 0) + " %"};
  }
  const double spread = std::sqrt(std::max(0.0, e->covariance.topLeftCorner<2, 2>().eigenvalues().real().maxCoeff()));
  if (spread > kMaxClusterStddev) {
    return {LocalizationState::kUncertain,
            "cluster spread " + number(spread) + " m > " + number(kMaxClusterStddev) + " m"};
  }
  const double ess_share =
      weighted_particles ? report.effective_sample_size / static_cast<double>(weighted_particles) : 1.0;
  if (report.detections > 0 && ess_share < kMinEssShare) {
    return {LocalizationState::kUncertain, "effective sample size " + number(100.0 * ess_share, 1) + " % of " +
                                               std::to_string(weighted_particles) + " particles < " +
                                               number(100.0 * kMinEssShare, 0) + " %"};
  }
  return {LocalizationState::kTracking, "tracking: cluster " + number(100.0 * e->mass, 0) + " % of the weight, spread " +
                                            number(spread, 3) + " m, w_fast/w_slow " +
                                            (slow > 0.0 ? number(fast / slow) : std::string("-"))};
}

UpdateResult CeilingPfLocalizer::correct(const Header& header, const std::vector<Detection>& detections) {
  const size_t weighted = filter_->particles().size();
  const CorrectionReport report = filter_->correct(detections);
  UpdateResult result;
  result.estimate = make_estimate(header);
  result.localization = assess(report, weighted);
  Diagnostics& d = result.diagnostics;
  d.values = {{"detections", static_cast<double>(report.detections)},
              {"particles", static_cast<double>(filter_->particles().size())},
              {"effective_sample_size", report.effective_sample_size},
              {"resampled", report.resampled ? 1.0 : 0.0},
              {"injected", static_cast<double>(report.injected)},
              {"injection_probability", report.injection_probability},
              {"likelihood_slow", filter_->slow_average()},
              {"likelihood_fast", filter_->fast_average()},
              {"rejected_inputs", static_cast<double>(rejected_)}};
  if (const auto e = filter_->estimate()) d.values.push_back({"cluster_mass", e->mass});
  for (size_t i = 0; i < report.associations.size(); ++i) {
    const Association& a = report.associations[i];
    d.associations.push_back({static_cast<uint32_t>(i), a.landmark >= 0 ? map_.id(static_cast<size_t>(a.landmark)) : "",
                              static_cast<uint32_t>(a.candidates), a.normalized_error2});
  }
  d.particles = diagnostic_particles(filter_->particles(), config_.diagnostics_particles);
  return result;
}

std::optional<PoseEstimate> CeilingPfLocalizer::make_estimate(const Header& header) const {
  const auto e = filter_->estimate();
  if (!e) return std::nullopt;
  PoseEstimate out;
  out.header.stamp_ns = header.stamp_ns;
  out.header.frame_id = map_.frame_id;
  out.pose = e->pose.to_isometry();
  const Eigen::Matrix3d covariance = floor_covariance(e->covariance, kPositionStddevFloor, kHeadingStddevFloor);
  out.covariance = pose_covariance(covariance);
  return out;
}

}  // namespace locd::ceiling_pf
