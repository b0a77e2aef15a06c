// Which database landmark produced each detection of a frame (sec. 2.2). Every same-class
// landmark is a hypothesis (eq. 15-17) with residual r_i = y_i - H x-bar and the common
// S = H P H^T + R (eq. 20, 22); its squared Mahalanobis distance d_i (eq. 22) is gated
// d_i <= gamma (eq. 24). Strategies:
//   known_id         the detection names its landmark (label "class#id"): the paper's ideal bound;
//   nearest_neighbor the paper: the smallest d_i inside the gate, per detection;
//   jcbb             joint compatibility branch and bound (Neira, Tardos 2001) over all detections
//                    of a frame: most pairings, then smallest joint distance, each landmark once;
//   pda              probabilistic data association (Bar-Shalom, Daum, Huang 2009): every gated
//                    hypothesis weighted by its likelihood (eq. 23), plus "the detection is false".
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/gaussian.hpp"

namespace locd::feature_ekf {

const char* association_strategy_name(AssociationStrategy s);
// Throws ConfigError for an unknown name.
AssociationStrategy association_strategy_from_name(const std::string& name);

// One hypothesis of a detection: a database landmark and its residual (state units).
struct Hypothesis {
  int landmark = -1;
  Eigen::Vector2d residual = Eigen::Vector2d::Zero();
  double mahalanobis2 = 0.0;
};

// A detection's hypotheses, all against the same prior: S = H P H^T + R.
struct DetectionHypotheses {
  Eigen::Matrix2d S = Eigen::Matrix2d::Identity();
  std::vector<Hypothesis> hypotheses;  // every same-class landmark (known_id: the named one)
};

struct AssociationDecision {
  int landmark = -1;          // chosen landmark (pda: the most probable one, when above "false")
  size_t hypotheses = 0;      // same-class landmarks (eq. 15)
  size_t in_gate = 0;         // hypotheses with d_i <= gamma (eq. 24)
  double mahalanobis2 = -1.0; // d of the chosen landmark; of the nearest one when none chosen
  // pda: (hypothesis index, beta) for each gated hypothesis, and beta of "the detection is false".
  std::vector<std::pair<size_t, double>> weights;
  double false_weight = 1.0;
  bool associated() const { return landmark >= 0; }
};

class LandmarkAssociation {
 public:
  explicit LandmarkAssociation(LandmarkAssociationConfig config = {});

  const LandmarkAssociationConfig& config() const { return config_; }
  const ChiSquareGate& gate() const { return gate_; }
  double gate_threshold() const { return gate_.threshold(2); }

  // Fills mahalanobis2 of every hypothesis, then decides per detection. HPHt = H P H^T, the part of
  // S common to all detections of the frame (their residuals' cross-covariance, used by jcbb).
  std::vector<AssociationDecision> associate(std::vector<DetectionHypotheses>& frame,
                                             const Eigen::Matrix2d& HPHt) const;

 private:
  AssociationDecision nearest(const DetectionHypotheses& d) const;
  AssociationDecision probabilistic(const DetectionHypotheses& d) const;
  std::vector<AssociationDecision> joint_compatibility(const std::vector<DetectionHypotheses>& frame,
                                                       const Eigen::Matrix2d& HPHt) const;

  LandmarkAssociationConfig config_;
  ChiSquareGate gate_;
  std::vector<double> joint_thresholds_;  // chi-square quantile for 2k dof at the gate's probability
};

}  // namespace locd::feature_ekf
