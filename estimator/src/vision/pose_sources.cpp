// The ring and code poses combined (the public header's steps 8-9): rings and code refined
// together when they agree, the central ring set's closed-form pose when fewer than min_rings
// sets are identified, else the code map's pose alone.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "vision/detector_stages.h"

namespace lander::vision_internal {

// A pose with the camera behind the top cannot show the pattern, yet a planar fit admits one:
// two ring sets that swap identities mirror the layout, and the mirrored layout seen from
// behind fits it exactly (an independent ray-traced frame at 14.8 m with 11 grey levels of
// noise: sets 3 and 5 read as each other, the pose 180 deg off with 0.05 px of reprojection
// error).
bool faces_camera(const Eigen::Isometry3d& X_CP) {
  return X_CP.translation().z() > 0 && X_CP.linear().col(2).dot(X_CP.translation()) < 0;
}

bool poses_agree(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const VisionParams& p) {
  const double ang = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
  const double dist = (a.translation() - b.translation()).norm();
  return ang <= p.combine_max_angle_rad &&
         dist <= p.combine_max_offset_ratio * std::max(a.translation().norm(), 0.05);
}

Eigen::Vector2d project(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP,
                        const Eigen::Vector2d& c_P) {
  const Eigen::Vector3d p = K * (X_CP * Eigen::Vector3d(c_P.x(), c_P.y(), 0.0));
  return p.head<2>() / p.z();
}

namespace {

// Closed-form pose of the central ring set (P origin) from its concentric pair: the projected
// centre c (harmonic / Kim-Gurdjos-Kweon), the vanishing line as the polar of c w.r.t. the
// outer conic (pole-polar: the polar of a circle's centre is the line at infinity of its
// plane), the plane normal n ~ K^T l, the depth from the known radii (each edge point's ray
// meets the plane at distance R from the centre), and the in-plane axis r1 from `x_dir`
// (a camera-frame direction to be P's +x after projection onto the plane).
std::optional<Eigen::Isometry3d> centre_pair_pose(const Eigen::Matrix3d& K, const Conic& C_outer,
                                                  const Eigen::Vector2d& c_px,
                                                  const std::vector<ConicObservation>& circles) {
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

// What the combination reads of the ring result: the identified sets' conics, the central
// set and another one, the gates the sets' extent scales, and the code's corners.
struct RingEvidence {
  std::vector<ConicObservation> obs;
  const IdentifiedCentre* centre0{nullptr};
  const IdentifiedCentre* other{nullptr};
  RingGates gates{0.0, 0.0};
  std::vector<PointObservation> pts;
};
RingEvidence ring_evidence(const RingDetection& d, const std::vector<EllipseCandidate>& cands,
                           const TargetGeometry& target, const VisionParams& p) {
  RingEvidence ev;
  // Conic observations of every identified set.
  for (const auto& c : d.centres) {
    if (c.outer_index < 0 || c.inner_index < 0 || c.outer_index >= static_cast<int>(cands.size()) ||
        c.inner_index >= static_cast<int>(cands.size())) {
      continue;
    }
    const RingSet& ring = target.ring(c.ring_id);
    ev.obs.push_back({ring.centre_P_m, ring.outer_radius_m, &cands[c.outer_index].points});
    ev.obs.push_back({ring.centre_P_m, ring.inner_radius_m, &cands[c.inner_index].points});
    if (ring.centre_P_m.norm() < 1e-9) {
      ev.centre0 = &c;
    } else if (ev.other == nullptr) {
      ev.other = &c;
    }
  }
  // The gates scale with the identified sets' extent (scaled_gate).
  std::vector<SetImage> set_images;
  for (const auto& c : d.centres) {
    if (c.outer_index < 0 || c.outer_index >= static_cast<int>(cands.size())) continue;
    const EllipseParams& outer = cands[c.outer_index].undist;
    set_images.push_back({c.centre_px, outer.a, outer.b});
  }
  ev.gates = ring_gates(p, ring_extent_px(set_images));
  if (d.code.detected) {
    for (std::size_t i = 0; i < d.code.corners_px.size(); ++i) {
      ev.pts.push_back({d.code.corners_P_m[i], d.code.corners_px[i]});
    }
  }
  return ev;
}

// One acceptance rule for every ring-based pose (rings + code, centre ring, centre ring +
// code): the ring centres' reprojection RMS (eq. 30) within the main path's gate
// (max_reproj_err_px, grown with the sets' extent by max_reproj_fraction). A pose beyond it
// is not reported (returns false, d unchanged but for the reason): at grazing views a small
// outer ring taken for the centre ring gave a pose 115 deg off with 16 px.
bool accept(RingDetection& d, const RefineResult& ref, PoseSource src, const std::string& why,
            const Eigen::Matrix3d& K, const TargetGeometry& target, const RingGates& gates) {
  double sum = 0.0;
  for (const auto& c : d.centres) {
    sum += (project(K, ref.X_CP, target.ring(c.ring_id).centre_P_m) - c.centre_px).squaredNorm();
  }
  const double reproj =
      d.centres.empty() ? d.code.reproj_rms_px : std::sqrt(sum / d.centres.size());
  const double gate = d.centres.empty() ? d.code.reproj_gate_px : gates.reproj_px;
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
  d.edge_gate_px = gates.edge_px;
  d.detected = true;
  d.status = VisionStatus::Detected;
  d.source = src;
  d.reason = why;
  return true;
}

// A ring pose and the code: refined together if the two agree, else the rings alone.
void rings_with_code(RingDetection& d, const RingEvidence& ev, const Eigen::Matrix3d& K,
                     const TargetGeometry& target, const VisionParams& p) {
  if (!d.code.detected) return;
  if (!poses_agree(d.X_CP, d.code.X_CP, p)) {
    d.reason += "; code pose disagrees with the rings, not used";
    return;
  }
  const auto ref = refine_pose_conics(K, d.X_CP, ev.obs, p.refine_points_per_ellipse,
                                      p.refine_max_iter, &ev.pts);
  if (ref.ok && ref.rms_px <= ev.gates.edge_px) {
    accept(d, ref, PoseSource::Combined, d.reason + " + " + d.code.reason, K, target, ev.gates);
  }
}

// Where the central pair's yaw came from ("" when nothing gives it), with the track's prior.
struct CentreYaw {
  std::string from;
  std::optional<YawPrior> prior;
};
// Sets the yaw of the central pair's pose X0: from another set's centre on the plane, else the
// code, else the tracked pose (then also a prior on it).
CentreYaw centre_pair_yaw(Eigen::Isometry3d& X0, const RingDetection& d, const RingEvidence& ev,
                          const Eigen::Matrix3d& K, const TargetGeometry& target,
                          const VisionParams& p, const Eigen::Isometry3d* tracked) {
  CentreYaw yaw;
  if (ev.other != nullptr) {
    // The other set's centre on the plane fixes the in-plane rotation.
    const IdentifiedCentre* other = ev.other;
    const Eigen::Matrix3d Ki = K.inverse();
    const Eigen::Vector3d n = X0.linear().col(2), t = X0.translation();
    const Eigen::Vector3d rj = Ki * Eigen::Vector3d(other->centre_px.x(), other->centre_px.y(), 1);
    const Eigen::Vector3d Xj = (n.dot(t) / n.dot(rj)) * rj;
    const Eigen::Vector3d v = (Xj - t).normalized();
    const Eigen::Vector2d q = target.ring(other->ring_id).centre_P_m.normalized();
    // v = q.x r1 + q.y r2 with r2 = n x r1  =>  r1 = q.x v - q.y (n x v).
    set_yaw(X0, q.x() * v - q.y() * n.cross(v));
    yaw.from = "ring set " + std::to_string(other->ring_id);
  } else if (d.code.detected) {
    set_yaw(X0, d.code.X_CP.linear().col(0));
    yaw.from = "code";
  } else if (tracked != nullptr) {
    set_yaw(X0, tracked->linear().col(0));
    yaw.prior = YawPrior{X0.linear(), p.tracked_yaw_sigma_rad};
    yaw.from = "tracked pose";
  }
  return yaw;
}

// The central pair's pose refined: `ok` when it passes the conic gate (and agrees with the
// code where it must), `with_code` when the code's corners joined, `note` for the reason.
struct CentreRefined {
  RefineResult ref;
  bool ok{false};
  bool with_code{false};
  std::string note;
};
// Rings first (yaw from a set or the track), then the code joins if it agrees; with
// the yaw from the code itself, conics and corners are refined together.
CentreRefined refine_centre_pair(const Eigen::Isometry3d& X0, const CentreYaw& yaw,
                                 const RingDetection& d, const RingEvidence& ev,
                                 const Eigen::Matrix3d& K, const VisionParams& p) {
  const bool code_yaw = yaw.from == "code";
  CentreRefined c;
  c.ref = refine_pose_conics(K, X0, ev.obs, p.refine_points_per_ellipse, p.refine_max_iter,
                             code_yaw ? &ev.pts : nullptr, yaw.prior ? &*yaw.prior : nullptr);
  c.ok = c.ref.ok && c.ref.rms_px <= ev.gates.edge_px;
  c.with_code = code_yaw;
  if (c.ok && !code_yaw && d.code.detected) {
    if (poses_agree(c.ref.X_CP, d.code.X_CP, p)) {
      const auto both = refine_pose_conics(K, c.ref.X_CP, ev.obs, p.refine_points_per_ellipse,
                                           p.refine_max_iter, &ev.pts);
      if (both.ok && both.rms_px <= ev.gates.edge_px) {
        c.ref = both;
        c.with_code = true;
      }
    } else {
      c.note = "; code pose disagrees with the rings, not used";
    }
  }
  if (c.ok && code_yaw && !poses_agree(c.ref.X_CP, d.code.X_CP, p)) c.ok = false;
  return c;
}

// A lone central pair with the track's yaw has nothing else to check it (its one
// centre reprojects onto itself): in blurred frames another set read as the central
// one gave poses 30 % and 88 % off in range. It must stay near the track.
bool near_track(const RefineResult& ref, const Eigen::Isometry3d& tracked,
                const VisionParams& p, RingDetection& d) {
  const double jump = (ref.X_CP.translation() - tracked.translation()).norm();
  const double gate =
      p.tracked_max_jump_m + p.tracked_max_jump_ratio * tracked.translation().norm();
  if (jump <= gate) return true;
  std::ostringstream os;
  os << "; centre pair with the track's yaw is " << jump << " m from the tracked pose (gate "
     << gate << " m): not used";
  d.reason += os.str();
  return false;
}

// Fewer than min_rings sets: the central pair gives normal, centre and depth, the yaw from
// another set, the code or the track; true when its pose was accepted.
bool centre_ring_pose(RingDetection& d, const std::vector<EllipseCandidate>& cands,
                      const RingEvidence& ev, const Eigen::Matrix3d& K,
                      const TargetGeometry& target, const VisionParams& p,
                      const Eigen::Isometry3d* tracked) {
  std::vector<ConicObservation> c0obs;
  for (const auto& o : ev.obs) {
    if (o.c_P_m.norm() < 1e-9) c0obs.push_back(o);
  }
  auto X0 = centre_pair_pose(K, cands[ev.centre0->outer_index].C, ev.centre0->centre_px, c0obs);
  if (!X0) return false;
  const CentreYaw yaw = centre_pair_yaw(*X0, d, ev, K, target, p, tracked);
  if (yaw.from.empty()) {
    d.reason += "; central pair seen but no yaw (no other set, code or track)";
    return false;
  }
  CentreRefined c = refine_centre_pair(*X0, yaw, d, ev, K, p);
  // The yaw came from the track (its prior).
  if (c.ok && yaw.prior && !c.with_code) c.ok = near_track(c.ref, *tracked, p, d);
  if (!c.ok) return false;
  std::ostringstream os;
  os << d.centres.size() << " ring sets identified (centre pair, yaw from " << yaw.from << ")";
  if (c.with_code) os << " + " << d.code.reason;
  os << c.note;
  if (accept(d, c.ref, c.with_code ? PoseSource::Combined : PoseSource::CentreRing, os.str(), K,
             target, ev.gates)) {
    return true;
  }
  if (!d.code.detected) d.status = VisionStatus::ReprojectionTooLarge;
  return false;
}

// The code map's pose alone.
void use_code_pose(RingDetection& d) {
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

}  // namespace

void combine_sources(RingDetection& d, const std::vector<EllipseCandidate>& cands,
                     const Eigen::Matrix3d& K, const TargetGeometry& target,
                     const VisionParams& p, const Eigen::Isometry3d* tracked) {
  const RingEvidence ev = ring_evidence(d, cands, target, p);
  if (d.detected) return rings_with_code(d, ev, K, target, p);
  if (p.centre_ring_pose && ev.centre0 != nullptr && d.status == VisionStatus::TooFewRings &&
      centre_ring_pose(d, cands, ev, K, target, p, tracked)) {
    return;
  }
  if (d.code.detected) use_code_pose(d);
}

}  // namespace lander::vision_internal
