// Our ring and code-map detector behind the detector seam (components.h), and the report of
// one detection that both stacks give the recorder.
#include <ctime>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include "internal.h"
#include "lander/estimator/altitude_vision.h"
#include "lander/estimator/target.h"
#include "lander/flight/components.h"

namespace lander::flight {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

cv::Mat as_mat(const ImageView& v) {
  return cv::Mat(v.height_px, v.width_px, CV_8UC3, const_cast<std::uint8_t*>(v.bgr), static_cast<size_t>(v.stride_bytes));
}

FrameReport detection_report(const RingDetection& det, const Eigen::Isometry3d& X_BC) {
  FrameReport r;
  r.detected = det.detected;
  r.reason = to_string(det.status);
  r.keyframe = det.detected && det.keyframe;
  r.keyframe_rejected = det.detected && det.keyframe_status == KeyframeStatus::Rejected;
  if (det.detected) r.vision_height_m = height_above_target_m(det.X_CP, X_BC);
  r.rings = static_cast<int>(det.centres.size());
  r.reproj_err_px = det.reproj_err_px;
  r.deblurred = det.deblurred;
  r.unfiltered = det.unfiltered;
  r.zoomed = det.zoomed;
  r.by_layout = det.by_layout;
  r.by_platform = det.by_platform;
  r.used_roi = det.used_roi;
  r.code_searched = det.code_searched;
  for (const auto& e : det.ellipses) {
    r.ellipses.push_back({e.image.centre, e.image.a, e.image.b, e.image.angle_rad, e.ring_id >= 0});
  }
  for (const auto& c : det.centres) r.points.push_back({c.centre_image_px, std::to_string(c.ring_id)});
  r.overlay_text = det.detected ? fmt::format("rings {}  reproj {:.2f} px  rho {:.4f}{}", det.centres.size(),
                                              det.reproj_err_px, det.rho, det.keyframe ? "" : "  (not a keyframe)")
                                : std::string("no target: ") + to_string(det.status);
  return r;
}

void apply_vision_fault(PlatformObservation& obs, const VisionFault& fault) {
  if (fault.kind == VisionFault::Kind::kOffsetAlongAxis) {
    obs.X_CP.translation().z() += fault.offset_m;
    return;
  }
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  obs.detected = true;
  obs.keyframe = true;
  obs.X_CP.translation().setConstant(kNaN);
  obs.cov.setConstant(kNaN);
}

const FlightConfig& validated(const FlightConfig& c) {
  c.validate();
  return c;
}

namespace {

class RingVisionDetector final : public VisionDetector {
 public:
  explicit RingVisionDetector(const FlightConfig& c)
      : X_BC_(c.mount.X_BC()), detector_(c.camera, TargetGeometry::load(c.target_path), c.estimator.vision) {}
  Detection detect(const ImageView& image, const CameraFrameIn& frame, const Eigen::Vector2d& blur_px) override {
    const auto t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    const RingDetection det = detector_.detect(as_mat(image), blur_px);
    Detection d;
    d.obs = to_platform_observation(det, frame.exposure.mid());
    d.report = detection_report(det, X_BC_);
    d.report.detector_cpu_ms = thread_cpu_ms() - c0;
    d.report.detector_ms = ms_since(t0);
    return d;
  }

 private:
  Eigen::Isometry3d X_BC_;
  RingTargetDetector detector_;
};

}  // namespace

std::unique_ptr<VisionDetector> make_ring_detector(const FlightConfig& config) {
  return std::make_unique<RingVisionDetector>(validated(config));
}

}  // namespace lander::flight
