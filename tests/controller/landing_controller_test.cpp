// LandingController and PlatformTracker details: behaviour without navigation, latency
// compensation of vision, the initial search behaviour.
#include "lander/controller/landing_controller.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace lander::ctl {
namespace {

TEST(LandingController, WithoutNavigationHoldsHoverThrustAndDampsRates) {
  LandingController ctl(ControllerParams{}, CameraMount{});
  NavState invalid;  // valid = false
  ImuSample imu;
  const RotorCommand level = ctl.step(0.0, invalid, imu);
  const VehicleParams v;
  const double w_hover = std::sqrt(v.mass_kg * v.gravity_mps2 / (6 * v.k_thrust));
  for (double w : level.w_radps) EXPECT_NEAR(w, w_hover, 1e-6);  // exact allocation
  EXPECT_EQ(ctl.mode(), Mode::kSearch);
  // A roll rate is opposed: rotors on the left (y > 0: k = 0, 1, 2) slow down.
  imu.gyro_B_radps = Eigen::Vector3d(0.5, 0, 0);
  const RotorCommand damp = ctl.step(0.004, invalid, imu);
  EXPECT_LT(damp.w_radps[1], damp.w_radps[4]);
  EXPECT_FALSE(damp.motors_cut);
  EXPECT_TRUE(ctl.transitions().empty());
}

TEST(LandingController, SearchHoldsPositionAndSweepsHeading) {
  ControllerParams p;
  LandingController ctl(p, CameraMount{});
  NavState nav;
  nav.valid = true;
  nav.p_W_m = Eigen::Vector3d(1, 2, 10);
  ImuSample imu;
  for (int i = 0; i <= 250; ++i) {  // 1 s at 250 Hz, no vision
    nav.t_s = imu.t_s = i * 0.004;
    ctl.step(nav.t_s, nav, imu);
  }
  EXPECT_EQ(ctl.mode(), Mode::kSearch);
  const Setpoint& sp = ctl.diagnostics().setpoint;
  EXPECT_NEAR((sp.p_W_m - nav.p_W_m).norm(), 0.0, 1e-12);
  // Heading setpoint advanced by the sweep rate over ~1 s (one outer period of slack).
  const double expected = p.landing.search_yaw_rate_degps * M_PI / 180.0 * 1.0;
  EXPECT_NEAR(sp.yaw_rad, expected, p.landing.search_yaw_rate_degps * M_PI / 180.0 / 30.0 + 1e-9);
}

TEST(PlatformTracker, UsesTheNavigationStateAtTheFrameTimeNotTheLatest) {
  const CameraMount mount;
  PlatformTracker tracker(TrackerParams{}, mount);
  // The vehicle flies at 2 m/s along x at 5 m; nav states every 4 ms.
  auto nav_at = [](double t) {
    NavState n;
    n.t_s = t;
    n.valid = true;
    n.p_W_m = Eigen::Vector3d(2.0 * t, 0.0, 5.0);
    n.v_W_mps = Eigen::Vector3d(2.0, 0, 0);
    return n;
  };
  for (int i = 0; i <= 100; ++i) tracker.add_nav(nav_at(i * 0.004));
  // A frame exposed at t = 0.25 s (between nav samples), delivered at 0.4 s.
  const double t_frame = 0.2513;
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.translation() = nav_at(t_frame).p_W_m;
  Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
  X_WP.translation() = Eigen::Vector3d(0.7, -0.3, 0.8);
  PlatformObservation obs;
  obs.t_s = t_frame;
  obs.detected = obs.keyframe = true;
  obs.X_CP = (X_WB * mount.X_BC()).inverse() * X_WP;
  ASSERT_TRUE(tracker.add_observation(obs));
  // Linear motion: interpolation is exact up to round-off.
  EXPECT_NEAR((tracker.latest().p_W_m - X_WP.translation()).norm(), 0.0, 1e-9);
  // Using the latest nav state (0.4 s) instead would have been 0.3 m off.
  EXPECT_GT((nav_at(0.4).p_W_m - nav_at(t_frame).p_W_m).norm(), 0.29);
}

// The tracker used to accept a non-finite pose (and then every fit and prediction was NaN).
TEST(PlatformTracker, NonFinitePoseIsRejectedAndCounted) {
  PlatformTracker tracker(TrackerParams{}, CameraMount{});
  NavState n;
  n.valid = true;
  n.p_W_m = Eigen::Vector3d(0, 0, 5);
  for (int i = 0; i <= 10; ++i) {
    n.t_s = i * 0.004;
    tracker.add_nav(n);
  }
  PlatformObservation obs;
  obs.t_s = 0.02;
  obs.detected = obs.keyframe = true;
  obs.X_CP.translation() = Eigen::Vector3d(0, 0, std::nan(""));
  EXPECT_FALSE(tracker.add_observation(obs));
  obs.X_CP.translation().z() = 4.0;
  obs.cov(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(tracker.add_observation(obs));
  EXPECT_EQ(tracker.rejected_observations(), 2);
  EXPECT_FALSE(tracker.has_fix());
  obs.cov.setIdentity();
  EXPECT_TRUE(tracker.add_observation(obs));
  EXPECT_TRUE(tracker.latest().p_W_m.allFinite());
}

TEST(LandingController, NonFiniteInputsAreDroppedAndTheLastCommandHeld) {
  LandingController ctl(ControllerParams{}, CameraMount{});
  NavState nav;
  nav.valid = true;
  nav.p_W_m = Eigen::Vector3d(1, 2, 10);
  ImuSample imu;
  const RotorCommand good = ctl.step(0.0, nav, imu);
  PlatformObservation obs;
  obs.t_s = 0.0;
  obs.detected = obs.keyframe = true;
  obs.X_CP.translation().setConstant(std::nan(""));
  ctl.on_vision(obs);
  AltitudeEstimate alt;
  alt.valid = true;
  alt.z_W_m = std::nan("");
  ctl.on_altitude(alt);
  ImuSample bad = imu;
  bad.accel_B_mps2.z() = std::nan("");
  const RotorCommand held = ctl.step(0.004, nav, bad);
  EXPECT_EQ(held.w_radps, good.w_radps);
  EXPECT_EQ(ctl.rejected_inputs(), 3);
  const RotorCommand next = ctl.step(0.008, nav, imu);
  for (double w : next.w_radps) EXPECT_TRUE(std::isfinite(w));
  EXPECT_FALSE(ctl.tracker().has_fix());
}

TEST(PlatformTracker, SteadinessRejectsATiltingPlatform) {
  const CameraMount mount;
  PlatformTracker tracker(TrackerParams{}, mount);
  NavState nav;
  nav.valid = true;
  nav.p_W_m = Eigen::Vector3d(0, 0, 2);
  for (int i = 0; i < 30; ++i) {
    nav.t_s = i / 30.0;
    tracker.add_nav(nav);
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.translation() = nav.p_W_m;
    Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
    X_WP.translation() = Eigen::Vector3d(0, 0, 0.8);
    // Rocking +-5 deg about x at 2 Hz: unsteady for a 3 deg spread limit.
    X_WP.linear() = Eigen::AngleAxisd(5.0 * M_PI / 180 * std::sin(2 * M_PI * 2 * nav.t_s),
                                      Eigen::Vector3d::UnitX())
                        .toRotationMatrix();
    PlatformObservation obs;
    obs.t_s = nav.t_s;
    obs.detected = obs.keyframe = true;
    obs.X_CP = (X_WB * mount.X_BC()).inverse() * X_WP;
    tracker.add_observation(obs);
  }
  std::string why;
  EXPECT_FALSE(tracker.steady(0.5, 3.0, 10.0, &why));
  EXPECT_NE(why.find("unsteady"), std::string::npos) << why;
  EXPECT_TRUE(tracker.steady(0.5, 8.0, 10.0, &why)) << why;
}

// The acceleration feed-forward's share: nothing up to the deadband (the estimate's noise at
// a constant cart speed), all from `full` on (a cart's 0.6 m/s^2 start passes whole, not
// reduced by the deadband), linear between; with full == deadband a hard step. Closed form:
// exact but for round-off.
TEST(LandingController, AccelerationFeedForwardShareRampsFromTheDeadbandToFull) {
  constexpr double kTol = 1e-12;
  EXPECT_EQ(accel_feed_forward_share(0.0, 0.1, 0.3), 0.0);
  EXPECT_EQ(accel_feed_forward_share(0.1, 0.1, 0.3), 0.0);
  EXPECT_NEAR(accel_feed_forward_share(0.15, 0.1, 0.3), 0.25, kTol);
  EXPECT_NEAR(accel_feed_forward_share(0.2, 0.1, 0.3), 0.5, kTol);
  EXPECT_EQ(accel_feed_forward_share(0.3, 0.1, 0.3), 1.0);
  EXPECT_EQ(accel_feed_forward_share(0.6, 0.1, 0.3), 1.0);
  // Continuous at both ends of the ramp.
  EXPECT_NEAR(accel_feed_forward_share(0.1 + 1e-9, 0.1, 0.3), 0.0, 1e-8);
  EXPECT_NEAR(accel_feed_forward_share(0.3 - 1e-9, 0.1, 0.3), 1.0, 1e-8);
  // A hard step when full equals the deadband.
  EXPECT_EQ(accel_feed_forward_share(0.2, 0.2, 0.2), 0.0);
  EXPECT_EQ(accel_feed_forward_share(0.2 + 1e-9, 0.2, 0.2), 1.0);
  // A non-finite magnitude feeds nothing forward.
  EXPECT_EQ(accel_feed_forward_share(std::numeric_limits<double>::quiet_NaN(), 0.1, 0.3), 0.0);
}

}  // namespace
}  // namespace lander::ctl
