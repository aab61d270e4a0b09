#!/usr/bin/env bash
# The project's whole test suite: the README's test command, and what CI runs.
#
#   ./scripts/test.sh
#
# Installs the Python package (building the Rust extension) and the test
# dependencies into the current Python, then runs the Rust tests, the
# Python tests (the emulator tests among them), and the firmware
# cross-build with its checks and figures.
#
# The firmware part needs a firmware toolchain (rustup's thumbv7em-none-eabihf
# target or Debian's rustc-web with its sources), the ARM binutils and QEMU:
# scripts/install-firmware-toolchain.sh. Without them, on a developer
# machine it is skipped with the reason; in CI (environment variable CI set,
# not empty/0/false/no: the rule of tests/ci_rules.py) the run fails.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each part's header says when it began (bash's SECONDS, from the start): where CI time goes.

case "$(echo "${CI:-}" | tr '[:upper:]' '[:lower:]' | tr -d '[:space:]')" in
    "" | 0 | false | no) ci=0 ;;
    *) ci=1 ;;
esac

# Can the firmware be built and run here? (Asked first: in CI a missing
# toolchain fails the run before the long parts.)
firmware_missing=""
if ! fw_says=$(scripts/firmware-build.sh --which 2>&1 >/dev/null); then
    firmware_missing=$fw_says
fi
if ! command -v qemu-system-arm >/dev/null; then
    firmware_missing="${firmware_missing:+$firmware_missing; }qemu-system-arm not installed"
fi
if [ -n "$firmware_missing" ]; then
    if [ "$ci" -eq 1 ]; then
        echo "FAIL: CI=$CI and the firmware cannot be built or run: $firmware_missing" >&2
        echo "      (.ci/run installs it with scripts/install-firmware-toolchain.sh)" >&2
        exit 1
    fi
    echo "== NOTE: firmware cross-build and emulator tests will be SKIPPED: $firmware_missing" >&2
    echo "         install with scripts/install-firmware-toolchain.sh (docs/firmware.md)" >&2
else
    echo "== $fw_says"
fi

echo "== Python package and test dependencies (at ${SECONDS} s)"
python3 -m pip install --quiet --upgrade pip
# The versions the pinned foreign-rig draws were read with (tests/constraints.txt says why).
python3 -m pip install --quiet -e ".[test]" -c tests/constraints.txt

echo "== Rust tests (workspace) (at ${SECONDS} s)"
# The release profile's optimisation, not its single codegen unit and LTO
# (Cargo.toml's test-release profile: the build 5.2 -> 2.1 min from scratch,
# `CARGO_TARGET_DIR=$(mktemp -d) cargo test --workspace --no-run` with
# --release and with --profile test-release, 2026-12-07).
cargo test --workspace --profile test-release

echo "== Python tests (at ${SECONDS} s)"
# One pytest worker per core (pytest-xdist): the tests' fits and
# simulations run on one core each but for short parallel stretches
# (measured: tests/test_flexible_fit.py 618 s of CPU in 660 s), so a
# 2-core machine runs the suite in about half the time. --dist loadfile
# keeps a file's tests on one worker, in order: a module's fixtures (a
# fitted campaign, a generated foreign case) are made once, not per worker.
# The slowest tests are listed at the end (where CI time goes).
python3 -m pytest -q -n auto --dist loadfile --durations=30

if [ -z "$firmware_missing" ]; then
    echo "== Firmware (cross-build, size/panic checks, lints, figures) (at ${SECONDS} s)"
    scripts/firmware-test.sh
    echo "== all tests passed (at ${SECONDS} s)"
else
    echo "== all tests passed (at ${SECONDS} s), firmware SKIPPED: $firmware_missing"
fi
