// The code map's stages 1-2 (code_stages.h): the grid in the image, from the threshold's
// polygons (corners and sides) to the lattice homography H (lattice (a, b) -> undistorted px).
#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/code_stages.h"
#include "vision/internal.h"

namespace lander::vision_internal::code_map {

namespace {

// Vertices closer than this to the image border are where a contour is cut by the border,
// not grid corners (px).
constexpr double kBorderMarginPx = 3.0;
// approxPolyDP tolerance (px): thresholded cell edges wander by about a pixel; corners stay
// sharp to within a pixel or two at the blur of the simulated camera.
constexpr double kPolyEpsPx = 2.0;
// Angle between the two sides at a grid corner (deg): 90 fronto-parallel; 20 deg tilt with
// the 90 deg field of view skews image corners by up to about 40 deg.
constexpr double kMinCornerAngleDeg = 40.0, kMaxCornerAngleDeg = 140.0;
// Side directions within this of a family's direction belong to it (deg): grid lines of one
// family converge towards their vanishing point by up to ~20 deg across the frame at 20 deg
// tilt.
constexpr double kFamilyTolDeg = 30.0;
// With a prior pose (the rings' of this frame, or the track's) each side is compared with
// the direction its family's predicted vanishing point gives at the side's own midpoint, so
// the convergence no longer needs room: a fresh ring pose is within ~0.1 deg, a frame-old
// track within a degree or two at the vehicle's turn rates. The polygon sides run along
// several cells, so nearly all lie within a few degrees of their line: on the 649 frames of
// a default landing 4, 6, 8 and 10 deg read the same frames, 12 deg fewer, 20 and 30 deg
// (clutter: ring edges, the rim) fewer still. 8 deg leaves the track its margin.
constexpr double kPriorFamilyTolDeg = 8.0;
// A segment is consistent with its family's vanishing point when its end points lie within
// this of the line through its midpoint and the vanishing point (px).
constexpr double kVpInlierPx = 2.0;
// Vertex inlier distance to its lattice prediction, as a fraction of the local cell side:
// corners move at most a threshold bias (~1 px) plus the polygon tolerance.
constexpr double kLatticeInlierFrac = 0.22;
// Doubling test of the lattice period: the true period keeps at least this fraction of the
// coherence at twice a half period; at twice the true period it drops to about zero.
constexpr double kDoublingCoherence = 0.7;
// Polygon sides shorter than this fraction of the length-weighted median side are ignored
// for the lattice period (a third of a cell at most, when the median is one cell).
constexpr double kMinSideOfMedian = 0.35;
// Seed region radius for the first lattice labels (cells) and the corners it needs.
constexpr double kSeedRadiusCells = 3.5;
constexpr std::size_t kMinSeedCorners = 12;

// ---- 1. threshold, contours, polygon vertices and sides ----

// The polygons' grid corners and the end points of their sides (pairs), in raw image px.
struct RawPolygonFeatures {
  std::vector<cv::Point2f> verts;
  std::vector<cv::Point2f> side_ends;
};

// Corners and sides of the threshold's contours in a frame of `frame` px, for cells at least
// `minc` px across.
RawPolygonFeatures polygon_features(const std::vector<std::vector<cv::Point>>& contours,
                                    const cv::Size& frame, double minc) {
  RawPolygonFeatures raw;
  auto near_border = [&](const cv::Point& q) {
    return q.x < kBorderMarginPx || q.y < kBorderMarginPx ||
           q.x > frame.width - 1 - kBorderMarginPx || q.y > frame.height - 1 - kBorderMarginPx;
  };
  const double cos_min = std::cos(kMaxCornerAngleDeg * M_PI / 180);
  const double cos_max = std::cos(kMinCornerAngleDeg * M_PI / 180);
  for (const auto& c : contours) {
    if (c.size() < 4 * 0.8 * minc) continue;
    std::vector<cv::Point> poly;
    cv::approxPolyDP(c, poly, kPolyEpsPx, true);
    const int m = static_cast<int>(poly.size());
    if (m < 4) continue;
    for (int i = 0; i < m; ++i) {
      const cv::Point& v = poly[i];
      const cv::Point& pr = poly[(i + m - 1) % m];
      const cv::Point& nx = poly[(i + 1) % m];
      const Eigen::Vector2d a(pr.x - v.x, pr.y - v.y), b(nx.x - v.x, nx.y - v.y);
      if (!near_border(v) && !near_border(nx) && b.norm() >= 0.6 * minc) {
        raw.side_ends.emplace_back(static_cast<float>(v.x), static_cast<float>(v.y));
        raw.side_ends.emplace_back(static_cast<float>(nx.x), static_cast<float>(nx.y));
      }
      if (near_border(v) || a.norm() < 0.6 * minc || b.norm() < 0.6 * minc) continue;
      const double cs = a.dot(b) / (a.norm() * b.norm());
      if (cs < cos_min || cs > cos_max) continue;
      raw.verts.emplace_back(static_cast<float>(v.x), static_cast<float>(v.y));
    }
  }
  return raw;
}

// The sides' end points (undistorted px, in pairs) as segments with length and direction.
std::vector<Segment> segments_of(const std::vector<Eigen::Vector2d>& su) {
  std::vector<Segment> segs;
  for (std::size_t i = 0; i + 1 < su.size(); i += 2) {
    Segment s{su[i], su[i + 1], (su[i + 1] - su[i]).norm(), 0.0};
    s.theta = std::atan2(su[i + 1].y() - su[i].y(), su[i + 1].x() - su[i].x());
    segs.push_back(s);
  }
  return segs;
}

// ---- 2. two line families, vanishing points, affine rectification, lattice labels ----

// The sides of the grid's two line families (A along the lattice's a, B along b).
struct LineFamilies {
  std::vector<Segment> A, B;
};

// The families predicted by a prior pose X_CP (principal point c, focal length f, px).
LineFamilies families_from_prior(const std::vector<Segment>& segs,
                                 const Eigen::Isometry3d& X_CP_prior, const Eigen::Vector2d& cpp,
                                 double f) {
  LineFamilies fam;
  // The map's rows and columns run along P's x and y axes: their vanishing points are the
  // camera-frame directions of those axes. A side joins the family whose line through the
  // side's midpoint towards that point it follows best, within kPriorFamilyTolDeg.
  const Eigen::Matrix3d R = X_CP_prior.linear();
  const Eigen::Vector3d vpA = R.col(0), vpB = R.col(1);
  const double sin_tol = std::sin(kPriorFamilyTolDeg * M_PI / 180);
  auto off = [&](const Segment& s, const Eigen::Vector3d& v) {
    const Eigen::Vector2d m = (0.5 * (s.p0 + s.p1) - cpp) / f;
    const Eigen::Vector2d dir(v.x() - m.x() * v.z(), v.y() - m.y() * v.z());
    const Eigen::Vector2d sd = s.p1 - s.p0;
    const double nn = dir.norm() * sd.norm();
    return nn > 0 ? std::abs(dir.x() * sd.y() - dir.y() * sd.x()) / nn : 1.0;
  };
  for (const auto& s : segs) {
    const double a = off(s, vpA), b = off(s, vpB);
    if (std::min(a, b) >= sin_tol) continue;
    (a < b ? fam.A : fam.B).push_back(s);
  }
  return fam;
}

// The families without a prior: the sides' dominant direction modulo 90 deg (the length-
// weighted mean of 4 theta) and its perpendicular, within kFamilyTolDeg.
LineFamilies families_by_angle(const std::vector<Segment>& segs) {
  LineFamilies fam;
  double C4 = 0, S4 = 0;
  for (const auto& s : segs) {
    C4 += s.len * std::cos(4 * s.theta);
    S4 += s.len * std::sin(4 * s.theta);
  }
  const double th0 = 0.25 * std::atan2(S4, C4);
  const double tol = kFamilyTolDeg * M_PI / 180;
  for (const auto& s : segs) {
    if (std::abs(std::remainder(s.theta - th0, M_PI)) < tol) {
      fam.A.push_back(s);
    } else if (std::abs(std::remainder(s.theta - th0 - 0.5 * M_PI, M_PI)) < tol) {
      fam.B.push_back(s);
    }
  }
  return fam;
}

// The affine rectification of the plane: undistorted px -> a plane where the grid is a
// lattice of the two families' directions (the vanishing line sent to infinity, then the
// two directions to the axes).
struct AffineRectification {
  Eigen::Matrix3d Hp;  // projective part: the vanishing line as the third row
  Eigen::Matrix2d Bi;  // the families' directions -> the axes
  Eigen::Vector2d cpp;
  double f;
  Eigen::Vector2d operator()(const Eigen::Vector2d& px) const {
    const Eigen::Vector3d q = Hp * Eigen::Vector3d((px.x() - cpp.x()) / f, (px.y() - cpp.y()) / f, 1);
    return Eigen::Vector2d(Bi * (q.head<2>() / q.z()));
  }
};

// The rectification from the families' vanishing points; `fam` keeps only their inliers.
std::optional<AffineRectification> rectify_families(LineFamilies& fam, const Eigen::Vector2d& cpp,
                                                    double f, std::string& why) {
  const auto vA = vanishing_point(fam.A, cpp, f);
  const auto vB = vanishing_point(fam.B, cpp, f);
  if (!vA || !vB) {
    why = "no two grid line families";
    return std::nullopt;
  }
  Eigen::Vector3d linf = vA->cross(*vB);
  if (std::abs(linf.z()) < 1e-9 * linf.norm()) {
    why = "degenerate vanishing line";
    return std::nullopt;
  }
  linf /= linf.z();
  Eigen::Matrix3d Hp = Eigen::Matrix3d::Identity();
  Hp.row(2) = linf.transpose();
  Eigen::Vector2d dA = (Hp * *vA).head<2>().normalized(), dB = (Hp * *vB).head<2>().normalized();
  if (dA.x() * dB.y() - dA.y() * dB.x() < 0) dB = -dB;
  Eigen::Matrix2d Bm;
  Bm.col(0) = dA;
  Bm.col(1) = dB;
  if (std::abs(Bm.determinant()) < 0.2) {
    why = "grid families not distinct";
    return std::nullopt;
  }
  return AffineRectification{Hp, Bm.inverse(), cpp, f};
}

// Cell size (px): median distance to the nearest other vertex (farther than minc / 2);
// nullopt when no vertex has a neighbour.
std::optional<double> median_nearest_px(const std::vector<Eigen::Vector2d>& verts, double minc) {
  std::vector<double> nn;
  // Scanned in x order outwards from each vertex, stopping where the x gap alone reaches the
  // nearest distance so far: the same minimum as comparing every pair, without the n^2.
  std::vector<std::size_t> by_x(verts.size());
  for (std::size_t i = 0; i < by_x.size(); ++i) by_x[i] = i;
  std::sort(by_x.begin(), by_x.end(),
            [&](std::size_t a, std::size_t b) { return verts[a].x() < verts[b].x(); });
  const std::ptrdiff_t nv = static_cast<std::ptrdiff_t>(by_x.size());
  std::vector<double> nearest(verts.size(), 1e18);
  for (std::ptrdiff_t k = 0; k < nv; ++k) {
    const std::size_t i = by_x[k];
    double best = 1e18;
    for (const std::ptrdiff_t step : {-1, 1}) {
      for (std::ptrdiff_t m = k + step; m >= 0 && m < nv; m += step) {
        const std::size_t j = by_x[m];
        if (std::abs(verts[j].x() - verts[i].x()) >= best) break;
        const double dd = (verts[i] - verts[j]).norm();
        if (dd > 0.5 * minc) best = std::min(best, dd);
      }
    }
    nearest[i] = best;
  }
  for (const double best : nearest) {
    if (best < 1e17) nn.push_back(best);
  }
  if (nn.empty()) return std::nullopt;
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  return nn[nn.size() / 2];
}

// Where the lattice is labelled first: the vertex `seed` and the vertices `local` within R0.
struct SeedRegion {
  Eigen::Vector2d seed;
  double R0;
  std::vector<std::size_t> local;
};

// The seed region for cells of cell0 px.
SeedRegion seed_region(const std::vector<Eigen::Vector2d>& verts, double cell0) {
  // Seed region: the lattice is labelled first near the vertex closest to the median vertex
  // (perspective left over from the vanishing-point estimates is small there), then grown.
  std::vector<double> mx, my;
  for (const auto& v : verts) {
    mx.push_back(v.x());
    my.push_back(v.y());
  }
  std::nth_element(mx.begin(), mx.begin() + mx.size() / 2, mx.end());
  std::nth_element(my.begin(), my.begin() + my.size() / 2, my.end());
  const Eigen::Vector2d med(mx[mx.size() / 2], my[my.size() / 2]);
  SeedRegion s;
  s.seed = verts[0];
  for (const auto& v : verts) {
    if ((v - med).norm() < (s.seed - med).norm()) s.seed = v;
  }
  s.R0 = kSeedRadiusCells * cell0;
  for (int grow = 0; grow < 6; ++grow, s.R0 *= 1.5) {
    s.local.clear();
    for (std::size_t i = 0; i < verts.size(); ++i) {
      if ((verts[i] - s.seed).norm() <= s.R0) s.local.push_back(i);
    }
    if (s.local.size() >= kMinSeedCorners) break;
  }
  return s;
}

std::optional<Eigen::Matrix3d> fit_homography(const std::vector<Eigen::Vector2d>& from,
                                              const std::vector<Eigen::Vector2d>& to, bool ransac,
                                              double thresh) {
  if (from.size() < 4) return std::nullopt;
  std::vector<cv::Point2f> a, b;
  for (std::size_t i = 0; i < from.size(); ++i) {
    a.emplace_back(static_cast<float>(from[i].x()), static_cast<float>(from[i].y()));
    b.emplace_back(static_cast<float>(to[i].x()), static_cast<float>(to[i].y()));
  }
  cv::Mat H;
  try {
    H = cv::findHomography(a, b, ransac ? cv::RANSAC : 0, thresh);
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
  if (H.empty()) return std::nullopt;
  Eigen::Matrix3d E;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) E(r, c) = H.at<double>(r, c);
  }
  return E;
}

// The first lattice homography, from the seed region: the rectified vertices labelled by
// the lattice spacing and phase of each family's sides near the seed, fitted with RANSAC.
std::optional<Eigen::Matrix3d> seed_homography(const std::vector<Eigen::Vector2d>& verts,
                                               const SeedRegion& s, const LineFamilies& fam,
                                               const AffineRectification& rect, double cell0,
                                               std::string& why) {
  std::vector<double> xs, ys, lenA, lenB;
  for (std::size_t i : s.local) {
    const Eigen::Vector2d r = rect(verts[i]);
    xs.push_back(r.x());
    ys.push_back(r.y());
  }
  auto near_seed = [&](const Segment& sg) {
    return (0.5 * (sg.p0 + sg.p1) - s.seed).norm() <= 2 * s.R0;
  };
  for (const auto& sg : fam.A) {
    if (near_seed(sg)) lenA.push_back(std::abs(rect(sg.p1).x() - rect(sg.p0).x()));
  }
  for (const auto& sg : fam.B) {
    if (near_seed(sg)) lenB.push_back(std::abs(rect(sg.p1).y() - rect(sg.p0).y()));
  }
  const auto lx = lattice_1d(lenA, xs), ly = lattice_1d(lenB, ys);
  if (!lx || !ly) {
    why = "no lattice spacing";
    return std::nullopt;
  }
  std::vector<Eigen::Vector2d> lab, img;
  for (std::size_t k = 0; k < s.local.size(); ++k) {
    lab.emplace_back(std::round((xs[k] - lx->second) / lx->first),
                     std::round((ys[k] - ly->second) / ly->first));
    img.push_back(verts[s.local[k]]);
  }
  auto H = fit_homography(lab, img, true, kLatticeInlierFrac * cell0);
  if (!H) why = "no lattice homography";
  return H;
}

// The lattice grown from the seed: the corners within a growing radius of the seed
// relabelled with the current homography, those on the lattice kept, refitted.
std::optional<GridLattice> grow_lattice(const std::vector<Eigen::Vector2d>& verts,
                                        const SeedRegion& s, Eigen::Matrix3d H0,
                                        std::string& why) {
  std::optional<Eigen::Matrix3d> H = H0;
  std::vector<Eigen::Vector2i> in_lab;
  double radius = 2 * s.R0;
  for (int it = 0; it < 12; ++it, radius *= 1.5) {
    const bool last = it == 11;
    const Eigen::Matrix3d Hi = H->inverse();
    std::vector<Eigen::Vector2d> l2, i2;
    in_lab.clear();
    bool all = true;
    for (const auto& v : verts) {
      if (!last && (v - s.seed).norm() > radius) {
        all = false;
        continue;
      }
      const Eigen::Vector2d q = apply_h(Hi, v);
      const Eigen::Vector2d r(std::round(q.x()), std::round(q.y()));
      const auto rx = vision_internal::to_int_coord(r.x()), ry = vision_internal::to_int_coord(r.y());
      if (!rx || !ry) continue;
      const double cell = (apply_h(*H, r + Eigen::Vector2d(0.5, 0)) -
                           apply_h(*H, r - Eigen::Vector2d(0.5, 0))).norm();
      if ((apply_h(*H, r) - v).norm() > kLatticeInlierFrac * cell) continue;
      l2.push_back(r);
      i2.push_back(v);
      in_lab.emplace_back(*rx, *ry);
    }
    if (l2.size() < 8) {
      why = std::to_string(l2.size()) + " corners on the lattice";
      return std::nullopt;
    }
    auto H2 = fit_homography(l2, i2, false, 0.0);
    if (!H2) {
      why = "lattice homography failed";
      return std::nullopt;
    }
    H = H2;
    if (all && it >= 2) break;
  }
  return GridLattice{*H, in_lab};
}

// Keeps the corners of one code map of `cells` cells: labels within cells + 2 of the median
// label (corners of the platform edge or ring polygons far away can fall on the lattice by
// chance); refits H when any were dropped. False (and why) with fewer than 8 left.
bool keep_code_corners(const std::vector<Eigen::Vector2d>& verts, int cells, GridLattice& lat,
                       std::string& why) {
  std::vector<int> la, lb;
  for (const auto& l : lat.labels) {
    la.push_back(l.x());
    lb.push_back(l.y());
  }
  std::nth_element(la.begin(), la.begin() + la.size() / 2, la.end());
  std::nth_element(lb.begin(), lb.begin() + lb.size() / 2, lb.end());
  const int ma = la[la.size() / 2], mb = lb[lb.size() / 2], reach = cells + 2;
  std::vector<Eigen::Vector2d> l2, i2;
  std::vector<Eigen::Vector2i> kept;
  const Eigen::Matrix3d& H = lat.H;
  const Eigen::Matrix3d Hi = H.inverse();
  for (const auto& v : verts) {
    const Eigen::Vector2d q = apply_h(Hi, v);
    const auto rx = vision_internal::to_int_coord(std::round(q.x())), ry = vision_internal::to_int_coord(std::round(q.y()));
    if (!rx || !ry) continue;
    const Eigen::Vector2i r(*rx, *ry);
    const Eigen::Vector2d rd = r.cast<double>();
    const double cell = (apply_h(H, rd + Eigen::Vector2d(0.5, 0)) -
                         apply_h(H, rd - Eigen::Vector2d(0.5, 0))).norm();
    if ((apply_h(H, rd) - v).norm() > kLatticeInlierFrac * cell) continue;
    if (std::abs(r.x() - ma) > reach || std::abs(r.y() - mb) > reach) continue;
    l2.push_back(rd);
    i2.push_back(v);
    kept.push_back(r);
  }
  if (kept.size() < 8) {
    why = std::to_string(kept.size()) + " corners near the code";
    return false;
  }
  if (kept.size() < lat.labels.size()) {
    auto H2 = fit_homography(l2, i2, false, 0.0);
    if (!H2) {
      why = "lattice homography failed";
      return false;
    }
    lat.H = *H2;
  }
  lat.labels = kept;
  return true;
}

// Handedness: the lattice (a, b) must map like the code map's (col, row) (vision_code.h);
// a mirrored lattice has its a and b swapped.
void orient_like_code_map(GridLattice& lat) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& l : lat.labels) mean += l.cast<double>();
  mean /= lat.labels.size();
  const Eigen::Vector2d o = apply_h(lat.H, mean);
  const Eigen::Vector2d ea = apply_h(lat.H, mean + Eigen::Vector2d(1, 0)) - o;
  const Eigen::Vector2d eb = apply_h(lat.H, mean + Eigen::Vector2d(0, 1)) - o;
  if (ea.x() * eb.y() - ea.y() * eb.x() < 0) {
    Eigen::Matrix3d S;
    S << 0, 1, 0, 1, 0, 0, 0, 0, 1;
    lat.H = lat.H * S;
    for (auto& l : lat.labels) std::swap(l.x(), l.y());
  }
}

}  // namespace

std::vector<Eigen::Vector2d> undistort_points(const CameraModel& cam,
                                              const std::vector<cv::Point2f>& pts) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(pts.size());
  if (!cam.has_distortion() || pts.empty()) {
    for (const auto& p : pts) out.emplace_back(p.x, p.y);
    return out;
  }
  const cv::Mat Kcv = camera_matrix_cv(cam);
  const cv::Mat Dcv = dist_coeffs_cv(cam);
  std::vector<cv::Point2f> und;
  cv::undistortPoints(pts, und, Kcv, Dcv, cv::noArray(), Kcv,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-6));
  for (const auto& p : und) out.emplace_back(p.x, p.y);
  return out;
}

std::optional<GridFeatures> find_grid_features(const cv::Mat& grey, const CameraModel& cam,
                                               const VisionParams& p, int block, bool halved,
                                               std::string& why) {
  // On the frame halved: a pixel (i, j) there covers (2i .. 2i + 1, 2j .. 2j + 1) here.
  cv::Mat half;
  if (halved) {
    cv::resize(grey, half, cv::Size(grey.cols / 2, grey.rows / 2), 0, 0, cv::INTER_AREA);
    block = std::min(block / 2 | 1, (std::min(half.cols, half.rows) / 2) * 2 - 1);
  }
  const cv::Mat& src = halved ? half : grey;
  const double scale = halved ? 2.0 : 1.0;
  if (block < 3) {
    why = "image too small";
    return std::nullopt;
  }
  // Dark cells as foreground, against the mean of their block.
  cv::Mat bin;
  cv::adaptiveThreshold(src, bin, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV, block,
                        p.code_threshold_offset);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  // Their polygons' corners and sides, then both undistorted.
  RawPolygonFeatures raw = polygon_features(contours, src.size(), p.code_min_cell_px / scale);
  if (raw.verts.size() < 8) {
    why = std::to_string(raw.verts.size()) + " grid corners found";
    return std::nullopt;
  }
  if (halved) {
    for (auto* pts : {&raw.verts, &raw.side_ends}) {
      for (cv::Point2f& q : *pts) q = cv::Point2f(2.0f * q.x + 0.5f, 2.0f * q.y + 0.5f);
    }
  }
  GridFeatures features;
  features.verts = undistort_points(cam, raw.verts);
  features.segs = segments_of(undistort_points(cam, raw.side_ends));
  return features;
}

std::optional<Eigen::Vector3d> vanishing_point(std::vector<Segment>& segs, const Eigen::Vector2d& c,
                                               double f) {
  auto nrm = [&](const Eigen::Vector2d& p) {
    return Eigen::Vector3d((p.x() - c.x()) / f, (p.y() - c.y()) / f, 1.0);
  };
  std::vector<char> in(segs.size(), 1);
  Eigen::Vector3d v;
  for (int it = 0; it < 4; ++it) {
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    int n = 0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
      if (!in[i]) continue;
      Eigen::Vector3d l = nrm(segs[i].p0).cross(nrm(segs[i].p1));
      const double s = l.head<2>().norm();
      if (s <= 0) continue;
      l /= s;
      M += segs[i].len * l * l.transpose();
      ++n;
    }
    if (n < 3) return std::nullopt;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
    v = es.eigenvectors().col(0);
    // Inliers: end points near the line through the midpoint and v.
    int kept = 0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
      const Eigen::Vector3d m = nrm(0.5 * (segs[i].p0 + segs[i].p1));
      Eigen::Vector3d l = m.cross(v);
      const double s = l.head<2>().norm();
      bool ok = s > 0;
      if (ok) {
        l /= s;
        const double d = std::max(std::abs(l.dot(nrm(segs[i].p0))), std::abs(l.dot(nrm(segs[i].p1))));
        ok = d * f < kVpInlierPx;
      }
      in[i] = ok;
      kept += ok;
    }
    if (kept < 3) return std::nullopt;
  }
  std::vector<Segment> kept;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (in[i]) kept.push_back(segs[i]);
  }
  segs = std::move(kept);
  return v;
}

// Lattice spacing and phase of 1-D coordinates x_k that lie near x0 + i * delta: delta from
// the segment lengths (the largest period consistent with them: lengths are whole numbers
// of cells), refined by the coherence of the vertex positions.
std::optional<std::pair<double, double>> lattice_1d(const std::vector<double>& lengths_in,
                                                    const std::vector<double>& x) {
  if (lengths_in.empty() || x.size() < 4) return std::nullopt;
  // Length-weighted median: short jagged sides (polygon noise, cut corners) carry little
  // weight; sides of one or more whole cells dominate.
  std::vector<double> sorted = lengths_in;
  std::sort(sorted.begin(), sorted.end());
  double total = 0.0, acc = 0.0, wmed = sorted.back();
  for (double L : sorted) total += L;
  for (double L : sorted) {
    acc += L;
    if (acc >= 0.5 * total) {
      wmed = L;
      break;
    }
  }
  // Sides shorter than a third of that are noise, not whole cells.
  std::vector<double> lengths;
  for (double L : lengths_in) {
    if (L >= kMinSideOfMedian * wmed) lengths.push_back(L);
  }
  if (lengths.empty()) return std::nullopt;
  auto len_score = [&](double d) {
    double s = 0.0, w = 0.0;
    for (double L : lengths) {
      s += L * std::cos(2 * M_PI * L / d);
      w += L;
    }
    return s / w;
  };
  // Candidate periods: lengths and half lengths, at most 1.3 weighted median lengths (every
  // grid side is a whole number of cells, so one cell is below that; a long side such as the
  // platform edge would otherwise win: any period far above all lengths scores 1).
  const double dmax = 1.3 * wmed;
  std::vector<double> cands;
  for (double L : lengths) {
    if (L <= dmax) cands.push_back(L);
    if (0.5 * L <= dmax) cands.push_back(0.5 * L);
  }
  if (cands.empty()) return std::nullopt;
  double best = -1e9;
  for (double d : cands) best = std::max(best, len_score(d));
  double delta = 0.0;
  for (double d : cands) {
    if (len_score(d) >= best - 0.1 && d > delta) delta = d;
  }
  if (!(delta > 0)) return std::nullopt;
  auto coherence = [&](double d, double* phase) {
    std::complex<double> z(0, 0);
    for (double v : x) z += std::polar(1.0, 2 * M_PI * v / d);
    if (phase) *phase = std::arg(z);
    return std::abs(z) / x.size();
  };
  double best_c = -1, best_d = delta;
  for (int k = -40; k <= 40; ++k) {
    const double d = delta * (1.0 + 0.005 * k);
    const double c = coherence(d, nullptr);
    if (c > best_c) {
      best_c = c;
      best_d = d;
    }
  }
  // Half-period trap: if the segment lengths suggested half a cell, the vertex positions
  // are as coherent at twice the period (at the true period, twice it splits them in two).
  for (int k = 0; k < 2; ++k) {
    if (coherence(2 * best_d, nullptr) >= kDoublingCoherence * best_c) {
      best_d *= 2;
      best_c = coherence(best_d, nullptr);
    }
  }
  double phase = 0.0;
  coherence(best_d, &phase);
  return std::make_pair(best_d, phase / (2 * M_PI) * best_d);
}

std::optional<GridLattice> fit_grid_lattice(const GridFeatures& features, const CameraModel& cam,
                                            const TargetGeometry& g, const VisionParams& p,
                                            const Eigen::Isometry3d* X_CP_prior,
                                            std::string& why) {
  const std::vector<Eigen::Vector2d>& verts = features.verts;
  const Eigen::Vector2d cpp(cam.cx_px, cam.cy_px);
  const double f = cam.fx_px;
  // The sides split into the two line families, by the prior's directions or by angle.
  LineFamilies fam = X_CP_prior != nullptr ? families_from_prior(features.segs, *X_CP_prior, cpp, f)
                                           : families_by_angle(features.segs);
  // Their vanishing points rectify the plane up to an affinity of the lattice's axes.
  const std::optional<AffineRectification> rect = rectify_families(fam, cpp, f, why);
  if (!rect) return std::nullopt;
  // The cell size in the image, from the corners' nearest neighbours.
  const std::optional<double> cell0 = median_nearest_px(verts, p.code_min_cell_px);
  if (!cell0) {
    why = "isolated corners";
    return std::nullopt;
  }
  // Labelled first near the middle of the corners, then grown over all of them.
  const SeedRegion seed = seed_region(verts, *cell0);
  const std::optional<Eigen::Matrix3d> H = seed_homography(verts, seed, fam, *rect, *cell0, why);
  if (!H) return std::nullopt;
  std::optional<GridLattice> lat = grow_lattice(verts, seed, *H, why);
  if (!lat) return std::nullopt;
  // One code map's corners, with the map's handedness.
  if (!keep_code_corners(verts, g.code.cells, *lat, why)) return std::nullopt;
  orient_like_code_map(*lat);
  return lat;
}

}  // namespace lander::vision_internal::code_map
