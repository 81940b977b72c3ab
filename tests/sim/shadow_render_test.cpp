// The sun's shadows on real renders (render.shadows): the vehicle's shadow falls on the
// platform where the sun's direction puts it, wherever the cart has driven. MuJoCo draws a
// directional light's shadow map only within +-shadowClip of a line fixed in the model; before
// the renderer moved that line to where the camera looks, a cart 10 m or more from the world
// origin carried no shadow at all and `render.shadows: true` silently changed nothing there.
//
// One GL context per process: this file's tests each run in their own (ctest runs every
// case alone), with their own World and Renderer.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "lander/sim/plant/world.h"
#include "lander/sim/render/renderer.h"

namespace lander::sim {
namespace {

// The hub's shadow: the sun (0.55) is missing there, the headlight's ambient and diffuse
// (0.35 + 0.35) remain, so a shadowed white platform reads ~0.7 of a lit one (which
// saturates); anything above 0.85 of the lit level is not a shadow.
constexpr double kShadowedMaxFraction = 0.85;
// Where the shadow lies: the dark pixels around the predicted centre of the hub's shadow
// (hub, battery, six arms and four legs, symmetric about the body's z axis) must have their
// centroid within this of it. The hub's 3 cm height and the battery above it, seen along a
// ray 10 deg off the vertical, shift it by ~0.5 cm (~2 px at 1.5 m); the shadow map's texel
// is ~3 mm there (3 x 2.3 m over 2048).
constexpr double kShadowCentreTolPx = 8.0;
// The window searched for the shadow: a bit more than the hub's shadow (0.11 m at 1.5 m:
// 47 px).
constexpr double kShadowWindowPx = 60.0;

struct ShadowScene {
  Eigen::Vector2d predicted_px;  ///< projected centre of the hub's shadow
  Eigen::Vector2d rotor_disc_px; ///< a point of rotor 0's disc shadow, off its arm's
  cv::Mat grey;
};

// A point of rotor 0's disc (models/hexarotor.xml: centre (0.3681, 0.2125, 0.06) in B, radius
// 0.19 m), 0.12 m from its centre across its arm: the spinning disc casts no shadow, so its
// shadow point must be lit.
const Eigen::Vector3d kRotorDiscPoint_B =
    Eigen::Vector3d(0.3681, 0.2125, 0.06) + 0.12 * Eigen::Vector3d(-0.5, 0.866, 0.0);

// The cart at `cart_xy` (W), the vehicle level `height_m` above the platform, the sun along
// `sun_dir_W`, a plain white platform: the rendered frame and where the hub's shadow should be.
ShadowScene render_shadow_scene(const Eigen::Vector2d& cart_xy, double height_m,
                                const Eigen::Vector3d& sun_dir_W) {
  World world(WorldParams{}, CameraModel{});
  const TargetGeometry& g = world.target();
  world.set_texture("target_tex", cv::Mat(g.texture_px, g.texture_px, CV_8UC3,
                                          cv::Scalar(255, 255, 255)));
  mjModel* m = world.model();
  const int sun = mj_name2id(m, mjOBJ_LIGHT, "sun");
  EXPECT_GE(sun, 0);
  const Eigen::Vector3d d = sun_dir_W.normalized();
  for (int i = 0; i < 3; ++i) m->light_dir[3 * sun + i] = static_cast<float>(d[i]);
  m->light_castshadow[sun] = 1;
  world.set_cart_state(Eigen::Vector3d(cart_xy.x(), cart_xy.y(), 0.3), Eigen::Vector3d::Zero());
  world.forward();
  const Eigen::Vector3d top = world.X_WP().translation();
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.translation() = top + Eigen::Vector3d(0, 0, height_m);
  world.set_vehicle_state(X_WB, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  world.forward();

  RenderParams rp;
  rp.shadows = true;
  Renderer renderer(m, rp);
  const CameraModel& c = world.camera();
  cv::Mat bgr;
  renderer.render_camera(m, world.data(), world.camera_id(), c.width_px, c.height_px, bgr);
  ShadowScene out;
  cv::cvtColor(bgr, out.grey, cv::COLOR_BGR2GRAY);
  // The hub's centre (the body origin) carried along the sunlight to the platform's plane.
  auto shadow_px = [&](const Eigen::Vector3d& q_W) {
    const Eigen::Vector3d S = q_W + d * ((top.z() - q_W.z()) / d.z());
    const Eigen::Vector3d uv = c.K() * (world.X_WC().inverse() * S);
    return Eigen::Vector2d(uv.head<2>() / uv.z());
  };
  out.predicted_px = shadow_px(X_WB.translation());
  out.rotor_disc_px = shadow_px(X_WB * kRotorDiscPoint_B);
  return out;
}

void expect_hub_shadow_where_predicted(const ShadowScene& s) {
  const cv::Mat& img = s.grey;
  ASSERT_GT(s.predicted_px.x(), kShadowWindowPx);
  ASSERT_LT(s.predicted_px.x(), img.cols - kShadowWindowPx);
  ASSERT_GT(s.predicted_px.y(), kShadowWindowPx);
  ASSERT_LT(s.predicted_px.y(), img.rows - kShadowWindowPx);
  // Lit level: the 90th percentile of the frame (most of it is the lit white platform).
  std::vector<std::uint8_t> all(img.begin<std::uint8_t>(), img.end<std::uint8_t>());
  std::nth_element(all.begin(), all.begin() + all.size() * 9 / 10, all.end());
  const double lit = all[all.size() * 9 / 10];
  ASSERT_GT(lit, 200.0) << "the white platform should be lit";
  double sx = 0, sy = 0;
  int n = 0;
  const double r2 = kShadowWindowPx * kShadowWindowPx;
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      const double du = u - s.predicted_px.x(), dv = v - s.predicted_px.y();
      if (du * du + dv * dv > r2) continue;
      if (img.at<std::uint8_t>(v, u) > kShadowedMaxFraction * lit) continue;
      sx += u;
      sy += v;
      ++n;
    }
  }
  // The hub's shadow alone covers ~7000 px of the window's ~11300.
  ASSERT_GT(n, 3000) << "no shadow around (" << s.predicted_px.transpose() << "), lit level "
                     << lit;
  const Eigen::Vector2d centroid(sx / n, sy / n);
  EXPECT_LT((centroid - s.predicted_px).norm(), kShadowCentreTolPx)
      << "shadow centroid " << centroid.transpose() << " predicted " << s.predicted_px.transpose();
  // The predicted centre itself is in shadow.
  const int u0 = static_cast<int>(std::lround(s.predicted_px.x()));
  const int v0 = static_cast<int>(std::lround(s.predicted_px.y()));
  EXPECT_LT(img.at<std::uint8_t>(v0, u0), kShadowedMaxFraction * lit);
  // The rotor disc's shadow point is lit.
  const int u1 = static_cast<int>(std::lround(s.rotor_disc_px.x()));
  const int v1 = static_cast<int>(std::lround(s.rotor_disc_px.y()));
  ASSERT_TRUE(u1 >= 0 && v1 >= 0 && u1 < img.cols && v1 < img.rows) << s.rotor_disc_px.transpose();
  EXPECT_GT(img.at<std::uint8_t>(v1, u1), kShadowedMaxFraction * lit)
      << "rotor disc shadow at " << s.rotor_disc_px.transpose();
}

TEST(ShadowRender, VehicleShadowFallsOnAFarAwayCart) {
  // 32 m from the world origin: three times MuJoCo's fixed shadow half-width.
  expect_hub_shadow_where_predicted(
      render_shadow_scene(Eigen::Vector2d(30.0, -12.0), 1.5, Eigen::Vector3d(0.15, 0.1, -1.0)));
}

TEST(ShadowRender, VehicleShadowFallsWhereTheSunPutsItNearTheOrigin) {
  expect_hub_shadow_where_predicted(
      render_shadow_scene(Eigen::Vector2d(0.0, 0.0), 1.5, Eigen::Vector3d(-0.2, 0.1, -1.0)));
}

// The shadow map (shadowsize^2 floats, 16 MB at the model's 2048, allocated and cleared by
// llvmpipe) exists only with render.shadows: without it no light draws into one (issue 53).
TEST(ShadowRender, ShadowMapOnlyWithShadows) {
  World world(WorldParams{}, CameraModel{});
  Renderer renderer(world.model(), RenderParams{});
  EXPECT_EQ(renderer.shadow_map_px(), 0);
  EXPECT_EQ(world.model()->vis.quality.shadowsize, 2048);  // the model is left as it was
}

TEST(ShadowRender, ShadowMapAtTheModelsSizeWithShadows) {
  World world(WorldParams{}, CameraModel{});
  RenderParams rp;
  rp.shadows = true;
  Renderer renderer(world.model(), rp);
  EXPECT_EQ(renderer.shadow_map_px(), world.model()->vis.quality.shadowsize);
}

}  // namespace
}  // namespace lander::sim
