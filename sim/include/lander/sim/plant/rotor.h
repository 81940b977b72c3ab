// Rotor and motor model of the ZD850-class hexarotor (seed 000 vehicle): thrust T = kT w^2,
// reaction torque Q = kQ w^2, first-order motor lag with saturation, and the body wrench of
// the six rotors in the hex-X layout. Plain C++ (no MuJoCo): the simulation loop applies the
// returned wrench to the body.
//
// Layout (B: x forward, y left, z up, origin at the centre of mass): rotor k (k = 0..5) sits
// at azimuth 30 + 60 k degrees counter-clockwise from +x, at arm length `arm_m`, `height_m`
// above the centre of mass; spin s_k = +1 (CCW seen from above) for even k, -1 for odd k.
// Each rotor pushes along +z_B with T_k and twists the body about +z_B by -s_k kQ w_k^2.
#pragma once

#include <array>

#include <Eigen/Core>

#include "lander/core/params_io.h"

namespace lander::sim {

constexpr int kNumRotors = 6;
using RotorArray = std::array<double, kNumRotors>;

struct RotorParams {
  double kT{2.05e-5};        ///< thrust coefficient (N/(rad/s)^2), T = kT w^2
  double kQ{3.3e-7};         ///< reaction torque coefficient (N m/(rad/s)^2), Q = kQ w^2
  double tau_s{0.05};        ///< motor time constant (s), first-order lag
  double w_min_radps{0.0};   ///< lowest rotor speed (rad/s)
  double w_max_radps{800.0}; ///< highest rotor speed (rad/s)
  double radius_m{0.19};     ///< rotor radius (m), used by the ground effect
  double arm_m{0.425};       ///< centre of mass to rotor axis, in the xy plane of B (m)
  double height_m{0.05};     ///< rotor plane above the centre of mass (m)

  void validate() const {
    check_fields(*this);
    require(w_max_radps > w_min_radps, "w_max_radps", "must be > w_min_radps");
    require(arm_m > radius_m, "arm_m", "must be > radius_m (rotors would overlap the hub)");
  }
};

template <class V>
void visit_fields(V& v, RotorParams& p) {
  v("kT", p.kT, range::positive, "N/(rad/s)^2", "thrust coefficient");
  v("kQ", p.kQ, range::non_negative, "N m/(rad/s)^2", "reaction torque coefficient");
  v("tau_s", p.tau_s, range::positive, "s", "motor time constant");
  v("w_min_radps", p.w_min_radps, range::non_negative, "rad/s", "lowest rotor speed");
  v("w_max_radps", p.w_max_radps, range::any, "rad/s", "highest rotor speed");
  v("radius_m", p.radius_m, range::positive, "m", "rotor radius");
  v("arm_m", p.arm_m, range::any, "m", "centre of mass to rotor axis");
  v("height_m", p.height_m, range::any, "m", "rotor plane above the centre of mass");
}

// Position of rotor k's hub in B (m).
Eigen::Vector3d rotor_position_B(const RotorParams& p, int k);
// Spin direction of rotor k: +1 counter-clockwise seen from above (even k), -1 otherwise.
int rotor_spin(int k);
// Thrust of one rotor (N) at speed w (rad/s): T = kT w^2.
inline double rotor_thrust_N(const RotorParams& p, double w) { return p.kT * w * w; }
// Magnitude of one rotor's reaction torque (N m): Q = kQ w^2.
inline double rotor_torque_Nm(const RotorParams& p, double w) { return p.kQ * w * w; }
// Speed (rad/s) at which six equal rotors carry mass_kg against gravity_mps2 (vertical).
double hover_speed_radps(const RotorParams& p, double mass_kg, double gravity_mps2 = 9.81);

// Force and torque on the body about its centre of mass, in B.
struct BodyWrench {
  Eigen::Vector3d force_B_N{Eigen::Vector3d::Zero()};
  Eigen::Vector3d torque_B_Nm{Eigen::Vector3d::Zero()};
};

// Wrench of the six rotors at speeds w (rad/s). thrust_factor[k] multiplies rotor k's
// thrust (ground effect, ground_effect.h; 1 out of ground effect); the reaction torque is
// left unscaled.
//   F_B = sum_k f_k kT w_k^2 e_z
//   M_B = sum_k r_k x (f_k kT w_k^2 e_z) - s_k kQ w_k^2 e_z
// torque_factor[k] multiplies rotor k's reaction torque (a rotor with another kQ).
BodyWrench rotor_wrench(const RotorParams& p, const RotorArray& w_radps,
                        const RotorArray& thrust_factor = {1, 1, 1, 1, 1, 1},
                        const RotorArray& torque_factor = {1, 1, 1, 1, 1, 1});

// Six motors with first-order lag toward the commanded speed and saturation:
//   dw/dt = (sat(w_cmd) - w) / tau,
// integrated exactly over a step with the command held: w += (sat(w_cmd) - w)(1 - e^{-dt/tau}).
// The speed never leaves [w_min, w_max].
class MotorBank {
 public:
  explicit MotorBank(const RotorParams& p);  // validates p; starts at w_min
  void reset(const RotorArray& w_radps);     // clamps into [w_min, w_max]
  // Advances dt_s (> 0) seconds toward w_cmd_radps (saturated to [w_min, w_max]).
  void step(const RotorArray& w_cmd_radps, double dt_s);
  const RotorArray& speeds_radps() const { return w_; }
  const RotorParams& params() const { return p_; }
  double saturate(double w) const;
  // Rotor k's time constant becomes tau_s x scale[k] (each > 0): a slower or faster motor.
  void set_tau_scale(const RotorArray& scale);

 private:
  RotorParams p_;
  RotorArray w_{};
  RotorArray tau_scale_{1, 1, 1, 1, 1, 1};
};

}  // namespace lander::sim
