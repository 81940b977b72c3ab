#include "lander/estimator/navigation.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <utility>

namespace lander {
namespace {
// GPS fixes further apart than this are a gap (a drop-out): the correction from the last fix
// is held no longer, and the next fix's velocity difference is not an acceleration sample.
constexpr double kGpsHoldMax_s = 1.0;
// Before the first two fixes (no interval known yet): a receiver at 2 Hz or more delivers its
// second fix within this of the first (or its first within this of the start).
constexpr double kFirstPairMax_s = 0.5;
// The held error is applied for this many of the last fix intervals after a fix arrives.
constexpr double kHoldIntervals = 1.5;

// The IMU side's low-passed specific force at t_ref (W): the last of `hist` at or before it,
// else `f_lp`.
Eigen::Vector3d specific_force_at(const std::deque<std::pair<double, Eigen::Vector3d>>& hist,
                                  const Eigen::Vector3d& f_lp, double t_ref) {
  Eigen::Vector3d f_ref = f_lp;
  for (const auto& h : hist) {
    if (h.first <= t_ref) f_ref = h.second;
  }
  return f_ref;
}

// The attitude error (W) between the IMU's specific force f_ref and the one the GPS
// acceleration a_gps_W implies, zero unless |f_ref| is within the accelerometer gate of g;
// its z part from the directions of the two horizontal accelerations.
Eigen::Vector3d gps_attitude_error(const NavigationParams& p, const Eigen::Vector3d& f_ref,
                                   const Eigen::Vector3d& a_gps_W) {
  Eigen::Vector3d e_W = Eigen::Vector3d::Zero();
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ref_W = a_gps_W + p.gravity_mps2 * ez;
  const double fn = f_ref.norm();
  if (std::abs(fn - p.gravity_mps2) < p.accel_gate_frac * p.gravity_mps2) {
    e_W = (f_ref / fn).cross(ref_W.normalized());
    // Yaw from the direction of the horizontal acceleration.
    const Eigen::Vector2d a_meas = (f_ref - p.gravity_mps2 * ez).head<2>();
    const Eigen::Vector2d a_ref = a_gps_W.head<2>();
    if (a_meas.norm() > p.yaw_min_accel_mps2 && a_ref.norm() > p.yaw_min_accel_mps2) {
      const Eigen::Vector2d m = a_meas.normalized(), r = a_ref.normalized();
      e_W.z() += (p.mahony_k_yaw / std::max(p.mahony_kp, 1e-9)) * (m.x() * r.y() - m.y() * r.x());
    }
  }
  return e_W;
}

// One gated scalar update (seed 004 eq. 27) of the axis state x = (p, v, b_a) with
// covariance P by the measurement z = H x + noise of variance R: a residual beyond
// gate_sigma sigmas enters with gate_factor_n of its gain.
void gated_scalar_update(const NavigationParams& p, const Eigen::RowVector3d& H, double z,
                         double R, Eigen::Vector3d& x, Eigen::Matrix3d& P) {
  const double r = z - H * x;
  const double S = (H * P * H.transpose())(0, 0) + R;
  const double scale = std::abs(r) > p.gate_sigma * std::sqrt(S) ? p.gate_factor_n : 1.0;
  const Eigen::Vector3d K = scale * P * H.transpose() / S;
  x += K * r;
  const Eigen::Matrix3d IKH = Eigen::Matrix3d::Identity() - K * H;
  P = IKH * P * IKH.transpose() + K * R * K.transpose();
}
}  // namespace

void NavigationParams::validate() const {
  check_fields(*this);
  require(mag_field_W_uT.head<2>().norm() > 1.0, "mag_field_W_uT", "needs a horizontal component");
  require(gps_loss_gyro_only_s >= 0 && std::isfinite(gps_loss_gyro_only_s),
          "gps_loss_gyro_only_s", "must be >= 0 and finite");
  require(std::isfinite(initial_yaw_rad), "initial_yaw_deg", "must be finite");
}

Navigation::Navigation(const NavigationParams& p) : p_(p) {
  p_.validate();
  for (auto& P : P_) P.setZero();
}

bool Navigation::add_mag(const MagSample& mag) {
  if (!att_init_ || !p_.use_magnetometer || !mag.field_B_uT.allFinite()) return false;
  // Heading of the measured field's horizontal part in W, against the reference's.
  const Eigen::Vector3d m_W = q_WB_ * mag.field_B_uT;
  if (m_W.head<2>().norm() < 1e-6) return false;
  const double err = std::remainder(std::atan2(p_.mag_field_W_uT.y(), p_.mag_field_W_uT.x()) -
                                        std::atan2(m_W.y(), m_W.x()),
                                    2.0 * M_PI);
  double frac = 1.0;  // first sample: take the compass heading
  if (mag_init_) {
    const double dt = std::clamp(mag.t_s - t_mag_s_, 0.0, 1.0);
    frac = 1.0 - std::exp(-p_.mag_k_yaw * dt);
  }
  q_WB_ = Eigen::Quaterniond(Eigen::AngleAxisd(frac * err, Eigen::Vector3d::UnitZ())) * q_WB_;
  q_WB_.normalize();
  t_mag_s_ = mag.t_s;
  mag_init_ = true;
  return true;
}

bool Navigation::add_imu(const ImuSample& imu) {
  if (!std::isfinite(imu.t_s) || !imu.gyro_B_radps.allFinite() || !imu.accel_B_mps2.allFinite()) {
    return false;
  }
  const Eigen::Vector3d f = imu.accel_B_mps2;
  if (!att_init_) {
    // Roll and pitch from gravity at rest: f_B = R_WB^T g e_z.
    const double roll = std::atan2(f.y(), f.z());
    const double pitch = std::atan2(-f.x(), std::hypot(f.y(), f.z()));
    q_WB_ = Eigen::AngleAxisd(p_.initial_yaw_rad, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
    t_s_ = imu.t_s;
    t_init_s_ = imu.t_s;
    att_init_ = true;
    f_W_lp_ = q_WB_ * f;
    omega_B_ = imu.gyro_B_radps;
    return true;
  }
  const double dt = imu.t_s - t_s_;
  if (!(dt > 0)) return true;
  t_s_ = imu.t_s;

  // --- Mahony explicit complementary filter.
  Eigen::Vector3d w = imu.gyro_B_radps - b_g_;
  omega_B_ = w;
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
  f_W_lp_ += (1.0 - std::exp(-dt / p_.accel_lowpass_s)) * (q_WB_ * f - f_W_lp_);
  f_W_hist_.push_back({t_s_, f_W_lp_});
  constexpr double kHistory_s = 2.0;  // covers GPS latency + interval at >= 1 Hz
  while (!f_W_hist_.empty() && f_W_hist_.front().first < t_s_ - kHistory_s) f_W_hist_.pop_front();
  Eigen::Vector3d e_B = Eigen::Vector3d::Zero();
  bool use = false;
  // The GPS-derived correction is only held while fixes keep coming; in a drop-out the gyro
  // alone, for up to gps_loss_gyro_only_s, then plain Mahony (header).
  // The held error covers the interval to the next fix (1.5 intervals, for jitter), no
  // longer: when fixes stop, the error of the last one (GPS velocity noise differenced: ~2
  // deg) would otherwise steer the attitude for a whole second.
  // Before any fix, the time is counted from the first IMU sample: a start in a drop-out
  // (no second fix within kFirstPairMax_s) is flown on the gyro too, from the attitude at rest.
  const double since_fix = t_s_ - (t_gps_arrival_s_ >= 0.0 ? t_gps_arrival_s_ : t_init_s_);
  const double hold_s = std::min(kGpsHoldMax_s, kHoldIntervals * gps_interval_s_);
  const double lost_after_s = have_a_gps_ ? hold_s : kFirstPairMax_s;
  if (p_.compensate_accel && have_a_gps_ && since_fix < hold_s) {
    // Error computed at the last GPS fix (add_gps), rotated into B with today's attitude.
    use = e_W_hold_.allFinite() && !e_W_hold_.isZero(0.0);
    e_B = q_WB_.conjugate() * e_W_hold_;
  } else if (p_.compensate_accel && since_fix >= lost_after_s &&
             since_fix < lost_after_s + p_.gps_loss_gyro_only_s) {
    use = false;  // drop-out: gyro only
  } else {
    // Plain Mahony: the specific force in B is taken as "up".
    const double fn = f.norm();
    use = std::abs(fn - p_.gravity_mps2) < p_.accel_gate_frac * p_.gravity_mps2;
    if (use) e_B = (f / fn).cross(q_WB_.conjugate() * ez);
  }
  if (use) {
    w += p_.mahony_kp * e_B;
    b_g_ -= p_.mahony_ki * e_B * dt;
    b_g_ = b_g_.cwiseMax(-p_.gyro_bias_limit_radps).cwiseMin(p_.gyro_bias_limit_radps);
  }
  const double angle = w.norm() * dt;
  if (angle > 0) q_WB_ = q_WB_ * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w.normalized()));
  q_WB_.normalize();

  // --- Per-axis [p, v, b] prediction with the accelerometer in W.
  const Eigen::Vector3d a_meas_W = q_WB_ * f - Eigen::Vector3d(0, 0, p_.gravity_mps2);
  a_W_ = a_meas_W - b_a_;
  if (!pos_init_) return true;
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 1) = dt;
  F(0, 2) = -0.5 * dt * dt;
  F(1, 2) = -dt;
  const double q = p_.accel_noise_mps2 * p_.accel_noise_mps2;
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
  Q(0, 0) = q * dt * dt * dt / 3.0;
  Q(0, 1) = Q(1, 0) = q * dt * dt / 2.0;
  Q(1, 1) = q * dt;
  Q(2, 2) = p_.accel_bias_rw_mps3 * p_.accel_bias_rw_mps3 * dt;
  for (int i = 0; i < 3; ++i) {
    pos_[i] += vel_[i] * dt + 0.5 * a_W_[i] * dt * dt;
    vel_[i] += a_W_[i] * dt;
    P_[i] = F * P_[i] * F.transpose() + Q;
  }
  return true;
}

bool Navigation::add_gps(const GpsSample& gps) {
  if (!att_init_ || !gps.valid || !gps.p_W_m.allFinite() || !gps.v_W_mps.allFinite()) {
    return false;
  }
  const double age = t_s_ - gps.t_s;
  if (age > p_.max_sample_age_s || age < -1e-6) return false;
  // Low-passed GPS acceleration for the attitude correction.
  // A gap: fixes had come (the state was GPS-corrected), then none for kGpsHoldMax_s.
  const bool resumed_after_gap = t_gps_prev_ >= 0 && gps.t_s - t_gps_prev_ >= kGpsHoldMax_s;
  if (resumed_after_gap) {
    // After a gap: no correction from this fix; the GPS side restarts from the IMU side's
    // low-passed acceleration, so the next fixes' differences build on a consistent pair.
    a_gps_W_ = f_W_lp_ - p_.gravity_mps2 * Eigen::Vector3d::UnitZ();
    e_W_hold_.setZero();
  } else if (t_gps_prev_ >= 0 && gps.t_s > t_gps_prev_) {
    const double dtg = gps.t_s - t_gps_prev_;
    gps_interval_s_ = dtg;
    const Eigen::Vector3d a_raw = (gps.v_W_mps - v_gps_prev_) / dtg;
    a_gps_W_ += (1.0 - std::exp(-dtg / p_.accel_lowpass_s)) * (a_raw - a_gps_W_);
    have_a_gps_ = true;
    // IMU-side specific force at the time a_raw refers to.
    const double t_ref = gps.t_s - 0.5 * dtg;
    const Eigen::Vector3d f_ref = specific_force_at(f_W_hist_, f_W_lp_, t_ref);
    e_W_hold_ = gps_attitude_error(p_, f_ref, a_gps_W_);
  }
  t_gps_prev_ = gps.t_s;
  t_gps_arrival_s_ = t_s_;
  v_gps_prev_ = gps.v_W_mps;
  const double sd_p[3] = {p_.gps_horizontal_std_m, p_.gps_horizontal_std_m,
                          p_.gps_vertical_std_m};
  if (!pos_init_) {
    pos_ = gps.p_W_m + gps.v_W_mps * std::max(0.0, age);
    vel_ = gps.v_W_mps;
    b_a_.setZero();
    for (int i = 0; i < 3; ++i) {
      P_[i] = Eigen::Vector3d(sd_p[i] * sd_p[i], p_.gps_velocity_std_mps * p_.gps_velocity_std_mps,
                              p_.initial_accel_bias_std_mps2 * p_.initial_accel_bias_std_mps2)
                  .asDiagonal();
    }
    pos_init_ = true;
    return true;
  }
  const double a = std::max(0.0, age);
  const Eigen::Vector3d vel_before = vel_;
  if (resumed_after_gap && pos_init_) {
    // Fixes are back after a gap: the velocity is taken from the fix, as at the first fix.
    // Coasting on the accelerometer may have drifted by more than the residual gate (eq. 27),
    // and a gated update pulls the state back at a tenth of its gain per fix: seconds of a
    // velocity metres per second off, with the controller flying on it (a start in a
    // drop-out, default-0007 of the envelope: 5.9 m/s off at the fix, still 4 m/s 3 s later).
    // The position keeps its gated update (a receiver's glitch at that fix must not move it).
    vel_ = gps.v_W_mps + a_W_ * a;
    for (int i = 0; i < 3; ++i) {
      P_[i].row(1).setZero();
      P_[i].col(1).setZero();
      P_[i](1, 1) = p_.gps_velocity_std_mps * p_.gps_velocity_std_mps;
    }
    ++velocity_resets_;
  }
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d x(pos_[i], vel_[i], b_a_[i]);
    // Position then velocity, each a gated scalar update (seed 004 eq. 27). The value at the
    // sampling time is H x with H = [1, -age, 0] for the position.
    // Velocity: v(t - age) = v - a_W age, with a_W the last bias-corrected acceleration
    // (its dependence on b is neglected).
    const Eigen::RowVector3d Hs[2] = {Eigen::RowVector3d(1.0, -a, 0.0),
                                      Eigen::RowVector3d(0.0, 1.0, 0.0)};
    const double zs[2] = {gps.p_W_m[i], gps.v_W_mps[i] + a_W_[i] * a};
    const double Rs[2] = {sd_p[i] * sd_p[i], p_.gps_velocity_std_mps * p_.gps_velocity_std_mps};
    for (int k = 0; k < 2; ++k) gated_scalar_update(p_, Hs[k], zs[k], Rs[k], x, P_[i]);
    pos_[i] = x[0];
    vel_[i] = x[1];
    b_a_[i] = x[2];
  }
  v_corr_.head<2>() += (vel_ - vel_before).head<2>();
  return true;
}

NavState Navigation::state() const {
  NavState s;
  s.t_s = t_s_;
  s.valid = att_init_ && pos_init_;
  s.q_WB = q_WB_;
  s.p_W_m = pos_;
  s.v_W_mps = vel_;
  s.v_corr_W_mps = v_corr_;
  s.omega_B_radps = omega_B_;
  return s;
}

NavState with_altitude(NavState nav, const AltitudeEstimate& alt) {
  if (alt.valid) {
    nav.p_W_m.z() = alt.z_W_m;
    nav.v_W_mps.z() = alt.vz_W_mps;
  }
  return nav;
}

}  // namespace lander
