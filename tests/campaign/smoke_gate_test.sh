#!/usr/bin/env bash
# CI's statistical regression gate: runs the smoke campaign (campaigns/smoke.yaml, 20 quick
# landings, --jobs 2) and compares it with the committed baseline regression/smoke/.
#
#   bash tests/campaign/smoke_gate_test.sh LANDER_BINARY SOURCE_DIR
#
# Expects `lander regress CURRENT --baseline SOURCE_DIR/regression/smoke` to exit 0 (on an
# unchanged tree, on the machine that made the baseline, the runs are bit-identical and every
# paired difference is 0; elsewhere they may differ within the thresholds), prints the gate's
# summary, and checks regress.json with python3's json module: verdict "pass", no failed check,
# every run paired (a missing or null value fails). A failure after a deliberate change of
# landing behaviour means: look at the summary, then re-accept the baseline
# (regression/README.md). Prints `smoke_gate_test: N passed, M failed` last; exits 1 on any
# failure. SMOKE_GATE_TEST_KEEP=1 keeps the temporary directory (the campaign, regress.json).
set -euo pipefail

name="smoke_gate_test"

if [[ $# -ne 2 ]]; then
  echo "usage: $0 LANDER_BINARY SOURCE_DIR" >&2
  exit 2
fi

t_start=$SECONDS
tmp=""
passed=0
failed=0

finish() {
  echo "$name: total $((SECONDS - t_start)) s"
  echo "$name: $passed passed, $failed failed"
  if [[ "$failed" -eq 0 ]]; then exit 0; else exit 1; fi
}

ok() {
  passed=$((passed + 1))
  echo "$name: ok: $* ($((SECONDS - t_start)) s)"
}

bad() {
  failed=$((failed + 1))
  echo "$name: FAIL: $* ($((SECONDS - t_start)) s)" >&2
}

fatal() {
  bad "$@"
  finish
}

# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  local rc=$?
  set +e
  if [[ -n "$tmp" && -d "$tmp" ]]; then
    if [[ "${SMOKE_GATE_TEST_KEEP:-0}" == 1 ]]; then
      echo "$name: kept $tmp"
    else
      rm -rf -- "$tmp"
    fi
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

command -v python3 >/dev/null 2>&1 || fatal "python3 is not installed (it reads regress.json)"

lander="$1"
source_dir="$2"
[[ -x "$lander" && -f "$lander" ]] || fatal "not an executable: $lander"
[[ -d "$source_dir" ]] || fatal "not a directory: $source_dir"
lander="$(cd -- "$(dirname -- "$lander")" && pwd -P)/$(basename -- "$lander")"
source_dir="$(cd -- "$source_dir" && pwd -P)"
campaign="$source_dir/campaigns/smoke.yaml"
baseline="$source_dir/regression/smoke"
[[ -f "$campaign" ]] || fatal "missing $campaign"
for f in campaign.csv campaign.json plan.json thresholds.yaml; do
  [[ -f "$baseline/$f" ]] || fatal "missing $baseline/$f (the committed smoke baseline, regression/README.md)"
done

tmp="$(mktemp -d "${TMPDIR:-/tmp}/smoke_gate_test.XXXXXX")"
cur="$tmp/smoke"

echo "$name: \$ $lander campaign run $campaign --out $cur --jobs 2"
rc=0
"$lander" campaign run "$campaign" --out "$cur" --jobs 2 >"$tmp/campaign.log" 2>&1 || rc=$?
if [[ $rc -ne 0 ]]; then
  tail -n 40 -- "$tmp/campaign.log" >&2
  fatal "the smoke campaign exited with $rc (0 expected: every run ended)"
fi
[[ -f "$cur/campaign.csv" && -f "$cur/campaign.json" ]] ||
  fatal "the smoke campaign wrote no $cur/campaign.csv or campaign.json"
ok "smoke campaign: $(grep -E '^  (landed|simulator failures)' "$tmp/campaign.log" | tr -s " " | sed "s/^ //" | paste -sd ";" - || true)"

echo "$name: \$ $lander regress $cur --baseline $baseline"
rc=0
"$lander" regress "$cur" --baseline "$baseline" >"$tmp/regress.log" 2>&1 || rc=$?
sed 's/^/    /' -- "$tmp/regress.log"
if [[ $rc -eq 0 ]]; then
  ok "lander regress exited with 0 (gate passed)"
else
  bad "lander regress exited with $rc, expected 0 (1: a threshold crossed with confidence, 2: bad input)"
fi
[[ -f "$cur/regress.json" ]] || fatal "no $cur/regress.json written"

rc=0
out="$(python3 - "$cur/regress.json" <<'EOF'
import json
import math
import sys

path = sys.argv[1]
results = []


def check(cond, what):
    results.append(("ok" if cond else "FAIL") + ": " + what)


def number(obj, *keys):
    """A finite number at the path, else None (missing, null, not a number)."""
    try:
        for k in keys:
            obj = obj[k]
    except (KeyError, IndexError, TypeError):
        return None
    if isinstance(obj, bool) or not isinstance(obj, (int, float)) or not math.isfinite(obj):
        return None
    return float(obj)


try:
    with open(path) as f:
        r = json.load(f)
except (OSError, ValueError) as e:
    print(f"FAIL: {path} is not readable JSON: {e}")
    sys.exit(0)
if not isinstance(r, dict):
    print(f"FAIL: {path} is not a JSON object")
    sys.exit(0)

check(r.get("verdict") == "pass", f"verdict 'pass' (got {r.get('verdict')!r})")
failed = r.get("failed_checks")
check(failed == [], f"no failed check (got {failed})")
checks = r.get("checks")
statuses = [c.get("status") for c in checks if isinstance(c, dict)] if isinstance(checks, list) else []
check(len(statuses) > 0 and all(s in ("pass", "not_evaluable") for s in statuses),
      f"{len(statuses)} checks, each passed or not evaluable (got {sorted(set(map(str, statuses)))})")
paired = number(r, "pairing", "paired")
planned = number(r, "baseline", "runs_planned")
check(paired is not None and paired == number(r, "current", "runs") == number(r, "baseline", "runs")
      and paired == planned,
      f"every planned run complete and paired (paired {paired}, planned {planned})")
diffs = {}
for p in (("landing_rate",), ("touchdown_offset_m", "median"), ("touchdown_offset_m", "p95"),
          ("touchdown_rel_speed_mps", "median"), ("time_to_land_s", "median")):
    diffs[".".join(p)] = number(r, "overall", *p, "difference")
check(all(v is not None for v in diffs.values()),
      f"every overall difference present and finite ({diffs})")
# Informational: on the baseline's machine and build the runs are bit-identical.
zero = all(v == 0.0 for v in diffs.values())
results.append(f"note: overall differences {'all exactly 0 (bit-identical runs)' if zero else 'not all 0: ' + str(diffs)}")
print("\n".join(results))
EOF
)" || rc=$?
if [[ $rc -ne 0 ]]; then
  bad "python3 reading $cur/regress.json exited with $rc"
else
  while IFS= read -r line; do
    case "$line" in
      ok:*) ok "regress.json: ${line#ok: }" ;;
      FAIL:*) bad "regress.json: ${line#FAIL: }" ;;
      *) [[ -z "$line" ]] || echo "$name: $line" ;;
    esac
  done <<<"$out"
fi

finish
