#!/usr/bin/env bash
# End-to-end test of the statistical regression gate on real landings: a deliberately worse
# flight configuration run through the same campaign is caught, the same campaign is not.
#
#   bash tests/campaign/gate_test.sh LANDER_BINARY SOURCE_DIR
#
# Runs tests/campaign/data/gate_campaign.yaml (ten quick landings on the standing cart) and
# gate_campaign_worse.yaml (the same runs with the worse configuration as a constant
# "dispersion", see that file) into a temporary directory, makes the first a baseline with
# `lander regress --accept` (which writes the default thresholds.yaml), and then expects:
#   - `lander regress WORSE --baseline BASE` to exit 1 with a touchdown-offset check (median
#     or p95) failed overall, read from regress.json with python3's json module (a missing or
#     null value fails the test), and the worse knobs listed as inputs only the current
#     campaign has (the gate accepts those);
#   - `lander regress NORMAL --baseline BASE` (the campaign against itself) to exit 0 with no
#     failed check and every paired difference exactly 0.
# Prints `gate_test: N passed, M failed` last; exits 1 on any failure. About 20 runs of ~30 s
# of CPU each: ~5 min on two idle cores. GATE_TEST_KEEP=1 keeps the temporary directory.
set -euo pipefail

name="gate_test"

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

# A failure after which nothing else can be checked.
fatal() {
  bad "$@"
  finish
}

# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  local rc=$?
  set +e
  if [[ -n "$tmp" && -d "$tmp" ]]; then
    if [[ "${GATE_TEST_KEEP:-0}" == 1 ]]; then
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
normal_yaml="$source_dir/tests/campaign/data/gate_campaign.yaml"
worse_yaml="$source_dir/tests/campaign/data/gate_campaign_worse.yaml"
[[ -f "$normal_yaml" ]] || fatal "missing $normal_yaml"
[[ -f "$worse_yaml" ]] || fatal "missing $worse_yaml"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/gate_test.XXXXXX")"

# Runs a campaign; its output is shown only when it fails.
# run_campaign WHAT CAMPAIGN_FILE OUT_DIR
run_campaign() {
  local what="$1" file="$2" out="$3" rc=0
  echo "$name: \$ $lander campaign run $file --out $out --jobs 2"
  "$lander" campaign run "$file" --out "$out" --jobs 2 >"$out.log" 2>&1 || rc=$?
  if [[ $rc -ne 0 ]]; then
    echo "----- output of the $what campaign -----" >&2
    tail -n 40 -- "$out.log" >&2
    fatal "the $what campaign exited with $rc (0 expected: every run ended)"
  fi
  [[ -f "$out/campaign.csv" && -f "$out/campaign.json" ]] ||
    fatal "the $what campaign wrote no $out/campaign.csv or campaign.json"
  ok "$what campaign: $(grep -E '^  (landed|simulator failures)' "$out.log" | tr -s " " | sed "s/^ //" | paste -sd ";" - || true)"
}

# Runs `lander regress CURRENT --baseline BASE` and checks its exit code.
# regress_expect WHAT EXPECTED_RC CURRENT_DIR
regress_expect() {
  local what="$1" want="$2" cur="$3" rc=0
  echo "$name: \$ $lander regress $cur --baseline $tmp/baseline"
  "$lander" regress "$cur" --baseline "$tmp/baseline" >"$cur.regress.log" 2>&1 || rc=$?
  sed 's/^/    /' -- "$cur.regress.log"
  if [[ $rc -eq "$want" ]]; then
    ok "$what: lander regress exited with $rc"
  else
    bad "$what: lander regress exited with $rc, expected $want"
  fi
  [[ -f "$cur/regress.json" ]] || fatal "$what: no $cur/regress.json written"
}

# Checks regress.json with python3's json module; prints one "ok: ..." or "FAIL: ..." line
# per check. check_json MODE REGRESS_JSON   (MODE: worse | same)
check_json() {
  local mode="$1" file="$2" line rc=0 out
  out="$(python3 - "$mode" "$file" <<'EOF'
import json
import math
import sys

mode, path = sys.argv[1], sys.argv[2]
results = []


def check(cond, what):
    results.append(("ok" if cond else "FAIL") + ": " + what)


def get(obj, *keys):
    """obj[k0][k1]...; raises KeyError/IndexError/TypeError when a level is missing."""
    for k in keys:
        obj = obj[k]
    return obj


def number(obj, *keys):
    """A finite number at the path, else None (missing, null, not a number)."""
    try:
        v = get(obj, *keys)
    except (KeyError, IndexError, TypeError):
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        return None
    return float(v)


try:
    with open(path) as f:
        r = json.load(f)
except (OSError, ValueError) as e:
    print(f"FAIL: {path} is not readable JSON: {e}")
    sys.exit(0)

verdict = r.get("verdict") if isinstance(r, dict) else None
failed = r.get("failed_checks") if isinstance(r, dict) else None
checks = r.get("checks") if isinstance(r, dict) else None
if not isinstance(failed, list) or not isinstance(checks, list):
    print("FAIL: regress.json has no failed_checks or checks list")
    sys.exit(0)

paired = number(r, "pairing", "paired")
n_cur = number(r, "current", "runs")
check(paired is not None and paired == n_cur and paired >= 10,
      f"every run paired (paired {paired}, current runs {n_cur})")
try:
    unpaired = len(get(r, "pairing", "only_in_current")) + len(get(r, "pairing", "only_in_baseline"))
except (KeyError, TypeError):
    unpaired = None
check(unpaired == 0, f"no unpaired run ids (got {unpaired})")

if mode == "worse":
    check(verdict == "fail", f"verdict 'fail' (got {verdict!r})")
    offset_keys = ("offset_median_growth_m", "offset_p95_growth_m")
    named = [c for c in failed if isinstance(c, str) and c.startswith("overall: ")
             and c.split(": ", 1)[1] in offset_keys]
    check(bool(named), f"an overall touchdown-offset check named in failed_checks (got {failed})")
    found = False
    for c in checks:
        if not isinstance(c, dict) or c.get("group") != "overall" or c.get("check") not in offset_keys:
            continue
        if c.get("status") != "fail":
            continue
        found = True
        v, lim = number(c, "value"), number(c, "limit")
        lo, hi = number(c, "ci95", 0), number(c, "ci95", 1)
        msg = c.get("message")
        check(v is not None and lim is not None and v > lim,
              f"{c['check']}: value {v} m above its limit {lim} m")
        check(lo is not None and hi is not None and 0 < lo <= hi,
              f"{c['check']}: 95 % interval [{lo}, {hi}] m lies above 0")
        check(isinstance(msg, str) and bool(msg.strip()), f"{c['check']}: message {msg!r}")
    check(found, "an overall offset check with status 'fail' in checks")
    for stat in ("median", "p95"):
        b = number(r, "overall", "touchdown_offset_m", stat, "baseline")
        cu = number(r, "overall", "touchdown_offset_m", stat, "current")
        check(b is not None and cu is not None and cu > b,
              f"offset {stat} grew: baseline {b} m, current {cu} m")
    try:
        extra = get(r, "pairing", "inputs_only_in_current")
    except (KeyError, TypeError):
        extra = None
    check(isinstance(extra, list) and any(isinstance(x, str) and x.startswith("flight.controller.") for x in extra),
          f"the worse knobs listed as inputs only the current campaign has (got {extra})")
elif mode == "same":
    check(verdict == "pass", f"verdict 'pass' (got {verdict!r})")
    check(failed == [], f"no failed check (got {failed})")
    statuses = [c.get("status") for c in checks if isinstance(c, dict)]
    check(len(statuses) > 0 and all(s in ("pass", "not_evaluable") for s in statuses),
          f"every check passes or is not evaluable (got {statuses})")
    for path in (("landing_rate",), ("touchdown_offset_m", "median"), ("touchdown_offset_m", "p95"),
                 ("touchdown_rel_speed_mps", "median"), ("time_to_land_s", "median")):
        d = number(r, "overall", *path, "difference")
        check(d == 0.0, f"overall {'.'.join(path)} difference exactly 0 (got {d})")
    try:
        extra = get(r, "pairing", "inputs_only_in_current") + get(r, "pairing", "inputs_only_in_baseline")
    except (KeyError, TypeError):
        extra = None
    check(extra == [], f"the same sampled inputs in both (inputs in one only: {extra})")
else:
    print(f"FAIL: unknown mode {mode}")

print("\n".join(results))
EOF
)" || rc=$?
  if [[ $rc -ne 0 ]]; then
    bad "python3 reading $file exited with $rc"
    return
  fi
  while IFS= read -r line; do
    case "$line" in
      ok:*) ok "$mode: ${line#ok: }" ;;
      FAIL:*) bad "$mode: ${line#FAIL: }" ;;
      *) [[ -z "$line" ]] || echo "$name: $line" ;;
    esac
  done <<<"$out"
}

echo "$name: --- campaigns in $tmp ($((SECONDS - t_start)) s)"
run_campaign "normal" "$normal_yaml" "$tmp/normal"
run_campaign "worse" "$worse_yaml" "$tmp/worse"

echo "$name: --- baseline ($((SECONDS - t_start)) s)"
rc=0
"$lander" regress --accept "$tmp/normal" --baseline "$tmp/baseline" >"$tmp/accept.log" 2>&1 || rc=$?
if [[ $rc -ne 0 || ! -f "$tmp/baseline/thresholds.yaml" ]]; then
  cat -- "$tmp/accept.log" >&2
  fatal "lander regress --accept exited with $rc or wrote no thresholds.yaml"
fi
ok "lander regress --accept made $tmp/baseline with the default thresholds"

echo "$name: --- the worse configuration against the baseline ($((SECONDS - t_start)) s)"
regress_expect "worse against normal" 1 "$tmp/worse"
check_json worse "$tmp/worse/regress.json"

echo "$name: --- the same campaign against itself ($((SECONDS - t_start)) s)"
regress_expect "normal against itself" 0 "$tmp/normal"
check_json same "$tmp/normal/regress.json"

finish
