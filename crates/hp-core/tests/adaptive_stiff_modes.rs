//! The adaptive integrator with more than one stiff mode in `W` and with
//! [`StiffMethod::Switching`]: against exact solutions, and the choice of
//! method where each one pays.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
use hp_core::adaptive::{AdaptiveSystem, Control, Integrator, LowRank, Method, RankOne, StiffMethod};
use hp_core::ode::OdeSystem;
use hp_core::Result;

/// Two stiff modes on top of a slow solution:
/// `y' = -(k1 u1 v1^T + k2 u2 v2^T)(y - g(t)) + g'(t)`, `v_i.u_j = delta_ij`,
/// so `y - g` decays along `u1` at `k1` and along `u2` at `k2`, and the
/// exact solution from a start on `g` is `g`.
struct TwoModes {
    k: [f64; 2],
    w: f64,
}

const U: [[f64; 3]; 2] = [[1.0, -1.0, 0.0], [0.0, 1.0, 1.0]];
// Dual to U: v_i.u_j = delta_ij.
const V: [[f64; 3]; 2] = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];

impl TwoModes {
    fn g(&self, t: f64) -> [f64; 3] {
        [(self.w * t).sin(), 2.0 + (self.w * t).cos(), 0.5 * (self.w * t).sin()]
    }
    fn dg(&self, t: f64) -> [f64; 3] {
        [self.w * (self.w * t).cos(), -self.w * (self.w * t).sin(), 0.5 * self.w * (self.w * t).cos()]
    }
}

impl OdeSystem<3> for TwoModes {
    fn derivatives(&self, t: f64, y: &[f64; 3]) -> Result<[f64; 3]> {
        let (g, dg) = (self.g(t), self.dg(t));
        let mut f = dg;
        for m in 0..2 {
            let s: f64 = (0..3).map(|i| V[m][i] * (y[i] - g[i])).sum();
            for i in 0..3 {
                f[i] -= self.k[m] * U[m][i] * s;
            }
        }
        Ok(f)
    }
}

impl AdaptiveSystem<3> for TwoModes {
    fn abs_tolerance(&self) -> [f64; 3] {
        [1e-10; 3]
    }
    fn derivatives_with_stiff_part(&self, t: f64, y: &[f64; 3]) -> Result<([f64; 3], LowRank<3>)> {
        let mut w = LowRank::NONE;
        for m in 0..2 {
            let u = [-self.k[m] * U[m][0], -self.k[m] * U[m][1], -self.k[m] * U[m][2]];
            assert!(w.push(RankOne { u, v: V[m] }));
        }
        Ok((self.derivatives(t, y)?, w))
    }
}

fn run(system: &TwoModes, control: Control, t_end: f64) -> (Integrator<3>, Vec<f64>) {
    let mut it = Integrator::new(system, 0.0, system.g(0.0), 1e-4, control).unwrap();
    let mut ends = Vec::new();
    while it.t() < t_end {
        it.step(system, t_end).unwrap();
        ends.push(it.t());
    }
    (it, ends)
}

fn error(system: &TwoModes, it: &Integrator<3>) -> f64 {
    let g = system.g(it.t());
    (0..3).map(|i| (it.y()[i] - g[i]).abs()).fold(0.0, f64::max)
}

#[test]
fn two_stiff_modes_are_both_implicit() {
    // Rates 1e6 and 1e4 (explicit steps below 3e-6 s): both in W, the steps
    // follow the slow solution.
    let system = TwoModes { k: [1e6, 1e4], w: 1.0 };
    let (it, _) = run(&system, Control::new(1e-6, 1e-2), 2.0);
    assert!(error(&system, &it) < 1e-5, "{}", error(&system, &it));
    let stats = it.stats();
    assert!(stats.accepted < 2000, "{stats:?}");
    assert_eq!(stats.rosenbrock, stats.accepted);
}

#[test]
fn switching_takes_the_method_that_pays() {
    let control = |rtol: f64| Control { stiff: StiffMethod::Switching, ..Control::new(rtol, 1.0) };
    // Modes at 50 and 20 per second under a slow solution: Dormand-Prince
    // would be held below 3.3 / 50 s by its stability (909 steps over
    // 60 s), where ROS34PW2 takes the accuracy's steps.
    let slow = TwoModes { k: [50.0, 20.0], w: 0.2 };
    let (it, _) = run(&slow, control(1e-6), 60.0);
    let stats = it.stats();
    assert!(stats.rosenbrock > 9 * stats.accepted / 10, "{stats:?}");
    assert!(stats.accepted < 600, "{stats:?}");
    assert!(error(&slow, &it) < 1e-5, "{}", error(&slow, &it));
    // The same modes under a solution that changes in a fraction of their
    // time constants: Dormand-Prince's fifth order sets the steps, well
    // within its stability.
    let fast = TwoModes { k: [50.0, 20.0], w: 40.0 };
    let (it, _) = run(&fast, control(1e-6), 2.0);
    let stats = it.stats();
    assert_eq!(stats.rosenbrock, 0, "{stats:?}");
    assert!(error(&fast, &it) < 1e-5, "{}", error(&fast, &it));
}

#[test]
fn switching_replays_the_same_choices() {
    // A replay (Integrator::step_exact) of a switching run's steps takes
    // each with the same method, so it reproduces the run exactly.
    let system = TwoModes { k: [50.0, 20.0], w: 0.2 };
    let control = Control { stiff: StiffMethod::Switching, ..Control::new(1e-6, 1.0) };
    let (it, ends) = run(&system, control, 60.0);
    let stats = it.stats();
    assert!(stats.rosenbrock > 0 && stats.rosenbrock < stats.accepted && stats.switches > 1, "{stats:?}");
    let mut replay = Integrator::new(&system, 0.0, system.g(0.0), 1e-4, control).unwrap();
    let mut methods = [0u64; 2];
    for &e in &ends {
        match replay.step_exact(&system, e).unwrap() {
            Method::DormandPrince => methods[0] += 1,
            Method::Rosenbrock => methods[1] += 1,
        }
    }
    assert_eq!(methods[1], stats.rosenbrock);
    assert_eq!(replay.y(), it.y());
}
