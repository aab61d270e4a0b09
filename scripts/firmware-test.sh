#!/usr/bin/env bash
# The firmware part of the test suite (called by scripts/test.sh):
# cross-build every board, check the binaries (no panic machinery, no heap,
# size budgets), then measure and print the firmware figures.
# The emulator tests themselves (tests/test_can_firmware.py) run with the
# other Python tests.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/firmware-build.sh >/dev/null
python3 scripts/firmware_figures.py --json out/firmware-figures.json
