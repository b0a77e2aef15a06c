#include "params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace locd::ceiling_pf {
namespace {

// The largest particle count a config may ask for, whatever the server allows.
constexpr long kMaxParticles = 10'000'000;
// Outlier share of the measurement model: (0, 1], 1 - hit_fraction > 0 keeps the outlier term.
const Range kHitFraction{0.0, 1.0, true, false};

void read_camera(const Params& params, const Limits& limits, double ceiling_height, Config& c) {
  const Params cam = params.child("camera");
  cam.expect_only({"width", "height", "fx", "fy", "cx", "cy", "mount", "lens_height"});
  if (!params.has("camera")) params.fail("camera", "is missing; expected width, height, fx, fy, cx, cy");
  CameraIntrinsics& in = c.camera;
  in.width = static_cast<int>(cam.integer("width", in.width, 16, 8192));
  in.height = static_cast<int>(cam.integer("height", in.height, 16, 8192));
  if (static_cast<size_t>(in.width) * in.height > limits.max_image_pixels) {
    cam.fail("width", "x height = " + std::to_string(in.width * in.height) + " pixels exceeds limits.max_image_pixels = " +
                          std::to_string(limits.max_image_pixels));
  }
  in.fx = cam.required_number("fx", Range::open(0.0, 1e5));
  in.fy = cam.required_number("fy", Range::open(0.0, 1e5));
  in.cx = cam.required_number("cx", Range::closed(0.0, in.width));
  in.cy = cam.required_number("cy", Range::closed(0.0, in.height));
  CameraMounting& m = c.mounting;
  const std::vector<double> mount = cam.numbers("mount", {m.x, m.y, m.yaw}, 3, Range::closed(-10.0, 10.0));
  m.x = mount[0];
  m.y = mount[1];
  m.yaw = mount[2];
  m.height = cam.number("lens_height", m.height, Range::closed(0.0, 100.0));
  if (!(ceiling_height > m.height)) {
    cam.fail("lens_height", "= " + std::to_string(m.height) + " must be below the ceiling height " +
                                std::to_string(ceiling_height));
  }
}

void read_detector(const Params& params, DetectorConfig& dc) {
  const Params det = params.child("detector");
  det.expect_only({"blur_kernel", "blur_sigma", "threshold", "hough_dp", "min_distance_px", "canny_threshold",
                   "accumulator_threshold", "min_radius_px", "max_radius_px", "max_circles", "pyramid_levels",
                   "refine_centroid"});
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
}

void read_measurement(const Params& params, Config& c) {
  ParticleFilterConfig& fc = c.filter;
  const Params meas = params.child("measurement");
  meas.expect_only({"range_stddev", "bearing_stddev", "hit_fraction", "candidates", "index_cell_size"});
  fc.range_stddev = meas.number("range_stddev", fc.range_stddev, Range::open(0.0, 10.0));
  fc.bearing_stddev = meas.number("bearing_stddev", fc.bearing_stddev, Range::open(0.0, M_PI));
  fc.hit_fraction = meas.number("hit_fraction", fc.hit_fraction, kHitFraction);
  fc.candidates = static_cast<int>(meas.integer("candidates", fc.candidates, 1, kMaxCandidates));
  c.index_cell_size = meas.number("index_cell_size", c.index_cell_size, Range::closed(0.05, 100.0));
}

void read_particles(const Params& params, const Limits& limits, ParticleFilterConfig& fc) {
  const Params part = params.child("particles");
  part.expect_only({"count", "kld_sampling", "min", "max", "global", "kld_epsilon", "kld_quantile", "kld_bin",
                    "resample_ess_fraction"});
  const long max_particles = static_cast<long>(std::min<size_t>(limits.max_particles, kMaxParticles));
  fc.particles = static_cast<size_t>(part.integer("count", static_cast<long>(fc.particles), 1, max_particles));
  fc.kld_sampling = part.flag("kld_sampling", fc.kld_sampling);
  fc.min_particles = static_cast<size_t>(part.integer("min", static_cast<long>(fc.min_particles), 1, max_particles));
  fc.max_particles = static_cast<size_t>(part.integer("max", std::min<long>(static_cast<long>(fc.max_particles), max_particles),
                                                      static_cast<long>(fc.min_particles), max_particles));
  fc.global_particles = static_cast<size_t>(part.integer("global", static_cast<long>(fc.max_particles), 1, max_particles));
  fc.kld_epsilon = part.number("kld_epsilon", fc.kld_epsilon, Range::open(0.0, 1.0));
  fc.kld_quantile = part.number("kld_quantile", fc.kld_quantile, Range::open(0.5, 1.0));
  const std::vector<double> bin =
      part.numbers("kld_bin", {fc.kld_bin.x(), fc.kld_bin.y(), fc.kld_bin.z()}, 3, Range::open(0.0, 100.0));
  fc.kld_bin = Eigen::Vector3d(bin[0], bin[1], bin[2]);
  fc.resample_ess_fraction = part.number("resample_ess_fraction", fc.resample_ess_fraction, Range::closed(0.0, 1.0));
}

void read_recovery(const Params& params, ParticleFilterConfig& fc) {
  const Params rec = params.child("recovery");
  rec.expect_only({"enabled", "alpha_slow", "alpha_fast", "min_injection_probability", "ambiguous_injection", "position_stddev",
                   "heading_stddev", "pair_distance_tolerance"});
  fc.recovery = rec.flag("enabled", fc.recovery);
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
}

}  // namespace

Config parse_config(const Params& params, const Limits& limits,
                    const std::function<double(const std::string& map)>& ceiling_height_of) {
  params.expect_only({"map", "ceiling_height", "camera", "detector", "detections", "motion", "measurement",
                      "particles", "recovery", "initial_pose", "initial_stddev", "output", "seed"});
  Config c;
  c.map = params.required_text("map");
  c.ceiling_height = params.number("ceiling_height", ceiling_height_of(c.map), Range::open(0.0, 100.0));
  read_camera(params, limits, *c.ceiling_height, c);
  read_detector(params, c.detector);

  const Params ext = params.child("detections");
  ext.expect_only({"class_label"});
  c.detection_label = ext.text("class_label", c.detection_label);

  const Params mot = params.child("motion");
  mot.expect_only({"alpha"});
  const std::vector<double> a = mot.numbers("alpha", std::vector<double>(c.motion_noise.begin(), c.motion_noise.end()), 6,
                                            Range::closed(0.0, 10.0));
  std::copy(a.begin(), a.end(), c.motion_noise.begin());

  read_measurement(params, c);
  read_particles(params, limits, c.filter);
  read_recovery(params, c.filter);

  const Params out = params.child("output");
  out.expect_only({"diagnostics_particles", "cluster_radius"});
  c.diagnostics_particles =
      static_cast<size_t>(out.integer("diagnostics_particles", static_cast<long>(c.diagnostics_particles), 0, 65536));
  c.filter.cluster_radius = out.number("cluster_radius", c.filter.cluster_radius, Range::open(0.0, 100.0));
  c.filter.seed = static_cast<uint64_t>(params.integer("seed", static_cast<long>(c.filter.seed), 0, std::numeric_limits<long>::max()));

  const std::vector<double> s =
      params.numbers("initial_stddev", {c.initial_stddev.x(), c.initial_stddev.y(), c.initial_stddev.z()}, 3,
                     Range::open(0.0, 1000.0));
  c.initial_stddev = Eigen::Vector3d(s[0], s[1], s[2]);
  if (params.has("initial_pose")) {
    const std::vector<double> p = params.numbers("initial_pose", {}, 3, Range::closed(-1e6, 1e6));
    c.initial_pose = Pose2(p[0], p[1], p[2]);
  }
  return c;
}

}  // namespace locd::ceiling_pf
