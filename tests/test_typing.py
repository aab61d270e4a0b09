"""The package type-checks under mypy --strict, and the hand-kept stub of
the extension agrees with the extension (stubtest)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_strict() -> None:
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", str(ROOT / "python" / "hpctl")], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr


def test_stubtest_agrees_with_extension() -> None:
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "hpctl._core"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr


def test_a_users_strict_code_sees_the_public_names(tmp_path: Path) -> None:
    # The package loads its names lazily (PEP 562); a type checker must still
    # see each one as exported (mypy --strict refuses implicit re-exports).
    import hpctl

    user = tmp_path / "user.py"
    user.write_text("import hpctl\n\n" + "".join(f"print(hpctl.{n})\n" for n in hpctl.__all__))
    env = {**os.environ, "MYPYPATH": str(ROOT / "python")}
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(user)], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stdout + r.stderr


def _typed_keys(td: type) -> dict[str, object]:
    """A TypedDict's keys, nested TypedDicts as dicts of theirs, leaves as None."""
    import typing

    out: dict[str, object] = {}
    for name, hint in typing.get_type_hints(td).items():
        out[name] = _typed_keys(hint) if typing.is_typeddict(hint) else None
    return out


def _runtime_keys(d: dict[str, object]) -> dict[str, object]:
    return {k: (_runtime_keys(v) if isinstance(v, dict) else None) for k, v in d.items()}


def test_the_controller_typeddicts_are_what_the_extension_reads_and_returns() -> None:
    # The stub's TypedDicts (hpctl._coretypes) are hand-written from hp_ctrl's
    # structs: key for key, nested blocks too, they are what the bindings use.
    from hpctl import _core, _coretypes
    from hpctl.control.controller import Inputs

    config = _core.ctrl_seed_config()
    assert _typed_keys(_coretypes.ControllerConfigDict) == _runtime_keys(dict(config))
    vehicle = _core.vehicle_presets()["4x4"]
    assert _runtime_keys(dict(_core.vehicle_controller_config(vehicle))) == _runtime_keys(dict(config))
    inputs = Inputs(1.5e7, 1.5e7, 293.15).to_dict()
    assert list(_typed_keys(_coretypes.ControllerInputsDict)) == list(inputs)
    assert set(inputs) == set(_core.CTRL_INPUT_FIELDS)
    outputs = _core.Controller(config).step(inputs, 1e-3)
    assert set(_typed_keys(_coretypes.ControllerOutputsDict)) == set(outputs)
    # The parallel runners' optional keys are the ones hp-py reads as optional.


def test_closed_loop_many_reads_the_case_keys_the_stub_declares() -> None:
    # Required keys: leaving one out is a ParameterError naming it; optional
    # ones (NotRequired in the stub) may be left out.
    import pytest

    from hpctl import _core, _coretypes
    from hpctl.control import closed_loop

    case = closed_loop.Case(closed_loop.Scenario(0.5, 5.0)).core_args()
    optional = _not_required(_coretypes.ClosedLoopCaseDict)
    assert optional == {"config", "max_dt_s", "channels", "record_every", "t_gas_sensor_tau_s"}
    assert set(case) <= set(_typed_keys(_coretypes.ClosedLoopCaseDict))
    minimal = {k: v for k, v in case.items() if k not in optional}
    (result,) = _core.closed_loop_many([minimal])  # type: ignore[list-item]
    assert not isinstance(result, Exception), result
    for key in minimal:
        with pytest.raises(_core.ParameterError, match=f"missing key cases\\[0\\].{key}"):
            _core.closed_loop_many([{k: v for k, v in minimal.items() if k != key}])  # type: ignore[list-item]
    with pytest.raises(_core.ParameterError, match="nonsense"):
        _core.closed_loop_many([{**case, "nonsense": 1}])  # type: ignore[list-item]


def _not_required(td: type) -> set[str]:
    # (The module's postponed annotations hide NotRequired from __optional_keys__.)
    import typing

    hints = typing.get_type_hints(td, include_extras=True)
    return {k for k, h in hints.items() if typing.get_origin(h) is typing.NotRequired}
