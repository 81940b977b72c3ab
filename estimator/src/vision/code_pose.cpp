// The code map's stage 5 (code_stages.h): the placed map's corners refined to sub-pixel in
// the image and the pose X_CP from them by planar PnP, with its gate and covariance.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/code_stages.h"
#include "vision/internal.h"

namespace lander::vision_internal::code_map {

namespace {

// Corner refinement: the sub-pixel corner must stay within this fraction of a cell of its
// prediction.
constexpr double kCornerMoveFrac = 0.25;
// Corner outlier rejection after the first pose (detect_code_pattern, step 5): at most this
// many drop-and-solve passes ...
constexpr int kCodeOutlierPasses = 2;
// ... and the corners kept must be at least this fraction of those refined: a pose is fitted
// on the majority of the placement's corners, never on a few that happen to agree.
constexpr double kMinCodeInlierFraction = 0.6;
// Corners closer than this to the central ring's inner circle are dropped (fraction of a
// cell): the annulus edge would enter the cornerSubPix window.
constexpr double kRingClearanceCells = 0.8;

// The map corners predicted in the image: raw px for cornerSubPix, undistorted px, and the
// corners in P (m).
struct PredictedCorners {
  std::vector<cv::Point2f> raw_px;
  std::vector<Eigen::Vector2d> undist_px;
  std::vector<Eigen::Vector2d> P_m;
};

// Every map corner with an L or X pattern, clear of the ring, through the placement and H,
// at least the cornerSubPix window `win` inside the frame.
PredictedCorners predict_map_corners(const cv::Mat& grey, const CameraModel& cam,
                                     const TargetGeometry& g, const std::vector<std::uint8_t>& map,
                                     const CodePlacement& placement, const Eigen::Matrix3d& H,
                                     int win) {
  PredictedCorners c;
  const ExtendedMap em = extended_map(g, map);
  const int n = g.code.cells;
  const double half = 0.5 * g.code.side_m(), cm = g.code.cell_m;
  const double inner_r = central_inner_radius_m(g);
  const int qi = (4 - placement.rotation) % 4;
  for (int row = 0; row <= n; ++row) {
    for (int col = 0; col <= n; ++col) {
      const int tl = em.at(col - 1, row - 1), tr = em.at(col, row - 1);
      const int bl = em.at(col - 1, row), br = em.at(col, row);
      if (tl == 2 || tr == 2 || bl == 2 || br == 2) continue;
      if (tl == tr && bl == br) continue;  // straight horizontal edge or uniform
      if (tl == bl && tr == br) continue;  // straight vertical edge
      const Eigen::Vector2d P(-half + col * cm, half - row * cm);
      if (P.norm() > inner_r - kRingClearanceCells * cm) continue;
      // Map vertex -> observed lattice: (a, b) = rot^-1((col, row) - offset).
      const Eigen::Vector2i l =
          rotate_lattice(col - placement.col_offset, row - placement.row_offset, qi);
      const Eigen::Vector2d u = apply_h(H, l.cast<double>());
      const Eigen::Vector2d r = cam.distort_px(u);
      if (r.x() < win + 2 || r.y() < win + 2 || r.x() > grey.cols - win - 3 ||
          r.y() > grey.rows - win - 3) {
        continue;
      }
      c.raw_px.emplace_back(static_cast<float>(r.x()), static_cast<float>(r.y()));
      c.undist_px.push_back(u);
      c.P_m.push_back(P);
    }
  }
  return c;
}

// IPPE's solution in front of the camera with the smaller reprojection error, refined by
// Levenberg-Marquardt into rvec, tvec; false if none.
bool solve_corner_pnp(const std::vector<cv::Point3d>& obj, const std::vector<cv::Point2d>& ip,
                      const cv::Mat& Kcv, cv::Mat& rvec, cv::Mat& tvec) {
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solvePnPGeneric(obj, ip, Kcv, cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    return false;
  }
  double best = 1e18;
  for (std::size_t s = 0; s < rvecs.size(); ++s) {
    if (tvecs[s].at<double>(2) <= 0) continue;
    std::vector<cv::Point2d> pr;
    cv::projectPoints(obj, rvecs[s], tvecs[s], Kcv, cv::noArray(), pr);
    double e = 0.0;
    for (std::size_t i = 0; i < pr.size(); ++i) e += cv::norm(pr[i] - ip[i]);
    if (e < best) {
      best = e;
      rvec = rvecs[s].clone();
      tvec = tvecs[s].clone();
    }
  }
  if (best >= 1e18) return false;
  cv::solvePnPRefineLM(obj, ip, Kcv, cv::noArray(), rvec, tvec,
                       cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50,
                                        1e-10));
  return true;
}

// Drops the corners off the pose by more than a robust gate and solves again (pose.inliers,
// rvec, tvec updated); pose.reproj_rms_px is the last pose's RMS. False (pose.why) when too
// few corners are left or the PnP fails.
bool drop_corner_outliers(CornerPose& pose, const cv::Mat& Kcv, cv::Mat& rvec, cv::Mat& tvec,
                          const VisionParams& p) {
  std::vector<cv::Point3d>& obj = pose.inliers.corners_P_m;
  std::vector<cv::Point2d>& ip = pose.inliers.corners_px;
  // Outliers: a corner that cornerSubPix pulled onto another edge (a shadow's edge across the
  // cell corner: the vehicle's own shadow in the last metre) sits pixels off while the rest
  // fit within a tenth of a pixel, and a fifth of such corners lift the RMS above the gate.
  // So the scale is robust (1.4826 x the median residual, not the RMS they inflate): corners
  // beyond max(gate, 3 x scale) are dropped and the pose solved again, up to
  // kCodeOutlierPasses times, keeping at least kMinCodeInlierFraction of the corners and
  // code_min_corners. On clean frames (median residual below 0.22 px) the threshold is the
  // gate itself, as with the former single pass at 3 x RMS.
  const std::size_t n_corners = obj.size();
  for (int pass = 0;; ++pass) {
    std::vector<cv::Point2d> pr;
    cv::projectPoints(obj, rvec, tvec, Kcv, cv::noArray(), pr);
    std::vector<double> res(pr.size());
    double ss = 0.0;
    for (std::size_t i = 0; i < pr.size(); ++i) {
      res[i] = cv::norm(pr[i] - ip[i]);
      ss += res[i] * res[i];
    }
    pose.reproj_rms_px = std::sqrt(ss / pr.size());
    if (pass == kCodeOutlierPasses) break;
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double scale = 1.4826 * sorted[sorted.size() / 2];
    const double gate = std::max(p.code_max_reproj_px, 3.0 * scale);
    std::vector<cv::Point3d> o2;
    std::vector<cv::Point2d> i2;
    for (std::size_t i = 0; i < pr.size(); ++i) {
      if (res[i] <= gate) {
        o2.push_back(obj[i]);
        i2.push_back(ip[i]);
      }
    }
    if (o2.size() == obj.size()) break;
    if (static_cast<int>(o2.size()) < p.code_min_corners ||
        static_cast<double>(o2.size()) < kMinCodeInlierFraction * static_cast<double>(n_corners)) {
      pose.why = "too many corner outliers (" + std::to_string(n_corners - o2.size()) + " of " +
                 std::to_string(n_corners) + ")";
      return false;
    }
    obj = o2;
    ip = i2;
    if (!solve_corner_pnp(obj, ip, Kcv, rvec, tvec)) {
      pose.why = "PnP failed";
      return false;
    }
  }
  return true;
}

// The corner gate (the larger of code_max_reproj_px and code_max_reproj_fraction x the
// corners' spread) into pose.reproj_gate_px; false (pose.why) when the RMS is above it.
bool pass_corner_gate(CornerPose& pose, const VisionParams& p) {
  // The gate grows with the code's extent in the image (code_max_reproj_fraction of the
  // corners' RMS distance from their centroid): a relative calibration error (pixel aspect)
  // leaves residuals in proportion to that extent, largest in the last decimetres.
  cv::Scalar corner_mean, corner_sd;
  cv::meanStdDev(pose.inliers.corners_px, corner_mean, corner_sd);
  const double spread_px = std::hypot(corner_sd[0], corner_sd[1]);
  const double reproj_gate =
      vision_internal::scaled_gate(p.code_max_reproj_px, p.code_max_reproj_fraction, spread_px);
  pose.reproj_gate_px = reproj_gate;
  if (!(pose.reproj_rms_px <= reproj_gate)) {
    std::ostringstream os;
    os << "corner reprojection " << pose.reproj_rms_px << " px above the gate " << reproj_gate
       << " px (the larger of code_max_reproj_px and code_max_reproj_fraction x the corners' "
          "spread, "
       << spread_px << " px)";
    pose.why = os.str();
    return false;
  }
  return true;
}

// Covariance sigma^2 (J^T J)^-1 over [rvec, tvec] into pose.cov; false if J^T J is singular.
bool corner_covariance(CornerPose& pose, const cv::Mat& Kcv, const cv::Mat& rvec,
                       const cv::Mat& tvec) {
  const std::vector<cv::Point3d>& obj = pose.inliers.corners_P_m;
  std::vector<cv::Point2d> pr;
  cv::Mat J;
  cv::projectPoints(obj, rvec, tvec, Kcv, cv::noArray(), pr, J);
  Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
  for (int r = 0; r < J.rows; ++r) {
    Eigen::Matrix<double, 6, 1> gr;
    for (int c = 0; c < 6; ++c) gr(c) = J.at<double>(r, c);
    JtJ += gr * gr.transpose();
  }
  const double dof = std::max(1.0, 2.0 * obj.size() - 6.0);
  const double sigma2 = pose.reproj_rms_px * pose.reproj_rms_px * 2.0 * obj.size() / dof;
  Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(JtJ);
  if (!lu.isInvertible()) return false;
  pose.cov = sigma2 * lu.inverse();
  return true;
}

}  // namespace

std::optional<CornerMatches> map_corner_matches(const cv::Mat& grey, const CameraModel& cam,
                                                const TargetGeometry& g,
                                                const std::vector<std::uint8_t>& map,
                                                const CodePlacement& placement,
                                                const Eigen::Matrix3d& H, double cell_px,
                                                const VisionParams& p, std::string& why) {
  // The corners predicted, with a cornerSubPix window of a quarter cell.
  const int win = std::clamp(static_cast<int>(std::lround(0.25 * cell_px)), 2, 10);
  const PredictedCorners pc = predict_map_corners(grey, cam, g, map, placement, H, win);
  if (static_cast<int>(pc.raw_px.size()) < p.code_min_corners) {
    why = std::to_string(pc.raw_px.size()) + " corners in view";
    return std::nullopt;
  }
  // Refined to sub-pixel; those that moved more than kCornerMoveFrac of a cell are dropped.
  std::vector<cv::Point2f> refined = pc.raw_px;
  cv::cornerSubPix(grey, refined, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01));
  const std::vector<Eigen::Vector2d> ref_u = undistort_points(cam, refined);
  CornerMatches m;
  for (std::size_t i = 0; i < refined.size(); ++i) {
    if ((ref_u[i] - pc.undist_px[i]).norm() > kCornerMoveFrac * cell_px) continue;
    m.corners_P_m.emplace_back(pc.P_m[i].x(), pc.P_m[i].y(), 0.0);
    m.corners_px.emplace_back(ref_u[i].x(), ref_u[i].y());
  }
  if (static_cast<int>(m.corners_P_m.size()) < p.code_min_corners) {
    why = std::to_string(m.corners_P_m.size()) + " corners refined";
    return std::nullopt;
  }
  return m;
}

CornerPose code_corner_pose(CornerMatches matches, const CameraModel& cam,
                            const VisionParams& p) {
  CornerPose pose;
  pose.inliers = std::move(matches);
  const cv::Mat Kcv = camera_matrix_cv(cam);
  cv::Mat rvec, tvec;
  // IPPE + LM on all matches, then again without the outliers.
  if (!solve_corner_pnp(pose.inliers.corners_P_m, pose.inliers.corners_px, Kcv, rvec, tvec)) {
    pose.why = "PnP failed";
    return pose;
  }
  if (!drop_corner_outliers(pose, Kcv, rvec, tvec, p)) return pose;
  // The gate on the corners' RMS, then the covariance.
  if (!pass_corner_gate(pose, p)) return pose;
  if (!corner_covariance(pose, Kcv, rvec, tvec)) {
    pose.why = "singular corner Jacobian";
    return pose;
  }
  pose.X_CP = pose_from_cv(rvec, tvec);
  pose.ok = true;
  return pose;
}

}  // namespace lander::vision_internal::code_map
