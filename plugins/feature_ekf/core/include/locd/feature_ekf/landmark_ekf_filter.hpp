// The paper's localization filter (Fig. 1) on ExtendedKalmanFilter<4>: IMU samples predict
// (eq. 7-9, 14), a frame of landmark detections is associated with the non-unique database
// (sec. 2.2, by the configured strategy) and fused (eq. 12-13). No I/O: the plugin copies
// parameters into LandmarkEkfConfig; the server has validated every message (locd/sdk/validate.hpp).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "locd/feature_ekf/extended_kalman_filter.hpp"
#include "locd/feature_ekf/geodetic_models.hpp"
#include "locd/feature_ekf/landmark_association.hpp"
#include "locd/feature_ekf/landmark_database.hpp"
#include "locd/sdk/types.hpp"

namespace locd::feature_ekf {

// A detection label is "class" or, for the known_id strategy (and evaluation), "class#id".
struct DetectionLabel {
  std::string class_label;
  std::string id;  // empty when not given
};
DetectionLabel parse_detection_label(const std::string& label);

struct DetectionReport {
  std::string label;
  int landmark = -1;          // chosen landmark index in the database, -1 = none
  size_t hypotheses = 0;      // same-class landmarks (eq. 15)
  size_t in_gate = 0;         // of them inside the gate (eq. 24)
  double mahalanobis2 = -1.0; // of the chosen (or nearest) hypothesis
  double weight = 0.0;        // pda: beta of the chosen landmark; 1 for the others when applied
  bool applied = false;       // an update was made with this detection
};

struct LandmarkUpdateReport {
  std::vector<DetectionReport> detections;
  size_t applied = 0;
};

class LandmarkEkfFilter {
 public:
  using Filter = ExtendedKalmanFilter<4>;
  using State = HorizontalModel::State;
  using StateMatrix = HorizontalModel::StateMatrix;

  LandmarkEkfFilter(LandmarkEkfConfig config, LandmarkDatabase database);

  // Position and velocity in ENU about the centre, covariance over (E, N, vE, vN).
  void set_state_enu(const Eigen::Vector2d& position, const Eigen::Vector2d& velocity,
                     const Eigen::Matrix4d& covariance_enu);

  // An IMU sample: from the second one on, predicts over the interval with the previous sample's
  // attitude and acceleration (Euler, eq. 9). Returns true when it predicted; a sample not after
  // the previous one (or after a gap above max_imu_gap) only restarts the prediction.
  bool apply_imu(const Imu& imu);

  // Association and update. Throws InputError (and changes nothing) before any IMU attitude, on
  // an unknown class or id, or a covariance that is not positive definite when detection_stddev is 0.
  LandmarkUpdateReport update(const LandmarkDetections& detections);

  const HorizontalModel& model() const { return model_; }
  const LandmarkDatabase& database() const { return database_; }
  const LandmarkAssociation& association() const { return association_; }
  const LandmarkEkfConfig& config() const { return config_; }
  const State& state() const { return filter_.state(); }
  const StateMatrix& covariance() const { return filter_.covariance(); }
  Eigen::Vector2d position_enu() const { return model_.position_enu(filter_.state()); }
  Eigen::Vector2d velocity_enu() const { return model_.velocity_enu(filter_.state()); }
  Eigen::Matrix4d covariance_enu() const;
  Eigen::Vector2d landmark_enu(size_t index) const { return landmark_enu_[index]; }
  bool has_attitude() const { return last_imu_.has_value(); }
  Eigen::Quaterniond attitude() const;

 private:
  struct PreparedDetection {
    LandmarkMeasurement measurement;
    std::vector<int> candidates;
  };
  PreparedDetection prepare(const LandmarkDetection& detection) const;
  DetectionHypotheses hypotheses(const PreparedDetection& d) const;
  bool apply(const PreparedDetection& d, const AssociationDecision& decision);

  LandmarkEkfConfig config_;
  LandmarkDatabase database_;
  HorizontalModel model_;
  LandmarkAssociation association_;
  Filter filter_;
  std::vector<Eigen::Vector2d> landmark_state_;  // database positions in state units
  std::vector<Eigen::Vector2d> landmark_enu_;
  StateMatrix process_noise_;
  std::optional<Imu> last_imu_;
};

}  // namespace locd::feature_ekf
