"""The vehicle ECU firmware in the emulator (QEMU mps2-an386), over
python-can's SLCAN interface, speaking SAE J1939.

- The free-running build (``hp-fw-mps2``, a 4x4) answers like an SLCAN
  adapter, holds every corner in its safe state without inputs, counts
  frames with a bad CRC, reports its trouble codes in a DM1 sent by BAM
  once a second, and answers a request for its address claim with its NAME.
- The lock-step builds (``hp-fw-pil`` for a 4x4, ``hp-fw-pil8`` for an 8x8)
  in closed loop with the full-vehicle plant (hpctl.hil.scenario on
  hpctl.hil.plant.PilPlant: hp-vehicle's rigid body in heave, pitch and
  roll with one unit and one tyre per wheel): a lowering request on a
  rough road, levelling at rest on a slope (the road's plane under the
  wheels), a corner's pressure
  transducer failing (that corner safe, the others holding), a corner
  leaking gas (its DM1 code), and the input frames stopping (every corner
  safe). In every period the frames the firmware sends equal, bit for bit,
  those of the host build of the same code (``hp_ctrl::can::ecu::Ecu``
  through ``hpctl._core.Ecu``) fed the same input frames.
- QEMU runs on one core, every thread of it (``pil.Emulator``'s
  ``one_core``: about twice as fast), and starting it there leaves the
  starting thread's cores as they were.

Needs QEMU and a firmware toolchain, rustup's or Debian's
(scripts/install-firmware-toolchain.sh, docs/firmware.md). Without them
these tests are skipped with the reason on a developer machine and fail in
CI (ci_rules.py).
"""

import math
import os
import shutil
import subprocess
import time
from pathlib import Path

import can
import numpy as np
import pytest

from hpctl import _core
from hpctl.hil import pil, scenario

ROOT = Path(__file__).resolve().parent.parent
NO_TOOLCHAIN = 3  # scripts/firmware-build.sh: no usable firmware toolchain
PGN_ADDRESS_CLAIMED = 0xEE00
PIL_BINARY = {4: "hp-fw-pil", 8: "hp-fw-pil8"}
SEQ_LOWERING, SEQ_HOLDING = 1, 3  # hp_ctrl::SequencerState


@pytest.fixture(scope="session")
def firmware() -> dict[str, Path]:
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm not installed (scripts/install-firmware-toolchain.sh)")
    # The build script picks the toolchain (FW_TOOLCHAIN=auto|rustup|debian).
    run = subprocess.run([str(ROOT / "scripts" / "firmware-build.sh")], cwd=ROOT, capture_output=True, text=True)
    if run.returncode == NO_TOOLCHAIN:
        pytest.skip(run.stderr.strip() or "no firmware toolchain (scripts/install-firmware-toolchain.sh)")
    # Exit 1 = built, but a binary check failed: reported by the build
    # script in scripts/firmware-test.sh; the emulator tests still run.
    assert run.returncode in (0, 1), run.stderr[-4000:]
    elfs = {}
    for line in run.stdout.splitlines():
        kind, name, path = line.split(maxsplit=2)
        if kind == "elf":
            elfs[name] = Path(path)
    return elfs


def test_a_process_started_on_one_core_leaves_the_starting_thread_as_it_was():
    # What pil.Emulator starts QEMU in: the child on one core of the
    # thread's, the thread back on all of them after, and on an error too.
    before = os.sched_getaffinity(0)
    with pil._on_one_core(7):
        child = subprocess.Popen(["sleep", "5"])
    try:
        assert os.sched_getaffinity(0) == before
        got = os.sched_getaffinity(child.pid)
        assert got <= before and len(got) == (1 if len(before) > 1 else len(before))
        if len(before) > 1:
            assert got == {sorted(before)[7 % len(before)]}
    finally:
        child.kill()
        child.wait()
    with pytest.raises(RuntimeError), pil._on_one_core(0):
        raise RuntimeError("in the block")
    assert os.sched_getaffinity(0) == before


def test_free_running_firmware_is_an_slcan_adapter_in_the_safe_state(firmware):
    codec = pil.FrameCodec()
    dm1 = pil.Dm1Reader()
    with pil.Emulator(firmware["hp-fw-mps2"]) as emu:
        bus = pil.open_bus(emu.channel)
        try:
            assert bus.get_version(timeout=5) == (10, 13)
            assert bus.get_serial_number(timeout=5) == "HP01"
            # Frames with a wrong CRC: rejected and counted.
            good = codec.encode("HP_CornerMotion_0", {"StrutDisp": 0.0, "BodyAcc": 0.0, "GasTemp": 293.15})
            bad = bytearray(good.data)
            bad[0] ^= 0xFF
            for _ in range(3):
                bus.send(can.Message(arbitration_id=good.arbitration_id, is_extended_id=True, data=bytes(bad)))
            bus.send(codec.request(PGN_ADDRESS_CLAIMED))
            steps, crc_rejects, claims, sources = [], 0, [], set()
            deadline = time.monotonic() + 30
            while (len(steps) < 50 or crc_rejects < 3 or dm1.count < 1 or not claims) and time.monotonic() < deadline:
                msg = bus.recv(timeout=1)
                if msg is None:
                    continue
                assert msg.is_extended_id
                sources.add(msg.arbitration_id & 0xFF)
                dm1.feed(msg)
                name, _, values = codec.decode(msg)  # raises on a bad CRC
                if name == "HP_Valves":
                    # No sensor frames: link fault, every valve de-energised.
                    assert values["LinkFault"] == 1
                    for k in range(4):
                        assert values[f"CornerSafe_{k}"] == 1
                        assert values[f"Valve5Open_{k}"] == 0 and values[f"Valve6Open_{k}"] == 0
                    steps.append(int(values["StepIndex"]))
                elif name == "HP_DiagE2E":
                    crc_rejects = int(values["RejectCrc"])
                elif name == "J1939_AddressClaimed":
                    claims.append(bytes(msg.data))
            assert len(steps) >= 50 and crc_rejects == 3
            # The 1 kHz loop counts periods; the host may miss frames if it
            # reads slower than the emulator runs, but never out of order.
            assert all(0 < (b - a) % 65536 < 1000 for a, b in zip(steps, steps[1:]))
            # Its address, its NAME (as the host build has it), its codes:
            # every sensor of every corner and the vehicle's signals missing.
            assert sources == {pil.ECU_ADDRESS}
            host = _core.Ecu(4, "seed")
            host_claim = next(d for i, d in host.period() if pil.pgn_of(i) == PGN_ADDRESS_CLAIMED)
            assert claims[0] == host_claim
            assert dm1.amber == 1 and sorted(dm1.codes) == sorted(host.dtcs())
        finally:
            bus.shutdown()


@pytest.fixture(scope="module", params=[4, 8], ids=["4x4", "8x8"])
def corners(request) -> int:
    return int(request.param)


def run_lock_step(elf: Path, loop: scenario.VehicleLoop) -> None:
    """Runs ``loop`` on the lock-step firmware ``elf``, checking every
    period's frames against the host build fed the same input frames."""
    host = _core.Ecu(loop.corners, "pil")
    with pil.Emulator(elf) as emu:
        assert emu.proc is not None
        if len(os.sched_getaffinity(0)) > 1:
            # QEMU and every thread of it on one core (pil.Emulator's one_core).
            tasks = list(Path(f"/proc/{emu.proc.pid}/task").iterdir())
            assert len(tasks) >= 2 and {len(os.sched_getaffinity(int(t.name))) for t in tasks} == {1}
        bus = pil.open_bus(emu.channel)
        try:
            session = pil.PilSession(bus, loop.codec)
            for f in session.sent:  # the synchronising tick: no period
                host.receive(f.arbitration_id, bytes(f.data))

            def exchange(frames: list[can.Message]) -> list[can.Message]:
                got = session.period(frames)
                for f in frames + [session.sent[-1]]:
                    host.receive(f.arbitration_id, bytes(f.data))
                expect = host.period()
                assert [(m.arbitration_id, bytes(m.data)) for m in got] == expect, f"period {session.periods - 1}"
                return got

            loop.run(exchange)
        finally:
            bus.shutdown()
    assert host.tx_dropped == 0


def test_lowering_slope_levelling_and_a_failed_sensor_in_the_loop(firmware, corners):
    failing = 1
    loop = scenario.VehicleLoop(corners, "drive", corner=failing)
    run_lock_step(firmware[PIL_BINARY[corners]], loop)
    snaps = loop.snapshots
    everyone = range(corners)

    # At rest on a level road: out of the safe state, no trouble code.
    rest = snaps["rest"]
    assert all(rest.valves[f"CornerSafe_{k}"] == 0 for k in everyone)

    # Lowering on the road (6.4 s at 10 m/s): on the rigid body the corners
    # lower more slowly than on separate rigs (the tyres and unsprung masses
    # filter the road's pressure differences, and a corner lowered alone
    # sheds load to the others through the body's warp). Every corner has
    # lowered by at least half the request and none beyond it (tolerance)
    # by the ECU's estimate; the corners that have finished hold it within
    # the tolerance by the ECU's estimate; the others are still in their
    # lowering step (docs/firmware.md, Known issues). The plant's held
    # offset is taken at the corner's static load; the body's warp moves the
    # loads (the vehicle has just stopped at the foot of the slope), so it
    # differs from the ECU's estimate (which follows the corner's load):
    # measured up to 5.5 mm (8x8) and 3.1 mm (4x4); checked within 6 mm of
    # the estimate and lowered by at least half the request.
    drive = snaps["drive"]
    assert drive.dm1 == [] and drive.dm1_count >= 4
    for k in everyone:
        status = drive.status[k]
        assert status["CornerSafe"] == 0 and status["GasChargeFault"] == 0
        assert scenario.LOWER_M - scenario.TOLERANCE_M <= status["RideHeight"] <= scenario.LOWER_M / 2, k
        assert abs(drive.held_offset_m[k] - status["RideHeight"]) <= 0.006 and drive.held_offset_m[k] <= scenario.LOWER_M / 2, k
        assert status["Sequencer"] in (SEQ_LOWERING, SEQ_HOLDING), k
        if status["Sequencer"] == SEQ_HOLDING:
            assert abs(status["RideHeight"] - scenario.LOWER_M) <= scenario.TOLERANCE_M, k
    assert any(drive.status[k]["Sequencer"] == SEQ_HOLDING for k in everyone)

    # Stopped on the slope (the road's plane under the wheels), levelling at
    # rest: the body was tilted beyond the tolerance and ends within it; the
    # low side rose (each corner's rise goes with the slope's correction at
    # that corner, -x tan(pitch) - y tan(roll): positively correlated; all
    # rise a little as L's gas cools after the drive), nothing sank (at rest
    # a pump-free unit only moves towards zero).
    slope = snaps["slope"]
    assert slope.valves["HeightMode"] == scenario.pil.HEIGHT_MODES["slope_level"]
    assert loop.max_tilt_rad["slope"] > scenario.SLOPE_TOLERANCE_RAD
    assert max(abs(a) for a in slope.attitude_rad) < scenario.SLOPE_TOLERANCE_RAD
    assert all(slope.held_offset_m[k] >= drive.held_offset_m[k] - 0.001 for k in everyone)
    pitch, roll = scenario.slope_rad(corners)
    geo = loop.plant.geometry
    correction = -geo[:, 0] * math.tan(pitch) - geo[:, 1] * math.tan(roll)
    rise = [slope.held_offset_m[k] - drive.held_offset_m[k] for k in everyone]
    assert np.corrcoef(correction, rise)[0, 1] > 0.5
    assert slope.dm1 == []

    # The failed transducer: that corner in its safe state (valves
    # de-energised) with its codes (pressures erratic, safe state from a
    # fault); the others not safe, doing what they would have done without
    # the failure: their held offsets are those of the same scenario
    # without it (run on the host build, whose frames the firmware's match
    # bit for bit). (Not "unchanged since the slope snapshot": with the
    # reference gas a 4x4's corner is still finishing its levelling step
    # then, 1 mm in the 150 ms.)
    sensor = snaps["sensor"]
    v = sensor.valves
    assert v[f"CornerSafe_{failing}"] == 1 and v[f"Valve5Open_{failing}"] == 0 and v[f"Valve6Open_{failing}"] == 0
    assert v["LinkFault"] == 0
    healthy = scenario.VehicleLoop(corners, "drive", corner=failing, sensor_fails=False)
    healthy.run(scenario.host_exchange(corners))
    reference = healthy.snapshots["sensor"]
    assert all(reference.status[k]["CornerSafe"] == 0 for k in everyone)
    for k in everyone:
        if k != failing:
            assert v[f"CornerSafe_{k}"] == 0, k
            assert abs(sensor.held_offset_m[k] - reference.held_offset_m[k]) < 1e-6, k
    fmi = scenario.FMI_ERRATIC, scenario.FMI_CONDITION
    assert {(s, f) for s, f, _ in sensor.dm1} == {(scenario.spn(failing, scenario.SLOT_PRESSURES), fmi[0]), (scenario.spn(failing, scenario.SLOT_SAFE), fmi[1])}


def test_a_gas_leak_raises_its_dm1_code_in_the_loop(firmware, corners):
    leaking = corners - 1
    loop = scenario.VehicleLoop(corners, "leak", corner=leaking)
    run_lock_step(firmware[PIL_BINARY[corners]], loop)
    leak, cut = loop.snapshots["leak"], loop.snapshots["cut"]
    # The leaking corner: its gas-charge code (moderately severe: its
    # estimate, the mean of the first second, is below 10 % lost) in the
    # DM1 sent in answer to the request; no other corner's charge is
    # questioned.
    assert [(s, f) for s, f, _ in leak.dm1] == [(scenario.spn(leaking, scenario.SLOT_GAS), scenario.FMI_BELOW_MODERATE)]
    status = leak.status[leaking]
    assert status["GasChargeFault"] == 1 and status["GasLossConfidence"] > 0.9
    # The plant's charge over the first second, exp(-t / 10 s), has the
    # mean 0.952 (the estimate is updated once a second); the fast leak
    # cools the gas faster than the temperature sensor follows, which
    # biases this first estimate low (0.938 / 0.937 on the 4x4 / 8x8 on the
    # rigid body; about a per cent on separate rigs).
    assert abs(status["GasCharge"] - 0.952) < 0.02
    for k in range(corners):
        if k != leaking:
            assert leak.status[k]["GasChargeFault"] == 0 and abs(leak.status[k]["GasCharge"] - 1.0) < 0.01, k
    # Inputs cut: 60 ms later (beyond the vehicle messages' 50 ms timeout)
    # every corner is safe, with the vehicle link fault.
    v = cut.valves
    assert v["LinkFault"] == 1
    assert all(v[f"CornerSafe_{k}"] == 1 and v[f"Valve5Open_{k}"] == 0 and v[f"Valve6Open_{k}"] == 0 for k in range(corners))
