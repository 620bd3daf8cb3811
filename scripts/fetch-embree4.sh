#!/usr/bin/env bash
# Fetches a prebuilt Embree 4.4 library that runs on Debian 12 (glibc 2.36), for building ember
# with `--features embree4`. Debian 12 packages only Embree 3, and Debian 13's Embree 4 needs a
# newer glibc; the PyPI wheel `embreex` 4.4.0.post1 carries Embree 4.4.0 and its own TBB in
# `embreex.libs/`. A wheel is a zip: it is downloaded with pip and unpacked, nothing is installed.
#
# Usage:   scripts/fetch-embree4.sh [DIR]
#          DIR defaults to $EMBREE4_CACHE, else ~/.cache/ember/embree-4.4.0 ($XDG_CACHE_HOME).
# Output:  the directory holding libembree4.so, alone on stdout (messages go to stderr), so
#            export EMBREE_DIR="$(scripts/fetch-embree4.sh)"
#            cargo test --features embree4
#          works; build.rs links from $EMBREE_DIR and records it as the binaries' rpath.
# Idempotent: a directory already complete is reused without touching the network.
set -euo pipefail

WHEEL_VERSION=4.4.0.post1
# One fixed file whatever the local Python: CPython 3.11, manylinux_2_28 (glibc >= 2.28).
WHEEL=embreex-4.4.0.post1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl
WHEEL_SHA256=2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f

say() { echo "fetch-embree4: $*" >&2; }
die() { echo "fetch-embree4: error: $*" >&2; exit 1; }

cache_root=${XDG_CACHE_HOME:-${HOME:?HOME is not set}/.cache}
dir=${1:-${EMBREE4_CACHE:-$cache_root/ember/embree-4.4.0}}
stamp="embreex==$WHEEL_VERSION sha256=$WHEEL_SHA256"

if [ -f "$dir/.complete" ] && [ "$(cat "$dir/.complete")" = "$stamp" ] && [ -e "$dir/libembree4.so" ]; then
  say "using $dir (already fetched)"
  echo "$dir"
  exit 0
fi

[ "$(uname -m)" = x86_64 ] || die "the embreex wheel used here is for x86_64 Linux only (this is $(uname -m)); install Embree 4 from your distribution instead (see docs/installing.md, 'Embree 4')"

# shellcheck source=find-pip.sh
. "$(dirname "$0")/find-pip.sh"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/fetch-embree4.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

say "downloading the embreex $WHEEL_VERSION wheel from PyPI with ${pip[*]}"
if ! "${pip[@]}" download --quiet --disable-pip-version-check --no-deps --only-binary=:all: \
    --python-version 3.11 --implementation cp --abi cp311 --platform manylinux_2_28_x86_64 \
    --dest "$tmp/dl" "embreex==$WHEEL_VERSION" >&2; then
  die "pip could not download embreex==$WHEEL_VERSION (is PyPI reachable?)"
fi
[ -f "$tmp/dl/$WHEEL" ] || die "pip downloaded $(ls "$tmp/dl" | tr '\n' ' ')instead of $WHEEL"
got=$(sha256sum "$tmp/dl/$WHEEL" | cut -d' ' -f1)
[ "$got" = "$WHEEL_SHA256" ] || die "$WHEEL has sha256 $got, expected $WHEEL_SHA256; refusing to use it"

say "unpacking embreex.libs/"
python3 - "$tmp/dl/$WHEEL" "$tmp/lib" <<'EOF'
import os, sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
os.makedirs(out)
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist() if n.startswith("embreex.libs/") and not n.endswith("/")]
    for n in names:
        with z.open(n) as src, open(os.path.join(out, os.path.basename(n)), "wb") as dst:
            dst.write(src.read())
    lic = [n for n in z.namelist() if n.endswith("/LICENSE")]
    for n in lic:
        with z.open(n) as src, open(os.path.join(out, "LICENSE.embreex"), "wb") as dst:
            dst.write(src.read())
EOF

shopt -s nullglob
embree=("$tmp"/lib/libembree4*.so.4)
tbb=("$tmp"/lib/libtbb*.so.12)
shopt -u nullglob
[ ${#embree[@]} -eq 1 ] || die "expected one libembree4*.so.4 in the wheel's embreex.libs/, found ${#embree[@]}"
[ ${#tbb[@]} -eq 1 ] || die "expected one libtbb*.so.12 in the wheel's embreex.libs/, found ${#tbb[@]}"
ln -s "$(basename "${embree[0]}")" "$tmp/lib/libembree4.so"
chmod 0755 "$tmp"/lib/*.so.*

# The library finds its TBB through its own rpath ($ORIGIN); check that nothing is missing.
if command -v ldd >/dev/null 2>&1; then
  missing=$(ldd "$tmp/lib/libembree4.so" | grep 'not found' || true)
  [ -z "$missing" ] || die "libembree4.so cannot load here: $missing"
fi

echo "$stamp" > "$tmp/lib/.complete"
mkdir -p "$(dirname "$dir")"
rm -rf "$dir.old"
[ ! -e "$dir" ] || mv "$dir" "$dir.old"
mv "$tmp/lib" "$dir"
rm -rf "$dir.old"
say "Embree $(basename "${embree[0]}") and $(basename "${tbb[0]}") are in $dir"
echo "$dir"
