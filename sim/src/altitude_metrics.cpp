#include "lander/sim/altitude_metrics.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace lander::sim {

double ErrorStats::rmse_m() const {
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(sum_sq_m2 / static_cast<double>(n));
}

void ErrorStats::add(double error_m) {
  ++n;
  sum_sq_m2 += error_m * error_m;
  max_abs_m = std::max(max_abs_m, std::abs(error_m));
}

void AltitudeMetrics::add(const std::string& sensor, double error_m, double true_h_surface_m) {
  if (!std::isfinite(error_m) || !std::isfinite(true_h_surface_m)) {
    throw std::invalid_argument("AltitudeMetrics::add: non-finite value for '" + sensor + "'");
  }
  Entry* e = nullptr;
  for (auto& x : entries_) {
    if (x.name == sensor) e = &x;
  }
  if (!e) {
    entries_.push_back(Entry{sensor, {}});
    e = &entries_.back();
  }
  e->band[static_cast<int>(AltitudeBand::kAll)].add(error_m);
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

namespace {
void write_number(std::ostringstream& os, double v) {
  if (std::isfinite(v)) {
    os << v;
  } else {
    os << "null";
  }
}
}  // namespace

std::string AltitudeMetrics::to_json() const {
  static const char* kBandNames[3] = {"all", "above_3m", "below_3m"};
  std::ostringstream os;
  os << std::setprecision(6);
  os << "{";
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    if (i) os << ", ";
    os << "\"" << entries_[i].name << "\": {";
    for (int b = 0; b < 3; ++b) {
      const ErrorStats& s = entries_[i].band[b];
      if (b) os << ", ";
      os << "\"" << kBandNames[b] << "\": {\"rmse_m\": ";
      write_number(os, s.rmse_m());
      os << ", \"max_m\": ";
      write_number(os, s.n ? s.max_abs_m : std::numeric_limits<double>::quiet_NaN());
      os << ", \"n\": " << s.n << "}";
    }
    os << "}";
  }
  os << "}";
  return os.str();
}

}  // namespace lander::sim
