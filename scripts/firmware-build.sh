#!/usr/bin/env bash
# Cross-builds the ECU firmware (crates/hp-fw) for thumbv7em-none-eabihf and
# checks the linked binaries: no panic machinery, no heap, size budgets.
#
#   scripts/firmware-build.sh            # build all boards, check
#
# Needs Debian's rustc/cargo with the library sources and the ARM binutils
# (scripts/install-firmware-toolchain.sh); see docs/firmware.md.
# Prints the paths of the built ELF files as `elf NAME PATH` lines.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

# Debian's cargo and rustc: the core sources under /usr/lib/rustlib must
# match the compiler exactly. RUSTC_BOOTSTRAP=1 lets it take -Z build-std.
export RUSTC=${FW_RUSTC:-/usr/bin/rustc}
CARGO=${FW_CARGO:-/usr/bin/cargo}
export RUSTC_BOOTSTRAP=1
# A target directory of its own: the host workspace is built by another
# compiler, sharing one would only cause rebuilds.
export CARGO_TARGET_DIR=${FW_TARGET_DIR:-$ROOT/crates/hp-fw/target}
OUT=$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release

for tool in "$RUSTC" "$CARGO" arm-none-eabi-ld arm-none-eabi-nm arm-none-eabi-size arm-none-eabi-objdump; do
    command -v "$tool" >/dev/null || { echo "firmware-build: $tool not found (scripts/install-firmware-toolchain.sh)" >&2; exit 2; }
done

build() {
    (cd crates/hp-fw && "$CARGO" build --release "$@")
}

echo "== cross-build (emulator board: hp-fw-mps2, hp-fw-pil)" >&2
build --features mps2 --bin hp-fw-mps2 --bin hp-fw-pil
echo "== cross-build (figures build: hp-fw-figures)" >&2
build --features figures --bin hp-fw-figures
echo "== cross-build (STM32F405 bxCAN board: hp-fw-stm32f4)" >&2
build --features stm32f4 --bin hp-fw-stm32f4

FLASH_BUDGET=$((32 * 1024))
RAM_BUDGET=$((8 * 1024))
status=0
# The production binaries; hp-fw-figures prints over semihosting with
# core::fmt and is only a measuring tool.
for name in hp-fw-mps2 hp-fw-pil hp-fw-stm32f4; do
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
    [ "$flash" -le "$FLASH_BUDGET" ] || note="$note flash OVER the ${FLASH_BUDGET} B budget;"
    [ "$ram" -le "$RAM_BUDGET" ] || note="$note static RAM OVER the ${RAM_BUDGET} B budget;"
    echo "size $name flash=$flash static_ram=$ram${note}" >&2
done

for name in hp-fw-mps2 hp-fw-pil hp-fw-figures hp-fw-stm32f4; do
    echo "elf $name $OUT/$name"
done
if [ "$status" -ne 0 ]; then
    echo "firmware-build: checks FAILED" >&2
fi
exit "$status"
