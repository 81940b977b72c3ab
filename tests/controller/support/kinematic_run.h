// Test support: a kinematic vehicle that sits on the landing controller's setpoint (so the
// mode logic is tested apart from the flight dynamics) with the synthetic camera of
// hex_model.h. Used by mode_machine_test.cpp and landing_decision_test.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "lander/controller/landing_controller.h"
#include "lander/controller/vehicle_limits.h"
#include "hex_model.h"

namespace lander::ctl::test {

inline constexpr double kGravity_mps2 = 9.81;  // (m/s^2)
// Bandwidth of the kinematic vehicle's setpoint tracking (1/s): ten times the position loop's
// 1.3 1/s, so the mode machine, not the vehicle, is what the tests exercise.
inline constexpr double kTrackGain_per_s = 15.0;

// Given a controller and a platform, moves a point-mass vehicle onto each setpoint; after
// the motor cut it falls under gravity onto the platform (or forever if `solid` is false).
struct KinematicRun {
  ControllerParams params;
  PlatformTruth platform;
  Eigen::Vector3d start{-2.0, 0.5, 8.0};
  // A constant tilt of the vehicle (rad): body = Rz(yaw) Ry(pitch) Rx(roll). Vision and
  // navigation see it; the point-mass motion does not (level flight otherwise).
  double roll_rad{0.0}, pitch_rad{0.0};
  double max_time_s{60.0};
  bool solid{true};  // the platform top stops the fall
  std::function<bool(double, const Eigen::Isometry3d&)> visible;
  std::function<bool(int frame)> keyframe = [](int) { return true; };
  std::function<Eigen::Vector3d(double)> platform_jump = [](double) {
    return Eigen::Vector3d::Zero();
  };
  std::function<bool(const LandingController&)> stop_when;
  // When finite: the fused altitude reaches the controller every step, the true height of
  // the vehicle above the platform top plus this error (m).
  double fused_altitude_error_m{std::numeric_limits<double>::quiet_NaN()};
  // A sudden displacement of the vehicle (a gust) to apply at this step, zero for none.
  std::function<Eigen::Vector3d(const LandingController&)> push =
      [](const LandingController&) { return Eigen::Vector3d::Zero(); };
  // A displacement of the vehicle from where it tracks the setpoint, as a function of time
  // (a disturbance the controller cannot remove: wind it does not reject); its rate adds to
  // the navigation velocity. Zero for none.
  std::function<Eigen::Vector3d(double, const LandingController&)> offset;
  // An error of the navigation position (a GPS height that steps, say) as a function of
  // time: the controller is given truth + this, and the vehicle flies so that its navigation
  // position, not its true one, sits on the setpoint. Zero for none.
  std::function<Eigen::Vector3d(double)> nav_error;
  // Called after every controller step.
  std::function<void(double, const Eigen::Vector3d&, const LandingController&)> on_step;

  // Outputs.
  std::vector<ModeTransition> transitions;
  LandingDecisionLog decision_log;
  std::vector<Reacquisition> reacquisitions;
  Mode final_mode{Mode::kSearch};
  Eigen::Vector3d final_p{Eigen::Vector3d::Zero()};
  int keyframes_before_approach{-1};
  bool landed{false};
  double final_offset_m{0.0};

  // True gear clearance of a vehicle at p above the platform top at t (m): the CoM's height
  // above the top less gear_height_m, for a level vehicle.
  double gear_clearance_m(double t, const Eigen::Vector3d& p) const {
    return p.z() - platform.p_W(t).z() - params.landing.gear_height_m;
  }

  void run() {
    LandingController ctl(params, CameraMount{});
    VisionModelParams vp;
    vp.latency_s = 0.05;
    SyntheticVision vision(vp, CameraMount{}, CameraModel{});
    vision.visible = visible;
    Eigen::Vector3d p = start, v = Eigen::Vector3d::Zero();
    Eigen::Vector3d off = Eigen::Vector3d::Zero();  // current offset (see `offset`)
    double yaw = 0.0;
    bool resting = false;
    // The vehicle's acceleration in W over the last step (m/s^2): a perfect IMU reads the
    // specific force R_WB^T (a_W + g z_W) at the next step (hovering: +g along z_W; free fall:
    // 0), so the flight software's inertial height (the deck predictor's) follows p.
    Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
    int frame = 0, keyframes = 0, pushed_steps = 0;
    constexpr double dt = 0.004;  // 250 Hz: vision and controller on the same clock
    for (int i = 0; i * dt < max_time_s; ++i) {
      const double t = i * dt;
      Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
      X_WB.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
      X_WB.translation() = p;
      Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
      X_WP.translation() = platform.p_W(t) + platform_jump(t);
      vision.update(t, X_WB, X_WP);
      for (PlatformObservation obs : vision.deliver(t)) {
        obs.keyframe = obs.detected && keyframe(frame++);
        if (obs.keyframe) ++keyframes;
        ctl.on_vision(obs);
      }
      NavState nav;
      nav.t_s = t;
      nav.valid = true;
      const Eigen::Vector3d nav_err = nav_error ? nav_error(t) : Eigen::Vector3d::Zero();
      nav.p_W_m = p + nav_err;
      nav.v_W_mps = v;
      nav.q_WB = Eigen::Quaterniond(X_WB.linear());
      ImuSample imu;
      imu.t_s = t;
      imu.accel_B_mps2 = X_WB.linear().transpose() * (a_W + Eigen::Vector3d(0, 0, kGravity_mps2));
      const Eigen::Vector3d v_before = v;
      if (std::isfinite(fused_altitude_error_m)) {
        AltitudeEstimate alt;
        alt.t_s = t;
        alt.valid = true;
        alt.h_surface_m = p.z() - platform.p_W(t).z() + fused_altitude_error_m;
        ctl.on_altitude(alt);
      }
      const Mode before = ctl.mode();
      const RotorCommand cmd = ctl.step(t, nav, imu);
      if (before != Mode::kApproach && ctl.mode() == Mode::kApproach &&
          keyframes_before_approach < 0) {
        keyframes_before_approach = keyframes;
      }
      if (!cmd.motors_cut) {
        // Near-perfect tracking (see kTrackGain_per_s); hovering reads +g. A push holds
        // the vehicle displaced for 12 steps (48 ms), longer than one outer-loop period, so the
        // mode machine sees it.
        resting = false;
        const Eigen::Vector3d shove = push(ctl);
        if (!shove.isZero()) {
          // A displacement within one step: the navigation reads it as that step's velocity,
          // then the vehicle is held still where it was pushed.
          p += shove;
          v = shove / dt;
          pushed_steps = 13;
        }
        if (pushed_steps > 0) {
          if (--pushed_steps < 12) v.setZero();
        } else {
          // Tight first-order tracking of the setpoint, velocity fed forward: position and
          // velocity stay consistent (the tracker dead-reckons the vehicle from the latter).
          const Setpoint& sp = ctl.diagnostics().setpoint;
          const Eigen::Vector3d off_new = offset ? offset(t, ctl) : Eigen::Vector3d::Zero();
          const Eigen::Vector3d off_rate = (off_new - off) / dt;
          off = off_new;
          v = sp.v_W_mps + off_rate + kTrackGain_per_s * (sp.p_W_m + off - (p + nav_err));
          // ... at the cascade's speed limits, as the real vehicle.
          const double v_xy = v.head<2>().norm();
          const double v_max = derive_limits(params.vehicle, params.cascade).max_speed_xy_mps;
          if (v_xy > v_max) v.head<2>() *= v_max / v_xy;
          v.z() = std::clamp(v.z(), -params.cascade.max_vel_down_mps, params.cascade.max_vel_up_mps);
          p += v * dt;
        }
        yaw = ctl.diagnostics().setpoint.yaw_rad;
      } else if (!resting) {
        // Motors cut: free fall (reads 0) until the gear meets the platform top.
        v.z() -= kGravity_mps2 * dt;
        p += v * dt;
        const Eigen::Vector3d top = platform.p_W(t);
        if (solid && gear_clearance_m(t, p) <= 0.0) {
          resting = true;
          final_offset_m = (p - top).head<2>().norm();
        }
      }
      if (resting) {  // carried by the cart, reads +g
        p += platform.v_W(t) * dt;
        v = platform.v_W(t);
      }
      a_W = (v - v_before) / dt;
      if (on_step) on_step(t, p, ctl);
      if (ctl.landed() || (stop_when && stop_when(ctl))) break;
    }
    transitions = ctl.transitions();
    landed = ctl.landed();
    decision_log = ctl.decision_log();
    reacquisitions = ctl.reacquisitions();
    final_mode = ctl.mode();
    final_p = p;
  }
};

inline std::string describe(const std::vector<ModeTransition>& trs) {
  std::string s;
  for (const ModeTransition& tr : trs) {
    s += "  t=" + std::to_string(tr.t_s) + " " + to_string(tr.from) + " -> " + to_string(tr.to) +
         ": " + tr.reason + "\n";
  }
  return s;
}

inline std::vector<Mode> targets(const std::vector<ModeTransition>& trs) {
  std::vector<Mode> out;
  for (const ModeTransition& tr : trs) out.push_back(tr.to);
  return out;
}

}  // namespace lander::ctl::test
