// The flight software's front door for sensor samples and vision results: anything that is
// not finite or lies outside what the sensor can physically report is a fault (a broken
// driver, a bit flip, a numerical failure in the vision pipeline), not a measurement. It is
// rejected and counted here, before any filter sees it, so no single bad sample can throw
// mid-flight or poison a filter state. (The filters also refuse non-finite inputs on their
// own; this is where the counts reported in summary.json come from.)
//
// Range checks are deliberately wide: they catch the absurd, not the merely unlikely (which
// the filters' residual gates handle). The ultrasonic's out-of-range garbage (seed 004
// eq. 12) is the altitude fusion's business; only non-finite or negative ranges stop here.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "lander/core/params_io.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander {

struct SampleLimits {
  double max_gyro_radps{35.0};         ///< |rate| per axis (rad/s); 2000 deg/s full scale
  double max_accel_mps2{160.0};        ///< |specific force| per axis (m/s^2); 16 g full scale
  double min_pressure_pa{30000.0};     ///< barometer range (Pa): ~9 km above sea level ...
  double max_pressure_pa{110000.0};    ///< ... to ~700 m below it
  double max_gps_distance_m{100000.0}; ///< |p_W| of a fix from the W origin (m)
  double max_gps_speed_mps{100.0};     ///< |v_W| of a fix (m/s)
  double max_mag_field_uT{1000.0};     ///< |field| (uT); the Earth's is 25-65 uT
  double max_vision_range_m{1000.0};   ///< |p_CP| of a vision pose (m)
  void validate() const;
};

template <class V>
void visit_fields(V& v, SampleLimits& p) {
  v("max_gyro_radps", p.max_gyro_radps, range::positive, "rad/s", "|rate| per axis");
  v("max_accel_mps2", p.max_accel_mps2, range::positive, "m/s^2", "|specific force| per axis");
  v("min_pressure_pa", p.min_pressure_pa, range::positive, "Pa", "barometer range");
  v("max_pressure_pa", p.max_pressure_pa, range::any, "Pa", "... to ~700 m below it");
  v("max_gps_distance_m", p.max_gps_distance_m, range::positive, "m",
    "|p_W| of a fix from the W origin");
  v("max_gps_speed_mps", p.max_gps_speed_mps, range::positive, "m/s", "|v_W| of a fix");
  v("max_mag_field_uT", p.max_mag_field_uT, range::positive, "uT",
    "|field|; the Earth's is 25-65 uT");
  v("max_vision_range_m", p.max_vision_range_m, range::positive, "m", "|p_CP| of a vision pose");
}

// Rejected samples by source, since the start of the flight.
struct RejectedSamples {
  long imu{0};
  long baro{0};
  long gps{0};
  long ultrasonic{0};
  long magnetometer{0};
  long vision{0};
  long total() const { return imu + baro + gps + ultrasonic + magnetometer + vision; }
};

// A vision result's pose and covariance are finite, its rotation a rotation and the platform
// in front of the camera. (Not-detected results carry no pose and pass.)
bool plausible_observation(const PlatformObservation& obs, double max_range_m = 1000.0);

class SampleScreen {
 public:
  explicit SampleScreen(const SampleLimits& limits);  // validates limits

  // The IMU sample to use: `s` when it is plausible; otherwise (counted) the last plausible
  // sample restamped at s.t_s, so the inner loop keeps running on a zero-order hold through
  // a burst of bad samples; nullopt before the first plausible sample or for a bad time stamp.
  std::optional<ImuSample> imu(const ImuSample& s);
  // True when the sample may be used; false (counted) when it is rejected.
  bool accept(const BaroSample& s);
  bool accept(const GpsSample& s);  ///< a fix flagged invalid (drop-out) is not a fault: passes
  bool accept(const UltrasonicSample& s);
  bool accept(const MagSample& s);
  bool accept(const PlatformObservation& obs);

  const RejectedSamples& rejected() const { return rejected_; }
  const SampleLimits& limits() const { return p_; }

 private:
  SampleLimits p_;
  RejectedSamples rejected_;
  std::optional<ImuSample> last_imu_;
};

}  // namespace lander
