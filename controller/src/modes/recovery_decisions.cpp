// The recovery mode's decisions (recovery_decisions.h).
#include "modes/recovery_decisions.h"

#include <algorithm>

namespace lander::ctl::modes {
namespace {

// The clearance setpoint stays at most this far below the current clearance (m): bounds the
// descent speed near the top after a pause of the descent (1.5 1/s * 0.5 m).
constexpr double kMaxClearanceStepDown_m = 0.5;

}  // namespace

FinalGate widening_final_gate(const LandingParams& L, double waited_s) {
  const double f = L.final_decision_window_s > 0.0
                       ? std::min(1.0, (waited_s - L.final_decision_after_s) / L.final_decision_window_s)
                       : 1.0;
  const double wide_gate = L.wide_gate_m();
  return {L.final_descent_error_m + f * (wide_gate - L.final_descent_error_m),
          L.final_descent_rel_speed_mps + f * (L.max_touchdown_rel_speed_mps - L.final_descent_rel_speed_mps)};
}

// Low enough for the cut: the level gear within cut_height_m of the top (the fall the cut was
// made for), or the lowest skid end (skid_drop_m) already at the top, within kSkidTouch_m, by
// both clearances: a tilted vehicle stands on a skid end before its level gear gets there.
// The fused altitude (ultrasonic, vision, baro; seed 004) must agree that the skids are at the
// top: once vision's clearance read 0.7 cm with the truth 3.4 cm (blurred frames near the
// top) and the cut dropped the vehicle at 0.72 m/s. Should the fused estimate read high, the
// descent simply goes on into contact at the final rate.
CutTest touchdown_test(const CutInputs& in, const LandingParams& L) {
  const double h = in.clearance_m, h_fused = in.fused_clearance_m;
  const double h_low = h + in.skid_drop_m, h_fused_low = h_fused + in.skid_drop_m;
  const bool level_gear_low = h < L.cut_height_m && h_fused < L.cut_height_m;
  const bool skid_end_down = h_low < LandingParams::kSkidTouch_m && h_fused_low < LandingParams::kSkidTouch_m;
  const bool pass = in.fresh && (level_gear_low || skid_end_down) && in.error_m < in.gate_m &&
                    in.rel_speed_mps < L.max_touchdown_rel_speed_mps;
  return {pass, h_low, h_fused_low};
}

// Final decimetres: below final_hold_height_m go on into contact only while within
// final_descent_error_m and moving with the platform (the skids may meet the top before the
// cut, and the error at first contact is the landing's); otherwise wait low
// (final_wait_gap_m), so the dash into contact once aligned is short (a stop-and-go cart is
// steady for ~2 s); climb back to final_hold_height_m when the error exceeds twice the
// touchdown criterion. Committed wide: the wide gate and the cut's relative speed instead.
// A moving deck: only while it is predicted quiescent (LandingContext::deck_quiescent).
// The height is servoed like the horizontal position: on the gear clearance measured by
// vision (h_sp - h), so steps of the navigation height (baro / GPS) cancel.
DescentStep descend(double h_sp, const DescentInputs& in, const LandingParams& L) {
  const double h = in.clearance_m, e_xy = in.error_m;
  const bool near = h < L.near_height_m;
  const double gate = in.committed_wide ? in.wide_gate_m : near ? L.descent_gate_near_m : L.descent_gate_m;
  // Below the final hold height the slowest rate: the cut happens from it (soft contact).
  const double rate = h < L.final_hold_height_m ? in.final_rate_mps.value_or(L.descent_rate_final_mps)
                      : near                    ? L.descent_rate_near_mps
                                                : L.descent_rate_mps;
  // On a moving deck the last centimetres wait for a quiescent period too (issue 56).
  const bool aligned =
      in.deck_quiescent &&
      (in.committed_wide   ? e_xy < in.wide_gate_m && in.rel_speed_mps < L.max_touchdown_rel_speed_mps
       : in.deck_committed ? e_xy < L.touchdown_error_m && in.rel_speed_mps < L.max_touchdown_rel_speed_mps
                           : e_xy < L.final_descent_error_m && in.rel_speed_mps < L.final_descent_rel_speed_mps);
  // Above the final hold height the setpoint runs on towards contact, except over a moving
  // deck: a setpoint 0.5 m below the vehicle still pulled it down at 0.4 m/s as it crossed
  // the final hold height, into a deck rising at 0.3 m/s.
  const bool deck_wait = in.wait_gap_m.has_value();
  const double h_floor = (aligned || (h > L.final_hold_height_m && !deck_wait))
                             ? L.final_hover_gap_m
                             : in.wait_gap_m.value_or(L.final_wait_gap_m);
  if (!in.committed_wide && e_xy > 2.0 * L.touchdown_error_m) h_sp = std::max(h_sp, L.final_hold_height_m);
  double vz_ff = 0.0;
  if (in.fresh && e_xy < gate && h_sp > h_floor) {
    h_sp -= rate * in.dt_s;
    vz_ff = -rate;
  }
  if (h_sp <= h_floor) {
    h_sp = h_floor;
    vz_ff = 0.0;
  }
  // Never command the setpoint far below the vehicle (limits the descent speed near the top
  // even after a pause of the descent).
  h_sp = std::max(h_sp, h - kMaxClearanceStepDown_m);
  return {h_sp, vz_ff};
}

// Visual-servo integral: the horizontal error between the platform and the vehicle is
// integrated (only once roughly aligned, so the entry transient does not wind it up) and
// added to the setpoint; it removes the bias of the lagging velocity feed-forward on curved
// or accelerating cart paths. It learns only while the platform is not accelerating: a
// cart's start or stop is a transient the acceleration feed-forward meets, not a bias.
double along_track_accel_mps2(const Eigen::Vector2d& v, const Eigen::Vector2d& a) {
  // Below this speed the direction of travel is noise (m/s).
  constexpr double kMinTravelSpeed_mps = 0.5;
  const double speed = v.norm();
  return speed < kMinTravelSpeed_mps ? a.norm() : std::abs(a.dot(v) / speed);
}

Eigen::Vector2d servo_integral(const Eigen::Vector2d& integral_m, const Eigen::Vector2d& error_W_m,
                               double error_m, const Eigen::Vector2d& platform_v_W_mps,
                               const Eigen::Vector2d& platform_accel_W_mps2, double dt_s,
                               const LandingParams& L) {
  Eigen::Vector2d i = integral_m;
  if (error_m < L.descent_gate_m &&
      along_track_accel_mps2(platform_v_W_mps, platform_accel_W_mps2) < L.servo_int_max_platform_accel_mps2) {
    i += L.servo_ki * error_W_m * dt_s;
    const double n = i.norm();
    if (n > L.servo_max_correction_m) i *= L.servo_max_correction_m / n;
  }
  return i;
}

Eigen::Vector2d carrot_setpoint(const Eigen::Vector2d& vehicle_W_m, const Eigen::Vector2d& target_W_m,
                                double max_carrot_m) {
  Eigen::Vector2d carrot = target_W_m - vehicle_W_m;
  if (carrot.norm() > max_carrot_m) carrot *= max_carrot_m / carrot.norm();
  return vehicle_W_m + carrot;
}

}  // namespace lander::ctl::modes
