// The estimator benchmark of issue 3: ours vs AprilTag vs ArUco on frames with known truth.
#include "lander/bench/estimator_bench.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <ostream>
#include <random>
#include <sstream>
#include <ctime>

#include <opencv2/calib3d.hpp>

#include "lander/estimator/camera_cv.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/stats.h"

namespace lander::bench {

using namespace lander::sim;  // output files, statistics

void EstimatorBenchParams::validate() const {
  require(!altitudes_m.empty(), "altitudes_m", "must not be empty");
  for (double a : altitudes_m) require(a > 0, "altitudes_m", "must be > 0");
  require(!tilts_deg.empty(), "tilts_deg", "must not be empty");
  for (double t : tilts_deg) require(t >= 0 && t < 85, "tilts_deg", "must be in [0, 85)");
  require(!blur_px.empty(), "blur_px", "must not be empty");
  for (double b : blur_px) require(b >= 0, "blur_px", "must be >= 0");
  require(yaws_per_view >= 1, "yaws_per_view", "must be >= 1");
  require(empty_frames >= 0, "empty_frames", "must be >= 0");
  require(aim_jitter_m >= 0, "aim_jitter_m", "must be >= 0");
}

Eigen::Isometry3d bench_camera_pose_P(double altitude_m, double tilt_deg, double yaw_deg,
                                      double azimuth_deg, const Eigen::Vector2d& aim_P_m) {
  const double th = tilt_deg * M_PI / 180, az = azimuth_deg * M_PI / 180;
  const Eigen::Vector3d d(std::sin(th) * std::cos(az), std::sin(th) * std::sin(az), std::cos(th));
  const Eigen::Vector3d z = -d;
  Eigen::Vector3d x0 = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z;
  if (x0.norm() < 1e-6) x0 = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(z) * z;
  x0.normalize();
  const Eigen::Vector3d y0 = z.cross(x0);
  const double yaw = yaw_deg * M_PI / 180;
  const Eigen::Vector3d x = std::cos(yaw) * x0 + std::sin(yaw) * y0;
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  X_PC.linear() << x, z.cross(x), z;
  X_PC.translation() = Eigen::Vector3d(aim_P_m.x(), aim_P_m.y(), 0) + (altitude_m / std::cos(th)) * d;
  return X_PC;
}

namespace {

using Json = nlohmann::ordered_json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// CPU time of the calling thread (ms): the per-frame cost on one core, unaffected by other
// processes sharing the machine (wall time is, on a loaded 2-core box, by 2-3x).
double thread_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// Runs f() and returns its result with the thread CPU time it took (ms).
template <class F>
auto timed(F&& f, double& ms) {
  const double t0 = thread_cpu_ms();
  auto r = f();
  ms = thread_cpu_ms() - t0;
  return r;
}

// Metric accumulator for one method and one group of frames.
struct Stats {
  int frames = 0, detected = 0, empty = 0, false_pos = 0;
  std::vector<double> centre_err, reproj, pos, rot, ms, ms_tracking;

  Json json(bool with_tracking) const {
    Json j = Json::object();
    j["detection_rate"] = frames ? static_cast<double>(detected) / frames : kNaN;
    j["false_positive_rate"] = empty ? static_cast<double>(false_pos) / empty : kNaN;
    const SampleSummary reproj_s = summarize(reproj);
    j["centre_err_px_mean"] = summarize(centre_err).mean;
    j["reproj_err_px_mean"] = reproj_s.mean;
    j["reproj_err_px_var"] = reproj_s.var;
    j["pos_err_m_mean"] = summarize(pos).mean;
    j["rot_err_deg_mean"] = summarize(rot).mean;
    j["ms_per_frame_median"] = summarize(ms).median;
    if (with_tracking) j["ms_per_frame_median_tracking"] = summarize(ms_tracking).median;
    j["frames"] = frames;
    j["detected"] = detected;
    j["empty_frames"] = empty;
    j["false_positives"] = false_pos;
    return j;
  }
};

// One method's accumulators: overall, by altitude, by blur.
struct MethodStats {
  Stats overall;
  std::map<double, Stats> by_alt, by_blur;
  template <class F>
  void add(double alt, double blur, F&& f) {
    f(overall);
    f(by_alt[alt]);
    f(by_blur[blur]);
  }
  template <class F>
  void add_empty(double alt, F&& f) {
    f(overall);
    f(by_alt[alt]);
  }
  static std::string key(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  }
  Json json(bool with_tracking) const {
    Json j = Json::object();
    j["overall"] = overall.json(with_tracking);
    Json a = Json::object();
    for (const auto& [k, s] : by_alt) a[key(k)] = s.json(false);
    j["by_altitude_m"] = a;
    Json b = Json::object();
    for (const auto& [k, s] : by_blur) b[key(k)] = s.json(false);
    j["by_blur_px"] = b;
    return j;
  }
};

double rot_err_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

// Raw-image projections of P points (distortion applied).
std::vector<Eigen::Vector2d> project_P(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                                       const std::vector<Eigen::Vector2d>& pts_P) {
  std::vector<cv::Point3d> obj;
  for (const auto& p : pts_P) {
    const Eigen::Vector3d q = X_CP * Eigen::Vector3d(p.x(), p.y(), 0);
    obj.emplace_back(q.x(), q.y(), q.z());
  }
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix_cv(cam),
                    dist_coeffs_cv(cam), img);
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : img) out.emplace_back(p.x, p.y);
  return out;
}

// True if any part of the platform top projects into the image in front of the camera.
bool platform_in_view(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                      const TargetGeometry& g) {
  const double hx = 0.5 * g.platform_size_m.x(), hy = 0.5 * g.platform_size_m.y();
  for (int i = 0; i <= 8; ++i) {
    for (int j = 0; j <= 8; ++j) {
      const Eigen::Vector3d q = X_CP * Eigen::Vector3d(-hx + i * hx / 4, -hy + j * hy / 4, 0);
      if (q.z() <= 0.05) continue;
      const double u = cam.fx_px * q.x() / q.z() + cam.cx_px;
      const double v = cam.fy_px * q.y() / q.z() + cam.cy_px;
      const double m = 0.5 * std::max(cam.width_px, cam.height_px);  // generous margin
      if (u > -m && u < cam.width_px + m && v > -m && v < cam.height_px + m) return true;
    }
  }
  return false;
}

}  // namespace

std::string run_estimator_bench(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP,
                                const TargetGeometry& g, const CameraModel& cam,
                                const VisionParams& vision, const EstimatorBenchParams& p,
                                std::ostream* progress) {
  p.validate();
  cam.validate();
  g.validate();
  VisionParams single = vision;
  single.tracking = false;
  RingTargetDetector ours(cam, g, single);
  AprilTagDetector apriltag;
  MethodStats s_ours, s_tag, s_aruco, s_aruco_sub;
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);

  std::vector<Eigen::Vector2d> ring_centres_P;
  for (const auto& r : g.rings) ring_centres_P.push_back(r.centre_P_m);
  const auto corners = marker_corners_P(g);
  const std::vector<Eigen::Vector2d> corners_P(corners.begin(), corners.end());

  // Square-marker frame: detection, corner error against the true projections, pose error.
  auto score_square = [&](MethodStats& ms, const PeerDetection& d, double cpu_ms,
                          const Eigen::Isometry3d& X_CP, double alt, double blur) {
    const auto truth = project_P(cam, X_CP, corners_P);
    ms.add(alt, blur, [&](Stats& s) {
      ++s.frames;
      s.ms.push_back(cpu_ms);
      if (!d.detected) return;
      ++s.detected;
      for (int i = 0; i < 4; ++i) s.centre_err.push_back((d.corners_px[i] - truth[i]).norm());
      s.reproj.push_back(d.reproj_err_px);
      s.pos.push_back((d.X_CP.translation() - X_CP.translation()).norm());
      s.rot.push_back(rot_err_deg(d.X_CP, X_CP));
    });
  };

  for (double alt : p.altitudes_m) {
    for (double tilt : p.tilts_deg) {
      for (double blur : p.blur_px) {
        for (int k = 0; k < p.yaws_per_view; ++k) {
          const double yaw = 360.0 * U(rng), az = 360.0 * U(rng);
          const double jr = p.aim_jitter_m * std::sqrt(U(rng)), ja = 2 * M_PI * U(rng);
          const Eigen::Vector2d aim(jr * std::cos(ja), jr * std::sin(ja));
          const Eigen::Isometry3d X_WC = X_WP * bench_camera_pose_P(alt, tilt, yaw, az, aim);
          const Eigen::Isometry3d X_CP = X_WC.inverse() * X_WP;

          // Ours: a single-frame (full-frame) search, then the same frame again with a
          // tracking detector primed on it, for the ROI timing.
          const cv::Mat rings = render(X_WC, MarkerKind::Rings, blur);
          double ms_ours = 0.0;
          const RingDetection d = timed([&] { return ours.detect(rings); }, ms_ours);
          double ms_track = kNaN;
          if (d.detected) {
            VisionParams tp = vision;
            tp.tracking = true;
            RingTargetDetector tracker(cam, g, tp);
            tracker.detect(rings);
            double ms2 = 0.0;
            const RingDetection d2 = timed([&] { return tracker.detect(rings); }, ms2);
            if (d2.used_roi) ms_track = ms2;
          }
          const auto truth = project_P(cam, X_CP, ring_centres_P);
          s_ours.add(alt, blur, [&](Stats& s) {
            ++s.frames;
            s.ms.push_back(ms_ours);
            if (!d.detected) return;
            ++s.detected;
            if (std::isfinite(ms_track)) s.ms_tracking.push_back(ms_track);
            for (const auto& c : d.centres) {
              for (std::size_t i = 0; i < g.rings.size(); ++i) {
                if (g.rings[i].id == c.ring_id) {
                  s.centre_err.push_back((c.centre_image_px - truth[i]).norm());
                }
              }
            }
            s.reproj.push_back(d.reproj_err_px);
            s.pos.push_back((d.X_CP.translation() - X_CP.translation()).norm());
            s.rot.push_back(rot_err_deg(d.X_CP, X_CP));
          });

          const cv::Mat tag = render(X_WC, MarkerKind::AprilTag, blur);
          double ms = 0.0;
          const PeerDetection dt = timed([&] { return apriltag.detect(tag, cam, g); }, ms);
          score_square(s_tag, dt, ms, X_CP, alt, blur);
          const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, blur);
          const PeerDetection da = timed([&] { return detect_aruco(aruco, cam, g, false); }, ms);
          score_square(s_aruco, da, ms, X_CP, alt, blur);
          const PeerDetection ds = timed([&] { return detect_aruco(aruco, cam, g, true); }, ms);
          score_square(s_aruco_sub, ds, ms, X_CP, alt, blur);
        }
      }
    }
    if (progress) {
      *progress << "bench estimator: altitude " << alt << " m done, ours "
                << s_ours.by_alt[alt].detected << "/" << s_ours.by_alt[alt].frames << "\n";
    }
  }

  // Frames with no target: the camera over the ground away from the platform, looking down
  // (tilt up to 45 deg); poses where any of the platform could be in view are redrawn.
  for (int i = 0; i < p.empty_frames; ++i) {
    const double alt = p.altitudes_m[i % p.altitudes_m.size()];
    Eigen::Isometry3d X_WC;
    for (int tries = 0;; ++tries) {
      const double r = alt * 2.0 + 4.0 + 30.0 * U(rng), a = 2 * M_PI * U(rng);
      const Eigen::Vector2d aim(r * std::cos(a), r * std::sin(a));
      X_WC = X_WP * bench_camera_pose_P(alt, 45.0 * U(rng), 360.0 * U(rng), 360.0 * U(rng), aim);
      if (!platform_in_view(cam, X_WC.inverse() * X_WP, g) || tries > 100) break;
    }
    const RingDetection d = ours.detect(render(X_WC, MarkerKind::Rings, 0.0));
    s_ours.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += d.detected;
    });
    const bool tag = apriltag.detect(render(X_WC, MarkerKind::AprilTag, 0.0), cam, g).detected;
    s_tag.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += tag;
    });
    const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, 0.0);
    const bool ar = detect_aruco(aruco, cam, g, false).detected;
    const bool ars = detect_aruco(aruco, cam, g, true).detected;
    s_aruco.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += ar;
    });
    s_aruco_sub.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += ars;
    });
  }
  if (progress) *progress << "bench estimator: " << p.empty_frames << " empty frames done\n";

  Json out = Json::object();
  out["ours"] = s_ours.json(true);
  out["apriltag"] = s_tag.json(false);
  Json aruco = s_aruco.json(false);
  aruco["subpix"] = s_aruco_sub.json(false);
  out["aruco"] = aruco;
  Json cfg = Json::object();
  cfg["camera"] = std::to_string(cam.width_px) + "x" + std::to_string(cam.height_px) +
                  " fx " + MethodStats::key(cam.fx_px);
  cfg["marker_side_m"] = marker_side_m(g);
  cfg["yaws_per_view"] = p.yaws_per_view;
  cfg["empty_frames"] = p.empty_frames;
  cfg["seed"] = static_cast<long long>(p.seed);
  cfg["apriltag"] = "tag36h11 id 0, libapriltag 3.3, 1 thread, quad_decimate 1, corners -0.5 px";
  cfg["aruco"] = "DICT_6X6_250 id 0, OpenCV 4.6; aruco = CORNER_REFINE_NONE, aruco.subpix = "
                 "CORNER_REFINE_SUBPIX; both + solvePnP IPPE_SQUARE";
  cfg["ms_per_frame"] = "thread CPU time of one detection (+ PnP), one thread";
  cfg["reproj_err"] = "per-frame RMS of detected points vs the fitted pose (eq. 30 / N, sqrt)";
  out["config"] = cfg;
  return json_text(out);
}

BenchRenderFn make_synthetic_bench_renderer(const TargetGeometry& g, const CameraModel& cam,
                                            const Eigen::Isometry3d& X_WP) {
  auto views = std::make_shared<std::map<MarkerKind, std::unique_ptr<SyntheticPlatformView>>>();
  for (auto kind : {MarkerKind::Rings, MarkerKind::AprilTag, MarkerKind::Aruco}) {
    (*views)[kind] = std::make_unique<SyntheticPlatformView>(render_marker_texture(kind, g), g);
  }
  return [views, cam, X_WP](const Eigen::Isometry3d& X_WC, MarkerKind kind, double blur_px) {
    return views->at(kind)->render(cam, X_WC.inverse() * X_WP, blur_px, 30.0);
  };
}

}  // namespace lander::bench
