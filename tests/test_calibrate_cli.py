"""`hpctl rig`, `hpctl fit`, `hpctl diagnose` and `hpctl demo` from the
command line: outputs checked for sense, exit codes for bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from hpctl import __version__ as hpctl_version
from hpctl.cli import main
from hpctl.data.records import read_record
from hpctl.identify import MAX_NFEV, MAX_NFEV_FLEXIBLE
from hpctl.model.effects import LIBRARY


def hpctl(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(main, list(args))
    return r.exit_code, r.stdout, r.stderr


@pytest.fixture(scope="module")
def leaky_rig(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rig")
    code, _, err = hpctl("rig", "--out", str(out), "--effect", "leakage", "--set", "leak_time_constant_s=40000", "--seed", "3", "--quiet")
    assert code == 0, err
    return out


def test_rig_writes_records_that_do_not_name_their_effects(leaky_rig: Path) -> None:
    names = sorted(p.stem for p in leaky_rig.glob("*.csv"))
    assert names == sorted(["hold", "sine_0.01hz", "sine_0.03hz", "sine_0.1hz", "sine_0.3hz", "sine_1hz"])
    for n in names:
        rec = read_record(leaky_rig / n)
        text = (leaky_rig / f"{n}.toml").read_text() + (leaky_rig / f"{n}.csv").read_text(encoding="utf-8")[:200]
        assert "leak" not in text and rec.kind == "characterisation"
    truth = json.loads((leaky_rig / "truth.json").read_text())
    assert truth["effects"] == ["heat_transfer", "real_gas", "leakage"]
    assert truth["params"]["leak_time_constant_s"] == 40000


def test_diagnose_finds_the_leak_and_reports_it(leaky_rig: Path, tmp_path: Path) -> None:
    code, out, err = hpctl("diagnose", str(leaky_rig), "--model", "seed", "--out", str(tmp_path), "--json", "--quiet")
    assert code == 0, err
    s: dict[str, Any] = json.loads(out)
    assert s["verdict"] == "effects_found"
    (step,) = s["effects"]
    assert step["effect"] == "leakage"
    assert step["params"]["leak_time_constant_s"] == pytest.approx(40000, rel=0.1)
    assert step["rms_ratio_after"] < 1.1 < step["rms_ratio_before"]
    assert s["error_after"]["rms_ratio"] < s["error_before"]["rms_ratio"]
    # Every round's candidates: the leak among the first's with the gain it
    # was accepted on; the round that found the rest at the noise tried
    # nothing, and it is the last.
    (leak,) = [c for c in s["candidates_by_round"][0] if c["effect"] == "leakage"]
    assert leak["delta_bic"] == step["delta_bic"] and leak["stopped_at_null"] is False
    assert len(s["candidates_by_round"]) == 2 and s["candidates_by_round"][1] == s["candidates_last_round"] == []
    report = (tmp_path / "report.md").read_text()
    assert "`leakage`" in report and "Error before and after" in report
    # Who wrote it: the version and the exact command, in the JSON and the report.
    command = f"hpctl diagnose {leaky_rig} --model seed --out {tmp_path} --json --quiet"
    assert s["hpctl"] == {"version": hpctl_version, "command": command}
    assert json.loads((tmp_path / "diagnosis.json").read_text())["hpctl"]["command"] == command
    assert f"Written by hpctl {hpctl_version}: `{command}`" in report.splitlines()[:4]
    for line in report.splitlines():
        if line.startswith("!["):
            assert (tmp_path / line.split("(")[1].rstrip(")")).exists()


def test_fit_prints_parameters_with_uncertainty(leaky_rig: Path, tmp_path: Path) -> None:
    code, out, err = hpctl("fit", *(str(p) for p in sorted(leaky_rig.glob("*.toml"))), "--model", "seed,leakage", "--out", str(tmp_path), "--json", "--quiet")
    assert code == 0, err
    s = json.loads(out)
    assert s["model"] == ["heat_transfer", "real_gas", "leakage"]
    assert s["params"]["leak_time_constant_s"] == pytest.approx(40000, rel=0.1)
    assert 0 < s["stderr"]["leak_time_constant_s"] < 4000
    assert (tmp_path / "fit.md").exists() and (tmp_path / "fit_hold.png").exists()
    assert s["hpctl"]["version"] == hpctl_version and s["hpctl"]["command"].startswith("hpctl fit ") and "--model seed,leakage" in s["hpctl"]["command"]
    assert s["hpctl"]["command"] in (tmp_path / "fit.md").read_text()


def test_a_fit_that_runs_out_of_evaluations_says_so_and_how_to_go_on(leaky_rig: Path, tmp_path: Path) -> None:
    # One evaluation cannot converge: the fit is still written, with a
    # not_converged warning naming the budget; --strict makes it exit 3.
    recs = [str(p) for p in sorted(leaky_rig.glob("*.toml"))]
    code, out, err = hpctl("fit", *recs, "--model", "seed,leakage", "--max-evaluations", "1", "--out", str(tmp_path / "a"), "--json", "--quiet")
    assert code == 0, err
    s = json.loads(out)
    warned = [w for w in s["warnings"] if w["code"] == "not_converged"]
    assert s["converged"] is False and len(warned) == 1, s["warnings"]
    assert "--max-evaluations above 1" in warned[0]["message"] and warned[0]["details"]["max_evaluations"] == 1, warned
    code, _, err = hpctl("fit", *recs, "--model", "seed,leakage", "--max-evaluations", "1", "--out", str(tmp_path / "b"), "--strict", "--quiet")
    assert code == 3 and "not_converged" in err, err


@pytest.mark.parametrize(("args", "budget"), [((), MAX_NFEV), (("--flexible",), MAX_NFEV_FLEXIBLE), (("--flexible", "--max-evaluations", "7"), 7)])
def test_a_flexible_fit_gets_the_larger_budget_unless_one_is_given(leaky_rig: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                   args: tuple[str, ...], budget: int) -> None:
    # The budget the command hands the optimiser (the fit itself then runs
    # on one evaluation: what is checked is the choice, not the fit).
    import hpctl.identify.fit as fit_module

    asked: list[int] = []
    real = fit_module.fit

    def spy(*a: Any, max_nfev: int, **kw: Any) -> Any:
        asked.append(max_nfev)
        return real(*a, max_nfev=1, **kw)

    monkeypatch.setattr(fit_module, "fit", spy)
    code, out, err = hpctl("fit", str(leaky_rig / "hold.toml"), "--model", "seed,leakage", *args, "--out", str(tmp_path / "o"), "--json", "--quiet")
    assert code == 0, err
    assert asked == [budget]
    warned = [w for w in json.loads(out)["warnings"] if w["code"] == "not_converged"]
    assert warned and warned[0]["details"]["max_evaluations"] == budget


def test_list_effects_names_the_library() -> None:
    code, out, _ = hpctl("diagnose", "--list-effects", "--json")
    assert code == 0 and set(json.loads(out)) == set(LIBRARY)
    code, out, _ = hpctl("diagnose", "--list-effects")
    assert all(name in out for name in LIBRARY)


def test_demo_tells_the_whole_story(tmp_path: Path) -> None:
    code, out, err = hpctl("demo", "--out", str(tmp_path), "--json", "--quiet")
    assert code == 0, err
    s = json.loads(out)
    assert [e["effect"] for e in s["effects"]] == ["heat_transfer", "real_gas", "friction"]
    before = [e["rms_ratio_before"] for e in s["effects"]]
    assert before == sorted(before, reverse=True) and s["error_after"]["rms_ratio"] < 1.1
    assert s["final_params"]["friction_coulomb_n"] == pytest.approx(350, rel=0.1)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["diagnose", "--model", "seed,magic"], "unknown effect 'magic'"),
        (["diagnose"], "give at least one rig record"),
        (["rig", "--set", "warp_factor=9"], "expected PARAM=VALUE"),
        (["rig", "--set", "leak_time_constant_s=fast"], "is not a number"),
        (["fit", "--max-evaluations", "0"], "0 is not in the range 1<=x<=100000"),
        (["fit", "--max-evaluations", "2.5"], "'2.5' is not a valid integer"),
    ],
)
def test_bad_input_exits_2(tmp_path: Path, args: list[str], message: str) -> None:
    code, out, err = hpctl(*args, "--out", str(tmp_path / "o"))
    assert code == 2 and message in (err + out)


def test_malformed_record_exits_2_naming_the_file(leaky_rig: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad"
    bad.mkdir()
    for suffix in (".csv", ".toml"):
        (bad / f"hold{suffix}").write_text((leaky_rig / f"hold{suffix}").read_text())
    (bad / "hold.toml").write_text((bad / "hold.toml").read_text().replace("pressure_pa", "pressure_bar"))
    code, _, err = hpctl("fit", str(bad / "hold"), "--out", str(tmp_path / "o"))
    assert code == 2 and "hold.toml" in err and "pressure_bar" in err
