// Helpers the flight stacks share (flight/src only).
#pragma once

#include <chrono>

#include <opencv2/core.hpp>

#include "lander/estimator/vision_detector.h"
#include "lander/flight/flight_software.h"

namespace lander::flight {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0);
// CPU time of the calling thread (ms): what `lander bench loop` reports for the detector.
double thread_cpu_ms();
// The frame's pixels as OpenCV sees them (no copy).
cv::Mat as_mat(const ImageView& v);
// Our detector's view of one frame for the recorder: the counts of summary.json's vision
// section, the vision height of a pose (camera mount X_BC), the video's overlays.
FrameReport detection_report(const RingDetection& det, const Eigen::Isometry3d& X_BC);

}  // namespace lander::flight
