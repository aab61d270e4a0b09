"""Benchmark of the lock-step processor-in-the-loop exchange: how long one
1 ms period of ``tests/test_can_firmware.py``'s drive scenario takes with
the firmware in QEMU, with QEMU on one core (:class:`hpctl.hil.pil.Emulator`'s
``one_core``, the default) and free to take any (the baseline), alternately,
in the same run.

    python scripts/bench_pil.py [--periods 500] [--repeats 2] [--corners 4,8]

The firmware is built first (``scripts/firmware-build.sh``, as the tests
build it; it needs the firmware toolchain and QEMU:
``scripts/install-firmware-toolchain.sh``). Each row runs the first
``--periods`` periods of the scenario (the plant, the input frames, the
ECU's frames read back) in a fresh emulator; the host build's check of
every frame is left out (it is the tests', not the exchange's). The load
average is printed with every row: the machine may be shared.

This is a benchmark, not a test: it prints numbers and never fails because
the machine is slow.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

from hpctl.hil import pil, scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))
from firmware_figures import build  # noqa: E402  (the firmware build and its ELFs, as the figures take them)

PIL_BINARY = {4: "hp-fw-pil", 8: "hp-fw-pil8"}


def period_ms(elf: Path, corners: int, periods: int, one_core: bool) -> float:
    """Milliseconds a period over the first ``periods`` of the drive scenario."""
    loop = scenario.VehicleLoop(corners, "drive", corner=1)  # type: ignore[arg-type]
    loop.periods = periods
    with pil.Emulator(elf, one_core=one_core) as emu:
        bus = pil.open_bus(emu.channel)
        try:
            session = pil.PilSession(bus, loop.codec)
            began = time.perf_counter()
            loop.run(session.period)
            return 1e3 * (time.perf_counter() - began) / periods
        finally:
            bus.shutdown()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--periods", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--corners", default="4,8", help="comma-separated: 4, 8")
    args = ap.parse_args()
    _, elfs = build()
    print(f"{len(os.sched_getaffinity(0))} cores; {args.periods} periods a row; load {os.getloadavg()[0]:.2f}")
    for corners in (int(c) for c in args.corners.split(",")):
        elf = elfs[PIL_BINARY[corners]]
        times: dict[bool, list[float]] = {True: [], False: []}
        for r in range(args.repeats):
            # Either first by turns, so that a trend in the load falls on both.
            for one_core in (True, False) if r % 2 == 0 else (False, True):
                ms = period_ms(elf, corners, args.periods, one_core)
                times[one_core].append(ms)
                print(f"  {corners} corners, {'one core ' if one_core else 'any core '}: {ms:6.2f} ms a period (load {os.getloadavg()[0]:.2f})")
        one, anyc = statistics.median(times[True]), statistics.median(times[False])
        print(f"{corners} corners: one core {one:.2f} ms, any core {anyc:.2f} ms a period (medians): {one / anyc:.2f} x the baseline")


if __name__ == "__main__":
    main()
