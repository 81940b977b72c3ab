// Controller params: default valid, load(save(x)) == x, a bad value names its field
// (STYLE.md 3).
#include "lander/controller/params.h"

#include <gtest/gtest.h>

#include <string>

#include "common/config_error_checks.h"

namespace lander::ctl {
namespace {

using lander::test::expect_config_error;

TEST(ControllerParams, DefaultIsValid) {
  EXPECT_NO_THROW(ControllerParams{}.validate());
  EXPECT_NO_THROW(VehicleParams{}.validate());
  EXPECT_NO_THROW(CascadeParams{}.validate());
  EXPECT_NO_THROW(TrackerParams{}.validate());
  EXPECT_NO_THROW(LandingParams{}.validate());
}

TEST(ControllerParams, DefaultsCarryThePaperFiguresAndVehicleFacts) {
  const ControllerParams p;
  EXPECT_EQ(p.landing.observe_frames, 80);             // seed 000 section 3.2
  EXPECT_DOUBLE_EQ(p.landing.approach_epsilon_m, 1.5); // seed 000 eq. 28
  EXPECT_DOUBLE_EQ(p.landing.approach_switch_error_m, 0.05);
  EXPECT_DOUBLE_EQ(p.landing.touchdown_error_m, 0.05); // seed 000 section 3.3
  EXPECT_EQ(p.tracker.poly_order, 4);                  // seed 000 eq. 25-27
  EXPECT_DOUBLE_EQ(p.vehicle.mass_kg, 4.0);
  EXPECT_DOUBLE_EQ(p.vehicle.k_thrust, 2.05e-5);
}

TEST(ControllerParams, SaveLoadRoundTrip) {
  ControllerParams p;
  p.vehicle.mass_kg = 4.3;
  p.vehicle.inertia_kgm2 = Eigen::Vector3d(0.1, 0.11, 0.17);
  p.cascade.max_tilt_deg = 25.0;
  p.tracker.poly_order = 3;
  p.landing.observe_frames = 60;
  p.landing.search_yaw_rate_degps = 0.0;
  const YAML::Node saved = params_to_yaml(p);
  ControllerParams q;
  read_params(saved, "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(saved));
  EXPECT_DOUBLE_EQ(q.vehicle.mass_kg, 4.3);
  EXPECT_EQ(q.vehicle.inertia_kgm2, p.vehicle.inertia_kgm2);
  EXPECT_EQ(q.tracker.poly_order, 3);
  EXPECT_EQ(q.landing.observe_frames, 60);
}

TEST(ControllerParams, PartialYamlAppliesOnlyTheKeysPresent) {
  ControllerParams p;
  read_params(YAML::Load("landing: {observe_frames: 40}\ncascade: {pos_kp_xy: 0.8}"), "<inline>",
              p);
  EXPECT_EQ(p.landing.observe_frames, 40);
  EXPECT_DOUBLE_EQ(p.cascade.pos_kp_xy, 0.8);
  EXPECT_DOUBLE_EQ(p.landing.approach_epsilon_m, 1.5);  // untouched default
}

TEST(ControllerParams, BadValueThrowsNamingTheField) {
  ControllerParams p;
  p.vehicle.mass_kg = -1.0;
  expect_config_error([&] { p.validate(); }, {"vehicle", "mass_kg"});

  ControllerParams q;
  q.cascade.max_tilt_deg = 95.0;
  expect_config_error([&] { q.validate(); }, {"cascade", "max_tilt_deg"});

  ControllerParams r;
  r.landing.observe_frames = 0;
  expect_config_error([&] { r.validate(); }, {"landing", "observe_frames"});

  ControllerParams s;
  s.tracker.poly_order = 9;
  expect_config_error([&] { s.validate(); }, {"tracker", "poly_order"});

  // Through YAML: the reader validates after applying the keys.
  ControllerParams y;
  expect_config_error(
      [&] { read_params(YAML::Load("landing: {descent_rate_mps: -0.5}"), "<inline>", y); },
      {"descent_rate_mps"});
}

// Issue 10's parameters: each bad value names its field.
TEST(ControllerParams, DecisionAndDisturbanceParamsAreChecked) {
  ControllerParams a;
  a.cascade.dist_ff_gain = 1.5;
  expect_config_error([&] { a.validate(); }, {"cascade", "dist_ff_gain"});
  ControllerParams b;
  b.cascade.dist_filter_tau_s = 0.0;
  expect_config_error([&] { b.validate(); }, {"cascade", "dist_filter_tau_s"});
  ControllerParams c;
  c.tracker.turn_fit_window_s = 0.0;
  expect_config_error([&] { c.validate(); }, {"tracker", "turn_fit_window_s"});
  ControllerParams d;
  d.landing.max_landing_attempts = 0;
  expect_config_error([&] { d.validate(); }, {"landing", "max_landing_attempts"});
  ControllerParams e;
  e.landing.final_decision_after_s = 0.0;
  expect_config_error([&] { e.validate(); }, {"landing", "final_decision_after_s"});
  // A top too small for the skids, the final drift and the margin leaves no wide gate:
  // 0.6 - 0.297 - 0.2 - 0.05 = 0.053 m is still above the 5 cm cut gate, 0.59 m is not.
  ControllerParams f;
  f.landing.platform_half_size_m = 0.6;
  EXPECT_NO_THROW(f.validate());
  f.landing.platform_half_size_m = 0.59;
  expect_config_error([&] { f.validate(); }, {"landing", "platform_half_size_m", "wide gate"});
  // Read from YAML like every other key.
  ControllerParams y;
  read_params(YAML::Load("landing: {skid_half_spread_m: 0.25, final_decision_window_s: 3}\n"
                         "cascade: {dist_ff_gain: 0.5}"),
              "<inline>", y);
  EXPECT_DOUBLE_EQ(y.landing.skid_half_spread_m, 0.25);
  EXPECT_DOUBLE_EQ(y.landing.final_decision_window_s, 3.0);
  EXPECT_DOUBLE_EQ(y.cascade.dist_ff_gain, 0.5);
}

TEST(ControllerParams, UnknownKeyIsRejected) {
  ControllerParams p;
  expect_config_error([&] { read_params(YAML::Load("landing: {observe_frame: 40}"), "f.yaml", p); },
                      {"observe_frame", "f.yaml"});
}

}  // namespace
}  // namespace lander::ctl
