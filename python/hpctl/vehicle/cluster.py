"""A Dask cluster on this machine, started and stopped by process id:
what ``hpctl``'s tests and the tuning benchmark use to run the same code
path as a real cluster (``dask scheduler`` and ``dask worker`` processes
talking TCP) without leaving anything behind.

Everything listens on 127.0.0.1 only; each process is stopped by its own
id (terminate, then kill after a grace period), never by name.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from hpctl.errors import HpctlError


class ClusterError(HpctlError):
    """The local cluster could not be started."""


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _dask(role: str) -> list[str]:
    """The scheduler or worker command of this interpreter's Dask (the
    modules, not a ``dask`` script that may be another environment's)."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError("Dask's distributed scheduler is not installed (pip install 'hpctl[cluster]')") from None
    return [sys.executable, "-m", f"distributed.cli.dask_{role}"]


@dataclass
class LocalCluster:
    """A scheduler and ``workers`` single-threaded workers (no nanny, so one
    process each) on 127.0.0.1."""

    workers: int = 2
    address: str = ""
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)
    log_dir: Path | None = None

    def start(self, timeout_s: float = 60.0) -> LocalCluster:
        port = _free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False", "OMP_NUM_THREADS": "1"}
        logs = self.log_dir

        def spawn(name: str, args: list[str]) -> None:
            if logs is None:
                p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, env=env)
            else:
                with (logs / f"{name}.log").open("wb") as log:
                    p = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, env=env)
            self.processes.append(p)

        spawn("scheduler", [*_dask("scheduler"), "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"])
        for k in range(self.workers):
            spawn(f"worker{k}", [*_dask("worker"), self.address, "--no-nanny", "--nthreads", "1", "--host", "127.0.0.1",
                                 "--no-dashboard", "--name", f"hpctl-{k}"])
        self._wait(timeout_s)
        return self

    def _wait(self, timeout_s: float) -> None:
        from dask.distributed import Client

        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if any(p.poll() is not None for p in self.processes):
                self.stop()
                raise ClusterError("a cluster process exited while starting")
            try:
                with Client(self.address, timeout=5) as c:  # type: ignore[no-untyped-call]
                    if len(c.scheduler_info().get("workers", {})) >= self.workers:
                        return
            except OSError:
                pass
            time.sleep(0.5)
        self.stop()
        raise ClusterError(f"the local cluster did not come up with {self.workers} workers within {timeout_s} s")

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self.processes]

    def stop(self, grace_s: float = 10.0) -> None:
        """Stops every process it started, by its id (workers first)."""
        for p in reversed(self.processes):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for p in reversed(self.processes):
            try:
                p.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.processes.clear()

    def __enter__(self) -> LocalCluster:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
