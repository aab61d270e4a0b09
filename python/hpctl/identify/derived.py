"""Quantities derived from fitted parameters (:data:`hpctl.model.effects.DERIVED`),
with their errors carried through the fit's covariance (the delta method:
for a product ``f`` of factors ``x_i``, ``var f = g' C g`` with
``g_i = f / x_i``), and the check that tells when the factors' own errors
rest on the model's shapes rather than on the records.

Why a derived value and not a reparameterised fit: the fit's parameters are
the model's (hp-core's ``Friction``), which simulations and reports use;
the derived value is what the records determine when two of them trade."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypedDict

import numpy as np

from hpctl.identify.fit import FitResult
from hpctl.model.effects import DERIVED, Derived

#: Factors correlated at least this much (in magnitude) are told apart only
#: by the model's shapes: their own errors, from the curvature of a cost
#: whose valley the model's shapes bend, understate what the records leave
#: open (the foreign rig's seal friction, docs/foreign-rig.md, stop 35:
#: Coulomb force z-scores of -3.2, -2.8 and +2.8 at correlations of -0.97
#: to -1.00 on seeds 14, 18 and 5, while their products were within 3 %).
CONFOUNDED_CORRELATION = 0.95


class DerivedJson(TypedDict):
    """``fit.json``'s ``derived`` entries."""

    name: str
    description: str
    value: float
    #: None where there is no finite error (a fit without errors, or
    #: parameters it could not tell apart).
    stderr: float | None
    factors: list[str]
    factor_correlation: float | None
    #: The factors' own errors are not to be trusted (see ``reason``).
    confounded: bool
    reason: str


@dataclass(frozen=True)
class DerivedValue:
    """One derived quantity of a fit: its value, its error through the
    fit's covariance, and whether its factors' own errors hold."""

    name: str
    description: str
    value: float
    #: Standard error (nan when the fit has no covariance).
    stderr: float
    factors: tuple[str, ...]
    #: The correlation of the first two factors' estimates (nan with fewer).
    factor_correlation: float
    #: The fit identified the damper characteristic with factors that the
    #: damper's shape stands in for (:attr:`Derived.confounded_by_damper_shape`).
    damper_shape: bool = False

    @property
    def confounded(self) -> bool:
        """The factors trade so closely that their own errors are not to
        be trusted, the derived value's is: by the fit's covariance, or
        because the damper's identified shape stands in for them."""
        return self.damper_shape or abs(self.factor_correlation) >= CONFOUNDED_CORRELATION

    @property
    def reason(self) -> str:
        """Why the factors are confounded ("" when they are not)."""
        out = []
        if abs(self.factor_correlation) >= CONFOUNDED_CORRELATION:
            out.append(f"their estimates' correlation is {self.factor_correlation:+.2f}")
        if self.damper_shape:
            out.append("the damper's identified low-speed curve stands in for them (without noise the model's shapes fit the "
                       "foreign rig's true curves best with the Coulomb force 67 % low to 20 % high: docs/foreign-rig.md)")
        return "; ".join(out)

    def to_json(self) -> DerivedJson:
        fc = self.factor_correlation
        return {"name": self.name, "description": self.description, "value": self.value,
                "stderr": self.stderr if math.isfinite(self.stderr) else None, "factors": list(self.factors),
                "factor_correlation": fc if math.isfinite(fc) else None, "confounded": self.confounded, "reason": self.reason}


def derived(result: FitResult) -> list[DerivedValue]:
    """The derived quantities whose factors ``result`` fitted, in
    :data:`DERIVED`'s order."""
    names = [p.name for p in result.model.params]
    return [_value(result, d, names) for d in DERIVED if all(f in names for f in d.factors)]


def _value(result: FitResult, d: Derived, names: list[str]) -> DerivedValue:
    x = np.array([result.values[f] for f in d.factors])
    value = float(np.prod(x))
    # d f / d x_i: the product of the other factors (no division by a zero factor).
    g = np.array([float(np.prod(np.delete(x, i))) for i in range(len(x))])
    if result.covariance is None:
        se = math.nan
    else:
        idx = [names.index(f) for f in d.factors]
        c = result.covariance[np.ix_(idx, idx)]
        se = math.sqrt(max(float(g @ c @ g), 0.0)) if np.all(np.isfinite(c)) else math.inf
    corr = result.correlation(d.factors[0], d.factors[1]) if len(d.factors) > 1 else math.nan
    return DerivedValue(d.name, d.description, value, se, d.factors, corr, d.confounded_by_damper_shape and bool(result.model.damper_branches))
