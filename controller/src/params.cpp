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
  check_fields(*this);
  require(w_idle_radps >= 0 && w_idle_radps < w_max_radps, "w_idle_radps",
          "must be in [0, w_max_radps)");
  // Six rotors at full speed must lift the vehicle with margin for control.
  require(6.0 * k_thrust * w_max_radps * w_max_radps > 1.2 * mass_kg * gravity_mps2,
          "w_max_radps", "full thrust must exceed 1.2 times the weight");
}

void CascadeParams::validate() const { check_fields(*this); }

void DeckTimingParams::validate() const {
  check_fields(*this);
  validate_nested("predictor", predictor);
}

void TrackerParams::validate() const {
  check_fields(*this);
  require(history_s >= fit_window_s, "history_s", "must be >= fit_window_s");
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
  require(L.approach_max_duration_s >= L.approach_min_duration_s, "approach_max_duration_s",
          "must be >= approach_min_duration_s");
  require(L.approach_frame == "platform" || L.approach_frame == "world", "approach_frame",
          "must be platform or world");
}

// LandingParams: the recovery descent and its visual servo.
void validate_descent(const LandingParams& L) {
  require(L.descent_rate_near_mps > 0 && L.descent_rate_near_mps <= L.descent_rate_mps,
          "descent_rate_near_mps", "must be in (0, descent_rate_mps]");
  require(L.descent_rate_final_mps > 0 && L.descent_rate_final_mps <= L.descent_rate_near_mps,
          "descent_rate_final_mps", "must be in (0, descent_rate_near_mps]");
  require(L.final_hover_gap_m >= -kMaxFinalHoverGapBelow_m && L.final_hover_gap_m < L.cut_height_m,
          "final_hover_gap_m", "must be in [-0.2, cut_height_m)");
  require(L.final_hold_height_m > L.cut_height_m, "final_hold_height_m", "must be > cut_height_m");
  require(L.final_wait_gap_m > L.cut_height_m && L.final_wait_gap_m < L.final_hold_height_m,
          "final_wait_gap_m", "must be in (cut_height_m, final_hold_height_m)");
  require(L.platform_accel_ff_full_mps2 >= L.platform_accel_ff_deadband_mps2,
          "platform_accel_ff_full_mps2", "must be >= platform_accel_ff_deadband_mps2");
}

// LandingParams: the cut height, the touchdown error and the final descent.
void validate_final_descent(const LandingParams& L) {
  require(L.final_descent_error_m > 0 && L.final_descent_error_m <= L.touchdown_error_m,
          "final_descent_error_m", "must be in (0, touchdown_error_m]");
  require(L.max_descent_near_mps >= L.descent_rate_near_mps, "max_descent_near_mps",
          "must be >= descent_rate_near_mps");
  require(L.max_descent_final_mps >= L.descent_rate_final_mps, "max_descent_final_mps",
          "must be >= descent_rate_final_mps");
}

// LandingParams: the search spiral.
void validate_search_pattern(const LandingParams& L) {
}

// LandingParams: the touchdown test and the contact detection.
void validate_touchdown_test(const LandingParams& L) {
  require(L.contact_timeout_s > L.contact_min_time_s, "contact_timeout_s",
          "must be > contact_min_time_s");
}

// LandingParams: loss timeouts and re-acquisition.
void validate_loss(const LandingParams& L) {
}

// LandingParams: the go-around.
void validate_go_around(const LandingParams& L) {
  require(L.go_around_error_m > L.touchdown_error_m, "go_around_error_m",
          "must be > touchdown_error_m");
  require(L.go_around_height_m > L.approach_epsilon_m, "go_around_height_m",
          "must be > approach_epsilon_m");
}

// LandingParams: the search, the follow point and the platform broadcast.
void validate_search(const LandingParams& L) {
}

// LandingParams: the skid geometry and the wide gate.
void validate_wide_gate(const LandingParams& L) {
  // The wide gate must be wider than the nominal cut gate (else it adds nothing) and inside
  // the go-around error (else recovery goes around before it could commit). The message
  // names whichever of the two limits sets it.
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
}

}  // namespace

void LandingParams::validate() const {
  check_fields(*this);
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
  validate_nested("deck", deck);
  // The speed limit from the vehicle model needs a drag to balance the thrust against.
  require(cascade.max_vel_xy_mps > 0.0 || vehicle.drag_linear_Nspm > 0.0 || vehicle.drag_quadratic_Ns2pm2 > 0.0,
          "cascade.max_vel_xy_mps",
          "is 0 (from the vehicle model) but vehicle.drag_linear_Nspm and drag_quadratic_Ns2pm2 are both 0: "
          "no drag limits the speed; give the limit or the drag");
}

}  // namespace lander::ctl
