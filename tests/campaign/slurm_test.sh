#!/usr/bin/env bash
# End-to-end test of the Slurm path of `lander campaign`: runs a 4-run campaign locally,
# then on a one-node Slurm cluster started by tools/slurm_local.sh as a job array (2 tasks of
# 2 runs), merges it, and checks that the merged campaign.csv equals the local one (rows
# sorted, wall_s dropped).
#
#   bash tests/campaign/slurm_test.sh LANDER_BINARY SOURCE_DIR
#
# Needs root, Slurm 22.05 (slurmctld, slurmd, slurm-client), munge and python3. It FAILS when
# they are missing: CI installs them, so this test never skips. SLURM_TEST_KEEP=1 keeps the
# temporary directory (and prints it) for debugging.
set -euo pipefail

name="slurm_test"

if [[ $# -ne 2 ]]; then
  echo "usage: $0 LANDER_BINARY SOURCE_DIR" >&2
  exit 2
fi

t_start=$SECONDS
tmp=""
cluster_started=0
slurm_local=""

summary_fail() {
  echo "$name: FAIL: $*" >&2
  echo "$name: 0 passed, 1 failed"
  exit 1
}

ok() {
  echo "$name: ok: $* ($((SECONDS - t_start)) s)"
}

step() {
  echo "$name: --- $* ($((SECONDS - t_start)) s)"
}

cleanup() {
  local rc=$?
  set +e
  if [[ "$cluster_started" -eq 1 ]]; then
    bash "$slurm_local" stop "$tmp/cluster" >/dev/null 2>&1 ||
      echo "$name: warning: stopping the cluster failed" >&2
  fi
  if [[ -n "$tmp" && -d "$tmp" ]]; then
    if [[ "${SLURM_TEST_KEEP:-0}" == 1 ]]; then
      echo "$name: kept $tmp"
    else
      rm -rf -- "$tmp"
    fi
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# ---------------------------------------------------------------------------------------------
# prerequisites (a missing one is a failure, never a skip)

missing=()
for c in slurmctld slurmd sbatch sinfo squeue scancel munged munge unmunge python3 timeout; do
  command -v "$c" >/dev/null 2>&1 || missing+=("$c")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  summary_fail "not installed: ${missing[*]} (apt-get install -y slurmctld slurmd slurm-client munge python3)"
fi
[[ "$(id -u)" -eq 0 ]] || summary_fail "must run as root (slurmd runs the jobs)"

lander="$1"
source_dir="$2"
[[ -x "$lander" && -f "$lander" ]] || summary_fail "not an executable: $lander"
[[ -d "$source_dir" ]] || summary_fail "not a directory: $source_dir"
lander="$(cd -- "$(dirname -- "$lander")" && pwd -P)/$(basename -- "$lander")"
source_dir="$(cd -- "$source_dir" && pwd -P)"
slurm_local="$source_dir/tools/slurm_local.sh"
[[ -f "$slurm_local" ]] || summary_fail "missing $slurm_local"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/slurm_test.XXXXXX")"
chmod 0755 "$tmp"

# Runs a command, prints its output only when it fails; fails the test on a non-zero exit.
# run_or_fail WHAT LOG COMMAND...
run_or_fail() {
  local what="$1" logf="$2" rc=0
  shift 2
  echo "$name: \$ $*"
  "$@" >"$logf" 2>&1 || rc=$?
  if [[ $rc -ne 0 ]]; then
    echo "----- output of: $* -----" >&2
    tail -n 60 -- "$logf" >&2
    summary_fail "$what exited with $rc"
  fi
}

# ---------------------------------------------------------------------------------------------
# the campaign: 4 short runs of a tiny scenario, one dispersed key

step "writing the campaign in $tmp"
cat >"$tmp/tiny.yaml" <<'EOF'
name: tiny
description: slurm_test scenario, a few seconds of flight close above a slow cart.
duration_s: 4.0
cart:
  path: straight
  start_m: [0.0, 0.0]
  speed_mps: 0.5
vehicle:
  control: closed_loop
  start_m: [-1.0, 0.0, 3.0]
EOF
cat >"$tmp/C.yaml" <<'EOF'
name: slurmtest
seed: 7
scenarios:
  - {file: tiny.yaml, runs: 4}
dispersions:
  cart.speed_mps: {uniform: [0.0, 1.0]}
EOF
n_runs=4
runs_per_task=2
n_tasks=$(((n_runs + runs_per_task - 1) / runs_per_task))

# ---------------------------------------------------------------------------------------------
# local reference run

step "local run"
run_or_fail "local campaign run" "$tmp/local.log" \
  "$lander" campaign run "$tmp/C.yaml" --out "$tmp/local" --jobs 2
[[ -f "$tmp/local/campaign.csv" ]] || summary_fail "local run wrote no $tmp/local/campaign.csv"
ok "local campaign run, $tmp/local/campaign.csv written"

# ---------------------------------------------------------------------------------------------
# cluster

step "starting the one-node cluster"
cluster_started=1
run_or_fail "tools/slurm_local.sh start" "$tmp/cluster-start.log" \
  bash "$slurm_local" start "$tmp/cluster"
export SLURM_CONF="$tmp/cluster/slurm.conf"
[[ -f "$SLURM_CONF" ]] || summary_fail "slurm_local.sh wrote no $SLURM_CONF"
ok "cluster up: $(sinfo -h -o '%P %a %D %T %C')"

step "writing the job array"
run_or_fail "lander campaign slurm" "$tmp/slurm-gen.log" \
  "$lander" campaign slurm "$tmp/C.yaml" --out "$tmp/sl" --runs-per-task "$runs_per_task" --throttle 2
sbatch_file="$tmp/sl/slurm/campaign.sbatch"
joblist="$tmp/sl/slurm/joblist.txt"
[[ -f "$sbatch_file" ]] || summary_fail "campaign slurm wrote no $sbatch_file"
[[ -f "$joblist" ]] || summary_fail "campaign slurm wrote no $joblist"
array_line="$(grep -E '^#SBATCH[[:space:]]+(--array|-a)' "$sbatch_file" || true)"
[[ "$array_line" =~ (--array=|-a[[:space:]]*)0-([0-9]+)(%([0-9]+))? ]] ||
  summary_fail "no '#SBATCH --array=0-N%T' line in $sbatch_file"
[[ "${BASH_REMATCH[2]}" -eq $((n_tasks - 1)) ]] ||
  summary_fail "array '$array_line': expected tasks 0-$((n_tasks - 1)) for $n_runs runs, $runs_per_task per task"
[[ "${BASH_REMATCH[4]:-}" == 2 ]] || summary_fail "array '$array_line': expected throttle %2"
# The job list holds one `lander campaign run` line per array task or per run.
joblist_lines="$(grep -cv '^[[:space:]]*$' "$joblist" || true)"
[[ "$joblist_lines" -eq "$n_tasks" || "$joblist_lines" -eq "$n_runs" ]] ||
  summary_fail "$joblist has $joblist_lines jobs, expected $n_tasks (one a task) or $n_runs (one a run)"
bad_line="$(grep -v '^[[:space:]]*$' "$joblist" | grep -v -F " campaign run " | head -n 1 || true)"
[[ -z "$bad_line" ]] || summary_fail "$joblist: not a 'lander campaign run' command: $bad_line"
ok "campaign.sbatch ($array_line) and joblist.txt ($joblist_lines jobs) written"

step "sbatch --wait (from /, so that every path in the script must be absolute)"
echo "$name: \$ sbatch --parsable --wait $sbatch_file"
rc=0
job_out="$(cd / && timeout 300 sbatch --parsable --wait "$sbatch_file" 2>"$tmp/sbatch.err")" || rc=$?
job_id="${job_out%%;*}"
job_id="${job_id//[^0-9]/}"
if [[ $rc -ne 0 ]]; then
  cat -- "$tmp/sbatch.err" >&2
  for f in "$tmp/sl/slurm/"task-*.out; do
    [[ -f "$f" ]] || continue
    echo "----- $f -----" >&2
    tail -n 40 -- "$f" >&2
  done
  summary_fail "sbatch --wait exited with $rc (job ${job_id:-?}; the highest exit code of the array's tasks, 124 = timed out)"
fi
[[ -n "$job_id" ]] || summary_fail "sbatch printed no job id: '$job_out'"
ok "job array $job_id finished, every task exited 0"

for ((i = 0; i < n_tasks; i++)); do
  f="$tmp/sl/slurm/task-${job_id}_${i}.out"
  [[ -f "$f" ]] || summary_fail "missing task output $f (have: $(ls "$tmp/sl/slurm"))"
done
ok "task outputs task-${job_id}_0..$((n_tasks - 1)).out exist"

# sbatch --wait's exit code is not every task's (Slurm 22.05 returned 0 while task 0 of 2 had
# refused to start, CI of stop 65): each task's own exit code, from scontrol (job records
# stay MinJobAge, 300 s), and each task's last progress line.
show_task_outputs() {
  for f in "$tmp/sl/slurm/"task-*.out; do
    echo "----- $f -----" >&2
    tail -n 40 -- "$f" >&2
  done
}
for ((i = 0; i < n_tasks; i++)); do
  rec="$(scontrol -o show job "${job_id}_${i}" 2>&1 || true)"
  code="$(grep -o ' ExitCode=[0-9]*:[0-9]*' <<<"$rec" | head -n 1 || true)"
  [[ -n "$code" ]] || { show_task_outputs; summary_fail "scontrol has no exit code for task ${job_id}_${i}: $rec"; }
  [[ "$code" == " ExitCode=0:0" ]] || { show_task_outputs; summary_fail "task ${job_id}_${i} ended with$code"; }
  f="$tmp/sl/slurm/task-${job_id}_${i}.out"
  grep -q -E ' ([0-9]+)/\1 runs done' "$f" || { show_task_outputs; summary_fail "$f: no 'K/K runs done' line"; }
done
ok "every task's own exit code is 0:0 and its runs are done"

n_dirs="$(find "$tmp/sl/runs" -mindepth 1 -maxdepth 1 -type d 2>/dev/null | wc -l)"
[[ "$n_dirs" -eq "$n_runs" ]] ||
  { show_task_outputs; summary_fail "$tmp/sl/runs has $n_dirs run directories, expected $n_runs: $(find "$tmp/sl/runs" -mindepth 1 -maxdepth 1 -printf '%f ' 2>&1)"; }
ok "$n_runs run directories in sl/runs"

# ---------------------------------------------------------------------------------------------
# merge and compare

step "merge"
run_or_fail "lander campaign report" "$tmp/report.log" "$lander" campaign report "$tmp/sl"
[[ -f "$tmp/sl/campaign.csv" ]] || summary_fail "campaign report wrote no $tmp/sl/campaign.csv"
ok "campaign report wrote sl/campaign.csv"

step "comparing local/campaign.csv and sl/campaign.csv (rows sorted, wall_s dropped)"
rc=0
python3 - "$tmp/local/campaign.csv" "$tmp/sl/campaign.csv" "$n_runs" <<'EOF' || rc=$?
import csv
import sys

local_path, slurm_path, n_runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
DROP = {"wall_s"}


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        sys.exit(f"{path}: empty")
    header, body = rows[0], [r for r in rows[1:] if r]
    for i, r in enumerate(body):
        if len(r) != len(header):
            sys.exit(f"{path}: row {i + 2} has {len(r)} fields, header has {len(header)}")
    return header, body


lh, lrows = load(local_path)
sh, srows = load(slurm_path)
if lh != sh:
    sys.exit(f"headers differ:\n  local: {lh}\n  slurm: {sh}")
if "wall_s" not in lh:
    print("  note: no wall_s column in the header")
keep = [i for i, h in enumerate(lh) if h not in DROP]


def project(rows):
    return sorted(tuple(r[i] for i in keep) for r in rows)


lp, sp = project(lrows), project(srows)
if len(lp) != n_runs or len(sp) != n_runs:
    sys.exit(f"expected {n_runs} rows: local has {len(lp)}, slurm has {len(sp)}")
if lp != sp:
    names = [lh[i] for i in keep]
    for a, b in zip(lp, sp):
        if a != b:
            diffs = [f"{n}: {x!r} != {y!r}" for n, x, y in zip(names, a, b) if x != y]
            print("  row differs (local != slurm): " + "; ".join(diffs), file=sys.stderr)
    sys.exit("rows differ")
print(f"  {len(lp)} rows x {len(keep)} columns equal ({', '.join(lh[i] for i in keep)})")
EOF
[[ $rc -eq 0 ]] || summary_fail "campaign.csv of the Slurm run differs from the local one"
ok "same header, same rows"

echo "$name: total $((SECONDS - t_start)) s"
echo "$name: 1 passed, 0 failed"
