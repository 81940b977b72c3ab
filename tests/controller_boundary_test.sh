#!/usr/bin/env bash
# The controller's boundary (issue 52): lander_controller builds against lander_core and Eigen
# only. Checks, with the include path CMake gives the controller's own sources (INCLUDES_FILE,
# written at generation time from the target's INCLUDE_DIRECTORIES with its usage
# requirements):
#   1. the controller's public headers compile (the include path is the real one);
#   2. a controller file that includes OpenCV does not compile;
#   3. no source or header under controller/ includes OpenCV, Ceres, MuJoCo, GL/EGL or the
#      estimator's, simulator's or flight software's headers (Ceres and MuJoCo sit on the
#      system include path, so only this scan can catch them).
# Usage: controller_boundary_test.sh CXX INCLUDES_FILE SOURCE_DIR
set -euo pipefail
cxx=$1 includes=$2 src=$3
flags=()
while IFS= read -r d; do
  [ -n "$d" ] && flags+=("-I$d")
done < "$includes"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "controller_boundary: FAIL: $*" >&2; exit 1; }

echo '#include "lander/controller/landing_controller.h"' > "$tmp/ok.cpp"
"$cxx" -std=c++17 -fsyntax-only "${flags[@]}" "$tmp/ok.cpp" ||
  fail "the controller's headers do not compile with its include path: ${flags[*]}"
echo "controller_boundary: the controller's headers compile with its include path (${#flags[@]} directories)"

printf '#include "lander/controller/landing_controller.h"\n#include <opencv2/core.hpp>\n' > "$tmp/cv.cpp"
if "$cxx" -std=c++17 -fsyntax-only "${flags[@]}" "$tmp/cv.cpp" 2> "$tmp/cv.err"; then
  fail "a controller file including <opencv2/core.hpp> compiled: OpenCV is on the controller's include path"
fi
grep -q "opencv2/core.hpp" "$tmp/cv.err" || fail "the OpenCV probe failed for another reason: $(head -3 "$tmp/cv.err")"
echo "controller_boundary: <opencv2/core.hpp> is not on the controller's include path"

forbidden='#[[:space:]]*include[[:space:]]*[<"](opencv2/|opencv/|ceres/|mujoco/|GL/|EGL/|GLFW/|lander/estimator/|lander/sim/|lander/flight/)'
if grep -rnE "$forbidden" "$src/controller"; then
  fail "the includes above cross the controller's boundary (lander_core and Eigen only)"
fi
echo "controller_boundary: no controller source includes a library outside lander_core and Eigen"
