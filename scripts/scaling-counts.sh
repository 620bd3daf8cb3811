#!/usr/bin/env bash
# Why Embree's time per ray grows more than 3x from 1k to 1M triangles for random and shadow
# rays: for each of the bench's three workloads on blob-1k and blob-1m, the wall time per ray
# (best of 5 passes, 1 thread) beside what callgrind counts per ray for one pass: instructions,
# D1 misses, and misses of a last-level cache modelled as this machine's L2 (512 KiB) and L3
# (32 MiB). Instructions that barely grow while time does are stalls on memory.
#
#     scripts/scaling-counts.sh            # ~5 minutes on 2 cores
#
# The query array itself streams through the caches at 32 bytes per ray (0.5 lines per ray),
# which the hardware prefetches; it is part of every miss count below.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind > /dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 1; }
cargo build --release --quiet --example scaling_counts
bin=target/release/examples/scaling_counts
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

jobs=()
for scene in blob-1k blob-1m; do
  for kind in coherent incoherent occlusion; do
    "$bin" "$scene" "$kind" 5 > "$tmp/$scene.$kind.time"
    for ll in l2:524288,8,64 l3:33554432,16,64; do
      jobs+=("valgrind --tool=callgrind --cache-sim=yes --D1=32768,8,64 --LL=${ll#*:} \
        --collect-atstart=no --toggle-collect=scaling_counts::measured \
        --callgrind-out-file=/dev/null $bin $scene $kind 1 > $tmp/$scene.$kind.${ll%%:*} 2>&1")
    done
  done
done
printf '%s\n' "${jobs[@]}" | xargs -P 2 -I{} sh -c '{}'

count() { grep -h "$2" "$1" | awk '{gsub(",", "", $4); print $4}'; }
printf '%-8s %-10s %8s %10s %10s %10s %12s %12s\n' scene kind rays "ns/ray" "instr/ray" "D1 miss" "L2-LL miss" "L3-LL miss"
for scene in blob-1k blob-1m; do
  for kind in coherent incoherent occlusion; do
    t="$tmp/$scene.$kind"
    rays=$(sed -E 's/.* triangles, ([0-9]+) rays.*/\1/' "$t.time")
    ns=$(sed -E 's/.*: ([0-9.]+) ns\/ray/\1/' "$t.time")
    ir=$(count "$t.l2" "I   refs")
    d1=$(count "$t.l2" "D1  misses")
    l2=$(count "$t.l2" "LLd misses")
    l3=$(count "$t.l3" "LLd misses")
    awk -v s="$scene" -v k="$kind" -v n="$rays" -v ns="$ns" -v ir="$ir" -v d1="$d1" -v l2="$l2" -v l3="$l3" \
      'BEGIN { printf "%-8s %-10s %8d %10.1f %10.0f %10.2f %12.2f %12.2f\n", s, k, n, ns, ir / n, d1 / n, l2 / n, l3 / n }'
  done
done
