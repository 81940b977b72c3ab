// Hex-X control allocation with saturation handling.
//
// Rotor k (k = 0..5) sits at azimuth a_k = 30 + 60 k deg (CCW from body +x), radius L (arm),
// spins with s_k = +1 (CCW from above) for even k, -1 for odd k. With T_k = kT w_k^2 the
// wrench on the body (B: x forward, y left, z up) is
//
//   [ T   ]   [  1          ...  1          ]
//   [ t_x ] = [  L sin a_k  ...             ] [ T_0 ... T_5 ]^T  =  A T_rotors
//   [ t_y ]   [ -L cos a_k  ...             ]
//   [ t_z ]   [ -s_k kQ/kT  ...             ]
//
// (t = r_k x (0, 0, T_k) for the thrust, -s_k kQ w^2 for the reaction torque; the 0.05 m
// height of the rotors above the CoM adds nothing because the thrust is along z).
// Allocation uses the pseudo-inverse of A. When rotors saturate, priorities are:
// roll/pitch torque (attitude) first, then collective thrust, then yaw torque.
#pragma once

#include <array>

#include <Eigen/Core>

#include "lander/controller/params.h"

namespace lander::ctl {

constexpr int kNumRotors = 6;

// Commanded wrench in B: collective thrust (N, along +z_B) and torques (N m).
struct Wrench {
  double thrust_N{0.0};
  Eigen::Vector3d torque_B_Nm{Eigen::Vector3d::Zero()};
};

// Output of the mixer: rotor speeds and what they actually produce.
struct MixerOutput {
  std::array<double, kNumRotors> w_radps{};        ///< rotor speed commands (rad/s)
  std::array<double, kNumRotors> thrust_N{};       ///< per-rotor thrust commands (N)
  Wrench achieved;                                 ///< wrench of those thrusts (A T)
  bool saturated{false};                           ///< any limit changed the demand
  double roll_pitch_scale{1.0};                    ///< < 1: roll/pitch torque was scaled
  double yaw_scale{1.0};                           ///< < 1: yaw torque was scaled
};

class HexMixer {
 public:
  explicit HexMixer(const VehicleParams& vehicle);

  // Allocates a wrench to rotor speeds within [w_idle, w_max] (seed 003 section 2, "control
  // allocation"), keeping roll/pitch torque when the rotors saturate.
  MixerOutput mix(const Wrench& demand) const;

  // Wrench produced by the given per-rotor thrusts (N).
  Wrench wrench_of(const std::array<double, kNumRotors>& thrust_N) const;

  const Eigen::Matrix<double, 4, kNumRotors>& allocation() const { return A_; }
  double thrust_min_N() const { return t_min_; }  ///< per rotor at w_idle (N)
  double thrust_max_N() const { return t_max_; }  ///< per rotor at w_max (N)

  // Rotor geometry shared with test models: azimuth (rad) and spin direction of rotor k.
  static double rotor_azimuth_rad(int k);
  static int rotor_spin(int k);

 private:
  VehicleParams v_;
  Eigen::Matrix<double, 4, kNumRotors> A_;
  Eigen::Matrix<double, kNumRotors, 4> A_pinv_;
  double t_min_, t_max_;
};

}  // namespace lander::ctl
