// The platform in W from vision (seed 000 section 3.1-3.2): each keyframe's X_CP becomes a
// position in W through eq. 24 with the navigation state at the frame's time; the history
// feeds the per-axis polynomial fit (eq. 25-27), the prediction (eq. 28), a velocity estimate
// for the visual servo and the platform-steadiness test of the touchdown.
#pragma once

#include <deque>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/controller/params.h"
#include "lander/controller/trajectory.h"
#include "lander/core/sample_screen.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander::ctl {

// One platform fix in W (from one keyframe).
struct PlatformFix {
  double t_s{0.0};                                      ///< mid-exposure time (s)
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};       ///< platform origin in W (m), eq. 24
  Eigen::Vector3d n_W{Eigen::Vector3d::UnitZ()};        ///< platform +z in W (unit)
  Eigen::Vector3d p_BP_W_m{Eigen::Vector3d::Zero()};    ///< platform minus vehicle, in W (m)
  /// p_BP_W_m plus the vehicle's dead-reckoned position (the integral of the navigation
  /// velocity, see PlatformTracker::dead_reckoned_at): a platform path without the steps the
  /// GPS corrections put into the navigation position. Its slope is the platform velocity
  /// as the velocity loop sees it (navigation velocity + rate of the relative vector), also
  /// across corrections of the navigation velocity (PlatformTracker::add_nav).
  Eigen::Vector3d p_dr_m{Eigen::Vector3d::Zero()};
};

// The platform's horizontal motion as its recent fixes support it (issue 10): speed and
// heading with a constant turn rate (a turning cart keeps turning) and, when it was braking,
// a constant deceleration to a stop (a stopping cart stops). What search and go-around fly to
// after a loss.
//
// Motion from t0 (tau = t - t0 >= 0):
//   s(tau)   = max(0, speed + accel tau)       accel <= 0 (an accelerating cart is held at
//                                              its speed: the search widens anyway)
//   psi(tau) = heading + turn_rate tau
//   p(tau)   = p0 + integral_0^tau s(u) (cos psi(u), sin psi(u), 0) du
// For accel = 0 this is the circle p0 + speed / turn_rate (sin psi - sin psi0,
// cos psi0 - cos psi, 0) (a straight line for turn_rate = 0).
struct PlatformMotion {
  bool valid{false};                                 ///< false without any fix
  double t0_s{0.0};                                  ///< time of the last fix (s)
  Eigen::Vector3d p0_W_m{Eigen::Vector3d::Zero()};   ///< platform at t0 in W (m), smoothed
  double speed_mps{0.0};         ///< horizontal speed at t0 (m/s), <= platform_max_speed_mps
  double heading_rad{0.0};       ///< direction of travel at t0, from W +x towards +y (rad)
  double turn_rate_radps{0.0};   ///< constant turn rate (rad/s), + counter-clockwise seen
                                 ///< from above; 0 below turn_min_speed_mps
  double accel_mps2{0.0};        ///< along-track acceleration (m/s^2), <= 0
  /// Position at t_s (m); p0 for t_s <= t0.
  Eigen::Vector3d position_at(double t_s) const;
  /// Velocity at t_s (m/s): s(tau) (cos psi, sin psi, 0).
  Eigen::Vector3d velocity_at(double t_s) const;
};

class PlatformTracker {
 public:
  PlatformTracker(const TrackerParams& params, const CameraMount& mount);

  // Stores the navigation state for latency compensation (call every inner step). A GPS
  // correction of the navigation velocity since the previous state (the change of
  // nav.v_corr_W_mps, dv) is moved into the dead-reckoned history as if the velocity had been
  // corrected from the start: every stored dead-reckoned position, the fixes' p_dr_m and the
  // filters' states at t are moved by dv (t - t_prev), the filters' velocities by dv. So
  // velocity() steps with the navigation velocity, as the velocity loop that compares them
  // needs: with a lagging velocity() the step alone (0.7 m/s after a GPS drop-out, envelope
  // default-0121) commanded 0.1 s of a false relative velocity, which tilted the vehicle
  // 12 deg at 5 cm above the top.
  void add_nav(const NavState& nav);

  // Navigation state at t_s: linear/slerp interpolation in the buffer (clamped to its ends).
  // Throws std::logic_error if no valid nav state was added yet.
  NavState nav_at(double t_s) const;

  // The integral of the navigation velocity (trapezoidal over the add_nav() samples, from
  // an arbitrary origin) at t_s, interpolated like nav_at(). Differences of it are the
  // vehicle's displacement without the position corrections of GPS fixes.
  // Throws std::logic_error if no valid nav state was added yet.
  Eigen::Vector3d dead_reckoned_at(double t_s) const;

  // Processes one vision result. A detected keyframe becomes a fix (returns true); a detected
  // non-keyframe (blurred) counts as "in view" only; no detection resets the keyframe streak.
  // A detection with a non-finite or impossible pose (plausible_observation) is dropped and
  // counted in rejected_observations().
  bool add_observation(const PlatformObservation& obs);

  // Eq. 24 extended with the camera lever arm: p_W = R_WB (R_BC p_CP + p_BC) + p_WB.
  static PlatformFix fix_from(const PlatformObservation& obs, const NavState& nav_at_obs,
                              const Eigen::Isometry3d& X_BC);

  void clear();  ///< forgets all fixes (re-acquisition starts a fresh history)

  // The platform's velocity from elsewhere (its broadcast, W axes, m/s), or nothing: the
  // velocity filter's next (re)start begins from its horizontal part with
  // broadcast_velocity_std_mps instead of at rest with velocity_prior_std_mps. The caller
  // keeps it current (nothing once the broadcast is stale).
  void set_velocity_prior(const std::optional<Eigen::Vector3d>& v_W_mps) { velocity_prior_ = v_W_mps; }

  int num_fixes() const { return static_cast<int>(fixes_.size()); }  ///< in history_s
  /// Keyframes turned into fixes since the last clear() (not bounded by history_s): the
  /// count of seed 000's "80 observed frames" when blur leaves a few keyframes a second.
  int total_fixes() const { return total_fixes_; }
  /// Fixes the velocity filter rejected as outliers since the last clear().
  int rejected_fixes() const { return rejected_fixes_; }
  /// Vision results dropped as implausible (non-finite pose or covariance) since the start.
  int rejected_observations() const { return rejected_observations_; }
  int keyframe_streak() const { return streak_; }
  bool has_fix() const { return !fixes_.empty(); }
  const PlatformFix& latest() const;  ///< throws std::logic_error if none
  const std::deque<PlatformFix>& fixes() const { return fixes_; }
  double last_detection_t() const { return last_detection_t_; }  ///< -inf if never

  // Per-axis polynomial of eq. 25-27 over the fit window (refitted lazily on new fixes).
  // Order is TrackerParams::poly_order, lowered when there are too few fixes.
  const PolynomialFit3& fit() const;

  // Platform minus vehicle now, in W axes (m): what the visual servo closes. The relative
  // vectors of the last relative_window_s (line fit) at the last fix, moved on by velocity()
  // and back by the vehicle's own dead-reckoned displacement since then (add_nav() up to t_s
  // first). Unlike position_now() - nav.p, a wandering or stepping navigation position (GPS)
  // cancels out.
  Eigen::Vector3d relative_now(double t_s) const;

  // Rate of the relative vector at the last fix (platform velocity minus vehicle velocity,
  // W axes, m/s), straight from vision: the slope of the line fit relative_now() smooths
  // with (relative_window_s, at least 3 fixes). False with too few fixes.
  bool relative_velocity(Eigen::Vector3d* v_rel) const;

  // Predicted platform position at t_s (eq. 28 without epsilon): the polynomial up to
  // max_poly_extrapolation_s past the last fix, continued linearly beyond, and its distance
  // from the last fix bounded by platform_max_speed_mps * horizon.
  Eigen::Vector3d predict(double t_s) const;

  // The motion model of PlatformMotion at the last fix: a per-axis quadratic least-squares
  // fit p(d) = a + b d + c d^2 (d = t - t_last) of the dead-reckoned fixes p_dr_m over
  // turn_fit_window_s gives v = b and acceleration acc = 2 c at the last fix; then
  //   speed = |v_xy|, heading = atan2(v_y, v_x),
  //   turn_rate = (v_x acc_y - v_y acc_x) / speed^2   (bounded by max_turn_rate_radps),
  //   accel = min(0, v . acc / speed),
  // the last two 0 below turn_min_speed_mps, and each 0 unless its acceleration component
  // exceeds 3 times the fit's standard error of acc (from the residuals): a turn or braking
  // the fixes cannot tell from noise is not extrapolated. p0 is a moved into W by the last
  // fix's offset p_W_m - p_dr_m (its height that of the last fix). With fewer than 6 fixes spanning
  // 0.5 s in the window: the last fix and velocity(), no turn. Invalid without a fix.
  PlatformMotion motion() const;

  // Platform velocity in W at the last fix (m/s), speed-bounded; 0 before the first fix.
  // A constant-velocity Kalman filter per axis (white-noise acceleration
  // platform_accel_noise_mps2) on the dead-reckoned fixes p_dr_m, each weighted by its
  // range (fix_noise_m + fix_noise_per_m * range): a blurred run leaves a few keyframes a
  // second and far ones are noisier, which a fixed-window fit does not know. From p_dr_m
  // rather than p_W_m: the 5 Hz position corrections of a poor GPS (steps of decimetres)
  // made velocities of ~0.3 m/s out of p_W_m.
  Eigen::Vector3d velocity() const;

  // Platform acceleration in W at the last fix (m/s^2), bounded by platform_max_accel_mps2;
  // 0 before the first fix. A constant-acceleration Kalman filter per axis (white-noise jerk
  // platform_jerk_noise_mps3) on the same dead-reckoned fixes as velocity(), which it leaves
  // alone; a fix the velocity filter rejects is not used, and it restarts with it.
  Eigen::Vector3d acceleration() const;
  // That acceleration filter's velocity at the last fix (m/s, W; bounded like velocity()):
  // unbiased while the acceleration is steady, as in a turn, where the constant-velocity
  // filter's velocity lags.
  Eigen::Vector3d velocity_of_acceleration_filter() const;

  // The platform now: the local fit's position (velocity_window_s) at the last fix moved on
  // by velocity() (latency compensation); the raw last fix when there are too few to fit.
  Eigen::Vector3d position_now(double t_s) const;

  // Steady platform (seed 000 section 3.3): over the last window_s, every normal within
  // spread_deg of their mean and the mean within max_tilt_deg of vertical. `why` says which
  // test failed.
  bool steady(double window_s, double spread_deg, double max_tilt_deg,
              std::string* why = nullptr) const;

 private:
  // Where t_s falls in the nav buffer: between nav_[*lo] and nav_[*lo + 1] at fraction *u
  // (true), or clamped to the end *lo (false). Throws std::logic_error naming `who` if empty.
  bool bracket(double t_s, const char* who, std::size_t* lo, double* u) const;
  bool local_position(Eigen::Vector3d* p_last) const;
  bool relative_fit(Eigen::Vector3d* a, Eigen::Vector3d* b) const;
  // Moves the dead-reckoned history for a navigation velocity correction dv made at t_g
  // (add_nav).
  void rebase_dead_reckoning(const Eigen::Vector3d& dv, double t_g);

  TrackerParams p_;
  Eigen::Isometry3d X_BC_;
  std::deque<NavState> nav_;
  std::deque<Eigen::Vector3d> dr_;  ///< dead-reckoned position at each nav_ sample
  // Velocity filter: rows (position, velocity), one column per axis; the covariance is the
  // same for the three axes (same noise, same times).
  void filter_update(const PlatformFix& fix);
  bool kf_init_{false};
  double kf_t_{0.0};
  Eigen::Matrix<double, 2, 3> kf_x_{Eigen::Matrix<double, 2, 3>::Zero()};
  Eigen::Matrix2d kf_P_{Eigen::Matrix2d::Identity()};
  int kf_outliers_in_row_{0};
  std::optional<Eigen::Vector3d> velocity_prior_;  ///< see set_velocity_prior()
  // Acceleration filter: rows (position, velocity, acceleration), one column per axis.
  double ca_t_{0.0};
  Eigen::Matrix3d ca_x_{Eigen::Matrix3d::Zero()};
  Eigen::Matrix3d ca_P_{Eigen::Matrix3d::Identity()};
  int total_fixes_{0};
  int rejected_fixes_{0};
  int rejected_observations_{0};
  std::deque<PlatformFix> fixes_;
  int streak_{0};
  double last_detection_t_;
  mutable bool fit_dirty_{true};
  mutable PolynomialFit3 fit_;
};

}  // namespace lander::ctl
