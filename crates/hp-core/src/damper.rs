//! The damper pack and the valve orifices.
//!
//! The damper pack between the strut and accumulator S is an orifice with a
//! bleed below a blow-off pressure (the sealing washer on Belleville
//! springs), and opens along a linear slope above it. Valve 5 open bypasses
//! the pack; rather than a second parallel orifice solved for a common
//! pressure drop, each valve state has its own measured-style curve, which is
//! how damper characteristics are specified and what a rig identifies.

use crate::error::{check_range, Result};

/// One branch of the damper characteristic: pressure drop over flow
/// magnitude `q` (m^3/s): `R q + K q^2` below the blow-off pressure, then
/// `p_b + S (q - q_b)` above it.
///
/// With a `blowoff_knee` `k > 0` the knee is smooth: the sharp curve is
/// `g(q - r(q)) + S r(q)` with `g(q) = R q + K q |q|` and the ramp
/// `r(q) = max(q - q_b, 0)`; the smooth one rounds the ramp with the
/// hyperbola `h(x) = (x + sqrt(x^2 + w^2)) / 2`, `w = k q_b`, less its
/// tangent at no flow and rescaled to unit slope:
/// `r(q) = (h(q - q_b) - h(-q_b) - h'(-q_b) q) / (1 - h'(-q_b))`.
/// Its slope `g'(1 - r') + S r'` is a positive blend of the orifice's and
/// the blow-off's slopes (`0 <= r' < 1`, `h` being convex), so the curve
/// stays monotone for any parameters: what a fit may try. `r` and `r'` are
/// zero at no flow, so the knee leaves the low-speed curve `R q + K q^2`
/// alone: without the tangent removed the hyperbola's tail reached down to
/// zero flow and added `2 K h(-q_b) + (S - R) h'(-q_b)` to the slope there,
/// a linear damping the bleed could not take back (about half the bleed's
/// own on the foreign rig's fits, docs/foreign-rig.md). Far above the knee
/// it is the sharp curve with the knee moved to `q_b (1 + h(-q_b)/q_b) /
/// (1 - h'(-q_b))` (1.8 `q_b` at `k = 1.5`). `k = 0` takes the sharp
/// curve's own code path, so existing characteristics are unchanged bit
/// for bit.
///
/// A second blow-off stage (`blowoff2_pa > 0`): a second valve that opens
/// at `p_b2 > p_b` changes the slope from `S` to `S2`, as a bypass or a
/// second washer stack in parallel does (each lifts at its own pressure).
/// The first stage's excess flow `r1 = r(q)` is ramped again, `r2 =
/// rho(r1)` with `rho` the same rounded ramp at `x_2 = (p_b2 - p_b) / S`
/// (width `k x_2`): `dp = g(q - r1) + S (r1 - r2) + S2 r2`. Since
/// `0 <= r2' = rho'(r1) r1' <= r1' < 1`, the slope
/// `g'(1 - r1') + S (r1' - r2') + S2 r2'` is a positive blend again: the
/// curve stays monotone for any `S2 > 0`, above or below `S`. Sharp, it is
/// `p_b2 + S2 (q - q_b - x_2)` above the second knee. `blowoff2_pa = 0`
/// (no second stage) keeps the one-stage code paths, bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperCurve {
    /// Laminar (bleed) coefficient R, Pa s/m^3.
    pub bleed_pa_s_per_m3: f64,
    /// Turbulent (orifice) coefficient K, Pa s^2/m^6.
    pub orifice_pa_s2_per_m6: f64,
    /// Blow-off pressure drop p_b, Pa.
    pub blowoff_pa: f64,
    /// Slope above blow-off S, Pa s/m^3.
    pub blowoff_slope_pa_s_per_m3: f64,
    /// Width of the blow-off knee as a fraction of the blow-off flow `q_b`
    /// (0 = the sharp knee; about 0.3-1 for a washer that lifts
    /// progressively).
    pub blowoff_knee: f64,
    /// Pressure drop p_b2 at which a second blow-off stage opens, Pa (above
    /// `blowoff_pa`; 0 = no second stage).
    pub blowoff2_pa: f64,
    /// Slope above the second blow-off S2, Pa s/m^3 (used only with a
    /// second stage).
    pub blowoff2_slope_pa_s_per_m3: f64,
    /// Laminar conductance G of a bleed in parallel with the orifice,
    /// m^3/(s Pa) (0 = none: the bleed `R` in series only).
    pub bleed_parallel_m3_per_s_pa: f64,
}

impl DamperCurve {
    /// The curve that gives the strut force `F(v) = c1 v + c2 v^2` up to the
    /// blow-off force, then `F_b + slope (v - v_b)`, for strut velocity `v`
    /// and piston area `area_m2` (force = area x pressure drop, flow = area x
    /// velocity): how damper characteristics are usually specified.
    ///
    /// ```
    /// use hp_core::damper::DamperCurve;
    /// let c = DamperCurve::from_strut(2e-3, 12_000.0, 64_000.0, 7_000.0, 16_000.0);
    /// let v = 0.1;
    /// let force = 2e-3 * c.pressure_drop_pa(2e-3 * v);
    /// assert!((force - (12_000.0 * v + 64_000.0 * v * v)).abs() < 1e-6);
    /// ```
    pub fn from_strut(area_m2: f64, c1_n_s_per_m: f64, c2_n_s2_per_m2: f64, blowoff_n: f64, slope_n_s_per_m: f64) -> Self {
        DamperCurve {
            bleed_pa_s_per_m3: c1_n_s_per_m / (area_m2 * area_m2),
            orifice_pa_s2_per_m6: c2_n_s2_per_m2 / (area_m2 * area_m2 * area_m2),
            blowoff_pa: blowoff_n / area_m2,
            blowoff_slope_pa_s_per_m3: slope_n_s_per_m / (area_m2 * area_m2),
            blowoff_knee: 0.0,
            blowoff2_pa: 0.0,
            blowoff2_slope_pa_s_per_m3: 0.0,
            bleed_parallel_m3_per_s_pa: 0.0,
        }
    }

    /// Checks every coefficient is finite and within physical bounds.
    pub fn validate(&self) -> Result<()> {
        check_range("bleed_pa_s_per_m3", self.bleed_pa_s_per_m3, 0.0, 1e14)?;
        check_range("orifice_pa_s2_per_m6", self.orifice_pa_s2_per_m6, 0.0, 1e18)?;
        check_range("blowoff_pa", self.blowoff_pa, 0.0, 1e9)?;
        check_range("blowoff_slope_pa_s_per_m3", self.blowoff_slope_pa_s_per_m3, 1e3, 1e14)?;
        crate::ranges::DAMPER_BLOWOFF_KNEE.check(self.blowoff_knee)?;
        check_range("bleed_parallel_m3_per_s_pa", self.bleed_parallel_m3_per_s_pa, 0.0, 1e-3)?;
        if self.bleed_pa_s_per_m3 == 0.0 && self.orifice_pa_s2_per_m6 == 0.0 {
            // A curve with no resistance below blow-off cannot be inverted.
            check_range("bleed_pa_s_per_m3", self.bleed_pa_s_per_m3, 1e3, 1e14)?;
        }
        if self.blowoff2_pa != 0.0 {
            // Strictly above the first stage: at p_b itself the second
            // knee's ramp would have no width to round over.
            check_range("blowoff2_pa", self.blowoff2_pa, self.blowoff_pa * (1.0 + 1e-6) + 1e-3, 1e9)?;
            check_range("blowoff2_slope_pa_s_per_m3", self.blowoff2_slope_pa_s_per_m3, 1e3, 1e14)?;
        }
        Ok(())
    }

    /// True when a second blow-off stage is set.
    #[inline]
    fn staged(&self) -> bool {
        self.blowoff2_pa > 0.0
    }

    /// True when the curve takes the smooth code path: a rounded knee, or a
    /// parallel bleed (whose knee of 0 that path gives exactly).
    #[inline]
    fn smooth(&self) -> bool {
        self.blowoff_knee > 0.0 || self.bleed_parallel_m3_per_s_pa > 0.0
    }

    /// Flow at which the orifice branch reaches the blow-off pressure, m^3/s.
    fn blowoff_flow_m3_s(&self) -> f64 {
        self.orifice_flow_m3_s(self.blowoff_pa)
    }

    /// Flow the branch below blow-off (bleed and orifice) passes at a
    /// pressure drop `dp_pa >= 0`, m^3/s.
    fn orifice_flow_m3_s(&self, dp_pa: f64) -> f64 {
        solve_quadratic_flow(self.bleed_pa_s_per_m3, self.orifice_pa_s2_per_m6, dp_pa) + self.bleed_parallel_m3_per_s_pa * libm::fmax(dp_pa, 0.0)
    }

    /// The branch below blow-off `g(q)` and its slope, at a flow magnitude
    /// `q >= 0` (see the type's description).
    #[inline]
    fn below_blowoff(&self, q: f64) -> (f64, f64) {
        let (r, k, g) = (self.bleed_pa_s_per_m3, self.orifice_pa_s2_per_m6, self.bleed_parallel_m3_per_s_pa);
        if g > 0.0 {
            let b = 1.0 + r * g;
            let y = 2.0 * q / (b + sqrt(b * b + 4.0 * k * g * q));
            (y * (r + k * y), (r + 2.0 * k * y) / (b + 2.0 * k * g * y))
        } else {
            (q * (r + k * q), r + 2.0 * k * q)
        }
    }

    /// Pressure drop for a flow magnitude `q_m3_s >= 0`, Pa.
    pub fn pressure_drop_pa(&self, q_m3_s: f64) -> f64 {
        self.at(&self.knees(), q_m3_s).0
    }

    /// `d(dp)/dq` of [`DamperCurve::pressure_drop_pa`] at a flow magnitude
    /// `q_m3_s >= 0`, Pa s/m^3 (the sharp knee's slope from below at the
    /// knee itself).
    pub fn pressure_drop_slope_pa_s_per_m3(&self, q_m3_s: f64) -> f64 {
        self.at(&self.knees(), q_m3_s).1
    }

    /// The pressure drop and its slope at a flow magnitude `q_m3_s >= 0`,
    /// with the curve's [`Knees`] (its flow-independent parts): the
    /// two-stage curve, the smooth one or the sharp one, as the curve is
    /// set (see the type's description).
    #[inline]
    fn at(&self, k: &Knees, q_m3_s: f64) -> (f64, f64) {
        if self.staged() {
            return self.staged_at(k, q_m3_s);
        }
        if self.smooth() {
            return self.smooth_at(&k.first, q_m3_s);
        }
        let (orifice, slope) = self.below_blowoff(q_m3_s);
        if orifice <= self.blowoff_pa {
            (orifice, slope)
        } else {
            // `k.first.q_b` is the blow-off flow ([`DamperCurve::first_knee`]).
            (self.blowoff_pa + self.blowoff_slope_pa_s_per_m3 * (q_m3_s - k.first.q_b), self.blowoff_slope_pa_s_per_m3)
        }
    }

    /// [`DamperCurve::below_blowoff`] odd in `q` (the ramp may leave the
    /// orifice's share a rounding error below zero).
    #[inline]
    fn below_blowoff_signed(&self, q: f64) -> (f64, f64) {
        let (dp, slope) = self.below_blowoff(libm::fabs(q));
        (libm::copysign(dp, q), slope)
    }

    /// The first blow-off's ramp: with the second's ([`DamperCurve::knees`])
    /// what the curve needs that does not depend on the flow, computed once
    /// per curve ([`PreparedDamper`]) or per inversion, each in the same
    /// expression as at every evaluation before (stop 61), so the curve is
    /// the same to the last bit.
    fn first_knee(&self) -> Ramp {
        let q_b = self.blowoff_flow_m3_s();
        Ramp::new(q_b, self.blowoff_knee * q_b)
    }

    /// The curve's flow-independent parts: both blow-offs' ramps (the
    /// second's unused without a second stage).
    fn knees(&self) -> Knees {
        let x_2 = (self.blowoff2_pa - self.blowoff_pa) / self.blowoff_slope_pa_s_per_m3;
        Knees { first: self.first_knee(), second: Ramp::new(x_2, self.blowoff_knee * x_2) }
    }

    /// The smooth-knee curve (see the type's description) and its slope
    /// `d(dp)/dq`, at flow `q_m3_s >= 0`, with its first knee.
    #[inline]
    fn smooth_at(&self, first: &Ramp, q_m3_s: f64) -> (f64, f64) {
        let s = self.blowoff_slope_pa_s_per_m3;
        let (ramp_q, ramp_slope) = first.at(q_m3_s);
        let (g, g_slope) = self.below_blowoff_signed(q_m3_s - ramp_q);
        (g + s * ramp_q, g_slope * (1.0 - ramp_slope) + s * ramp_slope)
    }

    /// The two-stage curve (see the type's description) and its slope, at
    /// flow `q_m3_s >= 0`, with its [`Knees`]; a knee of 0 gives the sharp
    /// ramps (the rounded ramp's formula is exact at zero width).
    #[inline]
    fn staged_at(&self, k: &Knees, q_m3_s: f64) -> (f64, f64) {
        let (s, s2) = (self.blowoff_slope_pa_s_per_m3, self.blowoff2_slope_pa_s_per_m3);
        let (r1, r1_slope) = k.first.at(q_m3_s);
        let (r2, rho_slope) = k.second.at(r1);
        let r2_slope = rho_slope * r1_slope;
        let (g, g_slope) = self.below_blowoff_signed(q_m3_s - r1);
        (g + s * (r1 - r2) + s2 * r2, g_slope * (1.0 - r1_slope) + s * (r1_slope - r2_slope) + s2 * r2_slope)
    }

    /// Flow magnitude for a pressure drop `dp_pa >= 0`, m^3/s (the inverse of
    /// [`DamperCurve::pressure_drop_pa`]).
    ///
    /// ```
    /// use hp_core::damper::DamperCurve;
    /// let mut c = DamperCurve::from_strut(2e-3, 12_000.0, 64_000.0, 7_000.0, 16_000.0);
    /// c.blowoff_knee = 0.5;
    /// for q in [1e-6, 1e-4, 3e-4, 1e-3, 5e-3] {
    ///     let back = c.flow_m3_s(c.pressure_drop_pa(q));
    ///     assert!((back - q).abs() < 1e-12 * q.max(1e-3));
    /// }
    /// ```
    pub fn flow_m3_s(&self, dp_pa: f64) -> f64 {
        self.flow_at(&self.knees(), dp_pa)
    }

    /// [`DamperCurve::flow_m3_s`] with the curve's [`Knees`].
    fn flow_at(&self, k: &Knees, dp_pa: f64) -> f64 {
        if self.staged() {
            return self.bracketed_flow_m3_s(k.first.q_b, dp_pa, |q| self.staged_at(k, q));
        }
        if self.smooth() {
            return self.bracketed_flow_m3_s(k.first.q_b, dp_pa, |q| self.smooth_at(&k.first, q));
        }
        if dp_pa <= self.blowoff_pa {
            self.orifice_flow_m3_s(dp_pa)
        } else {
            k.first.q_b + (dp_pa - self.blowoff_pa) / self.blowoff_slope_pa_s_per_m3
        }
    }

    /// Inverse of a smooth curve `curve(q) = (dp, d(dp)/dq)`: Newton steps
    /// kept inside a bracket that bisection shrinks when Newton would leave
    /// it or would not halve the step before last (the curve is monotone,
    /// so the bracket always holds the root). The second rule is
    /// Numerical Recipes' `rtsafe`: without it Newton can bounce between
    /// the two ends of a bracket with a sharp second stage inside (a flat
    /// `S2` far above a steep orifice), each step staying inside and the
    /// bracket shrinking by a few per cent, and after its iterations hand
    /// back a flow 3.5 x the root's (a fitted damper, docs/foreign-rig.md).
    fn bracketed_flow_m3_s(&self, blowoff_flow_m3_s: f64, dp_pa: f64, curve: impl Fn(f64) -> (f64, f64)) -> f64 {
        if dp_pa <= 0.0 {
            return 0.0;
        }
        let mut lo = 0.0;
        // A first guess from both limbs; the smooth curve can lie below it
        // (the knee's offset), so double the upper end until it brackets.
        let mut hi = blowoff_flow_m3_s + dp_pa / self.slowest_slope_pa_s_per_m3() + self.orifice_flow_m3_s(dp_pa);
        for _ in 0..64 {
            if curve(hi).0 >= dp_pa {
                break;
            }
            lo = hi;
            hi *= 2.0;
        }
        let mut q = 0.5 * (lo + hi);
        // The last two steps' lengths (as `rtsafe`'s `dx` and `dxold`).
        let (mut step, mut step_before) = (hi - lo, hi - lo);
        for _ in 0..200 {
            let (f, slope) = curve(q);
            let err = f - dp_pa;
            if libm::fabs(err) <= 1e-14 * dp_pa || hi - lo <= 1e-15 * hi {
                break;
            }
            if err > 0.0 {
                hi = q;
            } else {
                lo = q;
            }
            let newton = if slope > 0.0 { q - err / slope } else { f64::NAN };
            let converging = libm::fabs(newton - q) <= 0.5 * libm::fabs(step_before);
            step_before = step;
            if newton > lo && newton < hi && converging {
                step = newton - q;
                q = newton;
            } else {
                step = 0.5 * (hi - lo);
                q = lo + step;
            }
        }
        q
    }

    /// The smaller of the blow-off slopes in use (the first guess of the
    /// inverse's bracket).
    fn slowest_slope_pa_s_per_m3(&self) -> f64 {
        if self.staged() {
            self.blowoff_slope_pa_s_per_m3.min(self.blowoff2_slope_pa_s_per_m3)
        } else {
            self.blowoff_slope_pa_s_per_m3
        }
    }
}

/// The ramp `max(q - q_b, 0)` rounded by the hyperbola of width `w` less its
/// tangent at no flow, rescaled to unit slope (see [`DamperCurve`]), and
/// its slope, at `q >= 0`. With `a = q - q_b`, `b = -q_b`, `s_a = sqrt(a^2 +
/// w^2)`, `s_b` likewise, in forms free of the cancellation near `q = 0`
/// (where both are O(q^2) and O(q) differences of O(q) terms):
///   `r  = q^2 (s_a s_b + w^2 + q_b (q - q_b)) / ((s_a + s_b)^2 (s_b + q_b))`
///   `r' = q (s_b + q_b (q - 2 q_b) / (s_a + s_b)) / (s_a (s_b + q_b))`
/// (the first numerator is at least 2 w^2 by Cauchy-Schwarz). Exact at
/// `w = 0`: the sharp ramp and its step. `s_b` does not depend on the
/// flow: computed once per knee ([`Ramp::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ramp {
    q_b: f64,
    w: f64,
    s_b: f64,
}

/// The flow-independent parts of a two-stage curve's knees
/// ([`DamperCurve::knees`]): the first blow-off's ramp over the flow, the
/// second stage's over the first ramp.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Knees {
    first: Ramp,
    second: Ramp,
}

impl Ramp {
    #[inline]
    fn new(q_b: f64, w: f64) -> Self {
        Ramp { q_b, w, s_b: sqrt(q_b * q_b + w * w) }
    }

    /// The ramp and its slope at `q >= 0`.
    #[inline]
    fn at(&self, q: f64) -> (f64, f64) {
        let Ramp { q_b, w, s_b } = *self;
        let a = q - q_b;
        let s_a = sqrt(a * a + w * w);
        let sum = s_a + s_b;
        let den = sum * sum * (s_b + q_b);
        let ramp = if den > 0.0 { q * q * (s_a * s_b + w * w + q_b * a) / den } else { 0.0 };
        let slope_den = s_a * (s_b + q_b);
        let slope = if slope_den > 0.0 && sum > 0.0 { q * (s_b + q_b * (q - 2.0 * q_b) / sum) / slope_den } else { 0.0 };
        (ramp, slope)
    }
}

/// Positive root q of `r q + k q^2 = dp`, in the cancellation-free form.
fn solve_quadratic_flow(r: f64, k: f64, dp: f64) -> f64 {
    if dp <= 0.0 {
        return 0.0;
    }
    let disc = sqrt(r * r + 4.0 * k * dp);
    let denom = r + disc;
    if denom > 0.0 {
        2.0 * dp / denom
    } else {
        0.0
    }
}

/// The two-state damper: a curve per valve-5 state and flow direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damper {
    /// Valve 5 closed (high damping), compression (flow out of the strut).
    pub on_compression: DamperCurve,
    /// Valve 5 closed, rebound (flow into the strut).
    pub on_rebound: DamperCurve,
    /// Valve 5 open (bypass, low damping), compression.
    pub off_compression: DamperCurve,
    /// Valve 5 open, rebound.
    pub off_rebound: DamperCurve,
}

impl Damper {
    /// Checks every curve.
    pub fn validate(&self) -> Result<()> {
        self.on_compression.validate()?;
        self.on_rebound.validate()?;
        self.off_compression.validate()?;
        self.off_rebound.validate()
    }

    /// Signed pressure drop from strut to accumulator for a signed flow out
    /// of the strut `q_m3_s`, with valve 5 open by the fraction
    /// `bypass_open` (0 = closed = damper on, 1 = open), Pa. Each call
    /// prepares the curves' knees: where the damper is evaluated many
    /// times, [`PreparedDamper`] does that once.
    pub fn pressure_drop_pa(&self, q_m3_s: f64, bypass_open: f64) -> f64 {
        PreparedDamper::new(self).pressure_drop_pa(q_m3_s, bypass_open)
    }

    /// `d(dp)/dq` of [`Damper::pressure_drop_pa`], Pa s/m^3.
    pub fn pressure_drop_slope_pa_s_per_m3(&self, q_m3_s: f64, bypass_open: f64) -> f64 {
        PreparedDamper::new(self).pressure_drop_slope_pa_s_per_m3(q_m3_s, bypass_open)
    }

    /// Signed flow out of the strut that a signed pressure drop `dp_pa`
    /// (strut minus accumulator) drives, m^3/s: the inverse of
    /// [`Damper::pressure_drop_pa`]. Used when the strut cavitates (its
    /// pressure is then pinned at the vapour pressure and the flow is what
    /// the pack passes) and when oil compliance makes the strut pressure a
    /// state.
    pub fn flow_m3_s(&self, dp_pa: f64, bypass_open: f64) -> f64 {
        PreparedDamper::new(self).flow_m3_s(dp_pa, bypass_open)
    }
}

/// A curve with its [`Knees`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct PreparedCurve {
    curve: DamperCurve,
    knees: Knees,
}

impl PreparedCurve {
    fn new(curve: &DamperCurve) -> Self {
        PreparedCurve { curve: *curve, knees: curve.knees() }
    }

    #[inline]
    fn at(&self, q_m3_s: f64) -> (f64, f64) {
        self.curve.at(&self.knees, q_m3_s)
    }

    fn flow_m3_s(&self, dp_pa: f64) -> f64 {
        self.curve.flow_at(&self.knees, dp_pa)
    }
}

/// A [`Damper`] with every curve's knees (the blow-off flows and the
/// ramps' flow-independent roots) computed once: the same values as
/// [`Damper`]'s to the last bit, for a unit that evaluates its damper at
/// every stage of every step. A two-stage curve's knees had been computed
/// at every evaluation (three square roots, two divisions), about a third
/// of the damper's time in a flexible fit's runs (perf, stop 60). Built by
/// [`crate::unit::Unit::new`] from its validated parameters, which do not
/// change after.
///
/// ```
/// use hp_core::damper::PreparedDamper;
/// use hp_core::presets;
/// let mut damper = presets::seed_unit().damper;
/// // A smooth knee in compression, a second stage in rebound (valve 5 closed).
/// damper.on_compression.blowoff_knee = 0.5;
/// let rebound = &mut damper.on_rebound;
/// (rebound.blowoff_knee, rebound.blowoff2_pa) = (0.3, 2.0 * rebound.blowoff_pa);
/// rebound.blowoff2_slope_pa_s_per_m3 = 0.5 * rebound.blowoff_slope_pa_s_per_m3;
/// damper.validate().unwrap();
/// let prepared = PreparedDamper::new(&damper);
/// for q in [-2e-3, -1e-4, 0.0, 3e-5, 1e-3] {
///     for bypass in [0.0, 0.3, 1.0] {
///         let dp = damper.pressure_drop_pa(q, bypass);
///         assert_eq!(prepared.pressure_drop_pa(q, bypass), dp);
///         assert_eq!(prepared.pressure_drop_slope_pa_s_per_m3(q, bypass), damper.pressure_drop_slope_pa_s_per_m3(q, bypass));
///         assert_eq!(prepared.flow_m3_s(dp, bypass), damper.flow_m3_s(dp, bypass));
///     }
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedDamper {
    on_compression: PreparedCurve,
    on_rebound: PreparedCurve,
    off_compression: PreparedCurve,
    off_rebound: PreparedCurve,
}

impl PreparedDamper {
    /// The damper's curves with their knees.
    pub fn new(damper: &Damper) -> Self {
        PreparedDamper {
            on_compression: PreparedCurve::new(&damper.on_compression),
            on_rebound: PreparedCurve::new(&damper.on_rebound),
            off_compression: PreparedCurve::new(&damper.off_compression),
            off_rebound: PreparedCurve::new(&damper.off_rebound),
        }
    }

    /// The valve-5 closed and open curves of a flow direction (compression:
    /// `out_of_strut`).
    #[inline(always)]
    fn pair(&self, out_of_strut: bool) -> (&PreparedCurve, &PreparedCurve) {
        if out_of_strut {
            (&self.on_compression, &self.off_compression)
        } else {
            (&self.on_rebound, &self.off_rebound)
        }
    }

    /// [`Damper::pressure_drop_pa`].
    #[inline(always)]
    pub fn pressure_drop_pa(&self, q_m3_s: f64, bypass_open: f64) -> f64 {
        let (on, off) = self.pair(q_m3_s >= 0.0);
        let q = libm::fabs(q_m3_s);
        let dp = blend_curves(on, off, bypass_open, |c| c.at(q).0);
        libm::copysign(dp, q_m3_s)
    }

    /// [`Damper::pressure_drop_slope_pa_s_per_m3`].
    pub fn pressure_drop_slope_pa_s_per_m3(&self, q_m3_s: f64, bypass_open: f64) -> f64 {
        let (on, off) = self.pair(q_m3_s >= 0.0);
        let q = libm::fabs(q_m3_s);
        blend_curves(on, off, bypass_open, |c| c.at(q).1)
    }

    /// [`Damper::flow_m3_s`].
    pub fn flow_m3_s(&self, dp_pa: f64, bypass_open: f64) -> f64 {
        let (on, off) = self.pair(dp_pa >= 0.0);
        let dp = libm::fabs(dp_pa);
        let q = if bypass_open <= 0.0 {
            on.flow_m3_s(dp)
        } else if bypass_open >= 1.0 {
            off.flow_m3_s(dp)
        } else {
            // The blended curve is monotonic: bisect on it. 60 halvings of a
            // bracket that holds both pure curves' flows reach machine precision.
            let mut lo = 0.0;
            let mut hi = on.flow_m3_s(dp).max(off.flow_m3_s(dp));
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if blend(on.at(mid).0, off.at(mid).0, bypass_open) > dp {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        };
        libm::copysign(q, dp_pa)
    }
}

#[inline]
fn blend(on: f64, off: f64, bypass_open: f64) -> f64 {
    on + (off - on) * bypass_open
}

/// `f` of the valve-5 closed curve blended with the open one's: with the
/// valve fully closed or open (always, unless it lags) only that curve is
/// evaluated, the hot path's common case.
#[inline]
fn blend_curves(on: &PreparedCurve, off: &PreparedCurve, bypass_open: f64, f: impl Fn(&PreparedCurve) -> f64) -> f64 {
    if bypass_open <= 0.0 {
        f(on)
    } else if bypass_open >= 1.0 {
        f(off)
    } else {
        blend(f(on), f(off), bypass_open)
    }
}

/// A turbulent orifice (valve 6), regularised near zero pressure difference
/// so that the flow is smooth (laminar-like) there instead of having an
/// infinite slope, which explicit integration could not follow.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orifice {
    /// Discharge coefficient times flow area, m^2.
    pub flow_area_m2: f64,
    /// Pressure difference below which the flow turns laminar, Pa.
    pub transition_pa: f64,
}

impl Orifice {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        crate::ranges::VALVE6_FLOW_AREA_M2.check(self.flow_area_m2)?;
        crate::ranges::VALVE6_TRANSITION_PA.check(self.transition_pa)?;
        Ok(())
    }

    /// `Cd A sqrt(2/rho)` for oil of density `oil_density_kg_m3`: the
    /// coefficient [`Orifice::flow_m3_s`] takes, computed once per unit
    /// (it sits on the integrator's hot path).
    pub fn coefficient(&self, oil_density_kg_m3: f64) -> f64 {
        self.flow_area_m2 * libm::sqrt(2.0 / oil_density_kg_m3)
    }

    /// Flow from side 1 to side 2 for a pressure difference `p1 - p2`, m^3/s:
    /// `Cd A sqrt(2/rho) dp / (dp^2 + dp_t^2)^(1/4)`, with `coefficient`
    /// from [`Orifice::coefficient`].
    pub fn flow_m3_s(&self, dp_pa: f64, coefficient: f64) -> f64 {
        let dp_t = self.transition_pa;
        let s = dp_pa * dp_pa + dp_t * dp_t;
        // dp s^(-1/4) as (dp / s) s^(1/2) s^(1/4): the division runs beside
        // the two square roots instead of after them. On the vehicle's hot
        // path (valve 6 open, every corner, both stages) the chain of two
        // roots and a division was the longest latency of an evaluation.
        let root = sqrt(s);
        coefficient * (dp_pa / s) * (root * sqrt(root))
    }

    /// `d(flow)/d(dp)` of [`Orifice::flow_m3_s`], m^3/(s Pa):
    /// `Cd A sqrt(2/rho) (dp^2/2 + dp_t^2) / (dp^2 + dp_t^2)^(5/4)`.
    pub fn flow_slope_m3_s_pa(&self, dp_pa: f64, coefficient: f64) -> f64 {
        let dp_t = self.transition_pa;
        let s = dp_pa * dp_pa + dp_t * dp_t;
        let quarter = sqrt(sqrt(s));
        coefficient * (0.5 * dp_pa * dp_pa + dp_t * dp_t) / (s * quarter)
    }
}

/// `sqrt(x)`, correctly rounded: the same value as `libm::sqrt`. On x86-64
/// `libm::sqrt` is inline assembly, a legacy-encoded `sqrtsd`; in code the
/// compiler builds for AVX (`hp_vehicle::wide`'s drive loop, into which the
/// damper and valve 6 are inlined) such an instruction, mixed with the
/// 256-bit operations there, stalls on the registers' upper halves (the
/// 8x8's run took 2.5 times as long). Through the SSE2 intrinsic the
/// compiler encodes it for the code it lands in.
#[inline(always)]
fn sqrt(x: f64) -> f64 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use core::arch::x86_64::{_mm_cvtsd_f64, _mm_set_sd, _mm_sqrt_pd};
        // SAFETY: sse2 is enabled (the cfg); no memory access.
        unsafe { _mm_cvtsd_f64(_mm_sqrt_pd(_mm_set_sd(x))) }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        libm::sqrt(x)
    }
}
