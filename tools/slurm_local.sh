#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for tests and for trying the cluster path of
# `lander campaign slurm` on a workstation.
#
#   bash tools/slurm_local.sh start STATE_DIR   # prints: export SLURM_CONF=STATE_DIR/slurm.conf
#   bash tools/slurm_local.sh stop  STATE_DIR   # idempotent
#
# Needs root and the Debian packages slurmctld, slurmd, slurm-client and munge (Slurm 22.05).
# Everything the cluster writes lives under STATE_DIR (slurm.conf, spool dirs, logs, pid
# files, env.sh), except what munge needs: /etc/munge/munge.key (created if absent) and
# /run/munge. munged is started only when no munged answers (marked by
# /run/munge/started-by-slurm_local); `stop` ends it again only if this script started it and
# no slurmctld/slurmd is still running (the last cluster to stop ends it).
#
# The cluster uses a free port pair (SlurmctldPort, SlurmdPort = +1) so that a system Slurm,
# a second cluster or a stale one does not collide; `start` first stops whatever cluster is
# left in the same STATE_DIR. No accounting: use `sbatch --wait` (its exit code is the
# highest of the array's tasks) instead of sacct.
set -euo pipefail

usage() {
  echo "usage: $0 start|stop STATE_DIR" >&2
  exit 2
}

die() {
  echo "slurm_local: error: $*" >&2
  exit 1
}

log() {
  echo "slurm_local: $*"
}

[[ $# -eq 2 ]] || usage
action="$1"
state_arg="$2"
[[ -n "$state_arg" ]] || usage
[[ "$action" == start || "$action" == stop ]] || usage

if [[ "$action" == stop && ! -d "$state_arg" ]]; then
  log "nothing to stop: no directory $state_arg"
  exit 0
fi
mkdir -p -- "$state_arg"
state_dir="$(cd -- "$state_arg" && pwd -P)"
conf="$state_dir/slurm.conf"
run_dir="$state_dir/run"
log_dir="$state_dir/log"
spool_dir="$state_dir/spool"
ctld_pid_file="$run_dir/slurmctld.pid"
slurmd_pid_file="$run_dir/slurmd.pid"
munged_marker="/run/munge/started-by-slurm_local"
munge_pid_file="/run/munge/munged.pid"

# ---------------------------------------------------------------------------------------------
# helpers

require_commands() {
  local missing=() c
  for c in "$@"; do
    command -v "$c" >/dev/null 2>&1 || missing+=("$c")
  done
  if [[ ${#missing[@]} -gt 0 ]]; then
    die "missing commands: ${missing[*]} (install the Debian packages: apt-get install -y slurmctld slurmd slurm-client munge)"
  fi
}

# The pid in FILE if that process is alive and its command name is NAME, else nothing.
live_pid() {
  local file="$1" name="$2" pid comm
  [[ -f "$file" ]] || return 0
  pid="$(tr -dc '0-9' <"$file" || true)"
  [[ -n "$pid" ]] || return 0
  comm="$(ps -p "$pid" -o comm= 2>/dev/null || true)"
  if [[ "$comm" == "$name" ]] && ! pid_dead "$pid"; then
    echo "$pid"
  fi
}

# True when PID is gone or a zombie (a killed daemon whose parent has not reaped it yet).
pid_dead() {
  local stat
  stat="$(ps -p "$1" -o stat= 2>/dev/null || true)"
  [[ -z "$stat" || "$stat" == Z* ]]
}

# Stop the daemon whose pid is in FILE (command name NAME): TERM, then KILL after 15 s.
stop_daemon() {
  local file="$1" name="$2" pid i
  pid="$(live_pid "$file" "$name")"
  if [[ -z "$pid" ]]; then
    rm -f -- "$file"
    return 0
  fi
  log "stopping $name (pid $pid)"
  kill -TERM "$pid" 2>/dev/null || true
  for ((i = 0; i < 150; i++)); do
    pid_dead "$pid" && break
    sleep 0.1
  done
  if ! pid_dead "$pid"; then
    log "$name (pid $pid) did not stop after 15 s; killing it"
    kill -KILL "$pid" 2>/dev/null || true
    sleep 0.5
  fi
  rm -f -- "$file"
}

munge_works() {
  munge -n 2>/dev/null | unmunge >/dev/null 2>&1
}

port_free() {
  local port="$1"
  [[ -z "$(ss -Htan "( sport = :$port )" 2>/dev/null)" ]]
}

# Prints a port P such that P and P+1 are both free. Starts from a value derived from
# STATE_DIR so that two clusters rarely even try the same pair.
pick_ports() {
  local sum base port i
  sum="$(printf '%s' "$state_dir" | cksum | cut -d' ' -f1)"
  base=$((21000 + (sum % 4000) * 2))
  for ((i = 0; i < 500; i++)); do
    port=$((base + 2 * i))
    if ((port > 64000)); then
      port=$((21000 + (port - 64000)))
    fi
    if port_free "$port" && port_free "$((port + 1))"; then
      echo "$port"
      return 0
    fi
  done
  return 1
}

show_logs() {
  local f
  for f in "$log_dir/slurmctld.log" "$log_dir/slurmd.log"; do
    if [[ -f "$f" ]]; then
      echo "----- last lines of $f -----" >&2
      tail -n 30 -- "$f" >&2 || true
    fi
  done
  if [[ -f "$conf" ]]; then
    echo "----- sinfo -----" >&2
    SLURM_CONF="$conf" timeout 15 sinfo -N -l >&2 2>&1 || true
  fi
}

# ---------------------------------------------------------------------------------------------
# munge

start_munge() {
  if [[ ! -s /etc/munge/munge.key ]]; then
    log "creating /etc/munge/munge.key"
    mkdir -p /etc/munge
    if command -v mungekey >/dev/null 2>&1; then
      mungekey --create --keyfile=/etc/munge/munge.key --force
    else
      dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
    fi
  fi
  # munged refuses keys and directories with loose ownership or permissions.
  chown munge:munge /etc/munge /etc/munge/munge.key
  chmod 0700 /etc/munge
  chmod 0400 /etc/munge/munge.key
  local d
  for d in /var/lib/munge /var/log/munge; do
    mkdir -p "$d"
    chown munge:munge "$d"
  done
  chmod 0700 /var/log/munge
  mkdir -p /run/munge
  chown munge:munge /run/munge
  chmod 0755 /run/munge

  if munge_works; then
    log "munged already running"
    return 0
  fi
  log "starting munged"
  # A stale socket or pid file from a killed munged makes it refuse to start.
  if [[ -z "$(live_pid "$munge_pid_file" munged)" ]]; then
    rm -f /run/munge/munged.pid /run/munge/munge.socket.2 /run/munge/munge.socket.2.lock
  fi
  runuser -u munge -- munged || die "munged did not start (see /var/log/munge/munged.log)"
  local i
  for ((i = 0; i < 100; i++)); do
    munge_works && break
    sleep 0.1
  done
  munge_works || die "munged started but 'munge -n | unmunge' fails (see /var/log/munge/munged.log)"
  touch -- "$munged_marker"
}

stop_munge_if_ours() {
  [[ -f "$munged_marker" ]] || return 0
  # Live (not zombie) slurmctld or slurmd processes of any cluster.
  if ps -e -o stat=,comm= | awk '$1 !~ /^Z/ && ($2 == "slurmctld" || $2 == "slurmd") {f = 1} END {exit !f}'; then
    log "leaving munged running: other Slurm daemons use it"
    return 0
  fi
  stop_daemon "$munge_pid_file" munged
  rm -f -- "$munged_marker"
}

# ---------------------------------------------------------------------------------------------
# stop

# do_stop [keep-munge]
do_stop() {
  local keep_munge="${1:-}" ctld_pid jobs i
  ctld_pid="$(live_pid "$ctld_pid_file" slurmctld)"
  if [[ -n "$ctld_pid" && -f "$conf" ]]; then
    # Cancel every job while slurmd still runs, so their processes are ended properly.
    jobs="$(SLURM_CONF="$conf" timeout 15 squeue -h -o %A 2>/dev/null || true)"
    if [[ -n "$jobs" ]]; then
      log "cancelling jobs: $(echo "$jobs" | tr '\n' ' ')"
      # shellcheck disable=SC2086  # one job id per word
      SLURM_CONF="$conf" timeout 15 scancel $jobs 2>/dev/null || true
      for ((i = 0; i < 30; i++)); do
        jobs="$(SLURM_CONF="$conf" timeout 15 squeue -h -t R,CG,PD -o %A 2>/dev/null || true)"
        [[ -z "$jobs" ]] && break
        sleep 0.5
      done
    fi
  fi
  stop_daemon "$slurmd_pid_file" slurmd
  stop_daemon "$ctld_pid_file" slurmctld
  if [[ "$keep_munge" != keep-munge ]]; then
    stop_munge_if_ours
  fi
}

# ---------------------------------------------------------------------------------------------
# start

write_conf() {
  local port="$1" node cpus mem_kb real_mem
  node="$(hostname -s)"
  cpus="$(nproc --all)"
  mem_kb="$(awk '/^MemTotal:/ {print $2}' /proc/meminfo)"
  real_mem=$((mem_kb * 9 / 10 / 1024)) # MB, a bit below what slurmd measures
  : >"$state_dir/plugstack.conf"      # no SPANK plugins from /etc/slurm
  cat >"$conf" <<EOF
# Written by tools/slurm_local.sh: a one-node cluster, everything under $state_dir.
ClusterName=landerlocal
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$spool_dir/slurmctld
SlurmdSpoolDir=$spool_dir/slurmd
SlurmctldPidFile=$ctld_pid_file
SlurmdPidFile=$slurmd_pid_file
SlurmctldLogFile=$log_dir/slurmctld.log
SlurmdLogFile=$log_dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$state_dir/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0
MinJobAge=5
KillWait=5
InactiveLimit=0
ReturnToService=2
MpiDefault=none
MailProg=/bin/true
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$real_mem State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
  echo "$node"
}

do_start() {
  require_commands slurmctld slurmd sinfo squeue sbatch scancel munged munge unmunge ss runuser
  [[ "$(id -u)" -eq 0 ]] || die "must run as root (slurmd runs jobs as their user)"

  # A stale cluster in the same STATE_DIR: stop it and throw away its state.
  do_stop keep-munge
  rm -rf -- "$spool_dir" "$log_dir" "$run_dir"
  mkdir -p -- "$spool_dir/slurmctld" "$spool_dir/slurmd" "$log_dir" "$run_dir"

  start_munge

  local port node i state=""
  port="$(pick_ports)" || die "no free port pair found"
  node="$(write_conf "$port")"
  log "config $conf (node $node, ports $port/$((port + 1)))"

  if ! slurmctld -f "$conf"; then
    show_logs
    do_stop
    die "slurmctld did not start"
  fi
  if ! slurmd -f "$conf"; then
    show_logs
    do_stop
    die "slurmd did not start"
  fi

  # Wait (60 s at most) until the node is idle.
  for ((i = 0; i < 120; i++)); do
    state="$(SLURM_CONF="$conf" timeout 10 sinfo -h -N -n "$node" -o %T 2>/dev/null | head -n 1 || true)"
    [[ "$state" == "idle" ]] && break
    if [[ -z "$(live_pid "$ctld_pid_file" slurmctld)" && $i -gt 4 ]]; then
      break
    fi
    sleep 0.5
  done
  if [[ "$state" != "idle" ]]; then
    echo "slurm_local: error: node $node is not idle after 60 s (state: '${state:-unknown}')" >&2
    show_logs
    do_stop
    exit 1
  fi

  echo "export SLURM_CONF=$(printf '%q' "$conf")" >"$state_dir/env.sh"
  log "node $node idle; cluster running. For clients:"
  echo "export SLURM_CONF=$(printf '%q' "$conf")"
}

case "$action" in
  start) do_start ;;
  stop)
    do_stop
    log "stopped (state in $state_dir)"
    ;;
  *) usage ;;
esac
