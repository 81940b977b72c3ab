// Test support: a simple rigid-body hexarotor (seed 000 eq. 19-22) with first-order motor
// lag, linear drag, a moving landing platform with contact, and a synthetic vision model.
// Ground truth lives only here; the controller sees NavState / PlatformObservation built
// from it.
#pragma once

#include <array>
#include <deque>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/controller/landing_controller.h"
#include "lander/controller/params.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander::ctl::test {

// Truth model parameters: the common vehicle facts plus what the controller does not know.
struct HexModelParams {
  double mass_kg{4.0};
  Eigen::Vector3d inertia_kgm2{0.09, 0.09, 0.16};
  double arm_m{0.425};
  double rotor_height_m{0.05};
  double k_thrust{2.05e-5};
  double k_torque{3.3e-7};
  double w_max_radps{800.0};
  double motor_tau_s{0.05};
  double gravity_mps2{9.81};
  double drag_N_per_mps{0.3};       ///< linear translational drag (unknown to the controller)
  double gear_height_m{0.25};       ///< CoM height above the surface when standing (m),
                                    ///< as models/hexarotor.xml (skids at -0.24 m, r 0.01 m)
  Eigen::Vector3d wind_W_mps{Eigen::Vector3d::Zero()};  ///< steady wind (drag acts on v - wind)
  double gust_amplitude_mps{0.0};   ///< sinusoidal gust on top of the wind, along wind (m/s)
  double gust_period_s{4.0};        ///< gust period (s)
};

// The landing platform: by default moving at constant velocity; `path` (position of the top
// centre in W as a function of time) overrides that for turning or stop-and-go carts.
struct PlatformTruth {
  Eigen::Vector3d p0_W_m{0.0, 0.0, 0.8};    ///< centre of the top at t = 0 (m)
  Eigen::Vector3d v_W_mps{0.0, 0.0, 0.0};   ///< velocity (m/s)
  double radius_m{0.6};                     ///< top radius (m)
  std::function<Eigen::Vector3d(double)> path;  ///< optional trajectory of the top centre
  Eigen::Vector3d p_W(double t_s) const { return path ? path(t_s) : p0_W_m + v_W_mps * t_s; }
  Eigen::Vector3d v_W(double t_s) const {   // central difference, 1 ms
    return path ? Eigen::Vector3d((path(t_s + 1e-3) - path(t_s - 1e-3)) / 2e-3) : v_W_mps;
  }
};

class HexModel {
 public:
  explicit HexModel(const HexModelParams& p = {});

  // Places the vehicle hovering (rotors at hover speed) at p_W with heading yaw.
  void reset_hover(const Eigen::Vector3d& p_W, double yaw_rad = 0.0);

  // Advances by dt_s with rotor commands w_cmd (rad/s); contact with `platform` if given.
  void step(double t_s, double dt_s, const std::array<double, 6>& w_cmd,
            const PlatformTruth* platform = nullptr);

  NavState nav(double t_s) const;       ///< perfect navigation state
  ImuSample imu(double t_s) const;      ///< perfect IMU (gyro, specific force)
  Eigen::Isometry3d X_WB() const;

  Eigen::Vector3d p, v, omega_B;
  Eigen::Quaterniond q;
  std::array<double, 6> w{};
  bool in_contact{false};
  bool contact_on_platform{false};
  double contact_t_s{0.0};
  Eigen::Vector3d contact_offset_W_m{Eigen::Vector3d::Zero()};  ///< CoM - platform centre
  Eigen::Vector3d contact_rel_v_W_mps{Eigen::Vector3d::Zero()};
  double contact_tilt_deg{0.0};
  const HexModelParams& params() const { return p_; }

 private:
  HexModelParams p_;
  Eigen::Vector3d specific_force_B_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d contact_p_offset_{Eigen::Vector3d::Zero()};
};

// Synthetic vision: at `rate_hz` a frame; if the platform centre projects into the image
// (with a margin) and is in range, an observation X_CP with noise, delivered after latency.
struct VisionModelParams {
  double rate_hz{30.0};
  double latency_s{0.06};
  double pos_noise_per_m{0.003};   ///< position noise sigma per metre of range (m/m)
  double pos_noise_floor_m{0.003}; ///< position noise floor (m)
  double rot_noise_deg{0.3};       ///< rotation noise sigma (deg)
  double margin_px{30.0};          ///< platform centre must be this far inside the image
  double max_range_m{15.0};
  unsigned seed{7};
};

class SyntheticVision {
 public:
  SyntheticVision(const VisionModelParams& p, const CameraMount& mount, const CameraModel& cam);

  // Call every physics step; captures frames at the camera rate. `visible(t, X_WB)` can
  // veto a detection (to script losses).
  void update(double t_s, const Eigen::Isometry3d& X_WB, const Eigen::Isometry3d& X_WP);
  // Observations whose delivery time has come.
  std::vector<PlatformObservation> deliver(double t_s);

  std::function<bool(double t_s, const Eigen::Isometry3d& X_WB)> visible;
  int frames{0}, detections{0};

 private:
  VisionModelParams p_;
  Eigen::Isometry3d X_BC_;
  CameraModel cam_;
  double next_frame_t_{0.0};
  std::deque<std::pair<double, PlatformObservation>> queue_;
  std::mt19937 rng_;
};

// Errors of the navigation state the controller gets (a filter is never perfect).
struct NavNoiseParams {
  double pos_walk_m_per_sqrt_s{0.0};  ///< random-walk position bias, like GPS wander
  double pos_white_m{0.0};            ///< white position noise per sample (m)
  double vel_white_mps{0.0};          ///< white velocity noise (m/s)
  double att_white_deg{0.0};          ///< white attitude noise per axis (deg)
  double gyro_white_radps{0.0};       ///< white rate noise (rad/s)
  unsigned seed{11};
};

// Closed loop: model at 1 kHz, controller at 250 Hz, vision at 30 Hz.
struct LandingRunConfig {
  ControllerParams controller;
  HexModelParams model;
  VisionModelParams vision;
  PlatformTruth platform;
  NavNoiseParams nav_noise;
  Eigen::Vector3d start_W_m{-5.0, 0.0, 10.0};
  double max_time_s{90.0};
  double physics_dt_s{0.001};
  int inner_every{4};               ///< controller every 4 physics steps = 250 Hz
  std::function<bool(double t_s, const Eigen::Isometry3d& X_WB)> visible;  ///< optional
  std::function<void(double t_s, const HexModel&, const LandingController&)> on_step;
  /// optional: called before each controller step, to feed it further inputs (e.g. the
  /// platform's broadcast) from the truth
  std::function<void(double t_s, const HexModel&, LandingController&)> feed;
};

struct LandingRunResult {
  bool contact{false};
  bool on_platform{false};
  bool landed{false};           ///< controller reported kLanded
  double contact_t_s{0.0};
  double touchdown_offset_m{0.0};   ///< horizontal CoM to platform centre at contact
  double touchdown_rel_speed_mps{0.0};
  double touchdown_tilt_deg{0.0};
  double max_tilt_deg{0.0};
  std::vector<ModeTransition> transitions;
  int vision_frames{0}, vision_detections{0};
  std::string describe() const;  ///< one line per transition plus the outcome, for failures
};

LandingRunResult run_landing(const LandingRunConfig& cfg);

}  // namespace lander::ctl::test
