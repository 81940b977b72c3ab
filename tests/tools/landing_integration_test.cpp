// The product end to end: a short closed-loop landing on the static platform, rendered
// frames -> real estimator -> real controller -> MuJoCo, checked against the simulator's
// truth (touchdown offset from the trace, not from anything the flight software reports).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
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

// The last row of a run's trace.csv: a column's value by name (a missing column fails the test
// and reads NaN).
std::function<double(const std::string&)> last_trace_row(const std::string& path) {
  std::ifstream trace(path);
  std::string header, line, last;
  std::getline(trace, header);
  while (std::getline(trace, line)) last = line;
  std::vector<std::string> cols, vals;
  for (std::stringstream hs(header); std::getline(hs, line, ',');) cols.push_back(line);
  for (std::stringstream ls(last); std::getline(ls, line, ',');) vals.push_back(line);
  return [cols, vals](const std::string& name) {
    for (std::size_t i = 0; i < cols.size() && i < vals.size(); ++i) {
      if (cols[i] == name) return std::stod(vals[i]);
    }
    ADD_FAILURE() << "no column " << name;
    return std::nan("");
  };
}

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
  const auto col = last_trace_row(dir + "/out/trace.csv");
  const double dx = col("x_WB_m") - col("x_WP_m"), dy = col("y_WB_m") - col("y_WP_m");
  EXPECT_LT(std::hypot(dx, dy), kRestOffsetTolM);
  EXPECT_LT(std::abs(col("z_WB_m") - col("z_WP_m") - 0.25), 0.02) << "not resting on its skids";
}

// The platform's broadcast (scenarios/cart_telemetry.yaml, issue 10's first search): a 1 m/s
// cart out of view of a 5 m start is flown to and landed on; the same start without the
// broadcast has not found it 12 s later (it would abort after search_give_up_s, 30 s).
// Named apart from LandingIntegration so that CI's sanitizer job (which runs that suite) does
// not pay for two more rendered runs; the controller's unit tests cover this code under it.

// The touchdown offset the campaigns count a moving-cart landing within (offset_limit_m).
constexpr double kMovingCartOffsetTolM = 0.10;
// With the broadcast the vehicle acquires the target ~6 s in (README); the run without it
// has not by 12 s. 10 s separates the two with room either side.
constexpr double kBroadcastAcquiredByS = 10.0;
// Without the broadcast the vehicle sweeps near its start while the cart drives away: after
// 12 s more than 8 m apart, beyond the 5 m high camera's ~3-5 m view radius.
constexpr double kOutOfViewM = 8.0;

double last_row_distance(const std::string& trace_path) {
  const auto col = last_trace_row(trace_path);
  return std::hypot(col("x_WB_m") - col("x_WP_m"), col("y_WB_m") - col("y_WP_m"));
}

TEST(BroadcastIntegration, SearchFliesToTheBroadcastCartAndLands) {
  const std::string dir = lander::test::make_temp_dir("lander_broadcast");
  const std::string scenario = std::string(LANDER_MODELS_DIR) + "/../scenarios/cart_telemetry.yaml";
  const auto r = lander::test::run_lander({"run", scenario, "--out", dir + "/on", "--quiet"});
  const std::string text = slurp(dir + "/on/summary.json");
  ASSERT_FALSE(text.empty()) << r.output;
  EXPECT_EQ(r.code, 0) << text;
  const nlohmann::json on = lander::test::parse_json(text);
  EXPECT_TRUE(lander::test::bool_at(on, "landed")) << text;
  EXPECT_LT(lander::test::number_at(on, "touchdown_offset_m"), kMovingCartOffsetTolM) << text;
  EXPECT_TRUE(lander::test::bool_at(on, "platform_telemetry.enabled"));
  EXPECT_GT(lander::test::number_at(on, "platform_telemetry.received"), 0);
  EXPECT_GT(lander::test::number_at(on, "platform_telemetry.search_s"), 0);
  const nlohmann::json& tr = lander::test::at_path(on, "mode_transitions");
  ASSERT_TRUE(tr.is_array() && !tr.empty()) << text;
  EXPECT_EQ(lander::test::string_at(tr[0], "to"), "observe");
  EXPECT_LT(lander::test::number_at(tr[0], "t_s"), kBroadcastAcquiredByS);

  // The same start without the broadcast, for 12 s.
  std::string yaml = slurp(scenario);
  const auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
  };
  replace("enabled: true", "enabled: false");
  replace("duration_s: 60", "duration_s: 12");
  std::ofstream(dir + "/off.yaml") << yaml;
  const auto r2 = lander::test::run_lander({"run", dir + "/off.yaml", "--out", dir + "/off", "--quiet"});
  const std::string text2 = slurp(dir + "/off/summary.json");
  ASSERT_FALSE(text2.empty()) << r2.output;
  const nlohmann::json off = lander::test::parse_json(text2);
  EXPECT_EQ(lander::test::string_at(off, "outcome"), "timeout") << text2;
  EXPECT_EQ(lander::test::string_at(off, "final_mode"), "search") << text2;
  EXPECT_TRUE(lander::test::at_path(off, "mode_transitions").empty()) << text2;
  EXPECT_EQ(lander::test::number_at(off, "platform_telemetry.received"), 0);
  EXPECT_GT(last_row_distance(dir + "/off/trace.csv"), kOutOfViewM);
}

// A fast platform (scenarios/fast_cart_4mps.yaml, issue 56): MBZIRC 2017's 4.2 m/s on a 30 m
// arc, the vehicle starting 3 m behind it at 10 m. With the speed limits from the vehicle model
// and the approach in the platform's frame it lands in its first attempt (observed 3.5 cm,
// 0.25 m/s, 22.4 s, 2026-12-03); before, it aborted after three approaches. Named apart from
// LandingIntegration so that the sanitizer job does not pay for the rendered run.

// The figures for fast platforms: offset 10 cm, relative touchdown speed 0.5 m/s.
constexpr double kFastPlatformOffsetTolM = 0.10;
constexpr double kFastPlatformRelSpeedMps = 0.5;

TEST(FastPlatformIntegration, LandsOnAPlatformAtFourPointTwoMetresPerSecondOnAnArc) {
  const std::string dir = lander::test::make_temp_dir("lander_fast");
  const std::string scenario = std::string(LANDER_MODELS_DIR) + "/../scenarios/fast_cart_4mps.yaml";
  const auto r = lander::test::run_lander({"run", scenario, "--out", dir, "--quiet"});
  const std::string text = slurp(dir + "/summary.json");
  ASSERT_FALSE(text.empty()) << r.output;
  EXPECT_EQ(r.code, 0) << text;
  const nlohmann::json s = lander::test::parse_json(text);
  EXPECT_TRUE(lander::test::bool_at(s, "landed")) << text;
  EXPECT_LT(lander::test::number_at(s, "touchdown_offset_m"), kFastPlatformOffsetTolM) << text;
  EXPECT_LT(lander::test::number_at(s, "touchdown_rel_speed_mps"), kFastPlatformRelSpeedMps) << text;
  EXPECT_EQ(lander::test::number_at(s, "landing_decision.attempts"), 1) << text;
}

// A touchdown decided just before duration_s is judged after it (closed_loop.cpp's
// kTouchdownJudgement_s): the static landing above, cut at t_cut, re-run with its duration
// ending 0.3 s after the cut (the 1 s of rest needed for "landed" is not over at the end) and
// 0.3 s before it (nothing decided: a timeout, nothing simulated past the end). Named apart
// from LandingIntegration so that the sanitizer job does not pay for its three rendered runs.

// After the cut the judge needs its 1 s of rest plus the fall (under 0.1 s): what the second
// run may simulate past its duration is at most that with the judgement's 2 s bound.
constexpr double kEndAfterCutS = 0.3;
constexpr double kJudgementBoundS = 2.0;
// One physics step (physics_dt_s = 1 ms): the first run and the re-runs are the same run
// up to their end (same seed), so the re-run lands at the same instant.
constexpr double kSameInstantS = 1e-3;

TEST(TouchdownJudgement, ACutBeforeTheEndIsJudgedAfterIt) {
  const std::string dir = lander::test::make_temp_dir("lander_judge");
  const auto scenario = [](double duration_s) {
    std::ostringstream os;
    os << "name: short_static_landing\n"
          "seed: 11\n"
          "duration_s: "
       << duration_s
       << "\n"
          "cart: {path: static, start_m: [0.0, 0.0]}\n"
          "vehicle: {control: closed_loop, start_m: [-0.6, 0.4, 4.0]}\n";
    return os.str();
  };
  const auto run = [&](const std::string& name, double duration_s) {
    std::ofstream(dir + "/" + name + ".yaml") << scenario(duration_s);
    const auto r = lander::test::run_lander({"run", dir + "/" + name + ".yaml", "--out", dir + "/" + name, "--quiet"});
    const std::string text = slurp(dir + "/" + name + "/summary.json");
    EXPECT_FALSE(text.empty()) << r.output;
    return text.empty() ? nlohmann::json::object() : lander::test::parse_json(text);
  };
  const nlohmann::json full = run("full", 60);
  ASSERT_TRUE(lander::test::bool_at(full, "landed")) << full.dump(1);
  EXPECT_EQ(lander::test::number_at(full, "judged_past_duration_s"), 0.0);
  double t_cut = std::nan("");
  for (const auto& tr : lander::test::at_path(full, "mode_transitions")) {
    if (lander::test::string_at(tr, "to") == "touchdown") t_cut = lander::test::number_at(tr, "t_s");
  }
  ASSERT_TRUE(std::isfinite(t_cut)) << full.dump(1);

  const nlohmann::json late = run("late", t_cut + kEndAfterCutS);
  EXPECT_EQ(lander::test::string_at(late, "outcome"), "landed") << late.dump(1);
  const double past = lander::test::number_at(late, "judged_past_duration_s");
  EXPECT_GT(past, 0.0);
  EXPECT_LE(past, kJudgementBoundS);
  EXPECT_NEAR(lander::test::number_at(late, "time_to_land_s"), lander::test::number_at(full, "time_to_land_s"),
              kSameInstantS);
  EXPECT_NEAR(lander::test::number_at(late, "touchdown_offset_m"),
              lander::test::number_at(full, "touchdown_offset_m"), 1e-9);

  const nlohmann::json early = run("early", t_cut - kEndAfterCutS);
  EXPECT_EQ(lander::test::string_at(early, "outcome"), "timeout") << early.dump(1);
  EXPECT_EQ(lander::test::number_at(early, "judged_past_duration_s"), 0.0);
}

}  // namespace
