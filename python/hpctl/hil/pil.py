"""Talking to the ECU firmware over CAN: frames from the DBC, E2E
protection, the emulator, and a processor-in-the-loop session.

- :class:`FrameCodec` encodes and decodes the frames of the package's DBC (``hpctl/data/hpctl.dbc``)
  with cantools, adding and checking the AUTOSAR-profile-11-style CRC and
  alive counter (CRC-8/GSM-A over data ID and payload, see docs/can.md).
- :class:`Emulator` runs a firmware ELF in ``qemu-system-arm -M mps2-an386``
  with its UART0 on a local TCP port, and stops it by its process id.
- :class:`PilSession` drives the lock-step firmware (``hp-fw-pil``) through
  python-can's ``slcan`` interface: send one period's sensor frames and a
  ``HP_PilTick``, get the frames the ECU sent in that period.

This module only needs cantools, crccheck and python-can; it does not use
the Rust extension.
"""

from __future__ import annotations

import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import cantools
from crccheck.crc import Crc8GsmA

from hpctl.data import DBC_PATH

HEADER = ("E2E_CRC", "E2E_Counter")
COUNTER_MODULO = 15  # profile 11: counter 0..14, 15 is invalid
PIL_TICK_ID = 0x050

#: Which DBC signal carries which ``hp_ctrl::Inputs`` field.
INPUT_SIGNALS = {
    "HP_Pressures": {"PressureSmall": "p_gas_pa", "PressureLarge": "p_gas2_pa"},
    "HP_Strut": {"StrutDisp": "strut_disp_m"},
    "HP_Body": {"BodyAcc": "body_acc_m_s2"},
    "HP_Vehicle": {
        "VehicleSpeed": "speed_m_s",
        "BrakePressed": "brake_pressed",
        "LatAcc": "lat_acc_m_s2",
        "LongAcc": "long_acc_m_s2",
    },
    "HP_Steering": {"SteerAngle": "steer_angle_rad", "SteerRate": "steer_rate_rad_s"},
    "HP_Temperature": {"GasTemp": "t_gas_k"},
    "HP_Driver": {"DriverMode": "driver_mode", "RideHeightRequest": "ride_height_request_m"},
}


class E2EError(ValueError):
    """A received frame failed its CRC or counter check."""


def e2e_crc(data_id: int, payload: bytes | bytearray) -> int:
    """Profile-11 CRC of an 8-byte payload: CRC-8/GSM-A over the data ID
    (low byte, high byte) and payload bytes 1..7."""
    return int(Crc8GsmA.calc(bytes([data_id & 0xFF, data_id >> 8]) + bytes(payload[1:])))


@dataclass
class FrameCodec:
    """Encodes and decodes the DBC's frames with E2E protection; keeps one
    alive counter per message sent."""

    db: Any = field(default_factory=lambda: cantools.database.load_file(str(DBC_PATH)))
    counters: dict[str, int] = field(default_factory=dict)

    def data_id(self, name: str) -> int:
        return int(self.db.get_message_by_name(name).dbc.attributes["E2E_DataID"].value)

    def cycle_ms(self, name: str) -> int:
        return int(self.db.get_message_by_name(name).dbc.attributes["GenMsgCycleTime"].value)

    def start_delay_ms(self, name: str) -> int:
        """``GenMsgStartDelayTime`` (0 unless set): the first send, after
        which the message follows its cycle time."""
        attr = self.db.get_message_by_name(name).dbc.attributes.get("GenMsgStartDelayTime")
        return int(attr.value) if attr is not None else 0

    def due(self, name: str, period: int) -> bool:
        """True if cyclic message ``name`` is sent in 1 ms period ``period``
        (period 0 = start)."""
        cycle, delay = self.cycle_ms(name), self.start_delay_ms(name)
        return cycle > 0 and period >= delay and (period - delay) % cycle == 0

    def ecu_frames_due(self, period: int) -> list[str]:
        """The messages the ECU sends in control period ``period``, in
        identifier order (the order it sends them in)."""
        ecu = sorted((m for m in self.db.messages if m.senders == ["HPECU"]), key=lambda m: m.frame_id)
        return [m.name for m in ecu if self.due(m.name, period)]

    def encode(self, name: str, values: dict[str, float]) -> can.Message:
        """A protected frame of message ``name`` with the next counter."""
        msg = self.db.get_message_by_name(name)
        counter = self.counters.get(name, 0)
        self.counters[name] = (counter + 1) % COUNTER_MODULO
        data = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": counter, **values}, strict=True))
        data[0] = e2e_crc(self.data_id(name), data)
        return can.Message(arbitration_id=msg.frame_id, is_extended_id=False, data=bytes(data))

    def decode(self, frame: can.Message) -> tuple[str, int, dict[str, float]]:
        """(message name, alive counter, signals); raises E2EError on a bad
        CRC or counter."""
        msg = self.db.get_message_by_frame_id(frame.arbitration_id)
        data = bytes(frame.data)
        if len(data) != 8 or data[0] != e2e_crc(self.data_id(msg.name), data):
            raise E2EError(f"{msg.name}: bad CRC or length in {data.hex()}")
        counter = data[1] & 0x0F
        if counter >= COUNTER_MODULO:
            raise E2EError(f"{msg.name}: invalid counter {counter}")
        values = msg.decode(data, decode_choices=False)
        return msg.name, counter, {k: v for k, v in values.items() if k not in HEADER}

    def input_frames(self, inputs: dict[str, float], period: int) -> list[can.Message]:
        """The sensor frames due in control period ``period`` (each message
        at its DBC cycle time), from ``hp_ctrl::Inputs``-named values."""
        frames = []
        for name, signals in INPUT_SIGNALS.items():
            if self.due(name, period):
                frames.append(self.encode(name, {sig: inputs[f] for sig, f in signals.items()}))
        return frames


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


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
    :meth:`read_words`."""

    def __init__(
        self, elf: Path, port: int | None = None, qemu: str = "qemu-system-arm", icount: bool = False, monitor: bool = False
    ):
        self.elf = Path(elf)
        self.port = port or free_port()
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
    """Lock-step exchange with ``hp-fw-pil``: :meth:`period` sends one
    period's sensor frames and a tick, and returns the ECU's frames of that
    period (the messages due by the DBC's cycle times and start delays,
    :meth:`FrameCodec.ecu_frames_due`). :attr:`sent` holds every frame
    sent, in order, so a host reference can be fed exactly the same."""

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
        expected = len(self.codec.ecu_frames_due(self.periods))
        self.periods += 1
        got: list[can.Message] = []
        deadline = time.monotonic() + self.timeout_s
        while len(got) < expected:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"period {self.periods}: {len(got)} of {expected} frames")
            msg = self.bus.recv(timeout=left)
            if msg is not None:
                got.append(msg)
        return got
