// Full closed-loop landing in the simple rigid-body model (tests/controller/support):
// perfect navigation state, synthetic 30 Hz vision with noise and latency, platform moving
// at 0.5 m/s. A controller unit test, not the product's integration test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <optional>
#include <random>

#include "../../controller/src/modes/recovery_decisions.h"
#include "support/hex_model.h"

namespace lander::ctl::test {
namespace {

// Issue 5: the default scenario must land within 5 cm of the platform centre.
constexpr double kMaxTouchdownOffset_m = 0.05;
// A touchdown faster than this would bounce off a cart top; the cut height of 10 cm gives
// sqrt(2 g 0.1) = 1.4 m/s at most, so a proper cut stays well below.
constexpr double kMaxTouchdownRelSpeed_mps = 1.5;
// Landing gear tolerates a few degrees of tilt at contact.
constexpr double kMaxTouchdownTilt_deg = 5.0;
// Attitude never exceeds the cascade's tilt limit (30 deg) by more than the overshoot of the
// attitude loop.
constexpr double kMaxFlightTilt_deg = 35.0;

LandingRunConfig moving_platform_config() {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(0.0, 0.0, 0.8);
  cfg.platform.v_W_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  cfg.start_W_m = Eigen::Vector3d(-5.0, 0.0, 10.0);
  return cfg;
}

TEST(ClosedLoopLanding, LandsOnPlatformMovingAtHalfMetrePerSecondWithin5cm) {
  const LandingRunResult r = run_landing(moving_platform_config());
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  ASSERT_TRUE(r.contact);
  EXPECT_TRUE(r.on_platform);
  EXPECT_TRUE(r.landed) << "controller did not report contact";
  EXPECT_LT(r.touchdown_offset_m, kMaxTouchdownOffset_m);
  EXPECT_LT(r.touchdown_rel_speed_mps, kMaxTouchdownRelSpeed_mps);
  EXPECT_LT(r.touchdown_tilt_deg, kMaxTouchdownTilt_deg);
  EXPECT_LT(r.max_tilt_deg, kMaxFlightTilt_deg);
  // The paper's order of modes, without detours.
  std::vector<Mode> seen;
  for (const ModeTransition& tr : r.transitions) seen.push_back(tr.to);
  const std::vector<Mode> expected = {Mode::kObserve, Mode::kApproach, Mode::kRecovery,
                                      Mode::kTouchdown, Mode::kLanded};
  EXPECT_EQ(seen, expected);
}

TEST(ClosedLoopLanding, LandsOnStaticPlatformWithin5cm) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.platform.v_W_mps.setZero();
  cfg.start_W_m = Eigen::Vector3d(-3.0, 2.0, 10.0);
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  ASSERT_TRUE(r.contact);
  EXPECT_TRUE(r.on_platform);
  EXPECT_TRUE(r.landed);
  EXPECT_LT(r.touchdown_offset_m, kMaxTouchdownOffset_m);
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

// The bound for the scenarios other than default and static.
constexpr double kHardScenarioOffset_m = 0.10;

// Runs cfg and checks contact on the platform, the controller's contact report and the offset.
void expect_lands(const LandingRunConfig& cfg, double max_offset_m) {
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  ASSERT_TRUE(r.contact);
  EXPECT_TRUE(r.on_platform);
  EXPECT_TRUE(r.landed);
  EXPECT_LT(r.touchdown_offset_m, max_offset_m);
  EXPECT_LT(r.touchdown_tilt_deg, kMaxTouchdownTilt_deg);
  for (const ModeTransition& tr : r.transitions) EXPECT_NE(tr.to, Mode::kGoAround) << tr.reason;
}

TEST(ClosedLoopLanding, CartAtOneMetrePerSecondOnAnArc) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  // Starts at the origin heading +x, turns left on a 10 m radius at 1 m/s.
  cfg.platform.path = [](double t) {
    const double R = 10.0, th = 1.0 * t / R;
    return Eigen::Vector3d(R * std::sin(th), R * (1.0 - std::cos(th)), 0.8);
  };
  expect_lands(cfg, kHardScenarioOffset_m);
}

// A person pulling a cart along +x: accelerate at a to v, cruise `go` s, brake at a, stop
// `stop` s, and again.
std::function<Eigen::Vector3d(double)> stop_and_go_path(double v, double a, double go, double stop) {
  return [=](double t) {
    const double ta = v / a, cycle = 2 * ta + go + stop, per_cycle = v * ta + v * go;
    const double n = std::floor(t / cycle), tau = t - n * cycle;
    double s;
    if (tau < ta) {
      s = 0.5 * a * tau * tau;
    } else if (tau < ta + go) {
      s = 0.5 * v * ta + v * (tau - ta);
    } else if (tau < 2 * ta + go) {
      const double u = tau - ta - go;
      s = 0.5 * v * ta + v * go + v * u - 0.5 * a * u * u;
    } else {
      s = per_cycle;
    }
    return Eigen::Vector3d(n * per_cycle + s, 0.0, 0.8);
  };
}

TEST(ClosedLoopLanding, StopAndGoCart) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  cfg.platform.path = stop_and_go_path(0.8, 0.6, 4.0, 2.0);
  expect_lands(cfg, kHardScenarioOffset_m);
}

// The platform's acceleration fed forward in recovery (platform_accel_ff_gain 1, the default
// since 2026-11-28; since 2026-11-29 nothing of it below 0.1 m/s^2 and all from 0.3 m/s^2 on,
// where a 0.2 m/s^2 soft deadband took 0.2 off every start and stop): behind a 1.2 m/s stop-and-go
// cart (0.6 m/s^2 starts and stops, as the plant's stop_and_go profile) the vehicle's velocity no
// longer trails the cart's by the velocity loop's lag at every start and stop. Measured in
// this model (its seed-7 vision, 60 ms latency): the true horizontal error in recovery's
// final metre has an RMS of 13.0 cm without the feed-forward and 7.5 cm with it (ratio 0.58;
// the entry transient, alike both ways, is in both), and the cut comes 8.9 s into recovery
// instead of 26.8 s (ratio 0.33; without it a wide commit 8.2 cm off, with it 2.1 cm). With
// the ramp from 0.1 to 0.3 m/s^2 and the servo integral held while the cart accelerates
// (2026-11-29): 11.6 cm without, 5.6 cm with (ratio 0.48), the cut 22.6 s and 8.0 s into
// recovery (ratio 0.35). With the approach flown in the platform's frame and the speed
// limits from the vehicle model (issue 56, 2026-12-03) the flight without the feed-forward
// enters recovery 2-4 cm behind the cart and cuts sooner: 12.3 cm without, 5.1 cm with
// (ratio 0.41), the cut 13.8 s and 8.4 s into recovery (5.4 s saved). The error bound sits
// between the ratios and 1 (a feed-forward that does not act) with room; the recovery bound
// asks for 3 s of the 5.4 s saved.
constexpr double kFeedForwardErrorRatio = 0.75;
constexpr double kFeedForwardRecoverySaving_s = 3.0;
// Below this gear clearance the error is the landing's (recovery's final metre).
constexpr double kFinalMetre_m = 1.0;

// Behind a 1.2 m/s stop-and-go cart (0.6 m/s^2 starts and stops, 3 s going, 2 s standing),
// the vehicle 3 m behind and 6 m up: the cart of the feed-forward and servo-integral tests.
LandingRunConfig stop_and_go_recovery_config() {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-3.0, 0.0, 6.0);
  cfg.platform.path = stop_and_go_path(1.2, 0.6, 3.0, 2.0);
  return cfg;
}

TEST(ClosedLoopLanding, AccelerationFeedForwardClosesTheErrorBehindAStopAndGoCart) {
  struct Flight {
    double rms_m{std::nan("")}, recovery_s{std::nan("")};
    LandingRunResult r;
  };
  auto fly = [](std::optional<double> gain) {
    LandingRunConfig cfg = stop_and_go_recovery_config();
    if (gain) cfg.controller.landing.platform_accel_ff_gain = *gain;  // else the default
    double sum = 0.0;
    int n = 0;
    cfg.on_step = [&](double t, const HexModel& m, const LandingController& c) {
      if (c.mode() != Mode::kRecovery) return;
      const Eigen::Vector3d p_plat = cfg.platform.p_W(t);
      if (m.p.z() - p_plat.z() - m.params().gear_height_m > kFinalMetre_m) return;
      sum += (m.p - p_plat).head<2>().squaredNorm();
      ++n;
    };
    Flight f;
    f.r = run_landing(cfg);
    if (n > 0) f.rms_m = std::sqrt(sum / n);
    double t_rec = std::nan(""), t_cut = std::nan("");
    for (const ModeTransition& tr : f.r.transitions) {
      if (tr.to == Mode::kRecovery && std::isnan(t_rec)) t_rec = tr.t_s;
      if (tr.to == Mode::kTouchdown) t_cut = tr.t_s;
    }
    f.recovery_s = t_cut - t_rec;
    return f;
  };
  const Flight off = fly(0.0), on = fly(std::nullopt);
  const std::string both = off.r.describe() + on.r.describe();
  ASSERT_TRUE(std::isfinite(off.rms_m) && std::isfinite(on.rms_m)) << both;
  ASSERT_TRUE(std::isfinite(off.recovery_s) && std::isfinite(on.recovery_s)) << both;
  std::printf("final-metre error RMS off %.1f cm, on %.1f cm; cut %.1f s / %.1f s into recovery\n",
              100.0 * off.rms_m, 100.0 * on.rms_m, off.recovery_s, on.recovery_s);
  EXPECT_LT(on.rms_m, kFeedForwardErrorRatio * off.rms_m) << both;
  EXPECT_LT(on.recovery_s, off.recovery_s - kFeedForwardRecoverySaving_s) << both;
  EXPECT_TRUE(on.r.landed) << both;
  EXPECT_LT(on.r.touchdown_offset_m, kHardScenarioOffset_m) << both;
}

// The visual servo's integral learns only while the platform is not speeding up or braking
// (servo_int_max_platform_accel_mps2, 0.2 m/s^2 by default since 2026-11-29): a stop-and-go
// cart's start put 15 cm of transient error into it, which it then held as a bias of a few
// centimetres for its 5 s time constant (1 / servo_ki), through the next stop. Behind the
// same 1.2 m/s stop-and-go cart as above, the integral is read from each recovery step as
// the setpoint's offset from the platform (while the carrot does not clamp it): it must stay
// exactly as it was over every step whose tracked acceleration is above the limit, and move
// over others. With the limit beyond any acceleration it moves in those steps too.
struct IntegralSteps {
  int held_steps{0}, held_moved{0}, learning_moved{0};
  LandingRunResult r;
};

IntegralSteps integral_steps(double limit_mps2) {
  LandingRunConfig cfg = stop_and_go_recovery_config();
  cfg.controller.landing.servo_int_max_platform_accel_mps2 = limit_mps2;
  const double hold_limit = LandingParams{}.servo_int_max_platform_accel_mps2;
  const double carrot = cfg.controller.landing.recovery_max_carrot_m;
  IntegralSteps out;
  std::optional<Eigen::Vector2d> prev;
  cfg.on_step = [&](double, const HexModel& m, const LandingController& c) {
    const LandingDiagnostics& d = c.diagnostics();
    const Eigen::Vector2d sp = d.setpoint.p_W_m.head<2>();
    if (c.mode() != Mode::kRecovery || (sp - m.p.head<2>()).norm() > carrot - 0.01) {
      prev.reset();  // the carrot may clamp (its reference is the navigation, not the truth)
      return;
    }
    const Eigen::Vector2d integral = sp - d.platform_W_m.head<2>();
    if (prev) {
      // 1e-9 m: the setpoint and the platform are sums of metres, the difference round-off.
      const bool moved = (integral - *prev).norm() > 1e-9;
      // Held on the acceleration along the cart's travel (a straight cart: all of it).
      if (modes::along_track_accel_mps2(d.platform_v_W_mps.head<2>(), c.tracker().acceleration().head<2>()) >=
          hold_limit) {
        ++out.held_steps;
        out.held_moved += moved;
      } else {
        out.learning_moved += moved;
      }
    }
    prev = integral;
  };
  out.r = run_landing(cfg);
  return out;
}

TEST(ClosedLoopLanding, ServoIntegralHeldWhileTheCartAccelerates) {
  const IntegralSteps held = integral_steps(LandingParams{}.servo_int_max_platform_accel_mps2);
  const IntegralSteps always = integral_steps(1e9);
  const std::string both = held.r.describe() + always.r.describe();
  std::printf(
      "steps above the limit: %d (integral moved in %d), below it moved in %d; "
      "learning always: %d above (moved in %d)\n",
      held.held_steps, held.held_moved, held.learning_moved, always.held_steps, always.held_moved);
  // Enough of both kinds for the check to mean something (a 1.2 m/s cart starts and stops
  // a few times while recovery descends its last metre).
  ASSERT_GT(held.held_steps, 30) << both;
  EXPECT_GT(held.learning_moved, 30) << both;
  EXPECT_EQ(held.held_moved, 0) << both;
  EXPECT_GT(always.held_moved, 30) << both;
  EXPECT_TRUE(held.r.landed) << both;
  EXPECT_LT(held.r.touchdown_offset_m, kHardScenarioOffset_m) << both;
}

TEST(ClosedLoopLanding, WindWithGusts) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  cfg.model.wind_W_mps = Eigen::Vector3d(0.0, 4.0, 0.0);  // 4 m/s cross wind
  cfg.model.gust_amplitude_mps = 2.0;                     // +-2 m/s gusts, 4 s period
  expect_lands(cfg, kHardScenarioOffset_m);
}

TEST(ClosedLoopLanding, SlowNoisyVision) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  cfg.vision.latency_s = 0.12;       // a slow estimator
  cfg.vision.pos_noise_per_m = 0.006;
  cfg.vision.rot_noise_deg = 0.6;
  expect_lands(cfg, kHardScenarioOffset_m);
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

TEST(ClosedLoopLanding, NoisyNavigationState) {
  LandingRunConfig cfg = moving_platform_config();
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  // A GPS/INS-grade navigation solution: wandering position bias, white noise on everything.
  cfg.nav_noise.pos_walk_m_per_sqrt_s = 0.02;
  cfg.nav_noise.pos_white_m = 0.01;
  cfg.nav_noise.vel_white_mps = 0.03;
  cfg.nav_noise.att_white_deg = 0.2;
  cfg.nav_noise.gyro_white_radps = 0.005;
  expect_lands(cfg, kHardScenarioOffset_m);
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

TEST(ClosedLoopLanding, DefaultScenarioLandsWithin5cmForTwentyNoiseSeeds) {
  // Monte Carlo over the vision and navigation noise: not one lucky seed.
  int landed = 0;
  double worst = 0.0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    LandingRunConfig cfg = moving_platform_config();
    cfg.vision.seed = seed;
    cfg.nav_noise.seed = 100 + seed;
    cfg.nav_noise.pos_white_m = 0.005;
    cfg.nav_noise.att_white_deg = 0.1;
    const LandingRunResult r = run_landing(cfg);
    SCOPED_TRACE("seed " + std::to_string(seed) + "\n" + r.describe());
    EXPECT_TRUE(r.landed && r.on_platform);
    EXPECT_LT(r.touchdown_offset_m, kMaxTouchdownOffset_m);
    if (r.landed && r.on_platform) ++landed;
    worst = std::max(worst, r.touchdown_offset_m);
  }
  std::cout << "landed " << landed << "/20, worst offset " << worst << " m\n";
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

TEST(ClosedLoopLanding, IntermittentVisionCloseToThePlatform) {
  // As the first runs of the real estimator showed: detections become sparse when the camera
  // is close to the target (65 % of frames at 1.2-1.8 m, 20 % below 1.2 m camera height).
  LandingRunConfig cfg = moving_platform_config();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  cfg.visible = [&](double, const Eigen::Isometry3d& X_WB) {
    const double cam_h = X_WB.translation().z() - 0.08 - cfg.platform.p0_W_m.z();
    const double p = cam_h < 1.2 ? 0.2 : (cam_h < 1.8 ? 0.65 : 1.0);
    return u01(rng) < p;
  };
  expect_lands(cfg, kMaxTouchdownOffset_m);
}

}  // namespace
}  // namespace lander::ctl::test
