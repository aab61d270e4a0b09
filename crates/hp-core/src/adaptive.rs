//! Adaptive integration with error control and dense output: an explicit
//! embedded Runge-Kutta pair and a linearly implicit one for stiff
//! low-rank couplings, beside the fixed-step RK4 of [`crate::ode`] (which
//! the firmware keeps).
//!
//! - Dormand-Prince 5(4) (Dormand & Prince 1980; the coefficients and the
//!   fourth-order continuous extension as in Hairer, Norsett & Wanner,
//!   *Solving ODEs I*, and their `dopri5`): seven stages, the last one the
//!   first of the next step.
//! - The Rosenbrock-W method ROS34PW2 (Rang & Angermann 2005, BIT 45;
//!   coefficients and its third-order dense output as in PETSc's
//!   `TSROSWRA34PW2`): four stages, third order with a second-order
//!   embedded solution, L-stable, and a W-method, so its order holds for
//!   any approximation `W` of the Jacobian. The system supplies `W` as a
//!   sum of at most [`MAX_RANK`] rank-one matrices `u_j v_j^T` (its stiff
//!   couplings, each through a fast flow: e.g. the valve-6 orifice between
//!   the accumulators, the damper pack relieving the compressible oil), so
//!   each stage solves `(I - h gamma U V^T) k = r` by the Woodbury formula
//!   (Sherman-Morrison for one term) in O(n): those modes are integrated
//!   implicitly and no longer limit the step, at the cost of an explicit
//!   method's arithmetic.
//!
//! A step uses ROS34PW2 when the system reports a stiff coupling at its
//! start, Dormand-Prince otherwise; or, with [`StiffMethod::Switching`],
//! Dormand-Prince also wherever its step is stable for the stiff modes,
//! ROS34PW2 only where they would hold Dormand-Prince's steps well below
//! what its accuracy allows. The states are the first
//! [`AdaptiveSystem::integrated_len`] entries of an `[f64; N]`: states a model does
//! not use are not integrated (and do not enter the error norm).
//!
//! Hand-written (no allocation, no panics, `no_std`, a fixed-size state):
//! the Rust ODE crates allocate or need `std`.

// The tableaus' constants are written with the digits they are published with.
#![allow(clippy::excessive_precision)]

use crate::error::{Error, Result};
use crate::ode::OdeSystem;

/// A rank-one approximation `u v^T` of the stiff part of a Jacobian
/// `df/dy`: `u = df/dq` for a fast internal quantity `q` (e.g. a flow) and
/// `v = dq/dy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankOne<const N: usize> {
    pub u: [f64; N],
    pub v: [f64; N],
}

/// Most rank-one terms of a [`LowRank`] stiff part.
pub const MAX_RANK: usize = 2;

/// A low-rank approximation `sum_j u_j v_j^T` of the stiff part of a
/// Jacobian: one [`RankOne`] term per fast internal quantity, at most
/// [`MAX_RANK`] of them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LowRank<const N: usize> {
    terms: [RankOne<N>; MAX_RANK],
    rank: usize,
}

impl<const N: usize> LowRank<N> {
    /// No stiff part.
    pub const NONE: Self = LowRank { terms: [RankOne { u: [0.0; N], v: [0.0; N] }; MAX_RANK], rank: 0 };

    /// Adds a term; false (and nothing added) if there are [`MAX_RANK`] already.
    pub fn push(&mut self, term: RankOne<N>) -> bool {
        match self.terms.get_mut(self.rank) {
            Some(slot) => {
                *slot = term;
                self.rank += 1;
                true
            }
            None => false,
        }
    }

    /// The number of terms.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// The terms.
    pub fn terms(&self) -> &[RankOne<N>] {
        self.terms.get(..self.rank).unwrap_or(&[])
    }
}

impl<const N: usize> From<Option<RankOne<N>>> for LowRank<N> {
    fn from(term: Option<RankOne<N>>) -> Self {
        let mut out = LowRank::NONE;
        if let Some(t) = term {
            out.push(t);
        }
        out
    }
}

/// A system for the adaptive integrator.
pub trait AdaptiveSystem<const N: usize>: OdeSystem<N> {
    /// Number of integrated states: the first `integrated_len()` entries of
    /// the state.
    fn integrated_len(&self) -> usize {
        N
    }

    /// Absolute error tolerance of each state (the relative tolerance is
    /// the integrator's).
    fn abs_tolerance(&self) -> [f64; N];

    /// The derivative and, where the system has a stiff coupling, its
    /// rank-one part of the Jacobian. A system with several stiff
    /// couplings implements [`AdaptiveSystem::derivatives_with_stiff_part`]
    /// instead.
    fn derivatives_with_coupling(&self, t_s: f64, y: &[f64; N]) -> Result<([f64; N], Option<RankOne<N>>)> {
        Ok((self.derivatives(t_s, y)?, None))
    }

    /// The derivative and the stiff part of the Jacobian (what the
    /// integrator asks for); by default the one coupling of
    /// [`AdaptiveSystem::derivatives_with_coupling`].
    fn derivatives_with_stiff_part(&self, t_s: f64, y: &[f64; N]) -> Result<([f64; N], LowRank<N>)> {
        let (f, coupling) = self.derivatives_with_coupling(t_s, y)?;
        Ok((f, coupling.into()))
    }

    /// Keeps an accepted state within the model's constraints (e.g. a void
    /// volume that cannot be negative); returns true if it changed `y`.
    fn project(&self, _t_s: f64, _y: &mut [f64; N]) -> bool {
        false
    }

    /// Checks an accepted state (the integrator rejects the step if not).
    fn check(&self, _t_s: f64, _y: &[f64; N]) -> Result<()> {
        Ok(())
    }
}

/// Which method took a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    DormandPrince,
    Rosenbrock,
}

/// How steps with a stiff coupling are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StiffMethod {
    /// Every one by ROS34PW2.
    #[default]
    RosenbrockW,
    /// By Dormand-Prince where its step is stable for the stiff modes
    /// (`h rho <= DP_STABLE`, `rho` the spectral radius of `W`), by
    /// ROS34PW2 beyond. A stiff mode that is stiff only against slow
    /// motion is resolved by Dormand-Prince's fifth order at about the
    /// steps ROS34PW2's third order would need, at the default tolerance
    /// (measured with the oil spring on a 0.5 Hz sine: 3,214 steps, ROS34PW2
    /// 9,047; on a 0.01 Hz sine 14,033 against 2,531): the cheaper one is
    /// taken. Which one takes a step depends only on the step and `rho`,
    /// so that a replay ([`Integrator::step_exact`]) makes the same
    /// choices; the step sizes keep clear of the boundary (see
    /// [`Integrator::step`]).
    Switching,
}

/// Counts of the work done.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stats {
    pub accepted: u64,
    pub rejected: u64,
    /// Steps taken by the Rosenbrock-W method (of the accepted ones).
    pub rosenbrock: u64,
    /// With [`StiffMethod::Switching`]: changes from Dormand-Prince's held
    /// steps to ROS34PW2's and back.
    pub switches: u64,
    pub evaluations: u64,
}

/// Settings of the step control.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Control {
    /// Relative error tolerance per step.
    pub rtol: f64,
    /// Largest step, s.
    pub max_dt_s: f64,
    /// Smallest step before giving up, s.
    pub min_step_s: f64,
    /// How steps with a stiff coupling are taken.
    pub stiff: StiffMethod,
}

impl Control {
    /// With relative tolerance `rtol` and steps of at most `max_dt_s`.
    pub fn new(rtol: f64, max_dt_s: f64) -> Self {
        Control { rtol, max_dt_s, min_step_s: 1e-12, stiff: StiffMethod::RosenbrockW }
    }
}

/// Dense output of the last accepted step: the solution as a polynomial
/// in `theta = (t - t0) / h`.
#[derive(Debug, Clone, Copy)]
enum Dense<const N: usize> {
    /// Hairer's form `r1 + theta (r2 + (1 - theta) (r3 + theta (r4 + (1 - theta) r5)))`.
    DormandPrince([[f64; N]; 5]),
    /// `y0 + theta c1 + theta^2 c2 + theta^3 c3`.
    Rosenbrock([[f64; N]; 4]),
}

// Dormand-Prince 5(4).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
/// Error coefficients: fifth-order weights minus the embedded fourth-order ones.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
/// Continuous extension (dense output) coefficients.
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

// ROS34PW2: stage table alpha, Gamma (diagonal GAMMA), weights, embedded
// weights, dense output (PETSc's binterpt, by stage then power of theta).
const GAMMA: f64 = 4.358_665_215_084_590_0e-01;
const RA21: f64 = 8.717_330_430_169_180_1e-01;
const RA31: f64 = 8.445_706_001_536_942_3e-01;
const RA32: f64 = -1.129_906_423_648_418_5e-01;
const RA43: f64 = 1.0;
const RG21: f64 = -8.717_330_430_169_180_1e-01;
const RG31: f64 = -9.033_805_701_304_408_2e-01;
const RG32: f64 = 5.418_067_238_809_532_6e-02;
const RG41: f64 = 2.421_238_070_609_534_6e-01;
const RG42: f64 = -1.223_250_583_904_514_7e+00;
const RG43: f64 = 5.452_602_553_351_021_4e-01;
const RB: [f64; 4] = [2.421_238_070_609_534_6e-01, -1.223_250_583_904_514_7e+00, 1.545_260_255_335_102_0e+00, 4.358_665_215_084_590_0e-01];
const RB_EMBEDDED: [f64; 4] =
    [3.781_090_314_581_936_9e-01, -9.604_229_221_242_317_8e-02, 5.000_000_000_000_000_0e-01, 2.179_332_607_542_295_0e-01];
const RC2: f64 = RA21;
const RC3: f64 = RA31 + RA32;
const RC4: f64 = RA43;
const R_DENSE: [[f64; 3]; 4] = [
    [1.0564298455794094, -1.3864882699759573, 0.5721822314575016],
    [2.296429974281067, -8.262611700275677, 4.742931142090097],
    [-1.307599564525376, 7.250979895056055, -4.398120075195578],
    [-1.045260255335102, 2.398120075195581, -0.9169932983520199],
];

/// A point the integration reached, with what the step to it left: the
/// state, its derivative and stiff part, the step's dense output.
///
/// Why two of them ([`Integrator`]'s `points`): a trial step writes its end
/// into the one not current and an accepted step makes it current, so that
/// nothing is copied. Returned by value, a trial's 1.8 kB (20 states: the
/// dense output's five rows, the stiff part's four) was copied twice or
/// more per step, about a tenth of a rig run's time in `memmove` (perf,
/// stop 60).
#[derive(Debug, Clone, Copy)]
struct Point<const N: usize> {
    y: [f64; N],
    f: [f64; N],
    stiff: LowRank<N>,
    dense: Dense<N>,
}

/// The current point and the trial's (the other), from [`Integrator`]'s
/// two.
#[inline(always)]
fn split<const N: usize>(points: &mut [Point<N>; 2], second: bool) -> (&Point<N>, &mut Point<N>) {
    let [a, b] = points;
    if second {
        (b, a)
    } else {
        (a, b)
    }
}

/// `y + h sum(a_j k_j)` over the first `n` entries.
#[inline(always)]
fn combine<const N: usize, const K: usize>(n: usize, y: &[f64; N], h: f64, terms: [(f64, &[f64; N]); K]) -> [f64; N] {
    let mut out = *y;
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let mut s = 0.0;
        for (a, k) in terms.iter() {
            s += a * k.get(i).copied().unwrap_or(0.0);
        }
        *o += h * s;
    }
    out
}

/// Weighted RMS norm over the first `n` entries of the error estimate `err`
/// between states `y0` and `y1`.
fn error_norm<const N: usize>(n: usize, atol: &[f64; N], rtol: f64, y0: &[f64; N], y1: &[f64; N], err: &[f64; N]) -> f64 {
    let mut sum = 0.0;
    for (((a, b), e), atol) in y0.iter().zip(y1).zip(err).zip(atol).take(n) {
        let scale = atol + rtol * libm::fabs(*a).max(libm::fabs(*b));
        let r = e / scale;
        sum += r * r;
    }
    libm::sqrt(sum / n.max(1) as f64)
}

/// `sum_i v_i x_i` over the first `n` entries.
#[inline(always)]
fn dot<const N: usize>(n: usize, v: &[f64; N], x: &[f64; N]) -> f64 {
    v.iter().zip(x).take(n).map(|(a, b)| a * b).sum()
}

/// `x -> (I - c U V^T)^-1 x` for the terms `u_j v_j^T` of `W = U V^T`, by
/// the Woodbury formula `x + c U (I - c V^T U)^-1 V^T x`, the small matrix
/// inverted by Cramer's rule (for one term the Sherman-Morrison formula
/// `x + c u (v.x) / (1 - c v.u)`). A singular small matrix gives
/// non-finite values, which the step's error norm rejects.
fn woodbury<const N: usize>(n: usize, terms: &[RankOne<N>], c: f64) -> impl Fn([f64; N]) -> [f64; N] + '_ {
    let term = |j: usize| terms.get(j);
    // m_jk = delta_jk - c v_j.u_k, for j, k < 2 (the rank is at most MAX_RANK).
    let m = |j: usize, k: usize| match (term(j), term(k)) {
        (Some(a), Some(b)) => f64::from(u8::from(j == k)) - c * dot(n, &a.v, &b.u),
        _ => f64::from(u8::from(j == k)),
    };
    let (m00, m01, m10, m11) = (m(0, 0), m(0, 1), m(1, 0), m(1, 1));
    let det = m00 * m11 - m01 * m10;
    move |x: [f64; N]| -> [f64; N] {
        let b = |j: usize| term(j).map_or(0.0, |t| dot(n, &t.v, &x));
        match terms {
            [RankOne { u, .. }] => {
                let s = c * b(0) / m00;
                combine(n, &x, s, [(1.0, u)])
            }
            [RankOne { u: u0, .. }, RankOne { u: u1, .. }] => {
                let (b0, b1) = (b(0), b(1));
                let s0 = c * (m11 * b0 - m01 * b1) / det;
                let s1 = c * (m00 * b1 - m10 * b0) / det;
                combine(n, &x, 1.0, [(s0, u0), (s1, u1)])
            }
            _ => x,
        }
    }
}

/// The adaptive integrator's state: the current point, its derivative, the
/// proposed next step, and the dense output of the last step.
#[derive(Debug, Clone)]
pub struct Integrator<const N: usize> {
    n: usize,
    t: f64,
    /// The current point (`points[1]` where `second`) and the scratch a
    /// trial step writes ([`Point`] says why).
    points: [Point<N>; 2],
    second: bool,
    /// A trial step's end holds its derivative and stiff part (the last
    /// stage of Dormand-Prince's steps).
    trial_has_next: bool,
    h: f64,
    control: Control,
    atol: [f64; N],
    t_prev: f64,
    h_prev: f64,
    stats: Stats,
    /// Error norm of the last accepted step (for the PI step control).
    err_prev: f64,
    /// The spectral radius of the stiff part at the current point, 1/s.
    stiff_rate: f64,
    /// The state of [`StiffMethod::Switching`].
    switching: Switching,
}

/// Weight of the previous step's error in the step-size control.
const PI_BETA: f64 = 0.04;

/// `h rho` up to which a step with a stiff coupling is Dormand-Prince's
/// under [`StiffMethod::Switching`]: its stability region reaches -3.3 on
/// the negative real axis.
const DP_STABLE: f64 = 3.0;
/// `h rho` at which Dormand-Prince's steps are held.
const DP_HOLD: f64 = 2.7;
/// `h rho` from which Dormand-Prince's steps count as set by the stiff
/// modes: near its stability bound its error estimate grows with `h rho`
/// whatever the solution does, so its own proposals rarely reach beyond
/// the bound even where a stiff method could take far longer steps.
const DP_STIFF: f64 = 1.5;
/// `h rho` below which ROS34PW2's steps are no longer worth their lower
/// order: the explicit steps take over. A try of ROS34PW2 starts at twice
/// this.
const STIFF_FLOOR: f64 = 3.3;
/// Explicit steps set by the stiff modes before ROS34PW2 is tried, at
/// first and at most: each try that does not last doubles the wait, so
/// that a stretch where ROS34PW2's steps are no longer than the explicit
/// ones does not pay for a try every few steps.
const RETRY_MIN: u32 = 4;
const RETRY_MAX: u32 = 1024;
/// Accepted ROS34PW2 steps after which a try counts as lasting.
const LASTING: u32 = 8;

/// Where [`StiffMethod::Switching`] is.
#[derive(Debug, Clone, Copy)]
struct Switching {
    /// Dormand-Prince's steps are held stable (else ROS34PW2's proposals
    /// are taken).
    explicit: bool,
    /// Consecutive explicit steps set by the stiff modes.
    limited: u32,
    /// Such steps before ROS34PW2 is tried.
    retry_after: u32,
    /// Accepted ROS34PW2 steps since it was tried.
    stiff_steps: u32,
}

/// The spectral radius of `sum_j u_j v_j^T` over the first `n` entries: that
/// of the small matrix `V^T U`, which has the same nonzero eigenvalues.
fn spectral_radius<const N: usize>(n: usize, terms: &[RankOne<N>]) -> f64 {
    match terms {
        [] => 0.0,
        [a] => libm::fabs(dot(n, &a.v, &a.u)),
        [a, b, ..] => {
            let (m00, m01, m10, m11) = (dot(n, &a.v, &a.u), dot(n, &a.v, &b.u), dot(n, &b.v, &a.u), dot(n, &b.v, &b.u));
            let (tr, det) = (m00 + m11, m00 * m11 - m01 * m10);
            let disc = tr * tr - 4.0 * det;
            if disc >= 0.0 {
                let r = libm::sqrt(disc);
                libm::fabs(0.5 * (tr + r)).max(libm::fabs(0.5 * (tr - r)))
            } else {
                // A complex pair: |mu|^2 = det.
                libm::sqrt(det)
            }
        }
    }
}

impl<const N: usize> Integrator<N> {
    /// Starts at `(t_s, y)` with a first trial step `h_s`.
    pub fn new<S: AdaptiveSystem<N> + ?Sized>(system: &S, t_s: f64, y: [f64; N], h_s: f64, control: Control) -> Result<Self> {
        let (f, stiff) = system.derivatives_with_stiff_part(t_s, &y)?;
        let n = system.integrated_len().min(N);
        let point = Point { y, f, stiff, dense: Dense::Rosenbrock([y, [0.0; N], [0.0; N], [0.0; N]]) };
        Ok(Integrator {
            n,
            t: t_s,
            points: [point, point],
            second: false,
            trial_has_next: false,
            // max then min rather than clamp: no panic on a bad bound.
            h: h_s.max(control.min_step_s).min(control.max_dt_s),
            control,
            atol: system.abs_tolerance(),
            t_prev: t_s,
            h_prev: 0.0,
            stats: Stats { evaluations: 1, ..Stats::default() },
            err_prev: 1e-4,
            stiff_rate: spectral_radius(n, stiff.terms()),
            switching: Switching { explicit: true, limited: 0, retry_after: RETRY_MIN, stiff_steps: 0 },
        })
    }

    /// Restarts at the current point after the system changed
    /// discontinuously (e.g. a valve switched), keeping the step size.
    pub fn restart<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S) -> Result<()> {
        let (f, stiff) = system.derivatives_with_stiff_part(self.t, &self.point().y)?;
        let now = self.point_mut();
        now.f = f;
        now.stiff = stiff;
        now.dense = Dense::Rosenbrock([now.y, [0.0; N], [0.0; N], [0.0; N]]);
        self.stiff_rate = spectral_radius(self.n, stiff.terms());
        self.stats.evaluations += 1;
        self.t_prev = self.t;
        self.h_prev = 0.0;
        Ok(())
    }

    /// The current point.
    #[inline(always)]
    fn point(&self) -> &Point<N> {
        let [a, b] = &self.points;
        if self.second {
            b
        } else {
            a
        }
    }

    /// The current point, to change.
    #[inline(always)]
    fn point_mut(&mut self) -> &mut Point<N> {
        let [a, b] = &mut self.points;
        if self.second {
            b
        } else {
            a
        }
    }

    /// The trial step's end becomes the current point, at `t1_s` after a
    /// step of `h_s` (its derivative and stiff part set).
    #[inline(always)]
    fn adopt(&mut self, t1_s: f64, h_s: f64) {
        self.second = !self.second;
        self.t_prev = self.t;
        self.h_prev = h_s;
        self.t = t1_s;
        self.stiff_rate = spectral_radius(self.n, self.point().stiff.terms());
        self.stats.accepted += 1;
    }

    /// Sets the trial's end's derivative and stiff part where the step did
    /// not leave them (a Rosenbrock step) or moved its state (projected);
    /// counts the evaluation.
    fn complete_trial<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S, t1_s: f64, projected: bool) -> Result<()> {
        if self.trial_has_next && !projected {
            return Ok(());
        }
        self.stats.evaluations += 1;
        let (_, next) = split(&mut self.points, self.second);
        let (f, stiff) = system.derivatives_with_stiff_part(t1_s, &next.y)?;
        next.f = f;
        next.stiff = stiff;
        Ok(())
    }

    /// Current time, s.
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Current state.
    pub fn y(&self) -> &[f64; N] {
        &self.point().y
    }

    /// Derivative at the current state.
    pub fn derivative(&self) -> &[f64; N] {
        &self.point().f
    }

    /// Work done so far.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// The next step the controller proposes, s.
    pub fn proposed_step_s(&self) -> f64 {
        self.h
    }

    /// Caps the next step at `h_max_s` (e.g. where the input starts to
    /// change, which the error estimate of a step that jumps over it
    /// cannot see).
    pub fn limit_step(&mut self, h_max_s: f64) {
        if h_max_s < self.h {
            self.h = h_max_s.max(self.control.min_step_s);
        }
    }

    /// The solution at `t_s` within the last accepted step (from its
    /// dense output; the current state at its end).
    pub fn dense(&self, t_s: f64) -> [f64; N] {
        let now = self.point();
        if self.h_prev <= 0.0 || t_s >= self.t {
            return now.y;
        }
        let theta = ((t_s - self.t_prev) / self.h_prev).clamp(0.0, 1.0);
        let mut out = now.y;
        match &now.dense {
            Dense::DormandPrince([r1, r2, r3, r4, r5]) => {
                let one = 1.0 - theta;
                for (i, o) in out.iter_mut().enumerate().take(self.n) {
                    let g = |r: &[f64; N]| r.get(i).copied().unwrap_or(0.0);
                    *o = g(r1) + theta * (g(r2) + one * (g(r3) + theta * (g(r4) + one * g(r5))));
                }
            }
            Dense::Rosenbrock([y0, c1, c2, c3]) => {
                for (i, o) in out.iter_mut().enumerate().take(self.n) {
                    let g = |r: &[f64; N]| r.get(i).copied().unwrap_or(0.0);
                    *o = g(y0) + theta * (g(c1) + theta * (g(c2) + theta * g(c3)));
                }
            }
        }
        out
    }

    /// Takes one step to exactly `t_end_s` and accepts it whatever its error
    /// estimate: for replaying the steps of an error-controlled run (a
    /// finite-difference derivative of the solution with respect to a
    /// parameter must not see the step-size selection switch).
    pub fn step_exact<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S, t_end_s: f64) -> Result<Method> {
        let h = t_end_s - self.t;
        if !(h > 0.0) {
            return Err(Error::OutOfRange { name: "step end (replayed)", value: t_end_s, min: self.t, max: f64::MAX });
        }
        let method = self.method_for(h);
        match method {
            Method::DormandPrince => self.try_dormand_prince(system, h)?,
            Method::Rosenbrock => self.try_rosenbrock(system, h)?,
        };
        let (_, next) = split(&mut self.points, self.second);
        let projected = system.project(t_end_s, &mut next.y);
        system.check(t_end_s, &next.y)?;
        self.complete_trial(system, t_end_s, projected)?;
        self.adopt(t_end_s, h);
        if method == Method::Rosenbrock {
            self.stats.rosenbrock += 1;
        }
        Ok(method)
    }

    /// The method of a step of size `h` from the current point.
    fn method_for(&self, h: f64) -> Method {
        if self.point().stiff.rank() == 0 {
            return Method::DormandPrince;
        }
        match self.control.stiff {
            StiffMethod::RosenbrockW => Method::Rosenbrock,
            StiffMethod::Switching if h * self.stiff_rate <= DP_STABLE => Method::DormandPrince,
            StiffMethod::Switching => Method::Rosenbrock,
        }
    }

    /// The longest step Dormand-Prince takes while its steps are held
    /// stable, s (infinite when they are not held).
    fn hold_s(&self) -> f64 {
        let holding = self.control.stiff == StiffMethod::Switching && self.switching.explicit && self.point().stiff.rank() > 0;
        if holding && self.stiff_rate > 0.0 {
            DP_HOLD / self.stiff_rate
        } else {
            f64::INFINITY
        }
    }

    /// Updates [`StiffMethod::Switching`] after an accepted step of `h`
    /// by `method`, the proposed next step already set: explicit steps set
    /// by the stiff modes try ROS34PW2 at longer steps; where ROS34PW2's
    /// steps are no longer than what the explicit ones can stably take,
    /// back to those.
    fn switch_after(&mut self, method: Method, h: f64) {
        if self.control.stiff != StiffMethod::Switching || self.point().stiff.rank() == 0 {
            return;
        }
        let s = &mut self.switching;
        match (s.explicit, method) {
            (true, _) => {
                s.limited = if h * self.stiff_rate >= DP_STIFF { s.limited + 1 } else { 0 };
                if s.limited >= s.retry_after && self.stiff_rate > 0.0 {
                    *s = Switching { explicit: false, limited: 0, stiff_steps: 0, ..*s };
                    self.h = self.h.max(2.0 * STIFF_FLOOR / self.stiff_rate);
                    self.stats.switches += 1;
                }
            }
            (false, Method::Rosenbrock) => {
                s.stiff_steps += 1;
                if self.h * self.stiff_rate < STIFF_FLOOR {
                    self.leave_stiff();
                }
            }
            // ROS34PW2's error control took the step down to where
            // Dormand-Prince took it.
            (false, Method::DormandPrince) => self.leave_stiff(),
        }
    }

    /// Back to held explicit steps.
    fn leave_stiff(&mut self) {
        let s = &mut self.switching;
        let retry_after = if s.stiff_steps >= LASTING { RETRY_MIN } else { (2 * s.retry_after).min(RETRY_MAX) };
        *s = Switching { explicit: true, limited: 0, retry_after, stiff_steps: 0 };
        self.stats.switches += 1;
    }

    /// Takes one accepted step that ends at or before `t_end_s`; returns the
    /// method that took it. Fails if the step size fell below the minimum
    /// (the error names what went wrong at the last attempt).
    pub fn step<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S, t_end_s: f64) -> Result<Method> {
        let mut last_error = Error::NoConvergence { what: "adaptive step (step size below the minimum)", target: self.t };
        loop {
            let remaining = t_end_s - self.t;
            let mut h = self.h.min(self.control.max_dt_s);
            h = h.min(self.hold_s());
            let wanted = h;
            // Land on the end exactly, without leaving a sliver.
            if h >= remaining * (1.0 - 1e-12) {
                h = remaining;
            } else if h > 0.5 * remaining {
                h = 0.5 * remaining;
            }
            if !(h >= self.control.min_step_s) {
                return Err(last_error);
            }
            // The step is the difference of its end and start as stored, so
            // that a replay (Integrator::step_exact) takes the very same one.
            let t1 = if h == remaining { t_end_s } else { self.t + h };
            let h = t1 - self.t;
            // A step cut short to land on the end says nothing about the
            // steps the methods could take.
            let landing = h < wanted * (1.0 - 1e-12);
            let method = self.method_for(h);
            let attempt = match method {
                Method::DormandPrince => self.try_dormand_prince(system, h),
                Method::Rosenbrock => self.try_rosenbrock(system, h),
            };
            // An exponent of 1/(q+1) for an error estimate of order q, less
            // the PI controller's share (Gustafsson; as in Hairer's dopri5,
            // beta = 0.04): the previous step's error damps the step-size
            // oscillation that makes many rejections.
            // ROS34PW2's steps are mostly limited by accuracy on smooth
            // stretches, where the I controller is as good (measured: 3-6 %
            // fewer evaluations than with PI), Dormand-Prince's by the
            // damper's kinks, where PI halves the rejections.
            let beta = match method {
                Method::DormandPrince => PI_BETA,
                Method::Rosenbrock => 0.0,
            };
            let exponent = match method {
                Method::DormandPrince => 0.2,
                Method::Rosenbrock => 1.0 / 3.0,
            } - 0.75 * beta;
            match attempt {
                Ok(err) if err <= 1.0 => {
                    let (_, next) = split(&mut self.points, self.second);
                    let projected = system.project(t1, &mut next.y);
                    if let Err(e) = system.check(t1, &next.y) {
                        last_error = e;
                        self.h = 0.25 * h;
                        self.stats.rejected += 1;
                        continue;
                    }
                    // Dormand-Prince's last stage is the derivative at the
                    // new point (unless the projection moved it).
                    if let Err(e) = self.complete_trial(system, t1, projected) {
                        last_error = e;
                        self.h = 0.25 * h;
                        self.stats.rejected += 1;
                        continue;
                    }
                    self.adopt(t1, t1 - self.t);
                    if method == Method::Rosenbrock {
                        self.stats.rosenbrock += 1;
                    }
                    // err^-exponent err_prev^beta as one exp of logs: two
                    // of fdlibm's pow were 4 % of a run (perf, stop 60);
                    // err_prev >= 1e-4, err > 0, so both logs are finite.
                    let factor = if err > 0.0 {
                        0.9 * libm::exp(beta * libm::log(self.err_prev) - exponent * libm::log(err))
                    } else {
                        5.0
                    };
                    self.err_prev = err.max(1e-4);
                    self.h = h * factor.clamp(0.2, 5.0);
                    if !landing {
                        self.switch_after(method, h);
                    }
                    return Ok(method);
                }
                Ok(err) => {
                    self.stats.rejected += 1;
                    let factor = if err.is_finite() { 0.9 * libm::exp(-exponent * libm::log(err)) } else { 0.25 };
                    self.h = h * factor.clamp(0.1, 0.9);
                }
                Err(e) => {
                    // A stage left the model's valid region: a smaller step.
                    last_error = e;
                    self.stats.rejected += 1;
                    self.h = 0.25 * h;
                }
            }
        }
    }
}

impl<const N: usize> Integrator<N> {
    /// One Dormand-Prince 5(4) trial step of size `h`, its end written to
    /// the trial point (with its derivative and stiff part: the last
    /// stage); its error estimate in the weighted RMS norm (accepted when
    /// at most 1).
    fn try_dormand_prince<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S, h: f64) -> Result<f64> {
        self.trial_has_next = false;
        let (n, t) = (self.n, self.t);
        let (now, next) = split(&mut self.points, self.second);
        let (y, k1) = (&now.y, &now.f);
        let k2 = system.derivatives(t + C2 * h, &combine(n, y, h, [(A21, k1)]))?;
        let k3 = system.derivatives(t + C3 * h, &combine(n, y, h, [(A31, k1), (A32, &k2)]))?;
        let k4 = system.derivatives(t + C4 * h, &combine(n, y, h, [(A41, k1), (A42, &k2), (A43, &k3)]))?;
        let k5 = system.derivatives(t + C5 * h, &combine(n, y, h, [(A51, k1), (A52, &k2), (A53, &k3), (A54, &k4)]))?;
        let k6 = system.derivatives(t + h, &combine(n, y, h, [(A61, k1), (A62, &k2), (A63, &k3), (A64, &k4), (A65, &k5)]))?;
        next.y = combine(n, y, h, [(A71, k1), (A73, &k3), (A74, &k4), (A75, &k5), (A76, &k6)]);
        self.stats.evaluations += 5;
        let (k7, stiff) = system.derivatives_with_stiff_part(t + h, &next.y)?;
        self.stats.evaluations += 1;
        let zero = [0.0; N];
        let err = combine(n, &zero, h, [(E1, k1), (E3, &k3), (E4, &k4), (E5, &k5), (E6, &k6), (E7, &k7)]);
        let err = error_norm(n, &self.atol, self.control.rtol, y, &next.y, &err);
        // Continuous extension: r1 = y0, r2 = y1 - y0, r3 = h k1 - r2,
        // r4 = r2 - h k7 - r3, r5 = h sum(d_i k_i); written in place.
        let r5 = combine(n, &zero, h, [(D1, k1), (D3, &k3), (D4, &k4), (D5, &k5), (D6, &k6), (D7, &k7)]);
        if !matches!(next.dense, Dense::DormandPrince(_)) {
            next.dense = Dense::DormandPrince([zero; 5]);
        }
        if let Dense::DormandPrince(r) = &mut next.dense {
            r[0] = *y;
            for i in 0..n {
                let g = |v: &[f64; N]| v.get(i).copied().unwrap_or(0.0);
                let r2 = g(&next.y) - g(y);
                let r3 = h * g(k1) - r2;
                let r4 = r2 - h * g(&k7) - r3;
                for (slot, value) in r.iter_mut().skip(1).zip([r2, r3, r4, g(&r5)]) {
                    if let Some(x) = slot.get_mut(i) {
                        *x = value;
                    }
                }
            }
        }
        next.f = k7;
        next.stiff = stiff;
        self.trial_has_next = true;
        Ok(err)
    }

    /// One ROS34PW2 trial step of size `h`, linearly implicit in the
    /// stiff part at the step's start, its end written to the trial point
    /// (without its derivative); its error estimate.
    fn try_rosenbrock<S: AdaptiveSystem<N> + ?Sized>(&mut self, system: &S, h: f64) -> Result<f64> {
        self.trial_has_next = false;
        let (n, t) = (self.n, self.t);
        let (now, next) = split(&mut self.points, self.second);
        let (y, f1) = (&now.y, &now.f);
        let zero = [0.0; N];
        let terms = now.stiff.terms();
        let solve = woodbury(n, terms, h * GAMMA);
        // Stage i: (I - h gamma W) k_i = h f(Y_i) + h W sum_j gamma_ij k_j,
        // W = sum_j u_j v_j^T, Y_i = y + sum_j alpha_ij k_j.
        let stage = |f: &[f64; N], g: [f64; N]| -> [f64; N] {
            let mut r = combine(n, &zero, h, [(1.0, f)]);
            for RankOne { u, v } in terms {
                let s = h * dot(n, v, &g);
                r = combine(n, &r, s, [(1.0, u)]);
            }
            solve(r)
        };
        let k1 = stage(f1, zero);
        let f2 = system.derivatives(t + RC2 * h, &combine(n, y, 1.0, [(RA21, &k1)]))?;
        let k2 = stage(&f2, combine(n, &zero, 1.0, [(RG21, &k1)]));
        let f3 = system.derivatives(t + RC3 * h, &combine(n, y, 1.0, [(RA31, &k1), (RA32, &k2)]))?;
        let k3 = stage(&f3, combine(n, &zero, 1.0, [(RG31, &k1), (RG32, &k2)]));
        let f4 = system.derivatives(t + RC4 * h, &combine(n, y, 1.0, [(RA43, &k3)]))?;
        let k4 = stage(&f4, combine(n, &zero, 1.0, [(RG41, &k1), (RG42, &k2), (RG43, &k3)]));
        self.stats.evaluations += 3;
        let [b1, b2, b3, b4] = RB;
        let [e1, e2, e3, e4] = RB_EMBEDDED;
        next.y = combine(n, y, 1.0, [(b1, &k1), (b2, &k2), (b3, &k3), (b4, &k4)]);
        let err = combine(n, &zero, 1.0, [(b1 - e1, &k1), (b2 - e2, &k2), (b3 - e3, &k3), (b4 - e4, &k4)]);
        let err = error_norm(n, &self.atol, self.control.rtol, y, &next.y, &err);
        let [d1, d2, d3, d4] = R_DENSE;
        let power = |p: usize| {
            let c = |d: [f64; 3]| d.get(p).copied().unwrap_or(0.0);
            combine(n, &zero, 1.0, [(c(d1), &k1), (c(d2), &k2), (c(d3), &k3), (c(d4), &k4)])
        };
        next.dense = Dense::Rosenbrock([*y, power(0), power(1), power(2)]);
        Ok(err)
    }
}
