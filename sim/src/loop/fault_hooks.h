// Test hooks of FaultParams shared by the scripted and closed-loop runs (private to sim/):
// corrupted samples for the flight software's sample screen, and broken processes (abort,
// hang) for the campaign runner's tests.
#pragma once

#include <sys/prctl.h>

#include <chrono>
#include <cstdlib>
#include <limits>
#include <string>
#include <thread>

#include "lander/core/state.h"
#include "lander/core/types.h"
#include "lander/sim/scenario.h"

namespace lander::sim {

// faults.abort_t_s: the process dies by SIGABRT; faults.hang_t_s: it sleeps forever.
// The deliberate abort leaves no core dump: with `ulimit -c unlimited` each one wrote a 400 MB
// core file into the working directory, and a host's core handler (a core_pattern pipe) could
// hold the dying process for as long as it likes. Real crashes still dump as the host says.
inline void run_process_fault_hooks(const FaultParams& f, double t_s) {
  if (f.abort_t_s >= 0 && t_s >= f.abort_t_s) {
    prctl(PR_SET_DUMPABLE, 0);
    std::abort();
  }
  if (f.hang_t_s >= 0 && t_s >= f.hang_t_s) {
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  }
}

constexpr double kFaultNaN = std::numeric_limits<double>::quiet_NaN();

inline void corrupt_sample(ImuSample& s) {
  s.gyro_B_radps.setConstant(kFaultNaN);
  s.accel_B_mps2.setConstant(kFaultNaN);
}
inline void corrupt_sample(BaroSample& s) { s.pressure_pa = kFaultNaN; }
// A fix that claims to be valid, a million kilometres away at a thousand kilometres a second.
inline void corrupt_sample(GpsSample& s) {
  s.valid = true;
  s.p_W_m = Eigen::Vector3d(1e9, -1e9, 1e9);
  s.v_W_mps = Eigen::Vector3d(1e6, 1e6, -1e6);
}
inline void corrupt_sample(UltrasonicSample& s) { s.range_m = kFaultNaN; }
inline void corrupt_sample(MagSample& s) { s.field_B_uT.setConstant(kFaultNaN); }
// (The vision faults act through the flight software's frame jobs: FrameJob::inject.)

// MuJoCo's warnings of a diverging simulation (mj_checkPos / Vel / Acc in mj_step: "Nan, Inf
// or huge value in QACC at DOF 3. The simulation is unstable.").
inline bool is_instability_warning(const std::string& what) {
  return what.find("unstable") != std::string::npos ||
         what.find("Nan, Inf or huge value") != std::string::npos;
}

}  // namespace lander::sim
