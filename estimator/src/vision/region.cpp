// One search region from contours to the refined pose (seed 000 section 2.2-2.4): the stages
// of region_identities.cpp and region_pose.cpp in order, with the layout's identification
// (vision_layout.h) as the fallback when the ratios give no pose.
#include <sstream>

#include "vision/detector_stages.h"

namespace lander::vision_internal {
namespace {

// The initial pose of the chosen sets, then its refinement and gates; d filled either way.
bool pose_from_identities(const RegionInput& in, const RegionEllipses& found, Identities& ids,
                          RingDetection& d) {
  StageFailure why;
  const std::optional<Eigen::Isometry3d> X0 = initial_pose(in, found, ids, why);
  if (!X0) {
    fill_centres(ids, in.cam, d);  // the sets the layout check left
    return fail(d, why);
  }
  return refine_and_gate(in, found, ids, *X0, d);
}

// Identification by the layout (vision_layout.h): the ratio path gave no pose (`d`, with the
// ratio path's identities `ids`). Its result stands unless the layout's assignment gives a
// pose through the same gates, so the frames the ratio path detects are untouched.
// `no_pairs`: the reason when the region had no concentric pair (empty otherwise).
bool try_layout(const RegionInput& in, const RegionEllipses& found, const Identities& ids,
                const std::string& no_pairs, RingDetection& d) {
  const LayoutInput li = layout_input(in, found, ids);
  std::string lwhy;
  const std::optional<LayoutMatch> m = identify_by_layout(li.sets, in.target, in.p, lwhy);
  if (m) {
    Identities lids = identities_from_layout(*m, li, found, ids, in.target);
    RingDetection dl = d;
    fill_centres(lids, in.cam, dl);
    if (pose_from_identities(in, found, lids, dl)) {
      std::ostringstream os;
      os << "layout: " << dl.reason << " (" << m->candidate.size() << " placed, "
         << m->ratio_sets << " ratios, mean error " << m->mean_ratio_err
         << " after a common bias of " << m->ratio_bias << ", best other identity "
         << m->runner_up_err << "; ratio path: " << d.reason << ")";
      dl.reason = os.str();
      dl.by_layout = true;
      d = std::move(dl);
      return true;
    }
    lwhy = m->candidate.size() > 0
               ? "placed " + std::to_string(m->candidate.size()) + " sets, no pose: " + dl.reason
               : dl.reason;
  }
  if (!no_pairs.empty() && ids.chosen.empty()) {
    return fail(d, {VisionStatus::NoConcentricPairs, no_pairs + "; layout: " + lwhy});
  }
  d.reason += "; layout: " + lwhy;
  return false;
}

// The stages after the ellipses: pairs, identities by ratio, the pose, else the layout.
bool identify_and_pose(const RegionInput& in, RegionEllipses& found, RingDetection& d) {
  const auto& cands = found.cands;
  for (const auto& c : cands) d.ellipses.push_back(detected_ellipse(c));
  if (cands.empty()) {
    return fail(d, {VisionStatus::NoEllipses, "no contour passed the ellipse tests"});
  }
  std::vector<PairCandidate> pairs = concentric_pairs(cands, in.target, in.p);
  // No concentric pair: the frame ends here unless the layout can name outer circles alone
  // by their photometric ratios (grazing views, whose inner circles are 1-3 px across).
  const std::string no_pairs =
      pairs.empty() ? std::to_string(cands.size()) + " ellipses, no concentric pair (eq. 1)" : "";
  if (pairs.empty() &&
      !(in.p.layout_identification && static_cast<int>(cands.size()) >= in.p.min_rings)) {
    return fail(d, {VisionStatus::NoConcentricPairs, no_pairs});
  }
  Identities ids = identify_by_ratio(std::move(pairs), cands.size(), in.p);
  if (in.p.guided_inner_search) guided_inner_search(in, found, ids, d.ellipses);
  fill_centres(ids, in.cam, d);
  if (pose_from_identities(in, found, ids, d)) return true;
  if (!in.p.layout_identification) return false;
  return try_layout(in, found, ids, no_pairs, d);
}

}  // namespace

bool run_region(const RegionInput& in, RingDetection& d, std::vector<EllipseCandidate>& cands) {
  d = RingDetection{};
  d.roi = in.roi;
  RegionEllipses found = region_ellipses(in);
  const bool ok = identify_and_pose(in, found, d);
  cands = std::move(found.cands);
  return ok;
}

}  // namespace lander::vision_internal
