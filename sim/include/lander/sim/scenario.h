// A scenario: everything one run needs, as one YAML file (scenarios/*.yaml). The file names
// only the keys it changes; everything else keeps the defaults below. Unknown keys and bad
// values are rejected with file:line and the key. The resolved scenario (every key, values
// in force) is written next to each run's output.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "lander/estimator/params_io.h"
#include "lander/sim/camera.h"
#include "lander/sim/cart_motion.h"
#include "lander/sim/renderer.h"
#include "lander/sim/world.h"

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
  v("t_s", p.t_s);
  v("p_m", p.p_W_m);
  v("rpy_deg", p.rpy_rad, M_PI / 180.0);
}

struct VehicleSetup {
  std::string control{"closed_loop"};        ///< closed_loop | kinematic (scripted waypoints)
  Eigen::Vector3d start_p_W_m{-5.0, 0.0, 10.0};  ///< closed_loop start position (m)
  double start_yaw_rad{0.0};                 ///< closed_loop start yaw (rad); YAML start_yaw_deg
  std::vector<Waypoint> waypoints;           ///< kinematic script, t_s increasing
  void validate() const;
};

template <class V>
void visit_fields(V& v, VehicleSetup& p) {
  v("control", p.control);
  v("start_m", p.start_p_W_m);
  v("start_yaw_deg", p.start_yaw_rad, M_PI / 180.0);
  v.list("waypoints", p.waypoints);
}

struct VideoParams {
  int chase_width_px{640};        ///< chase view size (px)
  int chase_height_px{360};
  double chase_distance_m{5.0};   ///< chase camera distance behind/above the vehicle (m)
  int camera_scale_div{2};        ///< camera.mp4 is the camera image downscaled by this
  bool overlays{true};            ///< draw fitted ellipses, ring ids, mode, altitude
  void validate() const {
    require(chase_width_px >= 64 && chase_width_px <= 1280, "video.chase_width_px",
            "must be in [64, 1280]");
    require(chase_height_px >= 64 && chase_height_px <= 720, "video.chase_height_px",
            "must be in [64, 720]");
    require(chase_distance_m > 0, "video.chase_distance_m", "must be > 0");
    require(camera_scale_div >= 1 && camera_scale_div <= 8, "video.camera_scale_div",
            "must be in [1, 8]");
  }
};

template <class V>
void visit_fields(V& v, VideoParams& p) {
  v("chase_width_px", p.chase_width_px);
  v("chase_height_px", p.chase_height_px);
  v("chase_distance_m", p.chase_distance_m);
  v("camera_scale_div", p.camera_scale_div);
  v("overlays", p.overlays);
}

struct Scenario {
  std::string name{"unnamed"};
  std::string description;
  std::uint64_t seed{1};        ///< derives every random stream of the run
  double duration_s{60.0};      ///< maximum simulated time (s)
  WorldParams world;
  CameraParams camera;
  RenderParams render;
  CartMotionParams cart;
  VehicleSetup vehicle;
  VideoParams video;

  void validate() const;
  // Loads a scenario YAML on top of the defaults. Throws ConfigError with file:line and key.
  static Scenario load(const std::string& path);
};

template <class V>
void visit_fields(V& v, Scenario& p) {
  v("name", p.name);
  v("description", p.description);
  v("seed", p.seed);
  v("duration_s", p.duration_s);
  v.nested("world", p.world);
  v.nested("camera", p.camera);
  v.nested("render", p.render);
  v.nested("cart", p.cart);
  v.nested("vehicle", p.vehicle);
  v.nested("video", p.video);
}

// Derives the seed of one random stream ("imu", "camera", ...) from the scenario seed.
std::uint64_t derive_seed(std::uint64_t scenario_seed, const std::string& stream);

// Kinematic script: body pose and velocity at t (clamped to the first/last waypoint).
void scripted_vehicle_state(const VehicleSetup& v, double t_s, Eigen::Isometry3d& X_WB,
                            Eigen::Vector3d& v_W, Eigen::Vector3d& omega_B);

}  // namespace lander::sim
