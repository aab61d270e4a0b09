"""CAN logs (candump ``.log``, Vector ``.asc`` and ``.blf``, and the other
formats python-can reads) decoded with the project's CAN database.

The bus is SAE J1939: 29-bit identifiers of priority, PGN and source
address. A frame is matched to a J1939 message of the DBC by its PGN
(and, for a PDU1 group, its destination if a message of the DBC names
it), ignoring the priority and the source address as a J1939 receiver
does; the source address is reported (a ``source_address`` column in the
message's table, the sources per message in the summary, the source of
every rejected frame). Messages the DBC does not mark as J1939 (e.g. a
rig's own 11-bit or 29-bit frames) match their identifier exactly.

Signals are decoded by cantools from the DBC (whatever it holds); every
frame the codec protects is first checked by the codec itself
(``_core.can_decode``: identifier, length, CRC, counter value, reserved
bits, signal ranges) and its alive counter by the ECU's own sequence rule
(``_core.CanCounter``, one per message and source address), so a log is
judged as the ECU would judge it. A frame that fails is reported (time,
identifier, source, message, reason) and not decoded into the tables: a
bad CRC or a repeated or skipped counter never reaches a record silently.
Messages in the DBC that the codec does not protect (J1939 network
management: address claim, DM1, requests, transport protocol) are decoded
and marked ``unprotected``; identifiers the DBC does not know are counted.
"""

from __future__ import annotations

import struct
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl.caveats import Caveat, Code
from hpctl.data import DBC_PATH
from hpctl.errors import CanRejectError, RecordError
from hpctl.interop._support import require
from hpctl.interop.mapping import Channel, RawTable

FloatArray = NDArray[np.float64]

#: Per-frame outcomes that put the frame into the tables.
ACCEPTED = ("next", "synced", "unprotected")


@dataclass(frozen=True)
class FrameIssue:
    """A frame that was not decoded, and why (``source`` the J1939 source
    address, None for a frame of a message that is not J1939)."""

    time_s: float
    id: int
    message: str | None
    reason: str
    source: int | None = None


class MessageIndex:
    """The DBC's messages by what identifies them on the bus: a J1939
    message (cantools' ``protocol == "j1939"``) by its PGN, and by its
    destination too where the DBC holds several PDU1 messages of one PGN
    (a request to the ECU and a global one); any other message by its
    exact identifier and format."""

    def __init__(self, db: Any, j1939: Any) -> None:
        self._j1939 = j1939
        self._exact: dict[tuple[int, bool], Any] = {}
        self._by_pgn: dict[int, list[Any]] = defaultdict(list)
        for m in db.messages:
            if m.protocol == "j1939" and m.is_extended_frame:
                self._by_pgn[j1939.pgn_from_frame_id(m.frame_id)].append(m)
            else:
                self._exact[(m.frame_id, bool(m.is_extended_frame))] = m

    def lookup(self, frame_id: int, extended: bool) -> tuple[Any, int | None] | None:
        """The message of a received identifier and its J1939 source
        address (None if not a J1939 message), or None if the DBC has no
        such message."""
        exact = self._exact.get((frame_id, extended))
        if exact is not None or not extended:
            return (exact, None) if exact is not None else None
        candidates = self._by_pgn.get(self._j1939.pgn_from_frame_id(frame_id))
        if not candidates:
            return None
        fid = self._j1939.frame_id_unpack(frame_id)
        if len(candidates) > 1 and self._j1939.is_pdu_format_1(fid.pdu_format):
            # PDU1: the PS field is the destination; prefer the message
            # that names this one, else the global one.
            def destination(m: Any) -> int:
                return int(self._j1939.frame_id_unpack(m.frame_id).pdu_specific)
            named = [m for m in candidates if destination(m) == fid.pdu_specific] or [m for m in candidates if destination(m) == 0xFF]
            candidates = named or candidates
        return candidates[0], int(fid.source_address)


@dataclass
class CanDecode:
    """A decoded log: one table per message (``time_s`` from the first
    frame of the log, then the DBC's signals), the frames that failed, and
    the count of every outcome per message."""

    source: str
    tables: dict[str, dict[str, FloatArray]]
    units: dict[str, dict[str, str]]
    issues: list[FrameIssue]
    outcomes: dict[str, dict[str, int]]
    unknown_ids: dict[int, int] = field(default_factory=dict)
    frames: int = 0
    #: Frames per J1939 source address of each message.
    sources: dict[str, dict[int, int]] = field(default_factory=dict)

    @property
    def rejected(self) -> int:
        return len(self.issues)

    def caveats(self) -> list[Caveat]:
        """What the tables cannot stand behind: one warning per message
        with rejected frames, one for identifiers the DBC does not know."""
        out = []
        by_message: dict[str, Counter[str]] = defaultdict(Counter)
        for i in self.issues:
            by_message[i.message or f"id {i.id:#x}"][i.reason] += 1
        for m, reasons in sorted(by_message.items()):
            n = sum(reasons.values())
            out.append(Caveat(Code.CAN_FRAMES_REJECTED,
                              f"{m}: {n} frame(s) rejected and not decoded (" + ", ".join(f"{r}: {k}" for r, k in sorted(reasons.items())) + ")",
                              {"message": m, "frames": n, "reasons": sorted(reasons), "counts": [reasons[r] for r in sorted(reasons)]}))
        if self.unknown_ids:
            ids = sorted(self.unknown_ids)
            n = sum(self.unknown_ids.values())
            out.append(Caveat(Code.CAN_UNKNOWN_IDS,
                              f"{n} frame(s) with {len(ids)} identifier(s) the DBC does not know: " + ", ".join(f"{i:#x}" for i in ids),
                              {"frames": n, "ids": ids}))
        return out

    def to_raw(self) -> RawTable:
        """The signals as channels named ``MESSAGE.SIGNAL`` (each on its
        message's time base), for a channel mapping to a record."""
        channels = {}
        for m, table in self.tables.items():
            for s, values in table.items():
                if s not in ("time_s", "source_address"):
                    channels[f"{m}.{s}"] = Channel(values, self.units[m].get(s) or None, table["time_s"])
        return RawTable(self.source, channels)


def decode_log(path: str | Path, dbc: str | Path | None = None) -> CanDecode:
    """Decodes the CAN log at ``path`` (python-can picks the reader by the
    suffix: .log candump, .asc, .blf, .csv, .trc, ...) with ``dbc``
    (default: the package's ``hpctl.dbc``)."""
    can = require("can", "reading CAN logs")
    cantools = require("cantools", "decoding CAN logs")
    j1939 = require("cantools.j1939", "decoding J1939 identifiers")
    p = Path(path)
    if not p.is_file():
        raise RecordError(f"{p}: file not found")
    db_path = Path(dbc) if dbc is not None else DBC_PATH
    try:
        db = cantools.database.load_file(str(db_path))
    except Exception as e:  # cantools raises several parser errors
        raise RecordError(f"{db_path}: not a readable CAN database: {e}") from None
    index = MessageIndex(db, j1939)
    # What python-can's readers raise on a file that is not their format:
    # ValueError/OSError/EOFError, struct.error on short records, and the
    # BLF reader's own BLFParseError (an Exception, not a ValueError).
    malformed: tuple[type[BaseException], ...] = (ValueError, OSError, EOFError, struct.error)
    blf_error = getattr(getattr(getattr(can, "io", None), "blf", None), "BLFParseError", None)
    if isinstance(blf_error, type) and issubclass(blf_error, BaseException):
        malformed += (blf_error,)
    try:
        reader = can.LogReader(str(p))
    except malformed as e:
        raise RecordError(f"{p}: python-can cannot read this log: {e}") from None

    rows: dict[str, list[tuple[float, int | None, dict[str, float]]]] = defaultdict(list)
    issues: list[FrameIssue] = []
    outcomes: dict[str, Counter[str]] = defaultdict(Counter)
    sources: dict[str, Counter[int]] = defaultdict(Counter)
    unknown: Counter[int] = Counter()
    # One alive-counter sequence per message and sender (two senders of one
    # PGN are two sequences).
    counters: dict[tuple[str, int | None], Any] = {}
    t0: float | None = None
    frames = 0
    try:
        for msg in reader:
            if msg.is_error_frame or msg.is_remote_frame:
                continue
            frames += 1
            t0 = msg.timestamp if t0 is None else t0
            t = float(msg.timestamp - t0)
            data = bytes(msg.data)
            found = index.lookup(msg.arbitration_id, bool(msg.is_extended_id))
            if found is None:
                unknown[msg.arbitration_id] += 1
                continue
            definition, source = found
            name = definition.name
            if source is not None:
                sources[name][source] += 1
            try:
                _core.can_decode(msg.arbitration_id, data, extended=bool(msg.is_extended_id))
                counter = definition.decode(data, decode_choices=False).get("E2E_Counter")
                check = counters.setdefault((name, source), _core.CanCounter()).check
                outcome = check(int(counter)) if counter is not None else "next"
            except CanRejectError as e:
                outcome = "unprotected" if e.args[1] == "unknown_id" else str(e.args[1])
            outcomes[name][outcome] += 1
            if outcome not in ACCEPTED:
                issues.append(FrameIssue(t, msg.arbitration_id, name, outcome, source))
                continue
            try:
                values = definition.decode(data, decode_choices=False)
            except Exception as e:  # cantools: a frame too short for its signals
                outcomes[name][outcome] -= 1
                outcomes[name]["undecodable"] += 1
                issues.append(FrameIssue(t, msg.arbitration_id, name, f"undecodable: {e}", source))
                continue
            rows[name].append((t, source, {k: float(v) for k, v in values.items()}))
    except malformed as e:
        raise RecordError(f"{p}: the log is malformed after {frames} frames: {e}") from None
    finally:
        stop = getattr(reader, "stop", None)
        if stop is not None:
            stop()

    tables: dict[str, dict[str, FloatArray]] = {}
    units: dict[str, dict[str, str]] = {}
    for name, entries in rows.items():
        definition = db.get_message_by_name(name)
        signals = [s.name for s in definition.signals]
        table = {"time_s": np.array([t for t, _, _ in entries])}
        if name in sources:
            table["source_address"] = np.array([float(a if a is not None else np.nan) for _, a, _ in entries])
        tables[name] = table | {s: np.array([v.get(s, np.nan) for _, _, v in entries]) for s in signals}
        units[name] = {s.name: s.unit or "" for s in definition.signals}
    return CanDecode(str(p), tables, units, issues, {m: dict(c) for m, c in outcomes.items()}, dict(unknown), frames,
                     {m: dict(c) for m, c in sources.items()})
