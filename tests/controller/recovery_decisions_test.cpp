// The recovery mode's decisions as pure functions (controller/src/modes/recovery_decisions.h):
// the widening final gate, the touchdown test, the clearance descent, the servo integral and
// the carrot, each against the rule it implements, on the default LandingParams.
#include "../../controller/src/modes/recovery_decisions.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lander::ctl::modes {
namespace {

// The decisions are a few additions and multiplications of metre-scale values: 1e-12 m is
// rounding, far below any figure the controller acts on (millimetres).
constexpr double kExact = 1e-12;

TEST(FinalGate, WidensLinearlyFromTheNominalToTheWideGateOverTheWindow) {
  const LandingParams L;
  ASSERT_GT(L.final_decision_window_s, 0.0);
  const double wide = L.wide_gate_m();
  const FinalGate at_start = widening_final_gate(L, L.final_decision_after_s);
  EXPECT_NEAR(at_start.error_m, L.final_descent_error_m, kExact);
  EXPECT_NEAR(at_start.rel_speed_mps, L.final_descent_rel_speed_mps, kExact);
  const FinalGate half = widening_final_gate(L, L.final_decision_after_s + 0.5 * L.final_decision_window_s);
  EXPECT_NEAR(half.error_m, 0.5 * (L.final_descent_error_m + wide), kExact);
  EXPECT_NEAR(half.rel_speed_mps, 0.5 * (L.final_descent_rel_speed_mps + L.max_touchdown_rel_speed_mps), kExact);
  // At and after the window's end: the wide gate, no wider.
  for (const double extra : {1.0, 3.0}) {
    const FinalGate g = widening_final_gate(L, L.final_decision_after_s + extra * L.final_decision_window_s);
    EXPECT_NEAR(g.error_m, wide, kExact);
    EXPECT_NEAR(g.rel_speed_mps, L.max_touchdown_rel_speed_mps, kExact);
  }
}

TEST(FinalGate, ANoWindowGateIsTheWideGateAtOnce) {
  LandingParams L;
  L.final_decision_window_s = 0.0;
  const FinalGate g = widening_final_gate(L, L.final_decision_after_s);
  EXPECT_NEAR(g.error_m, L.wide_gate_m(), kExact);
  EXPECT_NEAR(g.rel_speed_mps, L.max_touchdown_rel_speed_mps, kExact);
}

// A cut-ready state: half the cut height above the top by both clearances, level, half the
// gate off, half the allowed relative speed, a fresh detection.
CutInputs ready(const LandingParams& L) {
  return {true, 0.5 * L.cut_height_m, 0.5 * L.cut_height_m, 0.0, 0.5 * L.touchdown_error_m, L.touchdown_error_m,
          0.5 * L.max_touchdown_rel_speed_mps};
}

TEST(TouchdownTest, PassesLowAlignedSlowAndFresh) {
  const LandingParams L;
  EXPECT_TRUE(touchdown_test(ready(L), L).pass);
}

TEST(TouchdownTest, EachConditionAloneRefusesTheCut) {
  const LandingParams L;
  CutInputs in = ready(L);
  in.fresh = false;
  EXPECT_FALSE(touchdown_test(in, L).pass) << "stale detection";
  in = ready(L);
  in.clearance_m = in.fused_clearance_m = 2.0 * L.cut_height_m;
  EXPECT_FALSE(touchdown_test(in, L).pass) << "too high by both clearances";
  in = ready(L);
  in.fused_clearance_m = 2.0 * L.cut_height_m;
  EXPECT_FALSE(touchdown_test(in, L).pass) << "vision low but the fused altitude disagrees";
  in = ready(L);
  in.error_m = in.gate_m;
  EXPECT_FALSE(touchdown_test(in, L).pass) << "error at the gate";
  in = ready(L);
  in.rel_speed_mps = L.max_touchdown_rel_speed_mps;
  EXPECT_FALSE(touchdown_test(in, L).pass) << "relative speed at the limit";
}

TEST(TouchdownTest, ATiltedVehicleStandingOnASkidEndMayCutAboveTheCutHeight) {
  const LandingParams L;
  CutInputs in = ready(L);
  // The level gear above the cut height, the lowest skid end already at the top.
  in.clearance_m = in.fused_clearance_m = L.cut_height_m + 0.01;
  in.skid_drop_m = -(in.clearance_m - 0.5 * LandingParams::kSkidTouch_m);
  const CutTest t = touchdown_test(in, L);
  EXPECT_TRUE(t.pass);
  EXPECT_NEAR(t.lowest_skid_m, in.clearance_m + in.skid_drop_m, kExact);
  EXPECT_NEAR(t.fused_lowest_skid_m, in.fused_clearance_m + in.skid_drop_m, kExact);
  in.skid_drop_m = 0.0;  // level: no skid end down, the gear too high
  EXPECT_FALSE(touchdown_test(in, L).pass);
}

DescentInputs descent_at(const LandingParams& L, double clearance_m, double error_m) {
  return {true, false, error_m, 0.0, clearance_m, L.wide_gate_m(), 0.1, true, std::nullopt, std::nullopt};
}

TEST(Descent, DescendsAtTheRateOfItsBandWhileWithinTheGate) {
  const LandingParams L;
  const double dt = 0.1;
  // Above the near height: the nominal rate.
  const double high = L.near_height_m + 1.0;
  DescentStep d = descend(high, descent_at(L, high, 0.5 * L.descent_gate_m), L);
  EXPECT_NEAR(d.clearance_sp_m, high - L.descent_rate_mps * dt, kExact);
  EXPECT_NEAR(d.vz_ff_mps, -L.descent_rate_mps, kExact);
  // Near: the near rate, within the near gate.
  const double near = 0.5 * (L.near_height_m + L.final_hold_height_m);
  d = descend(near, descent_at(L, near, 0.5 * L.descent_gate_near_m), L);
  EXPECT_NEAR(d.clearance_sp_m, near - L.descent_rate_near_mps * dt, kExact);
  // Outside the gate: no descent.
  d = descend(high, descent_at(L, high, 2.0 * L.descent_gate_m), L);
  EXPECT_NEAR(d.clearance_sp_m, high, kExact);
  EXPECT_EQ(d.vz_ff_mps, 0.0);
  // A stale detection: no descent either.
  DescentInputs stale = descent_at(L, high, 0.5 * L.descent_gate_m);
  stale.fresh = false;
  EXPECT_NEAR(descend(high, stale, L).clearance_sp_m, high, kExact);
}

TEST(Descent, WaitsLowUntilAlignedThenGoesOnToTheHoverGap) {
  const LandingParams L;
  const double low = 0.5 * (L.final_wait_gap_m + L.final_hold_height_m);
  // Below the final hold height, not aligned (error above the final descent error but within
  // twice the touchdown error): the setpoint stops at the wait gap.
  const double off = 0.5 * (L.final_descent_error_m + std::min(L.descent_gate_near_m, 2.0 * L.touchdown_error_m));
  ASSERT_GT(off, L.final_descent_error_m);
  DescentStep d = descend(L.final_wait_gap_m, descent_at(L, low, off), L);
  EXPECT_NEAR(d.clearance_sp_m, std::max(L.final_wait_gap_m, low - 0.5), kExact);
  EXPECT_EQ(d.vz_ff_mps, 0.0);
  // Aligned: on down to the hover gap (the floor).
  d = descend(L.final_hover_gap_m, descent_at(L, L.final_hover_gap_m + 0.01, 0.5 * L.final_descent_error_m), L);
  EXPECT_NEAR(d.clearance_sp_m, L.final_hover_gap_m, kExact);
}

// A moving deck (issue 56): the clearance setpoint never runs below the deck's wait gap
// while the deck is not quiescent, above the final hold height too (a setpoint 0.5 m below
// the vehicle pulled it into a rising deck); in a committed period the dash goes on within
// the cut's gate, beyond the final descent's.
TEST(Descent, OverAMovingDeckTheSetpointStopsAtTheWaitGapAtAnyHeight) {
  const LandingParams L;
  const double wait = 0.5, high = L.final_hold_height_m + 0.4;
  ASSERT_GT(wait, L.final_hold_height_m);  // a wait above the final hold height (unpredicted deck)
  DescentInputs in = descent_at(L, high, 0.5 * L.final_descent_error_m);
  in.deck_quiescent = false;
  in.wait_gap_m = wait;
  in.final_rate_mps = 0.3;
  DescentStep d = descend(high - 0.5, in, L);  // a setpoint left 0.5 m below the vehicle
  EXPECT_NEAR(d.clearance_sp_m, wait, kExact);
  EXPECT_EQ(d.vz_ff_mps, 0.0);
  // Without the deck the same step runs on towards the hover gap.
  in.wait_gap_m.reset();
  d = descend(high - 0.5, in, L);
  EXPECT_LT(d.clearance_sp_m, wait);
}

TEST(Descent, ACommittedDeckPeriodDashesOnWithinTheCutsGate) {
  const LandingParams L;
  const double h = 0.2;
  // An error between the final descent's gate and the cut's.
  const double err = 0.5 * (L.final_descent_error_m + L.touchdown_error_m);
  ASSERT_GT(err, L.final_descent_error_m);
  DescentInputs in = descent_at(L, h, err);
  in.wait_gap_m = 0.25;
  in.final_rate_mps = 0.3;
  in.deck_quiescent = true;
  in.deck_committed = true;
  DescentStep d = descend(h, in, L);
  EXPECT_NEAR(d.clearance_sp_m, h - 0.3 * in.dt_s, kExact);  // on down at the deck's rate
  EXPECT_NEAR(d.vz_ff_mps, -0.3, kExact);
  in.deck_committed = false;  // the cart's rule: 3 cm, so it waits at the gap
  d = descend(h, in, L);
  EXPECT_NEAR(d.clearance_sp_m, 0.25, kExact);
}

TEST(Descent, ALargeErrorClimbsBackToTheFinalHoldHeight) {
  const LandingParams L;
  const double low = L.final_wait_gap_m;
  const DescentStep d = descend(low, descent_at(L, low, 2.5 * L.touchdown_error_m), L);
  EXPECT_NEAR(d.clearance_sp_m, L.final_hold_height_m, kExact);
}

TEST(Descent, NeverCommandsFarBelowTheVehicle) {
  const LandingParams L;
  // A setpoint left 2 m below a vehicle that climbed: raised to 0.5 m below it.
  const double h = L.near_height_m + 3.0;
  const DescentStep d = descend(h - 2.0, descent_at(L, h, 2.0 * L.descent_gate_m), L);
  EXPECT_NEAR(d.clearance_sp_m, h - 0.5, kExact);
}

TEST(ServoIntegral, LearnsTheErrorWhileAlignedAndBoundsIt) {
  const LandingParams L;
  const Eigen::Vector2d e(0.02, -0.01);
  const Eigen::Vector2d zero_accel = Eigen::Vector2d::Zero();
  const Eigen::Vector2d zero_v = Eigen::Vector2d::Zero();
  const Eigen::Vector2d i1 = servo_integral(Eigen::Vector2d::Zero(), e, e.norm(), zero_v, zero_accel, 0.1, L);
  EXPECT_NEAR((i1 - L.servo_ki * e * 0.1).norm(), 0.0, kExact);
  // Bounded in norm by servo_max_correction_m.
  Eigen::Vector2d i = Eigen::Vector2d::Zero();
  for (int k = 0; k < 100000; ++k) i = servo_integral(i, e, e.norm(), zero_v, zero_accel, 0.1, L);
  EXPECT_NEAR(i.norm(), L.servo_max_correction_m, kExact);
  // Not while the error is outside the descent gate, nor while the platform accelerates.
  const Eigen::Vector2d far = Eigen::Vector2d(2.0 * L.descent_gate_m, 0.0);
  EXPECT_EQ(servo_integral(i1, far, far.norm(), zero_v, zero_accel, 0.1, L), i1);
  const Eigen::Vector2d accel(2.0 * L.servo_int_max_platform_accel_mps2 + 0.1, 0.0);
  EXPECT_EQ(servo_integral(i1, e, e.norm(), zero_v, accel, 0.1, L), i1);
  // Moving: braking along the travel holds it; the same acceleration across the travel (a
  // steady turn's centripetal part) does not.
  const Eigen::Vector2d v_travel(4.2, 0.0);
  EXPECT_EQ(servo_integral(i1, e, e.norm(), v_travel, accel, 0.1, L), i1);
  const Eigen::Vector2d turning(0.0, accel.x());
  EXPECT_NEAR((servo_integral(i1, e, e.norm(), v_travel, turning, 0.1, L) - (i1 + L.servo_ki * e * 0.1)).norm(), 0.0,
              kExact);
}

TEST(ServoIntegral, AlongTrackAccelerationIsTheTravelComponent) {
  const Eigen::Vector2d a(0.3, 0.4);  // |a| = 0.5
  EXPECT_NEAR(along_track_accel_mps2(Eigen::Vector2d(2.0, 0.0), a), 0.3, kExact);
  EXPECT_NEAR(along_track_accel_mps2(Eigen::Vector2d(0.0, -3.0), a), 0.4, kExact);
  // Too slow for a direction of travel: the whole magnitude.
  EXPECT_NEAR(along_track_accel_mps2(Eigen::Vector2d(0.1, 0.0), a), 0.5, kExact);
}

TEST(Carrot, KeepsTheSetpointWithinItsReachOfTheVehicle) {
  const Eigen::Vector2d vehicle(1.0, 2.0);
  EXPECT_EQ(carrot_setpoint(vehicle, Eigen::Vector2d(1.1, 2.0), 0.5), Eigen::Vector2d(1.1, 2.0));
  const Eigen::Vector2d far = carrot_setpoint(vehicle, Eigen::Vector2d(4.0, 6.0), 0.5);  // 5 m away
  EXPECT_NEAR((far - vehicle).norm(), 0.5, kExact);
  EXPECT_NEAR((far - Eigen::Vector2d(1.3, 2.4)).norm(), 0.0, kExact);
}

}  // namespace
}  // namespace lander::ctl::modes
