// The ring identities checked on the sets' radial profiles (issue 12: never a wrong pose).
//
// The six outer sets sit on a regular hexagon and share one outer radius: a pose turned by a
// multiple of 60 deg about the platform's normal puts every outer circle where another one
// is, so neither the centres' reprojection nor the conic fit can tell it from the right one.
// Only the inner circles tell the sets apart (eq. 9's ratios), and a frame smeared by the
// camera's yaw during the exposure reads them wrongly: set 4's 0.30 as 0.185 (set 1's) at
// 4 m with 16 deg of yaw, and the pose came out 60, 120 or 180 deg off with every other gate
// passed (16 of 69 poses on exactly drawn frames at 3-7 m with 12-24 deg of yaw).
//
// So, for every pose not following a checked track: each outer set's disc is sampled in the
// frame along rays from its predicted centre, each ray divided by its mean (a shadow's light
// cancels) and the rays averaged (a radial profile, which a smear in any direction leaves
// centred); the profiles are compared (normalised cross-correlation, weighted by radius, i.e.
// by area) with the sets' printed profiles (white inside the inner circle, dark out to the
// outer one) under every rotation that maps the layout onto itself. The pose's own identities
// must fit best, by at least the margin (VisionParams::rotation_check_margin). Measured on
// exactly drawn frames: the right identities lead the next turn (always the 180 deg one,
// whose sets' ratios are the nearest: 0.20/0.30, 0.40/0.50, 0.58/0.66) by 0.07-0.11, the
// turned ones trail by 0.08 or more.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <utility>

#include "vision/internal.h"

namespace lander::vision_internal {
namespace {

// Radial samples per disc, out to kDiscFraction of the outer radius (the outer edge itself
// is the same for every identity, and its blur would only add the same to all of them), and
// angles averaged at each radius.
constexpr int kRadii = 34;
constexpr int kAngles = 32;
constexpr double kDiscFraction = 0.85;
// Two sets at least: one set's profile alone still decides, but a pose whose other sets are
// all out of view has its yaw from the code or the track, which the check cannot add to.
constexpr int kMinDiscs = 2;
// A ray darker than this on average (grey levels) has no light to compare.
constexpr double kMinRayMeanGrey = 2.0;

struct Symmetry {
  double angle_rad;
  std::vector<int> from;  // from[v]: the set (index in g.rings) X's set v is under this turn
};

// Rotations about P's origin that map every outer set onto an outer set of the same outer
// radius (the hexagon's six), with the identity first.
std::vector<Symmetry> layout_symmetries(const TargetGeometry& g, const std::vector<int>& outer) {
  std::vector<Symmetry> out;
  if (outer.empty()) return out;
  const RingSet& s0 = g.rings[outer[0]];
  for (int w : outer) {
    const RingSet& sw = g.rings[w];
    const double th = std::atan2(s0.centre_P_m.y(), s0.centre_P_m.x()) -
                      std::atan2(sw.centre_P_m.y(), sw.centre_P_m.x());
    const Eigen::Rotation2Dd R(-th);  // X's set v shows the set at R(-th) c_v
    Symmetry s{th, std::vector<int>(g.rings.size(), -1)};
    bool ok = true;
    for (int v : outer) {
      const Eigen::Vector2d q = R * g.rings[v].centre_P_m;
      int match = -1;
      for (int u : outer) {
        if ((g.rings[u].centre_P_m - q).norm() < 1e-6 &&
            std::abs(g.rings[u].outer_radius_m - g.rings[v].outer_radius_m) < 1e-9) {
          match = u;
        }
      }
      if (match < 0) {
        ok = false;
        break;
      }
      s.from[v] = match;
    }
    if (ok) out.push_back(std::move(s));
  }
  std::sort(out.begin(), out.end(), [](const Symmetry& a, const Symmetry& b) {
    return std::abs(std::remainder(a.angle_rad, 2 * M_PI)) <
           std::abs(std::remainder(b.angle_rad, 2 * M_PI));
  });
  return out;
}

// The outer sets (indices in g.rings) and the radius their discs are sampled to (m): the
// smallest outer radius's kDiscFraction.
struct OuterSets {
  std::vector<int> sets;
  double r_max{std::numeric_limits<double>::infinity()};
};
OuterSets outer_sets(const TargetGeometry& g) {
  OuterSets o;
  for (std::size_t i = 0; i < g.rings.size(); ++i) {
    if (g.rings[i].centre_P_m.norm() > 1e-9) {
      o.sets.push_back(static_cast<int>(i));
      o.r_max = std::min(o.r_max, kDiscFraction * g.rings[i].outer_radius_m);
    }
  }
  return o;
}

// The sample points of every disc wholly in the frame (raw px; radius-major, kAngles per
// radius; empty for a disc not wholly in view), how many discs, and their bounding box.
struct DiscSamples {
  std::vector<std::vector<Eigen::Vector2f>> pts;  ///< per set of g.rings
  int discs{0};
  double x0{1e18}, y0{1e18}, x1{-1e18}, y1{-1e18};
};
// Disc v's sample points under X_CP; empty if one is behind the camera or off the frame.
std::vector<Eigen::Vector2f> disc_points(const cv::Size& frame, const CameraModel& cam,
                                         const Eigen::Matrix3d& K, const RingSet& set,
                                         const Eigen::Isometry3d& X_CP, double r_max) {
  std::vector<Eigen::Vector2f> pv;
  pv.reserve(kRadii * kAngles);
  for (int i = 0; i < kRadii; ++i) {
    const double rho = (i + 0.5) * r_max / kRadii;
    for (int a = 0; a < kAngles; ++a) {
      const double th = 2 * M_PI * a / kAngles;
      const Eigen::Vector3d c =
          X_CP * Eigen::Vector3d(set.centre_P_m.x() + rho * std::cos(th),
                                 set.centre_P_m.y() + rho * std::sin(th), 0.0);
      if (!(c.z() > 0)) return {};
      const Eigen::Vector2d u = cam.distort_px((K * c).hnormalized());
      if (!(u.x() >= 0 && u.y() >= 0 && u.x() < frame.width - 1 && u.y() < frame.height - 1)) {
        return {};
      }
      pv.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()));
    }
  }
  return pv;
}
DiscSamples disc_samples(const cv::Size& frame, const CameraModel& cam, const TargetGeometry& g,
                         const Eigen::Isometry3d& X_CP, const OuterSets& outer) {
  const Eigen::Matrix3d K = cam.K();
  DiscSamples s;
  s.pts.resize(g.rings.size());
  for (int v : outer.sets) {
    std::vector<Eigen::Vector2f> pv = disc_points(frame, cam, K, g.rings[v], X_CP, outer.r_max);
    if (pv.empty()) continue;
    for (const auto& u : pv) {
      s.x0 = std::min<double>(s.x0, u.x()), s.y0 = std::min<double>(s.y0, u.y());
      s.x1 = std::max<double>(s.x1, u.x()), s.y1 = std::max<double>(s.y1, u.y());
    }
    s.pts[v] = std::move(pv);
    ++s.discs;
  }
  return s;
}

// Each ray (one angle, every radius) divided by its own mean before the rays are averaged:
// a shadow's light multiplies the grey along the rays it covers, so a band across a disc
// leaves the profile's shape (exactly drawn views under 1 m bands at 20 % light: the right
// identities' lead over the next turn 0.01 with plain averages, 0.10 with this; on the
// yaw-smeared views it stays 0.07, the wrong identities' deficit 0.08). A disc whose rays
// are nearly all black (no light to compare) is left out (empty, and `discs` one less).
std::vector<double> radial_profile(const cv::Mat& grey, const std::vector<Eigen::Vector2f>& pts) {
  std::vector<double> ray(kRadii);
  std::vector<double> sum(kRadii, 0.0);
  int rays = 0;
  for (int a = 0; a < kAngles; ++a) {
    double mean = 0.0;
    for (int i = 0; i < kRadii; ++i) {
      ray[i] = bilinear(grey, pts[i * kAngles + a].x(), pts[i * kAngles + a].y());
      mean += ray[i] / kRadii;
    }
    if (!(mean >= kMinRayMeanGrey)) continue;
    for (int i = 0; i < kRadii; ++i) sum[i] += ray[i] / mean;
    ++rays;
  }
  if (rays < kAngles / 2) return {};
  std::vector<double> prof(kRadii);
  for (int i = 0; i < kRadii; ++i) prof[i] = sum[i] / rays;
  return prof;
}
std::vector<std::vector<double>> radial_profiles(const cv::Mat& grey, const DiscSamples& s,
                                                 const OuterSets& outer, int& discs) {
  std::vector<std::vector<double>> prof(s.pts.size());
  for (int v : outer.sets) {
    if (s.pts[v].empty()) continue;
    prof[v] = radial_profile(grey, s.pts[v]);
    if (prof[v].empty()) --discs;
  }
  return prof;
}

// Weighted normalised cross-correlation of the profiles with each turn's printed ones
// (angle, score), the pose's own first.
std::vector<std::pair<double, double>> turn_scores(const std::vector<Symmetry>& syms,
                                                   const std::vector<std::vector<double>>& prof,
                                                   const OuterSets& outer,
                                                   const TargetGeometry& g) {
  std::vector<std::pair<double, double>> scores;
  for (const auto& sym : syms) {
    double sw = 0, so = 0, sm = 0, soo = 0, smm = 0, som = 0;
    for (int v : outer.sets) {
      if (prof[v].empty()) continue;
      const double rin = g.rings[sym.from[v]].inner_radius_m;
      for (int i = 0; i < kRadii; ++i) {
        const double rho = (i + 0.5) * outer.r_max / kRadii;
        const double m = rho < rin ? 1.0 : 0.0, o = prof[v][i];
        sw += rho, so += rho * o, sm += rho * m, soo += rho * o * o, smm += rho * m * m,
            som += rho * o * m;
      }
    }
    const double mo = so / sw, mm = sm / sw;
    const double var_o = soo / sw - mo * mo, var_m = smm / sw - mm * mm;
    const double ncc =
        var_o > 1e-9 && var_m > 1e-12 ? (som / sw - mo * mm) / std::sqrt(var_o * var_m) : 0.0;
    scores.emplace_back(sym.angle_rad, ncc);
  }
  return scores;
}

// The verdict on the scores: the pose's own identities (first) against the best turn.
void judge(const std::vector<std::pair<double, double>>& scores, double margin,
           RotationCheck& r) {
  r.checked = true;
  std::size_t best = 1;
  for (std::size_t k = 2; k < scores.size(); ++k) {
    if (scores[k].second > scores[best].second) best = k;
  }
  const double own = scores[0].second;
  r.passed = own - scores[best].second >= margin;
  std::ostringstream os;
  os.precision(3);
  os << "ring identities checked on " << r.discs << " sets' radial profiles: " << own << " against "
     << scores[best].second << " for the layout turned by "
     << std::lround(std::remainder(scores[best].first, 2 * M_PI) * 180.0 / M_PI) << " deg";
  r.verdict = os.str();
}

}  // namespace

RotationCheck check_set_rotation(const cv::Size& frame,
                                 const std::function<cv::Mat(const cv::Rect&)>& grey_of,
                                 const CameraModel& cam, const TargetGeometry& g,
                                 const Eigen::Isometry3d& X_CP, double margin) {
  RotationCheck r;
  const OuterSets outer = outer_sets(g);
  const auto syms = layout_symmetries(g, outer.sets);
  if (syms.size() < 2) {
    r.verdict = "no turn of the layout maps it onto itself";
    return r;
  }
  // The sample points of every disc wholly in the frame (raw px), and their bounding box.
  const DiscSamples s = disc_samples(frame, cam, g, X_CP, outer);
  r.discs = s.discs;
  if (r.discs < kMinDiscs) {
    r.verdict = std::to_string(r.discs) + " outer set(s) wholly in view, not checked";
    return r;
  }
  // The frame's grey values, converted at least in the discs' bounding box.
  const cv::Rect box(static_cast<int>(std::floor(s.x0)), static_cast<int>(std::floor(s.y0)),
                     static_cast<int>(std::floor(s.x1)) - static_cast<int>(std::floor(s.x0)) + 2,
                     static_cast<int>(std::floor(s.y1)) - static_cast<int>(std::floor(s.y0)) + 2);
  const cv::Mat grey = grey_of(box & cv::Rect(0, 0, frame.width, frame.height));
  const std::vector<std::vector<double>> prof = radial_profiles(grey, s, outer, r.discs);
  if (r.discs < kMinDiscs) {
    r.verdict = std::to_string(r.discs) + " outer set(s) lit in view, not checked";
    return r;
  }
  judge(turn_scores(syms, prof, outer, g), margin, r);
  return r;
}

}  // namespace lander::vision_internal
