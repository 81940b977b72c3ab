// Cascaded multirotor control (seed 003 section 2, Fig. 3):
//   position -> velocity -> thrust vector + yaw (attitude) -> body rate -> hex-X mixer.
// The outer loop (position, velocity) runs at CascadeParams::outer_rate_hz (the camera rate);
// the inner loop (attitude, rate, mixer) at every call of update_inner(), which the caller
// makes at >= 250 Hz. No ground truth: inputs are NavState and ImuSample only.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/controller/mixer.h"
#include "lander/controller/params.h"
#include "lander/controller/vehicle_limits.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander::ctl {

// A position setpoint with feed-forward, all in W (z up).
struct Setpoint {
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};      ///< position (m)
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};    ///< velocity feed-forward (m/s)
  Eigen::Vector3d a_W_mps2{Eigen::Vector3d::Zero()};   ///< acceleration feed-forward (m/s^2)
  double yaw_rad{0.0};                                 ///< heading of body +x from W +x (rad)
};

// What the loops computed last, for traces.
struct CascadeDiagnostics {
  Setpoint setpoint;                                       ///< last outer-loop setpoint
  Eigen::Vector3d v_sp_W_mps{Eigen::Vector3d::Zero()};     ///< velocity setpoint (m/s)
  Eigen::Vector3d a_cmd_W_mps2{Eigen::Vector3d::Zero()};   ///< acceleration command (m/s^2)
  /// Estimated horizontal disturbance acceleration in W (m/s^2, z = 0): the external force
  /// per mass the accelerometer sees (see CascadeParams::dist_ff_gain); dist_ff_gain times it
  /// is subtracted from a_cmd.
  Eigen::Vector3d dist_W_mps2{Eigen::Vector3d::Zero()};
  Eigen::Vector3d force_sp_W_N{Eigen::Vector3d::Zero()};   ///< thrust vector setpoint (N)
  Eigen::Quaterniond q_sp_WB{Eigen::Quaterniond::Identity()};  ///< attitude setpoint
  Eigen::Vector3d omega_sp_B_radps{Eigen::Vector3d::Zero()};   ///< body-rate setpoint
  Wrench demand;                                           ///< wrench asked of the mixer
  MixerOutput mixer;                                       ///< last mixer output
};

class CascadeController {
 public:
  CascadeController(const VehicleParams& vehicle, const CascadeParams& gains);

  // Clears integrators and sets a hover thrust vector (call before the first update).
  void reset();

  // True when the outer loop is due at time t_s (s): every 1/outer_rate_hz.
  bool outer_due(double t_s) const;

  // Outer loop: P position -> PI velocity -> acceleration command -> thrust vector
  // F_W = m (a_cmd + g e_z), tilt-limited to max_tilt_deg (seed 003 eq. 3-4 linearised form;
  // here the full thrust-vector form). The horizontal disturbance estimate of update_inner()
  // is fed forward: a_cmd_xy -= dist_ff_gain d_xy.
  void update_outer(double t_s, const Setpoint& sp, const NavState& nav);
  // Instead of update_outer: the thrust vector F_W (N) and heading given directly (an
  // attitude-and-thrust setpoint from a companion computer, flight/components.h); the inner
  // loop flies it as it flies the outer loop's.
  void hold_thrust(double t_s, const Eigen::Vector3d& force_W_N, double yaw_rad);

  // Inner loop: attitude from (F_W, yaw) -> body-rate setpoint -> rate PI -> torque
  // tau = J alpha + omega x J omega (seed 003 eq. 1) -> mixer. Returns rotor speeds.
  // Uses nav.q_WB and nav.omega_B_radps; if nav is invalid, levels with the gyro.
  // Also updates the disturbance estimate from imu.accel_B_mps2 (with a valid nav).
  MixerOutput update_inner(double t_s, const NavState& nav, const ImuSample& imu);

  // Tilt limit of the thrust vector (deg, in (0, 80)), at most CascadeParams::max_tilt_deg;
  // the landing controller lowers it while the target must stay in the camera's view.
  void set_tilt_limit_deg(double deg);
  // Descent speed limit of the velocity setpoint (m/s, > 0), at most
  // CascadeParams::max_vel_down_mps; the landing controller lowers it near the platform.
  void set_descent_limit_mps(double mps);

  const CascadeDiagnostics& diagnostics() const { return diag_; }
  const HexMixer& mixer() const { return mixer_; }
  const VehicleParams& vehicle() const { return v_; }
  const CascadeParams& gains() const { return g_; }
  // The speed and tilt limits derived from the vehicle model and the gains.
  const VehicleLimits& limits() const { return limits_; }

  // Attitude whose body z is along `force_W` and whose heading is `yaw_rad` (rad).
  static Eigen::Quaterniond attitude_from_thrust(const Eigen::Vector3d& force_W, double yaw_rad);

 private:
  // Low-passes the horizontal external acceleration read by the accelerometer (see .cpp).
  void update_disturbance(double dt, const NavState& nav, const ImuSample& imu);

  VehicleParams v_;
  CascadeParams g_;
  VehicleLimits limits_;
  HexMixer mixer_;
  Eigen::Vector3d vel_int_{Eigen::Vector3d::Zero()};   // velocity integral (m/s^2)
  Eigen::Vector3d rate_int_{Eigen::Vector3d::Zero()};  // rate integral (rad/s^2)
  Eigen::Vector2d dist_W_{Eigen::Vector2d::Zero()};    // horizontal disturbance (m/s^2)
  Eigen::Vector3d force_sp_W_{Eigen::Vector3d::Zero()};
  double yaw_sp_{0.0};
  double tilt_limit_deg_{30.0};
  double descent_limit_mps_{1.5};
  double last_outer_t_{-1e300};
  double last_inner_t_{-1e300};
  CascadeDiagnostics diag_;
};

}  // namespace lander::ctl
