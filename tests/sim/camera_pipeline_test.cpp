// The camera pipeline's image processing without a renderer: read noise, gain.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

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

}  // namespace
}  // namespace lander::sim
