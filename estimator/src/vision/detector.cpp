// Stages 3-6 of the ring detector (seed 000 section 2.2-2.4), tracking and output.
#include "lander/estimator/vision_detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "lander/estimator/vision_layout.h"
#include "vision/internal.h"

namespace lander {

using vision_internal::EllipseCandidate;

const char* to_string(VisionStatus s) {
  switch (s) {
    case VisionStatus::Detected: return "detected";
    case VisionStatus::EmptyImage: return "empty_image";
    case VisionStatus::UnsupportedImage: return "unsupported_image";
    case VisionStatus::ImageSizeMismatch: return "image_size_mismatch";
    case VisionStatus::NoEllipses: return "no_ellipses";
    case VisionStatus::NoConcentricPairs: return "no_concentric_pairs";
    case VisionStatus::NoRingIdentified: return "no_ring_identified";
    case VisionStatus::TooFewRings: return "too_few_rings";
    case VisionStatus::PoseFailed: return "pose_failed";
    case VisionStatus::ReprojectionTooLarge: return "reprojection_too_large";
  }
  return "unknown";
}

const char* to_string(PoseSource s) {
  switch (s) {
    case PoseSource::None: return "none";
    case PoseSource::Rings: return "rings";
    case PoseSource::CentreRing: return "centre_ring";
    case PoseSource::Code: return "code";
    case PoseSource::Combined: return "combined";
  }
  return "unknown";
}

const char* to_string(KeyframeStatus s) {
  switch (s) {
    case KeyframeStatus::NotDetected: return "not_detected";
    case KeyframeStatus::First: return "first";
    case KeyframeStatus::Accepted: return "accepted";
    case KeyframeStatus::Rejected: return "rejected";
    case KeyframeStatus::Restarted: return "restarted";
  }
  return "unknown";
}

// Eq. (17)-(18): unit pose vectors I = P / |P| with P = [alpha, beta, gamma, dx, dy, dz],
// the rotation vector (Rodrigues) and the translation; rho = 1 - |I_old . I_new|.
double keyframe_rho(const Eigen::Isometry3d& X_old, const Eigen::Isometry3d& X_new) {
  auto unit = [](const Eigen::Isometry3d& X) {
    const Eigen::AngleAxisd aa(X.linear());
    Eigen::Matrix<double, 6, 1> P;
    P << aa.angle() * aa.axis(), X.translation();
    const double n = P.norm();
    return n > 0 ? Eigen::Matrix<double, 6, 1>(P / n) : P;
  };
  return 1.0 - std::abs(unit(X_old).dot(unit(X_new)));
}

namespace {

struct PairCandidate {
  int outer{-1}, inner{-1};
  Eigen::Vector2d centre;
  double ratio{0.0};
  int iterations{0};
  int ring_id{-1};
  double err{1e9};
};

bool supported_image(const cv::Mat& img) {
  const int ch = img.channels();
  return (ch == 1 || ch == 3 || ch == 4) && (img.depth() == CV_8U || img.depth() == CV_16U);
}

// Three-set pose: another P3P solution whose refined conic RMS is within this factor of the
// best one's, and which is a different pose, makes the frame ambiguous (no pose reported).
// Wrong P3P branches refine to conic residuals of several px where the right one fits to a
// few tenths; 3x keeps a clear margin between them.
constexpr double kThreeSetMinResidualRatio = 3.0;

// The platform pass's choice between the plane's two tilts (see finish() in run_region): the
// other tilt must fit the conics worse by this factor and the outline's corners by this one.
// On exactly drawn and rendered views at 15-20 m (sets 3-5 px across) the right tilt's
// residual was 1.13-1.7 times lower and its corner error 1.4-2.8 times; the one wrong choice
// seen (the closed form's, 109 deg off) had the other tilt 4 % worse by the conics and 11 %
// better by the corners.
constexpr double kMirrorMinResidualRatio = 1.1;
constexpr double kMirrorMinCornerRatio = 1.3;
// A photometric ratio (photometric_ratio) is used only if its fit shows a dark set on light
// with at least this contrast (grey levels; the rendered platform gives 150-230, an inner
// circle mistaken for an outer one fits with a negative contrast) and an RMS residual below
// this fraction of it (the sets of the grazing views fit with 0.07-0.15: the renderer's
// anisotropic texture filter is not the model's Gaussian).
constexpr double kPhotoMinContrast = 40.0;
constexpr double kPhotoMaxRmsFraction = 0.25;

bool poses_agree(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const VisionParams& p);

// The target's marked side faces the camera: the camera is in front of the platform's top
// (P's z axis, out of the top, points towards it). A pose with the camera behind the top
// cannot show the pattern, yet a planar fit admits one: two ring sets that swap identities
// mirror the layout, and the mirrored layout seen from behind fits it exactly (an independent
// ray-traced frame at 14.8 m with 11 grey levels of noise: sets 3 and 5 read as each other,
// the pose 180 deg off with 0.05 px of reprojection error).
bool faces_camera(const Eigen::Isometry3d& X_CP) {
  return X_CP.translation().z() > 0 && X_CP.linear().col(2).dot(X_CP.translation()) < 0;
}

// 8-bit grey frame in which at least `region` is converted: 8-bit grey input is used as is;
// otherwise only `region` of a per-thread full-size buffer is converted (tracking then pays
// for the ROI only).
void grey_region(const cv::Mat& img, const cv::Rect& region, cv::Mat& grey) {
  if (img.channels() == 1 && img.depth() == CV_8U) {
    grey = img;
    return;
  }
  thread_local cv::Mat buf;
  if (buf.size() != img.size()) buf.create(img.size(), CV_8UC1);
  const cv::Mat src = img(region);
  cv::Mat dst = buf(region);  // a view: the conversions below write into the buffer
  const int code = img.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY;
  if (img.depth() == CV_8U) {
    cv::cvtColor(src, dst, code);
  } else if (img.channels() == 1) {
    src.convertTo(dst, CV_8U, 1.0 / 256.0);
  } else {
    cv::Mat g16;
    cv::cvtColor(src, g16, code);
    g16.convertTo(dst, CV_8U, 1.0 / 256.0);
  }
  grey = buf;
}

Eigen::Vector2d project(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP,
                        const Eigen::Vector2d& c_P) {
  const Eigen::Vector3d p = K * (X_CP * Eigen::Vector3d(c_P.x(), c_P.y(), 0.0));
  return p.head<2>() / p.z();
}

// Everything from contours to the refined pose on one search region. Fills `d` except the
// keyframe fields and the timing; returns d.detected.
// `cands_out` receives the ellipse candidates (index-aligned with d.ellipses) for the
// fewer-ring and combined poses.
// `shadow` selects the shadow-tolerant segmentation (find_ellipses).
// `guesses`, if given, replaces the contours: the ellipses are these guesses refined (the
// platform pass).
bool run_region(const cv::Mat& grey, const cv::Rect& roi, const CameraModel& cam,
                const TargetGeometry& target, const VisionParams& p, RingDetection& d,
                std::vector<EllipseCandidate>& cands, bool shadow = false,
                const vision_internal::PlatformGuesses* platform = nullptr) {
  d = RingDetection{};
  d.roi = roi;
  auto fail = [&](VisionStatus s, std::string why) {
    d.detected = false;
    d.status = s;
    d.reason = std::move(why);
    return false;
  };
  cv::Mat blurred;
  cands = platform ? vision_internal::refine_guesses(grey, roi, platform->ellipses,
                                                     p.edge_search_px, cam, p, &blurred)
                   : vision_internal::find_ellipses(grey, roi, cam, p, &blurred, shadow);
  auto add_ellipse = [&](const EllipseCandidate& c) {
    DetectedEllipse e;
    e.C = c.C;
    e.image = c.image;
    e.fit_rms_px = c.fit_rms_px;
    d.ellipses.push_back(e);
  };
  for (const auto& c : cands) add_ellipse(c);
  if (cands.empty()) return fail(VisionStatus::NoEllipses, "no contour passed the ellipse tests");

  // Concentric pairs (eq. 1), their centres (eq. 2-8) and radius ratios (eq. 9).
  auto make_pair = [&](int i, int j) -> std::optional<PairCandidate> {
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
  };
  std::vector<PairCandidate> pairs;
  for (int i = 0; i < static_cast<int>(cands.size()); ++i) {
    for (int j = 0; j < static_cast<int>(cands.size()); ++j) {
      if (auto pc = make_pair(i, j)) pairs.push_back(*pc);
    }
  }
  // No concentric pair: the frame ends here unless the layout can name outer circles alone
  // by their photometric ratios (grazing views, whose inner circles are 1-3 px across).
  const std::string no_pairs =
      pairs.empty() ? std::to_string(cands.size()) + " ellipses, no concentric pair (eq. 1)" : "";
  if (pairs.empty() &&
      !(p.layout_identification && static_cast<int>(cands.size()) >= p.min_rings)) {
    return fail(VisionStatus::NoConcentricPairs, no_pairs);
  }
  // Greedy one-to-one assignment by identity error; curves matching no ring set are dropped.
  std::vector<int> order(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return pairs[a].err < pairs[b].err; });
  std::vector<bool> used_ellipse(cands.size(), false);
  std::vector<int> chosen;
  auto id_used = [&](int id) {
    for (int c : chosen) {
      if (pairs[c].ring_id == id) return true;
    }
    return false;
  };
  for (int k : order) {
    const auto& pc = pairs[k];
    if (pc.err > p.ratio_tol || id_used(pc.ring_id) || used_ellipse[pc.outer] ||
        used_ellipse[pc.inner]) {
      continue;
    }
    used_ellipse[pc.outer] = used_ellipse[pc.inner] = true;
    chosen.push_back(k);
  }
  auto fill_centres = [&]() {
    d.centres.clear();
    for (auto& e : d.ellipses) e.ring_id = -1;
    for (int k : chosen) {
      const auto& pc = pairs[k];
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
  };
  // Guided inner search: an outer circle whose inner circle was not found as a contour (too
  // small, or touching the code pattern inside the central ring) is searched for an inner
  // edge at each unidentified model ratio, in a band narrower than the gap to the outer edge.
  if (p.guided_inner_search) {
    const int n0 = static_cast<int>(cands.size());
    for (int i = 0; i < n0; ++i) {
      if (used_ellipse[i]) continue;
      for (const auto& ring : target.rings) {
        if (id_used(ring.id) || used_ellipse[i]) continue;
        const double rho = ring.radius_ratio();
        EllipseParams guess = cands[i].image;
        guess.a *= rho;
        guess.b *= rho;
        if (guess.b < p.min_axis_px) continue;
        const double search = std::min(p.edge_search_px, 0.45 * (1.0 - rho) * cands[i].image.b);
        if (search < 0.5) continue;
        auto inner = vision_internal::refine_candidate(blurred, cv::Point2f(roi.x, roi.y), guess,
                                                       search, cam, p, shadow);
        if (!inner) continue;
        cands.push_back(std::move(*inner));
        const int j = static_cast<int>(cands.size()) - 1;
        used_ellipse.push_back(false);
        auto pc = make_pair(i, j);
        if (!pc || pc->err > p.ratio_tol || id_used(pc->ring_id)) {
          cands.pop_back();
          used_ellipse.pop_back();
          continue;
        }
        add_ellipse(cands.back());
        pairs.push_back(*pc);
        used_ellipse[i] = used_ellipse[j] = true;
        chosen.push_back(static_cast<int>(pairs.size()) - 1);
      }
    }
  }
  fill_centres();
  // Initial pose: IPPE (Collins and Bartoli 2014) - made for planar targets, closed form,
  // returns both solutions of the planar ambiguity so we can keep the consistent one, and
  // is exact with four points; SQPnP is general-purpose (3D) and slower for our 4-7 points.
  const Eigen::Matrix3d K = cam.K();
  const cv::Mat Kcv = camera_matrix_cv(cam);
  // The identified centres of `set` (indices into pairs): P points and undistorted pixels.
  auto centre_points = [&](const std::vector<int>& set, std::vector<cv::Point3d>& obj,
                           std::vector<cv::Point2d>& img) {
    for (int k : set) {
      const auto& c = target.ring(pairs[k].ring_id).centre_P_m;
      obj.emplace_back(c.x(), c.y(), 0.0);
      img.emplace_back(pairs[k].centre.x(), pairs[k].centre.y());
    }
  };
  // The two circles of each set of `set` with their edge points, for the conic cost.
  auto conic_observations = [&](const std::vector<int>& set) {
    std::vector<vision_internal::ConicObservation> obs;
    for (int k : set) {
      const RingSet& ring = target.ring(pairs[k].ring_id);
      obs.push_back({ring.centre_P_m, ring.outer_radius_m, &cands[pairs[k].outer].points});
      if (pairs[k].inner >= 0) {
        obs.push_back({ring.centre_P_m, ring.inner_radius_m, &cands[pairs[k].inner].points});
      }
    }
    return obs;
  };
  // The extent of the sets `set` in the image and the gates it scales (scaled_gate).
  auto extent_of = [&](const std::vector<int>& set) {
    std::vector<vision_internal::SetImage> im;
    for (int k : set) {
      im.push_back({pairs[k].centre, cands[pairs[k].outer].undist.a, cands[pairs[k].outer].undist.b});
    }
    return vision_internal::ring_extent_px(im);
  };
  auto centre_gate = [&](const std::vector<int>& set) {
    return vision_internal::scaled_gate(p.max_centre_reproj_px, p.max_centre_reproj_fraction, extent_of(set));
  };
  // IPPE on the identified centres `set`: the solution facing the camera (faces_camera) with
  // the smallest largest centre reprojection error; none if no solution faces it.
  struct Fit {
    Eigen::Isometry3d X;
    double max_err;
  };
  // IPPE's two solutions (the plane's two tilts) on the centres of `set`; false if it fails.
  auto ippe_solutions = [&](const std::vector<int>& set, std::vector<cv::Point3d>& obj,
                            std::vector<cv::Point2d>& img, std::vector<cv::Mat>& rvecs,
                            std::vector<cv::Mat>& tvecs) {
    centre_points(set, obj, img);
    try {
      cv::solvePnPGeneric(obj, img, Kcv, cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE);
    } catch (const cv::Exception&) {
      return false;
    }
    return true;
  };
  // The largest reprojection error of the identified centres of `set` under the pose X (px).
  auto max_centre_err = [&](const std::vector<int>& set, const Eigen::Isometry3d& X) {
    double mx = 0.0;
    for (int k : set) {
      mx = std::max(
          mx, (project(K, X, target.ring(pairs[k].ring_id).centre_P_m) - pairs[k].centre).norm());
    }
    return mx;
  };
  auto ippe = [&](const std::vector<int>& set) -> std::optional<Fit> {
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    std::vector<cv::Mat> rvecs, tvecs;
    if (!ippe_solutions(set, obj, img, rvecs, tvecs)) return std::nullopt;
    auto max_err = [&](const Eigen::Isometry3d& X) { return max_centre_err(set, X); };
    std::optional<Fit> fit;
    for (std::size_t s = 0; s < rvecs.size(); ++s) {
      // IPPE's closed form is exact for exact centres, not the least-squares pose. Refined on
      // the centres, the largest error measures the layout's consistency rather than the
      // closed form's (under a 2 % pixel aspect error 23 px at 1 m against ~5 px refined);
      // the refinement is kept only where it lowers that largest error.
      Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
      if (!faces_camera(X)) continue;
      double mx = max_err(X);
      try {
        cv::Mat rv = rvecs[s].clone(), tv = tvecs[s].clone();
        cv::solvePnPRefineLM(obj, img, Kcv, cv::noArray(), rv, tv);
        const Eigen::Isometry3d Xr = pose_from_cv(rv, tv);
        const double mr = faces_camera(Xr) ? max_err(Xr) : std::numeric_limits<double>::infinity();
        if (mr < mx) {
          X = Xr;
          mx = mr;
        }
      } catch (const cv::Exception&) {
      }
      if (mx < (fit ? fit->max_err : std::numeric_limits<double>::infinity())) fit = Fit{X, mx};
    }
    return fit;
  };
  // Pose from three identified sets: P3P on their centres (up to four solutions), each
  // solution in front of the camera with the target facing it refined on the six conics.
  auto three_set_pose = [&](const std::vector<int>& set,
                            std::string& why) -> std::optional<Eigen::Isometry3d> {
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    centre_points(set, obj, img);
    const std::vector<vision_internal::ConicObservation> o3 = conic_observations(set);
    std::vector<cv::Mat> rvecs, tvecs;
    try {
      cv::solveP3P(obj, img, Kcv, cv::noArray(), rvecs, tvecs, cv::SOLVEPNP_P3P);
    } catch (const cv::Exception&) {
      why = "; three-set pose: P3P failed";
      return std::nullopt;
    }
    std::vector<std::pair<double, Eigen::Isometry3d>> fits;  // conic RMS, refined pose
    for (std::size_t s = 0; s < rvecs.size(); ++s) {
      const Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
      if (!faces_camera(X)) continue;
      const auto r = vision_internal::refine_pose_conics(K, X, o3, p.refine_points_per_ellipse,
                                                         p.refine_max_iter);
      if (r.ok && std::isfinite(r.rms_px) && r.X_CP.translation().z() > 0) {
        fits.emplace_back(r.rms_px, r.X_CP);
      }
    }
    std::sort(fits.begin(), fits.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::ostringstream os;
    if (fits.empty()) {
      why = "; three-set pose: no P3P solution in front refined";
      return std::nullopt;
    }
    const double edge_gate = vision_internal::ring_gates(p, extent_of(set)).edge_px;
    if (!(fits[0].first <= edge_gate)) {
      os << "; three-set pose: conic residual " << fits[0].first << " px (gate " << edge_gate
         << " px)";
      why = os.str();
      return std::nullopt;
    }
    for (std::size_t i = 1; i < fits.size(); ++i) {
      if (!poses_agree(fits[0].second, fits[i].second, p) &&
          fits[i].first < kThreeSetMinResidualRatio * fits[0].first) {
        os << "; three-set pose ambiguous: conic residuals " << fits[0].first << " and "
           << fits[i].first << " px for two different poses";
        why = os.str();
        return std::nullopt;
      }
    }
    return fits[0].second;
  };
  // The initial pose of the identified sets `chosen`; nullopt after fail() with the reason.
  auto initial_pose = [&]() -> std::optional<Eigen::Isometry3d> {
    if (chosen.empty()) {
      fail(VisionStatus::NoRingIdentified,
           std::to_string(pairs.size()) + " concentric pairs, no cross-ratio (eq. 9) matched");
      return std::nullopt;
    }
    Eigen::Isometry3d X0 = Eigen::Isometry3d::Identity();
    if (static_cast<int>(chosen.size()) < p.min_rings) {
      // Three sets (grazing views, far range, the frame's edge): P3P's up to four poses, each
      // refined on the six conics; the one that fits them is kept if it fits well and clearly
      // better than the others (the conics decide P3P's ambiguity; three points alone always
      // reproject exactly).
      std::optional<Eigen::Isometry3d> X3;
      std::string why3;
      if (p.three_ring_pose && chosen.size() == 3) X3 = three_set_pose(chosen, why3);
      if (!X3) {
        fail(VisionStatus::TooFewRings, std::to_string(chosen.size()) +
                                            " ring sets identified, need " +
                                            std::to_string(p.min_rings) + why3);
        return std::nullopt;
      }
      X0 = *X3;
    } else {
      for (;;) {
        const std::optional<Fit> fit = ippe(chosen);
        if (fit && fit->max_err <= centre_gate(chosen)) {
          X0 = fit->X;
          break;
        }
        // Hexagon layout check: drop the centre whose removal leaves the most consistent rest
        // (a misidentified centre can pull the fit so that a correct one has the largest
        // error, or put both IPPE solutions behind the camera), and retry.
        if (static_cast<int>(chosen.size()) <= p.min_rings) {
          fill_centres();
          if (fit) {
            fail(VisionStatus::PoseFailed,
                 "identified centres inconsistent with the ring layout (max error " +
                     std::to_string(fit->max_err) + " px, gate " +
                     std::to_string(centre_gate(chosen)) + " px)");
          } else {
            fail(VisionStatus::PoseFailed, "IPPE gave no solution facing the camera");
          }
          return std::nullopt;
        }
        std::size_t drop = 0;
        std::optional<double> best;
        for (std::size_t i = 0; i < chosen.size(); ++i) {
          std::vector<int> rest = chosen;
          rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
          const std::optional<Fit> f = ippe(rest);
          if (f && (!best || f->max_err < *best)) {
            best = f->max_err;
            drop = i;
          }
        }
        if (!best) {
          fill_centres();
          fail(VisionStatus::PoseFailed, "IPPE gave no solution facing the camera");
          return std::nullopt;
        }
        used_ellipse[pairs[chosen[drop]].outer] = false;
        if (pairs[chosen[drop]].inner >= 0) used_ellipse[pairs[chosen[drop]].inner] = false;
        chosen.erase(chosen.begin() + static_cast<std::ptrdiff_t>(drop));
      }
    }
    return X0;
  };
  // From the initial pose: sets recovered by the layout, the conic refinement and the gates.
  auto finish = [&](const Eigen::Isometry3d& X0) -> bool {
    // Use the layout to recover pairs whose ratio was ambiguous: an unused concentric pair at
    // the predicted centre of an unidentified ring set with a ratio within twice the tolerance.
    const double recover_gate = centre_gate(chosen);
    for (const auto& ring : target.rings) {
      if (id_used(ring.id)) continue;
      const Eigen::Vector2d pred = project(K, X0, ring.centre_P_m);
      int best = -1;
      double best_d = recover_gate;
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        const auto& pc = pairs[k];
        if (pc.inner < 0 || used_ellipse[pc.outer] || used_ellipse[pc.inner]) continue;
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
        used_ellipse[pairs[best].outer] = used_ellipse[pairs[best].inner] = true;
        chosen.push_back(best);
      }
    }
    fill_centres();

    // Levenberg-Marquardt on the conic reprojection cost, eq. (14)-(15).
    const std::vector<vision_internal::ConicObservation> obs = conic_observations(chosen);
    const auto ref = vision_internal::refine_pose_conics(K, X0, obs, p.refine_points_per_ellipse,
                                                         p.refine_max_iter);
    if (!ref.ok) return fail(VisionStatus::PoseFailed, "conic refinement (eq. 14-15) failed");
    if (!faces_camera(ref.X_CP)) {
      return fail(VisionStatus::PoseFailed,
                  "the refined pose puts the camera behind the target's surface");
    }
    d.X_CP = ref.X_CP;
    d.cov = ref.cov;
    d.edge_rms_px = ref.rms_px;
    d.refine_iterations = ref.iterations;
    // Eq. (30): sum over identified centres of |x_i - H X_i|^2.
    auto set_reprojection = [&]() {
      double sum = 0.0;
      for (int k : chosen) {
        sum += (project(K, d.X_CP, target.ring(pairs[k].ring_id).centre_P_m) - pairs[k].centre)
                   .squaredNorm();
      }
      d.reproj_err_sum_px2 = sum;
      d.reproj_err_px = std::sqrt(sum / chosen.size());
    };
    set_reprojection();
    const vision_internal::RingGates gates = vision_internal::ring_gates(p, extent_of(chosen));
    d.reproj_gate_px = gates.reproj_px;
    d.edge_gate_px = gates.edge_px;
    if (!(d.reproj_err_px <= d.reproj_gate_px) || !(d.edge_rms_px <= d.edge_gate_px)) {
      std::ostringstream os;
      os << "reprojection error " << d.reproj_err_px << " px (gate " << d.reproj_gate_px
         << "), conic residual " << d.edge_rms_px << " px (gate " << d.edge_gate_px << ")";
      return fail(VisionStatus::ReprojectionTooLarge, os.str());
    }
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
    std::string tilt_note;  // the reason's note when the other tilt was kept
    {
      std::vector<cv::Point3d> obj;
      std::vector<cv::Point2d> img;
      std::vector<cv::Mat> rvecs, tvecs;
      if (!ippe_solutions(chosen, obj, img, rvecs, tvecs)) rvecs.clear();
      struct Tilt {
        vision_internal::RefineResult r;
        double corners_px;
      };
      auto corners_px = [&](const Eigen::Isometry3d& X) {
        return platform != nullptr
                   ? vision_internal::platform_corner_error_px(platform->quad, X, cam, target)
                   : 0.0;
      };
      const double layout_gate = centre_gate(chosen);
      std::vector<Tilt> tilts{{ref, corners_px(ref.X_CP)}};
      for (std::size_t s = 0; s < rvecs.size(); ++s) {
        const Eigen::Isometry3d X = pose_from_cv(rvecs[s], tvecs[s]);
        if (!faces_camera(X) || poses_agree(X, d.X_CP, p)) continue;
        if (platform == nullptr && !(max_centre_err(chosen, X) <= layout_gate)) continue;
        const auto r = vision_internal::refine_pose_conics(K, X, obs, p.refine_points_per_ellipse,
                                                           p.refine_max_iter);
        if (!r.ok || !std::isfinite(r.rms_px) || !faces_camera(r.X_CP) ||
            poses_agree(r.X_CP, d.X_CP, p)) {
          continue;
        }
        tilts.push_back({r, corners_px(r.X_CP)});
      }
      if (tilts.size() > 1) {
        const bool second = tilts[1].r.rms_px < tilts[0].r.rms_px;
        const Tilt& a = tilts[second ? 1 : 0];
        const Tilt& b = tilts[second ? 0 : 1];
        if (!(b.r.rms_px >= kMirrorMinResidualRatio * a.r.rms_px &&
              (platform == nullptr || b.corners_px >= kMirrorMinCornerRatio * a.corners_px))) {
          std::ostringstream os;
          os << "mirror pose ambiguous: conic residuals " << a.r.rms_px << " and " << b.r.rms_px
             << " px";
          if (platform != nullptr) {
            os << ", the top's corners " << a.corners_px << " and " << b.corners_px
               << " px off its outline";
          }
          os << ", for the plane's two tilts";
          return fail(VisionStatus::PoseFailed, os.str());
        }
        if (second) {
          d.X_CP = a.r.X_CP;
          d.cov = a.r.cov;
          d.edge_rms_px = a.r.rms_px;
          d.refine_iterations = a.r.iterations;
          std::ostringstream ot;
          ot << " (the plane's other tilt: conic residual " << a.r.rms_px << " px against "
             << b.r.rms_px << ")";
          tilt_note = ot.str();
          set_reprojection();
          if (!(d.reproj_err_px <= d.reproj_gate_px)) {
            std::ostringstream os;
            os << "the better of the plane's two tilts reprojects the centres " << d.reproj_err_px
               << " px (gate " << d.reproj_gate_px << ")";
            return fail(VisionStatus::ReprojectionTooLarge, os.str());
          }
        }
      }
    }
    d.detected = true;
    d.status = VisionStatus::Detected;
    d.source = PoseSource::Rings;
    std::ostringstream os;
    os << chosen.size() << " ring sets identified" << tilt_note;
    d.reason = os.str();
    return true;
  };
  if (const auto X0 = initial_pose(); X0 && finish(*X0)) return true;
  if (!p.layout_identification) return false;

  // Identification by the layout (vision_layout.h): the ratio path gave no pose. Its result
  // is restored unless the layout's assignment gives a pose through the same gates, so the
  // frames the ratio path detects are untouched.
  const RingDetection d_ratio = d;
  const std::vector<int> chosen_ratio = chosen;
  const std::vector<PairCandidate> pairs_ratio = pairs;
  const std::vector<bool> used_ratio = used_ellipse;
  std::vector<int> best_pair(cands.size(), -1);  // per ellipse: its pair as the outer circle
  std::vector<bool> is_inner(cands.size(), false);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& pc = pairs[k];
    if (pc.inner < 0) continue;
    is_inner[pc.inner] = true;
    if (best_pair[pc.outer] < 0 || pc.err < pairs[best_pair[pc.outer]].err) {
      best_pair[pc.outer] = static_cast<int>(k);
    }
  }
  std::vector<LayoutCandidate> lc;
  std::vector<int> lc_ellipse;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    if (best_pair[i] < 0 && is_inner[i]) continue;  // an inner circle, not a set of its own
    LayoutCandidate c;
    c.outer = cands[i].undist;
    if (best_pair[i] >= 0) {
      c.centre = pairs[best_pair[i]].centre;
      c.ratio = pairs[best_pair[i]].ratio;
    } else {
      c.centre = cands[i].undist.centre;
    }
    // Small sets: the ratio from the set's model fitted to its pixels (photometric_ratio),
    // unbiased where eq. (9) on 1-3 px inner circles reads 0.05-0.3 off or has no inner
    // circle at all. A fit must show the set as dark on light with a residual well below the
    // contrast (an inner circle taken as an outer one fits as light on dark).
    if (cands[i].image.b <= p.layout_photometric_max_minor_px) {
      const auto pr = photometric_ratio(grey, cands[i].image);
      if (pr && pr->contrast >= kPhotoMinContrast && pr->rms <= kPhotoMaxRmsFraction * pr->contrast) {
        c.ratio = pr->ratio;
        c.photometric = true;
      }
    }
    lc.push_back(c);
    lc_ellipse.push_back(static_cast<int>(i));
  }
  std::string lwhy;
  const std::optional<LayoutMatch> m = identify_by_layout(lc, target, p, lwhy);
  if (m) {
    chosen.clear();
    std::fill(used_ellipse.begin(), used_ellipse.end(), false);
    for (std::size_t s = 0; s < m->candidate.size(); ++s) {
      const int e = lc_ellipse[m->candidate[s]];
      const int id = m->ring_id[s];
      int k = best_pair[e];
      if (k < 0) {  // the outer circle alone: its ellipse centre stands for the set's centre
        PairCandidate pc;
        pc.outer = e;
        pc.centre = cands[e].undist.centre;
        pc.ratio = 0.0;
        pairs.push_back(pc);
        k = static_cast<int>(pairs.size()) - 1;
      }
      pairs[k].ring_id = id;
      pairs[k].err =
          pairs[k].inner >= 0 ? std::abs(pairs[k].ratio - target.ring(id).radius_ratio()) : 0.0;
      used_ellipse[pairs[k].outer] = true;
      if (pairs[k].inner >= 0) used_ellipse[pairs[k].inner] = true;
      chosen.push_back(k);
    }
    fill_centres();
    const auto X0 = initial_pose();
    if (X0 && finish(*X0)) {
      std::ostringstream os;
      os << "layout: " << d.reason << " (" << m->candidate.size() << " placed, " << m->ratio_sets
         << " ratios, mean error " << m->mean_ratio_err << " after a common bias of "
         << m->ratio_bias << ", best other identity " << m->runner_up_err
         << "; ratio path: " << d_ratio.reason << ")";
      d.reason = os.str();
      d.by_layout = true;
      return true;
    }
    lwhy = m->candidate.size() > 0
               ? "placed " + std::to_string(m->candidate.size()) + " sets, no pose: " + d.reason
               : d.reason;
  }
  d = d_ratio;
  chosen = chosen_ratio;
  pairs = pairs_ratio;
  used_ellipse = used_ratio;
  if (!no_pairs.empty() && chosen.empty()) {
    return fail(VisionStatus::NoConcentricPairs, no_pairs + "; layout: " + lwhy);
  }
  d.reason += "; layout: " + lwhy;
  return false;
}

// ---- fewer-ring poses and ring + code combination ----

// Closed-form pose of the central ring set (P origin) from its concentric pair: the projected
// centre c (harmonic / Kim-Gurdjos-Kweon), the vanishing line as the polar of c w.r.t. the
// outer conic (pole-polar: the polar of a circle's centre is the line at infinity of its
// plane), the plane normal n ~ K^T l, the depth from the known radii (each edge point's ray
// meets the plane at distance R from the centre), and the in-plane axis r1 from `x_dir`
// (a camera-frame direction to be P's +x after projection onto the plane).
std::optional<Eigen::Isometry3d> centre_pair_pose(const Eigen::Matrix3d& K, const Conic& C_outer,
                                                  const Eigen::Vector2d& c_px,
                                                  const std::vector<vision_internal::ConicObservation>& circles) {
  const Eigen::Matrix3d Ki = K.inverse();
  const Eigen::Vector3d ch(c_px.x(), c_px.y(), 1.0);
  const Eigen::Vector3d l = C_outer * ch;
  Eigen::Vector3d n = (K.transpose() * l);
  if (!(n.norm() > 0)) return std::nullopt;
  n.normalize();
  const Eigen::Vector3d rc = Ki * ch;
  if (n.dot(rc) > 0) n = -n;  // P's z axis points back towards the camera
  std::vector<double> lambdas;
  for (const auto& o : circles) {
    for (const auto& x : *o.points) {
      const Eigen::Vector3d rx = Ki * Eigen::Vector3d(x.x(), x.y(), 1.0);
      const double den = n.dot(rx);
      if (std::abs(den) < 1e-12) continue;
      const double len = ((n.dot(rc) / den) * rx - rc).norm();
      if (len > 0) lambdas.push_back(o.r_m / len);
    }
  }
  if (lambdas.size() < 6) return std::nullopt;
  std::nth_element(lambdas.begin(), lambdas.begin() + lambdas.size() / 2, lambdas.end());
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = lambdas[lambdas.size() / 2] * rc;
  X.linear().col(2) = n;
  return X;  // r1, r2 still to set (yaw)
}

// Sets the yaw of X (whose col(2) is the plane normal): P's +x along the projection of
// `x_dir` onto the plane.
void set_yaw(Eigen::Isometry3d& X, const Eigen::Vector3d& x_dir) {
  const Eigen::Vector3d n = X.linear().col(2);
  const Eigen::Vector3d r1 = (x_dir - x_dir.dot(n) * n).normalized();
  X.linear().col(0) = r1;
  X.linear().col(1) = n.cross(r1);
}

// True if two poses agree within the combination gates.
bool poses_agree(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const VisionParams& p) {
  const double ang = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
  const double dist = (a.translation() - b.translation()).norm();
  return ang <= p.combine_max_angle_rad &&
         dist <= p.combine_max_offset_ratio * std::max(a.translation().norm(), 0.05);
}

// The global segmentation first; if it gives no pose, the shadow-tolerant one (issue 12).
// The shadow pass's result replaces the first when it gives a pose, or identifies more ring
// sets (for the fewer-ring poses of combine_sources); the first pass's reason is kept.
bool search_region(const cv::Mat& grey, const cv::Rect& roi, const CameraModel& cam,
                   const TargetGeometry& target, const VisionParams& p, RingDetection& d,
                   std::vector<EllipseCandidate>& cands) {
  const bool found = run_region(grey, roi, cam, target, p, d, cands);
  // A pose from the global threshold is kept unless a shadow's edge crosses one of the
  // ellipses it used: at 50 % light the global level still meets the shadowed edges, near
  // their light end, and the pose is biased (seen: 3.6 deg at 10 m). Then the shadow pass
  // decides, and its pose is used if it gives one.
  bool shadowed = false;
  for (const auto& c : d.centres) {
    for (int i : {c.outer_index, c.inner_index}) {
      if (i >= 0 && i < static_cast<int>(cands.size()) && cands[i].two_lights) shadowed = true;
    }
  }
  if (found && !shadowed) return true;
  if (!p.shadow_pass) return found;
  RingDetection ds;
  std::vector<EllipseCandidate> cs;
  bool ok = run_region(grey, roi, cam, target, p, ds, cs, true);
  // A shadow-pass pose must fit its edge points as a clean pose does (0.02-0.1 px RMS on the
  // rendered frames): an ellipse the shadow still biases (the central ring's inner circle,
  // whose code cells hide the shadow's edge) pulled one pose 59 deg off at 10 m with 0.79 px.
  constexpr double kShadowMaxEdgeResidualPx = 0.5;
  if (ok && ds.edge_rms_px > kShadowMaxEdgeResidualPx) {
    ok = false;
    ds.detected = false;
    ds.status = VisionStatus::PoseFailed;
    ds.reason = "conic fit residual " + std::to_string(ds.edge_rms_px) + " px above the shadow "
                "pass's " + std::to_string(kShadowMaxEdgeResidualPx) + " px";
  }
  // Both passes gave a pose: the one that reprojects the ring centres better.
  if (found && ok && ds.reproj_err_px > d.reproj_err_px) {
    d.reason += "; a shadow's edge crosses its ellipses; the shadow pass's pose reprojects "
                "worse (" + std::to_string(ds.reproj_err_px) + " px), not used";
    return true;
  }
  if (found && !ok) {
    d.reason += "; a shadow's edge crosses its ellipses, the shadow pass found no pose: " + ds.reason;
    return true;
  }
  if (ok || ds.centres.size() > d.centres.size()) {
    ds.reason = "shadow pass: " + ds.reason + " (global threshold: " + d.reason + ")";
    d = std::move(ds);
    cands = std::move(cs);
  } else {
    d.reason += "; shadow pass: " + ds.reason;
  }
  return ok;
}

// Fewer-ring / combined pose on top of the ring pass. `d` is the ring result (detected or
// not), `cands` its ellipse candidates, `code` the code result (may be undetected),
// `tracked` the last tracked pose (nullptr if none). Updates d when a pose results.
void combine_sources(RingDetection& d, const std::vector<EllipseCandidate>& cands,
                     const Eigen::Matrix3d& K, const TargetGeometry& target,
                     const VisionParams& p, const Eigen::Isometry3d* tracked) {
  const bool rings_ok = d.detected;
  // Conic observations of every identified set.
  std::vector<vision_internal::ConicObservation> obs;
  const IdentifiedCentre* centre0 = nullptr;
  const IdentifiedCentre* other = nullptr;
  for (const auto& c : d.centres) {
    if (c.outer_index < 0 || c.inner_index < 0 || c.outer_index >= static_cast<int>(cands.size()) ||
        c.inner_index >= static_cast<int>(cands.size())) {
      continue;
    }
    const RingSet& ring = target.ring(c.ring_id);
    obs.push_back({ring.centre_P_m, ring.outer_radius_m, &cands[c.outer_index].points});
    obs.push_back({ring.centre_P_m, ring.inner_radius_m, &cands[c.inner_index].points});
    if (ring.centre_P_m.norm() < 1e-9) {
      centre0 = &c;
    } else if (other == nullptr) {
      other = &c;
    }
  }
  // The gates scale with the identified sets' extent (scaled_gate).
  std::vector<vision_internal::SetImage> set_images;
  for (const auto& c : d.centres) {
    if (c.outer_index < 0 || c.outer_index >= static_cast<int>(cands.size())) continue;
    set_images.push_back({c.centre_px, cands[c.outer_index].undist.a, cands[c.outer_index].undist.b});
  }
  const vision_internal::RingGates gates = vision_internal::ring_gates(p, vision_internal::ring_extent_px(set_images));
  const double reproj_gate = gates.reproj_px;
  const double edge_gate = gates.edge_px;
  std::vector<vision_internal::PointObservation> pts;
  if (d.code.detected) {
    for (std::size_t i = 0; i < d.code.corners_px.size(); ++i) {
      pts.push_back({d.code.corners_P_m[i], d.code.corners_px[i]});
    }
  }
  // One acceptance rule for every ring-based pose (rings + code, centre ring, centre ring +
  // code): the ring centres' reprojection RMS (eq. 30) within the main path's gate
  // (max_reproj_err_px, grown with the sets' extent by max_reproj_fraction). A pose beyond it
  // is not reported (returns false, d unchanged): at grazing views a small outer ring taken
  // for the centre ring gave a pose 115 deg off with 16 px.
  auto accept = [&](const vision_internal::RefineResult& ref, PoseSource src,
                    const std::string& why) {
    double sum = 0.0;
    for (const auto& c : d.centres) {
      sum += (project(K, ref.X_CP, target.ring(c.ring_id).centre_P_m) - c.centre_px).squaredNorm();
    }
    const double reproj = d.centres.empty() ? d.code.reproj_rms_px : std::sqrt(sum / d.centres.size());
    const double gate = d.centres.empty() ? d.code.reproj_gate_px : reproj_gate;
    if (!(reproj <= gate)) {
      std::ostringstream os;
      os << "; " << to_string(src) << " pose rejected: reprojection error " << reproj << " px (gate "
         << gate << " px)";
      d.reason += os.str();
      return false;
    }
    d.X_CP = ref.X_CP;
    d.cov = ref.cov;
    d.edge_rms_px = ref.rms_px;
    d.refine_iterations = ref.iterations;
    d.reproj_err_sum_px2 = sum;
    d.reproj_err_px = reproj;
    d.reproj_gate_px = gate;
    d.edge_gate_px = edge_gate;
    d.detected = true;
    d.status = VisionStatus::Detected;
    d.source = src;
    d.reason = why;
    return true;
  };
  if (rings_ok) {
    if (!d.code.detected) return;
    if (!poses_agree(d.X_CP, d.code.X_CP, p)) {
      d.reason += "; code pose disagrees with the rings, not used";
      return;
    }
    const auto ref = vision_internal::refine_pose_conics(K, d.X_CP, obs, p.refine_points_per_ellipse,
                                                         p.refine_max_iter, &pts);
    if (ref.ok && ref.rms_px <= edge_gate) {
      accept(ref, PoseSource::Combined, d.reason + " + " + d.code.reason);
    }
    return;
  }
  // Fewer than min_rings sets: the central pair gives normal, centre and depth.
  if (p.centre_ring_pose && centre0 != nullptr && d.status == VisionStatus::TooFewRings) {
    std::vector<vision_internal::ConicObservation> c0obs;
    for (const auto& o : obs) {
      if (o.c_P_m.norm() < 1e-9) c0obs.push_back(o);
    }
    auto X0 = centre_pair_pose(K, cands[centre0->outer_index].C, centre0->centre_px, c0obs);
    if (X0) {
      std::string yaw_from;
      std::optional<vision_internal::YawPrior> prior;
      if (other != nullptr) {
        // The other set's centre on the plane fixes the in-plane rotation.
        const Eigen::Matrix3d Ki = K.inverse();
        const Eigen::Vector3d n = X0->linear().col(2), t = X0->translation();
        const Eigen::Vector3d rj = Ki * Eigen::Vector3d(other->centre_px.x(), other->centre_px.y(), 1);
        const Eigen::Vector3d Xj = (n.dot(t) / n.dot(rj)) * rj;
        const Eigen::Vector3d v = (Xj - t).normalized();
        const Eigen::Vector2d q = target.ring(other->ring_id).centre_P_m.normalized();
        // v = q.x r1 + q.y r2 with r2 = n x r1  =>  r1 = q.x v - q.y (n x v).
        set_yaw(*X0, q.x() * v - q.y() * n.cross(v));
        yaw_from = "ring set " + std::to_string(other->ring_id);
      } else if (d.code.detected) {
        set_yaw(*X0, d.code.X_CP.linear().col(0));
        yaw_from = "code";
      } else if (tracked != nullptr) {
        set_yaw(*X0, tracked->linear().col(0));
        prior = vision_internal::YawPrior{X0->linear(), p.tracked_yaw_sigma_rad};
        yaw_from = "tracked pose";
      }
      if (!yaw_from.empty()) {
        // Rings first (yaw from a set or the track), then the code joins if it agrees; with
        // the yaw from the code itself, conics and corners are refined together.
        const bool code_yaw = yaw_from == "code";
        auto ref = vision_internal::refine_pose_conics(K, *X0, obs, p.refine_points_per_ellipse,
                                                       p.refine_max_iter, code_yaw ? &pts : nullptr,
                                                       prior ? &*prior : nullptr);
        bool ok = ref.ok && ref.rms_px <= edge_gate;
        bool with_code = code_yaw;
        std::string note;
        if (ok && !code_yaw && d.code.detected) {
          if (poses_agree(ref.X_CP, d.code.X_CP, p)) {
            const auto both = vision_internal::refine_pose_conics(
                K, ref.X_CP, obs, p.refine_points_per_ellipse, p.refine_max_iter, &pts);
            if (both.ok && both.rms_px <= edge_gate) {
              ref = both;
              with_code = true;
            }
          } else {
            note = "; code pose disagrees with the rings, not used";
          }
        }
        if (ok && code_yaw && !poses_agree(ref.X_CP, d.code.X_CP, p)) ok = false;
        if (ok && prior && !with_code) {  // the yaw came from the track (its prior)
          // A lone central pair with the track's yaw has nothing else to check it (its one
          // centre reprojects onto itself): in blurred frames another set read as the central
          // one gave poses 30 % and 88 % off in range. It must stay near the track.
          const double jump = (ref.X_CP.translation() - tracked->translation()).norm();
          const double gate = p.tracked_max_jump_m + p.tracked_max_jump_ratio * tracked->translation().norm();
          if (!(jump <= gate)) {
            std::ostringstream os;
            os << "; centre pair with the track's yaw is " << jump << " m from the tracked pose (gate " << gate
               << " m): not used";
            d.reason += os.str();
            ok = false;
          }
        }
        if (ok) {
          std::ostringstream os;
          os << d.centres.size() << " ring sets identified (centre pair, yaw from " << yaw_from
             << ")";
          if (with_code) os << " + " << d.code.reason;
          os << note;
          if (accept(ref, with_code ? PoseSource::Combined : PoseSource::CentreRing, os.str())) return;
          if (!d.code.detected) d.status = VisionStatus::ReprojectionTooLarge;
        }
      } else {
        d.reason += "; central pair seen but no yaw (no other set, code or track)";
      }
    }
  }
  if (d.code.detected) {
    d.X_CP = d.code.X_CP;
    d.cov = d.code.cov;
    d.edge_rms_px = 0.0;
    d.reproj_err_px = d.code.reproj_rms_px;
    d.reproj_gate_px = d.code.reproj_gate_px;
    d.edge_gate_px = 0.0;
    d.reproj_err_sum_px2 = d.code.reproj_rms_px * d.code.reproj_rms_px * d.code.corners_px.size();
    d.refine_iterations = 0;
    d.detected = true;
    d.status = VisionStatus::Detected;
    d.source = PoseSource::Code;
    d.reason = d.code.reason;
  }
}

}  // namespace

RingTargetDetector::RingTargetDetector(CameraModel camera, TargetGeometry target,
                                       VisionParams params)
    : camera_(std::move(camera)), target_(std::move(target)), params_(std::move(params)) {
  camera_.validate();
  target_.validate();
  params_.validate();
}

void RingTargetDetector::reset() {
  have_prediction_ = false;
  have_keyframe_ = false;
  misses_ = 0;
  rejections_ = 0;
}

namespace {

// The pixel rectangle covering [x0, x1] x [y0, y1] (outward to whole pixels), within `full`.
cv::Rect covering_rect(double x0, double y0, double x1, double y1, const cv::Rect& full) {
  using vision_internal::clamp_coord;
  return cv::Rect(cv::Point(static_cast<int>(std::floor(clamp_coord(x0))),
                            static_cast<int>(std::floor(clamp_coord(y0)))),
                  cv::Point(static_cast<int>(std::ceil(clamp_coord(x1))),
                            static_cast<int>(std::ceil(clamp_coord(y1))))) &
         full;
}

// The pixel bounds of points in the camera frame (all in front of it), projected through the
// camera with its distortion.
struct PixelBounds {
  double x0{1e18}, y0{1e18}, x1{-1e18}, y1{-1e18};
};
PixelBounds projected_bounds(const std::vector<cv::Point3d>& pts_C, const CameraModel& cam) {
  std::vector<cv::Point2d> img;
  cv::projectPoints(pts_C, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix_cv(cam),
                    dist_coeffs_cv(cam), img);
  PixelBounds b;
  for (const auto& q : img) {
    b.x0 = std::min(b.x0, q.x);
    b.y0 = std::min(b.y0, q.y);
    b.x1 = std::max(b.x1, q.x);
    b.y1 = std::max(b.y1, q.y);
  }
  return b;
}

// Where to search the code map (seed 001) in a frame whose pose `X_CP` is known (this frame's
// rings, else the track): the projection of the square around the centre ring's inner circle
// (the map and the white cells the lattice reads around it), grown by a slack for a tracked
// pose (a quarter of its size and 16 px) and by half the threshold's block, so that around the
// map the threshold is the whole frame's. Nothing (search the whole frame) when a corner is
// behind the camera or the region would be most of the frame anyway.
std::optional<cv::Rect> code_region(const Eigen::Isometry3d& X_CP, const CameraModel& cam,
                                    const TargetGeometry& g, const VisionParams& p,
                                    const cv::Rect& full) {
  double s = 0.5 * g.code.side_m();
  for (const auto& r : g.rings) {
    if (r.centre_P_m.norm() < 1e-9) s = std::max(s, r.inner_radius_m);
  }
  std::vector<cv::Point3d> pts;
  for (const double x : {-s, s}) {
    for (const double y : {-s, s}) {
      const Eigen::Vector3d q = X_CP * Eigen::Vector3d(x, y, 0);
      if (!(q.z() > 0.05)) return std::nullopt;
      pts.emplace_back(q.x(), q.y(), q.z());
    }
  }
  const auto [x0, y0, x1, y1] = projected_bounds(pts, cam);
  if (!std::isfinite(x0 + y0 + x1 + y1)) return std::nullopt;
  const double grow = 0.25 * std::max(x1 - x0, y1 - y0) + 16 + 0.5 * p.code_threshold_block_px + 1;
  const cv::Rect r = covering_rect(x0 - grow, y0 - grow, x1 + grow, y1 + grow, full);
  if (r.width < 16 || r.height < 16 || r.area() >= 0.7 * full.area()) return std::nullopt;
  return r;
}

// Regions for the zoomed pass: clusters of the failed pass's small ellipses (a ring set and
// its neighbours lie within a few of their radii of each other), the most populous first,
// each grown by its own size on every side (the sets not found lie around the ones found).
std::vector<cv::Rect> zoom_regions(const std::vector<DetectedEllipse>& ellipses,
                                   const cv::Rect& full, const VisionParams& p) {
  std::vector<int> idx;
  for (int i = 0; i < static_cast<int>(ellipses.size()); ++i) {
    const auto& e = ellipses[i].image;
    if (e.a >= p.min_axis_px && e.a <= p.zoom_max_axis_px) idx.push_back(i);
  }
  const int n = static_cast<int>(idx.size());
  std::vector<int> label(n);
  for (int i = 0; i < n; ++i) label[i] = i;
  auto root = [&](int i) {
    while (label[i] != i) i = label[i] = label[label[i]];
    return i;
  };
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const auto& a = ellipses[idx[i]].image;
      const auto& b = ellipses[idx[j]].image;
      if ((a.centre - b.centre).norm() <= 4.0 * std::max(a.a, b.a) + 4.0) label[root(i)] = root(j);
    }
  }
  struct Cluster {
    int count{0};
    double x0{1e18}, y0{1e18}, x1{-1e18}, y1{-1e18};
  };
  std::map<int, Cluster> clusters;
  for (int i = 0; i < n; ++i) {
    const auto& e = ellipses[idx[i]].image;
    Cluster& c = clusters[root(i)];
    ++c.count;
    c.x0 = std::min(c.x0, e.centre.x() - e.a);
    c.y0 = std::min(c.y0, e.centre.y() - e.a);
    c.x1 = std::max(c.x1, e.centre.x() + e.a);
    c.y1 = std::max(c.y1, e.centre.y() + e.a);
  }
  std::vector<Cluster> order;
  for (const auto& kv : clusters) {
    if (kv.second.count >= 2) order.push_back(kv.second);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const Cluster& a, const Cluster& b) { return a.count > b.count; });
  std::vector<cv::Rect> out;
  for (const Cluster& c : order) {
    if (static_cast<int>(out.size()) >= p.zoom_max_regions) break;
    const double gx = std::max(c.x1 - c.x0, 8.0), gy = std::max(c.y1 - c.y0, 8.0);
    const double g = std::max(gx, gy);
    const cv::Rect r = covering_rect(c.x0 - g, c.y0 - g, c.x1 + g, c.y1 + g, full);
    if (r.width < 8 || r.height < 8 || r.width > p.zoom_max_region_px ||
        r.height > p.zoom_max_region_px) {
      continue;
    }
    out.push_back(r);
  }
  return out;
}

// Maps a detection made on the zoomed region back to the frame's pixels (the pose does not
// change with the magnification; pixel residuals shrink by s).
void unzoom(RingDetection& d, std::vector<EllipseCandidate>& cands, const cv::Rect& region, int s) {
  const Eigen::Vector2d t(s * (0.5 - region.x) - 0.5, s * (0.5 - region.y) - 0.5);
  auto back = [&](const Eigen::Vector2d& u) -> Eigen::Vector2d { return (u - t) / s; };
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();  // zoomed = T * frame (homogeneous)
  T(0, 0) = T(1, 1) = s;
  T(0, 2) = t.x();
  T(1, 2) = t.y();
  auto conic_back = [&](const Conic& C) {
    Conic Cf = T.transpose() * C * T;
    normalise_conic(Cf);
    return Cf;
  };
  auto ellipse_back = [&](EllipseParams e) {
    e.centre = back(e.centre);
    e.a /= s;
    e.b /= s;
    return e;
  };
  for (auto& c : d.centres) {
    c.centre_px = back(c.centre_px);
    c.centre_image_px = back(c.centre_image_px);
  }
  for (auto& e : d.ellipses) {
    e.C = conic_back(e.C);
    e.image = ellipse_back(e.image);
    e.fit_rms_px /= s;
  }
  for (auto& c : cands) {
    c.C = conic_back(c.C);
    c.image = ellipse_back(c.image);
    c.undist = ellipse_back(c.undist);
    for (auto& q : c.points) q = back(q);
    c.fit_rms_px /= s;
  }
  d.reproj_err_px /= s;
  d.reproj_err_sum_px2 /= static_cast<double>(s) * s;
  d.edge_rms_px /= s;
  d.roi = region;
}

}  // namespace

RingDetection RingTargetDetector::detect(const cv::Mat& image, const Eigen::Vector2d& blur_px) {
  const auto t0 = std::chrono::steady_clock::now();
  RingDetection d;
  auto finish = [&]() {
    d.time_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return d;
  };
  if (image.empty()) {
    d.status = VisionStatus::EmptyImage;
    d.reason = "empty image";
    return finish();
  }
  if (!supported_image(image)) {
    d.status = VisionStatus::UnsupportedImage;
    d.reason = "unsupported pixel type (need 8/16-bit grey, BGR or BGRA)";
    return finish();
  }
  if (image.cols != camera_.width_px || image.rows != camera_.height_px) {
    d.status = VisionStatus::ImageSizeMismatch;
    d.reason = "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
               ", calibration is " + std::to_string(camera_.width_px) + "x" +
               std::to_string(camera_.height_px);
    return finish();
  }
  cv::Mat grey;
  const cv::Rect full(0, 0, image.cols, image.rows);
  bool done = false;
  std::vector<EllipseCandidate> cands;
  if (params_.tracking && have_prediction_) {
    // Predicted region: the outer circles projected with the last pose, plus a margin.
    std::vector<cv::Point3d> pts;
    for (const auto& ring : target_.rings) {
      for (int k = 0; k < 12; ++k) {
        const double a = 2 * M_PI * k / 12;
        const Eigen::Vector3d q =
            X_CP_pred_ * Eigen::Vector3d(ring.centre_P_m.x() + ring.outer_radius_m * std::cos(a),
                                         ring.centre_P_m.y() + ring.outer_radius_m * std::sin(a), 0);
        if (q.z() > 0.05) pts.emplace_back(q.x(), q.y(), q.z());
      }
    }
    if (!pts.empty()) {
      const auto [x0, y0, x1, y1] = projected_bounds(pts, camera_);
      const double mx = params_.roi_margin * (x1 - x0), my = params_.roi_margin * (y1 - y0);
      const cv::Rect2d r(x0 - mx, y0 - my, x1 - x0 + 2 * mx, y1 - y0 + 2 * my);
      const cv::Rect roi = covering_rect(r.x, r.y, r.x + r.width, r.y + r.height, full);
      if (roi.width >= 16 && roi.height >= 16 && roi.area() < 0.7 * full.area()) {
        grey_region(image, roi, grey);
        done = search_region(grey, roi, camera_, target_, params_, d, cands);
        d.used_roi = done;
      }
    }
  }
  bool grey_full = false;  // the whole frame is in `grey` (the later passes need no conversion)
  auto whole_grey = [&]() {
    if (!grey_full) grey_region(image, full, grey);
    grey_full = true;
  };
  if (!done && full.width >= 16 && full.height >= 16) {
    whole_grey();
    search_region(grey, full, camera_, target_, params_, d, cands);
  } else if (!done) {
    d.status = VisionStatus::NoEllipses;
    d.reason = "image too small to hold the target";
  }
  // Blur-aware pass (issue 12): no pose from the frame as it is, and the caller predicts a
  // blur long enough to close the inner circles and bridge the gaps: the rings again, on the
  // frame deconvolved with that blur. The acceptance gates are the same.
  cv::Mat sharp;  // the deconvolved frame, when the pass ran
  if (!d.detected && params_.deblur_min_px > 0 && blur_px.allFinite() &&
      blur_px.norm() >= params_.deblur_min_px && full.width >= 16 && full.height >= 16) {
    whole_grey();
    sharp = vision_internal::wiener_deblur(grey, blur_px, params_.deblur_noise_ratio);
    RingDetection d2;
    std::vector<EllipseCandidate> c2;
    std::ostringstream os;
    os << "deconvolved for a predicted blur of " << blur_px.norm() << " px";
    if (search_region(sharp, full, camera_, target_, params_, d2, c2)) {
      d2.reason += "; " + os.str();
      d2.deblurred = true;
      d = std::move(d2);
      cands = std::move(c2);
    } else {
      d.reason += "; " + os.str() + ": " + d2.reason;
    }
  }
  // Unfiltered pass (issue 12: far and grazing views): no pose, and the failed passes found
  // small ellipses. The pre-filter that makes large rings' edges precise closes the inner
  // circles of sets 5-8 px across and reads their ratios low (a set named as its neighbour in
  // ratio); the frame (then the deconvolved frame, if any) is searched again without it,
  // under the same gates. Frames detected with the filter are untouched.
  if (!d.detected && params_.unfiltered_pass && params_.gaussian_sigma_px > 0 &&
      full.width >= 16 && full.height >= 16) {
    int small = 0;
    for (const auto& e : d.ellipses) small += e.image.b <= params_.unfiltered_max_minor_px;
    if (small >= params_.unfiltered_min_ellipses) {
      whole_grey();
      VisionParams pu = params_;
      pu.gaussian_sigma_px = 0.0;
      for (const cv::Mat* frame : {&grey, &sharp}) {
        if (frame->empty()) continue;
        const bool deconvolved = frame == &sharp;
        RingDetection du;
        std::vector<EllipseCandidate> cu;
        const std::string what = deconvolved ? "unfiltered pass on the deconvolved frame"
                                             : "unfiltered pass";
        if (search_region(*frame, full, camera_, target_, pu, du, cu)) {
          du.reason = what + ": " + du.reason + " (pre-filtered: " + d.reason + ")";
          du.unfiltered = true;
          du.deblurred = deconvolved;
          d = std::move(du);
          cands = std::move(cu);
          break;
        }
        d.reason += "; " + what + ": " + du.reason;
      }
    }
  }
  // Zoomed pass (issue 12: far and grazing views): no pose, and the failed passes found small
  // ellipses in a cluster: the cluster's region magnified twice (bicubic) and searched again
  // with the camera model of the magnified region, under the same gates in its pixels (so
  // twice as strict in the frame's). At 10-15 m and 45-60 deg the ring sets are 5-8 px across
  // and the thin annuli's contours break or merge at the frame's resolution.
  if (!d.detected && params_.zoom_pass && full.width >= 16 && full.height >= 16) {
    whole_grey();
    constexpr int kZoom = 2;
    std::string tried;
    for (const cv::Rect& region : zoom_regions(d.ellipses, full, params_)) {
      cv::Mat zoomed;
      cv::resize(grey(region), zoomed, cv::Size(), kZoom, kZoom, cv::INTER_CUBIC);
      const CameraModel zcam = vision_internal::zoomed_camera(camera_, region, kZoom);
      RingDetection dz;
      std::vector<EllipseCandidate> cz;
      const bool ok = search_region(zoomed, cv::Rect(0, 0, zoomed.cols, zoomed.rows), zcam, target_,
                                    params_, dz, cz);
      std::ostringstream os;
      os << "zoomed x" << kZoom << " on " << region.width << "x" << region.height << " px at ("
         << region.x << ", " << region.y << ")";
      if (ok) {
        unzoom(dz, cz, region, kZoom);
        dz.reason = os.str() + ": " + dz.reason + " (frame: " + d.reason + ")";
        dz.zoomed = true;
        d = std::move(dz);
        cands = std::move(cz);
        break;
      }
      tried += "; " + os.str() + ": " + dz.reason;
    }
    if (!d.detected) d.reason += tried;
  }
  // Platform pass (issue 12: far and grazing views; vision internal platform.cpp): no pose,
  // and the frame shows a bright quadrilateral that may be the platform's top. Its outline
  // predicts the ring sets' outer circles (two placements of the hexagon in the square); the
  // guesses are refined to sub-pixel edges and identified and gated as contours' ellipses
  // are, with the pre-filter and then without it (small sets, as the unfiltered pass).
  if (!d.detected && params_.platform_pass && full.width >= 16 && full.height >= 16) {
    whole_grey();
    std::string tried;
    for (const auto& q : vision_internal::platform_quads(grey, params_)) {
      double x0 = q.corners[0].x(), x1 = x0, y0 = q.corners[0].y(), y1 = y0;
      for (const auto& c : q.corners) {
        x0 = std::min(x0, c.x()), x1 = std::max(x1, c.x());
        y0 = std::min(y0, c.y()), y1 = std::max(y1, c.y());
      }
      const double gx = 0.25 * (x1 - x0) + 8, gy = 0.25 * (y1 - y0) + 8;
      const cv::Rect region = covering_rect(x0 - gx, y0 - gy, x1 + gx, y1 + gy, full);
      std::ostringstream os;
      os << "platform pass on " << static_cast<int>(x1 - x0) << "x" << static_cast<int>(y1 - y0)
         << " px at (" << static_cast<int>(x0) << ", " << static_cast<int>(y0) << ")";
      for (int placement = 0; placement < 2 && !d.detected; ++placement) {
        const vision_internal::PlatformGuesses guesses{
            vision_internal::platform_set_guesses(q, placement, camera_, target_), q};
        for (const double sigma : {params_.gaussian_sigma_px, 0.0}) {
          VisionParams pp = params_;
          pp.gaussian_sigma_px = sigma;
          RingDetection dq;
          std::vector<EllipseCandidate> cq;
          bool ok = run_region(grey, region, camera_, target_, pp, dq, cq, false, &guesses);
          if (ok) {
            const double err =
                vision_internal::platform_corner_error_px(q, dq.X_CP, camera_, target_);
            const double gate = vision_internal::platform_corner_gate_px(q);
            if (!(err <= gate)) {
              ok = false;
              std::ostringstream oc;
              oc << "the pose puts the top's corners " << err << " px off its outline (gate "
                 << gate << " px): " << dq.reason;
              dq.detected = false;
              dq.status = VisionStatus::PoseFailed;
              dq.reason = oc.str();
            }
          }
          if (ok) {
            dq.reason = os.str() + ", placement " + std::to_string(placement) +
                        (sigma > 0 ? "" : ", unfiltered") + ": " + dq.reason +
                        " (frame: " + d.reason + ")";
            dq.by_platform = true;
            d = std::move(dq);
            cands = std::move(cq);
            break;
          }
          tried += "; " + os.str() + ", placement " + std::to_string(placement) +
                   (sigma > 0 ? "" : ", unfiltered") + ": " + dq.reason;
          if (params_.gaussian_sigma_px <= 0) break;
        }
      }
      if (d.detected) break;
    }
    if (!d.detected) d.reason += tried;
  }
  // The track (the last pose) informs this frame only when tracking is on: with it off each
  // frame stands alone (single images, the estimator benchmark's independent views).
  const Eigen::Isometry3d* track = params_.tracking && have_prediction_ ? &X_CP_pred_ : nullptr;
  // Code map (seed 001): searched unless the pose (this frame's rings, else the track) shows
  // its cells smaller than code_min_cell_px.
  if (params_.code_enabled && target_.code.cells > 0 && full.width >= 16 && full.height >= 16) {
    const Eigen::Isometry3d* ref = d.detected ? &d.X_CP : track;
    bool search = true;
    if (ref != nullptr) {
      const double z = ref->translation().z();
      search = z > 0 && target_.code.cell_m * camera_.fx_px / z >= params_.code_min_cell_px;
    }
    if (search) {
      d.code_searched = true;
      const auto region = ref != nullptr && params_.code_search_region
                              ? code_region(*ref, camera_, target_, params_, full)
                              : std::nullopt;
      const Eigen::Isometry3d* prior = params_.code_lattice_from_pose ? ref : nullptr;
      if (region) {
        if (!grey_full) grey_region(image, *region, grey);
        d.code = detect_code_pattern(grey, camera_, target_, params_, *region, prior);
        d.code_region = *region;
      }
      // A region from the track (a frame old) may have missed the map: the whole frame then,
      // without the track's prediction of the grid lines (it may be what missed). Without a
      // region (close, the map fills the view), the whole frame with the prediction, and
      // without it too when it came from the track and missed.
      if (!region || (!d.code.detected && !d.detected)) {
        whole_grey();
        d.code = detect_code_pattern(grey, camera_, target_, params_, region ? nullptr : prior);
        d.code_region = cv::Rect();
        if (!d.code.detected && !region && prior != nullptr && !d.detected) {
          d.code = detect_code_pattern(grey, camera_, target_, params_);
        }
      }
    }
  }
  combine_sources(d, cands, camera_.K(), target_, params_, track);
  // Whatever gave the pose (rings, the code, the centre ring, combined), it must show the
  // camera in front of the target's top (faces_camera).
  if (d.detected && !faces_camera(d.X_CP)) {
    d.detected = false;
    d.status = VisionStatus::PoseFailed;
    d.reason = std::string(to_string(d.source)) +
               " pose rejected: it puts the camera behind the target's surface (" + d.reason + ")";
  }
  // Whatever gave the pose, its ring identities must fit the outer sets' radial profiles
  // better than every turn of the layout onto itself (rotation_check.cpp). Not needed for a
  // pose within half the layout's smallest turn (60 deg) of the track: the track's pose was
  // checked or followed a checked one, so identities turned by a whole turn would put this
  // pose at least 30 deg from it (it saves the check's 0.2-0.3 ms in tracked frames).
  constexpr double kTrackedMaxTurnRad = 30.0 * M_PI / 180.0;
  const bool follows_track =
      track != nullptr &&
      Eigen::AngleAxisd(track->linear().transpose() * d.X_CP.linear()).angle() < kTrackedMaxTurnRad;
  if (d.detected && params_.rotation_check && !follows_track) {
    auto grey_of = [&](const cv::Rect& r) {
      if (!grey_full) grey_region(image, r, grey);
      return grey;
    };
    const auto rc = vision_internal::check_set_rotation(image.size(), grey_of, camera_, target_,
                                                        d.X_CP, params_.rotation_check_margin);
    if (!rc.passed) {
      d.detected = false;
      d.status = VisionStatus::PoseFailed;
      d.reason = std::string(to_string(d.source)) + " pose rejected: " + rc.verdict + " (margin " +
                 std::to_string(params_.rotation_check_margin) +
                 "): ring identities read wrongly (" + d.reason + ")";
    } else if (rc.checked) {
      d.reason += "; " + rc.verdict;
    }
  }

  // Tracking state: constant-pose prediction, dropped after a few misses.
  if (d.detected) {
    have_prediction_ = true;
    X_CP_pred_ = d.X_CP;
    misses_ = 0;
  } else if (++misses_ > params_.max_frames_without_detection) {
    have_prediction_ = false;
  }
  // Keyframe selection, eq. (17)-(18).
  if (!d.detected) {
    d.keyframe_status = KeyframeStatus::NotDetected;
  } else if (!have_keyframe_) {
    d.keyframe = true;
    d.keyframe_status = KeyframeStatus::First;
  } else {
    d.rho = keyframe_rho(X_CP_key_, d.X_CP);
    if (d.rho <= params_.rho_max) {
      d.keyframe = true;
      d.keyframe_status = KeyframeStatus::Accepted;
    } else if (++rejections_ > params_.keyframe_reset_after) {
      d.keyframe = true;
      d.keyframe_status = KeyframeStatus::Restarted;
    } else {
      d.keyframe_status = KeyframeStatus::Rejected;
    }
  }
  if (d.keyframe) {
    have_keyframe_ = true;
    X_CP_key_ = d.X_CP;
    rejections_ = 0;
  }
  return finish();
}

RingDetection detect_ring_target(const cv::Mat& image, const CameraModel& camera,
                                 const TargetGeometry& target, const VisionParams& params,
                                 const Eigen::Vector2d& blur_px) {
  VisionParams p = params;
  p.tracking = false;
  RingTargetDetector det(camera, target, p);
  return det.detect(image, blur_px);
}

PlatformObservation to_platform_observation(const RingDetection& d, double t_s) {
  PlatformObservation o;
  o.t_s = t_s;
  o.detected = d.detected;
  o.keyframe = d.keyframe;
  o.X_CP = d.X_CP;
  o.cov = d.cov;
  o.rings_identified = static_cast<int>(d.centres.size());
  o.reproj_err_px = d.reproj_err_px;
  return o;
}

std::string to_json(const RingDetection& d) {
  using Json = nlohmann::ordered_json;  // NaN and infinities are written as null
  const Eigen::Quaterniond q(d.X_CP.linear());
  const Eigen::Vector3d p = d.X_CP.translation();
  Json j;
  j["detected"] = d.detected;
  j["status"] = to_string(d.status);
  j["reason"] = d.reason;
  j["source"] = to_string(d.source);
  j["code"] = {{"searched", d.code_searched},
               {"region", d.code_region.area() > 0
                              ? Json::array({d.code_region.x, d.code_region.y,
                                             d.code_region.width, d.code_region.height})
                              : Json(nullptr)},
               {"detected", d.code.detected},
               {"reason", d.code.reason},
               {"cells_read", d.code.cells_read},
               {"local_white", d.code.local_white},
               {"corners", d.code.corners_px.size()},
               {"rotation", d.code.placement.rotation},
               {"reproj_rms_px", d.code.reproj_rms_px},
               {"reproj_gate_px", d.code.reproj_gate_px}};
  j["p_CP_m"] = {p.x(), p.y(), p.z()};
  j["q_CP_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
  Json cov = Json::array();
  for (int r = 0; r < 6; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 6; ++c) row.push_back(d.cov(r, c));
    cov.push_back(row);
  }
  j["cov_rot_trans"] = cov;
  j["reproj_err_px"] = d.reproj_err_px;
  j["reproj_err_sum_px2"] = d.reproj_err_sum_px2;
  j["edge_rms_px"] = d.edge_rms_px;
  j["reproj_gate_px"] = d.reproj_gate_px;  // the gates passed (or failed last; 0: no pose tried)
  j["edge_gate_px"] = d.edge_gate_px;
  j["keyframe"] = d.keyframe;
  j["keyframe_status"] = to_string(d.keyframe_status);
  j["rho"] = d.rho;
  j["used_roi"] = d.used_roi;
  j["deblurred"] = d.deblurred;
  j["unfiltered"] = d.unfiltered;
  j["zoomed"] = d.zoomed;
  j["by_layout"] = d.by_layout;
  j["by_platform"] = d.by_platform;
  j["roi"] = {d.roi.x, d.roi.y, d.roi.width, d.roi.height};
  j["time_ms"] = d.time_ms;
  Json centres = Json::array();
  for (const auto& c : d.centres) {
    centres.push_back({{"ring_id", c.ring_id},
                       {"centre_px", {c.centre_px.x(), c.centre_px.y()}},
                       {"centre_image_px", {c.centre_image_px.x(), c.centre_image_px.y()}},
                       {"radius_ratio", c.radius_ratio}});
  }
  j["centres"] = centres;
  Json ellipses = Json::array();
  for (const auto& e : d.ellipses) {
    ellipses.push_back({{"ring_id", e.ring_id},
                        {"outer", e.outer},
                        {"centre_px", {e.image.centre.x(), e.image.centre.y()}},
                        {"axes_px", {e.image.a, e.image.b}},
                        {"angle_rad", e.image.angle_rad},
                        {"fit_rms_px", e.fit_rms_px}});
  }
  j["ellipses"] = ellipses;
  // Invalid UTF-8 in a reason (never expected) is replaced rather than thrown.
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

CameraModel load_camera_model(const std::string& path) {
  CameraModel cam;
  read_params(load_yaml_file(path), path, cam);
  return cam;
}

}  // namespace lander
