// Navigation: attitude from gyro and accelerometer (Mahony's complementary filter on SO(3))
// and position/velocity from GPS and accelerometer (a Kalman filter per world axis). This is
// what seeds 000/004 read from their flight controller as R_b^n and t_b^n.
//
// Attitude (Mahony, Hamel, Pflimlin, "Nonlinear complementary filters on the special
// orthogonal group", IEEE TAC 53(5), 2008, explicit complementary filter with bias):
//   v^  = R^_WB^T e_z                       predicted "up" in B
//   v   = f_B / |f_B|                       measured "up" (specific force at low acceleration)
//   e   = v x v^
//   w   = gyro - b^ + kp e,   db^/dt = -ki e,   dq/dt = q (x) [0, w/2]
// A multirotor accelerates by tilting, so f_B is not "up" while it manoeuvres (a 0.8 m/s^2
// turn would bias roll/pitch by ~5 deg). With compensate_accel (once GPS velocity arrives)
// the comparison is made in W between two equally low-passed specific forces (time
// constant accel_lowpass_s, so their lags cancel), at each GPS fix, with the IMU side
// taken at the time the GPS velocity difference refers to (mid-interval of the two fixes),
// and the resulting error held until the next fix (for 1.5 fix intervals at most):
//   measured  f^_W = LP(R^_WB f_B),   reference  f_W = LP(a_gps) + g e_z,
//   e_W = f^_W/|f^_W| x f_W/|f_W|,  w += kp R^_WB^T e_W,  db^/dt = -ki R^_WB^T e_W,
// with a_gps the difference of successive GPS velocities. While the horizontal acceleration
// exceeds yaw_min_accel_mps2, the yaw is also corrected from the angle between the measured
// and GPS horizontal accelerations (gain mahony_k_yaw); otherwise yaw is the gyro integral
// from initial_yaw_deg and drifts with the z gyro bias (no magnetometer). The correction is
// skipped when |f^| differs from g by more than accel_gate_frac g.
//
// In a GPS drop-out (no fix for 1.5 intervals, after fixes had come) the attitude is the gyro's
// integral with the bias estimated so far, for up to gps_loss_gyro_only_s; only a longer
// loss falls back to plain Mahony. Plain Mahony takes the specific force for "up", and a
// multirotor's specific force is along its thrust axis whatever its tilt: while it
// manoeuvres, plain Mahony pulls the estimate towards level at the rate kp (a 12 deg
// acceleration tilt read as 5 deg after 1 s), which then tilts the velocity integration
// (g sin 7 deg = 1.2 m/s^2 of error) and every vision fix rotated into W (0.8 m at 7 m).
// The gyro alone drifts by its bias error: the IMU's bias random walk (1e-4 rad/s/sqrt(s)
// by default) adds 0.02 deg in 3 s. The first fix after a gap does not make a correction
// (its velocity difference spans the gap, not the low-pass both sides share): the
// GPS-derived acceleration restarts from the IMU side's. A start without fixes (not two in
// the first half second) is flown on the gyro the same way, from the attitude at rest. The
// first fix after a gap also sets the velocity outright (the coasted one may be metres per
// second off, beyond the residual gate); the position keeps its gated update.
//
// Position: for each W axis a 3-state Kalman filter [p, v, b] driven by the accelerometer in
// W, a = R^_WB f_B - g e_z - b, updated by GPS position and velocity (latency-compensated to
// first order), each component gated as seed 004 eq. 27 (gain n K beyond gate_sigma).
#pragma once

#include <cmath>
#include <deque>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/params_io.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander {

struct NavigationParams {
  double gravity_mps2{9.81};
  double mahony_kp{1.0};                  ///< proportional gain (1/s)
  double mahony_ki{0.05};                 ///< integral (gyro bias) gain (1/s^2)
  double accel_gate_frac{0.1};            ///< skip accel correction beyond this |f|/g error
  double gyro_bias_limit_radps{0.1};      ///< clamp of the gyro bias estimate (rad/s)
  double initial_yaw_rad{0.0};            ///< yaw at start (rad), no magnetometer
  bool compensate_accel{true};            ///< subtract the GPS-derived acceleration
  double accel_lowpass_s{0.5};            ///< low-pass time constant of both (s)
  double mahony_k_yaw{0.0};               ///< yaw gain from horizontal acceleration (1/s); off:
                                          ///< differenced GPS velocity is too noisy for it
  double yaw_min_accel_mps2{0.3};         ///< least horizontal acceleration for it
  double gps_loss_gyro_only_s{10.0};      ///< in a GPS drop-out, gyro-only attitude for up
                                          ///< to this long, then plain Mahony (s)
  double accel_noise_mps2{0.2};           ///< accel noise density in W (m/s^2/sqrt(Hz))
  double accel_bias_rw_mps3{0.005};       ///< accel bias random walk (m/s^2/sqrt(s))
  double initial_accel_bias_std_mps2{0.1};
  double gps_horizontal_std_m{0.7};       ///< GPS position std x, y (m)
  double gps_vertical_std_m{1.2};         ///< GPS position std z (m)
  double gps_velocity_std_mps{0.1};       ///< GPS velocity std per axis (m/s)
  double gate_sigma{3.0};                 ///< residual gate (multiples of sqrt(P~))
  double gate_factor_n{0.1};              ///< gain factor beyond the gate (eq. 27)
  double max_sample_age_s{0.5};           ///< older GPS fixes are dropped (s)
  bool use_magnetometer{true};            ///< correct yaw from the magnetometer (add_mag)
  Eigen::Vector3d mag_field_W_uT{22.0, 2.0, -42.0};  ///< reference field in W (uT), from a
                                          ///< world magnetic model for the site
  double mag_k_yaw{0.5};                  ///< yaw correction gain (1/s)
  bool height_from_altitude_fusion{true};  ///< the flight stack hands the controller the
                                          ///< altitude fusion's height and climb rate (baro-
                                          ///< anchored, seed 004) instead of this filter's
                                          ///< GPS-only vertical channel

  void validate() const;
};

template <class V>
void visit_fields(V& v, NavigationParams& p) {
  v("gravity_mps2", p.gravity_mps2, range::positive, "m/s^2", "");
  v("mahony_kp", p.mahony_kp, range::non_negative, "1/s", "proportional gain");
  v("mahony_ki", p.mahony_ki, range::non_negative, "1/s^2", "integral (gyro bias) gain");
  v("accel_gate_frac", p.accel_gate_frac, range::open(0, 1), "",
    "skip accel correction beyond this |f|/g error");
  v("gyro_bias_limit_radps", p.gyro_bias_limit_radps, range::positive, "rad/s",
    "clamp of the gyro bias estimate");
  v("initial_yaw_deg", p.initial_yaw_rad, range::any, "deg", "yaw at start", M_PI / 180.0);
  v("compensate_accel", p.compensate_accel, range::any, "",
    "subtract the GPS-derived acceleration");
  v("accel_lowpass_s", p.accel_lowpass_s, range::positive, "s", "low-pass time constant of both");
  v("mahony_k_yaw", p.mahony_k_yaw, range::non_negative, "1/s",
    "yaw gain from horizontal acceleration");
  v("yaw_min_accel_mps2", p.yaw_min_accel_mps2, range::positive, "m/s^2",
    "least horizontal acceleration for it");
  v("gps_loss_gyro_only_s", p.gps_loss_gyro_only_s, range::any, "s", "in a GPS drop-out");
  v("accel_noise_mps2", p.accel_noise_mps2, range::positive, "m/s^2",
    "accel noise density in W (m/s^2/sqrt)");
  v("accel_bias_rw_mps3", p.accel_bias_rw_mps3, range::non_negative, "m/s^3",
    "accel bias random walk (m/s^2/sqrt)");
  v("initial_accel_bias_std_mps2", p.initial_accel_bias_std_mps2, range::positive, "m/s^2", "");
  v("gps_horizontal_std_m", p.gps_horizontal_std_m, range::positive, "m", "GPS position std x");
  v("gps_vertical_std_m", p.gps_vertical_std_m, range::positive, "m", "GPS position std z");
  v("gps_velocity_std_mps", p.gps_velocity_std_mps, range::positive, "m/s",
    "GPS velocity std per axis");
  v("gate_sigma", p.gate_sigma, range::positive, "", "residual gate (multiples of sqrt(P~))");
  v("gate_factor_n", p.gate_factor_n, range::closed(0, 1), "N",
    "gain factor beyond the gate (eq. 27)");
  v("max_sample_age_ms", p.max_sample_age_s, range::positive, "ms",
    "older GPS fixes are dropped", 1e-3);
  v("use_magnetometer", p.use_magnetometer, range::any, "", "correct yaw from the magnetometer");
  v("mag_field_W_uT", p.mag_field_W_uT, range::any, "uT", "reference field in W");
  v("mag_k_yaw", p.mag_k_yaw, range::non_negative, "1/s", "yaw correction gain");
  v("height_from_altitude_fusion", p.height_from_altitude_fusion, range::any, "",
    "the flight stack hands the controller the altitude fusion's height");
}

class Navigation {
 public:
  explicit Navigation(const NavigationParams& p);  // validates p
  // Integrates one IMU sample. The first sample initialises roll and pitch from gravity
  // (vehicle assumed at rest) and yaw from params. Returns false (and changes nothing) for a
  // sample that is not finite.
  bool add_imu(const ImuSample& imu);
  // Fuses one GPS fix. The first valid fix initialises position and velocity. Returns false
  // if the fix was not used (invalid, stale, before the first IMU sample).
  bool add_gps(const GpsSample& gps);
  // Corrects yaw from one magnetometer sample: the horizontal direction of the measured field,
  // rotated into W with the current attitude, is pulled towards the reference field's
  // (complementary, gain mag_k_yaw). The first sample sets the yaw outright (compass heading
  // at start). Returns false if not used (before the first IMU sample, or disabled).
  bool add_mag(const MagSample& mag);
  // The navigation solution; valid once both IMU and a GPS fix have been received.
  NavState state() const;
  const Eigen::Vector3d& gyro_bias_B() const { return b_g_; }
  const Eigen::Vector3d& accel_bias_W() const { return b_a_; }
  const NavigationParams& params() const { return p_; }
  // How often the velocity was taken from the first fix after a drop-out.
  int velocity_resets() const { return velocity_resets_; }

 private:
  NavigationParams p_;
  bool att_init_{false}, pos_init_{false}, mag_init_{false};
  double t_mag_s_{0.0};
  double t_s_{0.0};
  Eigen::Quaterniond q_WB_{Eigen::Quaterniond::Identity()};
  Eigen::Vector3d b_g_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d omega_B_{Eigen::Vector3d::Zero()};
  // Per-axis filter [p, v, b] for x, y, z of W.
  Eigen::Vector3d pos_{Eigen::Vector3d::Zero()}, vel_{Eigen::Vector3d::Zero()},
      b_a_{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d P_[3];
  Eigen::Vector3d a_W_{Eigen::Vector3d::Zero()};  // last bias-corrected acceleration
  // GPS-derived acceleration for the attitude correction.
  Eigen::Vector3d a_gps_W_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d v_gps_prev_{Eigen::Vector3d::Zero()};
  double t_gps_prev_{-1.0};        // sample time of the last fix
  double t_gps_arrival_s_{-1.0};   // IMU time at which it arrived
  double t_init_s_{0.0};           // time of the first IMU sample
  int velocity_resets_{0};         // velocity taken from a fix after a gap
  Eigen::Vector3d v_corr_{Eigen::Vector3d::Zero()};  // NavState::v_corr_W_mps
  double gps_interval_s_{1.0};     // sample interval of the last two fixes
  bool have_a_gps_{false};
  Eigen::Vector3d f_W_lp_{0.0, 0.0, 9.81};  // LP of R^ f_B
  std::deque<std::pair<double, Eigen::Vector3d>> f_W_hist_;  // (t, f_W_lp) for alignment
  Eigen::Vector3d e_W_hold_{Eigen::Vector3d::Zero()};       // error from the last GPS fix
};

// The navigation solution with its vertical position and velocity replaced by the fused
// altitude (altitude_fusion.h), which is far better than GPS alone.
NavState with_altitude(NavState nav, const AltitudeEstimate& alt);

}  // namespace lander
