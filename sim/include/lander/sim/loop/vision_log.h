// The vision results a run delivered to its flight stack, recorded exactly (hexadecimal
// floating point, every bit), so that a later run can replay them instead of rendering and
// detecting: the change-indication tier of the regression checks (regression/change/) drives
// the dynamics, sensors, fusion and controller from recorded vision, keeping llvmpipe's
// machine-dependent rendering out of it.
#pragma once

#include <string>
#include <vector>

#include "lander/flight/flight_stack.h"

namespace lander::sim {

struct VisionLogEntry {
  int frame{0};
  double deliver_t_s{0.0};     ///< when the result reached the flight stack (s)
  flight::VisionResult result;  ///< as delivered (after any fault hook)
};

// Writes the log atomically (CSV, one row per frame, doubles as C99 hex floats). Throws
// OutputError naming the file.
void write_vision_log(const std::string& path, const std::vector<VisionLogEntry>& log);

// Reads a log written by write_vision_log. Throws ConfigError naming the file and line for a
// missing file or a malformed row.
std::vector<VisionLogEntry> read_vision_log(const std::string& path);

}  // namespace lander::sim
