// Levenberg-Marquardt refinement of X_CP on the conic reprojection cost (seed 000 eq. 14-15).
//
// For a circle (centre c, radius r) on the plane z = 0 of P, with H = K [r1 r2 t] (eq. 10),
// its image is C'(R, t) ~ H^-T C H^-1 (eq. 14); H^-1 ~ adj(H), so C' ~ adj(H)^T C adj(H) up to
// a positive scale. Eq. (15) sums (x_i^T C' x_i)^2 over image points x_i of the detected
// ellipse; the algebraic value depends on the scale of C' and on where x lies, so each term
// is divided by |grad(x^T C' x)| (Sampson): the residual is then the first-order geometric
// distance of the edge point to the predicted ellipse, in pixels, invariant to the scale.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>

#include "vision/internal.h"

namespace lander::vision_internal {

namespace {

struct ConicEdgeCost {
  ConicEdgeCost(const Eigen::Matrix3d& K, const Eigen::Vector2d& c, double r,
                std::vector<Eigen::Vector2d> pts)
      : K_(K), c_(c), r_(r), pts_(std::move(pts)) {}

  template <class T>
  bool operator()(const T* const x, T* residuals) const {
    // R_CP (column-major) from the angle-axis x[0..2], t = x[3..5].
    T R[9];
    ceres::AngleAxisToRotationMatrix(x, R);
    // M = [r1 r2 t]; H = K M.
    Eigen::Matrix<T, 3, 3> M;
    M << R[0], R[3], x[3], R[1], R[4], x[4], R[2], R[5], x[5];
    const Eigen::Matrix<T, 3, 3> H = K_.cast<T>() * M;
    // adj(H) = cofactor matrix transposed.
    Eigen::Matrix<T, 3, 3> A;
    A(0, 0) = H(1, 1) * H(2, 2) - H(1, 2) * H(2, 1);
    A(0, 1) = H(0, 2) * H(2, 1) - H(0, 1) * H(2, 2);
    A(0, 2) = H(0, 1) * H(1, 2) - H(0, 2) * H(1, 1);
    A(1, 0) = H(1, 2) * H(2, 0) - H(1, 0) * H(2, 2);
    A(1, 1) = H(0, 0) * H(2, 2) - H(0, 2) * H(2, 0);
    A(1, 2) = H(0, 2) * H(1, 0) - H(0, 0) * H(1, 2);
    A(2, 0) = H(1, 0) * H(2, 1) - H(1, 1) * H(2, 0);
    A(2, 1) = H(0, 1) * H(2, 0) - H(0, 0) * H(2, 1);
    A(2, 2) = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
    Eigen::Matrix<T, 3, 3> Cp;
    Cp << T(1), T(0), T(-c_.x()), T(0), T(1), T(-c_.y()), T(-c_.x()), T(-c_.y()),
        T(c_.squaredNorm() - r_ * r_);
    const Eigen::Matrix<T, 3, 3> C = A.transpose() * Cp * A;  // eq. (14), up to scale
    for (std::size_t i = 0; i < pts_.size(); ++i) {
      const Eigen::Matrix<T, 3, 1> xh(T(pts_[i].x()), T(pts_[i].y()), T(1));
      const Eigen::Matrix<T, 3, 1> Cx = C * xh;
      const T g = T(2) * ceres::sqrt(Cx(0) * Cx(0) + Cx(1) * Cx(1));
      residuals[i] = xh.dot(Cx) / g;  // eq. (15) term, Sampson-normalised (px)
    }
    return true;
  }

  Eigen::Matrix3d K_;
  Eigen::Vector2d c_;
  double r_;
  std::vector<Eigen::Vector2d> pts_;
};

struct PointCost {
  PointCost(const Eigen::Matrix3d& K, std::vector<PointObservation> pts)
      : K_(K), pts_(std::move(pts)) {}
  template <class T>
  bool operator()(const T* const x, T* residuals) const {
    for (std::size_t i = 0; i < pts_.size(); ++i) {
      const T P[3] = {T(pts_[i].c_P_m.x()), T(pts_[i].c_P_m.y()), T(0)};
      T q[3];
      ceres::AngleAxisRotatePoint(x, P, q);
      q[0] += x[3];
      q[1] += x[4];
      q[2] += x[5];
      residuals[2 * i] = T(K_(0, 0)) * q[0] / q[2] + T(K_(0, 2)) - T(pts_[i].px.x());
      residuals[2 * i + 1] = T(K_(1, 1)) * q[1] / q[2] + T(K_(1, 2)) - T(pts_[i].px.y());
    }
    return true;
  }
  Eigen::Matrix3d K_;
  std::vector<PointObservation> pts_;
};

// Yaw offset: the z component (in P) of the small rotation R_prior^T R.
struct YawPriorCost {
  explicit YawPriorCost(const YawPrior& p) : R0_(p.R_CP), w_(1.0 / p.sigma_rad) {}
  template <class T>
  bool operator()(const T* const x, T* residual) const {
    T R[9];
    ceres::AngleAxisToRotationMatrix(x, R);  // column-major
    // Rrel = R0^T R; Rrel(1,0) - Rrel(0,1) = col0(R0)... via dot products of columns.
    T r10 = T(0), r01 = T(0);
    for (int k = 0; k < 3; ++k) {
      r10 += T(R0_(k, 1)) * R[k];      // R0 col 1 . R col 0
      r01 += T(R0_(k, 0)) * R[3 + k];  // R0 col 0 . R col 1
    }
    residual[0] = T(w_) * T(0.5) * (r10 - r01);
    return true;
  }
  Eigen::Matrix3d R0_;
  double w_;
};

}  // namespace

RefineResult refine_pose_conics(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP0,
                                const std::vector<ConicObservation>& obs, int points_per_ellipse,
                                int max_iter, const std::vector<PointObservation>* points,
                                const YawPrior* yaw_prior) {
  RefineResult res;
  double x[6];
  const Eigen::AngleAxisd aa(X_CP0.linear());
  const Eigen::Vector3d rv = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) {
    x[i] = rv(i);
    x[3 + i] = X_CP0.translation()(i);
  }
  ceres::Problem::Options popts;
  ceres::Problem problem(popts);
  int m = 0;
  for (const auto& o : obs) {
    const auto& all = *o.points;
    if (all.empty()) continue;
    // An even subset of the edge points (they are ordered around the ellipse).
    std::vector<Eigen::Vector2d> pts;
    const int n = static_cast<int>(all.size());
    const int want = std::min(n, points_per_ellipse);
    for (int k = 0; k < want; ++k) pts.push_back(all[(static_cast<long>(k) * n) / want]);
    m += want;
    auto* cost = new ceres::AutoDiffCostFunction<ConicEdgeCost, ceres::DYNAMIC, 6>(
        new ConicEdgeCost(K, o.c_P_m, o.r_m, std::move(pts)), want);
    problem.AddResidualBlock(cost, nullptr, x);
  }
  if (points != nullptr && !points->empty()) {
    const int np = static_cast<int>(points->size());
    auto* cost = new ceres::AutoDiffCostFunction<PointCost, ceres::DYNAMIC, 6>(
        new PointCost(K, *points), 2 * np);
    problem.AddResidualBlock(cost, nullptr, x);
    m += 2 * np;
  }
  if (yaw_prior != nullptr) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<YawPriorCost, 1, 6>(new YawPriorCost(*yaw_prior)), nullptr,
        x);
    m += 1;
  }
  if (m < 12) return res;
  ceres::Solver::Options opts;
  opts.linear_solver_type = ceres::DENSE_QR;
  opts.max_num_iterations = max_iter;
  opts.num_threads = 1;
  opts.function_tolerance = 1e-8;
  opts.gradient_tolerance = 1e-10;
  opts.parameter_tolerance = 1e-8;
  opts.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(opts, &problem, &summary);
  if (!summary.IsSolutionUsable()) return res;
  res.iterations = static_cast<int>(summary.iterations.size());

  // Covariance: sigma^2 (J^T J)^-1 with sigma^2 = SSR / (m - 6).
  double cost = 0.0;
  ceres::CRSMatrix J;
  std::vector<double> r;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, &r, nullptr, &J);
  Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
  for (int row = 0; row < J.num_rows; ++row) {
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (int k = J.rows[row]; k < J.rows[row + 1]; ++k) g(J.cols[k]) = J.values[k];
    JtJ += g * g.transpose();
  }
  double ssr = 0.0;
  for (double v : r) ssr += v * v;
  res.rms_px = std::sqrt(ssr / std::max<std::size_t>(1, r.size()));
  const double sigma2 = ssr / std::max(1, m - 6);
  Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(JtJ);
  if (!lu.isInvertible()) return res;
  res.cov = sigma2 * lu.inverse();

  Eigen::Vector3d v(x[0], x[1], x[2]);
  const double ang = v.norm();
  res.X_CP = Eigen::Isometry3d::Identity();
  res.X_CP.linear() = ang > 0 ? Eigen::AngleAxisd(ang, v / ang).toRotationMatrix()
                              : Eigen::Matrix3d::Identity();
  res.X_CP.translation() = Eigen::Vector3d(x[3], x[4], x[5]);
  res.ok = x[5] > 0.0;  // platform in front of the camera
  return res;
}

}  // namespace lander::vision_internal
