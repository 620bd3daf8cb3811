#!/usr/bin/env bash
# Embree 3 vs Embree 4 closest-hit throughput on the teapot and the bunny, measured in one
# session: builds examples/embree_throughput.rs with the default backend (Debian's Embree 3)
# and with --features embree4 (Embree 4.4 from scripts/fetch-embree4.sh unless EMBREE_DIR is
# set), then runs the two binaries alternately, ROUNDS times each.
#
# Usage: scripts/embree3-vs-4.sh [SIDE [REPEATS [ROUNDS]]]   (defaults 1024 5 2)
set -euo pipefail
cd "$(dirname "$0")/.."
side=${1:-1024}
repeats=${2:-5}
rounds=${3:-2}

export EMBREE_DIR="${EMBREE_DIR:-$(scripts/fetch-embree4.sh)}"
out=target/release/examples
cargo build --release --example embree_throughput
cp "$out/embree_throughput" "$out/embree_throughput-embree3"
cargo build --release --features embree4 --example embree_throughput
cp "$out/embree_throughput" "$out/embree_throughput-embree4"

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
for r in $(seq "$rounds"); do
  for backend in embree3 embree4; do
    echo
    echo "round $r (load average $(cut -d' ' -f1-3 /proc/loadavg)):"
    "$out/embree_throughput-$backend" "$side" "$repeats"
  done
done
