#include "lander/sim/plant/ground_effect.h"

#include <algorithm>
#include <cmath>

namespace lander::sim {

namespace {
// Cheeseman-Bennett ratio T_IGE/T_OGE at height z for rotor radius R.
double cheeseman_bennett(double R, double z) {
  const double r = R / (4.0 * z);
  return 1.0 / (1.0 - r * r);
}
}  // namespace

double ground_effect_factor(const GroundEffectParams& p, double height_m) {
  if (!p.enabled || !std::isfinite(height_m) || height_m < 0) return 1.0;
  const double z_min = p.z_min_over_R * p.radius_m;
  const double z_max = p.z_max_over_R * p.radius_m;
  if (height_m >= z_max) return 1.0;
  const double z = std::max(height_m, z_min);
  return 1.0 + cheeseman_bennett(p.radius_m, z) - cheeseman_bennett(p.radius_m, z_max);
}

}  // namespace lander::sim
