#include "locd/icp_explorer/modified_icp.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace locd::icp_explorer {

const char* icp_stop_name(IcpStop stop) {
  switch (stop) {
    case IcpStop::kNotRun: return "not run";
    case IcpStop::kConverged: return "converged";
    case IcpStop::kIterationLimit: return "iteration limit";
    case IcpStop::kTooFewCorrespondences: return "too few correspondences";
    case IcpStop::kSolverFailed: return "solver failed";
  }
  return "unknown";
}

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

Vector6d se3_log(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd angle_axis(T.linear());
  const double theta = angle_axis.angle();
  const Eigen::Vector3d w = theta * angle_axis.axis();
  const Eigen::Matrix3d W = skew(w);
  // V^-1 = I - W/2 + (1 - (theta/2) cot(theta/2)) / theta^2 W^2.
  Eigen::Matrix3d V_inverse = Eigen::Matrix3d::Identity() - 0.5 * W;
  if (theta > 1e-9) {
    const double half = 0.5 * theta;
    V_inverse += (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta) * W * W;
  }
  Vector6d xi;
  xi.head<3>() = V_inverse * T.translation();
  xi.tail<3>() = w;
  return xi;
}

Matrix6d se3_adjoint(const Eigen::Isometry3d& T) {
  Matrix6d A = Matrix6d::Zero();
  A.topLeftCorner<3, 3>() = T.linear();
  A.topRightCorner<3, 3>() = skew(T.translation()) * T.linear();
  A.bottomRightCorner<3, 3>() = T.linear();
  return A;
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

Matrix6d local_to_xi(const Eigen::Vector3d& c, const Eigen::Matrix3d& rotation_scale) {
  // A point x moves by v_c + omega x (x - c) = (v_c + c x omega) + omega x x: v = v_c + [c]x omega,
  // and omega = rotation_scale^-1 z_omega.
  const Eigen::Matrix3d inverse = rotation_scale.inverse();
  Matrix6d M = Matrix6d::Identity();
  M.topRightCorner<3, 3>() = skew(c) * inverse;
  M.bottomRightCorner<3, 3>() = inverse;
  return M;
}

Eigen::Matrix3d rotation_scale(const std::vector<Eigen::Vector3d>& offsets) {
  // Mean squared motion of the points d under a small rotation omega: mean |omega x d|^2 =
  // omega^T J omega with J = tr(C) I - C, C = mean d d^T (the points' inertia tensor per point).
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& d : offsets) C += d * d.transpose();
  if (!offsets.empty()) C /= static_cast<double>(offsets.size());
  const Eigen::Matrix3d J = C.trace() * Eigen::Matrix3d::Identity() - C;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(J);
  // A floor of 1 mm^2 keeps a degenerate scan (all points on one line through the scanner) invertible.
  const Eigen::Vector3d root = eigen.eigenvalues().cwiseMax(1e-6).cwiseSqrt();
  return eigen.eigenvectors() * root.asDiagonal() * eigen.eigenvectors().transpose();
}

namespace {

// z = xi_to_local(c, S) xi, the inverse of local_to_xi.
Matrix6d xi_to_local(const Eigen::Vector3d& c, const Eigen::Matrix3d& rotation_scale) {
  Matrix6d N = Matrix6d::Identity();
  N.topRightCorner<3, 3>() = -skew(c);
  N.bottomRightCorner<3, 3>() = rotation_scale;
  return N;
}

// While the kernel is above this multiple of its final scale the registration is coarse: only
// every coarse_stride-th data point is used.
constexpr double kCoarseKernelMultiple = 4.0;
// The pose has settled at the current kernel scale when a step moves no point of the scan by
// more than this fraction of the scale.
constexpr double kSettledFraction = 0.1;
// Each time the pose settles the kernel scale shrinks by this factor, down to kernel_scale but
// never below this multiple of the residuals' robust standard deviation: a kernel narrower than
// the data's own noise would discard good correspondences and leave the optimum to a few of them.
constexpr double kKernelShrink = 0.5;
constexpr double kNoiseMultiple = 3.0;
// A model normal with |n_z| at or above this is a floor or a ceiling (trust: structure share).
constexpr double kLevelSurface = 0.7;
// The inlier share is taken over structure (walls, furniture), over at least this many points.
constexpr size_t kMinStructurePoints = 30;
// Iterates kept for the covariance of a registration that did not converge.
constexpr size_t kRecentPoses = 5;
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
// exceed. The rejection rules' verdict depends only on the pair (the data point in base_link and
// the model point), so it is kept with the match.
struct RememberedMatch {
  Eigen::Vector3d searched_at;
  size_t model = 0;
  double nearest = -1.0, second = 0.0;  // m; nearest < 0: no match within the gate
  bool searched = false;
  bool judged = false;
  Rejection verdict = Rejection::kAccepted;
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
    if (!match.searched || found == 0 || index[0] != match.model) match.judged = false;
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

// One pass over the data points at a pose: the normal equations (upper triangle of H while
// accumulating) and the statistics of the correspondences.
struct Pass {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  double squared_error = 0.0, weight_sum = 0.0;
  // The information the degeneracy analysis and the covariance use: with the point-to-plane
  // metric only the point-to-plane pairs (a pair without a model normal, e.g. on the sparse far
  // rings of a floor, would pin the scan to the voxel sampling along a bare surface: a constraint
  // the geometry does not give); with point-to-point every pair.
  Matrix6d information = Matrix6d::Zero();
  double information_weight = 0.0, information_squared_error = 0.0;
  // Each pair's Jacobian rows in xi, with its weight and the data point in the map frame (the
  // strong-contribution test of the analysis).
  std::vector<Eigen::Matrix<double, 1, 6>> rows;
  std::vector<double> row_weights;
  std::vector<Eigen::Vector3d> row_points;
  size_t correspondences = 0, beyond_distance = 0, back_facing = 0, within_reach = 0;
  std::array<size_t, kRejectionKinds> counts{};
  std::vector<double> residuals;  // |r| of accepted correspondences (point-to-point: |r| / sqrt(3))
  // Final pass only.
  size_t inliers = 0;
  double inlier_squared_error = 0.0;
  // The same over the points whose model point is not on a floor or ceiling (normal within
  // kLevelSurface of vertical): a floor fits whatever the horizontal error.
  size_t structure_within_reach = 0, structure_inliers = 0;
  std::vector<int> insert_slot;  // model insert -> index in by_insert, -1 if none yet
  std::vector<std::pair<uint32_t, Matrix6d>> by_insert;
};

// Robust standard deviation of the residuals: 1.4826 x their median absolute value.
double robust_sigma(std::vector<double> residuals) {
  if (residuals.empty()) return 0.0;
  const auto middle = residuals.begin() + static_cast<std::ptrdiff_t>(residuals.size() / 2);
  std::nth_element(residuals.begin(), middle, residuals.end());
  return 1.4826 * *middle;
}

// The scan's points relative to the scanner, in base_link.
std::vector<Eigen::Vector3d> offsets_from(const ScanPoints& scan, const Eigen::Vector3d& scanner) {
  std::vector<Eigen::Vector3d> d;
  d.reserve(scan.points.size());
  for (const Eigen::Vector3d& p : scan.points) d.push_back(p - scanner);
  return d;
}

class Registration {
 public:
  Registration(const ScanPoints& scan, const VoxelMap& model, const CorrespondenceRejector& rejector,
               const IcpSettings& settings)
      : scan_(scan),
        model_(model),
        rejector_(rejector),
        settings_(settings),
        max_distance2_(settings.max_correspondence_distance * settings.max_correspondence_distance),
        with_intensity_(scan.has_intensity() && rejector.rules().intensity),
        oriented_(model.normals_face_scanners()),
        matches_(scan.points.size()) {}

  Pass run_pass(const Eigen::Isometry3d& T, double kernel, size_t stride, bool final_pass) {
    Pass pass;
    pass.residuals.reserve(scan_.points.size() / stride + 1);
    pass.rows.reserve(scan_.points.size() / stride + 1);
    pass.row_weights.reserve(scan_.points.size() / stride + 1);
    pass.row_points.reserve(scan_.points.size() / stride + 1);
    const double kernel2 = kernel * kernel;
    const double inlier2 = settings_.trust.inlier_distance * settings_.trust.inlier_distance;
    const double overlap2 = settings_.trust.overlap_distance * settings_.trust.overlap_distance;
    const Eigen::Vector3d scanner = T * rejector_.sensor_in_base();
    const float no_intensity = std::numeric_limits<float>::quiet_NaN();
    if (final_pass) pass.insert_slot.assign(model_.inserts(), -1);
    for (size_t i = 0; i < scan_.points.size(); i += stride) {
      const Eigen::Vector3d& p = scan_.points[i];
      const Eigen::Vector3d x = T * p;
      RememberedMatch& match = matches_[i];
      if (!match_point(x, model_, max_distance2_, match)) {
        ++pass.beyond_distance;
        continue;
      }
      const size_t j = match.model;
      if (!match.judged) {
        match.verdict = rejector_.check(p, with_intensity_ ? scan_.intensity[i] : no_intensity, model_.points()[j],
                                        with_intensity_ ? model_.intensity()[j] : no_intensity);
        match.judged = true;
      }
      ++pass.counts[static_cast<size_t>(match.verdict)];
      if (match.verdict != Rejection::kAccepted) continue;
      const Eigen::Vector3d& q = model_.points()[j];
      const Eigen::Vector3d& n = model_.normals()[j];
      if (oriented_ && n.dot(scanner - q) < 0.0) {
        ++pass.back_facing;
        continue;
      }
      // The scan overlaps the model here: an accepted, front-facing pair within overlap_distance (a
      // point farther from every model point, or facing the back of a surface, sees something new).
      const bool overlapping = (x - q).squaredNorm() <= overlap2;
      const bool structure = std::abs(n.z()) < kLevelSurface;
      pass.within_reach += overlapping;
      pass.structure_within_reach += overlapping && structure;
      double residual2 = 0.0, w = 0.0;
      bool in_information = false;
      Matrix6d JtJ;
      if (settings_.metric == IcpMetric::kPointToPlane && !n.isZero()) {
        const double r = n.dot(x - q);
        residual2 = r * r;
        w = geman_mcclure_weight(residual2, kernel2);
        const Eigen::Matrix<double, 1, 6> J = point_to_plane_jacobian(x, n);
        for (int a = 0; a < 6; ++a)  // upper triangle; completed after the pass
          for (int b = a; b < 6; ++b) pass.information(a, b) += w * J(a) * J(b);
        pass.g.noalias() += (w * r) * J.transpose();
        in_information = true;
        pass.rows.push_back(J);
        pass.row_weights.push_back(w);
        pass.row_points.push_back(x);
        if (final_pass) JtJ.noalias() = J.transpose() * J;
      } else {
        const Eigen::Vector3d r = x - q;
        residual2 = r.squaredNorm();
        w = geman_mcclure_weight(residual2, kernel2);
        const Eigen::Matrix<double, 3, 6> J = point_to_point_jacobian(x);
        pass.H.noalias() += w * J.transpose() * J;
        pass.g.noalias() += w * J.transpose() * r;
        in_information = settings_.metric == IcpMetric::kPointToPoint;
        if (in_information)
          for (int a = 0; a < 3; ++a) {
            pass.rows.push_back(J.row(a));
            pass.row_weights.push_back(w);
            pass.row_points.push_back(x);
          }
        if (final_pass) JtJ.noalias() = J.transpose() * J;
      }
      pass.residuals.push_back(settings_.metric == IcpMetric::kPointToPlane && !n.isZero() ? std::sqrt(residual2)
                                                                                          : std::sqrt(residual2 / 3.0));
      pass.squared_error += w * residual2;
      pass.weight_sum += w;
      ++pass.correspondences;
      if (in_information) {
        pass.information_weight += w;
        pass.information_squared_error += w * residual2;
      }
      if (final_pass) {
        if (overlapping && residual2 <= inlier2) {
          ++pass.inliers;
          pass.structure_inliers += structure;
          pass.inlier_squared_error += residual2;
        }
        const uint32_t insert = model_.first_insert(j);
        if (in_information && insert < pass.insert_slot.size()) {
          if (pass.insert_slot[insert] < 0) {
            pass.insert_slot[insert] = static_cast<int>(pass.by_insert.size());
            pass.by_insert.emplace_back(insert, Matrix6d::Zero());
          }
          pass.by_insert[static_cast<size_t>(pass.insert_slot[insert])].second.noalias() += w * JtJ;
        }
      }
    }
    // Point-to-plane pairs filled the upper triangle of `information`, point-to-point pairs all of H.
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < a; ++b) pass.information(a, b) = pass.information(b, a);
    if (settings_.metric == IcpMetric::kPointToPlane) {
      pass.H += pass.information;
    } else {
      pass.information = pass.H;
    }
    return pass;
  }

 private:
  const ScanPoints& scan_;
  const VoxelMap& model_;
  const CorrespondenceRejector& rejector_;
  const IcpSettings& settings_;
  const double max_distance2_;
  const bool with_intensity_;
  const bool oriented_;
  std::vector<RememberedMatch> matches_;
};

// The information in the local frame z = N xi, split into eigen-directions (ascending
// eigenvalues). A direction's constraint is the information it gets from pairs that constrain it
// strongly: the pair's residual direction (its model normal) within 60 degrees of the motion the
// direction gives its point (|J u| >= kStrongContribution |motion|), as a share of the pairs'
// total weight (after X-ICP, Tuna et al. 2023: many pairs each leaning slightly toward a
// direction, e.g. the slightly tilted normals of a bare corridor's walls along its axis, do not
// make it constrained). Directions whose share is below the threshold are
// poorly constrained; they are ordered first (`degenerate` of them) in `order`.
struct LocalSystem {
  Matrix6d M, N;  // xi = M z, z = N xi
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen;
  Vector6d shares = Vector6d::Zero();
  Matrix6d U = Matrix6d::Identity();  // eigenvectors, poorly constrained first
  Vector6d lambda = Vector6d::Zero();  // their eigenvalues
  std::array<int, 6> order{};          // U.col(k) = eigenvectors().col(order[k])
  int degenerate = 0;
  int order_index(int k) const { return order[static_cast<size_t>(k)]; }
};

constexpr double kStrongContribution = 0.5;
constexpr double kSurelyConstrained = 0.1;

LocalSystem local_system(const Pass& pass, const Eigen::Vector3d& scanner, const Eigen::Matrix3d& rotation_scale,
                         const DegeneracySettings& settings) {
  LocalSystem s;
  s.M = local_to_xi(scanner, rotation_scale);
  s.N = xi_to_local(scanner, rotation_scale);
  s.eigen.compute(s.M.transpose() * pass.information * s.M);
  const Matrix6d V = s.M * s.eigen.eigenvectors();  // J_xi V = J_z U
  const double total = std::max(pass.information_weight, 1e-12);
  // Directions whose eigenvalue alone is a large share are constrained whatever the count (many
  // slightly leaning pairs cannot add up to it); the count is made for the others only.
  std::array<bool, 6> count{};
  for (int i = 0; i < 6; ++i) count[static_cast<size_t>(i)] = s.eigen.eigenvalues()(i) < kSurelyConstrained * total;
  Vector6d strong = s.eigen.eigenvalues();
  for (int i = 0; i < 6; ++i)
    if (count[static_cast<size_t>(i)]) strong(i) = 0.0;
  const double tau2 = kStrongContribution * kStrongContribution;
  for (size_t k = 0; k < pass.rows.size(); ++k) {
    const Eigen::Vector3d& x = pass.row_points[k];
    for (int i = 0; i < 6; ++i) {
      if (!count[static_cast<size_t>(i)]) continue;
      const double c = pass.rows[k].dot(V.col(i));
      const double motion2 = (V.col(i).head<3>() + V.col(i).tail<3>().cross(x)).squaredNorm();
      if (c * c >= tau2 * motion2) strong(i) += pass.row_weights[k] * c * c;
    }
  }
  std::vector<int> order, constrained;
  for (int i = 0; i < 6; ++i) {
    s.shares(i) = strong(i) / total;
    const bool poor = !(s.shares(i) >= settings.min_constraint_share && s.eigen.eigenvalues()(i) > 0.0);
    (poor ? order : constrained).push_back(i);
  }
  s.degenerate = static_cast<int>(order.size());
  order.insert(order.end(), constrained.begin(), constrained.end());
  for (int k = 0; k < 6; ++k) {
    s.order[static_cast<size_t>(k)] = order[static_cast<size_t>(k)];
    s.U.col(k) = s.eigen.eigenvectors().col(order[static_cast<size_t>(k)]);
    s.lambda(k) = s.eigen.eigenvalues()(order[static_cast<size_t>(k)]);
  }
  return s;
}

}  // namespace

RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_initial,
                                 const CorrespondenceRejector& rejector, const IcpSettings& settings) {
  return register_scan(scan, model, T_initial, T_initial, rejector, settings);
}

RegistrationResult register_coarse_to_fine(const ScanPoints& scan, const VoxelMap& model, const VoxelMap* coarse_model,
                                           const Eigen::Isometry3d& T_prior, const CorrespondenceRejector& rejector,
                                           const IcpSettings& settings) {
  if (!settings.coarse.enabled || coarse_model == nullptr || coarse_model->empty())
    return register_scan(scan, model, T_prior, T_prior, rejector, settings);
  const CoarseStageSettings& c = settings.coarse;
  std::vector<Eigen::Vector3f> points;
  points.reserve(scan.points.size());
  for (const Eigen::Vector3d& p : scan.points) points.push_back(p.cast<float>());
  const ScanPoints coarse_scan = voxel_downsample(points, scan.intensity, c.voxel_size);
  IcpSettings coarse = settings;
  coarse.initial_kernel_scale = c.initial_kernel_scale;
  coarse.kernel_scale = c.kernel_scale;
  coarse.coarse_stride = 1;
  // Converged at the coarse resolution: a step moves the scanner less than a hundredth of a
  // coarse voxel and turns less than a milliradian.
  coarse.convergence_translation = 0.01 * c.voxel_size;
  coarse.convergence_rotation = 1e-3;
  const CorrespondenceRejector coarse_rejector = rejector.widened(0.5 * std::sqrt(3.0) * c.voxel_size);
  const RegistrationResult first = register_scan(coarse_scan, *coarse_model, T_prior, T_prior, coarse_rejector, coarse);
  IcpSettings fine = settings;
  fine.initial_kernel_scale = std::min(settings.initial_kernel_scale, c.kernel_scale);
  // A coarse stage that ran off (solver failure) leaves the fine stage to start from the prior.
  const Eigen::Isometry3d start = first.stop == IcpStop::kSolverFailed ? T_prior : first.T_map_base;
  RegistrationResult result = register_scan(scan, model, start, T_prior, rejector, fine);
  result.coarse_iterations = first.iterations;
  return result;
}

namespace {

// One Gauss-Newton step in the local frame z = N xi: on the well-constrained directions (the last
// 6 - degenerate eigenvectors); with hold_to_prior the poorly constrained ones return to the prior.
Vector6d solve_step(const Pass& pass, const LocalSystem& local, const Eigen::Isometry3d& T,
                    const Eigen::Isometry3d& T_initial, const DegeneracySettings& degeneracy) {
  const Matrix6d H_local = local.M.transpose() * pass.H * local.M;
  const Vector6d g_local = local.M.transpose() * pass.g;
  if (!degeneracy.hold_to_prior || local.degenerate == 0) return -H_local.ldlt().solve(g_local);
  const int constrained = 6 - local.degenerate;
  const Eigen::MatrixXd U = local.U.rightCols(constrained);
  const Eigen::MatrixXd D = local.U.leftCols(local.degenerate);
  const Vector6d to_prior = local.N * se3_log(T_initial * T.inverse());
  Vector6d z = D * (D.transpose() * to_prior);
  if (constrained > 0) z -= U * (U.transpose() * H_local * U).ldlt().solve(U.transpose() * g_local);
  return z;
}

// The fit at the final pose: correspondences, rejections, inliers and their residuals.
void fill_fit(const Pass& final_pass, RegistrationResult& result) {
  result.correspondences = final_pass.correspondences;
  result.counts = final_pass.counts;
  result.beyond_distance = final_pass.beyond_distance;
  result.back_facing = final_pass.back_facing;
  // The share over structure (walls, furniture); with fewer than kMinStructurePoints of it
  // overlapping, over that minimum (a scan whose horizontal fit rests on a handful of points does
  // not fit).
  result.within_reach = std::max(final_pass.structure_within_reach, kMinStructurePoints);
  result.rms_error = final_pass.weight_sum > 0.0 ? std::sqrt(final_pass.squared_error / final_pass.weight_sum) : 0.0;
  result.inliers = final_pass.inliers;
  const size_t share_inliers = final_pass.structure_inliers;
  result.inlier_share =
      result.within_reach > 0 ? static_cast<double>(share_inliers) / static_cast<double>(result.within_reach) : 0.0;
  result.inlier_rms =
      final_pass.inliers > 0 ? std::sqrt(final_pass.inlier_squared_error / static_cast<double>(final_pass.inliers)) : 0.0;
}

// Information, degeneracy and covariance at the final pose T: sigma^2 (J^T W J)^-1 over the
// constrained directions, part of the prior's variance kept on the barely constrained ones, and,
// when the iterates had not settled, their spread.
void fill_covariance(const Pass& final_pass, const LocalSystem& local, IcpStop stop,
                     const std::vector<Eigen::Isometry3d>& recent, const Eigen::Isometry3d& T,
                     const DegeneracySettings& degeneracy, RegistrationResult& result) {
  // The residual variance of the pairs in the information (kernel-weighted).
  const double sigma2 = std::max(final_pass.information_squared_error / final_pass.information_weight, 1e-8);
  Matrix6d inverse_local = Matrix6d::Zero(), degenerate_local = Matrix6d::Zero(), prior_local = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i) {
    const Vector6d u = local.U.col(i);
    if (i >= local.degenerate) {
      inverse_local += u * u.transpose() / local.lambda(i);
      // Barely constrained (share below confident_constraint_share): the data moved the pose,
      // but the prior's variance is kept in part, falling linearly from all of it at
      // min_constraint_share to none at confident_constraint_share.
      const double low = degeneracy.min_constraint_share;
      const double high = std::max(degeneracy.confident_constraint_share, low);
      const double share = local.shares(local.order_index(i));
      if (share < high && high > low) prior_local += std::sqrt((high - share) / (high - low)) * u * u.transpose();
    } else {
      degenerate_local += u * u.transpose();
      prior_local += u * u.transpose();
    }
  }
  result.constraint_shares = local.shares;
  result.directions = local.eigen.eigenvectors();
  result.degenerate_directions = local.degenerate;
  result.local_to_xi = local.M;
  result.constrained_inverse = local.M * inverse_local * local.M.transpose();
  result.covariance = sigma2 * result.constrained_inverse;
  if (stop != IcpStop::kConverged) {
    // Not settled: the pose is no better known than the spread of the last iterates.
    Matrix6d spread = Matrix6d::Zero();
    for (const Eigen::Isometry3d& Ti : recent) {
      const Vector6d d = se3_log(Ti * T.inverse());
      spread += d * d.transpose();
    }
    if (!recent.empty()) result.covariance += spread / static_cast<double>(recent.size());
  }
  result.degenerate_projector = local.M * degenerate_local * local.N;
  result.prior_projector = local.M * prior_local * local.N;
}

// Trust: whether the registration fits, and the verdict saying why or why not.
void judge(IcpStop stop, int iterations, const IcpSettings& settings, RegistrationResult& result) {
  const TrustSettings& trust = settings.trust;
  result.fits = result.inlier_share >= trust.min_inlier_share && result.inlier_rms <= trust.max_rms_error;
  char text[200];
  if (stop != IcpStop::kConverged) {
    std::snprintf(text, sizeof text, "not converged (%s after %d iterations)", icp_stop_name(stop), iterations);
  } else if (result.inlier_share < trust.min_inlier_share) {
    std::snprintf(text, sizeof text, "inlier share %.0f %% < %.0f %% (residual within %.2f m)",
                  100.0 * result.inlier_share, 100.0 * trust.min_inlier_share, trust.inlier_distance);
  } else if (result.inlier_rms > trust.max_rms_error) {
    std::snprintf(text, sizeof text, "inlier RMS residual %.3f m > %.3f m", result.inlier_rms, trust.max_rms_error);
  } else if (result.degenerate_directions > trust.max_degenerate_directions) {
    std::snprintf(text, sizeof text, "%d poorly constrained directions > %d", result.degenerate_directions,
                  trust.max_degenerate_directions);
  } else {
    result.converged = true;
    std::snprintf(text, sizeof text, "converged: inliers %.0f %%, RMS %.3f m, %d poorly constrained direction(s)%s",
                  100.0 * result.inlier_share, result.inlier_rms, result.degenerate_directions,
                  result.degenerate_directions > 0 && settings.degeneracy.hold_to_prior ? " held to odometry" : "");
  }
  result.verdict = text;
}

}  // namespace

// The registration loop: a pass of correspondences at the current kernel scale, a step solved in
// the local frame with the poorly constrained directions held, the kernel shrunk once the pose has
// settled at its scale; then the fit, the covariance and the verdict at the final pose.
RegistrationResult register_scan(const ScanPoints& scan, const VoxelMap& model, const Eigen::Isometry3d& T_start,
                                 const Eigen::Isometry3d& T_initial, const CorrespondenceRejector& rejector,
                                 const IcpSettings& settings) {
  RegistrationResult result;
  result.T_map_base = T_start;
  result.verdict = "no registration: empty model or scan";
  if (model.empty() || scan.points.empty()) return result;
  Registration registration(scan, model, rejector, settings);
  const Eigen::Vector3d scanner_in_base = rejector.sensor_in_base();
  const std::vector<Eigen::Vector3d> offsets = offsets_from(scan, scanner_in_base);
  const Eigen::Matrix3d rotation_scale_in_base = rotation_scale(offsets);
  result.lever_arm = std::sqrt(0.5 * rotation_scale_in_base.squaredNorm());
  double farthest = 0.0;
  for (const Eigen::Vector3d& d : offsets) farthest = std::max(farthest, d.norm());
  // z's rotation scale in the map frame at pose T.
  auto scale_at = [&](const Eigen::Isometry3d& T) -> Eigen::Matrix3d {
    return T.linear() * rotation_scale_in_base * T.linear().transpose();
  };
  double kernel = std::max(settings.initial_kernel_scale, settings.kernel_scale);
  Eigen::Isometry3d T = T_start;
  IcpStop stop = IcpStop::kIterationLimit;
  std::vector<Eigen::Isometry3d> recent;  // the last kRecentPoses iterates
  int iteration = 0;
  for (; iteration < settings.max_iterations; ++iteration) {
    const size_t stride =
        kernel > kCoarseKernelMultiple * settings.kernel_scale ? static_cast<size_t>(std::max(1, settings.coarse_stride)) : 1;
    const Pass pass = registration.run_pass(T, kernel, stride, false);
    if (pass.correspondences < kMinCorrespondences) {
      stop = IcpStop::kTooFewCorrespondences;
      break;
    }
    const LocalSystem local = local_system(pass, T * scanner_in_base, scale_at(T), settings.degeneracy);
    const Vector6d z = solve_step(pass, local, T, T_initial, settings.degeneracy);
    if (!z.allFinite()) {
      stop = IcpStop::kSolverFailed;
      break;
    }
    T = se3_exp(local.M * z) * T;
    if (recent.size() == kRecentPoses) recent.erase(recent.begin());
    recent.push_back(T);
    // Coarse to fine: the kernel shrinks once the pose has settled at the current scale; at the
    // final scale the convergence thresholds end the loop.
    const double moved = z.head<3>().norm(), turned = (local.M * z).tail<3>().norm();
    // Settled: the step moves no point of the scan by more than a tenth of the scale (its motion at
    // the scanner plus its rotation times the farthest point's distance).
    if (moved + turned * farthest < kSettledFraction * kernel) {
      const double next = std::max({settings.kernel_scale, kNoiseMultiple * robust_sigma(pass.residuals), kernel * kKernelShrink});
      if (next < kernel) {
        kernel = next;
      } else if (moved < settings.convergence_translation && turned < settings.convergence_rotation) {
        stop = IcpStop::kConverged;
        ++iteration;
        break;
      }
    }
  }
  result.T_map_base = T;
  result.iterations = iteration;
  result.stop = stop;
  result.kernel_scale = kernel;

  Pass final_pass = registration.run_pass(T, kernel, 1, true);
  fill_fit(final_pass, result);
  result.information = final_pass.information;
  result.information_by_insert = std::move(final_pass.by_insert);
  if (final_pass.information_weight > 0.0) {
    const LocalSystem local = local_system(final_pass, T * scanner_in_base, scale_at(T), settings.degeneracy);
    fill_covariance(final_pass, local, stop, recent, T, settings.degeneracy, result);
  } else {
    result.degenerate_directions = 6;
    result.degenerate_projector = Matrix6d::Identity();
    result.prior_projector = Matrix6d::Identity();
  }
  judge(stop, iteration, settings, result);
  return result;
}

}  // namespace locd::icp_explorer
