// Polynomial platform fit (seed 000 eq. 25-27), cubic trajectory (eq. 29), waypoint script.
#include "lander/controller/trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace lander::ctl {

void PolynomialFit3::fit(const std::vector<double>& t_s, const std::vector<Eigen::Vector3d>& p_W,
                         int order) {
  valid_ = false;
  if (order < 0) throw std::invalid_argument("PolynomialFit3: order must be >= 0");
  if (t_s.size() != p_W.size()) throw std::invalid_argument("PolynomialFit3: size mismatch");
  const int n = static_cast<int>(t_s.size());
  if (n <= order) {
    throw std::invalid_argument("PolynomialFit3: " + std::to_string(n) +
                                " samples cannot fit order " + std::to_string(order));
  }
  double t_min = t_s.front(), t_max = t_s.front();
  for (double t : t_s) {
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
  }
  if (!(t_max > t_min) && order > 0) {
    throw std::invalid_argument("PolynomialFit3: samples span no time");
  }
  t_first_ = t_min;
  t_last_ = t_max;
  t_mid_ = 0.5 * (t_min + t_max);
  t_half_ = std::max(0.5 * (t_max - t_min), 1e-6);
  order_ = order;
  // Least squares on the Vandermonde matrix in normalised time (eq. 25-27 per axis).
  Eigen::MatrixXd V(n, order + 1);
  Eigen::MatrixXd Y(n, 3);
  for (int i = 0; i < n; ++i) {
    const double tau = (t_s[i] - t_mid_) / t_half_;
    double pw = 1.0;
    for (int k = 0; k <= order; ++k, pw *= tau) V(i, k) = pw;
    Y.row(i) = p_W[i].transpose();
  }
  const Eigen::MatrixXd C = V.colPivHouseholderQr().solve(Y);  // (order+1) x 3
  c_ = C.transpose();
  rms_ = std::sqrt((V * C - Y).squaredNorm() / n);
  valid_ = true;
}

Eigen::Vector3d PolynomialFit3::position(double t_s) const {
  if (!valid_) throw std::logic_error("PolynomialFit3::position before fit");
  const double tau = (t_s - t_mid_) / t_half_;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int k = order_; k >= 0; --k) p = p * tau + c_.col(k);  // Horner
  return p;
}

Eigen::Vector3d PolynomialFit3::velocity(double t_s) const {
  if (!valid_) throw std::logic_error("PolynomialFit3::velocity before fit");
  const double tau = (t_s - t_mid_) / t_half_;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (int k = order_; k >= 1; --k) v = v * tau + k * c_.col(k);
  return v / t_half_;
}

Eigen::MatrixXd PolynomialFit3::coefficients_about(double t0_s) const {
  if (!valid_) throw std::logic_error("PolynomialFit3::coefficients_about before fit");
  // tau = (t' + (t0 - t_mid)) / t_half with t' = t - t0: expand each tau^k binomially.
  const double a = (t0_s - t_mid_) / t_half_, b = 1.0 / t_half_;
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(3, order_ + 1);
  for (int k = 0; k <= order_; ++k) {
    // (a + b t')^k = sum_j C(k, j) a^(k-j) b^j t'^j
    double binom = 1.0;
    for (int j = 0; j <= k; ++j) {
      out.col(j) += c_.col(k) * binom * std::pow(a, k - j) * std::pow(b, j);
      binom = binom * (k - j) / (j + 1);
    }
  }
  return out;
}

CubicTrajectory::CubicTrajectory(const Eigen::Vector3d& p0_W, double t0_s, const Eigen::Vector3d& pd_W,
                                 double td_s, const Eigen::Vector3d& v0_W, const Eigen::Vector3d& vd_W)
    : p0_(p0_W), pd_(pd_W), v0_(v0_W), vd_(vd_W), t0_(t0_s), td_(td_s),
      hermite_(!v0_W.isZero(0.0) || !vd_W.isZero(0.0)) {
  if (!(td_s > t0_s)) throw std::invalid_argument("CubicTrajectory: t_d must be after t_0");
}

// eq. 29: P(t) = P_0 + 3 Diff s^2 - 2 Diff s^3, s = (t - t_0)/(t_d - t_0), clamped to [0, 1];
// with end velocities, the Hermite terms of trajectory.h on top (eq. 29's own expressions are
// kept as they were, so a trajectory from rest to rest gives the same bits as before).
Eigen::Vector3d CubicTrajectory::position(double t_s) const {
  const double s = std::clamp((t_s - t0_) / (td_ - t0_), 0.0, 1.0);
  const Eigen::Vector3d p = p0_ + (pd_ - p0_) * (3.0 * s * s - 2.0 * s * s * s);
  if (!hermite_) return p;
  const double T = td_ - t0_;
  if (t_s >= td_) return p + vd_ * (t_s - td_);
  return p + v0_ * (T * (s - 2.0 * s * s + s * s * s)) + vd_ * (T * (s * s * s - s * s));
}

Eigen::Vector3d CubicTrajectory::velocity(double t_s) const {
  const double T = td_ - t0_;
  const double s = (t_s - t0_) / T;
  if (s <= 0.0 || s >= 1.0) return hermite_ ? (s <= 0.0 ? v0_ : vd_) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d v = (pd_ - p0_) * (6.0 * s - 6.0 * s * s) / T;
  if (!hermite_) return v;
  return v + v0_ * (1.0 - 4.0 * s + 3.0 * s * s) + vd_ * (3.0 * s * s - 2.0 * s);
}

Eigen::Vector3d CubicTrajectory::acceleration(double t_s) const {
  const double T = td_ - t0_;
  const double s = (t_s - t0_) / T;
  if (s < 0.0 || s > 1.0) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d a = (pd_ - p0_) * (6.0 - 12.0 * s) / (T * T);
  if (!hermite_) return a;
  return a + v0_ * ((6.0 * s - 4.0) / T) + vd_ * ((6.0 * s - 2.0) / T);
}

Setpoint CubicTrajectory::setpoint(double t_s, double yaw_rad) const {
  Setpoint sp;
  sp.p_W_m = position(t_s);
  sp.v_W_mps = velocity(t_s);
  sp.a_W_mps2 = acceleration(t_s);
  sp.yaw_rad = yaw_rad;
  return sp;
}

WaypointScript::WaypointScript(const Eigen::Vector3d& p_W, double yaw_rad, double t_s)
    : start_(p_W), yaw_(yaw_rad), t_start_(t_s) {}

void WaypointScript::go_to(const Eigen::Vector3d& p_W, double speed_mps, double hold_s) {
  if (!(speed_mps > 0)) throw std::invalid_argument("WaypointScript::go_to: speed must be > 0");
  if (hold_s < 0) throw std::invalid_argument("WaypointScript::go_to: hold must be >= 0");
  const Eigen::Vector3d from = legs_.empty() ? start_ : legs_.back().traj.goal();
  const double t0 = legs_.empty() ? t_start_ : legs_.back().hold_until_s;
  const double duration = std::max((p_W - from).norm() / speed_mps, 1e-3);
  legs_.push_back({CubicTrajectory(from, t0, p_W, t0 + duration), t0 + duration + hold_s});
}

Setpoint WaypointScript::at(double t_s) const {
  for (const Leg& leg : legs_) {
    if (t_s < leg.hold_until_s) return leg.traj.setpoint(t_s, yaw_);
  }
  Setpoint sp;
  sp.p_W_m = legs_.empty() ? start_ : legs_.back().traj.goal();
  sp.yaw_rad = yaw_;
  return sp;
}

double WaypointScript::end_time() const {
  return legs_.empty() ? t_start_ : legs_.back().hold_until_s;
}

}  // namespace lander::ctl
