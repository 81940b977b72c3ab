#!/usr/bin/env bash
# Builds everything with clang + AddressSanitizer + UndefinedBehaviorSanitizer (and the
# libFuzzer targets: one instrumented build serves both) in build-san/, then runs the unit
# and integration tests under the sanitizers. Extra arguments go to ctest.
# Skipped under the sanitizers (stated here, run in the plain build): the render tests (the
# slowest; llvmpipe's JIT is not instrumented anyway), the one-node Slurm cluster test, the
# chromium report test (Python) and the campaign integration tests (each run is its own
# process; the runner's own code is covered by the campaign unit tests).
set -euo pipefail
cd "$(dirname "$0")/.."
ASAN_BASE="abort_on_error=1:strict_string_checks=1"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$PWD/tools/lsan.supp:print_suppressions=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
CC=clang CXX=clang++ cmake -S . -B build-san -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DLANDER_FUZZ=ON > build-san.log 2>&1 || { cat build-san.log; exit 1; }
cmake --build build-san -j"$(nproc)" >> build-san.log 2>&1 || { tail -50 build-san.log; exit 1; }
echo "sanitize: build ok (build-san/)"
cd build-san
# Unit tests with LeakSanitizer on. The integration tests run whole landings whose GL driver
# (Mesa, loaded with dlopen by libEGL) is unloaded before exit: its one-time allocations
# can then be neither symbolized nor suppressed by name, so leak checking is off there
# (AddressSanitizer's memory errors and UBSan stay on).
ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:$ASAN_BASE}" \
  ctest --output-on-failure -j2 --timeout 1500 -L unit "$@"
ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0:$ASAN_BASE}" \
  ctest --output-on-failure -j2 --timeout 1500 -L integration \
  -E 'campaign_slurm_cluster|campaign_report_html|CampaignRunner|gate_test|smoke_gate' "$@"
