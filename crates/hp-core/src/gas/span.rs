//! Nitrogen: the reference equation of state of Span, Lemmon, Jacobsen,
//! Wagner and Yokozeki (2000), J. Phys. Chem. Ref. Data 29(6), 1361-1433,
//! exactly as CoolProp implements it.
//!
//! The constants are transcribed from CoolProp's fluid file
//! `dev/fluids/Nitrogen.json` (github.com/CoolProp/CoolProp, commit
//! ea27c6394887390270a03dcd0ad00a1274be4efc), including CoolProp's
//! reducing density and gas constant, so that this module and CoolProp
//! agree to rounding (`crates/hp-core/tests/span.rs` holds it to that).
//! The formulation is a reduced Helmholtz energy
//! `a(rho, T) / (R T) = alpha0(delta, tau) + alphar(delta, tau)` with
//! `delta = rho / rho_c`, `tau = T_c / T`:
//!
//! - ideal part: `ln delta + a1 + a2 tau + 2.5 ln tau + sum n_k tau^t_k
//!   + n ln(1 - exp(-v / T))` (only its second `tau` derivative enters here);
//! - residual part: 32 terms `n delta^d tau^t exp(-delta^l)` (`l = 0`: no
//!   exponential) and 4 Gaussian terms
//!   `n delta^d tau^t exp(-eta (delta - 1)^2 - beta (tau - gamma)^2)`.
//!
//! Every property is a derivative of that one function, so the model is
//! thermodynamically consistent by construction:
//! `p = rho R T (1 + delta ar_d)`,
//! `(dp/drho)_T = R T (1 + 2 delta ar_d + delta^2 ar_dd)`,
//! `(dp/dT)_rho = rho R (1 + delta ar_d - delta tau ar_dt)`,
//! `c_v = -R tau^2 (a0_tt + ar_tt)`.
//!
//! Speed. Written by hand rather than as a loop over the coefficient
//! tables: each term is one product of a precomputed power of `delta` and
//! of `tau` (every `t` is a multiple of 1/8, so all powers of `tau` come
//! from three square roots and products), the products of each
//! coefficient with its exponents fold at compile time, and the terms
//! that share an exponential are summed before multiplying by it. The
//! Gaussian terms only matter near the critical temperature (their
//! exponent is below -100 above 190 K) and are skipped when they cannot
//! change the result. On a bare-metal target the evaluation is one shared
//! function instead of being inlined into every caller (flash).

/// Critical (reducing) temperature, K.
pub const T_C_K: f64 = 126.192;
/// Reducing molar density, mol/m^3 (CoolProp's value).
pub const RHO_C_MOL_M3: f64 = 11_183.901_464_580_624;
/// Molar mass, kg/mol.
pub const MOLAR_MASS_KG_PER_MOL: f64 = 0.028_013_48;
/// Molar gas constant of the formulation, J/(mol K).
pub const GAS_CONSTANT_J_PER_MOL_K: f64 = 8.314_51;
/// Specific gas constant of the formulation, J/(kg K).
pub const GAS_CONSTANT_J_PER_KG_K: f64 = GAS_CONSTANT_J_PER_MOL_K / MOLAR_MASS_KG_PER_MOL;
/// Reducing mass density, kg/m^3.
pub const RHO_C_KG_M3: f64 = RHO_C_MOL_M3 * MOLAR_MASS_KG_PER_MOL;
/// Temperature range of the formulation (triple point to its upper limit), K.
pub const VALID_TEMPERATURE_K: (f64, f64) = (63.151, 2000.0);
/// Upper pressure limit of the formulation, Pa.
pub const VALID_PRESSURE_MAX_PA: f64 = 2.2e9;

const INV_RHO_C_KG_M3: f64 = 1.0 / RHO_C_KG_M3;

/// Ideal part: `n_k tau^t_k` with `t_k = -1, -2, -3` ("IdealGasHelmholtzPower").
const IDEAL_POWER_N: [f64; 3] = [-0.000_193_481_9, -1.247_742e-05, 6.678_326e-08];
/// Ideal part: `2.5 ln tau` ("IdealGasHelmholtzLogTau").
const IDEAL_LOG_TAU: f64 = 2.5;
/// Ideal part: `n ln(1 - exp(-v / T))` ("IdealGasHelmholtzPlanckEinsteinFunctionT").
const IDEAL_PLANCK_EINSTEIN_N: f64 = 1.012_941;
const IDEAL_PLANCK_EINSTEIN_V_K: f64 = 3364.011;

/// The residual power terms ("ResidualHelmholtzPower"), as in the JSON
/// file: coefficient `n`, density exponent `d`, temperature exponent `t`,
/// exponential `l`. The fast evaluation below spells the same terms out;
/// `tests/span.rs` checks it against a plain loop over these tables.
pub const RESIDUAL_N: [f64; 32] = [
    0.924803575275,
    -0.492448489428,
    0.661883336938,
    -1.92902649201,
    -0.0622469309629,
    0.349943957581,
    0.564857472498,
    -1.61720005987,
    -0.481395031883,
    0.421150636384,
    -0.0161962230825,
    0.172100994165,
    0.00735448924933,
    0.0168077305479,
    -0.00107626664179,
    -0.0137318088513,
    0.000635466899859,
    0.00304432279419,
    -0.0435762336045,
    -0.0723174889316,
    0.0389644315272,
    -0.021220136391,
    0.00408822981509,
    -5.51990017984e-05,
    -0.0462016716479,
    -0.00300311716011,
    0.0368825891208,
    -0.0025585684622,
    0.00896915264558,
    -0.0044151337035,
    0.00133722924858,
    0.000264832491957,
];
/// Density exponents of [`RESIDUAL_N`].
pub const RESIDUAL_D: [i32; 32] = [1, 1, 2, 2, 3, 3, 1, 1, 1, 3, 3, 4, 6, 6, 7, 7, 8, 8, 1, 2, 3, 4, 5, 8, 4, 5, 5, 8, 3, 5, 6, 9];
/// Temperature exponents of [`RESIDUAL_N`].
pub const RESIDUAL_T: [f64; 32] = [
    0.25, 0.875, 0.5, 0.875, 0.375, 0.75, 0.5, 0.75, 2.0, 1.25, 3.5, 1.0, 0.5, 3.0, 0.0, 2.75, 0.75, 2.5, 4.0, 6.0, 6.0, 3.0,
    3.0, 6.0, 16.0, 11.0, 15.0, 12.0, 12.0, 7.0, 4.0, 16.0,
];
/// Exponential exponents of [`RESIDUAL_N`] (`0`: none).
pub const RESIDUAL_L: [i32; 32] = [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4];

/// One Gaussian term ("ResidualHelmholtzGaussian", `epsilon = 1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianTerm {
    pub n: f64,
    pub d: f64,
    pub t: f64,
    pub eta: f64,
    pub beta: f64,
    pub gamma: f64,
}

/// The four Gaussian terms.
pub const GAUSSIAN: [GaussianTerm; 4] = [
    GaussianTerm { n: 19.6688194015, d: 1.0, t: 0.0, eta: 20.0, beta: 325.0, gamma: 1.16 },
    GaussianTerm { n: -20.911560073, d: 1.0, t: 1.0, eta: 20.0, beta: 325.0, gamma: 1.16 },
    GaussianTerm { n: 0.0167788306989, d: 3.0, t: 2.0, eta: 15.0, beta: 300.0, gamma: 1.13 },
    GaussianTerm { n: 2627.67566274, d: 2.0, t: 3.0, eta: 25.0, beta: 275.0, gamma: 1.25 },
];

/// A Gaussian term whose exponent is below this contributes less than
/// 1e-30 of any property at any state the code accepts.
const GAUSSIAN_NEGLIGIBLE_EXPONENT: f64 = -100.0;

/// Sums over a group of terms that share one exponential factor, each
/// term `n delta^d tau^t` weighted by the exponent factors that its
/// derivatives bring down.
#[derive(Clone, Copy)]
struct Sums {
    /// `sum n delta^d tau^t`
    a: f64,
    /// `sum d n delta^d tau^t`
    d: f64,
    /// `sum d (d - 1) n delta^d tau^t`
    dd: f64,
    /// `sum t n delta^d tau^t`
    t: f64,
    /// `sum t (t - 1) n delta^d tau^t`
    tt: f64,
    /// `sum d t n delta^d tau^t`
    dt: f64,
}

impl Default for Sums {
    /// Empty sums start at -0.0, the identity of addition (0.0 is not:
    /// -0.0 + 0.0 = 0.0), so the first addition folds away.
    fn default() -> Self {
        Sums { a: -0.0, d: -0.0, dd: -0.0, t: -0.0, tt: -0.0, dt: -0.0 }
    }
}

impl Sums {
    /// Adds one term with monomial `m = delta^d tau^t`. Always inlined with
    /// literal `n`, `d`, `t`, so the coefficient products are constants.
    #[inline(always)]
    fn add(&mut self, n: f64, d: f64, t: f64, m: f64) {
        self.a += n * m;
        self.d += (n * d) * m;
        self.dd += (n * d * (d - 1.0)) * m;
        self.t += (n * t) * m;
        self.tt += (n * t * (t - 1.0)) * m;
        self.dt += (n * d * t) * m;
    }
}

/// Reduced residual derivatives: `delta ar_d`, `delta^2 ar_dd`,
/// `tau^2 ar_tt`, `delta tau ar_dt`.
#[derive(Clone, Copy, Default, Debug, PartialEq)]
pub struct Residual {
    pub d: f64,
    pub dd: f64,
    pub tt: f64,
    pub dt: f64,
}

impl Residual {
    /// Adds a group of terms multiplied by `exp(-delta^l)`: `e` is that
    /// exponential and `u = l delta^l` (what each `delta` derivative of it
    /// brings down, over `delta`).
    #[inline(always)]
    fn add_group(&mut self, s: &Sums, e: f64, u: f64, l: f64) {
        // delta d/d(delta) of n delta^d tau^t exp(-delta^l) = term (d - u);
        // delta^2 d2/d(delta)2 = term ((d - u)(d - 1 - u) - l u).
        self.d += e * (s.d - u * s.a);
        self.dd += e * (s.dd - 2.0 * u * s.d + (u * u + u - l * u) * s.a);
        self.tt += e * s.tt;
        self.dt += e * (s.dt - u * s.t);
    }
}

/// Powers of `delta` and `tau` shared by the terms.
struct Powers {
    d1: f64,
    d2: f64,
    d3: f64,
    d4: f64,
    d5: f64,
    d6: f64,
    d7: f64,
    d8: f64,
    d9: f64,
    t0_25: f64,
    t0_375: f64,
    t0_5: f64,
    t0_75: f64,
    t0_875: f64,
    t1: f64,
    t1_25: f64,
    t2: f64,
    t2_5: f64,
    t2_75: f64,
    t3: f64,
    t3_5: f64,
    t4: f64,
    t6: f64,
    t7: f64,
    t11: f64,
    t12: f64,
    t15: f64,
    t16: f64,
}

impl Powers {
    #[inline(always)]
    fn new(delta: f64, tau: f64) -> Self {
        let d2 = delta * delta;
        let d3 = d2 * delta;
        let d4 = d2 * d2;
        let t0_5 = libm::sqrt(tau);
        let t0_25 = libm::sqrt(t0_5);
        let t0_125 = libm::sqrt(t0_25);
        let t2 = tau * tau;
        let t3 = t2 * tau;
        let t4 = t2 * t2;
        let t6 = t3 * t3;
        let t8 = t4 * t4;
        let t12 = t6 * t6;
        let t0_75 = t0_5 * t0_25;
        Powers {
            d1: delta,
            d2,
            d3,
            d4,
            d5: d4 * delta,
            d6: d3 * d3,
            d7: d4 * d3,
            d8: d4 * d4,
            d9: d4 * d4 * delta,
            t0_25,
            t0_375: t0_25 * t0_125,
            t0_5,
            t0_75,
            t0_875: t0_75 * t0_125,
            t1: tau,
            t1_25: tau * t0_25,
            t2,
            t2_5: t2 * t0_5,
            t2_75: t2 * t0_75,
            t3,
            t3_5: t3 * t0_5,
            t4,
            t6,
            t7: t6 * tau,
            t11: t8 * t3,
            t12,
            t15: t12 * t3,
            t16: t8 * t8,
        }
    }
}

/// The residual part's reduced derivatives at `(delta, tau)`.
#[cfg_attr(not(target_os = "none"), inline(always))]
pub fn residual(delta: f64, tau: f64) -> Residual {
    let w = Powers::new(delta, tau);
    let mut r = Residual::default();

    // l = 0: no exponential.
    let mut s = Sums::default();
    s.add(0.924803575275, 1.0, 0.25, w.d1 * w.t0_25);
    s.add(-0.492448489428, 1.0, 0.875, w.d1 * w.t0_875);
    s.add(0.661883336938, 2.0, 0.5, w.d2 * w.t0_5);
    s.add(-1.92902649201, 2.0, 0.875, w.d2 * w.t0_875);
    s.add(-0.0622469309629, 3.0, 0.375, w.d3 * w.t0_375);
    s.add(0.349943957581, 3.0, 0.75, w.d3 * w.t0_75);
    r.add_group(&s, 1.0, 0.0, 0.0);

    // l = 1: exp(-delta).
    let mut s = Sums::default();
    s.add(0.564857472498, 1.0, 0.5, w.d1 * w.t0_5);
    s.add(-1.61720005987, 1.0, 0.75, w.d1 * w.t0_75);
    s.add(-0.481395031883, 1.0, 2.0, w.d1 * w.t2);
    s.add(0.421150636384, 3.0, 1.25, w.d3 * w.t1_25);
    s.add(-0.0161962230825, 3.0, 3.5, w.d3 * w.t3_5);
    s.add(0.172100994165, 4.0, 1.0, w.d4 * w.t1);
    s.add(0.00735448924933, 6.0, 0.5, w.d6 * w.t0_5);
    s.add(0.0168077305479, 6.0, 3.0, w.d6 * w.t3);
    s.add(-0.00107626664179, 7.0, 0.0, w.d7);
    s.add(-0.0137318088513, 7.0, 2.75, w.d7 * w.t2_75);
    s.add(0.000635466899859, 8.0, 0.75, w.d8 * w.t0_75);
    s.add(0.00304432279419, 8.0, 2.5, w.d8 * w.t2_5);
    r.add_group(&s, libm::exp(-w.d1), w.d1, 1.0);

    // l = 2: exp(-delta^2).
    let mut s = Sums::default();
    s.add(-0.0435762336045, 1.0, 4.0, w.d1 * w.t4);
    s.add(-0.0723174889316, 2.0, 6.0, w.d2 * w.t6);
    s.add(0.0389644315272, 3.0, 6.0, w.d3 * w.t6);
    s.add(-0.021220136391, 4.0, 3.0, w.d4 * w.t3);
    s.add(0.00408822981509, 5.0, 3.0, w.d5 * w.t3);
    s.add(-5.51990017984e-05, 8.0, 6.0, w.d8 * w.t6);
    r.add_group(&s, libm::exp(-w.d2), 2.0 * w.d2, 2.0);

    // l = 3: exp(-delta^3).
    let mut s = Sums::default();
    s.add(-0.0462016716479, 4.0, 16.0, w.d4 * w.t16);
    s.add(-0.00300311716011, 5.0, 11.0, w.d5 * w.t11);
    s.add(0.0368825891208, 5.0, 15.0, w.d5 * w.t15);
    s.add(-0.0025585684622, 8.0, 12.0, w.d8 * w.t12);
    r.add_group(&s, libm::exp(-w.d3), 3.0 * w.d3, 3.0);

    // l = 4: exp(-delta^4).
    let mut s = Sums::default();
    s.add(0.00896915264558, 3.0, 12.0, w.d3 * w.t12);
    s.add(-0.0044151337035, 5.0, 7.0, w.d5 * w.t7);
    s.add(0.00133722924858, 6.0, 4.0, w.d6 * w.t4);
    s.add(0.000264832491957, 9.0, 16.0, w.d9 * w.t16);
    r.add_group(&s, libm::exp(-w.d4), 4.0 * w.d4, 4.0);

    for g in GAUSSIAN {
        add_gaussian(&mut r, &g, delta, tau);
    }
    r
}

/// One Gaussian term, skipped where it is negligible (everywhere above
/// about 190 K).
#[inline(always)]
fn add_gaussian(r: &mut Residual, g: &GaussianTerm, delta: f64, tau: f64) {
    let (x, y) = (delta - 1.0, tau - g.gamma);
    let exponent = -g.eta * x * x - g.beta * y * y;
    if exponent < GAUSSIAN_NEGLIGIBLE_EXPONENT {
        return;
    }
    gaussian_term(r, g, delta, tau, exponent);
}

#[cold]
#[inline(never)]
fn gaussian_term(r: &mut Residual, g: &GaussianTerm, delta: f64, tau: f64, exponent: f64) {
    let term = g.n * pow_small_int(delta, g.d) * pow_small_int(tau, g.t) * libm::exp(exponent);
    // delta d/d(delta) and tau d/d(tau) of the exponent plus the power.
    let fd = g.d - 2.0 * g.eta * delta * (delta - 1.0);
    let ft = g.t - 2.0 * g.beta * tau * (tau - g.gamma);
    r.d += term * fd;
    r.dd += term * (fd * fd - g.d - 2.0 * g.eta * delta * delta);
    r.tt += term * (ft * ft - g.t - 2.0 * g.beta * tau * tau);
    r.dt += term * fd * ft;
}

/// `x^n` for a small non-negative whole number `n` (the Gaussian terms'
/// exponents are 0-3).
fn pow_small_int(x: f64, n: f64) -> f64 {
    let mut out = 1.0;
    let mut k = 0.0;
    while k < n {
        out *= x;
        k += 1.0;
    }
    out
}

/// `delta ar_d` and `delta^2 ar_dd` only: what the pressure and its
/// density derivative need (the density solve, and outputs that are only
/// a pressure).
#[cfg_attr(not(target_os = "none"), inline(always))]
pub fn residual_density_derivatives(delta: f64, tau: f64) -> (f64, f64) {
    // The full evaluation costs little more than a pressure-only one would
    // (the exponentials and powers dominate) and keeps one place for the
    // coefficients; the compiler drops the unused sums.
    let r = residual(delta, tau);
    (r.d, r.dd)
}

/// `-tau^2 d2(alpha0)/d(tau)2`: the ideal-gas isochoric heat capacity over `R`.
#[inline(always)]
pub fn ideal_cv_over_r(tau: f64) -> f64 {
    let inv_tau = 1.0 / tau; // T / T_c
    // n tau^t with t = -1, -2, -3: tau^2 d2/dtau2 brings down t (t - 1) = 2, 6, 12.
    let [n1, n2, n3] = IDEAL_POWER_N;
    let power = inv_tau * (2.0 * n1 + inv_tau * (6.0 * n2 + inv_tau * 12.0 * n3));
    // n ln(1 - exp(-x)), x = v / T: tau^2 d2/dtau2 = -n x^2 e^-x / (1 - e^-x)^2.
    let x = IDEAL_PLANCK_EINSTEIN_V_K / T_C_K * tau;
    let em = libm::exp(-x);
    let one_minus = 1.0 - em;
    let planck = IDEAL_PLANCK_EINSTEIN_N * x * x * em / (one_minus * one_minus);
    IDEAL_LOG_TAU - power + planck
}

/// Reduced density and inverse temperature.
#[inline(always)]
fn reduced(rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
    (rho_kg_m3 * INV_RHO_C_KG_M3, T_C_K / t_k)
}

/// Pressure, its derivatives and `c_v` at density `rho_kg_m3` and
/// temperature `t_k` (per unit mass, SI).
#[cfg_attr(not(target_os = "none"), inline(always))]
pub fn props(rho_kg_m3: f64, t_k: f64) -> super::GasProps {
    let (delta, tau) = reduced(rho_kg_m3, t_k);
    let r = residual(delta, tau);
    let rt = GAS_CONSTANT_J_PER_KG_K * t_k;
    let z = 1.0 + r.d;
    super::GasProps {
        p_pa: rho_kg_m3 * rt * z,
        dp_dt_pa_per_k: rho_kg_m3 * GAS_CONSTANT_J_PER_KG_K * (z - r.dt),
        dp_drho_pa_m3_per_kg: rt * (z + r.d + r.dd),
        cv_j_per_kg_k: GAS_CONSTANT_J_PER_KG_K * (ideal_cv_over_r(tau) - r.tt),
    }
}

/// Pressure and `(dp/drho)_T` at density `rho_kg_m3` and temperature `t_k`.
#[cfg_attr(not(target_os = "none"), inline(always))]
pub fn pressure_and_slope(rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
    let (delta, tau) = reduced(rho_kg_m3, t_k);
    let (d, dd) = residual_density_derivatives(delta, tau);
    let rt = GAS_CONSTANT_J_PER_KG_K * t_k;
    (rho_kg_m3 * rt * (1.0 + d), rt * (1.0 + 2.0 * d + dd))
}

/// Vapour pressure at `t_k` from CoolProp's ancillary equation for this
/// fluid (`ANCILLARIES.pS` of the same file; within 0.006 % of the
/// equation of state's own saturation pressure), for `t_k` between the
/// triple point and the critical temperature; `None` outside.
pub fn saturation_pressure_pa(t_k: f64) -> Option<f64> {
    const N: [f64; 6] =
        [7.557523110967278, -15.31423072093374, 2.530452363947435, -3.5464937257192077, 2.4443140451500853, -1.089727092432518];
    const T: [f64; 6] = [0.945, 0.976, 1.134, 4.43, 4.942, 6.222];
    const P_C_PA: f64 = 3_395_800.0;
    if !(t_k >= VALID_TEMPERATURE_K.0 && t_k < T_C_K) {
        return None;
    }
    let theta = 1.0 - t_k / T_C_K;
    let sum: f64 = N.iter().zip(T.iter()).map(|(n, t)| n * libm::pow(theta, *t)).sum();
    Some(P_C_PA * libm::exp(T_C_K / t_k * sum))
}

/// A density above every liquid density of nitrogen in the valid range
/// (1030 kg/m^3 at the triple point and 300 MPa), where the iteration for
/// a liquid state starts.
const LIQUID_START_KG_M3: f64 = 1100.0;

/// Where the density solve starts: on the liquid side for a compressed
/// liquid (below the critical temperature and above the vapour pressure),
/// from the ideal gas otherwise.
pub fn density_start_kg_m3(p_pa: f64, t_k: f64) -> Option<f64> {
    match saturation_pressure_pa(t_k) {
        Some(p_sat) if p_pa > p_sat => Some(LIQUID_START_KG_M3),
        _ => None,
    }
}

/// The reference equation of state in single precision, for a target whose
/// FPU has no double precision (the ECU builds its gas table with it; see
/// `hp_ctrl::gas_table`): pressure and `(dp/drho)_T` only, from the same
/// coefficient tables, summed term by term in a loop (compact code rather
/// than speed: the ECU evaluates it a few hundred times at start-up). Its
/// relative error against the double-precision model is about 1e-6 over
/// the unit's envelope, where terms that partly cancel are rounded to
/// single precision (`tests/span.rs`). The density solve covers the gas
/// and supercritical states (it starts from the ideal gas).
pub mod single {
    use super::{GAUSSIAN, GAUSSIAN_NEGLIGIBLE_EXPONENT, GAS_CONSTANT_J_PER_KG_K, RESIDUAL_D, RESIDUAL_L, RESIDUAL_N, RESIDUAL_T, RHO_C_KG_M3, T_C_K};

    /// `x^n` by repeated squaring.
    fn powi(x: f32, n: u32) -> f32 {
        let (mut base, mut n, mut out) = (x, n, 1.0_f32);
        while n > 0 {
            if n & 1 == 1 {
                out *= base;
            }
            base *= base;
            n >>= 1;
        }
        out
    }

    /// `delta ar_d` and `delta^2 ar_dd`.
    fn residual(delta: f32, tau: f32) -> (f32, f32) {
        // Every t is a multiple of 1/8: tau^t = (tau^(1/8))^(8 t).
        let tau_eighth = libm::sqrtf(libm::sqrtf(libm::sqrtf(tau)));
        let exps = [1.0, libm::expf(-delta), libm::expf(-delta * delta), libm::expf(-powi(delta, 3)), libm::expf(-powi(delta, 4))];
        let (mut r_d, mut r_dd) = (0.0_f32, 0.0_f32);
        for (((&n, &d), &t), &l) in RESIDUAL_N.iter().zip(&RESIDUAL_D).zip(&RESIDUAL_T).zip(&RESIDUAL_L) {
            let (d, l_u) = (d as f32, l as u32);
            let e = exps.get(l as usize).copied().unwrap_or(0.0);
            let term = n as f32 * powi(delta, d as u32) * powi(tau_eighth, (8.0 * t) as u32) * e;
            let u = l as f32 * powi(delta, l_u);
            r_d += term * (d - u);
            r_dd += term * ((d - u) * (d - 1.0 - u) - l as f32 * u);
        }
        for g in GAUSSIAN {
            let (x, y) = (delta - 1.0, tau - g.gamma as f32);
            let exponent = -(g.eta as f32) * x * x - g.beta as f32 * y * y;
            if exponent < GAUSSIAN_NEGLIGIBLE_EXPONENT as f32 {
                continue;
            }
            let gd = g.d as f32;
            let term = g.n as f32 * powi(delta, g.d as u32) * powi(tau, g.t as u32) * libm::expf(exponent);
            let fd = gd - 2.0 * g.eta as f32 * delta * (delta - 1.0);
            r_d += term * fd;
            r_dd += term * (fd * fd - gd - 2.0 * g.eta as f32 * delta * delta);
        }
        (r_d, r_dd)
    }

    /// Pressure, Pa, and `(dp/drho)_T`, Pa m^3/kg, at density `rho_kg_m3`
    /// and temperature `t_k`.
    pub fn pressure_and_slope(rho_kg_m3: f32, t_k: f32) -> (f32, f32) {
        let delta = rho_kg_m3 * (1.0 / RHO_C_KG_M3) as f32;
        let (d, dd) = residual(delta, T_C_K as f32 / t_k);
        let rt = GAS_CONSTANT_J_PER_KG_K as f32 * t_k;
        (rho_kg_m3 * rt * (1.0 + d), rt * (1.0 + 2.0 * d + dd))
    }

    /// Density at pressure `p_pa` and temperature `t_k`, kg/m^3, by a
    /// Newton iteration from the ideal gas kept inside a bracket that holds
    /// the root (bisecting where a Newton step would leave it); `None` if
    /// it does not converge to single precision in 60 iterations.
    pub fn density_kg_m3(p_pa: f32, t_k: f32) -> Option<f32> {
        let (mut lo, mut hi) = (0.0_f32, 3000.0_f32);
        if !(p_pa > 0.0 && t_k > 0.0 && pressure_and_slope(hi, t_k).0 > p_pa) {
            return None;
        }
        let mut rho = (p_pa / (GAS_CONSTANT_J_PER_KG_K as f32 * t_k)).min(hi);
        for _ in 0..60 {
            let (p, slope) = pressure_and_slope(rho, t_k);
            let residual = p - p_pa;
            if !residual.is_finite() {
                return None;
            }
            // At the root to single precision (a zero residual would also
            // leave the Newton step on the bracket's edge).
            if libm::fabsf(residual) <= 4.0 * f32::EPSILON * p_pa {
                return Some(rho);
            }
            if residual > 0.0 {
                hi = rho;
            } else {
                lo = rho;
            }
            let newton = rho - residual / slope;
            let next = if slope > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if libm::fabsf(next - rho) <= 2.0 * f32::EPSILON * rho {
                return Some(next);
            }
            rho = next;
        }
        None
    }
}
