#!/usr/bin/env bash
# Installs the Debian packages for the firmware cross-build and the
# emulator (docs/firmware.md): Debian's Rust with the standard library
# sources (for -Z build-std=core), the ARM binutils and QEMU.
# Does nothing if they are already installed. Needs root (or sudo).
set -euo pipefail
packages="rustc-web cargo-web rust-web-src binutils-arm-none-eabi gcc-arm-none-eabi qemu-system-arm"
missing=""
for p in $packages; do
    dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
if [ -z "$missing" ]; then
    exit 0
fi
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "== installing firmware toolchain:$missing"
$sudo apt-get update -qq
# shellcheck disable=SC2086
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq $missing >/dev/null
