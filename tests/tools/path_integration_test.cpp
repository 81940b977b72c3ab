// Image-based path following (issue 14, seed 003) end to end: rendered frames with a painted
// route -> the estimator's path stage -> the controller's follow_path mode -> MuJoCo, judged
// by the simulator's truth (the cross-track error of the vehicle's ground point to the
// route's centre line, measured by the recorder from the true pose).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "common/json_checks.h"
#include "tools/support/cli.h"

namespace {

using lander::test::bool_at;
using lander::test::number_at;
using lander::test::parse_json;
using lander::test::slurp;

// The paper's figure for its route (seed 003, section 5): mean cross-track error under 0.1 m.
constexpr double kMeanCrossTrackTolM = 0.10;
// After the vehicle first came within 0.1 m of the centre line, it never strays more than
// the view's margin that keeps the route in the annulus: at 4 m the annulus' inner radius is
// 0.375 m on the ground; 0.35 m leaves the route in view with room.
constexpr double kMaxAfterCaptureTolM = 0.35;
// The cart waits at the far end: the landing there is a normal landing on a static platform
// (issue 5: within 5 cm of the centre).
constexpr double kTouchdownOffsetTolM = 0.05;

nlohmann::json run(const std::string& name, const std::string& yaml, int* code, std::string* text) {
  const std::string dir = lander::test::make_temp_dir(name);
  std::ofstream(dir + "/s.yaml") << yaml;
  const auto r = lander::test::run_lander({"run", dir + "/s.yaml", "--out", dir + "/out", "--quiet"});
  *code = r.code;
  *text = slurp(dir + "/out/summary.json");
  EXPECT_FALSE(text->empty()) << r.output;
  return parse_json(*text);
}

// The first three corners of scenarios/path_follow.yaml (straight, right angle, acute 45 deg,
// obtuse 135 deg) with a yellow distractor and a worn gap of 0.6 m on the first leg, to the
// end of the route. The vehicle starts 0.1 m off the route: the mean measures the following,
// not the approach from the start (measured: 7.6 cm; 9.0 cm when it starts 0.4 m off).
TEST(PathIntegration, FollowsTheRouteThroughItsCornersToItsEndWithinTheCrossTrackTolerance) {
  int code = -1;
  std::string text;
  const nlohmann::json s = run("lander_path_follow",
                               "name: path_corners\n"
                               "seed: 21\n"
                               "duration_s: 70\n"
                               "expect_outcome: route_end\n"
                               "world:\n"
                               "  route:\n"
                               "    waypoints: [{p_m: [0, 0]}, {p_m: [8, 0]}, {p_m: [8, 8]},\n"
                               "                {p_m: [3.757, 3.757]}, {p_m: [-2, 3.757]}]\n"
                               "    gaps: [{from_m: 3.0, to_m: 3.6}]\n"
                               "    paint: [{centre_m: [4, -1], size_m: [5, 0.15], rgb: [0.9, 0.8, 0.1]}]\n"
                               "cart: {path: static, start_m: [40, 30]}\n"
                               "vehicle: {control: closed_loop, start_m: [0.3, 0.1, 4.0]}\n"
                               "flight: {controller: {path: {direction_given: true, direction_deg: 0}}}\n",
                               &code, &text);
  EXPECT_EQ(code, 0) << text;  // expect_outcome route_end
  EXPECT_EQ(s.at("outcome").get<std::string>(), "route_end") << text;
  const nlohmann::json& pf = s.at("path_following");
  EXPECT_TRUE(bool_at(pf, "covered")) << text;
  EXPECT_LT(number_at(pf, "cross_track_mean_m"), kMeanCrossTrackTolM) << text;
  EXPECT_LT(number_at(pf, "cross_track_max_after_capture_m"), kMaxAfterCaptureTolM) << text;
  // The route is 8 + 8 + 6 + 5.8 = 27.8 m less the corners: covered at 1 m/s with the
  // corners' slow-down well within 45 s (a law that wandered or stopped would not be).
  EXPECT_LT(number_at(pf, "time_to_cover_s"), 45.0) << text;
  // The end is where the route ends, not back along it (the dead-end rule).
  EXPECT_GT(number_at(pf, "covered_m"), number_at(pf, "route_length_m") - 0.5) << text;
}

TEST(PathIntegration, FollowsTheRouteToTheParkedCartAndLands) {
  int code = -1;
  std::string text;
  const nlohmann::json s = run("lander_path_to_cart",
                               "name: path_to_cart_short\n"
                               "seed: 22\n"
                               "duration_s: 90\n"
                               "world:\n"
                               "  route:\n"
                               "    corner_radius_m: 1.5\n"
                               "    waypoints: [{p_m: [0, 0]}, {p_m: [8, 0]}, {p_m: [8, 8]}, {p_m: [8, 20]}]\n"
                               "cart: {path: route, route_start_m: 17, speed_mps: 0}\n"
                               "vehicle: {control: closed_loop, start_m: [0, 0.3, 4.0]}\n"
                               "flight: {controller: {path: {direction_given: true, direction_deg: 0}}}\n",
                               &code, &text);
  EXPECT_EQ(code, 0) << text;
  EXPECT_TRUE(bool_at(s, "landed")) << text;
  EXPECT_LT(number_at(s, "touchdown_offset_m"), kTouchdownOffsetTolM) << text;
  // The target was found by following the route: follow_path, then observe.
  const nlohmann::json& tr = s.at("mode_transitions");
  ASSERT_GE(tr.size(), 2u) << text;
  EXPECT_EQ(tr.at(0).at("to").get<std::string>(), "follow_path") << text;
  EXPECT_EQ(tr.at(1).at("from").get<std::string>(), "follow_path") << text;
  EXPECT_EQ(tr.at(1).at("to").get<std::string>(), "observe") << text;
  EXPECT_LT(number_at(s.at("path_following"), "cross_track_mean_m"), kMeanCrossTrackTolM) << text;
}

}  // namespace
