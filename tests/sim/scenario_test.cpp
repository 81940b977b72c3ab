// Scenario configuration: every shipped scenario loads; defaults are valid; save/load round
// trip; bad values and unknown keys name the key; cart paths are exact.
#include <gtest/gtest.h>

#include <dirent.h>

#include <cmath>

#include "lander/sim/cart_motion.h"
#include "lander/sim/scenario.h"

namespace lander::sim {
namespace {

std::vector<std::string> shipped_scenarios() {
  std::vector<std::string> out;
  DIR* d = opendir(LANDER_SCENARIOS_DIR);
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 5 && n.substr(n.size() - 5) == ".yaml") out.push_back(std::string(LANDER_SCENARIOS_DIR) + "/" + n);
  }
  closedir(d);
  return out;
}

TEST(Scenario, EveryShippedScenarioLoadsAndValidates) {
  const auto files = shipped_scenarios();
  ASSERT_GE(files.size(), 8u);  // default, flyover and the six of issue 5
  for (const auto& f : files) {
    EXPECT_NO_THROW(Scenario::load(f).validate()) << f;
  }
}

TEST(Scenario, DefaultsAreValid) { EXPECT_NO_THROW(Scenario::defaults().validate()); }

TEST(Scenario, SaveLoadRoundTrip) {
  Scenario s = Scenario::load(std::string(LANDER_SCENARIOS_DIR) + "/motion_blur.yaml");
  const std::string text = yaml_to_string(params_to_yaml(s));
  Scenario back;
  read_params(YAML::Load(text), "<saved>", back);
  EXPECT_EQ(yaml_to_string(params_to_yaml(back)), text);
  EXPECT_EQ(back.camera.blur_samples, 8);
  EXPECT_DOUBLE_EQ(back.camera.exposure_s, 0.020);
}

TEST(Scenario, BadValueNamesTheField) {
  Scenario s = Scenario::defaults();
  s.cart.path = "zigzag";
  try {
    s.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cart.path"), std::string::npos) << e.what();
  }
}

TEST(Scenario, UnknownNestedKeyNamesFileLineAndPath) {
  Scenario s;
  try {
    read_params(YAML::Load("seed: 3\nsensors:\n  gps:\n    rate: 5\n"), "x.yaml", s);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("x.yaml:4"), std::string::npos) << m;
    EXPECT_NE(m.find("sensors.gps.rate"), std::string::npos) << m;
  }
}

TEST(Scenario, DerivedSeedsDifferPerStreamAndRepeat) {
  EXPECT_EQ(derive_seed(1, "imu"), derive_seed(1, "imu"));
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(1, "gps"));
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(2, "imu"));
}

// Tolerance for comparing closed-form cart references with numerical derivatives: the
// central difference with h = 1e-4 s has an error of order h^2 * q''' (<< 1e-5).
constexpr double kDerivTol = 1e-5;

TEST(CartMotion, ArcKeepsItsRadiusAndDerivativesAreConsistent) {
  CartMotionParams p;
  p.path = "arc";
  p.speed_mps = 1.0;
  p.turn_radius_m = 15.0;
  p.start_m = {2.0, -1.0};
  const Eigen::Vector2d centre = p.start_m + Eigen::Vector2d(0, 15.0);  // left turn, heading 0
  for (double t : {0.5, 3.0, 10.0, 40.0}) {  // t > 0: the path starts at t = 0
    const CartReference r = cart_reference(p, t);
    EXPECT_NEAR((r.q.head<2>() - centre).norm(), 15.0, 1e-9) << t;
    EXPECT_NEAR(r.qd.head<2>().norm(), 1.0, 1e-12) << t;
    const double h = 1e-4;
    const CartReference a = cart_reference(p, t + h), b = cart_reference(p, t - h);
    EXPECT_LT(((a.q - b.q) / (2 * h) - r.qd).norm(), kDerivTol) << t;
    EXPECT_LT(((a.qd - b.qd) / (2 * h) - r.qdd).norm(), kDerivTol) << t;
  }
}

TEST(CartMotion, StopAndGoStopsAndMovesOnAsConfigured) {
  CartMotionParams p;
  p.speed_profile = "stop_and_go";
  p.speed_mps = 0.8;
  p.accel_mps2 = 0.4;  // 2 s to cruise speed
  p.go_s = 4.0;
  p.stop_s = 2.0;      // period 2 + 4 + 2 + 2 = 10 s
  EXPECT_NEAR(cart_reference(p, 1.0).qd.x(), 0.4, 1e-12);   // accelerating
  EXPECT_NEAR(cart_reference(p, 4.0).qd.x(), 0.8, 1e-12);   // cruising
  EXPECT_NEAR(cart_reference(p, 9.0).qd.x(), 0.0, 1e-12);   // standing
  EXPECT_NEAR(cart_reference(p, 11.0).qd.x(), 0.4, 1e-12);  // next cycle
  // One cycle covers the ramp distances plus the cruise: 0.8 * 2 + 0.8 * 4 = 4.8 m.
  EXPECT_NEAR(cart_reference(p, 10.0).q.x(), 4.8, 1e-9);
}

}  // namespace
}  // namespace lander::sim
