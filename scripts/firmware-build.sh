#!/usr/bin/env bash
# Cross-builds the ECU firmware (crates/hp-fw) for thumbv7em-none-eabihf and
# checks the linked binaries: no panic machinery, no heap, size budgets.
#
#   scripts/firmware-build.sh            # build all boards, check
#   scripts/firmware-build.sh --which    # only say which toolchain it would use
#   FW_TOOLCHAIN=rustup scripts/firmware-build.sh   # force one: rustup | debian
#
# Two toolchains, either will do (docs/firmware.md, Build):
#   rustup  the rustc/cargo on PATH with the prebuilt target
#           (`rustup target add thumbv7em-none-eabihf`): a plain cross-build.
#   debian  Debian's rustc-web/cargo-web (/usr/bin, or FW_RUSTC/FW_CARGO)
#           with the library sources (rust-web-src): core is built from
#           source, RUSTC_BOOTSTRAP=1 ... -Z build-std=core.
# FW_TOOLCHAIN=auto (the default) takes rustup's if its target is installed,
# else Debian's. Both need the ARM binutils (binutils-arm-none-eabi).
# scripts/install-firmware-toolchain.sh installs them.
#
# Prints `toolchain NAME VERSION` and the built ELF files as `elf NAME PATH`
# lines on stdout. Exit status: 0 built and checked; 1 built, a check
# failed; 3 no usable firmware toolchain (nothing built; the message says
# what is missing); anything else: the build failed.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
TARGET=thumbv7em-none-eabihf
WANT=${FW_TOOLCHAIN:-auto}
WHICH_ONLY=0
[ "${1:-}" = "--which" ] && WHICH_ONLY=1

DEBIAN_RUSTC=${FW_RUSTC:-/usr/bin/rustc}
DEBIAN_CARGO=${FW_CARGO:-/usr/bin/cargo}

# Why a toolchain cannot be used, or nothing if it can.
rustup_missing() {
    command -v rustc >/dev/null && command -v cargo >/dev/null || { echo "no rustc/cargo on PATH"; return; }
    local libdir
    libdir=$(rustc --print target-libdir --target "$TARGET" 2>/dev/null) || { echo "$(rustc -V) does not know $TARGET"; return; }
    compgen -G "$libdir/libcore-*.rlib" >/dev/null || echo "$(rustc -V) has no prebuilt $TARGET (rustup target add $TARGET)"
}
debian_missing() {
    [ -x "$DEBIAN_RUSTC" ] || { echo "no $DEBIAN_RUSTC (apt-get install rustc-web)"; return; }
    [ -x "$DEBIAN_CARGO" ] || { echo "no $DEBIAN_CARGO (apt-get install cargo-web)"; return; }
    local src
    src="$("$DEBIAN_RUSTC" --print sysroot)/lib/rustlib/src/rust/library/core"
    [ -d "$src" ] || echo "no library sources at $src (apt-get install rust-web-src)"
}

case "$WANT" in
    auto)
        why_rustup=$(rustup_missing)
        if [ -z "$why_rustup" ]; then
            toolchain=rustup
        else
            why_debian=$(debian_missing)
            if [ -z "$why_debian" ]; then
                toolchain=debian
            else
                echo "firmware-build: no firmware toolchain: rustup: $why_rustup; debian: $why_debian (scripts/install-firmware-toolchain.sh)" >&2
                exit 3
            fi
        fi
        ;;
    rustup | debian)
        why=$("${WANT}_missing")
        if [ -n "$why" ]; then
            echo "firmware-build: FW_TOOLCHAIN=$WANT cannot be used: $why (scripts/install-firmware-toolchain.sh)" >&2
            exit 3
        fi
        toolchain=$WANT
        ;;
    *)
        echo "firmware-build: FW_TOOLCHAIN=$WANT: expected auto, rustup or debian" >&2
        exit 2
        ;;
esac
for tool in arm-none-eabi-ld arm-none-eabi-nm arm-none-eabi-size arm-none-eabi-objdump; do
    command -v "$tool" >/dev/null || { echo "firmware-build: $tool not found (apt-get install binutils-arm-none-eabi; scripts/install-firmware-toolchain.sh)" >&2; exit 3; }
done

if [ "$toolchain" = rustup ]; then
    CARGO=cargo
    export RUSTC=rustc
    build_std=()
else
    # Debian's cargo and rustc: the core sources under /usr/lib/rustlib must
    # match the compiler exactly. RUSTC_BOOTSTRAP=1 lets it take -Z build-std.
    CARGO=$DEBIAN_CARGO
    export RUSTC=$DEBIAN_RUSTC
    export RUSTC_BOOTSTRAP=1
    build_std=(-Z build-std=core)
fi
version=$("$RUSTC" -V)
echo "toolchain $toolchain $version"
echo "firmware-build: toolchain $toolchain ($version)" >&2
[ "$WHICH_ONLY" -eq 0 ] || exit 0

# A target directory per toolchain: switching between them rebuilds nothing,
# and the path of an ELF file says which compiler made it. Not the host
# workspace's: that one is built by another compiler for another target.
export CARGO_TARGET_DIR=${FW_TARGET_DIR:-$ROOT/crates/hp-fw/target/$toolchain}
OUT=$CARGO_TARGET_DIR/$TARGET/release

build() {
    # --locked: both toolchains build the versions in crates/hp-fw/Cargo.lock
    # (chosen for rust-version 1.85, see Cargo.toml); never re-resolve here.
    (cd crates/hp-fw && "$CARGO" build --locked --release "${build_std[@]}" "$@")
}

echo "== cross-build (emulator board: hp-fw-mps2, hp-fw-pil)" >&2
build --features mps2 --bin hp-fw-mps2 --bin hp-fw-pil --bin hp-fw-pil8
echo "== cross-build (figures build: hp-fw-figures)" >&2
build --features figures --bin hp-fw-figures --bin hp-fw-figures8
echo "== cross-build (STM32F405 bxCAN board: hp-fw-stm32f4)" >&2
build --features stm32f4 --bin hp-fw-stm32f4

FLASH_BUDGET=$((32 * 1024))  # scripts/firmware_figures.py, docs/firmware.md
RAM_BUDGET=$((8 * 1024))
status=0
# The production binaries; hp-fw-figures prints over semihosting with
# core::fmt and is only a measuring tool.
for name in hp-fw-mps2 hp-fw-pil hp-fw-pil8 hp-fw-stm32f4; do
    elf=$OUT/$name
    echo "== checks: $name" >&2
    # Panic machinery: the panic handler (rust_begin_unwind) and core's
    # panicking functions are linked only if some reachable code can panic.
    panics=$(arm-none-eabi-nm -C "$elf" | grep -E 'core::panicking|rust_begin_unwind|panic_bounds_check|slice_index_fail|core::result::unwrap_failed|core::option::unwrap_failed|core::option::expect_failed' || true)
    if [ -n "$panics" ]; then
        echo "FAIL $name: panic machinery linked:" >&2
        echo "$panics" | sed 's/^/    /' >&2
        echo "  called from:" >&2
        arm-none-eabi-objdump -d "$elf" | grep -E 'bl?\.?w?\s+[0-9a-f]+ <.*(panicking|rust_begin_unwind|unwrap_failed|expect_failed|slice_index)' \
            | awk '{print $1}' | tr -d ':' | while read -r addr; do
                echo "    0x$addr:" >&2
                arm-none-eabi-addr2line -e "$elf" -i -f -C "0x$addr" 2>/dev/null | paste - - | head -3 | sed 's/^/        /' >&2
            done
        status=1
    fi
    # No heap: no allocator symbols at all.
    heap=$(arm-none-eabi-nm "$elf" | grep -E '__rust_alloc|__rg_alloc|__rdl_alloc|\bmalloc\b|_sbrk' || true)
    if [ -n "$heap" ]; then
        echo "FAIL $name: allocator linked: $heap" >&2
        status=1
    fi
    # Flash = vectors + code + read-only data + initialised data (copied
    # to RAM at start); static RAM = .data + .bss + .uninit.
    read -r flash ram < <(arm-none-eabi-size -A "$elf" | awk '
        $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" { f += $2 }
        $1 == ".data" { f += $2; r += $2 }
        $1 == ".bss" || $1 == ".uninit" { r += $2 }
        END { print f + 0, r + 0 }')
    note=""
    [ "$flash" -le "$FLASH_BUDGET" ] || { note="$note flash OVER the ${FLASH_BUDGET} B budget;"; status=1; }
    [ "$ram" -le "$RAM_BUDGET" ] || { note="$note static RAM OVER the ${RAM_BUDGET} B budget;"; status=1; }
    echo "size $name flash=$flash static_ram=$ram${note}" >&2
done

for name in hp-fw-mps2 hp-fw-pil hp-fw-pil8 hp-fw-figures hp-fw-figures8 hp-fw-stm32f4; do
    echo "elf $name $OUT/$name"
done
if [ "$status" -ne 0 ]; then
    echo "firmware-build: checks FAILED" >&2
fi
exit "$status"
