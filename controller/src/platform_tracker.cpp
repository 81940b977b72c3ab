// Platform fixes in W (eq. 24), polynomial prediction (eq. 25-28), velocity, steadiness.
#include "lander/controller/platform_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace lander::ctl {
namespace {
constexpr double kDegToRad = M_PI / 180.0;

// Bounds the norm of v to max_norm.
Eigen::Vector3d clamp_norm(const Eigen::Vector3d& v, double max_norm) {
  const double n = v.norm();
  return n > max_norm ? Eigen::Vector3d(v * (max_norm / n)) : v;
}

// The horizontal correction of the navigation velocity from one state to the next (the
// change of NavState::v_corr_W_mps); zero if not finite.
Eigen::Vector3d velocity_correction(const NavState& from, const NavState& to) {
  Eigen::Vector3d dv = to.v_corr_W_mps - from.v_corr_W_mps;
  dv.z() = 0.0;
  return dv.allFinite() ? dv : Eigen::Vector3d::Zero();
}
}  // namespace

PlatformTracker::PlatformTracker(const TrackerParams& params, const CameraMount& mount)
    : p_(params), X_BC_(mount.X_BC()), last_detection_t_(-std::numeric_limits<double>::infinity()) {
  p_.validate();
}

void PlatformTracker::add_nav(const NavState& nav) {
  if (!nav.valid) return;
  if (!nav_.empty() && nav.t_s <= nav_.back().t_s) {
    if (nav.t_s == nav_.back().t_s) {  // the same instant again, perhaps corrected at it
      rebase_dead_reckoning(velocity_correction(nav_.back(), nav), nav.t_s);
      nav_.back() = nav;
    }
    return;  // out of order: ignore
  }
  if (nav_.empty()) {
    dr_.push_back(Eigen::Vector3d::Zero());
    nav_.push_back(nav);
    return;
  }
  // A correction of the navigation velocity since the last state, taken as made at its time.
  const Eigen::Vector3d dv = velocity_correction(nav_.back(), nav);
  rebase_dead_reckoning(dv, nav_.back().t_s);
  // Trapezoidal integral of the navigation velocity (the last one corrected).
  dr_.push_back(dr_.back() +
                0.5 * (nav_.back().v_W_mps + dv + nav.v_W_mps) * (nav.t_s - nav_.back().t_s));
  nav_.push_back(nav);
  while (nav_.size() > 2 && nav_.front().t_s < nav.t_s - p_.nav_history_s) {
    nav_.pop_front();
    dr_.pop_front();
  }
}

void PlatformTracker::rebase_dead_reckoning(const Eigen::Vector3d& dv, double t_g) {
  if (dv.isZero(0.0)) return;
  for (std::size_t i = 0; i < dr_.size(); ++i) dr_[i] += dv * (nav_[i].t_s - t_g);
  for (PlatformFix& f : fixes_) f.p_dr_m += dv * (f.t_s - t_g);
  if (!kf_init_) return;
  kf_x_.row(0) += (dv * (kf_t_ - t_g)).transpose();
  kf_x_.row(1) += dv.transpose();
  ca_x_.row(0) += (dv * (ca_t_ - t_g)).transpose();
  ca_x_.row(1) += dv.transpose();
}

bool PlatformTracker::bracket(double t_s, const char* who, std::size_t* lo, double* u) const {
  if (nav_.empty()) {
    throw std::logic_error(std::string("PlatformTracker::") + who +
                           ": no valid navigation state");
  }
  if (t_s <= nav_.front().t_s) {
    *lo = 0;
    return false;
  }
  if (t_s >= nav_.back().t_s) {
    *lo = nav_.size() - 1;
    return false;
  }
  // First element with time > t_s; its predecessor has time <= t_s.
  const auto hi = std::upper_bound(nav_.begin(), nav_.end(), t_s,
                                   [](double t, const NavState& n) { return t < n.t_s; });
  *lo = static_cast<std::size_t>(hi - nav_.begin()) - 1;
  *u = (t_s - nav_[*lo].t_s) / (hi->t_s - nav_[*lo].t_s);
  return true;
}

Eigen::Vector3d PlatformTracker::dead_reckoned_at(double t_s) const {
  std::size_t i = 0;
  double u = 0.0;
  if (!bracket(t_s, "dead_reckoned_at", &i, &u)) return dr_[i];
  return (1 - u) * dr_[i] + u * dr_[i + 1];
}

NavState PlatformTracker::nav_at(double t_s) const {
  std::size_t i = 0;
  double u = 0.0;
  if (!bracket(t_s, "nav_at", &i, &u)) return nav_[i];
  const NavState& lo = nav_[i];
  const NavState& hi = nav_[i + 1];
  NavState out = lo;
  out.t_s = t_s;
  out.p_W_m = (1 - u) * lo.p_W_m + u * hi.p_W_m;
  out.v_W_mps = (1 - u) * lo.v_W_mps + u * hi.v_W_mps;
  out.omega_B_radps = (1 - u) * lo.omega_B_radps + u * hi.omega_B_radps;
  out.q_WB = lo.q_WB.slerp(u, hi.q_WB);
  return out;
}

PlatformFix PlatformTracker::fix_from(const PlatformObservation& obs, const NavState& nav,
                                      const Eigen::Isometry3d& X_BC) {
  // seed 000 eq. 24: P_n = R_b^n R_c^b P_c + t_b^n, plus the camera offset p_BC in B.
  const Eigen::Matrix3d R_WB = nav.q_WB.toRotationMatrix();
  PlatformFix f;
  f.t_s = obs.t_s;
  f.p_BP_W_m = R_WB * (X_BC.linear() * obs.X_CP.translation() + X_BC.translation());
  f.p_W_m = f.p_BP_W_m + nav.p_W_m;
  f.n_W = (R_WB * X_BC.linear() * obs.X_CP.linear()).col(2).normalized();
  return f;
}

bool PlatformTracker::add_observation(const PlatformObservation& obs) {
  if (!plausible_observation(obs)) {
    ++rejected_observations_;
    return false;
  }
  if (!obs.detected) {
    streak_ = 0;
    return false;
  }
  last_detection_t_ = std::max(last_detection_t_, obs.t_s);
  if (!obs.keyframe || nav_.empty()) return false;
  if (!fixes_.empty() && obs.t_s <= fixes_.back().t_s) return false;  // stale or duplicate
  PlatformFix fix = fix_from(obs, nav_at(obs.t_s), X_BC_);
  fix.p_dr_m = fix.p_BP_W_m + dead_reckoned_at(obs.t_s);
  fixes_.push_back(fix);
  ++total_fixes_;
  filter_update(fix);
  ++streak_;
  while (!fixes_.empty() && fixes_.front().t_s < obs.t_s - p_.history_s) fixes_.pop_front();
  fit_dirty_ = true;
  return true;
}

void PlatformTracker::filter_update(const PlatformFix& fix) {
  const double range = fix.p_BP_W_m.norm();
  const double sigma = p_.fix_noise_m + p_.fix_noise_per_m * range;
  const double R = sigma * sigma;
  const Eigen::Vector3d z = fix.p_dr_m;
  auto restart = [&] {
    kf_init_ = true;
    kf_t_ = fix.t_s;
    kf_x_.row(0) = z.transpose();
    kf_x_.row(1).setZero();
    // Velocity unknown: at rest with velocity_prior_std_mps (a cart walks at ~0.5-1.5 m/s);
    // the broadcast's horizontal velocity when one is received (a fast platform's first
    // fixes, seen briefly at the view's edge, cannot tell 5 m/s from rest against a prior at
    // rest).
    double v_var = p_.velocity_prior_std_mps * p_.velocity_prior_std_mps;
    if (velocity_prior_) {
      kf_x_.row(1).head<2>() = velocity_prior_->head<2>().transpose();
      v_var = p_.broadcast_velocity_std_mps * p_.broadcast_velocity_std_mps;
    }
    kf_P_ << R, 0.0, 0.0, v_var;
    kf_outliers_in_row_ = 0;
    ca_t_ = fix.t_s;
    ca_x_.setZero();
    ca_x_.row(0) = z.transpose();
    ca_x_.row(1) = kf_x_.row(1);
    ca_P_ = Eigen::Vector3d(R, v_var, 1.0).asDiagonal();  // 1 m/s^2: a cart's braking is ~0.6
  };
  if (!kf_init_) {
    restart();
    return;
  }
  // Predict with the constant-velocity model (white-noise acceleration q).
  const double dt = std::max(0.0, fix.t_s - kf_t_);
  kf_t_ = fix.t_s;
  Eigen::Matrix2d F;
  F << 1.0, dt, 0.0, 1.0;
  const double q = p_.platform_accel_noise_mps2 * p_.platform_accel_noise_mps2;
  Eigen::Matrix2d Q;
  Q << q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt;
  kf_x_ = F * kf_x_;
  kf_P_ = F * kf_P_ * F.transpose() + Q;
  // Update with the position fix (H = [1 0] on each axis).
  const Eigen::Vector3d innov = z - kf_x_.row(0).transpose();
  const double S = kf_P_(0, 0) + R;
  if (innov.norm() > p_.fix_gate_sigma * std::sqrt(S)) {
    ++rejected_fixes_;
    if (++kf_outliers_in_row_ >= 3) restart();  // the platform is elsewhere: start again
    return;
  }
  kf_outliers_in_row_ = 0;
  const Eigen::Vector2d K = kf_P_.col(0) / S;
  kf_x_ += K * innov.transpose();
  kf_P_ = (Eigen::Matrix2d::Identity() - K * Eigen::RowVector2d(1.0, 0.0)) * kf_P_;
  kf_P_ = 0.5 * (kf_P_ + kf_P_.transpose()).eval();
  // The acceleration filter on the same accepted fix: constant acceleration, white-noise jerk
  // j (continuous-time Q of the triple integrator), H = [1 0 0].
  const double dt_ca = std::max(0.0, fix.t_s - ca_t_);
  ca_t_ = fix.t_s;
  Eigen::Matrix3d Fa;
  Fa << 1.0, dt_ca, 0.5 * dt_ca * dt_ca, 0.0, 1.0, dt_ca, 0.0, 0.0, 1.0;
  const double j = p_.platform_jerk_noise_mps3 * p_.platform_jerk_noise_mps3;
  const double d2 = dt_ca * dt_ca, d3 = d2 * dt_ca, d4 = d3 * dt_ca, d5 = d4 * dt_ca;
  Eigen::Matrix3d Qa;
  Qa << d5 / 20.0, d4 / 8.0, d3 / 6.0, d4 / 8.0, d3 / 3.0, d2 / 2.0, d3 / 6.0, d2 / 2.0, dt_ca;
  ca_x_ = Fa * ca_x_;
  ca_P_ = Fa * ca_P_ * Fa.transpose() + j * Qa;
  const Eigen::Vector3d innov_ca = z - ca_x_.row(0).transpose();
  const Eigen::Vector3d Ka = ca_P_.col(0) / (ca_P_(0, 0) + R);
  ca_x_ += Ka * innov_ca.transpose();
  ca_P_ = (Eigen::Matrix3d::Identity() - Ka * Eigen::RowVector3d(1.0, 0.0, 0.0)) * ca_P_;
  ca_P_ = 0.5 * (ca_P_ + ca_P_.transpose()).eval();
}

void PlatformTracker::clear() {
  kf_init_ = false;
  kf_outliers_in_row_ = 0;
  total_fixes_ = 0;
  rejected_fixes_ = 0;
  fixes_.clear();
  streak_ = 0;
  fit_dirty_ = true;
  fit_ = PolynomialFit3{};
}

const PlatformFix& PlatformTracker::latest() const {
  if (fixes_.empty()) throw std::logic_error("PlatformTracker::latest: no fix");
  return fixes_.back();
}

const PolynomialFit3& PlatformTracker::fit() const {
  if (!fit_dirty_) return fit_;
  fit_dirty_ = false;
  fit_ = PolynomialFit3{};
  std::vector<double> t;
  std::vector<Eigen::Vector3d> p;
  if (fixes_.empty()) return fit_;
  const double t_from = fixes_.back().t_s - p_.fit_window_s;
  for (const PlatformFix& f : fixes_) {
    if (f.t_s < t_from) continue;
    t.push_back(f.t_s);
    p.push_back(f.p_W_m);
  }
  // Keep at least two samples of redundancy per coefficient (eq. 25-27 by least squares).
  const int order = std::min(p_.poly_order, static_cast<int>(t.size()) - 2);
  if (order < 0) return fit_;
  if (order > 0 && !(t.back() > t.front())) return fit_;
  fit_.fit(t, p, order);
  return fit_;
}

// Local quadratic least squares over the last velocity_window_s, p(d) = a + b d + c d^2 with
// d = t - t_last: a is the smoothed position at the last fix without the lag of a mean (the
// cart brakes and turns).
bool PlatformTracker::local_position(Eigen::Vector3d* p_last) const {
  if (fixes_.size() < 3) return false;
  const double t_last = fixes_.back().t_s;
  const double t_from = t_last - p_.velocity_window_s;
  std::vector<double> t;
  std::vector<Eigen::Vector3d> p;
  for (const PlatformFix& f : fixes_) {
    if (f.t_s < t_from) continue;
    t.push_back(f.t_s - t_last);
    p.push_back(f.p_W_m);
  }
  // Quadratic with >= 6 samples (3 of redundancy), else a straight line with >= 3.
  const int order = t.size() >= 6 ? 2 : (t.size() >= 3 ? 1 : -1);
  if (order < 0 || !(t.back() > t.front())) return false;
  const int n = static_cast<int>(t.size());
  Eigen::MatrixXd V(n, order + 1);
  Eigen::MatrixXd Y(n, 3);
  const double scale = std::max(-t.front(), 1e-3);  // d / scale in [-1, 0]
  for (int i = 0; i < n; ++i) {
    const double d = t[i] / scale;
    V(i, 0) = 1.0;
    V(i, 1) = d;
    if (order == 2) V(i, 2) = d * d;
    Y.row(i) = p[i].transpose();
  }
  const Eigen::MatrixXd C = V.colPivHouseholderQr().solve(Y);
  *p_last = C.row(0).transpose();
  return true;
}

Eigen::Vector3d PlatformTracker::velocity() const {
  if (!kf_init_) return Eigen::Vector3d::Zero();
  return clamp_norm(kf_x_.row(1).transpose(), p_.platform_max_speed_mps);
}

Eigen::Vector3d PlatformTracker::acceleration() const {
  if (!kf_init_) return Eigen::Vector3d::Zero();
  return clamp_norm(ca_x_.row(2).transpose(), p_.platform_max_accel_mps2);
}

Eigen::Vector3d PlatformTracker::velocity_of_acceleration_filter() const {
  if (!kf_init_) return Eigen::Vector3d::Zero();
  return clamp_norm(ca_x_.row(1).transpose(), p_.platform_max_speed_mps);
}

Eigen::Vector3d PlatformTracker::position_now(double t_s) const {
  const PlatformFix& f = latest();
  Eigen::Vector3d p;
  if (!local_position(&p)) return f.p_W_m;
  return p + velocity() * std::max(0.0, t_s - f.t_s);
}

// Line fit r = a + b (t - t_last) of the recent relative vectors (platform minus vehicle):
// the fixes of the last relative_window_s, or the last 3 when fewer (blur) as long as they
// are within 4 windows. a is the smoothed relative vector at the last fix, b its rate.
bool PlatformTracker::relative_fit(Eigen::Vector3d* a, Eigen::Vector3d* b) const {
  if (fixes_.empty()) return false;
  const double t_last = fixes_.back().t_s;
  double t_from = t_last - p_.relative_window_s;
  if (fixes_.size() >= 3) {
    t_from = std::min(t_from, std::max(fixes_[fixes_.size() - 3].t_s,
                                       t_last - 4.0 * p_.relative_window_s));
  }
  double s0 = 0, s1 = 0, s2 = 0;
  Eigen::Vector3d sr = Eigen::Vector3d::Zero(), str = Eigen::Vector3d::Zero();
  for (const PlatformFix& f : fixes_) {
    if (f.t_s < t_from) continue;
    const double d = f.t_s - t_last;
    s0 += 1;
    s1 += d;
    s2 += d * d;
    sr += f.p_BP_W_m;
    str += d * f.p_BP_W_m;
  }
  const double det = s0 * s2 - s1 * s1;
  if (s0 < 3 || det <= 1e-12) return false;
  *a = (s2 * sr - s1 * str) / det;
  *b = (s0 * str - s1 * sr) / det;
  return true;
}

Eigen::Vector3d PlatformTracker::relative_now(double t_s) const {
  const PlatformFix& last = latest();
  Eigen::Vector3d r_last, rate;
  if (!relative_fit(&r_last, &rate)) r_last = last.p_BP_W_m;
  // The vehicle's displacement since the fix, dead-reckoned (no GPS correction steps).
  const Eigen::Vector3d vehicle_moved = dead_reckoned_at(t_s) - dead_reckoned_at(last.t_s);
  return r_last + velocity() * std::max(0.0, t_s - last.t_s) - vehicle_moved;
}

bool PlatformTracker::relative_velocity(Eigen::Vector3d* v_rel) const {
  Eigen::Vector3d a;
  return relative_fit(&a, v_rel);
}

Eigen::Vector3d PlatformTracker::predict(double t_s) const {
  const PlatformFix& last = latest();
  const double horizon = std::max(0.0, t_s - last.t_s);
  const PolynomialFit3& poly = fit();
  Eigen::Vector3d p;
  if (!poly.valid()) {
    p = last.p_W_m + velocity() * horizon;
  } else if (horizon <= p_.max_poly_extrapolation_s) {
    p = poly.position(t_s);  // eq. 25-27 evaluated at t_d (eq. 28)
  } else {
    // Beyond the fit's edge: on along the motion model (its turn and braking, issue 56) or
    // straight on at the filter's velocity (eq. 28's linear continuation).
    const double t_edge = last.t_s + p_.max_poly_extrapolation_s;
    if (p_.predict_turns) {
      const PlatformMotion m = motion();
      p = poly.position(t_edge) + (m.position_at(t_s) - m.position_at(t_edge));
    } else {
      p = poly.position(t_edge) + velocity() * (t_s - t_edge);
    }
  }
  // Plausibility: the platform cannot have moved faster than its speed bound.
  return last.p_W_m + clamp_norm(p - last.p_W_m, p_.platform_max_speed_mps * horizon + 0.05);
}

Eigen::Vector3d PlatformMotion::position_at(double t_s) const {
  const double tau = std::max(0.0, t_s - t0_s);
  if (!valid || tau == 0.0) return p0_W_m;
  // Moving time: up to the stop when braking.
  const double t_move = accel_mps2 < 0.0 ? std::min(tau, speed_mps / -accel_mps2) : tau;
  Eigen::Vector3d p = p0_W_m;
  if (accel_mps2 == 0.0) {
    // Closed form: circle (or line) at constant speed.
    const double psi = heading_rad + turn_rate_radps * t_move;
    if (std::abs(turn_rate_radps) * t_move < 1e-9) {
      p.x() += speed_mps * t_move * std::cos(heading_rad);
      p.y() += speed_mps * t_move * std::sin(heading_rad);
    } else {
      const double r = speed_mps / turn_rate_radps;
      p.x() += r * (std::sin(psi) - std::sin(heading_rad));
      p.y() += r * (std::cos(heading_rad) - std::cos(psi));
    }
    return p;
  }
  // Braking: midpoint rule on steps of at most 20 ms (the heading turns by at most 0.01 rad
  // a step: sub-millimetre error over the 10 s of search_predict_max_s).
  constexpr double kMaxStep_s = 0.02;
  const int n = std::max(1, static_cast<int>(std::ceil(t_move / kMaxStep_s)));
  const double h = t_move / n;
  for (int i = 0; i < n; ++i) {
    const double u = (i + 0.5) * h;
    const double s = speed_mps + accel_mps2 * u;
    const double psi = heading_rad + turn_rate_radps * u;
    p.x() += s * std::cos(psi) * h;
    p.y() += s * std::sin(psi) * h;
  }
  return p;
}

Eigen::Vector3d PlatformMotion::velocity_at(double t_s) const {
  if (!valid) return Eigen::Vector3d::Zero();
  const double tau = std::max(0.0, t_s - t0_s);
  const double s = std::max(0.0, speed_mps + accel_mps2 * tau);
  if (s == 0.0) return Eigen::Vector3d::Zero();
  const double psi = heading_rad + turn_rate_radps * tau;
  return Eigen::Vector3d(s * std::cos(psi), s * std::sin(psi), 0.0);
}

PlatformMotion PlatformTracker::motion() const {
  PlatformMotion m;
  if (fixes_.empty()) return m;
  const PlatformFix& last = fixes_.back();
  m.valid = true;
  m.t0_s = last.t_s;
  // Fallback: the last fix moving on at the filter's velocity, no turn.
  m.p0_W_m = last.p_W_m;
  Eigen::Vector2d v = velocity().head<2>();
  Eigen::Vector2d acc = Eigen::Vector2d::Zero();
  double acc_sigma = std::numeric_limits<double>::infinity();  // no fit: no turn, no braking
  // Quadratic fit over the turn window (d scaled to [-1, 0] for conditioning).
  std::vector<double> d;
  std::vector<Eigen::Vector2d> p;
  for (const PlatformFix& f : fixes_) {
    if (f.t_s < last.t_s - p_.turn_fit_window_s) continue;
    d.push_back(f.t_s - last.t_s);
    p.push_back(f.p_dr_m.head<2>());
  }
  // 6 fixes spanning 0.5 s: 3 of redundancy for the 3 coefficients, and a span over which
  // centimetres of noise do not make the acceleration.
  constexpr int kMinFixes = 6;
  constexpr double kMinSpan_s = 0.5;
  if (static_cast<int>(d.size()) >= kMinFixes && -d.front() >= kMinSpan_s) {
    const int n = static_cast<int>(d.size());
    const double scale = -d.front();
    Eigen::MatrixXd V(n, 3);
    Eigen::MatrixXd Y(n, 2);
    for (int i = 0; i < n; ++i) {
      const double x = d[i] / scale;
      V(i, 0) = 1.0;
      V(i, 1) = x;
      V(i, 2) = x * x;
      Y.row(i) = p[i].transpose();
    }
    const Eigen::MatrixXd C = V.colPivHouseholderQr().solve(Y);  // rows a, b scale, c scale^2
    const Eigen::Vector2d a = C.row(0).transpose();
    v = C.row(1).transpose() / scale;
    acc = 2.0 * C.row(2).transpose() / (scale * scale);
    m.p0_W_m.head<2>() = a + (last.p_W_m - last.p_dr_m).head<2>();
    // Standard error of the acceleration: residual variance (both axes pooled, n - 3 degrees
    // of freedom each) times the c entry of (V^T V)^-1.
    const double s2 = (Y - V * C).squaredNorm() / (2.0 * (n - 3));
    const double inv_cc = (V.transpose() * V).inverse()(2, 2);
    acc_sigma = 2.0 * std::sqrt(s2 * inv_cc) / (scale * scale);
  }
  const double speed = v.norm();
  m.speed_mps = std::min(speed, p_.platform_max_speed_mps);
  m.heading_rad = speed > 1e-9 ? std::atan2(v.y(), v.x()) : 0.0;
  if (speed >= p_.turn_min_speed_mps) {
    // A turn or a braking the fixes cannot tell from their noise (within kAccelSignificance
    // standard errors of zero) is not extrapolated: 1.4 s of fixes at 8 m (~3 cm noise) leave
    // ~0.06 m/s^2 of acceleration noise, a false 0.1-0.2 rad/s turn at 0.5 m/s. 3 sigma: a
    // 1 m/s cart on a 10 m radius seen for 3 s is at ~15 sigma.
    constexpr double kAccelSignificance = 3.0;
    const double a_perp = (v.x() * acc.y() - v.y() * acc.x()) / speed;
    const double a_along = v.dot(acc) / speed;
    if (std::abs(a_perp) > kAccelSignificance * acc_sigma) {
      m.turn_rate_radps =
          std::clamp(a_perp / speed, -p_.max_turn_rate_radps, p_.max_turn_rate_radps);
    }
    if (a_along < -kAccelSignificance * acc_sigma) m.accel_mps2 = a_along;
  }
  return m;
}

bool PlatformTracker::steady(double window_s, double spread_deg, double max_tilt_deg,
                             std::string* why) const {
  if (fixes_.empty()) {
    if (why) *why = "no platform fix";
    return false;
  }
  const double t_from = fixes_.back().t_s - window_s;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  int n = 0;
  for (const PlatformFix& f : fixes_) {
    if (f.t_s >= t_from) {
      mean += f.n_W;
      ++n;
    }
  }
  if (n < 2) {
    if (why) *why = "fewer than 2 fixes in the steadiness window";
    return false;
  }
  mean.normalize();
  const double tilt = std::acos(std::clamp(mean.z(), -1.0, 1.0));
  if (tilt > max_tilt_deg * kDegToRad) {
    if (why) *why = "platform tilted " + std::to_string(tilt / kDegToRad) + " deg";
    return false;
  }
  for (const PlatformFix& f : fixes_) {
    if (f.t_s < t_from) continue;
    const double a = std::acos(std::clamp(f.n_W.dot(mean), -1.0, 1.0));
    if (a > spread_deg * kDegToRad) {
      if (why) *why = "platform attitude unsteady (" + std::to_string(a / kDegToRad) + " deg)";
      return false;
    }
  }
  if (why) why->clear();
  return true;
}

}  // namespace lander::ctl
