// The ring detector's internal stages (estimator/src/vision/detector_stages.h) on their own:
// the ratio identities' one-to-one assignment, the layout's identities, one region's stages
// chained by hand against run_region, and the ring-identity check on a turned pose.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "../../estimator/src/vision/detector_stages.h"
#include "estimator/support/vision_synth.h"

namespace lander {
namespace {

using vision_internal::Identities;
using vision_internal::PairCandidate;

const CameraModel kCam{};

PairCandidate pair_of(int outer, int inner, int ring_id, double err) {
  PairCandidate pc;
  pc.outer = outer;
  pc.inner = inner;
  pc.ring_id = ring_id;
  pc.err = err;
  pc.centre = Eigen::Vector2d(10.0 * outer, 10.0 * outer);
  return pc;
}

// Given pairs that compete for one identity and for one ellipse, when they are identified by
// ratio, then pairs are taken in order of error, each identity and each ellipse at most once
// (a pair whose ellipse was taken leaves its identity to the next pair), and a pair beyond
// ratio_tol is never chosen.
TEST(VisionStages, RatioIdentitiesAreOneToOneByError) {
  const VisionParams p;
  std::vector<PairCandidate> pairs{
      pair_of(0, 1, 2, 0.02),               // identity 2, its better pair having lost ellipse 2
      pair_of(2, 3, 2, 0.01),               // ellipse 2 already taken by identity 3
      pair_of(2, 4, 3, 0.005),              // identity 3
      pair_of(5, 6, 4, p.ratio_tol * 1.5),  // beyond the tolerance
      pair_of(7, 8, 5, 0.0),                // identity 5
      pair_of(9, 10, 5, 0.001)};            // identity 5 already taken
  const Identities ids = vision_internal::identify_by_ratio(pairs, 11, p);
  EXPECT_EQ(ids.chosen, (std::vector<int>{4, 2, 0}));  // in order of error
  EXPECT_TRUE(ids.id_used(2));
  EXPECT_TRUE(ids.id_used(3));
  EXPECT_TRUE(ids.id_used(5));
  EXPECT_FALSE(ids.id_used(4));
  const std::vector<bool> used{true, true, true, false, true, false,
                               false, true, true, false, false};
  EXPECT_EQ(ids.used_ellipse, used);
}

// Given identified sets, when one is released, then it leaves the chosen sets and its two
// ellipses are free for another pair; fill_centres then names only the remaining sets.
TEST(VisionStages, ReleasedSetFreesItsEllipses) {
  Identities ids = vision_internal::identify_by_ratio(
      {pair_of(0, 1, 1, 0.0), pair_of(2, 3, 2, 0.001)}, 4, VisionParams{});
  ASSERT_EQ(ids.chosen.size(), 2u);
  ids.release(0);  // identity 1's pair (the first chosen)
  EXPECT_EQ(ids.chosen, std::vector<int>{1});
  EXPECT_EQ(ids.used_ellipse, (std::vector<bool>{false, false, true, true}));
  RingDetection d;
  d.ellipses.resize(4);
  vision_internal::fill_centres(ids, kCam, d);
  ASSERT_EQ(d.centres.size(), 1u);
  EXPECT_EQ(d.centres[0].ring_id, 2);
  EXPECT_EQ(d.ellipses[0].ring_id, -1);
  EXPECT_EQ(d.ellipses[2].ring_id, 2);
  EXPECT_EQ(d.ellipses[3].ring_id, 2);
  EXPECT_TRUE(d.ellipses[2].outer);
  EXPECT_FALSE(d.ellipses[3].outer);
}

// Given a layout match that places an outer circle without an inner one, when its identities
// are made, then that set is a pair of its own (no inner circle, no ratio error) at its
// ellipse's centre, and the matched pair takes the layout's identity.
TEST(VisionStages, LayoutIdentitiesPlaceOuterCirclesAlone) {
  const TargetGeometry& g = test::default_target();
  vision_internal::RegionEllipses found;
  found.cands.resize(3);
  found.cands[2].undist.centre = Eigen::Vector2d(40.0, 50.0);
  const Identities ratio_ids = vision_internal::identify_by_ratio(
      {pair_of(0, 1, g.rings[1].id, 0.2)}, 3, VisionParams{});  // 0.2: beyond ratio_tol
  ASSERT_TRUE(ratio_ids.chosen.empty());
  vision_internal::LayoutInput li;
  li.ellipse = {0, 2};
  li.best_pair = {0, -1, -1};
  LayoutMatch m;
  m.candidate = {0, 1};
  m.ring_id = {g.rings[3].id, g.rings[4].id};
  const Identities ids = vision_internal::identities_from_layout(m, li, found, ratio_ids, g);
  ASSERT_EQ(ids.pairs.size(), 2u);
  EXPECT_EQ(ids.chosen, (std::vector<int>{0, 1}));
  EXPECT_EQ(ids.pairs[0].ring_id, g.rings[3].id);
  EXPECT_EQ(ids.pairs[1].ring_id, g.rings[4].id);
  EXPECT_EQ(ids.pairs[1].inner, -1);
  EXPECT_EQ(ids.pairs[1].err, 0.0);
  EXPECT_EQ(ids.pairs[1].centre, Eigen::Vector2d(40.0, 50.0));
  EXPECT_EQ(ids.used_ellipse, (std::vector<bool>{true, true, true}));
}

// A frame drawn at 5 m, 20 deg of tilt: every ring set in view and large.
struct DrawnView {
  Eigen::Isometry3d X_true = test::look_at_pose(5.0, 20.0, 17.0);
  cv::Mat grey;
  DrawnView() {
    test::SynthOptions opt;
    opt.bgr = false;
    grey = test::render_view(test::default_target(), kCam, X_true, opt);
  }
};

// The initial pose must be close enough for the conic refinement to converge to the right
// minimum: IPPE on centres accurate to ~0.1 px lands well within a degree and 1 % of range at
// 5 m; these bounds are ten times looser than that and still far inside the basin.
constexpr double kInitialRotTolRad = 0.05;
constexpr double kInitialPosTolFraction = 0.02;

// Given a drawn frame, when one region's stages are run by hand (ellipses, pairs, ratio
// identities, the guided inner search, initial pose, refined and gated pose), then every ring
// set is identified, the initial pose is near the truth and the refined pose and reason
// equal run_region's.
TEST(VisionStages, RegionStagesChainToRunRegion) {
  const DrawnView view;
  const TargetGeometry& g = test::default_target();
  const VisionParams p;
  const vision_internal::RegionInput in{view.grey, cv::Rect(0, 0, view.grey.cols, view.grey.rows),
                                        kCam, g, p};
  vision_internal::RegionEllipses found = vision_internal::region_ellipses(in);
  ASSERT_FALSE(found.cands.empty());
  Identities ids = vision_internal::identify_by_ratio(
      vision_internal::concentric_pairs(found.cands, g, p), found.cands.size(), p);
  EXPECT_GE(static_cast<int>(ids.chosen.size()), p.min_rings);
  RingDetection d;
  d.roi = in.roi;
  for (const auto& c : found.cands) d.ellipses.push_back(vision_internal::detected_ellipse(c));
  // The central set's inner circle touches the code pattern: the guided search finds it.
  ASSERT_TRUE(p.guided_inner_search);
  vision_internal::guided_inner_search(in, found, ids, d.ellipses);
  EXPECT_EQ(ids.chosen.size(), g.rings.size());
  vision_internal::fill_centres(ids, kCam, d);
  vision_internal::StageFailure why;
  const auto X0 = vision_internal::initial_pose(in, found, ids, why);
  ASSERT_TRUE(X0) << why.reason;
  const double range = view.X_true.translation().norm();
  EXPECT_LT(test::rotation_error_rad(*X0, view.X_true), kInitialRotTolRad);
  EXPECT_LT(test::position_error_m(*X0, view.X_true), kInitialPosTolFraction * range);
  ASSERT_TRUE(vision_internal::refine_and_gate(in, found, ids, *X0, d)) << d.reason;

  RingDetection whole;
  std::vector<vision_internal::EllipseCandidate> cands;
  ASSERT_TRUE(vision_internal::run_region(in, whole, cands));
  EXPECT_EQ(whole.reason, d.reason);
  EXPECT_TRUE(whole.X_CP.isApprox(d.X_CP, 0.0));  // the same stages: the same numbers
  EXPECT_EQ(whole.reproj_err_px, d.reproj_err_px);
  EXPECT_EQ(cands.size(), found.cands.size());
}

// Given a drawn frame, when its ring identities are checked against the true pose and
// against the pose turned by 60 deg about the platform's normal (every outer circle then lies
// where another one is), then the true pose passes and the turned one is rejected.
TEST(VisionStages, RotationCheckRejectsTurnedIdentities) {
  const DrawnView view;
  const TargetGeometry& g = test::default_target();
  const VisionParams p;
  auto grey_of = [&](const cv::Rect&) { return view.grey; };
  const auto right = vision_internal::check_set_rotation(view.grey.size(), grey_of, kCam, g,
                                                         view.X_true, p.rotation_check_margin);
  EXPECT_TRUE(right.checked) << right.verdict;
  EXPECT_TRUE(right.passed) << right.verdict;
  const Eigen::Isometry3d X_turned =
      view.X_true * Eigen::AngleAxisd(M_PI / 3.0, Eigen::Vector3d::UnitZ());
  const auto turned = vision_internal::check_set_rotation(view.grey.size(), grey_of, kCam, g,
                                                          X_turned, p.rotation_check_margin);
  EXPECT_TRUE(turned.checked) << turned.verdict;
  EXPECT_FALSE(turned.passed) << turned.verdict;
}

}  // namespace
}  // namespace lander
