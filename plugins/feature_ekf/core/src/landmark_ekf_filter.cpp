#include "locd/feature_ekf/landmark_ekf_filter.hpp"

#include <cmath>

#include "locd/sdk/errors.hpp"

namespace locd::feature_ekf {

namespace {

constexpr double kDegree = M_PI / 180.0;

OperatingArea area_of(const LandmarkEkfConfig& config, const LandmarkDatabase& database) {
  double lat = 0.0, lon = 0.0;
  if (config.centre_deg) {
    lat = config.centre_deg->x();
    lon = config.centre_deg->y();
  } else {
    database.centre_deg(&lat, &lon);
  }
  return OperatingArea::centred_at(lat * kDegree, lon * kDegree, config.altitude);
}

const Eigen::Matrix<double, 2, 4> kH = (Eigen::Matrix<double, 2, 4>() << 1, 0, 0, 0, 0, 1, 0, 0).finished();

}  // namespace

DetectionLabel parse_detection_label(const std::string& label) {
  const size_t hash = label.find('#');
  if (hash == std::string::npos) return {label, {}};
  return {label.substr(0, hash), label.substr(hash + 1)};
}

LandmarkEkfFilter::LandmarkEkfFilter(LandmarkEkfConfig config, LandmarkDatabase database)
    : config_(std::move(config)),
      database_(std::move(database)),
      model_(config_.model, area_of(config_, database_)),
      association_(config_.association) {
  for (const Landmark& l : database_.landmarks()) {
    landmark_state_.push_back(model_.landmark_position(l.latitude_deg * kDegree, l.longitude_deg * kDegree));
    landmark_enu_.push_back(model_.area().to_enu(l.latitude_deg * kDegree, l.longitude_deg * kDegree));
  }
  // Q of eq. 14 in state units: position noise through T, velocity noise as is.
  const Eigen::Matrix2d T = model_.position_per_metre();
  process_noise_.setZero();
  process_noise_.topLeftCorner<2, 2>() =
      config_.position_noise_per_step * config_.position_noise_per_step * T * T.transpose();
  process_noise_.bottomRightCorner<2, 2>() =
      config_.velocity_noise_per_step * config_.velocity_noise_per_step * Eigen::Matrix2d::Identity();
  Eigen::Vector4d variance_enu;
  const double p = config_.initial_position_stddev, v = config_.initial_velocity_stddev;
  variance_enu << p * p, p * p, v * v, v * v;
  set_state_enu(config_.initial_position, config_.initial_velocity, variance_enu.asDiagonal());
}

void LandmarkEkfFilter::set_state_enu(const Eigen::Vector2d& position, const Eigen::Vector2d& velocity,
                                      const Eigen::Matrix4d& covariance_enu) {
  const StateMatrix J_inverse = model_.enu_jacobian().inverse();
  filter_.reset(model_.state_from_enu(position, velocity), J_inverse * covariance_enu * J_inverse.transpose());
}

Eigen::Matrix4d LandmarkEkfFilter::covariance_enu() const {
  const StateMatrix J = model_.enu_jacobian();
  return J * filter_.covariance() * J.transpose();
}

Eigen::Quaterniond LandmarkEkfFilter::attitude() const {
  return last_imu_ ? last_imu_->orientation.normalized() : Eigen::Quaterniond::Identity();
}

bool LandmarkEkfFilter::apply_imu(const Imu& imu) {
  const std::optional<Imu> previous = last_imu_;
  last_imu_ = imu;
  if (!previous) return false;
  const double dt = 1e-9 * static_cast<double>(imu.header.stamp_ns - previous->header.stamp_ns);
  if (!(dt > 0.0) || dt > config_.max_imu_gap) return false;
  // f^N = C_B^N f^B (eq. 7), horizontal part, from the sample at the start of the interval.
  const Eigen::Vector3d force = previous->orientation.normalized() * previous->linear_acceleration;
  const State x = filter_.state();
  filter_.predict<4>(model_.predict(x, force.head<2>(), dt), model_.transition_jacobian(x, dt),
                     StateMatrix::Identity(), process_noise_);
  return true;
}

LandmarkEkfFilter::PreparedDetection LandmarkEkfFilter::prepare(const LandmarkDetection& detection) const {
  const DetectionLabel label = parse_detection_label(detection.class_label);
  PreparedDetection d;
  if (config_.association.strategy == AssociationStrategy::kKnownId) {
    if (!label.id.empty()) d.candidates = {database_.index_of(label.id)};
  } else {
    d.candidates = database_.of_class(label.class_label);
  }
  Eigen::Vector2d offset;
  Eigen::Matrix2d covariance;
  Eigen::Matrix3d body_covariance = detection.covariance;
  if (config_.detection_stddev > 0.0) {
    body_covariance = config_.detection_stddev * config_.detection_stddev * Eigen::Matrix3d::Identity();
  }
  body_to_horizontal(attitude(), detection.position, body_covariance, &offset, &covariance);
  if (config_.detection_stddev > 0.0) {
    covariance = config_.detection_stddev * config_.detection_stddev * Eigen::Matrix2d::Identity();
  }
  d.measurement = landmark_measurement(model_, offset, covariance);
  return d;
}

// Eq. 16-17: y_i = l_i - T z, r_i = y_i - H x-bar, and S = H P H^T + R.
DetectionHypotheses LandmarkEkfFilter::hypotheses(const PreparedDetection& d) const {
  DetectionHypotheses h;
  h.S = filter_.innovation_covariance<2>(kH, d.measurement.covariance);
  const Eigen::Vector2d predicted = filter_.state().head<2>();
  for (int landmark : d.candidates) {
    h.hypotheses.push_back({landmark, landmark_state_[landmark] - d.measurement.offset - predicted, 0.0});
  }
  return h;
}

bool LandmarkEkfFilter::apply(const PreparedDetection& d, const AssociationDecision& decision) {
  const Eigen::Vector2d predicted = filter_.state().head<2>();
  if (config_.association.strategy == AssociationStrategy::kPda) {
    if (decision.weights.empty()) return false;
    std::vector<std::pair<Eigen::Vector2d, double>> weighted;
    for (const auto& [index, beta] : decision.weights) {
      weighted.push_back({landmark_state_[d.candidates[index]] - d.measurement.offset - predicted, beta});
    }
    return filter_.update_mixture<2>(weighted, decision.false_weight, kH, d.measurement.covariance);
  }
  if (!decision.associated()) return false;
  // Eq. 13 with y = l - T z (eq. 12), relinearized at the current state.
  const Eigen::Vector2d residual = landmark_state_[decision.landmark] - d.measurement.offset - predicted;
  return filter_.update<2>(residual, kH, d.measurement.covariance);
}

LandmarkUpdateReport LandmarkEkfFilter::update(const LandmarkDetections& detections) {
  if (!last_imu_) throw InputError("feature_ekf: landmark detections before any imu attitude");
  const bool known_id = config_.association.strategy == AssociationStrategy::kKnownId;
  for (size_t i = 0; i < detections.detections.size(); ++i) {
    const LandmarkDetection& d = detections.detections[i];
    const std::string which = "feature_ekf: detection " + std::to_string(i) + " ('" + d.class_label + "')";
    const DetectionLabel label = parse_detection_label(d.class_label);
    if (!database_.has_class(label.class_label)) {
      std::string known;
      for (const std::string& c : database_.classes()) known += (known.empty() ? "" : ", ") + c;
      throw InputError(which + ": class '" + label.class_label + "' is not in the landmark database; known: " + known);
    }
    if (known_id && !label.id.empty()) {
      const int index = database_.index_of(label.id);
      if (index < 0 || database_[index].class_label != label.class_label) {
        throw InputError(which + ": landmark id '" + label.id + "' of class '" + label.class_label +
                         "' is not in the landmark database");
      }
    }
    if (config_.detection_stddev <= 0.0 &&
        Eigen::LLT<Eigen::Matrix2d>(d.covariance.topLeftCorner<2, 2>()).info() != Eigen::Success) {
      throw InputError(which + ": covariance is not positive definite (needed: detection_stddev is 0)");
    }
  }

  LandmarkUpdateReport report;
  std::vector<PreparedDetection> prepared;
  for (const LandmarkDetection& d : detections.detections) {
    prepared.push_back(prepare(d));
    report.detections.push_back({d.class_label});
  }
  auto record = [&](size_t i, const AssociationDecision& a, bool applied) {
    DetectionReport& r = report.detections[i];
    r.landmark = a.landmark;
    r.hypotheses = known_id ? database_.of_class(parse_detection_label(r.label).class_label).size() : a.hypotheses;
    r.in_gate = a.in_gate;
    r.mahalanobis2 = a.mahalanobis2;
    r.weight = 0.0;
    for (const auto& [index, beta] : a.weights)
      if (prepared[i].candidates[index] == a.landmark) r.weight = beta;
    r.applied = applied;
    if (applied) ++report.applied;
  };

  if (config_.association.strategy == AssociationStrategy::kJcbb) {
    // Joint decision against the predicted state, then sequential updates (H is linear, so this
    // equals one stacked update).
    std::vector<DetectionHypotheses> frame;
    for (const PreparedDetection& d : prepared) frame.push_back(hypotheses(d));
    const Eigen::Matrix2d HPHt = kH * filter_.covariance() * kH.transpose();
    const std::vector<AssociationDecision> decisions = association_.associate(frame, HPHt);
    for (size_t i = 0; i < prepared.size(); ++i) record(i, decisions[i], apply(prepared[i], decisions[i]));
    return report;
  }
  // Sec. 2.2.2 steps 1-3 per detection, each against the state updated by the previous ones.
  for (size_t i = 0; i < prepared.size(); ++i) {
    std::vector<DetectionHypotheses> frame{hypotheses(prepared[i])};
    const Eigen::Matrix2d HPHt = kH * filter_.covariance() * kH.transpose();
    const AssociationDecision decision = association_.associate(frame, HPHt)[0];
    record(i, decision, apply(prepared[i], decision));
  }
  return report;
}

}  // namespace locd::feature_ekf
