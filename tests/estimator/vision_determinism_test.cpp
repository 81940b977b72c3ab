// The detector's result depends on its frames and its own state only: never on which thread
// runs it, nor on what that thread ran before. The loop's overlapped schedule runs each
// frame's detection on a fresh worker thread while the serial schedule runs them all on the
// loop's thread; both must give the same detections bit for bit (issue 13). A per-thread
// scratch buffer that is converted or filtered only in part, and read around that part,
// breaks this (a tracking region's Gaussian and closing read pixels just outside it).
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "estimator/support/vision_synth.h"
#include "lander/estimator/vision_detector.h"

namespace lander {
namespace {

const CameraModel kCam{};

// A tracked approach: full frame first, then frames found in the predicted region, with a
// shadow band and some noise so that thresholds and edges are not trivially clean.
std::vector<cv::Mat> approach_frames() {
  const TargetGeometry& g = test::default_target();
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 6; ++i) {
    test::SynthOptions opt;
    opt.noise_sigma = 2.0;
    opt.seed = 40 + static_cast<std::uint64_t>(i);
    opt.supersample = 2;
    if (i % 2 == 1) opt.shadows.push_back({0.15, 0.3, 30.0 + 10.0 * i, 0.1 * i - 0.2});
    const auto X = test::look_at_pose(6.0 - 0.4 * i, 12.0 + 0.5 * i, 5.0 + i, 0.0,
                                      Eigen::Vector2d(0.3 - 0.05 * i, 0.2));
    frames.push_back(test::render_view(g, kCam, X, opt));
  }
  return frames;
}

// The detection as compared: everything but the wall time.
std::string fingerprint(RingDetection d) {
  d.time_ms = 0.0;
  return to_json(d);
}

// Runs `frames` through one detector, each frame on a new thread that first runs a throwaway
// detector on `poison` (which leaves that thread's scratch buffers holding its content).
std::vector<std::string> run_on_fresh_threads(const std::vector<cv::Mat>& frames, const cv::Mat& poison) {
  RingTargetDetector det(kCam, test::default_target(), VisionParams{});
  std::vector<std::string> out;
  for (const cv::Mat& f : frames) {
    std::thread t([&] {
      RingTargetDetector other(kCam, test::default_target(), VisionParams{});
      other.detect(poison);
      other.detect(poison);  // the second one tracks nothing: a full-frame pass again
      out.push_back(fingerprint(det.detect(f)));
    });
    t.join();
  }
  return out;
}

// Given a tracked sequence of frames, when one detector runs it on the calling thread and
// another runs it with each frame on a fresh thread whose scratch buffers were first filled
// with black, with white, or with another scene, then all detections are identical, and the
// sequence does use the tracking region (the case that reads around a partly converted buffer).
TEST(VisionDeterminism, DetectionsDoNotDependOnTheThreadOrWhatItRanBefore) {
  const std::vector<cv::Mat> frames = approach_frames();
  RingTargetDetector det(kCam, test::default_target(), VisionParams{});
  std::vector<std::string> serial;
  int in_roi = 0;
  for (const cv::Mat& f : frames) {
    const RingDetection d = det.detect(f);
    ASSERT_TRUE(d.detected) << d.reason;
    in_roi += d.used_roi ? 1 : 0;
    serial.push_back(fingerprint(d));
  }
  ASSERT_GE(in_roi, 3) << "the sequence must exercise the tracking region";

  const cv::Mat black(kCam.height_px, kCam.width_px, CV_8UC3, cv::Scalar::all(0));
  const cv::Mat white(kCam.height_px, kCam.width_px, CV_8UC3, cv::Scalar::all(255));
  const cv::Mat scene = test::distractor_frame(kCam, 7);
  for (const cv::Mat* poison : {&black, &white, &scene}) {
    const std::vector<std::string> threaded = run_on_fresh_threads(frames, *poison);
    ASSERT_EQ(threaded.size(), serial.size());
    for (std::size_t i = 0; i < serial.size(); ++i) {
      EXPECT_EQ(threaded[i], serial[i]) << "frame " << i << " differs when run on a fresh thread";
    }
  }
}

}  // namespace
}  // namespace lander
