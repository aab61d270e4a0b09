#!/usr/bin/env bash
# The project's whole test suite: the README's test command, and what CI runs.
#
#   ./scripts/test.sh
#
# Installs the Python package (building the Rust extension) and the test
# dependencies into the current Python, then runs the Rust tests, the
# Python tests, and the firmware cross-build and emulator tests when the
# firmware toolchain is installed (scripts/install-firmware-toolchain.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== Python package and test dependencies"
python3 -m pip install --quiet --upgrade pip
python3 -m pip install --quiet -e ".[test]"

echo "== Rust tests (workspace)"
cargo test --workspace --release

echo "== Python tests"
python3 -m pytest -q

if [ -x scripts/firmware-test.sh ]; then
    echo "== Firmware (cross-build, size/panic checks, emulator tests)"
    scripts/firmware-test.sh
fi
echo "== all tests passed"
