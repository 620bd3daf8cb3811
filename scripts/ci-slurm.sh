#!/usr/bin/env bash
# CI check of sharded rendering on Slurm: an image rendered as N shards by a Slurm array job
# and merged (scripts/slurm-render.sh) must equal, byte for byte, the same render on one
# machine. Starts a throwaway single-node Slurm in a temporary folder
# (scripts/slurm-local-cluster.sh; installs the Debian packages if missing, needs root) and
# always stops it, on failure and on Ctrl-C too.
#
#   scripts/ci-slurm.sh EMBER_BINARY [SCENE]       # SCENE defaults to scenes/cornell.toml
#
# Environment: EMBER_ARGS, the render settings of both renders (default
# "--spp 32 --width 64 --height 48": adaptive, so a shard's second stage plans from the whole
# image's first round); CI_SLURM_SHARDS (default 4); CI_SLURM_KEEP=1 keeps the temporary
# folder (images, shard logs, daemon logs) instead of deleting it.
# Prints the time of each phase. Exits 0 only if the images are identical and no process of
# the cluster is left running.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd -P)
root=$(dirname "$here")
log() { echo "ci-slurm: $*"; }
die() { echo "ci-slurm: error: $*" >&2; exit 2; }
now() { date +%s.%N; }

if [ $# -lt 1 ] || [ $# -gt 2 ]; then sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; fi
ember=$1
scene=${2:-scenes/cornell.toml}
if [ ! -f "$ember" ] || [ ! -x "$ember" ]; then die "not an executable file: $ember"; fi
ember=$(realpath -- "$ember")
if [ ! -f "$scene" ] && [ -f "$root/$scene" ]; then scene=$root/$scene; fi
[ -f "$scene" ] || die "scene not found: $scene"
scene=$(realpath -- "$scene")
shards=${CI_SLURM_SHARDS:-4}
[[ $shards =~ ^[1-9][0-9]*$ ]] || die "CI_SLURM_SHARDS must be a positive integer, not '$shards'"
settings=${EMBER_ARGS:-"--spp 32 --width 64 --height 48"}
read -r -a settings_words <<<"$settings"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ember-ci-slurm.XXXXXX")
chmod 755 "$tmp"   # munged wants every folder above its socket searchable by all
cluster=$tmp/cluster
merged=$tmp/merged.exr
local_img=$tmp/local.exr
t_all=$(now)
timings=()
t_phase="" phase=""
# begin LABEL MESSAGE / end: time one phase
begin() { t_phase=$(now) phase=$1; log "== $2"; }
end() {
  timings+=("$(awk -v a="$t_phase" -v b="$(now)" -v n="$phase${1:-}" 'BEGIN { printf "  %-54s %7.2f s", n, b - a }')")
  phase=""
}

cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  set +e
  [ -z "$phase" ] || end " (failed)"
  begin "cluster stop" "stopping the cluster"
  if ! "$here/slurm-local-cluster.sh" stop "$cluster"; then
    log "FAIL: processes of the cluster are still running"
    rc=1
  fi
  # belt and braces: nothing alive (zombies aside) whose command line names the folder
  local left
  ps -e -o pid=,stat=,args= >"$tmp/ps"
  left=$(awk -v d="$tmp" 'index($0, d) && $2 !~ /^Z/' "$tmp/ps")
  if [ -n "$left" ]; then
    log "FAIL: still running:"
    echo "$left"
    rc=1
  fi
  end
  if [ $rc != 0 ]; then
    local f
    for f in "$merged".parts/logs/*.log "$cluster"/log/slurmctld.log "$cluster"/log/slurmd.log "$cluster"/log/munged.log; do
      [ -s "$f" ] || continue
      echo "---- tail of $f"
      tail -n 20 "$f"
    done
  fi
  echo "ci-slurm: timings ($shards shards, $settings):"
  printf '%s\n' "${timings[@]}"
  awk -v a="$t_all" -v b="$(now)" 'BEGIN { printf "  %-54s %7.2f s\n", "total", b - a }'
  if [ "${CI_SLURM_KEEP:-0}" = 1 ]; then log "kept $tmp"; else rm -rf "$tmp"; fi
  if [ $rc = 0 ]; then log "PASS: merged image of $shards Slurm shards == local render"; else log "FAIL (exit $rc)"; fi
  exit $rc
}
trap cleanup EXIT
trap 'echo; log "interrupted"; exit 130' INT
trap 'log "terminated"; exit 143' TERM

begin "cluster start (with install if needed)" "starting a throwaway Slurm in $cluster"
"$here/slurm-local-cluster.sh" start "$cluster" >/dev/null
# shellcheck source=/dev/null
. "$cluster/env"
end

begin "sharded render + merge (slurm-render --wait)" "rendering $scene as $shards shards on Slurm, then merging"
EMBER=$ember EMBER_ARGS=$settings "$here/slurm-render.sh" --wait "$scene" "$merged" "$shards"
end

begin "local render" "rendering it locally"
"$ember" render "$scene" -o "$local_img" "${settings_words[@]}"
end

begin "compare (cmp)" "comparing"
if ! cmp "$merged" "$local_img"; then
  log "FAIL: the merged image differs from the local render ($(stat -c %s "$merged") vs $(stat -c %s "$local_img") bytes)"
  exit 1
fi
end
