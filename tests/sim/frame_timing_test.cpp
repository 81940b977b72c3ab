// The camera's frame timing (issue 54): drops, the driver stamp's jitter and the delivery
// latency match their keys over many frames, are the same for the same seed and frame, and
// are nothing at all with the keys at 0.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "lander/sim/sensors/camera.h"

namespace lander::sim {
namespace {

constexpr int kFrames = 40000;

CameraParams timed_camera() {
  CameraParams p;
  p.frame_drop_prob = 0.03;
  p.timestamp_jitter_s = 0.002;
  p.delivery_latency_s = 0.010;
  p.delivery_latency_std_s = 0.004;
  return p;
}

// Over 40 000 frames: the drop fraction's binomial sigma is sqrt(0.03 x 0.97 / 40000) =
// 0.00085, the jitter's std is known to 1/sqrt(2n) = 0.35 % (0.007 ms), the latency's mean to
// 0.004 / sqrt(n) = 0.02 ms; each tolerance is 4 sigma. The latency's Gaussian is cut at 0
// 2.5 sigma below its mean: that moves its mean by 0.004 x phi(2.5) ~ 0.07 ms, inside its
// tolerance of 0.1 ms (stated, not fitted).
TEST(FrameTiming, DropJitterAndLatencyMatchTheirKeys) {
  const CameraParams p = timed_camera();
  const FrameTimingModel m(p, 2026);
  FrameDeliveryStats stats;
  double jitter_sum = 0.0;
  for (int i = 0; i < kFrames; ++i) {
    const FrameTiming t = m.at(i);
    stats.add(t);
    if (!t.dropped) jitter_sum += t.stamp_error_s;
    EXPECT_GE(t.delivery_latency_s, 0.0);
  }
  const double drop_fraction = static_cast<double>(stats.dropped()) / kFrames;
  EXPECT_NEAR(drop_fraction, p.frame_drop_prob, 4 * std::sqrt(0.03 * 0.97 / kFrames));
  EXPECT_EQ(stats.captured(), kFrames);
  EXPECT_EQ(stats.delivered() + stats.dropped(), kFrames);
  const double n = static_cast<double>(stats.delivered());
  EXPECT_NEAR(jitter_sum / n, 0.0, 4 * p.timestamp_jitter_s / std::sqrt(n));
  EXPECT_NEAR(stats.stamp_error_rms_s(), p.timestamp_jitter_s, 4 * p.timestamp_jitter_s / std::sqrt(2 * n));
  // A Gaussian's largest of ~39 000 draws lies near 4.2 sigma; 3.5-5.5 sigma holds it.
  EXPECT_GT(stats.stamp_error_max_abs_s(), 3.5 * p.timestamp_jitter_s);
  EXPECT_LT(stats.stamp_error_max_abs_s(), 5.5 * p.timestamp_jitter_s);
  EXPECT_NEAR(stats.delivery_latency_mean_s(), p.delivery_latency_s, 1e-4);
}

// The same seed and frame give the same timing whatever order the frames are asked in; another
// seed gives other timings.
TEST(FrameTiming, SeededPerFrame) {
  const CameraParams p = timed_camera();
  const FrameTimingModel a(p, 7), b(p, 7), c(p, 8);
  std::vector<FrameTiming> forward;
  for (int i = 0; i < 100; ++i) forward.push_back(a.at(i));
  int differ = 0;
  for (int i = 99; i >= 0; --i) {
    const FrameTiming t = b.at(i);
    EXPECT_EQ(t.dropped, forward[i].dropped);
    EXPECT_EQ(t.stamp_error_s, forward[i].stamp_error_s);
    EXPECT_EQ(t.delivery_latency_s, forward[i].delivery_latency_s);
    differ += c.at(i).stamp_error_s != forward[i].stamp_error_s;
  }
  EXPECT_EQ(differ, 100);
}

// Keys at 0 (the default camera): every frame delivered, stamped exactly, no extra latency;
// a constant latency without its std is that constant.
TEST(FrameTiming, DefaultCameraDeliversEveryFrameOnTime) {
  CameraParams p;
  const FrameTimingModel m(p, 1);
  p.delivery_latency_s = 0.015;
  const FrameTimingModel constant(p, 1);
  for (int i = 0; i < 1000; ++i) {
    const FrameTiming t = m.at(i);
    EXPECT_FALSE(t.dropped);
    EXPECT_EQ(t.stamp_error_s, 0.0);
    EXPECT_EQ(t.delivery_latency_s, 0.0);
    EXPECT_EQ(constant.at(i).delivery_latency_s, 0.015);
  }
}

}  // namespace
}  // namespace lander::sim
