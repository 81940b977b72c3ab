// The camera's frame timing (issue 54): drops, the driver stamp's jitter and the delivery
// latency match their keys over many frames, are the same for the same seed and frame, and
// are nothing at all with the keys at 0; the rolling shutter's schedule of bands and renders.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

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

// The rolling shutter's schedule (issue 54): with one band per row, row v's render falls at
// t0 + readout v / H + exposure / 2 (n_blur = 1, the physics step 1 ns so nothing snaps), the
// rows of a larger render outside the image take the first or last image row's time, every
// row is covered once per blur render, and the renders come in time order. One band is the
// global shutter's schedule.
TEST(RollingShutter, ScheduleTimesEachBandAtItsCentreRow) {
  CameraParams p;
  p.rolling_shutter_readout_s = 0.030;
  p.exposure_s = 0.002;
  constexpr int kImageRows = 720, kRenderRows = 760;  // 20 render rows above and below the image
  constexpr double kT0 = 1.0, kDt = 1e-9;
  const std::vector<ExposureRender> rows = exposure_renders(p, kT0, kDt, kRenderRows, kImageRows, kRenderRows, 1);
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kRenderRows));
  std::vector<int> covered(kRenderRows, 0);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const ExposureRender& r = rows[i];
    ASSERT_EQ(r.row1, r.row0 + 1);
    ++covered[r.row0];
    const int v = std::clamp(r.row0 - 20, 0, kImageRows - 1);
    EXPECT_NEAR(r.t_s, kT0 + p.rolling_shutter_readout_s * v / kImageRows + 0.5 * p.exposure_s, 1e-9);
    if (i > 0) EXPECT_GE(r.t_s, rows[i - 1].t_s);
  }
  for (int c : covered) EXPECT_EQ(c, 1);
  // Four bands, three blur renders each: 12 renders, every row three times.
  const std::vector<ExposureRender> blurred = exposure_renders(p, kT0, kDt, kRenderRows, kImageRows, 4, 3);
  EXPECT_EQ(blurred.size(), 12u);
  std::vector<int> times(kRenderRows, 0);
  for (const ExposureRender& r : blurred) {
    for (int v = r.row0; v < r.row1; ++v) ++times[v];
  }
  for (int c : times) EXPECT_EQ(c, 3);
  // One band: the global shutter's renders over every row.
  const std::vector<ExposureRender> one = exposure_renders(p, kT0, 0.001, kRenderRows, kImageRows, 1, 2);
  const std::vector<double> global = exposure_sample_times(p, kT0, 0.001, 2);
  ASSERT_EQ(one.size(), global.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i].t_s, global[i]);
    EXPECT_EQ(one[i].row0, 0);
    EXPECT_EQ(one[i].row1, kRenderRows);
  }
}

// Bands from the image motion over the readout: one per rolling_shutter_px_per_band pixels,
// at least one, at most rolling_shutter_max_bands; one without a rolling shutter.
TEST(RollingShutter, BandsFollowTheMotionOverTheReadout) {
  CameraParams p;
  EXPECT_EQ(rolling_shutter_bands(p, 50.0), 1);  // global shutter
  p.rolling_shutter_readout_s = 0.03;
  p.rolling_shutter_px_per_band = 0.5;
  p.rolling_shutter_max_bands = 32;
  EXPECT_EQ(rolling_shutter_bands(p, 0.0), 1);
  EXPECT_EQ(rolling_shutter_bands(p, 0.4), 1);
  EXPECT_EQ(rolling_shutter_bands(p, 4.2), 9);
  EXPECT_EQ(rolling_shutter_bands(p, 1000.0), 32);
  EXPECT_EQ(rolling_shutter_bands(p, std::numeric_limits<double>::quiet_NaN()), 1);
}

// The bands assembled by CameraPipeline::add_rows: renders whose pixels are their own time
// stamp (in ms) give a frame whose every row holds its band's time; with two renders a row,
// their mean.
TEST(RollingShutter, PipelineAssemblesEachRowFromItsBand) {
  CameraParams p;
  p.intrinsics.width_px = 64;
  p.intrinsics.height_px = 48;
  p.intrinsics.fx_px = p.intrinsics.fy_px = 40;
  p.intrinsics.cx_px = 31.5;
  p.intrinsics.cy_px = 23.5;
  p.rolling_shutter_readout_s = 0.030;
  for (int n_blur : {1, 2}) {
    CameraPipeline pipe(p, 3);
    const std::vector<ExposureRender> renders = exposure_renders(p, 0.0, 1e-4, 48, 48, 6, n_blur);
    pipe.begin(0.0, n_blur);
    std::vector<double> sum(48, 0.0);
    for (const ExposureRender& r : renders) {
      const double value = 1e3 * r.t_s;  // 1-31 ms: fits a grey level
      pipe.add_rows(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(std::round(value))), r.row0, r.row1);
      for (int v = r.row0; v < r.row1; ++v) sum[v] += std::round(value);
    }
    const CameraFrame f = pipe.finish(0, Eigen::Isometry3d::Identity());
    EXPECT_DOUBLE_EQ(f.exposure.readout_s, p.rolling_shutter_readout_s);
    EXPECT_DOUBLE_EQ(f.exposure.row_exposure_s(), p.exposure_s);
    for (int v = 0; v < 48; ++v) {
      // Rounded to 8 bit like any frame: within half a grey level of the rows' mean.
      EXPECT_NEAR(f.bgr.at<cv::Vec3b>(v, 10)[1], sum[v] / n_blur, 0.5) << "row " << v << ", " << n_blur << " renders";
    }
  }
}

}  // namespace
}  // namespace lander::sim
