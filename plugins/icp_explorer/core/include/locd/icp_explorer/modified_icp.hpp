// Scan-to-model registration (paper eq. 1) by Gauss-Newton on SE(3): nearest model centroid per
// data point (kd-tree), the correspondence rejection of section 2.1 (CorrespondenceRejector),
// point-to-plane residuals where the model has a normal (model normals face the scanners that saw
// them: a model surface facing away from the scanner cannot be what it sees, so such pairs,
// typically the far face of a thin wall, are skipped), (point-to-point elsewhere, or everywhere
// when asked), and a Geman-McClure robust kernel whose scale halves from initial_kernel_scale
// down to kernel_scale each time the pose settles at the current scale (coarse to fine); while
// the scale is coarse (above 4 x kernel_scale) only every coarse_stride-th data point is used.
// Updates are left-multiplied: T <- exp(xi) T.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

#include "locd/icp_explorer/config.hpp"
#include "locd/icp_explorer/correspondence_rejection.hpp"
#include "locd/icp_explorer/scan_points.hpp"
#include "locd/icp_explorer/voxel_map.hpp"

namespace locd::icp_explorer {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

struct RegistrationResult {
  Eigen::Isometry3d T_map_base = Eigen::Isometry3d::Identity();
  bool converged = false;
  int iterations = 0;
  size_t correspondences = 0;                  // accepted in the last iteration
  std::array<size_t, kRejectionKinds> counts{};  // last iteration, by Rejection (kAccepted included)
  size_t beyond_distance = 0;                  // last iteration, farther than max_correspondence_distance
  size_t back_facing = 0;                      // last iteration, model surface facing away from the scanner
  double rms_error = 0.0;                      // m, kernel-weighted RMS residual, last iteration
  Matrix6d information = Matrix6d::Zero();     // J^T W J of the last iteration, (xi = v, omega)
};

// Skew matrix [v]x.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
// SE(3) exponential of xi = (v, omega) (translation first), as an isometry.
Eigen::Isometry3d se3_exp(const Vector6d& xi);
// d r / d xi at xi = 0 for r = n . (exp(xi) x - q) (point-to-plane) and r = exp(xi) x - q.
Eigen::Matrix<double, 1, 6> point_to_plane_jacobian(const Eigen::Vector3d& x_in_map, const Eigen::Vector3d& normal);
Eigen::Matrix<double, 3, 6> point_to_point_jacobian(const Eigen::Vector3d& x_in_map);

// scan: data points in base_link (downsampled); model: the map; T_initial: the start (odometry
// prediction); rejector: the rules around that prediction.
RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_initial,
                                 const CorrespondenceRejector& rejector, const IcpSettings& settings);

}  // namespace locd::icp_explorer
