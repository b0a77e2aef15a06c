// Scan-to-model registration (paper eq. 1) by Gauss-Newton on SE(3): nearest model centroid per
// data point (kd-tree), the correspondence rejection of section 2.1 (CorrespondenceRejector),
// point-to-plane residuals where the model has a normal (model normals face the scanners that saw
// them: a model surface facing away from the scanner cannot be what it sees, so such pairs,
// typically the far face of a thin wall, are skipped), (point-to-point elsewhere, or everywhere
// when asked), and a Geman-McClure robust kernel whose scale halves from initial_kernel_scale
// down to kernel_scale each time the pose settles at the current scale (coarse to fine); while
// the scale is coarse (above 4 x kernel_scale) only every coarse_stride-th data point is used.
// Updates are left-multiplied: T <- exp(xi) T.
//
// Degeneracy (Zhang, Kaess, Singh, "On degeneracy of optimization-based state estimation
// problems", ICRA 2016, with the odometry prior in place of their solution remapping): every step
// is taken in the local frame z = (v at the scanner, S omega), S the square root of the scan's
// inertia tensor about the scanner (rotation_scale), so that |z| is the RMS motion of the scan's
// points in metres whatever the direction. The information matrix (point-to-plane pairs only
// with that metric: a pair without a model normal would pin the scan to the voxel sampling of a
// bare surface) is split into eigen-directions in z; a direction's constraint is the information
// from pairs that constrain it strongly (|J_z u| >= 0.5: for a translation, a model normal within
// 60 degrees of it; after X-ICP, Tuna et al. 2023), as a share of the pairs' total kernel weight.
// Those below DegeneracySettings::min_constraint_share are poorly constrained: along them the step returns the pose to the prior (the odometry prediction)
// instead of following the data; the other directions take the Gauss-Newton step restricted to them. The result reports them, the covariance of the
// well-constrained part (sigma^2 H^+, sigma the RMS residual) and the information each earlier
// scan's voxels contributed (so a caller can add the uncertainty of the model itself).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "locd/icp_explorer/config.hpp"
#include "locd/icp_explorer/correspondence_rejection.hpp"
#include "locd/icp_explorer/scan_points.hpp"
#include "locd/icp_explorer/voxel_map.hpp"

namespace locd::icp_explorer {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Why the Gauss-Newton loop ended.
enum class IcpStop { kNotRun, kConverged, kIterationLimit, kTooFewCorrespondences, kSolverFailed };
const char* icp_stop_name(IcpStop stop);  // "not run", "converged", ...

struct RegistrationResult {
  Eigen::Isometry3d T_map_base = Eigen::Isometry3d::Identity();
  // The scan fits the model at the result: inlier share and inlier RMS within TrustSettings.
  bool fits = false;
  // True only when the result is trustworthy (TrustSettings): the loop converged, the inlier
  // share and the inliers' RMS residual pass, and at most max_degenerate_directions directions
  // are poorly constrained. `verdict` says which criterion decided.
  bool converged = false;
  std::string verdict;
  IcpStop stop = IcpStop::kNotRun;
  int iterations = 0;
  int coarse_iterations = 0;                   // register_coarse_to_fine: the coarse stage's
  size_t correspondences = 0;                  // accepted, at the final pose
  std::array<size_t, kRejectionKinds> counts{};  // at the final pose, by Rejection (kAccepted included)
  size_t beyond_distance = 0;                  // at the final pose, farther than max_correspondence_distance
  size_t back_facing = 0;                      // at the final pose, model surface facing away from the scanner
  double rms_error = 0.0;                      // m, kernel-weighted RMS residual at the final pose
  double kernel_scale = 0.0;                   // m, the final kernel scale (kernel_scale, or 3 x the residuals' robust sigma)
  // Data points overlapping the model (TrustSettings::overlap_distance) and, of them, inliers
  // (accepted, residual within inlier_distance). The share counts only points whose model point is
  // not on a floor or ceiling (|n_z| < 0.7; a floor fits whatever the horizontal error), over at
  // least 30 of them (within_reach: that count or 30).
  size_t within_reach = 0;
  size_t inliers = 0;                          // all overlapping points
  double inlier_share = 0.0;
  double inlier_rms = 0.0;                     // m, RMS residual of the inliers
  Matrix6d information = Matrix6d::Zero();     // J^T W J at the final pose (the pairs above), xi about the map origin

  // Degeneracy, in the local frame z (see above): the eigenvectors of the information (columns,
  // ascending eigenvalues), each one's constraint share (strong pairs' information / total
  // weight), and how many directions are poorly constrained.
  double lever_arm = 1.0;                      // m, RMS lever of the scan's points about the scanner (|S| / sqrt 2)
  Vector6d constraint_shares = Vector6d::Zero();
  Matrix6d directions = Matrix6d::Identity();
  int degenerate_directions = 0;
  Matrix6d local_to_xi = Matrix6d::Identity();  // xi = local_to_xi z at the final pose
  // The same in xi (left perturbation about the map origin): the covariance of the
  // well-constrained part, and the projector onto the poorly constrained directions (its
  // component of a perturbation; identity - projector keeps the rest).
  Matrix6d covariance = Matrix6d::Zero();
  Matrix6d degenerate_projector = Matrix6d::Zero();
  // What of the prior's covariance to keep: the projector onto the poorly constrained directions
  // plus, for directions constrained by less than twice min_constraint_share, sqrt(a) u u^T with a
  // falling linearly from 1 at the threshold to 0 at twice it (prior_projector P: P S P^T).
  Matrix6d prior_projector = Matrix6d::Zero();
  Matrix6d constrained_inverse = Matrix6d::Zero();  // H^+ on the well-constrained directions (covariance / sigma^2)
  // Information per model insert (VoxelMap::first_insert of the matched voxels), for the model's
  // own uncertainty: pairs (insert, J^T W J of the correspondences on its voxels).
  std::vector<std::pair<uint32_t, Matrix6d>> information_by_insert;
};

// Skew matrix [v]x.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
// SE(3) exponential of xi = (v, omega) (translation first), as an isometry.
Eigen::Isometry3d se3_exp(const Vector6d& xi);
// Its inverse: the xi with se3_exp(xi) = T (rotation angle below pi).
Vector6d se3_log(const Eigen::Isometry3d& T);
// Adjoint of T on xi = (v, omega): exp(Ad_T xi) T = T exp(xi).
Matrix6d se3_adjoint(const Eigen::Isometry3d& T);
// d r / d xi at xi = 0 for r = n . (exp(xi) x - q) (point-to-plane) and r = exp(xi) x - q.
Eigen::Matrix<double, 1, 6> point_to_plane_jacobian(const Eigen::Vector3d& x_in_map, const Eigen::Vector3d& normal);
Eigen::Matrix<double, 3, 6> point_to_point_jacobian(const Eigen::Vector3d& x_in_map);
// xi = local_to_xi(c, S) z: z = (v at the point c, S omega) to xi about the origin.
Matrix6d local_to_xi(const Eigen::Vector3d& c, const Eigen::Matrix3d& rotation_scale);
// S for points at `offsets` from the rotation centre: S = J^(1/2), J = tr(C) I - C, C = mean d d^T,
// so that |S omega|^2 = mean |omega x d|^2, the mean squared motion of the points.
Eigen::Matrix3d rotation_scale(const std::vector<Eigen::Vector3d>& offsets);

// scan: data points in base_link (downsampled); model: the map; T_start: where the iterations
// start; T_prior: the prior the poorly constrained directions are held to (the odometry
// prediction); rejector: the rules around that prediction. One resolution (settings.coarse is
// not used here).
RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_start,
                                 const Eigen::Isometry3d& T_prior, const CorrespondenceRejector& rejector,
                                 const IcpSettings& settings);
// Start and prior the same (the odometry prediction).
RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_initial,
                                 const CorrespondenceRejector& rejector, const IcpSettings& settings);

// Coarse to fine: when settings.coarse is enabled and coarse_model is given (the same map at
// settings.coarse.voxel_size), the scan thinned to that voxel size is registered to it first
// (kernel from coarse.initial_kernel_scale down to coarse.kernel_scale, the rejection margin
// widened by half a coarse voxel diagonal), then the full scan to `model` from there, holding the
// poorly constrained directions to T_prior throughout. The result is the fine stage's, with the
// coarse stage's iterations in coarse_iterations.
RegistrationResult register_coarse_to_fine(const ScanPoints& scan, const VoxelMap& model, const VoxelMap* coarse_model,
                                           const Eigen::Isometry3d& T_prior, const CorrespondenceRejector& rejector,
                                           const IcpSettings& settings);

}  // namespace locd::icp_explorer
