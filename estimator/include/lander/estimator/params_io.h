// Moved to lander_core (core/include/lander/core/params_io.h): estimator users keep this name.
#pragma once

#include "lander/core/params_io.h"
