// MuJoCo error and warning handlers that throw. MuJoCo 2.2.2's default error handler prints,
// waits for Enter on stdin and exits; a library must never do that (STYLE.md 7).
#pragma once

#include <stdexcept>
#include <string>

namespace lander::sim {

class MujocoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Installs handlers so that any MuJoCo error or warning throws MujocoError. Idempotent.
// (MuJoCo calls the handlers from C code; throwing through it is what MuJoCo's own test
// fixture does, and the engine state is discarded after such an error anyway.)
void install_mujoco_handlers();

}  // namespace lander::sim
