// Platform motion model and vehicle trajectories of seed 000 section 3.2, and a scripted
// setpoint source for test flights.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "lander/controller/cascade.h"

namespace lander::ctl {

// Per-axis least-squares polynomial of the platform trajectory in W (seed 000 eq. 25-27):
//   x_n(t) = a0 + a1 t + a2 t^2 + a3 t^3 + a4 t^4   (and the same for y, z).
// Time is normalised, tau = (t - t_mid) / t_half, so the normal equations stay conditioned;
// the fit is solved with a QR decomposition of the Vandermonde matrix.
class PolynomialFit3 {
 public:
  // Fits `order` (>= 0) to the samples (t_s[i], p_W[i]). Needs more samples than the order
  // and a time span > 0; throws std::invalid_argument otherwise.
  void fit(const std::vector<double>& t_s, const std::vector<Eigen::Vector3d>& p_W, int order);

  bool valid() const { return valid_; }
  int order() const { return order_; }
  double t_first() const { return t_first_; }
  double t_last() const { return t_last_; }

  Eigen::Vector3d position(double t_s) const;  ///< P_n(t) (m)
  Eigen::Vector3d velocity(double t_s) const;  ///< dP_n/dt (m/s)

  // Coefficients in the paper's form a_k of t^k, t in seconds from `t0_s` (for tests and logs).
  Eigen::MatrixXd coefficients_about(double t0_s) const;  ///< 3 x (order+1)

  double rms_residual_m() const { return rms_; }

 private:
  bool valid_{false};
  int order_{0};
  double t_mid_{0.0}, t_half_{1.0}, t_first_{0.0}, t_last_{0.0}, rms_{0.0};
  Eigen::MatrixXd c_;  // 3 x (order+1), coefficients in tau
};

// Cubic approach trajectory of seed 000 eq. 29, from P_0 at t_0 to P_d at t_d:
//   Diff = P_d - P_0,  P(t) = P_0 + 3 Diff s^2 - 2 Diff s^3,  s = (t - t_0) / (t_d - t_0),
// zero velocity at both ends (the paper starts from a hover over a target that stops). The
// cubic Hermite form adds end velocities V_0 and V_d (both zero: eq. 29 exactly):
//   P(t) = P_0 + Diff (3 s^2 - 2 s^3) + V_0 T (s - 2 s^2 + s^3) + V_d T (s^3 - s^2),  T = t_d - t_0,
// so an approach entered while following a moving cart starts at the vehicle's velocity and
// ends at the platform's instead of braking to a stop and chasing again.
// Before t_0 it returns P_0 (velocity V_0); after t_d, P_d moved on at V_d (acceleration 0).
class CubicTrajectory {
 public:
  CubicTrajectory() = default;
  CubicTrajectory(const Eigen::Vector3d& p0_W, double t0_s, const Eigen::Vector3d& pd_W, double td_s,
                  const Eigen::Vector3d& v0_W = Eigen::Vector3d::Zero(),
                  const Eigen::Vector3d& vd_W = Eigen::Vector3d::Zero());  // throws std::invalid_argument unless td_s > t0_s

  // Replaces the end point (replanning with a new prediction, t_0 and P_0 unchanged).
  void set_goal(const Eigen::Vector3d& pd_W) { pd_ = pd_W; }

  Eigen::Vector3d position(double t_s) const;
  Eigen::Vector3d velocity(double t_s) const;
  Eigen::Vector3d acceleration(double t_s) const;
  Setpoint setpoint(double t_s, double yaw_rad) const;

  const Eigen::Vector3d& p0() const { return p0_; }
  const Eigen::Vector3d& goal() const { return pd_; }
  double t0() const { return t0_; }
  double td() const { return td_; }

 private:
  Eigen::Vector3d p0_{Eigen::Vector3d::Zero()}, pd_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d v0_{Eigen::Vector3d::Zero()}, vd_{Eigen::Vector3d::Zero()};
  double t0_{0.0}, td_{1.0};
  bool hermite_{false};  // an end velocity is not zero
};

// Scripted setpoints for test flights: hold a position, then fly straight to waypoints at a
// cruise speed with a smooth (eq. 29 cubic) profile per leg. Times are absolute (s).
class WaypointScript {
 public:
  // Starts holding `p_W` with heading `yaw_rad` from time t_s.
  WaypointScript(const Eigen::Vector3d& p_W, double yaw_rad, double t_s);

  // Appends a leg to `p_W`, flown at mean speed `speed_mps` (> 0), then held for `hold_s`.
  void go_to(const Eigen::Vector3d& p_W, double speed_mps, double hold_s = 0.0);

  // The setpoint at time t_s (holds the last waypoint after the script ends).
  Setpoint at(double t_s) const;
  double end_time() const;

 private:
  struct Leg {
    CubicTrajectory traj;
    double hold_until_s;
  };
  Eigen::Vector3d start_;
  double yaw_;
  double t_start_;
  std::vector<Leg> legs_;
};

}  // namespace lander::ctl
