"""Writing outputs without losing data: the one place files are written.

Every output of a run goes through an :class:`OutputDir`:

- **Staged, then renamed into place.** A run writes into a staging folder
  inside ``--out`` (``.hpctl-staging-PID``, on the same file system) and
  moves the files into place only when it has finished. A run that fails,
  is interrupted (Ctrl-C) or finds the disk full leaves the previous
  outputs untouched, byte for byte; the staging folder is removed (or, after
  a kill, by the next run into the folder).
- **Order.** Data first, then each record's ``.toml`` after its ``.csv``
  (readers list records by their TOML: a record appears complete or not at
  all), summaries (``*.json``) last, so a summary never names a file that
  is not there yet. Renames are atomic; Ctrl-C is held back while they run
  (milliseconds).
- **A record is a pair.** Between the renames of a rewritten record's CSV
  and TOML a reader could see the new CSV with the old TOML. The TOML
  carries the SHA-256 of its CSV (``[record] csv_sha256``) and
  :func:`hpctl.data.records.read_record` refuses a pair that does not match
  (:class:`~hpctl.errors.RecordError`), instead of reading it as a valid
  record. A CSV without a TOML is not a record (never listed; named
  explicitly, "file not found").
- **Only its own files.** ``.hpctl-manifest.json`` lists what hpctl wrote
  (path, SHA-256, size, command). A run refuses to replace a file that is
  not in the manifest, or that was changed since hpctl wrote it, unless
  ``force`` (``--force``): a user's ``summary.json`` or an edited report is
  not silently overwritten. After a run, the files an earlier run of the
  *same command* wrote and this one did not are removed (stale records
  that ``fit DIR`` would otherwise fit too); files changed since are left
  and dropped from the manifest.
- **One run at a time.** ``.hpctl-lock`` holds an exclusive ``flock`` for
  the whole run and the writer's PID and command: a second run into the
  folder stops at once with an :class:`~hpctl.errors.OutputError` naming
  the first. The kernel drops the lock when its process dies, so a lock
  file left by a dead process is simply taken over. Readers
  (:func:`reading`) take the lock shared, so ``fit DIR`` does not read a
  folder while a run writes into it.

Written by hand rather than with a library: the pieces are a few standard
calls (``os.replace``, ``fcntl.flock``, ``hashlib``), and what matters is
their order, which is this module.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import json
import os
import shlex
import shutil
import signal
import threading
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from hpctl._version import __version__
from hpctl.errors import OutputError

try:  # POSIX; elsewhere the lock falls back to an exclusive create.
    import fcntl
except ImportError:  # pragma: no cover - not on the platforms tested
    fcntl = None  # type: ignore[assignment]

MANIFEST = ".hpctl-manifest.json"
LOCK = ".hpctl-lock"
STAGING_PREFIX = ".hpctl-staging-"
_FORMAT = "hpctl-manifest"


def provenance(argv: Sequence[str]) -> dict[str, str]:
    """Who wrote an output: hpctl's ``version`` and the exact ``command``
    (``argv`` quoted as a POSIX shell reads it back), for every summary
    (``"hpctl"`` in the JSON) and report (its first lines)."""
    return {"version": __version__, "command": shlex.join(argv)}


def provenance_line(p: Mapping[str, str]) -> str:
    """The provenance as a Markdown line for a report."""
    return f"Written by hpctl {p['version']}: `{p['command']}`"


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _fsync_dir(path: Path) -> None:
    """Makes renames in ``path`` durable (POSIX; a no-op where directories
    cannot be opened)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def temp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Writes ``path`` so that it is either the old file or the new one:
    to a temporary name beside it (flushed to disk), then renamed over it."""
    tmp = temp_name(path)
    try:
        with tmp.open("wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def replace_in_order(pairs: Iterable[tuple[Path, Path]]) -> None:
    """Renames each ``(temporary, final)`` pair in the order given (with
    Ctrl-C held back until all are done)."""
    with defer_interrupt():
        done = set()
        for tmp, final in pairs:
            os.replace(tmp, final)
            done.add(final.parent)
        for d in done:
            _fsync_dir(d)


@contextlib.contextmanager
def defer_interrupt() -> Iterator[None]:
    """Holds Ctrl-C (SIGINT) back until the block is done, then raises it:
    for a few renames that must all happen or none. Only in the main
    thread (where Python handles signals); elsewhere a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught:
            raise KeyboardInterrupt


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:
        return False
    return True


def _holder(path: Path) -> str:
    """Who holds the lock, as its file says."""
    try:
        info = json.loads(path.read_text())
        return f"pid {info['pid']}, hpctl {info['command']}, since {info['started_utc']}"
    except (OSError, ValueError, KeyError, TypeError):
        return "another process"


class _Lock:
    """An exclusive lock on a folder for one run (see the module docs)."""

    def __init__(self, folder: Path, command: str) -> None:
        self.path = folder / LOCK
        self.folder = folder
        self.command = command
        self.fd: int | None = None

    def _busy(self) -> OutputError:
        return OutputError(f"{self.folder} is in use by another hpctl run ({_holder(self.path)}); "
                           "wait for it to finish, or write to another --out")

    def acquire(self) -> None:
        info = json.dumps({"pid": os.getpid(), "command": self.command,
                           "started_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}) + "\n"
        if fcntl is None:  # pragma: no cover
            self._acquire_exclusive_create(info)
            return
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise self._busy() from None
            # The run that held it may have removed the file between our
            # open and our lock: then we locked a file nobody else sees.
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.write(fd, info.encode())
            self.fd = fd
            return

    def _acquire_exclusive_create(self, info: str) -> None:  # pragma: no cover - non-POSIX
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                try:
                    pid = int(json.loads(self.path.read_text())["pid"])
                except (OSError, ValueError, KeyError, TypeError):
                    pid = -1
                if pid > 0 and _pid_alive(pid):
                    raise self._busy() from None
                self.path.unlink(missing_ok=True)  # a dead run's lock
                continue
            os.write(fd, info.encode())
            self.fd = fd
            return
        raise self._busy()

    def release(self) -> None:
        if self.fd is None:
            return
        # Remove the file while still holding the lock (a waiting opener
        # then finds its inode gone and retries), then let go.
        self.path.unlink(missing_ok=True)
        if fcntl is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
        os.close(self.fd)
        self.fd = None


@contextlib.contextmanager
def reading(folder: Path) -> Iterator[None]:
    """While reading records from ``folder``: fails at once if an hpctl run
    is writing into it, and keeps one from starting meanwhile (a shared
    lock; nothing is created in the folder, which may be read-only)."""
    path = Path(folder) / LOCK
    if fcntl is None or not path.exists():
        yield
        return
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            raise OutputError(f"{folder} is being written by an hpctl run ({_holder(path)}); read it when that run has finished") from None
        yield
    finally:
        os.close(fd)


class Manifest:
    """``.hpctl-manifest.json``: the files hpctl wrote into a folder."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / MANIFEST
        self.files: dict[str, dict[str, Any]] = {}
        self.committing = False
        if self.path.exists():
            try:
                data = json.loads(self.path.read_text())
                if data.get("format") != _FORMAT:
                    raise ValueError("not an hpctl manifest")
                self.files = {str(k): dict(v) for k, v in data["files"].items()}
                self.committing = bool(data.get("committing", False))
            except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
                raise OutputError(f"{self.path}: unreadable manifest ({e}); remove it to let hpctl treat every file in the folder as not its own") from None

    def save(self) -> None:
        data = {"format": _FORMAT, "version": 1, "committing": self.committing, "files": dict(sorted(self.files.items()))}
        atomic_write_text(self.path, json.dumps(data, indent=1) + "\n")

    def owns(self, rel: str, path: Path) -> bool:
        """``path`` (at ``rel``) is a file hpctl wrote and nobody changed."""
        entry = self.files.get(rel)
        if entry is None or not path.is_file():
            return False
        return path.stat().st_size == entry.get("bytes") and sha256_file(path) == entry.get("sha256")


def _commit_rank(rel: str) -> tuple[int, str]:
    """Commit order: data, then records' TOML halves, then JSON summaries."""
    if rel.endswith(".json"):
        return (2, rel)
    if rel.endswith(".toml"):
        return (1, rel)
    return (0, rel)


class OutputDir:
    """The output folder of one run (see the module docs). Use as a
    context manager; write with :meth:`path` (a staging path to write to)
    or the ``write_*`` helpers; the files move into place when the block
    ends without an exception.

    ``protect`` names files the run will write, checked at the start so
    that a conflict stops the run before it computes for minutes.
    """

    def __init__(self, root: str | Path, command: str, *, force: bool = False, protect: Iterable[str] = (),
                 provenance: Mapping[str, str] | None = None) -> None:
        self.root = Path(root)
        self.command = command
        #: Who writes this folder (:func:`provenance`), for the reports
        #: written into it; None when not known (the Python API).
        self.provenance = None if provenance is None else dict(provenance)
        self.force = force
        self.protect = tuple(protect)
        self._lock = _Lock(self.root, command)
        self._staging: Path | None = None
        self.removed: list[str] = []
        self.kept: list[str] = []
        self._renaming = False

    # ------------------------------------------------------------ lifecycle

    def __enter__(self) -> OutputDir:
        self.root.mkdir(parents=True, exist_ok=True)
        self._lock.acquire()
        try:
            self._manifest = Manifest(self.root)
            # Staging folders left by killed runs (we hold the lock: no run
            # is using them).
            for old in self.root.glob(f"{STAGING_PREFIX}*"):
                shutil.rmtree(old, ignore_errors=True)
            self._check_conflicts(self.protect)
            self._staging = self.root / f"{STAGING_PREFIX}{os.getpid()}"
            self._staging.mkdir()
        except BaseException:
            self._lock.release()
            raise
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        try:
            if exc_type is None:
                self.commit()
            elif isinstance(exc, OSError):
                exc.add_note(f"the previous outputs in {self.root} are unchanged")
        except OSError as e:
            if not self._renaming:
                e.add_note(f"the previous outputs in {self.root} are unchanged")
            else:  # pragma: no cover - a failing rename within one file system
                e.add_note(f"the outputs in {self.root} may be partly replaced; {MANIFEST} lists every file hpctl wrote")
            raise
        finally:
            if self._staging is not None:
                shutil.rmtree(self._staging, ignore_errors=True)
                self._staging = None
            self._lock.release()

    # --------------------------------------------------------------- writing

    @property
    def dir(self) -> Path:
        """The staging folder (write here; see :meth:`path`)."""
        if self._staging is None:
            raise RuntimeError("OutputDir used outside its with-block")
        return self._staging

    def path(self, rel: str | Path) -> Path:
        """Where to write the output ``rel`` (relative to the folder) now;
        it moves to ``root / rel`` when the run ends."""
        rel_path = Path(rel)
        if rel_path.is_absolute() or ".." in rel_path.parts:
            raise OutputError(f"{rel}: outputs are named relative to the output folder")
        p = self.dir / rel_path
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def final(self, rel: str | Path) -> Path:
        """Where the output ``rel`` will be once the run has ended."""
        return self.root / rel

    def write_text(self, rel: str | Path, text: str) -> Path:
        p = self.path(rel)
        p.write_text(text, encoding="utf-8")
        return p

    def write_json(self, rel: str | Path, data: Any) -> Path:
        return self.write_text(rel, json.dumps(data, indent=2) + "\n")

    # ------------------------------------------------------------ committing

    def _staged(self) -> list[str]:
        if self._staging is None:
            return []
        files = [p.relative_to(self._staging).as_posix() for p in self._staging.rglob("*") if p.is_file()]
        return sorted(files, key=_commit_rank)

    def _check_conflicts(self, rels: Iterable[str]) -> None:
        if self.force:
            return
        foreign = []
        for rel in rels:
            dest = self.root / rel
            if dest.is_dir() or (dest.exists() and not self._manifest.owns(rel, dest)):
                foreign.append(rel)
        if foreign:
            shown = ", ".join(foreign[:8]) + (f" and {len(foreign) - 8} more" if len(foreign) > 8 else "")
            raise OutputError(f"{self.root}: would overwrite files hpctl did not write (or that changed since): {shown}; "
                              "move them away, choose another --out, or pass --force")

    def commit(self) -> None:
        """Moves the staged files into place and removes this command's
        stale outputs (see the module docs)."""
        staged = self._staged()
        self._check_conflicts(staged)
        m = self._manifest
        old = dict(m.files)
        stale = [rel for rel, e in old.items() if e.get("command") == self.command and rel not in staged]
        now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        for rel in staged:
            src = self.dir / rel
            m.files[rel] = {"sha256": sha256_file(src), "bytes": src.stat().st_size, "command": self.command, "written_utc": now}
        # The manifest first: should the renames be cut short (power
        # loss), every file in the folder it names is hpctl's either way.
        m.committing = True
        m.save()
        with defer_interrupt():
            self._renaming = True
            for rel in staged:
                dest = self.root / rel
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(self.dir / rel, dest)
            for rel in stale:
                dest = self.root / rel
                entry = old[rel]
                if dest.is_file() and dest.stat().st_size == entry.get("bytes") and sha256_file(dest) == entry.get("sha256"):
                    dest.unlink()
                    self.removed.append(rel)
                elif dest.exists():
                    self.kept.append(rel)  # changed since: the user's now
                m.files.pop(rel, None)
            _fsync_dir(self.root)
            m.committing = False
            m.save()

