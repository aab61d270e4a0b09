"""The effect registry as a document (``docs/effects.md`` is this module's
output: ``python -m hpctl.report.effects > docs/effects.md``; a test keeps
the two equal)."""

from __future__ import annotations

from hpctl.model.effects import CORE_RANGES, DAMPER_BRANCHES, LIBRARY, MODELS, flexible_params


def _num(x: float) -> str:
    return f"{x:g}"


def markdown() -> str:
    """The effect library: what each effect is, what reveals it, and its
    parameters with fit bounds, typical values and the core's valid range."""
    lines = [
        "# The effect library",
        "",
        "Generated from the registry (`hpctl.model.effects.LIBRARY`) by",
        "`python -m hpctl.report.effects > docs/effects.md`; do not edit by hand.",
        "`hpctl diagnose --list-effects [--json]` prints the same.",
        "",
        "Models by name: " + "; ".join(f"`{m}` = {', '.join(f'`{e}`' for e in effects) or 'the classical polytropic ideal gas'}"
                                       for m, effects in MODELS.items()) + ".",
        "",
        "| effect | what it is | revealed by | virtual-rig tests |",
        "|---|---|---|---|",
    ]
    for name, e in LIBRARY.items():
        lines.append(f"| `{name}` | {e.description} | {e.revealed_by} | {', '.join(f'`{t}`' for t in e.tests) or 'the sine sweep'} |")
    lines += [
        "",
        "| parameter | effect | fit bounds | fit start | typical | random range | scale | core's valid range |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, e in LIBRARY.items():
        for p in e.params:
            lo, hi = CORE_RANGES[p.name]
            rnd = f"±[{_num(p.random[0])}, {_num(p.random[1])}]" if p.signed else f"[{_num(p.random[0])}, {_num(p.random[1])}]"
            lines.append(f"| `{p.name}` | `{name}` | [{_num(p.lower)}, {_num(p.upper)}] | {_num(p.initial)} | {_num(p.typical)} | {rnd} | "
                         f"{'log' if p.log else 'linear'} | [{_num(lo)}, {_num(hi)}] |")
    lines += [
        "",
        "## The flexible model (`hpctl fit --flexible`, `fit(..., flexible=True)`)",
        "",
        "For real hardware: instead of one gain on the assumed damper curve, each branch of",
        "hp-core's damper (valve 5 closed = `on` / open = `off`, compression / rebound) has",
        "multipliers of its bleed (laminar), orifice (quadratic), blow-off pressure and slope",
        "above blow-off, and a smooth blow-off knee (hp-core's `blowoff_knee`, a fraction of",
        "the blow-off flow; 0 = the nominal sharp knee; it leaves the low-speed curve alone,",
        "so the bleed alone sets the slope at no flow), and a second blow-off stage (its",
        "pressure over the first's and its slope over the first's: hp-core's `blowoff2_pa`,",
        "`blowoff2_slope_pa_s_per_m3`; a slope ratio of 1, the prior's centre, is no second",
        "stage), for a bypass or a second washer stack that lifts later, and the share of the",
        "no-flow conductance that passes beside the orifice rather than in series with it (hp-core's",
        "`bleed_parallel_m3_per_s_pa`: a real valve's bleed hole; 0, the prior's centre, is the",
        "series curve `R q + K q^2`); only the branches of the valve states",
        "the records use are fitted. Where the records open valve 6, its orifice's flow area",
        "(discharge coefficient included) and laminar-turbulent transition pressure, as",
        "multipliers of the unit's (a record declares the accumulators, not the valve).",
        "With `heat_transfer`, how the thermal time constant",
        "moves with the gas's heat capacity (`tau = tau_s (m c_v / (m c_v)_static)^n`, hp-core's",
        "`WallConductance`: n = 0 the seed's constant time constant, 1 a constant wall",
        "conductance h A). With `leakage`, the exponents of its rate",
        "`dm/dt = -(m0 / tau_L) (m / m0)^k r^n`, r the gauge pressure over the static one:",
        "n (0 a decay at one time constant, 1 a leak driven by the pressure) and k (1 the",
        "current mass decaying, 0 a flow that follows the pressure only: seal permeation).",
        "With `heat_buildup`, the heat capacity of the gas's wall, which the gas's own heat",
        "warms (hp-core's `wall_heat_capacity_j_per_k`; the prior's centre, 1e12, is the",
        "seed's wall that the gas cannot warm), and the wall's time constant to ambient (the",
        "seed's calibration assumes 20,000 s).",
        "With `friction`, its smoothing velocity and a Stribeck",
        "peak are fitted too. Each has a Gaussian prior centred on the nominal value",
        "(regularisation: what the records cannot see stays nominal, with the prior's width",
        "as its standard error); sigma in decades for log parameters.",
        "",
        "| parameter | fit bounds | fit start | nominal (prior centre) | prior sigma | scale |",
        "|---|---|---|---|---|---|",
    ]
    for p in flexible_params(("heat_transfer", "friction", "leakage", "heat_buildup"), DAMPER_BRANCHES, valve6=True):
        lines.append(f"| `{p.name}` | [{_num(p.lower)}, {_num(p.upper)}] | {_num(p.initial)} | {_num(p.typical)} | "
                     f"{_num(p.prior_sigma or 0.0)} | {'log' if p.log else 'linear'} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # pragma: no cover
    print(markdown(), end="")
