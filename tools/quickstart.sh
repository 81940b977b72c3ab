#!/usr/bin/env bash
# One command on a fresh Debian 12 machine (as root): installs the Debian packages, builds,
# and runs the default scenario with videos. Prints where the outputs went.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
bash tools/build.sh
scenario="${1:-scenarios/default.yaml}"
out="out/$(basename "$scenario" .yaml)"
./build/lander run "$scenario" --out "$out" --video
echo "outputs: $(pwd)/$out"
