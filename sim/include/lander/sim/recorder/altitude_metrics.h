// Per-sensor altitude error statistics for `lander bench altitude`: RMSE and max |error| of
// each source (baro, gps, vision, ultrasonic, fused) against the truth, in three bands by
// the TRUE height above the surface below: all, above_3m (h >= 3 m), below_3m (h < 3 m).
//
// JSON layout (issue 4):
//   {"baro": {"all": {"rmse_m": 0.12, "max_m": 0.4, "n": 3000},
//             "above_3m": {...}, "below_3m": {...}}, "gps": {...}, ...}
// Sensors appear in a fixed order (baro, gps, ultrasonic, vision, fused, then any other in the
// order first added), so identical runs write identical files. An empty band has
// "rmse_m": null, "max_m": null, "n": 0. "non_finite" (in "all") counts the samples whose
// error was NaN or infinite (a bad sample from the flight side must not abort the run): they
// enter no figure. A finite error whose true height is not finite counts in
// "all" only.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lander/sim/util/stats.h"

namespace lander::sim {

enum class AltitudeBand { kAll = 0, kAbove3m = 1, kBelow3m = 2 };

class AltitudeMetrics {
 public:
  static constexpr double kBandSplit_m = 3.0;  ///< seed 004's ultrasonic switch height

  // Adds one error sample (estimate - truth, m) of `sensor` taken when the true height
  // above the surface below was true_h_surface_m. Non-finite values are counted, not used.
  void add(const std::string& sensor, double error_m, double true_h_surface_m);
  // Statistics of one sensor in one band (all zero if the sensor was never added).
  ErrorStats stats(const std::string& sensor, AltitudeBand band) const;
  // Sensor names in the order first added.
  std::vector<std::string> sensors() const;
  // The JSON object described above.
  nlohmann::ordered_json json() const;

 private:
  struct Entry {
    std::string name;
    ErrorStats band[3];
  };
  std::vector<Entry> entries_;
};

}  // namespace lander::sim
