"""hpctl.identify.trust_region against SciPy's least_squares itself: the
same trust-region reflective loop on a QR-compressed Jacobian must take the
same path (the same evaluations, the same end) on problems it did not
write: SciPy's documented bounded Rosenbrock, an exponential decay with a
bound that binds, an underdetermined problem, trial points where the
residuals are not finite."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares

from hpctl.identify.trust_region import QR_BLOCK_ROWS, compress, least_squares


def _both(fun, jac, x0, lb, ub, **kw):
    ours = least_squares(fun, np.asarray(x0, float), jac, np.asarray(lb, float), np.asarray(ub, float), **kw)
    theirs = scipy_least_squares(fun, x0, jac=lambda x: jac(x), bounds=(lb, ub), method="trf", x_scale="jac", **kw)
    return ours, theirs


def _rosenbrock(x):
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])


def _rosenbrock_jac(x):
    return np.array([[-20 * x[0], 10], [-1, 0]], dtype=float)


def _decay_problem(seed: int):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, 400)
    y = 2.5 * np.exp(-1.3 * t) + 0.4 + 0.01 * rng.standard_normal(t.size)

    def fun(p):
        return p[0] * np.exp(-p[1] * t) + p[2] - y

    def jac(p):
        e = np.exp(-p[1] * t)
        return np.column_stack([e, -p[0] * t * e, np.ones_like(t)])

    return fun, jac


def test_compress_gives_the_gram_matrix_and_the_gradient():
    rng = np.random.default_rng(3)
    # Tall ones are reduced a block of rows at a time: one of whole blocks
    # and a short last one, one just above the blocked size.
    for m, k in [(500, 7), (7, 7), (4, 9), (5 * QR_BLOCK_ROWS + 17, 30), (2 * QR_BLOCK_ROWS + 1, 3)]:
        j, f = rng.standard_normal((m, k)), rng.standard_normal(m)
        r, qf = compress(j, f)
        assert r.shape == (min(m, k), k)
        np.testing.assert_allclose(r.T @ r, j.T @ j, atol=1e-10)
        np.testing.assert_allclose(r.T @ qf, j.T @ f, atol=1e-10)
        np.testing.assert_allclose(np.tril(r, -1), 0.0)


def test_scipys_bounded_rosenbrock_takes_scipys_path():
    # SciPy's own example (least_squares's docstring): the bound x[1] <= 1.5
    # is active at the end, at (1.22437075, 1.5).
    ours, theirs = _both(_rosenbrock, _rosenbrock_jac, [2.0, 2.0], [-np.inf, 1.5], [np.inf, np.inf], max_nfev=200)
    np.testing.assert_allclose(ours.x, [1.22437075, 1.5], rtol=1e-7)
    np.testing.assert_allclose(ours.x, theirs.x, rtol=1e-10)
    assert (ours.nfev, ours.njev, ours.status, ours.message) == (theirs.nfev, theirs.njev, theirs.status, theirs.message)
    np.testing.assert_array_equal(ours.active_mask, theirs.active_mask)
    assert ours.cost == pytest.approx(theirs.cost, rel=1e-10)


@pytest.mark.parametrize("ub_rate", [np.inf, 1.0])  # free, and a rate bound that binds (truth 1.3)
def test_decay_fit_takes_scipys_path(ub_rate: float):
    fun, jac = _decay_problem(11)
    ours, theirs = _both(fun, jac, [1.0, 0.2, 0.0], [0.0, 0.0, -1.0], [10.0, ub_rate, 1.0], max_nfev=100, ftol=1e-10)
    assert (ours.nfev, ours.njev, ours.status) == (theirs.nfev, theirs.njev, theirs.status)
    np.testing.assert_allclose(ours.x, theirs.x, rtol=1e-8)
    np.testing.assert_allclose(ours.grad, theirs.grad, atol=1e-6 * max(1.0, float(np.max(np.abs(theirs.grad)))))
    np.testing.assert_allclose(ours.jac, theirs.jac, rtol=1e-8, atol=1e-12)  # at the same x to the last digits
    if np.isfinite(ub_rate):
        assert ours.x[1] == pytest.approx(1.0, abs=1e-6)
        assert ours.active_mask[1] == 1
    else:
        assert ours.x[1] == pytest.approx(1.3, rel=0.02)


def test_budget_ends_the_solve_as_scipys_does():
    fun, jac = _decay_problem(5)
    ours, theirs = _both(fun, jac, [1.0, 0.2, 0.0], [0.0, 0.0, -1.0], [10.0, 10.0, 1.0], max_nfev=4)
    assert ours.status == theirs.status == 0
    assert not ours.success
    assert ours.nfev == theirs.nfev == 4
    np.testing.assert_allclose(ours.x, theirs.x, rtol=1e-8)


def test_underdetermined_problem():
    # Fewer residuals than parameters: R has m rows.
    def fun(x):
        return np.array([x[0] + 2 * x[1] - x[2] ** 2 - 1.0, x[1] * x[2] - 0.5])

    def jac(x):
        return np.array([[1.0, 2.0, -2 * x[2]], [0.0, x[2], x[1]]])

    ours, theirs = _both(fun, jac, [0.1, 0.1, 0.1], [-2.0, -2.0, -2.0], [2.0, 2.0, 2.0], max_nfev=100)
    assert ours.status == theirs.status and ours.status > 0
    assert ours.cost < 1e-12
    np.testing.assert_allclose(ours.x, theirs.x, rtol=1e-6)


def test_trial_points_with_non_finite_residuals_shrink_the_region():
    # log(x) is NaN for x < 0: the first steps from far away cross zero.
    t = np.linspace(0.1, 2.0, 50)

    def fun(x):
        with np.errstate(invalid="ignore"):
            return np.log(x[0]) * t + x[1] - (np.log(0.05) * t + 0.3)

    def jac(x):
        return np.column_stack([t / x[0], np.ones_like(t)])

    ours, theirs = _both(fun, jac, [20.0, 0.0], [-10.0, -5.0], [100.0, 5.0], max_nfev=200)
    assert ours.status > 0
    np.testing.assert_allclose(ours.x, [0.05, 0.3], rtol=1e-6)
    assert (ours.nfev, ours.njev) == (theirs.nfev, theirs.njev)


def test_stop_ends_with_status_minus_two_at_an_evaluated_point():
    fun, jac = _decay_problem(7)
    seen: set[bytes] = set()

    def counted(x):
        seen.add(x.tobytes())
        return fun(x)

    asked: list[np.ndarray] = []

    def stop(x):
        asked.append(x)
        return len(asked) == 3

    sol = least_squares(counted, np.array([1.0, 0.2, 0.0]), jac, np.array([0.0, 0.0, -1.0]), np.array([10.0, 10.0, 1.0]), max_nfev=100, stop=stop)
    assert sol.status == -2 and not sol.success
    assert sol.message.startswith("Stopped because")
    assert len(asked) == 3
    assert all(x.tobytes() in seen for x in asked)
    assert sol.x.tobytes() == asked[-1].tobytes()


def test_non_finite_start_is_refused():
    with pytest.raises(ValueError, match="not finite in the initial point"):
        least_squares(lambda x: np.array([np.nan, 1.0]), np.array([1.0]), lambda x: np.ones((2, 1)), np.array([0.0]), np.array([2.0]), max_nfev=10)


def test_first_reduction_is_the_first_accepted_steps_gain():
    # What a restart on a fresh Jacobian gained from that Jacobian alone
    # (fit's confirmation of a Broyden fit reads it): the cost at the start
    # less the cost at the first point the Jacobian is asked at after it
    # (asked only at accepted points).
    fun, jac = _decay_problem(2)
    asked: list[np.ndarray] = []

    def counted_jac(p):
        asked.append(np.array(p))
        return jac(p)

    x0 = np.array([5.0, 3.0, 0.9])
    sol = least_squares(fun, x0, counted_jac, np.array([0.0, 0.0, -1.0]), np.array([10.0, 10.0, 1.0]), max_nfev=100)
    assert len(asked) >= 3 and sol.status > 0
    start, first = fun(asked[0]), fun(asked[1])
    assert sol.first_reduction == pytest.approx(0.5 * (start @ start - first @ first), rel=1e-12)
    assert 0.0 < sol.first_reduction < 0.5 * float(start @ start) - sol.cost
    # No step taken (a budget of one evaluation): nothing gained.
    assert least_squares(fun, x0, jac, np.array([0.0, 0.0, -1.0]), np.array([10.0, 10.0, 1.0]), max_nfev=1).first_reduction == 0.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_accepted_fits_tolerance_is_a_tenth_of_a_standard_error(seed: int):
    # diagnose.accepted_ftol: a step that gains ftol of the cost near the
    # optimum moves the estimate by ACCEPTED_STEP_SE white-noise standard
    # errors. On a noisy decay fit (400 samples, 3 parameters): at the
    # optimum, a displacement of that many standard errors (Mahalanobis, in
    # any direction) raises the cost by ftol of it, to within the model's
    # curvature over so small a step; and a fit from far away with that
    # tolerance ends within that many errors of the optimum.
    from hpctl.identify.diagnose import ACCEPTED_STEP_SE, accepted_ftol

    fun, jac = _decay_problem(seed)
    lb, ub = np.array([0.0, 0.0, -1.0]), np.array([10.0, 10.0, 1.0])
    n, k = 400, 3
    best = least_squares(fun, np.array([1.0, 0.2, 0.0]), jac, lb, ub, max_nfev=500, ftol=1e-15, xtol=1e-15, gtol=1e-15)
    s2 = 2.0 * best.cost / (n - k)
    cov = s2 * np.linalg.inv(best.jac.T @ best.jac)
    ftol = accepted_ftol(n, k)
    rng = np.random.default_rng(seed)
    for _ in range(5):
        u = rng.standard_normal(k)
        d = ACCEPTED_STEP_SE * u / np.sqrt(u @ np.linalg.solve(cov, u))
        r = fun(best.x + d)
        assert 0.5 * float(r @ r) - best.cost == pytest.approx(ftol * best.cost, rel=0.02)
    for x0 in ([5.0, 3.0, 0.9], [0.3, 0.05, -0.5]):
        sol = least_squares(fun, np.array(x0), jac, lb, ub, max_nfev=500, ftol=ftol)
        d = sol.x - best.x
        assert sol.success and float(np.sqrt(d @ np.linalg.solve(cov, d))) < ACCEPTED_STEP_SE
    # Never finer than the fits' own 1e-8 (a short record).
    assert accepted_ftol(100, 3) > accepted_ftol(10**9, 3) == 1e-8
