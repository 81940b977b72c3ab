// One search region's poses (seed 000 section 2.4): the initial pose of the identified sets
// (IPPE with the layout check, or P3P on three sets), then the conic refinement, its gates
// and the choice between the plane's two tilts.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/calib3d.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/detector_stages.h"

namespace lander::vision_internal {
namespace {

// Three-set pose: another P3P solution whose refined conic RMS is within this factor of the
// best one's, and which is a different pose, makes the frame ambiguous (no pose reported).
// Wrong P3P branches refine to conic residuals of several px where the right one fits to a
// few tenths; 3x keeps a clear margin between them.
constexpr double kThreeSetMinResidualRatio = 3.0;

// The platform pass's choice between the plane's two tilts (see choose_tilt()): the other
// tilt must fit the conics worse by this factor and the outline's corners by this one.
// On exactly drawn and rendered views at 15-20 m (sets 3-5 px across) the right tilt's
// residual was 1.13-1.7 times lower and its corner error 1.4-2.8 times; the one wrong choice
// seen (the closed form's, 109 deg off) had the other tilt 4 % worse by the conics and 11 %
// better by the corners.
constexpr double kMirrorMinResidualRatio = 1.1;
constexpr double kMirrorMinCornerRatio = 1.3;

// What the pose stages read of a region: its inputs, its ellipses and its pairs (a set is a
// list of indices into the pairs).
struct RegionSets {
  const RegionInput& in;
  const std::vector<EllipseCandidate>& cands;
  const std::vector<PairCandidate>& pairs;
};

// The identified centres of `set`: P points and undistorted pixels.
void centre_points(const RegionSets& v, const std::vector<int>& set,
                   std::vector<cv::Point3d>& obj, std::vector<cv::Point2d>& img) {
  for (int k : set) {
    const auto& c = v.in.target.ring(v.pairs[k].ring_id).centre_P_m;
    obj.emplace_back(c.x(), c.y(), 0.0);
    img.emplace_back(v.pairs[k].centre.x(), v.pairs[k].centre.y());
  }
}

// The two circles of each set of `set` with their edge points, for the conic cost.
std::vector<ConicObservation> conic_observations(const RegionSets& v,
                                                 const std::vector<int>& set) {
  std::vector<ConicObservation> obs;
  for (int k : set) {
    const RingSet& ring = v.in.target.ring(v.pairs[k].ring_id);
    obs.push_back({ring.centre_P_m, ring.outer_radius_m, &v.cands[v.pairs[k].outer].points});
    if (v.pairs[k].inner >= 0) {
      obs.push_back({ring.centre_P_m, ring.inner_radius_m, &v.cands[v.pairs[k].inner].points});
    }
  }
  return obs;
}

// The extent of the sets `set` in the image and the gates it scales (scaled_gate).
double extent_of(const RegionSets& v, const std::vector<int>& set) {
  std::vector<SetImage> im;
  for (int k : set) {
    const auto& outer = v.cands[v.pairs[k].outer].undist;
    im.push_back({v.pairs[k].centre, outer.a, outer.b});
  }
  return ring_extent_px(im);
}
double centre_gate(const RegionSets& v, const std::vector<int>& set) {
  return scaled_gate(v.in.p.max_centre_reproj_px, v.in.p.max_centre_reproj_fraction,
                     extent_of(v, set));
}

// IPPE's two solutions (the plane's two tilts) on the centres of `set`; false if it fails.
// IPPE (Collins and Bartoli 2014) is made for planar targets, closed form, returns both
// solutions of the planar ambiguity so we can keep the consistent one, and is exact with four
// points; SQPnP is general-purpose (3D) and slower for our 4-7 points.
bool ippe_solutions(const RegionSets& v, const std::vector<int>& set,
                    std::vector<cv::Point3d>& obj, std::vector<cv::Point2d>& img,
                    std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs) {
  centre_points(v, set, obj, img);
  try {
    cv::solvePnPGeneric(obj, img, camera_matrix_cv(v.in.cam), cv::noArray(), rvecs, tvecs, false,
                        cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    return false;
  }
  return true;
}

// The largest reprojection error of the identified centres of `set` under the pose X (px).
double max_centre_err(const RegionSets& v, const std::vector<int>& set,
                      const Eigen::Isometry3d& X) {
  const Eigen::Matrix3d K = v.in.cam.K();
  double mx = 0.0;
  for (int k : set) {
    mx = std::max(
        mx, (project(K, X, v.in.target.ring(v.pairs[k].ring_id).centre_P_m) - v.pairs[k].centre)
                .norm());
  }
  return mx;
}

// An IPPE pose and its largest centre reprojection error (px).
struct Fit {
  Eigen::Isometry3d X;
  double max_err;
};
// IPPE on the identified centres `set`: the solution facing the camera (faces_camera) with
// the smallest largest centre reprojection error; none if no solution faces it.
std::optional<Fit> ippe(const RegionSets& v, const std::vector<int>& set) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  std::vector<cv::Mat> rvecs, tvecs;
  if (!ippe_solutions(v, set, obj, img, rvecs, tvecs)) return std::nullopt;
  const cv::Mat Kcv = camera_matrix_cv(v.in.cam);
  std::optional<Fit> fit;
  for (std::size_t s = 0; s < rvecs.size(); ++s) {
    // IPPE's closed form is exact for exact centres, not the least-squares pose. Refined on
    // the centres, the largest error measures the layout's consistency rather than the
    // closed form's (under a 2 % pixel aspect error 23 px at 1 m against ~5 px refined);
    // the refinement is kept only where it lowers that largest error.
    Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
    if (!faces_camera(X)) continue;
    double mx = max_centre_err(v, set, X);
    try {
      cv::Mat rv = rvecs[s].clone(), tv = tvecs[s].clone();
      cv::solvePnPRefineLM(obj, img, Kcv, cv::noArray(), rv, tv);
      const Eigen::Isometry3d Xr = pose_from_cv(rv, tv);
      const double mr =
          faces_camera(Xr) ? max_centre_err(v, set, Xr) : std::numeric_limits<double>::infinity();
      if (mr < mx) {
        X = Xr;
        mx = mr;
      }
    } catch (const cv::Exception&) {
    }
    if (mx < (fit ? fit->max_err : std::numeric_limits<double>::infinity())) fit = Fit{X, mx};
  }
  return fit;
}

// P3P's solutions on the centres of `set` in front of the camera with the target facing it,
// each refined on the six conics: (conic RMS, refined pose), best first. nullopt if P3P fails.
std::optional<std::vector<std::pair<double, Eigen::Isometry3d>>> p3p_fits(
    const RegionSets& v, const std::vector<int>& set) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  centre_points(v, set, obj, img);
  const std::vector<ConicObservation> o3 = conic_observations(v, set);
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solveP3P(obj, img, camera_matrix_cv(v.in.cam), cv::noArray(), rvecs, tvecs,
                 cv::SOLVEPNP_P3P);
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
  const Eigen::Matrix3d K = v.in.cam.K();
  std::vector<std::pair<double, Eigen::Isometry3d>> fits;  // conic RMS, refined pose
  for (std::size_t s = 0; s < rvecs.size(); ++s) {
    const Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
    if (!faces_camera(X)) continue;
    const auto r = refine_pose_conics(K, X, o3, v.in.p.refine_points_per_ellipse,
                                      v.in.p.refine_max_iter);
    if (r.ok && std::isfinite(r.rms_px) && r.X_CP.translation().z() > 0) {
      fits.emplace_back(r.rms_px, r.X_CP);
    }
  }
  std::sort(fits.begin(), fits.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  return fits;
}

// Pose from three identified sets: P3P on their centres (up to four solutions), each
// solution in front of the camera with the target facing it refined on the six conics; the
// best if it fits within the conic gate and clearly better than every different pose.
std::optional<Eigen::Isometry3d> three_set_pose(const RegionSets& v, const std::vector<int>& set,
                                                std::string& why) {
  const auto fits = p3p_fits(v, set);
  if (!fits) {
    why = "; three-set pose: P3P failed";
    return std::nullopt;
  }
  std::ostringstream os;
  if (fits->empty()) {
    why = "; three-set pose: no P3P solution in front refined";
    return std::nullopt;
  }
  const auto& f = *fits;
  const double edge_gate = ring_gates(v.in.p, extent_of(v, set)).edge_px;
  if (!(f[0].first <= edge_gate)) {
    os << "; three-set pose: conic residual " << f[0].first << " px (gate " << edge_gate
       << " px)";
    why = os.str();
    return std::nullopt;
  }
  for (std::size_t i = 1; i < f.size(); ++i) {
    if (!poses_agree(f[0].second, f[i].second, v.in.p) &&
        f[i].first < kThreeSetMinResidualRatio * f[0].first) {
      os << "; three-set pose ambiguous: conic residuals " << f[0].first << " and "
         << f[i].first << " px for two different poses";
      why = os.str();
      return std::nullopt;
    }
  }
  return f[0].second;
}

// Of the chosen sets, the one whose removal leaves the most consistent rest (IPPE's smallest
// largest error); nullopt if no rest gives a solution facing the camera.
std::optional<std::size_t> most_inconsistent_set(const RegionSets& v,
                                                 const std::vector<int>& chosen) {
  std::size_t drop = 0;
  std::optional<double> best;
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    std::vector<int> rest = chosen;
    rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
    const std::optional<Fit> f = ippe(v, rest);
    if (f && (!best || f->max_err < *best)) {
      best = f->max_err;
      drop = i;
    }
  }
  if (!best) return std::nullopt;
  return drop;
}

// IPPE on the chosen (>= min_rings) sets within the layout gate, dropping sets while more
// than min_rings remain.
std::optional<Eigen::Isometry3d> ippe_with_layout_check(const RegionSets& v, Identities& ids,
                                                        StageFailure& why) {
  const VisionParams& p = v.in.p;
  for (;;) {
    const std::optional<Fit> fit = ippe(v, ids.chosen);
    if (fit && fit->max_err <= centre_gate(v, ids.chosen)) return fit->X;
    // Hexagon layout check: drop the centre whose removal leaves the most consistent rest
    // (a misidentified centre can pull the fit so that a correct one has the largest
    // error, or put both IPPE solutions behind the camera), and retry.
    if (static_cast<int>(ids.chosen.size()) <= p.min_rings) {
      if (fit) {
        why = {VisionStatus::PoseFailed,
               "identified centres inconsistent with the ring layout (max error " +
                   std::to_string(fit->max_err) + " px, gate " +
                   std::to_string(centre_gate(v, ids.chosen)) + " px)"};
      } else {
        why = {VisionStatus::PoseFailed, "IPPE gave no solution facing the camera"};
      }
      return std::nullopt;
    }
    const std::optional<std::size_t> drop = most_inconsistent_set(v, ids.chosen);
    if (!drop) {
      why = {VisionStatus::PoseFailed, "IPPE gave no solution facing the camera"};
      return std::nullopt;
    }
    ids.release(*drop);
  }
}

}  // namespace

std::optional<Eigen::Isometry3d> initial_pose(const RegionInput& in, const RegionEllipses& found,
                                              Identities& ids, StageFailure& why) {
  const VisionParams& p = in.p;
  const RegionSets v{in, found.cands, ids.pairs};
  if (ids.chosen.empty()) {
    why = {VisionStatus::NoRingIdentified,
           std::to_string(ids.pairs.size()) + " concentric pairs, no cross-ratio (eq. 9) matched"};
    return std::nullopt;
  }
  if (static_cast<int>(ids.chosen.size()) >= p.min_rings) {
    return ippe_with_layout_check(v, ids, why);
  }
  // Three sets (grazing views, far range, the frame's edge): P3P's up to four poses, each
  // refined on the six conics; the one that fits them is kept if it fits well and clearly
  // better than the others (the conics decide P3P's ambiguity; three points alone always
  // reproject exactly).
  std::optional<Eigen::Isometry3d> X3;
  std::string why3;
  if (p.three_ring_pose && ids.chosen.size() == 3) X3 = three_set_pose(v, ids.chosen, why3);
  if (!X3) {
    why = {VisionStatus::TooFewRings, std::to_string(ids.chosen.size()) +
                                          " ring sets identified, need " +
                                          std::to_string(p.min_rings) + why3};
  }
  return X3;
}

namespace {

// Use the layout to recover pairs whose ratio was ambiguous: an unused concentric pair at
// the predicted centre of an unidentified ring set with a ratio within twice the tolerance.
void recover_sets(const RegionSets& v, const Eigen::Isometry3d& X0, Identities& ids) {
  const VisionParams& p = v.in.p;
  const Eigen::Matrix3d K = v.in.cam.K();
  auto& pairs = ids.pairs;
  const double recover_gate = centre_gate(v, ids.chosen);
  for (const auto& ring : v.in.target.rings) {
    if (ids.id_used(ring.id)) continue;
    const Eigen::Vector2d pred = project(K, X0, ring.centre_P_m);
    int best = -1;
    double best_d = recover_gate;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const auto& pc = pairs[k];
      if (pc.inner < 0 || ids.used_ellipse[pc.outer] || ids.used_ellipse[pc.inner]) continue;
      if (std::abs(pc.ratio - ring.radius_ratio()) > 2 * p.ratio_tol) continue;
      const double dist = (pc.centre - pred).norm();
      if (dist < best_d) {
        best_d = dist;
        best = static_cast<int>(k);
      }
    }
    if (best >= 0) {
      pairs[best].ring_id = ring.id;
      pairs[best].err = std::abs(pairs[best].ratio - ring.radius_ratio());
      ids.choose(best);
    }
  }
}

// The refined pose into d: pose, covariance, conic residual and iterations.
void record_pose(const RefineResult& r, RingDetection& d) {
  d.X_CP = r.X_CP;
  d.cov = r.cov;
  d.edge_rms_px = r.rms_px;
  d.refine_iterations = r.iterations;
}

// Eq. (30): sum over identified centres of |x_i - H X_i|^2, under d.X_CP, into d.
void record_reprojection(const RegionSets& v, const std::vector<int>& chosen, RingDetection& d) {
  const Eigen::Matrix3d K = v.in.cam.K();
  double sum = 0.0;
  for (int k : chosen) {
    sum += (project(K, d.X_CP, v.in.target.ring(v.pairs[k].ring_id).centre_P_m) -
            v.pairs[k].centre)
               .squaredNorm();
  }
  d.reproj_err_sum_px2 = sum;
  d.reproj_err_px = std::sqrt(sum / chosen.size());
}

// One of the plane's two tilts refined on the conics, with the top's corners' error against
// the platform pass's outline (0 outside it).
struct Tilt {
  RefineResult r;
  double corners_px;
};
// The plane's tilts that fit the conics: the refined pose `ref` first, then IPPE's other
// solution refined, if it is a different pose facing the camera (and outside the platform
// pass, its closed form passes the layout gate).
std::vector<Tilt> plane_tilts(const RegionSets& v, const std::vector<int>& chosen,
                              const std::vector<ConicObservation>& obs,
                              const RefineResult& ref) {
  const RegionInput& in = v.in;
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  std::vector<cv::Mat> rvecs, tvecs;
  if (!ippe_solutions(v, chosen, obj, img, rvecs, tvecs)) rvecs.clear();
  auto corners_px = [&](const Eigen::Isometry3d& X) {
    return in.platform != nullptr
               ? platform_corner_error_px(in.platform->quad, X, in.cam, in.target)
               : 0.0;
  };
  const double layout_gate = centre_gate(v, chosen);
  std::vector<Tilt> tilts{{ref, corners_px(ref.X_CP)}};
  for (std::size_t s = 0; s < rvecs.size(); ++s) {
    const Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
    if (!faces_camera(X) || poses_agree(X, ref.X_CP, in.p)) continue;
    if (in.platform == nullptr && !(max_centre_err(v, chosen, X) <= layout_gate)) continue;
    const auto r = refine_pose_conics(in.cam.K(), X, obs, in.p.refine_points_per_ellipse,
                                      in.p.refine_max_iter);
    if (!r.ok || !std::isfinite(r.rms_px) || !faces_camera(r.X_CP) ||
        poses_agree(r.X_CP, ref.X_CP, in.p)) {
      continue;
    }
    tilts.push_back({r, corners_px(r.X_CP)});
  }
  return tilts;
}

// The choice between the plane's two tilts: the other one (`other`) and the reason's note, or
// keep `ref`; nullopt when ambiguous (`why`).
struct TiltChoice {
  std::optional<RefineResult> other;
  std::string note;
};
// The plane's two tilts (IPPE's two solutions: the normal tilted either way about the line
// of sight) project the centres almost alike when the sets are small or far, and the
// closed form's choice by the centres is then a coin toss: seen on exactly drawn 20 m,
// 55 deg views in the platform pass (a pose 109 deg off), and on independent ray-traced
// frames at 11-14 m and 22-39 deg under an uneven light that moved the centre ring's centre
// by 1.2-1.8 px (poses 44-75 deg off, the camera's tilt direction mirrored, within the
// reprojection gate). Both tilts are refined on the conics, which carry the perspective
// the centres lose, and the one that fits them better is kept only if the other is worse
// by kMirrorMinResidualRatio (the platform pass: and the top's corners against its outline
// by kMirrorMinCornerRatio). Otherwise the frame is ambiguous. Outside the platform pass
// the other tilt is refined only when its centres pass the layout gate (its closed form
// within centre_gate): a tilt that misplaces them is no rival.
std::optional<TiltChoice> choose_tilt(const RegionSets& v, const std::vector<int>& chosen,
                                      const std::vector<ConicObservation>& obs,
                                      const RefineResult& ref, StageFailure& why) {
  const bool platform = v.in.platform != nullptr;
  const std::vector<Tilt> tilts = plane_tilts(v, chosen, obs, ref);
  if (tilts.size() <= 1) return TiltChoice{};
  const bool second = tilts[1].r.rms_px < tilts[0].r.rms_px;
  const Tilt& a = tilts[second ? 1 : 0];
  const Tilt& b = tilts[second ? 0 : 1];
  if (!(b.r.rms_px >= kMirrorMinResidualRatio * a.r.rms_px &&
        (!platform || b.corners_px >= kMirrorMinCornerRatio * a.corners_px))) {
    std::ostringstream os;
    os << "mirror pose ambiguous: conic residuals " << a.r.rms_px << " and " << b.r.rms_px
       << " px";
    if (platform) {
      os << ", the top's corners " << a.corners_px << " and " << b.corners_px
         << " px off its outline";
    }
    os << ", for the plane's two tilts";
    why = {VisionStatus::PoseFailed, os.str()};
    return std::nullopt;
  }
  if (!second) return TiltChoice{};
  std::ostringstream ot;
  ot << " (the plane's other tilt: conic residual " << a.r.rms_px << " px against "
     << b.r.rms_px << ")";
  return TiltChoice{a.r, ot.str()};
}

}  // namespace

bool refine_and_gate(const RegionInput& in, const RegionEllipses& found, Identities& ids,
                     const Eigen::Isometry3d& X0, RingDetection& d) {
  const RegionSets v{in, found.cands, ids.pairs};
  recover_sets(v, X0, ids);
  fill_centres(ids, in.cam, d);
  // Levenberg-Marquardt on the conic reprojection cost, eq. (14)-(15).
  const std::vector<ConicObservation> obs = conic_observations(v, ids.chosen);
  const auto ref = refine_pose_conics(in.cam.K(), X0, obs, in.p.refine_points_per_ellipse,
                                      in.p.refine_max_iter);
  if (!ref.ok) return fail(d, {VisionStatus::PoseFailed, "conic refinement (eq. 14-15) failed"});
  if (!faces_camera(ref.X_CP)) {
    return fail(d, {VisionStatus::PoseFailed,
                    "the refined pose puts the camera behind the target's surface"});
  }
  record_pose(ref, d);
  record_reprojection(v, ids.chosen, d);
  const RingGates gates = ring_gates(in.p, extent_of(v, ids.chosen));
  d.reproj_gate_px = gates.reproj_px;
  d.edge_gate_px = gates.edge_px;
  if (!(d.reproj_err_px <= d.reproj_gate_px) || !(d.edge_rms_px <= d.edge_gate_px)) {
    std::ostringstream os;
    os << "reprojection error " << d.reproj_err_px << " px (gate " << d.reproj_gate_px
       << "), conic residual " << d.edge_rms_px << " px (gate " << d.edge_gate_px << ")";
    return fail(d, {VisionStatus::ReprojectionTooLarge, os.str()});
  }
  StageFailure why;
  const std::optional<TiltChoice> tilt = choose_tilt(v, ids.chosen, obs, ref, why);
  if (!tilt) return fail(d, why);
  if (tilt->other) {
    record_pose(*tilt->other, d);
    record_reprojection(v, ids.chosen, d);
    if (!(d.reproj_err_px <= d.reproj_gate_px)) {
      std::ostringstream os;
      os << "the better of the plane's two tilts reprojects the centres " << d.reproj_err_px
         << " px (gate " << d.reproj_gate_px << ")";
      return fail(d, {VisionStatus::ReprojectionTooLarge, os.str()});
    }
  }
  d.detected = true;
  d.status = VisionStatus::Detected;
  d.source = PoseSource::Rings;
  std::ostringstream os;
  os << ids.chosen.size() << " ring sets identified" << tilt->note;
  d.reason = os.str();
  return true;
}

}  // namespace lander::vision_internal
