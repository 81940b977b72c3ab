// Ground truth of the vehicle at one instant, as the simulation loop hands it to the sensor
// models (sensors.h) and the metrics (altitude_metrics.h). Never seen by estimator/controller.
#pragma once

#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lander::sim {

struct VehicleTruth {
  double t_s{0.0};                                           ///< sim time (s)
  Eigen::Isometry3d X_WB{Eigen::Isometry3d::Identity()};    ///< pose of B in W
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};          ///< velocity of B's origin in W
  Eigen::Vector3d omega_B_radps{Eigen::Vector3d::Zero()};    ///< angular velocity in B
  Eigen::Vector3d a_W_mps2{Eigen::Vector3d::Zero()};         ///< acceleration in W (no -g)
  /// Height of B's origin above the surface (ground or platform top) straight below it,
  /// measured along -z_W (m). Drives the barometer's downwash error.
  double h_surface_m{std::numeric_limits<double>::quiet_NaN()};
  /// Length of the ultrasonic ray (along -z_B from the sensor) to the first hit (m);
  /// +infinity or NaN when the ray hits nothing.
  double range_m{std::numeric_limits<double>::quiet_NaN()};
  /// Total rotor thrust / full thrust of all rotors (-), ~0.5 at hover.
  double thrust_fraction{0.5};
};

// Ground truth of the landing platform (frame P's origin, the centre of the top) at one
// instant: what the platform's own GNSS receiver measures for its broadcast
// (sensors.platform_telemetry).
struct PlatformTruth {
  double t_s{0.0};                                   ///< sim time (s)
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};    ///< position of P's origin in W
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};  ///< its velocity in W
};

}  // namespace lander::sim
