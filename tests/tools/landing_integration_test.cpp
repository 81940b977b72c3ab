// The product end to end: a short closed-loop landing on the static platform, rendered
// frames -> real estimator -> real controller -> MuJoCo, checked against the simulator's
// truth (touchdown offset from the trace, not from anything the flight software reports).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/json_checks.h"
#include "tools/support/cli.h"

namespace {

// DESIGN/issue 5: static platform landings must touch down within 5 cm of the centre.
constexpr double kTouchdownOffsetTolM = 0.05;
// The final resting position may differ from the touchdown point by the skid's slide on
// contact; 3 cm more than the touchdown tolerance.
constexpr double kRestOffsetTolM = 0.08;

using lander::test::slurp;

TEST(LandingIntegration, ShortLandingOnTheStaticPlatformTouchesDownAtTheCentre) {
  const std::string dir = lander::test::make_temp_dir("lander_land");
  std::ofstream(dir + "/s.yaml") << "name: short_static_landing\n"
                                    "seed: 11\n"
                                    "duration_s: 60\n"
                                    "cart: {path: static, start_m: [0.0, 0.0]}\n"
                                    "vehicle: {control: closed_loop, start_m: [-0.6, 0.4, 4.0]}\n";
  const auto r = lander::test::run_lander({"run", dir + "/s.yaml", "--out", dir + "/out", "--quiet"});
  const std::string text = slurp(dir + "/out/summary.json");
  ASSERT_FALSE(text.empty()) << r.output;
  EXPECT_EQ(r.code, 0) << text;
  const nlohmann::json summary = lander::test::parse_json(text);
  EXPECT_TRUE(lander::test::bool_at(summary, "landed")) << text;
  EXPECT_LT(lander::test::number_at(summary, "touchdown_offset_m"), kTouchdownOffsetTolM) << text;
  // Truth from the trace's last row: the vehicle rests over the platform centre.
  std::ifstream trace(dir + "/out/trace.csv");
  std::string header, line, last;
  std::getline(trace, header);
  while (std::getline(trace, line)) last = line;
  std::vector<std::string> cols, vals;
  for (std::stringstream hs(header); std::getline(hs, line, ',');) cols.push_back(line);
  for (std::stringstream ls(last); std::getline(ls, line, ',');) vals.push_back(line);
  auto col = [&](const std::string& name) {
    for (std::size_t i = 0; i < cols.size(); ++i) if (cols[i] == name) return std::stod(vals.at(i));
    ADD_FAILURE() << "no column " << name;
    return 0.0;
  };
  const double dx = col("x_WB_m") - col("x_WP_m"), dy = col("y_WB_m") - col("y_WP_m");
  EXPECT_LT(std::hypot(dx, dy), kRestOffsetTolM);
  EXPECT_LT(std::abs(col("z_WB_m") - col("z_WP_m") - 0.25), 0.02) << "not resting on its skids";
}

}  // namespace
