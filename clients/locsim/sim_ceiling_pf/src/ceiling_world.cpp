#include "locd/sim_ceiling_pf/ceiling_world.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "locd/sdk/errors.hpp"

namespace locd::sim::ceiling {

CeilingWorldConfig CeilingWorldConfig::from_params(const Params& p) {
  p.expect_only({"layout", "size", "columns", "rows", "count", "jitter", "min_separation", "ceiling_height",
                 "landmark_radius", "distractors", "background", "lighting_gradient", "landmark_intensity", "seed"});
  CeilingWorldConfig c;
  c.layout = p.text("layout", c.layout, {"grid", "jittered_grid", "random"});
  const std::vector<double> size = p.numbers("size", {c.size.x(), c.size.y()}, 2, Range::closed(1.0, 10000.0));
  c.size = Eigen::Vector2d(size[0], size[1]);
  c.columns = static_cast<int>(p.integer("columns", c.columns, 1, 10000));
  c.rows = static_cast<int>(p.integer("rows", c.rows, 1, 10000));
  c.count = static_cast<int>(p.integer("count", c.count, 1, 1'000'000));
  c.jitter = p.number("jitter", c.jitter, Range::closed(0.0, 100.0));
  c.min_separation = p.number("min_separation", c.min_separation, Range::closed(0.0, 100.0));
  c.ceiling_height = p.number("ceiling_height", c.ceiling_height, Range::open(0.0, 100.0));
  c.landmark_radius = p.number("landmark_radius", c.landmark_radius, Range::open(0.0, 10.0));
  c.distractors = static_cast<int>(p.integer("distractors", c.distractors, 0, 100000));
  c.background = p.number("background", c.background, Range::closed(0.0, 255.0));
  c.lighting_gradient = p.number("lighting_gradient", c.lighting_gradient, Range::closed(-100.0, 100.0));
  c.landmark_intensity = p.number("landmark_intensity", c.landmark_intensity, Range::closed(0.0, 255.0));
  c.seed = static_cast<uint64_t>(p.integer("seed", static_cast<long>(c.seed), 0, std::numeric_limits<long>::max()));
  if (c.layout != "random" && c.count != c.columns * c.rows && p.has("count")) {
    p.fail("count", "= " + std::to_string(c.count) + " must equal columns * rows = " +
                        std::to_string(c.columns * c.rows) + " for layout " + c.layout);
  }
  if (c.layout != "random") c.count = c.columns * c.rows;
  return c;
}

CeilingWorld::CeilingWorld(const CeilingWorldConfig& config) : config_(config) {
  std::mt19937_64 rng(config_.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Eigen::Vector2d& size = config_.size;
  if (config_.layout == "random") {
    // Rejection sampling with a minimum separation; gives up on a landmark after many tries.
    const double margin = config_.landmark_radius;
    for (int i = 0; i < config_.count; ++i) {
      for (int attempt = 0; attempt < 1000; ++attempt) {
        const Eigen::Vector2d p(margin + unit(rng) * (size.x() - 2 * margin), margin + unit(rng) * (size.y() - 2 * margin));
        const bool clear = std::none_of(landmarks_.begin(), landmarks_.end(), [&](const Eigen::Vector2d& q) {
          return (q - p).norm() < config_.min_separation;
        });
        if (clear) {
          landmarks_.push_back(p);
          break;
        }
      }
    }
  } else {
    const double dx = size.x() / config_.columns, dy = size.y() / config_.rows;
    std::uniform_real_distribution<double> jitter(-config_.jitter, config_.jitter);
    for (int r = 0; r < config_.rows; ++r) {
      for (int c = 0; c < config_.columns; ++c) {
        Eigen::Vector2d p((c + 0.5) * dx, (r + 0.5) * dy);
        if (config_.layout == "jittered_grid") p += Eigen::Vector2d(jitter(rng), jitter(rng));
        landmarks_.push_back(p);
      }
    }
  }
  // Distractors: bright bars (tubes, vents), kept clear of the landmarks' disks.
  std::uniform_real_distribution<double> angle(0.0, M_PI);
  for (int i = 0; i < config_.distractors; ++i) {
    Distractor d;
    d.centre = Eigen::Vector2d(unit(rng) * size.x(), unit(rng) * size.y());
    d.length = 0.6 + 0.8 * unit(rng);
    d.width = 0.06 + 0.08 * unit(rng);
    d.angle = angle(rng);
    d.intensity = 200.0 + 40.0 * unit(rng);
    const double reach = 0.5 * d.length + config_.landmark_radius + 0.1;
    const bool clear = std::none_of(landmarks_.begin(), landmarks_.end(),
                                    [&](const Eigen::Vector2d& q) { return (q - d.centre).norm() < reach; });
    if (clear) distractors_.push_back(d);
  }
}

double CeilingWorld::background_at(const Eigen::Vector2d& p) const {
  return config_.background + config_.lighting_gradient * (p.x() - 0.5 * config_.size.x());
}

std::string CeilingWorld::map_yaml() const {
  std::ostringstream out;
  out.precision(6);
  out << std::fixed;
  out << "# Ceiling landmarks of the simulated hall, written by locd_ceiling_world_map from the\n"
      << "# scenario's sensors.ceiling_camera.world (layout " << config_.layout << ", seed " << config_.seed
      << ").\nframe_id: map\nceiling_height: " << config_.ceiling_height << "\nlandmarks:\n";
  for (const Eigen::Vector2d& p : landmarks_) out << "  - [" << p.x() << ", " << p.y() << "]\n";
  return out.str();
}

// ------------------------------------------------------------------ camera

CeilingCameraConfig CeilingCameraConfig::from_params(const Params& p) {
  p.expect_only({"rate_hz", "width", "height", "fx", "fy", "cx", "cy", "mount", "lens_height", "blur_sigma",
                 "noise_stddev", "frame_id", "world"});
  CeilingCameraConfig c;
  c.rate_hz = p.number("rate_hz", c.rate_hz, Range::closed(0.1, 1000.0));
  c.width = static_cast<int>(p.integer("width", c.width, 16, 8192));
  c.height = static_cast<int>(p.integer("height", c.height, 16, 8192));
  c.fx = p.number("fx", c.fx, Range::open(0.0, 1e5));
  c.fy = p.number("fy", c.fy, Range::open(0.0, 1e5));
  c.cx = p.number("cx", 0.5 * c.width - 0.5, Range::closed(0.0, c.width));
  c.cy = p.number("cy", 0.5 * c.height - 0.5, Range::closed(0.0, c.height));
  const std::vector<double> m = p.numbers("mount", {0.0, 0.0, 0.0}, 3, Range::closed(-10.0, 10.0));
  c.mount = Pose2(m[0], m[1], m[2]);
  c.lens_height = p.number("lens_height", c.lens_height, Range::closed(0.0, 100.0));
  c.blur_sigma = p.number("blur_sigma", c.blur_sigma, Range::closed(0.0, 20.0));
  c.noise_stddev = p.number("noise_stddev", c.noise_stddev, Range::closed(0.0, 100.0));
  c.frame_id = p.text("frame_id", c.frame_id);
  return c;
}

CeilingCameraRenderer::CeilingCameraRenderer(const CeilingCameraConfig& config, const CeilingWorld& world)
    : config_(config), world_(world) {
  if (!(world_.config().ceiling_height > config_.lens_height)) {
    throw std::invalid_argument("ceiling camera: lens height must be below the ceiling");
  }
  if (config_.noise_stddev > 0.0) {
    noise_tile_.create(2 * config_.height, 2 * config_.width);
    cv::RNG tile_rng(world_.config().seed + 0x9E3779B97F4A7C15ull);
    tile_rng.fill(noise_tile_, cv::RNG::NORMAL, 0.0, config_.noise_stddev);
  }
}

Eigen::Vector2d CeilingCameraRenderer::project(const Pose2& robot, const Eigen::Vector2d& q) const {
  const Pose2 camera = robot * config_.mount;
  const Eigen::Vector2d local = camera.inverse().transform(q);  // x: image top, y: image right
  const double h = world_.config().ceiling_height - config_.lens_height;
  return {config_.cx + config_.fx * local.y() / h, config_.cy - config_.fy * local.x() / h};
}

std::vector<VisibleLandmark> CeilingCameraRenderer::visible(const Pose2& robot) const {
  std::vector<VisibleLandmark> out;
  const double r = world_.config().landmark_radius * pixels_per_metre();
  const Pose2 inverse = robot.inverse();
  for (size_t i = 0; i < world_.landmarks().size(); ++i) {
    const Eigen::Vector2d px = project(robot, world_.landmarks()[i]);
    if (px.x() - r < -0.5 || px.y() - r < -0.5 || px.x() + r > config_.width - 0.5 || px.y() + r > config_.height - 0.5) continue;
    out.push_back({static_cast<int>(i), px, r, inverse.transform(world_.landmarks()[i])});
  }
  return out;
}

cv::Mat CeilingCameraRenderer::render(const Pose2& robot, std::mt19937_64& rng) const {
  const double h = world_.config().ceiling_height - config_.lens_height;
  const Pose2 camera = robot * config_.mount;
  // Pixel -> ceiling point is affine (camera looks straight up), so is the lighting gradient.
  auto ceiling_at = [&](double col, double row) {
    const Eigen::Vector2d local(-(row - config_.cy) * h / config_.fy, (col - config_.cx) * h / config_.fx);
    return camera.transform(local);
  };
  const double b0 = world_.background_at(ceiling_at(0, 0));
  const double bc = world_.background_at(ceiling_at(1, 0)) - b0;
  const double br = world_.background_at(ceiling_at(0, 1)) - b0;
  cv::Mat_<float> image(config_.height, config_.width);
  for (int row = 0; row < config_.height; ++row) {
    float* line = image[row];
    const double start = b0 + br * row;
    for (int col = 0; col < config_.width; ++col) line[col] = static_cast<float>(start + bc * col);
  }
  const double ppm = pixels_per_metre();
  constexpr int kShift = 4;  // sub-pixel precision of cv drawing: 1/16 px
  const double scale = 1 << kShift;
  const Eigen::AlignedBox2d view(Eigen::Vector2d(-200, -200), Eigen::Vector2d(config_.width + 200, config_.height + 200));
  for (const Distractor& d : world_.distractors()) {
    const Eigen::Vector2d c = project(robot, d.centre);
    if (!view.contains(c)) continue;
    const double angle_deg = (d.angle - camera.theta - M_PI / 2) * 180.0 / M_PI;  // bar axis in image x-right, y-down
    const cv::RotatedRect rect(cv::Point2f(static_cast<float>(c.x()), static_cast<float>(c.y())),
                               cv::Size2f(static_cast<float>(d.length * ppm), static_cast<float>(d.width * ppm)),
                               static_cast<float>(angle_deg));
    cv::Point2f corners[4];
    rect.points(corners);
    cv::Point pts[4];
    for (int i = 0; i < 4; ++i) pts[i] = cv::Point(cvRound(corners[i].x * scale), cvRound(corners[i].y * scale));
    cv::fillConvexPoly(image, pts, 4, cv::Scalar(d.intensity), cv::LINE_AA, kShift);
  }
  const int radius = cvRound(world_.config().landmark_radius * ppm * scale);
  for (const Eigen::Vector2d& q : world_.landmarks()) {
    const Eigen::Vector2d c = project(robot, q);
    if (!view.contains(c)) continue;
    cv::circle(image, cv::Point(cvRound(c.x() * scale), cvRound(c.y() * scale)), radius,
               cv::Scalar(world_.config().landmark_intensity), cv::FILLED, cv::LINE_AA, kShift);
  }
  if (config_.blur_sigma > 0.0) cv::GaussianBlur(image, image, cv::Size(0, 0), config_.blur_sigma);
  if (config_.noise_stddev > 0.0) {
    std::uniform_int_distribution<int> column(0, config_.width), row(0, config_.height);
    image += noise_tile_(cv::Rect(column(rng), row(rng), config_.width, config_.height));
  }
  cv::Mat mono;
  image.convertTo(mono, CV_8UC1);  // saturating
  return mono;
}

Image CeilingCameraRenderer::image(const Pose2& robot, int64_t stamp_ns, std::mt19937_64& rng) const {
  const cv::Mat mono = render(robot, rng);
  Image img;
  img.header.stamp_ns = stamp_ns;
  img.header.frame_id = config_.frame_id;
  img.width = mono.cols;
  img.height = mono.rows;
  img.channels = 1;
  img.data.assign(mono.data, mono.data + mono.total());
  return img;
}

}  // namespace locd::sim::ceiling
