// Conic geometry for the ring target (seed 000 section 2.1-2.3).
//
// A conic is a symmetric 3x3 matrix C with x^T C x = 0 for homogeneous image points
// x = (u, v, 1) in (undistorted) pixels. Convention here: the interior is x^T C x < 0
// (C is scaled so that its upper-left 2x2 block is positive definite for an ellipse).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lander {

using Conic = Eigen::Matrix3d;

// Ellipse in centre/axes form: centre (px), semi-axes a >= b (px), angle of the a axis from
// image +u towards +v (rad).
struct EllipseParams {
  Eigen::Vector2d centre{Eigen::Vector2d::Zero()};
  double a{0.0};
  double b{0.0};
  double angle_rad{0.0};
};

// Conic of an ellipse (interior negative, Frobenius norm 1).
Conic conic_from_ellipse(const EllipseParams& e);
// Centre/axes of an ellipse conic; nullopt if C is not a real ellipse.
std::optional<EllipseParams> ellipse_from_conic(const Conic& C);
// Scales C to unit Frobenius norm with the interior negative. Returns false if not an ellipse.
bool normalise_conic(Conic& C);

// Least-squares ellipse fit to points (px): Fitzgibbon-Pilu-Fisher direct fit (ellipse-
// specific, a 4ac - b^2 = 1 constraint) on Hartley-normalised coordinates. nullopt for fewer
// than 6 points or a degenerate set. `rms_px`, if given, receives the RMS Sampson distance.
std::optional<Conic> fit_ellipse(const std::vector<Eigen::Vector2d>& pts, double* rms_px = nullptr);

// First-order geometric (Sampson) distance of point x (px) to conic C (px): x^T C x / |grad|.
double sampson_distance(const Conic& C, const Eigen::Vector2d& x);

// Image of the circle of radius r (m) centred at c_P (m) on the plane z = 0 of P, through
// the homography H = K [r1 r2 t] (seed 000 eq. 10, 14): C' ~ H^-T C H^-1.
Eigen::Matrix3d plane_homography(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP);
Conic project_circle(const Eigen::Matrix3d& H, const Eigen::Vector2d& c_P_m, double r_m);

// Concentric test of seed 000 eq. (1): each ellipse's centre lies inside the other
// (p1^T C2 p1 < 0 and p2^T C1 p2 < 0).
bool concentric_test(const Conic& C1, const Conic& C2);

// Parameters t of the points x0 + t d where the line meets conic C, ascending; nullopt if it
// misses.
std::optional<std::pair<double, double>> intersect_line(const Conic& C, const Eigen::Vector2d& x0,
                                                        const Eigen::Vector2d& d);

// Point p on the line through the pairs (a, b) and (c, d) (line parameters) such that
// Cr{a, b; p, q} = Cr{c, d; p, q} = -1 for one q (seed 000 eq. 2-3), the root between c and d.
// Written as the quadratic A p^2 + B p + C = 0 obtained by eliminating q, which stays well
// conditioned when q goes to infinity (fronto-parallel view), unlike the p + q form of eq. 7.
std::optional<double> harmonic_point(double a, double b, double c, double d);

struct HarmonicCentreResult {
  Eigen::Vector2d centre{Eigen::Vector2d::Zero()};  ///< projected circle centre (px)
  int iterations{0};
  bool converged{false};
};

// Projected common centre of the circles imaged as C_outer and C_inner by the recursive
// harmonic-ratio construction of seed 000 eq. (2)-(8): from p_0 (the inner ellipse centre),
// draw a line through p_i, intersect both conics, take the harmonic point of eq. (2) as
// p_{i+1}; alternate between the two principal directions of the outer ellipse (the paper
// uses vertical and horizontal lines; any two directions work, the conic's axes converge
// fastest); stop when |p_{i+1} - p_i| < tol_px or after max_iter. nullopt if a line misses.
std::optional<HarmonicCentreResult> harmonic_centre(const Conic& C_outer, const Conic& C_inner,
                                                    double tol_px = 1e-9, int max_iter = 200);

// Closed form (Kim, Gurdjos and Kweon 2005): the projected centre is the eigenvector of
// C_outer^-1 C_inner for its distinct eigenvalue. For tests and checks.
std::optional<Eigen::Vector2d> closed_form_centre(const Conic& C_outer, const Conic& C_inner);

// Cross-ratio Cr{o1, i1; i2, o2} (seed 000 eq. 9) along the line through `centre` with
// direction d; nullopt if the line misses either conic.
std::optional<double> cross_ratio_through(const Conic& C_outer, const Conic& C_inner,
                                          const Eigen::Vector2d& centre, const Eigen::Vector2d& d);
// The inner/outer radius ratio rho with (1 + rho)^2 / (4 rho) = k, rho in (0, 1]: the
// inverse of RingSet::cross_ratio(), better conditioned for matching near k = 1.
double radius_ratio_from_cross_ratio(double k);

}  // namespace lander
