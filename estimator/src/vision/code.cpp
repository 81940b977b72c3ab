// Code-map localisation (seed 001 section 3), see vision_code.h for the pipeline.
#include "lander/estimator/vision_code.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/internal.h"

namespace lander {

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
// Cell reading: samples in the inner half of the cell (4 x 4) avoid the blurred edges.
constexpr int kCellSamples = 4;
// A cell whose mean lies within this fraction of the class separation from the threshold is
// unknown (straddles an edge, e.g. the ring annulus, or is blurred).
constexpr double kAmbiguousFrac = 0.2;
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

struct Segment {
  Eigen::Vector2d p0, p1;  // undistorted px
  double len{0.0};
  double theta{0.0};
};

// Vanishing point (homogeneous, normalised coordinates (x - c) / f) of a family of segments:
// least-squares intersection of their lines, iterated on the inliers.
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

Eigen::Vector2d apply_h(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * Eigen::Vector3d(p.x(), p.y(), 1.0);
  return q.head<2>() / q.z();
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

using vision_internal::bilinear;

// Code map extended by a margin of E cells: 0 light, 1 dark, 2 unknown (outside the inner
// circle of the central ring set or not background).
struct ExtendedMap {
  int n{0}, E{0}, w{0};
  std::vector<std::uint8_t> v;
  int at(int col, int row) const {
    if (col < -E || row < -E || col >= n + E || row >= n + E) return 2;
    return v[(row + E) * w + (col + E)];
  }
};

ExtendedMap extended_map(const TargetGeometry& g, const std::vector<std::uint8_t>& map) {
  ExtendedMap m;
  m.n = g.code.cells;
  double inner_r = 0.0;
  for (const auto& r : g.rings) {
    if (r.centre_P_m.norm() < 1e-9) inner_r = r.inner_radius_m;
  }
  const double half = 0.5 * g.code.side_m(), cell = g.code.cell_m;
  m.E = std::max(0, static_cast<int>(std::ceil((inner_r - half) / cell)) + 1);
  m.w = m.n + 2 * m.E;
  m.v.assign(static_cast<std::size_t>(m.w) * m.w, 2);
  for (int row = -m.E; row < m.n + m.E; ++row) {
    for (int col = -m.E; col < m.n + m.E; ++col) {
      std::uint8_t val = 2;
      if (row >= 0 && col >= 0 && row < m.n && col < m.n) {
        val = map[row * m.n + col] ? 1 : 0;
      } else {
        // Background if the whole cell lies inside the inner circle (1 mm margin).
        bool inside = true;
        for (int dc = 0; dc <= 1; ++dc) {
          for (int dr = 0; dr <= 1; ++dr) {
            const double x = -half + (col + dc) * cell, y = half - (row + dr) * cell;
            if (std::hypot(x, y) > inner_r - 0.001) inside = false;
          }
        }
        if (inside) val = 0;
      }
      m.v[(row + m.E) * m.w + (col + m.E)] = val;
    }
  }
  return m;
}

}  // namespace

Eigen::Vector2i rotate_lattice(int a, int b, int q) {
  switch (((q % 4) + 4) % 4) {
    case 0: return {a, b};
    case 1: return {-b, a};
    case 2: return {-a, -b};
    default: return {b, -a};
  }
}

CodePlacement place_code_cells(const std::vector<ObservedCell>& cells, const TargetGeometry& g,
                               const std::vector<std::uint8_t>& map, const VisionParams& p) {
  CodePlacement best;
  best.runner_up_mismatched = -1;
  const int n = g.code.cells, b = g.code.window;
  if (n == 0) {
    best.reason = "target has no code map";
    return best;
  }
  if (static_cast<int>(cells.size()) < b * b) {
    best.reason = std::to_string(cells.size()) + " cells read, a window needs " +
                  std::to_string(b * b);
    return best;
  }
  const ExtendedMap em = extended_map(g, map);
  int best_score = std::numeric_limits<int>::min() / 2, second_score = best_score, second_mis = -1;
  // Rotated cell index of (a, b): the cell centre rotated, minus one half (an integer).
  auto rot_cell = [](int a, int bb, int q) {
    const Eigen::Vector2i r2 = rotate_lattice(2 * a + 1, 2 * bb + 1, q);
    return Eigen::Vector2i((r2.x() - 1) / 2, (r2.y() - 1) / 2);
  };
  std::vector<Eigen::Vector2i> rc(cells.size());
  for (int q = 0; q < 4; ++q) {
    int amin = 1 << 30, amax = -(1 << 30), bmin = 1 << 30, bmax = -(1 << 30);
    for (std::size_t i = 0; i < cells.size(); ++i) {
      rc[i] = rot_cell(cells[i].a, cells[i].b, q);
      amin = std::min(amin, rc[i].x());
      amax = std::max(amax, rc[i].x());
      bmin = std::min(bmin, rc[i].y());
      bmax = std::max(bmax, rc[i].y());
    }
    // Offsets putting at least one read cell on the map.
    for (int oc = -amax; oc <= n - 1 - amin; ++oc) {
      for (int orow = -bmax; orow <= n - 1 - bmin; ++orow) {
        // A placement changes the best or the runner-up only if it scores above the
        // runner-up; each cell left can add at most one, so the count stops as soon as that
        // is out of reach (the result is the full count's, found sooner).
        int compared = 0, mis = 0;
        const int n_cells = static_cast<int>(cells.size());
        bool reachable = true;
        for (int i = 0; i < n_cells; ++i) {
          const int v = em.at(rc[i].x() + oc, rc[i].y() + orow);
          if (v != 2) {
            ++compared;
            mis += v != cells[i].dark;
          }
          if (compared - 4 * mis + (n_cells - 1 - i) <= second_score) {
            reachable = false;
            break;
          }
        }
        if (!reachable) continue;
        const int score = compared - 4 * mis;
        if (score > best_score) {
          if (best.compared > 0) {
            second_score = best_score;
            second_mis = best.mismatched;
          }
          best_score = score;
          best.rotation = q;
          best.col_offset = oc;
          best.row_offset = orow;
          best.compared = compared;
          best.mismatched = mis;
        } else if (score > second_score) {
          second_score = score;
          second_mis = mis;
        }
      }
    }
  }
  best.runner_up_mismatched = second_mis;
  // Full b x b window among the compared in-map cells.
  std::vector<char> seen(static_cast<std::size_t>(n) * n, 0);
  for (const auto& c : cells) {
    const Eigen::Vector2i r = rot_cell(c.a, c.b, best.rotation);
    const int col = r.x() + best.col_offset, row = r.y() + best.row_offset;
    if (col >= 0 && row >= 0 && col < n && row < n) seen[row * n + col] = 1;
  }
  for (int r0 = 0; r0 + b <= n && !best.full_window; ++r0) {
    for (int c0 = 0; c0 + b <= n && !best.full_window; ++c0) {
      bool all = true;
      for (int r = 0; r < b && all; ++r) {
        for (int c = 0; c < b && all; ++c) all = seen[(r0 + r) * n + c0 + c];
      }
      best.full_window = all;
    }
  }
  int in_map = 0;
  for (char c : seen) in_map += c;
  std::ostringstream os;
  // Uniqueness: a full b x b window is unique by construction of the map. Below ~0.2 m a
  // 45-deg yawed view holds no full window, so a read of at least 2 b^2 map cells is also
  // accepted: its uniqueness is then checked directly, every other placement of these cells
  // (all rotations and offsets) must score code_min_score_margin lower (disagree on at
  // least two more cells).
  if (!best.full_window && in_map < 2 * b * b) {
    os << "no full " << b << "x" << b << " window among the read cells and only " << in_map
       << " map cells (need " << 2 * b * b << ")";
  } else if (best.mismatched > p.code_max_mismatch_fraction * best.compared) {
    os << best.mismatched << " of " << best.compared << " read cells disagree with the map";
  } else if (best_score - second_score < p.code_min_score_margin) {
    os << "ambiguous placement (runner-up score " << second_score << " vs " << best_score << ")";
  } else {
    best.found = true;
  }
  best.reason = os.str();
  return best;
}

namespace {

// A cell's mean grey at lattice label (a, b).
struct CellRead {
  int a, b;
  double mean;
};

// Cells read against their local white (detect_code_pattern, step 4). The ink renders near
// 0 (a dark cell reads below 0.1 of its white, blurred ones too), a white cell under a
// shadow the closing followed near 1, and one under a thin shadow the closing filled in (an
// arm's, ~1 cell wide) at the shadow's light, 10-50 %: dark below 0.2 of the local white,
// white above 0.45, unknown between (on 30 frames of a shadowed landing 0.2/0.45 placed the
// code in 18, 0.3/0.7 in 12; 0.12/0.3 and 0.15/0.35 also in 18).
constexpr double kLocalDarkBelow = 0.2;
constexpr double kLocalWhiteAbove = 0.45;
std::vector<ObservedCell> read_cells_local_white(const std::vector<CellRead>& reads, int amin,
                                                 int amax, int bmin, int bmax) {
  const int w = amax - amin + 3, h = bmax - bmin + 3;
  auto at = [&](int a, int b) { return (b - bmin + 1) * w + (a - amin + 1); };
  const double kNone = -1.0;
  std::vector<double> mean(static_cast<std::size_t>(w) * h, kNone);
  for (const auto& r : reads) mean[at(r.a, r.b)] = r.mean;
  auto filter = [&](const std::vector<double>& in, bool take_max) {
    std::vector<double> out(in.size(), kNone);
    for (int b = bmin - 1; b <= bmax + 1; ++b) {
      for (int a = amin - 1; a <= amax + 1; ++a) {
        if (in[at(a, b)] == kNone) continue;
        double v = in[at(a, b)];
        for (int db = -1; db <= 1; ++db) {
          for (int da = -1; da <= 1; ++da) {
            const int aa = a + da, bb = b + db;
            if (aa < amin - 1 || aa > amax + 1 || bb < bmin - 1 || bb > bmax + 1) continue;
            const double q = in[at(aa, bb)];
            if (q == kNone) continue;
            v = take_max ? std::max(v, q) : std::min(v, q);
          }
        }
        out[at(a, b)] = v;
      }
    }
    return out;
  };
  const std::vector<double> white = filter(filter(mean, true), false);
  std::vector<ObservedCell> cells;
  for (const auto& r : reads) {
    const double wl = white[at(r.a, r.b)];
    if (!(wl > 0)) continue;
    const double v = r.mean / wl;
    if (v >= kLocalDarkBelow && v <= kLocalWhiteAbove) continue;
    cells.push_back({r.a, r.b, static_cast<std::uint8_t>(v < kLocalDarkBelow ? 1 : 0)});
  }
  return cells;
}

// Steps 1-5 on `grey` (the camera's whole image, or a region of it with `cam` shifted to
// it) with the adaptive threshold's block `block` px; `X_CP_prior`, when given, predicts the
// grid's two line families (step 2).
CodeDetection detect_code_impl(const cv::Mat& grey, const CameraModel& cam, const TargetGeometry& g,
                               const VisionParams& p, int block,
                               const Eigen::Isometry3d* X_CP_prior = nullptr) {
  CodeDetection d;
  auto fail = [&](std::string why) {
    d.detected = false;
    d.reason = "code: " + why;
    return d;
  };
  if (g.code.cells == 0) return fail("target has no code map");
  if (grey.empty() || grey.type() != CV_8UC1) return fail("need an 8-bit grey frame");
  const double minc = p.code_min_cell_px;
  // ---- 1. threshold, contours, polygon vertices and sides ----
  cv::Mat bin;
  if (block < 3) return fail("image too small");
  cv::adaptiveThreshold(grey, bin, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV, block,
                        p.code_threshold_offset);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  std::vector<cv::Point2f> vraw;
  std::vector<Segment> segs;
  std::vector<cv::Point2f> sraw;
  auto near_border = [&](const cv::Point& q) {
    return q.x < kBorderMarginPx || q.y < kBorderMarginPx || q.x > grey.cols - 1 - kBorderMarginPx ||
           q.y > grey.rows - 1 - kBorderMarginPx;
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
        sraw.emplace_back(static_cast<float>(v.x), static_cast<float>(v.y));
        sraw.emplace_back(static_cast<float>(nx.x), static_cast<float>(nx.y));
      }
      if (near_border(v) || a.norm() < 0.6 * minc || b.norm() < 0.6 * minc) continue;
      const double cs = a.dot(b) / (a.norm() * b.norm());
      if (cs < cos_min || cs > cos_max) continue;
      vraw.emplace_back(static_cast<float>(v.x), static_cast<float>(v.y));
    }
  }
  if (vraw.size() < 8) return fail(std::to_string(vraw.size()) + " grid corners found");
  const std::vector<Eigen::Vector2d> verts = undistort_points(cam, vraw);
  {
    const std::vector<Eigen::Vector2d> su = undistort_points(cam, sraw);
    for (std::size_t i = 0; i + 1 < su.size(); i += 2) {
      Segment s{su[i], su[i + 1], (su[i + 1] - su[i]).norm(), 0.0};
      s.theta = std::atan2(su[i + 1].y() - su[i].y(), su[i + 1].x() - su[i].x());
      segs.push_back(s);
    }
  }
  // ---- 2. two line families, vanishing points, affine rectification, lattice labels ----
  const Eigen::Vector2d cpp(cam.cx_px, cam.cy_px);
  const double f = cam.fx_px;
  std::vector<Segment> famA, famB;
  if (X_CP_prior != nullptr) {
    // The map's rows and columns run along P's x and y axes: their vanishing points are the
    // camera-frame directions of those axes. A side joins the family whose line through the
    // side's midpoint towards that point it follows best, within kPriorFamilyTolDeg.
    const Eigen::Matrix3d R = X_CP_prior->linear();
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
      (a < b ? famA : famB).push_back(s);
    }
  } else {
    double C4 = 0, S4 = 0;
    for (const auto& s : segs) {
      C4 += s.len * std::cos(4 * s.theta);
      S4 += s.len * std::sin(4 * s.theta);
    }
    const double th0 = 0.25 * std::atan2(S4, C4);
    const double tol = kFamilyTolDeg * M_PI / 180;
    for (const auto& s : segs) {
      if (std::abs(std::remainder(s.theta - th0, M_PI)) < tol) {
        famA.push_back(s);
      } else if (std::abs(std::remainder(s.theta - th0 - 0.5 * M_PI, M_PI)) < tol) {
        famB.push_back(s);
      }
    }
  }
  const auto vA = vanishing_point(famA, cpp, f);
  const auto vB = vanishing_point(famB, cpp, f);
  if (!vA || !vB) return fail("no two grid line families");
  Eigen::Vector3d linf = vA->cross(*vB);
  if (std::abs(linf.z()) < 1e-9 * linf.norm()) return fail("degenerate vanishing line");
  linf /= linf.z();
  Eigen::Matrix3d Hp = Eigen::Matrix3d::Identity();
  Hp.row(2) = linf.transpose();
  Eigen::Vector2d dA = (Hp * *vA).head<2>().normalized(), dB = (Hp * *vB).head<2>().normalized();
  if (dA.x() * dB.y() - dA.y() * dB.x() < 0) dB = -dB;
  Eigen::Matrix2d Bm;
  Bm.col(0) = dA;
  Bm.col(1) = dB;
  if (std::abs(Bm.determinant()) < 0.2) return fail("grid families not distinct");
  const Eigen::Matrix2d Bi = Bm.inverse();
  auto rect = [&](const Eigen::Vector2d& px) {
    const Eigen::Vector3d q = Hp * Eigen::Vector3d((px.x() - cpp.x()) / f, (px.y() - cpp.y()) / f, 1);
    return Eigen::Vector2d(Bi * (q.head<2>() / q.z()));
  };
  // Cell size (px): median distance to the nearest other vertex.
  // Scanned in x order outwards from each vertex, stopping where the x gap alone reaches the
  // nearest distance so far: the same minimum as comparing every pair, without the n^2.
  std::vector<double> nn;
  {
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
  }
  if (nn.empty()) return fail("isolated corners");
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  const double cell0 = nn[nn.size() / 2];
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
  Eigen::Vector2d seed = verts[0];
  for (const auto& v : verts) {
    if ((v - med).norm() < (seed - med).norm()) seed = v;
  }
  double R0 = kSeedRadiusCells * cell0;
  std::vector<std::size_t> local;
  for (int grow = 0; grow < 6; ++grow, R0 *= 1.5) {
    local.clear();
    for (std::size_t i = 0; i < verts.size(); ++i) {
      if ((verts[i] - seed).norm() <= R0) local.push_back(i);
    }
    if (local.size() >= kMinSeedCorners) break;
  }
  std::vector<double> xs, ys, lenA, lenB;
  for (std::size_t i : local) {
    const Eigen::Vector2d r = rect(verts[i]);
    xs.push_back(r.x());
    ys.push_back(r.y());
  }
  auto near_seed = [&](const Segment& sg) { return (0.5 * (sg.p0 + sg.p1) - seed).norm() <= 2 * R0; };
  for (const auto& sg : famA) {
    if (near_seed(sg)) lenA.push_back(std::abs(rect(sg.p1).x() - rect(sg.p0).x()));
  }
  for (const auto& sg : famB) {
    if (near_seed(sg)) lenB.push_back(std::abs(rect(sg.p1).y() - rect(sg.p0).y()));
  }
  const auto lx = lattice_1d(lenA, xs), ly = lattice_1d(lenB, ys);
  if (!lx || !ly) return fail("no lattice spacing");
  std::vector<Eigen::Vector2d> lab, img;
  for (std::size_t k = 0; k < local.size(); ++k) {
    lab.emplace_back(std::round((xs[k] - lx->second) / lx->first),
                     std::round((ys[k] - ly->second) / ly->first));
    img.push_back(verts[local[k]]);
  }
  auto H = fit_homography(lab, img, true, kLatticeInlierFrac * cell0);
  if (!H) return fail("no lattice homography");
  // Growth: relabel the corners within a growing radius of the seed with the current
  // homography, keep those on the lattice, refit.
  std::vector<Eigen::Vector2i> in_lab;
  double radius = 2 * R0;
  for (int it = 0; it < 12; ++it, radius *= 1.5) {
    const bool last = it == 11;
    const Eigen::Matrix3d Hi = H->inverse();
    std::vector<Eigen::Vector2d> l2, i2;
    in_lab.clear();
    bool all = true;
    for (const auto& v : verts) {
      if (!last && (v - seed).norm() > radius) {
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
    if (l2.size() < 8) return fail(std::to_string(l2.size()) + " corners on the lattice");
    auto H2 = fit_homography(l2, i2, false, 0.0);
    if (!H2) return fail("lattice homography failed");
    H = H2;
    if (all && it >= 2) break;
  }
  // Keep the corners of one code map: labels within cells + 2 of the median label (corners
  // of the platform edge or ring polygons far away can fall on the lattice by chance).
  {
    std::vector<int> la, lb;
    for (const auto& l : in_lab) {
      la.push_back(l.x());
      lb.push_back(l.y());
    }
    std::nth_element(la.begin(), la.begin() + la.size() / 2, la.end());
    std::nth_element(lb.begin(), lb.begin() + lb.size() / 2, lb.end());
    const int ma = la[la.size() / 2], mb = lb[lb.size() / 2], reach = g.code.cells + 2;
    std::vector<Eigen::Vector2d> l2, i2;
    std::vector<Eigen::Vector2i> kept;
    const Eigen::Matrix3d Hi = H->inverse();
    for (const auto& v : verts) {
      const Eigen::Vector2d q = apply_h(Hi, v);
      const auto rx = vision_internal::to_int_coord(std::round(q.x())), ry = vision_internal::to_int_coord(std::round(q.y()));
      if (!rx || !ry) continue;
      const Eigen::Vector2i r(*rx, *ry);
      const Eigen::Vector2d rd = r.cast<double>();
      const double cell = (apply_h(*H, rd + Eigen::Vector2d(0.5, 0)) -
                           apply_h(*H, rd - Eigen::Vector2d(0.5, 0))).norm();
      if ((apply_h(*H, rd) - v).norm() > kLatticeInlierFrac * cell) continue;
      if (std::abs(r.x() - ma) > reach || std::abs(r.y() - mb) > reach) continue;
      l2.push_back(rd);
      i2.push_back(v);
      kept.push_back(r);
    }
    if (kept.size() < 8) return fail(std::to_string(kept.size()) + " corners near the code");
    if (kept.size() < in_lab.size()) {
      auto H2 = fit_homography(l2, i2, false, 0.0);
      if (!H2) return fail("lattice homography failed");
      H = H2;
    }
    in_lab = kept;
  }
  // Handedness: the lattice (a, b) must map like the code map's (col, row) (vision_code.h).
  {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& l : in_lab) mean += l.cast<double>();
    mean /= in_lab.size();
    const Eigen::Vector2d o = apply_h(*H, mean);
    const Eigen::Vector2d ea = apply_h(*H, mean + Eigen::Vector2d(1, 0)) - o;
    const Eigen::Vector2d eb = apply_h(*H, mean + Eigen::Vector2d(0, 1)) - o;
    if (ea.x() * eb.y() - ea.y() * eb.x() < 0) {
      Eigen::Matrix3d S;
      S << 0, 1, 0, 1, 0, 0, 0, 0, 1;
      *H = *H * S;
      for (auto& l : in_lab) std::swap(l.x(), l.y());
    }
  }
  // ---- 3. read the cells ----
  int amin = 1 << 30, amax = -(1 << 30), bmin = 1 << 30, bmax = -(1 << 30);
  for (const auto& l : in_lab) {
    amin = std::min(amin, l.x());
    amax = std::max(amax, l.x());
    bmin = std::min(bmin, l.y());
    bmax = std::max(bmax, l.y());
  }
  const int span_cap = 2 * g.code.cells + 16;
  if (amax - amin > span_cap || bmax - bmin > span_cap) return fail("lattice too large");
  std::vector<CellRead> reads;
  std::vector<double> cell_sides;
  for (int b = bmin - 1; b <= bmax; ++b) {
    for (int a = amin - 1; a <= amax; ++a) {
      Eigen::Vector2d corner[4];
      bool ok = true;
      const int da[4] = {0, 1, 1, 0}, db[4] = {0, 0, 1, 1};
      for (int k = 0; k < 4 && ok; ++k) {
        corner[k] = apply_h(*H, Eigen::Vector2d(a + da[k], b + db[k]));
        const Eigen::Vector2d r = cam.distort_px(corner[k]);
        ok = r.x() >= 1 && r.y() >= 1 && r.x() <= grey.cols - 2 && r.y() <= grey.rows - 2;
      }
      if (!ok) continue;
      double side = 1e18;
      for (int k = 0; k < 4; ++k) side = std::min(side, (corner[(k + 1) % 4] - corner[k]).norm());
      if (side < 0.8 * minc) continue;
      cell_sides.push_back(side);
      double sum = 0.0;
      for (int i = 0; i < kCellSamples; ++i) {
        for (int j = 0; j < kCellSamples; ++j) {
          const double u = a + 0.25 + 0.5 * (i + 0.5) / kCellSamples;
          const double v = b + 0.25 + 0.5 * (j + 0.5) / kCellSamples;
          const Eigen::Vector2d r = cam.distort_px(apply_h(*H, Eigen::Vector2d(u, v)));
          sum += bilinear(grey, r.x(), r.y());
        }
      }
      reads.push_back({a, b, sum / (kCellSamples * kCellSamples)});
    }
  }
  if (reads.size() < 4) return fail("no cells in view");
  std::nth_element(cell_sides.begin(), cell_sides.begin() + cell_sides.size() / 2, cell_sides.end());
  d.cell_px = cell_sides[cell_sides.size() / 2];
  // Two-class (Otsu) threshold on the cell means.
  std::vector<double> vals;
  for (const auto& r : reads) vals.push_back(r.mean);
  std::sort(vals.begin(), vals.end());
  const vision_internal::OtsuSplit split = vision_internal::otsu_split_sorted(vals);
  const double lo = split.mean_lo, hi = split.mean_hi;
  if (hi - lo < p.code_min_contrast) {
    return fail("cell contrast " + std::to_string(hi - lo) + " below the gate");
  }
  const double mid = 0.5 * (lo + hi);
  std::vector<ObservedCell> cells;
  for (const auto& r : reads) {
    if (std::abs(r.mean - mid) < kAmbiguousFrac * (hi - lo)) continue;
    cells.push_back({r.a, r.b, static_cast<std::uint8_t>(r.mean < mid ? 1 : 0)});
  }
  d.cells_read = static_cast<int>(cells.size());
  // ---- 4. place the read cells in the map ----
  const std::vector<std::uint8_t> map = generate_code_map(g.code);
  d.placement = place_code_cells(cells, g, map, p);
  if (!d.placement.found && p.code_local_white) {
    // Under a shadow (the vehicle's own, in the last metre) one level for every cell reads
    // the shadowed white cells as dark. Read again, each cell against its local white: the
    // closing of the cell means over the lattice (the largest of each 3 x 3 neighbourhood,
    // then the smallest of those over 3 x 3) follows a shadow's edge wherever each 3 x 3
    // block holds a white cell, and fills the dark cells in. Clean frames never get here
    // unless the one level failed anyway.
    std::vector<ObservedCell> local = read_cells_local_white(reads, amin, amax, bmin, bmax);
    CodePlacement again = place_code_cells(local, g, map, p);
    if (again.found) {
      again.reason += " (cells read against their local white: " +
                      std::to_string(local.size()) + " read; one level: " +
                      d.placement.reason + ")";
      d.placement = again;
      d.cells_read = static_cast<int>(local.size());
      d.local_white = true;
    } else {
      d.placement.reason += "; against their local white: " + again.reason;
    }
  }
  if (!d.placement.found) return fail(d.placement.reason);
  // ---- 5. sub-pixel corners of the map and PnP ----
  const ExtendedMap em = extended_map(g, map);
  const int n = g.code.cells;
  const double half = 0.5 * g.code.side_m(), cm = g.code.cell_m;
  double inner_r = 0.0;
  for (const auto& r : g.rings) {
    if (r.centre_P_m.norm() < 1e-9) inner_r = r.inner_radius_m;
  }
  const int qi = (4 - d.placement.rotation) % 4;
  const int win = std::clamp(static_cast<int>(std::lround(0.25 * d.cell_px)), 2, 10);
  std::vector<cv::Point2f> pred;
  std::vector<Eigen::Vector2d> predu, objs;
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
          rotate_lattice(col - d.placement.col_offset, row - d.placement.row_offset, qi);
      const Eigen::Vector2d u = apply_h(*H, l.cast<double>());
      const Eigen::Vector2d r = cam.distort_px(u);
      if (r.x() < win + 2 || r.y() < win + 2 || r.x() > grey.cols - win - 3 ||
          r.y() > grey.rows - win - 3) {
        continue;
      }
      pred.emplace_back(static_cast<float>(r.x()), static_cast<float>(r.y()));
      predu.push_back(u);
      objs.push_back(P);
    }
  }
  if (static_cast<int>(pred.size()) < p.code_min_corners) {
    return fail(std::to_string(pred.size()) + " corners in view");
  }
  std::vector<cv::Point2f> refined = pred;
  cv::cornerSubPix(grey, refined, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01));
  const std::vector<Eigen::Vector2d> ref_u = undistort_points(cam, refined);
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> ip;
  for (std::size_t i = 0; i < refined.size(); ++i) {
    if ((ref_u[i] - predu[i]).norm() > kCornerMoveFrac * d.cell_px) continue;
    obj.emplace_back(objs[i].x(), objs[i].y(), 0.0);
    ip.emplace_back(ref_u[i].x(), ref_u[i].y());
  }
  if (static_cast<int>(obj.size()) < p.code_min_corners) {
    return fail(std::to_string(obj.size()) + " corners refined");
  }
  const cv::Mat Kcv = camera_matrix_cv(cam);
  cv::Mat rvec, tvec;
  auto solve = [&]() -> bool {
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
  };
  if (!solve()) return fail("PnP failed");
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
    d.reproj_rms_px = std::sqrt(ss / pr.size());
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
      return fail("too many corner outliers (" + std::to_string(n_corners - o2.size()) + " of " +
                  std::to_string(n_corners) + ")");
    }
    obj = o2;
    ip = i2;
    if (!solve()) return fail("PnP failed");
  }
  // The gate grows with the code's extent in the image (code_max_reproj_fraction of the
  // corners' RMS distance from their centroid): a relative calibration error (pixel aspect)
  // leaves residuals in proportion to that extent, largest in the last decimetres.
  cv::Scalar corner_mean, corner_sd;
  cv::meanStdDev(ip, corner_mean, corner_sd);
  const double spread_px = std::hypot(corner_sd[0], corner_sd[1]);
  const double reproj_gate =
      vision_internal::scaled_gate(p.code_max_reproj_px, p.code_max_reproj_fraction, spread_px);
  d.reproj_gate_px = reproj_gate;
  if (!(d.reproj_rms_px <= reproj_gate)) {
    std::ostringstream os;
    os << "corner reprojection " << d.reproj_rms_px << " px above the gate " << reproj_gate
       << " px (the larger of code_max_reproj_px and code_max_reproj_fraction x the corners' "
          "spread, "
       << spread_px << " px)";
    return fail(os.str());
  }
  // Covariance sigma^2 (J^T J)^-1 over [rvec, tvec].
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
  const double sigma2 = d.reproj_rms_px * d.reproj_rms_px * 2.0 * obj.size() / dof;
  Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(JtJ);
  if (!lu.isInvertible()) return fail("singular corner Jacobian");
  d.cov = sigma2 * lu.inverse();
  d.X_CP = pose_from_cv(rvec, tvec);
  for (std::size_t i = 0; i < obj.size(); ++i) {
    d.corners_P_m.emplace_back(obj[i].x, obj[i].y);
    d.corners_px.emplace_back(ip[i].x, ip[i].y);
  }
  d.detected = true;
  std::ostringstream os;
  os << "code: " << d.cells_read << " cells read, " << d.placement.compared << " compared, "
     << d.placement.mismatched << " disagree, " << obj.size() << " corners, rotation "
     << d.placement.rotation;
  d.reason = os.str();
  return d;
}

// The adaptive threshold's block on a whole frame: code_threshold_block_px, at most the
// largest odd size within half the frame's shorter side.
int threshold_block(const cv::Mat& frame, const VisionParams& p) {
  return std::min(p.code_threshold_block_px, (std::min(frame.cols, frame.rows) / 2) * 2 - 1);
}

}  // namespace

CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& cam,
                                  const TargetGeometry& g, const VisionParams& p,
                                  const Eigen::Isometry3d* X_CP_prior) {
  return detect_code_impl(grey, cam, g, p, threshold_block(grey, p), X_CP_prior);
}

CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& cam,
                                  const TargetGeometry& g, const VisionParams& p,
                                  const cv::Rect& region, const Eigen::Isometry3d* X_CP_prior) {
  const cv::Rect r = region & cv::Rect(0, 0, grey.cols, grey.rows);
  if (grey.empty() || r.width < 16 || r.height < 16) {
    CodeDetection d;
    d.reason = "code: search region outside the frame";
    return d;
  }
  // A copy: no filter of the search reads pixels outside the region. The block is the whole
  // frame's, so pixels at least half a block inside the region threshold as on the frame.
  CodeDetection d = detect_code_impl(grey(r).clone(), vision_internal::zoomed_camera(cam, r, 1), g,
                                     p, threshold_block(grey, p), X_CP_prior);
  for (auto& c : d.corners_px) c += Eigen::Vector2d(r.x, r.y);
  return d;
}

namespace vision_internal {

double bilinear(const cv::Mat& g, double x, double y) {
  x = vision_internal::clamp_coord(x);
  y = vision_internal::clamp_coord(y);
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xx, int yy) {
    xx = std::clamp(xx, 0, g.cols - 1);
    yy = std::clamp(yy, 0, g.rows - 1);
    return static_cast<double>(g.at<std::uint8_t>(yy, xx));
  };
  return (1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) +
         (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1);
}

}  // namespace vision_internal
}  // namespace lander
