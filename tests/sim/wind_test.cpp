// Wind gusts (Gauss-Markov) statistics and drag.
#include "lander/sim/plant/wind.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace lander::sim {
namespace {

TEST(WindParams, DefaultIsValid) { EXPECT_NO_THROW(WindParams{}.validate()); }

TEST(WindParams, SaveLoadRoundTrip) {
  WindParams p;
  p.steady_W_mps = {2.0, -1.0, 0.0};
  p.gust_std_horizontal_mps = 0.8;
  WindParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_EQ(q.steady_W_mps, p.steady_W_mps);
}

TEST(WindParams, BadValueNamesField) {
  WindParams p;
  try {
    read_params(YAML::Load("gust_tau_s: 0"), "w.yaml", p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("gust_tau_s"), std::string::npos) << e.what();
  }
}

TEST(Wind, SteadyOnlyWithoutGusts) {
  WindParams p;
  p.steady_W_mps = {3.0, 1.0, 0.0};
  WindModel w(p, 1);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(w.step(0.01), p.steady_W_mps);
}

TEST(Wind, GustStatisticsMatchParams) {
  WindParams p;
  p.steady_W_mps = {2.0, 0.0, 0.0};
  p.gust_std_horizontal_mps = 1.0;
  p.gust_std_vertical_mps = 0.3;
  p.gust_tau_s = 2.0;
  WindModel w(p, 42);
  const double dt = 0.01;
  const int n = 2000000;  // 20000 s = 5000 correlation times (both ways)
  std::vector<double> gx(n);
  double sx = 0, sxx = 0, sz = 0, szz = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d u = w.step(dt);
    gx[i] = u.x() - 2.0;
    sx += gx[i];
    sxx += gx[i] * gx[i];
    sz += u.z();
    szz += u.z() * u.z();
  }
  const double mean_x = sx / n, std_x = std::sqrt(sxx / n - mean_x * mean_x);
  const double std_z = std::sqrt(szz / n - (sz / n) * (sz / n));
  // ~5000 independent stretches: std of the mean ~ sigma sqrt(2 tau / T) = 0.014 sigma, of
  // the std ~ 1 %; tolerances are 4x that.
  EXPECT_NEAR(mean_x, 0.0, 0.06);
  EXPECT_NEAR(std_x, 1.0, 0.04);
  EXPECT_NEAR(std_z, 0.3, 0.3 * 0.04);
  // Autocorrelation at lag tau is e^-1 for a first-order process.
  const int lag = static_cast<int>(p.gust_tau_s / dt);
  double c = 0;
  for (int i = 0; i + lag < n; ++i) c += (gx[i] - mean_x) * (gx[i + lag] - mean_x);
  c /= (n - lag) * std_x * std_x;
  constexpr double kCorrTolerance = 0.04;  // ~4x the estimator's std for 5000 stretches
  EXPECT_NEAR(c, std::exp(-1.0), kCorrTolerance);
}

TEST(Wind, SeededAndReproducible) {
  WindParams p;
  p.gust_std_horizontal_mps = 1.0;
  WindModel a(p, 7), b(p, 7), c(p, 8);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d ua = a.step(0.01);
    EXPECT_EQ(ua, b.step(0.01));
    differs = differs || (ua != c.step(0.01));
  }
  EXPECT_TRUE(differs);
}

TEST(Wind, DragOpposesAirRelativeVelocityLinearPlusQuadratic) {
  const WindParams p;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  // Moving with the air: no drag.
  EXPECT_NEAR(drag_force_W(p, I, {3, 1, 0}, {3, 1, 0}).norm(), 0.0, 1e-15);
  // Still air, moving +x at 2 m/s: F = -(c_lin 2 + c_quad 4).
  const Eigen::Vector3d F = drag_force_W(p, I, {2, 0, 0}, Eigen::Vector3d::Zero());
  EXPECT_NEAR(F.x(), -(p.drag_linear_B_Nspm.x() * 2 + p.drag_quadratic_B_Ns2pm2.x() * 4), 1e-12);
  EXPECT_NEAR(F.y(), 0.0, 1e-15);
  // Hovering in a 5 m/s wind along +y: pushed along +y.
  EXPECT_GT(drag_force_W(p, I, Eigen::Vector3d::Zero(), {0, 5, 0}).y(), 0.0);
  // Body yawed 90 deg: world x is body -y, so the y-axis coefficients apply.
  WindParams q = p;
  q.drag_linear_B_Nspm = {1.0, 2.0, 3.0};
  q.drag_quadratic_B_Ns2pm2.setZero();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_NEAR(drag_force_W(q, Rz, {1, 0, 0}, Eigen::Vector3d::Zero()).x(), -2.0, 1e-12);
}

}  // namespace
}  // namespace lander::sim
