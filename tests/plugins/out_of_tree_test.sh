#!/usr/bin/env bash
# A flight plugin built out of tree against the installed headers, as the docs tell a user
# (docs/guide/flight-software.md): `cmake --install` into a prefix, the example's own CMake
# project configured with CMAKE_PREFIX_PATH, built, its exports checked (the three C entry
# points only), and flown for a few seconds of the default scenario.
#   bash tests/plugins/out_of_tree_test.sh BUILD_DIR SOURCE_DIR LANDER_BINARY
set -euo pipefail
build="$1"
src="$(cd "$2" && pwd)"
lander="$3"
tmp="$(mktemp -d /tmp/plugin_oot.XXXXXX)"
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "out_of_tree_test: FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log" || { cat "$tmp/install.log"; fail "install"; }
cmake -S "$src/examples/pd_lander" -B "$tmp/pd" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release \
  > "$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; fail "configure against the installed package"; }
cmake --build "$tmp/pd" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; fail "build"; }
so="$tmp/pd/libpd_lander.so"
[ -f "$so" ] || fail "no $so"
exports="$(nm -D --defined-only "$so" | awk '$2 == "T" {print $3}' | sort | tr '\n' ' ')"
want="lander_flight_plugin_api_version lander_flight_plugin_create lander_flight_plugin_destroy "
[ "$exports" = "$want" ] || fail "exports are '$exports', want '$want'"
sed 's/^duration_s: .*/duration_s: 3/' "$src/scenarios/default.yaml" > "$tmp/short.yaml"
"$lander" run "$tmp/short.yaml" --out "$tmp/out" --quiet --flight-plugin "$so" > "$tmp/run.log" 2>&1 || { cat "$tmp/run.log"; [ -f "$tmp/out/summary.json" ] || fail "the run wrote no summary.json"; }
/usr/bin/python3 - "$tmp/out" <<'PY'
import json, sys
d = sys.argv[1]
s = json.load(open(d + "/summary.json"))
assert s["flight_software"]["name"] == "pd_lander", s["flight_software"]
assert s["outcome"] == "timeout", s["outcome"]  # 3 s of flight: nothing else may end it
f = json.load(open(d + "/flight_software.json"))
assert f["source"] == "plugin" and len(f["plugin_sha256"]) == 64, f
print("out_of_tree_test: built, exports", 3, "entry points, flew", s["vision"]["frames"], "frames")
PY
