// Seed 003 section 4, the image-based path-following law: eq. 10 (annulus), eq. 11-12 (the
// candidate with the smallest angle to the velocity's image, ties to the farthest, behind
// rejected, the flown trail set aside) on hand-made point sets; eq. 13-16 (the target's
// ground point: exact ray-ground intersection and the paper's constant k) against hand
// computations with the default camera mount; PathGuidanceParams::validate names its keys.
#include "lander/controller/path_guidance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <string>
#include <vector>

#include "lander/core/types.h"

#include "common/config_error_checks.h"

namespace lander::ctl {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Closed-form projections (a 3x3 rotation, a division) reproduce each other to round-off:
// offsets of a few metres at 4 m height carry ~1e-15 relative error, far below 1e-9 m.
constexpr double kProjectionTol_m = 1e-9;
// Pixel coordinates from the same closed forms: round-off on ~1e3 px.
constexpr double kPixelTol_px = 1e-9;
// Entries of a rotation built from 180 and -90 deg: cos/sin round-off (~1e-16).
constexpr double kRotationTol = 1e-12;

// ---------------------------------------------------------------------------------------
// eq. 10-12: select_target

// The defaults of PathGuidanceParams: r1 = 60 px, r2 = 300 px, tie 3 deg, max turn 165 deg.
constexpr double kR1 = 60.0, kR2 = 300.0;
constexpr double kTie = 3.0 * kDeg, kMaxTurn = 165.0 * kDeg;
const Eigen::Vector2d kU(640.0, 360.0);
const Eigen::Vector2d kV(1.0, 0.0);

// The image point at `r_px` from U in the direction `deg` from +u (towards +v).
Eigen::Vector2d polar(double deg, double r_px) {
  return kU + r_px * Eigen::Vector2d(std::cos(deg * kDeg), std::sin(deg * kDeg));
}

std::optional<std::size_t> select(const std::vector<Eigen::Vector2d>& pts,
                                  const Eigen::Vector2d& v = kV,
                                  const std::vector<bool>* excluded = nullptr) {
  return select_target(pts, kU, v, kR1, kR2, kTie, kMaxTurn, excluded);
}

TEST(PathGuidanceSelect, EmptySetAndAllOutsideTheAnnulusGiveNothing) {
  EXPECT_FALSE(select({}).has_value());
  // Inside r1, beyond r2, and both straight ahead (angle 0) so only eq. 10 can reject them.
  EXPECT_FALSE(select({polar(0, 10), polar(0, 59.9), polar(0, 300.1), polar(0, 900)}).has_value());
  // Control: one point just inside the annulus is chosen.
  const auto c = select({polar(0, 10), polar(0, 59.9), polar(0, 60.1), polar(0, 300.1)});
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 2u);
}

TEST(PathGuidanceSelect, PointsExactlyOnTheBoundsAreNeverChosen) {
  // eq. 10 is strict: r1 < |p - U| < r2. These distances are exact in binary floating point
  // (60, 300, and the 3-4-5 triangles 36-48-60 and 180-240-300).
  const std::vector<Eigen::Vector2d> on_bounds{
      kU + Eigen::Vector2d(60, 0), kU + Eigen::Vector2d(300, 0),
      kU + Eigen::Vector2d(36, 48), kU + Eigen::Vector2d(180, -240)};
  EXPECT_FALSE(select(on_bounds).has_value());
  // With a point strictly inside at a worse angle (40 deg), that one is chosen instead of the
  // boundary points at 0 deg.
  std::vector<Eigen::Vector2d> with_inner = on_bounds;
  with_inner.push_back(polar(40, 150));
  const auto c = select(with_inner);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 4u);
}

TEST(PathGuidanceSelect, ChoosesTheSmallestAngleToTheVelocity) {
  // Angles 90, -30, 10 and 0 deg at different radii: 0 deg wins although it is the nearest.
  const std::vector<Eigen::Vector2d> pts{polar(90, 280), polar(-30, 250), polar(10, 200),
                                         polar(0, 80)};
  const auto c = select(pts);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 3u);
  // Without the 0 deg point the 10 deg one wins.
  const auto c2 = select({pts[0], pts[1], pts[2]});
  ASSERT_TRUE(c2.has_value());
  EXPECT_EQ(*c2, 2u);
  // Velocity pointing down the image (+v): now the 90 deg point is the best.
  const auto c3 = select(pts, Eigen::Vector2d(0, 1));
  ASSERT_TRUE(c3.has_value());
  EXPECT_EQ(*c3, 0u);
  // Velocity at -25 deg: the -30 deg point (5 deg off) beats 0 deg (25 deg off).
  const auto c4 = select(pts, Eigen::Vector2d(std::cos(-25 * kDeg), std::sin(-25 * kDeg)));
  ASSERT_TRUE(c4.has_value());
  EXPECT_EQ(*c4, 1u);
}

TEST(PathGuidanceSelect, APointBehindBeyondMaxTurnIsNotChosen) {
  // 180 deg and 170 deg are beyond max_turn = 165 deg: nothing is ahead.
  EXPECT_FALSE(select({polar(180, 200)}).has_value());
  EXPECT_FALSE(select({polar(170, 200), polar(-170, 100)}).has_value());
  // Control: 160 deg is within max_turn and is chosen when it is the only one.
  const auto c = select({polar(180, 200), polar(160, 200)});
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 1u);
}

TEST(PathGuidanceSelect, TiesWithinTheBandGoToTheFarthest) {
  // Best angle 1 deg; 3.5 deg is within best + tie (4 deg) and farther: it wins.
  const auto c = select({polar(1, 100), polar(3.5, 250)});
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 1u);
  // The tie band is on |angle|: -3.5 deg also ties with 1 deg (|-3.5| < 1 + 3).
  const auto c2 = select({polar(1, 100), polar(-3.5, 250)});
  ASSERT_TRUE(c2.has_value());
  EXPECT_EQ(*c2, 1u);
  // 4.5 deg is just outside the band: the smaller angle wins although it is nearer.
  const auto c3 = select({polar(1, 100), polar(4.5, 250)});
  ASSERT_TRUE(c3.has_value());
  EXPECT_EQ(*c3, 0u);
  // With tie_rad = 0 only exact ties count: the smaller angle wins.
  const auto c4 = select_target({polar(1, 100), polar(3.5, 250)}, kU, kV, kR1, kR2, 0.0, kMaxTurn);
  ASSERT_TRUE(c4.has_value());
  EXPECT_EQ(*c4, 0u);
}

TEST(PathGuidanceSelect, ExcludedCandidatesAreSetAside) {
  const std::vector<Eigen::Vector2d> pts{polar(20, 150), polar(0, 150), polar(-12, 150)};
  const auto all = select(pts);
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(*all, 1u);
  // The best (0 deg) set aside: the next best, -12 deg, is chosen.
  const std::vector<bool> ex{false, true, false};
  const auto c = select(pts, kV, &ex);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(*c, 2u);
  // All set aside: nothing.
  const std::vector<bool> ex_all{true, true, true};
  EXPECT_FALSE(select(pts, kV, &ex_all).has_value());
}

TEST(PathGuidanceSelect, TheChoiceDoesNotDependOnTheSpeed) {
  // Candidates spread around U; velocity directions at several angles, each scaled over
  // seven orders of magnitude: the angles (eq. 12) and so the choice are the same.
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 24; ++i) pts.push_back(polar(15.0 * i + 2.0, 70.0 + 9.0 * i));
  int distinct = 0;
  std::optional<std::size_t> prev;
  for (double dir_deg : {0.0, 37.0, 103.0, -66.0, 170.0}) {
    const Eigen::Vector2d v(std::cos(dir_deg * kDeg), std::sin(dir_deg * kDeg));
    const auto ref = select(pts, v);
    ASSERT_TRUE(ref.has_value()) << dir_deg;
    if (ref != prev) ++distinct;
    prev = ref;
    for (double scale : {1e-4, 0.3, 7.0, 1e3}) {
      EXPECT_EQ(select(pts, scale * v), ref) << dir_deg << " deg x" << scale;
    }
  }
  EXPECT_EQ(distinct, 5);  // the directions do pick different candidates
}

// ---------------------------------------------------------------------------------------
// eq. 13-16: projection with the default mount

// The configured camera: 1280 x 720, fx = fy = 640, principal point at the image centre.
constexpr double kF = 640.0, kCx = 639.5, kCy = 359.5;
// Vehicle height above the ground (m); the camera is 0.08 m below the body origin.
constexpr double kH = 4.0;
constexpr double kHCamLevel = kH - 0.08;

Eigen::Matrix3d rpy(double roll_deg, double pitch_deg, double yaw_deg) {
  return R_from_rpy(Eigen::Vector3d(roll_deg, pitch_deg, yaw_deg) * kDeg);
}

GroundView view(const Eigen::Matrix3d& R_WB = Eigen::Matrix3d::Identity(),
                const CameraMount& mount = CameraMount{}) {
  GroundView g;
  g.R_WB = R_WB;
  g.R_BC = mount.X_BC().linear();
  g.t_BC_m = mount.X_BC().translation();
  g.h_B_m = kH;
  g.fx = g.fy = kF;
  g.cx = kCx;
  g.cy = kCy;
  return g;
}

TEST(PathGuidanceProjection, DefaultMountLooksDownWithTheImageTopAtTheNose) {
  // rpy {180, 0, -90}: camera x (image right) = body -y, camera y (image down) = body -x,
  // optical axis = body -z.
  const Eigen::Matrix3d R_BC = CameraMount{}.X_BC().linear();
  EXPECT_LT((R_BC.col(0) - Eigen::Vector3d(0, -1, 0)).norm(), kRotationTol);
  EXPECT_LT((R_BC.col(1) - Eigen::Vector3d(-1, 0, 0)).norm(), kRotationTol);
  EXPECT_LT((R_BC.col(2) - Eigen::Vector3d(0, 0, -1)).norm(), kRotationTol);
}

TEST(PathGuidanceProjection, VehicleImagePointIsThePrincipalPointShiftedByTheCameraOffset) {
  // Default mount: the camera sits straight below the body origin, so U is the principal
  // point.
  const Eigen::Vector2d U = vehicle_image_point(view());
  EXPECT_NEAR(U.x(), kCx, kPixelTol_px);
  EXPECT_NEAR(U.y(), kCy, kPixelTol_px);
  // Camera 0.10 m ahead (+x_B) and 0.05 m left (+y_B): the ground point below the body origin
  // lies 0.10 m behind and 0.05 m right of the camera, 3.92 m down. Behind = image down (+v),
  // right = image right (+u): U = (cx + f 0.05 / 3.92, cy + f 0.10 / 3.92).
  CameraMount m;
  m.p_BC_m = {0.10, 0.05, -0.08};
  const Eigen::Vector2d U2 = vehicle_image_point(view(Eigen::Matrix3d::Identity(), m));
  EXPECT_NEAR(U2.x(), kCx + kF * 0.05 / kHCamLevel, kPixelTol_px);
  EXPECT_NEAR(U2.y(), kCy + kF * 0.10 / kHCamLevel, kPixelTol_px);
}

TEST(PathGuidanceProjection, ImageAxesMapToBodyAxesAsTheMountSays) {
  // A point 100 px above the principal point lies ahead (+x_B), 3.92 m * 100 / 640 away; a
  // point 100 px to the right lies to the right (-y_B).
  const double d = kHCamLevel * 100.0 / kF;
  const auto ahead = image_to_ground_ray(view(), {kCx, kCy - 100.0});
  ASSERT_TRUE(ahead.has_value());
  EXPECT_NEAR(ahead->x(), d, kProjectionTol_m);
  EXPECT_NEAR(ahead->y(), 0.0, kProjectionTol_m);
  const auto right = image_to_ground_ray(view(), {kCx + 100.0, kCy});
  ASSERT_TRUE(right.has_value());
  EXPECT_NEAR(right->x(), 0.0, kProjectionTol_m);
  EXPECT_NEAR(right->y(), -d, kProjectionTol_m);
  // Heading 90 deg (nose along W +y): ahead is W +y.
  const auto ahead_yawed = image_to_ground_ray(view(rpy(0, 0, 90)), {kCx, kCy - 100.0});
  ASSERT_TRUE(ahead_yawed.has_value());
  EXPECT_NEAR(ahead_yawed->x(), 0.0, kProjectionTol_m);
  EXPECT_NEAR(ahead_yawed->y(), d, kProjectionTol_m);
  // The constant-k projection uses the same axes.
  const Eigen::Vector2d k_ahead =
      image_to_ground_k(view(), {kCx, kCy - 100.0}, {kCx, kCy}, kHCamLevel / kF);
  EXPECT_NEAR(k_ahead.x(), d, kProjectionTol_m);
  EXPECT_NEAR(k_ahead.y(), 0.0, kProjectionTol_m);
}

TEST(PathGuidanceProjection, RayInvertsGroundToImageAtAnyAttitude) {
  const std::vector<Eigen::Matrix3d> attitudes{
      rpy(0, 0, 0),  rpy(5, 0, 0),   rpy(0, -12, 0), rpy(0, 0, 20),
      rpy(15, 8, -20), rpy(-20, 20, 160), rpy(10, -5, 90)};
  int checked = 0;
  for (std::size_t a = 0; a < attitudes.size(); ++a) {
    const GroundView g = view(attitudes[a]);
    for (double x = -3.0; x <= 3.0; x += 0.5) {
      for (double y = -3.0; y <= 3.0; y += 0.5) {
        const Eigen::Vector2d off(x, y);
        const auto px = ground_to_image(g, off);
        ASSERT_TRUE(px.has_value()) << a << " " << off.transpose();
        const auto back = image_to_ground_ray(g, *px);
        ASSERT_TRUE(back.has_value()) << a << " " << off.transpose();
        EXPECT_LT((*back - off).norm(), kProjectionTol_m) << a << " " << off.transpose();
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 7 * 13 * 13);
}

TEST(PathGuidanceProjection, ConstantKEqualsTheRayAtLevelAttitude) {
  // k = h_C / f is the exact scale when the camera looks straight down: at any heading the
  // two projections agree over the whole image.
  const double k = kHCamLevel / kF;
  for (double yaw : {0.0, 30.0, -135.0}) {
    const GroundView g = view(rpy(0, 0, yaw));
    const Eigen::Vector2d U = vehicle_image_point(g);
    for (double u : {0.0, 320.0, kCx, 1000.0, 1279.0}) {
      for (double v : {0.0, 180.0, kCy, 719.0}) {
        const auto ray = image_to_ground_ray(g, {u, v});
        ASSERT_TRUE(ray.has_value());
        const Eigen::Vector2d kk = image_to_ground_k(g, {u, v}, U, k);
        EXPECT_LT((*ray - kk).norm(), kProjectionTol_m) << yaw << " " << u << " " << v;
      }
    }
  }
}

// With U taken as the principal point (as the controller does for constant_k: the paper's
// vehicle point is the image centre), a 10 deg roll moves the ground under the principal
// point by h tan(10 deg) = 0.705 m, which the constant-k projection does not see. At the
// principal point that is exact (the camera offset along -z_B cancels: c_y + h_C tan =
// 0.08 sin + (4 - 0.08 cos) tan = 4 tan). Over +-100 px the error grows or shrinks with
// tan's curvature, roughly h (tan(10 deg + a) - tan(a)) for |a| <= atan(100/640) = 8.9 deg:
// computed, 0.992 to 1.053 h tan(10 deg); the perpendicular component (the tilted ray
// reaches further off the axis) is at most 2.7 cm at the (+-100, +-100) px corners. 8 % and
// 4 cm bound both.
constexpr double kConstantKRollRelTol = 0.08;
constexpr double kConstantKRollCrossTol_m = 0.04;

TEST(PathGuidanceProjection, ConstantKMissesTheTiltUnderRoll) {
  const double k = kHCamLevel / kF;
  const double expected = kH * std::tan(10 * kDeg);
  const GroundView g = view(rpy(10, 0, 0));
  const Eigen::Vector2d c(kCx, kCy);
  // Positive roll about x_B tilts the optical axis (-z_B) towards W +y.
  const auto ray_c = image_to_ground_ray(g, c);
  ASSERT_TRUE(ray_c.has_value());
  const Eigen::Vector2d k_c = image_to_ground_k(g, c, c, k);
  EXPECT_NEAR(ray_c->x(), 0.0, kProjectionTol_m);
  EXPECT_NEAR(ray_c->y(), expected, kProjectionTol_m);
  EXPECT_LT(k_c.norm(), kProjectionTol_m);
  for (double du : {-100.0, -50.0, 0.0, 50.0, 100.0}) {
    for (double dv : {-100.0, 0.0, 100.0}) {
      const Eigen::Vector2d p = c + Eigen::Vector2d(du, dv);
      const auto ray = image_to_ground_ray(g, p);
      ASSERT_TRUE(ray.has_value());
      const Eigen::Vector2d err = *ray - image_to_ground_k(g, p, c, k);
      EXPECT_GT(err.y(), 0.0) << du << " " << dv;  // the ray lies further towards +y
      EXPECT_NEAR(err.y(), expected, kConstantKRollRelTol * expected) << du << " " << dv;
      EXPECT_NEAR(err.x(), 0.0, kConstantKRollCrossTol_m) << du << " " << dv;
    }
  }
  // Negative roll: the same error towards -y.
  const auto ray_n = image_to_ground_ray(view(rpy(-10, 0, 0)), c);
  ASSERT_TRUE(ray_n.has_value());
  EXPECT_NEAR(ray_n->y(), -expected, kProjectionTol_m);
}

TEST(PathGuidanceProjection, ARayThatDoesNotDescendGivesNothing) {
  // Pitched nose-up 70 deg (pitch -70 deg about y_B, z up): the optical axis (-z_B) points
  // 20 deg below the horizon, forward; image up (the nose) is towards the sky.
  const GroundView g = view(rpy(0, -70, 0));
  // 10 deg above the axis (f tan 10 deg px up): 10 deg below the horizon, it meets the ground
  // ahead.
  const auto below = image_to_ground_ray(g, {kCx, kCy - kF * std::tan(10 * kDeg)});
  ASSERT_TRUE(below.has_value());
  EXPECT_GT(below->x(), 0.0);
  // 30 deg above the axis: 10 deg above the horizon, the ray never meets the ground.
  EXPECT_FALSE(image_to_ground_ray(g, {kCx, kCy - kF * std::tan(30 * kDeg)}).has_value());
  // Camera looking exactly at the horizon (pitch 90 deg) and past it (100 deg).
  EXPECT_FALSE(image_to_ground_ray(view(rpy(0, -90, 0)), {kCx, kCy}).has_value());
  EXPECT_FALSE(image_to_ground_ray(view(rpy(0, -100, 0)), {kCx, kCy}).has_value());
  EXPECT_FALSE(image_to_ground_ray(view(rpy(0, 100, 0)), {kCx, kCy}).has_value());
  // Control: nose-up 60 deg the principal ray still descends; it meets the ground h tan 60
  // deg ahead (the camera offset cancels as in the roll case); nose-down 60 deg, as far
  // behind.
  const auto up60 = image_to_ground_ray(view(rpy(0, -60, 0)), {kCx, kCy});
  ASSERT_TRUE(up60.has_value());
  EXPECT_NEAR(up60->x(), kH * std::tan(60 * kDeg), kProjectionTol_m);
  EXPECT_NEAR(up60->y(), 0.0, kProjectionTol_m);
  const auto down60 = image_to_ground_ray(view(rpy(0, 60, 0)), {kCx, kCy});
  ASSERT_TRUE(down60.has_value());
  EXPECT_NEAR(down60->x(), -kH * std::tan(60 * kDeg), kProjectionTol_m);
}

// ---------------------------------------------------------------------------------------
// Parameters

using lander::test::expect_config_error;

TEST(PathGuidanceParams, DefaultsAreValid) { EXPECT_NO_THROW(PathGuidanceParams{}.validate()); }

TEST(PathGuidanceParams, BadValuesNameTheirKey) {
  {
    PathGuidanceParams p;
    p.r2_px = p.r1_px;
    expect_config_error([&] { p.validate(); }, {"'r2_px'"});
    p.r2_px = p.r1_px - 1;
    expect_config_error([&] { p.validate(); }, {"'r2_px'"});
  }
  {
    PathGuidanceParams p;
    p.guidance = "foo";
    expect_config_error([&] { p.validate(); }, {"'guidance'", "foo"});
  }
  {
    PathGuidanceParams p;
    p.projection = "bar";
    expect_config_error([&] { p.validate(); }, {"'projection'", "bar"});
  }
  {
    PathGuidanceParams p;
    p.speed_mps = 0.0;
    expect_config_error([&] { p.validate(); }, {"'speed_mps'"});
  }
  {
    PathGuidanceParams p;
    p.max_turn_rad = 181 * kDeg;
    expect_config_error([&] { p.validate(); }, {"'max_turn_deg'"});
  }
  {
    PathGuidanceParams p;
    p.tie_rad = 45 * kDeg;
    expect_config_error([&] { p.validate(); }, {"'tie_deg'"});
  }
  {
    // The other guidance and projection are accepted.
    PathGuidanceParams p;
    p.guidance = "pixel_distribution";
    p.projection = "constant_k";
    EXPECT_NO_THROW(p.validate());
  }
}

}  // namespace
}  // namespace lander::ctl
