// A scenario: everything one run needs, as one YAML file (scenarios/*.yaml). The file names
// only the keys it changes; everything else keeps the defaults below. Unknown keys and bad
// values are rejected with file:line and the key. The resolved scenario (every key, values
// in force) is written next to each run's output.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "lander/core/params_io.h"
#include "lander/flight/flight_config.h"
#include "lander/sim/sensors/camera.h"
#include "lander/sim/plant/ground_effect.h"
#include "lander/sim/plant/rotor.h"
#include "lander/sim/sensors/sensors.h"
#include "lander/sim/plant/wind.h"
#include "lander/sim/plant/cart_motion.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {

// A pose the scripted (kinematic) vehicle passes through at time t_s; linear interpolation
// in position and in roll-pitch-yaw between waypoints.
struct Waypoint {
  double t_s{0.0};
  Eigen::Vector3d p_W_m{0.0, 0.0, 10.0};  ///< body position in W (m)
  Eigen::Vector3d rpy_rad{Eigen::Vector3d::Zero()};  ///< roll, pitch, yaw (rad); YAML rpy_deg
  void validate() const {}
};

template <class V>
void visit_fields(V& v, Waypoint& p) {
  v("t_s", p.t_s, range::any, "s", "");
  v("p_m", p.p_W_m, range::any, "m", "body position in W");
  v("rpy_deg", p.rpy_rad, range::any, "deg", "roll, pitch, yaw", M_PI / 180.0);
}

// The simulated vehicle as it is (truth side): mass and inertia (applied to the MJCF body),
// rotors and ground effect, and per-rotor deviations (one weak motor, a slow ESC). Defaults
// come from models/vehicle.yaml. The flight software's belief about the vehicle is
// flight.controller.vehicle and never reads these.
struct VehicleModelParams {
  double mass_kg{4.0};                                   ///< total mass (kg)
  Eigen::Vector3d inertia_kgm2{0.09, 0.09, 0.16};        ///< diagonal inertia in B (kg m^2)
  RotorParams rotor;
  GroundEffectParams ground_effect;
  std::vector<double> thrust_scale{1, 1, 1, 1, 1, 1};  ///< rotor k's kT is rotor.kT x this
  std::vector<double> torque_scale{1, 1, 1, 1, 1, 1};  ///< rotor k's kQ is rotor.kQ x this
  std::vector<double> tau_scale{1, 1, 1, 1, 1, 1};     ///< rotor k's lag is rotor.tau_s x this
  void validate() const {
    check_fields(*this);
    validate_nested("rotor", rotor);
    validate_nested("ground_effect", ground_effect);
    for (auto [key, v] : {std::pair<const char*, const std::vector<double>*>{"thrust_scale", &thrust_scale},
                          {"torque_scale", &torque_scale},
                          {"tau_scale", &tau_scale}}) {
      require(v->size() == static_cast<std::size_t>(kNumRotors), key, "needs one value per rotor (6)");
      for (double x : *v) require(x > 0 && x <= 2, key, "every value must be in (0, 2]");
    }
  }
};

template <class V>
void visit_fields(V& v, VehicleModelParams& p) {
  v("mass_kg", p.mass_kg, range::open(0, 100), "kg", "total mass");
  v("inertia_kgm2", p.inertia_kgm2, range::positive, "kg m^2", "diagonal inertia in B");
  v.nested("rotor", p.rotor);
  v.nested("ground_effect", p.ground_effect);
  v("thrust_scale", p.thrust_scale, range::any, "", "rotor k's kT is rotor.kT x this");
  v("torque_scale", p.torque_scale, range::any, "", "rotor k's kQ is rotor.kQ x this");
  v("tau_scale", p.tau_scale, range::any, "", "rotor k's lag is rotor.tau_s x this");
}

struct VehicleSetup {
  std::string control{"closed_loop"};        ///< closed_loop | kinematic (scripted waypoints)
  Eigen::Vector3d start_p_W_m{-5.0, 0.0, 10.0};  ///< closed_loop start position (m)
  double start_yaw_rad{0.0};                 ///< closed_loop start yaw (rad); YAML start_yaw_deg
  std::vector<Waypoint> waypoints;           ///< kinematic script, t_s increasing
  VehicleModelParams model;                  ///< rotors and ground effect (truth)
  void validate() const;
};

template <class V>
void visit_fields(V& v, VehicleSetup& p) {
  v("control", p.control, range::any, "", "closed_loop | kinematic (scripted waypoints)");
  v("start_m", p.start_p_W_m, range::any, "m", "closed_loop start position");
  v("start_yaw_deg", p.start_yaw_rad, range::any, "deg", "closed_loop start yaw", M_PI / 180.0);
  v.list("waypoints", p.waypoints);
  v.nested("model", p.model);
}

// The flight computer as the simulator models it: how long its vision processing takes. (What
// the flight software believes is flight:, flight/include/lander/flight/flight_config.h.)
struct ComputerParams {
  // Exposure end -> result at the controller. Seed 000's Table 1 measures the detection alone
  // at 21.4-42.2 ms (mean 31.3) on the vehicle's Raspberry Pi 4B; its 1280x720 USB camera
  // (Table 2, 30 fps, JPEG) adds read-out, transfer and decoding, which we put at half a frame
  // (~17 ms): 31 + 17 ~ 50 ms, longer than a frame period, so the loop runs the estimator
  // beside the next frame's render (RunOptions::vision_schedule).
  double vision_latency_s{0.050};  ///< processing latency of a frame (s); YAML vision_latency_ms
  bool measured_latency{false};    ///< use the measured processing time instead (not
                                   ///< deterministic: depends on the machine's load)
  void validate() const { check_fields(*this); }
};

template <class V>
void visit_fields(V& v, ComputerParams& p) {
  v("vision_latency_ms", p.vision_latency_s, range::closed_open(0, 1000), "ms",
    "processing latency of a frame", 1e-3);
  v("measured_latency", p.measured_latency, range::any, "",
    "use the measured processing time instead");
}

// Injected faults. Times are sim times (s); a time < 0 turns the fault off.
struct FaultParams {
  // Sensor faults within their models' physics (seed 004's robustness tests).
  double gps_step_t_s{-1.0};                     ///< start of a GPS position step (s)
  double gps_step_duration_s{2.0};               ///< its duration (s)
  Eigen::Vector3d gps_step_W_m{0.0, 0.0, 5.0};   ///< the step (m)
  double ultrasonic_garbage_t_s{-1.0};           ///< start of an ultrasonic garbage burst (s)
  double ultrasonic_garbage_duration_s{1.0};     ///< its duration (s)
  double vision_outlier_t_s{-1.0};               ///< first vision frame replaced by an outlier (s)
  int vision_outlier_frames{3};                  ///< consecutive outlier frames
  double vision_outlier_m{1.0};                  ///< outlier: platform pose shifted along z_C (m)

  // Corrupted samples (test hooks of the flight software's sample screen): every sample
  // delivered in [t, t + duration) is replaced by a NaN or absurd one on its way to the flight
  // software (the simulator's sensor metrics see the true sample). The flight software must
  // reject and count them (summary.json rejected_samples) and fly on.
  double nan_imu_t_s{-1.0};                ///< IMU: gyro and accelerometer NaN (s)
  double nan_imu_duration_s{0.1};          ///< (s)
  double nan_baro_t_s{-1.0};               ///< barometer: pressure NaN (s)
  double nan_baro_duration_s{0.5};         ///< (s)
  double absurd_gps_t_s{-1.0};             ///< GPS: valid fixes 1e9 m away at 1e6 m/s (s)
  double absurd_gps_duration_s{1.0};       ///< (s)
  double nan_ultrasonic_t_s{-1.0};         ///< ultrasonic: range NaN (s)
  double nan_ultrasonic_duration_s{0.5};   ///< (s)
  double nan_magnetometer_t_s{-1.0};       ///< magnetometer: field NaN (s)
  double nan_magnetometer_duration_s{0.5}; ///< (s)
  double nan_vision_t_s{-1.0};             ///< vision: results claim a keyframe detection with
                                           ///< a NaN pose and covariance (by exposure mid-time)
  double nan_vision_duration_s{0.5};       ///< (s)

  // Broken simulator processes (test hooks of the campaign runner's handling of runs that
  // diverge, crash or hang; never for real scenarios).
  double diverge_t_s{-1.0};  ///< a NaN is written into the vehicle's physics state at this
                             ///< time: the run ends with outcome `diverged` (exit code 1)
  double abort_t_s{-1.0};    ///< the process calls std::abort() at this time: a crash by
                             ///< signal (SIGABRT), no summary.json
  double hang_t_s{-1.0};     ///< the process stops making progress at this time (sleeps in a
                             ///< loop forever): for wall-clock timeouts

  void validate() const {
    check_fields(*this);
    for (auto [key, v] : {std::pair<const char*, double>{"nan_imu_duration_s", nan_imu_duration_s},
                          {"nan_baro_duration_s", nan_baro_duration_s},
                          {"absurd_gps_duration_s", absurd_gps_duration_s},
                          {"nan_ultrasonic_duration_s", nan_ultrasonic_duration_s},
                          {"nan_magnetometer_duration_s", nan_magnetometer_duration_s},
                          {"nan_vision_duration_s", nan_vision_duration_s}}) {
      require(v >= 0, key, "must be >= 0");
    }
  }
};

// True when t_s lies in the fault window [start_s, start_s + duration_s) (off if start < 0).
inline bool fault_active(double t_s, double start_s, double duration_s) {
  return start_s >= 0 && t_s >= start_s && t_s < start_s + duration_s;
}

template <class V>
void visit_fields(V& v, FaultParams& p) {
  v("gps_step_t_s", p.gps_step_t_s, range::any, "s", "start of a GPS position step");
  v("gps_step_duration_s", p.gps_step_duration_s, range::non_negative, "s", "duration of the GPS step");
  v("gps_step_m", p.gps_step_W_m, range::any, "m", "GPS position step");
  v("ultrasonic_garbage_t_s", p.ultrasonic_garbage_t_s, range::any, "s",
    "start of an ultrasonic garbage burst");
  v("ultrasonic_garbage_duration_s", p.ultrasonic_garbage_duration_s, range::non_negative, "s",
    "duration of the burst");
  v("vision_outlier_t_s", p.vision_outlier_t_s, range::any, "s",
    "first vision frame replaced by an outlier");
  v("vision_outlier_frames", p.vision_outlier_frames, range::non_negative, "",
    "consecutive outlier frames");
  v("vision_outlier_m", p.vision_outlier_m, range::any, "m",
    "outlier: platform pose shifted along z_C");
  v("nan_imu_t_s", p.nan_imu_t_s, range::any, "s", "IMU: gyro and accelerometer NaN");
  v("nan_imu_duration_s", p.nan_imu_duration_s, range::any, "s", "");
  v("nan_baro_t_s", p.nan_baro_t_s, range::any, "s", "barometer: pressure NaN");
  v("nan_baro_duration_s", p.nan_baro_duration_s, range::any, "s", "");
  v("absurd_gps_t_s", p.absurd_gps_t_s, range::any, "s", "GPS: valid fixes 1e9 m away at 1e6 m/s");
  v("absurd_gps_duration_s", p.absurd_gps_duration_s, range::any, "s", "");
  v("nan_ultrasonic_t_s", p.nan_ultrasonic_t_s, range::any, "s", "ultrasonic: range NaN");
  v("nan_ultrasonic_duration_s", p.nan_ultrasonic_duration_s, range::any, "s", "");
  v("nan_magnetometer_t_s", p.nan_magnetometer_t_s, range::any, "s", "magnetometer: field NaN");
  v("nan_magnetometer_duration_s", p.nan_magnetometer_duration_s, range::any, "s", "");
  v("nan_vision_t_s", p.nan_vision_t_s, range::any, "s",
    "vision: results claim a keyframe detection with a NaN pose");
  v("nan_vision_duration_s", p.nan_vision_duration_s, range::any, "s", "");
  v("diverge_t_s", p.diverge_t_s, range::any, "s",
    "a NaN is written into the vehicle's physics state at this time");
  v("abort_t_s", p.abort_t_s, range::any, "s", "the process calls std::abort() at this time");
  v("hang_t_s", p.hang_t_s, range::any, "s", "the process stops making progress at this time");
}

struct VideoParams {
  int chase_width_px{640};        ///< chase view size (px)
  int chase_height_px{360};
  double chase_distance_m{5.0};   ///< chase camera distance behind/above the vehicle (m)
  int camera_scale_div{2};        ///< camera.mp4 is the camera image downscaled by this
  bool overlays{true};            ///< draw fitted ellipses, ring ids, mode, altitude
  void validate() const {
    check_fields(*this);
    // H.264 (yuv420p) needs even frame sizes; the chase view renders into the offscreen
    // buffer, which the camera (at most kMaxRenderSidePx) also uses.
    require(chase_width_px >= 64 && chase_width_px <= 1280 && chase_width_px % 2 == 0,
            "chase_width_px", "must be even and in [64, 1280]");
    require(chase_height_px >= 64 && chase_height_px <= 720 && chase_height_px % 2 == 0,
            "chase_height_px", "must be even and in [64, 720]");
  }
};

template <class V>
void visit_fields(V& v, VideoParams& p) {
  v("chase_width_px", p.chase_width_px, range::any, "px", "chase view size");
  v("chase_height_px", p.chase_height_px, range::any, "px", "");
  v("chase_distance_m", p.chase_distance_m, range::positive, "m",
    "chase camera distance behind/above the vehicle");
  v("camera_scale_div", p.camera_scale_div, range::closed(1, 8), "",
    "camera.mp4 is the camera image downscaled by this");
  v("overlays", p.overlays, range::any, "", "draw fitted ellipses");
}

struct Scenario {
  std::string name{"unnamed"};
  std::string description;
  std::uint64_t seed{1};        ///< derives every random stream of the run
  double duration_s{60.0};      ///< maximum simulated time (s)
  std::string expect_outcome{"landed"};  ///< the outcome `lander run` exits 0 for: landed |
                                         ///< route_end (a path-following run to its end)
  WorldParams world;
  CameraParams camera;
  RenderParams render;
  CartMotionParams cart;
  VehicleSetup vehicle;
  SensorSuiteParams sensors;
  WindParams wind;
  ComputerParams computer;
  flight::FlightConfig flight;  ///< what the flight software believes (never the fields above)
  FaultParams faults;
  VideoParams video;
  double trace_rate_hz{100.0};  ///< rows per second in trace.csv

  void validate() const;
  // Loads a scenario YAML on top of the defaults (models/vehicle.yaml for the vehicle model,
  // the flight parameter file named by flight.file, default models/flight.yaml, for the flight
  // software). Throws ConfigError with file:line and key.
  static Scenario load(const std::string& path);
  // The same from a YAML tree already in memory (the Python package's dict scenarios);
  // `path` names it in messages, and relative paths in it are taken from its folder.
  static Scenario load_node(const YAML::Node& root, const std::string& path);
  // The defaults with models/vehicle.yaml and models/flight.yaml applied: what a scenario
  // file starts from.
  static Scenario defaults();
};

template <class V>
void visit_fields(V& v, Scenario& p) {
  v("name", p.name, range::any, "", "");
  v("description", p.description, range::any, "", "");
  v("seed", p.seed, range::any, "", "derives every random stream of the run");
  v("duration_s", p.duration_s, range::open_closed(0, 3600), "s", "maximum simulated time");
  v("expect_outcome", p.expect_outcome, range::any, "", "the outcome `lander run` exits 0 for");
  v.nested("world", p.world);
  v.nested("camera", p.camera);
  v.nested("render", p.render);
  v.nested("cart", p.cart);
  v.nested("vehicle", p.vehicle);
  v.nested("sensors", p.sensors);
  v.nested("wind", p.wind);
  v.nested("computer", p.computer);
  v.nested("flight", p.flight);
  v.nested("faults", p.faults);
  v.nested("video", p.video);
  v("trace_rate_hz", p.trace_rate_hz, range::open_closed(0, 1000), "Hz",
    "rows per second in trace.csv");
}

// Smallest side of camera.mp4 (px) that the video writer accepts.
constexpr int kMinVideoSidePx = 16;

// Kinematic script: body pose and velocity at t (clamped to the first/last waypoint).
void scripted_vehicle_state(const VehicleSetup& v, double t_s, Eigen::Isometry3d& X_WB,
                            Eigen::Vector3d& v_W, Eigen::Vector3d& omega_B);

}  // namespace lander::sim
