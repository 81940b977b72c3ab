// The predicted motion blur (issue 12) against the projection of a moving camera.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "lander/estimator/motion_blur.h"

namespace lander {
namespace {

// Truth: the point on the optical axis at the exposure's start, projected again at its end
// with the camera moved (constant rates and velocity) over the exposure.
Eigen::Vector2d projected_motion_px(const Eigen::Vector3d& w_C, const Eigen::Vector3d& v_C, double Z, double fx,
                                    double fy, double T) {
  const Eigen::Vector3d P0(0, 0, Z);  // scene point in the start camera frame
  // Camera at the end, in the start frame: rotated by w T, moved by v T.
  const double angle = w_C.norm() * T;
  const Eigen::Matrix3d R = angle > 0 ? Eigen::AngleAxisd(angle, w_C.normalized()).toRotationMatrix()
                                      : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d P1 = R.transpose() * (P0 - v_C * T);  // the point in the end frame
  return {fx * P1.x() / P1.z(), fy * P1.y() / P1.z()};
}

// The prediction is first order in the motion over the exposure: with 20 ms, 1 rad/s and
// 2 m/s at 3 m the second-order terms stay below this fraction of the blur.
constexpr double kFirstOrderRelTol = 0.03;

TEST(MotionBlur, MatchesTheProjectionOfAMovingCamera) {
  const double fx = 640, fy = 650, T = 0.020;
  struct Case {
    Eigen::Vector3d w, v;
    double Z;
  };
  const Case cases[] = {
      {{0.8, 0, 0}, {0, 0, 0}, 5.0},        // roll rate alone: along y
      {{0, -0.6, 0}, {0, 0, 0}, 5.0},       // pitch rate alone: along x
      {{0, 0, 0}, {1.5, 0, 0}, 3.0},        // sideways translation: -fx v T / Z
      {{0, 0, 0}, {0, -2.0, 0.3}, 4.0},     // with a little motion along the axis
      {{0.3, 0.5, 0.4}, {1.0, -0.7, 0}, 6.0},  // everything together, with a yaw rate
  };
  for (const Case& c : cases) {
    const Eigen::Vector2d predicted = axis_point_motion_blur_px(c.w, c.v, c.Z, fx, fy, T);
    const Eigen::Vector2d truth = projected_motion_px(c.w, c.v, c.Z, fx, fy, T);
    ASSERT_GT(truth.norm(), 1.0) << "a case with a visible blur";
    EXPECT_LT((predicted - truth).norm(), kFirstOrderRelTol * truth.norm())
        << "w " << c.w.transpose() << " v " << c.v.transpose() << ": predicted " << predicted.transpose()
        << " projected " << truth.transpose();
  }
}

TEST(MotionBlur, ScalesWithTheExposureAndVanishesWithoutMotion) {
  const Eigen::Vector3d w(0.2, -0.4, 0.1), v(0.5, 0.3, 0);
  const Eigen::Vector2d b10 = axis_point_motion_blur_px(w, v, 4.0, 640, 640, 0.010);
  const Eigen::Vector2d b20 = axis_point_motion_blur_px(w, v, 4.0, 640, 640, 0.020);
  EXPECT_NEAR((b20 - 2.0 * b10).norm(), 0.0, 1e-12);
  EXPECT_EQ(axis_point_motion_blur_px(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 4.0, 640, 640, 0.02),
            Eigen::Vector2d::Zero());
  // A rotation about the optical axis does not move the point on it.
  EXPECT_EQ(axis_point_motion_blur_px(Eigen::Vector3d(0, 0, 2.0), Eigen::Vector3d::Zero(), 4.0, 640, 640, 0.02),
            Eigen::Vector2d::Zero());
}

}  // namespace
}  // namespace lander
