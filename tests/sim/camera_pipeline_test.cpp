// The camera pipeline's image processing without a renderer: read noise, gain.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/sim/sensors/camera.h"

namespace lander::sim {
namespace {

CameraFrame one_frame(CameraPipeline& p, const cv::Mat& img, int index) {
  p.begin(0.0);
  p.add(img);
  return p.finish(index, Eigen::Isometry3d::Identity());
}

// Read noise from the noise bank: zero-mean Gaussian of the configured std per pixel and
// channel, the same for the same frame, different between frames. Tolerances: 2.7 M samples
// give the mean to +-0.004 DN and the std to +-0.002 DN (1 sigma); rounding to 8 bit adds
// 1/12 DN^2 of variance (std 2.0 -> 2.02); 0.05 DN covers both with a wide margin.
TEST(CameraPipeline, ReadNoiseHasItsStdAndIsSeededPerFrame) {
  CameraParams cp;
  cp.read_noise_dn = 2.0;
  CameraPipeline p(cp, 77);
  const cv::Mat grey(cp.intrinsics.height_px, cp.intrinsics.width_px, CV_8UC3, cv::Scalar(128, 128, 128));
  const CameraFrame a = one_frame(p, grey, 3), b = one_frame(p, grey, 3), c = one_frame(p, grey, 4);
  cv::Mat af;
  a.bgr.convertTo(af, CV_64FC3);
  cv::Scalar mean, std;
  cv::meanStdDev(af.reshape(1), mean, std);
  EXPECT_NEAR(mean[0], 128.0, 0.05);
  EXPECT_NEAR(std[0], std::sqrt(4.0 + 1.0 / 12.0), 0.05);
  EXPECT_EQ(cv::norm(a.bgr, b.bgr, cv::NORM_INF), 0.0);  // same frame, same noise
  EXPECT_GT(cv::norm(a.bgr, c.bgr, cv::NORM_L1), 0.0);   // another frame, other noise
  // Neighbouring pixels are independent (the bank is white noise): lag-1 correlation ~0.
  cv::Mat n = af.reshape(1) - 128.0;
  const cv::Mat left = n(cv::Rect(0, 0, n.cols - 3, n.rows)), right = n(cv::Rect(3, 0, n.cols - 3, n.rows));
  const double corr = left.dot(right) / std::sqrt(left.dot(left) * right.dot(right));
  EXPECT_LT(std::abs(corr), 0.01);
}

TEST(CameraPipeline, NoNoiseNoGainIsTheRenderItself) {
  CameraParams cp;
  CameraPipeline p(cp, 1);
  cv::Mat img(cp.intrinsics.height_px, cp.intrinsics.width_px, CV_8UC3);
  cv::randu(img, 0, 256);
  EXPECT_EQ(cv::norm(one_frame(p, img, 0).bgr, img, cv::NORM_INF), 0.0);
}

TEST(CameraPipeline, GainScalesAndClipsAtWhite) {
  CameraParams cp;
  cp.gain = 2.0;
  CameraPipeline p(cp, 1);
  const cv::Mat img(cp.intrinsics.height_px, cp.intrinsics.width_px, CV_8UC3, cv::Scalar(50, 100, 200));
  const cv::Vec3b px = one_frame(p, img, 0).bgr.at<cv::Vec3b>(10, 10);
  EXPECT_EQ(px[0], 100);
  EXPECT_EQ(px[1], 200);
  EXPECT_EQ(px[2], 255);
}

// A grey ring target like the platform's: black anti-aliased rings on white, the camera's size.
cv::Mat ring_image(const CameraParams& cp) {
  cv::Mat img(cp.intrinsics.height_px, cp.intrinsics.width_px, CV_8UC3, cv::Scalar(235, 235, 235));
  const cv::Point c(img.cols / 2, img.rows / 2);
  for (int r = 20; r < img.rows / 2; r += 23) cv::circle(img, c, r, cv::Scalar(20, 20, 20), 6, cv::LINE_AA);
  return img;
}

double psnr_db(const cv::Mat& a, const cv::Mat& b) { return cv::PSNR(a, b); }

double mean_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  return cv::mean(d.reshape(1))[0];
}

// JPEG delivery (issue 54): off by default (the render itself, see
// NoNoiseNoGainIsTheRenderItself); at quality 100 within a grey level of the lossless frame;
// at 50 its 8x8 blocks show (lower PSNR, steps at block edges); the same frame, the same
// bytes (no randomness).
TEST(CameraPipeline, JpegDeliveryAtQuality100IsWithinAGreyLevelAt50Blocky) {
  CameraParams cp;
  const cv::Mat img = ring_image(cp);
  cp.jpeg_quality = 100;
  CameraPipeline q100(cp, 1);
  const cv::Mat f100 = one_frame(q100, img, 0).bgr;
  ASSERT_EQ(f100.size(), img.size());
  ASSERT_EQ(f100.type(), CV_8UC3);
  EXPECT_GT(q100.last_jpeg_bytes(), 0u);
  // Within a grey level on average (observed 0.03, PSNR 63.4 dB; bounds: the grey
  // level, and 55 dB).
  EXPECT_LT(mean_abs_diff(f100, img), 1.0);
  EXPECT_GT(psnr_db(f100, img), 55.0);
  cp.jpeg_quality = 50;
  CameraPipeline q50(cp, 1);
  const cv::Mat f50 = one_frame(q50, img, 0).bgr;
  // Quality 50: observed PSNR 32.7 dB, 3.1 grey levels mean error, 27 % of the bytes of
  // quality 100; the range [28, 38] dB is the observed value +-5 dB (libjpeg versions differ
  // by tenths of a dB).
  EXPECT_GT(psnr_db(f50, img), 28.0);
  EXPECT_LT(psnr_db(f50, img), 38.0);
  EXPECT_GT(mean_abs_diff(f50, img), 1.5);
  EXPECT_LT(q50.last_jpeg_bytes(), q100.last_jpeg_bytes());
  EXPECT_EQ(cv::norm(one_frame(q50, img, 1).bgr, f50, cv::NORM_INF), 0.0);  // deterministic
}

}  // namespace
}  // namespace lander::sim

namespace lander::sim {
namespace {

// The camera looking straight down (OpenCV z along -z_W) from `height_m` above the origin.
ExposureMotion looking_down(double height_m) {
  ExposureMotion m;
  m.X_WC.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  m.X_WC.translation() = Eigen::Vector3d(0, 0, height_m);
  return m;
}

// Image motion of the adaptive blur against closed forms. Tolerance 1e-9 px: the same
// pinhole arithmetic in another order.
TEST(AdaptiveBlur, TranslationParallelToTheImageMovesAStillPointByFTimesDistanceOverDepth) {
  const CameraModel cam;  // the default 1280 x 720 camera
  ExposureMotion m = looking_down(10.0);
  m.v_W = Eigen::Vector3d(2.0, 0, 0);
  m.points_W = {Eigen::Vector3d(0.5, -0.3, 0.0)};
  m.point_velocities_W = {Eigen::Vector3d::Zero()};
  EXPECT_NEAR(image_motion_px(cam, m, 0.02), cam.fx_px * 2.0 * 0.02 / 10.0, 1e-9);
  // The same point moving with the camera (a cart under a vehicle flying along): no motion.
  m.point_velocities_W = {Eigen::Vector3d(2.0, 0, 0)};
  EXPECT_NEAR(image_motion_px(cam, m, 0.02), 0.0, 1e-9);
}

TEST(AdaptiveBlur, RotationAboutTheOpticalAxisMovesAPointAlongItsChord) {
  const CameraModel cam;
  ExposureMotion m = looking_down(5.0);
  m.w_W = Eigen::Vector3d(0, 0, 1.5);  // yaw rate, rad/s
  // A ground point seen 300 px right of the principal point.
  m.points_W = {Eigen::Vector3d(300.0 * 5.0 / cam.fx_px, 0, 0)};
  m.point_velocities_W = {Eigen::Vector3d::Zero()};
  const double r = 300.0, angle = 1.5 * 0.02;
  EXPECT_NEAR(image_motion_px(cam, m, 0.02), 2.0 * r * std::sin(angle / 2), 1e-6);
}

TEST(AdaptiveBlur, PointsBehindTheCameraOrFarOutsideTheImageDoNotCount) {
  const CameraModel cam;
  ExposureMotion m = looking_down(10.0);
  m.v_W = Eigen::Vector3d(1.0, 0, 0);
  m.points_W = {Eigen::Vector3d(0, 0, 20.0), Eigen::Vector3d(200.0, 0, 0.0)};  // behind; 200 m aside
  m.point_velocities_W = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  EXPECT_EQ(image_motion_px(cam, m, 0.02), 0.0);
}

TEST(AdaptiveBlur, RendersFollowTheMotionUpToTheCap) {
  CameraParams p;
  p.blur_samples = 8;
  p.blur_px_per_render = 1.0;
  EXPECT_EQ(blur_renders(p, 0.0), 1);    // hover: one render
  EXPECT_EQ(blur_renders(p, 0.4), 1);
  EXPECT_EQ(blur_renders(p, 3.2), 4);    // one render per started pixel
  EXPECT_EQ(blur_renders(p, 40.0), 8);   // capped
  EXPECT_EQ(blur_renders(p, std::nan("")), 1);
  p.blur_px_per_render = 2.0;
  EXPECT_EQ(blur_renders(p, 3.2), 2);
  p.blur_px_per_render = 0.0;            // fixed count
  EXPECT_EQ(blur_renders(p, 0.0), 8);
  // The sample times of n renders: n midpoints of equal slices of the exposure (1.0025,
  // 1.0075, ...), each snapped to the physics step (moves it by at most half a step).
  p.exposure_s = 0.02;
  const std::vector<double> t = exposure_sample_times(p, 1.0, 0.001, 4);
  ASSERT_EQ(t.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(t[i], 1.0 + (i + 0.5) * 0.005, 0.0005 + 1e-12) << i;
}

}  // namespace
}  // namespace lander::sim
