#include "lander/estimator/vision_params.h"

namespace lander {

void VisionParams::validate() const {
  check_fields(*this);
  require(adaptive_block_px >= 3 && adaptive_block_px % 2 == 1, "adaptive_block_px",
          "must be odd and >= 3");
  require(!shadow_pass || !shadow_levels.empty(), "shadow_levels",
          "must not be empty when shadow_pass is on");
  for (double f : shadow_levels) {
    require(f > 0 && f < 1, "shadow_levels", "each level must be in (0, 1)");
  }
  require(code_threshold_block_px >= 3 && code_threshold_block_px % 2 == 1,
          "code_threshold_block_px", "must be odd and >= 3");
}

}  // namespace lander
