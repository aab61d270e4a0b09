"""Talking to the ECU firmware over CAN (SAE J1939): frames from the DBC,
E2E protection, the DM1 trouble codes, the emulator, and a
processor-in-the-loop session.

- :class:`FrameCodec` encodes and decodes the frames of the package's DBC
  (``hpctl/data/hpctl.dbc``) with cantools: the ECU's own messages and its
  inputs with the AUTOSAR-profile-11-style CRC and alive counter (CRC-8/GSM-A
  over data ID and payload, see docs/can.md), the standard J1939 groups
  (address claim, DM1, transport protocol, acknowledgement) as plain
  frames. Frames are matched by PGN, whatever their source address and
  priority, as a J1939 node does.
- :class:`Dm1Reader` collects the ECU's active trouble codes from its DM1,
  a single frame or a BAM transfer (J1939-21 transport protocol).
- :class:`Emulator` runs a firmware ELF in ``qemu-system-arm -M mps2-an386``
  with its UART0 on a local TCP port, and stops it by its process id.
- :class:`PilSession` drives the lock-step firmware (``hp-fw-pil``,
  ``hp-fw-pil8``) through python-can's ``slcan`` interface: send one
  period's sensor frames and a ``HP_PilTick``, get the frames the ECU sent
  in that period (everything up to its ``HP_Valves``, which closes every
  period).

This module only needs cantools, crccheck and python-can; it does not use
the Rust extension.
"""

from __future__ import annotations

import contextlib
import math
import os
import socket
import subprocess
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import can
import cantools
from crccheck.crc import Crc8GsmA

from hpctl.data import DBC_PATH

HEADER = ("E2E_CRC", "E2E_Counter")
COUNTER_MODULO = 15  # profile 11: counter 0..14, 15 is invalid
#: The ECU's preferred source address (J1939: it may have to claim another).
ECU_ADDRESS = 0x2F
#: The PGN of ``HP_Valves``, the ECU's last frame of every period.
PGN_VALVES = 0xFF80
#: The test bench's source address (the DBC's TESTER node).
TESTER_ADDRESS = 0xF9
PGN_REQUEST = 0xEA00
PGN_DM1 = 0xFECA
PGN_TP_CM = 0xEC00
PGN_TP_DT = 0xEB00
#: J1939-21 connection management: broadcast announce message.
TP_CM_BAM = 0x20

#: Which DBC signal carries which field of :class:`CornerSensors`.
CORNER_SIGNALS = {
    "HP_CornerPressures": {"PressureSmall": "p_gas_pa", "PressureLarge": "p_gas2_pa"},
    "HP_CornerMotion": {"StrutDisp": "strut_disp_m", "BodyAcc": "body_acc_m_s2", "GasTemp": "t_gas_k"},
}
#: Which DBC signal carries which field of :class:`VehicleSignals`.
VEHICLE_SIGNALS = {
    "HP_Vehicle": {
        "VehicleSpeed": "speed_m_s",
        "BrakePressed": "brake_pressed",
        "LatAcc": "lat_acc_m_s2",
        "LongAcc": "long_acc_m_s2",
    },
    "HP_Steering": {"SteerAngle": "steer_angle_rad", "SteerRate": "steer_rate_rad_s"},
    "HP_Driver": {"DriverMode": "driver_mode", "HeightMode": "height_mode", "RideHeightRequest": "ride_height_request_m"},
    "HP_Inclination": {"BodyPitch": "pitch_rad", "BodyRoll": "roll_rad"},
}

#: The driver's height modes (``HP_Driver.HeightMode``; ``HP_Valves`` also
#: reports 6, the ECU's own lowering at speed).
HEIGHT_MODES = {"normal": 0, "lower": 1, "raise": 2, "kneel_front": 3, "kneel_rear": 4, "slope_level": 5, "auto_lower": 6}


class E2EError(ValueError):
    """A received frame failed its CRC or counter check."""


#: CRC-8/GSM-A of every single byte (init and final XOR 0, not
#: reflected), from crccheck: the byte-wise table of the same CRC, so a
#: payload costs nine look-ups instead of crccheck's bit loop (a lock-step
#: run encodes tens of thousands of frames).
_CRC8_TABLE = [int(Crc8GsmA.calc([i])) for i in range(256)]


def e2e_crc(data_id: int, payload: bytes | bytearray) -> int:
    """Profile-11 CRC of an 8-byte payload: CRC-8/GSM-A over the data ID
    (low byte, high byte) and payload bytes 1..7."""
    crc = 0
    for byte in (data_id & 0xFF, data_id >> 8, *payload[1:]):
        crc = _CRC8_TABLE[crc ^ byte]
    return crc


def pgn_of(can_id: int) -> int:
    """The parameter group number of a 29-bit J1939 identifier (for a PDU1
    group, PF < 240, without its destination address)."""
    pgn = (can_id >> 8) & 0x3FFFF
    return pgn & 0x3FF00 if (pgn >> 8) & 0xFF < 240 else pgn


@dataclass
class CornerSensors:
    """What one corner's sensor cluster measures (``hp_ctrl`` input names)."""

    p_gas_pa: float
    p_gas2_pa: float
    strut_disp_m: float
    body_acc_m_s2: float
    t_gas_k: float


@dataclass
class VehicleSignals:
    """What the vehicle network gateway and the driver's switches send."""

    speed_m_s: float = 0.0
    brake_pressed: int = 0
    lat_acc_m_s2: float = 0.0
    long_acc_m_s2: float = 0.0
    steer_angle_rad: float = 0.0
    steer_rate_rad_s: float = 0.0
    driver_mode: int = 0
    height_mode: int = 0
    ride_height_request_m: float = 0.0
    pitch_rad: float = 0.0
    roll_rad: float = 0.0


class Decoded(NamedTuple):
    """A decoded frame: DBC name, alive counter (None for the standard J1939
    groups, which carry none), signals (without the E2E header)."""

    name: str
    counter: int | None
    values: dict[str, float]


@dataclass
class FrameCodec:
    """Encodes and decodes the DBC's frames; keeps one alive counter per
    message sent."""

    db: Any = field(default_factory=lambda: cantools.database.load_file(str(DBC_PATH)))
    counters: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.by_pgn = {pgn_of(m.frame_id): m for m in self.db.messages}
        # Per message: (message, data ID, cycle, start delay, signal ranges),
        # looked up once (a lock-step period encodes up to 21 frames).
        self._spec: dict[str, tuple[Any, int, int, int, dict[str, tuple[float, float]]]] = {}
        for m in self.db.messages:
            a = m.dbc.attributes

            def value(key: str, a: Any = a) -> int:
                return int(a[key].value) if key in a else 0

            ranges = {sig.name: (sig.minimum, sig.maximum) for sig in m.signals}
            self._spec[m.name] = (m, value("E2E_DataID"), value("GenMsgCycleTime"), value("GenMsgStartDelayTime"), ranges)

    def message(self, can_id: int) -> Any:
        """The DBC message of a frame, by its PGN (KeyError if unknown)."""
        return self.by_pgn[pgn_of(can_id)]

    def protected(self, name: str) -> bool:
        return self._spec[name][1] != 0

    def data_id(self, name: str) -> int:
        return self._spec[name][1]

    def cycle_ms(self, name: str) -> int:
        return self._spec[name][2]

    def start_delay_ms(self, name: str) -> int:
        """``GenMsgStartDelayTime`` (0 unless set): the first send, after
        which the message follows its cycle time."""
        return self._spec[name][3]

    def due(self, name: str, period: int) -> bool:
        """True if cyclic message ``name`` is sent in 1 ms period ``period``
        (period 0 = start)."""
        _, _, cycle, delay, _ = self._spec[name]
        return cycle > 0 and period >= delay and (period - delay) % cycle == 0

    def encode(self, name: str, values: dict[str, float], source: int | None = None) -> can.Message:
        """A protected frame of message ``name`` with the next counter, from
        ``source`` (default: the sender's address in the DBC). A value
        outside its signal's DBC range raises ValueError."""
        msg, data_id, _, _, ranges = self._spec[name]
        for sig, v in values.items():
            lo, hi = ranges[sig]
            if not lo <= v <= hi:
                raise ValueError(f"{name}.{sig} = {v} is outside the DBC range [{lo}, {hi}]")
        counter = self.counters.get(name, 0)
        self.counters[name] = (counter + 1) % COUNTER_MODULO
        # Ranges checked above (cantools' own check costs more than the rest).
        data = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": counter, **values}, strict=False))
        data[0] = e2e_crc(data_id, data)
        frame_id = msg.frame_id if source is None else (msg.frame_id & ~0xFF) | source
        return can.Message(arbitration_id=frame_id, is_extended_id=True, data=bytes(data))

    def decode(self, frame: can.Message) -> Decoded:
        """Name, alive counter and signals of a frame of the DBC; raises
        E2EError on a bad CRC or counter of a protected message, KeyError
        for a PGN the DBC does not have."""
        msg = self.message(frame.arbitration_id)
        data = bytes(frame.data)
        if not self.protected(msg.name):
            return Decoded(msg.name, None, dict(msg.decode(data, decode_choices=False)))
        if len(data) != 8 or data[0] != e2e_crc(self.data_id(msg.name), data):
            raise E2EError(f"{msg.name}: bad CRC or length in {data.hex()}")
        counter = data[1] & 0x0F
        if counter >= COUNTER_MODULO:
            raise E2EError(f"{msg.name}: invalid counter {counter}")
        values = msg.decode(data, decode_choices=False)
        return Decoded(msg.name, counter, {k: v for k, v in values.items() if k not in HEADER})

    def request(self, pgn: int, destination: int = ECU_ADDRESS, source: int = TESTER_ADDRESS) -> can.Message:
        """A J1939 request (PGN 0xEA00, J1939-21) for parameter group
        ``pgn`` to ``destination`` (0xFF: every node), priority 6."""
        can_id = (6 << 26) | ((PGN_REQUEST | destination) << 8) | source
        return can.Message(arbitration_id=can_id, is_extended_id=True, data=pgn.to_bytes(3, "little"))

    def input_frames(self, corners: Sequence[CornerSensors | None], vehicle: VehicleSignals, period: int) -> list[can.Message]:
        """The input frames due in control period ``period`` (each message
        at its DBC cycle time): corner ``k``'s sensor frames (none if
        ``corners[k]`` is None: its sensor cluster is silent), then the
        vehicle's."""
        frames = []
        for k, sensors in enumerate(corners):
            if sensors is None:
                continue
            for base, signals in CORNER_SIGNALS.items():
                name = f"{base}_{k}"
                if self.due(name, period):
                    frames.append(self.encode(name, {sig: getattr(sensors, f) for sig, f in signals.items()}))
        for name, signals in VEHICLE_SIGNALS.items():
            if self.due(name, period):
                frames.append(self.encode(name, {sig: getattr(vehicle, f) for sig, f in signals.items()}))
        return frames


def parse_dm1(data: bytes) -> tuple[int, list[tuple[int, int, int]]]:
    """A DM1 payload (J1939-73): the amber warning lamp's status (0 off, 1
    on) and the active codes as ``(spn, fmi, occurrence_count)``; the "no
    fault" entry (SPN 0, FMI 0) is no code."""
    amber = (data[0] >> 2) & 0x3
    codes = []
    for i in range(2, len(data) - 3, 4):
        b = data[i : i + 4]
        if b == b"\xff\xff\xff\xff":
            continue
        spn = b[0] | (b[1] << 8) | ((b[2] >> 5) << 16)
        fmi, oc = b[2] & 0x1F, b[3] & 0x7F
        if spn or fmi:
            codes.append((spn, fmi, oc))
    return amber, codes


@dataclass
class Dm1Reader:
    """The latest complete DM1 of a node: fed every frame it sends,
    reassembles BAM transfers (J1939-21) of the DM1. ``codes`` and
    ``amber`` hold the last complete DM1; ``count`` how many arrived."""

    codes: list[tuple[int, int, int]] = field(default_factory=list)
    amber: int = 0
    count: int = 0
    _bam: dict[str, Any] | None = None

    def feed(self, frame: can.Message) -> None:
        pgn, data = pgn_of(frame.arbitration_id), bytes(frame.data)
        if pgn == PGN_DM1:
            self._done(data)
        elif pgn == PGN_TP_CM and data[0] == TP_CM_BAM and int.from_bytes(data[5:8], "little") == PGN_DM1:
            self._bam = {"size": int.from_bytes(data[1:3], "little"), "packets": data[3], "data": bytearray(), "next": 1}
        elif pgn == PGN_TP_DT and self._bam is not None:
            if data[0] != self._bam["next"]:
                self._bam = None  # a lost packet: the transfer is void
                return
            self._bam["data"] += data[1:]
            self._bam["next"] += 1
            if data[0] == self._bam["packets"]:
                self._done(bytes(self._bam["data"][: self._bam["size"]]))
                self._bam = None

    def _done(self, data: bytes) -> None:
        self.amber, self.codes = parse_dm1(data)
        self.count += 1


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def _on_one_core(spread: int) -> Iterator[None]:
    """This thread on one of its cores while the block runs, then back on
    all it had: a process started in the block (forked from this thread)
    keeps that one core, and so do its threads. The core is the
    ``spread``-th of the allowed ones (modulo their number), so that
    emulators started side by side with different ports tend to take
    different cores. Where the platform cannot say or set a thread's cores
    (not Linux) nothing is changed. Only the calling thread moves: on
    Linux the affinity of pid 0 is the calling thread's."""
    get = getattr(os, "sched_getaffinity", None)
    put = getattr(os, "sched_setaffinity", None)
    if get is None or put is None:
        yield
        return
    allowed = sorted(get(0))
    if len(allowed) < 2:
        yield
        return
    put(0, {allowed[spread % len(allowed)]})
    try:
        yield
    finally:
        put(0, allowed)


class Emulator:
    """``qemu-system-arm -M mps2-an386`` running ``elf`` with UART0 on
    ``127.0.0.1:port``. Use as a context manager; stopped by process id.

    ``icount=True`` adds ``-icount shift=0`` (one instruction per virtual
    nanosecond, deterministic timers). The lock-step firmware is
    deterministic without it (each period is closed by a tick frame), so it
    is off by default. The TCP serial port has Nagle's algorithm off
    (``nodelay=on``): the UART sends byte by byte, and with Nagle against
    the host's delayed acknowledgements every exchange waits about 40 ms.
    ``monitor=True`` puts QEMU's monitor on another local port, for
    :meth:`read_words`.

    ``one_core=True`` (the default) starts QEMU on one of this thread's
    cores, all its threads there (:func:`_on_one_core`). The CMSDK UART
    holds one byte: QEMU's I/O thread hands each received byte to the vCPU
    thread and waits for it to be read, two thread wake-ups a byte; across
    cores each is an inter-processor wake-up, on the same core a context
    switch. Measured on a 2-vCPU VM (2026-12-07, ``scripts/bench_pil.py``:
    ``tests/test_can_firmware.py``'s lock-step scenario, 500 periods):
    28.3 -> 13.3 ms a period with eight corners, 15.2 -> 7.7 ms with four
    (``-accel tcg,thread=single`` instead: no better). ``icount``'s instruction counts do not
    depend on the host's scheduling, so the figures build's are unchanged."""

    def __init__(
        self,
        elf: Path,
        port: int | None = None,
        qemu: str = "qemu-system-arm",
        icount: bool = False,
        monitor: bool = False,
        one_core: bool = True,
    ):
        self.elf = Path(elf)
        self.port = port or free_port()
        self.one_core = one_core
        self.monitor_port = free_port() if monitor else None
        monitor_arg = f"tcp:127.0.0.1:{self.monitor_port},server,nowait" if self.monitor_port else "none"
        self.cmd = [
            qemu, "-M", "mps2-an386", "-nographic", "-monitor", monitor_arg,
            "-semihosting-config", "enable=on,target=native",
            *(["-icount", "shift=0"] if icount else []),
            "-serial", f"tcp:127.0.0.1:{self.port},server,nowait,nodelay=on",
            "-kernel", str(self.elf),
        ]  # fmt: skip
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def channel(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def start(self, timeout_s: float = 10.0) -> None:
        with _on_one_core(self.port) if self.one_core else contextlib.nullcontext():
            self.proc = subprocess.Popen(self.cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                _, err = self.proc.communicate()
                raise RuntimeError(f"qemu exited with {self.proc.returncode}: {err.decode(errors='replace')}")
            # server,nowait: the port accepts once QEMU is up; probe it
            # without keeping the connection (QEMU takes one client).
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError("qemu did not open its serial port in time")

    def stop(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5)
        self.proc = None

    def read_words(self, address: int, count: int, timeout_s: float = 10.0) -> list[int]:
        """``count`` 32-bit words of guest memory from ``address`` (the
        monitor's ``xp``), e.g. to read the painted stack."""
        if self.monitor_port is None:
            raise RuntimeError("the emulator was started without monitor=True")
        with socket.create_connection(("127.0.0.1", self.monitor_port), timeout=timeout_s) as mon:

            def until_prompt() -> str:
                text = b""
                while not text.endswith(b"(qemu) "):
                    chunk = mon.recv(65536)
                    if not chunk:
                        raise RuntimeError("the monitor closed the connection")
                    text += chunk
                return text.decode(errors="replace")

            until_prompt()
            mon.sendall(f"xp /{count}wx {address:#x}\n".encode())
            words: list[int] = []
            for line in until_prompt().splitlines():
                head, sep, rest = line.partition(": ")
                if sep and all(c in "0123456789abcdef" for c in head.strip()) and head.strip():
                    words.extend(int(w, 16) for w in rest.split() if w.startswith("0x"))
        if len(words) != count:
            raise RuntimeError(f"read {len(words)} of {count} words at {address:#x}")
        return words

    def __enter__(self) -> Emulator:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def open_bus(channel: str) -> can.BusABC:
    """python-can's SLCAN interface on ``channel`` (e.g. an emulator's
    ``socket://127.0.0.1:PORT``), opened at 500 kbit/s as for an adapter.

    On a TCP channel Nagle's algorithm is switched off: SLCAN writes one
    short line per frame, and with Nagle (against the peer's delayed
    acknowledgements) each exchange would wait about 40 ms."""
    bus = can.Bus(interface="slcan", channel=channel, bitrate=500_000, sleep_after_open=0)
    sock = getattr(getattr(bus, "serialPortOrig", None), "_socket", None)
    if isinstance(sock, socket.socket):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return bus


class PilSession:
    """Lock-step exchange with ``hp-fw-pil`` / ``hp-fw-pil8``:
    :meth:`period` sends one period's input frames and a tick, and returns
    the ECU's frames of that period. The ECU sends ``HP_Valves`` last in
    every period (docs/can.md), so the period's frames are everything up to
    and including it: the DBC's cyclic messages and whatever J1939 network
    management (address claim, DM1, BAM packets, acknowledgements) the
    period brought. :attr:`sent` holds every frame sent, in order, so a host
    reference can be fed exactly the same."""

    def __init__(self, bus: can.BusABC, codec: FrameCodec | None = None, timeout_s: float = 5.0):
        self.bus = bus
        self.codec = codec or FrameCodec()
        self.timeout_s = timeout_s
        self.periods = 0
        self.ticks = 0
        self.sent: list[can.Message] = []
        # The first tick only synchronises the ECU's counter check: no period.
        self._send(self._tick())

    def _tick(self) -> can.Message:
        self.ticks += 1
        return self.codec.encode("HP_PilTick", {"TickIndex": (self.ticks - 1) % 65536})

    def _send(self, frame: can.Message) -> None:
        self.bus.send(frame)
        self.sent.append(frame)

    def period(self, frames: list[can.Message]) -> list[can.Message]:
        for f in frames:
            self._send(f)
        self._send(self._tick())
        self.periods += 1
        got: list[can.Message] = []
        deadline = time.monotonic() + self.timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"period {self.periods}: no HP_Valves after {len(got)} frames")
            msg = self.bus.recv(timeout=left)
            if msg is None:
                continue
            got.append(msg)
            if msg.is_extended_id and pgn_of(msg.arbitration_id) == PGN_VALVES:
                return got


def temperature_lag_weight(dt_s: float, tau_s: float) -> float:
    """Weight per period of a first-order sensor lag of ``tau_s`` (exact for
    a signal held over the period)."""
    return 1.0 - math.exp(-dt_s / tau_s) if tau_s > 0 else 1.0
