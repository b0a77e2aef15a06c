#include "locd/icp_explorer/modified_icp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace locd::icp_explorer {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Isometry3d se3_exp(const Vector6d& xi) {
  const Eigen::Vector3d v = xi.head<3>(), w = xi.tail<3>();
  const double theta = w.norm();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d V = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d W = skew(w);
  if (theta > 1e-12) {
    R = Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
    V += (1 - std::cos(theta)) / (theta * theta) * W + (theta - std::sin(theta)) / (theta * theta * theta) * W * W;
  } else {
    R += W;
    V += 0.5 * W;
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = V * v;
  return T;
}

Eigen::Matrix<double, 1, 6> point_to_plane_jacobian(const Eigen::Vector3d& x, const Eigen::Vector3d& n) {
  Eigen::Matrix<double, 1, 6> J;
  J.head<3>() = n.transpose();
  J.tail<3>() = x.cross(n).transpose();
  return J;
}

Eigen::Matrix<double, 3, 6> point_to_point_jacobian(const Eigen::Vector3d& x) {
  Eigen::Matrix<double, 3, 6> J;
  J.leftCols<3>().setIdentity();
  J.rightCols<3>() = -skew(x);
  return J;
}

namespace {

// While the kernel is above this multiple of its final scale the registration is coarse: only
// every coarse_stride-th data point is used.
constexpr double kCoarseKernelMultiple = 4.0;
// The pose has settled at the current kernel scale when a step moves no point of the scan by more
// than this fraction of the scale (its translation, and its rotation times the farthest point's
// distance).
constexpr double kSettledFraction = 0.1;
// Each time the pose settles the kernel scale shrinks by this factor, down to kernel_scale.
constexpr double kKernelShrink = 0.5;
// A 6-DoF step needs at least this many accepted correspondences.
constexpr size_t kMinCorrespondences = 6;
// Slack on the bounded re-search radius (relative, and absolute in m^2) against rounding.
constexpr double kSearchBoundRelativeSlack = 1e-9;
constexpr double kSearchBoundAbsoluteSlack = 1e-12;

// Correspondence search with memory: where a data point was searched last (searched_at), its
// nearest model point there (nearest) and a lower bound on the second nearest (second). After the
// point moves by delta, every other model point is at least second - delta away and the match at
// most nearest + delta, so the match is unchanged while delta < (second - nearest) / 2: no search
// needed (exact). Otherwise the search is bounded by second + delta, which the two nearest cannot
// exceed.
struct RememberedMatch {
  Eigen::Vector3d searched_at;
  size_t model = 0;
  double nearest = -1.0, second = 0.0;  // m; nearest < 0: no match within the gate
  bool searched = false;
};

// The model point matched to x (a data point in the map frame); false when none lies within the gate.
bool match_point(const Eigen::Vector3d& x, const VoxelMap& model, double max_distance2, RememberedMatch& match) {
  const double moved_since_search = match.searched ? (x - match.searched_at).norm() : 0.0;
  if (!match.searched || match.nearest < 0.0 || moved_since_search >= 0.5 * (match.second - match.nearest)) {
    double bound2 = max_distance2;
    if (match.searched && match.nearest >= 0.0) {
      const double reach = match.second + moved_since_search;
      bound2 = std::min(bound2, reach * reach * (1.0 + kSearchBoundRelativeSlack) + kSearchBoundAbsoluteSlack);
    }
    size_t index[2];
    double distance2[2];
    const size_t found = model.nearest_two_within(x, bound2, index, distance2);
    match.searched = true;
    match.searched_at = x;
    match.model = index[0];
    match.nearest = found > 0 ? std::sqrt(distance2[0]) : -1.0;
    match.second = std::sqrt(distance2[1]);
  }
  return match.nearest >= 0.0 && (x - model.points()[match.model]).squaredNorm() <= max_distance2;
}

// Geman-McClure weight of a squared residual at kernel scale^2.
double geman_mcclure_weight(double residual2, double kernel2) {
  const double denominator = kernel2 + residual2;
  return kernel2 / (denominator * denominator) * kernel2;
}

// The normal equations of one Gauss-Newton step, with the statistics of the correspondences.
struct NormalEquations {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  double squared_error = 0.0, weight_sum = 0.0;
};

void add_point_to_plane(const Eigen::Vector3d& x, const Eigen::Vector3d& q, const Eigen::Vector3d& n, double kernel2,
                        NormalEquations& eq) {
  const double r = n.dot(x - q);
  const double w = geman_mcclure_weight(r * r, kernel2);
  const auto J = point_to_plane_jacobian(x, n);
  eq.H.noalias() += w * J.transpose() * J;
  eq.g.noalias() += w * J.transpose() * r;
  eq.squared_error += w * r * r;
  eq.weight_sum += w;
}

void add_point_to_point(const Eigen::Vector3d& x, const Eigen::Vector3d& q, double kernel2, NormalEquations& eq) {
  const Eigen::Vector3d r = x - q;
  const double r2 = r.squaredNorm();
  const double w = geman_mcclure_weight(r2, kernel2);
  const auto J = point_to_point_jacobian(x);
  eq.H.noalias() += w * J.transpose() * J;
  eq.g.noalias() += w * J.transpose() * r;
  eq.squared_error += w * r2;
  eq.weight_sum += w;
}

// Distance of the scan's farthest point from the base origin: the lever arm that turns a rotation
// (rad) into the largest displacement (m) it gives a point of the scan.
double lever_arm(const ScanPoints& scan) {
  double farthest2 = 0.0;
  for (const Eigen::Vector3d& p : scan.points) farthest2 = std::max(farthest2, p.squaredNorm());
  return std::sqrt(farthest2);
}

}  // namespace

RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_initial,
                                 const CorrespondenceRejector& rejector, const IcpSettings& settings) {
  RegistrationResult result;
  result.T_map_base = T_initial;
  if (model.empty() || scan.points.empty()) return result;
  const double max_distance2 = settings.max_correspondence_distance * settings.max_correspondence_distance;
  const bool with_intensity = scan.has_intensity() && rejector.rules().intensity;
  const float no_intensity = std::numeric_limits<float>::quiet_NaN();
  double kernel = std::max(settings.initial_kernel_scale, settings.kernel_scale);
  const bool oriented = model.normals_face_scanners();
  const double scan_lever_arm = lever_arm(scan);
  std::vector<RememberedMatch> matches(scan.points.size());
  for (int iteration = 0; iteration < settings.max_iterations; ++iteration) {
    NormalEquations eq;
    RegistrationResult step;
    const double kernel2 = kernel * kernel;
    const Eigen::Vector3d scanner = result.T_map_base * rejector.sensor_in_base();
    const size_t stride = kernel > kCoarseKernelMultiple * settings.kernel_scale
                              ? static_cast<size_t>(std::max(1, settings.coarse_stride))
                              : 1;
    for (size_t i = 0; i < scan.points.size(); i += stride) {
      const Eigen::Vector3d& p = scan.points[i];
      const Eigen::Vector3d x = result.T_map_base * p;
      if (!match_point(x, model, max_distance2, matches[i])) {
        ++step.beyond_distance;
        continue;
      }
      const size_t j = matches[i].model;
      const Eigen::Vector3d& q = model.points()[j];
      const Rejection verdict = rejector.check(p, with_intensity ? scan.intensity[i] : no_intensity, q,
                                               with_intensity ? model.intensity()[j] : no_intensity);
      ++step.counts[static_cast<size_t>(verdict)];
      if (verdict != Rejection::kAccepted) continue;
      const Eigen::Vector3d& n = model.normals()[j];
      if (oriented && n.dot(scanner - q) < 0.0) {
        ++step.back_facing;
        continue;
      }
      if (settings.metric == IcpMetric::kPointToPlane && !n.isZero()) {
        add_point_to_plane(x, q, n, kernel2, eq);
      } else {
        add_point_to_point(x, q, kernel2, eq);
      }
      ++step.correspondences;
    }
    result.iterations = iteration + 1;
    result.counts = step.counts;
    result.beyond_distance = step.beyond_distance;
    result.back_facing = step.back_facing;
    result.correspondences = step.correspondences;
    result.rms_error = eq.weight_sum > 0.0 ? std::sqrt(eq.squared_error / eq.weight_sum) : 0.0;
    result.information = eq.H;
    if (step.correspondences < kMinCorrespondences) break;
    const Vector6d xi = -eq.H.ldlt().solve(eq.g);
    if (!xi.allFinite()) break;
    result.T_map_base = se3_exp(xi) * result.T_map_base;
    // Coarse to fine: the kernel shrinks once the pose has settled at the current scale; at the
    // final scale the convergence thresholds end the loop.
    const double moved = xi.head<3>().norm(), turned = xi.tail<3>().norm();
    if (kernel > settings.kernel_scale) {
      const double settled = kSettledFraction * kernel;
      if (moved < settled && turned * scan_lever_arm < settled) {
        kernel = std::max(settings.kernel_scale, kernel * kKernelShrink);
      }
    } else if (moved < settings.convergence_translation && turned < settings.convergence_rotation) {
      result.converged = true;
      break;
    }
  }
  return result;
}

}  // namespace locd::icp_explorer
