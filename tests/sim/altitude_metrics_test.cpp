// Per-sensor altitude error statistics for `lander bench altitude`.
#include "lander/sim/altitude_metrics.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>

namespace lander::sim {
namespace {

TEST(AltitudeMetrics, RmseAndMaxPerBand) {
  AltitudeMetrics m;
  // Above 3 m: errors 0.3, -0.4 -> rmse sqrt(0.125), max 0.4. Below: 0.1 -> 0.1, 0.1.
  m.add("baro", 0.3, 10.0);
  m.add("baro", -0.4, 3.0);  // exactly 3 m counts as above
  m.add("baro", 0.1, 2.99);
  const ErrorStats all = m.stats("baro", AltitudeBand::kAll);
  EXPECT_EQ(all.n, 3u);
  EXPECT_NEAR(all.rmse_m(), std::sqrt((0.09 + 0.16 + 0.01) / 3), 1e-15);
  EXPECT_NEAR(all.max_abs_m, 0.4, 1e-15);
  EXPECT_NEAR(m.stats("baro", AltitudeBand::kAbove3m).rmse_m(), std::sqrt(0.125), 1e-15);
  EXPECT_NEAR(m.stats("baro", AltitudeBand::kBelow3m).max_abs_m, 0.1, 1e-15);
  EXPECT_EQ(m.stats("gps", AltitudeBand::kAll).n, 0u);
  EXPECT_TRUE(std::isnan(m.stats("gps", AltitudeBand::kAll).rmse_m()));
  EXPECT_THROW(m.add("baro", std::numeric_limits<double>::quiet_NaN(), 1.0),
               std::invalid_argument);
}

TEST(AltitudeMetrics, JsonHasTheIssueKeys) {
  AltitudeMetrics m;
  m.add("fused", 0.01, 5.0);
  m.add("fused", -0.02, 5.0);
  m.add("ultrasonic", 0.003, 1.0);
  const std::string json = m.to_json();
  // JSON is a subset of YAML 1.2 flow style: parse it back with yaml-cpp.
  const YAML::Node n = YAML::Load(json);
  ASSERT_TRUE(n.IsMap());
  EXPECT_EQ(m.sensors(), (std::vector<std::string>{"fused", "ultrasonic"}));
  for (const char* band : {"all", "above_3m", "below_3m"}) {
    ASSERT_TRUE(n["fused"][band]) << band;
    ASSERT_TRUE(n["fused"][band]["rmse_m"]) << band;
    ASSERT_TRUE(n["fused"][band]["max_m"]) << band;
  }
  EXPECT_NEAR(n["fused"]["above_3m"]["rmse_m"].as<double>(), std::sqrt(0.00025), 1e-6);
  EXPECT_NEAR(n["fused"]["all"]["max_m"].as<double>(), 0.02, 1e-9);
  EXPECT_EQ(n["fused"]["below_3m"]["n"].as<int>(), 0);
  EXPECT_TRUE(n["fused"]["below_3m"]["rmse_m"].IsNull());  // empty band: null
  EXPECT_NEAR(n["ultrasonic"]["below_3m"]["rmse_m"].as<double>(), 0.003, 1e-9);
}

}  // namespace
}  // namespace lander::sim
