#!/usr/bin/env bash
# A throwaway single-node Slurm (munged, slurmctld, slurmd) living entirely in one private
# folder, for testing scripts/slurm-render.sh here and in CI (scripts/ci-slurm.sh).
#
#   scripts/slurm-local-cluster.sh start DIR   # returns once the node is idle; writes DIR/env
#   . DIR/env                                   # export SLURM_CONF=DIR/slurm.conf for sbatch, squeue...
#   scripts/slurm-local-cluster.sh stop DIR    # stops all it started; non-zero if something is left
#   scripts/slurm-local-cluster.sh status DIR  # which of its processes are alive
#
# start: needs root (the daemons run as root: SlurmUser=root). Installs the Debian packages
#   slurmctld slurmd slurm-client munge if missing (apt-get install --no-install-recommends,
#   with a temporary /usr/sbin/policy-rc.d exiting 101 if there is none, so no system daemon
#   starts). DIR is created if missing; it must be empty or a folder this script made before
#   (marker DIR/.slurm-local-cluster), must not be on a noexec mount (batch scripts run from
#   DIR/spool) and must not contain spaces. Everything lives under DIR: slurm.conf, the munge
#   key and socket, controller state, slurmd spool, pid and log files (DIR/log/). Fixed free
#   TCP ports are picked at start and written to slurm.conf. The node is "ci1" (127.0.0.1,
#   the machine's CPU count), in the default partition "ci"; no cgroups needed
#   (proctrack/linuxproc, task/none). START_TIMEOUT (seconds, default 30) bounds the wait for
#   the node to be idle; past it the log tails are printed, everything is stopped, exit 1.
# stop: SIGTERM slurmd (SIGKILL after 5 s), SIGKILL the job steps (slurmstepd ignores SIGTERM
#   and outlives slurmd; found as processes with files open under DIR) and the jobs' processes
#   (their descendants, and processes of a job of this cluster by their environment), then
#   slurmctld and munged the same way. Then checks that none of them is left (zombies, state
#   Z, are ignored: PID 1 reaps them late here) and exits 1, listing them, if one is. Safe to
#   call twice, after a failed start, or on a folder where nothing ever started. DIR is kept
#   (its logs); delete it yourself.
set -euo pipefail

PACKAGES=(slurmctld slurmd slurm-client munge)
MARKER=.slurm-local-cluster
NODE=ci1

die() { echo "slurm-local-cluster: error: $*" >&2; exit 1; }
say() { echo "slurm-local-cluster: $*" >&2; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

usage() {
  sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

# ---------------------------------------------------------------- processes

# proc_stat PID: sets P_STATE and P_PPID from /proc/PID/stat (no fork: ps costs ~15 ms a call
# on a busy machine); false if there is no such process.
proc_stat() {
  local s
  [ -n "$1" ] || return 1
  { IFS= read -r s <"/proc/$1/stat"; } 2>/dev/null || return 1
  s=${s##*) }   # after "pid (command name) "
  P_STATE=${s%% *}
  s=${s#* }
  P_PPID=${s%% *}
}

# alive PID: the process exists and is not a zombie.
alive() {
  proc_stat "$1" || return 1
  case $P_STATE in Z|X|x) return 1 ;; esac
  return 0
}

# The shell running this script and its ancestors: never to be killed (a caller may well
# have its working directory or environment pointing into DIR).
protected_pids() {
  local p=$$
  while [ -n "$p" ] && [ "$p" -gt 1 ]; do
    echo "$p"
    proc_stat "$p" || break
    p=$P_PPID
  done
  echo 1
}

# The daemons this script started in DIR, still alive and still the same program (the pid
# file is checked against /proc/PID/cmdline, which names DIR, so a reused PID is left alone).
daemon_pids() {
  local name pid
  [ -f "$DIR/run/started" ] || return 0
  while read -r name pid; do
    [ -n "$pid" ] || continue
    alive "$pid" || continue
    if grep -qaF -- "$DIR/" "/proc/$pid/cmdline" 2>/dev/null; then
      echo "$name $pid"
    fi
  done <"$DIR/run/started"
}

# Every process belonging to the cluster other than the daemons: processes with a file open
# under DIR (slurmstepd and the batch shell, which reads its script from DIR/spool), processes
# of a job of this cluster (SLURM_JOB_ID and SLURM_CONF=DIR/slurm.conf in their environment),
# and all their descendants. The daemons' descendants are included too, except the subtrees
# of the PIDs given as arguments (e.g. slurmctld's own helper, slurmscriptd, which also has
# DIR/log open and must go with slurmctld, not before it).
cluster_pids() {
  local seeds=() p exclude="$*"
  local -A protected=()
  for p in $(protected_pids); do protected[$p]=1; done
  # run as $(...) or <(...), this is a subshell: it and its find, grep, ps and awk inherit
  # the script's open files, which may be under DIR; they are not the cluster's
  [ "$BASHPID" = $$ ] || exclude+=" $BASHPID"
  # open files under DIR (cwd is not looked at: a user's shell may sit in DIR)
  while IFS= read -r p; do
    p=${p#/proc/}; p=${p%%/*}
    seeds+=("$p")
  done < <(find /proc/[0-9]*/fd -maxdepth 1 -type l -lname "$DIR/*" 2>/dev/null || true)
  # a job's processes, by environment
  while IFS= read -r p; do
    if grep -qzs '^SLURM_JOB_ID=' "$p"; then
      p=${p#/proc/}; seeds+=("${p%%/*}")
    fi
  done < <(grep -lzsFx "SLURM_CONF=$DIR/slurm.conf" /proc/[0-9]*/environ 2>/dev/null || true)
  while read -r _ p; do seeds+=("$p"); done < <(daemon_pids)
  [ ${#seeds[@]} -gt 0 ] || return 0
  # close over descendants
  ps -e -o pid= -o ppid= -o stat= | awk -v seeds="${seeds[*]}" -v prot="${!protected[*]}" -v excl="$exclude" '
    BEGIN { n = split(seeds, s, " "); for (i = 1; i <= n; i++) want[s[i]] = 1
            m = split(prot, q, " "); for (i = 1; i <= m; i++) skip[q[i]] = 1
            m = split(excl, q, " "); for (i = 1; i <= m; i++) { skip[q[i]] = 1; ex[q[i]] = 1 } }
    { pid[NR] = $1; ppid[NR] = $2; st[NR] = $3 }
    END {
      do { changed = 0
           for (i = 1; i <= NR; i++) if (!(pid[i] in ex) && (ppid[i] in ex)) { ex[pid[i]] = 1; skip[pid[i]] = 1; changed = 1 }
      } while (changed)
      do { changed = 0
           for (i = 1; i <= NR; i++) if (!(pid[i] in want) && (ppid[i] in want)) { want[pid[i]] = 1; changed = 1 }
      } while (changed)
      for (i = 1; i <= NR; i++) if ((pid[i] in want) && !(pid[i] in skip) && st[i] !~ /^Z/) print pid[i]
    }'
}

# term_then_kill SECONDS PID...: SIGTERM, wait up to SECONDS for each to go, then SIGKILL.
term_then_kill() {
  local secs=$1 p t0 left
  shift
  [ $# -gt 0 ] || return 0
  kill -TERM "$@" 2>/dev/null || true
  t0=$(date +%s%N)
  while :; do
    left=()
    for p in "$@"; do alive "$p" && left+=("$p"); done   # kill -0 a b c is true if any lives
    [ ${#left[@]} -gt 0 ] || return 0
    [ $(( ($(date +%s%N) - t0) / 1000000 )) -lt $((secs * 1000)) ] || break
    sleep 0.05
  done
  say "SIGKILL after ${secs}s: ${left[*]}"
  kill -KILL "${left[@]}" 2>/dev/null || true
}

describe() { local p; for p in "$@"; do ps -o pid=,stat=,args= -p "$p" 2>/dev/null || true; done; }

# ---------------------------------------------------------------- DIR

resolve_dir() {
  [ -n "${1:-}" ] || usage
  case $1 in *[[:space:]]*|*[\*\?\[\]]*) die "DIR must not contain spaces or glob characters: '$1'" ;; esac
  DIR=$1
}

# ---------------------------------------------------------------- stop

cmd_stop() {
  resolve_dir "${1:-}"
  if [ ! -d "$DIR" ]; then say "nothing to stop: $DIR does not exist"; return 0; fi
  DIR=$(cd "$DIR" && pwd -P)
  [ "$DIR" != / ] || die "refusing DIR=/"
  if [ ! -f "$DIR/$MARKER" ]; then
    say "nothing to stop: $DIR was not made by this script (no $MARKER)"
    return 0
  fi
  local t0 name pid ctld="" slurmd="" munged="" others=() left=()
  t0=$(now)
  while read -r name pid; do
    case $name in slurmctld) ctld=$pid ;; slurmd) slurmd=$pid ;; munged) munged=$pid ;; esac
  done < <(daemon_pids)
  # slurmd first while the controller is still up (without it slurmd may take minutes to
  # exit, retrying to register), then the job steps and jobs, then the controller, munged.
  [ -z "$slurmd" ] || term_then_kill 5 "$slurmd"
  mapfile -t others < <(cluster_pids "$ctld" "$munged")
  if [ ${#others[@]} -gt 0 ]; then
    say "killing job steps and jobs: $(describe "${others[@]}" | awk '{ printf "%s%s(%s)", sep, $1, $3; sep = " " }')"
    kill -KILL "${others[@]}" 2>/dev/null || true
  fi
  [ -z "$ctld" ] || term_then_kill 5 "$ctld"
  [ -z "$munged" ] || term_then_kill 5 "$munged"
  # what is left, after a short grace for SIGKILLs to land (orphans reparented meanwhile
  # are found again through DIR or their environment)
  for _ in $(seq 20); do
    mapfile -t left < <(cluster_pids)
    [ ${#left[@]} -gt 0 ] || break
    kill -KILL "${left[@]}" 2>/dev/null || true
    sleep 0.05
  done
  if [ ${#left[@]} -gt 0 ]; then
    say "error: still running after stop:"
    describe "${left[@]}" >&2
    return 1
  fi
  rm -f "$DIR/run/started"
  if [ -z "$ctld$slurmd$munged" ] && [ ${#others[@]} -eq 0 ]; then
    say "nothing was running in $DIR"
  else
    say "stopped in $(since "$t0") s; nothing left running"
  fi
}

# ---------------------------------------------------------------- start

install_packages() {
  local missing=() p created_policy=0
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed' || missing+=("$p")
  done
  [ ${#missing[@]} -gt 0 ] || return 0
  command -v apt-get >/dev/null || die "missing ${missing[*]} and no apt-get to install them"
  local t0
  t0=$(now)
  say "installing ${missing[*]} (apt-get install --no-install-recommends)"
  if [ ! -e /usr/sbin/policy-rc.d ]; then
    # no service may start during the install: a system munged (or slurmd) started by the
    # packages' scripts would be left running, outside DIR
    printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
    chmod 755 /usr/sbin/policy-rc.d
    created_policy=1
    trap 'rm -f /usr/sbin/policy-rc.d' EXIT
    trap 'exit 130' INT
    trap 'exit 143' TERM
  fi
  local rc=0
  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      --no-install-recommends "${missing[@]}"; } >"$DIR/log/apt.log" 2>&1 || rc=$?
  if [ $created_policy = 1 ]; then rm -f /usr/sbin/policy-rc.d; trap - EXIT INT TERM; fi
  if [ $rc != 0 ]; then tail -n 20 "$DIR/log/apt.log" >&2; die "apt-get failed (exit $rc), log: $DIR/log/apt.log"; fi
  say "installed in $(since "$t0") s"
}

# A TCP port nobody listens on or uses (from /proc/net/tcp{,6}), other than $1. Fixed in
# slurm.conf once picked.
free_port() {
  local used=" " p local_addr
  for p in /proc/net/tcp /proc/net/tcp6; do
    [ -r "$p" ] || continue
    while read -r _ local_addr _; do
      case $local_addr in *:*) used+="$((16#${local_addr##*:})) " ;; esac
    done < <(tail -n +2 "$p")
  done
  for _ in $(seq 200); do
    p=$((20000 + RANDOM % 12000))   # below Linux's ephemeral ports (32768-60999)
    [ "$p" != "${1:-}" ] || continue
    case $used in *" $p "*) ;; *) echo "$p"; return 0 ;; esac
  done
  die "no free TCP port found"
}

write_conf() {
  local ctld_port slurmd_port cpus
  ctld_port=$(free_port)
  slurmd_port=$(free_port "$ctld_port")
  cpus=$(nproc)
  # One key per line: several Key=Value on one line is a parse error and the daemons exit.
  cat >"$DIR/slurm.conf" <<EOF
# Throwaway single-node cluster written by scripts/slurm-local-cluster.sh; everything under $DIR.
ClusterName=emberci
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/run/slurmctld.pid
SlurmdPidFile=$DIR/run/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
# The default batch_sched_delay=3 starts queued batch jobs only every 3 s (an array of short
# tasks on 2 CPUs took 6 s instead of 2); with 0 they start within about a second.
SchedulerParameters=batch_sched_delay=0
SlurmdParameters=config_overrides
ReturnToService=2
MailProg=/bin/true
KillWait=5
MinJobAge=300
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1000 State=UNKNOWN
PartitionName=ci Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
}

show_logs() {
  local f
  for f in "$DIR"/log/munged.log "$DIR"/log/slurmctld.log "$DIR"/log/slurmctld.out \
           "$DIR"/log/slurmd.log "$DIR"/log/slurmd.out; do
    [ -s "$f" ] || continue
    echo "---- tail of $f" >&2
    tail -n 15 "$f" >&2
  done
}

start_failed() {
  say "error: $*"
  show_logs
  cmd_stop "$DIR" || true
  exit 1
}

# launch NAME LOG CMD...: run a foreground daemon in the background, in its own session (a
# Ctrl-C meant for the caller does not reach it), and record its PID.
launch() {
  local name=$1 log=$2
  shift 2
  setsid "$@" </dev/null >>"$log" 2>&1 &
  echo "$name $!" >>"$DIR/run/started"
}

cmd_start() {
  resolve_dir "${1:-}"
  [ "$(id -u)" = 0 ] || die "start needs root (the daemons run as root, and may need apt-get)"
  mkdir -p "$DIR"
  DIR=$(cd "$DIR" && pwd -P)
  [ "$DIR" != / ] || die "refusing DIR=/"
  if [ ! -f "$DIR/$MARKER" ] && [ -n "$(ls -A "$DIR")" ]; then
    die "$DIR is not empty and was not made by this script: give a new or empty folder"
  fi
  if [ -n "$(daemon_pids)" ]; then
    die "a cluster is already running in $DIR (stop it first: $0 stop $DIR)"
  fi
  local sock="$DIR/munge/munge.socket"
  [ ${#sock} -lt 100 ] || die "DIR path too long for a unix socket: $sock"
  # munged refuses a socket unless every folder above it is searchable by all (o+x):
  # "Socket is inaccessible: execute permissions for all required on ..."
  local d=$DIR mode
  while d=$(dirname "$d"); [ "$d" != / ]; do
    mode=$(stat -c %A "$d")
    case ${mode:9:1} in x|t) ;; *)
      die "munged needs every folder above $DIR to be searchable by all, and $d is $mode: chmod o+x it, or choose another DIR" ;;
    esac
  done
  # batch scripts run from DIR/spool
  if findmnt -no OPTIONS --target "$DIR" 2>/dev/null | tr , '\n' | grep -qx noexec; then
    die "$DIR is on a noexec mount: batch scripts run from DIR/spool; choose another DIR"
  fi
  touch "$DIR/$MARKER"
  local t0
  t0=$(now)
  mkdir -p "$DIR/log" "$DIR/run" "$DIR/munge" "$DIR/etc"
  install_packages
  local b
  for b in munged slurmctld slurmd sinfo sbatch; do
    command -v "$b" >/dev/null || die "$b not found after installing ${PACKAGES[*]}"
  done
  # fresh state: a throwaway cluster starts with no jobs
  rm -rf "$DIR/state" "$DIR/spool" "$DIR/run/started" "$DIR/run/"*.pid "$DIR/env"
  mkdir -p "$DIR/state" "$DIR/spool"
  : >"$DIR/run/started"
  # munged refuses a socket folder others cannot enter ("Socket is inaccessible"), so DIR and
  # DIR/munge are 0755; the key is private to root.
  chmod 0755 "$DIR" "$DIR/munge"
  chmod 0700 "$DIR/etc"
  if [ ! -s "$DIR/etc/munge.key" ]; then
    (umask 077; head -c 1024 /dev/urandom >"$DIR/etc/munge.key")
  fi
  chmod 0400 "$DIR/etc/munge.key"
  write_conf

  local t1
  t1=$(now)
  launch munged "$DIR/log/munged.log" munged -F --key-file="$DIR/etc/munge.key" \
    --socket="$sock" --pid-file="$DIR/run/munged.pid" --seed-file="$DIR/etc/munge.seed"
  for _ in $(seq 100); do
    [ -S "$sock" ] && break
    alive "$(awk '$1 == "munged" { print $2 }' "$DIR/run/started")" || break
    sleep 0.05
  done
  [ -S "$sock" ] || start_failed "munged did not create its socket $sock"
  launch slurmctld "$DIR/log/slurmctld.out" slurmctld -D -f "$DIR/slurm.conf"
  launch slurmd "$DIR/log/slurmd.out" slurmd -D -N "$NODE" -f "$DIR/slurm.conf"

  export SLURM_CONF="$DIR/slurm.conf"
  local deadline state="" name pid
  deadline=$(( $(date +%s) + ${START_TIMEOUT:-30} ))
  local started=()
  mapfile -t started <"$DIR/run/started"   # (no loop reading a file under DIR: see stop)
  while :; do
    for name in "${started[@]}"; do
      pid=${name#* } name=${name%% *}
      alive "$pid" || start_failed "$name (pid $pid) exited during start"
    done
    state=$(timeout 5 sinfo -h -N -n "$NODE" -o %t 2>/dev/null || true)
    [ "$state" != idle ] || break
    [ "$(date +%s)" -lt "$deadline" ] || \
      start_failed "node $NODE not idle after ${START_TIMEOUT:-30} s (sinfo says: '${state:-no answer}')"
    sleep 0.1
  done
  printf 'export SLURM_CONF=%q\n' "$DIR/slurm.conf" >"$DIR/env"
  say "node $NODE idle: daemons up in $(since "$t1") s (all of start: $(since "$t0") s); logs in $DIR/log"
  say "clients need (also in $DIR/env, to source):"
  cat "$DIR/env"
}

cmd_status() {
  resolve_dir "${1:-}"
  [ -d "$DIR" ] || { echo "no $DIR"; return 1; }
  DIR=$(cd "$DIR" && pwd -P)
  local p
  daemon_pids
  for p in $(cluster_pids); do
    grep -qw "$p" < <(daemon_pids) || describe "$p"
  done
}

case ${1:-} in
  start) shift; [ $# = 1 ] || usage; cmd_start "$1" ;;
  stop) shift; [ $# = 1 ] || usage; cmd_stop "$1" ;;
  status) shift; [ $# = 1 ] || usage; cmd_status "$1" ;;
  -h|--help|"") usage ;;
  *) echo "slurm-local-cluster: unknown command '$1'" >&2; usage ;;
esac
