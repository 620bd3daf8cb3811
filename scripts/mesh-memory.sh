#!/bin/sh
# Peak memory of rendering a 1,000,000-triangle mesh: generates the mesh (scripts/gen-grid-obj.sh,
# into a temporary folder), renders it with the release build under /usr/bin/time -v and
# prints the peak resident set size. Exits non-zero above the budget (default 400 MB).
#   scripts/mesh-memory.sh [BUDGET_MB] [extra ember render flags]
set -eu
cd "$(dirname "$0")/.."
budget_mb=${1:-400}
[ $# -gt 0 ] && shift
cargo build --release --quiet
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
scripts/gen-grid-obj.sh 1000 500 > "$dir/grid.obj"
echo "mesh: $(grep -c '^f' "$dir/grid.obj") triangles, $(grep -c '^v' "$dir/grid.obj") vertices, $(wc -c < "$dir/grid.obj") bytes"
/usr/bin/time -v target/release/ember render "$dir/grid.obj" -o "$dir/grid.png" \
    --width 320 --height 240 --spp 4 "$@" 2> "$dir/time.txt" || { cat "$dir/time.txt"; exit 1; }
grep -E '^rendered' "$dir/time.txt" || true
kb=$(awk '/Maximum resident set size/ {print $NF}' "$dir/time.txt")
mb=$((kb / 1024))
echo "peak RSS: ${kb} kB (${mb} MiB), budget ${budget_mb} MB"
[ $((kb * 1024)) -le $((budget_mb * 1000000)) ]
