// One search region's ellipses, concentric pairs and ring identities (seed 000 section 2.2-2.3):
// the stages before the pose, each from typed input to typed output (detector_stages.h).
#include <algorithm>
#include <cmath>

#include "vision/detector_stages.h"

namespace lander::vision_internal {

bool fail(RingDetection& d, StageFailure f) {
  d.detected = false;
  d.status = f.status;
  d.reason = std::move(f.reason);
  return false;
}

RegionEllipses region_ellipses(const RegionInput& in) {
  RegionEllipses out;
  out.cands = in.platform ? refine_guesses(in.grey, in.roi, in.platform->ellipses,
                                           in.p.edge_search_px, in.cam, in.p, &out.blurred)
                          : find_ellipses(in.grey, in.roi, in.cam, in.p, &out.blurred, in.shadow);
  return out;
}

DetectedEllipse detected_ellipse(const EllipseCandidate& c) {
  DetectedEllipse e;
  e.C = c.C;
  e.image = c.image;
  e.fit_rms_px = c.fit_rms_px;
  return e;
}

// Concentric pairs (eq. 1), their centres (eq. 2-8) and radius ratios (eq. 9).
std::optional<PairCandidate> concentric_pair(const std::vector<EllipseCandidate>& cands, int i,
                                             int j, const TargetGeometry& target,
                                             const VisionParams& p) {
  const EllipseParams& O = cands[i].undist;
  const EllipseParams& I = cands[j].undist;
  if (i == j || !(I.a < O.a && I.b < O.b)) return std::nullopt;
  if ((O.centre - I.centre).norm() > p.max_centre_offset_ratio * I.b) return std::nullopt;
  if (!concentric_test(cands[i].C, cands[j].C)) return std::nullopt;  // eq. (1)
  const auto hc = harmonic_centre(cands[i].C, cands[j].C, p.harmonic_tol_px,
                                  p.harmonic_max_iter);  // eq. (2)-(8)
  if (!hc) return std::nullopt;
  // Eq. (9) along the outer ellipse's two axis directions through the centre.
  double rsum = 0.0;
  int rn = 0;
  for (double ang : {O.angle_rad, O.angle_rad + 0.5 * M_PI}) {
    const auto k = cross_ratio_through(cands[i].C, cands[j].C, hc->centre,
                                       Eigen::Vector2d(std::cos(ang), std::sin(ang)));
    if (k) {
      rsum += radius_ratio_from_cross_ratio(*k);
      ++rn;
    }
  }
  if (rn == 0) return std::nullopt;
  PairCandidate pc;
  pc.outer = i;
  pc.inner = j;
  pc.centre = hc->centre;
  pc.iterations = hc->iterations;
  pc.ratio = rsum / rn;
  for (const auto& ring : target.rings) {
    const double err = std::abs(pc.ratio - ring.radius_ratio());
    if (err < pc.err) {
      pc.err = err;
      pc.ring_id = ring.id;
    }
  }
  return pc;
}

std::vector<PairCandidate> concentric_pairs(const std::vector<EllipseCandidate>& cands,
                                            const TargetGeometry& target, const VisionParams& p) {
  std::vector<PairCandidate> pairs;
  for (int i = 0; i < static_cast<int>(cands.size()); ++i) {
    for (int j = 0; j < static_cast<int>(cands.size()); ++j) {
      if (auto pc = concentric_pair(cands, i, j, target, p)) pairs.push_back(*pc);
    }
  }
  return pairs;
}

bool Identities::id_used(int id) const {
  for (int c : chosen) {
    if (pairs[c].ring_id == id) return true;
  }
  return false;
}

void Identities::choose(int k) {
  used_ellipse[pairs[k].outer] = true;
  if (pairs[k].inner >= 0) used_ellipse[pairs[k].inner] = true;
  chosen.push_back(k);
}

void Identities::release(std::size_t c) {
  used_ellipse[pairs[chosen[c]].outer] = false;
  if (pairs[chosen[c]].inner >= 0) used_ellipse[pairs[chosen[c]].inner] = false;
  chosen.erase(chosen.begin() + static_cast<std::ptrdiff_t>(c));
}

// Greedy one-to-one assignment by identity error; curves matching no ring set are dropped.
Identities identify_by_ratio(std::vector<PairCandidate> pairs, std::size_t n_cands,
                             const VisionParams& p) {
  Identities ids;
  ids.pairs = std::move(pairs);
  ids.used_ellipse.assign(n_cands, false);
  const auto& ps = ids.pairs;
  std::vector<int> order(ps.size());
  for (std::size_t i = 0; i < ps.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return ps[a].err < ps[b].err; });
  for (int k : order) {
    const auto& pc = ps[k];
    if (pc.err > p.ratio_tol || ids.id_used(pc.ring_id) || ids.used_ellipse[pc.outer] ||
        ids.used_ellipse[pc.inner]) {
      continue;
    }
    ids.choose(k);
  }
  return ids;
}

// Guided inner search: an outer circle whose inner circle was not found as a contour (too
// small, or touching the code pattern inside the central ring) is searched for an inner
// edge at each unidentified model ratio, in a band narrower than the gap to the outer edge.
void guided_inner_search(const RegionInput& in, RegionEllipses& found, Identities& ids,
                         std::vector<DetectedEllipse>& ellipses) {
  const VisionParams& p = in.p;
  auto& cands = found.cands;
  const int n0 = static_cast<int>(cands.size());
  for (int i = 0; i < n0; ++i) {
    if (ids.used_ellipse[i]) continue;
    for (const auto& ring : in.target.rings) {
      if (ids.id_used(ring.id) || ids.used_ellipse[i]) continue;
      const double rho = ring.radius_ratio();
      EllipseParams guess = cands[i].image;
      guess.a *= rho;
      guess.b *= rho;
      if (guess.b < p.min_axis_px) continue;
      const double search = std::min(p.edge_search_px, 0.45 * (1.0 - rho) * cands[i].image.b);
      if (search < 0.5) continue;
      auto inner = refine_candidate(found.blurred, cv::Point2f(in.roi.x, in.roi.y), guess, search,
                                    in.cam, p, in.shadow);
      if (!inner) continue;
      cands.push_back(std::move(*inner));
      const int j = static_cast<int>(cands.size()) - 1;
      ids.used_ellipse.push_back(false);
      auto pc = concentric_pair(cands, i, j, in.target, p);
      if (!pc || pc->err > p.ratio_tol || ids.id_used(pc->ring_id)) {
        cands.pop_back();
        ids.used_ellipse.pop_back();
        continue;
      }
      ellipses.push_back(detected_ellipse(cands.back()));
      ids.pairs.push_back(*pc);
      ids.choose(static_cast<int>(ids.pairs.size()) - 1);
    }
  }
}

void fill_centres(const Identities& ids, const CameraModel& cam, RingDetection& d) {
  d.centres.clear();
  for (auto& e : d.ellipses) e.ring_id = -1;
  for (int k : ids.chosen) {
    const auto& pc = ids.pairs[k];
    IdentifiedCentre c;
    c.ring_id = pc.ring_id;
    c.centre_px = pc.centre;
    c.centre_image_px = cam.distort_px(pc.centre);
    c.radius_ratio = pc.ratio;
    c.outer_index = pc.outer;
    c.inner_index = pc.inner;
    c.harmonic_iterations = pc.iterations;
    d.centres.push_back(c);
    d.ellipses[pc.outer].ring_id = pc.ring_id;
    if (pc.inner >= 0) d.ellipses[pc.inner].ring_id = pc.ring_id;  // -1: outer circle alone
    d.ellipses[pc.outer].outer = true;
  }
}

// ---- identification by the layout (vision_layout.h) ----

namespace {

// A photometric ratio (photometric_ratio) is used only if its fit shows a dark set on light
// with at least this contrast (grey levels; the rendered platform gives 150-230, an inner
// circle mistaken for an outer one fits with a negative contrast) and an RMS residual below
// this fraction of it (the sets of the grazing views fit with 0.07-0.15: the renderer's
// anisotropic texture filter is not the model's Gaussian).
constexpr double kPhotoMinContrast = 40.0;
constexpr double kPhotoMaxRmsFraction = 0.25;

// Candidate i as a set for the layout: its centre and ratio from its best pair, or its
// ellipse's centre alone; a small set's ratio from its pixels when the fit is clean.
LayoutCandidate layout_candidate(const RegionInput& in, const EllipseCandidate& cand,
                                 const PairCandidate* best) {
  LayoutCandidate c;
  c.outer = cand.undist;
  if (best != nullptr) {
    c.centre = best->centre;
    c.ratio = best->ratio;
  } else {
    c.centre = cand.undist.centre;
  }
  // Small sets: the ratio from the set's model fitted to its pixels (photometric_ratio),
  // unbiased where eq. (9) on 1-3 px inner circles reads 0.05-0.3 off or has no inner
  // circle at all. A fit must show the set as dark on light with a residual well below the
  // contrast (an inner circle taken as an outer one fits as light on dark).
  if (cand.image.b <= in.p.layout_photometric_max_minor_px) {
    const auto pr = photometric_ratio(in.grey, cand.image);
    if (pr && pr->contrast >= kPhotoMinContrast && pr->rms <= kPhotoMaxRmsFraction * pr->contrast) {
      c.ratio = pr->ratio;
      c.photometric = true;
    }
  }
  return c;
}

}  // namespace

LayoutInput layout_input(const RegionInput& in, const RegionEllipses& found,
                         const Identities& ids) {
  const auto& cands = found.cands;
  const auto& pairs = ids.pairs;
  LayoutInput li;
  li.best_pair.assign(cands.size(), -1);  // per ellipse: its pair as the outer circle
  std::vector<bool> is_inner(cands.size(), false);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& pc = pairs[k];
    if (pc.inner < 0) continue;
    is_inner[pc.inner] = true;
    if (li.best_pair[pc.outer] < 0 || pc.err < pairs[li.best_pair[pc.outer]].err) {
      li.best_pair[pc.outer] = static_cast<int>(k);
    }
  }
  for (std::size_t i = 0; i < cands.size(); ++i) {
    if (li.best_pair[i] < 0 && is_inner[i]) continue;  // an inner circle, not a set of its own
    const PairCandidate* best = li.best_pair[i] >= 0 ? &pairs[li.best_pair[i]] : nullptr;
    li.sets.push_back(layout_candidate(in, cands[i], best));
    li.ellipse.push_back(static_cast<int>(i));
  }
  return li;
}

Identities identities_from_layout(const LayoutMatch& m, const LayoutInput& li,
                                  const RegionEllipses& found, Identities ids,
                                  const TargetGeometry& target) {
  ids.chosen.clear();
  std::fill(ids.used_ellipse.begin(), ids.used_ellipse.end(), false);
  auto& pairs = ids.pairs;
  for (std::size_t s = 0; s < m.candidate.size(); ++s) {
    const int e = li.ellipse[m.candidate[s]];
    const int id = m.ring_id[s];
    int k = li.best_pair[e];
    if (k < 0) {  // the outer circle alone: its ellipse centre stands for the set's centre
      PairCandidate pc;
      pc.outer = e;
      pc.centre = found.cands[e].undist.centre;
      pc.ratio = 0.0;
      pairs.push_back(pc);
      k = static_cast<int>(pairs.size()) - 1;
    }
    pairs[k].ring_id = id;
    pairs[k].err =
        pairs[k].inner >= 0 ? std::abs(pairs[k].ratio - target.ring(id).radius_ratio()) : 0.0;
    ids.choose(k);
  }
  return ids;
}

}  // namespace lander::vision_internal
