"""SciPy's bounded trust-region reflective least squares
(``least_squares(method="trf", x_scale="jac")``, exact trust-region
solver, linear loss) on a QR-compressed Jacobian.

Why a loop of our own: SciPy's takes the SVD of the whole augmented
Jacobian (m + k rows, k columns, copied to a C-ordered array first) at every
iteration, and its step selection multiplies the whole Jacobian again.
Every one of those only needs the Jacobian's Gram matrix and its product
with the residuals, ``J^T J`` and ``J^T f``: one QR of ``[J f]`` (``R``
only, no ``Q`` formed) gives ``J = Q R`` and ``Q^T f``, and the augmented
SVD is then that of ``[R d; D]``, 2k x k. The same steps in exact
arithmetic (the tests compare the paths with ``least_squares`` itself), at
a k x k cost per iteration instead of an m x k SVD: on the bundled campaign
(57,255 residuals, 35-40 parameters) 191 SVDs took 13.9 s of CPU, 73 ms
each, where the QR takes 25 ms (BENCHMARKS.md, stop 54).

The loop is SciPy's ``trf_bounds`` (BSD-3-Clause, scipy/optimize/_lsq/trf.py);
its helpers are imported from SciPy (private modules, unchanged since SciPy
0.17; ``tests/test_trust_region.py`` compares the whole path with
``least_squares``, so a change there fails a test rather than a fit).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.linalg import norm
from numpy.typing import NDArray
from scipy.linalg import qr, svd
from scipy.optimize._lsq.common import (
    CL_scaling_vector,
    check_termination,
    compute_jac_scale,
    find_active_constraints,
    make_strictly_feasible,
    solve_lsq_trust_region,
    update_tr_radius,
)
from scipy.optimize._lsq.trf import select_step

FloatArray = NDArray[np.float64]

#: SciPy's own words for each status (``least_squares``'s), so that a
#: result reads the same whichever loop produced it.
MESSAGES = {
    -2: "Stopped because `stop` returned `True`",
    0: "The maximum number of function evaluations is exceeded.",
    1: "`gtol` termination condition is satisfied.",
    2: "`ftol` termination condition is satisfied.",
    3: "`xtol` termination condition is satisfied.",
    4: "Both `ftol` and `xtol` termination conditions are satisfied.",
}


@dataclass
class Solution:
    """What :func:`least_squares` ends with: the fields of SciPy's result
    that :mod:`hpctl.identify.fit` reads and the tests compare the path by,
    same meanings."""

    x: FloatArray
    cost: float
    jac: FloatArray
    grad: FloatArray
    active_mask: NDArray[np.int_]
    nfev: int
    njev: int
    status: int
    #: The cost reduction of the first step taken (0 where none was): what
    #: a fit started on a fresh Jacobian gained from that Jacobian alone.
    first_reduction: float = 0.0

    @property
    def success(self) -> bool:
        return self.status > 0

    @property
    def message(self) -> str:
        return MESSAGES[self.status]


#: Rows of ``[J f]`` per block of :func:`compress`'s first pass: about
#: 0.2-0.3 MB a block at the fits' 25-40 columns, within a core's L2 cache,
#: so that each Householder reflection of a block reads it from cache
#: instead of from memory (LAPACK's QR of the whole tall matrix passes over
#: all of it once per column). Measured with one BLAS thread (random
#: matrices; 256, 1,024 and 4,096 rows a block): 1,024 the fastest of the
#: three at 45,000 x 27 (5.4 against 10.0 ms), 57,255 x 41 (14.0 against
#: 29.2 ms) and 160,000 x 42 (43 against 118 ms).
QR_BLOCK_ROWS = 1024


def compress(j: FloatArray, f: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``R`` and ``Q^T f`` of the economic QR ``J = Q R`` (``J`` is m x k):
    a QR of ``[J f]``, ``Q`` never formed. Where m <= k, ``R`` has m rows.

    Tall matrices are reduced a block of :data:`QR_BLOCK_ROWS` rows at a
    time (each block's ``R`` stacked, then one QR of the stack: the
    "tall-skinny QR" of Demmel et al. 2012, as stable as Householder's on
    the whole): the same ``R`` up to the signs of its rows (which ``Q^T f``
    shares, so ``R^T R`` and ``R^T Q^T f`` are the same) and rounding."""
    m, k = j.shape
    if m <= 2 * QR_BLOCK_ROWS:
        return _split(_r_of(_augmented(j, f)), k)
    # A short last block's R has as many rows as it (the slice keeps them).
    tops = [_r_of(_augmented(j[s:s + QR_BLOCK_ROWS], f[s:s + QR_BLOCK_ROWS]))[: k + 1] for s in range(0, m, QR_BLOCK_ROWS)]
    return _split(_r_of(np.asfortranarray(np.vstack(tops))), k)


def _augmented(j: FloatArray, f: FloatArray) -> FloatArray:
    """``[J f]`` in a new column-major array, for :func:`_r_of` to overwrite."""
    a = np.empty((j.shape[0], j.shape[1] + 1), order="F")
    a[:, :-1] = j
    a[:, -1] = f
    return a


def _r_of(a: FloatArray) -> FloatArray:
    """The triangular factor of a Householder QR of ``a`` (overwritten):
    mode "raw", since mode "r" also fills the m x n zeros below it."""
    return np.asarray(qr(a, mode="raw", overwrite_a=True, check_finite=False)[1])


def _split(r: FloatArray, k: int) -> tuple[FloatArray, FloatArray]:
    """``R`` and ``Q^T f`` from the QR of ``[J f]``: its first k columns and
    the last. Row k, where there is one, is the residual's part outside
    J's columns: not needed (the cost is taken from f itself)."""
    rows = min(r.shape[0], k)
    return np.ascontiguousarray(r[:rows, :k]), r[:rows, k].copy()


def least_squares(
    fun: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    jac: Callable[[FloatArray], FloatArray],
    lb: FloatArray,
    ub: FloatArray,
    *,
    max_nfev: int,
    ftol: float = 1e-8,
    xtol: float = 1e-8,
    gtol: float = 1e-8,
    stop: Callable[[FloatArray], bool] | None = None,
) -> Solution:
    """Minimises ``0.5 |fun(x)|^2`` for ``lb <= x <= ub`` as SciPy's
    ``least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf",
    x_scale="jac", ...)`` does; ``stop(x)``, asked after every iteration,
    ends the solve with status -2 where true (SciPy's callback raising
    ``StopIteration``). ``jac(x)`` is asked only at points ``fun`` was
    asked at, right after."""
    lb = np.asarray(lb, dtype=float)
    ub = np.asarray(ub, dtype=float)
    x = make_strictly_feasible(np.asarray(x0, dtype=float), lb, ub)
    f = np.asarray(fun(x), dtype=float)
    if not np.all(np.isfinite(f)):
        raise ValueError("Residuals are not finite in the initial point.")
    j = np.asarray(jac(x), dtype=float)
    m, n = j.shape
    nfev = njev = 1
    cost = 0.5 * float(f @ f)
    r, qf = compress(j, f)
    g = r.T @ qf
    scale, scale_inv = compute_jac_scale(r)
    v, dv = CL_scaling_vector(x, g, lb, ub)
    v[dv != 0] *= scale_inv[dv != 0]
    delta = float(norm(x * scale_inv / v**0.5))
    if delta == 0:
        delta = 1.0
    qf_aug = np.zeros(r.shape[0] + n)
    alpha = 0.0  # the Levenberg-Marquardt parameter
    status: int | None = None
    first_reduction: float | None = None
    while True:
        v, dv = CL_scaling_vector(x, g, lb, ub)
        g_norm = float(norm(g * v, ord=np.inf))
        if g_norm < gtol:
            status = 1
        if status is not None or nfev == max_nfev:
            break
        v[dv != 0] *= scale_inv[dv != 0]
        d = v**0.5 * scale
        diag_h = g * dv * scale
        g_h = d * g
        # SciPy's "hat" Jacobian J d is Q (R d): its SVD with the
        # Coleman-Li diagonal below it is that of the small [R d; D].
        r_h = r * d
        u, s, vt = svd(np.vstack((r_h, np.diag(diag_h**0.5))), full_matrices=False, check_finite=False)
        qf_aug[: qf.size] = qf
        uf = u.T @ qf_aug
        v_svd = vt.T
        theta = max(0.995, 1 - g_norm)
        actual_reduction = -1.0
        while actual_reduction <= 0 and nfev < max_nfev:
            p_h, alpha, _ = solve_lsq_trust_region(n, m, uf, s, v_svd, delta, initial_alpha=alpha)
            p = d * p_h
            # select_step needs |J_h s| and (J_h a).(J_h b) only: R d
            # gives them (Q's columns are orthonormal).
            step, step_h, predicted_reduction = select_step(x, r_h, diag_h, g_h, p, p_h, d, delta, lb, ub, theta)
            x_new = make_strictly_feasible(x + step, lb, ub, rstep=0)
            f_new = np.asarray(fun(x_new), dtype=float)
            nfev += 1
            step_h_norm = float(norm(step_h))
            if not np.all(np.isfinite(f_new)):
                delta = 0.25 * step_h_norm
                continue
            cost_new = 0.5 * float(f_new @ f_new)
            actual_reduction = cost - cost_new
            delta_new, ratio = update_tr_radius(delta, actual_reduction, predicted_reduction, step_h_norm, step_h_norm > 0.95 * delta)
            step_norm = float(norm(step))
            status = check_termination(actual_reduction, cost, step_norm, float(norm(x)), ratio, ftol, xtol)
            if status is not None:
                break
            alpha *= delta / delta_new
            delta = delta_new
        if actual_reduction > 0:
            if first_reduction is None:
                first_reduction = actual_reduction
            x, f, cost = x_new, f_new, cost_new
            j = np.asarray(jac(x), dtype=float)
            njev += 1
            r, qf = compress(j, f)
            g = r.T @ qf
            scale, scale_inv = compute_jac_scale(r, scale_inv)
        if stop is not None and stop(x.copy()):
            status = -2
            break
    if status is None:
        status = 0
    return Solution(x=x, cost=cost, jac=j, grad=g, active_mask=find_active_constraints(x, lb, ub, rtol=xtol),
                    nfev=nfev, njev=njev, status=status, first_reduction=first_reduction or 0.0)
