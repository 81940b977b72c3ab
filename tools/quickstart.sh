#!/usr/bin/env bash
# One command on a fresh Debian 12 machine (as root): installs the Debian packages, builds,
# and runs the default scenario with videos. Prints where the outputs went.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_deps.sh
bash tools/build.sh
scenario="${1:-scenarios/default.yaml}"
out="out/$(basename "$scenario" .yaml)"
status=0
./build/lander run "$scenario" --out "$out" --video || status=$?
echo "outputs: $(pwd)/$out"
if [ "$status" -eq 1 ]; then
  echo "the run did not land: see $out/summary.json (outcome, mode_transitions)"
elif [ "$status" -ne 0 ]; then
  exit "$status"
fi
