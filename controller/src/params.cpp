// validate() of the controller params: every check names its field.
#include "lander/controller/params.h"

#include <algorithm>
#include <cmath>

namespace lander::ctl {
namespace {
// A floor further than this below the top would let the vertical loop push the gear into the
// cart at full descent speed if the cut did not trigger (m).
constexpr double kMaxFinalHoverGapBelow_m = 0.2;
}  // namespace

void VehicleParams::validate() const {
  require(mass_kg > 0, "mass_kg", "must be > 0");
  require(inertia_kgm2.minCoeff() > 0, "inertia_kgm2", "all entries must be > 0");
  require(arm_m > 0, "arm_m", "must be > 0");
  require(k_thrust > 0, "k_thrust", "must be > 0");
  require(k_torque > 0, "k_torque", "must be > 0");
  require(w_max_radps > 0, "w_max_radps", "must be > 0");
  require(w_idle_radps >= 0 && w_idle_radps < w_max_radps, "w_idle_radps",
          "must be in [0, w_max_radps)");
  require(motor_tau_s >= 0, "motor_tau_s", "must be >= 0");
  require(gravity_mps2 > 0, "gravity_mps2", "must be > 0");
  // Six rotors at full speed must lift the vehicle with margin for control.
  require(6.0 * k_thrust * w_max_radps * w_max_radps > 1.2 * mass_kg * gravity_mps2,
          "w_max_radps", "full thrust must exceed 1.2 times the weight");
}

void CascadeParams::validate() const {
  require(outer_rate_hz > 0, "outer_rate_hz", "must be > 0");
  for (auto [name, value] : {std::pair<const char*, double>{"pos_kp_xy", pos_kp_xy},
                             {"pos_kp_z", pos_kp_z},
                             {"vel_kp_xy", vel_kp_xy},
                             {"vel_kp_z", vel_kp_z},
                             {"att_kp_rp", att_kp_rp},
                             {"att_kp_yaw", att_kp_yaw},
                             {"rate_kp_rp", rate_kp_rp},
                             {"rate_kp_yaw", rate_kp_yaw},
                             {"max_vel_xy_mps", max_vel_xy_mps},
                             {"max_vel_up_mps", max_vel_up_mps},
                             {"max_vel_down_mps", max_vel_down_mps},
                             {"max_accel_z_mps2", max_accel_z_mps2},
                             {"max_rate_rp_degps", max_rate_rp_degps},
                             {"max_rate_yaw_degps", max_rate_yaw_degps}}) {
    require(value > 0, name, "must be > 0");
  }
  for (auto [name, value] : {std::pair<const char*, double>{"vel_ki_xy", vel_ki_xy},
                             {"vel_ki_z", vel_ki_z},
                             {"rate_ki_rp", rate_ki_rp},
                             {"rate_ki_yaw", rate_ki_yaw},
                             {"max_int_accel_mps2", max_int_accel_mps2},
                             {"max_int_alpha_radps2", max_int_alpha_radps2}}) {
    require(value >= 0, name, "must be >= 0");
  }
  require(max_tilt_deg > 0 && max_tilt_deg < 80, "max_tilt_deg", "must be in (0, 80)");
  require(dist_ff_gain >= 0 && dist_ff_gain <= 1, "dist_ff_gain", "must be in [0, 1]");
  require(dist_filter_tau_s > 0, "dist_filter_tau_s", "must be > 0");
  require(max_dist_accel_mps2 >= 0, "max_dist_accel_mps2", "must be >= 0");
}

void TrackerParams::validate() const {
  require(poly_order >= 1 && poly_order <= 6, "poly_order", "must be in [1, 6]");
  require(fit_window_s > 0, "fit_window_s", "must be > 0");
  require(max_poly_extrapolation_s >= 0, "max_poly_extrapolation_s", "must be >= 0");
  require(velocity_window_s > 0, "velocity_window_s", "must be > 0");
  require(platform_accel_noise_mps2 > 0, "platform_accel_noise_mps2", "must be > 0");
  require(fix_noise_m > 0, "fix_noise_m", "must be > 0");
  require(fix_noise_per_m >= 0, "fix_noise_per_m", "must be >= 0");
  require(fix_gate_sigma > 0, "fix_gate_sigma", "must be > 0");
  require(relative_window_s > 0, "relative_window_s", "must be > 0");
  require(platform_max_speed_mps > 0, "platform_max_speed_mps", "must be > 0");
  require(platform_jerk_noise_mps3 > 0, "platform_jerk_noise_mps3", "must be > 0");
  require(platform_max_accel_mps2 > 0, "platform_max_accel_mps2", "must be > 0");
  require(history_s >= fit_window_s, "history_s", "must be >= fit_window_s");
  require(nav_history_s > 0, "nav_history_s", "must be > 0");
  require(turn_fit_window_s > 0, "turn_fit_window_s", "must be > 0");
  require(turn_min_speed_mps > 0, "turn_min_speed_mps", "must be > 0");
  require(max_turn_rate_radps >= 0, "max_turn_rate_radps", "must be >= 0");
}

double LandingParams::wide_gate_on_top_m() const {
  const double footprint_m = std::hypot(skid_half_spread_m, skid_half_length_m);
  const double drift_m = max_touchdown_rel_speed_mps * final_wait_gap_m / descent_rate_final_mps;
  return platform_half_size_m - footprint_m - drift_m - wide_gate_margin_m;
}

double LandingParams::wide_gate_m() const {
  return std::min(wide_gate_on_top_m(), cut_vision_radius_m);
}

namespace {

// LandingParams: the observe and approach phases.
void validate_approach(const LandingParams& L) {
  require(L.observe_frames >= 1, "observe_frames", "must be >= 1");
  require(L.approach_entry_max_error_m >= 0, "approach_entry_max_error_m", "must be >= 0 (0: off)");
  require(L.approach_entry_wait_s >= 0, "approach_entry_wait_s", "must be >= 0");
  require(L.approach_epsilon_m > 0, "approach_epsilon_m", "must be > 0");
  require(L.approach_speed_mps > 0, "approach_speed_mps", "must be > 0");
  require(L.approach_min_duration_s > 0, "approach_min_duration_s", "must be > 0");
  require(L.approach_max_duration_s >= L.approach_min_duration_s, "approach_max_duration_s",
          "must be >= approach_min_duration_s");
  require(L.approach_switch_error_m > 0, "approach_switch_error_m", "must be > 0");
  require(L.approach_settle_timeout_s >= 0, "approach_settle_timeout_s", "must be >= 0");
}

// LandingParams: the recovery descent and its visual servo.
void validate_descent(const LandingParams& L) {
  require(L.descent_rate_mps > 0, "descent_rate_mps", "must be > 0");
  require(L.descent_rate_near_mps > 0 && L.descent_rate_near_mps <= L.descent_rate_mps,
          "descent_rate_near_mps", "must be in (0, descent_rate_mps]");
  require(L.descent_rate_final_mps > 0 && L.descent_rate_final_mps <= L.descent_rate_near_mps,
          "descent_rate_final_mps", "must be in (0, descent_rate_near_mps]");
  require(L.near_height_m > 0, "near_height_m", "must be > 0");
  require(L.descent_gate_m > 0, "descent_gate_m", "must be > 0");
  require(L.descent_gate_near_m > 0, "descent_gate_near_m", "must be > 0");
  require(L.final_hover_gap_m >= -kMaxFinalHoverGapBelow_m && L.final_hover_gap_m < L.cut_height_m,
          "final_hover_gap_m", "must be in [-0.2, cut_height_m)");
  require(L.final_hold_height_m > L.cut_height_m, "final_hold_height_m", "must be > cut_height_m");
  require(L.final_wait_gap_m > L.cut_height_m && L.final_wait_gap_m < L.final_hold_height_m,
          "final_wait_gap_m", "must be in (cut_height_m, final_hold_height_m)");
  require(L.recovery_max_carrot_m > 0, "recovery_max_carrot_m", "must be > 0");
  require(L.servo_ki >= 0, "servo_ki", "must be >= 0");
  require(L.servo_max_correction_m >= 0, "servo_max_correction_m", "must be >= 0");
  require(L.servo_int_max_platform_accel_mps2 >= 0, "servo_int_max_platform_accel_mps2",
          "must be >= 0");
  require(L.platform_accel_ff_gain >= 0 && L.platform_accel_ff_gain <= 1, "platform_accel_ff_gain",
          "must be in [0, 1]");
  require(L.platform_accel_ff_deadband_mps2 >= 0, "platform_accel_ff_deadband_mps2", "must be >= 0");
  require(L.platform_accel_ff_full_mps2 >= L.platform_accel_ff_deadband_mps2,
          "platform_accel_ff_full_mps2", "must be >= platform_accel_ff_deadband_mps2");
}

// LandingParams: the cut height, the touchdown error and the final descent.
void validate_final_descent(const LandingParams& L) {
  require(L.gear_height_m >= 0, "gear_height_m", "must be >= 0");
  require(L.cut_height_m > 0, "cut_height_m", "must be > 0");
  require(L.touchdown_error_m > 0, "touchdown_error_m", "must be > 0");
  require(L.final_descent_error_m > 0 && L.final_descent_error_m <= L.touchdown_error_m,
          "final_descent_error_m", "must be in (0, touchdown_error_m]");
  require(L.final_descent_rel_speed_mps > 0, "final_descent_rel_speed_mps", "must be > 0");
  require(L.max_descent_near_mps >= L.descent_rate_near_mps, "max_descent_near_mps",
          "must be >= descent_rate_near_mps");
  require(L.max_descent_final_mps >= L.descent_rate_final_mps, "max_descent_final_mps",
          "must be >= descent_rate_final_mps");
}

// LandingParams: the search spiral.
void validate_search_pattern(const LandingParams& L) {
  require(L.search_spiral_after_s >= 0, "search_spiral_after_s", "must be >= 0");
  require(L.search_spiral_spacing_m > 0, "search_spiral_spacing_m", "must be > 0");
  require(L.search_spiral_speed_mps >= 0, "search_spiral_speed_mps", "must be >= 0");
  require(L.search_max_radius_m > 0, "search_max_radius_m", "must be > 0");
}

// LandingParams: the touchdown test and the contact detection.
void validate_touchdown_test(const LandingParams& L) {
  require(L.max_touchdown_rel_speed_mps > 0, "max_touchdown_rel_speed_mps", "must be > 0");
  require(L.steady_window_s > 0, "steady_window_s", "must be > 0");
  require(L.steady_tilt_deg > 0, "steady_tilt_deg", "must be > 0");
  require(L.max_platform_tilt_deg > 0 && L.max_platform_tilt_deg < 90, "max_platform_tilt_deg",
          "must be in (0, 90)");
  require(L.contact_min_time_s >= 0, "contact_min_time_s", "must be >= 0");
  require(L.contact_accel_frac > 0 && L.contact_accel_frac < 1.5, "contact_accel_frac",
          "must be in (0, 1.5)");
  require(L.contact_confirm_s >= 0, "contact_confirm_s", "must be >= 0");
  require(L.contact_timeout_s > L.contact_min_time_s, "contact_timeout_s",
          "must be > contact_min_time_s");
}

// LandingParams: loss timeouts and re-acquisition.
void validate_loss(const LandingParams& L) {
  require(L.loss_timeout_s > 0, "loss_timeout_s", "must be > 0");
  require(L.recovery_loss_timeout_s > 0, "recovery_loss_timeout_s", "must be > 0");
  require(L.descent_stale_s > 0, "descent_stale_s", "must be > 0");
  require(L.approach_goal_max_rate_mps > 0, "approach_goal_max_rate_mps", "must be > 0");
  require(L.track_max_tilt_deg > 0 && L.track_max_tilt_deg < 80, "track_max_tilt_deg",
          "must be in (0, 80)");
  require(L.reacquire_frames >= 1, "reacquire_frames", "must be >= 1");
}

// LandingParams: the go-around.
void validate_go_around(const LandingParams& L) {
  require(L.go_around_low_height_m > 0, "go_around_low_height_m", "must be > 0");
  require(L.go_around_error_m > L.touchdown_error_m, "go_around_error_m",
          "must be > touchdown_error_m");
  require(L.go_around_height_m > L.approach_epsilon_m, "go_around_height_m",
          "must be > approach_epsilon_m");
}

// LandingParams: the search, the follow point and the platform broadcast.
void validate_search(const LandingParams& L) {
  require(L.search_min_height_m > 0, "search_min_height_m", "must be > 0");
  require(L.search_yaw_rate_degps >= 0 && L.search_yaw_rate_degps <= 90, "search_yaw_rate_degps",
          "must be in [0, 90]");
  require(L.observe_follow_max_speed_mps > 0, "observe_follow_max_speed_mps", "must be > 0");
  require(L.observe_follow_max_accel_mps2 > 0, "observe_follow_max_accel_mps2", "must be > 0");
  require(L.search_predict_max_s >= 0, "search_predict_max_s", "must be >= 0");
  require(L.search_expand_after_s >= 0, "search_expand_after_s", "must be >= 0");
  require(L.search_climb_rate_mps >= 0, "search_climb_rate_mps", "must be >= 0");
  require(L.search_first_climb_rate_mps >= 0, "search_first_climb_rate_mps", "must be >= 0");
  require(L.search_max_height_m > 0, "search_max_height_m", "must be > 0");
  require(L.telemetry_max_age_s >= 0, "telemetry_max_age_s", "must be >= 0");
  require(L.telemetry_arrive_radius_m > 0, "telemetry_arrive_radius_m", "must be > 0");
  require(L.telemetry_search_height_m > 0, "telemetry_search_height_m", "must be > 0");
}

// LandingParams: the skid geometry and the wide gate.
void validate_wide_gate(const LandingParams& L) {
  require(L.skid_half_spread_m > 0, "skid_half_spread_m", "must be > 0");
  require(L.skid_half_length_m > 0, "skid_half_length_m", "must be > 0");
  require(L.wide_gate_margin_m >= 0, "wide_gate_margin_m", "must be >= 0");
  // The wide gate must be wider than the nominal cut gate (else it adds nothing) and inside
  // the go-around error (else recovery goes around before it could commit). The message
  // names whichever of the two limits sets it.
  require(L.platform_half_size_m > 0, "platform_half_size_m", "must be > 0");
  require(L.cut_vision_radius_m > 0, "cut_vision_radius_m", "must be > 0");
  const char* limit = L.wide_gate_on_top_m() <= L.cut_vision_radius_m ? "platform_half_size_m"
                                                                   : "cut_vision_radius_m";
  require(L.wide_gate_m() > L.touchdown_error_m, limit,
          "leaves a wide gate (wide_gate_m()) no wider than touchdown_error_m: the top is too "
          "small for the skids, the final drift and wide_gate_margin_m, or vision too narrow");
  require(L.wide_gate_m() < L.go_around_error_m, limit,
          "gives a wide gate (wide_gate_m()) >= go_around_error_m");
}

// LandingParams: the bounded decisions.
void validate_decisions(const LandingParams& L) {
  require(L.final_decision_after_s > 0, "final_decision_after_s", "must be > 0");
  require(L.recovery_decision_after_s > 0, "recovery_decision_after_s", "must be > 0");
  require(L.search_give_up_s > 0, "search_give_up_s", "must be > 0");
  require(L.final_decision_window_s >= 0, "final_decision_window_s", "must be >= 0");
  require(L.max_landing_attempts >= 1, "max_landing_attempts", "must be >= 1");
  require(L.max_wide_departures >= 0, "max_wide_departures", "must be >= 0");
}

}  // namespace

void LandingParams::validate() const {
  validate_approach(*this);
  validate_descent(*this);
  validate_final_descent(*this);
  validate_search_pattern(*this);
  validate_touchdown_test(*this);
  validate_loss(*this);
  validate_go_around(*this);
  validate_search(*this);
  validate_wide_gate(*this);
  validate_decisions(*this);
}

void ControllerParams::validate() const {
  validate_nested("vehicle", vehicle);
  validate_nested("cascade", cascade);
  validate_nested("tracker", tracker);
  validate_nested("landing", landing);
  validate_nested("path", path);
}

}  // namespace lander::ctl
