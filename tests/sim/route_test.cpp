// The painted route's centre line (issue 14): lines and filleted corners by arc length,
// continuous in position and heading; clamped fillets on short legs; distance to the line;
// the painted pieces with the gaps left out; the cart driving it (path "route"); the params
// name their keys.
#include "lander/sim/plant/route.h"

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

#include "lander/sim/plant/cart_motion.h"

#include "common/config_error_checks.h"

namespace lander::sim {
namespace {

// Closed-form lines and circles evaluated in double precision: positions and lengths of
// ~10 m carry round-off of ~1e-15 relative, far below 1e-9 m.
constexpr double kExactTol_m = 1e-9;
// Angles from atan2 of the same closed forms: round-off.
constexpr double kAngleTol_rad = 1e-9;
// Step of the numeric continuity walk along the route (m).
constexpr double kWalkStep_m = 1e-3;
// A chord of length ds on an arc of radius r is shorter than ds by ds^3 / (24 r^2): with
// ds = 1 mm and r >= 0.5 m that is < 2e-10 m; a position jump at a joint would be far larger.
constexpr double kChordTol_m = 1e-9;
// Central differences of the cart reference with h = 1e-4 s: error of order h^2 q''' / 6
// (q''' ~ v^3 / r^2 = 0.25 m/s^3 on the 2 m arc, << 1e-5), as in the CartMotion tests.
constexpr double kDerivTol = 1e-5;
constexpr double kFdStep_s = 1e-4;
// Curvatures, speeds and accelerations are products of a few exact numbers: round-off.
constexpr double kRateTol = 1e-12;
// Two evaluations 2e-9 m of arc length apart straddling a joint: they differ by that much in
// position and 2e-9 / r in heading; a jump at the joint would be orders larger.
constexpr double kJointTol = 1e-8;
// The direction of a 1 mm step against the tangent: round-off of ~1e-15 m on its ends turns
// it by ~1e-12 rad; 1e-6 rad is generous and still far below a kink.
constexpr double kTangentTol_rad = 1e-6;
// A 6 deg chord's midpoint lies r (1 - cos 3 deg) = 2.7 mm inside an arc of r = 2 m.
constexpr double kChordSag_m = 0.005;

RouteParams make_route(std::initializer_list<Eigen::Vector2d> pts, double radius_m) {
  RouteParams p;
  for (const Eigen::Vector2d& q : pts) {
    RouteWaypoint w;
    w.p_m = q;
    p.waypoints.push_back(w);
  }
  p.corner_radius_m = radius_m;
  return p;
}

double wrap(double a) { return std::remainder(a, 2 * M_PI); }

// Walks the route in steps of kWalkStep_m: each step moves the point by the step (position
// continuous and parametrised by arc length), turns the heading by at most step * max
// |curvature| (heading continuous), and the heading at the step's middle is the direction
// of the step (heading is the tangent).
void expect_continuous(const RouteGeometry& g, double max_curvature) {
  const int n = static_cast<int>(std::floor(g.length() / kWalkStep_m));
  ASSERT_GT(n, 100);
  int bad_pos = 0, bad_heading = 0, bad_tangent = 0;
  for (int i = 0; i < n; ++i) {
    const double s0 = i * kWalkStep_m, s1 = s0 + kWalkStep_m;
    const RoutePoint a = g.at(s0), b = g.at(s1), m = g.at(0.5 * (s0 + s1));
    const Eigen::Vector2d d = b.p_m - a.p_m;
    if (std::abs(d.norm() - kWalkStep_m) > kChordTol_m) ++bad_pos;
    if (std::abs(wrap(b.heading_rad - a.heading_rad)) > kWalkStep_m * max_curvature + kAngleTol_rad) {
      ++bad_heading;
    }
    // The chord of an arc is parallel to the tangent at its middle; a line's step is its
    // direction. Near a joint the middle may lie on the other piece: the tangent is
    // continuous, so the difference is at most step * curvature.
    if (std::abs(wrap(std::atan2(d.y(), d.x()) - m.heading_rad)) >
        kWalkStep_m * max_curvature + kTangentTol_rad) {
      ++bad_tangent;
    }
  }
  EXPECT_EQ(bad_pos, 0);
  EXPECT_EQ(bad_heading, 0);
  EXPECT_EQ(bad_tangent, 0);
}

// ---------------------------------------------------------------------------------------

TEST(Route, StraightTwoPointRoute) {
  const RouteGeometry g(make_route({{1, 2}, {4, 6}}, 0.0));
  ASSERT_FALSE(g.empty());
  EXPECT_NEAR(g.length(), 5.0, kExactTol_m);
  const Eigen::Vector2d d(0.6, 0.8), n(-0.8, 0.6);  // direction and left normal
  const double h = std::atan2(4.0, 3.0);
  for (double s : {0.0, 1.0, 2.5, 5.0}) {
    const RoutePoint p = g.at(s);
    EXPECT_LT((p.p_m - (Eigen::Vector2d(1, 2) + s * d)).norm(), kExactTol_m) << s;
    EXPECT_NEAR(p.heading_rad, h, kAngleTol_rad) << s;
    EXPECT_EQ(p.curvature, 0.0) << s;
  }
  // at() clamps to the ends.
  EXPECT_LT((g.at(-1.0).p_m - Eigen::Vector2d(1, 2)).norm(), kExactTol_m);
  EXPECT_LT((g.at(7.0).p_m - Eigen::Vector2d(4, 6)).norm(), kExactTol_m);
  // Beside: 1 m to the left of s = 2.5, 0.5 m to the right of s = 4.
  double s = -1;
  EXPECT_NEAR(g.distance(Eigen::Vector2d(1, 2) + 2.5 * d + 1.0 * n, &s), 1.0, kExactTol_m);
  EXPECT_NEAR(s, 2.5, kExactTol_m);
  EXPECT_NEAR(g.distance(Eigen::Vector2d(1, 2) + 4.0 * d - 0.5 * n, &s), 0.5, kExactTol_m);
  EXPECT_NEAR(s, 4.0, kExactTol_m);
  // Beyond the end: 2 m further along; before the start: 3 m back and 4 m to the left (5 m).
  EXPECT_NEAR(g.distance(Eigen::Vector2d(4, 6) + 2.0 * d, &s), 2.0, kExactTol_m);
  EXPECT_NEAR(s, 5.0, kExactTol_m);
  EXPECT_NEAR(g.distance(Eigen::Vector2d(1, 2) - 3.0 * d + 4.0 * n, &s), 5.0, kExactTol_m);
  EXPECT_NEAR(s, 0.0, kExactTol_m);
  // On the line.
  EXPECT_NEAR(g.distance(Eigen::Vector2d(2.5, 4.0), &s), 0.0, kExactTol_m);
  EXPECT_NEAR(s, 2.5, kExactTol_m);
  // No corners: no discs, one rectangle over the whole line.
  EXPECT_TRUE(g.paint_discs().empty());
  const auto rects = g.paint_rects();
  ASSERT_EQ(rects.size(), 1u);
  EXPECT_NEAR(rects[0].length_m, 5.0, kExactTol_m);
  EXPECT_LT((rects[0].centre_m - Eigen::Vector2d(2.5, 4.0)).norm(), kExactTol_m);
  EXPECT_NEAR(rects[0].heading_rad, h, kAngleTol_rad);
}

TEST(Route, NoWaypointsIsNoRoute) {
  EXPECT_TRUE(RouteGeometry().empty());
  EXPECT_TRUE(RouteGeometry(RouteParams{}).empty());
  EXPECT_EQ(RouteGeometry(RouteParams{}).length(), 0.0);
}

// (0,0) -> (10,0) -> (10,10) with radius 2: the fillet's tangent points lie r tan(45 deg) =
// 2 m before and after the corner, at (8,0) and (10,2), around the centre (8,2).
const double kLLength = 20.0 - 2 * 2.0 * std::tan(M_PI / 4) + 2.0 * M_PI / 2;

TEST(Route, LCornerIsFilletedWithTheRadius) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0));
  EXPECT_NEAR(g.length(), kLLength, kExactTol_m);
  EXPECT_NEAR(g.length(), 16.0 + M_PI, kExactTol_m);
  // The joints: line to arc at s = 8, arc to line at s = 8 + pi.
  const double s_a = 8.0, s_b = 8.0 + M_PI;
  EXPECT_LT((g.at(s_a).p_m - Eigen::Vector2d(8, 0)).norm(), kExactTol_m);
  EXPECT_LT((g.at(s_b).p_m - Eigen::Vector2d(10, 2)).norm(), kExactTol_m);
  for (double s : {s_a, s_b}) {
    const RoutePoint lo = g.at(s - 1e-9), hi = g.at(s + 1e-9);
    EXPECT_LT((lo.p_m - hi.p_m).norm(), kJointTol) << s;
    EXPECT_NEAR(wrap(lo.heading_rad - hi.heading_rad), 0.0, kJointTol) << s;
  }
  // The arc's middle: 45 deg around from (8,0), heading 45 deg.
  const RoutePoint mid = g.at(s_a + M_PI / 2);
  EXPECT_LT((mid.p_m - Eigen::Vector2d(8 + std::sqrt(2.0), 2 - std::sqrt(2.0))).norm(), kExactTol_m);
  EXPECT_NEAR(mid.heading_rad, M_PI / 4, kAngleTol_rad);
  // Curvature 1/r on the arc (a left turn: > 0), 0 on the lines.
  for (double s : {0.5, 4.0, 7.99}) EXPECT_EQ(g.at(s).curvature, 0.0) << s;
  for (double s : {8.01, 9.0, 10.0, 11.1}) EXPECT_NEAR(g.at(s).curvature, 0.5, kRateTol) << s;
  for (double s : {11.2, 15.0, g.length()}) EXPECT_EQ(g.at(s).curvature, 0.0) << s;
  EXPECT_NEAR(g.at(0.0).heading_rad, 0.0, kAngleTol_rad);
  EXPECT_NEAR(g.at(g.length()).heading_rad, M_PI / 2, kAngleTol_rad);
  EXPECT_LT((g.at(g.length()).p_m - Eigen::Vector2d(10, 10)).norm(), kExactTol_m);
  expect_continuous(g, 0.5);
  // The arc's centre is r from the whole line (the two lines' ends are also 2 m away).
  EXPECT_NEAR(g.distance(Eigen::Vector2d(8, 2)), 2.0, kExactTol_m);
  // A point on the arc, 60 deg around from (8,0): distance 0, s = 8 + 2 pi / 3.
  double s = -1;
  const Eigen::Vector2d on_arc = Eigen::Vector2d(8, 2) + 2.0 * Eigen::Vector2d(std::cos(-M_PI / 6), std::sin(-M_PI / 6));
  EXPECT_NEAR(g.distance(on_arc, &s), 0.0, kExactTol_m);
  EXPECT_NEAR(s, 8.0 + 2.0 * M_PI / 3, kExactTol_m);
  // Outside the corner: (11, -1) is nearest to the arc's middle, 3 sqrt(2) - r away (the
  // lines' ends are sqrt(10) away).
  const double r_out = (Eigen::Vector2d(11, -1) - Eigen::Vector2d(8, 2)).norm();
  EXPECT_NEAR(g.distance(Eigen::Vector2d(11, -1), &s), r_out - 2.0, kExactTol_m);
  EXPECT_NEAR(s, s_a + M_PI / 2, kExactTol_m);
  // The corner vertex itself is not on the route: r / cos(45 deg) - r from it.
  EXPECT_NEAR(g.distance(Eigen::Vector2d(10, 0)), 2.0 * std::sqrt(2.0) - 2.0, kExactTol_m);
  // A rounded corner needs no disc.
  EXPECT_TRUE(g.paint_discs().empty());
}

TEST(Route, RadiusZeroIsASharpCorner) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 0.0));
  EXPECT_NEAR(g.length(), 20.0, kExactTol_m);
  EXPECT_LT((g.at(10.0).p_m - Eigen::Vector2d(10, 0)).norm(), kExactTol_m);
  EXPECT_NEAR(g.at(9.9).heading_rad, 0.0, kAngleTol_rad);
  EXPECT_NEAR(g.at(10.1).heading_rad, M_PI / 2, kAngleTol_rad);
  EXPECT_EQ(g.at(10.1).curvature, 0.0);
  EXPECT_NEAR(g.distance(Eigen::Vector2d(10, 0)), 0.0, kExactTol_m);
  const auto discs = g.paint_discs();
  ASSERT_EQ(discs.size(), 1u);
  EXPECT_LT((discs[0] - Eigen::Vector2d(10, 0)).norm(), kExactTol_m);
  // A waypoint's own radius overrides the route's: 0 at the corner of a route with 2.
  RouteParams p = make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0);
  p.waypoints[1].corner_radius_m = 0.0;
  EXPECT_NEAR(RouteGeometry(p).length(), 20.0, kExactTol_m);
  // ... and a per-waypoint 2 on a sharp route rounds it.
  RouteParams q = make_route({{0, 0}, {10, 0}, {10, 10}}, 0.0);
  q.waypoints[1].corner_radius_m = 2.0;
  EXPECT_NEAR(RouteGeometry(q).length(), kLLength, kExactTol_m);
}

TEST(Route, RightTurnHasNegativeCurvature) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, -10}}, 2.0));
  EXPECT_NEAR(g.length(), kLLength, kExactTol_m);
  const RoutePoint mid = g.at(8.0 + M_PI / 2);
  EXPECT_NEAR(mid.curvature, -0.5, kRateTol);
  EXPECT_LT((mid.p_m - Eigen::Vector2d(8 + std::sqrt(2.0), -2 + std::sqrt(2.0))).norm(), kExactTol_m);
  EXPECT_NEAR(mid.heading_rad, -M_PI / 4, kAngleTol_rad);
  EXPECT_NEAR(g.at(g.length()).heading_rad, -M_PI / 2, kAngleTol_rad);
  EXPECT_LT((g.at(g.length()).p_m - Eigen::Vector2d(10, -10)).norm(), kExactTol_m);
  expect_continuous(g, 0.5);
  double s = -1;
  EXPECT_NEAR(g.distance(Eigen::Vector2d(8, -2), &s), 2.0, kExactTol_m);
  const Eigen::Vector2d on_arc = Eigen::Vector2d(8, -2) + 2.0 * Eigen::Vector2d(std::cos(M_PI / 6), std::sin(M_PI / 6));
  EXPECT_NEAR(g.distance(on_arc, &s), 0.0, kExactTol_m);
  EXPECT_NEAR(s, 8.0 + 2.0 * M_PI / 3, kExactTol_m);
}

TEST(Route, AcuteCornerOnShortLegsIsClamped) {
  // A 135 deg left turn on 3 m legs. Radius 2 would need tangent points r tan(67.5 deg) =
  // 4.83 m from the corner; the fillet may use only half the next leg (1.5 m), so the
  // radius shrinks to 1.5 / tan(67.5 deg) = 0.621 m.
  const double turn = 135.0 * M_PI / 180;
  const Eigen::Vector2d P(3, 0), E = P + 3.0 * Eigen::Vector2d(std::cos(turn), std::sin(turn));
  const RouteGeometry g(make_route({{0, 0}, P, E}, 2.0));
  const double r = 1.5 / std::tan(0.5 * turn);
  EXPECT_NEAR(g.length(), 1.5 + r * turn + 1.5, kExactTol_m);
  EXPECT_LT(g.length(), 6.0);  // shorter than the polyline
  const RoutePoint mid = g.at(1.5 + 0.5 * r * turn);
  EXPECT_NEAR(mid.curvature, 1.0 / r, kRateTol);
  EXPECT_NEAR(mid.heading_rad, 0.5 * turn, kAngleTol_rad);
  EXPECT_NEAR(g.at(g.length()).heading_rad, turn, kAngleTol_rad);
  EXPECT_LT((g.at(g.length()).p_m - E).norm(), kExactTol_m);
  // The arc meets the second leg half-way along it.
  EXPECT_LT((g.at(1.5 + r * turn).p_m - (P + 0.5 * (E - P))).norm(), kExactTol_m);
  expect_continuous(g, 1.0 / r);
}

TEST(Route, TwoCornersSharingAShortLegAreBothClamped) {
  // (0,0) -> (4,0) -> (4,3) -> (-10,3), radius 3, two left turns of 90 deg. The first may use
  // half the 3 m leg: r = 1.5. The second may use only what the first left of that leg
  // (1.5 m), although half its next leg is 7 m: r = 1.5 again.
  const RouteGeometry g(make_route({{0, 0}, {4, 0}, {4, 3}, {-10, 3}}, 3.0));
  const double r = 1.5;
  EXPECT_NEAR(g.length(), 2.5 + r * M_PI / 2 + r * M_PI / 2 + 12.5, kExactTol_m);
  EXPECT_LT(g.length(), 4.0 + 3.0 + 14.0);
  EXPECT_NEAR(g.at(2.5 + r * M_PI / 4).curvature, 1.0 / r, kRateTol);
  EXPECT_NEAR(g.at(2.5 + 3 * r * M_PI / 4).curvature, 1.0 / r, kRateTol);
  // The two arcs meet at the middle of the short leg, heading +y.
  const RoutePoint joint = g.at(2.5 + r * M_PI / 2);
  EXPECT_LT((joint.p_m - Eigen::Vector2d(4, 1.5)).norm(), kExactTol_m);
  EXPECT_NEAR(joint.heading_rad, M_PI / 2, kAngleTol_rad);
  EXPECT_NEAR(g.at(g.length()).heading_rad, M_PI, kAngleTol_rad);
  expect_continuous(g, 1.0 / r);
}

TEST(Route, CollinearWaypointsAddNothing) {
  const RouteGeometry g(make_route({{0, 0}, {3, 0}, {7, 0}, {7, 5}}, 1.0));
  EXPECT_NEAR(g.length(), 7.0 - 1.0 + M_PI / 2 + 5.0 - 1.0, kExactTol_m);
  EXPECT_TRUE(g.paint_discs().empty());
  expect_continuous(g, 1.0);
}

// ---------------------------------------------------------------------------------------
// Paint

double total_length(const std::vector<RouteGeometry::Rect>& rects) {
  double sum = 0;
  for (const auto& r : rects) sum += r.length_m;
  return sum;
}

TEST(Route, PaintRectsLeaveTheGapsOut) {
  RouteParams p = make_route({{0, 0}, {10, 0}}, 0.0);
  p.gaps = {{2.0, 3.0}, {5.0, 5.5}};
  const RouteGeometry g(p);
  const auto rects = g.paint_rects();
  ASSERT_EQ(rects.size(), 3u);
  EXPECT_NEAR(total_length(rects), 10.0 - 1.0 - 0.5, kExactTol_m);
  // [0,2], [3,5], [5.5,10]: centres and lengths.
  EXPECT_LT((rects[0].centre_m - Eigen::Vector2d(1.0, 0)).norm(), kExactTol_m);
  EXPECT_NEAR(rects[0].length_m, 2.0, kExactTol_m);
  EXPECT_LT((rects[1].centre_m - Eigen::Vector2d(4.0, 0)).norm(), kExactTol_m);
  EXPECT_NEAR(rects[1].length_m, 2.0, kExactTol_m);
  EXPECT_LT((rects[2].centre_m - Eigen::Vector2d(7.75, 0)).norm(), kExactTol_m);
  EXPECT_NEAR(rects[2].length_m, 4.5, kExactTol_m);
  // A gap past the end cuts only what is there.
  RouteParams q = make_route({{0, 0}, {10, 0}}, 0.0);
  q.gaps = {{9.0, 30.0}};
  EXPECT_NEAR(total_length(RouteGeometry(q).paint_rects()), 9.0, kExactTol_m);
}

TEST(Route, PaintRectsOnACurvedRouteCoverThePaintedLength) {
  // L route, radius 2: lines [0,8] and [8+pi, 16+pi], arc [8, 8+pi]. Gaps inside the first
  // line, across the line-arc joint, and inside the second line.
  RouteParams p = make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0);
  p.gaps = {{1.0, 2.0}, {7.0, 9.0}, {15.0, 16.0}};
  const RouteGeometry g(p);
  double lines = 0, arcs = 0;
  int n_arc = 0;
  for (const auto& r : g.paint_rects()) {
    // Line pieces head exactly 0 or 90 deg; the arc's chords head strictly in between.
    if (std::abs(r.heading_rad) < kAngleTol_rad || std::abs(r.heading_rad - M_PI / 2) < kAngleTol_rad) {
      lines += r.length_m;
    } else {
      arcs += r.length_m;
      ++n_arc;
    }
    // No rectangle's centre lies in a gap.
    double s = -1;
    EXPECT_NEAR(g.distance(r.centre_m, &s), 0.0, kChordSag_m);
    for (const RouteGap& gap : p.gaps) {
      EXPECT_FALSE(s > gap.from_m && s < gap.to_m) << s;
    }
  }
  // Lines: 8 - 1 - 1 = 6 of the first, 8 - 1 = 7 of the second; the arc: pi - 1.
  EXPECT_NEAR(lines, 13.0, kExactTol_m);
  EXPECT_NEAR(lines, g.length() - 4.0 - (M_PI - 1.0), kExactTol_m);
  // Chords of at most 6 deg (0.209 m at r = 2): ceil((pi - 1) / 0.209) = 11, each
  // lengthened by 2 % + 2 mm so the outer edge has no notches (route.cpp).
  EXPECT_EQ(n_arc, 11);
  EXPECT_NEAR(arcs, 1.02 * (M_PI - 1.0) + 0.002 * n_arc, kExactTol_m);
}

TEST(Route, AWornSharpCornerHasNoDisc) {
  RouteParams p = make_route({{0, 0}, {10, 0}, {10, 10}}, 0.0);
  p.gaps = {{9.0, 11.0}};
  EXPECT_TRUE(RouteGeometry(p).paint_discs().empty());
  p.gaps = {{11.0, 12.0}};
  EXPECT_EQ(RouteGeometry(p).paint_discs().size(), 1u);
}

TEST(Route, TheRouteEndsArePaintedSquare) {
  // paint_discs() fills sharp corners only; the ends of the paint are square like a real
  // painted line's (the cart and the guidance law stop at the centre line's end either way).
  const RouteGeometry g(make_route({{0, 0}, {10, 0}}, 0.0));
  EXPECT_TRUE(g.paint_discs().empty());
}

// ---------------------------------------------------------------------------------------
// The cart on the route

CartMotionParams route_cart() {
  CartMotionParams p;
  p.path = "route";
  p.speed_mps = 1.0;
  return p;
}

void expect_consistent_derivatives(const CartMotionParams& p, const RouteGeometry& g, double t) {
  const CartReference r = cart_reference(p, t, &g);
  const CartReference a = cart_reference(p, t + kFdStep_s, &g), b = cart_reference(p, t - kFdStep_s, &g);
  EXPECT_LT(((a.q - b.q) / (2 * kFdStep_s) - r.qd).norm(), kDerivTol) << t;
  EXPECT_LT(((a.qd - b.qd) / (2 * kFdStep_s) - r.qdd).norm(), kDerivTol) << t;
}

TEST(Route, CartFollowsTheRouteWithConsistentDerivatives) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0));
  const CartMotionParams p = route_cart();
  // On the first line, on the arc, on the second line (away from the joints, where the
  // curvature and so qdd jump).
  for (double t : {3.0, 8.5, 8.0 + M_PI / 2, 10.9, 14.0}) {
    const CartReference r = cart_reference(p, t, &g);
    const RoutePoint rp = g.at(t);
    EXPECT_LT((r.q.head<2>() - rp.p_m).norm(), kExactTol_m) << t;
    EXPECT_NEAR(r.q.z(), rp.heading_rad, kAngleTol_rad) << t;
    EXPECT_NEAR(r.qd.head<2>().norm(), 1.0, kRateTol) << t;
    expect_consistent_derivatives(p, g, t);
  }
  // On the arc: centripetal acceleration v^2 / r = 0.5 m/s^2 towards the centre, yaw rate
  // v / r = 0.5 rad/s.
  const CartReference on_arc = cart_reference(p, 8.0 + M_PI / 2, &g);
  EXPECT_NEAR(on_arc.qdd.head<2>().norm(), 0.5, kRateTol);
  EXPECT_LT(on_arc.qdd.head<2>().dot(on_arc.q.head<2>() - Eigen::Vector2d(8, 2)), 0.0);
  EXPECT_NEAR(on_arc.qd.z(), 0.5, kRateTol);
}

TEST(Route, CartStopsAtTheRouteEnd) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0));
  const CartMotionParams p = route_cart();
  // Still moving just before the end, standing at the end afterwards.
  EXPECT_NEAR(cart_reference(p, g.length() - 0.5, &g).qd.head<2>().norm(), 1.0, kRateTol);
  for (double t : {g.length() + 0.01, g.length() + 5.0, 1000.0}) {
    const CartReference r = cart_reference(p, t, &g);
    EXPECT_LT((r.q.head<2>() - Eigen::Vector2d(10, 10)).norm(), kExactTol_m) << t;
    EXPECT_NEAR(r.q.z(), M_PI / 2, kAngleTol_rad) << t;
    EXPECT_EQ(r.qd.norm(), 0.0) << t;
    EXPECT_EQ(r.qdd.norm(), 0.0) << t;
  }
}

TEST(Route, RouteStartOffsetsTheCart) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0));
  CartMotionParams p = route_cart();
  p.route_start_m = 5.0;
  EXPECT_LT((cart_reference(p, 0.0, &g).q.head<2>() - Eigen::Vector2d(5, 0)).norm(), kExactTol_m);
  EXPECT_LT((cart_reference(p, 2.0, &g).q.head<2>() - Eigen::Vector2d(7, 0)).norm(), kExactTol_m);
  // It reaches the end 5 s earlier.
  EXPECT_NEAR(cart_reference(p, g.length() - 5.5, &g).qd.head<2>().norm(), 1.0, kRateTol);
  EXPECT_EQ(cart_reference(p, g.length() - 4.5, &g).qd.norm(), 0.0);
  // start_m and heading_deg are unused on a route.
  p.start_m = {30, -4};
  p.heading_rad = 1.0;
  EXPECT_LT((cart_reference(p, 0.0, &g).q.head<2>() - Eigen::Vector2d(5, 0)).norm(), kExactTol_m);
  // A start beyond the end: the cart stands at the end.
  p.route_start_m = 100.0;
  EXPECT_LT((cart_reference(p, 0.0, &g).q.head<2>() - Eigen::Vector2d(10, 10)).norm(), kExactTol_m);
}

TEST(Route, StopAndGoCartOnTheArcHasConsistentDerivatives) {
  const RouteGeometry g(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0));
  CartMotionParams p = route_cart();
  p.speed_profile = "stop_and_go";
  p.speed_mps = 0.8;
  p.accel_mps2 = 0.4;  // 2 s ramps
  p.route_start_m = 8.5;
  // t = 1 s: accelerating (s = 0.2 m past the start, on the arc); t = 3 s: cruising on the
  // arc; t = 5 s: cruising on the second line.
  for (double t : {1.0, 3.0, 5.5}) expect_consistent_derivatives(p, g, t);
  const CartReference r = cart_reference(p, 1.0, &g);
  // Tangential 0.4 m/s^2 and centripetal 0.4^2 / 2 = 0.08 m/s^2.
  EXPECT_NEAR(r.qdd.head<2>().norm(), std::hypot(0.4, 0.08), kRateTol);
  EXPECT_NEAR(r.qdd.z(), 0.4 * 0.5, kRateTol);  // k * sdd
}

TEST(Route, CartOnARouteWithoutOneThrows) {
  EXPECT_THROW(cart_reference(route_cart(), 1.0, nullptr), std::logic_error);
  const RouteGeometry none;
  EXPECT_THROW(cart_reference(route_cart(), 1.0, &none), std::logic_error);
}

// ---------------------------------------------------------------------------------------
// Parameters

using lander::test::expect_config_error;

TEST(Route, ParamsValidateNamesTheKey) {
  EXPECT_NO_THROW(RouteParams{}.validate());  // no route
  EXPECT_NO_THROW(make_route({{0, 0}, {10, 0}, {10, 10}}, 2.0).validate());
  expect_config_error([] { make_route({{0, 0}}, 0.0).validate(); }, {"'waypoints'"});
  RouteParams w = make_route({{0, 0}, {10, 0}}, 0.0);
  w.width_m = 0.0;
  expect_config_error([&] { w.validate(); }, {"'width_m'"});
  RouteParams c = make_route({{0, 0}, {10, 0}}, -1.0);
  expect_config_error([&] { c.validate(); }, {"'corner_radius_m'"});
  RouteParams d = make_route({{0, 0}, {0.01, 0}}, 0.0);
  expect_config_error([&] { d.validate(); }, {"'waypoints[1].p_m'"});
  RouteParams gp = make_route({{0, 0}, {10, 0}}, 0.0);
  gp.gaps = {{3.0, 2.0}};
  expect_config_error([&] { gp.validate(); }, {"'gaps[0].to_m'"});
}

}  // namespace
}  // namespace lander::sim
