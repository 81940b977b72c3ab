#!/usr/bin/env bash
# Runs each libFuzzer target for SECONDS (default 60) on the committed seed corpus
# (tests/fuzz/corpus/<target>/, read-only; new inputs go to a scratch corpus) and fails if any
# input crashes, trips a sanitizer, or throws anything but a ConfigError. Builds build-san/
# first (tools/sanitize.sh's build) if needed.
#   bash tools/fuzz.sh 600          # ten minutes each
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH="${1:-60}"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
if [ ! -f build-san/CMakeCache.txt ]; then
  CC=clang CXX=clang++ cmake -S . -B build-san -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" \
    -DLANDER_FUZZ=ON -DLANDER_PYTHON=OFF > build-san.log 2>&1 || { cat build-san.log; exit 1; }
fi
cmake --build build-san -j"$(nproc)" --target fuzz_scenario fuzz_target_camera fuzz_detector \
  >> build-san.log 2>&1 || { tail -50 build-san.log; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf -- "$work"' EXIT
status=0
for t in fuzz_scenario:scenario fuzz_target_camera:target_camera fuzz_detector:detector; do
  exe="${t%%:*}"
  corpus="tests/fuzz/corpus/${t##*:}"
  mkdir -p "$work/$exe" "$work/$exe-artifacts"
  echo "fuzz: $exe for ${SECONDS_EACH} s on $corpus"
  # FUZZ_SEED fixes libFuzzer's random seed; FUZZ_RUNS=N (with FUZZ_SEED) makes each target
  # run exactly its first N inputs, so CI's fuzz step is the same input sequence on every
  # machine and `FUZZ_SEED=1 FUZZ_RUNS=1 bash tools/fuzz.sh ...` reproduces it (SECONDS then
  # only caps the time). Without FUZZ_RUNS the time alone decides how far each target gets.
  seed_opt=()
  if [[ -n "${FUZZ_SEED:-}" ]]; then seed_opt=(-seed="$FUZZ_SEED"); fi
  if [[ -n "${FUZZ_RUNS:-}" ]]; then
    case "$exe" in
      fuzz_scenario) n=1000 ;; fuzz_target_camera) n=20000 ;; *) n=1000 ;;
    esac
    seed_opt+=(-runs="$((n * FUZZ_RUNS))")
  fi
  if ! "build-san/tests/fuzz/$exe" "${seed_opt[@]}" -max_total_time="$SECONDS_EACH" -timeout=30 -rss_limit_mb=4096 \
      -max_len=262144 -print_final_stats=1 -artifact_prefix="$work/$exe-artifacts/" \
      "$work/$exe" "$corpus" > "$work/$exe.log" 2>&1; then
    status=1
    echo "fuzz: $exe FAILED; last lines:"
    tail -40 "$work/$exe.log"
    mkdir -p fuzz-artifacts && cp -r "$work/$exe-artifacts" fuzz-artifacts/ || true
  else
    grep -E "^stat::number_of_executed_units|^stat::new_units_added|^#[0-9]+ +DONE" "$work/$exe.log" | tr '\n' ' '
    echo
  fi
done
if [ "$status" -eq 0 ]; then echo "fuzz: 3 passed, 0 failed"; else echo "fuzz: failures (inputs in fuzz-artifacts/)"; fi
exit "$status"
