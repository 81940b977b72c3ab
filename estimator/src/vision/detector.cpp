// The ring detector's frame (RingTargetDetector::detect): its stages in order (their code in
// detector_stages.h), the checks every pose must pass, tracking, keyframes and the output.
#include "lander/estimator/vision_detector.h"

#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "vision/detector_stages.h"

namespace lander {

const char* to_string(VisionStatus s) {
  switch (s) {
    case VisionStatus::Detected: return "detected";
    case VisionStatus::EmptyImage: return "empty_image";
    case VisionStatus::UnsupportedImage: return "unsupported_image";
    case VisionStatus::ImageSizeMismatch: return "image_size_mismatch";
    case VisionStatus::NoEllipses: return "no_ellipses";
    case VisionStatus::NoConcentricPairs: return "no_concentric_pairs";
    case VisionStatus::NoRingIdentified: return "no_ring_identified";
    case VisionStatus::TooFewRings: return "too_few_rings";
    case VisionStatus::PoseFailed: return "pose_failed";
    case VisionStatus::ReprojectionTooLarge: return "reprojection_too_large";
  }
  return "unknown";
}

const char* to_string(PoseSource s) {
  switch (s) {
    case PoseSource::None: return "none";
    case PoseSource::Rings: return "rings";
    case PoseSource::CentreRing: return "centre_ring";
    case PoseSource::Code: return "code";
    case PoseSource::Combined: return "combined";
  }
  return "unknown";
}

const char* to_string(KeyframeStatus s) {
  switch (s) {
    case KeyframeStatus::NotDetected: return "not_detected";
    case KeyframeStatus::First: return "first";
    case KeyframeStatus::Accepted: return "accepted";
    case KeyframeStatus::Rejected: return "rejected";
    case KeyframeStatus::Restarted: return "restarted";
  }
  return "unknown";
}

// Eq. (17)-(18): unit pose vectors I = P / |P| with P = [alpha, beta, gamma, dx, dy, dz],
// the rotation vector (Rodrigues) and the translation; rho = 1 - |I_old . I_new|.
double keyframe_rho(const Eigen::Isometry3d& X_old, const Eigen::Isometry3d& X_new) {
  auto unit = [](const Eigen::Isometry3d& X) {
    const Eigen::AngleAxisd aa(X.linear());
    Eigen::Matrix<double, 6, 1> P;
    P << aa.angle() * aa.axis(), X.translation();
    const double n = P.norm();
    return n > 0 ? Eigen::Matrix<double, 6, 1>(P / n) : P;
  };
  return 1.0 - std::abs(unit(X_old).dot(unit(X_new)));
}

RingTargetDetector::RingTargetDetector(CameraModel camera, TargetGeometry target,
                                       VisionParams params)
    : camera_(std::move(camera)), target_(std::move(target)), params_(std::move(params)) {
  camera_.validate();
  target_.validate();
  params_.validate();
}

void RingTargetDetector::reset() {
  have_prediction_ = false;
  have_keyframe_ = false;
  misses_ = 0;
  rejections_ = 0;
}

namespace {

using vision_internal::FrameContext;
using vision_internal::StageFailure;

bool supported_image(const cv::Mat& img) {
  const int ch = img.channels();
  return (ch == 1 || ch == 3 || ch == 4) && (img.depth() == CV_8U || img.depth() == CV_16U);
}

// Why `image` cannot be searched at all with the calibration `cam` (nullopt: it can).
std::optional<StageFailure> unusable_image(const cv::Mat& image, const CameraModel& cam) {
  if (image.empty()) return StageFailure{VisionStatus::EmptyImage, "empty image"};
  if (!supported_image(image)) {
    return StageFailure{VisionStatus::UnsupportedImage,
                        "unsupported pixel type (need 8/16-bit grey, BGR or BGRA)"};
  }
  if (image.cols != cam.width_px || image.rows != cam.height_px) {
    return StageFailure{VisionStatus::ImageSizeMismatch,
                        "image is " + std::to_string(image.cols) + "x" +
                            std::to_string(image.rows) + ", calibration is " +
                            std::to_string(cam.width_px) + "x" + std::to_string(cam.height_px)};
  }
  return std::nullopt;
}

// Whatever gave the pose (rings, the code, the centre ring, combined), it must show the
// camera in front of the target's top (faces_camera).
void check_faces_camera(RingDetection& d) {
  if (d.detected && !vision_internal::faces_camera(d.X_CP)) {
    d.detected = false;
    d.status = VisionStatus::PoseFailed;
    d.reason = std::string(to_string(d.source)) +
               " pose rejected: it puts the camera behind the target's surface (" + d.reason + ")";
  }
}

// Whatever gave the pose, its ring identities must fit the outer sets' radial profiles
// better than every turn of the layout onto itself (rotation_check.cpp). Not needed for a
// pose within half the layout's smallest turn (60 deg) of the track: the track's pose was
// checked or followed a checked one, so identities turned by a whole turn would put this
// pose at least 30 deg from it (it saves the check's 0.2-0.3 ms in tracked frames).
void check_ring_identities(FrameContext& f, const Eigen::Isometry3d* track, RingDetection& d) {
  constexpr double kTrackedMaxTurnRad = 30.0 * M_PI / 180.0;
  const bool follows_track =
      track != nullptr &&
      Eigen::AngleAxisd(track->linear().transpose() * d.X_CP.linear()).angle() < kTrackedMaxTurnRad;
  if (!(d.detected && f.p.rotation_check && !follows_track)) return;
  auto grey_of = [&](const cv::Rect& r) {
    f.grey_in(r);
    return f.grey;
  };
  const auto rc = vision_internal::check_set_rotation(f.image.size(), grey_of, f.cam, f.target,
                                                      d.X_CP, f.p.rotation_check_margin);
  if (!rc.passed) {
    d.detected = false;
    d.status = VisionStatus::PoseFailed;
    d.reason = std::string(to_string(d.source)) + " pose rejected: " + rc.verdict + " (margin " +
               std::to_string(f.p.rotation_check_margin) +
               "): ring identities read wrongly (" + d.reason + ")";
  } else if (rc.checked) {
    d.reason += "; " + rc.verdict;
  }
}

// Tracking state: constant-pose prediction, dropped after a few misses.
void update_track(const RingDetection& d, int max_misses, bool& have_prediction,
                  Eigen::Isometry3d& X_pred, int& misses) {
  if (d.detected) {
    have_prediction = true;
    X_pred = d.X_CP;
    misses = 0;
  } else if (++misses > max_misses) {
    have_prediction = false;
  }
}

// Keyframe selection, eq. (17)-(18): d's keyframe fields against the last keyframe `X_key`,
// which a keyframe replaces.
void select_keyframe(RingDetection& d, const VisionParams& p, bool& have_keyframe,
                     Eigen::Isometry3d& X_key, int& rejections) {
  if (!d.detected) {
    d.keyframe_status = KeyframeStatus::NotDetected;
  } else if (!have_keyframe) {
    d.keyframe = true;
    d.keyframe_status = KeyframeStatus::First;
  } else {
    d.rho = keyframe_rho(X_key, d.X_CP);
    if (d.rho <= p.rho_max) {
      d.keyframe = true;
      d.keyframe_status = KeyframeStatus::Accepted;
    } else if (++rejections > p.keyframe_reset_after) {
      d.keyframe = true;
      d.keyframe_status = KeyframeStatus::Restarted;
    } else {
      d.keyframe_status = KeyframeStatus::Rejected;
    }
  }
  if (d.keyframe) {
    have_keyframe = true;
    X_key = d.X_CP;
    rejections = 0;
  }
}

// d with detect()'s wall time since t0.
RingDetection timed(RingDetection d, std::chrono::steady_clock::time_point t0) {
  d.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

}  // namespace

RingDetection RingTargetDetector::detect(const cv::Mat& image, const Eigen::Vector2d& blur_px,
                                         double min_depth_m) {
  const auto t0 = std::chrono::steady_clock::now();
  if (const auto bad = unusable_image(image, camera_)) {
    RingDetection d;
    vision_internal::fail(d, *bad);
    return timed(std::move(d), t0);
  }
  // The track (the last pose) informs this frame only when tracking is on: with it off each
  // frame stands alone (single images, the estimator benchmark's independent views).
  const Eigen::Isometry3d* track = params_.tracking && have_prediction_ ? &X_CP_pred_ : nullptr;
  FrameContext f{image, camera_, target_, params_, blur_px, cv::Rect(0, 0, image.cols, image.rows)};
  f.min_depth_m = std::isfinite(min_depth_m) && min_depth_m > 0.0 ? min_depth_m : 0.0;
  // The rings: the predicted region, then the passes while no pose, and the code map (first
  // at close range); then the poses combined, then the checks every pose must pass.
  vision_internal::Found found;
  if (track != nullptr) {
    vision_internal::timed_stage(f.times.region_ms, [&] {
      vision_internal::try_predicted_region(f, *track, found);
    });
  }
  vision_internal::search_rings_and_code(f, track, found);
  RingDetection& d = found.d;
  vision_internal::timed_stage(f.times.checks_ms, [&] {
    vision_internal::combine_sources(d, found.cands, camera_.K(), target_, params_, track);
    check_faces_camera(d);
    check_ring_identities(f, track, d);
    update_track(d, params_.max_frames_without_detection, have_prediction_, X_CP_pred_, misses_);
    select_keyframe(d, params_, have_keyframe_, X_CP_key_, rejections_);
  });
  d.stage_ms = f.times;
  return timed(std::move(d), t0);
}

RingDetection detect_ring_target(const cv::Mat& image, const CameraModel& camera,
                                 const TargetGeometry& target, const VisionParams& params,
                                 const Eigen::Vector2d& blur_px) {
  VisionParams p = params;
  p.tracking = false;
  RingTargetDetector det(camera, target, p);
  return det.detect(image, blur_px);
}

PlatformObservation to_platform_observation(const RingDetection& d, double t_s) {
  PlatformObservation o;
  o.t_s = t_s;
  o.detected = d.detected;
  o.keyframe = d.keyframe;
  o.X_CP = d.X_CP;
  o.cov = d.cov;
  o.rings_identified = static_cast<int>(d.centres.size());
  o.reproj_err_px = d.reproj_err_px;
  return o;
}

std::string to_json(const RingDetection& d) {
  using Json = nlohmann::ordered_json;  // NaN and infinities are written as null
  const Eigen::Quaterniond q(d.X_CP.linear());
  const Eigen::Vector3d p = d.X_CP.translation();
  Json j;
  j["detected"] = d.detected;
  j["status"] = to_string(d.status);
  j["reason"] = d.reason;
  j["source"] = to_string(d.source);
  j["code"] = {{"searched", d.code_searched},
               {"region", d.code_region.area() > 0
                              ? Json::array({d.code_region.x, d.code_region.y,
                                             d.code_region.width, d.code_region.height})
                              : Json(nullptr)},
               {"detected", d.code.detected},
               {"reason", d.code.reason},
               {"cells_read", d.code.cells_read},
               {"local_white", d.code.local_white},
               {"corners", d.code.corners_px.size()},
               {"rotation", d.code.placement.rotation},
               {"reproj_rms_px", d.code.reproj_rms_px},
               {"reproj_gate_px", d.code.reproj_gate_px}};
  j["p_CP_m"] = {p.x(), p.y(), p.z()};
  j["q_CP_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
  Json cov = Json::array();
  for (int r = 0; r < 6; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 6; ++c) row.push_back(d.cov(r, c));
    cov.push_back(row);
  }
  j["cov_rot_trans"] = cov;
  j["reproj_err_px"] = d.reproj_err_px;
  j["reproj_err_sum_px2"] = d.reproj_err_sum_px2;
  j["edge_rms_px"] = d.edge_rms_px;
  j["reproj_gate_px"] = d.reproj_gate_px;  // the gates passed (or failed last; 0: no pose tried)
  j["edge_gate_px"] = d.edge_gate_px;
  j["keyframe"] = d.keyframe;
  j["keyframe_status"] = to_string(d.keyframe_status);
  j["rho"] = d.rho;
  j["used_roi"] = d.used_roi;
  j["rings_skipped"] = d.rings_skipped;
  j["deblurred"] = d.deblurred;
  j["unfiltered"] = d.unfiltered;
  j["zoomed"] = d.zoomed;
  j["by_layout"] = d.by_layout;
  j["by_platform"] = d.by_platform;
  j["roi"] = {d.roi.x, d.roi.y, d.roi.width, d.roi.height};
  j["time_ms"] = d.time_ms;
  Json centres = Json::array();
  for (const auto& c : d.centres) {
    centres.push_back({{"ring_id", c.ring_id},
                       {"centre_px", {c.centre_px.x(), c.centre_px.y()}},
                       {"centre_image_px", {c.centre_image_px.x(), c.centre_image_px.y()}},
                       {"radius_ratio", c.radius_ratio}});
  }
  j["centres"] = centres;
  Json ellipses = Json::array();
  for (const auto& e : d.ellipses) {
    ellipses.push_back({{"ring_id", e.ring_id},
                        {"outer", e.outer},
                        {"centre_px", {e.image.centre.x(), e.image.centre.y()}},
                        {"axes_px", {e.image.a, e.image.b}},
                        {"angle_rad", e.image.angle_rad},
                        {"fit_rms_px", e.fit_rms_px}});
  }
  j["ellipses"] = ellipses;
  // Invalid UTF-8 in a reason (never expected) is replaced rather than thrown.
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

CameraModel load_camera_model(const std::string& path) {
  CameraModel cam;
  read_params(load_yaml_file(path), path, cam);
  return cam;
}

}  // namespace lander
