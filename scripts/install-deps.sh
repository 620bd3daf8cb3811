#!/usr/bin/env bash
# Installs what ember needs to build on Debian 12 (or Ubuntu): Embree 3 (headers and library)
# and libclang (bindgen generates the Embree bindings at build time) from apt, and Intel Open
# Image Denoise for the denoiser
# (scripts/fetch-oidn.sh: the CPU libraries from the pyoidn wheel on PyPI, into
# ~/.cache/ember/oidn-2.5.1/lib, where ember looks for them at run time; pip from apt if
# missing). Idempotent.
set -euo pipefail

packages=(libembree-dev libclang-dev)
# The fuzz targets' libfuzzer-sys compiles LLVM's libFuzzer (C++) when they are built, as CI
# checks they still compile (.ci/run).
packages+=(g++)
# fetch-oidn.sh downloads a wheel with pip (no install) and unpacks it with python3.
if ! { python3 -m pip --version || pip3 --version; } >/dev/null 2>&1; then
  packages+=(python3-pip)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then SUDO=""; else SUDO="sudo"; fi
  echo "installing: ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# The denoiser's library (Open Image Denoise, CPU only); loaded at run time, so a failure here
# would leave everything but denoising working, but `cargo test` tests the denoiser too.
if ! oidn_dir=$("$(dirname "$0")/fetch-oidn.sh"); then
  echo "error: Open Image Denoise could not be fetched (see above); run scripts/fetch-oidn.sh again" >&2
  exit 1
fi
echo "Open Image Denoise: $oidn_dir" >&2

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found: install Rust with rustup (https://rustup.rs), then run this again" >&2
  exit 1
fi
