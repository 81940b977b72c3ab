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
// turn maps each set onto one whose ratio differs by only 0.08-0.1 (a set found twice, as
// ellipses at the same place and of about the same size, is one candidate with their mean
// ratio: it neither rivals itself nor lets an identity pick its reading). The pose from the
// assignment then passes every gate of the ratio path (layout check of the centres, conic
// residual, eq. 30 reprojection).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

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
  bool photometric{false};  ///< `ratio` is photometric_ratio's (unbiased), not eq. (9)'s
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

// Photometric radius ratio of a ring set seen as its outer circle `e` (raw image px) in the
// 8-bit grey frame `grey` (issue 12: grazing views, where the inner circle is too thin across
// the minor axis to be found as a contour, or is found with its shape and eq. (9)'s ratio
// 0.05-0.3 off, but still lightens the annulus). The model of the set, a dark annulus whose
// circles are `e` scaled by s and by rho * s about its centre (concentric circles under weak
// perspective; s absorbs an outer fit inflated by blur), is drawn with each pixel's coverage
// (4 x 4 samples), blurred by a Gaussian and fitted to the pixels within `e` grown by 1.5 px
// as I = white - contrast * model (linear least squares); the best fit over rho in
// [0.10, 0.80] (by 0.05, then by 0.01 around the best), sigma 0.5, 0.8, 1.1 px and s 0.88-1.06.
// A blur spreads darkness but keeps its sum, so the ratio is read without the low bias of
// eq. (9) on small rings. nullopt if the patch leaves the frame or is under 24 px.
struct PhotometricRatio {
  double ratio{0.0};
  double rms{0.0};       ///< the fit's RMS residual (grey levels)
  double contrast{0.0};  ///< white - black of the fit (grey levels)
  double white{0.0};
  double sigma_px{0.0};
  double scale{1.0};  ///< the fitted outer circle's size against `e`'s
};
std::optional<PhotometricRatio> photometric_ratio(const cv::Mat& grey, const EllipseParams& e);

}  // namespace lander
