#include "lander/sim/plant/mujoco_errors.h"

#include <mujoco/mujoco.h>

namespace lander::sim {

namespace {
void on_error(const char* msg) { throw MujocoError(std::string("MuJoCo error: ") + msg); }
void on_warning(const char* msg) { throw MujocoError(std::string("MuJoCo warning: ") + msg); }
}  // namespace

void install_mujoco_handlers() {
  mju_user_error = on_error;
  mju_user_warning = on_warning;
}

}  // namespace lander::sim
