// Mode machine of seed 000 section 3 on synthetic observation streams.
//
// Most tests use a kinematic vehicle that sits exactly on the controller's setpoint (so the
// mode logic is tested apart from the flight dynamics) and a synthetic camera (support/).
// The go-around-when-lost-low test flies the rigid-body model in closed loop.
#include "lander/controller/landing_controller.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <string>

#include "support/kinematic_run.h"

namespace lander::ctl::test {
namespace {

TEST(ModeMachine, ObserveApproachRecoveryTouchdownInOrder) {
  KinematicRun run;
  run.platform.v_W_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  std::cout << describe(run.transitions);
  const std::vector<Mode> expected = {Mode::kObserve, Mode::kApproach, Mode::kRecovery,
                                      Mode::kTouchdown, Mode::kLanded};
  EXPECT_EQ(targets(run.transitions), expected);
  // seed 000 section 3.2: approach after exactly 80 observed keyframes.
  EXPECT_EQ(run.keyframes_before_approach, 80);
  EXPECT_TRUE(run.landed);
  // Near-perfect tracking and noise of a few mm: the cut happens within the 5 cm criterion and
  // the fall keeps the horizontal offset.
  EXPECT_LT(run.final_offset_m, 0.05);
  // Every transition has a reason and non-decreasing time.
  for (std::size_t i = 0; i < run.transitions.size(); ++i) {
    EXPECT_FALSE(run.transitions[i].reason.empty());
    if (i > 0) {
      EXPECT_GE(run.transitions[i].t_s, run.transitions[i - 1].t_s);
    }
  }
}

TEST(ModeMachine, BlurredFramesDoNotCountTowardsTheEightyKeyframes) {
  KinematicRun run;
  run.keyframe = [](int frame) { return frame % 2 == 0; };  // every other frame blurred
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kApproach; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  std::cout << describe(run.transitions);
  EXPECT_EQ(run.keyframes_before_approach, 80);
  ASSERT_GE(run.transitions.size(), 2u);
  EXPECT_EQ(run.transitions[1].to, Mode::kApproach);
  // 80 keyframes at 15 Hz take at least 80 / 15 s (minus the ~0.1 s of acquisition).
  EXPECT_GT(run.transitions[1].t_s - run.transitions[0].t_s, 80.0 / 15.0 - 0.5);
}

// The approach starts only once observe's follower has closed on the platform
// (approach_entry_max_error_m): a disturbance the controller cannot remove holds the vehicle
// 3 m to the side until t = 6 s, well after the 80 keyframes (~2.7 s at 30 Hz).
TEST(ModeMachine, ApproachWaitsUntilTheFollowerHasClosedOnThePlatform) {
  constexpr double kHeldOff_m = 3.0;     // twice the 1.5 m entry gate
  constexpr double kReleased_s = 6.0;
  KinematicRun run;
  run.offset = [&](double t, const LandingController&) {
    return t < kReleased_s ? Eigen::Vector3d(0.0, kHeldOff_m, 0.0) : Eigen::Vector3d::Zero();
  };
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kApproach; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_GE(run.transitions.size(), 2u);
  EXPECT_EQ(run.transitions[0].to, Mode::kObserve);
  EXPECT_EQ(run.transitions[1].to, Mode::kApproach);
  EXPECT_GE(run.transitions[1].t_s, kReleased_s);
  // Released, the tight kinematic tracking closes the gap within a second.
  EXPECT_LT(run.transitions[1].t_s, kReleased_s + 1.0);
  EXPECT_GT(run.keyframes_before_approach, 80);
  // Entered close: the plain reason, not the wait's.
  EXPECT_EQ(run.transitions[1].reason.find("approach_entry_wait_s"), std::string::npos);
}

// ... and after approach_entry_wait_s of observing it starts anyway, saying why.
TEST(ModeMachine, ApproachStartsAfterTheEntryWaitWhenTheFollowerCannotClose) {
  KinematicRun run;
  run.offset = [](double, const LandingController&) { return Eigen::Vector3d(0.0, 3.0, 0.0); };
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kApproach; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_GE(run.transitions.size(), 2u);
  EXPECT_EQ(run.transitions[1].to, Mode::kApproach);
  const double observed_s = run.transitions[1].t_s - run.transitions[0].t_s;
  const double wait_s = run.params.landing.approach_entry_wait_s;
  constexpr double kOuterTick_s = 0.05;  // the mode machine runs at the outer loop's rate
  EXPECT_GE(observed_s, wait_s);
  EXPECT_LT(observed_s, wait_s + kOuterTick_s);
  EXPECT_NE(run.transitions[1].reason.find("approach_entry_wait_s"), std::string::npos);
}

TEST(ModeMachine, LossWhileObservingHighGoesToSearchAndReacquires) {
  KinematicRun run;
  run.visible = [](double t, const Eigen::Isometry3d&) { return t < 1.5 || t > 4.0; };
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kApproach; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  std::cout << describe(run.transitions);
  const std::vector<Mode> expected = {Mode::kObserve, Mode::kSearch, Mode::kObserve,
                                      Mode::kApproach};
  EXPECT_EQ(targets(run.transitions), expected);
  // The loss is declared after loss_timeout_s (1 s) without detection (+ one outer tick).
  ASSERT_GE(run.transitions.size(), 2u);
  EXPECT_NEAR(run.transitions[1].t_s, 1.5 + 1.0, 0.1);
}

TEST(ModeMachine, LargeErrorLowInRecoveryTriggersGoAround) {
  KinematicRun run;
  // Once the vehicle is within 0.6 m of the top in recovery, a gust shoves it 0.7 m sideways
  // along body y (the wide image axis, so the platform stays in view): that close to the cart
  // an error above go_around_error_m (0.6 m) is a go-around.
  bool pushed = false;
  run.push = [&](const LandingController& c) -> Eigen::Vector3d {
    if (pushed || c.mode() != Mode::kRecovery || c.diagnostics().gear_clearance_m > 0.6) {
      return Eigen::Vector3d::Zero();
    }
    pushed = true;
    const double yaw = c.diagnostics().setpoint.yaw_rad;
    return Eigen::Vector3d(0.7 * -std::sin(yaw), 0.7 * std::cos(yaw), 0.0);
  };
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kGoAround; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  std::cout << describe(run.transitions);
  ASSERT_TRUE(pushed);
  ASSERT_FALSE(run.transitions.empty());
  EXPECT_EQ(run.transitions.back().from, Mode::kRecovery);
  EXPECT_EQ(run.transitions.back().to, Mode::kGoAround);
  EXPECT_NE(run.transitions.back().reason.find("horizontal error"), std::string::npos);
}

TEST(ModeMachine, LargeErrorHighInRecoveryIsCaughtUpWithoutGoAround) {
  KinematicRun run;
  // The same gust at 1.2 m above the top: the servo holds height and catches up.
  bool pushed = false;
  run.push = [&](const LandingController& c) -> Eigen::Vector3d {
    if (pushed || c.mode() != Mode::kRecovery || c.diagnostics().gear_clearance_m > 1.2) {
      return Eigen::Vector3d::Zero();
    }
    pushed = true;
    const double yaw = c.diagnostics().setpoint.yaw_rad;
    return Eigen::Vector3d(0.7 * -std::sin(yaw), 0.7 * std::cos(yaw), 0.0);
  };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_TRUE(pushed);
  EXPECT_TRUE(run.landed);
  for (const ModeTransition& tr : run.transitions) EXPECT_NE(tr.to, Mode::kGoAround);
}

TEST(ModeMachine, NoContactAfterTheCutRestartsAndGoesAround) {
  KinematicRun run;
  run.solid = false;  // nothing to land on: the IMU never reads +g after the cut
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kGoAround; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  std::cout << describe(run.transitions);
  ASSERT_GE(run.transitions.size(), 2u);
  const ModeTransition& last = run.transitions.back();
  EXPECT_EQ(last.from, Mode::kTouchdown);
  EXPECT_EQ(last.to, Mode::kGoAround);
  EXPECT_NE(last.reason.find("no contact"), std::string::npos);
  // contact_timeout_s after the cut.
  const ModeTransition& cut = run.transitions[run.transitions.size() - 2];
  EXPECT_NEAR(last.t_s - cut.t_s, ControllerParams{}.landing.contact_timeout_s, 0.01);
}

TEST(ModeMachine, GoAroundWhenTheTargetIsLostLowThenLands) {
  // Closed loop on the rigid-body model: vision goes blind for 3 s the first time the
  // vehicle is below 2.5 m; it must climb back, re-acquire and still land.
  LandingRunConfig cfg;
  cfg.platform.v_W_mps = Eigen::Vector3d(0.3, 0.0, 0.0);
  cfg.start_W_m = Eigen::Vector3d(-2.0, 0.0, 8.0);
  double blind_from = -1.0;
  cfg.visible = [&](double t, const Eigen::Isometry3d& X_WB) {
    if (blind_from < 0 && X_WB.translation().z() < 2.5) blind_from = t;
    return !(blind_from >= 0 && t < blind_from + 3.0);
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  const std::vector<Mode> seen = targets(r.transitions);
  auto it = std::find(seen.begin(), seen.end(), Mode::kGoAround);
  ASSERT_NE(it, seen.end()) << "no go-around";
  const ModeTransition& ga = r.transitions[it - seen.begin()];
  EXPECT_NE(ga.reason.find("lost"), std::string::npos);
  // After the go-around: observe (or search then observe) again, and finally landed.
  EXPECT_NE(std::find(it, seen.end(), Mode::kObserve), seen.end());
  EXPECT_EQ(seen.back(), Mode::kLanded);
  EXPECT_TRUE(r.on_platform);
  EXPECT_LT(r.touchdown_offset_m, 0.05);  // the 5 cm
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

// The cut needs the fused altitude to agree with vision that the skids are at the top. With
// the fused height reading 10 cm high, the lowest clearance the descent aims at
// (final_hover_gap_m, -5 cm) never looks like contact to it: no cut. Reading right: the cut.
TEST(ModeMachine, CutWaitsForTheFusedAltitudeToAgree) {
  KinematicRun agree;
  agree.fused_altitude_error_m = 0.0;
  agree.run();
  SCOPED_TRACE(describe(agree.transitions));
  EXPECT_TRUE(agree.landed);

  KinematicRun high;
  high.fused_altitude_error_m = 0.10;
  high.max_time_s = 40.0;
  high.run();
  SCOPED_TRACE(describe(high.transitions));
  for (const ModeTransition& tr : high.transitions) EXPECT_NE(tr.to, Mode::kTouchdown);
  EXPECT_FALSE(high.landed);
}

// Given a navigation height that steps 3 m up one second into the approach (a GPS with
// metres of vertical error: the unseen campaign's default-0005 had a 5 m step and met the top
// at 1.5 m/s), then the approach still ends approach_epsilon_m above the platform: its height
// is held above the platform's height now (navigation + vision relative vector), in which the
// step cancels. Planned in absolute W it would have ended 3 m lower, through the top.
TEST(ModeMachine, ApproachHeightFollowsThePlatformThroughANavigationHeightStep) {
  KinematicRun run;
  run.platform.v_W_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  constexpr double kStep_m = 3.0;
  double t_step = std::numeric_limits<double>::infinity();
  run.nav_error = [&](double t) {
    return Eigen::Vector3d(0.0, 0.0, t >= t_step ? kStep_m : 0.0);
  };
  double min_clearance_in_approach = 1e9, clearance_at_recovery = -1.0;
  run.on_step = [&](double t, const Eigen::Vector3d& p, const LandingController& c) {
    const double clearance = run.gear_clearance_m(t, p);
    if (c.mode() == Mode::kApproach) {
      if (!std::isfinite(t_step)) t_step = t + 1.0;
      min_clearance_in_approach = std::min(min_clearance_in_approach, clearance);
    }
    if (c.mode() == Mode::kRecovery && clearance_at_recovery < 0.0) clearance_at_recovery = clearance;
  };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  const LandingParams& L = run.params.landing;
  ASSERT_TRUE(std::isfinite(t_step));
  EXPECT_TRUE(run.landed);
  // The approach's end: approach_epsilon_m above the top (the gear clearance is the CoM's
  // height above the top less gear_height_m); the kinematic vehicle tracks its setpoint to a
  // few cm and vision's height noise is ~1 cm at 2 m.
  constexpr double kTrack_m = 0.1;
  EXPECT_NEAR(clearance_at_recovery, L.approach_epsilon_m - L.gear_height_m, kTrack_m);
  EXPECT_GT(min_clearance_in_approach, L.approach_epsilon_m - L.gear_height_m - kTrack_m);
}

// Given a navigation height that steps 3 m up one second into observe (the same degraded
// GPS), then the observing vehicle stays at the height above the platform where it acquired
// the target: held in absolute W (as before) it would have descended by the whole step, 3 m
// nearer the top, while believing itself where it was.
TEST(ModeMachine, ObserveHeightFollowsThePlatformThroughANavigationHeightStep) {
  KinematicRun run;
  run.platform.v_W_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  constexpr double kStep_m = 3.0;  // the navigation reads 3 m high: a W hold descends
  double t_step = std::numeric_limits<double>::infinity();
  run.nav_error = [&](double t) {
    return Eigen::Vector3d(0.0, 0.0, t >= t_step ? kStep_m : 0.0);
  };
  double clearance_at_entry = -1.0, min_clearance = 1e9, max_clearance = -1e9;
  int observe_steps_after_step = 0;
  run.on_step = [&](double t, const Eigen::Vector3d& p, const LandingController& c) {
    if (c.mode() != Mode::kObserve) return;
    const double clearance = run.gear_clearance_m(t, p);
    if (!std::isfinite(t_step)) {
      t_step = t + 1.0;
      clearance_at_entry = clearance;
    }
    if (t >= t_step + 0.1) {  // the setpoint step itself is instantaneous in the nav frame
      ++observe_steps_after_step;
      min_clearance = std::min(min_clearance, clearance);
      max_clearance = std::max(max_clearance, clearance);
    }
  };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_TRUE(std::isfinite(t_step));
  ASSERT_GT(observe_steps_after_step, 250);  // observed for at least another second after it
  EXPECT_TRUE(run.landed);
  // The kinematic vehicle tracks its setpoint to a few cm; vision's height noise is ~1-3 cm
  // at 8 m. A hold in absolute W would be off by the whole 3 m step.
  constexpr double kTrack_m = 0.15;
  EXPECT_GT(min_clearance, clearance_at_entry - kTrack_m);
  EXPECT_LT(max_clearance, clearance_at_entry + kTrack_m);
}

}  // namespace
}  // namespace lander::ctl::test
