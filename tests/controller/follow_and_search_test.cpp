// Observe follows a fast platform; search after a loss flies to the tracker's prediction;
// the final descent touches down softly. Closed loop on the rigid-body model of support/
// (perfect navigation, synthetic 30 Hz vision with noise and latency).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>

#include "support/hex_model.h"

namespace lander::ctl::test {
namespace {

// The cart speed of scenarios/cart_1mps_turning.yaml (m/s).
constexpr double kCartSpeed_mps = 1.0;
// Keeps observe from ever switching to approach, so the follow behaviour is tested alone.
constexpr int kNeverApproach = 1000000;
// Once caught up, observe keeps the vehicle this close to the platform (m): at 9 m above
// the top the view along body x reaches ~5 m; 0.5 m is a tenth of it, so the platform stays
// near the image centre (the old 1 m/s follow stayed ~4 m behind, at the edge).
constexpr double kObserveFollowError_m = 0.5;
// After 3 s of blind extrapolation at 1 m/s, search brings the vehicle within this distance
// of the platform (m): the velocity estimate from ~1 s of fixes is good to a few cm/s (a few
// tenths of a metre after 3 s) plus the lag of the position loop; holding position instead
// would leave it 3 m or more behind.
constexpr double kSearchPredictionError_m = 1.0;
// Horizontal speed below which the vehicle counts as holding position (m/s).
constexpr double kHoldSpeed_mps = 0.1;
// Relative speed at touchdown the team asked for (~0.3 m/s); the descent at
// descent_rate_final_mps (0.15 m/s) plus the fall from below cut_height_m (1 cm) with the
// rotors spinning down stays under it.
constexpr double kSoftTouchdown_mps = 0.4;

LandingRunConfig fast_cart_config() {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(0.0, 0.0, 0.8);
  cfg.platform.v_W_mps = Eigen::Vector3d(kCartSpeed_mps, 0.0, 0.0);
  // 4 m behind at 10 m: the platform starts inside the 29 deg half-angle along body x.
  cfg.start_W_m = Eigen::Vector3d(-4.0, 0.0, 10.0);
  cfg.controller.landing.observe_frames = kNeverApproach;
  return cfg;
}

double horizontal_distance(const HexModel& m, const PlatformTruth& plat, double t_s) {
  return (m.p - plat.p_W(t_s)).head<2>().norm();
}

TEST(ObserveFollow, KeepsUpWithAOneMetrePerSecondPlatform) {
  LandingRunConfig cfg = fast_cart_config();
  cfg.max_time_s = 16.0;
  double max_err_late = 0.0;
  double err_at_acq = -1.0;
  const PlatformTruth plat = cfg.platform;
  cfg.on_step = [&](double t, const HexModel& m, const LandingController& c) {
    if (err_at_acq < 0 && c.mode() == Mode::kObserve) err_at_acq = horizontal_distance(m, plat, t);
    if (t > 10.0) max_err_late = std::max(max_err_late, horizontal_distance(m, plat, t));
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe() << "distance at acquisition " << err_at_acq
            << " m, max distance after 10 s " << max_err_late << " m\n";
  ASSERT_FALSE(r.transitions.empty());
  EXPECT_EQ(r.transitions.front().to, Mode::kObserve);
  EXPECT_GT(err_at_acq, 3.0);  // the test starts far behind: there is something to catch up
  // Acquired once and never lost.
  EXPECT_EQ(r.transitions.size(), 1u);
  EXPECT_LT(max_err_late, kObserveFollowError_m);
}

TEST(SearchAfterLoss, FliesToThePredictedPlatformInsteadOfHolding) {
  LandingRunConfig cfg = fast_cart_config();
  cfg.max_time_s = 14.0;
  // Caught up by 10 s (test above); then blind for 4 s: observe declares the loss after
  // loss_timeout_s (1 s) and search has ~3 s to fly after the prediction.
  constexpr double kBlindFrom_s = 10.0;
  cfg.visible = [&](double t, const Eigen::Isometry3d&) { return t < kBlindFrom_s; };
  const PlatformTruth plat = cfg.platform;
  double err_end = std::numeric_limits<double>::infinity();
  double search_speed = 0.0;
  Mode mode_end = Mode::kObserve;
  cfg.on_step = [&](double t, const HexModel& m, const LandingController& c) {
    err_end = horizontal_distance(m, plat, t);
    search_speed = m.v.head<2>().norm();
    mode_end = c.mode();
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe() << "distance after 3 s of search " << err_end << " m, speed "
            << search_speed << " m/s\n";
  ASSERT_EQ(r.transitions.size(), 2u);
  EXPECT_EQ(r.transitions[1].from, Mode::kObserve);
  EXPECT_EQ(r.transitions[1].to, Mode::kSearch);
  EXPECT_NE(r.transitions[1].reason.find("lost"), std::string::npos);
  EXPECT_EQ(mode_end, Mode::kSearch);
  EXPECT_LT(err_end, kSearchPredictionError_m);
  // It moves with the predicted cart, it does not hold.
  EXPECT_NEAR(search_speed, kCartSpeed_mps, 0.3);
}

// search_predict_max_s after the last fix the history is dropped: the search pattern's
// centre stops moving with the predicted cart and stays where the prediction led (issue 10:
// it used to restart an in-place sweep there; the expanding pattern now goes on around it).
TEST(SearchAfterLoss, PatternCentreStopsOnceThePredictionIsTooOld) {
  LandingRunConfig cfg = fast_cart_config();
  cfg.controller.landing.search_predict_max_s = 2.0;
  cfg.max_time_s = 20.0;
  constexpr double kBlindFrom_s = 10.0;
  cfg.visible = [&](double t, const Eigen::Isometry3d&) { return t < kBlindFrom_s; };
  int fixes_end = -1;
  Eigen::Vector3d centre_11 = Eigen::Vector3d::Zero(), centre_115 = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre_13 = Eigen::Vector3d::Zero(), centre_end = Eigen::Vector3d::Zero();
  cfg.on_step = [&](double t, const HexModel&, const LandingController& c) {
    fixes_end = c.tracker().num_fixes();
    const Eigen::Vector3d centre = c.diagnostics().search_centre_W_m;
    if (t <= 11.2) centre_11 = centre;
    if (t <= 11.7) centre_115 = centre;
    if (t <= 13.0) centre_13 = centre;
    centre_end = centre;
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  ASSERT_EQ(r.transitions.size(), 2u);
  EXPECT_EQ(r.transitions[1].to, Mode::kSearch);
  // 2 s after the last fix (~10 s) the history is dropped.
  EXPECT_EQ(fixes_end, 0);
  // Before that the centre moves with the predicted cart (1 m/s: 0.5 m in 0.5 s; 0.1 m for
  // the velocity estimate and the 33 ms outer-loop steps) ...
  EXPECT_NEAR((centre_115 - centre_11).head<2>().norm(), 0.5 * kCartSpeed_mps, 0.1);
  // ... after it, it stays put (exactly: nothing moves it).
  EXPECT_EQ((centre_end - centre_13).head<2>().norm(), 0.0);
}

// With the pattern off (search_spiral_speed_mps = 0) the search holds over that centre.
TEST(SearchAfterLoss, HoldsOnceThePredictionIsTooOldWithoutPattern) {
  LandingRunConfig cfg = fast_cart_config();
  cfg.controller.landing.search_predict_max_s = 2.0;
  cfg.controller.landing.search_spiral_speed_mps = 0.0;
  cfg.max_time_s = 20.0;
  constexpr double kBlindFrom_s = 10.0;
  cfg.visible = [&](double t, const Eigen::Isometry3d&) { return t < kBlindFrom_s; };
  double speed_end = 1e9;
  int fixes_end = -1;
  cfg.on_step = [&](double, const HexModel& m, const LandingController& c) {
    speed_end = m.v.head<2>().norm();
    fixes_end = c.tracker().num_fixes();
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  // 2 s after the last detection the history is dropped; 8 s later the vehicle holds.
  EXPECT_EQ(fixes_end, 0);
  EXPECT_LT(speed_end, kHoldSpeed_mps);
}

TEST(SoftTouchdown, RelativeSpeedAtContactIsAboutAThirdOfAMetrePerSecond) {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(0.0, 0.0, 0.8);
  cfg.platform.v_W_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  cfg.start_W_m = Eigen::Vector3d(-5.0, 0.0, 10.0);
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  ASSERT_TRUE(r.contact);
  EXPECT_TRUE(r.on_platform);
  EXPECT_LT(r.touchdown_rel_speed_mps, kSoftTouchdown_mps);
}

}  // namespace
}  // namespace lander::ctl::test

namespace lander::ctl::test {
namespace {

// A platform standing 16 m from where the vehicle starts at 10 m is outside the view in
// every heading (the wide image axis reaches ~10 m). Sweeping the heading in place never
// finds it; the outward spiral that follows one full turn does.
TEST(Search, SpiralFindsAPlatformOutOfViewOfTheStart) {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(12.0, -10.5, 0.8);
  cfg.platform.v_W_mps.setZero();
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 10.0);
  cfg.controller.landing.observe_frames = kNeverApproach;
  cfg.max_time_s = 120.0;
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  ASSERT_FALSE(r.transitions.empty());
  EXPECT_EQ(r.transitions.front().to, Mode::kObserve);
  // Not during the in-place sweep: the spiral found it.
  EXPECT_GT(r.transitions.front().t_s, cfg.controller.landing.search_spiral_after_s);

  // The same without the spiral: never acquired, and the bounded search (issue 10) ends it
  // in aborted after search_give_up_s, with its reason, instead of searching until the time
  // runs out.
  LandingRunConfig hold = cfg;
  hold.controller.landing.search_spiral_speed_mps = 0.0;
  hold.max_time_s = 60.0;
  const LandingRunResult h = run_landing(hold);
  SCOPED_TRACE(h.describe());
  ASSERT_EQ(h.transitions.size(), 1u);
  EXPECT_EQ(h.transitions.front().to, Mode::kAborted);
  // One outer-loop period (30 Hz) of slack on when the limit is noticed.
  EXPECT_NEAR(h.transitions.front().t_s, hold.controller.landing.search_give_up_s, 0.05);
  EXPECT_NE(h.transitions.front().reason.find("target not found in"), std::string::npos);
}

// Angle of the line of sight from the vehicle to the platform centre off the platform normal
// (deg): the search tests veto vision beyond the estimator's limit at these ranges.
double view_angle_deg(const Eigen::Isometry3d& X_WB, const PlatformTruth& plat, double t_s) {
  const Eigen::Vector3d d = X_WB.translation() - plat.p_W(t_s);
  return std::atan2(d.head<2>().norm(), d.z()) * 180.0 / M_PI;
}

// The envelope's "target not found in 30 s of search" class (regression/envelope: starts
// 5-10 m beside the cart and 6-8 m high, the cart driving off at ~1 m/s): from a low start
// the wide image axis reaches ~6 m, and the heading sweep brings it round only after the cart
// has left that circle. Vision is vetoed beyond kMaxViewAngle_deg off the platform normal,
// the estimator's limit at these ranges (lander bench estimator: 45 deg views detected at
// 10-15 m, 60 deg not). Climbing from the search's start (search_first_climb_rate_mps)
// widens the view while the sweep turns and finds the cart; without it the search gives up.
TEST(Search, FirstClimbFindsACartDrivingAwayFromALowStart) {
  constexpr double kMaxViewAngle_deg = 50.0;
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(6.0, 0.0, 0.8);
  cfg.platform.v_W_mps = Eigen::Vector3d(0.9, 0.0, 0.0);
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 7.0);
  cfg.controller.landing.observe_frames = kNeverApproach;
  cfg.max_time_s = 35.0;
  const PlatformTruth plat = cfg.platform;
  cfg.visible = [plat, kMaxViewAngle_deg](double t, const Eigen::Isometry3d& X_WB) {
    return view_angle_deg(X_WB, plat, t) <= kMaxViewAngle_deg;
  };
  LandingRunConfig off = cfg;
  off.controller.landing.search_first_climb_rate_mps = 0.0;
  const LandingRunResult r0 = run_landing(off);
  SCOPED_TRACE(r0.describe());
  ASSERT_FALSE(r0.transitions.empty());
  EXPECT_EQ(r0.transitions.front().to, Mode::kAborted);

  LandingRunConfig on = cfg;
  on.controller.landing.search_first_climb_rate_mps = 1.0;
  double z_max = 0.0, z_sp_climbing = -1.0;
  constexpr double kClimbCheck_s = 1.5;  // in the climb, before the cart is found
  on.on_step = [&](double t, const HexModel& m, const LandingController& c) {
    if (c.mode() == Mode::kSearch) z_max = std::max(z_max, m.p.z());
    if (c.mode() == Mode::kSearch && t <= kClimbCheck_s) z_sp_climbing = c.diagnostics().setpoint.p_W_m.z();
  };
  const LandingRunResult r1 = run_landing(on);
  SCOPED_TRACE(r1.describe());
  std::cout << r1.describe() << "highest in search " << z_max << " m\n";
  ASSERT_FALSE(r1.transitions.empty());
  EXPECT_EQ(r1.transitions.front().to, Mode::kObserve);
  // Found during the first heading turn or soon after, not by the spiral's late climb.
  EXPECT_LT(r1.transitions.front().t_s, on.controller.landing.search_spiral_after_s + 2.0);
  // Never above search_max_height_m (over the ground before any fix: platform_z() is 0
  // then), with 0.3 m for the position loop's overshoot; and it did climb.
  EXPECT_LT(z_max, on.controller.landing.search_max_height_m + 0.3);
  EXPECT_GT(z_max, cfg.start_W_m.z() + 1.0);
  // The setpoint ramps at the configured rate after the 0.3 s delay (the mode machine runs at
  // 30 Hz: one period at 1 m/s is 3.3 cm of slack).
  EXPECT_NEAR(z_sp_climbing, cfg.start_W_m.z() + 1.0 * (kClimbCheck_s - 0.3), 0.035);
}

// A first fix during that climb that does not become an acquisition (fewer than
// reacquire_frames keyframes: the target at the view's edge) must not take the vehicle back
// down to where the search began while it flies to the fix: in far_start.yaml's runs the
// setpoint fell from 10 m to 6 m (once to 2.4 m) at such a fix, narrowing the view.
TEST(Search, FirstClimbKeepsItsHeightOverAFixNotYetAcquired) {
  constexpr double kMaxViewAngle_deg = 50.0;
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(9.0, 0.0, 0.8);  // 55 deg off the 7 m start
  cfg.platform.v_W_mps.setZero();
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 7.0);
  cfg.controller.landing.search_first_climb_rate_mps = 1.0;
  cfg.max_time_s = 25.0;
  const PlatformTruth plat = cfg.platform;
  const int allowed = cfg.controller.landing.reacquire_frames - 1;
  int seen = 0;
  double t_fix = -1.0;
  cfg.visible = [&](double t, const Eigen::Isometry3d& X_WB) {
    if (view_angle_deg(X_WB, plat, t) > kMaxViewAngle_deg) return false;
    if (seen >= allowed) return false;
    if (seen++ == 0) t_fix = t;
    return true;
  };
  double z_at_fix = -1.0, z_min_after = 1e9;
  cfg.on_step = [&](double t, const HexModel&, const LandingController& c) {
    if (c.mode() != Mode::kSearch || t_fix < 0.0) return;
    const double z = c.diagnostics().setpoint.p_W_m.z();
    if (z_at_fix < 0.0) z_at_fix = z;
    z_min_after = std::min(z_min_after, z);
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe() << "fix at " << t_fix << " s, setpoint height then " << z_at_fix
            << " m, lowest after " << z_min_after << " m\n";
  ASSERT_GT(t_fix, 0.0);
  EXPECT_TRUE(r.transitions.empty());  // never acquired: the search goes on
  EXPECT_GT(z_at_fix, cfg.start_W_m.z() + 1.0);  // the fix came during the climb
  // Never lower than where the fix found it (the climb setpoint is a ramp: no slack needed).
  EXPECT_GE(z_min_after, z_at_fix);
}

// A platform that is never in view: the search gives up after search_give_up_s, also when
// that is set shorter; the decision log records the abort.
TEST(Search, GivesUpAfterTheConfiguredTime) {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(200.0, 0.0, 0.8);  // far beyond any view
  cfg.platform.v_W_mps.setZero();
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 8.0);
  cfg.controller.landing.search_give_up_s = 12.0;
  cfg.max_time_s = 40.0;
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  ASSERT_EQ(r.transitions.size(), 1u);
  EXPECT_EQ(r.transitions.front().from, Mode::kSearch);
  EXPECT_EQ(r.transitions.front().to, Mode::kAborted);
  EXPECT_NEAR(r.transitions.front().t_s, 12.0, 0.05);
  EXPECT_FALSE(r.contact);
}

}  // namespace
}  // namespace lander::ctl::test

// The platform's broadcast position (its own GNSS fix over a radio link, issue 10's first
// search): without a fix of the target, the search flies to it instead of sweeping around the
// vehicle's start.
namespace lander::ctl::test {
namespace {

// The broadcast as scenarios' sensors.platform_telemetry delivers it: 5 Hz, received 0.25 s
// after its sampling time, with a position error of the size of two GNSS receivers' relative
// error (~1 m: sqrt(2) x 0.7 m).
constexpr double kBroadcastRate_hz = 5.0;
constexpr double kBroadcastLatency_s = 0.25;
const Eigen::Vector3d kBroadcastError_W_m(0.8, -0.6, 0.5);

// Feeds the broadcast of `plat` into the controller (sampled every 1/rate, delivered after
// the latency) with the constant error above; `stamp_age_s` makes every message that much
// older than it really is (a stale link).
std::function<void(double, const HexModel&, LandingController&)> broadcast_feed(
    const PlatformTruth& plat, double stamp_age_s = 0.0) {
  auto next = std::make_shared<double>(kBroadcastLatency_s);
  return [plat, stamp_age_s, next](double t, const HexModel&, LandingController& c) {
    if (t + 1e-9 < *next) return;
    *next += 1.0 / kBroadcastRate_hz;
    const double t_sample = t - kBroadcastLatency_s;
    GpsSample g;
    g.t_s = t_sample - stamp_age_s;
    g.p_W_m = plat.p_W(t_sample) + kBroadcastError_W_m;
    g.v_W_mps = plat.v_W(t_sample);
    c.on_platform_telemetry(g);
  };
}

// The envelope's "low start, cart driving away" failure: a 1 m/s cart 14 m away (12 m ahead,
// 8 m beside), outside the view of a vehicle 6 m up, driving away.
LandingRunConfig driving_away_config() {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(12.0, 8.0, 0.8);
  cfg.platform.v_W_mps = Eigen::Vector3d(kCartSpeed_mps, 0.0, 0.0);
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 6.0);
  cfg.controller.landing.observe_frames = kNeverApproach;
  cfg.max_time_s = 35.0;
  return cfg;
}

// Flying to the broadcast closes the 14 m at observe's catch-up speed, 2 m/s relative to the
// cart (~7 s), after its 1 m/s^2 acceleration (~1 s more), and the view reaches ~3 m ahead:
// acquired by ~8 s, well before the sweep-and-spiral search, which does not find this cart in
// its 30 s at all (checked below). 12 s leaves room for the broadcast's 1 m error.
constexpr double kBroadcastAcquisitionBound_s = 12.0;

TEST(SearchWithBroadcast, FliesToTheBroadcastPositionAndFindsTheCart) {
  LandingRunConfig cfg = driving_away_config();
  cfg.feed = broadcast_feed(cfg.platform);
  long received = 0, search_steps = 0;
  cfg.on_step = [&](double, const HexModel&, const LandingController& c) {
    received = c.telemetry_received();
    search_steps = c.telemetry_search_steps();
  };
  const LandingRunResult r = run_landing(cfg);
  SCOPED_TRACE(r.describe());
  std::cout << r.describe();
  ASSERT_FALSE(r.transitions.empty());
  EXPECT_EQ(r.transitions.front().to, Mode::kObserve);
  EXPECT_LT(r.transitions.front().t_s, kBroadcastAcquisitionBound_s);
  EXPECT_GT(received, 0);
  EXPECT_GT(search_steps, 0);

  // Without the broadcast: the sweep and the spiral around the start never see it.
  LandingRunConfig none = driving_away_config();
  const LandingRunResult n = run_landing(none);
  SCOPED_TRACE(n.describe());
  ASSERT_EQ(n.transitions.size(), 1u);
  EXPECT_EQ(n.transitions.front().to, Mode::kAborted);
  EXPECT_NE(n.transitions.front().reason.find("target not found in"), std::string::npos);
}

// The fused altitude of the model's vehicle over the ground (z = 0), with the height above
// the surface believed `offset_m` higher than it is (0: exact).
AltitudeEstimate altitude_over_ground(double t, const HexModel& m, double offset_m = 0.0) {
  AltitudeEstimate a;
  a.t_s = t;
  a.valid = true;
  a.z_W_m = m.p.z();
  a.vz_W_mps = m.v.z();
  a.h_surface_m = m.p.z() + offset_m;
  return a;
}

// A search that began low (2.5 m: a low start, or search_min_height_m) climbs to
// telemetry_search_height_m above the surface (the fused altitude's, here the truth's) while it
// flies to the broadcast, so that the view covers the broadcast's error.
TEST(SearchWithBroadcast, ClimbsToTheBroadcastSearchHeight) {
  LandingRunConfig cfg = driving_away_config();
  cfg.start_W_m.z() = 2.5;
  cfg.max_time_s = 5.0;  // still in transit: the cart is ~14 m away
  const auto broadcast = broadcast_feed(cfg.platform);
  cfg.feed = [&](double t, const HexModel& m, LandingController& c) {
    broadcast(t, m, c);
    c.on_altitude(altitude_over_ground(t, m));
  };
  double z_end = 0.0;
  Mode mode_end = Mode::kObserve;
  cfg.on_step = [&](double, const HexModel& m, const LandingController& c) {
    z_end = m.p.z();
    mode_end = c.mode();
  };
  run_landing(cfg);
  EXPECT_EQ(mode_end, Mode::kSearch);
  // 3.5 m of climb at up to max_vel_up_mps (2 m/s) in 5 s: there, within the height loop's
  // settling (0.3 m).
  EXPECT_NEAR(z_end, cfg.controller.landing.telemetry_search_height_m, 0.3);
}

// A fast platform (issue 56): 5 m/s along +x, turning left onto a 20 m arc at kTurnAt_s;
// seen only until kTurnAt_s - 0.5 s, so the tracker's prediction after the loss runs on
// straight while the platform turns away.
constexpr double kFastSpeed_mps = 5.0;
constexpr double kFastArc_m = 20.0;
constexpr double kTurnAt_s = 2.0;
Eigen::Vector3d straight_then_arc(double t) {
  if (t <= kTurnAt_s) return Eigen::Vector3d(kFastSpeed_mps * t, 0.0, 0.8);
  const double th = kFastSpeed_mps * (t - kTurnAt_s) / kFastArc_m;
  return Eigen::Vector3d(kFastSpeed_mps * kTurnAt_s + kFastArc_m * std::sin(th), kFastArc_m * (1.0 - std::cos(th)),
                         0.8);
}

// The search's centre relative to the platform 6 s after it turned (the search after the
// loss, flying to its centre), with the broadcast on; telemetry_override_m as given.
double centre_error_after_turn(double override_m, long* broadcast_steps) {
  LandingRunConfig cfg;
  cfg.platform.path = straight_then_arc;
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, 10.0);
  cfg.controller.landing.observe_frames = kNeverApproach;
  cfg.controller.landing.telemetry_override_m = override_m;
  cfg.max_time_s = kTurnAt_s + 6.0;
  cfg.visible = [](double t, const Eigen::Isometry3d&) { return t < kTurnAt_s - 0.5; };
  cfg.feed = broadcast_feed(cfg.platform);
  double err = 0.0;
  const PlatformTruth plat = cfg.platform;
  cfg.on_step = [&](double t, const HexModel&, const LandingController& c) {
    err = (c.diagnostics().search_centre_W_m - plat.p_W(t)).head<2>().norm();
    *broadcast_steps = c.telemetry_search_steps();
  };
  run_landing(cfg);
  return err;
}

// The prediction from 1.5 s of a straight 5 m/s platform runs straight on while the platform
// turns 1.5 rad onto its arc, ~13 m to the side after 6 s. Beyond telemetry_override_m (6 m)
// from the broadcast position the search's centre is the broadcast's: within its error (1 m)
// and its latency's extrapolation along the arc (kArcExtrapolation_m); held to the
// prediction (override at 1 km) it is off by more than the override distance.
constexpr double kArcExtrapolation_m = 0.2;  // 0.5 x 1.25 m/s^2 x (0.45 s)^2, rounded up
TEST(SearchWithBroadcast, APredictionFarFromTheBroadcastGivesWayToIt) {
  long steps_override = 0, steps_kept = 0;
  const double with_override = centre_error_after_turn(6.0, &steps_override);
  const double kept = centre_error_after_turn(1000.0, &steps_kept);
  std::cout << "6 s after the turn the search centre is " << with_override << " m from the platform with the "
            << "override, " << kept << " m on the prediction\n";
  EXPECT_LT(with_override, kBroadcastError_W_m.head<2>().norm() + kArcExtrapolation_m);
  EXPECT_GT(steps_override, 0);
  EXPECT_GT(kept, 6.0);
  EXPECT_EQ(steps_kept, 0);
}

// A broadcast older than telemetry_max_age_s is not flown to: the search sweeps in place
// (as without one) for search_spiral_after_s; a message without a fix (valid = false) is
// ignored and one with a non-finite position is dropped and counted.
TEST(SearchWithBroadcast, StaleNoFixAndNonFiniteMessagesAreNotUsed) {
  LandingRunConfig cfg = driving_away_config();
  cfg.max_time_s = 6.0;  // inside the in-place sweep (search_spiral_after_s = 8 s)
  cfg.feed = broadcast_feed(cfg.platform, cfg.controller.landing.telemetry_max_age_s + 0.5);
  Eigen::Vector3d p_end = Eigen::Vector3d::Zero();
  long steps = -1;
  cfg.on_step = [&](double, const HexModel& m, const LandingController& c) {
    p_end = m.p;
    steps = c.telemetry_search_steps();
  };
  run_landing(cfg);
  EXPECT_EQ(steps, 0);
  // Holding at the start (the sweep turns the heading only): within the position loop's
  // hover wander, far from the 14 m towards the cart.
  EXPECT_LT((p_end - cfg.start_W_m).head<2>().norm(), 0.3);

  LandingController c(ControllerParams{}, CameraMount{});
  GpsSample no_fix;
  no_fix.t_s = 1.0;
  no_fix.valid = false;
  c.on_platform_telemetry(no_fix);
  EXPECT_EQ(c.telemetry_received(), 0);
  EXPECT_EQ(c.rejected_inputs(), 0);
  GpsSample bad;
  bad.t_s = 1.0;
  bad.p_W_m.x() = std::numeric_limits<double>::quiet_NaN();
  c.on_platform_telemetry(bad);
  EXPECT_EQ(c.telemetry_received(), 0);
  EXPECT_EQ(c.rejected_inputs(), 1);
  GpsSample good;
  good.t_s = 2.0;
  c.on_platform_telemetry(good);
  GpsSample older = good;
  older.t_s = 1.5;  // out of order: the newer is kept
  c.on_platform_telemetry(older);
  EXPECT_EQ(c.telemetry_received(), 1);
}

}  // namespace
}  // namespace lander::ctl::test

// The search's minimum height is kept every step, by the fused height and by the ultrasonic's
// own clearance (a far-start campaign run held its search 1 m over the ground while its
// fused height, wrong by metres, said 4.5 m; another started its search at a believed 0 m).
namespace lander::ctl::test {
namespace {

// A platform far out of view: the search holds and sweeps; the altitude fed is `believed`
// metres over the ground for a vehicle truly at m.p.z(), with the ultrasonic's clearance
// (the truth) or none.
struct FloorRun {
  double z_end_m{0.0};
  int low_clearance_events{0};
};
FloorRun search_floor_run(double start_z_m, double believed_offset_m, bool clearance) {
  LandingRunConfig cfg;
  cfg.platform.p0_W_m = Eigen::Vector3d(200.0, 0.0, 0.8);
  cfg.platform.v_W_mps.setZero();
  cfg.start_W_m = Eigen::Vector3d(0.0, 0.0, start_z_m);
  cfg.max_time_s = 6.0;  // inside the in-place sweep (search_spiral_after_s = 8 s)
  // The floor alone: the first search's climb (on by default) would lift every run anyway.
  cfg.controller.landing.search_first_climb_rate_mps = 0.0;
  cfg.feed = [=](double t, const HexModel& m, LandingController& c) {
    AltitudeEstimate a = altitude_over_ground(t, m, believed_offset_m);
    if (clearance) a.clearance_m = m.p.z();  // the truth
    c.on_altitude(a);
  };
  FloorRun out;
  cfg.on_step = [&](double, const HexModel& m, const LandingController& c) {
    out.z_end_m = m.p.z();
    out.low_clearance_events = 0;
    for (const LandingEvent& e : c.decision_log().events) {
      out.low_clearance_events += e.what == "low_clearance";
    }
  };
  const LandingRunResult r = run_landing(cfg);
  EXPECT_FALSE(r.contact);
  return out;
}

// The height loop's settling after a climb of a metre or two in 6 s (the same band as the
// broadcast search's climb above).
constexpr double kFloorSettle_m = 0.3;

TEST(SearchFloor, TheUltrasonicsClearanceLiftsASearchHeldLowByAHeightThatIsWrong) {
  const double min_h = ControllerParams{}.landing.search_min_height_m;
  // Truly 1.2 m up, believed 4.5 m: with the clearance, up to search_min_height_m, once
  // logged; without it (the fusion alone), held at 1.2 m.
  const FloorRun with = search_floor_run(1.2, 3.3, true);
  EXPECT_NEAR(with.z_end_m, min_h, kFloorSettle_m);
  EXPECT_EQ(with.low_clearance_events, 1);
  const FloorRun without = search_floor_run(1.2, 3.3, false);
  EXPECT_NEAR(without.z_end_m, 1.2, kFloorSettle_m);
  EXPECT_EQ(without.low_clearance_events, 0);
  // High enough by both: nothing happens.
  const FloorRun high = search_floor_run(5.0, 0.0, true);
  EXPECT_NEAR(high.z_end_m, 5.0, kFloorSettle_m);
  EXPECT_EQ(high.low_clearance_events, 0);
}

// The first search (entered at start, not by a transition) takes the floor of the fused
// height too: believed 0.5 m over the ground at a true 6 m, it climbs search_min_height_m -
// 0.5 m. No event: it is the fused height that asks for it.
TEST(SearchFloor, TheFirstSearchKeepsTheFusedMinimumHeight) {
  const double min_h = ControllerParams{}.landing.search_min_height_m;
  const FloorRun r = search_floor_run(6.0, 0.5 - 6.0, false);
  EXPECT_NEAR(r.z_end_m, 6.0 + (min_h - 0.5), kFloorSettle_m);
  EXPECT_EQ(r.low_clearance_events, 0);
}

}  // namespace
}  // namespace lander::ctl::test
