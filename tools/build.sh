#!/usr/bin/env bash
# Configures and builds everything (the `lander` tool and all tests) in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build.log 2>&1 || { cat build.log; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 || { tail -50 build.log; exit 1; }
# The Python package (build/python/lander) on Debian's python3's path, from any directory.
if [ -d build/python/lander ]; then
  site="$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')"
  if mkdir -p "$site" 2> /dev/null && echo "$(pwd)/build/python" > "$site/lander.pth" 2> /dev/null; then
    echo "build: python package: $site/lander.pth -> $(pwd)/build/python"
  else
    echo "build: not root: add $(pwd)/build/python to PYTHONPATH for 'import lander'"
  fi
fi
echo "build: ok (build/lander)"
