"""Running a case's tests and writing rig records (NAME.csv + NAME.toml,
exactly per /work/shared/docs/rig-data-format.md, with our own writer) and
truth.json beside them; generated cases are cached on disk by (effect,
seed, tests, noise, code version)."""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .draw import Case, draw_case
from .model import simulate
from .programs import Test, tests_for
from .sensors import jittered, measure

FloatArray = NDArray[np.float64]
VERSION = 1


@dataclass
class Record:
    name: str
    kind: str
    columns: dict[str, FloatArray]
    meta: dict[str, dict[str, Any]]


def run_test(case: Case, test: Test) -> tuple[Record, dict[str, FloatArray]]:
    """The noisy record of one test on the case's unit, and the true signals."""
    u, ds = case.unit, case.data_system
    rng = np.random.default_rng([case.seed, 2, zlib.crc32(test.name.encode())])
    nominal = test.times_s()
    actual = jittered(nominal, ds.jitter_s, rng, test.duration_s)
    res = simulate(u, test.motion, actual, test.segments(), test.duration_s, sprung_mass_kg=case.sprung_mass_kg if test.sdof else None)
    ch = res.channels
    off = u.effects.sensor_offset
    lag = u.effects.sensor_lag is not None
    f_off, p_off, p2_off = (off.force_n, off.p_gas_pa, off.p_gas2_pa) if off is not None else (0.0, 0.0, 0.0)
    cols: dict[str, FloatArray] = {"time_s": nominal}
    cols["disp_m"] = measure(ch["disp_m"], actual, ds.disp, rng)
    cols["force_n"] = measure(ch["force_n_lagged" if lag else "force_n"], actual, ds.force, rng, f_off)
    if test.sdof:
        cols["body_disp_m"] = measure(ch["body_disp_m"], actual, ds.disp, rng)
        cols["base_disp_m"] = measure(ch["base_disp_m"], actual, ds.disp, rng)
    cols["p_gas_pa"] = measure(ch["p_gas_pa_lagged" if lag else "p_gas_pa"], actual, ds.pressure, rng, p_off)
    cols["p_gas2_pa"] = measure(ch["p_gas2_pa_lagged" if lag else "p_gas2_pa"], actual, ds.pressure, rng, p2_off)
    cols["t_gas_k"] = measure(ch["t_gas_meas_k"], actual, ds.temperature, rng)
    cols["t_oil_k"] = measure(ch["t_oil_meas_k"], actual, ds.temperature, rng)
    cols["t_amb_k"] = measure(np.full(len(actual), u.ambient_k), actual, ds.temperature, rng)
    if test.switch_period_s is not None:
        cols["spring_hard"] = test.spring_hard_at(actual)
        cols["damper_on"] = np.full(len(actual), float(test.damper_on))
    meta: dict[str, dict[str, Any]] = {
        "record": {"kind": "sdof" if test.sdof else "characterisation", "description": "foreign rig (tests/foreign_rig)"},
        "unit": {"piston_area_m2": u.piston_area_m2, "small_acc_volume_m3": u.small_acc_volume_m3,
                 "large_acc_volume_m3": u.large_acc_volume_m3, "gas": "N2"},
        "static": {"pressure_pa": case.declared_pressure_pa, "temperature_k": u.static_temperature_k, "ambient_k": u.ambient_k},
        "test": {"spring": "hard" if test.spring_hard else "soft", "damper": "on" if test.damper_on else "off", "excitation": test.excitation},
    }
    if test.amplitude_m is not None:
        meta["test"]["amplitude_m"] = test.amplitude_m
    if test.frequency_hz is not None:
        meta["test"]["frequency_hz"] = test.frequency_hz
    if test.sdof:
        meta["sdof"] = {"sprung_mass_kg": case.sprung_mass_kg}
    true = {"time_s": actual, **ch}
    return Record(test.name, meta["record"]["kind"], cols, meta), true


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        f = float(v)
        if not math.isfinite(f):
            raise ValueError(f"not a finite number: {v!r}")
        return repr(f)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string for these ASCII texts
    raise TypeError(type(v))


def write_record(rec: Record, folder: Path) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    csv_path, toml_path = folder / f"{rec.name}.csv", folder / f"{rec.name}.toml"
    names = list(rec.columns)
    arrays = [np.asarray(rec.columns[c], dtype=float) for c in names]
    flags = {"spring_hard", "damper_on"}
    lines = [",".join(names)]
    for row in zip(*arrays):
        lines.append(",".join(str(int(v)) if n in flags else repr(float(v)) for n, v in zip(names, row)))
    csv_path.write_text("\n".join(lines) + "\n")
    toml = []
    for table, content in rec.meta.items():
        toml.append(f"[{table}]")
        toml += [f"{k} = {_toml_value(v)}" for k, v in content.items()]
        toml.append("")
    toml_path.write_text("\n".join(toml))
    return csv_path, toml_path


def code_version() -> str:
    """A hash of this package's source: cached cases expire when it changes."""
    h = hashlib.sha1(str(VERSION).encode())
    for p in sorted(Path(__file__).parent.glob("*.py")):
        h.update(p.read_bytes())
    return h.hexdigest()[:12]


def cache_root() -> Path:
    return Path(os.environ.get("FOREIGN_RIG_CACHE", Path(tempfile.gettempdir()) / "hpctl-foreign-rig"))


@dataclass
class Generated:
    folder: Path
    records: list[Path]
    truth: dict[str, Any]

    def read(self) -> list[Any]:
        """The records as hpctl reads them (``hpctl.data.records.read_record``;
        imported here only, the rig itself does not depend on hpctl)."""
        from hpctl.data.records import read_record

        return [read_record(p) for p in self.records]


def generate(
    effect: str | None,
    seed: int,
    out: str | Path | None = None,
    program: str = "effect",
    extra: Sequence[str] = (),
    tests: Sequence[Test] | None = None,
    noise: bool = True,
    cache: bool = True,
    gauge_error: bool = True,
) -> Generated:
    """Draws the case, runs its tests and writes the records and truth.json
    into ``out`` (a fresh folder) or, by default, into the cache, where a
    case already generated by the same code is reused."""
    tests = list(tests) if tests is not None else tests_for(effect, program, tuple(extra))
    key = f"{effect or 'none'}-{seed}-{'-'.join(t.name for t in tests)}-{'noise' if noise else 'quiet'}-{'gauge' if gauge_error else 'exact'}"
    if out is None:
        digest = hashlib.sha1(key.encode()).hexdigest()[:10]
        folder = cache_root() / code_version() / f"{effect or 'none'}-{seed}-{digest}"
        if cache and (folder / "truth.json").exists():
            truth = json.loads((folder / "truth.json").read_text())
            return Generated(folder, [folder / r for r in truth["records"]], truth)
    else:
        folder = Path(out)
        if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
            raise FileExistsError(f"{folder} exists and is not an empty folder: the foreign rig never overwrites records")
    case = draw_case(effect, seed, noise=noise, gauge_error=gauge_error)
    start = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix=".partial-", dir=_ensure(folder.parent)))
    try:
        names = []
        for t in tests:
            rec, _ = run_test(case, t)
            write_record(rec, tmp)
            names.append(rec.name)
        truth = case.truth()
        truth.update({"records": names, "program": program, "tests": [t.name for t in tests], "noise_on": noise, "gauge_error_on": gauge_error,
                      "generation_s": round(time.perf_counter() - start, 3), "foreign_rig_version": code_version()})
        (tmp / "truth.json").write_text(json.dumps(truth, indent=1, default=str) + "\n")
        if folder.exists():
            if out is None:
                shutil.rmtree(tmp)  # another process generated it meanwhile
                truth = json.loads((folder / "truth.json").read_text())
                return Generated(folder, [folder / r for r in truth["records"]], truth)
            if any(folder.iterdir()):
                raise FileExistsError(f"{folder} was filled while the case was generated")
            folder.rmdir()
        os.replace(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return Generated(folder, [folder / n for n in names], truth)


def _ensure(p: Path) -> Path:
    p.mkdir(parents=True, exist_ok=True)
    return p
