"""Command-line calibration: ``hpctl fit``, ``hpctl diagnose``, ``hpctl rig``
and ``hpctl demo``."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np
from rich.text import Text

from hpctl.caveats import Caveat, Code
from hpctl.cli._ui import FiniteFloat, Reporter, errors, finish, force_option, output_dir, status, strict_option, table, with_warnings
from hpctl.data import DEMO_DIR
from hpctl.data.output import reading
from hpctl.data.records import RigRecord, read_record, record_paths, write_record
from hpctl.errors import HpctlError, ParameterError, bad_argument
from hpctl.identify import MAX_NFEV, MAX_NFEV_FLEXIBLE, MAX_NFEV_LIMIT, virtual_rig
from hpctl.model.effects import LIBRARY, MODELS, parse_model
from hpctl.sim import checks

# SciPy (the fit) and matplotlib (the reports) are imported by the
# commands that use them, not at start-up: `hpctl --help` stays fast.
if TYPE_CHECKING:
    from hpctl.identify import diagnose
    from hpctl.identify.fit import AtBound, FitResult
    from hpctl.identify.profile import ProfileInterval, Restart
    from hpctl.identify.workers import WorkerPool


def _records(paths: tuple[Path, ...]) -> list[RigRecord]:
    """The records named (a folder stands for the records in it), read
    while no hpctl run writes into their folders."""
    if not paths:
        raise click.UsageError("give at least one rig record (NAME, NAME.csv or NAME.toml)")
    folders = sorted({p if p.is_dir() else p.parent for p in paths})
    with contextlib.ExitStack() as stack:
        for folder in folders:
            stack.enter_context(reading(folder))
        for folder in (p for p in paths if p.is_dir()):
            if not any(folder.glob("*.toml")):
                raise click.UsageError(f"no rig records (NAME.csv with NAME.toml) in {folder}")
        recs = [read_record(p) for p in _expand(paths)]
    names = [r.name for r in recs]
    if len(set(names)) != len(names):
        raise ParameterError(f"records given twice: {sorted({n for n in names if names.count(n) > 1})}")
    return recs


def _expand(paths: tuple[Path, ...]) -> tuple[Path, ...]:
    """Folders stand for the records in them (those with a TOML: a CSV
    alone is not a record)."""
    out: list[Path] = []
    for p in paths:
        if p.is_dir():
            out += sorted(record_paths(c)[0] for c in p.glob("*.toml"))
        else:
            out.append(p)
    return tuple(out)


def _record_caveats(recs: Sequence[RigRecord], gas: str) -> list[Caveat]:
    """Measured gas states outside the range the model's gas was validated on."""
    return [c for r in recs for c in checks.eos_range(gas, r.data, f"record {r.name}")]


def _fit_caveats(result: FitResult, budget: int, profiled: Sequence[str] = ()) -> list[Caveat]:
    """A fit that did not converge, or left more than noise."""
    from hpctl.identify import diagnose

    out = []
    if not result.success:
        # scipy's message when the budget ran out.
        more = (f" (--max-evaluations above {budget} lets it go on)"
                if "maximum number of function evaluations" in result.message else "")
        out.append(Caveat(Code.NOT_CONVERGED, f"the optimiser stopped without converging: {result.message}{more}",
                          {"message": result.message, "max_evaluations": budget}))
    out += _bound_caveats(result) + _confounded_caveats(result, profiled) + _no_flow_caveats(result) + _profile_band_caveats(result, profiled)
    out += _place_caveats(result)
    out += _noise_caveats(result)
    analysis = diagnose.analyse(result)
    if analysis.structured:
        worst = [r for r in analysis.rows if r.structured]
        where = ", ".join(f"{r.record}/{r.channel}" for r in worst[:6]) + (" ..." if len(worst) > 6 else "")
        out.append(Caveat(
            Code.RESIDUAL_STRUCTURED,
            f"the residual is more than noise (RMS / noise {result.rms_ratio:.3g}; structured in {where or 'the pooled residual'}): "
            "the model misses something (hpctl diagnose looks for what)",
            {"rms_ratio": result.rms_ratio, "structured": [f"{r.record}/{r.channel}" for r in worst]},
        ))
    return out


def _noise_caveats(result: FitResult) -> list[Caveat]:
    """Channels judged against a noise level that may hold signal
    (:attr:`hpctl.identify.dataset.Dataset.noise_unchecked`), each with the
    residual's own RMS beside its level: a residual below the level says
    the level is too high by at least their ratio (a residual holds the
    noise at least), unless the model fits the noise itself."""
    rows = [(d.name, c, d.sigma[c], float(np.sqrt(np.nanmean(result.residuals(i, c) ** 2))))
            for i, d in enumerate(result.datasets) for c in d.noise_unchecked]
    if not rows:
        return []
    where = "; ".join(f"{r}/{c}: {level:.4g} (the residual's RMS {rms:.4g})" for r, c, level, rms in rows)
    return [Caveat(
        Code.NOISE_UNCHECKED,
        f"noise levels read from differences that may still hold the signal (no order of differences held noise only, and no other "
        f"record of the channel had a level that did): {where}. A level too high makes RMS / noise too small: for these channels the "
        "judgement against the noise is lenient by up to the level over the true noise (records of the channel sampled faster, or "
        "a stretch at rest, give a level that can be checked)",
        {"channels": [f"{r}/{c}" for r, c, _, _ in rows], "noise": [level for _, _, level, _ in rows],
         "residual_rms": [rms for _, _, _, rms in rows]},
    )]


def _profile_caveats(profiles: Sequence[ProfileInterval]) -> list[Caveat]:
    """A profile that found a lower cost than the fit's optimum, a point the
    model could not be run at, a point whose fit stopped short, or a side
    the records did not bound."""
    out = []
    for iv in profiles:
        out += [Caveat(Code.CASE_FAILED, f"profile of {iv.name}: {f}", {"param": iv.name}) for f in iv.failed]
        for side, direction, why in (("lower", -1.0, iv.lower_open), ("upper", 1.0, iv.upper_open)):
            if why not in ("range_end", "not_reached") or (last := iv.farthest(direction)) is None:
                continue
            out.append(Caveat(
                Code.PROFILE_OPEN,
                f"profile of {iv.name}: the records do not bound it on its {side} side within the values searched "
                f"{iv.limit_text(direction)}, where the {iv.sigmas:g}-sigma limit needs a rise of {iv.sigmas**2:g} (the estimate "
                f"{iv.estimate:.6g}): the interval is open there",
                {"param": iv.name, "side": side, "reason": why, "value": last.value, "rise": last.rise},
            ))
        if bad := iv.unconverged:
            out.append(Caveat(
                Code.NOT_CONVERGED,
                f"profile of {iv.name}: {len(bad)} of {len(iv.points)} fits stopped at their evaluation limit "
                f"(at {', '.join(f'{q.value:.6g}' for q in bad)}): their cost rises may be too high and the interval too narrow",
                {"param": iv.name, "values": [q.value for q in bad]},
            ))
        if (b := iv.better_found) is not None:
            out.append(Caveat(
                Code.NOT_CONVERGED,
                f"the profile of {iv.name} found a cost {-b.rise:.3g} lower at {b.value:.6g} than at the fit's estimate "
                f"{iv.estimate:.6g}: the estimate is not the cost's minimum (the fit stopped short, or its input-noise bias "
                f"correction moved it further), and its values and errors are not the minimum's",
                {"param": iv.name, "value": b.value, "rise": b.rise},
            ))
    return out


def _profiles(rep: Reporter, fitted: FitResult, names: Sequence[str], again: str = "") -> tuple[list[ProfileInterval], list[Caveat]]:
    """The profile intervals of ``names``, and a warning for each that could
    not be had (a fit whose error for it is not finite gives no first
    step): the fit is reported either way, never lost to its profile."""
    from hpctl.identify.profile import profile_interval

    out, failed = [], []
    for name in names:
        with status(rep, f"profile of {name}{again}"):
            try:
                out.append(profile_interval(fitted, name))
            except HpctlError as e:
                failed.append(Caveat(Code.CASE_FAILED, f"the profile of {name} could not be had: {e}", {"param": name}))
    return out, failed


def _restart_caveat(restart: Restart) -> Caveat:
    """A fit started again from a profile point below its estimate
    (:func:`hpctl.identify.profile.refit_from_better`): what is reported is
    the fit from there; the first had stopped in a side valley, which a fit
    without profiles would not have seen."""
    p = restart.start
    return Caveat(
        Code.NOT_CONVERGED,
        f"the fit had stopped in a side valley of its cost: the profile of {restart.name} found the cost {-p.rise:.3g} lower at "
        f"{p.value:.6g}, and the fit started again from there ended {restart.before - restart.after:.3g} lower (cost "
        f"{restart.before:.6g} -> {restart.after:.6g}); these values, errors and profiles are that fit's. The cost has more than "
        "one valley here: a fit without --profile may stop in another",
        {"param": restart.name, "value": p.value, "rise": p.rise, "cost_before": restart.before, "cost_after": restart.after},
    )


def _bound_caveats(result: FitResult) -> list[Caveat]:
    """A fitted parameter on (or within two standard errors of) a bound of
    its fit range."""
    near = result.at_bounds()
    if not near:
        return []
    by_name: dict[str, list[AtBound]] = {}
    for b in near:
        by_name.setdefault(b.name, []).append(b)
    # One phrase a parameter: one whose two-error band reaches both bounds
    # is said once, as what it is (the data do not pin it within its
    # range), not as near one bound and near the other.
    phrases = [_bound_phrase(bs) for bs in by_name.values()]
    said = "; ".join(phrases[:6]) + (f"; {len(phrases) - 6} more in the details" if len(phrases) > 6 else "")
    return [Caveat(
        Code.PARAM_AT_BOUND,
        f"fitted parameters at the edge of their range ({said}): the data ask for values the model's range may not hold, "
        "or do not pin them within it, and these standard errors do not describe an estimate cut off by a bound",
        {"params": [b.name for b in near], "values": [b.value for b in near], "stderr": [b.stderr for b in near],
         "bounds": [b.bound for b in near]},
    )]


def _bound_phrase(bounds: Sequence[AtBound]) -> str:
    """One parameter's :class:`AtBound` entries (one per bound it is on or
    near) in words."""
    b = bounds[0]
    head = f"{b.name} = {b.value:.4g} +- {b.stderr:.2g}"
    if len(bounds) == 1:
        return f"{head} {'on' if b.on else 'near'} its {b.side} bound {b.bound:g}"
    lower, upper = sorted(bounds, key=lambda x: x.side != "lower")
    if on := [x for x in bounds if x.on]:
        other = upper if on[0] is lower else lower
        return f"{head} on its {on[0].side} bound {on[0].bound:g}, two errors reaching its {other.side} bound {other.bound:g}"
    return f"{head}, two errors spanning its whole range [{lower.bound:g}, {upper.bound:g}]"


def _place_caveats(result: FitResult) -> list[Caveat]:
    """Logged valve switches whose places are not at their joint optimum
    with the parameters: the fit's joint steps (``fit._joint_places``) ran
    out, or their last one was refused, while one more Gauss-Newton step
    would still move a place by more than :data:`fit.PLACE_SETTLED` of its
    interval. The parameters and their errors are then those of places a
    step away from the optimum (on the foreign valve-lag draw that showed
    it, the valve's time constant 13 % short)."""
    from hpctl.identify.fit import PLACE_SETTLED

    step, worst = result.place_step, result.place_step_max
    if step is None or worst is None or not worst > PLACE_SETTLED:
        return []
    records = [d.record.name for d in result.datasets for _ in range(d.switch_leads.size)]
    moved = [i for i, s in enumerate(step) if abs(float(s)) > PLACE_SETTLED]
    where = sorted({records[i] for i in moved})
    return [Caveat(
        Code.NOT_CONVERGED,
        f"the valve switches' places are not at their optimum with the parameters: one more joint step would move "
        f"{len(moved)} of {step.size} by up to {worst:.2f} of their sample intervals (in {', '.join(where)}); "
        "the fitted values and their errors are those of places short of the optimum",
        {"place_step_max": worst, "moved": len(moved), "switches": int(step.size), "records": where},
    )]


def _profile_band_caveats(result: FitResult, profiled: Sequence[str] = ()) -> list[Caveat]:
    """Fitted parameters whose standard errors are known to understate
    what the records leave open (:attr:`hpctl.model.effects.Param.profile_band`),
    unless their profile was asked for."""
    bent = [p for p in result.model.params if p.profile_band is not None and p.name not in profiled and p.name in result.stderr]
    return [Caveat(
        Code.PROFILE_BAND,
        f"{p.name} = {result.values[p.name]:.5g} +- {result.stderr[p.name]:.2g}: this standard error can understate what the "
        f"records leave open ({p.profile_band}); its profile interval is the honest band: hpctl fit ... --profile {p.name}",
        {"param": p.name, "value": result.values[p.name], "stderr": result.stderr[p.name]},
    ) for p in bent]


def _no_flow_caveats(result: FitResult) -> list[Caveat]:
    """An identified damper characteristic that makes a force at no flow
    (:func:`hpctl.identify.no_flow.force_at_no_flow`): seal friction, or
    what stands in for it, inside the damper. Said where the residual is at
    the noise, where nothing else would: a model that misses more (a bump
    stop outside the library bent the foreign rig's fitted damper to 1,586 N
    at 2 mm/s at 148 x the noise) has its `residual_structured` warning, and
    its step need not be friction."""
    from hpctl.identify.diagnose import NOISE_CEILING
    from hpctl.identify.no_flow import NO_FLOW_SPEED_M_S, force_at_no_flow

    found = force_at_no_flow(result) if result.rms_ratio <= NOISE_CEILING else []
    if not found:
        return []
    where = ", ".join(f.describe() for f in found)
    return [Caveat(
        Code.DAMPER_FORCE_AT_NO_FLOW,
        f"the fitted damper makes a force at no flow, {where} at {1e3 * NO_FLOW_SPEED_M_S:g} mm/s, more than "
        f"{found[0].noise_n:.3g} N of force noise explains: a hydraulic damper does not; seal friction does, in both directions (a "
        "load cell's offset looks like one in one), and these records do not tell it from the damper; with friction in the model "
        "(--model ...,friction) the two are split by the shapes the model assumes",
        {"branches": [f.branch for f in found], "force_n": [f.force_n for f in found], "template_n": [f.template_n for f in found],
         "speed_m_s": NO_FLOW_SPEED_M_S, "noise_n": found[0].noise_n},
    )]


def _confounded_caveats(result: FitResult, profiled: Sequence[str] = ()) -> list[Caveat]:
    """Factors of a derived quantity (:data:`hpctl.model.effects.DERIVED`)
    whose own errors are not to be trusted
    (:attr:`hpctl.identify.derived.DerivedValue.confounded`); where the
    derived quantity's profile was not asked for, the command that asks."""
    from hpctl.identify.derived import derived

    out = []
    for d in derived(result):
        if not d.confounded:
            continue
        a, b = d.factors[0], d.factors[1]
        ask = "" if d.name in profiled else (
            f"; its profile interval (hpctl fit ... --profile {d.name}) follows the cost where the valley bends: on slow sines alone "
            "it held the truth in 19 of 24 foreign fits (8 draws, 3 noise draws each), the estimate +- 2 errors in 13 (stop 68)")
        out.append(Caveat(
            Code.CONFOUNDED,
            f"{a} and {b} are told apart only by the shapes the model assumes ({d.reason}): their own values can be off by more "
            f"than their standard errors; what the records determine best is their product, {d.name} = {d.value:.5g} +- {d.stderr:.2g}, "
            "though its error too rests on the damper's shapes and priors (on the foreign rig it read 3-5 % low, one to three errors, on "
            f"small frictions over a five-sine sweep, and up to 15 % low, 4.5 errors, on slow sines alone: docs/foreign-rig.md, stop 67){ask}",
            {"params": list(d.factors), "correlation": d.factor_correlation, "damper_shape": d.damper_shape, "derived": d.name,
             "value": d.value, "stderr": d.stderr},
        ))
    return out


@contextlib.contextmanager
def _worker_pool(flexible: bool) -> Iterator[WorkerPool | None]:
    """For a flexible run: worker processes for its static damper fits
    (:func:`hpctl.identify.damper_start.prefetch_static`) and then the
    report's figures (:func:`hpctl.report.calibration.draw_record_plots`),
    started now beside this process's reading of the records, the static
    fit's code imported at once and the figures' once a worker is idle
    (:func:`hpctl.identify.workers.static_pool`); shut down on leaving
    (what is queued dropped). None otherwise. Entered before the command
    imports SciPy and hpctl's identification, which leave a core idle for
    the workers' own imports."""
    if not flexible:
        yield None
        return
    from hpctl.identify.workers import static_pool

    pool = static_pool(later=("hpctl.report.figures",))
    try:
        yield pool
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _model_gas(result: FitResult) -> str:
    return result.model.unit_for(result.datasets[0], result.values).gas


def _print_fit(rep: Reporter, result: FitResult) -> None:
    t = table(f"Fitted parameters ({', '.join(result.model.effects) or 'classical polytropic ideal gas'})", ("parameter", "value", "standard error"))
    for p in result.model.params:
        t.add_row(p.name, f"{result.values[p.name]:.5g}", f"{result.stderr.get(p.name, float('nan')):.2g}")
    from hpctl.identify.derived import derived

    for d in derived(result):
        t.add_row(f"{d.name} (derived)", f"{d.value:.5g}", f"{d.stderr:.2g}")
    rep.out.print(t)
    t = table(f"Residual per record and channel (RMS / noise overall {result.rms_ratio:.3f})",
              ("record", "channel", "noise", "RMS", "NRMS", "max", "loop area err [J]"))
    for s in result.stats:
        loop = "-" if s.loop_area_error_j is None else f"{s.loop_area_error_j:.2f}"
        # Record names come from file names: text, never markup.
        t.add_row(Text(s.record), s.channel, f"{s.noise:.3g}", f"{s.rms:.3g}", f"{s.nrms:.2e}", f"{s.max_abs:.3g}", loop)
    rep.out.print(t)


MODEL_HELP = f"Model: {', '.join(MODELS)}, or effects separated by commas (from: {', '.join(LIBRARY)})."

@click.command("fit")
@click.argument("records", nargs=-1, type=click.Path(path_type=Path))
@click.option("--model", "model", default="seed", show_default=True, help=MODEL_HELP)
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-fit"), show_default=True)
@force_option
@strict_option
@click.option("--flexible", is_flag=True,
              help="Identify the damper characteristic (per valve state and direction) instead of one gain on the assumed curve, "
                   "and the friction's smoothing and Stribeck term; regularised toward the nominal values.")
@click.option("--quiet", "-q", is_flag=True)
@click.option("--profile", "profiled", multiple=True, metavar="PARAM",
              help="Also a 2-sigma profile-likelihood interval of this fitted parameter or derived quantity (repeatable; "
                   "friction_breakaway_n with --flexible and friction): it is held on either side, the others fitted again; a fit per point; "
                   "where one finds the cost lower than at the estimate, the fit starts again from there.")
@click.option("--max-evaluations", "max_evaluations", type=click.IntRange(1, MAX_NFEV_LIMIT), default=None,
              help=f"The optimiser's budget of cost evaluations [default: {MAX_NFEV}, {MAX_NFEV_FLEXIBLE} with --flexible]; "
                   "a fit that stops on it is a warning (not converged).")
@click.option("--json", "as_json", is_flag=True, help="Print parameters and residuals as JSON.")
def fit_cmd(records: tuple[Path, ...], model: str, out_dir: Path, force: bool, strict: bool, flexible: bool, profiled: tuple[str, ...],
            max_evaluations: int | None, quiet: bool, as_json: bool) -> None:
    """Fit the model's free parameters to one or more rig records (a
    folder stands for the records in it), with uncertainties and the
    residual per record and channel; writes fit.md, fit.json and plots.
    A record the model cannot be simulated on is an error; a fit that did
    not converge or left more than noise is a warning."""
    rep = Reporter(quiet, as_json)
    # The flexible model's static damper start, its three starts side by
    # side (1.2 s each in this process alone on the bundled campaign), and
    # the figures after; the workers started first.
    with errors(rep), _worker_pool(flexible) as workers:
        from hpctl.identify.damper_start import prefetch_static
        from hpctl.identify.dataset import carry_input_noise, measured_datasets
        from hpctl.identify.fit import at_own_noise, fit, model_for
        from hpctl.identify.profile import profiled_names, refit_from_better

        effects = parse_model(model)
        budget = max_evaluations or (MAX_NFEV_FLEXIBLE if flexible else MAX_NFEV)
        recs = _records(records)
        measured = measured_datasets(recs)
        # Named wrong, said before the fit, not after it.
        fitted_model = model_for(measured, effects, flexible=flexible)
        names = profiled_names(fitted_model)
        for name in profiled:
            if name not in names:
                raise bad_argument("--profile", name, f"a parameter the model fits or a quantity derived from them ({', '.join(names)})")
        if workers is not None:
            # Begun before the input's noise is carried into the
            # weights, which it does not read (measured_datasets says why);
            # the fit takes back what the workers have not begun when it
            # asks (this process then has nothing else to do).
            prefetch_static(measured, fitted_model.params, fitted_model.effects, workers, take_back=True)
        # What the fit does not need, imported once the workers have their
        # starts (matplotlib's pyplot behind the report: 0.3 s of one core
        # while the workers' were idle).
        from hpctl.report import calibration as report

        datasets = carry_input_noise(measured)
        with output_dir(out_dir, "fit", force=force, protect=("fit.json", "fit.md")) as out:
            with status(rep, f"fitting the {'flexible ' if flexible else ''}model to {len(datasets)} record(s)"):
                # Reported and judged in its own model's weights (the
                # input's noise carried through it, not the template's).
                fitted = fit(datasets, effects, flexible=flexible, max_nfev=budget)
                result = at_own_noise(fitted)
            # In the fit's own weights, where its estimate is the optimum
            # (the report's are the fitted model's, above).
            profiles, unprofiled = _profiles(rep, fitted, profiled)
            restarted: list[Caveat] = []
            if any(iv.better_found is not None for iv in profiles):
                with status(rep, "fitting again from a profile's point below the estimate"):
                    try:
                        restart = refit_from_better(fitted, profiles, budget)
                    except HpctlError as e:
                        # A second opinion: its failure never costs the first fit.
                        restart = None
                        restarted = [Caveat(Code.CASE_FAILED, f"the fit again from a profile's point below the estimate failed ({e}): "
                                            "the first fit is reported, off its cost's minimum (the profile's warning says where)")]
                if restart is not None:
                    # The estimate was a side valley's: everything from the
                    # fit from there, its profiles again (once: a profile of
                    # that fit finding lower still is its warning).
                    fitted = restart.result
                    result = at_own_noise(fitted)
                    profiles, unprofiled = _profiles(rep, fitted, profiled, " again")
                    restarted = [_restart_caveat(restart)]
            caveats = (_record_caveats(recs, _model_gas(result)) + _fit_caveats(result, budget, profiled) + restarted
                       + _profile_caveats(profiles) + unprofiled)
            report.fit_report(result, out, caveats, profiles, workers)
            document = with_warnings(report.fit_summary(result, profiles), caveats)
            out.write_json("fit.json", document)
        if as_json:
            click.echo(json.dumps(document, indent=2))
        else:
            _print_fit(rep, result)
            for iv in profiles:
                rep.say(iv.describe())
            rep.say(f"Wrote fit.md, fit.json and plots to {out_dir}/")
        finish(rep, caveats, strict)


@click.command("diagnose")
@click.argument("records", nargs=-1, type=click.Path(path_type=Path))
@click.option("--model", "model", default="classical", show_default=True, help="Declared starting model. " + MODEL_HELP)
@click.option("--list-effects", is_flag=True, help="List the effect library and exit.")
@click.option("--max-rounds", type=click.IntRange(1, 20), default=6, show_default=True)
@click.option("--flexible", is_flag=True,
              help="Every fit identifies the damper characteristic, the heat-transfer law and the friction's shape (as fit --flexible) "
                   "instead of one gain on the assumed curve: for hardware whose damper is not the assumed one; 4-10x slower.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-diagnosis"), show_default=True)
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print the conclusion as JSON.")
def diagnose_cmd(records: tuple[Path, ...], model: str, list_effects: bool, max_rounds: int, flexible: bool, out_dir: Path, force: bool,
                 strict: bool, quiet: bool, as_json: bool) -> None:
    """Find what the declared model lacks: fit it, analyse the residual,
    try each effect of the library, keep what the evidence supports,
    repeat; writes report.md (with plots) and diagnosis.json."""
    rep = Reporter(quiet, as_json)
    if list_effects:
        if as_json:
            click.echo(json.dumps({n: e.to_json() for n, e in LIBRARY.items()}, indent=2))
        else:
            for n, e in LIBRARY.items():
                click.echo(f"{n:16} {e.description} [{', '.join(p.name for p in e.params) or 'no parameters'}]")
        return
    with errors(rep):
        effects = parse_model(model)
        _run_diagnosis(rep, _records(records), effects, max_rounds, out_dir, as_json, "diagnose", force, strict, flexible)

@click.command("rig")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-rig"), show_default=True)
@click.option("--program", type=click.Choice(list(virtual_rig.PROGRAMS)), default="sweep", show_default=True,
              help="sweep: sines 0.01-1 Hz; full: plus a fast damper-on sine, valve switching, a long hold, a heat run and an SDOF step.")
@click.option("--effect", "effects", multiple=True, type=click.Choice([e for e in LIBRARY if e not in ("heat_transfer", "real_gas")]),
              help="Effect present in the rig's unit (repeatable); real gas and heat transfer always are.")
@click.option("--set", "sets", multiple=True, metavar="PARAM=VALUE", help="Effect parameter value, SI (repeatable).")
@click.option("--random", "random_values", is_flag=True, help="Draw effect parameters at random (see --seed).")
@click.option("--seed", type=click.IntRange(0, 2**63 - 1), default=0, show_default=True, help="Seed of the noise and of --random.")
@click.option("--noise-scale", type=FiniteFloat(0.0, 100.0), default=1.0, show_default=True, help="Noise relative to the rig's standard noise, 0-100.")
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True)
def rig_cmd(out_dir: Path, program: str, effects: tuple[str, ...], sets: tuple[str, ...], random_values: bool, seed: int, noise_scale: float,
            force: bool, strict: bool, quiet: bool) -> None:
    """A virtual test rig: write rig records from a unit with the chosen
    effects and noise on every channel. The records do not say which
    effects they contain; truth.json beside them does."""
    rep = Reporter(quiet, False)
    with errors(rep):
        overrides = _parse_sets(sets)
        rng = np.random.default_rng(seed)
        values = virtual_rig.effect_values(effects, rng if random_values else None, overrides)
        unit = virtual_rig.truth_unit(effects, values)
        tests = virtual_rig.tests_for(effects, program)
        with output_dir(out_dir, "rig", force=force, protect=("truth.json",)) as out:
            recs = virtual_rig.make_records(unit, tests=tests, noise=virtual_rig.Noise().scaled(noise_scale), seed=seed)
            caveats = [c for r in recs for c in checks.channels(unit, r.data, f"record {r.name}")]
            for r in recs:
                write_record(r, out.path(r.name))
            truth = {"effects": ["heat_transfer", "real_gas", *effects], "params": {"tau_s": unit.tau_s, **values}, "seed": seed,
                     "noise": vars(virtual_rig.Noise().scaled(noise_scale))}
            out.write_json("truth.json", with_warnings(truth, caveats))
        rep.say(f"Wrote {len(recs)} records and truth.json to {out_dir}/")
        finish(rep, caveats, strict)

@click.command("demo")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-demo"), show_default=True)
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True)
def demo_cmd(out_dir: Path, force: bool, strict: bool, quiet: bool, as_json: bool) -> None:
    """The whole story on bundled rig data: start from the classical
    polytropic ideal-gas model, find heat transfer, then real gas, then
    whatever else is hidden, and print the errors before and after."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        recs = [read_record(p) for p in sorted(DEMO_DIR.glob("*.toml"))]
        rep.note(f"{len(recs)} bundled records from a rig unit with undeclared effects; declared model: classical polytropic ideal gas")
        rep.note("(each step fits the model with the Rust simulator in the loop; about 15 s in all)")
        _run_diagnosis(rep, recs, (), 6, out_dir, as_json, "demo", force, strict)


def _parse_sets(sets: tuple[str, ...]) -> dict[str, float]:
    known = {p.name for e in LIBRARY.values() for p in e.params}
    out = {}
    for s in sets:
        name, sep, value = s.partition("=")
        if not sep or name not in known:
            raise ParameterError(f"--set {s!r}: expected PARAM=VALUE with PARAM one of {', '.join(sorted(known))}")
        try:
            out[name] = float(value)
        except ValueError:
            raise ParameterError(f"--set {s!r}: {value!r} is not a number") from None
    return out


def _run_diagnosis(rep: Reporter, recs: list[RigRecord], start: tuple[str, ...], max_rounds: int, out_dir: Path, as_json: bool,
                   command: str, force: bool, strict: bool, flexible: bool = False) -> None:
    # The flexible model's static damper fits' worker processes, started
    # before the imports below (_worker_pool says why) and kept for the
    # report's figures after (hpctl.report.calibration.draw_record_plots).
    with _worker_pool(flexible) as statics:
        from hpctl.identify import diagnose
        from hpctl.report import calibration as report

        with output_dir(out_dir, command, force=force, protect=("diagnosis.json", "report.md")) as out:
            with status(rep, "diagnosing") as spinner:
                diag = diagnose.diagnose(recs, start, max_rounds=max_rounds, progress=spinner.update, flexible=flexible, statics=statics)
            caveats = _record_caveats(recs, _model_gas(diag.final)) + _diagnosis_caveats(diag)
            path = report.diagnosis_report(diag, out, caveats, workers=statics)
            document = with_warnings(diagnose.summary(diag), caveats)
            out.write_json("diagnosis.json", document)
    if as_json:
        click.echo(json.dumps(document, indent=2))
    else:
        _print_diagnosis(rep, diag, path)
    finish(rep, caveats, strict)


def _diagnosis_caveats(diag: diagnose.Diagnosis) -> list[Caveat]:
    from hpctl.identify.diagnose import NOISE_CEILING

    out = []
    if not diag.final.success:
        out.append(Caveat(Code.NOT_CONVERGED, f"the final fit stopped without converging: {diag.final.message}",
                          {"message": diag.final.message, "fit": "final"}))
    if diag.initial is not diag.final and not diag.initial.success:
        # The declared model is the first round's baseline and the "before"
        # of the error table: stopped short, it makes every gain from it
        # look larger by what its fit had left.
        out.append(Caveat(
            Code.NOT_CONVERGED,
            f"the declared model's fit stopped without converging ({diag.initial.message}): its errors (\"before\") are where it "
            "stopped, no lower than at its optimum, and the gains from it may be that much smaller",
            {"message": diag.initial.message, "fit": "declared"},
        ))
    out += _bound_caveats(diag.final) + _confounded_caveats(diag.final) + _no_flow_caveats(diag.final) + _profile_band_caveats(diag.final)
    out += _place_caveats(diag.final)
    out += _noise_caveats(diag.final)
    j = diag.judgement
    if j is not None and j.structure_remains:
        found = f"after adding {', '.join(diag.found)} " if diag.found else "and no effect in the library explains it: "
        out.append(Caveat(
            Code.RESIDUAL_STRUCTURED,
            f"structure remains {found}(RMS / noise {j.rms_ratio:.3g}, worst channel {j.worst_rms_ratio:.3g}; "
            f"'nothing left' needs at most {NOISE_CEILING:g}): " + "; ".join(pl.describe() for pl in j.places[:3]),
            {"rms_ratio": j.rms_ratio, "worst_rms_ratio": j.worst_rms_ratio, "verdict": diag.verdict, "found": list(diag.found),
             "structured": [f"{pl.record}/{pl.channel}" for pl in j.places],
             "regimes": [",".join(pl.worst_regimes.values()) for pl in j.places]},
        ))
    if j is not None and j.jitter:
        out.append(Caveat(
            Code.JITTER_COUNTED,
            "judged at the noise only by counting a sample-time jitter read from the residual itself (the rig's clock, not an "
            "effect the model explains; check the rig's sampling): " + "; ".join(c.describe() for c in j.jitter),
            {"channels": [f"{c.record}/{c.channel}" for c in j.jitter], "jitter_s": [c.jitter_s for c in j.jitter],
             "rms_ratio_without": [c.rms_ratio_without for c in j.jitter], "rms_ratio": [c.rms_ratio for c in j.jitter]},
        ))
    if j is not None and j.colours:
        out.append(Caveat(
            Code.COLOUR_COUNTED,
            "judged at the noise only by counting a correlated part of the noise that the records' noise levels suggest without "
            "establishing it (more records of the channel at other sampling rates, or a longer one, would tell): "
            + "; ".join(c.describe() for c in j.colours),
            {"channels": [f"{c.record}/{c.channel}" for c in j.colours], "evidence": [c.colour.evidence for c in j.colours],
             "rms_ratio_without": [c.rms_ratio_without for c in j.colours], "rms_ratio": [c.rms_ratio for c in j.colours]},
        ))
    return out


def _print_diagnosis(rep: Reporter, diag: diagnose.Diagnosis, path: Path) -> None:
    t = table(f"Diagnosis: {diag.verdict.replace('_', ' ')}", ("step", "model", "RMS / noise", "BIC", "added", "BIC gain", "parameters"))
    for k, rnd in enumerate(diag.rounds):
        c = rnd.accepted
        params = "" if c is None else ", ".join(f"{p.name}={c.result.values[p.name]:.4g}" for e in c.effects for p in LIBRARY[e].params)
        t.add_row(str(k), ", ".join(rnd.before.model.effects) or "classical", f"{rnd.before.rms_ratio:.3g}", f"{rnd.before.bic:.0f}",
                  "-" if c is None else c.effect, "-" if c is None else f"{c.delta_bic:.0f}", params)
    for r in diag.reconsidered:
        if r.dropped and r.refit_delta_bic is not None:
            t.add_row("tested again", "", "", "", f"{r.effect} dropped", f"{-r.refit_delta_bic:.0f}", "")
    t.add_row("final", ", ".join(diag.final.model.effects) or "classical", f"{diag.final.rms_ratio:.3g}", f"{diag.final.bic:.0f}", "", "", "")
    rep.out.print(t)
    for r in diag.reconsidered:
        if r.refit_delta_bic is not None:
            rep.say(f"Tested again at the final model: {r.describe()}.")
    if diag.judgement is not None:
        rep.say(diag.judgement.describe())
    rep.say(f"Report: {path}")


COMMANDS = (fit_cmd, diagnose_cmd, rig_cmd, demo_cmd)
