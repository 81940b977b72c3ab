#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "lander/estimator/vision_conic.h"

namespace lander {

namespace {
// Roots of A t^2 + 2 B t + C = 0 (note the 2), ascending, by the cancellation-free formula.
std::optional<std::pair<double, double>> quad_roots_2b(double A, double B, double C) {
  const double disc = B * B - A * C;
  if (disc < 0.0 || A == 0.0) return std::nullopt;
  const double q = -(B + std::copysign(std::sqrt(disc), B));
  if (q == 0.0) return std::make_pair(0.0, 0.0);
  double t1 = q / A, t2 = C / q;
  if (t1 > t2) std::swap(t1, t2);
  return std::make_pair(t1, t2);
}
}  // namespace

bool normalise_conic(Conic& C) {
  C = 0.5 * (C + C.transpose()).eval();
  const double n = C.norm();
  if (!(n > 0.0) || !std::isfinite(n)) return false;
  C /= n;
  if (C.topLeftCorner<2, 2>().determinant() <= 0.0) return false;  // not an ellipse
  if (C.topLeftCorner<2, 2>().trace() < 0.0) C = -C;
  // Interior must be negative: value at the centre < 0 (else an imaginary ellipse).
  const Eigen::Matrix2d A = C.topLeftCorner<2, 2>();
  const Eigen::Vector2d c = -A.inverse() * C.topRightCorner<2, 1>();
  const Eigen::Vector3d ch(c.x(), c.y(), 1.0);
  return ch.dot(C * ch) < 0.0;
}

Conic conic_from_ellipse(const EllipseParams& e) {
  const double ca = std::cos(e.angle_rad), sa = std::sin(e.angle_rad);
  Eigen::Matrix2d R;
  R << ca, -sa, sa, ca;
  const Eigen::Matrix2d A =
      R * Eigen::Vector2d(1.0 / (e.a * e.a), 1.0 / (e.b * e.b)).asDiagonal() * R.transpose();
  Conic C;
  C.topLeftCorner<2, 2>() = A;
  C.topRightCorner<2, 1>() = -A * e.centre;
  C.bottomLeftCorner<1, 2>() = (-A * e.centre).transpose();
  C(2, 2) = e.centre.dot(A * e.centre) - 1.0;
  C /= C.norm();
  return C;
}

std::optional<EllipseParams> ellipse_from_conic(const Conic& Cin) {
  Conic C = Cin;
  if (!normalise_conic(C)) return std::nullopt;
  const Eigen::Matrix2d A = C.topLeftCorner<2, 2>();
  const Eigen::Vector2d c = -A.ldlt().solve(C.topRightCorner<2, 1>());
  const double k = C(2, 2) + C.topRightCorner<2, 1>().dot(c);  // value at the centre, < 0
  if (!(k < 0.0)) return std::nullopt;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(A / -k);
  const Eigen::Vector2d l = es.eigenvalues();  // ascending: l0 -> major axis
  if (!(l(0) > 0.0)) return std::nullopt;
  EllipseParams e;
  e.centre = c;
  e.a = 1.0 / std::sqrt(l(0));
  e.b = 1.0 / std::sqrt(l(1));
  const Eigen::Vector2d v = es.eigenvectors().col(0);
  e.angle_rad = std::atan2(v.y(), v.x());
  return e;
}

// Direct least-squares ellipse fit (Fitzgibbon, Pilu and Fisher 1999) in the numerically
// stable block form of Halir and Flusser 1998, on points normalised to zero mean and RMS
// radius sqrt(2) (Hartley), then mapped back: C = N^T C_n N.
std::optional<Conic> fit_ellipse(const std::vector<Eigen::Vector2d>& pts, double* rms_px) {
  const int n = static_cast<int>(pts.size());
  if (n < 6) return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= n;
  double dist = 0.0;
  for (const auto& p : pts) dist += (p - mean).norm();
  dist /= n;
  if (!(dist > 0.0)) return std::nullopt;
  const double s = std::sqrt(2.0) / dist;
  Eigen::Matrix3d S1 = Eigen::Matrix3d::Zero(), S2 = Eigen::Matrix3d::Zero(),
                  S3 = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const double x = (p.x() - mean.x()) * s, y = (p.y() - mean.y()) * s;
    const Eigen::Vector3d d1(x * x, x * y, y * y), d2(x, y, 1.0);
    S1 += d1 * d1.transpose();
    S2 += d1 * d2.transpose();
    S3 += d2 * d2.transpose();
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu3(S3);
  if (!lu3.isInvertible()) return std::nullopt;
  const Eigen::Matrix3d T = -lu3.solve(S2.transpose());
  const Eigen::Matrix3d M = S1 + S2 * T;
  Eigen::Matrix3d Mp;
  Mp.row(0) = 0.5 * M.row(2);
  Mp.row(1) = -M.row(1);
  Mp.row(2) = 0.5 * M.row(0);
  Eigen::EigenSolver<Eigen::Matrix3d> es(Mp);
  int best = -1;
  double best_cond = 0.0;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d v = es.eigenvectors().col(i).real();
    const double cond = 4.0 * v(0) * v(2) - v(1) * v(1);
    if (cond > 0.0 && (best < 0 || cond / v.squaredNorm() > best_cond)) {
      best = i;
      best_cond = cond / v.squaredNorm();
    }
  }
  if (best < 0) return std::nullopt;
  const Eigen::Vector3d a1 = es.eigenvectors().col(best).real();
  const Eigen::Vector3d a2 = T * a1;
  Conic Cn;
  Cn << a1(0), 0.5 * a1(1), 0.5 * a2(0), 0.5 * a1(1), a1(2), 0.5 * a2(1), 0.5 * a2(0),
      0.5 * a2(1), a2(2);
  Eigen::Matrix3d N;
  N << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
  Conic C = N.transpose() * Cn * N;
  if (!normalise_conic(C)) return std::nullopt;
  if (rms_px) {
    double ss = 0.0;
    for (const auto& p : pts) {
      const double d = sampson_distance(C, p);
      ss += d * d;
    }
    *rms_px = std::sqrt(ss / n);
  }
  return C;
}

double sampson_distance(const Conic& C, const Eigen::Vector2d& x) {
  const Eigen::Vector3d xh(x.x(), x.y(), 1.0);
  const Eigen::Vector3d Cx = C * xh;
  const double g = 2.0 * Cx.head<2>().norm();
  return g > 0.0 ? xh.dot(Cx) / g : std::numeric_limits<double>::infinity();
}

Eigen::Matrix3d plane_homography(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP) {
  Eigen::Matrix3d M;
  M.col(0) = X_CP.linear().col(0);
  M.col(1) = X_CP.linear().col(1);
  M.col(2) = X_CP.translation();
  return K * M;
}

Conic project_circle(const Eigen::Matrix3d& H, const Eigen::Vector2d& c, double r) {
  Conic Cp;
  Cp << 1, 0, -c.x(), 0, 1, -c.y(), -c.x(), -c.y(), c.squaredNorm() - r * r;
  const Eigen::Matrix3d Hi = H.inverse();
  Conic C = Hi.transpose() * Cp * Hi;
  normalise_conic(C);
  return C;
}

bool concentric_test(const Conic& C1, const Conic& C2) {
  const auto e1 = ellipse_from_conic(C1), e2 = ellipse_from_conic(C2);
  if (!e1 || !e2) return false;
  const Eigen::Vector3d p1(e1->centre.x(), e1->centre.y(), 1.0);
  const Eigen::Vector3d p2(e2->centre.x(), e2->centre.y(), 1.0);
  return p1.dot(C2 * p1) < 0.0 && p2.dot(C1 * p2) < 0.0;  // seed 000 eq. (1)
}

std::optional<std::pair<double, double>> intersect_line(const Conic& C, const Eigen::Vector2d& x0,
                                                        const Eigen::Vector2d& d) {
  const Eigen::Vector3d X(x0.x(), x0.y(), 1.0), D(d.x(), d.y(), 0.0);
  return quad_roots_2b(D.dot(C * D), D.dot(C * X), X.dot(C * X));
}

// Eliminating q from the two harmonic conditions 2pq - (a+b)(p+q) + 2ab = 0 and
// 2pq - (c+d)(p+q) + 2cd = 0 (eq. 3 expanded) gives
//   [(a+b) - (c+d)] p^2 - 2 (ab - cd) p + [ab (c+d) - cd (a+b)] = 0,
// whose roots are p and q. The paper's eq. (4)-(8) is the same pair written with
// k = p + q; that form divides by (a+b) - (c+d), which vanishes in a fronto-parallel view.
std::optional<double> harmonic_point(double a, double b, double c, double d) {
  const double A = (a + b) - (c + d);
  const double B = -2.0 * (a * b - c * d);
  const double C = a * b * (c + d) - c * d * (a + b);
  const double lo = std::min(c, d), hi = std::max(c, d);
  const double disc = B * B - 4.0 * A * C;
  if (disc < 0.0) return std::nullopt;
  const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
  std::optional<double> best;
  auto consider = [&](double r) {
    if (std::isfinite(r) && r >= lo && r <= hi) best = r;
  };
  if (q != 0.0) consider(C / q);
  if (A != 0.0) consider(q / A);
  return best;
}

std::optional<HarmonicCentreResult> harmonic_centre(const Conic& C_outer, const Conic& C_inner,
                                                    double tol_px, int max_iter) {
  const auto ei = ellipse_from_conic(C_inner);
  const auto eo = ellipse_from_conic(C_outer);
  if (!ei || !eo) return std::nullopt;
  const Eigen::Vector2d dirs[2] = {
      Eigen::Vector2d(std::cos(eo->angle_rad), std::sin(eo->angle_rad)),
      Eigen::Vector2d(-std::sin(eo->angle_rad), std::cos(eo->angle_rad))};
  HarmonicCentreResult res;
  Eigen::Vector2d p = ei->centre;  // p_0: the fitted inner ellipse centre
  double last_step = std::numeric_limits<double>::infinity();
  for (int i = 0; i < max_iter; ++i) {
    const Eigen::Vector2d& d = dirs[i % 2];
    const auto o = intersect_line(C_outer, p, d);
    const auto in = intersect_line(C_inner, p, d);
    if (!o || !in) return std::nullopt;
    const auto t = harmonic_point(o->first, o->second, in->first, in->second);  // eq. (2)-(8)
    if (!t) return std::nullopt;
    p += *t * d;
    res.iterations = i + 1;
    const double step = std::abs(*t);
    if (step < tol_px && last_step < tol_px) {
      res.converged = true;
      break;
    }
    last_step = step;
  }
  res.centre = p;
  return res;
}

std::optional<Eigen::Vector2d> closed_form_centre(const Conic& C_outer, const Conic& C_inner) {
  const Eigen::Matrix3d M = C_outer.fullPivLu().solve(C_inner);
  Eigen::EigenSolver<Eigen::Matrix3d> es(M);
  const Eigen::Vector3cd ev = es.eigenvalues();
  int best = -1;
  double best_sep = -1.0;
  for (int i = 0; i < 3; ++i) {
    double sep = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j) {
      if (j != i) sep = std::min(sep, std::abs(ev(i) - ev(j)));
    }
    if (sep > best_sep) {
      best_sep = sep;
      best = i;
    }
  }
  const Eigen::Vector3d v = es.eigenvectors().col(best).real();
  if (std::abs(v.z()) < 1e-15) return std::nullopt;
  return Eigen::Vector2d(v.x() / v.z(), v.y() / v.z());
}

std::optional<double> cross_ratio_through(const Conic& C_outer, const Conic& C_inner,
                                          const Eigen::Vector2d& centre,
                                          const Eigen::Vector2d& d) {
  const auto o = intersect_line(C_outer, centre, d);
  const auto i = intersect_line(C_inner, centre, d);
  if (!o || !i) return std::nullopt;
  const double o1 = o->first, o2 = o->second, i1 = i->first, i2 = i->second;
  const double den = (i2 - i1) * (o2 - o1);
  if (den == 0.0) return std::nullopt;
  return ((i2 - o1) * (o2 - i1)) / den;  // Cr{o1, i1; i2, o2}, seed 000 eq. (9)
}

double radius_ratio_from_cross_ratio(double k) {
  if (!(k > 1.0)) return 1.0;
  return (2.0 * k - 1.0) - 2.0 * std::sqrt(k * k - k);
}

}  // namespace lander
