#!/usr/bin/env bash
# Renders one image as N shards on a Slurm cluster, then merges them (bit-identical to a
# render on one machine), in three jobs, each starting only if the one before succeeded
# (--dependency=afterok):
#   stage 1, an array of N tasks, task K running
#     $EMBER render SCENE --shard K/N --first-round -o PARTS_DIR/first-K.shard [ember options]
#   (an adaptive render's first round; all of a uniform render's samples),
#   stage 2, an array of N tasks, task K running
#     $EMBER render SCENE --shard K/N -o PARTS_DIR/part-K.shard [ember options] \
#         --plan-from PARTS_DIR/first-0.shard ... PARTS_DIR/first-(N-1).shard
#   (the rest of shard K, planned from the whole image's first round),
#   and the merge
#     $EMBER merge PARTS_DIR/part-0.shard ... PARTS_DIR/part-(N-1).shard -o OUT
#
#   scripts/slurm-render.sh [--wait] [--only K[,K...]] SCENE OUT N [sbatch options...] [-- ember render options...]
#
#   SCENE, OUT       the scene and the merged image (OUT's folder must exist)
#   N                number of shards (array tasks 0..N-1), a positive integer
#   sbatch options   passed to both sbatch calls, e.g. --partition=P --time=1:00:00 -c 8;
#                    except --array, --dependency, --output, --error, --parsable, --wait,
#                    which this script sets
#   -- OPTIONS       ember render options for every shard, e.g. -- --spp 256 --threads 8
#   --wait           block until the merge job ends (polling squeue every 0.2 s); exit 0 if
#                    every shard and the merge succeeded, 1 otherwise, naming the failed
#                    shards and their logs
#   --only K[,K...]  re-render only these shards (e.g. ones that failed), then merge all N
#                    again; the other part files are kept, and so are the first rounds
#                    (stage 1 runs only for the listed shards that lack theirs).
#
# Environment:
#   EMBER       the ember binary (default: ember on PATH), resolved to an absolute path here;
#               the compute nodes must see it, SCENE and PARTS_DIR at the same paths
#   EMBER_ARGS  more ember render options, split on whitespace (no quoting), placed before
#               the ones after "--"
#   PARTS_DIR   where the shards and logs go (default: OUT.parts beside OUT); holds
#               first-K.shard and part-K.shard, the batch scripts first.sbatch, shard.sbatch
#               and merge.sbatch, and logs/: first-K.log and part-K.log (appended to by every
#               run of shard K's stage) and merge-JOBID.log
#
# Submission: stale PARTS_DIR/part-K.shard of the shards to render are deleted first (and,
# without --only, every first-K.shard). Stage 2 and the merge are submitted with
# --kill-on-invalid-dep=yes, so Slurm cancels them when a task they wait for fails (without
# that, afterok leaves them pending forever with reason DependencyNeverSatisfied; --wait also
# cancels them in that case). To finish after a failure, re-run the failed shards with --only
# (the command is printed). The shard count N is written into the batch scripts
# (SLURM_ARRAY_TASK_COUNT would be 1 when a single shard is re-run with --array=K).
set -euo pipefail

prog=slurm-render
die() { echo "$prog: error: $*" >&2; exit 2; }    # bad arguments or setup
fail() { echo "$prog: error: $*" >&2; exit 1; }   # Slurm refused or failed
say() { echo "$prog: $*"; }
usage() { sed -n '2,46p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
quote() { local a out=""; for a in "$@"; do out+=" $(printf '%q' "$a")"; done; printf '%s' "${out# }"; }

# ---------------------------------------------------------------- arguments

wait_mode=0 only="" pos=() sbopts=() extra=()
while [ $# -gt 0 ]; do
  case $1 in
    --wait) wait_mode=1 ;;
    --only) [ $# -ge 2 ] || die "--only needs a shard list, e.g. --only 2 or --only 1,3"; only=$2; shift ;;
    --only=*) only=${1#--only=} ;;
    -h|--help) usage 0 ;;
    --) shift; extra=("$@"); break ;;
    *)
      if [ ${#pos[@]} -lt 3 ]; then
        case $1 in -[0-9]*) ;; -*) die "unknown option '$1' (sbatch options go after SCENE OUT N; see --help)" ;; esac
        pos+=("$1")
      else
        sbopts+=("$1")
      fi ;;
  esac
  shift
done
[ ${#pos[@]} = 3 ] || { echo "usage: $0 [--wait] [--only K[,K...]] SCENE OUT N [sbatch options...] [-- ember render options...]" >&2; exit 2; }
scene=${pos[0]} out=${pos[1]} n=${pos[2]}

[[ $n =~ ^[1-9][0-9]*$ ]] || die "N must be a positive integer (the number of shards), not '$n'"
[ -f "$scene" ] || die "scene not found: $scene"
[ -r "$scene" ] || die "scene not readable: $scene"
out_dir=$(dirname -- "$out")
[ -d "$out_dir" ] || die "the folder of OUT does not exist: $out_dir"
command -v sbatch >/dev/null || die "sbatch not found: is the Slurm client installed and on PATH? (a local test cluster: scripts/slurm-local-cluster.sh start DIR; . DIR/env)"
for b in squeue scontrol scancel; do
  command -v "$b" >/dev/null || die "$b not found (Slurm client incomplete)"
done

for o in "${sbopts[@]}"; do
  case $o in
    --array*|-a|-a[0-9]*|--dependency*|-d|-d[a-z]*|--output*|-o|-o?*|--error*|-e|-e?*|--parsable|--wait|-W|--open-mode*)
      die "sbatch option '$o' is set by this script and cannot be passed" ;;
  esac
done

eargs=()
if [ -n "${EMBER_ARGS:-}" ]; then read -r -a eargs <<<"$EMBER_ARGS"; fi
eargs+=("${extra[@]}")
for a in "${eargs[@]}"; do
  case $a in
    --shard|--shard=*|-o|--output|--output=*|--resume|--first-round|--plan-from|--plan-from=*) die "ember option '$a' is set by this script (or makes no sense for a shard)" ;;
  esac
done

ember=${EMBER:-ember}
if [[ $ember == */* ]]; then
  if [ ! -f "$ember" ] || [ ! -x "$ember" ]; then die "EMBER=$ember is not an executable file"; fi
  ember=$(realpath -s -- "$ember")
else
  ember_path=$(command -v -- "$ember") || die "'$ember' not found on PATH: set EMBER=/path/to/ember"
  ember=$(realpath -s -- "$ember_path")
fi

scene=$(realpath -s -- "$scene")
out=$(realpath -s -m -- "$out")
parts=$(realpath -s -m -- "${PARTS_DIR:-$out.parts}")
mkdir -p "$parts/logs" || die "cannot create $parts/logs"

# which shards to run: all, or --only's list
if [ -n "$only" ]; then
  [[ $only =~ ^[0-9]+(,[0-9]+)*$ ]] || die "--only takes shard numbers separated by commas, e.g. 2 or 1,3, not '$only'"
  IFS=, read -r -a todo <<<"$only"
  for k in "${todo[@]}"; do
    [ $((10#$k)) -lt "$n" ] || die "--only: shard $k is not one of 0..$((n - 1))"
  done
  array=$only
else
  todo=()
  for ((k = 0; k < n; k++)); do todo+=("$k"); done
  array="0-$((n - 1))"
fi

# ---------------------------------------------------------------- batch scripts

part_files=() first_files=()
for ((k = 0; k < n; k++)); do part_files+=("$parts/part-$k.shard") first_files+=("$parts/first-$k.shard"); done

# stage_script STAGE WHAT: the batch script of one stage; ember's arguments follow the
# common part (with --plan-from last: it takes every file after it).
stage_script() {
  local stage=$1 what=$2
  # shellcheck disable=SC2016 # $-expressions in single quotes are for the batch scripts
  {
    echo '#!/bin/bash'
    echo "# $what job written by scripts/slurm-render.sh: shard K (= the array task id) of $n of"
    echo "# $scene. Re-run shard K alone: sbatch --array=K [same options] $parts/$stage.sbatch"
    echo 'set -uo pipefail'
    echo "n=$n"
    echo 'k=${SLURM_ARRAY_TASK_ID:?"run it as a Slurm array task: sbatch --array=K"}'
    echo 'if [ "$k" -ge "$n" ]; then echo "error: array task $k is not a shard: 0..$((n - 1))" >&2; exit 2; fi'
    echo "echo \"== $stage \$k/\$n: job \${SLURM_ARRAY_JOB_ID:-?}_\$k (\${SLURM_JOB_ID:-?}) on \$(hostname) at \$(date '+%F %T')\""
    printf '%s render %s --shard "$k/$n"' "$(quote "$ember")" "$(quote "$scene")"
    [ ${#eargs[@]} = 0 ] || printf ' %s' "$(quote "${eargs[@]}")"
    if [ "$stage" = first ]; then
      printf ' --first-round -o %s/first-"$k".shard\n' "$(quote "$parts")"
    else
      printf ' -o %s/part-"$k".shard --plan-from %s\n' "$(quote "$parts")" "$(quote "${first_files[@]}")"
    fi
    echo 'rc=$?'
    echo "echo \"== $stage \$k/\$n: exit \$rc at \$(date '+%F %T')\""
    echo 'exit $rc'
  } >"$parts/$stage.sbatch"
}
stage_script first "Stage 1 (first round)"
stage_script shard "Stage 2 (the rest of the shard)"

# shellcheck disable=SC2016
{
  echo '#!/bin/bash'
  echo "# Merge job written by scripts/slurm-render.sh: the $n shards in $parts into $out."
  echo 'set -uo pipefail'
  echo 'echo "== merge: job ${SLURM_JOB_ID:-?} on $(hostname) at $(date "+%F %T")"'
  printf '%s merge %s -o %s\n' "$(quote "$ember")" "$(quote "${part_files[@]}")" "$(quote "$out")"
  echo 'rc=$?'
  echo 'echo "== merge: exit $rc at $(date "+%F %T")"'
  echo 'exit $rc'
} >"$parts/merge.sbatch"
chmod +x "$parts/first.sbatch" "$parts/shard.sbatch" "$parts/merge.sbatch"

name=ember-$(basename -- "$out")
first_sbatch=(sbatch --parsable --job-name="$name-first" --output="$parts/logs/first-%a.log" --open-mode=append)
shard_sbatch=(sbatch --parsable --job-name="$name" --output="$parts/logs/part-%a.log" --open-mode=append
              --kill-on-invalid-dep=yes)
merge_sbatch=(sbatch --parsable --job-name="$name-merge" --output="$parts/logs/merge-%j.log"
              --kill-on-invalid-dep=yes)

# How to re-run shards LIST and merge again, as a shell command.
resubmit_help() {
  local list=$1
  local envs=""
  [ -z "${EMBER:-}" ] || envs+="EMBER=$(quote "$EMBER") "
  [ -z "${EMBER_ARGS:-}" ] || envs+="EMBER_ARGS=$(quote "$EMBER_ARGS") "
  [ -z "${PARTS_DIR:-}" ] || envs+="PARTS_DIR=$(quote "$PARTS_DIR") "
  local tail=""
  [ ${#extra[@]} = 0 ] || tail=" -- $(quote "${extra[@]}")"
  local opts=""
  [ ${#sbopts[@]} = 0 ] || opts=" $(quote "${sbopts[@]}")"
  echo "  $envs$(quote "$(realpath -- "$0")") [--wait] --only $list $(quote "${pos[@]}")$opts$tail"
}

# ---------------------------------------------------------------- submission

# The shards whose stage 1 runs: all, or those of --only's list without a first round.
firsts=()
for k in "${todo[@]}"; do
  k=$((10#$k))
  rm -f "$parts/part-$k.shard"
  if [ -z "$only" ]; then rm -f "$parts/first-$k.shard"; fi
  [ -f "$parts/first-$k.shard" ] || firsts+=("$k")
done
if [ -n "$only" ]; then
  for ((k = 0; k < n; k++)); do
    case ",$only," in *",$k,"*) continue ;; esac
    [ -f "$parts/first-$k.shard" ] || die "--only: $parts/first-$k.shard (the first round of shard $k, which stage 2 reads) is missing: add $k to the list"
  done
fi

t0=$(now)
# (sbatch's own messages go to stderr, straight to the user; its stdout is the job id)
f="" dep=()
if [ ${#firsts[@]} -gt 0 ]; then
  first_array=$(IFS=,; echo "${firsts[*]}")
  [ -n "$only" ] || first_array="0-$((n - 1))"
  if ! f=$(timeout 60 "${first_sbatch[@]}" --array="$first_array" "${sbopts[@]}" "$parts/first.sbatch"); then
    fail "sbatch of the first rounds failed"
  fi
  f=${f%%;*}
  [[ $f =~ ^[0-9]+$ ]] || fail "unexpected answer from sbatch: $f"
  dep=(--dependency="afterok:$f")
fi
if ! a=$(timeout 60 "${shard_sbatch[@]}" --array="$array" "${dep[@]}" "${sbopts[@]}" "$parts/shard.sbatch"); then
  [ -z "$f" ] || timeout 30 scancel "$f" || true
  fail "sbatch of the shards failed${f:+ (first rounds job $f cancelled)}"
fi
a=${a%%;*}
[[ $a =~ ^[0-9]+$ ]] || fail "unexpected answer from sbatch: $a"
if ! m=$(timeout 60 "${merge_sbatch[@]}" --dependency="afterok:$a" "${sbopts[@]}" "$parts/merge.sbatch"); then
  timeout 30 scancel $f "$a" || true
  fail "sbatch of the merge failed (jobs ${f:+$f and }$a cancelled)"
fi
m=${m%%;*}

tasks="${#todo[@]} tasks"; [ ${#todo[@]} != 1 ] || tasks="1 task"
if [ -n "$f" ]; then
  say "stage 1: job $f, the first rounds of ${#firsts[@]} shard(s), logs $parts/logs/first-K.log"
else
  say "stage 1: none (every first round is there)"
fi
say "stage 2: job $a, array $array of $n ($tasks), logs $parts/logs/part-K.log"
say "merge:   job $m after all of them -> $out, log $parts/logs/merge-$m.log"
jobs=$a,$m; [ -z "$f" ] || jobs=$f,$jobs
if [ $wait_mode = 0 ]; then
  say "follow with: squeue -j $jobs"
  say "if a shard fails, Slurm cancels what waits for it; then re-run the failed shards and merge again:"
  resubmit_help K
  exit 0
fi

# ---------------------------------------------------------------- --wait

trap 'echo; say "interrupted: jobs $jobs go on; cancel them with: scancel ${jobs//,/ }"; exit 130' INT

# Final states that never change again.
final_state() {
  case $1 in
    COMPLETED|FAILED|CANCELLED*|TIMEOUT|NODE_FAIL|PREEMPTED|BOOT_FAIL|DEADLINE|OUT_OF_MEMORY|SPECIAL_EXIT|REVOKED) return 0 ;;
    *) return 1 ;;
  esac
}

merge_state="" merge_reason="" shards_done_at="" errors=0
while :; do
  if ! q=$(timeout 30 squeue -h -t all -j "$jobs" -o '%i %T %r' 2>&1); then
    case $q in
      *"Invalid job id"*) q="" ;;   # all purged already (MinJobAge)
      *)
        errors=$((errors + 1))
        [ $errors -lt 30 ] || fail "squeue keeps failing: $q"
        sleep 1; continue ;;
    esac
  fi
  errors=0
  active=0 stuck=0 merge_state="" merge_reason=""
  while read -r id st reason; do
    [ -n "${id:-}" ] || continue
    if [ "$id" = "$m" ]; then merge_state=$st merge_reason=$reason
    elif ! final_state "$st"; then
      if [ "$st" = PENDING ] && [ "$reason" = DependencyNeverSatisfied ]; then stuck=1; else active=1; fi
    fi
  done <<<"$q"
  if [ $active = 0 ] && [ -z "$shards_done_at" ]; then shards_done_at=$(since "$t0"); fi
  [ -n "$merge_state" ] || [ $active = 1 ] || [ $stuck = 1 ] || break
  if [ -n "$merge_state" ] && final_state "$merge_state"; then break; fi
  if [ $active = 0 ] && { [ $stuck = 1 ] || [ "$merge_reason" = DependencyNeverSatisfied ]; }; then
    timeout 30 scancel "$a" "$m" || true
    merge_state="CANCELLED" merge_reason="DependencyNeverSatisfied (cancelled by $prog)"
    break
  fi
  sleep 0.2
done
total=$(since "$t0")

# The last run's part of a stage's log (each run of the stage appends to it, with a header).
last_run() {
  [ -r "$1" ] || return 0
  awk '/^== (first|shard) [0-9]+\/[0-9]+: job / { buf = "" } { buf = buf $0 "\n" } END { printf "%s", buf }' "$1"
}

field() { grep -o "\(^\| \)$1=[^ ]*" <<<"$2" | head -n 1 | sed "s/^ *$1=//" || true; }

# records JOB: one line "TASK STATE EXITCODE REASON" per job of JOB (TASK: the array task id,
# or - for a plain job), from scontrol while the controller keeps the job (MinJobAge), else
# from sacct when accounting is on.
records() {
  local info line tid st ec reason
  info=$(timeout 30 scontrol -o show job "$1" 2>/dev/null || true)
  if [ -n "$info" ]; then
    while IFS= read -r line; do
      [ -n "$line" ] || continue
      tid=$(field ArrayTaskId "$line") st=$(field JobState "$line")
      ec=$(field ExitCode "$line") reason=$(field Reason "$line")
      echo "${tid:--} ${st:-?} ${ec:-?} ${reason:-?}"
    done <<<"$info"
  elif command -v sacct >/dev/null; then
    { timeout 30 sacct -n -X -P -j "$1" --format=JobID,State,ExitCode 2>/dev/null || true; } |
      while IFS='|' read -r tid st ec; do
        case $tid in *_*) tid=${tid#*_} ;; *) tid=- ;; esac
        echo "$tid ${st%% *} $ec ?"
      done
  fi
}

# Stage 1: a failed first round cancels all of stage 2, so every listed shard is then to redo.
first_failed=0
if [ -n "$f" ]; then
  while read -r tid st ec _; do
    [ -n "${tid:-}" ] || continue
    if [ "$st" != COMPLETED ] || [ "$ec" != 0:0 ]; then
      first_failed=1
      say "first round of shard $tid failed: $st, exit code $ec (code:signal), log $parts/logs/first-$tid.log:"
      last_run "$parts/logs/first-$tid.log" | tail -n 8 | sed 's/^/    /' || true
    fi
  done < <(records "$f")
fi
failed=() ok=0 seen=" "
if [ $first_failed = 1 ]; then
  for k in "${todo[@]}"; do failed+=("$((10#$k))"); done
  say "stage 2 (job $a) did not run: it needs every first round"
else
  while read -r tid st ec _; do
    [ -n "${tid:-}" ] || continue
    seen+="$tid "
    if [ "$st" = COMPLETED ] && [ "$ec" = 0:0 ]; then
      ok=$((ok + 1))
    else
      failed+=("$tid")
      say "shard $tid failed: $st, exit code $ec (code:signal), log $parts/logs/part-$tid.log:"
      last_run "$parts/logs/part-$tid.log" | tail -n 8 | sed 's/^/    /' || true
    fi
  done < <(records "$a")
  for k in "${todo[@]}"; do
    case $seen in *" $((10#$k)) "*) ;; *)
      failed+=("$((10#$k))"); say "shard $((10#$k)): no record left in Slurm (see $parts/logs/part-$((10#$k)).log)" ;;
    esac
  done
fi

merge_ec="?"
read -r _ st ec reason < <(records "$m") || true
if [ -n "${st:-}" ]; then
  merge_state=$st merge_ec=$ec
  [ "$merge_reason" = "DependencyNeverSatisfied (cancelled by $prog)" ] || merge_reason=$reason
fi

if [ ${#failed[@]} = 0 ] && [ "$merge_state" = COMPLETED ] && [ "$merge_ec" = 0:0 ]; then
  say "done: $ok shard(s) of $n rendered in ${shards_done_at:-?} s, merged into $out in $total s"
  exit 0
fi

if [ ${#failed[@]} -gt 0 ]; then
  list=$(IFS=,; echo "${failed[*]}")
  say "merge job $m: $merge_state ($merge_reason): it never runs when a shard failed"
  say "$ok of ${#todo[@]} shards succeeded; re-run the failed one(s) alone and merge again:"
  resubmit_help "$list"
else
  say "merge job $m failed: $merge_state, exit code $merge_ec, reason $merge_reason; log $parts/logs/merge-$m.log:"
  tail -n 10 "$parts/logs/merge-$m.log" 2>/dev/null | sed 's/^/    /' || true
  say "if a part file is missing or bad, re-render that shard K and merge again:"
  resubmit_help K
fi
exit 1
