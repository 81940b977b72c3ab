// Cascade position -> velocity -> attitude -> rate -> mixer (see cascade.h).
#include "lander/controller/cascade.h"

#include <algorithm>
#include <cmath>

namespace lander::ctl {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Longest inner/outer step used for integration; a longer gap (first call, pause) is not
// integrated over so the integrators cannot jump.
constexpr double kMaxInnerDt = 0.05;
constexpr double kMaxOuterDt = 0.2;

Eigen::Vector2d clamp_norm(const Eigen::Vector2d& v, double max_norm) {
  const double n = v.norm();
  return n > max_norm ? Eigen::Vector2d(v * (max_norm / n)) : v;
}

}  // namespace

CascadeController::CascadeController(const VehicleParams& vehicle, const CascadeParams& gains)
    : v_(vehicle), g_(gains), mixer_(vehicle) {
  g_.validate();
  limits_ = derive_limits(v_, g_);
  tilt_limit_deg_ = g_.max_tilt_deg;
  descent_limit_mps_ = g_.max_vel_down_mps;
  reset();
}

void CascadeController::set_tilt_limit_deg(double deg) {
  tilt_limit_deg_ = std::clamp(deg, 1.0, g_.max_tilt_deg);
}

void CascadeController::set_descent_limit_mps(double mps) {
  descent_limit_mps_ = std::clamp(mps, 0.01, g_.max_vel_down_mps);
}

void CascadeController::reset() {
  vel_int_.setZero();
  rate_int_.setZero();
  dist_W_.setZero();
  force_sp_W_ = Eigen::Vector3d(0, 0, v_.mass_kg * v_.gravity_mps2);
  last_outer_t_ = -1e300;
  last_inner_t_ = -1e300;
  diag_ = CascadeDiagnostics{};
  diag_.force_sp_W_N = force_sp_W_;
}

bool CascadeController::outer_due(double t_s) const {
  // Half a microsecond of slack so a loop on exact multiples of the period is not skipped.
  return t_s - last_outer_t_ >= 1.0 / g_.outer_rate_hz - 5e-7;
}

Eigen::Quaterniond CascadeController::attitude_from_thrust(const Eigen::Vector3d& force_W,
                                                           double yaw_rad) {
  const Eigen::Vector3d z_B =
      force_W.norm() > 1e-9 ? Eigen::Vector3d(force_W.normalized()) : Eigen::Vector3d::UnitZ();
  // Heading direction projected: x_C = (cos yaw, sin yaw, 0); y_B = z_B x x_C; x_B = y_B x z_B.
  const Eigen::Vector3d x_C(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  Eigen::Vector3d y_B = z_B.cross(x_C);
  if (y_B.norm() < 1e-6) y_B = z_B.cross(Eigen::Vector3d::UnitX());  // thrust horizontal
  y_B.normalize();
  const Eigen::Vector3d x_B = y_B.cross(z_B);
  Eigen::Matrix3d R;
  R.col(0) = x_B;
  R.col(1) = y_B;
  R.col(2) = z_B;
  return Eigen::Quaterniond(R).normalized();
}

void CascadeController::update_outer(double t_s, const Setpoint& sp, const NavState& nav) {
  const bool first = last_outer_t_ < -1e299;  // nothing to integrate over on the first call
  const double dt = first ? 0.0 : std::clamp(t_s - last_outer_t_, 0.0, kMaxOuterDt);
  last_outer_t_ = t_s;
  const double g = v_.gravity_mps2;

  // Position P -> velocity setpoint: the feed-forward plus a correction bounded by the
  // closing speed, the sum by the vehicle's speed limit (vehicle_limits.h).
  const Eigen::Vector3d e_p = sp.p_W_m - nav.p_W_m;
  Eigen::Vector3d v_sp = sp.v_W_mps;
  const Eigen::Vector2d closing = clamp_norm(g_.pos_kp_xy * e_p.head<2>(), g_.max_closing_vel_xy_mps);
  v_sp.head<2>() = clamp_norm(v_sp.head<2>() + closing, limits_.max_speed_xy_mps);
  v_sp.z() += g_.pos_kp_z * e_p.z();
  v_sp.z() = std::clamp(v_sp.z(), -descent_limit_mps_, g_.max_vel_up_mps);

  // Velocity PI -> acceleration command (with anti-windup clamp on the integral).
  const Eigen::Vector3d e_v = v_sp - nav.v_W_mps;
  vel_int_.x() += g_.vel_ki_xy * e_v.x() * dt;
  vel_int_.y() += g_.vel_ki_xy * e_v.y() * dt;
  vel_int_.z() += g_.vel_ki_z * e_v.z() * dt;
  vel_int_ = vel_int_.cwiseMax(-g_.max_int_accel_mps2).cwiseMin(g_.max_int_accel_mps2);
  Eigen::Vector3d a_cmd = sp.a_W_mps2 + vel_int_;
  a_cmd.x() += g_.vel_kp_xy * e_v.x();
  a_cmd.y() += g_.vel_kp_xy * e_v.y();
  // Disturbance feed-forward: the plant adds d to what the thrust vector gives, so ask for
  // that much less (the integral takes what the estimate misses).
  a_cmd.head<2>() -= g_.dist_ff_gain * dist_W_;
  a_cmd.z() += g_.vel_kp_z * e_v.z();
  a_cmd.z() = std::clamp(a_cmd.z(), -g_.max_accel_z_mps2, g_.max_accel_z_mps2);

  // Tilt limit: |a_xy| <= (g + a_z) tan(max_tilt) keeps the thrust vector in the cone.
  const double a_xy_max = (g + a_cmd.z()) * std::tan(tilt_limit_deg_ * kDegToRad);
  a_cmd.head<2>() = clamp_norm(a_cmd.head<2>(), std::max(0.0, a_xy_max));

  force_sp_W_ = v_.mass_kg * (a_cmd + Eigen::Vector3d(0, 0, g));
  yaw_sp_ = sp.yaw_rad;

  diag_.setpoint = sp;
  diag_.v_sp_W_mps = v_sp;
  diag_.a_cmd_W_mps2 = a_cmd;
  diag_.force_sp_W_N = force_sp_W_;
}

void CascadeController::hold_thrust(double t_s, const Eigen::Vector3d& force_W_N, double yaw_rad) {
  last_outer_t_ = t_s;
  force_sp_W_ = force_W_N;
  yaw_sp_ = yaw_rad;
  diag_.force_sp_W_N = force_sp_W_;
}

// The rotors push along z_B only, so the specific force the accelerometer reads is
//   f_B = (T / m) e_z + R_WB^T F_ext / m,
// and its body-x/y components are the external force (drag in wind, gusts) per mass. In W,
// d = R_WB (f_Bx, f_By, 0) is that force's horizontal part, up to the projection of its
// body-z component (~sin^2 of the tilt: 3 % at 10 deg). First-order low-pass, bounded:
//   d_k = d_{k-1} + (d_meas - d_{k-1}) min(1, dt / tau).
void CascadeController::update_disturbance(double dt, const NavState& nav, const ImuSample& imu) {
  if (!(dt > 0) || !imu.accel_B_mps2.allFinite()) return;
  const Eigen::Vector3d f_xy_B(imu.accel_B_mps2.x(), imu.accel_B_mps2.y(), 0.0);
  const Eigen::Vector2d d_meas = (nav.q_WB * f_xy_B).head<2>();
  dist_W_ += (d_meas - dist_W_) * std::min(1.0, dt / g_.dist_filter_tau_s);
  dist_W_ = clamp_norm(dist_W_, g_.max_dist_accel_mps2);
  diag_.dist_W_mps2 = Eigen::Vector3d(dist_W_.x(), dist_W_.y(), 0.0);
}

MixerOutput CascadeController::update_inner(double t_s, const NavState& nav,
                                            const ImuSample& imu) {
  const bool first = last_inner_t_ < -1e299;
  const double dt = first ? 0.0 : std::clamp(t_s - last_inner_t_, 0.0, kMaxInnerDt);
  last_inner_t_ = t_s;
  const Eigen::Vector3d J = v_.inertia_kgm2;

  Eigen::Vector3d omega_sp = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega;
  double thrust;
  if (nav.valid) {
    update_disturbance(dt, nav, imu);
    omega = nav.omega_B_radps;
    const Eigen::Quaterniond q_sp = attitude_from_thrust(force_sp_W_, yaw_sp_);
    diag_.q_sp_WB = q_sp;
    // Attitude error with roll/pitch before yaw (reduced attitude, as PX4's AttitudeControl):
    // q_red tilts the current z_B onto the desired one by the shortest rotation; the rest of
    // the way to q_sp is a pure yaw q_mix, whose angle is scaled by w = kp_yaw / kp_rp so a
    // large heading change does not disturb the thrust direction.
    const Eigen::Vector3d e_z = nav.q_WB * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d e_z_d = q_sp * Eigen::Vector3d::UnitZ();
    Eigen::Quaterniond q_red = Eigen::Quaterniond::FromTwoVectors(e_z, e_z_d) * nav.q_WB;
    if (e_z.dot(e_z_d) < -1.0 + 1e-9) q_red = q_sp;  // upside down: no unique tilt axis
    Eigen::Quaterniond q_mix = q_red.conjugate() * q_sp;
    if (q_mix.w() < 0) q_mix.coeffs() *= -1.0;
    const double yaw_w = std::clamp(g_.att_kp_yaw / g_.att_kp_rp, 0.0, 1.0);
    const double half_yaw = std::asin(std::clamp(q_mix.z(), -1.0, 1.0));
    const Eigen::Quaterniond q_d =
        q_red * Eigen::Quaterniond(std::cos(yaw_w * half_yaw), 0, 0, std::sin(yaw_w * half_yaw));
    Eigen::Quaterniond q_e = nav.q_WB.conjugate() * q_d;
    if (q_e.w() < 0) q_e.coeffs() *= -1.0;
    // Rotation vector ~ 2 vec(q_e) in B; one gain, the yaw already weighted in q_d.
    omega_sp = g_.att_kp_rp * 2.0 * q_e.vec();
    const double max_rp = g_.max_rate_rp_degps * kDegToRad;
    const double max_yaw = g_.max_rate_yaw_degps * kDegToRad;
    omega_sp.x() = std::clamp(omega_sp.x(), -max_rp, max_rp);
    omega_sp.y() = std::clamp(omega_sp.y(), -max_rp, max_rp);
    omega_sp.z() = std::clamp(omega_sp.z(), -max_yaw, max_yaw);
    // Collective: the thrust vector projected on the current body z.
    const Eigen::Vector3d z_B = nav.q_WB * Eigen::Vector3d::UnitZ();
    thrust = std::max(0.0, force_sp_W_.dot(z_B));
  } else {
    // No navigation: damp the rates with the gyro and hold hover thrust.
    omega = imu.gyro_B_radps;
    thrust = v_.mass_kg * v_.gravity_mps2;
  }

  // Rate PI on angular acceleration, then tau = J alpha + omega x (J omega).
  const Eigen::Vector3d e_w = omega_sp - omega;
  const Eigen::Vector3d kp(g_.rate_kp_rp, g_.rate_kp_rp, g_.rate_kp_yaw);
  const Eigen::Vector3d ki(g_.rate_ki_rp, g_.rate_ki_rp, g_.rate_ki_yaw);
  rate_int_ += ki.cwiseProduct(e_w) * dt;
  rate_int_ = rate_int_.cwiseMax(-g_.max_int_alpha_radps2).cwiseMin(g_.max_int_alpha_radps2);
  const Eigen::Vector3d alpha = kp.cwiseProduct(e_w) + rate_int_;
  const Eigen::Vector3d Jw = J.cwiseProduct(omega);
  Wrench demand;
  demand.thrust_N = thrust;
  demand.torque_B_Nm = J.cwiseProduct(alpha) + omega.cross(Jw);

  diag_.omega_sp_B_radps = omega_sp;
  diag_.demand = demand;
  diag_.mixer = mixer_.mix(demand);
  return diag_.mixer;
}

}  // namespace lander::ctl
