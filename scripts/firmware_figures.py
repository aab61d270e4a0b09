#!/usr/bin/env python3
"""Firmware figures of the vehicle ECU (4 and 8 corners): flash, static RAM,
heap, stack and instructions per control period, measured on the built ELF
files (scripts/firmware-build.sh), and checked against the budgets.

- Flash and static RAM: ``arm-none-eabi-size -A`` of the production
  binaries (flash = vector table + .text + .rodata + .data; static RAM =
  .data + .bss + .uninit).
- Heap: zero if no allocator symbol is linked (``arm-none-eabi-nm``).
- Stack of the production builds: ``hp-fw-pil`` (4x4) and ``hp-fw-pil8``
  (8x8) run the first 2 s of the processor-in-the-loop ``drive`` scenario
  in QEMU (hpctl.hil.scenario: power-on, the DM1 by BAM, recovery, a
  lowering request on a class C road with the plant in the loop);
  cortex-m-rt painted the stack at reset, and the painted words left are
  read back through QEMU's monitor. The emulator board links with a
  24 KiB RAM region (crates/hp-fw/memory-mps2.x), stack below the static
  data: an overflow of the region faults; the budget is checked here on
  the measured high-water mark.
- Instructions and stack: ``hp-fw-figures`` / ``hp-fw-figures8`` run a
  scripted 6 s drive through the whole ECU path under ``qemu-system-arm
  -icount shift=0`` (one instruction per virtual nanosecond) and time each
  part with SysTick on the 25 MHz core clock: one tick = 40 instructions,
  checked by timing 4000 ``nop`` instructions. Means are exact to well
  under one instruction; maxima are quantised to 40 instructions. QEMU
  counts instructions, not Cortex-M4 cycles. Then, untimed, 1.5 s stopped
  on a slope with slope levelling (in the stack high-water mark).

Budgets (docs/firmware.md): flash <= 32 KiB for any corner count (the
single-strut ECU's budget: parameters compiled on the host and kept in
flash made room for J1939 and eight corners); RAM (static + stack
high-water) <= 4 KiB + 1 KiB per corner (8 KiB for a 4x4, the single-strut
ECU's budget, 12 KiB for an 8x8); the vehicle step <= 5000 instructions
per corner (the single-strut step's budget, per corner).

Exit status 1 if a figure is over its budget or the measurement failed.

    scripts/firmware_figures.py [--json out/firmware-figures.json]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Literal

ROOT = Path(__file__).resolve().parent.parent
SYSCLK_HZ = 25_000_000
NS_PER_INSTRUCTION = 1  # -icount shift=0
INSTR_PER_TICK = 1e9 / SYSCLK_HZ / NS_PER_INSTRUCTION
FLASH_BUDGET = 32 * 1024
STEP_BUDGET_PER_CORNER = 5000
PAINT = 0xCCCC_CCCC  # cortex_m_rt::STACK_PAINT_VALUE
PRODUCTION = ("hp-fw-mps2", "hp-fw-pil", "hp-fw-pil8", "hp-fw-stm32f4")
CORNERS = {"hp-fw-mps2": 4, "hp-fw-pil": 4, "hp-fw-pil8": 8, "hp-fw-stm32f4": 8}


def ram_budget(corners: int) -> int:
    """Static RAM + stack high-water budget, bytes."""
    return (4 + corners) * 1024


def build() -> tuple[str, dict[str, Path]]:
    """Builds with the toolchain scripts/firmware-build.sh picks
    (FW_TOOLCHAIN=auto|rustup|debian); returns "NAME VERSION" of that
    toolchain and the ELF files."""
    run = subprocess.run([str(ROOT / "scripts" / "firmware-build.sh")], cwd=ROOT, capture_output=True, text=True)
    sys.stderr.write(run.stderr[-3000:])
    if run.returncode not in (0, 1):
        raise SystemExit(f"firmware build failed ({run.returncode})")
    lines = [line.split(maxsplit=2) for line in run.stdout.splitlines()]
    toolchain = next(f"{name} {rest}" for kind, name, rest in lines if kind == "toolchain")
    return toolchain, {name: Path(path) for kind, name, path in lines if kind == "elf"}


def sizes(elf: Path) -> dict[str, int]:
    out = subprocess.run(["arm-none-eabi-size", "-A", str(elf)], check=True, capture_output=True, text=True).stdout
    sec = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sec[parts[0]] = int(parts[1])
    flash = sum(sec.get(s, 0) for s in (".vector_table", ".text", ".rodata", ".data"))
    ram = sum(sec.get(s, 0) for s in (".data", ".bss", ".uninit"))
    return {"flash_bytes": flash, "static_ram_bytes": ram}


def heap_bytes(elf: Path) -> int:
    out = subprocess.run(["arm-none-eabi-nm", str(elf)], check=True, capture_output=True, text=True).stdout
    allocators = re.findall(r"\b(__rust_alloc|__rg_alloc|__rdl_alloc|malloc|_sbrk)\b", out)
    return 0 if not allocators else -1  # -1: an allocator is linked, heap unknown


def measure(elf: Path) -> dict[str, float]:
    cmd = [
        "qemu-system-arm", "-M", "mps2-an386", "-nographic", "-monitor", "none", "-serial", "null",
        "-semihosting-config", "enable=on,target=native", "-icount", "shift=0", "-kernel", str(elf),
    ]  # fmt: skip
    # A stack overflow locks the core up (memory-mps2.x): QEMU then never exits.
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        raise SystemExit(f"{elf.name}: figures run did not finish (a stack overflow locks the core up)") from None
    line = next((l for l in run.stdout.splitlines() if l.startswith("figures ")), None)
    if run.returncode != 0 or line is None:
        raise SystemExit(f"{elf.name}: figures run failed ({run.returncode}): {run.stdout}{run.stderr}")
    raw = {k: int(v) for k, v in (w.split("=") for w in line.split()[1:])}
    calib = raw["calib_4000_nops"] * INSTR_PER_TICK
    if abs(calib - 4000) > INSTR_PER_TICK:
        raise SystemExit(f"calibration off: 4000 nops measured as {calib:.0f} instructions")
    n = raw["periods"]
    fig: dict[str, float] = {"corners": raw["corners"], "periods_timed": n, "calibration_4000_nops_instr": calib}
    for part in ("rx", "step", "send", "period"):
        fig[f"{part}_instr_mean"] = raw[f"{part}_sum"] * INSTR_PER_TICK / n
        fig[f"{part}_instr_max"] = raw[f"{part}_max"] * INSTR_PER_TICK
    for k in ("stack_init_bytes", "stack_loop_bytes", "safe_periods", "valve5_open", "valve6_open", "frames_sent", "tx_dropped", "slope_level_periods"):
        fig[k] = raw[k]
    sizes_line = next((l for l in run.stdout.splitlines() if l.startswith("sizes ")), "")
    for w in sizes_line.split()[1:]:
        key, value = w.split("=")
        if key != "corners":
            fig[key] = int(value)
    # Per-frame codec costs: `frame rx|tx NAME sum=.. max=.. n=..` (ticks).
    for l in run.stdout.splitlines():
        words = l.split()
        if len(words) >= 6 and words[0] == "frame":
            f = {k: int(v) for k, v in (w.split("=") for w in words[3:])}
            fig[f"frame_{words[1]}_{words[2]}_instr_mean"] = f["sum"] * INSTR_PER_TICK / max(f["n"], 1)
            fig[f"frame_{words[1]}_{words[2]}_instr_max"] = f["max"] * INSTR_PER_TICK
        # The gas table: `table pressure|offset sum=.. max=.. n=..` (ticks).
        if len(words) == 5 and words[0] == "table":
            f = {k: int(v) for k, v in (w.split("=") for w in words[2:])}
            fig[f"table_{words[1]}_instr_mean"] = f["sum"] * INSTR_PER_TICK / max(f["n"], 1)
            fig[f"table_{words[1]}_instr_max"] = f["max"] * INSTR_PER_TICK
    return fig


def symbol(elf: Path, name: str) -> int:
    out = subprocess.run(["arm-none-eabi-nm", str(elf)], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        words = line.split()
        if len(words) == 3 and words[2] == name:
            return int(words[0], 16)
    raise SystemExit(f"{elf.name}: no symbol {name}")


def pil_stack(elf: Path, corners: Literal[4, 8], periods: int = 2000) -> dict[str, float]:
    """Stack high-water mark of a lock-step production binary after the
    first ``periods`` of the ``drive`` scenario, read through QEMU's
    monitor."""
    sys.path.insert(0, str(ROOT / "python"))
    from hpctl.hil import pil, scenario

    stack_start, stack_end = symbol(elf, "_stack_start"), symbol(elf, "_stack_end")
    loop = scenario.VehicleLoop(corners, "drive", corner=1)
    loop.periods = periods
    with pil.Emulator(elf, monitor=True) as emu:
        bus = pil.open_bus(emu.channel)
        try:
            session = pil.PilSession(bus, loop.codec)
            loop.run(session.period)
        finally:
            bus.shutdown()
        words = emu.read_words(stack_end, (stack_start - stack_end) // 4)
    painted = next((i for i, w in enumerate(words) if w != PAINT), len(words))
    drive = loop.snapshots["drive"]
    return {
        "pil_stack_bytes": stack_start - stack_end - 4 * painted,
        "pil_stack_region_bytes": stack_start - stack_end,
        "pil_periods": periods,
        "pil_corners_safe_at_end": sum(int(drive.valves[f"CornerSafe_{k}"]) for k in range(corners)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args()
    toolchain, elfs = build()
    figures: dict[str, dict[str, float] | str] = {"toolchain": toolchain}
    for name in PRODUCTION:
        figures[name] = {**sizes(elfs[name]), "heap_bytes": heap_bytes(elfs[name]), "corners": CORNERS[name]}
    runs = {4: measure(elfs["hp-fw-figures"]), 8: measure(elfs["hp-fw-figures8"])}
    figures["run4"], figures["run8"] = runs[4], runs[8]
    pil_corners: tuple[tuple[str, Literal[4, 8]], ...] = (("hp-fw-pil", 4), ("hp-fw-pil8", 8))
    for name, pil_n in pil_corners:
        figures[name].update(pil_stack(elfs[name], pil_n))  # type: ignore[union-attr]

    over: list[str] = []
    print("Firmware figures of the vehicle ECU (budgets: flash <= 32 KiB; RAM <= 4 KiB + 1 KiB per corner;")
    print("vehicle step <= 5000 instructions per corner)")
    print(f"  built with {toolchain}")
    for name in PRODUCTION:
        f = figures[name]
        assert isinstance(f, dict)
        ok = f["flash_bytes"] <= FLASH_BUDGET and f["heap_bytes"] == 0
        over += [] if ok else [f"{name} flash {f['flash_bytes']:.0f} B"]
        print(
            f"  {name:14s} ({f['corners']:.0f} corners) flash {f['flash_bytes']:6.0f} B ({f['flash_bytes'] / 1024:4.1f} KiB) "
            f"{'ok' if ok else 'OVER'}; static RAM {f['static_ram_bytes']:4.0f} B; heap {f['heap_bytes']:.0f} B"
        )
    for name, corners in (("hp-fw-pil", 4), ("hp-fw-pil8", 8)):
        f = figures[name]
        assert isinstance(f, dict)
        total = f["pil_stack_bytes"] + f["static_ram_bytes"]
        ok = total <= ram_budget(corners) and f["pil_corners_safe_at_end"] == 0
        over += [] if ok else [f"{name} RAM {total:.0f} B"]
        print(
            f"  RAM, {name} after {f['pil_periods']:.0f} PIL periods: stack {f['pil_stack_bytes']:.0f} B + static "
            f"{f['static_ram_bytes']:.0f} B = {total:.0f} B of {ram_budget(corners)} B {'ok' if ok else 'OVER'}"
            f"{' (corners in the safe state at the end!)' if f['pil_corners_safe_at_end'] else ''}"
        )
    labels = {
        "step": "vehicle step (hp_ctrl::vehicle::step)",
        "rx": "receive + check frames, close period",
        "send": "J1939, encode + queue frames",
        "period": "whole period",
    }
    for corners, run in runs.items():
        stack = max(run["stack_init_bytes"], run["stack_loop_bytes"])
        print(f"  {corners} corners, figures build: stack {stack:.0f} B (start-up {run['stack_init_bytes']:.0f}, loop and slope levelling "
              f"{run['stack_loop_bytes']:.0f}); Ecu {run['ecu_bytes']:.0f} B, VehicleParams {run['params_bytes']:.0f} B (flash), "
              f"VehicleState {run['state_bytes']:.0f} B")  # fmt: skip
        print(f"    instructions per period over {run['periods_timed']:.0f} periods of a 10 m/s drive (mean / max):")
        for part, label in labels.items():
            mean, peak = run[f"{part}_instr_mean"], run[f"{part}_instr_max"]
            mark = ""
            if part == "step":
                ok = peak <= STEP_BUDGET_PER_CORNER * corners
                over += [] if ok else [f"{corners}-corner step {peak:.0f}"]
                mark = f"{'ok' if ok else 'OVER'} ({mean / corners:.0f} / {peak / corners:.0f} per corner)"
            print(f"      {label:38s} {mean:8.0f} / {peak:6.0f} {mark}")
        print(
            f"    (safe-state corner-periods {run['safe_periods']:.0f}, valve 5 open {run['valve5_open']:.0f}, "
            f"valve 6 open {run['valve6_open']:.0f}, frames sent {run['frames_sent']:.0f}, dropped {run['tx_dropped']:.0f}, "
            f"slope-levelling periods {run['slope_level_periods']:.0f})"
        )
        if run["slope_level_periods"] == 0 or run["tx_dropped"] or run["safe_periods"]:
            over.append(f"{corners}-corner figures run: not the scenario it should be")
    print("  instructions per frame, 4 corners (mean / max over 100 frames each):")
    for direction, label in (("rx", "receive"), ("tx", "encode")):
        for key in sorted(k for k in runs[4] if k.startswith(f"frame_{direction}_") and k.endswith("_mean")):
            name = key[len(f"frame_{direction}_") : -len("_instr_mean")]
            print(f"    {label} {name:31s} {runs[4][key]:8.0f} / {runs[4][key.replace('_mean', '_max')]:6.0f}")
    run = runs[4]
    if "table_pressure_instr_mean" in run:
        print("  gas table of L (reference EOS in single precision, built on the host), instructions (mean / max over 100 lookups):")
        print(f"    pressure from volume offset and temperature {run['table_pressure_instr_mean']:8.0f} / {run['table_pressure_instr_max']:6.0f}")
        print(f"    volume offset from pressure and temperature {run['table_offset_instr_mean']:8.0f} / {run['table_offset_instr_max']:6.0f}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    if over:
        raise SystemExit(f"over budget: {'; '.join(over)}")


if __name__ == "__main__":
    main()
