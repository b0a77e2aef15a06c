// ceiling_pf plugin: parameters, measurement I/O and outputs around the core filter.
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <sstream>

#include "locd/ceiling_pf/ceiling_camera.hpp"
#include "locd/ceiling_pf/ceiling_detector.hpp"
#include "locd/ceiling_pf/ceiling_particle_filter.hpp"
#include "locd/ceiling_pf/landmark_map.hpp"
#include "locd/ceiling_pf/velocity_motion_model.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::ceiling_pf {
namespace {

class CeilingPfLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override {
    params.expect_only({"map", "ceiling_height", "camera", "detector", "detections", "motion", "measurement",
                        "particles", "recovery", "initial_pose", "initial_stddev", "output", "seed"});
    context_ = context;
    const std::string map_name = params.required_text("map");
    map_ = load_landmark_map(context.maps.resolve(map_name).string(), context.limits.max_map_cells);
    const double ceiling_height =
        params.number("ceiling_height", map_.ceiling_height, Range::open(0.0, 100.0));

    const Params cam = params.child("camera");
    cam.expect_only({"width", "height", "fx", "fy", "cx", "cy", "mount", "lens_height"});
    if (!params.has("camera")) params.fail("camera", "is missing; expected width, height, fx, fy, cx, cy");
    CameraIntrinsics in;
    in.width = static_cast<int>(cam.integer("width", 640, 16, 8192));
    in.height = static_cast<int>(cam.integer("height", 480, 16, 8192));
    if (static_cast<size_t>(in.width) * in.height > context.limits.max_image_pixels) {
      cam.fail("width", "x height = " + std::to_string(in.width * in.height) + " pixels exceeds limits.max_image_pixels = " +
                            std::to_string(context.limits.max_image_pixels));
    }
    in.fx = cam.required_number("fx", Range::open(0.0, 1e5));
    in.fy = cam.required_number("fy", Range::open(0.0, 1e5));
    in.cx = cam.required_number("cx", Range::closed(0.0, in.width));
    in.cy = cam.required_number("cy", Range::closed(0.0, in.height));
    const std::vector<double> mount = cam.numbers("mount", {0.0, 0.0, 0.0}, 3, Range::closed(-10.0, 10.0));
    CameraMounting mounting{mount[0], mount[1], mount[2],
                            cam.number("lens_height", 0.32, Range::closed(0.0, 100.0))};
    if (!(ceiling_height > mounting.height)) {
      cam.fail("lens_height", "= " + std::to_string(mounting.height) + " must be below the ceiling height " +
                                  std::to_string(ceiling_height));
    }
    camera_ = std::make_unique<CeilingCamera>(in, mounting, ceiling_height);

    const Params det = params.child("detector");
    det.expect_only({"blur_kernel", "blur_sigma", "threshold", "hough_dp", "min_distance_px", "canny_threshold",
                     "accumulator_threshold", "min_radius_px", "max_radius_px", "max_circles", "pyramid_levels",
                     "refine_centroid"});
    DetectorConfig dc;
    dc.blur_kernel = static_cast<int>(det.integer("blur_kernel", dc.blur_kernel, 1, 31));
    if (dc.blur_kernel % 2 == 0) det.fail("blur_kernel", "= " + std::to_string(dc.blur_kernel) + " must be odd");
    dc.blur_sigma = det.number("blur_sigma", dc.blur_sigma, Range::closed(0.0, 20.0));
    dc.threshold = det.number("threshold", dc.threshold, Range::closed(0.0, 255.0));
    dc.hough_dp = det.number("hough_dp", dc.hough_dp, Range::closed(1.0, 4.0));
    dc.min_distance_px = det.number("min_distance_px", dc.min_distance_px, Range::closed(1.0, 10000.0));
    dc.canny_threshold = det.number("canny_threshold", dc.canny_threshold, Range::closed(1.0, 1000.0));
    dc.accumulator_threshold = det.number("accumulator_threshold", dc.accumulator_threshold, Range::closed(1.0, 1000.0));
    dc.min_radius_px = static_cast<int>(det.integer("min_radius_px", dc.min_radius_px, 1, 1000));
    dc.max_radius_px = static_cast<int>(det.integer("max_radius_px", dc.max_radius_px, dc.min_radius_px, 2000));
    dc.max_circles = static_cast<int>(det.integer("max_circles", dc.max_circles, 1, 1024));
    dc.pyramid_levels = static_cast<int>(det.integer("pyramid_levels", dc.pyramid_levels, 0, 3));
    dc.refine_centroid = det.flag("refine_centroid", dc.refine_centroid);
    detector_ = std::make_unique<CeilingDetector>(dc);

    const Params ext = params.child("detections");
    ext.expect_only({"class_label"});
    detection_label_ = ext.text("class_label", "");

    const Params mot = params.child("motion");
    mot.expect_only({"alpha"});
    const std::vector<double> a = mot.numbers("alpha", {0.3, 0.3, 0.1, 0.25, 0.001, 0.001}, 6, Range::closed(0.0, 10.0));

    ParticleFilterConfig fc;
    const Params meas = params.child("measurement");
    meas.expect_only({"range_stddev", "bearing_stddev", "hit_fraction", "candidates", "index_cell_size"});
    fc.range_stddev = meas.number("range_stddev", fc.range_stddev, Range::open(0.0, 10.0));
    fc.bearing_stddev = meas.number("bearing_stddev", fc.bearing_stddev, Range::open(0.0, M_PI));
    fc.hit_fraction = meas.number("hit_fraction", fc.hit_fraction, {0.0, 1.0, true, false});
    fc.candidates = static_cast<int>(meas.integer("candidates", fc.candidates, 1, 32));
    const double cell = meas.number("index_cell_size", 0.5, Range::closed(0.05, 100.0));
    fc.max_range = camera_->max_view_range() + 0.5;

    const Params part = params.child("particles");
    part.expect_only({"count", "kld_sampling", "min", "max", "global", "kld_epsilon", "kld_quantile", "kld_bin",
                      "resample_ess_fraction"});
    const long max_particles = static_cast<long>(std::min<size_t>(context.limits.max_particles, 10'000'000));
    fc.particles = static_cast<size_t>(part.integer("count", 500, 1, max_particles));
    fc.kld_sampling = part.flag("kld_sampling", true);
    fc.min_particles = static_cast<size_t>(part.integer("min", 100, 1, max_particles));
    fc.max_particles = static_cast<size_t>(part.integer("max", std::min<long>(20000, max_particles),
                                                        static_cast<long>(fc.min_particles), max_particles));
    fc.global_particles = static_cast<size_t>(part.integer("global", static_cast<long>(fc.max_particles), 1, max_particles));
    fc.kld_epsilon = part.number("kld_epsilon", fc.kld_epsilon, Range::open(0.0, 1.0));
    fc.kld_quantile = part.number("kld_quantile", fc.kld_quantile, Range::open(0.5, 1.0));
    const std::vector<double> bin = part.numbers("kld_bin", {0.2, 0.2, 0.1}, 3, Range::open(0.0, 100.0));
    fc.kld_bin = Eigen::Vector3d(bin[0], bin[1], bin[2]);
    fc.resample_ess_fraction = part.number("resample_ess_fraction", 0.5, Range::closed(0.0, 1.0));

    const Params rec = params.child("recovery");
    rec.expect_only({"enabled", "alpha_slow", "alpha_fast", "min_injection_probability", "ambiguous_injection", "position_stddev",
                     "heading_stddev", "pair_distance_tolerance"});
    fc.recovery = rec.flag("enabled", true);
    fc.alpha_slow = rec.number("alpha_slow", fc.alpha_slow, Range::open(0.0, 1.0));
    fc.alpha_fast = rec.number("alpha_fast", fc.alpha_fast, Range::open(0.0, 1.0));
    if (!(fc.alpha_fast > fc.alpha_slow)) {
      rec.fail("alpha_fast", "= " + std::to_string(fc.alpha_fast) + " must exceed alpha_slow = " + std::to_string(fc.alpha_slow));
    }
    fc.min_injection_probability =
        rec.number("min_injection_probability", fc.min_injection_probability, Range::closed(0.0, 1.0));
    fc.ambiguous_injection = rec.number("ambiguous_injection", fc.ambiguous_injection, Range::closed(0.0, 1.0));
    fc.proposal_position_stddev = rec.number("position_stddev", fc.proposal_position_stddev, Range::closed(0.0, 10.0));
    fc.proposal_heading_stddev = rec.number("heading_stddev", fc.proposal_heading_stddev, Range::closed(0.0, M_PI));
    fc.pair_distance_tolerance = rec.number("pair_distance_tolerance", fc.pair_distance_tolerance, Range::open(0.0, 10.0));

    const Params out = params.child("output");
    out.expect_only({"diagnostics_particles", "cluster_radius"});
    diagnostics_particles_ = static_cast<size_t>(out.integer("diagnostics_particles", 500, 0, 65536));
    fc.cluster_radius = out.number("cluster_radius", fc.cluster_radius, Range::open(0.0, 100.0));
    fc.seed = static_cast<uint64_t>(params.integer("seed", 1, 0, std::numeric_limits<long>::max()));

    initial_stddev_ = params.numbers("initial_stddev", {0.3, 0.3, 0.1}, 3, Range::open(0.0, 1000.0));
    std::optional<Pose2> initial;
    if (params.has("initial_pose")) {
      const std::vector<double> p = params.numbers("initial_pose", {}, 3, Range::closed(-1e6, 1e6));
      initial = Pose2(p[0], p[1], p[2]);
    }

    auto index = std::make_shared<const NearestLandmarkIndex>(map_.landmarks, fc.candidates, cell, fc.max_range + 2.0,
                                                              context.limits.max_map_cells);
    filter_ = std::make_unique<CeilingParticleFilter>(
        fc, index, VelocityMotionModel({a[0], a[1], a[2], a[3], a[4], a[5]}));
    if (initial) {
      filter_->set_pose(*initial, Eigen::Vector3d(initial_stddev_[0], initial_stddev_[1], initial_stddev_[2])
                                      .cwiseAbs2()
                                      .asDiagonal());
    }
  }

  void set_pose(const PoseEstimate& pose) override {
    const Pose2 mean = Pose2::from_isometry(pose.pose);
    if (!std::isfinite(mean.x) || !std::isfinite(mean.y) || !std::isfinite(mean.theta)) {
      throw InputError("initial pose: position and yaw must be finite");
    }
    Eigen::Matrix3d cov;
    const int idx[3] = {0, 1, 5};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) cov(r, c) = pose.covariance(idx[r], idx[c]);
    const Eigen::LLT<Eigen::Matrix3d> llt(cov);
    if (!cov.allFinite() || llt.info() != Eigen::Success) {
      cov = Eigen::Vector3d(initial_stddev_[0], initial_stddev_[1], initial_stddev_[2]).cwiseAbs2().asDiagonal();
    }
    filter_->set_pose(mean, cov);
  }

  UpdateResult update(const Measurement& measurement) override {
    try {
      return std::visit([this](const auto& m) { return handle(m); }, measurement);
    } catch (const InputError&) {
      ++rejected_;
      throw;
    }
  }

  UpdateResult initial_outputs() const override {
    UpdateResult r;
    std::vector<MapFeature> features;
    for (size_t i = 0; i < map_.landmarks.size(); ++i) {
      MapFeature f;
      f.id = map_.id(i);
      f.kind = "ceiling_landmark";
      f.a = Eigen::Vector3d(map_.landmarks[i].x(), map_.landmarks[i].y(), camera_ ? camera_->lens_to_ceiling() + camera_->mounting().height : map_.ceiling_height);
      f.b = f.a;
      features.push_back(f);
    }
    r.landmark_map = std::move(features);
    return r;
  }

 private:
  UpdateResult handle(const Odometry& odom) {
    const Pose2 pose = Pose2::from_isometry(odom.pose);
    if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta)) {
      throw InputError("odometry: pose has a non-finite value");
    }
    if (last_odometry_ && odom.header.stamp_ns <= last_odometry_stamp_) {
      throw InputError("odometry: stamp " + std::to_string(odom.header.stamp_ns) + " ns is not after the previous " +
                       std::to_string(last_odometry_stamp_) + " ns");
    }
    UpdateResult result;
    if (last_odometry_) {
      const double dt = 1e-9 * static_cast<double>(odom.header.stamp_ns - last_odometry_stamp_);
      filter_->predict(velocity_between(*last_odometry_, pose, dt));
    }
    last_odometry_ = pose;
    last_odometry_stamp_ = odom.header.stamp_ns;
    result.estimate = make_estimate(odom.header);
    return result;
  }

  UpdateResult handle(const Image& image) {
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
    if (image.data.size() != static_cast<size_t>(image.width) * image.height) {
      throw InputError("image: " + std::to_string(image.data.size()) + " bytes, expected width * height = " +
                       std::to_string(static_cast<size_t>(image.width) * image.height));
    }
    const cv::Mat mono(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data.data()));
    std::vector<Detection> detections;
    for (const Eigen::Vector2d& p : detector_->detect_points(mono, *camera_)) detections.push_back(Detection::from_point(p));
    return correct(image.header, detections);
  }

  UpdateResult handle(const LandmarkDetections& frame) {
    if (frame.detections.size() > context_.limits.max_detections) {
      throw InputError("landmark detections: " + std::to_string(frame.detections.size()) +
                       " detections exceed limits.max_detections = " + std::to_string(context_.limits.max_detections));
    }
    std::vector<Detection> detections;
    for (size_t i = 0; i < frame.detections.size(); ++i) {
      const LandmarkDetection& d = frame.detections[i];
      if (!d.position.allFinite()) {
        throw InputError("landmark detections: detection " + std::to_string(i) + " ('" + d.class_label +
                         "') has a non-finite position; expected finite x, y in base_link");
      }
      if (!detection_label_.empty() && d.class_label != detection_label_) continue;
      detections.push_back(Detection::from_point(d.position.head<2>()));
    }
    return correct(frame.header, detections);
  }

  template <typename Other>
  UpdateResult handle(const Other&) {
    throw InputError("ceiling_pf consumes odometry, image and landmark detections only");
  }

  UpdateResult correct(const Header& header, const std::vector<Detection>& detections) {
    const CorrectionReport report = filter_->correct(detections);
    UpdateResult result;
    result.estimate = make_estimate(header);
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
    if (const auto e = filter_->estimate()) d.values.push_back({"cluster_mass", e->cluster_mass});
    for (size_t i = 0; i < report.associations.size(); ++i) {
      const Association& a = report.associations[i];
      d.associations.push_back({static_cast<uint32_t>(i), a.landmark >= 0 ? map_.id(static_cast<size_t>(a.landmark)) : "",
                                static_cast<uint32_t>(a.candidates), a.normalized_error2});
    }
    const auto& particles = filter_->particles();
    if (diagnostics_particles_ > 0 && !particles.empty()) {
      const size_t stride = (particles.size() + diagnostics_particles_ - 1) / diagnostics_particles_;
      for (size_t i = 0; i < particles.size(); i += stride) {
        const Particle& p = particles[i];
        d.particles.push_back({p.pose.x, p.pose.y, p.pose.theta, p.weight * static_cast<double>(stride)});
      }
    }
    return result;
  }

  std::optional<PoseEstimate> make_estimate(const Header& header) const {
    const auto e = filter_->estimate();
    if (!e) return std::nullopt;
    PoseEstimate out;
    out.header.stamp_ns = header.stamp_ns;
    out.header.frame_id = map_.frame_id;
    out.pose = e->pose.to_isometry();
    out.covariance.setZero();
    const int idx[3] = {0, 1, 5};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out.covariance(idx[r], idx[c]) = e->covariance(r, c);
    return out;
  }

  PluginContext context_;
  LandmarkMap map_;
  std::unique_ptr<CeilingCamera> camera_;
  std::unique_ptr<CeilingDetector> detector_;
  std::unique_ptr<CeilingParticleFilter> filter_;
  std::string detection_label_;
  std::vector<double> initial_stddev_{0.3, 0.3, 0.1};
  size_t diagnostics_particles_ = 500;
  std::optional<Pose2> last_odometry_;
  int64_t last_odometry_stamp_ = 0;
  size_t rejected_ = 0;
};

}  // namespace
}  // namespace locd::ceiling_pf

LOCD_REGISTER_PLUGIN(locd::ceiling_pf::CeilingPfLocalizer, "ceiling_pf", "1.0.0",
                     "Particle filter on identical ceiling landmarks (camera or on-board detections), "
                     "global localization and kidnap recovery",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kImage,
                                 locd::MeasurementKind::kLandmarkDetections))
