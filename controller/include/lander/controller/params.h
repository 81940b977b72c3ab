// Controller parameters: nominal vehicle, cascade gains, landing mode machine.
//
// Every struct follows the params protocol of lander/core/params_io.h: in-class defaults
// with units, validate() throwing ConfigError naming the field, visit_fields() listing the
// YAML keys. The vehicle figures are the controller's own nominal copy of the ZD850-class
// hexarotor of seed 000 (a real flight controller does not read the simulator's model).
#pragma once

#include <Eigen/Core>

#include "lander/controller/deck_motion.h"
#include "lander/controller/path_guidance.h"
#include "lander/core/params_io.h"

namespace lander::ctl {

// Nominal vehicle model used for allocation and feed-forward.
struct VehicleParams {
  double mass_kg{4.0};                                    ///< total mass (kg), > 0
  Eigen::Vector3d inertia_kgm2{0.09, 0.09, 0.16};         ///< diagonal of J in B (kg m^2), > 0
  double arm_m{0.425};                                    ///< centre to rotor axis (m), > 0
  double k_thrust{2.05e-5};                               ///< T = kT w^2 (N/(rad/s)^2), > 0
  double k_torque{3.3e-7};                                ///< Q = kQ w^2 (N m/(rad/s)^2), > 0
  double w_max_radps{800.0};                              ///< max rotor speed (rad/s)
  double w_idle_radps{100.0};                             ///< min rotor speed in flight (rad/s)
  double motor_tau_s{0.05};                               ///< first-order motor lag (s), >= 0
  double gravity_mps2{9.81};                              ///< gravity (m/s^2), > 0
  // Horizontal drag of the airframe, F = drag_linear v + drag_quadratic v^2 at airspeed v:
  // the flight software's nominal figures for a ZD850-class frame (they set the speed limit
  // of vehicle_limits.h, not the plant's drag, which the scenario's wind section holds).
  double drag_linear_Nspm{0.25};                          ///< N/(m/s), >= 0
  double drag_quadratic_Ns2pm2{0.06};                     ///< N/(m/s)^2, >= 0
  void validate() const;
};

template <class V>
void visit_fields(V& v, VehicleParams& p) {
  v("mass_kg", p.mass_kg, range::positive, "kg", "total mass");
  v("inertia_kgm2", p.inertia_kgm2, range::positive, "kg m^2", "diagonal of J in B");
  v("arm_m", p.arm_m, range::positive, "m", "centre to rotor axis");
  v("k_thrust", p.k_thrust, range::positive, "N/(rad/s)^2", "rotor thrust T = kT w^2");
  v("k_torque", p.k_torque, range::positive, "N m/(rad/s)^2", "rotor drag torque Q = kQ w^2");
  v("w_max_radps", p.w_max_radps, range::positive, "rad/s", "max rotor speed");
  v("w_idle_radps", p.w_idle_radps, range::any, "rad/s", "min rotor speed in flight");
  v("motor_tau_s", p.motor_tau_s, range::non_negative, "s", "first-order motor lag");
  v("gravity_mps2", p.gravity_mps2, range::positive, "m/s^2", "gravity");
  v("drag_linear_Nspm", p.drag_linear_Nspm, range::non_negative, "N/(m/s)",
    "horizontal airframe drag, linear part");
  v("drag_quadratic_Ns2pm2", p.drag_quadratic_Ns2pm2, range::non_negative, "N/(m/s)^2",
    "horizontal airframe drag, quadratic part");
}

// Gains and limits of the cascade (seed 003 section 2, Fig. 3): position -> velocity ->
// attitude -> body rate. Gains are bandwidths (1/s) so they do not depend on mass or inertia:
// the loops multiply by m and J of VehicleParams.
struct CascadeParams {
  double outer_rate_hz{30.0};        ///< position/velocity loop rate (Hz): camera rate
  double pos_kp_xy{1.3};             ///< horizontal position gain (1/s)
  double pos_kp_z{1.5};              ///< vertical position gain (1/s)
  double vel_kp_xy{3.0};             ///< horizontal velocity gain (1/s)
  double vel_ki_xy{1.2};             ///< horizontal velocity integral gain (1/s^2)
  double vel_kp_z{4.0};              ///< vertical velocity gain (1/s)
  double vel_ki_z{2.0};              ///< vertical velocity integral gain (1/s^2)
  double max_int_accel_mps2{2.0};    ///< anti-windup bound of each integral term (m/s^2)
  double max_vel_xy_mps{0.0};        ///< horizontal speed limit of the velocity setpoint (m/s);
                                     ///< 0 (default): from the vehicle model (vehicle_limits.h:
                                     ///< the airspeed where drag takes max_vel_drag_share of
                                     ///< the thrust's horizontal part at the tilt limit)
  double max_vel_drag_share{0.5};    ///< that share, in (0, 1): the rest is left for control
  double max_closing_vel_xy_mps{3.0};///< the position loop's correction above the setpoint's
                                     ///< velocity feed-forward (m/s): how fast the vehicle
                                     ///< closes on a point, moving or not (3 m/s before
                                     ///< issue 56 bounded the total instead)
  double max_vel_up_mps{2.0};        ///< climb speed limit (m/s)
  double max_vel_down_mps{1.5};      ///< descent speed limit (m/s)
  double max_accel_z_mps2{4.0};      ///< |vertical acceleration command| limit (m/s^2)
  double max_tilt_deg{30.0};         ///< tilt limit of the thrust vector (deg), in (0, 80)
  double att_kp_rp{7.0};             ///< roll/pitch attitude gain (1/s)
  double att_kp_yaw{2.5};            ///< yaw attitude gain (1/s)
  double max_rate_rp_degps{200.0};   ///< roll/pitch rate setpoint limit (deg/s)
  double max_rate_yaw_degps{60.0};   ///< yaw rate setpoint limit (deg/s)
  double rate_kp_rp{16.0};           ///< roll/pitch rate gain (1/s)
  double rate_ki_rp{4.0};            ///< roll/pitch rate integral gain (1/s^2)
  double rate_kp_yaw{8.0};           ///< yaw rate gain (1/s)
  double rate_ki_yaw{2.0};           ///< yaw rate integral gain (1/s^2)
  double max_int_alpha_radps2{5.0};  ///< anti-windup bound of the rate integral (rad/s^2)
  // Disturbance feed-forward (issue 10): the accelerometer's body-x/y specific force is the
  // external (drag, wind) force per mass, since the rotors push along body z only; low-passed
  // and rotated into W it is subtracted from the horizontal acceleration command, so a gust
  // is met within ~dist_filter_tau_s instead of the integrator's ~vel_kp_xy / vel_ki_xy
  // (2.5 s).
  double dist_ff_gain{0.0};          ///< share of that estimate fed forward, in [0, 1]; 0 = off.
                                     ///< Off by default: at 1 it moved cart_stop_and_go.yaml's
                                     ///< touchdown from 2.3 to 12.6 cm (seed 2; the cart's
                                     ///< braking seen through the contact-free estimate?
                                     ///< not yet understood), gps_degraded from 2.6 to 4.3 cm
  double dist_filter_tau_s{0.2};     ///< its first-order low-pass time constant (s), > 0:
                                     ///< 0.03 m/s^2 of accelerometer noise at 250 Hz becomes
                                     ///< ~3 mm/s^2; a 4 s gust is cut to ~30 %, a 2 s gust
                                     ///< correlation time (wind.h) to ~10 %
  double max_dist_accel_mps2{3.0};   ///< bound of the estimate's norm (m/s^2), >= 0: ~17 deg
                                     ///< of tilt, more than the 3.7 N of drag in a 6 m/s wind
  void validate() const;
};

template <class V>
void visit_fields(V& v, CascadeParams& p) {
  v("outer_rate_hz", p.outer_rate_hz, range::positive, "Hz", "position/velocity loop rate");
  v("pos_kp_xy", p.pos_kp_xy, range::positive, "1/s", "horizontal position gain");
  v("pos_kp_z", p.pos_kp_z, range::positive, "1/s", "vertical position gain");
  v("vel_kp_xy", p.vel_kp_xy, range::positive, "1/s", "horizontal velocity gain");
  v("vel_ki_xy", p.vel_ki_xy, range::non_negative, "1/s^2", "horizontal velocity integral gain");
  v("vel_kp_z", p.vel_kp_z, range::positive, "1/s", "vertical velocity gain");
  v("vel_ki_z", p.vel_ki_z, range::non_negative, "1/s^2", "vertical velocity integral gain");
  v("max_int_accel_mps2", p.max_int_accel_mps2, range::non_negative, "m/s^2",
    "anti-windup bound of each integral term");
  v("max_vel_xy_mps", p.max_vel_xy_mps, range::non_negative, "m/s",
    "horizontal speed limit of the velocity setpoint (0 = from the vehicle model)");
  v("max_vel_drag_share", p.max_vel_drag_share, range::open(0, 1), "",
    "share of the horizontal thrust at the tilt limit that drag may take at that speed");
  v("max_closing_vel_xy_mps", p.max_closing_vel_xy_mps, range::positive, "m/s",
    "position-loop correction bound above the velocity feed-forward");
  v("max_vel_up_mps", p.max_vel_up_mps, range::positive, "m/s", "climb speed limit");
  v("max_vel_down_mps", p.max_vel_down_mps, range::positive, "m/s", "descent speed limit");
  v("max_accel_z_mps2", p.max_accel_z_mps2, range::positive, "m/s^2",
    "|vertical acceleration command| limit");
  v("max_tilt_deg", p.max_tilt_deg, range::open(0, 80), "deg", "tilt limit of the thrust vector");
  v("att_kp_rp", p.att_kp_rp, range::positive, "1/s", "roll/pitch attitude gain");
  v("att_kp_yaw", p.att_kp_yaw, range::positive, "1/s", "yaw attitude gain");
  v("max_rate_rp_degps", p.max_rate_rp_degps, range::positive, "deg/s",
    "roll/pitch rate setpoint limit");
  v("max_rate_yaw_degps", p.max_rate_yaw_degps, range::positive, "deg/s", "yaw rate setpoint limit");
  v("rate_kp_rp", p.rate_kp_rp, range::positive, "1/s", "roll/pitch rate gain");
  v("rate_ki_rp", p.rate_ki_rp, range::non_negative, "1/s^2", "roll/pitch rate integral gain");
  v("rate_kp_yaw", p.rate_kp_yaw, range::positive, "1/s", "yaw rate gain");
  v("rate_ki_yaw", p.rate_ki_yaw, range::non_negative, "1/s^2", "yaw rate integral gain");
  v("max_int_alpha_radps2", p.max_int_alpha_radps2, range::non_negative, "rad/s^2",
    "anti-windup bound of the rate integral");
  v("dist_ff_gain", p.dist_ff_gain, range::closed(0, 1), "", "share of that estimate fed forward");
  v("dist_filter_tau_s", p.dist_filter_tau_s, range::positive, "s",
    "low-pass time constant of the disturbance estimate");
  v("max_dist_accel_mps2", p.max_dist_accel_mps2, range::non_negative, "m/s^2",
    "bound of the estimate's norm");
}

// Platform tracking from vision (seed 000 eq. 24-28).
struct TrackerParams {
  int poly_order{4};                    ///< order of the per-axis fit, eq. 25-27 (paper: 4)
  double fit_window_s{3.0};             ///< fit window (s): ~ the paper's 80 frames at 30 Hz
  double max_poly_extrapolation_s{0.5}; ///< beyond this horizon the prediction continues
                                        ///< linearly (a quartic diverges far out) (s)
  double velocity_window_s{1.0};        ///< window of the local position fit (s)
  double platform_accel_noise_mps2{0.7};///< velocity filter: white-noise acceleration of the
                                        ///< platform (m/s^2); a cart pulled by a person
                                        ///< speeds up and brakes at ~0.6 m/s^2
  double fix_noise_m{0.005};            ///< velocity filter: fix noise at zero range (m); 2 cm
                                        ///< made the filter lag a braking cart near the top
  double fix_noise_per_m{0.01};         ///< ... growing with the range (m per m): ~0.6 deg of
                                        ///< attitude and vision error seen from the vehicle
  double fix_gate_sigma{5.0};           ///< a fix this many sigma off the filter's prediction
                                        ///< is rejected; 3 in a row restart the filter
  double relative_window_s{0.25};       ///< window of the line fit of the relative vector (s)
  double platform_jerk_noise_mps3{2.0}; ///< acceleration filter (a constant-acceleration Kalman
                                        ///< filter beside the velocity one, same fixes): white-
                                        ///< noise jerk of the platform (m/s^3); a cart reaches
                                        ///< its 0.6 m/s^2 of braking in ~0.2 s
  double platform_max_accel_mps2{2.0};  ///< bound of that acceleration estimate (m/s^2)
  double platform_max_speed_mps{7.0};   ///< plausibility bound of the platform speed (m/s):
                                        ///< the platforms expected (MBZIRC's 4.2 m/s vehicle,
                                        ///< a small boat's 5) with margin; 2 before issue 56
  double history_s{10.0};               ///< how long observations are kept (s)
  double nav_history_s{1.0};            ///< nav-state buffer for latency (s)
  // Motion model for the prediction after a loss (PlatformTracker::motion(), issue 10).
  double turn_fit_window_s{3.0};        ///< window of the quadratic fit that gives speed,
                                        ///< heading, turn rate and braking (s): ~90 fixes;
                                        ///< with 2.7 cm of fix noise at 8 m the turn rate is
                                        ///< good to ~0.01 rad/s (2 s: ~0.025 rad/s)
  double turn_min_speed_mps{0.2};       ///< below this speed no heading, turn or braking is
                                        ///< estimated (the cart is held at its velocity) (m/s)
  double max_turn_rate_radps{0.5};      ///< bound of the turn rate (rad/s): a 1 m/s cart on a
                                        ///< 2 m radius; tighter is fit noise
  bool predict_turns{true};             ///< the approach's prediction (predict()) continues
                                        ///< beyond max_poly_extrapolation_s along motion()'s
                                        ///< turn and braking instead of straight on: at
                                        ///< 4.2 m/s on a 30 m arc the straight line put the
                                        ///< goal 2-3 m outside the arc (issue 56)
  double velocity_prior_std_mps{1.0};   ///< without a broadcast, the velocity filter starts
                                        ///< at rest with this sigma (m/s): the platform's
                                        ///< expected speed. 1 m/s for a walking cart; a
                                        ///< 5 m/s platform wants ~its speed, or its first
                                        ///< fixes are pulled towards rest (issue 56)
  double broadcast_velocity_std_mps{0.5}; ///< with the platform's broadcast received, the
                                        ///< velocity filter starts from its velocity with
                                        ///< this sigma (m/s): the broadcast's velocity error
                                        ///< and the platform's change over its latency.
                                        ///< Without one it starts at rest with
                                        ///< velocity_prior_std_mps, which at 1 m/s pulled a
                                        ///< 5.7 m/s platform seen for 0.15 s at the view's
                                        ///< edge to 1.6 m/s (issue 56)
  void validate() const;
};

template <class V>
void visit_fields(V& v, TrackerParams& p) {
  v("poly_order", p.poly_order, range::closed(1, 6), "", "order of the per-axis fit");
  v("fit_window_s", p.fit_window_s, range::positive, "s",
    "fit window: ~ the paper's 80 frames at 30 Hz");
  v("max_poly_extrapolation_s", p.max_poly_extrapolation_s, range::non_negative, "s",
    "beyond this horizon the prediction continues linearly");
  v("velocity_window_s", p.velocity_window_s, range::positive, "s",
    "window of the local position fit");
  v("platform_accel_noise_mps2", p.platform_accel_noise_mps2, range::positive, "m/s^2",
    "velocity filter");
  v("fix_noise_m", p.fix_noise_m, range::positive, "m", "vision fix noise std at zero range");
  v("fix_noise_per_m", p.fix_noise_per_m, range::non_negative, "m",
    "... growing with the range (m per m)");
  v("fix_gate_sigma", p.fix_gate_sigma, range::positive, "",
    "a fix this many sigma off the filter's prediction is rejected");
  v("relative_window_s", p.relative_window_s, range::positive, "s",
    "window of the line fit of the relative vector");
  v("platform_jerk_noise_mps3", p.platform_jerk_noise_mps3, range::positive, "m/s^3",
    "acceleration filter");
  v("platform_max_accel_mps2", p.platform_max_accel_mps2, range::positive, "m/s^2",
    "bound of that acceleration estimate");
  v("platform_max_speed_mps", p.platform_max_speed_mps, range::positive, "m/s",
    "plausibility bound of the platform speed");
  v("history_s", p.history_s, range::any, "s", "how long observations are kept");
  v("nav_history_s", p.nav_history_s, range::positive, "s", "nav-state buffer for latency");
  v("turn_fit_window_s", p.turn_fit_window_s, range::positive, "s",
    "window of the quadratic fit that gives speed");
  v("turn_min_speed_mps", p.turn_min_speed_mps, range::positive, "m/s",
    "below this speed no heading");
  v("max_turn_rate_radps", p.max_turn_rate_radps, range::non_negative, "rad/s",
    "bound of the turn rate");
  v("predict_turns", p.predict_turns, range::any, "",
    "the approach's prediction follows the motion model's turn and braking");
  v("velocity_prior_std_mps", p.velocity_prior_std_mps, range::positive, "m/s",
    "without a broadcast, the velocity filter starts at rest with this sigma");
  v("broadcast_velocity_std_mps", p.broadcast_velocity_std_mps, range::positive, "m/s",
    "with the platform's broadcast, the velocity filter starts from its velocity with this sigma");
}

// Landing mode machine (seed 000 section 3) and the safety behaviour the paper leaves out.
struct LandingParams {
  // observe -> approach (seed 000 section 3.2)
  int observe_frames{80};                 ///< keyframes before approach (paper: 80)
  // The approach starts only once observe's follower has closed on the platform: an approach
  // begun metres off (a re-acquisition after a loss, keyframes already counted) chases the
  // cart at the view's edge and loses it again. After approach_entry_wait_s in observe it
  // starts anyway (bounded: a cart the follower cannot close on still gets its attempt).
  double approach_entry_max_error_m{1.5};  ///< horizontal error to the platform (m); 0: off
  double approach_entry_wait_s{8.0};       ///< observe time after which it starts anyway (s)
  double approach_epsilon_m{1.5};         ///< height above the platform at t_d, eq. 28 (m)
  double approach_speed_mps{1.0};         ///< mean speed that sets t_d (m/s), > 0
  double approach_min_duration_s{3.0};    ///< lower bound of t_d - t_0 (s)
  double approach_max_duration_s{15.0};   ///< upper bound of t_d - t_0 (s)
  double approach_switch_error_m{0.05};   ///< |Diff| at t >= t_d to enter recovery (paper 5 cm)
  double approach_settle_timeout_s{0.3};  ///< after t_d: enter recovery anyway if in view (s);
                                          ///< short, the cart does not wait
  bool approach_match_velocities{true};   ///< true (default since 2026-11-28): the approach
                                          ///< cubic starts at the vehicle's velocity and ends
                                          ///< at the platform's horizontal velocity
                                          ///< (trajectory.h). false: eq. 29 from rest to rest,
                                          ///< which brakes an entry made while following a
                                          ///< fast cart (24 deg of roll at 1.4 m/s). The whole
                                          ///< 200-run envelope decided it (README, "The landing
                                          ///< envelope")
  std::string approach_frame{"platform"}; ///< platform (issue 56): the cubic is planned in the
                                          ///< platform's frame, from the vehicle's offset to
                                          ///< approach_epsilon_m above the top, and flown on
                                          ///< top of the platform's position and velocity now,
                                          ///< so the vehicle rides along a turning or fast
                                          ///< platform while it closes; world: seed 000 eq. 29
                                          ///< in W to the eq. 28 prediction at t_d, replanned
  // recovery: visual servo and controlled descent (seed 000 section 3.3)
  double descent_rate_mps{0.5};           ///< descent rate high above the platform (m/s)
  double descent_rate_near_mps{0.2};      ///< descent rate below near_height_m (m/s)
  double descent_rate_final_mps{0.15};    ///< descent rate below final_hold_height_m (m/s):
                                          ///< the descent goes on into contact at it (see
                                          ///< final_hover_gap_m); slower needs the 5 cm
                                          ///< alignment held longer (0.1 m/s from 0.3 m: 70 s
                                          ///< of retries in default.yaml; now from 0.1 m)
  double max_descent_near_mps{0.3};       ///< descent speed limit of the velocity setpoint
                                          ///< in recovery below near_height_m (m/s)
  double max_descent_final_mps{0.2};      ///< the same below final_hold_height_m (m/s): the
                                          ///< clearance servo overshot to 0.32 m/s in the
                                          ///< last 15 cm without it
  double near_height_m{1.0};              ///< gear height above the top where it slows (m)
  double descent_gate_m{0.25};            ///< descend only while |horizontal error| < this (m)
  double descent_gate_near_m{0.10};       ///< the same gate below near_height_m (m)
  double final_hover_gap_m{-0.05};        ///< lowest gear clearance the descent aims at (m);
                                          ///< below 0 (under the top) so the final descent
                                          ///< goes on into contact at ~descent_rate_final_mps
                                          ///< and the cut falls from at most cut_height_m
  double final_hold_height_m{0.30};       ///< below this gear clearance descend into contact
                                          ///< only while |error| < touchdown_error_m (else
                                          ///< wait at final_wait_gap_m); climb back to it
                                          ///< when |error| > 2 touchdown_error_m (m)
  double final_descent_error_m{0.03};     ///< below final_hold_height_m descend on into contact
                                          ///< only while |error| < this (m): tighter than
                                          ///< touchdown_error_m because the skids may meet
                                          ///< the top before the cut, and the error at first
                                          ///< contact is what counts (3 cm leaves 2 cm for the
                                          ///< drift of the last centimetres; 5 cm gave 5.4 cm)
  double final_descent_rel_speed_mps{0.15};///< ... and while the horizontal speed relative to
                                          ///< the platform (the rate of the relative vector
                                          ///< seen by vision) is below this (m/s): a braking
                                          ///< cart (0.6 m/s^2) ran 8 cm ahead of a vehicle
                                          ///< committed to the last 3 cm of descent
  double final_wait_gap_m{0.10};          ///< below final_hold_height_m with an error between
                                          ///< touchdown_error_m and twice it: wait at this
                                          ///< gear clearance (m); 5 cm let a tilted skid touch
                                          ///< the cart before the cut
  double recovery_max_carrot_m{0.3};      ///< visual-servo setpoint at most this far from the
                                          ///< vehicle horizontally: bounds the catch-up speed
                                          ///< (and tilt, which would swing the view off) (m)
  double servo_ki{0.2};                   ///< integral gain of the visual servo on the
                                          ///< horizontal error (removes tracking bias) (1/s);
                                          ///< 0.6 wound up to -0.15 m while a stop-and-go cart
                                          ///< braked and then held the vehicle behind it
  double servo_max_correction_m{0.15};    ///< bound of that integral correction (m)
  /// The integral learns only while the platform's estimated acceleration along its travel
  /// is below this (m/s^2): a cart's start or stop is a transient the acceleration
  /// feed-forward meets, not a bias (README, "Starts and stops fed forward whole"); a steady
  /// turn's centripetal part is not counted (issue 56: at 4.2 m/s on a 30 m arc, 0.59 m/s^2,
  /// the integral was frozen and a 10 cm lag outward stayed).
  double servo_int_max_platform_accel_mps2{0.2};
  double platform_accel_ff_gain{1.0};     ///< share of the platform's estimated acceleration
                                          ///< (PlatformTracker::acceleration()) the visual
                                          ///< servo feeds forward, in [0, 1]; 0 = off (on by
                                          ///< default since 2026-11-28: README, "The
                                          ///< acceleration feed-forward by default")
  /// Below this magnitude nothing of that acceleration is fed forward (m/s^2): the
  /// estimate's noise at a constant speed stays out.
  double platform_accel_ff_deadband_mps2{0.1};
  /// From this magnitude on it is fed forward whole, between the two a share rising linearly
  /// from 0 to 1 (m/s^2, >= the deadband; accel_feed_forward_share), so a cart's starts and
  /// stops (~0.6) pass whole.
  double platform_accel_ff_full_mps2{0.3};
  /// The velocity the servo feeds forward horizontally: false, the constant-velocity filter's
  /// (PlatformTracker::velocity()); true, the acceleration filter's
  /// (PlatformTracker::velocity_of_acceleration_filter()), which does not lag a turn: on a
  /// 20 m arc at 4.7 m/s the former is 0.15-0.19 m/s off across the track and holds the
  /// vehicle ~14 cm outward (docs/results/fast-platforms.md). Off by default until the
  /// envelope's gate has judged it.
  bool turn_velocity_feed_forward{false};
  // touchdown (seed 000 section 3.3: < 5 cm and steady platform)
  double gear_height_m{0.25};             ///< CoM height above the surface when landed (m):
                                          ///< models/hexarotor.xml skids at -0.24 m, r 0.01 m
  // A skid end this close to the top (m) counts as standing on it: the cut comes then even
  // if the level gear (tilted vehicle) is still above cut_height_m. The clearances' noise
  // and bias near the top are a few millimetres.
  static constexpr double kSkidTouch_m = 0.005;
  double cut_height_m{0.010};             ///< cut when gear clearance is below this (m):
                                          ///< a fall of 1.5 cm adds ~0.3 m/s (rotors spin
                                          ///< down; 0.48 m/s at contact in the SoftTouchdown
                                          ///< test, 0.23 m/s from 1 cm); 6 cm gave
                                          ///< ~0.75-1 m/s
  double touchdown_error_m{0.05};         ///< cut only when |horizontal error| < this (m)
  double max_touchdown_rel_speed_mps{0.3};///< cut only when |relative velocity| < this (m/s)
  double steady_window_s{0.5};            ///< window of the platform-steadiness test (s)
  double steady_tilt_deg{3.0};            ///< max spread of the platform normal in it (deg)
  double max_platform_tilt_deg{10.0};     ///< max platform tilt from vertical (deg)
  double contact_min_time_s{0.15};        ///< after the cut, wait for rotor spin-down (s)
  double contact_accel_frac{0.6};         ///< contact: specific force z > this * g
  double contact_confirm_s{0.05};         ///< ... held for this long (s)
  double contact_timeout_s{2.0};          ///< no contact after the cut -> go-around (s)
  // loss, search, go-around (not in the paper)
  double loss_timeout_s{1.0};             ///< no detection this long = target lost (s)
  double recovery_loss_timeout_s{2.0};    ///< the same in recovery (s); the descent pauses
                                          ///< as soon as vision is older than descent_stale_s
  double descent_stale_s{0.4};            ///< descend only with a detection this fresh (s)
  double approach_goal_max_rate_mps{1.5}; ///< a replan moves P_d by at most this per second,
                                          ///< so prediction noise does not jerk the setpoint
  double track_max_tilt_deg{20.0};        ///< tilt limit while the target must stay in view
                                          ///< (observe, approach, recovery) (deg)
  int reacquire_frames{3};                ///< consecutive keyframes to re-acquire
  double go_around_low_height_m{3.0};     ///< lost below this height above the top -> go-around
  double go_around_error_m{0.6};          ///< horizontal error in recovery below near_height_m
                                          ///< -> go-around (m)
  double go_around_height_m{6.0};         ///< climb to this height above the top (m)
  double search_min_height_m{2.0};        ///< search/hold at least this high above ground (m)
  double search_yaw_rate_degps{45.0};     ///< heading sweep while searching, so the wide image
                                          ///< axis scans around the vehicle (deg/s), 0 = off;
                                          ///< 20 deg/s took 4.5 s to bring the wide axis onto
                                          ///< a 1 m/s cart first seen at the narrow edge, and
                                          ///< it had left the view by then
  double search_spiral_after_s{8.0};      ///< with nothing to predict from: after this long
                                          ///< sweeping the heading in place (one turn at
                                          ///< 45 deg/s), fly an outward spiral (s)
  double search_spiral_spacing_m{8.0};    ///< distance between the spiral's turns (m): the
                                          ///< camera's narrow-axis footprint at 8-10 m is ~10 m
  double search_spiral_speed_mps{1.5};    ///< speed along the spiral (m/s); 0 = hold in place
  double search_max_radius_m{30.0};       ///< the spiral becomes a circle at this radius (m)
  double observe_follow_max_speed_mps{2.0};///< catch-up speed of the observe follow point
                                          ///< relative to the platform, on top of its fed-
                                          ///< forward velocity (m/s): a 1 m/s cart acquired
                                          ///< 9 m away is caught in ~6 s
  double observe_follow_max_accel_mps2{1.0};///< acceleration of that catch-up (m/s^2): ~6 deg
                                          ///< of tilt, the camera (fixed under the body)
                                          ///< swings little and keeps a platform ahead
  double search_predict_max_s{10.0};      ///< after a loss, search (and go-around) fly to the
                                          ///< tracker's prediction of the platform for at most
                                          ///< this long after the last fix; then the history
                                          ///< is dropped and the search pattern's centre stays
                                          ///< where the prediction led (s)
  double search_expand_after_s{5.0};      ///< after a loss, fly to the prediction alone until
                                          ///< this long after the last fix, then around it an
                                          ///< outward spiral (search_spiral_spacing_m,
                                          ///< search_spiral_speed_mps) sweeping the heading (s):
                                          ///< a stop-and-go cart (0.6 m/s^2) is within the
                                          ///< ~3 m half-footprint at 6 m for ~3 s of it
  double search_climb_rate_mps{0.3};      ///< ... and climbing at this rate for a wider view
                                          ///< (m/s), 0 = off
  double search_first_climb_rate_mps{1.0};///< the first search with nothing to predict from
                                          ///< (no fix, no broadcast): climb from its start at
                                          ///< this rate (m/s) to search_max_height_m, while
                                          ///< the heading sweeps, instead of only with the
                                          ///< spiral at search_climb_rate_mps; 0 = off. From a
                                          ///< 6-8 m start the wide image axis reaches 6-8 m, and
                                          ///< a cart 5-10 m away driving off at ~1 m/s has left
                                          ///< it before the first turn ends (on by default
                                          ///< since the whole envelope ran with it: README)
  double search_max_height_m{10.0};       ///< ... up to this height above the platform top
                                          ///< (m): the view's narrow half-width grows from
                                          ///< ~3 m at 6 m to ~5.5 m, and the target is
                                          ///< detected from 15 m (docs/design/architecture.md)
  // The platform's broadcast position (its own GNSS fix sent over a radio link, as a ship or a
  // ground vehicle would send it; received only when the scenario's plant has
  // sensors.platform_telemetry.enabled). Without a fix of the target, the search flies to it
  // instead of sweeping around the vehicle's own start.
  double telemetry_max_age_s{2.0};        ///< use the broadcast while its latest message was
                                          ///< sampled at most this long ago (s), predicted to
                                          ///< now with its velocity; 0 = never use it
  double telemetry_arrive_radius_m{3.0};  ///< the search pattern (spiral, heading sweep, climb)
                                          ///< around the broadcast position begins
                                          ///< search_expand_after_s after the vehicle first
                                          ///< came this close to it (m): ~ the view's
                                          ///< narrow half-width at 6 m
  double telemetry_override_m{6.0};       ///< after a loss, the motion model's prediction is
                                          ///< flown while it lies within this distance of
                                          ///< the broadcast position, the broadcast beyond
                                          ///< it (m): two receivers' errors are ~1-3 m, a
                                          ///< prediction from a few fixes of a fast platform
                                          ///< tens of metres off after 10 s (issue 56)
  double telemetry_search_height_m{6.0}; ///< ... flown at least this high above the surface
                                          ///< below (by the fused altitude) (m): the view's
                                          ///< narrow half-width at 6 m (~3 m) covers the
                                          ///< broadcast's error; a 2 m search sees ~1 m
  // Bounded landing decision (issue 10). The geometry is the flight software's own belief,
  // nominal copies of models/cart.xml and models/hexarotor.xml (like gear_height_m).
  double platform_half_size_m{0.9};       ///< half the side of the square landing top (m):
                                          ///< cart.xml "platform" box 0.9 x 0.9 (half sizes)
  double skid_half_spread_m{0.21};        ///< skids' outer edges from the vehicle's centre
                                          ///< line (m): hexarotor.xml skids at y = +-0.20 m,
                                          ///< radius 0.01 m
  double skid_half_length_m{0.21};        ///< skids' ends from the centre along body x (m):
                                          ///< x = +-0.20 m, radius 0.01 m
  double wide_gate_margin_m{0.05};        ///< margin of the wide gate for vision error and a
                                          ///< tilted gear at contact (m); see wide_gate_m()
  double cut_vision_radius_m{0.17};       ///< largest horizontal offset from the platform
                                          ///< centre at which vision still localises the
                                          ///< platform at the cut (m): the cut needs a fresh
                                          ///< detection. Own belief of the target and camera:
                                          ///< the 0.40 m code map (models/target.yaml), the
                                          ///< camera 0.18 m above the top at the cut (mount
                                          ///< -0.08 m) seeing 0.36 m x 0.20 m (fx 640 px),
                                          ///< a 5 x 5 window of 2.5 cm cells needed: across
                                          ///< the narrow axis 0.20 + 0.10 - 0.125 = 0.175 m
  double final_decision_after_s{15.0};    ///< in recovery, this long after first going below
                                          ///< final_hold_height_m without a cut, the final
                                          ///< gate starts widening towards the wide gate (s):
                                          ///< the nominal final stage takes ~2 s
                                          ///< (default.yaml); a stop-and-go cart (8.7 s
                                          ///< cycle, stands 2 s) is met in its first or
                                          ///< second stop (up to ~18 s in 6 seeds of
                                          ///< cart_stop_and_go.yaml): 15 s + the window
                                          ///< covers the second stop and ends the attempt
                                          ///< within ~20 s (was 30 s: in the 200-run
                                          ///< envelope 17 runs hovered until the 60 s ran out)
  double recovery_decision_after_s{12.0};  ///< the final-stage timer above also starts this
                                          ///< long after entering recovery if the vehicle has
                                          ///< not yet gone below final_hold_height_m (the
                                          ///< descent gates never met in gusts): the decision
                                          ///< then comes higher up (s); landed envelope runs
                                          ///< reached the final stage 3.5-10.8 s after entry
  double search_give_up_s{30.0};          ///< search (first or after a loss) that has not
                                          ///< acquired the target this long after entering it
                                          ///< ends in aborted with the reason (s): by then a
                                          ///< 1.5 m/s cart is 45 m from where it was
  double final_decision_window_s{5.0};    ///< ... linearly over this long, to wide_gate_m()
                                          ///< and max_touchdown_rel_speed_mps; not within it
                                          ///< by then: go-around (s); 0 = the wide gate at once
  int max_wide_departures{2};             ///< committed wide, the error may leave the wide
                                          ///< gate this often (climb back to
                                          ///< final_hold_height_m, descend again within it);
                                          ///< one more departure, or final_decision_window_s
                                          ///< outside, is a go-around; 0 = the first is
  int max_landing_attempts{3};            ///< approaches (each entry into approach) before a
                                          ///< failed one ends in aborted instead of another
                                          ///< go-around or search
  // The wide final gate (m). From the geometry: the skids' footprint (a rectangle of
  // half-sides skid_half_spread_m x skid_half_length_m, any heading relative to the cart, so
  // its circumscribed radius) must stay on the top's inscribed circle after the drift of the
  // final descent (max_touchdown_rel_speed_mps for final_wait_gap_m / descent_rate_final_mps),
  // with wide_gate_margin_m to spare:
  //   on_top = platform_half_size_m - hypot(skid_half_spread_m, skid_half_length_m)
  //            - max_touchdown_rel_speed_mps * final_wait_gap_m / descent_rate_final_mps
  //            - wide_gate_margin_m
  // and the cut must still see the target: wide = min(on_top, cut_vision_radius_m).
  // Defaults: on_top = 0.9 - 0.297 - 0.2 - 0.05 = 0.353 m; wide = 0.17 m (vision-limited).
  double wide_gate_on_top_m() const;
  double wide_gate_m() const;
  void validate() const;
};

// LandingParams' keys: the observe and approach phases, the recovery descent.
template <class V>
void visit_approach_and_descent_fields(V& v, LandingParams& p) {
  v("observe_frames", p.observe_frames, range::at_least(1), "",
    "keyframes before approach (paper: 80)");
  v("approach_entry_max_error_m", p.approach_entry_max_error_m, range::non_negative.because("0: off"), "m",
    "horizontal error to the platform");
  v("approach_entry_wait_s", p.approach_entry_wait_s, range::non_negative, "s",
    "observe time after which it starts anyway");
  v("approach_epsilon_m", p.approach_epsilon_m, range::positive, "m",
    "height above the platform at t_d");
  v("approach_speed_mps", p.approach_speed_mps, range::positive, "m/s", "mean speed that sets t_d");
  v("approach_min_duration_s", p.approach_min_duration_s, range::positive, "s",
    "lower bound of t_d");
  v("approach_max_duration_s", p.approach_max_duration_s, range::any, "s", "upper bound of t_d");
  v("approach_switch_error_m", p.approach_switch_error_m, range::positive, "m",
    "|Diff| at t >= t_d to enter recovery (paper 5 cm)");
  v("approach_settle_timeout_s", p.approach_settle_timeout_s, range::non_negative, "s",
    "after t_d: enter recovery anyway if in view");
  v("approach_match_velocities", p.approach_match_velocities, range::any, "",
    "true (default since 2026-11-28)");
  v("approach_frame", p.approach_frame, range::any, "",
    "platform (the cubic relative to the platform) | world (eq. 29 in W to the eq. 28 prediction)");
  v("descent_rate_mps", p.descent_rate_mps, range::positive, "m/s",
    "descent rate high above the platform");
  v("descent_rate_near_mps", p.descent_rate_near_mps, range::any, "m/s",
    "descent rate below near_height_m");
  v("descent_rate_final_mps", p.descent_rate_final_mps, range::any, "m/s",
    "descent rate below final_hold_height_m");
  v("max_descent_near_mps", p.max_descent_near_mps, range::any, "m/s",
    "descent speed limit of the velocity setpoint in recovery below");
  v("max_descent_final_mps", p.max_descent_final_mps, range::any, "m/s",
    "descent speed limit below final_hold_height_m");
  v("near_height_m", p.near_height_m, range::positive, "m",
    "gear height above the top where it slows");
  v("descent_gate_m", p.descent_gate_m, range::positive, "m",
    "descend only while |horizontal error| < this");
  v("descent_gate_near_m", p.descent_gate_near_m, range::positive, "m",
    "descent gate below near_height_m");
  v("final_hover_gap_m", p.final_hover_gap_m, range::any, "m",
    "lowest gear clearance the descent aims at");
  v("final_hold_height_m", p.final_hold_height_m, range::any, "m",
    "below this gear clearance descend into contact only while |error| <");
  v("final_descent_error_m", p.final_descent_error_m, range::any, "m",
    "below final_hold_height_m descend on into contact only while |error| <");
  v("final_descent_rel_speed_mps", p.final_descent_rel_speed_mps, range::positive, "m/s",
    "... and while the horizontal speed relative to the platform is below");
  v("final_wait_gap_m", p.final_wait_gap_m, range::any, "m",
    "below final_hold_height_m with an error between touchdown_error_m");
}

// ... the visual servo, the cut and touchdown test, loss timeouts, the go-around.
template <class V>
void visit_servo_and_touchdown_fields(V& v, LandingParams& p) {
  v("recovery_max_carrot_m", p.recovery_max_carrot_m, range::positive, "m",
    "visual-servo setpoint at most this far from the vehicle horizontally");
  v("servo_ki", p.servo_ki, range::non_negative, "1/s",
    "integral gain of the visual servo on the horizontal error");
  v("servo_max_correction_m", p.servo_max_correction_m, range::non_negative, "m",
    "bound of that integral correction");
  v("servo_int_max_platform_accel_mps2", p.servo_int_max_platform_accel_mps2, range::non_negative, "m/s^2",
    "The integral learns only while the platform's estimated acceleration");
  v("platform_accel_ff_gain", p.platform_accel_ff_gain, range::closed(0, 1), "",
    "share of the platform's estimated acceleration");
  v("platform_accel_ff_deadband_mps2", p.platform_accel_ff_deadband_mps2, range::non_negative, "m/s^2",
    "Below this magnitude nothing of that acceleration is fed forward");
  v("platform_accel_ff_full_mps2", p.platform_accel_ff_full_mps2, range::any, "m/s^2",
    "From this magnitude on it is fed forward whole");
  v("turn_velocity_feed_forward", p.turn_velocity_feed_forward, range::any, "",
    "feed forward the acceleration filter's velocity (no lag in a turn)");
  v("gear_height_m", p.gear_height_m, range::non_negative, "m",
    "CoM height above the surface when landed");
  v("cut_height_m", p.cut_height_m, range::positive, "m", "cut when gear clearance is below this");
  v("touchdown_error_m", p.touchdown_error_m, range::positive, "m",
    "cut only when |horizontal error| < this");
  v("max_touchdown_rel_speed_mps", p.max_touchdown_rel_speed_mps, range::positive, "m/s",
    "cut only when |relative velocity| < this");
  v("steady_window_s", p.steady_window_s, range::positive, "s",
    "window of the platform-steadiness test");
  v("steady_tilt_deg", p.steady_tilt_deg, range::positive, "deg",
    "max spread of the platform normal in it");
  v("max_platform_tilt_deg", p.max_platform_tilt_deg, range::open(0, 90), "deg",
    "max platform tilt from vertical");
  v("contact_min_time_s", p.contact_min_time_s, range::non_negative, "s",
    "after the cut, wait for rotor spin-down");
  v("contact_accel_frac", p.contact_accel_frac, range::open(0, 1.5), "",
    "contact: specific force z > this * g");
  v("contact_confirm_s", p.contact_confirm_s, range::non_negative, "s", "... held for this long");
  v("contact_timeout_s", p.contact_timeout_s, range::any, "s",
    "no contact after the cut -> go-around");
  v("loss_timeout_s", p.loss_timeout_s, range::positive, "s", "no detection this long");
  v("recovery_loss_timeout_s", p.recovery_loss_timeout_s, range::positive, "s",
    "the same in recovery");
  v("descent_stale_s", p.descent_stale_s, range::positive, "s",
    "descend only with a detection this fresh");
  v("approach_goal_max_rate_mps", p.approach_goal_max_rate_mps, range::positive, "m/s",
    "a replan moves P_d by at most this per second");
  v("track_max_tilt_deg", p.track_max_tilt_deg, range::open(0, 80), "deg",
    "tilt limit while the target must stay in view");
  v("reacquire_frames", p.reacquire_frames, range::at_least(1), "",
    "consecutive keyframes to re-acquire");
  v("go_around_low_height_m", p.go_around_low_height_m, range::positive, "m",
    "lost below this height above the top -> go-around");
  v("go_around_error_m", p.go_around_error_m, range::any, "m",
    "horizontal error in recovery below near_height_m -> go-around");
  v("go_around_height_m", p.go_around_height_m, range::any, "m",
    "climb to this height above the top");
}

// ... the search, the platform broadcast, the footprint, the landing decision.
template <class V>
void visit_search_and_decisions_fields(V& v, LandingParams& p) {
  v("search_min_height_m", p.search_min_height_m, range::positive, "m",
    "search/hold at least this high above ground");
  v("search_yaw_rate_degps", p.search_yaw_rate_degps, range::closed(0, 90), "deg/s",
    "heading sweep while searching");
  v("search_spiral_after_s", p.search_spiral_after_s, range::non_negative, "s",
    "with nothing to predict from");
  v("search_spiral_spacing_m", p.search_spiral_spacing_m, range::positive, "m",
    "distance between the spiral's turns");
  v("search_spiral_speed_mps", p.search_spiral_speed_mps, range::non_negative, "m/s",
    "speed along the spiral");
  v("search_max_radius_m", p.search_max_radius_m, range::positive, "m",
    "the spiral becomes a circle at this radius");
  v("observe_follow_max_speed_mps", p.observe_follow_max_speed_mps, range::positive, "m/s",
    "catch-up speed of the observe follow point relative to the platform");
  v("observe_follow_max_accel_mps2", p.observe_follow_max_accel_mps2, range::positive, "m/s^2",
    "acceleration of that catch-up");
  v("search_predict_max_s", p.search_predict_max_s, range::non_negative, "s",
    "after a loss, search fly to the tracker's prediction of the platform");
  v("search_expand_after_s", p.search_expand_after_s, range::non_negative, "s",
    "after a loss, fly to the prediction alone until this long after");
  v("search_climb_rate_mps", p.search_climb_rate_mps, range::non_negative, "m/s",
    "... and climbing at this rate for a wider view");
  v("search_first_climb_rate_mps", p.search_first_climb_rate_mps, range::non_negative, "m/s",
    "the first search with nothing to predict from (no fix, no broadcast)");
  v("search_max_height_m", p.search_max_height_m, range::positive, "m",
    "... up to this height above the platform top");
  v("telemetry_max_age_s", p.telemetry_max_age_s, range::non_negative, "s",
    "use the broadcast while its latest message was sampled at most");
  v("telemetry_arrive_radius_m", p.telemetry_arrive_radius_m, range::positive, "m",
    "the search pattern around the broadcast position begins");
  v("telemetry_override_m", p.telemetry_override_m, range::positive, "m",
    "after a loss, the prediction is flown within this distance of the broadcast, the broadcast beyond");
  v("telemetry_search_height_m", p.telemetry_search_height_m, range::positive, "m",
    "... flown at least this high above the surface below");
  v("platform_half_size_m", p.platform_half_size_m, range::positive, "m",
    "half the side of the square landing top");
  v("skid_half_spread_m", p.skid_half_spread_m, range::positive, "m",
    "skids' outer edges from the vehicle's centre line");
  v("skid_half_length_m", p.skid_half_length_m, range::positive, "m",
    "skids' ends from the centre along body x");
  v("wide_gate_margin_m", p.wide_gate_margin_m, range::non_negative, "m",
    "margin of the wide gate for vision error and a tilted gear at contact");
  v("cut_vision_radius_m", p.cut_vision_radius_m, range::positive, "m",
    "largest horizontal offset from the platform centre at which vision");
  v("final_decision_after_s", p.final_decision_after_s, range::positive, "s",
    "in recovery, this long after first going below final_hold_height_m");
  v("recovery_decision_after_s", p.recovery_decision_after_s, range::positive, "s",
    "the final-stage timer above also starts this long after entering");
  v("search_give_up_s", p.search_give_up_s, range::positive, "s",
    "search that has not acquired the target this long after entering it");
  v("final_decision_window_s", p.final_decision_window_s, range::non_negative, "s",
    "... linearly over this long");
  v("max_wide_departures", p.max_wide_departures, range::non_negative, "",
    "committed wide, the error may leave the wide gate this often");
  v("max_landing_attempts", p.max_landing_attempts, range::at_least(1), "",
    "approaches before a failed one ends in aborted instead of another");
}

template <class V>
void visit_fields(V& v, LandingParams& p) {
  visit_approach_and_descent_fields(v, p);
  visit_servo_and_touchdown_fields(v, p);
  visit_search_and_decisions_fields(v, p);
}

// The deck predictor's keys (deck_motion.h; its validate() keeps the rules across fields).
template <class V>
void visit_fields(V& v, DeckMotionParams& p) {
  v("window_s", p.window_s, range::positive, "s", "history of deck fixes the fit uses");
  v("min_history_s", p.min_history_s, range::positive, "s", "fit only once the fixes span this long");
  v("max_components", p.max_components, range::closed(1, 8), "", "sinusoids per channel");
  v("min_period_s", p.min_period_s, range::positive, "s", "shortest period searched");
  v("max_period_s", p.max_period_s, range::positive, "s", "longest period searched");
  v("min_fit_r2", p.min_fit_r2, range::closed(0, 1), "",
    "a moving channel's fit with a smaller coefficient of determination is not trusted");
  v("moving_heave_m", p.moving_heave_m, range::positive, "m", "the deck counts as still below this heave amplitude");
  v("moving_tilt_deg", p.moving_tilt_rad, range::open(0, 90), "deg", "... and below this tilt amplitude",
    M_PI / 180.0);
  v("quiescent_step_s", p.quiescent_step_s, range::positive, "s", "time step of the scan for a quiescent period");
  v("quadratic_trend", p.quadratic_trend, range::any, "",
    "fit a quadratic datum drift besides the linear one (the inertial height's accelerometer bias)");
  v("heave_trend_is_drift", p.heave_trend_is_drift, range::any, "",
    "the heave's linear trend is the fixes' datum drifting: the deck's vertical speed leaves it out");
  v("backtest_s", p.backtest_s, range::non_negative, "s",
    "the newest fixes of this span are predicted from the older ones before the fit is trusted; 0 off");
  v("max_backtest_error_m", p.max_backtest_error_m, range::positive, "m", "largest heave backtest error");
  v("max_backtest_error_deg", p.max_backtest_error_rad, range::positive, "deg", "largest roll or pitch backtest error",
    M_PI / 180.0);
}

// Landing on a moving deck (issue 56): the platform's height and tilt from each fix feed a
// sum-of-sinusoids predictor (deck_motion.h); when it finds the deck moving, the last
// centimetres into contact and the cut wait for a quiescent period by its prediction (the
// deck's vertical speed and tilt small for window_s from now) instead of the cart's
// steadiness test, and the clearance servo feeds the predicted vertical speed forward.
struct DeckTimingParams {
  bool enabled{true};                 ///< time the touchdown on the deck's predicted motion
  /// The platform is a boat's deck, expected to move: until the predictor is ready and finds
  /// it still, the last centimetres wait as over a moving deck (without it the first 6-8 s of
  /// fixes, before the predictor has a fit, were flown as over a cart: straight into contact,
  /// at up to 1 m/s relative to a rising deck).
  bool expected{false};
  double max_vz_mps{0.25};            ///< deck vertical speed allowed over the window (m/s)
  double max_tilt_rad{6.0 * M_PI / 180.0};  ///< deck tilt allowed over the window (rad);
                                      ///< YAML max_tilt_deg
  double window_s{1.0};               ///< the quiescent period must last this long (s): the
                                      ///< descent starts clearance / descent_rate_mps before
                                      ///< it, the contact planned at its start, its length the
                                      ///< margin for a descent slower than planned
  double sample_max_range_m{6.0};     ///< fixes further than this from the camera are not fed
                                      ///< to the predictor (their height noise is decimetres)
  double wait_gap_m{0.25};            ///< below landing.final_hold_height_m, the gear clearance
                                      ///< held while the deck is not quiescent (m): above the
                                      ///< heave the clearance servo lags (final_wait_gap_m's
                                      ///< 10 cm let a rising deck meet the skids)
  double unpredicted_gap_m{0.50};     ///< the gear clearance held over a moving deck while
                                      ///< its motion is not yet predictable (m): without the
                                      ///< prediction's feed-forward the clearance servo lags a
                                      ///< deck rising at 0.4 m/s by ~0.15 m
  double descent_rate_mps{0.30};      ///< the last centimetres' rate relative to the deck in a
                                      ///< quiescent period (m/s): wait_gap_m in 0.8 s
  DeckMotionParams predictor{landing_predictor()};
  void validate() const;
  // The predictor as the touchdown uses it: a deck moves from 10 cm of heave or 3 deg of tilt
  // (a cart's fixes, braking, turning or in gusts, show up to 1.7 deg and 6 cm of apparent motion; sea
  // state 2's deck, 0.12 m and 2.5 deg, lands as a cart does); trusted when its fit predicts the newest 1 s
  // (window_s's horizon) from the older fixes within 10 cm and 3 deg (the fixes' heave wanders
  // by ~5 cm on the inertial height, InertialHeight; a sea state's components lie closer than
  // a 12 s window resolves, so 2 s ahead is seldom within 5 cm).
  static DeckMotionParams landing_predictor() {
    DeckMotionParams p;
    p.quadratic_trend = true;  // the inertial height drifts with the accelerometer's bias
    p.moving_heave_m = 0.10;
    p.moving_tilt_rad = 3.0 * M_PI / 180.0;
    p.backtest_s = 1.0;
    p.max_backtest_error_m = 0.10;
    p.max_backtest_error_rad = 3.0 * M_PI / 180.0;
    return p;
  }
};

template <class V>
void visit_fields(V& v, DeckTimingParams& p) {
  v("enabled", p.enabled, range::any, "", "time the touchdown on the deck's predicted motion");
  v("expected", p.expected, range::any, "",
    "the platform is a deck expected to move: wait until the predictor is ready and finds it still");
  v("max_vz_mps", p.max_vz_mps, range::positive, "m/s", "deck vertical speed allowed over the window");
  v("max_tilt_deg", p.max_tilt_rad, range::open(0, 45), "deg", "deck tilt allowed over the window", M_PI / 180.0);
  v("window_s", p.window_s, range::open_closed(0, 10), "s",
    "the quiescent period must last this long; the descent starts before it, the contact planned at its start");
  v("sample_max_range_m", p.sample_max_range_m, range::positive, "m",
    "fixes further than this from the camera are not fed to the predictor");
  v("wait_gap_m", p.wait_gap_m, range::closed(0, 1), "m",
    "below landing.final_hold_height_m, the gear clearance held while the deck is not quiescent");
  v("unpredicted_gap_m", p.unpredicted_gap_m, range::closed(0, 2), "m",
    "the gear clearance held over a moving deck while its motion is not yet predictable");
  v("descent_rate_mps", p.descent_rate_mps, range::open_closed(0, 1), "m/s",
    "the last centimetres' rate relative to the deck in a quiescent period");
  v.nested("predictor", p.predictor);
}

// Everything the controller reads, one YAML mapping with four sections.
struct ControllerParams {
  VehicleParams vehicle;
  CascadeParams cascade;
  TrackerParams tracker;
  LandingParams landing;
  PathGuidanceParams path;  ///< follow_path mode (seed 003), path_guidance.h
  DeckTimingParams deck;    ///< a moving deck (issue 56)
  void validate() const;
};

template <class V>
void visit_fields(V& v, ControllerParams& p) {
  v.nested("vehicle", p.vehicle);
  v.nested("cascade", p.cascade);
  v.nested("tracker", p.tracker);
  v.nested("landing", p.landing);
  v.nested("path", p.path);
  v.nested("deck", p.deck);
}

}  // namespace lander::ctl
