// The recovery mode's decisions as pure functions of what it measured (unit-tested on their
// own, tests/controller/recovery_decisions_test.cpp): the widening final gate, the touchdown
// test, the clearance descent and the horizontal servo setpoint.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "lander/controller/params.h"

namespace lander::ctl::modes {

// The final gate waited_s into the final stage (issue 10). final_decision_after_s in, if the
// nominal gate has still not led to a cut, it widens over final_decision_window_s, linearly
// from the nominal (final_descent_error_m, final_descent_rel_speed_mps) to the wide one
// (wide_gate_m(), max_touchdown_rel_speed_mps):
//   f = (waited - final_decision_after_s) / final_decision_window_s in [0, 1],
//   gate = nominal + f (wide - nominal).
struct FinalGate {
  double error_m;
  double rel_speed_mps;
};
FinalGate widening_final_gate(const LandingParams& L, double waited_s);

// The touchdown test's inputs (seed 000 section 3.3), all relative to the platform.
struct CutInputs {
  bool fresh;                ///< a detection within descent_stale_s
  double clearance_m;        ///< level gear above the top, by vision
  double fused_clearance_m;  ///< the same by the fused altitude
  double skid_drop_m;        ///< lowest skid end below the level gear (<= 0)
  double error_m;            ///< horizontal error
  double gate_m;             ///< the cut's gate: touchdown_error_m, or the wide gate once committed
  double rel_speed_mps;      ///< |vehicle velocity - platform velocity|
};
struct CutTest {
  bool pass;                   ///< low, aligned and slow (the platform's steadiness is tested after)
  double lowest_skid_m;        ///< clearance of the lowest skid end, by vision
  double fused_lowest_skid_m;  ///< the same by the fused altitude
};
CutTest touchdown_test(const CutInputs& in, const LandingParams& L);

// The clearance servo's inputs for one step of the controlled descent.
struct DescentInputs {
  bool fresh;           ///< a detection within descent_stale_s
  bool committed_wide;  ///< committed within the wide gate
  double error_m;       ///< horizontal error
  double rel_speed_mps; ///< horizontal speed relative to the platform, by vision
  double clearance_m;   ///< level gear above the top, by vision
  double wide_gate_m;   ///< LandingParams::wide_gate_m()
  double dt_s;
  bool deck_quiescent{true};  ///< a moving deck is quiescent for deck.window_s (true when
                              ///< the deck does not move)
  /// A moving deck: the wait (deck.wait_gap_m, at any height: the clearance setpoint never
  /// runs below it while the deck is not quiescent) and the rate of the last centimetres
  /// (deck.descent_rate_mps) instead of final_wait_gap_m below final_hold_height_m and
  /// descent_rate_final_mps.
  std::optional<double> wait_gap_m;
  std::optional<double> final_rate_mps;
  /// A moving deck's committed quiescent period: the dash into it goes on within the cut's
  /// gate (touchdown_error_m, max_touchdown_rel_speed_mps), not the final descent's 3 cm: the
  /// deck's roll sways its top by centimetres and a dash stopped half-way misses the period.
  bool deck_committed{false};
};
struct DescentStep {
  double clearance_sp_m;  ///< the gear-clearance setpoint after this step
  double vz_ff_mps;       ///< descent rate fed forward (<= 0)
};
// The gear-clearance setpoint moved down at the controlled rate while the error is within
// the descent gate, held at the floor of the final decimetres, raised back to the final hold
// height when the error grows, never far below the vehicle.
DescentStep descend(double clearance_sp_m, const DescentInputs& in, const LandingParams& L);

// The platform's acceleration along its direction of travel (m/s^2, magnitude): speeding up
// and braking. A steady turn's centripetal part is left out; below kMinTravelSpeed_mps, the
// whole magnitude.
double along_track_accel_mps2(const Eigen::Vector2d& platform_v_W_mps, const Eigen::Vector2d& platform_accel_W_mps2);

// The visual-servo integral after one step: the horizontal error (platform - vehicle) is
// integrated while roughly aligned and the platform neither speeding up nor braking (a steady
// turn is a bias to learn: the velocity estimate lags the turning velocity), bounded in norm.
Eigen::Vector2d servo_integral(const Eigen::Vector2d& integral_m, const Eigen::Vector2d& error_W_m,
                               double error_m, const Eigen::Vector2d& platform_v_W_mps,
                               const Eigen::Vector2d& platform_accel_W_mps2, double dt_s,
                               const LandingParams& L);

// Carrot: the horizontal setpoint towards target_W_m kept within recovery_max_carrot_m of the
// vehicle, so a large error is closed at a bounded relative speed.
Eigen::Vector2d carrot_setpoint(const Eigen::Vector2d& vehicle_W_m, const Eigen::Vector2d& target_W_m,
                                double max_carrot_m);

}  // namespace lander::ctl::modes
