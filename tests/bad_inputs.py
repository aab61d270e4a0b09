"""The bad-input table: input, outcome, message. One list, two uses:
``tests/test_bad_input_table.py`` runs every row, and ``docs/bad-inputs.md``
is generated from it (``python tests/bad_inputs.py > docs/bad-inputs.md``;
a test fails if the document differs from what this prints), so the
document cannot claim a behaviour no test checks.

A row's input is a command line (``hpctl ...``, with the placeholders of
:data:`PLACES` for files it needs) or a Python expression (evaluated with
the names of :data:`NAMES`). Its outcome is an exit code, an exception
class of ``hpctl.errors``, or ``ok``; its message is text the output (the
command's stderr, the exception's message, the result's repr) contains.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Row:
    input: str
    outcome: str  # "exit N", "raises ClassName" or "ok"
    message: str


#: The placeholders command lines use: what each stands for.
PLACES: dict[str, str] = {
    "OUT": "an empty output folder",
    "USER_OUT": "a folder holding a `summary.json` that hpctl did not write",
    "BUSY_OUT": "a folder another hpctl run is writing into (it holds the folder's lock)",
    "FILE": "a regular file (so `FILE/sub` cannot be created)",
    "NEG_TIME": "a rig record, valid except that its `time_s` starts at -0.5 s",
    "MARKUP": "a rig record with `[/x]` in a `force_n` cell (rich markup that used to crash the error printer)",
    "NO_STATIC": "a rig record whose TOML has no `[static]` table",
    "RECORD": "a valid rig record",
    "TORN": "a rig record whose CSV was rewritten after its TOML was (the pair a reader sees between the two renames of a rewrite)",
}

#: The names Python expressions use.
NAMES: dict[str, str] = {
    "hpctl": "the package",
    "_core": "`hpctl._core`, the Rust extension",
    "np": "numpy",
    "math": "the standard library's math",
    "unit": "`hpctl.Unit.seed()`",
    "sdof_rig": "`hpctl.sim.run.sdof_rig`",
    "frame": '`_core.can_encode("HP_CornerMotion_0", 0, {"StrutDisp": 0.01, "BodyAcc": 0.0, "GasTemp": 293.0})`, a J1939 identifier and 8 bytes',
}

ROWS: tuple[Row, ...] = (
    # Command-line options.
    Row("hpctl rig --noise-scale nan --out OUT", "exit 2", "'nan' is not a finite number"),
    Row("hpctl simulate --test sine --amplitude-m inf --out OUT", "exit 2", "'inf' is not a finite number"),
    Row("hpctl simulate --tau-s -1 --out OUT", "exit 2", "tau_s = -1 is outside the valid range [0, 1e9]"),
    Row("hpctl simulate --sweep --threads -1 --out OUT", "exit 2", "-1 is not in the range x>=0"),
    Row("hpctl simulate --sweep --threads 100000 --out OUT", "exit 2", "threads = 100000: expected an integer from 0 (all"),
    Row("hpctl simulate --sweep --sweep-pressure-pa 1e3 --out OUT", "exit 2",
        "every one of the 6 sweep cases failed; the first: static_pressure_pa = 1000 is outside the valid range"),
    # Results a run cannot stand behind: exit 0 with the warning, exit 3 with --strict.
    Row("hpctl simulate --sweep --sweep-pressure-pa 14811300,1e3 --sweep-tau-s 2 --spring hard --damper on --strict --out OUT", "exit 3",
        "warning [case_failed]: sweep case p = 0.001 MPa, tau = 2 s, damper on failed"),
    Row("hpctl simulate --test sine --frequency-hz 50 --spring hard --damper on --strict --out OUT", "exit 3",
        "warning [rated_speed]: char_sine_hard_on: the strut moved at up to 15.7 m/s, beyond the unit's rated 2 m/s"),
    Row("hpctl simulate --dt-s 0.1 --out OUT", "exit 2", "--dt-s does not apply to --test seed"),
    Row("hpctl simulate --test sdof-step --fixed-steps --dt-s 0.1 --duration-s 1 --spring hard --damper on --strict --out OUT", "exit 3",
        "warning [step_replaced]: sdof_step_hard_on: the step asked for, 0.1 s, is longer than the output interval; steps of 0.001 s were taken"),
    Row("hpctl closed-loop --road-class E --speed-m-s 20 --lower-m 0.05 --strict --out OUT", "exit 3",
        "warning [sequencer_blocked]: lowering: the ride-height sequencer was blocked"),
    # Records.
    Row("hpctl fit NEG_TIME --out OUT", "exit 2",
        "record neg_time: the model cannot be simulated on it: time_s = -0.5 is outside the valid range [0, 1e9]"),
    Row("hpctl fit MARKUP --out OUT", "exit 2", "line 3, column 'force_n': '[/x]' is not a number"),
    Row("hpctl fit NO_STATIC --out OUT", "exit 2", "[static]: missing table"),
    Row("hpctl fit TORN --out OUT", "exit 2", "torn.csv: does not match the csv_sha256 in torn.toml"),
    Row("hpctl fit RECORD --profile friction_coulomb_n --out OUT", "exit 2",
        "--profile = 'friction_coulomb_n': expected a parameter the model fits or a quantity derived from them "
        "(tau_s, charge_scale, damper_gain)"),
    Row("hpctl fit RECORD --max-evaluations 0 --out OUT", "exit 2", "Invalid value for '--max-evaluations': 0 is not in the range 1<=x<=100000."),
    # Output folders.
    Row("hpctl simulate --test sdof-step --duration-s 1 --out USER_OUT", "exit 2",
        "would overwrite files hpctl did not write (or that changed since): summary.json; move them away, choose another --out, or pass --force"),
    Row("hpctl simulate --test sdof-step --duration-s 1 --out BUSY_OUT", "exit 2", "is in use by another hpctl run (pid"),
    Row("hpctl simulate --test sdof-step --duration-s 1 --out FILE/sub", "exit 1", "Not a directory"),
    Row("hpctl can decode FILE --out BUSY_OUT", "exit 2", "is in use by another hpctl run (pid"),
    # Data in and out.
    Row("hpctl convert TORN OUT/torn.parquet", "exit 2", "torn.csv: does not match the csv_sha256 in torn.toml"),
    Row("hpctl can decode FILE --out OUT", "exit 2", "python-can cannot read this log: No read support for unknown log format"),
    # The Python API and the bindings.
    Row('_core.can_encode("HP_Driver", 0, {"DriverMode": 1.5, "HeightMode": 0, "RideHeightRequest": 0.0})', "raises ParameterError",
        "values.DriverMode = 1.5: expected a whole number (a flag, an enumeration or a count)"),
    Row('_core.can_encode("HP_Vehicle", 0, {"VehicleSpeed": 10.0, "BrakePressed": 0.7, "LatAcc": 0.0, "LongAcc": 0.0})', "raises ParameterError",
        "values.BrakePressed = 0.7: expected a whole number"),
    Row('_core.can_encode("HP_CornerMotion_0", -1, {"StrutDisp": 0.0, "BodyAcc": 0.0, "GasTemp": 293.0})', "raises ParameterError",
        "counter = -1: expected the alive counter: an integer within [0, 14]"),
    Row("_core.can_decode(-1, bytes(8))", "raises ParameterError", "id = -1: expected an extended identifier (29 bits)"),
    Row('_core.can_decode(0x18FF0147, "abcdefgh")', "raises ParameterError", "data = 'abcdefgh': expected bytes, a bytearray or a memoryview"),
    Row("_core.can_decode(frame[0], bytearray(frame[1]))", "ok", "('HP_CornerMotion_0', 0, {'StrutDisp': 0.01, 'BodyAcc': 0.0, 'GasTemp': 293.0})"),
    Row("_core.can_decode(frame[0], memoryview(frame[1]))", "ok", "('HP_CornerMotion_0', 0, {'StrutDisp': 0.01, 'BodyAcc': 0.0, 'GasTemp': 293.0})"),
    Row('_core.gas_props("bwr-textbook", [-1.0], [300.0])', "raises ParameterError", "rho_kg_m3[0] = -1.0: expected a number within [0, 3000]"),
    Row("hpctl.run(unit, sdof_rig(hpctl.Step(0.04)), np.zeros((2, 2)))", "raises ParameterError",
        "expected a one-dimensional array or sequence of real numbers (got 2-D float64)"),
    Row('hpctl.run_sdof(unit, hpctl.Step(0.04), 1.0, dt_s="x")', "raises ParameterError", "dt_s = 'x': expected a finite real number"),
    Row('hpctl.run_sdof(unit, hpctl.Step(0.04), 1.0, spring_hard="yes")', "raises ParameterError",
        "spring_hard = 'yes': expected a bool or a one-dimensional sequence of bools"),
    Row("hpctl.run_sdof(unit, hpctl.Step(0.04), math.nan)", "raises ParameterError", "duration_s = nan: expected a finite real number"),
    Row('hpctl.run_characterisation(unit, hpctl.Sampled(["a"], [0.0]), 1.0)', "raises ParameterError",
        "Sampled.time_s = ['a']: expected a one-dimensional array or sequence of real numbers"),
    Row("hpctl.run_many([], threads=-1)", "raises ParameterError", "threads = -1: expected an integer from 0 (all"),
    Row('unit.replace(colour="red")', "raises ParameterError", "Unit has no field colour"),
    Row("unit.damper.force_n([math.nan], unit.piston_area_m2, True)", "raises ParameterError", "vel_m_s = [nan]: expected finite strut speeds, m/s"),
    Row("unit.damper.force_n([0.01], -1.0, True)", "raises ParameterError", "piston_area_m2 = -1.0: expected a positive area, m^2"),
    Row('unit.damper.force_n([0.01], unit.piston_area_m2, "yes")', "raises ParameterError", "damper_on = 'yes': expected a bool"),
)


def _outcome_text(outcome: str) -> str:
    kind, _, arg = outcome.partition(" ")
    if kind == "exit":
        meaning = {"1": "the environment failed", "2": "bad input", "3": "warning, with --strict"}[arg]
        return f"exit {arg} ({meaning})"
    if kind == "raises":
        return f"`{arg}` (a `ValueError`)"
    return "accepted"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown() -> str:
    """docs/bad-inputs.md."""
    lines = [
        "# Bad input: what happens",
        "",
        "<!-- Generated by `python tests/bad_inputs.py > docs/bad-inputs.md` from the table that",
        "     tests/test_bad_input_table.py runs row by row; edit the table, not this file. -->",
        "",
        "Every row is a test. Bad input never gives a traceback, a hang, a silently wrong result",
        "or lost data: a command exits with 2 and a message naming what was wrong, the Python API",
        "raises `hpctl.errors.ParameterError` (a `ValueError`) naming the parameter, its value and",
        "what was expected (also as the attributes `parameter`, `value`, `expected`), and a result",
        "the program cannot stand behind is a warning (printed, and listed under `\"warnings\"` in",
        "`summary.json`, `fit.json` or `diagnosis.json`) that `--strict` turns into exit code 3.",
        "Exit codes: 0 ok, 1 internal error or the environment failed (an output that cannot be",
        "written), 2 bad input, 3 warnings with `--strict`, 130 interrupted (Ctrl-C; the previous",
        "outputs are kept).",
        "",
        "Command lines use these placeholders:",
        "",
        *[f"- `{k}`: {v}" for k, v in PLACES.items()],
        "",
        "Python expressions use these names:",
        "",
        *[f"- `{k}`: {v}" for k, v in NAMES.items()],
        "",
        "| input | outcome | message (contains) |",
        "|---|---|---|",
        *[f"| `{_cell(r.input)}` | {_outcome_text(r.outcome)} | `{_cell(r.message)}` |" for r in ROWS],
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown(), end="")
