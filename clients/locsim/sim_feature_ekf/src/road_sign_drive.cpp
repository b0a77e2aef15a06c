#include "locd/sim_feature_ekf/road_sign_drive.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace locd::sim::road_signs {

namespace {

constexpr double kDegree = M_PI / 180.0;
constexpr double kEarthRate = 7.292115e-5;
constexpr double kGravity = 9.80665;

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

}  // namespace

DriveConfig DriveConfig::from_params(const Params& drive, const Params& imu, const Params& detector) {
  DriveConfig c;
  const Range positive = Range::positive(), non_negative = Range::non_negative();
  drive.expect_only({"duration_s", "cruise_speed", "turn_speed", "turn_radius", "max_acceleration"});
  c.duration = drive.number("duration_s", c.duration, positive);
  c.cruise_speed = drive.number("cruise_speed", c.cruise_speed, Range::closed(1.0, 50.0));
  c.turn_speed = drive.number("turn_speed", c.turn_speed, Range::closed(1.0, 50.0));
  c.turn_radius = drive.number("turn_radius", c.turn_radius, Range::closed(1.0, 50.0));
  c.max_acceleration = drive.number("max_acceleration", c.max_acceleration, positive);
  imu.expect_only({"rate_hz", "accelerometer_stddev", "heading_error_rms_deg", "tilt_error_rms_deg",
                   "attitude_error_time_s", "gravity_leak"});
  c.imu_rate = imu.number("rate_hz", c.imu_rate, Range::closed(1.0, 10000.0));
  c.accelerometer_stddev = imu.number("accelerometer_stddev", c.accelerometer_stddev, non_negative);
  c.heading_error_rms_deg = imu.number("heading_error_rms_deg", c.heading_error_rms_deg, non_negative);
  c.tilt_error_rms_deg = imu.number("tilt_error_rms_deg", c.tilt_error_rms_deg, non_negative);
  c.attitude_error_time = imu.number("attitude_error_time_s", c.attitude_error_time, positive);
  c.gravity_leak = imu.flag("gravity_leak", c.gravity_leak);
  detector.expect_only({"rate_hz", "min_range", "max_range", "fov_deg", "max_facing_error_deg",
                        "detection_probability", "position_stddev_at_max_range", "false_detection_rate",
                        "oracle_ids"});
  c.detection_rate = detector.number("rate_hz", c.detection_rate, Range::closed(0.01, c.imu_rate));
  c.min_range = detector.number("min_range", c.min_range, non_negative);
  c.max_range = detector.number("max_range", c.max_range, positive);
  if (c.max_range <= c.min_range) detector.fail("max_range", "must be greater than min_range");
  c.field_of_view_deg = detector.number("fov_deg", c.field_of_view_deg, Range::closed(1.0, 360.0));
  c.max_facing_error_deg = detector.number("max_facing_error_deg", c.max_facing_error_deg, Range::closed(0.0, 180.0));
  c.detection_probability = detector.number("detection_probability", c.detection_probability, Range::closed(0.0, 1.0));
  c.position_stddev_at_max_range =
      detector.number("position_stddev_at_max_range", c.position_stddev_at_max_range, non_negative);
  c.false_detection_rate = detector.number("false_detection_rate", c.false_detection_rate, non_negative);
  c.oracle_ids = detector.flag("oracle_ids", c.oracle_ids);
  return c;
}

RoadSignDrive::RoadSignDrive(const RoadSignWorld& world, DriveConfig config, uint64_t route_seed, uint64_t noise_seed)
    : world_(world), config_(config), rng_(noise_seed) {
  build_route(route_seed);
  ticks_per_frame_ = std::max(1L, std::lround(config_.imu_rate / config_.detection_rate));
  speed_ = config_.cruise_speed;
  const double sigma_tilt = config_.tilt_error_rms_deg * kDegree, sigma_heading = config_.heading_error_rms_deg * kDegree;
  attitude_error_ = {sigma_tilt * normal_(rng_), sigma_tilt * normal_(rng_), sigma_heading * normal_(rng_)};
  step_truth();
}

// A random walk over the intersections without U-turns, long enough for the drive; corners are
// quarter circles of turn_radius.
void RoadSignDrive::build_route(uint64_t seed) {
  std::mt19937_64 rng(seed);
  const WorldConfig& w = world_.config();
  int i = static_cast<int>(rng() % (w.blocks_east + 1)), j = static_cast<int>(rng() % (w.blocks_north + 1));
  std::vector<Eigen::Vector2i> nodes{{i, j}};
  Eigen::Vector2i from(-100, -100);
  const double needed = config_.cruise_speed * config_.duration * 1.2 + 2.0 * w.block_size;
  double length = 0.0;
  while (length < needed) {
    std::vector<Eigen::Vector2i> options;
    for (const Eigen::Vector2i step : {Eigen::Vector2i(1, 0), Eigen::Vector2i(-1, 0), Eigen::Vector2i(0, 1), Eigen::Vector2i(0, -1)}) {
      const Eigen::Vector2i n = nodes.back() + step;
      if (n.x() < 0 || n.y() < 0 || n.x() > w.blocks_east || n.y() > w.blocks_north || n == from) continue;
      options.push_back(n);
    }
    const Eigen::Vector2i next = options[rng() % options.size()];
    from = nodes.back();
    nodes.push_back(next);
    length += w.block_size;
  }
  const double r = config_.turn_radius;
  Eigen::Vector2d cursor = world_.node(nodes[0].x(), nodes[0].y());
  for (size_t k = 1; k < nodes.size(); ++k) {
    const Eigen::Vector2d a = world_.node(nodes[k - 1].x(), nodes[k - 1].y());
    const Eigen::Vector2d b = world_.node(nodes[k].x(), nodes[k].y());
    const Eigen::Vector2d d = (b - a).normalized();
    const double heading = std::atan2(d.y(), d.x());
    Eigen::Vector2d end = b;
    double turn = 0.0;
    if (k + 1 < nodes.size()) {
      const Eigen::Vector2d c = world_.node(nodes[k + 1].x(), nodes[k + 1].y());
      const Eigen::Vector2d d2 = (c - b).normalized();
      turn = d.x() * d2.y() - d.y() * d2.x();  // +1 left, -1 right, 0 straight on
      if (std::fabs(turn) > 0.5) end = b - r * d;
    }
    pieces_.push_back({cursor, heading, (end - cursor).norm(), 0.0});
    cursor = end;
    if (std::fabs(turn) > 0.5) {
      const double curvature = turn > 0 ? 1.0 / r : -1.0 / r;
      pieces_.push_back({cursor, heading, r * M_PI / 2.0, curvature});
      const Eigen::Vector2d c = world_.node(nodes[k + 1].x(), nodes[k + 1].y());
      cursor = b + r * (c - b).normalized();
    }
  }
  for (const Piece& p : pieces_) {
    piece_start_.push_back(route_length_);
    route_length_ += p.length;
  }
}

void RoadSignDrive::evaluate(double s, Eigen::Vector2d* position, double* heading, double* curvature) const {
  size_t k = std::upper_bound(piece_start_.begin(), piece_start_.end(), s) - piece_start_.begin();
  k = k == 0 ? 0 : k - 1;
  const Piece& p = pieces_[k];
  const double u = std::min(s - piece_start_[k], p.length);
  if (p.curvature == 0.0) {
    *position = p.start + u * Eigen::Vector2d(std::cos(p.heading), std::sin(p.heading));
  } else {
    const double h = p.heading + p.curvature * u;
    *position = p.start + Eigen::Vector2d(std::sin(h) - std::sin(p.heading), -std::cos(h) + std::cos(p.heading)) / p.curvature;
  }
  *heading = p.heading + p.curvature * u;
  *curvature = p.curvature;
}

double RoadSignDrive::distance_to_next_turn(double s) const {
  for (size_t k = 0; k < pieces_.size(); ++k) {
    if (pieces_[k].curvature != 0.0 && piece_start_[k] + pieces_[k].length > s) return std::max(0.0, piece_start_[k] - s);
  }
  return std::numeric_limits<double>::infinity();
}

// The truth at tick_ (ENU path -> ellipsoid, eq. 6-7) with this tick's acceleration.
void RoadSignDrive::step_truth() {
  const double dt = 1.0 / config_.imu_rate;
  // Speed: brake ahead of a corner so as to enter it at turn_speed.
  const double to_turn = distance_to_next_turn(s_);
  const double target = to_turn == 0.0 ? config_.turn_speed
                                       : std::min(config_.cruise_speed,
                                                  std::sqrt(config_.turn_speed * config_.turn_speed +
                                                            1.6 * config_.max_acceleration * to_turn));
  acceleration_ = std::clamp(2.0 * (target - speed_), -config_.max_acceleration, config_.max_acceleration);

  Eigen::Vector2d p;
  double psi = 0.0, kappa = 0.0;
  evaluate(s_, &p, &psi, &kappa);
  const WorldConfig& w = world_.config();
  const double lat0 = w.centre_latitude_deg * kDegree, h = w.altitude;
  const double Rm = world_.meridian_radius() + h, Rt = world_.transverse_radius() + h;
  const double v = speed_, a = acceleration_;
  const double E_dot = v * std::cos(psi), N_dot = v * std::sin(psi);
  const double E_ddot = a * std::cos(psi) - v * v * kappa * std::sin(psi);
  const double N_ddot = a * std::sin(psi) + v * v * kappa * std::cos(psi);
  const double lat = lat0 + p.y() / Rm;
  const double lon = w.centre_longitude_deg * kDegree + p.x() / (Rt * std::cos(lat0));
  const double vN = N_dot, vE = E_dot * std::cos(lat) / std::cos(lat0);
  const double lat_dot = N_dot / Rm;
  const double vN_dot = N_ddot, vE_dot = (E_ddot * std::cos(lat) - E_dot * std::sin(lat) * lat_dot) / std::cos(lat0);
  // Eq. 7 solved for the specific force.
  const double fN = vN_dot + 2.0 * kEarthRate * vE * std::sin(lat) + vE * vE * std::tan(lat) / Rt;
  const double fE = vE_dot - 2.0 * kEarthRate * vN * std::sin(lat) - vN * vE * std::tan(lat) / Rm;
  specific_force_ = {fE, fN};
  truth_.time = static_cast<double>(tick_) * dt;
  truth_.position = p;
  truth_.velocity = {vE, vN};
  truth_.yaw = std::atan2(vN, vE);
  truth_.latitude = lat;
  truth_.longitude = lon;
}

Imu RoadSignDrive::make_imu() {
  const Eigen::Matrix3d R_true = Eigen::AngleAxisd(truth_.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d R_reported = (Eigen::AngleAxisd(truth_.yaw + attitude_error_.z(), Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(attitude_error_.y(), Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(attitude_error_.x(), Eigen::Vector3d::UnitX()))
                                         .toRotationMatrix();
  const Eigen::Vector3d up(0.0, 0.0, kGravity);
  // The accelerometer senses the specific force in the true body frame; gravity is removed with
  // the AHRS attitude, so its errors leak gravity into the horizontal acceleration.
  const Eigen::Vector3d sensed = R_true.transpose() * (Eigen::Vector3d(specific_force_.x(), specific_force_.y(), 0.0) + up);
  Imu imu;
  imu.header.stamp_ns = static_cast<int64_t>(std::llround(truth_.time * 1e9)) + 1'000'000'000;
  imu.header.frame_id = "base_link";
  imu.orientation = Eigen::Quaterniond(R_reported);
  imu.linear_acceleration = sensed - (config_.gravity_leak ? R_reported : R_true).transpose() * up;
  for (int i = 0; i < 3; ++i) imu.linear_acceleration(i) += config_.accelerometer_stddev * normal_(rng_);
  imu.orientation_stddev = config_.heading_error_rms_deg * kDegree;
  imu.acceleration_stddev = config_.accelerometer_stddev;
  return imu;
}

LandmarkDetections RoadSignDrive::make_detections(std::vector<int>* true_signs) {
  LandmarkDetections frame;
  frame.header.stamp_ns = static_cast<int64_t>(std::llround(truth_.time * 1e9)) + 1'000'000'000;
  frame.header.frame_id = "base_link";
  const WorldConfig& w = world_.config();
  const double lat0 = w.centre_latitude_deg * kDegree;
  const double c = std::cos(truth_.yaw), s = std::sin(truth_.yaw);
  const double half_fov = 0.5 * config_.field_of_view_deg * kDegree;
  auto add = [&](const std::string& label, const Eigen::Vector2d& body, double range, int sign) {
    const double sigma = config_.position_stddev_at_max_range * range / config_.max_range;
    LandmarkDetection d;
    d.class_label = label;
    d.position = {body.x() + sigma * normal_(rng_), body.y() + sigma * normal_(rng_), 0.0};
    d.covariance = std::max(sigma * sigma, 1e-4) * Eigen::Matrix3d::Identity();
    frame.detections.push_back(d);
    true_signs->push_back(sign);
  };
  const std::vector<RoadSign>& signs = world_.signs();
  for (size_t k = 0; k < signs.size(); ++k) {
    const RoadSign& sign = signs[k];
    // Offset on the ellipsoid: north exact, east scaled by cos(lat) / cos(lat0) (eq. 10 inverse).
    const Eigen::Vector2d offset((sign.position.x() - truth_.position.x()) * std::cos(truth_.latitude) / std::cos(lat0),
                                 sign.position.y() - truth_.position.y());
    const Eigen::Vector2d body(c * offset.x() + s * offset.y(), -s * offset.x() + c * offset.y());
    const double range = body.norm();
    if (range < config_.min_range || range > config_.max_range || body.x() <= 0.0) continue;
    if (std::fabs(std::atan2(body.y(), body.x())) > half_fov) continue;
    if (std::fabs(wrap(sign.facing - truth_.yaw)) > config_.max_facing_error_deg * kDegree) continue;
    if (uniform_(rng_) >= config_.detection_probability) continue;
    add(config_.oracle_ids ? sign.class_label + "#" + sign.id : sign.class_label, body, range, static_cast<int>(k));
  }
  std::poisson_distribution<int> false_count(config_.false_detection_rate / config_.detection_rate);
  const int n_false = config_.false_detection_rate > 0.0 ? false_count(rng_) : 0;
  for (int k = 0; k < n_false; ++k) {
    const double range = config_.min_range + uniform_(rng_) * (config_.max_range - config_.min_range);
    const double bearing = (2.0 * uniform_(rng_) - 1.0) * half_fov;
    const auto& classes = w.classes;
    const std::string& label = classes[static_cast<size_t>(uniform_(rng_) * classes.size()) % classes.size()].first;
    add(label, range * Eigen::Vector2d(std::cos(bearing), std::sin(bearing)), range, -1);
  }
  return frame;
}

std::optional<DriveEvent> RoadSignDrive::next(double until) {
  const double dt = 1.0 / config_.imu_rate;
  if (frame_pending_) {
    frame_pending_ = false;
    DriveEvent e;
    e.truth = truth_;
    e.measurement = make_detections(&e.true_signs);
    // Then on to the next tick.
    s_ += speed_ * dt + 0.5 * acceleration_ * dt * dt;
    speed_ += acceleration_ * dt;
    ++tick_;
    step_truth();
    return e;
  }
  if (truth_.time > until || truth_.time > config_.duration || s_ >= route_length_) return std::nullopt;
  // Attitude errors: first-order Gauss-Markov with the configured RMS.
  const double phi = std::exp(-dt / config_.attitude_error_time), q = std::sqrt(1.0 - phi * phi);
  const double sigma_tilt = config_.tilt_error_rms_deg * kDegree, sigma_heading = config_.heading_error_rms_deg * kDegree;
  attitude_error_ = phi * attitude_error_ +
                    q * Eigen::Vector3d(sigma_tilt * normal_(rng_), sigma_tilt * normal_(rng_), sigma_heading * normal_(rng_));
  DriveEvent e;
  e.truth = truth_;
  e.measurement = make_imu();
  if (tick_ > 0 && tick_ % ticks_per_frame_ == 0) {
    frame_pending_ = true;
  } else {
    s_ += speed_ * dt + 0.5 * acceleration_ * dt * dt;
    speed_ += acceleration_ * dt;
    ++tick_;
    step_truth();
  }
  return e;
}

}  // namespace locd::sim::road_signs
