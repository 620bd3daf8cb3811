#!/usr/bin/env bash
# Fetches Intel Open Image Denoise 2.5.1 (the CPU device only) for ember's denoiser. Debian 12
# has no OIDN package; the PyPI wheel `pyoidn` 2.5.1.0 carries the prebuilt OIDN 2.5.1 libraries
# with their own TBB (OIDN and TBB: Apache-2.0; the wheel's Python binding: MIT). A wheel is a
# zip: it is downloaded with pip and unpacked, nothing is installed. Only the CPU parts are
# unpacked (~56 MB): libOpenImageDenoise, libOpenImageDenoise_core (the trained weights are
# built in), libOpenImageDenoise_device_cpu and libtbb; not the CUDA/HIP/SYCL devices.
#
# Usage:   scripts/fetch-oidn.sh [DIR]
#          DIR defaults to $OIDN_CACHE, else ~/.cache/ember/oidn-2.5.1 ($XDG_CACHE_HOME).
# Output:  DIR/lib, the folder holding libOpenImageDenoise.so.2, alone on stdout (messages go
#          to stderr). ember loads the library at run time (src/oidn/): from $EMBER_OIDN_DIR if
#          set, else from the default DIR/lib recorded by build.rs, else the standard library
#          path; so with the default DIR nothing needs to be set, and with another DIR
#            export EMBER_OIDN_DIR="$(scripts/fetch-oidn.sh /opt/oidn)"
# Layout:  the libraries stay in a folder named `lib`, as in the wheel: their RPATH is
#          `$ORIGIN/../lib`, which is their own folder only when it is called `lib`.
# Idempotent: a folder already complete, whose files still match the checksums written when it
#          was unpacked, is reused without touching the network.
set -euo pipefail

VERSION=2.5.1
WHEEL_VERSION=2.5.1.0
# `py3-none`: one file for every Python; the libraries need glibc >= 2.17 (manylinux2014).
WHEEL=pyoidn-2.5.1.0-py3-none-manylinux2014_x86_64.whl
WHEEL_SHA256=32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e
# The real files in the wheel's pyoidn/oidn/lib/ (its .so / .so.2 / .so.12 entries are copies of
# these, a wheel holding no symlinks; the links are made below).
FILES=(
  libOpenImageDenoise.so.2.5.1
  libOpenImageDenoise_core.so.2.5.1
  libOpenImageDenoise_device_cpu.so.2.5.1
  libtbb.so.12.19
)

say() { echo "fetch-oidn: $*" >&2; }
die() { echo "fetch-oidn: error: $*" >&2; exit 1; }

cache_root=${XDG_CACHE_HOME:-${HOME:?HOME is not set}/.cache}
dir=${1:-${OIDN_CACHE:-$cache_root/ember/oidn-$VERSION}}
lib="$dir/lib"
stamp="pyoidn==$WHEEL_VERSION sha256=$WHEEL_SHA256"

if [ -f "$dir/.complete" ] && [ "$(cat "$dir/.complete")" = "$stamp" ] && [ -e "$lib/libOpenImageDenoise.so.2" ] \
    && (cd "$lib" && sha256sum --check --quiet --strict SHA256SUMS >/dev/null 2>&1); then
  say "using $lib (already fetched, checksums match)"
  echo "$lib"
  exit 0
fi

[ "$(uname -m)" = x86_64 ] || die "the pyoidn wheel used here is for x86_64 Linux only (this is $(uname -m)); install Open Image Denoise 2.x from a release archive and set EMBER_OIDN_DIR to its lib folder"

# shellcheck source=find-pip.sh
. "$(dirname "$0")/find-pip.sh"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/fetch-oidn.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

say "downloading the pyoidn $WHEEL_VERSION wheel (88 MB) from PyPI with ${pip[*]}"
if ! "${pip[@]}" download --quiet --disable-pip-version-check --no-deps --only-binary=:all: \
    --platform manylinux2014_x86_64 --dest "$tmp/dl" "pyoidn==$WHEEL_VERSION" >&2; then
  die "pip could not download pyoidn==$WHEEL_VERSION (is PyPI reachable?)"
fi
[ -f "$tmp/dl/$WHEEL" ] || die "pip downloaded $(ls "$tmp/dl" | tr '\n' ' ')instead of $WHEEL"
got=$(sha256sum "$tmp/dl/$WHEEL" | cut -d' ' -f1)
[ "$got" = "$WHEEL_SHA256" ] || die "$WHEEL has sha256 $got, expected $WHEEL_SHA256; refusing to use it"

say "unpacking the CPU libraries"
mkdir -p "$tmp/out/lib"
python3 - "$tmp/dl/$WHEEL" "$tmp/out/lib" "${FILES[@]}" <<'EOF'
import os, sys, zipfile
wheel, out, files = sys.argv[1], sys.argv[2], sys.argv[3:]
with zipfile.ZipFile(wheel) as z:
    for f in files:
        with z.open("pyoidn/oidn/lib/" + f) as src, open(os.path.join(out, f), "wb") as dst:
            dst.write(src.read())
    with z.open("pyoidn-2.5.1.0.dist-info/licenses/LICENSE") as src, \
            open(os.path.join(out, "LICENSE.pyoidn"), "wb") as dst:
        dst.write(src.read())
EOF
chmod 0755 "$tmp"/out/lib/*.so.*
(
  cd "$tmp/out/lib"
  ln -s libOpenImageDenoise.so.$VERSION libOpenImageDenoise.so.2
  ln -s libOpenImageDenoise.so.2 libOpenImageDenoise.so
  ln -s libtbb.so.12.19 libtbb.so.12
  sha256sum "${FILES[@]}" > SHA256SUMS
)

# The libraries find each other (and the CPU device its TBB) through their own RPATH; check
# that nothing is missing. The CPU device is loaded by the core library at run time.
if command -v ldd >/dev/null 2>&1; then
  for f in libOpenImageDenoise.so.2 libOpenImageDenoise_device_cpu.so.$VERSION; do
    missing=$(ldd "$tmp/out/lib/$f" | grep 'not found' || true)
    [ -z "$missing" ] || die "$f cannot load here: $missing"
  done
fi

echo "$stamp" > "$tmp/out/.complete"
mkdir -p "$(dirname "$dir")"
rm -rf "$dir.old"
[ ! -e "$dir" ] || mv "$dir" "$dir.old"
mv "$tmp/out" "$dir"
rm -rf "$dir.old"
say "Open Image Denoise $VERSION (CPU device, TBB 12.19) is in $lib"
echo "$lib"
