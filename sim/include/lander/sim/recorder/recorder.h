// The recorder: everything a run leaves behind, judged against the truth the simulator
// keeps. trace.csv (truth beside the flight software's estimates), per-sensor and fused height
// errors, vision counts, the landing judgement (contact, touchdown figures, outcome), the
// videos and summary.json. It reads the flight software's state only through the seam's
// status, telemetry and report (flight_software.h) and counts an estimate only once the
// flight software has one.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "lander/flight/flight_software.h"
#include "lander/sim/recorder/altitude_metrics.h"
#include "lander/sim/sensors/camera.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"
#include "lander/sim/sensors/sensors.h"
#include "lander/sim/util/stats.h"
#include "lander/sim/plant/truth.h"
#include "lander/sim/render/video.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {

// How a run ended: "landed", "tipped_over", "touched_ground", "diverged", "timeout", and a
// sentence saying why.
struct Outcome {
  std::string name;
  std::string detail;
};

// Contact and the landing's verdict, from MuJoCo's contacts and the vehicle's truth.
class LandingJudge {
 public:
  explicit LandingJudge(const World& world);
  // After each physics step (time tn): records the first contact's touchdown figures and
  // returns the outcome once the run is decided (landed: resting on the platform, motors cut,
  // upright, for 1 s; tipped over; on the ground).
  std::optional<Outcome> update(double tn, const VehicleTruth& truth, const flight::FlightStatus& st,
                                const flight::FlightSoftware& fs);
  const nlohmann::ordered_json& touchdown() const { return touchdown_; }
  double t_first_contact_s() const { return t_first_contact_; }  ///< < 0 before contact

 private:
  Eigen::Vector3d platform_velocity_below(const Eigen::Vector3d& p_W, const Eigen::Isometry3d& X_WP) const;

  const World& world_;
  int skid_left_, skid_right_, platform_geom_, ground_geom_;
  double t_first_contact_{-1.0}, t_landed_confirm_{-1.0};
  bool touched_ground_{false};
  nlohmann::ordered_json touchdown_ = nlohmann::ordered_json::object();
};

class Recorder {
 public:
  // Opens trace.csv (and the videos when o.video) in o.out_dir.
  // `renderer` is used only for the chase video (may be null without video).
  Recorder(const Scenario& s, const RunOptions& o, World& world, Renderer* renderer);

  // What the recorder keeps of the world and the flight software at a frame's exposure end,
  // taken then (capture_frame) and used when the frame's detection is ready (on_frame), which
  // with the overlapped vision schedule is later, after the plant has moved on.
  struct FrameCapture {
    double z_mid_m{0}, h_ray_m{0}, platform_z_m{0};  ///< truth at mid-exposure
    std::string mode;                                 ///< controller mode then (video)
    bool altitude_started{false};
    AltitudeEstimate altitude;
    cv::Mat chase;                                    ///< chase-view frame (video only)
  };
  FrameCapture capture_frame(const CameraFrame& frame, const flight::FlightSoftware& fs);
  // A finished camera frame with its capture and what the flight software's processing found
  // (before the NaN-pose fault hook): vision counts, the vision height error, video frames.
  void on_frame(const CameraFrame& frame, const FrameCapture& cap, const flight::FrameReport& rep);
  // A vision result reaching the flight software: the trace's `detected` column follows what
  // the flight software has been told.
  void on_vision_delivered(bool detected) { last_detected_ = detected; }
  // The samples taken at truth.t_s, as the sensors measured them: per-sensor height errors.
  void on_samples(const SensorSuite::Sampled& smp, const VehicleTruth& truth);
  // After the step k (time truth.t_s) and the flight software's updates: fused-height errors,
  // the landing judgement, a trace row when due. Returns the outcome when the run ends here
  // (no trace row then).
  std::optional<Outcome> on_step(int k, const VehicleTruth& truth, const flight::FlightSoftware& fs,
                                 const RotorArray& rotor_speeds_radps);
  void count_outlier_injected() { ++outliers_injected_; }
  int outliers_injected() const { return outliers_injected_; }

  // Closes the trace and videos and fills summary.json's landing, vision, sample and altitude
  // sections.
  void finish(const Outcome& outcome, const flight::FlightSoftware& fs, nlohmann::ordered_json& summary);

 private:
  const Scenario& s_;
  World& world_;
  Renderer* renderer_;
  bool video_;
  int video_w_, video_h_;
  std::unique_ptr<VideoWriter> cam_video_, chase_video_;
  CsvWriter trace_;
  int trace_every_;
  LandingJudge judge_;
  int frames_ = 0, detections_ = 0, keyframes_ = 0, keyframes_rejected_ = 0;
  int detections_deblurred_ = 0;  // poses from the blur-aware pass (issue 12)
  int detections_unfiltered_ = 0;  // ... from the unfiltered pass (issue 12)
  int detections_zoomed_ = 0;     // ... from the zoomed pass (issue 12)
  int detections_by_layout_ = 0;  // ... whose sets were identified by the layout (issue 12)
  int detections_by_platform_ = 0;  // ... from the platform pass (issue 12)
  int outliers_injected_ = 0;
  bool last_detected_ = false;
  std::map<std::string, int> not_detected_reasons_;
  ErrorStats fused_z_err_, fused_h_err_;
  AltitudeMetrics alt_metrics_;  // per-sensor height errors against truth (seed 004 figures)
  // Path following (seed 003): the vehicle's cross-track error to the route's centre line
  // while it follows the route, until it has covered it.
  std::vector<double> cross_track_m_;
  double path_t0_{-1.0}, path_covered_t_{-1.0}, path_s_max_{0.0};
};

}  // namespace lander::sim
