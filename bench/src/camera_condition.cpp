// The camera condition of `lander bench estimator` (issue 54): camera_condition.h.
#include "camera_condition.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <ostream>
#include <random>
#include <string>
#include <utility>

#include "lander/bench/peer_detectors.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/sensors/jpeg.h"

namespace lander::bench::detail {
namespace {

// The camera's motion over one frame: its pose at the frame's middle instant, its velocity and
// angular rate (W), constant over the readout.
struct FrameMotion {
  Eigen::Isometry3d X_WC_mid{Eigen::Isometry3d::Identity()};
  Eigen::Vector3d v_W{Eigen::Vector3d::Zero()};
  Eigen::Vector3d w_W{Eigen::Vector3d::Zero()};

  // The pose t_s after the middle instant: rotated by w t about the camera centre, moved by v t.
  Eigen::Isometry3d at(double t_s) const {
    Eigen::Isometry3d X = X_WC_mid;
    const double angle = w_W.norm() * t_s;
    if (angle != 0.0) X.linear() = Eigen::AngleAxisd(angle, w_W.normalized()).toRotationMatrix() * X.linear();
    X.translation() += v_W * t_s;
    return X;
  }
};

// A camera of the condition: its readout (0 = global shutter) and JPEG quality (0 = lossless).
struct CameraKind {
  const char* name;
  double readout_s;
  int jpeg_quality;
};

// Time of image row `row` relative to the frame's middle instant: row v of H is read
// readout x v / H after row 0 (the simulator's rolling shutter and the flight software's
// observation time use the same rule).
double row_offset_s(double row, int rows, double readout_s) {
  return readout_s * (std::clamp(row, 0.0, rows - 1.0) / rows - 0.5);
}

// A method's detection in common form: pose, RMS reprojection, its points (P coordinates and
// where they were found in the image), its thread CPU time, and why it found none.
struct Found {
  bool detected{false};
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};
  double reproj_px{0.0};
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> points;
  double ms{0.0};
  std::string status, reason;
};

Found from_rings(const RingDetection& d, const TargetGeometry& g, double ms) {
  Found f{d.detected, d.X_CP, d.reproj_err_px, {}, ms, to_string(d.status), d.reason};
  for (const auto& c : d.centres) {
    for (const auto& r : g.rings) {
      if (r.id == c.ring_id) f.points.emplace_back(r.centre_P_m, c.centre_image_px);
    }
  }
  return f;
}

Found from_square(const PeerDetection& d, const std::vector<Eigen::Vector2d>& corners_P, double ms) {
  Found f{d.detected, d.X_CP, d.reproj_err_px, {}, ms, "", d.reason};
  for (int i = 0; i < 4; ++i) f.points.emplace_back(corners_P[i], d.corners_px[i]);
  return f;
}

// Per camera and method: every frame, the frames with the whole target in view (truth at the
// middle instant and at the platform centre's row) and those by altitude.
struct Groups {
  Stats all, in_view, in_view_row_time;
  std::map<double, Stats> by_alt;
};

constexpr int kMethods = 4;
constexpr std::array<const char*, kMethods> kMethodKeys{"ours", "apriltag", "aruco", "aruco_subpix"};

class CameraCondition {
 public:
  CameraCondition(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP, const TargetGeometry& g,
                  const CameraModel& cam, const VisionParams& vision, const EstimatorBenchParams& p)
      : render_(render), X_WP_(X_WP), g_(g), cam_(cam), p_(p), ours_(cam, g, single_frame(vision)),
        cameras_{{{"global", 0.0, 0},
                  {"jpeg", 0.0, p.camera_jpeg_quality},
                  {"rolling_shutter", 1e-3 * p.camera_readout_ms, 0},
                  {"rolling_shutter+jpeg", 1e-3 * p.camera_readout_ms, p.camera_jpeg_quality}}},
        groups_(cameras_.size()) {
    const auto corners = marker_corners_P(g);
    corners_P_.assign(corners.begin(), corners.end());
  }

  // One view: every camera's frames of the three markers, every method on them, scored.
  void run_view(double alt, double tilt, const FrameMotion& m) {
    const bool in_view = target_in_view(cam_, m.X_WC_mid.inverse() * X_WP_, g_, corners_P_);
    ++views_;
    in_view_views_ += in_view;
    std::map<double, std::array<cv::Mat, 3>> shot;  // by readout: rings, AprilTag, ArUco
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      const CameraKind& k = cameras_[c];
      auto it = shot.find(k.readout_s);
      if (it == shot.end()) {
        it = shot.emplace(k.readout_s, std::array<cv::Mat, 3>{frame(MarkerKind::Rings, m, k.readout_s),
                                                               frame(MarkerKind::AprilTag, m, k.readout_s),
                                                               frame(MarkerKind::Aruco, m, k.readout_s)})
                 .first;
      }
      std::array<cv::Mat, 3> img = it->second;
      if (k.jpeg_quality > 0) {
        for (auto& i : img) i = sim::jpeg_round_trip(i, k.jpeg_quality);
      }
      const std::array<Found, kMethods> found = detect(img);
      for (int mi = 0; mi < kMethods; ++mi) score(groups_[c][mi], found[mi], m, k.readout_s, alt, in_view);
      if (in_view && !found[0].detected) {
        Json miss = Json::object();
        miss["view"] = views_ - 1;
        miss["camera"] = k.name;
        miss["altitude_m"] = alt;
        miss["tilt_deg"] = tilt;
        miss["status"] = found[0].status;
        miss["reason"] = found[0].reason;
        misses_.push_back(std::move(miss));
      }
    }
  }

  Json json() const;
  void print_table(std::ostream& out) const;
  // Ours through the last camera (the seed's: rolling shutter and JPEG) at `alt`, in view.
  const Stats& ours_through_seed_camera(double alt) { return groups_.back()[0].by_alt[alt]; }

 private:
  static VisionParams single_frame(VisionParams v) {
    v.tracking = false;
    return v;
  }

  // The frame a camera with `readout_s` takes of marker `kind` during motion m: one render at
  // the middle instant (global shutter), or camera_bands bands of rows, each rendered at the
  // time of its centre row.
  cv::Mat frame(MarkerKind kind, const FrameMotion& m, double readout_s) {
    if (readout_s <= 0) return render_(m.at(0.0), kind, 0.0);
    const int H = cam_.height_px, n = std::min(p_.camera_bands, H);
    cv::Mat out;
    for (int b = 0; b < n; ++b) {
      const int row0 = H * b / n, row1 = H * (b + 1) / n;
      if (row1 <= row0) continue;
      const cv::Mat band = render_(m.at(row_offset_s(0.5 * (row0 + row1 - 1), H, readout_s)), kind, 0.0);
      if (out.empty()) out.create(band.size(), band.type());
      band.rowRange(row0, row1).copyTo(out.rowRange(row0, row1));
    }
    return out;
  }

  std::array<Found, kMethods> detect(const std::array<cv::Mat, 3>& img) {
    std::array<Found, kMethods> f;
    double ms = 0.0;
    const RingDetection d = timed([&] { return ours_.detect(img[0]); }, ms);
    f[0] = from_rings(d, g_, ms);
    const PeerDetection dt = timed([&] { return apriltag_.detect(img[1], cam_, g_); }, ms);
    f[1] = from_square(dt, corners_P_, ms);
    const PeerDetection da = timed([&] { return detect_aruco(img[2], cam_, g_, false); }, ms);
    f[2] = from_square(da, corners_P_, ms);
    const PeerDetection ds = timed([&] { return detect_aruco(img[2], cam_, g_, true); }, ms);
    f[3] = from_square(ds, corners_P_, ms);
    return f;
  }

  // Where P point q projects in a frame read with `readout_s`: at the pose of its own row's
  // time (found by fixed-point iteration from the row it was detected on).
  Eigen::Vector2d true_px(const Eigen::Vector2d& q, double row_guess, const FrameMotion& m, double readout_s) const {
    Eigen::Vector2d px(0.0, row_guess);
    for (int i = 0; i < (readout_s > 0 ? 3 : 1); ++i) {
      const Eigen::Isometry3d X_CP = m.at(row_offset_s(px.y(), cam_.height_px, readout_s)).inverse() * X_WP_;
      px = project_P(cam_, X_CP, {q}).front();
    }
    return px;
  }

  void score(Groups& G, const Found& f, const FrameMotion& m, double readout_s, double alt, bool in_view) const {
    const Eigen::Isometry3d X_CP_mid = m.at(0.0).inverse() * X_WP_;
    double t_row = 0.0;  // the platform centre's row time, as the flight software computes it
    const Eigen::Vector3d c = f.X_CP.translation();
    if (f.detected && c.z() > 0) t_row = row_offset_s(cam_.fy_px * c.y() / c.z() + cam_.cy_px, cam_.height_px, readout_s);
    const Eigen::Isometry3d X_CP_row = m.at(t_row).inverse() * X_WP_;
    auto add = [&](Stats& s, const Eigen::Isometry3d& truth) {
      ++s.frames;
      s.ms.push_back(f.ms);
      if (!f.detected) return;
      ++s.detected;
      for (const auto& [q, px] : f.points) s.centre_err.push_back((px - true_px(q, px.y(), m, readout_s)).norm());
      add_pose(s, f.reproj_px, f.X_CP, truth);
    };
    add(G.all, X_CP_mid);
    if (!in_view) return;
    add(G.in_view, X_CP_mid);
    add(G.in_view_row_time, X_CP_row);
    add(G.by_alt[alt], X_CP_mid);
  }

  const BenchRenderFn& render_;
  Eigen::Isometry3d X_WP_;
  const TargetGeometry& g_;
  const CameraModel& cam_;
  const EstimatorBenchParams& p_;
  RingTargetDetector ours_;
  AprilTagDetector apriltag_;
  std::vector<Eigen::Vector2d> corners_P_;
  std::vector<CameraKind> cameras_;
  std::vector<std::array<Groups, kMethods>> groups_;
  int views_ = 0, in_view_views_ = 0;
  Json misses_ = Json::array();            // ours' misses of in-view frames
};

Json CameraCondition::json() const {
  Json conditions = Json::object();
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    Json jc = Json::object();
    for (int mi = 0; mi < kMethods; ++mi) {
      const Groups& G = groups_[c][mi];
      Json jm = Json::object();
      jm["in_view"] = G.in_view.json(false);
      jm["in_view_row_time"] = G.in_view_row_time.json(false);
      jm["all"] = G.all.json(false);
      Json a = Json::object();
      for (const auto& [k, st] : G.by_alt) a[MethodStats::key(k)] = st.json(false);
      jm["by_altitude_m"] = a;
      jc[kMethodKeys[mi]] = jm;
    }
    conditions[cameras_[c].name] = jc;
  }
  Json cfg = Json::object();
  cfg["views"] = views_;
  cfg["views_in_view"] = in_view_views_;
  cfg["altitudes_m"] = p_.camera_altitudes_m;
  cfg["tilts_deg"] = p_.camera_tilts_deg;
  cfg["views_per_pose"] = p_.camera_views_per_pose;
  cfg["readout_ms"] = p_.camera_readout_ms;
  cfg["jpeg_quality"] = p_.camera_jpeg_quality;
  cfg["speed_mps"] = p_.camera_speed_mps;
  cfg["rate_dps"] = p_.camera_rate_dps;
  cfg["bands"] = p_.camera_bands;
  cfg["model"] = "each view: the camera moving at speed_mps parallel to the platform (random "
                 "direction) and turning at rate_dps (random axis); global: every row at the "
                 "frame's middle instant; rolling_shutter: row v of H at readout (v/H - 1/2), the "
                 "frame built from `bands` renders; jpeg: an OpenCV/libjpeg round trip at "
                 "jpeg_quality (4:2:0). in_view: truth at the middle instant; in_view_row_time: "
                 "truth at the row of the detected platform centre; centre_err_px: each point "
                 "against its true projection at its own row's time; the platform centre "
                 "placed at a random image point (x in the middle 40 %, y in the middle 70 % of "
                 "the frame); ours_misses: ours' in-view misses, by view index";
  Json out = Json::object();
  out["config"] = cfg;
  out["conditions"] = conditions;
  out["ours_misses"] = misses_;
  return out;
}

void CameraCondition::print_table(std::ostream& out) const {
  auto pad = [](std::string t, std::size_t n) {
    if (t.size() < n) t += std::string(n - t.size(), ' ');
    return t;
  };
  auto cell = [](const Stats& a, const Stats& b) {
    if (a.frames == 0) return std::string("-");
    char buf[64];
    const double rate = static_cast<double>(a.detected) / a.frames;
    if (a.detected == 0) {
      std::snprintf(buf, sizeof buf, "%.2f", rate);
    } else {
      std::snprintf(buf, sizeof buf, "%.2f %.1f/%.1f", rate, 1e3 * summarize(a.pos).mean, 1e3 * summarize(b.pos).mean);
    }
    return std::string(buf);
  };
  out << "\ncamera condition (" << in_view_views_ << " of " << views_
      << " views with the whole target in view): detection rate, mean position error (mm)\n"
         "against the truth at the frame's middle / at the platform centre's row\n";
  out << pad("camera", 22);
  for (const char* m : {"ours", "AprilTag", "ArUco", "ArUco+subpix"}) out << pad(m, 18);
  out << "\n";
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    out << pad(cameras_[c].name, 22);
    for (int mi = 0; mi < kMethods; ++mi) out << pad(cell(groups_[c][mi].in_view, groups_[c][mi].in_view_row_time), 18);
    out << "\n";
  }
}

// X_WC turned about its centre so that the platform's origin projects (no distortion) at
// image point (u, v): under a rolling shutter the row it is read on sets its time.
Eigen::Isometry3d aim_at_image_point(Eigen::Isometry3d X_WC, const Eigen::Isometry3d& X_WP,
                                     const CameraModel& cam, double u, double v) {
  const Eigen::Vector3d p_C = (X_WC.inverse() * X_WP).translation().normalized();
  const Eigen::Vector3d d_C =
      Eigen::Vector3d((u - cam.cx_px) / cam.fx_px, (v - cam.cy_px) / cam.fy_px, 1.0).normalized();
  X_WC.linear() = X_WC.linear() * Eigen::Quaterniond::FromTwoVectors(d_C, p_C).toRotationMatrix();
  return X_WC;
}

}  // namespace

Json run_camera_condition(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP, const TargetGeometry& g,
                          const CameraModel& cam, const VisionParams& vision, const EstimatorBenchParams& p,
                          std::ostream* progress) {
  CameraCondition cc(render, X_WP, g, cam, vision, p);
  // Own random stream: the other conditions draw the same poses with or without this one.
  std::mt19937_64 rng(p.seed + 54);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N(0.0, 1.0);
  for (double alt : p.camera_altitudes_m) {
    for (double tilt : p.camera_tilts_deg) {
      for (int k = 0; k < p.camera_views_per_pose; ++k) {
        const double yaw = 360.0 * U(rng), az = 360.0 * U(rng);
        const double jr = p.aim_jitter_m * std::sqrt(U(rng)), ja = 2 * M_PI * U(rng);
        const Eigen::Vector2d aim(jr * std::cos(ja), jr * std::sin(ja));
        FrameMotion m;
        m.X_WC_mid = aim_at_image_point(X_WP * bench_camera_pose_P(alt, tilt, yaw, az, aim), X_WP,
                                        cam, cam.width_px * (0.3 + 0.4 * U(rng)),
                                        cam.height_px * (0.15 + 0.7 * U(rng)));
        const double heading = 2 * M_PI * U(rng);
        m.v_W = X_WP.linear() * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.0) * p.camera_speed_mps;
        Eigen::Vector3d axis(N(rng), N(rng), N(rng));
        m.w_W = axis.normalized() * (p.camera_rate_dps * M_PI / 180.0);
        cc.run_view(alt, tilt, m);
      }
    }
    if (progress) {
      const Stats& s = cc.ours_through_seed_camera(alt);
      *progress << "bench estimator: camera condition, altitude " << alt << " m done, ours through the "
                << "seed's camera " << s.detected << "/" << s.frames << " in view\n";
    }
  }
  if (progress) cc.print_table(*progress);
  return cc.json();
}

}  // namespace lander::bench::detail
