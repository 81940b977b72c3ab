// Moved to lander_core (core/include/lander/core/state.h): estimator users keep this name.
#pragma once

#include "lander/core/state.h"
