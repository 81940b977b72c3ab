// Moved to lander_core (core/include/lander/core/sample_screen.h): estimator users keep this name.
#pragma once

#include "lander/core/sample_screen.h"
