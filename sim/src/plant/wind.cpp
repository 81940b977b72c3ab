#include "lander/sim/plant/wind.h"

#include <cmath>
#include <stdexcept>

namespace lander::sim {

WindModel::WindModel(const WindParams& p, std::uint64_t seed) : p_(p), rng_(seed) {
  p_.validate();
  sigma_W_ = {p_.gust_std_horizontal_mps, p_.gust_std_horizontal_mps, p_.gust_std_vertical_mps};
  for (int i = 0; i < 3; ++i) gust_W_[i] = sigma_W_[i] * normal_(rng_);
}

Eigen::Vector3d WindModel::step(double dt_s) {
  if (!(dt_s > 0)) throw std::invalid_argument("WindModel::step: dt_s must be > 0");
  // Exact discretisation of the Gauss-Markov gust (keeps the stationary std for any dt).
  const double a = std::exp(-dt_s / p_.gust_tau_s);
  const double b = std::sqrt(1.0 - a * a);
  for (int i = 0; i < 3; ++i) gust_W_[i] = a * gust_W_[i] + b * sigma_W_[i] * normal_(rng_);
  return air_velocity_W();
}

Eigen::Vector3d drag_force_W(const WindParams& p, const Eigen::Matrix3d& R_WB,
                             const Eigen::Vector3d& v_W_mps, const Eigen::Vector3d& air_W_mps) {
  const Eigen::Vector3d v_rel_B = R_WB.transpose() * (v_W_mps - air_W_mps);
  const Eigen::Vector3d F_B =
      -(p.drag_linear_B_Nspm.array() * v_rel_B.array() +
        p.drag_quadratic_B_Ns2pm2.array() * v_rel_B.array().abs() * v_rel_B.array())
           .matrix();
  return R_WB * F_B;
}

}  // namespace lander::sim
