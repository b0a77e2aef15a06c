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
  // Correspondence search with memory: where a data point was searched last (x_s), its nearest
  // model point there (d1) and a lower bound on the second nearest (d2). After the point moves
  // by delta, every other model point is at least d2 - delta away and the match at most
  // d1 + delta, so the match is unchanged while delta < (d2 - d1) / 2: no search needed (exact).
  // Otherwise the search is bounded by d2 + delta, which the two nearest cannot exceed.
  struct Match {
    Eigen::Vector3d searched_at;
    size_t model = 0;
    double nearest = -1.0, second = 0.0;  // m; nearest < 0: no match within the gate
  };
  std::vector<Match> matches(scan.points.size());
  std::vector<char> searched(scan.points.size(), 0);
  for (int iteration = 0; iteration < settings.max_iterations; ++iteration) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    RegistrationResult step;
    double squared_error = 0.0, weight_sum = 0.0;
    const double kernel2 = kernel * kernel;
    const Eigen::Vector3d scanner = result.T_map_base * rejector.sensor_in_base();
    const size_t stride =
        kernel > 4.0 * settings.kernel_scale ? static_cast<size_t>(std::max(1, settings.coarse_stride)) : 1;
    for (size_t i = 0; i < scan.points.size(); i += stride) {
      const Eigen::Vector3d& p = scan.points[i];
      const Eigen::Vector3d x = result.T_map_base * p;
      Match& match = matches[i];
      const double moved_since_search = searched[i] ? (x - match.searched_at).norm() : 0.0;
      if (!searched[i] || match.nearest < 0.0 || moved_since_search >= 0.5 * (match.second - match.nearest)) {
        double bound2 = max_distance2;
        if (searched[i] && match.nearest >= 0.0)
          bound2 = std::min(bound2, (match.second + moved_since_search) * (match.second + moved_since_search) * (1.0 + 1e-9) + 1e-12);
        size_t index[2];
        double distance2[2];
        const size_t found = model.nearest_two_within(x, bound2, index, distance2);
        searched[i] = 1;
        match.searched_at = x;
        match.model = index[0];
        match.nearest = found > 0 ? std::sqrt(distance2[0]) : -1.0;
        match.second = std::sqrt(distance2[1]);
      }
      const size_t j = match.model;
      const double d2 = match.nearest < 0.0 ? std::numeric_limits<double>::infinity() : (x - model.points()[j]).squaredNorm();
      if (d2 > max_distance2) {
        ++step.beyond_distance;
        continue;
      }
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
        const double r = n.dot(x - q);
        const double w = kernel2 / ((kernel2 + r * r) * (kernel2 + r * r)) * kernel2;  // Geman-McClure
        const auto J = point_to_plane_jacobian(x, n);
        H.noalias() += w * J.transpose() * J;
        g.noalias() += w * J.transpose() * r;
        squared_error += w * r * r;
        weight_sum += w;
      } else {
        const Eigen::Vector3d r = x - q;
        const double r2 = r.squaredNorm();
        const double w = kernel2 / ((kernel2 + r2) * (kernel2 + r2)) * kernel2;
        const auto J = point_to_point_jacobian(x);
        H.noalias() += w * J.transpose() * J;
        g.noalias() += w * J.transpose() * r;
        squared_error += w * r2;
        weight_sum += w;
      }
      ++step.correspondences;
    }
    result.iterations = iteration + 1;
    result.counts = step.counts;
    result.beyond_distance = step.beyond_distance;
    result.back_facing = step.back_facing;
    result.correspondences = step.correspondences;
    result.rms_error = weight_sum > 0.0 ? std::sqrt(squared_error / weight_sum) : 0.0;
    result.information = H;
    if (step.correspondences < 6) break;
    const Vector6d xi = -H.ldlt().solve(g);
    if (!xi.allFinite()) break;
    result.T_map_base = se3_exp(xi) * result.T_map_base;
    // Coarse to fine: the kernel halves once the pose has settled at the current scale (steps
    // below a tenth of the scale); at the final scale the convergence thresholds end the loop.
    const double moved = xi.head<3>().norm(), turned = xi.tail<3>().norm();
    if (kernel > settings.kernel_scale) {
      if (moved < 0.1 * kernel && turned < 0.01 * kernel) kernel = std::max(settings.kernel_scale, kernel * 0.5);
    } else if (moved < settings.convergence_translation && turned < settings.convergence_rotation) {
      result.converged = true;
      break;
    }
  }
  return result;
}

}  // namespace locd::icp_explorer
