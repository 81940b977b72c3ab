// Helpers the flight stacks share (flight/src only).
#pragma once

#include <chrono>

#include <opencv2/core.hpp>

#include "lander/estimator/vision_detector.h"
#include "lander/flight/flight_config.h"
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
// An injected vision fault (flight_software.h, VisionFault) on a frame's observation: the
// pose pushed along the optical axis, or a claimed keyframe detection with a NaN pose and
// covariance. The caller updates what it derives from the pose (the vision height).
void apply_vision_fault(PlatformObservation& obs, const VisionFault& fault);
// The configuration, after validate() (throws ConfigError naming the key).
const FlightConfig& validated(const FlightConfig& c);

}  // namespace lander::flight
