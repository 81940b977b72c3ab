// One frame's searches for the rings (issue 12: far, grazing, blurred and shadowed views): the
// predicted region, then while no pose the ordered passes try_<pass>(frame, so_far), each
// recording why its tries failed one way (TriedLog); then the code map (seed 001).
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/detector_stages.h"

namespace lander::vision_internal {

// 8-bit grey frame in which at least `region` is converted: 8-bit grey input is used as is;
// otherwise only `region` of a per-thread full-size buffer is converted (tracking then pays
// for the ROI only).
void grey_region(const cv::Mat& img, const cv::Rect& region, cv::Mat& grey) {
  if (img.channels() == 1 && img.depth() == CV_8U) {
    grey = img;
    return;
  }
  thread_local cv::Mat buf;
  if (buf.size() != img.size()) buf.create(img.size(), CV_8UC1);
  const cv::Mat src = img(region);
  cv::Mat dst = buf(region);  // a view: the conversions below write into the buffer
  const int code = img.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY;
  if (img.depth() == CV_8U) {
    cv::cvtColor(src, dst, code);
  } else if (img.channels() == 1) {
    src.convertTo(dst, CV_8U, 1.0 / 256.0);
  } else {
    cv::Mat g16;
    cv::cvtColor(src, g16, code);
    g16.convertTo(dst, CV_8U, 1.0 / 256.0);
  }
  grey = buf;
}

void FrameContext::whole_grey() {
  if (!grey_full) grey_region(image, full, grey);
  grey_full = true;
}

void FrameContext::grey_in(const cv::Rect& r) {
  if (!grey_full) grey_region(image, r, grey);
}

cv::Rect covering_rect(double x0, double y0, double x1, double y1, const cv::Rect& full) {
  return cv::Rect(cv::Point(static_cast<int>(std::floor(clamp_coord(x0))),
                            static_cast<int>(std::floor(clamp_coord(y0)))),
                  cv::Point(static_cast<int>(std::ceil(clamp_coord(x1))),
                            static_cast<int>(std::ceil(clamp_coord(y1))))) &
         full;
}

// ---- one region: the global segmentation, then the shadow-tolerant one ----

namespace {

// A pose from the global threshold is kept unless a shadow's edge crosses one of the
// ellipses it used: at 50 % light the global level still meets the shadowed edges, near
// their light end, and the pose is biased (seen: 3.6 deg at 10 m). Then the shadow pass
// decides, and its pose is used if it gives one.
bool shadow_crosses(const Found& f) {
  bool shadowed = false;
  for (const auto& c : f.d.centres) {
    for (int i : {c.outer_index, c.inner_index}) {
      if (i >= 0 && i < static_cast<int>(f.cands.size()) && f.cands[i].two_lights) shadowed = true;
    }
  }
  return shadowed;
}

// A shadow-pass pose must fit its edge points as a clean pose does (0.02-0.1 px RMS on the
// rendered frames): an ellipse the shadow still biases (the central ring's inner circle,
// whose code cells hide the shadow's edge) pulled one pose 59 deg off at 10 m with 0.79 px.
constexpr double kShadowMaxEdgeResidualPx = 0.5;
bool shadow_pose_clean(RingDetection& ds) {
  if (!(ds.edge_rms_px > kShadowMaxEdgeResidualPx)) return true;
  ds.detected = false;
  ds.status = VisionStatus::PoseFailed;
  ds.reason = "conic fit residual " + std::to_string(ds.edge_rms_px) + " px above the shadow "
              "pass's " + std::to_string(kShadowMaxEdgeResidualPx) + " px";
  return false;
}

// The shadow pass's result `s` (`ok`: its pose) against the global one in `out` (`found`):
// it replaces it when it gives a pose, or identifies more ring sets (for the fewer-ring poses
// of combine_sources); the first pass's reason is kept.
bool merge_shadow_pass(bool found, bool ok, Found& out, Found& s) {
  RingDetection& d = out.d;
  // Both passes gave a pose: the one that reprojects the ring centres better.
  if (found && ok && s.d.reproj_err_px > d.reproj_err_px) {
    d.reason += "; a shadow's edge crosses its ellipses; the shadow pass's pose reprojects "
                "worse (" + std::to_string(s.d.reproj_err_px) + " px), not used";
    return true;
  }
  if (found && !ok) {
    d.reason += "; a shadow's edge crosses its ellipses, the shadow pass found no pose: " +
                s.d.reason;
    return true;
  }
  if (ok || s.d.centres.size() > d.centres.size()) {
    s.d.reason = "shadow pass: " + s.d.reason + " (global threshold: " + d.reason + ")";
    out = std::move(s);
  } else {
    d.reason += "; shadow pass: " + s.d.reason;
  }
  return ok;
}

}  // namespace

bool search_region(const cv::Mat& grey, const cv::Rect& roi, const CameraModel& cam,
                   const TargetGeometry& target, const VisionParams& p, Found& out,
                   const std::function<bool()>& before_shadow) {
  const bool found = run_region({grey, roi, cam, target, p}, out.d, out.cands);
  if (found && !shadow_crosses(out)) return true;
  if (!found && before_shadow && before_shadow()) return false;
  if (!p.shadow_pass) return found;
  Found s;
  bool ok = run_region({grey, roi, cam, target, p, true}, s.d, s.cands);
  if (ok) ok = shadow_pose_clean(s.d);
  return merge_shadow_pass(found, ok, out, s);
}

// ---- the passes ----

namespace {

// The pixel bounds of points in the camera frame (all in front of it), projected through the
// camera with its distortion.
struct PixelBounds {
  double x0{1e18}, y0{1e18}, x1{-1e18}, y1{-1e18};
};
PixelBounds projected_bounds(const std::vector<cv::Point3d>& pts_C, const CameraModel& cam) {
  std::vector<cv::Point2d> img;
  cv::projectPoints(pts_C, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix_cv(cam),
                    dist_coeffs_cv(cam), img);
  PixelBounds b;
  for (const auto& q : img) {
    b.x0 = std::min(b.x0, q.x);
    b.y0 = std::min(b.y0, q.y);
    b.x1 = std::max(b.x1, q.x);
    b.y1 = std::max(b.y1, q.y);
  }
  return b;
}

}  // namespace

std::vector<cv::Point3d> outer_circle_C(const RingSet& ring, const Eigen::Isometry3d& X) {
  std::vector<cv::Point3d> pts;
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * M_PI * k / 12;
    const Eigen::Vector3d q =
        X * Eigen::Vector3d(ring.centre_P_m.x() + ring.outer_radius_m * std::cos(a),
                            ring.centre_P_m.y() + ring.outer_radius_m * std::sin(a), 0);
    if (q.z() > 0.05) pts.emplace_back(q.x(), q.y(), q.z());
  }
  return pts;
}

bool wholly_in_view(const FrameContext& f, const RingSet& ring, const Eigen::Isometry3d& X) {
  const std::vector<cv::Point3d> pts = outer_circle_C(ring, X);
  if (pts.size() < 12) return false;
  const auto [x0, y0, x1, y1] = projected_bounds(pts, f.cam);
  const bool inside = x0 >= 0 && y0 >= 0 && x1 <= f.full.width - 1 && y1 <= f.full.height - 1;
  return inside && 0.5 * std::max(x1 - x0, y1 - y0) >= f.p.min_axis_px;
}

int ring_sets_in_view(const FrameContext& f, const Eigen::Isometry3d& X) {
  int n = 0;
  for (const auto& ring : f.target.rings) n += wholly_in_view(f, ring, X);
  return n;
}

namespace {

// Predicted region: the outer circles projected with the last pose, plus a margin; nullopt
// when none is in front or the region is too small or most of the frame.
std::optional<cv::Rect> predicted_region(const FrameContext& f, const Eigen::Isometry3d& X_pred) {
  std::vector<cv::Point3d> pts;
  for (const auto& ring : f.target.rings) {
    const std::vector<cv::Point3d> circle = outer_circle_C(ring, X_pred);
    pts.insert(pts.end(), circle.begin(), circle.end());
  }
  if (pts.empty()) return std::nullopt;
  const auto [x0, y0, x1, y1] = projected_bounds(pts, f.cam);
  const double mx = f.p.roi_margin * (x1 - x0), my = f.p.roi_margin * (y1 - y0);
  const cv::Rect2d r(x0 - mx, y0 - my, x1 - x0 + 2 * mx, y1 - y0 + 2 * my);
  const cv::Rect roi = covering_rect(r.x, r.y, r.x + r.width, r.y + r.height, f.full);
  if (roi.width >= 16 && roi.height >= 16 && roi.area() < 0.7 * f.full.area()) return roi;
  return std::nullopt;
}

// Why a pass's tries failed, in order ("; <what>: <reason>" each): the frame's reason gets
// them when the pass ends without a pose.
struct TriedLog {
  std::string text;
  void failed(const std::string& what, const RingDetection& tried) {
    text += "; " + what + ": " + tried.reason;
  }
  void close(Found& so_far) const {
    if (!so_far.d.detected) so_far.d.reason += text;
  }
};
// A try's pose becomes the frame's result, with the reason `reason`.
void adopt(Found& so_far, Found& tried, std::string reason) {
  tried.d.reason = std::move(reason);
  so_far = std::move(tried);
}

// The whole frame (the predicted region gave no pose, or there was none).
void try_full_frame(FrameContext& f, Found& so_far) {
  if (!f.big_enough()) {
    so_far.d.status = VisionStatus::NoEllipses;
    so_far.d.reason = "image too small to hold the target";
    return;
  }
  f.whole_grey();
  search_region(f.grey, f.full, f.cam, f.target, f.p, so_far, f.before_shadow);
}

// Blur-aware pass (issue 12): no pose from the frame as it is, and the caller predicts a
// blur long enough to close the inner circles and bridge the gaps: the rings again, on the
// frame deconvolved with that blur. The acceptance gates are the same.
void try_deblurred(FrameContext& f, Found& so_far) {
  const Eigen::Vector2d& blur = f.blur_px;
  if (!(f.p.deblur_min_px > 0 && blur.allFinite() && blur.norm() >= f.p.deblur_min_px &&
        f.big_enough())) {
    return;
  }
  f.whole_grey();
  f.sharp = wiener_deblur(f.grey, blur, f.p.deblur_noise_ratio);
  std::ostringstream os;
  os << "deconvolved for a predicted blur of " << blur.norm() << " px";
  Found t;
  TriedLog log;
  if (search_region(f.sharp, f.full, f.cam, f.target, f.p, t)) {
    t.d.deblurred = true;
    adopt(so_far, t, t.d.reason + "; " + os.str());
  } else {
    log.failed(os.str(), t.d);
  }
  log.close(so_far);
}

// Unfiltered pass (issue 12: far and grazing views): no pose, and the failed passes found
// small ellipses. The pre-filter that makes large rings' edges precise closes the inner
// circles of sets 5-8 px across and reads their ratios low (a set named as its neighbour in
// ratio); the frame (then the deconvolved frame, if any) is searched again without it,
// under the same gates. Frames detected with the filter are untouched.
void try_unfiltered(FrameContext& f, Found& so_far) {
  if (!(f.p.unfiltered_pass && f.p.gaussian_sigma_px > 0 && f.big_enough())) return;
  int small = 0;
  for (const auto& e : so_far.d.ellipses) small += e.image.b <= f.p.unfiltered_max_minor_px;
  if (small < f.p.unfiltered_min_ellipses) return;
  f.whole_grey();
  VisionParams pu = f.p;
  pu.gaussian_sigma_px = 0.0;
  TriedLog log;
  for (const cv::Mat* frame : {&f.grey, &f.sharp}) {
    if (frame->empty()) continue;
    const bool deconvolved = frame == &f.sharp;
    const std::string what =
        deconvolved ? "unfiltered pass on the deconvolved frame" : "unfiltered pass";
    Found t;
    if (search_region(*frame, f.full, f.cam, f.target, pu, t)) {
      t.d.unfiltered = true;
      t.d.deblurred = deconvolved;
      adopt(so_far, t,
            what + ": " + t.d.reason + " (pre-filtered: " + so_far.d.reason + log.text + ")");
      break;
    }
    log.failed(what, t.d);
  }
  log.close(so_far);
}

// Regions for the zoomed pass: clusters of the failed pass's small ellipses (a ring set and
// its neighbours lie within a few of their radii of each other), the most populous first,
// each grown by its own size on every side (the sets not found lie around the ones found).
struct Cluster {
  int count{0};
  double x0{1e18}, y0{1e18}, x1{-1e18}, y1{-1e18};
};
// The clusters of the small ellipses (zoom_min_axis..zoom_max_axis), most populous first.
std::vector<Cluster> small_ellipse_clusters(const std::vector<DetectedEllipse>& ellipses,
                                            const VisionParams& p) {
  std::vector<int> idx;
  for (int i = 0; i < static_cast<int>(ellipses.size()); ++i) {
    const auto& e = ellipses[i].image;
    if (e.a >= p.min_axis_px && e.a <= p.zoom_max_axis_px) idx.push_back(i);
  }
  const int n = static_cast<int>(idx.size());
  std::vector<int> label(n);
  for (int i = 0; i < n; ++i) label[i] = i;
  auto root = [&](int i) {
    while (label[i] != i) i = label[i] = label[label[i]];
    return i;
  };
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const auto& a = ellipses[idx[i]].image;
      const auto& b = ellipses[idx[j]].image;
      if ((a.centre - b.centre).norm() <= 4.0 * std::max(a.a, b.a) + 4.0) label[root(i)] = root(j);
    }
  }
  std::map<int, Cluster> clusters;
  for (int i = 0; i < n; ++i) {
    const auto& e = ellipses[idx[i]].image;
    Cluster& c = clusters[root(i)];
    ++c.count;
    c.x0 = std::min(c.x0, e.centre.x() - e.a);
    c.y0 = std::min(c.y0, e.centre.y() - e.a);
    c.x1 = std::max(c.x1, e.centre.x() + e.a);
    c.y1 = std::max(c.y1, e.centre.y() + e.a);
  }
  std::vector<Cluster> order;
  for (const auto& kv : clusters) {
    if (kv.second.count >= 2) order.push_back(kv.second);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const Cluster& a, const Cluster& b) { return a.count > b.count; });
  return order;
}
std::vector<cv::Rect> zoom_regions(const std::vector<DetectedEllipse>& ellipses,
                                   const cv::Rect& full, const VisionParams& p) {
  std::vector<cv::Rect> out;
  for (const Cluster& c : small_ellipse_clusters(ellipses, p)) {
    if (static_cast<int>(out.size()) >= p.zoom_max_regions) break;
    const double gx = std::max(c.x1 - c.x0, 8.0), gy = std::max(c.y1 - c.y0, 8.0);
    const double g = std::max(gx, gy);
    const cv::Rect r = covering_rect(c.x0 - g, c.y0 - g, c.x1 + g, c.y1 + g, full);
    if (r.width < 8 || r.height < 8 || r.width > p.zoom_max_region_px ||
        r.height > p.zoom_max_region_px) {
      continue;
    }
    out.push_back(r);
  }
  return out;
}

// Maps a detection made on the zoomed region back to the frame's pixels (the pose does not
// change with the magnification; pixel residuals shrink by s).
void unzoom(Found& z, const cv::Rect& region, int s) {
  RingDetection& d = z.d;
  const Eigen::Vector2d t(s * (0.5 - region.x) - 0.5, s * (0.5 - region.y) - 0.5);
  auto back = [&](const Eigen::Vector2d& u) -> Eigen::Vector2d { return (u - t) / s; };
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();  // zoomed = T * frame (homogeneous)
  T(0, 0) = T(1, 1) = s;
  T(0, 2) = t.x();
  T(1, 2) = t.y();
  auto conic_back = [&](const Conic& C) {
    Conic Cf = T.transpose() * C * T;
    normalise_conic(Cf);
    return Cf;
  };
  auto ellipse_back = [&](EllipseParams e) {
    e.centre = back(e.centre);
    e.a /= s;
    e.b /= s;
    return e;
  };
  for (auto& c : d.centres) {
    c.centre_px = back(c.centre_px);
    c.centre_image_px = back(c.centre_image_px);
  }
  for (auto& e : d.ellipses) {
    e.C = conic_back(e.C);
    e.image = ellipse_back(e.image);
    e.fit_rms_px /= s;
  }
  for (auto& c : z.cands) {
    c.C = conic_back(c.C);
    c.image = ellipse_back(c.image);
    c.undist = ellipse_back(c.undist);
    for (auto& q : c.points) q = back(q);
    c.fit_rms_px /= s;
  }
  d.reproj_err_px /= s;
  d.reproj_err_sum_px2 /= static_cast<double>(s) * s;
  d.edge_rms_px /= s;
  d.roi = region;
}

// Zoomed pass (issue 12: far and grazing views): no pose, and the failed passes found small
// ellipses in a cluster: the cluster's region magnified twice (bicubic) and searched again
// with the camera model of the magnified region, under the same gates in its pixels (so
// twice as strict in the frame's). At 10-15 m and 45-60 deg the ring sets are 5-8 px across
// and the thin annuli's contours break or merge at the frame's resolution.
void try_zoomed(FrameContext& f, Found& so_far) {
  if (!(f.p.zoom_pass && f.big_enough())) return;
  f.whole_grey();
  constexpr int kZoom = 2;
  TriedLog log;
  for (const cv::Rect& region : zoom_regions(so_far.d.ellipses, f.full, f.p)) {
    cv::Mat zoomed;
    cv::resize(f.grey(region), zoomed, cv::Size(), kZoom, kZoom, cv::INTER_CUBIC);
    const CameraModel zcam = zoomed_camera(f.cam, region, kZoom);
    Found t;
    const bool ok = search_region(zoomed, cv::Rect(0, 0, zoomed.cols, zoomed.rows), zcam,
                                  f.target, f.p, t);
    std::ostringstream os;
    os << "zoomed x" << kZoom << " on " << region.width << "x" << region.height << " px at ("
       << region.x << ", " << region.y << ")";
    if (ok) {
      unzoom(t, region, kZoom);
      t.d.zoomed = true;
      adopt(so_far, t, os.str() + ": " + t.d.reason + " (frame: " + so_far.d.reason + ")");
      break;
    }
    log.failed(os.str(), t.d);
  }
  log.close(so_far);
}

// The platform top `q`'s search region (its corners' box grown by a quarter and 8 px) and
// the pass's name for it.
cv::Rect platform_region(const PlatformQuad& q, const cv::Rect& full, std::string& what) {
  double x0 = q.corners[0].x(), x1 = x0, y0 = q.corners[0].y(), y1 = y0;
  for (const auto& c : q.corners) {
    x0 = std::min(x0, c.x()), x1 = std::max(x1, c.x());
    y0 = std::min(y0, c.y()), y1 = std::max(y1, c.y());
  }
  const double gx = 0.25 * (x1 - x0) + 8, gy = 0.25 * (y1 - y0) + 8;
  std::ostringstream os;
  os << "platform pass on " << static_cast<int>(x1 - x0) << "x" << static_cast<int>(y1 - y0)
     << " px at (" << static_cast<int>(x0) << ", " << static_cast<int>(y0) << ")";
  what = os.str();
  return covering_rect(x0 - gx, y0 - gy, x1 + gx, y1 + gy, full);
}

// A platform-pass pose must put the top's corners on its outline (platform_corner_gate_px);
// otherwise `d` fails with the error.
bool corners_on_outline(const FrameContext& f, const PlatformQuad& q, RingDetection& d) {
  const double err = platform_corner_error_px(q, d.X_CP, f.cam, f.target);
  const double gate = platform_corner_gate_px(q);
  if (err <= gate) return true;
  std::ostringstream oc;
  oc << "the pose puts the top's corners " << err << " px off its outline (gate " << gate
     << " px): " << d.reason;
  d.detected = false;
  d.status = VisionStatus::PoseFailed;
  d.reason = oc.str();
  return false;
}

// The ring sets guessed from the top `q` in each of the hexagon's two placements, with the
// pre-filter and then without it; true when a pose was adopted.
bool try_platform_quad(FrameContext& f, const PlatformQuad& q, TriedLog& log, Found& so_far) {
  std::string where;
  const cv::Rect region = platform_region(q, f.full, where);
  for (int placement = 0; placement < 2; ++placement) {
    const PlatformGuesses guesses{platform_set_guesses(q, placement, f.cam, f.target), q};
    for (const double sigma : {f.p.gaussian_sigma_px, 0.0}) {
      VisionParams pp = f.p;
      pp.gaussian_sigma_px = sigma;
      Found t;
      bool ok = run_region({f.grey, region, f.cam, f.target, pp, false, &guesses}, t.d, t.cands);
      if (ok) ok = corners_on_outline(f, q, t.d);
      const std::string what = where + ", placement " + std::to_string(placement) +
                               (sigma > 0 ? "" : ", unfiltered");
      if (ok) {
        t.d.by_platform = true;
        adopt(so_far, t, what + ": " + t.d.reason + " (frame: " + so_far.d.reason + ")");
        return true;
      }
      log.failed(what, t.d);
      if (f.p.gaussian_sigma_px <= 0) break;
    }
  }
  return false;
}

// Platform pass (issue 12: far and grazing views; vision internal platform.cpp): no pose,
// and the frame shows a bright quadrilateral that may be the platform's top. Its outline
// predicts the ring sets' outer circles (two placements of the hexagon in the square); the
// guesses are refined to sub-pixel edges and identified and gated as contours' ellipses
// are, with the pre-filter and then without it (small sets, as the unfiltered pass).
void try_platform(FrameContext& f, Found& so_far) {
  if (!(f.p.platform_pass && f.big_enough())) return;
  f.whole_grey();
  TriedLog log;
  for (const auto& q : platform_quads(f.grey, f.p)) {
    if (try_platform_quad(f, q, log, so_far)) break;
  }
  log.close(so_far);
}

}  // namespace

void try_predicted_region(FrameContext& f, const Eigen::Isometry3d& X_pred, Found& so_far) {
  const std::optional<cv::Rect> roi = predicted_region(f, X_pred);
  if (!roi) return;
  grey_region(f.image, *roi, f.grey);
  const bool done = search_region(f.grey, *roi, f.cam, f.target, f.p, so_far);
  so_far.d.used_roi = done;
}

void try_fallback_passes(FrameContext& f, Found& so_far) {
  using Pass = void (*)(FrameContext&, Found&);
  for (const Pass pass : {&try_full_frame, &try_deblurred, &try_unfiltered, &try_zoomed,
                          &try_platform}) {
    if (so_far.d.detected || f.rings_stopped) return;
    pass(f, so_far);
  }
}

// ---- the code map ----

namespace {

// Where to search the code map (seed 001) in a frame whose pose `X_CP` is known (this frame's
// rings, else the track): the projection of the square around the centre ring's inner circle
// (the map and the white cells the lattice reads around it), grown by a slack for a tracked
// pose (a quarter of its size and 16 px) and by half the threshold's block, so that around the
// map the threshold is the whole frame's. Nothing (search the whole frame) when a corner is
// behind the camera or the region would be most of the frame anyway.
std::optional<cv::Rect> code_region(const Eigen::Isometry3d& X_CP, const CameraModel& cam,
                                    const TargetGeometry& g, const VisionParams& p,
                                    const cv::Rect& full) {
  double s = 0.5 * g.code.side_m();
  for (const auto& r : g.rings) {
    if (r.centre_P_m.norm() < 1e-9) s = std::max(s, r.inner_radius_m);
  }
  std::vector<cv::Point3d> pts;
  for (const double x : {-s, s}) {
    for (const double y : {-s, s}) {
      const Eigen::Vector3d q = X_CP * Eigen::Vector3d(x, y, 0);
      if (!(q.z() > 0.05)) return std::nullopt;
      pts.emplace_back(q.x(), q.y(), q.z());
    }
  }
  const auto [x0, y0, x1, y1] = projected_bounds(pts, cam);
  if (!std::isfinite(x0 + y0 + x1 + y1)) return std::nullopt;
  const double grow = 0.25 * std::max(x1 - x0, y1 - y0) + 16 + 0.5 * p.code_threshold_block_px + 1;
  const cv::Rect r = covering_rect(x0 - grow, y0 - grow, x1 + grow, y1 + grow, full);
  if (r.width < 16 || r.height < 16 || r.area() >= 0.7 * full.area()) return std::nullopt;
  return r;
}

}  // namespace

// Code map (seed 001): searched unless the pose (this frame's rings, else the track) shows
// its cells smaller than code_min_cell_px.
namespace {

// The code's cells at depth z (m) are at least code_min_cell_px across.
bool cells_readable_at(const FrameContext& f, double z) {
  return z > 0 && f.target.code.cell_m * f.cam.fx_px / z >= f.p.code_min_cell_px;
}

// Whether the code map is searched in this frame under the pose `ref`: it is on, the frame can
// hold it, and its cells are readable at the pose's (or track's) depth; without a pose, at the
// least depth the caller says the plane can be at (anywhere when it does not say).
bool code_searchable(const FrameContext& f, const Eigen::Isometry3d* ref) {
  if (!(f.p.code_enabled && f.target.code.cells > 0 && f.big_enough())) return false;
  if (ref != nullptr) return cells_readable_at(f, ref->translation().z());
  return f.min_depth_m <= 0.0 || cells_readable_at(f, f.min_depth_m);
}

}  // namespace

void search_code_map(FrameContext& f, const Eigen::Isometry3d* track, RingDetection& d) {
  const Eigen::Isometry3d* ref = d.detected ? &d.X_CP : track;
  if (!code_searchable(f, ref)) return;
  d.code_searched = true;
  const auto region = ref != nullptr && f.p.code_search_region
                          ? code_region(*ref, f.cam, f.target, f.p, f.full)
                          : std::nullopt;
  const Eigen::Isometry3d* prior = f.p.code_lattice_from_pose ? ref : nullptr;
  if (region) {
    f.grey_in(*region);
    d.code = detect_code_pattern(f.grey, f.cam, f.target, f.p, *region, prior);
    d.code_region = *region;
  }
  // A region from the track (a frame old) may have missed the map: the whole frame then,
  // without the track's prediction of the grid lines (it may be what missed). Without a
  // region (close, the map fills the view), the whole frame with the prediction, and
  // without it too when it came from the track and missed.
  if (!region || (!d.code.detected && !d.detected)) {
    f.whole_grey();
    d.code = detect_code_pattern(f.grey, f.cam, f.target, f.p, region ? nullptr : prior);
    d.code_region = cv::Rect();
    if (!d.code.detected && !region && prior != nullptr && !d.detected) {
      d.code = detect_code_pattern(f.grey, f.cam, f.target, f.p);
    }
  }
}

// ---- the order of the passes and the code map ----

namespace {

// What search_code_map() wrote into a detection, kept across passes that replace it.
struct CodeSearch {
  bool searched{false};
  CodeDetection code;
  cv::Rect region;
  explicit CodeSearch(const RingDetection& d)
      : searched(d.code_searched), code(d.code), region(d.code_region) {}
  void restore(RingDetection& d) const {
    d.code_searched = searched;
    d.code = code;
    d.code_region = region;
  }
};

bool code_first(const FrameContext& f, const Eigen::Isometry3d* track, const Found& found) {
  return f.p.code_first_close_range && track != nullptr && !found.d.detected &&
         ring_sets_in_view(f, *track) == 0;
}

// Close range otherwise: no pose yet and a track under which search_code_map() searches.
bool code_before_shadow(const FrameContext& f, const Eigen::Isometry3d* track,
                        const Found& found) {
  return f.p.code_first_close_range && track != nullptr && !found.d.detected &&
         code_searchable(f, track);
}

}  // namespace

void search_rings_and_code(FrameContext& f, const Eigen::Isometry3d* track, Found& found) {
  auto passes = [&] { timed_stage(f.times.passes_ms, [&] { try_fallback_passes(f, found); }); };
  auto code_map = [&] {
    timed_stage(f.times.code_ms, [&] { search_code_map(f, track, found.d); });
  };
  if (code_first(f, track, found)) {
    code_map();
    if (found.d.code.detected) {
      found.d.rings_skipped = true;
      return;
    }
    // The code map gave no pose: the rings' passes as without it (they replace the detection).
    const CodeSearch code(found.d);
    passes();
    code.restore(found.d);
    return;
  }
  // Close range with sets in view: the code map as soon as the whole frame's global
  // segmentation gives no pose; the shadow pass and the later passes only when it gives none.
  std::optional<CodeSearch> early;
  if (code_before_shadow(f, track, found)) {
    f.before_shadow = [&] {
      code_map();
      early.emplace(found.d);
      f.rings_stopped = found.d.code.detected;
      return f.rings_stopped;
    };
  }
  passes();
  f.before_shadow = nullptr;
  if (f.rings_stopped) {
    found.d.rings_skipped = true;
    return;
  }
  // No ring pose after all: the code map as searched early (the same track, the same search).
  if (early && !found.d.detected) {
    early->restore(found.d);
    return;
  }
  code_map();
}

}  // namespace lander::vision_internal
