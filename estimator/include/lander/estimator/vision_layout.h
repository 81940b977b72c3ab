// Identification of ring sets by the target's layout (issue 12: far and grazing views).
//
// At 10-15 m and 45-70 deg from the platform normal the ring sets are 5-8 px across: their
// concentric pairs are still found, but the radius ratio measured through eq. (9) on such
// small, blurred ellipses is often off by 0.05-0.1, more than the 0.08 between the closest
// model ratios, so ratio-by-ratio identification names them wrongly (and the layout check
// then rejects the frame) or not at all. The layout is still plain to see: the central set,
// the largest circle, with the six others around it on a hexagon.
//
// One found circle of known radius fixes an affine rectification of the platform plane up to
// a rotation (weak perspective: at these ranges the target's depth varies by 1-7 %). Each
// candidate ellipse is tried as the outer circle of each set (and, alone, as the central
// set's inner circle: the central set's thin outer ring is often the one lost at grazing
// views); the others are mapped into the plane and matched to the model's ring centres
// (position and circle size) for each rotation that puts one of them on a model centre, in
// the mirror sense of a plane seen from its front. The hexagon's symmetry leaves the
// identities to the measured ratios, judged together after removing their common bias
// (small rings read their ratios low): a hypothesis is kept only if they agree with the
// model (mean within `layout_ratio_tol`, none beyond twice that), and no other identity of
// about as many sets, valid or not, comes within `layout_ratio_margin` of it: the 180 deg
// turn maps each set onto one whose ratio differs by only 0.08-0.1. The pose from the
// assignment then passes every gate of the ratio path (layout check of the centres, conic
// residual, eq. 30 reprojection).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "lander/estimator/target.h"
#include "lander/estimator/vision_conic.h"
#include "lander/estimator/vision_params.h"

namespace lander {

// One ring-set candidate: an ellipse (undistorted px) taken as a set's outer circle, with the
// projected centre (the harmonic centre of its concentric pair, else the ellipse's centre)
// and the inner/outer radius ratio from eq. (9) if it has an inner circle (< 0: none).
struct LayoutCandidate {
  EllipseParams outer;
  Eigen::Vector2d centre{Eigen::Vector2d::Zero()};
  double ratio{-1.0};
};

struct LayoutMatch {
  std::vector<int> candidate;  ///< index into the candidates, one per identified set
  std::vector<int> ring_id;    ///< its identity, index-aligned with `candidate`
  int ratio_sets{0};           ///< sets whose measured ratio entered the decision
  double mean_ratio_err{0.0};  ///< their mean |ratio - model ratio|
  double runner_up_err{-1.0};  ///< the best other identity's mean error (-1: none)
  double ratio_bias{0.0};      ///< the common offset of the measured ratios, removed
};

// The assignment described above, or nullopt with `why` saying what was missing or
// ambiguous. Needs `min_rings` sets placed and `layout_min_ratio_sets` measured ratios among
// them.
std::optional<LayoutMatch> identify_by_layout(const std::vector<LayoutCandidate>& cands,
                                              const TargetGeometry& target, const VisionParams& p,
                                              std::string& why);

}  // namespace lander
