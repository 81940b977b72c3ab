// Wind: a steady component plus gusts, and the aerodynamic drag it puts on the body.
//
// Gusts are first-order Gauss-Markov processes (filtered white noise), one per world axis,
// the one-pole approximation of the Dryden spectrum (MIL-F-8785C) at constant airspeed:
//   dg/dt = -g / tau + sigma sqrt(2 / tau) n(t),     stationary std sigma, correlation time tau,
// integrated exactly per step: g_{k+1} = a g_k + sigma sqrt(1 - a^2) n_k, a = exp(-dt / tau).
// Air velocity in W: u_W = steady_W + g.
//
// Drag on the body from the air-relative velocity v_rel = v_W - u_W, resolved in B per axis:
//   F_B,i = -c_lin,i v_rel_B,i - c_quad,i |v_rel_B,i| v_rel_B,i,      F_W = R_WB F_B.
#pragma once

#include <cstdint>
#include <random>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/params_io.h"

namespace lander::sim {

struct WindParams {
  Eigen::Vector3d steady_W_mps{0.0, 0.0, 0.0};     ///< mean wind in W (m/s)
  double gust_std_horizontal_mps{0.0};             ///< stationary gust std, x and y of W (m/s)
  double gust_std_vertical_mps{0.0};               ///< stationary gust std, z of W (m/s)
  double gust_tau_s{2.0};                          ///< gust correlation time (s)
  /// Linear drag per body axis (N s/m); ~0.25 N s/m for an 850 mm hexarotor (rotor
  /// induced drag dominates at low speed).
  Eigen::Vector3d drag_linear_B_Nspm{0.25, 0.25, 0.35};
  /// Quadratic drag per body axis (N s^2/m^2): 0.5 rho Cd A with A ~ 0.1 m^2 side, 0.3 m^2
  /// top, Cd ~ 1.
  Eigen::Vector3d drag_quadratic_B_Ns2pm2{0.06, 0.06, 0.18};

  void validate() const {
    check_fields(*this);
    require(steady_W_mps.allFinite(), "steady_W_mps", "must be finite");
    require((drag_linear_B_Nspm.array() >= 0).all(), "drag_linear_B_Nspm", "must be >= 0");
    require((drag_quadratic_B_Ns2pm2.array() >= 0).all(), "drag_quadratic_B_Ns2pm2",
            "must be >= 0");
  }
};

template <class V>
void visit_fields(V& v, WindParams& p) {
  v("steady_W_mps", p.steady_W_mps, range::any, "m/s", "mean wind in W");
  v("gust_std_horizontal_mps", p.gust_std_horizontal_mps, range::non_negative, "m/s",
    "stationary gust std");
  v("gust_std_vertical_mps", p.gust_std_vertical_mps, range::non_negative, "m/s",
    "stationary gust std");
  v("gust_tau_s", p.gust_tau_s, range::positive, "s", "gust correlation time");
  v("drag_linear_B_Nspm", p.drag_linear_B_Nspm, range::any, "",
    "Linear drag per body axis (N s/m)");
  v("drag_quadratic_B_Ns2pm2", p.drag_quadratic_B_Ns2pm2, range::any, "",
    "Quadratic drag per body axis (N s^2/m^2)");
}

class WindModel {
 public:
  // Validates p; the gust state starts drawn from its stationary distribution.
  WindModel(const WindParams& p, std::uint64_t seed);
  // Advances the gusts by dt_s (> 0) and returns the new air velocity in W (m/s).
  Eigen::Vector3d step(double dt_s);
  // Current air velocity in W (m/s).
  Eigen::Vector3d air_velocity_W() const { return p_.steady_W_mps + gust_W_; }
  const WindParams& params() const { return p_; }

 private:
  WindParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Eigen::Vector3d sigma_W_;
  Eigen::Vector3d gust_W_{Eigen::Vector3d::Zero()};
};

// Drag force in W (N) on a body with attitude R_WB moving at v_W (m/s) through air moving
// at air_W (m/s).
Eigen::Vector3d drag_force_W(const WindParams& p, const Eigen::Matrix3d& R_WB,
                             const Eigen::Vector3d& v_W_mps, const Eigen::Vector3d& air_W_mps);

}  // namespace lander::sim
