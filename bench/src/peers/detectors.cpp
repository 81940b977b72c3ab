// Peer square-marker detectors (AprilTag, ArUco) + IPPE_SQUARE for the estimator benchmark.
#include <chrono>
#include <cmath>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "lander/bench/peer_detectors.h"

namespace lander::bench {


namespace {

using Clock = std::chrono::steady_clock;

cv::Mat to_grey(const cv::Mat& img) {
  cv::Mat g;
  if (img.channels() == 3) {
    cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  } else if (img.channels() == 4) {
    cv::cvtColor(img, g, cv::COLOR_BGRA2GRAY);
  } else {
    g = img;
  }
  return g;
}

// IPPE_SQUARE on the four corners (marker_corners_P order); fills X_CP and the RMS error.
bool square_pnp(PeerDetection& d, const CameraModel& cam, const TargetGeometry& g) {
  const double h = 0.5 * marker_side_m(g);
  const std::vector<cv::Point3d> obj = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  std::vector<cv::Point2d> img;
  for (const auto& c : d.corners_px) img.emplace_back(c.x(), c.y());
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(obj, img, camera_matrix_cv(cam), dist_coeffs_cv(cam), rvec, tvec, false,
                    cv::SOLVEPNP_IPPE_SQUARE)) {
    d.reason = "IPPE_SQUARE failed";
    return false;
  }
  std::vector<cv::Point2d> proj;
  cv::projectPoints(obj, rvec, tvec, camera_matrix_cv(cam), dist_coeffs_cv(cam), proj);
  double ss = 0;
  for (int i = 0; i < 4; ++i) ss += std::pow(cv::norm(proj[i] - img[i]), 2);
  d.reproj_err_px = std::sqrt(ss / 4);
  d.X_CP = pose_from_cv(rvec, tvec);
  return true;
}

}  // namespace

AprilTagDetector::AprilTagDetector() {
  auto* fam = tag36h11_create();
  auto* td = apriltag_detector_create();
  apriltag_detector_add_family(td, fam);
  td->nthreads = 1;          // one thread, as for ours
  td->quad_decimate = 1.0f;  // full resolution: best corner accuracy at range
  td->quad_sigma = 0.0f;
  td->refine_edges = true;
  td->decode_sharpening = 0.25;
  td_ = td;
  fam_ = fam;
}

AprilTagDetector::~AprilTagDetector() {
  apriltag_detector_destroy(static_cast<apriltag_detector_t*>(td_));
  tag36h11_destroy(static_cast<apriltag_family_t*>(fam_));
}

PeerDetection AprilTagDetector::detect(const cv::Mat& image, const CameraModel& cam,
                                       const TargetGeometry& g) {
  const auto t0 = Clock::now();
  PeerDetection d;
  if (image.empty() || image.depth() != CV_8U) {
    d.reason = "empty or non-8-bit image";
    return d;
  }
  cv::Mat grey = to_grey(image);
  if (!grey.isContinuous()) grey = grey.clone();
  image_u8_t im{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
  zarray_t* dets = apriltag_detector_detect(static_cast<apriltag_detector_t*>(td_), &im);
  for (int i = 0; i < zarray_size(dets); ++i) {
    apriltag_detection_t* det;
    zarray_get(dets, i, &det);
    if (det->id != kMarkerId || det->hamming > 0) continue;
    // libapriltag's p[] wrap counter-clockwise starting at the tag's bottom-left; reorder to
    // top-left, top-right, bottom-right, bottom-left, and shift by -0.5 px: the library puts
    // pixel centres at (x + 0.5, y + 0.5), OpenCV at integers.
    const int order[4] = {3, 2, 1, 0};
    for (int k = 0; k < 4; ++k) {
      d.corners_px[k] = Eigen::Vector2d(det->p[order[k]][0] - 0.5, det->p[order[k]][1] - 0.5);
    }
    d.detected = true;
    break;
  }
  apriltag_detections_destroy(dets);
  if (!d.detected) {
    d.reason = "no tag36h11 id 0 found";
  } else if (!square_pnp(d, cam, g)) {
    d.detected = false;
  }
  d.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return d;
}

PeerDetection detect_aruco(const cv::Mat& image, const CameraModel& cam, const TargetGeometry& g,
                           bool subpix) {
  const auto t0 = Clock::now();
  PeerDetection d;
  if (image.empty() || image.depth() != CV_8U) {
    d.reason = "empty or non-8-bit image";
    return d;
  }
  static const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_6X6_250);
  auto params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod =
      subpix ? cv::aruco::CORNER_REFINE_SUBPIX : cv::aruco::CORNER_REFINE_NONE;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(to_grey(image), dict, corners, ids, params);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (ids[i] != kMarkerId) continue;
    // ArUco order: top-left, top-right, bottom-right, bottom-left (marker_corners_P order).
    for (int k = 0; k < 4; ++k) d.corners_px[k] = Eigen::Vector2d(corners[i][k].x, corners[i][k].y);
    d.detected = true;
    break;
  }
  if (!d.detected) {
    d.reason = "no DICT_6X6_250 id 0 found";
  } else if (!square_pnp(d, cam, g)) {
    d.detected = false;
  }
  d.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return d;
}

}  // namespace lander::bench
