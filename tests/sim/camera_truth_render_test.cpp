// The truth a camera frame carries (CameraFrame::X_WC_true, X_WP_true) is the camera's and the
// platform's pose at the exposure's middle, not at its end when the frame is finished: with a
// 20 ms exposure and 2-3 m/s of motion the two differ by 2-3 cm, which a per-frame detector
// error (the frames CSV's true_* columns, a fitted vision surrogate) must not carry.
//
// One GL context per process (ctest runs each case alone).
#include <gtest/gtest.h>

#include <cmath>

#include "lander/sim/plant/world.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/sensors/camera.h"

namespace lander::sim {
namespace {

constexpr double kDt = 0.001;           // the physics step the rig is advanced by (s)
constexpr double kCartSpeed = 3.0;      // m/s along W's x
constexpr double kVehicleSpeed = 2.0;   // m/s along W's y
constexpr double kExposure = 0.020;     // s
// The truth is taken at the first physics state at or after the middle: at most one step
// late, kDt x the speed (3 mm at 3 m/s); the exposure's end is 10 ms (3 cm) away.
constexpr double kMidTolM = kCartSpeed * kDt + 1e-9;

TEST(CameraTruth, FramesCarryThePosesAtTheExposuresMiddle) {
  World world(WorldParams{}, CameraModel{});
  Renderer renderer(world.model(), RenderParams{});
  CameraParams p;
  p.exposure_s = kExposure;
  CameraRig rig(p, 7, kDt);
  const Eigen::Vector3d start_B(0.0, 0.0, 5.0);
  // The world at t: the cart kCartSpeed * t along x, the vehicle kVehicleSpeed * t along y
  // (forward() recomputes the positions the camera and the platform are read from).
  auto place = [&](double t) {
    world.set_cart_state(Eigen::Vector3d(kCartSpeed * t, 0.0, 0.0), Eigen::Vector3d(kCartSpeed, 0.0, 0.0));
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.translation() = start_B + Eigen::Vector3d(0.0, kVehicleSpeed * t, 0.0);
    world.set_vehicle_state(X_WB, Eigen::Vector3d(0.0, kVehicleSpeed, 0.0), Eigen::Vector3d::Zero());
    world.forward();
  };
  place(0.0);
  const double x0_platform = world.X_WP().translation().x();
  const double y0_camera = world.X_WC().translation().y();
  int frames = 0;
  for (int k = 0; k <= 120 && frames < 3; ++k) {
    const double t = k * kDt;
    place(t);
    const std::optional<CameraFrame> f = rig.advance(t, world, renderer);
    if (!f) continue;
    ++frames;
    const double mid = f->exposure.mid();
    ASSERT_NEAR(mid, f->exposure.t_start_s + 0.5 * kExposure, 1e-9);
    // The cart's platform moved kCartSpeed * mid along x from where it was at t = 0.
    EXPECT_NEAR(f->X_WP_true.translation().x() - x0_platform, kCartSpeed * mid, kMidTolM) << "frame " << f->index;
    // The camera rides on the vehicle: kVehicleSpeed * mid along y from its start.
    EXPECT_NEAR(f->X_WC_true.translation().y() - y0_camera, kVehicleSpeed * mid, kMidTolM) << "frame " << f->index;
  }
  EXPECT_EQ(frames, 3);
}

}  // namespace
}  // namespace lander::sim
