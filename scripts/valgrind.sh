#!/bin/sh
# Memory safety of the Embree FFI layer: renders tests/data/valgrind.toml (an OBJ mesh with an
# MTL library, a quad, spheres and cylinders as Embree user geometry, point and area lights)
# under valgrind memcheck with full leak checking. Exits non-zero when valgrind reports an
# invalid read or write, a use of uninitialised memory, or a definite, indirect or possible
# leak not covered by scripts/valgrind.supp (which states what it suppresses and why).
# Still-reachable blocks (Embree's, TBB's and rayon's globals) are not errors.
#   scripts/valgrind.sh [extra ember render flags]     e.g. --accel naive, --threads 1
# The profiling build: the release code with line tables, so reports name file and line.
set -eu
cd "$(dirname "$0")/.."
cargo build --profile profiling --quiet
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
valgrind --tool=memcheck --error-exitcode=3 --leak-check=full \
    --errors-for-leak-kinds=definite,indirect,possible --show-leak-kinds=definite,indirect,possible \
    --track-origins=yes --num-callers=40 --suppressions=scripts/valgrind.supp \
    target/profiling/ember render tests/data/valgrind.toml -o "$out/valgrind.png" "$@"
test -s "$out/valgrind.png"
echo "valgrind: no errors"
