#include "lander/sim/recorder/altitude_metrics.h"

#include <algorithm>
#include <iterator>

#include <cmath>
#include <limits>

namespace lander::sim {

void AltitudeMetrics::add(const std::string& sensor, double error_m, double true_h_surface_m) {
  Entry* e = nullptr;
  for (auto& x : entries_) {
    if (x.name == sensor) e = &x;
  }
  if (!e) {
    entries_.push_back(Entry{sensor, {}});
    e = &entries_.back();
  }
  e->band[static_cast<int>(AltitudeBand::kAll)].add(error_m);
  // A non-finite error is counted (in "all") and used nowhere; without a finite true
  // height the sample has no band.
  if (!std::isfinite(error_m) || !std::isfinite(true_h_surface_m)) return;
  const AltitudeBand b =
      true_h_surface_m >= kBandSplit_m ? AltitudeBand::kAbove3m : AltitudeBand::kBelow3m;
  e->band[static_cast<int>(b)].add(error_m);
}

ErrorStats AltitudeMetrics::stats(const std::string& sensor, AltitudeBand band) const {
  for (const auto& x : entries_) {
    if (x.name == sensor) return x.band[static_cast<int>(band)];
  }
  return {};
}

std::vector<std::string> AltitudeMetrics::sensors() const {
  std::vector<std::string> out;
  for (const auto& x : entries_) out.push_back(x.name);
  return out;
}

nlohmann::ordered_json AltitudeMetrics::json() const {
  static const char* kBandNames[3] = {"all", "above_3m", "below_3m"};
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  // A fixed order, not the order first added: with the overlapped vision schedule a frame's
  // result is recorded when the worker is joined, whose step varies with thread timing, so
  // "vision" could come first in one run and after "fused" in an identical one.
  static const char* kOrder[] = {"baro", "gps", "ultrasonic", "vision", "fused"};
  auto rank = [&](const std::string& n) {
    for (std::size_t i = 0; i < std::size(kOrder); ++i) {
      if (n == kOrder[i]) return i;
    }
    return std::size(kOrder);
  };
  std::vector<const Entry*> order;
  for (const Entry& e : entries_) order.push_back(&e);
  std::stable_sort(order.begin(), order.end(),
                   [&](const Entry* a, const Entry* b) { return rank(a->name) < rank(b->name); });
  for (const Entry* ep : order) {
    const Entry& e = *ep;
    nlohmann::ordered_json sensor;
    for (int b = 0; b < 3; ++b) {
      const ErrorStats& s = e.band[b];
      nlohmann::ordered_json band;
      band["rmse_m"] = s.rmse_m();  // NaN: written as null
      band["max_m"] = s.n ? s.max_abs_m : std::numeric_limits<double>::quiet_NaN();
      band["n"] = s.n;
      band["non_finite"] = s.non_finite;
      sensor[kBandNames[b]] = band;
    }
    out[e.name] = sensor;
  }
  return out;
}

}  // namespace lander::sim
