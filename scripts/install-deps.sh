#!/usr/bin/env bash
# Installs what ember needs to build on Debian 12 (or Ubuntu): Embree 3 (headers and library)
# libclang (bindgen generates the Embree bindings at build time) and the DejaVu font (text in
# benchmark and convergence plots). Idempotent.
set -euo pipefail

packages=(libembree-dev libclang-dev fonts-dejavu-core)
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

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found: install Rust with rustup (https://rustup.rs), then run this again" >&2
  exit 1
fi
