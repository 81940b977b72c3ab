#include "lander/sim/plant/rotor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace lander::sim {

namespace {
void check_index(int k) {
  if (k < 0 || k >= kNumRotors) {
    throw std::out_of_range("rotor index " + std::to_string(k) + " outside 0..5");
  }
}
}  // namespace

Eigen::Vector3d rotor_position_B(const RotorParams& p, int k) {
  check_index(k);
  // Azimuth 30 + 60 k degrees counter-clockwise from +x_B (hex-X).
  const double az = (30.0 + 60.0 * k) * M_PI / 180.0;
  return {p.arm_m * std::cos(az), p.arm_m * std::sin(az), p.height_m};
}

int rotor_spin(int k) {
  check_index(k);
  return (k % 2 == 0) ? +1 : -1;
}

double hover_speed_radps(const RotorParams& p, double mass_kg, double gravity_mps2) {
  if (!(mass_kg > 0) || !(gravity_mps2 > 0)) {
    throw std::invalid_argument("hover_speed_radps: mass and gravity must be > 0");
  }
  // 6 kT w^2 = m g.
  return std::sqrt(mass_kg * gravity_mps2 / (kNumRotors * p.kT));
}

BodyWrench rotor_wrench(const RotorParams& p, const RotorArray& w_radps,
                        const RotorArray& thrust_factor, const RotorArray& torque_factor) {
  BodyWrench out;
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
  for (int k = 0; k < kNumRotors; ++k) {
    const double thrust = thrust_factor[k] * rotor_thrust_N(p, w_radps[k]);
    const Eigen::Vector3d f = thrust * ez;
    out.force_B_N += f;
    // Moment of the thrust about the centre of mass plus the rotor's reaction torque.
    out.torque_B_Nm += rotor_position_B(p, k).cross(f);
    out.torque_B_Nm -= rotor_spin(k) * torque_factor[k] * rotor_torque_Nm(p, w_radps[k]) * ez;
  }
  return out;
}

MotorBank::MotorBank(const RotorParams& p) : p_(p) {
  p_.validate();
  w_.fill(p_.w_min_radps);
}

double MotorBank::saturate(double w) const {
  if (std::isnan(w)) throw std::invalid_argument("MotorBank: NaN motor command");
  return std::clamp(w, p_.w_min_radps, p_.w_max_radps);
}

void MotorBank::reset(const RotorArray& w_radps) {
  for (int k = 0; k < kNumRotors; ++k) w_[k] = saturate(w_radps[k]);
}

void MotorBank::step(const RotorArray& w_cmd_radps, double dt_s) {
  if (!(dt_s > 0)) throw std::invalid_argument("MotorBank::step: dt_s must be > 0");
  // Exact solution of the first-order lag over dt with the command held constant.
  for (int k = 0; k < kNumRotors; ++k) {
    const double alpha = 1.0 - std::exp(-dt_s / (p_.tau_s * tau_scale_[k]));
    w_[k] += (saturate(w_cmd_radps[k]) - w_[k]) * alpha;
  }
}

void MotorBank::set_tau_scale(const RotorArray& scale) {
  for (double s : scale) {
    if (!(s > 0)) throw std::invalid_argument("MotorBank::set_tau_scale: scales must be > 0");
  }
  tau_scale_ = scale;
}

}  // namespace lander::sim
