// The code map under the vehicle's own shadow on real renders (render.shadows): in the last
// metre of a landing in sunlight the hub's and the arms' shadows lie across the code. On
// MuJoCo's shadow map the shadow's edges are a few texels wide, and cornerSubPix pulls the
// grid corners next to them onto the shadow's edge: a fifth of the corners pixels off
// while the rest fit within a few tenths. With one outlier pass at 3 x RMS (the RMS the
// outliers inflate) those frames failed the corner gate (1 px); in a shadowed closed-loop
// landing (campaigns/shadows.yaml, run 3, sun 7 deg off the vertical) 8 of 9 sampled frames
// missed at 0.25-0.75 m gave "corner reprojection 1.1-1.5 px above the gate". The robust
// scale (median residual) drops them and keeps the pose on the rest.
//
// One GL context per process: the views share one World and one Renderer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <opencv2/imgproc.hpp>

#include "common/pose_errors.h"
#include "lander/estimator/vision_code.h"
#include "lander/sim/plant/plant.h"
#include "lander/sim/plant/world.h"
#include "lander/sim/render/renderer.h"

namespace lander::sim {
namespace {

// Pose tolerances of a code pose under a shadow, against the renderer's truth. Clean close
// views are good to 1e-3 of the distance and 2e-3 rad (tests/estimator/
// vision_close_range_test.cpp); the corners kept next to a shadow's edge are slightly biased,
// so three times those, as for the synthetic shadows there.
constexpr double kPosTolPerMetre = 3e-3;
constexpr double kRotTolRad = 6e-3;
// Views that must give a pose: observed 23 of 24 with the robust scale and 10 of 24 with the
// former 3 x RMS pass on these renders; 20 requires most of the gain.
constexpr int kMinPoses = 20;

// Given 24 views 0.3-0.7 m above the platform, the vehicle level to within 4 deg, offset up
// to 6 cm, any yaw, with the sun 5-12 deg off the vertical so that the hub's and arms'
// shadows lie across the code, and the light dispersed as in campaigns/shadows.yaml, when the
// code map is localised on the rendered frame, then every pose it gives is within the shadow
// tolerances of the truth, and at least kMinPoses views give one.
TEST(CodeShadowRender, CodeIsLocalisedUnderTheVehicleShadow) {
  World world(WorldParams{}, CameraModel{});
  mjModel* m = world.model();
  const int sun = mj_name2id(m, mjOBJ_LIGHT, "sun");
  ASSERT_GE(sun, 0);
  m->light_castshadow[sun] = 1;
  RenderParams rp;
  rp.shadows = true;
  Renderer renderer(m, rp);
  const CameraModel& cam = world.camera();
  const VisionParams p;
  world.set_cart_state(Eigen::Vector3d(4.0, -3.0, 0.2), Eigen::Vector3d::Zero());
  world.forward();
  const Eigen::Vector3d top = world.X_WP().translation();

  std::mt19937 rng(8);
  std::uniform_real_distribution<double> U(0, 1);
  int poses = 0, views = 0;
  for (const double h : {0.3, 0.4, 0.5, 0.6, 0.7, 0.45}) {
    for (int k = 0; k < 4; ++k, ++views) {
      const double sun_off = (5.0 + 7.0 * U(rng)) * M_PI / 180, sun_az = 2 * M_PI * U(rng);
      // The light as campaigns/shadows.yaml disperses it: the shadow keeps 10-50 % of the light.
      LightParams light;
      light.sun_dir_W = Eigen::Vector3d(std::sin(sun_off) * std::cos(sun_az),
                                        std::sin(sun_off) * std::sin(sun_az), -std::cos(sun_off));
      light.sun_intensity = 0.5 + 0.4 * U(rng);
      light.ambient = 0.05 + 0.2 * U(rng);
      light.headlight = 0.05 + 0.2 * U(rng);
      apply_light(m, light);
      Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
      const double tilt = 4.0 * M_PI / 180 * U(rng), tilt_az = 2 * M_PI * U(rng);
      X_WB.linear() = (Eigen::AngleAxisd(2 * M_PI * U(rng), Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(tilt_az), std::sin(tilt_az), 0)))
                          .toRotationMatrix();
      const double r = 0.06 * std::sqrt(U(rng)), a = 2 * M_PI * U(rng);
      X_WB.translation() = top + Eigen::Vector3d(r * std::cos(a), r * std::sin(a), h);
      world.set_vehicle_state(X_WB, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
      world.forward();
      cv::Mat bgr, grey;
      renderer.render_camera(m, world.data(), world.camera_id(), cam.width_px, cam.height_px, bgr);
      cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
      const Eigen::Isometry3d X_CP = world.X_WC().inverse() * world.X_WP();
      const CodeDetection c = detect_code_pattern(grey, cam, world.target(), p);
      SCOPED_TRACE("view " + std::to_string(views) + " at " + std::to_string(h) + " m: " + c.reason);
      if (!c.detected) continue;
      ++poses;
      const double dist = X_CP.translation().norm();
      EXPECT_LT(test::position_error_m(c.X_CP, X_CP), kPosTolPerMetre * dist);
      EXPECT_LT(test::rotation_error_rad(c.X_CP, X_CP), kRotTolRad);
    }
  }
  std::printf("code under the rendered vehicle shadow: %d of %d views give a pose\n", poses, views);
  EXPECT_GE(poses, kMinPoses);
}

}  // namespace
}  // namespace lander::sim
