// Moved to lander_core (core/include/lander/core/types.h): estimator users keep this name.
#pragma once

#include "lander/core/types.h"
