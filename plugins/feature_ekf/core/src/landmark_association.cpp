#include "locd/feature_ekf/landmark_association.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include "locd/sdk/errors.hpp"

namespace locd::feature_ekf {

namespace {

constexpr size_t kMaxJointDetections = 64;

double squared_distance(const Eigen::Vector2d& r, const Eigen::Matrix2d& S) {
  const Eigen::LLT<Eigen::Matrix2d> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return llt.matrixL().solve(r).squaredNorm();
}

}  // namespace

const char* association_strategy_name(AssociationStrategy s) {
  switch (s) {
    case AssociationStrategy::kKnownId: return "known_id";
    case AssociationStrategy::kNearestNeighbor: return "nearest_neighbor";
    case AssociationStrategy::kJcbb: return "jcbb";
    case AssociationStrategy::kPda: return "pda";
  }
  return "?";
}

AssociationStrategy association_strategy_from_name(const std::string& name) {
  for (AssociationStrategy s : {AssociationStrategy::kKnownId, AssociationStrategy::kNearestNeighbor,
                                AssociationStrategy::kJcbb, AssociationStrategy::kPda}) {
    if (name == association_strategy_name(s)) return s;
  }
  throw ConfigError("unknown association strategy '" + name + "'; allowed: known_id, nearest_neighbor, jcbb, pda");
}

// The gate is a ChiSquareGate whose probability is the chi-square CDF of gamma (2 dof).
LandmarkAssociation::LandmarkAssociation(LandmarkAssociationConfig config)
    : config_(config), gate_(chi_square_cdf(config.gate_threshold, 2)) {
  joint_thresholds_.resize(kMaxJointDetections + 1, 0.0);
  for (size_t k = 1; k <= kMaxJointDetections; ++k) {
    joint_thresholds_[k] = chi_square_quantile(gate_.probability(), static_cast<int>(2 * k));
  }
}

std::vector<AssociationDecision> LandmarkAssociation::associate(std::vector<DetectionHypotheses>& frame,
                                                                const Eigen::Matrix2d& HPHt) const {
  for (DetectionHypotheses& d : frame) {
    for (Hypothesis& h : d.hypotheses) h.mahalanobis2 = squared_distance(h.residual, d.S);  // eq. 22
  }
  std::vector<AssociationDecision> decisions;
  switch (config_.strategy) {
    case AssociationStrategy::kKnownId:
      for (const DetectionHypotheses& d : frame) {
        AssociationDecision a;
        a.hypotheses = d.hypotheses.size();
        if (!d.hypotheses.empty() && std::isfinite(d.hypotheses[0].mahalanobis2)) {
          a.landmark = d.hypotheses[0].landmark;
          a.mahalanobis2 = d.hypotheses[0].mahalanobis2;
          a.in_gate = gate_.accepts(a.mahalanobis2, 2) ? 1 : 0;
          a.weights = {{0, 1.0}};
          a.false_weight = 0.0;
        }
        decisions.push_back(a);
      }
      return decisions;
    case AssociationStrategy::kNearestNeighbor:
      for (const DetectionHypotheses& d : frame) decisions.push_back(nearest(d));
      return decisions;
    case AssociationStrategy::kPda:
      for (const DetectionHypotheses& d : frame) decisions.push_back(probabilistic(d));
      return decisions;
    case AssociationStrategy::kJcbb:
      return joint_compatibility(frame, HPHt);
  }
  return decisions;
}

// Steps 1-2 of sec. 2.2.2: gate (eq. 24), then the nearest neighbour.
AssociationDecision LandmarkAssociation::nearest(const DetectionHypotheses& d) const {
  AssociationDecision a;
  a.hypotheses = d.hypotheses.size();
  double best = std::numeric_limits<double>::infinity();
  size_t best_index = 0;
  for (size_t i = 0; i < d.hypotheses.size(); ++i) {
    const double m = d.hypotheses[i].mahalanobis2;
    if (gate_.accepts(m, 2)) ++a.in_gate;
    if (m < best) {
      best = m;
      best_index = i;
    }
  }
  if (std::isfinite(best)) a.mahalanobis2 = best;
  if (a.in_gate > 0) {
    a.landmark = d.hypotheses[best_index].landmark;
    a.weights = {{best_index, 1.0}};
    a.false_weight = 0.0;
  }
  return a;
}

// PDA with origin uncertainty on the landmark side: beta_i ∝ (1 - p_false) N(r_i; 0, S) for the
// gated hypotheses (eq. 23), beta_0 ∝ p_false / V, a false detection uniform over the gate's
// area V = pi gamma sqrt(det S). All in the same (state) units, so the ratio is unit-free.
AssociationDecision LandmarkAssociation::probabilistic(const DetectionHypotheses& d) const {
  AssociationDecision a = nearest(d);
  a.landmark = -1;
  a.weights.clear();
  const double det = d.S.determinant();
  if (a.in_gate == 0 || !(det > 0.0)) {
    a.false_weight = 1.0;
    return a;
  }
  const double gamma = gate_.threshold(2);
  const double p_false = config_.false_detection_probability;
  // Both terms divided by the gaussian's peak 1 / (2 pi sqrt(det S)): p_false / V becomes
  // 2 p_false / gamma and N(r_i; 0, S) becomes exp(-d_i / 2).
  const double false_term = 2.0 * p_false / gamma;
  double total = false_term;
  for (size_t i = 0; i < d.hypotheses.size(); ++i) {
    const double m = d.hypotheses[i].mahalanobis2;
    if (!gate_.accepts(m, 2)) continue;
    const double w = (1.0 - p_false) * std::exp(-0.5 * m);
    a.weights.push_back({i, w});
    total += w;
  }
  a.false_weight = false_term / total;
  double best = a.false_weight;
  for (auto& [index, w] : a.weights) {
    w /= total;
    if (w > best) {
      best = w;
      a.landmark = d.hypotheses[index].landmark;
      a.mahalanobis2 = d.hypotheses[index].mahalanobis2;
    }
  }
  return a;
}

// JCBB over the frame's detections: the interpretation tree pairs detection k with a gated,
// not yet used landmark or with nothing; a branch is kept only while the joint residual of its
// pairings passes the chi-square test with 2 * pairings dof. Best = most pairings, then the
// smallest joint distance. Residuals of different detections share H P H^T as cross-covariance.
std::vector<AssociationDecision> LandmarkAssociation::joint_compatibility(
    const std::vector<DetectionHypotheses>& frame, const Eigen::Matrix2d& HPHt) const {
  const size_t n = std::min(frame.size(), kMaxJointDetections);
  std::vector<AssociationDecision> decisions;
  for (const DetectionHypotheses& d : frame) {
    AssociationDecision a = nearest(d);  // gate counts and nearest distance for the report
    a.landmark = -1;
    a.weights.clear();
    a.false_weight = 1.0;
    decisions.push_back(a);
  }
  // Per detection, its individually compatible hypotheses (by distance, nearest first).
  std::vector<std::vector<size_t>> gated(n);
  for (size_t k = 0; k < n; ++k) {
    for (size_t i = 0; i < frame[k].hypotheses.size(); ++i) {
      if (gate_.accepts(frame[k].hypotheses[i].mahalanobis2, 2)) gated[k].push_back(i);
    }
    std::sort(gated[k].begin(), gated[k].end(), [&](size_t a, size_t b) {
      return frame[k].hypotheses[a].mahalanobis2 < frame[k].hypotheses[b].mahalanobis2;
    });
  }

  std::vector<int> current(n, -1), best(n, -1);
  size_t best_pairings = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  size_t nodes = 0;

  auto joint_distance = [&](const std::vector<int>& assignment, size_t upto) {
    std::vector<size_t> paired;
    for (size_t k = 0; k < upto; ++k)
      if (assignment[k] >= 0) paired.push_back(k);
    const Eigen::Index m = static_cast<Eigen::Index>(2 * paired.size());
    Eigen::VectorXd r(m);
    Eigen::MatrixXd C(m, m);
    for (size_t a = 0; a < paired.size(); ++a) {
      r.segment<2>(2 * a) = frame[paired[a]].hypotheses[assignment[paired[a]]].residual;
      for (size_t b = 0; b < paired.size(); ++b) {
        C.block<2, 2>(2 * a, 2 * b) = a == b ? frame[paired[a]].S : HPHt;
      }
    }
    return mahalanobis2(r, C);
  };

  std::function<void(size_t, size_t)> descend = [&](size_t k, size_t pairings) {
    if (++nodes > config_.jcbb_max_nodes) return;
    if (k == n) {
      const double distance = pairings ? joint_distance(current, n) : 0.0;
      if (pairings > best_pairings || (pairings == best_pairings && distance < best_distance)) {
        best_pairings = pairings;
        best_distance = distance;
        best = current;
      }
      return;
    }
    for (size_t i : gated[k]) {
      const int landmark = frame[k].hypotheses[i].landmark;
      bool used = false;
      for (size_t j = 0; j < k && !used; ++j)
        used = current[j] >= 0 && frame[j].hypotheses[current[j]].landmark == landmark;
      if (used) continue;
      current[k] = static_cast<int>(i);
      if (joint_distance(current, k + 1) <= joint_thresholds_[pairings + 1]) descend(k + 1, pairings + 1);
      current[k] = -1;
    }
    // Leaving detection k unpaired (it may be false) can still tie the best only if enough remain.
    if (pairings + (n - k - 1) >= best_pairings) descend(k + 1, pairings);
  };
  descend(0, 0);

  for (size_t k = 0; k < n; ++k) {
    if (best[k] < 0) continue;
    const Hypothesis& h = frame[k].hypotheses[best[k]];
    decisions[k].landmark = h.landmark;
    decisions[k].mahalanobis2 = h.mahalanobis2;
    decisions[k].weights = {{static_cast<size_t>(best[k]), 1.0}};
    decisions[k].false_weight = 0.0;
  }
  return decisions;
}

}  // namespace locd::feature_ekf
