// lander.Sim: a closed-loop run stepped from Python (to the next camera frame or a given
// time), with the samples the flight software was given since the last step, the frame, and
// the truth kept apart (python/lander/sim.py documents the Python side).
#pragma once

#include <pybind11/pybind11.h>

namespace lander::py {

void bind_sim(pybind11::module_& m);

}  // namespace lander::py
