//! The adaptive integrators against exact solutions: convergence order at
//! fixed steps (every step accepted), the order of the dense output, the
//! W-method's order with an arbitrary rank-one `W`, its stability on a
//! stiff rank-one mode far beyond the explicit limit, and tolerance
//! proportionality under error control.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
use hp_core::adaptive::{AdaptiveSystem, Control, Integrator, Method, RankOne};
use hp_core::ode::OdeSystem;
use hp_core::Result;

/// A non-stiff test, linear and nonlinear, with forcing in time (so the
/// time argument of the stages is checked): `a' = b, b' = -a,
/// c' = cos(t) - c^3`; exact `a = sin t`, `b = cos t`, and `c` from a
/// reference run at a much smaller step.
struct Nonstiff;

impl OdeSystem<3> for Nonstiff {
    fn derivatives(&self, t: f64, y: &[f64; 3]) -> Result<[f64; 3]> {
        Ok([y[1], -y[0], t.cos() - y[2] * y[2] * y[2]])
    }
}

impl AdaptiveSystem<3> for Nonstiff {
    fn abs_tolerance(&self) -> [f64; 3] {
        [1e-12; 3]
    }
}

/// The same system handed a rank-one `W` unrelated to its Jacobian: a
/// W-method keeps its order with any `W`.
struct NonstiffWithW;

impl OdeSystem<3> for NonstiffWithW {
    fn derivatives(&self, t: f64, y: &[f64; 3]) -> Result<[f64; 3]> {
        Nonstiff.derivatives(t, y)
    }
}

impl AdaptiveSystem<3> for NonstiffWithW {
    fn abs_tolerance(&self) -> [f64; 3] {
        [1e-12; 3]
    }
    fn derivatives_with_coupling(&self, t: f64, y: &[f64; 3]) -> Result<([f64; 3], Option<RankOne<3>>)> {
        Ok((self.derivatives(t, y)?, Some(RankOne { u: [0.3, -1.0, 0.5], v: [2.0, 0.7, -1.1] })))
    }
}

/// A stiff rank-one mode on top of a slow one: `y' = -k u v^T (y - g(t)) + g'(t)`
/// with `v.u = 1`, so `y - g` decays at rate `k` along `u` and the
/// exact solution is `g(t) + (y0 - g(0)) e^{-k t}` along `u`. With
/// `k = 1e6` an explicit method needs steps below 3e-6 s.
struct StiffRankOne {
    k: f64,
}

const U: [f64; 2] = [1.0, -1.0];
const V: [f64; 2] = [0.5, -0.5]; // v.u = 1

fn g(t: f64) -> [f64; 2] {
    [t.sin(), 2.0 + t.cos()]
}

impl OdeSystem<2> for StiffRankOne {
    fn derivatives(&self, t: f64, y: &[f64; 2]) -> Result<[f64; 2]> {
        let gt = g(t);
        let dg = [t.cos(), -t.sin()];
        let s = V[0] * (y[0] - gt[0]) + V[1] * (y[1] - gt[1]);
        Ok([-self.k * U[0] * s + dg[0], -self.k * U[1] * s + dg[1]])
    }
}

impl AdaptiveSystem<2> for StiffRankOne {
    fn abs_tolerance(&self) -> [f64; 2] {
        [1e-10; 2]
    }
    fn derivatives_with_coupling(&self, t: f64, y: &[f64; 2]) -> Result<([f64; 2], Option<RankOne<2>>)> {
        Ok((self.derivatives(t, y)?, Some(RankOne { u: [-self.k * U[0], -self.k * U[1]], v: V })))
    }
}

/// Runs to `t_end` with every step accepted at exactly `h`.
fn fixed_steps<const N: usize, S: AdaptiveSystem<N>>(system: &S, y0: [f64; N], t_end: f64, h: f64) -> (Integrator<N>, Method) {
    let control = Control::new(1e30, h);
    let mut it = Integrator::new(system, 0.0, y0, h, control).unwrap();
    let mut method = Method::DormandPrince;
    while it.t() < t_end {
        method = it.step(system, t_end).unwrap();
    }
    assert_eq!(it.stats().rejected, 0);
    (it, method)
}

fn reference_nonstiff(t_end: f64) -> [f64; 3] {
    let (it, _) = fixed_steps(&Nonstiff, [0.0, 1.0, 1.0], t_end, 1.0 / 4096.0);
    *it.y()
}

fn observed_orders(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

#[test]
fn dormand_prince_converges_at_fifth_order() {
    let reference = reference_nonstiff(2.0);
    let errors: Vec<f64> = [1.0 / 16.0, 1.0 / 32.0, 1.0 / 64.0]
        .iter()
        .map(|&h| {
            let (it, method) = fixed_steps(&Nonstiff, [0.0, 1.0, 1.0], 2.0, h);
            assert_eq!(method, Method::DormandPrince);
            (0..3).map(|i| (it.y()[i] - reference[i]).abs()).fold(0.0, f64::max)
        })
        .collect();
    for order in observed_orders(&errors) {
        assert!((4.6..5.6).contains(&order), "{errors:?}");
    }
}

#[test]
fn rosenbrock_w_converges_at_third_order_with_any_rank_one_w() {
    let reference = reference_nonstiff(2.0);
    let errors: Vec<f64> = [1.0 / 32.0, 1.0 / 64.0, 1.0 / 128.0]
        .iter()
        .map(|&h| {
            let (it, method) = fixed_steps(&NonstiffWithW, [0.0, 1.0, 1.0], 2.0, h);
            assert_eq!(method, Method::Rosenbrock);
            (0..3).map(|i| (it.y()[i] - reference[i]).abs()).fold(0.0, f64::max)
        })
        .collect();
    for order in observed_orders(&errors) {
        assert!((2.7..3.4).contains(&order), "{errors:?}");
    }
}

#[test]
fn dense_output_converges_at_the_methods_orders() {
    // Midpoints of the last step against a sine: Dormand-Prince's
    // continuous extension is fourth order, ROS34PW2's third.
    for (system_has_w, lo, hi) in [(false, 3.7, 5.6), (true, 2.7, 4.2)] {
        let errors: Vec<f64> = [1.0 / 8.0, 1.0 / 16.0, 1.0 / 32.0]
            .iter()
            .map(|&h| {
                let t_end = 1.0;
                let it = if system_has_w {
                    fixed_steps(&NonstiffWithW, [0.0, 1.0, 1.0], t_end, h).0
                } else {
                    fixed_steps(&Nonstiff, [0.0, 1.0, 1.0], t_end, h).0
                };
                // The last step's dense output at a few interior points,
                // against the exact sine (a, the first state).
                [0.2, 0.5, 0.8].iter().map(|&f| {
                    let t = t_end - h + f * h;
                    (it.dense(t)[0] - t.sin()).abs()
                })
                .fold(0.0, f64::max)
            })
            .collect();
        for order in observed_orders(&errors) {
            assert!((lo..hi).contains(&order), "W={system_has_w}: {errors:?}");
        }
    }
}

#[test]
fn rosenbrock_w_is_stable_and_accurate_far_beyond_the_explicit_limit() {
    // k = 1e6: steps of 1e-3 s are 1000 times the explicit stability
    // limit; the fast mode is damped and the slow solution followed.
    let system = StiffRankOne { k: 1e6 };
    let y0 = [0.4, 2.6]; // g(0) + 0.4 u: off the slow manifold along the fast mode
    let mut it = Integrator::new(&system, 0.0, y0, 1e-3, Control::new(1e-6, 1e-2)).unwrap();
    while it.t() < 2.0 {
        it.step(&system, 2.0).unwrap();
    }
    let exact = g(2.0);
    for i in 0..2 {
        assert!((it.y()[i] - exact[i]).abs() < 1e-5, "{:?} vs {exact:?}", it.y());
    }
    // Error control resolves the initial transient and then takes steps
    // bounded by the slow solution's accuracy, not by k.
    let stats = it.stats();
    assert!(stats.accepted < 2000, "{stats:?}");
    assert_eq!(stats.rosenbrock, stats.accepted);
}

#[test]
fn global_error_follows_the_tolerance() {
    let reference = reference_nonstiff(10.0);
    let run = |rtol: f64| {
        let mut it = Integrator::new(&Nonstiff, 0.0, [0.0, 1.0, 1.0], 1e-3, Control::new(rtol, 1.0)).unwrap();
        while it.t() < 10.0 {
            it.step(&Nonstiff, 10.0).unwrap();
        }
        ((0..3).map(|i| (it.y()[i] - reference[i]).abs()).fold(0.0, f64::max), it.stats().accepted)
    };
    let (coarse, n_coarse) = run(1e-5);
    let (fine, n_fine) = run(1e-8);
    assert!(coarse < 1e-3 && fine < 1e-6, "{coarse} {fine}");
    assert!(coarse / fine > 100.0, "{coarse} {fine}");
    // Fifth order: 1000 times tighter costs about 1000^(1/5) = 4 times the steps.
    let ratio = n_fine as f64 / n_coarse as f64;
    assert!((2.5..6.5).contains(&ratio), "{n_coarse} {n_fine}");
}

