// The EKF core: state, covariance, prediction (eq. 5) and measurement update (eq. 9, 13, 14).
// Models stay outside: a caller passes the predicted state with its Jacobians, or an innovation
// with its Jacobian and noise. Sized by the state dimension so other motion models (e.g. a
// [lat, lon, vN, vE] state) reuse it.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <utility>
#include <vector>

namespace locd::feature_ekf {

template <int StateSize>
class ExtendedKalmanFilter {
 public:
  using State = Eigen::Matrix<double, StateSize, 1>;
  using Covariance = Eigen::Matrix<double, StateSize, StateSize>;

  ExtendedKalmanFilter() : state_(State::Zero()), covariance_(Covariance::Identity()) {}
  ExtendedKalmanFilter(const State& state, const Covariance& covariance)
      : state_(state), covariance_(covariance) {}

  const State& state() const { return state_; }
  const Covariance& covariance() const { return covariance_; }
  void reset(const State& state, const Covariance& covariance) {
    state_ = state;
    covariance_ = covariance;
  }
  void set_state(const State& state) { state_ = state; }

  // Eq. 5: x(k+1|k) = f(x, u); P(k+1|k) = F P F^T + G Q G^T, with F = df/dx and G = df/du.
  template <int ControlSize>
  void predict(const State& predicted_state, const Covariance& F,
               const Eigen::Matrix<double, StateSize, ControlSize>& G,
               const Eigen::Matrix<double, ControlSize, ControlSize>& Q) {
    state_ = predicted_state;
    covariance_ = F * covariance_ * F.transpose() + G * Q * G.transpose();
    symmetrize();
  }

  // Eq. 9: S = H P H^T + R.
  template <int MeasurementSize>
  Eigen::Matrix<double, MeasurementSize, MeasurementSize> innovation_covariance(
      const Eigen::Matrix<double, MeasurementSize, StateSize>& H,
      const Eigen::Matrix<double, MeasurementSize, MeasurementSize>& R) const {
    return H * covariance_ * H.transpose() + R;
  }

  // Eq. 13, 14 with the covariance in Joseph form, (I - W H) P (I - W H)^T + W R W^T, which
  // stays symmetric positive definite where the paper's P - W S W^T can lose it to rounding.
  // Returns false (and changes nothing) when S is not positive definite.
  template <int MeasurementSize>
  bool update(const Eigen::Matrix<double, MeasurementSize, 1>& innovation,
              const Eigen::Matrix<double, MeasurementSize, StateSize>& H,
              const Eigen::Matrix<double, MeasurementSize, MeasurementSize>& R) {
    using MeasurementMatrix = Eigen::Matrix<double, MeasurementSize, MeasurementSize>;
    const MeasurementMatrix S = innovation_covariance(H, R);
    const Eigen::LLT<MeasurementMatrix> llt(S);
    if (llt.info() != Eigen::Success) return false;
    // W = P H^T S^-1, computed as (S^-1 H P)^T since S and P are symmetric.
    const Eigen::Matrix<double, StateSize, MeasurementSize> W =
        llt.solve(H * covariance_).transpose();
    state_ += W * innovation;
    const Covariance I_WH = Covariance::Identity() - W * H;
    covariance_ = I_WH * covariance_ * I_WH.transpose() + W * R * W.transpose();
    symmetrize();
    return true;
  }

  // Probabilistic data association update (Bar-Shalom, Daum, Huang 2009, eq. 37-41): innovations
  // r_i with weights beta_i, and beta_0 = false_weight for "none of them is right".
  // x += W sum(beta_i r_i); P = beta_0 P + (1 - beta_0) P_c + W (sum beta_i r_i r_i^T - r r^T) W^T,
  // with P_c the Joseph-form update. Returns false (and changes nothing) when S is not positive
  // definite.
  template <int MeasurementSize>
  bool update_mixture(const std::vector<std::pair<Eigen::Matrix<double, MeasurementSize, 1>, double>>& weighted,
                      double false_weight, const Eigen::Matrix<double, MeasurementSize, StateSize>& H,
                      const Eigen::Matrix<double, MeasurementSize, MeasurementSize>& R) {
    using MeasurementMatrix = Eigen::Matrix<double, MeasurementSize, MeasurementSize>;
    using MeasurementVector = Eigen::Matrix<double, MeasurementSize, 1>;
    const MeasurementMatrix S = innovation_covariance(H, R);
    const Eigen::LLT<MeasurementMatrix> llt(S);
    if (llt.info() != Eigen::Success) return false;
    const Eigen::Matrix<double, StateSize, MeasurementSize> W = llt.solve(H * covariance_).transpose();
    MeasurementVector combined = MeasurementVector::Zero();
    MeasurementMatrix spread = MeasurementMatrix::Zero();
    for (const auto& [r, beta] : weighted) {
      combined += beta * r;
      spread += beta * r * r.transpose();
    }
    spread -= combined * combined.transpose();
    const Covariance I_WH = Covariance::Identity() - W * H;
    const Covariance corrected = I_WH * covariance_ * I_WH.transpose() + W * R * W.transpose();
    state_ += W * combined;
    covariance_ = false_weight * covariance_ + (1.0 - false_weight) * corrected + W * spread * W.transpose();
    symmetrize();
    return true;
  }

 private:
  void symmetrize() { covariance_ = 0.5 * (covariance_ + covariance_.transpose()).eval(); }

  State state_;
  Covariance covariance_;
};

}  // namespace locd::feature_ekf
