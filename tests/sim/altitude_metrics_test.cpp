// Per-sensor altitude error statistics for `lander bench altitude`.
#include "lander/sim/recorder/altitude_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/json_checks.h"

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
  // A NaN from the flight side is counted and enters no figure (it must not abort a run).
  EXPECT_NO_THROW(m.add("baro", std::numeric_limits<double>::quiet_NaN(), 1.0));
  EXPECT_NO_THROW(m.add("baro", 0.2, std::numeric_limits<double>::infinity()));
  EXPECT_EQ(m.stats("baro", AltitudeBand::kAll).non_finite, 1u);
  EXPECT_EQ(m.stats("baro", AltitudeBand::kAll).n, 4u);  // the finite error, without a band
  EXPECT_EQ(m.stats("baro", AltitudeBand::kBelow3m).n, 1u);
  EXPECT_NEAR(m.stats("baro", AltitudeBand::kAll).max_abs_m, 0.4, 1e-15);
}

// Given the same samples added in a different order of first appearance (the overlapped
// vision schedule records a frame's result when its worker is joined, at a step that varies
// with thread timing), the JSON text is the same: sensors appear in a fixed order.
TEST(AltitudeMetrics, JsonOrderDoesNotDependOnWhichSensorCameFirst) {
  AltitudeMetrics a, b;
  a.add("baro", 0.5, 8.0);
  a.add("vision", 0.01, 8.0);
  a.add("fused", 0.02, 8.0);
  b.add("baro", 0.5, 8.0);
  b.add("fused", 0.02, 8.0);
  b.add("vision", 0.01, 8.0);
  EXPECT_EQ(a.json().dump(), b.json().dump());
  const nlohmann::ordered_json ja = a.json();
  std::vector<std::string> keys;
  for (const auto& [k, v] : ja.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"baro", "vision", "fused"}));
}

TEST(AltitudeMetrics, JsonHasTheIssueKeys) {
  AltitudeMetrics m;
  m.add("fused", 0.01, 5.0);
  m.add("fused", -0.02, 5.0);
  m.add("ultrasonic", 0.003, 1.0);
  // Written and parsed back as a file would be.
  const nlohmann::json n = test::parse_json(m.json().dump());
  ASSERT_TRUE(n.is_object());
  EXPECT_EQ(m.sensors(), (std::vector<std::string>{"fused", "ultrasonic"}));
  for (const char* band : {"all", "above_3m", "below_3m"}) {
    EXPECT_NO_THROW(test::at_path(n, std::string("fused.") + band + ".rmse_m")) << band;
    EXPECT_NO_THROW(test::at_path(n, std::string("fused.") + band + ".max_m")) << band;
  }
  EXPECT_NEAR(test::number_at(n, "fused.above_3m.rmse_m"), std::sqrt(0.00025), 1e-12);
  EXPECT_NEAR(test::number_at(n, "fused.all.max_m"), 0.02, 1e-15);
  EXPECT_EQ(test::number_at(n, "fused.below_3m.n"), 0);
  EXPECT_TRUE(test::at_path(n, "fused.below_3m.rmse_m").is_null());  // empty band: null
  EXPECT_NEAR(test::number_at(n, "ultrasonic.below_3m.rmse_m"), 0.003, 1e-15);
}

}  // namespace
}  // namespace lander::sim
