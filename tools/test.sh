#!/usr/bin/env bash
# Builds and runs every test (CTest labels: unit, render, integration).
# Pass ctest arguments to narrow it, e.g. `bash tools/test.sh -L unit`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh > /dev/null
bash tools/build.sh
cd build
ctest --output-on-failure -j2 --timeout 1500 "$@"
