#include "locd/icp_explorer/modified_icp.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

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
  for (int iteration = 0; iteration < settings.max_iterations; ++iteration) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    RegistrationResult step;
    double squared_error = 0.0, weight_sum = 0.0;
    const double kernel2 = kernel * kernel;
    const Eigen::Vector3d scanner = result.T_map_base * rejector.sensor_in_base();
    for (size_t i = 0; i < scan.points.size(); ++i) {
      const Eigen::Vector3d& p = scan.points[i];
      const Eigen::Vector3d x = result.T_map_base * p;
      size_t j = 0;
      double d2 = 0.0;
      model.nearest(x, j, d2);
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
