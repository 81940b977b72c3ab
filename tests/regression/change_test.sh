#!/usr/bin/env bash
# The change-indication tier (regression/change/): `lander change` passes on the committed
# files, and fails naming the field when an expected output differs (a copy of the directory
# with one touchdown offset moved by 1 mm and one golden-frame position by 1 mm).
#   bash tests/regression/change_test.sh LANDER_BINARY SOURCE_DIR
# Parses the expected files with python3's json module (a missing value fails).
set -euo pipefail
lander="$1"
src="$(cd "$2" && pwd)"
tmp="$(mktemp -d /tmp/change_test.XXXXXX)"
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "change_test: FAIL: $*" >&2; exit 1; }

out="$("$lander" change --dir "$src/regression/change")" || fail "unchanged tree: lander change exited $? ($out)"
echo "$out" | tail -1
grep -q "unchanged" <<<"$out" || fail "no 'unchanged' verdict"

cp -r "$src/regression/change" "$tmp/change"
python3 - "$tmp/change" <<'PY'
import json, sys
d = sys.argv[1]
p = d + "/replay/default/expected.json"
e = json.load(open(p))
off = e["summary"]["touchdown_offset_m"]
assert isinstance(off, float), "touchdown_offset_m missing or not a number"
e["summary"]["touchdown_offset_m"] = off + 0.001
json.dump(e, open(p, "w"), indent=2)
p = d + "/frames/expected.json"
f = json.load(open(p))
assert len(f) >= 1 and len(f[0]["p_CP_m"]) == 3, "golden frame without a position"
f[0]["p_CP_m"][2] += 0.001
json.dump(f, open(p, "w"), indent=2)
PY
# cases.yaml names the scenarios relative to its folder: point them at the source tree.
sed -i "s#\.\./\.\./scenarios/#$src/scenarios/#" "$tmp/change/cases.yaml"
set +e
out="$("$lander" change --dir "$tmp/change")"
rc=$?
set -e
echo "$out" | tail -4
[[ $rc -eq 1 ]] || fail "tampered expectations: exit $rc, expected 1"
grep -q "default.summary.touchdown_offset_m" <<<"$out" || fail "the moved touchdown offset is not named"
grep -q "frames\[0\].p_CP_m\[2\]" <<<"$out" || fail "the moved frame position is not named"
grep -q "2 differences" <<<"$out" || fail "expected exactly 2 differences"
echo "change_test: ok"
