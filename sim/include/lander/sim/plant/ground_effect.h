// Rotor ground effect: thrust factor T_IGE / T_OGE of one rotor from its height above the
// surface directly below it (ground or platform top; the loop casts one ray per rotor).
//
// Model: Cheeseman & Bennett, "The effect of the ground on a helicopter rotor in forward
// flight", ARC R&M 3021, 1955 (hover, no forward speed; method of images):
//
//   T_IGE / T_OGE = 1 / (1 - (R / 4z)^2)                                  (CB)
//
// with R the rotor radius and z the rotor's height above the surface. (CB) is singular at
// z = R/4 and is only supported by data for z/R >~ 0.5 (Cheeseman & Bennett's own range;
// Sanchez-Cuevas et al., "Characterization of the aerodynamic ground effect and its
// influence in multirotor control", Int. J. Aerospace Eng. 2017, find single-rotor data
// follow (CB) down to about z/R = 0.5), so the height is clipped below at z_min = 0.5 R
// (factor 4/3 there). Above z_max (validity height, default 3 R) the effect is taken as
// zero. To make the factor continuous at z_max and exactly 1 above it, the value of (CB)
// at z_max (1.007 for 3 R) is subtracted:
//
//   f(z) = 1 + CB(clip(z, z_min, z_max)) - CB(z_max)
//
// This shifts the curve by at most 0.7 % inside the band.
#pragma once

#include "lander/core/params_io.h"

namespace lander::sim {

struct GroundEffectParams {
  bool enabled{true};
  double radius_m{0.19};        ///< rotor radius R (m)
  double z_min_over_R{0.5};     ///< lower clip of z/R (-); (CB) is singular at 0.25
  double z_max_over_R{3.0};     ///< validity height / R (-); factor is 1 above it

  void validate() const {
    check_fields(*this);
    require(z_max_over_R > z_min_over_R, "z_max_over_R", "must be > z_min_over_R");
  }
};

template <class V>
void visit_fields(V& v, GroundEffectParams& p) {
  v("enabled", p.enabled, range::any, "", "");
  v("radius_m", p.radius_m, range::positive, "m", "rotor radius R");
  v("z_min_over_R", p.z_min_over_R, range::greater_than(0.25).because("Cheeseman-Bennett pole"), "",
    "lower clip of z/R");
  v("z_max_over_R", p.z_max_over_R, range::any, "", "validity height / R");
}

// Thrust factor f >= 1 for a rotor whose plane is height_m above the surface below it.
// A non-finite or negative height (no surface hit) gives 1.
double ground_effect_factor(const GroundEffectParams& p, double height_m);

}  // namespace lander::sim
