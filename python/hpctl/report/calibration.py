"""Reports of fits and diagnoses: PNG plots and a Markdown document a user
hands to a colleague."""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from hpctl.caveats import Caveat  # noqa: E402
from hpctl.data.output import OutputDir, provenance_line  # noqa: E402
from hpctl.identify.dataset import Dataset, clock_jitters, noise_colours  # noqa: E402
from hpctl.identify.derived import derived  # noqa: E402
from hpctl.identify.diagnose import AHEAD_SHARE, BIC_STRONG, NULL_Z, Candidate, Diagnosis, Round, counted_words, loop_areas  # noqa: E402
from hpctl.identify.fit import FitResult  # noqa: E402
from hpctl.identify.no_flow import NO_FLOW_SPEED_M_S  # noqa: E402
from hpctl.identify.profile import ProfileInterval  # noqa: E402
from hpctl.identify.switching import places  # noqa: E402
from hpctl.identify.workers import WorkerError  # noqa: E402
from hpctl.model.effects import LIBRARY  # noqa: E402
from hpctl.report import figures  # noqa: E402
from hpctl.report.plots import save  # noqa: E402

#: How a screening fit got its Jacobian (``Candidate.screened_by``), in the report's words.
JACOBIAN_WORDS = {"finite_difference": "finite differences", "broyden": "Broyden", "hybrid": "finite differences far, Broyden near"}


def record_plots(result: FitResult, out: OutputDir, prefix: str, workers: Executor | None = None) -> list[Path]:
    """Per record (:func:`record_figure`), written as ``PREFIX_RECORD.png``;
    drawn in ``workers`` too where given (:func:`draw_record_plots`)."""
    return draw_record_plots([(result, prefix)], out, workers)[0]


def draw_record_plots(plots: Sequence[tuple[FitResult, str]], out: OutputDir, workers: Executor | None = None) -> list[list[Path]]:
    """:func:`record_plots` of each ``(result, prefix)``, all drawn at once
    where ``workers`` (worker processes: :mod:`hpctl.identify.workers`) are
    given: a figure a worker has not taken up yet is drawn in this
    process, the last first, so that this process works beside them and
    never waits for a figure it could draw; a worker that fails
    (:class:`~hpctl.identify.workers.WorkerError`) has its figure drawn
    here. The same bytes either way (the same code and matplotlib in
    both). Why processes: matplotlib holds the GIL while it draws (two
    threads took 1.39 s for five figures, one 1.30 s), and the eleven
    figures of a diagnosis's report took 2.5 s of a 62 s campaign
    (BENCHMARKS.md, stop 59). A worker gets what the figure shows
    (:class:`~hpctl.report.figures.RecordFigure`), not the fit
    (:mod:`hpctl.report.figures` says why)."""
    # A record the model failed on has no figure.
    jobs = [(k, spec, out.path(f"{prefix}_{d.name}.png")) for k, (result, prefix) in enumerate(plots)
            for i, d in enumerate(result.datasets) if (spec := record_spec(result, i)) is not None]
    drawn: list[Path | None] = [None] * len(jobs)
    futures: list[Future[Path] | None] = [None] * len(jobs)
    if workers is not None:
        for n, (_, spec, path) in enumerate(jobs):
            try:
                futures[n] = workers.submit(figures.record_png, spec, path)
            except Exception:  # a pool shut down: drawn here
                break
    for n in reversed(range(len(jobs))):
        f = futures[n]
        if f is None or f.cancel():
            drawn[n] = figures.record_png(*jobs[n][1:])
    for n, f in enumerate(futures):
        if f is None or f.cancelled():
            continue
        try:
            drawn[n] = f.result()
        except WorkerError:
            drawn[n] = figures.record_png(*jobs[n][1:])
    return [[p for (k, _, _), p in zip(jobs, drawn) if k == which and p is not None] for which in range(len(plots))]


def record_spec(result: FitResult, i: int) -> figures.RecordFigure | None:
    """What the figure of record ``i`` of a fit shows (:func:`record_figure`);
    None if the model failed on it."""
    d = result.datasets[i]
    sim = result.sims[i]
    if isinstance(sim, Exception):
        return None
    channel = "force_n" if "force_n" in d.targets else next(iter(d.targets))
    scale, unit = (1e-3, "kN") if channel == "force_n" else (1e3, "mm") if channel.endswith("_m") else (1e-6, "MPa")
    hard, on = d.record.spring_hard(), d.record.damper_on()
    switching = bool(np.any(hard != hard[0]) or np.any(on != on[0]))
    test = d.record.test
    where = f"{test.excitation}" + (f" {1e3 * test.amplitude_m:g} mm" if test.amplitude_m else "") + (f" at {test.frequency_hz:g} Hz" if test.frequency_hz else "")
    states = "valves switching" if switching else f"{test.spring} spring, damper {test.damper}"
    return figures.RecordFigure(
        title=f"{d.name} ({where}, {states}): {', '.join(result.model.effects) or 'classical polytropic ideal gas'}",
        time_s=d.times_s,
        measured=d.targets[channel] * scale,
        model=sim[channel] * scale,
        residual=(sim[channel] - d.targets[channel]) * scale,
        disp_mm=1e3 * d.strut_disp_m,
        vel_m_s=d.strut_vel_m_s,
        channel_label=f"{channel} [{unit}]",
        unit=unit,
        disp_label=f"{'strut compression (base - body)' if d.record.kind == 'sdof' else 'strut compression'} [mm]",
        valves=figures.Valves(d.record["time_s"], hard, on) if switching else None,
    )


def record_figure(result: FitResult, i: int) -> Figure | None:
    """Record ``i`` of a fit: measured vs simulated over time (with the
    valve states under it when they switch), and the residual over time,
    displacement and velocity (:func:`hpctl.report.figures.record_figure`);
    None if the model failed on it."""
    spec = record_spec(result, i)
    return None if spec is None else figures.record_figure(spec)


def loop_area_plot(results: Sequence[tuple[str, FitResult]], path: Path) -> Path | None:
    """Loop area against frequency: measured and per model. A thermal loop
    vanishes at both ends of the frequency range; a friction loop does not."""
    rows = [(label, loop_areas(r)) for label, r in results]
    if not rows or not rows[0][1]:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.5))
    measured = rows[0][1]
    ax.semilogx([m.frequency_hz for m in measured], [m.measured_j for m in measured], "ko", label="measured")
    for label, areas in rows:
        ax.semilogx([m.frequency_hz for m in areas], [m.model_j for m in areas], "-", label=label)
    ax.set_xlabel("excitation frequency [Hz]")
    ax.set_ylabel("force-displacement loop area [J]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, path, dpi=100)
    return path


def _fmt(x: float | None, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}"


def params_table(result: FitResult) -> list[str]:
    lines = ["| parameter | value | standard error |", "|---|---|---|"]
    for p in result.model.params:
        lines.append(f"| `{p.name}` | {_fmt(result.values[p.name], 5)} | {_fmt(result.stderr.get(p.name), 2)} |")
    values = derived(result)
    if values:
        lines += ["", "Derived from the fitted parameters (errors through their covariance):", "",
                  "| quantity | value | standard error | from | correlation of the factors |", "|---|---|---|---|---|"]
        for d in values:
            lines.append(f"| `{d.name}` | {_fmt(d.value, 5)} | {_fmt(d.stderr, 2)} | {' x '.join(f'`{f}`' for f in d.factors)} | "
                         f"{_fmt(d.factor_correlation, 2)} |")
    return lines


def error_table(before: FitResult, after: FitResult | None = None) -> list[str]:
    head = "| record | channel | noise | RMS | NRMS | max | loop area error [J] |"
    if after is None:
        lines = [head, "|---|---|---|---|---|---|---|"]
        for s in before.stats:
            lines.append(f"| {s.record} | {s.channel} | {_fmt(s.noise)} | {_fmt(s.rms)} | {_fmt(s.nrms)} | {_fmt(s.max_abs)} | {_fmt(s.loop_area_error_j)} |")
        return lines
    lines = ["| record | channel | noise | RMS before | RMS after | NRMS before | NRMS after | max before | max after | loop area error before [J] | after [J] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for a, b in zip(before.stats, after.stats):
        lines.append(
            f"| {a.record} | {a.channel} | {_fmt(a.noise)} | {_fmt(a.rms)} | {_fmt(b.rms)} | {_fmt(a.nrms)} | {_fmt(b.nrms)} | "
            f"{_fmt(a.max_abs)} | {_fmt(b.max_abs)} | {_fmt(a.loop_area_error_j)} | {_fmt(b.loop_area_error_j)} |"
        )
    return lines


def switch_table(result: FitResult) -> list[str]:
    """Where the fit placed each logged valve switch (nothing for records
    that do not switch)."""
    placed = places(result.datasets)
    if not placed:
        return []
    lines = ["## Valve switches", "",
             "Each switch a record's flag columns show, placed within the interval before the first sample with the new state "
             "(0: at that sample), estimated from the residual up to the next switch.", "",
             "| record | first sample with the new state [s] | place in the interval before | switched at [s] |", "|---|---|---|---|"]
    for name, rows in placed.items():
        lines += [f"| {name} | {r['sample_s']:.6g} | {r['place']:.2f} | {r['switched_at_s']:.6g} |" for r in rows]
    return [*lines, ""]


def noise_section(datasets: Sequence[Dataset]) -> list[str]:
    """The correlated noise found per channel and the clock jitter carried
    in the weights (nothing when neither was)."""
    found = noise_colours(datasets)
    jitters = clock_jitters(datasets)
    lines: list[str] = []
    if found:
        lines += ["## Coloured noise", "",
                  "Channels whose records, sampled at different rates, show a noise correlated from sample to sample: the fourth "
                  "difference of a fast record reads only part of it, so each record's noise level above includes what it missed.", "",
                  *[f"- {k.describe()}" for k in found], ""]
    if jitters:
        lines += ["## The rig's clock", "",
                  "The measured input's samples at its steps' corners scatter beyond its noise in proportion to its rate, as samples "
                  "taken off the logged instants do: the weights carry that jitter through the model, on the input and on the "
                  "outputs the same clock samples (read from the steps' corners, the records of one rig together).", "",
                  *[f"- {kind} records: {s * 1e6:.3g} us" for kind, s in jitters.items()], ""]
    return lines


def warnings_section(caveats: Sequence[Caveat]) -> list[str]:
    """A report's "Warnings" section (nothing when there are none)."""
    if not caveats:
        return []
    return ["## Warnings", "", *[f"- `{c.code}`: {c.message}" for c in caveats], ""]


def _provenance(out: OutputDir) -> list[str]:
    """The report's provenance line (when the folder knows who writes it)."""
    return [] if out.provenance is None else [provenance_line(out.provenance), ""]


def profile_section(profiles: Sequence[ProfileInterval]) -> list[str]:
    """The profile-likelihood intervals asked for (nothing when none were)."""
    if not profiles:
        return []
    lines = ["## Profile-likelihood intervals", "",
             "Each parameter (or quantity derived from them, its first factor without a prior following the others) held at values "
             "on either side, every other parameter fitted again: the interval is where the cost (residuals in noise units and the "
             "priors) rises by sigmas^2 over the optimum. Wider than the linear one where the parameter trades with others along a "
             "bending valley.", "",
             "| parameter | estimate | linear interval | profile interval | fits |", "|---|---|---|---|---|"]
    for iv in profiles:
        lines.append(f"| {iv.name} | {iv.estimate:.5g} | +- {iv.sigmas * iv.stderr:.3g} ({iv.sigmas:g} sigma) | "
                     f"[{iv.limit_text(-1.0, 5)}, {iv.limit_text(1.0, 5)}] | {len(iv.points)} |")
    return [*lines, ""]


#: What the standard errors are, said under every parameter table of fit.md.
LINEAR_ERRORS = ("Standard errors are linearised at the estimate. Where parameters trade along a bent valley they understate "
                 "the uncertainty (measured on the foreign rig: heat build-up's wall-to-oil time constant, its two-error band "
                 "a quarter of the profile's; seal friction's Coulomb force against the flexible damper's first blow-off): "
                 "`--profile NAME` gives the profile-likelihood interval.")


def fit_report(result: FitResult, out: OutputDir, caveats: Sequence[Caveat] = (), profiles: Sequence[ProfileInterval] = (),
               workers: Executor | None = None) -> Path:
    """fit.md with parameters, errors, plots (drawn in ``workers`` too
    where given: :func:`draw_record_plots`) and the warnings."""
    plots = record_plots(result, out, "fit", workers)
    lines = [
        "# hpctl fit",
        "",
        *_provenance(out),
        f"Model: {', '.join(result.model.effects) or 'classical polytropic ideal gas'}; "
        f"{result.n} residuals; residual RMS / noise = {result.rms_ratio:.3f}; BIC = {result.bic:.1f}; {result.message}",
        "",
        *warnings_section(caveats),
        "## Parameters",
        "",
        *params_table(result),
        "",
        LINEAR_ERRORS,
        "",
        *profile_section(profiles),
        "## Residual per record and channel (SI units)",
        "",
        *error_table(result),
        "",
        *switch_table(result),
        *noise_section(result.datasets),
        "## Plots",
        "",
        *[f"![{p.stem}]({p.name})" for p in plots],
        "",
    ]
    out.write_text("fit.md", "\n".join(lines))
    return out.final("fit.md")


def _unconverged(initial: FitResult, final: FitResult) -> str:
    """Says which of the two fits stopped before converging (on its
    evaluation budget), whose errors are then where it stopped, not its
    optimum's."""
    fits = [("declared", initial)] + ([("final", final)] if final is not initial else [])
    return "".join(f" The {which} model's fit stopped before converging ({r.message.split(';')[0].rstrip('.').lower()}): its errors "
                   "are where it stopped, no lower than at its optimum." for which, r in fits if not r.success)


def _after(rnd: Round) -> str:
    j = rnd.judgement
    if j is None:
        return "-"
    return f"{j.rms_ratio:.3g} ({j.worst_rms_ratio:.3g}): {'at the noise' if j.at_noise else 'structure remains'}"


def diagnosis_report(diag: Diagnosis, out: OutputDir, caveats: Sequence[Caveat] = (), workers: Executor | None = None) -> Path:
    """report.md: the story from the declared model to the verdict, and the
    warnings; its figures drawn in ``workers`` too where given
    (:func:`draw_record_plots`)."""
    initial, final = diag.initial, diag.final
    lines = [
        "# hpctl diagnosis",
        "",
        *_provenance(out),
        f"**Verdict: {diag.verdict.replace('_', ' ')}.**",
        "",
    ]
    if diag.found:
        lines.append(f"The declared model ({', '.join(diag.start_effects) or 'classical polytropic ideal gas'}) lacked: "
                     + ", ".join(f"`{e}` ({LIBRARY[e].description})" for e in diag.found) + ".")
    elif diag.verdict == "nothing_left":
        lines.append("The residual of the declared model is indistinguishable from the measurement noise: nothing is left to explain.")
    else:
        lines.append("Structured residual remains that no effect in the library explains (see the residual analysis below).")
    if diag.reconsidered:
        lines += ["", f"Each effect found was tested again at the final model: one whose parameters were less than {NULL_Z:g} standard "
                  f"errors from doing nothing was refitted out of the model, and dropped where the model without it was no more than "
                  f"{BIC_STRONG:g} worse in BIC, its likelihood ratio divided by the residuals' design effect where their correlation or "
                  f"uneven spread makes it more than 1 (a structured residual counts each sample as evidence many times over; "
                  f"an effect found in one round can stand in there for one found later): "
                  + "; ".join(rc.describe() for rc in diag.reconsidered) + "."]
    if final.model.flexible:
        lines += ["", "Every model was fitted flexibly: the damper characteristic per valve state and direction, the heat-transfer law "
                  "and the friction's shape identified from the data (`--flexible`), not one gain on the assumed curve."]
    j = diag.judgement
    if j is not None:
        lines += ["", f"What is left: {j.describe(0)}."]
        if j.places:
            lines += ["", "## Remaining structure", "",
                      "Where the final residual is more than noise ('nothing left' needs every record's channel and the pooled residual "
                      "at most 1.3x its noise level), the regimes that hold most of it and what it correlates with:", "",
                      "| record | channel | RMS / noise | lag-1 autocorrelation | most in | correlates with |", "|---|---|---|---|---|---|"]
            for pl in j.places:
                most = ", ".join(f"{r} ({pl.regimes[r]:.2g}x)" for r in pl.worst_regimes.values()) or "evenly spread"
                what = [", ".join(f"{q} ({c:+.2f})" for q, c in pl.correlates_with)] if pl.correlates_with else []
                if pl.rate_noise is not None:
                    what.append(pl.describe_rate())
                if pl.colour_hint is not None:
                    what.append(pl.describe_colour())
                corr = "; ".join(what) or "-"
                lines.append(f"| {pl.record} | {pl.channel} | {pl.rms_ratio:.3g} | {pl.autocorr:.2f} | {most} | {corr} |")
    lines += ["", *warnings_section(caveats)]
    lines += ["## Records", "", "| record | kind | excitation | frequency [Hz] | amplitude [m] | samples |", "|---|---|---|---|---|---|"]
    for d in final.datasets:
        t = d.record.test
        lines.append(f"| {d.name} | {d.record.kind} | {t.excitation} | {_fmt(t.frequency_hz)} | {_fmt(t.amplitude_m)} | {len(d.times_s)} |")
    lines += ["", "## Steps", "",
              "| step | model | residual RMS / noise | BIC | added effect | BIC gain | per parameter | CV error before | CV error after | "
              "after: RMS / noise (worst channel) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for k, rnd in enumerate(diag.rounds):
        c = rnd.accepted
        model = ", ".join(rnd.before.model.effects) or "classical"
        if c is None:
            lines.append(f"| {k} | {model} | {rnd.before.rms_ratio:.3g} | {rnd.before.bic:.1f} | - | - | - | - | - | - |")
        else:
            lines.append(f"| {k} | {model} | {rnd.before.rms_ratio:.3g} | {rnd.before.bic:.1f} | `{c.effect}` | {c.delta_bic:.1f} | "
                         f"{c.score:.1f} | {_fmt(c.cv_before, 4)} | {_fmt(c.cv_after, 4)} | {_after(rnd)} |")
    for rc in diag.reconsidered:
        if rc.dropped and rc.refit_delta_bic is not None:
            # Its "gain": the BIC change of the model without it, as the rounds' gains (positive is better).
            lines.append(f"| tested again | | | | `{rc.effect}` dropped | {-rc.refit_delta_bic:.1f} | | | | {rc.rms_ratio_without:.3g} |")
    lines.append(f"| final | {', '.join(final.model.effects) or 'classical'} | {final.rms_ratio:.3g} | {final.bic:.1f} | | | | | | |")
    for k, rnd in enumerate(diag.rounds):
        if not rnd.candidates:
            continue
        lines += ["", f"### Candidates tried at step {k}", "",
                  "Screening fits; on long records the flexible model's rank the candidates with Broyden's Jacobian updates, and a "
                  "candidate weighed for acceptance is screened again, with finite differences wherever a step halves the cost "
                  "(far from the optimum, where the path chooses it), Broyden's updates near it (its gain by Broyden's alone in brackets; "
                  f"*ended at {AHEAD_SHARE:.0%}* where that screening was ended once it had explained that share of the excess, to be screened "
                  "again). "
                  "A gain marked *stopped* is where its screening fit was ended heading for the effect's null, no better than the "
                  "model it extends: not an optimum." + _no_flow_words(rnd), "",
                  "| effect | added parameters | BIC gain | per parameter of the effect | share of the excess residual explained | "
                  "residual RMS / noise | screening Jacobian | weighed for acceptance |",
                  "|---|---|---|---|---|---|---|---|"]
        for c in rnd.candidates:
            at_share = f", *ended at {AHEAD_SHARE:.0%}*" if c.ended_at_share else ""
            jac = JACOBIAN_WORDS.get(c.screened_by, c.screened_by) + ("" if c.broyden_delta_bic is None else f" (Broyden: {c.broyden_delta_bic:.1f}{at_share})")
            gain = f"{c.delta_bic:.1f}" + (" (*stopped*)" if c.stopped_at_null else "")
            lines.append(f"| `{c.effect}` | {c.added_params} | {gain} | {c.score:.1f} | {100 * c.explained:.1f} % | "
                         f"{c.result.rms_ratio:.3g} | {jac} | {_weighed(c, rnd.accepted)} |")
    lines += ["", "## Final parameters", "", *params_table(final), "",
              "## Error before and after", "",
              f"Declared model ({', '.join(diag.start_effects) or 'classical'}) against the final model, per record and channel (SI units)."
              + _unconverged(initial, final), "",
              *error_table(initial, final), "", *noise_section(final.datasets)]
    # Thermal versus friction hysteresis.
    areas_initial, areas_final = loop_areas(initial), loop_areas(final)
    if areas_final:
        lines += ["## Loop area against frequency", "",
                  "A thermal loop vanishes at very low frequency (isothermal) and very high frequency (adiabatic); "
                  "a Coulomb friction loop keeps its area at every frequency.", "",
                  "| frequency [Hz] | amplitude [m] | measured [J] | declared model [J] | final model [J] |", "|---|---|---|---|---|"]
        for a, b in zip(areas_initial, areas_final):
            lines.append(f"| {a.frequency_hz:g} | {_fmt(a.amplitude_m)} | {a.measured_j:.1f} | {a.model_j:.1f} | {b.model_j:.1f} |")
        png = loop_area_plot([("declared model", initial), ("final model", final)], out.path("loop_areas.png"))
        if png:
            lines += ["", f"![loop areas]({png.name})"]
    lines += ["", "## Residual analysis of the final model", "",
              "| record | channel | RMS / noise | lag-1 autocorrelation | structured |", "|---|---|---|---|---|"]
    for row in diag.final_analysis.rows:
        lines.append(f"| {row.record} | {row.channel} | {row.rms_ratio:.3g} | {row.autocorr:.2f} | {'yes' if row.structured else 'no'} |")
    strongest = sorted(diag.final_analysis.correlations, key=lambda c: -abs(c.r))[:8]
    if strongest:
        lines += ["", "Strongest correlations of the final residual with physical quantities:", "",
                  "| record | channel | quantity | correlation |", "|---|---|---|---|"]
        lines += [f"| {c.record} | {c.channel} | {c.regressor} | {c.r:+.2f} |" for c in strongest]
    before, after = draw_record_plots([(initial, "declared"), (final, "final")], out, workers)
    lines += ["", "## Plots", "", "Declared model:", "", *[f"![{p.stem}]({p.name})" for p in before], "", "Final model:", "",
              *[f"![{p.stem}]({p.name})" for p in after], ""]
    out.write_text("report.md", "\n".join(lines))
    return out.final("report.md")


def _weighed(c: Candidate, accepted: Candidate | None) -> str:
    """What became of a candidate whose full fit was weighed for acceptance
    (:func:`hpctl.identify.diagnose._settle`): its BIC change there, and
    the share of the excess it explains as the verdict judges it, each
    model in its own weights; where the residuals' correlation took its
    screening gain to :data:`BIC_STRONG` or below, that; "-" for one never
    weighed that far."""
    if c.refit_delta_bic is None:
        if c.scaled_delta_bic is not None and c.scaled_delta_bic <= BIC_STRONG and c.design_effect is not None:
            return f"gain {c.scaled_delta_bic:.1f} {counted_words(c.design_effect)}; not accepted"
        return "-"
    words = f"full fit {c.refit_delta_bic:+.1f} in BIC"
    if c.judged_explained is not None:
        words += f", {100 * c.judged_explained:.1f} % of the excess as judged (own weights)"
    return words + ("; accepted" if c is accepted else "; not accepted")


def _no_flow_words(rnd: Round) -> str:
    """Why a step at the noise screened only friction and offsets."""
    if not rnd.no_flow:
        return ""
    where = ", ".join(f.describe() for f in rnd.no_flow)
    return (f" The model was at the noise, but its fitted damper made a force at no flow ({where} at "
            f"{1e3 * NO_FLOW_SPEED_M_S:g} mm/s), which only seal friction or a load cell's offset make: only those were screened.")


def fit_summary(result: FitResult, profiles: Sequence[ProfileInterval] = ()) -> dict[str, Any]:
    return {
        "model": list(result.model.effects),
        "params": result.values,
        "stderr": result.stderr,
        "derived": [d.to_json() for d in derived(result)],
        "rms_ratio": result.rms_ratio,
        "bic": result.bic,
        "converged": result.success,
        "switch_places": places(result.datasets),
        "noise_colour": [k.to_json() for k in noise_colours(result.datasets)],
        "input_clock_jitter_s": clock_jitters(result.datasets),
        "channels": [vars(s) for s in result.stats],
        "profile_intervals": [iv.to_json() for iv in profiles],
    }
