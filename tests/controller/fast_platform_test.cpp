// Fast platforms (issue 56): speed limits from the vehicle model, the position loop's closing
// speed on top of a moving setpoint, the approach in the platform's frame on an arc, and the
// decision log's word when a platform is beyond the vehicle's reach.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>

#include "lander/controller/cascade.h"
#include "lander/controller/vehicle_limits.h"
#include "support/hex_model.h"
#include "support/kinematic_run.h"

namespace lander::ctl::test {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Closed-form values are compared to round-off of a few operations on metres and newtons.
constexpr double kExact = 1e-9;

// Given the nominal ZD850-class vehicle, the limits follow from its thrust, tilt and drag:
// full thrust 6 kT w_max^2 = 78.7 N against 39.2 N of weight; the 30 deg tilt limit is below
// the 56 deg at which 90 % of full thrust still holds height; the drag speed solves
// 0.25 v + 0.06 v^2 = 0.5 m g tan 30 deg (11.3 N): 11.8 m/s.
TEST(VehicleLimits, FollowFromThrustTiltAndDrag) {
  const VehicleParams v;
  const CascadeParams c;
  const VehicleLimits L = derive_limits(v, c);
  const double full_N = 6.0 * v.k_thrust * v.w_max_radps * v.w_max_radps;
  EXPECT_NEAR(L.hover_thrust_share, v.mass_kg * v.gravity_mps2 / full_N, kExact);
  EXPECT_NEAR(std::cos(L.thrust_tilt_deg * kDegToRad) * (1.0 - kThrustReserve) * full_N,
              v.mass_kg * v.gravity_mps2, 1e-6);
  EXPECT_NEAR(L.tilt_deg, c.max_tilt_deg, kExact);
  EXPECT_NEAR(L.max_accel_xy_mps2, v.gravity_mps2 * std::tan(c.max_tilt_deg * kDegToRad), kExact);
  EXPECT_NEAR(drag_force_N(v, L.drag_speed_mps), c.max_vel_drag_share * v.mass_kg * L.max_accel_xy_mps2, 1e-6);
  EXPECT_TRUE(L.speed_from_model);
  EXPECT_EQ(L.max_speed_xy_mps, L.drag_speed_mps);
  EXPECT_NEAR(L.max_speed_xy_mps, 11.81, 0.01);  // the hand computation above
  // Covers the platforms the issue names (6 m/s) with more than the closing speed to spare.
  EXPECT_GT(L.max_speed_xy_mps, 6.0 + c.max_closing_vel_xy_mps);
}

// Given a heavier vehicle on the same rotors, the thrust margin, not the cascade's tilt limit,
// bounds the tilt; given an explicit cascade.max_vel_xy_mps, that is the limit.
TEST(VehicleLimits, ThrustMarginAndAnExplicitLimit) {
  VehicleParams heavy;
  heavy.mass_kg = 6.5;  // 63.8 N of 70.8 N usable: acos(0.90) = 25.8 deg
  const VehicleLimits L = derive_limits(heavy, CascadeParams{});
  EXPECT_LT(L.tilt_deg, CascadeParams{}.max_tilt_deg);
  EXPECT_NEAR(L.tilt_deg, L.thrust_tilt_deg, kExact);
  // Less horizontal acceleration; the drag speed still follows from the force (its mass
  // pushes harder at that tilt: 6.5 x 4.7 against 4 x 5.7 N per kg).
  EXPECT_LT(L.max_accel_xy_mps2, derive_limits(VehicleParams{}, CascadeParams{}).max_accel_xy_mps2);
  EXPECT_NEAR(drag_force_N(heavy, L.drag_speed_mps), CascadeParams{}.max_vel_drag_share * heavy.mass_kg * L.max_accel_xy_mps2,
              1e-6);
  CascadeParams fixed;
  fixed.max_vel_xy_mps = 3.0;
  const VehicleLimits F = derive_limits(VehicleParams{}, fixed);
  EXPECT_FALSE(F.speed_from_model);
  EXPECT_EQ(F.max_speed_xy_mps, 3.0);
  EXPECT_NE(F.speed_source().find("cascade.max_vel_xy_mps"), std::string::npos);
}

// A limit from the model needs a drag: without one the configuration is refused, naming
// the key.
TEST(VehicleLimits, NoDragAndNoLimitIsRefused) {
  ControllerParams p;
  p.vehicle.drag_linear_Nspm = 0.0;
  p.vehicle.drag_quadratic_Ns2pm2 = 0.0;
  try {
    p.validate();
    FAIL() << "validate() accepted a speed limit with no drag to come from";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cascade.max_vel_xy_mps"), std::string::npos) << e.what();
  }
  p.cascade.max_vel_xy_mps = 5.0;
  EXPECT_NO_THROW(p.validate());
}

// The position loop closes at max_closing_vel_xy_mps on top of the setpoint's velocity: a
// point 20 m off, still, gives 3 m/s (as before issue 56); the same point moving at 5 m/s
// gives 5 + 3 m/s along it, where the old total bound of 3 m/s could never catch it.
TEST(CascadeSpeed, ClosingSpeedAddsToTheFeedForward) {
  const VehicleParams v;
  const CascadeParams g;
  NavState nav;
  nav.valid = true;
  nav.t_s = 0.0;
  Setpoint still;
  still.p_W_m = Eigen::Vector3d(20.0, 0.0, 0.0);
  CascadeController a(v, g);
  a.update_outer(0.0, still, nav);
  EXPECT_NEAR(a.diagnostics().v_sp_W_mps.head<2>().norm(), g.max_closing_vel_xy_mps, kExact);
  Setpoint moving = still;
  moving.v_W_mps = Eigen::Vector3d(5.0, 0.0, 0.0);
  CascadeController b(v, g);
  b.update_outer(0.0, moving, nav);
  EXPECT_NEAR(b.diagnostics().v_sp_W_mps.x(), 5.0 + g.max_closing_vel_xy_mps, kExact);
  // A setpoint faster than the vehicle can fly is held at its limit.
  moving.v_W_mps = Eigen::Vector3d(30.0, 0.0, 0.0);
  CascadeController c(v, g);
  c.update_outer(0.0, moving, nav);
  EXPECT_NEAR(c.diagnostics().v_sp_W_mps.head<2>().norm(), c.limits().max_speed_xy_mps, kExact);
}

// A platform on a 30 m arc at 4.2 m/s (MBZIRC 2017's vehicle speed), CCW from the origin
// heading +x.
constexpr double kArcRadius_m = 30.0, kArcSpeed_mps = 4.2;
Eigen::Vector3d on_arc(double t) {
  const double th = kArcSpeed_mps * t / kArcRadius_m;
  return Eigen::Vector3d(kArcRadius_m * std::sin(th), kArcRadius_m * (1.0 - std::cos(th)), 0.8);
}

struct ArcFlight {
  LandingRunResult r;
  double entry_error_m{std::nan("")};  // true horizontal error when recovery is entered (m)
};

ArcFlight fly_arc(const std::string& frame) {
  LandingRunConfig cfg;
  cfg.platform.path = on_arc;
  cfg.start_W_m = Eigen::Vector3d(-2.0, 0.0, 10.0);
  cfg.max_time_s = 60.0;
  cfg.controller.landing.approach_frame = frame;
  ArcFlight f;
  Mode prev = Mode::kSearch;
  cfg.on_step = [&](double t, const HexModel& m, const LandingController& c) {
    if (c.mode() == Mode::kRecovery && prev != Mode::kRecovery && std::isnan(f.entry_error_m)) {
      f.entry_error_m = (m.p - on_arc(t)).head<2>().norm();
    }
    prev = c.mode();
  };
  f.r = run_landing(cfg);
  return f;
}

// Given the arc, the approach planned in the platform's frame rides along it and enters
// recovery close over the top; the seed's world-frame cubic to the eq. 28 prediction,
// replanned at a bounded rate, arrives metres off (the chord of the arc and the goal's slew).
// Observed in this model (2026-12-03): recovery entered 0.11 m off against 0.31 m (2.8x), the
// platform frame landing 5.7 cm off, the world frame losing the target in recovery and
// aborting after three attempts. The bound on the world frame's entry asks for 2x.
TEST(FastPlatform, ApproachInThePlatformFrameMeetsAPlatformOnAnArc) {
  const ArcFlight rel = fly_arc("platform"), world = fly_arc("world");
  std::cout << rel.r.describe() << world.r.describe();
  std::cout << "recovery entered " << rel.entry_error_m << " m off (platform frame), " << world.entry_error_m
            << " m off (world frame)\n";
  ASSERT_TRUE(std::isfinite(rel.entry_error_m)) << rel.r.describe();
  // Within the descent gate's reach: the servo takes over without chasing.
  constexpr double kEntryError_m = 0.25;
  EXPECT_LT(rel.entry_error_m, kEntryError_m) << rel.r.describe();
  EXPECT_TRUE(rel.r.landed) << rel.r.describe();
  // The touchdown figure for fast platforms: 10 cm.
  EXPECT_LT(rel.r.touchdown_offset_m, 0.10) << rel.r.describe();
  if (std::isfinite(world.entry_error_m)) {
    EXPECT_GT(world.entry_error_m, 2.0 * rel.entry_error_m) << world.r.describe();
  }
}

// Given a vehicle limited to 3 m/s (cascade.max_vel_xy_mps) and a platform at 4 m/s, the
// decision log says the platform is out of reach, naming the limit, and the loss that follows
// says why.
TEST(FastPlatform, APlatformBeyondTheSpeedLimitIsSaidToBeOutOfReach) {
  KinematicRun run;
  run.params.cascade.max_vel_xy_mps = 3.0;
  run.platform.v_W_mps = Eigen::Vector3d(4.0, 0.0, 0.0);
  run.start = Eigen::Vector3d(-1.0, 0.0, 8.0);
  run.max_time_s = 20.0;
  run.run();
  std::cout << describe(run.transitions);
  bool said = false;
  for (const LandingEvent& e : run.decision_log.events) {
    if (e.what != "out_of_reach") continue;
    said = true;
    EXPECT_NE(e.reason.find("cascade.max_vel_xy_mps"), std::string::npos) << e.reason;
    EXPECT_NE(e.reason.find("3.00 m/s speed limit"), std::string::npos) << e.reason;
  }
  EXPECT_TRUE(said) << describe(run.transitions);
  bool loss_explained = false;
  for (const ModeTransition& t : run.transitions) {
    if (t.reason.find("target lost") != std::string::npos &&
        t.reason.find("beyond this vehicle's 3.00 m/s speed limit") != std::string::npos) {
      loss_explained = true;
    }
  }
  EXPECT_TRUE(loss_explained) << describe(run.transitions);
  // The default vehicle (limit from its model) follows the same platform without the event.
  KinematicRun free_run;
  free_run.platform.v_W_mps = run.platform.v_W_mps;
  free_run.start = run.start;
  free_run.max_time_s = run.max_time_s;
  free_run.run();
  for (const LandingEvent& e : free_run.decision_log.events) EXPECT_NE(e.what, "out_of_reach") << e.reason;
}

}  // namespace
}  // namespace lander::ctl::test
