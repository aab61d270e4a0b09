#!/usr/bin/env bash
# The firmware part of the test suite (called by scripts/test.sh):
# cross-build every board, check the binaries (no panic machinery, no heap,
# size budgets), then measure and print the firmware figures.
# The emulator tests themselves (tests/test_can_firmware.py) run with the
# other Python tests.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/firmware-build.sh >/dev/null
# Lints: the firmware crate with the host toolchain's clippy (it compiles
# for the host too; the cross toolchain has no clippy).
for features in mps2 figures stm32f4; do
    (cd crates/hp-fw && CARGO_TARGET_DIR=target/host-clippy cargo clippy -q --features "$features" --lib --bins \
        --target "$(rustc -vV | sed -n 's/^host: //p')" -- -D warnings)
done
python3 scripts/firmware_figures.py --json out/firmware-figures.json
