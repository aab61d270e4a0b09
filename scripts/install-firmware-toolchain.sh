#!/usr/bin/env bash
# Installs what the firmware cross-build and the emulator tests need
# (docs/firmware.md, Build), whichever Rust toolchain this machine offers:
#
#  - always, from Debian: the ARM binutils (the linker, nm, size, objdump)
#    and QEMU (qemu-system-arm, the mps2-an386 board);
#  - the Rust target: rustup's prebuilt thumbv7em-none-eabihf where
#    `rustup target add` works; else Debian's rustc-web, cargo-web and
#    rust-web-src (compiler and library sources, for -Z build-std=core).
#
#   scripts/install-firmware-toolchain.sh                  # as above
#   FW_TOOLCHAIN=rustup scripts/install-firmware-toolchain.sh   # rustup's target or fail
#   FW_TOOLCHAIN=debian scripts/install-firmware-toolchain.sh   # Debian's, even if rustup works
#   FW_TOOLCHAIN=both scripts/install-firmware-toolchain.sh     # both (to compare them)
#
# Installs only what is missing; needs root (or sudo) for apt-get. Ends by
# asking scripts/firmware-build.sh --which which toolchain the build will
# use, and exits non-zero if none is usable.
set -euo pipefail
cd "$(dirname "$0")/.."
WANT=${FW_TOOLCHAIN:-auto}
TARGET=thumbv7em-none-eabihf
case "$WANT" in auto | rustup | debian | both) ;; *)
    echo "install-firmware-toolchain: FW_TOOLCHAIN=$WANT: expected auto, rustup, debian or both" >&2
    exit 2
    ;;
esac

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
apt_updated=0
apt_install() {
    local missing="" p
    for p in "$@"; do
        dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
    done
    [ -n "$missing" ] || return 0
    echo "== apt-get install$missing" >&2
    if [ "$apt_updated" -eq 0 ]; then
        $sudo apt-get update -qq
        apt_updated=1
    fi
    # Only the packages themselves: QEMU's recommendations (GUI, firmware
    # images of other machines) are not needed for -nographic.
    # shellcheck disable=SC2086
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends $missing >/dev/null
}

# Both toolchains link with the ARM binutils; the tests run QEMU.
apt_install binutils-arm-none-eabi qemu-system-arm

rustup_ok=0
if [ "$WANT" != debian ]; then
    if command -v rustup >/dev/null && rustup target add "$TARGET" >&2; then
        rustup_ok=1
    else
        echo "install-firmware-toolchain: rustup cannot add $TARGET here" >&2
        if [ "$WANT" = rustup ]; then
            exit 1
        fi
    fi
fi
if [ "$WANT" = debian ] || [ "$WANT" = both ] || { [ "$WANT" = auto ] && [ "$rustup_ok" -eq 0 ]; }; then
    # Debian's compiler, its cargo, and the standard library's sources that
    # match it exactly (for -Z build-std=core).
    apt_install rustc-web cargo-web rust-web-src
fi

# What the build will use (exit 3 there: nothing usable).
if [ "$WANT" = both ]; then
    FW_TOOLCHAIN=rustup scripts/firmware-build.sh --which >/dev/null
    FW_TOOLCHAIN=debian scripts/firmware-build.sh --which >/dev/null
else
    FW_TOOLCHAIN=$WANT scripts/firmware-build.sh --which >/dev/null
fi
command -v qemu-system-arm >/dev/null || { echo "install-firmware-toolchain: qemu-system-arm missing after install" >&2; exit 1; }
