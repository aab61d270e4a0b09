#!/usr/bin/env python3
"""Firmware figures: flash, static RAM, heap, stack and instructions per
control step, measured on the built ELF files (scripts/firmware-build.sh).

- Flash and static RAM: ``arm-none-eabi-size -A`` of the production
  binaries (flash = vector table + .text + .rodata + .data; static RAM =
  .data + .bss + .uninit).
- Heap: zero if no allocator symbol is linked (``arm-none-eabi-nm``).
- Stack of the production build: ``hp-fw-pil`` runs a short
  processor-in-the-loop session in QEMU (every input message at its cycle
  time, a 1.5 Hz body motion on a 10 m/s drive, the diagnostics frames);
  cortex-m-rt painted its stack at reset, and the painted words left are
  read back through QEMU's monitor. The emulator board links with 8 KiB of
  RAM (crates/hp-fw/memory-mps2.x), stack below the static data, so an
  overflow faults instead of passing unnoticed.
- Instructions and stack: ``hp-fw-figures`` runs a scripted 6 s drive
  through the whole ECU path under ``qemu-system-arm -icount shift=0``
  (one instruction per virtual nanosecond) and times each part with
  SysTick on the 25 MHz core clock: one tick = 40 instructions, checked by
  timing 4000 ``nop`` instructions. Means are exact to well under one
  instruction; maxima are quantised to 40 instructions. QEMU counts
  instructions, not Cortex-M4 cycles.

Budgets (issue 5): flash <= 32 KiB, RAM <= 8 KiB, <= 5000 instructions per
control step. The figures are reported, not asserted: this is a
measurement, not a test (exit status 0 unless the measurement failed).

    scripts/firmware_figures.py [--json out/firmware-figures.json]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SYSCLK_HZ = 25_000_000
NS_PER_INSTRUCTION = 1  # -icount shift=0
INSTR_PER_TICK = 1e9 / SYSCLK_HZ / NS_PER_INSTRUCTION
FLASH_BUDGET = 32 * 1024
RAM_BUDGET = 8 * 1024
STEP_BUDGET = 5000


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
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired:
        raise SystemExit("figures run did not finish (a stack overflow locks the core up)") from None
    line = next((l for l in run.stdout.splitlines() if l.startswith("figures ")), None)
    if run.returncode != 0 or line is None:
        raise SystemExit(f"figures run failed ({run.returncode}): {run.stdout}{run.stderr}")
    raw = {k: int(v) for k, v in (w.split("=") for w in line.split()[1:])}
    calib = raw["calib_4000_nops"] * INSTR_PER_TICK
    if abs(calib - 4000) > INSTR_PER_TICK:
        raise SystemExit(f"calibration off: 4000 nops measured as {calib:.0f} instructions")
    n = raw["periods"]
    fig: dict[str, float] = {"periods_timed": n, "calibration_4000_nops_instr": calib}
    for part in ("rx", "step", "send", "period"):
        fig[f"{part}_instr_mean"] = raw[f"{part}_sum"] * INSTR_PER_TICK / n
        fig[f"{part}_instr_max"] = raw[f"{part}_max"] * INSTR_PER_TICK
    fig["stack_init_bytes"] = raw["stack_init_bytes"]
    fig["stack_loop_bytes"] = raw["stack_loop_bytes"]
    for k in ("params_ok", "safe_periods", "valve5_open", "valve6_open", "frames_sent", "tx_dropped"):
        fig[k] = raw[k]
    # Per-frame codec costs: `frame rx|tx NAME sum=.. max=.. n=..` (ticks).
    for l in run.stdout.splitlines():
        words = l.split()
        if len(words) >= 6 and words[0] == "frame":
            f = {k: int(v) for k, v in (w.split("=") for w in words[3:])}
            fig[f"frame_{words[1]}_{words[2]}_instr_mean"] = f["sum"] * INSTR_PER_TICK / max(f["n"], 1)
            fig[f"frame_{words[1]}_{words[2]}_instr_max"] = f["max"] * INSTR_PER_TICK
        # The gas table: `table pressure|offset|build sum=.. max=.. n=..` (ticks).
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


PAINT = 0xCCCC_CCCC  # cortex_m_rt::STACK_PAINT_VALUE


def pil_stack(elf: Path, periods: int = 800) -> dict[str, float]:
    """Stack high-water mark of the lock-step production binary after a
    PIL session of ``periods`` (past the power-on safe state into normal
    operation), read through QEMU's monitor."""
    sys.path.insert(0, str(ROOT / "python"))
    from hpctl import _core
    from hpctl.hil import pil

    unit = _core.seed_unit()
    p_pa, t_k = unit["static_pressure_pa"], unit["static_temperature_k"]
    stack_start, stack_end = symbol(elf, "_stack_start"), symbol(elf, "_stack_end")
    codec = pil.FrameCodec()
    with pil.Emulator(elf, monitor=True) as emu:
        bus = pil.open_bus(emu.channel)
        try:
            session = pil.PilSession(bus, codec)
            for k in range(periods):
                w = 2 * math.pi * 1.5 * k * 1e-3
                inputs = {
                    "p_gas_pa": p_pa * (1 + 0.05 * math.sin(w)),
                    "p_gas2_pa": p_pa * (1 + 0.05 * math.sin(w)),
                    "strut_disp_m": 0.01 * math.sin(w),
                    "body_acc_m_s2": -0.8 * math.cos(w),
                    "speed_m_s": 10.0, "brake_pressed": 0, "lat_acc_m_s2": 0.0, "long_acc_m_s2": 0.0,
                    "steer_angle_rad": 0.0, "steer_rate_rad_s": 0.0, "t_gas_k": t_k, "driver_mode": 0,
                    "ride_height_request_m": -0.02,
                }  # fmt: skip
                got = session.period(codec.input_frames(inputs, k))
            status = next(codec.decode(m)[2] for m in got if m.arbitration_id == 0x210)
        finally:
            bus.shutdown()
        words = emu.read_words(stack_end, (stack_start - stack_end) // 4)
    painted = next((i for i, w in enumerate(words) if w != PAINT), len(words))
    return {
        "pil_stack_bytes": stack_start - stack_end - 4 * painted,
        "pil_stack_region_bytes": stack_start - stack_end,
        "pil_periods": periods,
        "pil_safe_state_at_end": int(status["Diag"]) & 1,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args()
    toolchain, elfs = build()
    figures: dict[str, object] = {"toolchain": toolchain}
    for name in ("hp-fw-mps2", "hp-fw-pil", "hp-fw-stm32f4"):
        figures[name] = {**sizes(elfs[name]), "heap_bytes": heap_bytes(elfs[name])}
    run = measure(elfs["hp-fw-figures"])
    figures["run"] = run
    stack = max(run["stack_init_bytes"], run["stack_loop_bytes"])
    production = pil_stack(elfs["hp-fw-pil"])
    figures["hp-fw-pil"].update(production)  # type: ignore[attr-defined]

    print("Firmware figures (budgets: flash <= 32 KiB, RAM <= 8 KiB, step <= 5000 instructions)")
    print(f"  built with {toolchain}")
    for name in ("hp-fw-mps2", "hp-fw-pil", "hp-fw-stm32f4"):
        f = figures[name]
        assert isinstance(f, dict)
        print(
            f"  {name:14s} flash {f['flash_bytes']:6d} B ({f['flash_bytes'] / 1024:5.1f} KiB) "
            f"{'ok' if f['flash_bytes'] <= FLASH_BUDGET else 'OVER'}; static RAM {f['static_ram_bytes']:5d} B; "
            f"heap {f['heap_bytes']} B"
        )
    static = figures["hp-fw-pil"]["static_ram_bytes"]  # type: ignore[index]
    pil_total = production["pil_stack_bytes"] + static
    print(
        f"  stack high-water, hp-fw-pil after {production['pil_periods']:.0f} PIL periods: {production['pil_stack_bytes']:.0f} B "
        f"of the {production['pil_stack_region_bytes']:.0f} B stack region; static RAM + stack = {pil_total:.0f} B "
        f"{'ok' if pil_total <= RAM_BUDGET else 'OVER'}"
        f"{' (ended in the safe state!)' if production['pil_safe_state_at_end'] else ''}"
    )
    print(
        f"  stack high-water, figures build: {stack:.0f} B (start-up {run['stack_init_bytes']:.0f} B, "
        f"control loop {run['stack_loop_bytes']:.0f} B)"
    )
    print(f"  instructions per period over {run['periods_timed']:.0f} periods of a 10 m/s drive (mean / max):")
    labels = {
        "step": "controller step (hp_ctrl::step)",
        "rx": "receive + check frames, close period",
        "send": "encode + queue output frames",
        "period": "whole period",
    }
    for part, label in labels.items():
        mean, peak = run[f"{part}_instr_mean"], run[f"{part}_instr_max"]
        mark = ("ok" if peak <= STEP_BUDGET else "OVER") if part == "step" else ""
        print(f"    {label:38s} {mean:8.0f} / {peak:6.0f} {mark}")
    print("  instructions per frame (mean / max over 100 frames each):")
    for direction, label in (("rx", "receive"), ("tx", "encode")):
        for key in sorted(k for k in run if k.startswith(f"frame_{direction}_") and k.endswith("_mean")):
            name = key[len(f"frame_{direction}_") : -len("_instr_mean")]
            print(f"    {label} {name:31s} {run[key]:8.0f} / {run[key.replace('_mean', '_max')]:6.0f}")
    if "table_pressure_instr_mean" in run:
        print("  gas table of L (reference EOS in single precision), instructions (mean / max over 100 lookups):")
        print(f"    pressure from volume offset and temperature {run['table_pressure_instr_mean']:8.0f} / {run['table_pressure_instr_max']:6.0f}")
        print(f"    volume offset from pressure and temperature {run['table_offset_instr_mean']:8.0f} / {run['table_offset_instr_max']:6.0f}")
        print(f"    start-up (validate the configuration, build the table): {run['table_build_instr_mean']:,.0f}")
    print(
        f"  (safe-state periods {run['safe_periods']:.0f}, valve 5 open {run['valve5_open']:.0f}, "
        f"valve 6 open {run['valve6_open']:.0f}, frames sent {run['frames_sent']:.0f}, dropped {run['tx_dropped']:.0f})"
    )
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
