// Hex-X allocation: pseudo-inverse plus prioritised saturation (see mixer.h).
#include "lander/controller/mixer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace lander::ctl {

double HexMixer::rotor_azimuth_rad(int k) { return (30.0 + 60.0 * k) * M_PI / 180.0; }
int HexMixer::rotor_spin(int k) { return (k % 2 == 0) ? +1 : -1; }

HexMixer::HexMixer(const VehicleParams& vehicle) : v_(vehicle) {
  v_.validate();
  for (int k = 0; k < kNumRotors; ++k) {
    const double a = rotor_azimuth_rad(k);
    A_(0, k) = 1.0;
    A_(1, k) = v_.arm_m * std::sin(a);
    A_(2, k) = -v_.arm_m * std::cos(a);
    A_(3, k) = -rotor_spin(k) * v_.k_torque / v_.k_thrust;
  }
  A_pinv_ = A_.transpose() * (A_ * A_.transpose()).inverse();
  t_min_ = v_.k_thrust * v_.w_idle_radps * v_.w_idle_radps;
  t_max_ = v_.k_thrust * v_.w_max_radps * v_.w_max_radps;
}

Wrench HexMixer::wrench_of(const std::array<double, kNumRotors>& thrust_N) const {
  Eigen::Matrix<double, kNumRotors, 1> t;
  for (int k = 0; k < kNumRotors; ++k) t(k) = thrust_N[k];
  const Eigen::Vector4d w = A_ * t;
  Wrench out;
  out.thrust_N = w(0);
  out.torque_B_Nm = w.tail<3>();
  return out;
}

MixerOutput HexMixer::mix(const Wrench& demand) const {
  using Vec6 = Eigen::Matrix<double, kNumRotors, 1>;
  MixerOutput out;
  // Split the allocation into its parts: roll/pitch, collective, yaw.
  const Vec6 u_rp = A_pinv_ * Eigen::Vector4d(0, demand.torque_B_Nm.x(), demand.torque_B_Nm.y(), 0);
  const Vec6 u_yaw = A_pinv_ * Eigen::Vector4d(0, 0, 0, demand.torque_B_Nm.z());
  const double span = t_max_ - t_min_;
  constexpr double kEps = 1e-12;  // numerical slack for the range comparisons

  // 1) Roll/pitch alone must fit into the rotor range; otherwise scale them down together
  //    (the direction of the torque, hence of the attitude correction, is kept).
  const double rp_spread = u_rp.maxCoeff() - u_rp.minCoeff();
  if (rp_spread > span) {
    out.roll_pitch_scale = span / rp_spread;
    out.saturated = true;
  }
  Vec6 t = u_rp * out.roll_pitch_scale;

  // 2) Collective: add T/6 (thrust per rotor), then shift it into the range if needed
  //    (thrust gives way to attitude).
  const double per_rotor = std::clamp(demand.thrust_N, 0.0, kNumRotors * t_max_) / kNumRotors;
  t.array() += per_rotor;
  const double over = t.maxCoeff() - t_max_;
  const double under = t_min_ - t.minCoeff();
  if (over > kEps) {
    t.array() -= over;
    out.saturated = true;
  } else if (under > kEps) {
    t.array() += under;
    out.saturated = true;
  }
  if (demand.thrust_N < 0.0 || demand.thrust_N > kNumRotors * t_max_) out.saturated = true;

  // 3) Yaw: the largest fraction of the yaw allocation that keeps every rotor in range.
  double scale = 1.0;
  for (int k = 0; k < kNumRotors; ++k) {
    if (u_yaw(k) > kEps) scale = std::min(scale, std::max(0.0, (t_max_ - t(k)) / u_yaw(k)));
    if (u_yaw(k) < -kEps) scale = std::min(scale, std::max(0.0, (t_min_ - t(k)) / u_yaw(k)));
  }
  if (scale < 1.0 - 1e-9) out.saturated = true;
  out.yaw_scale = scale;
  t += scale * u_yaw;

  // Rotor speeds from thrusts (clamped against round-off).
  for (int k = 0; k < kNumRotors; ++k) {
    const double tk = std::clamp(t(k), t_min_, t_max_);
    out.thrust_N[k] = tk;
    out.w_radps[k] = std::sqrt(tk / v_.k_thrust);
  }
  out.achieved = wrench_of(out.thrust_N);
  return out;
}

}  // namespace lander::ctl
