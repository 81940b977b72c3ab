// Ground effect (Cheeseman-Bennett with validity clip).
#include "lander/sim/plant/ground_effect.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace lander::sim {
namespace {

double cb(double R, double z) { return 1.0 / (1.0 - std::pow(R / (4 * z), 2)); }

TEST(GroundEffectParams, DefaultIsValid) { EXPECT_NO_THROW(GroundEffectParams{}.validate()); }

TEST(GroundEffectParams, SaveLoadRoundTrip) {
  GroundEffectParams p;
  p.z_max_over_R = 2.5;
  p.enabled = false;
  GroundEffectParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_EQ(q.z_max_over_R, 2.5);
  EXPECT_FALSE(q.enabled);
}

TEST(GroundEffectParams, BadValueNamesField) {
  GroundEffectParams p;
  try {
    read_params(YAML::Load("z_min_over_R: 0.2"), "g.yaml", p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("z_min_over_R"), std::string::npos) << e.what();
  }
}

TEST(GroundEffect, RaisesThrustNearTheSurfaceFollowingCheesemanBennett) {
  const GroundEffectParams p;
  const double R = p.radius_m;
  const double offset = cb(R, p.z_max_over_R * R) - 1.0;
  // At one radius: CB = 16/15, minus the 0.7 % continuity offset.
  EXPECT_NEAR(ground_effect_factor(p, R), 16.0 / 15.0 - offset, 1e-12);
  EXPECT_GT(ground_effect_factor(p, R), 1.05);
  // At the lower clip: CB(R/2) = 4/3 and it stays there below the clip.
  EXPECT_NEAR(ground_effect_factor(p, 0.5 * R), 4.0 / 3.0 - offset, 1e-12);
  EXPECT_DOUBLE_EQ(ground_effect_factor(p, 0.1 * R), ground_effect_factor(p, 0.5 * R));
  EXPECT_DOUBLE_EQ(ground_effect_factor(p, 0.0), ground_effect_factor(p, 0.5 * R));
  // Monotonically decreasing inside the band.
  double prev = ground_effect_factor(p, 0.5 * R);
  for (double z = 0.5 * R + 0.001; z < 3.0 * R; z += 0.001) {
    const double f = ground_effect_factor(p, z);
    EXPECT_LE(f, prev + 1e-15) << z;
    prev = f;
  }
}

TEST(GroundEffect, IsOneAboveValidityHeightAndContinuous) {
  const GroundEffectParams p;
  const double z_max = p.z_max_over_R * p.radius_m;
  EXPECT_EQ(ground_effect_factor(p, z_max), 1.0);
  EXPECT_EQ(ground_effect_factor(p, 10.0), 1.0);
  // Continuity at z_max: the slope of CB there is ~0.05 /m, so 1 um gives < 1e-7.
  EXPECT_NEAR(ground_effect_factor(p, z_max - 1e-6), 1.0, 1e-7);
  // No surface hit / disabled: no effect.
  EXPECT_EQ(ground_effect_factor(p, std::numeric_limits<double>::infinity()), 1.0);
  EXPECT_EQ(ground_effect_factor(p, std::numeric_limits<double>::quiet_NaN()), 1.0);
  GroundEffectParams off = p;
  off.enabled = false;
  EXPECT_EQ(ground_effect_factor(off, 0.1), 1.0);
}

}  // namespace
}  // namespace lander::sim
