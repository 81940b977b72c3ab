// Identification of ring sets by the target's layout (vision_layout.h).
#include "lander/estimator/vision_layout.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <initializer_list>
#include <limits>
#include <set>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace lander {
namespace {

using Cplx = std::complex<double>;

Cplx to_c(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }

// The common offset removed from photometric ratios stays within [-low, high]: their mean
// error is +0.01 on exactly drawn grazing views (unit test VisionLayout.PhotometricRatios*),
// -0.02 to -0.03 on the bench's rendered ones at 2.5-10 m (-0.08 at 15 m), while the hexagon's
// 180 deg turn shifts every ratio by 0.08-0.1.
constexpr double kPhotometricMaxBiasLow = 0.05;
constexpr double kPhotometricMaxBiasHigh = 0.03;

// `layout_ratio_margin` is the margin between two identities' mean ratio errors when either
// has at most this many measured ratios; with n more on both sides it shrinks by
// sqrt(this / n), as the noise of a mean does (synthetic views with six ratios at 0.03-0.05 of
// noise: 0 wrong in 2000-3000 identified either way, and half as many again identified; unit
// test VisionLayout.ManyRatiosNeedLessMargin).
constexpr double kMarginReferenceSets = 4.0;

// One hypothesis: the candidate taken as the central set's circle of radius r0_m, the
// similarity (scale k, rotation) from the model plane to the rectified plane, and the sets
// matched under it.
struct Hypothesis {
  std::vector<int> cand_of_ring;  // per target.rings index: candidate, -1 none
  int matched{0};                 // rings matched, the central one included
  int ratio_sets{0};
  double mean_err{0.0};
  double max_err{0.0};
  double bias{0.0};  // the common ratio offset removed
};

// Whether candidates ca and cb stand for the same set: the same candidate, or two ellipses
// found for one set (its outer circle at two threshold levels, or the central set's inner
// circle beside its outer one), whose centres are within the smaller minor semi-axis of each
// other, while neighbouring sets' centres are at least a set's diameter apart.
bool same_place(const std::vector<LayoutCandidate>& cands, int ca, int cb) {
  if (ca == cb) return true;
  const double r = std::min(cands[ca].outer.b, cands[cb].outer.b);
  return (cands[ca].centre - cands[cb].centre).norm() < r;
}

// Whether two hypotheses give some set different identities: a set named i by one and
// placed elsewhere by the other, or named otherwise by it. Two hypotheses that differ only
// in which of a set's duplicate ellipses stands for it agree.
bool conflict(const std::vector<LayoutCandidate>& cands, const Hypothesis& a, const Hypothesis& b) {
  for (std::size_t i = 0; i < a.cand_of_ring.size(); ++i) {
    const int ca = a.cand_of_ring[i], cb = b.cand_of_ring[i];
    if (ca < 0) continue;
    if (cb >= 0 && !same_place(cands, ca, cb)) return true;
    // The same set under another identity.
    for (std::size_t k = 0; k < b.cand_of_ring.size(); ++k) {
      if (k != i && b.cand_of_ring[k] >= 0 && same_place(cands, ca, b.cand_of_ring[k])) return true;
    }
  }
  return false;
}

// Twins: one set's circle found twice (at two threshold levels of the shadow pass, or by
// two passes' ellipses), at the same place and of about the same size (within this fraction
// on both axes; a set's inner circle is at most 0.75 of its outer one).
constexpr double kTwinSizeTol = 0.15;

// The candidates with every group of twins merged into its first member, whose ratio becomes
// the mean of the group's measured ratios (photometric only if all of them are); `rep` maps
// each merged candidate to its index in `input`. A set then enters each hypothesis once, with
// one reading: a choice among twins would let every identity pick its most favourable
// reading, and the wrong ones gain most from that.
std::vector<LayoutCandidate> merge_twins(const std::vector<LayoutCandidate>& input,
                                         std::vector<int>& rep) {
  std::vector<LayoutCandidate> out;
  std::vector<bool> merged(input.size(), false);  // already in an earlier group
  rep.clear();
  for (std::size_t i = 0; i < input.size(); ++i) {
    if (merged[i]) continue;
    LayoutCandidate c = input[i];
    double sum = 0.0;
    int n = 0;
    bool photometric = true;
    auto add = [&](const LayoutCandidate& x) {
      if (x.ratio < 0) return;
      sum += x.ratio;
      ++n;
      photometric &= x.photometric;
    };
    add(input[i]);
    for (std::size_t j = i + 1; j < input.size(); ++j) {
      const LayoutCandidate& x = input[j];
      if (merged[j] || !same_place(input, static_cast<int>(i), static_cast<int>(j)) ||
          !(std::abs(x.outer.a / c.outer.a - 1.0) <= kTwinSizeTol) ||
          !(std::abs(x.outer.b / c.outer.b - 1.0) <= kTwinSizeTol)) {
        continue;
      }
      merged[j] = true;
      add(x);
    }
    c.ratio = n > 0 ? sum / n : -1.0;
    c.photometric = n > 0 && photometric;
    out.push_back(c);
    rep.push_back(static_cast<int>(i));
  }
  return out;
}

// The candidates seen in the model plane's metric frame (m, origin at the seed candidate's
// centre, up to a rotation): their centres q and outer radii (-1 where not round).
struct Rectified {
  std::vector<Eigen::Vector2d> q;
  std::vector<double> radius;
};

// All candidates rectified with the seed `f` taken as a circle of radius r0 (m).
Rectified rectify_about(const std::vector<LayoutCandidate>& cands, const LayoutCandidate& f,
                        double r0, const VisionParams& p) {
  const int n = static_cast<int>(cands.size());
  // Image -> rectified plane (m, origin at the candidate's centre) up to a rotation,
  // with the mirror sense of a plane seen from its front in an image whose y axis
  // points down (the map's determinant < 0).
  Eigen::Matrix2d A = Eigen::Vector2d(r0 / f.outer.a, -r0 / f.outer.b).asDiagonal();
  A = A * Eigen::Rotation2Dd(-f.outer.angle_rad).toRotationMatrix();
  Rectified r;
  r.q.resize(n);
  r.radius.assign(n, -1.0);  // rectified outer radius (m), -1 if not round
  for (int j = 0; j < n; ++j) {
    r.q[j] = A * (cands[j].centre - f.centre);
    const Eigen::Matrix2d M =
        A * Eigen::Rotation2Dd(cands[j].outer.angle_rad).toRotationMatrix() *
        Eigen::Vector2d(cands[j].outer.a, cands[j].outer.b).asDiagonal();
    const Eigen::JacobiSVD<Eigen::Matrix2d> svd(M);
    const Eigen::Vector2d sv = svd.singularValues();
    if (sv(1) > 0 && sv(0) / sv(1) <= 1.0 + p.layout_size_tol) {
      r.radius[j] = std::sqrt(sv(0) * sv(1));
    }
  }
  return r;
}

// One seed of hypotheses: candidate c0 taken as set i0 (model centre m_f), the candidates
// rectified about it, and the position tolerance (m).
struct LayoutSeed {
  int c0, i0;
  Eigen::Vector2d m_f;
  const Rectified* rect;
  double tol;
};

// The sets matched to candidates under the similarity `sim` (model -> rectified, k e^{i
// theta}): greedy one-to-one matching, nearest first, the similarity refitted on the matched
// sets, and matched again.
Hypothesis match_sets(const LayoutSeed& s, Cplx sim, const TargetGeometry& target,
                      const VisionParams& p) {
  const int nr = static_cast<int>(target.rings.size());
  const int n = static_cast<int>(s.rect->q.size());
  const std::vector<Eigen::Vector2d>& q = s.rect->q;
  const std::vector<double>& radius = s.rect->radius;
  Hypothesis h;
  for (int pass = 0; pass < 2; ++pass) {
    // Greedy one-to-one matching, nearest first.
    struct Near {
      double d;
      int i, j;
    };
    std::vector<Near> near;
    const double k = std::abs(sim);
    for (int i = 0; i < nr; ++i) {
      if (i == s.i0) continue;
      const RingSet& ring = target.rings[i];
      const Cplx pred = sim * to_c(ring.centre_P_m - s.m_f);
      for (int j = 0; j < n; ++j) {
        if (j == s.c0 || radius[j] < 0) continue;
        const double rel = radius[j] / (k * ring.outer_radius_m);
        if (rel > 1.0 + p.layout_size_tol || rel < 1.0 / (1.0 + p.layout_size_tol)) {
          continue;
        }
        const double d = std::abs(to_c(q[j]) - pred);
        if (d <= s.tol * k) near.push_back({d, i, j});
      }
    }
    std::sort(near.begin(), near.end(), [](const Near& a, const Near& b) {
      return a.d < b.d || (a.d == b.d && (a.i < b.i || (a.i == b.i && a.j < b.j)));
    });
    h = Hypothesis{};
    h.cand_of_ring.assign(nr, -1);
    h.cand_of_ring[s.i0] = s.c0;
    std::vector<bool> used(n, false);
    used[s.c0] = true;
    for (const Near& e : near) {
      if (h.cand_of_ring[e.i] >= 0 || used[e.j]) continue;
      h.cand_of_ring[e.i] = e.j;
      used[e.j] = true;
    }
    // Refit the similarity on the matched sets (least squares through the frame).
    Cplx num(0, 0);
    double den = 0.0;
    for (int i = 0; i < nr; ++i) {
      const int j = h.cand_of_ring[i];
      if (i == s.i0 || j < 0) continue;
      const Cplx m = to_c(target.rings[i].centre_P_m - s.m_f);
      num += std::conj(m) * to_c(q[j]);
      den += std::norm(m);
    }
    if (den > 0) sim = num / den;
  }
  return h;
}

// Counts h's matched sets and scores their ratios against the model's (mean and largest
// error after the common bias); false when fewer than three sets are matched.
bool score_ratios(Hypothesis& h, const std::vector<LayoutCandidate>& cands,
                  const TargetGeometry& target, const VisionParams& p) {
  const int nr = static_cast<int>(target.rings.size());
  h.matched = 0;
  std::vector<double> e;  // measured - model ratio of each set with an inner circle
  bool all_photometric = true;
  for (int i = 0; i < nr; ++i) {
    const int j = h.cand_of_ring[i];
    if (j < 0) continue;
    ++h.matched;
    if (cands[j].ratio >= 0) {
      e.push_back(cands[j].ratio - target.rings[i].radius_ratio());
      all_photometric &= cands[j].photometric;
    }
  }
  if (h.matched < 3) return false;
  // Small rings read their ratios off by a common amount (blur and the threshold
  // move both edges of every thin annulus the same way: the bench's far views read
  // 0.02-0.10 low): that bias, the median difference within its bounds, is removed
  // before the ratios are compared, so that a hypothesis is not preferred for
  // absorbing it (the 180 deg turn of the hexagon maps each set onto one whose
  // ratio differs by 0.08-0.1).
  h.ratio_sets = static_cast<int>(e.size());
  if (!e.empty()) {
    std::vector<double> sorted = e;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t mid = sorted.size() / 2;
    double bias = sorted.size() % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
    // Photometric ratios carry no such bias (they model the blur): their common
    // offset stays within the model's own spread, so that the 180 deg turn, a
    // common shift of 0.08-0.1, cannot be absorbed.
    const double lo = all_photometric ? kPhotometricMaxBiasLow : p.layout_max_ratio_bias;
    const double hi =
        all_photometric ? kPhotometricMaxBiasHigh : 0.5 * p.layout_max_ratio_bias;
    bias = std::clamp(bias, -lo, hi);
    double sum = 0.0;
    for (double x : e) {
      sum += std::abs(x - bias);
      h.max_err = std::max(h.max_err, std::abs(x - bias));
    }
    h.mean_err = sum / static_cast<double>(e.size());
    h.bias = bias;
  }
  return true;
}

// The distinct hypotheses of all seeds, and how many circle guesses were tried.
struct Hypotheses {
  std::vector<Hypothesis> hyps;
  int frames_tried{0};
};

// Every candidate taken as every set's outer circle (or the central set's inner one), and
// every other (candidate, set) at about the right distance from it seeding a rotation.
Hypotheses layout_hypotheses(const std::vector<LayoutCandidate>& cands,
                             const TargetGeometry& target, int centre_ring, const VisionParams& p) {
  const int nr = static_cast<int>(target.rings.size());
  double hex_radius = 0.0;  // the farthest set from the centre (the hexagon's radius)
  for (const auto& r : target.rings) hex_radius = std::max(hex_radius, r.centre_P_m.norm());
  const int n = static_cast<int>(cands.size());
  Hypotheses out;
  std::set<std::vector<int>> seen;  // assignments already in hyps (many seeds give the same)
  for (int c0 = 0; c0 < n; ++c0) {
    const LayoutCandidate& f = cands[c0];
    if (!(f.outer.a > 0 && f.outer.b > 0)) continue;
    // The candidate taken as set i0's outer circle (a lone ellipse: also the central set's
    // inner circle, which the code pattern inside may leave as the only one found).
    for (int i0 = 0; i0 < nr; ++i0) {
      std::vector<double> radii{target.rings[i0].outer_radius_m};
      if (f.ratio < 0 && i0 == centre_ring) radii.push_back(target.rings[i0].inner_radius_m);
      const Eigen::Vector2d m_f = target.rings[i0].centre_P_m;
      for (double r0 : radii) {
        ++out.frames_tried;
        const Rectified rect = rectify_about(cands, f, r0, p);
        const LayoutSeed seed{c0, i0, m_f, &rect, p.layout_position_tol * hex_radius};
        // Each (candidate, set) at about the right distance seeds a rotation.
        for (int j0 = 0; j0 < n; ++j0) {
          if (j0 == c0 || rect.radius[j0] < 0) continue;
          for (int i1 = 0; i1 < nr; ++i1) {
            if (i1 == i0) continue;
            const Eigen::Vector2d m1 = target.rings[i1].centre_P_m - m_f;
            if (std::abs(rect.q[j0].norm() - m1.norm()) > seed.tol) continue;
            Cplx sim = to_c(rect.q[j0]) / to_c(m1);  // k e^{i theta}: model -> rectified
            Hypothesis h = match_sets(seed, sim, target, p);
            if (!score_ratios(h, cands, target, p)) continue;
            if (seen.insert(h.cand_of_ring).second) out.hyps.push_back(std::move(h));
          }
        }
      }
    }
  }
  return out;
}

// The best valid hypothesis: most sets placed, then the smallest mean ratio error (nullptr
// if none is valid); `most_matched` receives the most sets any hypothesis placed.
const Hypothesis* best_hypothesis(const std::vector<Hypothesis>& hyps, const VisionParams& p,
                                  int* most_matched) {
  auto valid = [&](const Hypothesis& h) {
    return h.matched >= p.min_rings && h.ratio_sets >= p.layout_min_ratio_sets &&
           h.mean_err <= p.layout_ratio_tol && h.max_err <= 2.0 * p.layout_ratio_tol;
  };
  const Hypothesis* best = nullptr;
  *most_matched = 0;
  for (const auto& h : hyps) {
    *most_matched = std::max(*most_matched, h.matched);
    if (!valid(h)) continue;
    if (!best || h.matched > best->matched ||
        (h.matched == best->matched && h.mean_err < best->mean_err)) {
      best = &h;
    }
  }
  return best;
}

// Whether another identity rivals `best`; `runner` receives the best conflicting mean error
// seen (-1: none) and `why` the rival when there is one.
bool ambiguous(const std::vector<LayoutCandidate>& cands, const std::vector<Hypothesis>& hyps,
               const Hypothesis& best, const VisionParams& p, double* runner, std::string& why) {
  // Any other identity placed about as widely and fitting the ratios about as well, valid or
  // not (the true identity can miss the tolerance while a wrong one meets it), makes the
  // frame ambiguous.
  *runner = -1.0;
  for (const auto& h : hyps) {
    if (&h == &best || h.ratio_sets == 0 || !conflict(cands, h, best)) continue;
    if (*runner < 0 || h.mean_err < *runner) *runner = h.mean_err;
    // The margin holds for up to kMarginReferenceSets ratios on either side; a mean over more
    // readings is less noisy, by the square root of their number.
    const double nmin = std::min(best.ratio_sets, h.ratio_sets);
    const double margin = p.layout_ratio_margin *
                          std::sqrt(kMarginReferenceSets / std::max(kMarginReferenceSets, nmin));
    if (h.matched >= best.matched - 1 && h.mean_err <= best.mean_err + margin) {
      std::ostringstream os;
      os << "ambiguous layout: " << best.matched << " sets with mean ratio error "
         << best.mean_err << " against " << h.matched << " sets with " << h.mean_err
         << " under another identity (margin " << margin << ")";
      why = os.str();
      return true;
    }
  }
  return false;
}

}  // namespace

std::optional<LayoutMatch> identify_by_layout(const std::vector<LayoutCandidate>& input,
                                              const TargetGeometry& target, const VisionParams& p,
                                              std::string& why) {
  // Each set's twins merged into one candidate.
  std::vector<int> rep;
  const std::vector<LayoutCandidate> cands = merge_twins(input, rep);
  const int nr = static_cast<int>(target.rings.size());
  int centre_ring = -1;
  for (int i = 0; i < nr; ++i) {
    if (target.rings[i].centre_P_m.norm() < 1e-9) centre_ring = i;
  }
  if (centre_ring < 0 || nr < 2) {
    why = "the target has no central ring set";
    return std::nullopt;
  }
  // Every hypothesis, the best valid one, and no rival identity close to it.
  const Hypotheses all = layout_hypotheses(cands, target, centre_ring, p);
  const std::vector<Hypothesis>& hyps = all.hyps;
  int most_matched = 0;
  const Hypothesis* best = best_hypothesis(hyps, p, &most_matched);
  if (!best) {
    std::ostringstream os;
    os << "no layout hypothesis with " << p.min_rings << " sets and " << p.layout_min_ratio_sets
       << " agreeing ratios (" << hyps.size() << " hypotheses from " << all.frames_tried
       << " circle guesses, at most " << most_matched << " sets placed)";
    why = os.str();
    return std::nullopt;
  }
  double runner = -1.0;
  if (ambiguous(cands, hyps, *best, p, &runner, why)) return std::nullopt;
  // The best hypothesis's identities, as indices into `input`.
  LayoutMatch m;
  for (int i = 0; i < nr; ++i) {
    if (best->cand_of_ring[i] < 0) continue;
    m.candidate.push_back(rep[best->cand_of_ring[i]]);
    m.ring_id.push_back(target.rings[i].id);
  }
  m.ratio_sets = best->ratio_sets;
  m.mean_ratio_err = best->mean_err;
  m.runner_up_err = runner;
  m.ratio_bias = best->bias;
  return m;
}

namespace {

// supersampling per pixel side (the model's pixel coverage)
constexpr int kSub = 4;

// The pixels a photometric ratio is fitted on: the patch's box (x0, y0, w x h) in the frame,
// each sub-sample's normalised elliptic radius q (1 on the outer circle), the fitted pixels'
// indices (y * w + x) and grey values, and the sums of those values and of their squares.
struct PhotometricPatch {
  int x0, y0, w, h;
  std::vector<float> q;
  std::vector<int> patch;
  std::vector<double> img;
  double si{0.0}, sii{0.0};
};

// The patch of ellipse `e` (raw px) in `grey`; nullopt if it leaves the frame or is too small.
std::optional<PhotometricPatch> photometric_patch(const cv::Mat& grey, const EllipseParams& e) {
  // The patch: the ellipse grown by kMarginPx (a blurred edge's spread), on a rectangle grown
  // by the blur kernel's reach so that the model's blur sees the white around it.
  constexpr double kMarginPx = 1.5;
  constexpr int kPad = 4;
  const double ai = e.a + kMarginPx, bi = e.b + kMarginPx;
  const double c = std::cos(e.angle_rad), s = std::sin(e.angle_rad);
  const double hx = std::sqrt(ai * ai * c * c + bi * bi * s * s);
  const double hy = std::sqrt(ai * ai * s * s + bi * bi * c * c);
  const int x0 = static_cast<int>(std::floor(e.centre.x() - hx)) - kPad;
  const int x1 = static_cast<int>(std::ceil(e.centre.x() + hx)) + kPad;
  const int y0 = static_cast<int>(std::floor(e.centre.y() - hy)) - kPad;
  const int y1 = static_cast<int>(std::ceil(e.centre.y() + hy)) + kPad;
  if (!(x0 >= 0 && y0 >= 0 && x1 < grey.cols && y1 < grey.rows)) return std::nullopt;
  const int w = x1 - x0 + 1, h = y1 - y0 + 1;
  PhotometricPatch pp{x0, y0, w, h, {}, {}, {}};
  // Normalised elliptic radius of every sub-sample (1 on the outer circle), and the patch.
  std::vector<float>& q = pp.q;
  q.resize(static_cast<std::size_t>(w) * h * kSub * kSub);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int sy = 0; sy < kSub; ++sy) {
        for (int sx = 0; sx < kSub; ++sx) {
          const double px = x0 + x + (sx + 0.5) / kSub - 0.5 - e.centre.x();
          const double py = y0 + y + (sy + 0.5) / kSub - 0.5 - e.centre.y();
          const double u = (c * px + s * py) / e.a, v = (-s * px + c * py) / e.b;
          q[((static_cast<std::size_t>(y) * w + x) * kSub + sy) * kSub + sx] =
              static_cast<float>(std::sqrt(u * u + v * v));
        }
      }
      const double dx = x0 + x - e.centre.x(), dy = y0 + y - e.centre.y();
      const double u = c * dx + s * dy, v = -s * dx + c * dy;
      if ((u * u) / (ai * ai) + (v * v) / (bi * bi) <= 1.0) {
        pp.patch.push_back(y * w + x);
        pp.img.push_back(grey.ptr<std::uint8_t>(y0 + y)[x0 + x]);
      }
    }
  }
  const int n = static_cast<int>(pp.patch.size());
  constexpr int kMinPatchPixels = 24;
  if (n < kMinPatchPixels) return std::nullopt;
  for (double v : pp.img) {
    pp.si += v;
    pp.sii += v * v;
  }
  return pp;
}

// The model for ratio rho_pc / 100 and outer size `scale`, blurred by each of `sigmas`,
// fitted by linear least squares; keeps the best in `best`. `cover` (h x w, CV_32F) and
// `blurred` are work images.
void fit_ratio_model(const PhotometricPatch& pp, int rho_pc, double scale,
                     std::initializer_list<double> sigmas, cv::Mat& cover, cv::Mat& blurred,
                     PhotometricRatio& best) {
  const int w = pp.w, h = pp.h, n = static_cast<int>(pp.patch.size());
  const double si = pp.si, sii = pp.sii;
  const float outer = static_cast<float>(scale);
  const float inner = static_cast<float>(0.01 * rho_pc) * outer;
  for (int y = 0; y < h; ++y) {
    float* row = cover.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const float* qq = &pp.q[(static_cast<std::size_t>(y) * w + x) * kSub * kSub];
      int dark = 0;
      for (int t = 0; t < kSub * kSub; ++t) dark += (qq[t] >= inner && qq[t] <= outer);
      row[x] = static_cast<float>(dark) / (kSub * kSub);
    }
  }
  for (double sigma : sigmas) {
    cv::GaussianBlur(cover, blurred, cv::Size(0, 0), sigma, 0, cv::BORDER_REPLICATE);
    const float* model = blurred.ptr<float>();  // continuous: allocated by the blur
    double sm = 0.0, smm = 0.0, smi = 0.0;
    for (int t = 0; t < n; ++t) {
      const double m = model[pp.patch[t]];
      sm += m;
      smm += m * m;
      smi += m * pp.img[t];
    }
    const double det = n * smm - sm * sm;
    if (!(det > 1e-9)) continue;
    const double slope = (n * smi - sm * si) / det;  // I = alpha + slope * m: -contrast
    const double alpha = (si - slope * sm) / n;
    const double sse = sii - 2 * alpha * si - 2 * slope * smi + alpha * alpha * n +
                       2 * alpha * slope * sm + slope * slope * smm;
    const double rms = std::sqrt(std::max(0.0, sse) / n);
    if (rms < best.rms) {
      best.rms = rms;
      best.ratio = 0.01 * rho_pc;
      best.contrast = -slope;
      best.white = alpha;
      best.sigma_px = sigma;
      best.scale = scale;
    }
  }
}

}  // namespace

std::optional<PhotometricRatio> photometric_ratio(const cv::Mat& grey, const EllipseParams& e) {
  // Sets at most this large are fitted (the layout asks for minor semi-axes up to 8 px, whose
  // major ones are at most 8 / min_axis_ratio); it bounds the patch's memory.
  constexpr double kMaxAxisPx = 128.0;
  if (grey.type() != CV_8UC1 || !(e.a > 0 && e.b > 0 && e.a <= kMaxAxisPx && e.b <= kMaxAxisPx) ||
      !std::isfinite(e.centre.x()) || !std::isfinite(e.centre.y()) || !std::isfinite(e.angle_rad)) {
    return std::nullopt;
  }
  const std::optional<PhotometricPatch> pp = photometric_patch(grey, e);
  if (!pp) return std::nullopt;
  cv::Mat cover(pp->h, pp->w, CV_32F), blurred;
  PhotometricRatio best;
  best.rms = std::numeric_limits<double>::infinity();
  // Coarse to fine: rho by 0.05 over [0.10, 0.80], then by 0.01 within 0.05 of the best.
  constexpr int kRhoMinPc = 10, kRhoMaxPc = 80, kCoarsePc = 5;
  for (double scale : {0.88, 0.94, 1.0, 1.06}) {
    for (int k = kRhoMinPc; k <= kRhoMaxPc; k += kCoarsePc) {
      fit_ratio_model(*pp, k, scale, {0.5, 0.8, 1.1}, cover, blurred, best);
    }
  }
  const int coarse = static_cast<int>(std::lround(best.ratio * 100));
  const double sigma_best = best.sigma_px, scale_best = best.scale;
  for (int k = std::max(kRhoMinPc, coarse - kCoarsePc + 1);
       k <= std::min(kRhoMaxPc, coarse + kCoarsePc - 1); ++k) {
    if (k != coarse) fit_ratio_model(*pp, k, scale_best, {sigma_best}, cover, blurred, best);
  }
  if (!std::isfinite(best.rms)) return std::nullopt;
  return best;
}

}  // namespace lander
