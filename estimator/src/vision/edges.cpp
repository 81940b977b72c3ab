// Stages 1-2 of the ring detector: pre-processing (seed 000 section 2.1) and sub-pixel
// ellipse fitting.
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/internal.h"

namespace lander::vision_internal {

OtsuSplit otsu_split_sorted(const std::vector<double>& v) {
  const int n = static_cast<int>(v.size());
  std::vector<double> cum(n + 1, 0.0);
  for (int i = 0; i < n; ++i) cum[i + 1] = cum[i] + v[i];
  OtsuSplit best;
  double best_v = -1.0;
  for (int i = 1; i < n; ++i) {
    const double m_lo = cum[i] / i, m_hi = (cum[n] - cum[i]) / (n - i);
    const double bv = static_cast<double>(i) * (n - i) * (m_lo - m_hi) * (m_lo - m_hi);
    if (bv > best_v) {
      best_v = bv;
      best = {i, m_lo, m_hi};
    }
  }
  return best;
}

namespace {

// Bilinear grey value at (x, y) in an 8-bit image; false outside.
inline bool sample(const cv::Mat& img, double x, double y, double& out) {
  // Written so that NaN fails too (a NaN cast to int is undefined behaviour).
  if (!(x >= 0.0 && y >= 0.0 && x <= img.cols - 1.001 && y <= img.rows - 1.001)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double fx = x - x0, fy = y - y0;
  const std::uint8_t* r0 = img.ptr<std::uint8_t>(y0);
  const std::uint8_t* r1 = img.ptr<std::uint8_t>(y0 + 1);
  out = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

// Minimum grey-level swing along a normal profile for an edge point to count.
constexpr double kMinEdgeContrast = 12.0;
// Grey-level spread below which a set of plateau values is taken as one level (noise).
constexpr double kMinNoiseGrey = 2.0;
// Profile step along the normal (px): fine enough that linear interpolation of the
// mid-level crossing adds far less than 0.01 px for the blurred edges seen here.
constexpr double kProfileStepPx = 0.25;

// The normal profiles of one ellipse: n profiles of m samples kProfileStepPx apart over
// [-L, L] along the normal at base[k] (ROI px); valid[k] when the profile lies in the ROI
// and swings by kMinEdgeContrast, with its dark and light values plo[k], phi[k]; glo, ghi
// the darkest and brightest of those over all valid profiles.
struct EdgeProfiles {
  int n{0}, m{0};
  double L{0.0};
  std::vector<double> prof;  // n x m
  std::vector<char> valid;
  std::vector<double> plo, phi;
  std::vector<Eigen::Vector2d> base, normal;
  double glo{1e9}, ghi{-1e9};
};

// The profiles along p.edge_samples normals of `e` within +-search_px (at most 0.6 b).
// `split_light`: each profile's dark and light values are its own edge's (see below).
EdgeProfiles sample_profiles(const cv::Mat& img, const cv::Point2f& off, const EllipseParams& e,
                             double search_px, const VisionParams& p, bool split_light) {
  EdgeProfiles ep;
  const int n = p.edge_samples;
  ep.n = n;
  ep.L = std::clamp(std::min(search_px, 0.6 * e.b), 0.75, search_px);
  const double L = ep.L;
  const int m = static_cast<int>(std::round(2 * L / kProfileStepPx)) + 1;
  ep.m = m;
  ep.prof.resize(static_cast<std::size_t>(n) * m);
  ep.valid.assign(n, 0);
  ep.plo.assign(n, 0.0);
  ep.phi.assign(n, 0.0);
  ep.base.resize(n);
  ep.normal.resize(n);
  const double ca = std::cos(e.angle_rad), sa = std::sin(e.angle_rad);
  for (int k = 0; k < n; ++k) {
    const double th = 2.0 * M_PI * (k + 0.5) / n;
    const double lx = e.a * std::cos(th), ly = e.b * std::sin(th);
    const Eigen::Vector2d x(e.centre.x() + ca * lx - sa * ly - off.x,
                            e.centre.y() + sa * lx + ca * ly - off.y);
    Eigen::Vector2d nl(std::cos(th) / e.a, std::sin(th) / e.b);
    Eigen::Vector2d nrm(ca * nl.x() - sa * nl.y(), sa * nl.x() + ca * nl.y());
    nrm.normalize();
    ep.base[k] = x;
    ep.normal[k] = nrm;
    bool ok = true;
    double lo = 1e9, hi = -1e9;
    double* pr = &ep.prof[static_cast<std::size_t>(k) * m];
    for (int j = 0; j < m && ok; ++j) {
      const double s = -L + j * kProfileStepPx;
      ok = sample(img, x.x() + s * nrm.x(), x.y() + s * nrm.y(), pr[j]);
      lo = std::min(lo, pr[j]);
      hi = std::max(hi, pr[j]);
    }
    if (!ok || hi - lo < kMinEdgeContrast) continue;
    if (split_light) {
      // This edge's own dark and light values: from the profile's middle, strictly downhill
      // and strictly uphill. A further edge within reach of the profile (a shadow's edge a
      // pixel or two beyond the ring's) lies past a plateau and is not reached.
      const int jc = m / 2;
      const int up = pr[std::min(m - 1, jc + 2)] >= pr[std::max(0, jc - 2)] ? 1 : -1;
      int j = jc;
      while (j + up >= 0 && j + up < m && pr[j + up] > pr[j]) j += up;
      hi = pr[j];
      j = jc;
      while (j - up >= 0 && j - up < m && pr[j - up] < pr[j]) j -= up;
      lo = pr[j];
      if (hi - lo < kMinEdgeContrast) continue;
    }
    ep.valid[k] = 1;
    ep.plo[k] = lo;
    ep.phi[k] = hi;
    ep.glo = std::min(ep.glo, lo);
    ep.ghi = std::max(ep.ghi, hi);
  }
  return ep;
}

// Fewer profiles than this form no group of one illumination.
constexpr int kMinGroup = 4;

// The brightest value that splits the profiles into a shadowed and a lit class, or -1 for one
// illumination.
double shadow_split(const EdgeProfiles& ep, const VisionParams& p) {
  const int n = ep.n;
  double split_at = -1.0;
  std::vector<double> lh;  // log of the brightest values, sorted
  for (int k = 0; k < n; ++k) {
    if (ep.valid[k]) lh.push_back(std::log(std::max(ep.phi[k], 1.0)));
  }
  std::sort(lh.begin(), lh.end());
  const int nv = static_cast<int>(lh.size());
  if (nv >= 2 * kMinGroup) {
    const int best_i = otsu_split_sorted(lh).k;
    const double med_lo = lh[best_i / 2], med_hi = lh[best_i + (nv - best_i) / 2];
    if (best_i >= kMinGroup && nv - best_i >= kMinGroup &&
        med_hi - med_lo >= std::log(p.shadow_split_ratio)) {
      split_at = std::exp(0.5 * (lh[best_i - 1] + lh[best_i]));
      // A band's two straight edges cut an ellipse in at most four points, so the classes
      // alternate at most four times around it; more alternations are texture next to the
      // edge (the code cells inside the central ring), not a shadow.
      constexpr int kMaxShadowCrossings = 4;
      int changes = 0, first = -1, prev = -1;
      for (int k = 0; k < n; ++k) {
        if (!ep.valid[k]) continue;
        const int cls = ep.phi[k] < split_at ? 0 : 1;
        if (first < 0) first = cls;
        if (prev >= 0 && cls != prev) ++changes;
        prev = cls;
      }
      if (prev >= 0 && prev != first) ++changes;
      if (changes > kMaxShadowCrossings) split_at = -1.0;
    }
  }
  return split_at;
}

// Each profile's group (0 one illumination, 1 and 2 the two illuminations, -1 not used) and
// each group's level.
struct ProfileGroups {
  std::vector<int> group;
  double level[3];
};

// Group gi's profiles beyond 3 robust sigmas of its median dark or light value leave it; a
// group of fewer than kMinGroup is not used, else its level is set.
void robust_group_level(const EdgeProfiles& ep, int gi, ProfileGroups& g) {
  const int n = ep.n;
  std::vector<int>& group = g.group;
  auto median_sigma = [](std::vector<double> v, double& med, double& sig) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    med = v[v.size() / 2];
    for (double& x : v) x = std::abs(x - med);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    sig = 1.4826 * std::max(v[v.size() / 2], kMinNoiseGrey);
  };
  std::vector<double> los, his;
  for (int k = 0; k < n; ++k) {
    if (!ep.valid[k] || group[k] != gi) continue;
    los.push_back(ep.plo[k]);
    his.push_back(ep.phi[k]);
  }
  if (los.empty()) return;
  double mlo, slo, mhi, shi;
  median_sigma(los, mlo, slo);
  median_sigma(his, mhi, shi);
  double lo = 1e9, hi = -1e9;
  int used = 0;
  for (int k = 0; k < n; ++k) {
    if (!ep.valid[k] || group[k] != gi) continue;
    if (std::abs(ep.plo[k] - mlo) > 3 * slo || std::abs(ep.phi[k] - mhi) > 3 * shi) {
      group[k] = -1;
      continue;
    }
    lo = std::min(lo, ep.plo[k]);
    hi = std::max(hi, ep.phi[k]);
    ++used;
  }
  if (used < kMinGroup) {
    for (int k = 0; k < n; ++k) {
      if (ep.valid[k] && group[k] == gi) group[k] = -1;
    }
  } else {
    g.level[gi] = 0.5 * (lo + hi);
  }
}

// The groups: all profiles in one at the global level; with split_light, the two classes of
// `split_at` (if > 0) without the profiles next to a change of class, each group's outliers
// dropped and its own level.
ProfileGroups illumination_groups(const EdgeProfiles& ep, double split_at, bool split_light) {
  const int n = ep.n;
  const double level = 0.5 * (ep.glo + ep.ghi);
  ProfileGroups g{std::vector<int>(n, 0), {level, level, level}};
  if (!split_light) return g;
  std::vector<int>& group = g.group;
  if (split_at > 0) {
    for (int k = 0; k < n; ++k) {
      if (ep.valid[k]) group[k] = ep.phi[k] < split_at ? 2 : 1;
    }
    std::vector<int> g2 = group;
    for (int k = 0; k < n; ++k) {
      const int a = (k + n - 1) % n, b = (k + 1) % n;
      if (ep.valid[k] && ((ep.valid[a] && group[a] != group[k]) ||
                          (ep.valid[b] && group[b] != group[k]))) {
        g2[k] = -1;
      }
    }
    group.swap(g2);
  }
  for (int gi : {0, 1, 2}) robust_group_level(ep, gi, g);
  return g;
}

// Each used profile's crossing of its group's level nearest to the ellipse, moved outwards by
// the curvature correction s2 kappa / 2, in full-image px.
std::vector<Eigen::Vector2d> level_crossings(const EdgeProfiles& ep, const ProfileGroups& g,
                                             const cv::Point2f& off, const EllipseParams& e,
                                             double s2) {
  std::vector<Eigen::Vector2d> pts;
  const int n = ep.n, m = ep.m;
  const double L = ep.L;
  pts.reserve(n);
  for (int k = 0; k < n; ++k) {
    if (!ep.valid[k] || g.group[k] < 0) continue;
    const double level = g.level[g.group[k]];
    const double* pr = &ep.prof[static_cast<std::size_t>(k) * m];
    double best = 1e9;
    for (int j = 0; j + 1 < m; ++j) {
      const double d0 = pr[j] - level, d1 = pr[j + 1] - level;
      if ((d0 < 0) == (d1 < 0) && d0 != 0) continue;
      const double f = (d0 == d1) ? 0.5 : d0 / (d0 - d1);
      const double s = -L + (j + f) * kProfileStepPx;
      if (std::abs(s) < std::abs(best)) best = s;
    }
    if (std::abs(best) > L) continue;
    const double th = 2.0 * M_PI * (k + 0.5) / n;
    const double den = std::pow(e.a * e.a * std::sin(th) * std::sin(th) +
                                    e.b * e.b * std::cos(th) * std::cos(th), 1.5);
    const double kappa = e.a * e.b / den;
    best += 0.5 * s2 * kappa;
    pts.emplace_back(ep.base[k].x() + best * ep.normal[k].x() + off.x,
                     ep.base[k].y() + best * ep.normal[k].y() + off.y);
  }
  return pts;
}

// Sub-pixel edge points of ellipse `e` (full-image px): along each sampled normal, the
// crossing of the mid-level between the profile's darkest and brightest values nearest to
// the ellipse. `img` is the (blurred) ROI, `off` its origin in the full image.
//
// Curvature correction: blurring a disc of radius R with a Gaussian of variance s^2 moves its
// mid-level contour inwards by s^2 / (2 R) to first order, for a dark disc on light as for a
// light hole in dark; so each point is moved outwards by s^2 kappa / 2 with kappa the local
// curvature of the ellipse, s^2 = pre-filter^2 + camera blur^2 + 1/12 (the pixel box).
//
// Level: half-way between the darkest and the brightest value over all profiles of this
// ellipse, not of each profile: where the annulus or the hole is only a few pixels across
// (far range, strong tilt), a single profile never reaches the full dark or light level and
// its own mid-level would sit outside the true edge (a blurred thin bar looks wider).
//
// Shadows (split_light): where a hard shadow crosses the ellipse, the profiles see two
// illuminations, and one level half-way between the lit white and the shadowed black crosses
// no shadowed profile (at 20 % light the shadowed white is darker than that level). Then the
// profiles are split by their brightest value into a lit and a shadowed group at the largest
// gap of the sorted brightest values (when the groups differ by more than shadow_split_ratio),
// and each group gets its own mid-level. Without such a gap (no shadow; or the gradual change
// of the brightest value along a thin, tilted annulus) there is one group, as above.
std::vector<Eigen::Vector2d> edge_points(const cv::Mat& img, const cv::Point2f& off,
                                         const EllipseParams& e, double search_px,
                                         const VisionParams& p, bool split_light,
                                         bool* two_lights = nullptr) {
  const double s2 = p.gaussian_sigma_px * p.gaussian_sigma_px +
                    p.edge_blur_sigma_px * p.edge_blur_sigma_px + 1.0 / 12.0;
  // The normal profiles, with their dark and light values.
  const EdgeProfiles ep = sample_profiles(img, off, e, search_px, p, split_light);
  // Shadow pass: one or two illuminations. The profiles' brightest values are split in two
  // classes (Otsu on their logarithm); if the classes' medians differ by shadow_split_ratio
  // or more, a shadow's edge crosses the ellipse and each class is a group with its own
  // level; otherwise all profiles form one group. Within a group, a profile whose darkest or
  // brightest value lies beyond 3 robust sigmas (MAD) of the group's median is not used: it
  // reaches a shadow's edge just beyond the ring's, or crosses it (the gradual spread along
  // a thin tilted annulus stays within that band). Nor are the profiles next to a change of
  // group, nor a group of fewer than kMinGroup profiles. Group levels: half-way between the
  // darkest and the brightest value of the group's profiles in use.
  const double split_at = shadow_split(ep, p);
  if (two_lights) *two_lights = split_at > 0;
  const ProfileGroups groups = illumination_groups(ep, split_at, split_light);
  // Each profile's crossing of its group's level.
  return level_crossings(ep, groups, off, e, s2);
}

// Refits after dropping points farther than max(floor, 4 x median) from the conic.
std::optional<Conic> robust_fit(std::vector<Eigen::Vector2d>& pts, double* rms) {
  auto C = fit_ellipse(pts);
  if (!C) return std::nullopt;
  std::vector<double> d(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) d[i] = std::abs(sampson_distance(*C, pts[i]));
  std::vector<double> sorted = d;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double gate = std::max(0.3, 4.0 * sorted[sorted.size() / 2]);  // px
  std::vector<Eigen::Vector2d> kept;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (d[i] <= gate) kept.push_back(pts[i]);
  }
  if (kept.size() < 0.6 * pts.size() || kept.size() < 6) return std::nullopt;
  pts.swap(kept);
  return fit_ellipse(pts, rms);
}

// Initial ellipse of a pixel contour (full-image px) if it passes the cheap shape gates:
// whole inside the search region, long enough, axes, length close to the perimeter, and a
// small residual of the direct least-squares fit.
std::optional<EllipseParams> contour_ellipse(const std::vector<cv::Point>& c,
                                             const cv::Point2f& off, const cv::Rect& roi,
                                             const VisionParams& p) {
  if (static_cast<int>(c.size()) < p.min_contour_points) return std::nullopt;
  const cv::Rect br = cv::boundingRect(c);
  // A contour cut by the search region is not a whole ellipse.
  if (br.x <= 0 || br.y <= 0 || br.x + br.width >= roi.width || br.y + br.height >= roi.height) {
    return std::nullopt;
  }
  // Initial ellipse: direct least squares on the pixel contour (Eigen; cv::fitEllipse goes
  // through LAPACK SVD and costs several times more for these tiny systems).
  std::vector<Eigen::Vector2d> cpts;
  const int cstride = std::max<int>(1, static_cast<int>(c.size()) / 96);
  cpts.reserve(c.size() / cstride + 1);
  for (std::size_t i = 0; i < c.size(); i += cstride) {
    cpts.emplace_back(c[i].x + off.x, c[i].y + off.y);
  }
  const auto Cc = fit_ellipse(cpts);
  const auto ec = Cc ? ellipse_from_conic(*Cc) : std::nullopt;
  if (!ec) return std::nullopt;
  const EllipseParams& e0 = *ec;
  if (!(e0.b >= p.min_axis_px) || e0.b < p.min_axis_ratio * e0.a) return std::nullopt;
  // Contour length must be close to the ellipse perimeter (Ramanujan), a cheap shape gate.
  const double h = std::pow((e0.a - e0.b) / (e0.a + e0.b), 2);
  const double perim = M_PI * (e0.a + e0.b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
  if (c.size() > 1.6 * perim || c.size() < 0.5 * perim) return std::nullopt;
  // Pixel-contour fit residual gate.
  const Conic& C0 = *Cc;
  double ss = 0.0;
  int cnt = 0;
  for (const auto& q : cpts) {
    const double d = sampson_distance(C0, q);
    ss += d * d;
    ++cnt;
  }
  if (std::sqrt(ss / cnt) > p.max_contour_fit_rms_px) return std::nullopt;
  return e0;
}

// Duplicates (both sides of a Canny edge, or one edge found at several threshold levels,
// converge on the same sub-pixel edge): keep the best fitted one.
std::vector<EllipseCandidate> unique_ellipses(std::vector<EllipseCandidate>& out) {
  constexpr double kSameEllipsePx = 0.5;
  std::vector<EllipseCandidate> unique;
  for (auto& c : out) {
    bool dup = false;
    for (auto& u : unique) {
      if ((c.undist.centre - u.undist.centre).norm() < kSameEllipsePx &&
          std::abs(c.undist.a - u.undist.a) < kSameEllipsePx &&
          std::abs(c.undist.b - u.undist.b) < kSameEllipsePx) {
        if (c.fit_rms_px < u.fit_rms_px) u = c;
        dup = true;
        break;
      }
    }
    if (!dup) unique.push_back(std::move(c));
  }
  return unique;
}

}  // namespace

// Sub-pixel edges around `e0` (raw image px) and refit, then undistort the edge points (never
// the image) and fit again in undistorted px.
std::optional<EllipseCandidate> refine_candidate(const cv::Mat& blurred, const cv::Point2f& off,
                                                 const EllipseParams& e0, double search_px,
                                                 const CameraModel& cam, const VisionParams& p,
                                                 bool split_light) {
  // After the first pass the ellipse is within a few tenths of a pixel of the edge, so later
  // passes search a narrower band (faster, and less exposed to neighbouring edges).
  constexpr double kRefinedSearchPx = 1.0;
  EllipseParams e = e0;
  std::vector<Eigen::Vector2d> pts;
  std::optional<Conic> C_img;
  double rms = 0.0;
  bool two_lights = false;
  for (int it = 0; it < std::max(1, p.refine_iterations); ++it) {
    pts = edge_points(blurred, off, e, it == 0 ? search_px : std::min(search_px, kRefinedSearchPx),
                      p, split_light, &two_lights);
    if (static_cast<int>(pts.size()) < std::max(6, static_cast<int>(0.6 * p.edge_samples))) {
      return std::nullopt;
    }
    C_img = robust_fit(pts, &rms);
    const auto en = C_img ? ellipse_from_conic(*C_img) : std::nullopt;
    if (!en) return std::nullopt;
    e = *en;
  }
  if (rms > p.max_edge_fit_rms_px) return std::nullopt;
  // In the shadow pass an ellipse must fit as well as a clean one (the real renders' golden
  // frames fit within 0.016-0.072 px RMS): a small hole cut by a shadow's edge (both sides
  // blurred into each other), or the central ring's inner circle where the code cells next to
  // it hide the shadow's edge from the grouping, otherwise passes with up to a pixel of error
  // in its shape (seen: 0.22 px RMS and 1.3 px on an axis; 0.11 px RMS and 0.8 px).
  constexpr double kShadowMaxFitRmsPx = 0.1;
  if (split_light && rms > kShadowMaxFitRmsPx) return std::nullopt;
  EllipseCandidate cand;
  cand.two_lights = two_lights;
  cand.image = e;
  if (cam.has_distortion()) {
    const cv::Mat Kcv = camera_matrix_cv(cam);
    const cv::Mat Dcv = dist_coeffs_cv(cam);
    std::vector<cv::Point2d> src(pts.size()), dst;
    for (std::size_t i = 0; i < pts.size(); ++i) src[i] = cv::Point2d(pts[i].x(), pts[i].y());
    cv::undistortPoints(src, dst, Kcv, Dcv, cv::noArray(), Kcv);
    for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = Eigen::Vector2d(dst[i].x, dst[i].y);
    C_img = fit_ellipse(pts, &rms);
  }
  const auto& C = C_img;
  const auto eu = C ? ellipse_from_conic(*C) : std::nullopt;
  if (!eu || rms > p.max_edge_fit_rms_px) return std::nullopt;
  cand.C = *C;
  cand.undist = *eu;
  cand.points = std::move(pts);
  cand.fit_rms_px = rms;
  return cand;
}

int bright_level(const cv::Mat& grey, double pixels) {
  int hist[256] = {0};
  for (int y = 0; y < grey.rows; ++y) {
    const std::uint8_t* r = grey.ptr<std::uint8_t>(y);
    for (int x = 0; x < grey.cols; ++x) ++hist[r[x]];
  }
  int level = 255;
  for (double acc = 0; level > 0; --level) {
    acc += hist[level];
    if (acc >= pixels) break;
  }
  return level;
}

namespace {

// The pre-filter of a search region `sub` (a view of the frame's grey buffer) into `blurred`
// (which may be a view of a reusable buffer of sub's size): the Gaussian of
// p.gaussian_sigma_px, or `sub` itself when it is 0.
void prefilter(const cv::Mat& sub, const VisionParams& p, cv::Mat& blurred) {
  if (p.gaussian_sigma_px > 0) {
    // BORDER_ISOLATED: a region's blur must not read the pixels around it. `sub` is a view of
    // the frame's grey buffer, converted in the region only when tracking; outside it the
    // buffer holds whatever this thread converted last, so reading there made a detection
    // depend on the thread's history (the overlapped schedule's worker differed from the
    // serial loop's thread: tests/estimator/vision_determinism_test.cpp).
    cv::GaussianBlur(sub, blurred, cv::Size(0, 0), p.gaussian_sigma_px, 0,
                     cv::BORDER_REFLECT_101 | cv::BORDER_ISOLATED);
  } else {
    blurred = sub;
  }
}

// Shadow-tolerant segmentation. Under a hard shadow (light s) the target's two reflectances
// give four grey levels: lit white W, lit black B, shadowed white sW, shadowed black sB. A
// global threshold t with B < t < sW segments both sides of the shadow's edge correctly (the
// ring stays dark, the white around it light, lit or shadowed), where Otsu's threshold, near
// (B + W) / 2, puts sW with the rings. That interval exists whenever W/B > 1/s and is not known
// in advance, so contours are taken at a few levels, fractions shadow_levels of the region's
// white reference (the 99.5th percentile of the pre-filtered region); one edge found at several
// levels is refined once. Edge points then take a level per illumination (edge_points).
std::vector<EllipseCandidate> find_ellipses_shadow(const cv::Mat& blurred, cv::Mat& bin,
                                                   const cv::Point2f& off, const cv::Rect& roi,
                                                   const CameraModel& cam, const VisionParams& p) {
  // White reference: the 99.5th percentile of the grey levels.
  const int white =
      bright_level(blurred, 0.005 * static_cast<double>(blurred.rows) * blurred.cols);
  std::vector<EllipseCandidate> out;
  std::vector<EllipseParams> seen;  // initial ellipses already refined
  std::vector<std::vector<cv::Point>> contours;
  int last_t = -1;
  for (double f : p.shadow_levels) {
    const int t = static_cast<int>(std::lround(f * white));
    if (t < 2 || t == last_t) continue;
    last_t = t;
    cv::threshold(blurred, bin, t, 255, cv::THRESH_BINARY_INV);
    contours.clear();
    cv::findContours(bin, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    for (const auto& c : contours) {
      const auto e0 = contour_ellipse(c, off, roi, p);
      if (!e0) continue;
      // The same edge at another level: its contour ellipse is within a pixel or so (a few
      // per cent of the axes at close range), far less than an annulus' width.
      const double tol = std::max(1.0, 0.03 * e0->a);
      bool dup = false;
      for (const auto& q : seen) {
        if ((q.centre - e0->centre).norm() < tol && std::abs(q.a - e0->a) < tol &&
            std::abs(q.b - e0->b) < tol) {
          dup = true;
          break;
        }
      }
      if (dup) continue;
      seen.push_back(*e0);
      auto cand = refine_candidate(blurred, off, *e0, p.edge_search_px, cam, p, true);
      if (cand) out.push_back(std::move(*cand));
    }
  }
  return unique_ellipses(out);
}

}  // namespace

std::vector<EllipseCandidate> find_ellipses(const cv::Mat& grey, const cv::Rect& roi,
                                            const CameraModel& cam, const VisionParams& p,
                                            cv::Mat* blurred_out, bool shadow) {
  std::vector<EllipseCandidate> out;
  const cv::Mat sub = grey(roi);
  const cv::Point2f off(static_cast<float>(roi.x), static_cast<float>(roi.y));
  // Per-thread buffers, re-used frame to frame (views of the size of the ROI) instead of
  // re-allocated: fresh pages cost more than the thresholding itself.
  thread_local cv::Mat blurred_buf, bin_buf;
  for (cv::Mat* b : {&blurred_buf, &bin_buf}) {
    if (b->rows < roi.height || b->cols < roi.width) {
      b->create(std::max(b->rows, roi.height), std::max(b->cols, roi.width), CV_8UC1);
    }
  }
  cv::Mat blurred = blurred_buf(cv::Rect(0, 0, roi.width, roi.height));
  prefilter(sub, p, blurred);
  // Dark annuli become foreground (255).
  cv::Mat bin = bin_buf(cv::Rect(0, 0, roi.width, roi.height));
  if (blurred_out) *blurred_out = blurred;
  if (shadow) return find_ellipses_shadow(blurred, bin, off, roi, cam, p);
  if (p.adaptive_threshold) {
    cv::adaptiveThreshold(blurred, bin, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV,
                          p.adaptive_block_px, p.adaptive_offset);
  } else {
    cv::threshold(blurred, bin, 0, 255, cv::THRESH_BINARY_INV | cv::THRESH_OTSU);
  }
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(p.close_kernel_px, p.close_kernel_px));
  // Isolated too: `bin` is the top-left corner of a buffer sized for the largest region this
  // thread has seen, and the closing would read the earlier region's result beside it.
  constexpr int kIsolatedBorder = cv::BORDER_CONSTANT | cv::BORDER_ISOLATED;
  const cv::Scalar border = cv::morphologyDefaultBorderValue();
  if (p.canny_edges) {
    cv::Mat edges;
    cv::Canny(bin, edges, 50, 150);
    if (p.close_kernel_px > 1) {
      cv::morphologyEx(edges, edges, cv::MORPH_CLOSE, kernel, cv::Point(-1, -1), 1, kIsolatedBorder, border);
    }
    bin = edges;
  } else if (p.close_kernel_px > 1) {
    cv::morphologyEx(bin, bin, cv::MORPH_CLOSE, kernel, cv::Point(-1, -1), 1, kIsolatedBorder, border);
  }
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);

  for (const auto& c : contours) {
    const auto e0 = contour_ellipse(c, off, roi, p);
    if (!e0) continue;
    auto cand = refine_candidate(blurred, off, *e0, p.edge_search_px, cam, p);
    if (cand) out.push_back(std::move(*cand));
  }
  return unique_ellipses(out);
}

std::vector<EllipseCandidate> refine_guesses(const cv::Mat& grey, const cv::Rect& roi,
                                             const std::vector<EllipseParams>& guesses,
                                             double search_px, const CameraModel& cam,
                                             const VisionParams& p, cv::Mat* blurred_out) {
  const cv::Mat sub = grey(roi);
  const cv::Point2f off(static_cast<float>(roi.x), static_cast<float>(roi.y));
  cv::Mat blurred;
  prefilter(sub, p, blurred);
  if (blurred_out) *blurred_out = blurred;
  std::vector<EllipseCandidate> out;
  for (const EllipseParams& e0 : guesses) {
    // The whole guess inside the region, as a contour's must be.
    const double r = e0.a + search_px;
    if (e0.centre.x() - r < roi.x || e0.centre.y() - r < roi.y ||
        e0.centre.x() + r > roi.x + roi.width - 1 || e0.centre.y() + r > roi.y + roi.height - 1) {
      continue;
    }
    if (!(e0.b >= p.min_axis_px)) continue;
    auto cand = refine_candidate(blurred, off, e0, search_px, cam, p);
    if (cand) out.push_back(std::move(*cand));
  }
  return unique_ellipses(out);
}

}  // namespace lander::vision_internal
