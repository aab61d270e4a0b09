//! Equations of state of nitrogen: the reference equation of Span et al.
//! (2000) ([`span`], the default), ideal gas and Benedict-Webb-Rubin.
//!
//! All quantities are per unit *mass* and SI at this interface (kg/m^3, K,
//! Pa, J/(kg K)). The BWR constant sets are published in molar, non-SI units
//! and are evaluated in their own units internally; converting the constants
//! instead would be a second place for unit mistakes to hide.
//!
//! The ideal-gas heat capacity `c_v0(T)` of the ideal and BWR models is
//! NIST's Shomate fit for N2 (Chase, NIST-JANAF Thermochemical Tables, 1998),
//! which the tests check against CoolProp's ideal-gas part; the reference
//! model has its own.

use crate::error::{check_range, Error, Result};

pub mod span;

/// Molar mass of nitrogen (N2), g/mol (= kg/kmol).
pub const N2_MOLAR_MASS_G_PER_MOL: f64 = 28.0134;
/// Molar gas constant, J/(mol K) (CODATA 2018, exact).
pub const MOLAR_GAS_CONSTANT_J_PER_MOL_K: f64 = 8.314_462_618;
/// Specific gas constant of N2, J/(kg K).
pub const N2_GAS_CONSTANT_J_PER_KG_K: f64 =
    MOLAR_GAS_CONSTANT_J_PER_MOL_K / (N2_MOLAR_MASS_G_PER_MOL * 1e-3);

/// Valid pressure range of the density solve, Pa (the unit works in 2-110 MPa).
pub const PRESSURE_RANGE_PA: (f64, f64) = (1.0e3, 3.0e8);
/// Valid temperature range of every model, K.
pub const TEMPERATURE_RANGE_K: (f64, f64) = (60.0, 1000.0);
/// Density range searched, kg/m^3: real nitrogen stays below 700 kg/m^3 in
/// the unit's envelope, but the ideal gas reaches 1600 kg/m^3 at 110 MPa and
/// 233 K, and it must be usable there to show how wrong it is.
pub const DENSITY_RANGE_KG_M3: (f64, f64) = (0.0, 3000.0);

/// Where a model's accuracy has been measured (`docs/accuracy.md`): the
/// reference grid's 2-110 MPa and 233-473 K, with the pressure range
/// opened down to [`PRESSURE_RANGE_PA`]'s minimum because every model here
/// tends to the ideal gas as the density falls, where the ideal gas is
/// exact. Outside it a model still computes (within the wider ranges the
/// solver accepts) but nobody has checked how wrong it is: a result that
/// went there is a warning, not a number to stand behind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidatedRange {
    /// Smallest and largest pressure, Pa.
    pub pressure_pa: (f64, f64),
    /// Smallest and largest temperature, K.
    pub temperature_k: (f64, f64),
}

/// The range over which `gas` has been validated against CoolProp.
///
/// ```
/// use hp_core::gas::{validated_range, Gas};
/// let r = validated_range(Gas::BwrTextbook);
/// assert_eq!(r.pressure_pa.1, 110.0e6);
/// assert!(r.temperature_k.0 < 293.15 && 293.15 < r.temperature_k.1);
/// ```
pub fn validated_range(gas: Gas) -> ValidatedRange {
    // The accuracy grid of docs/accuracy.md (every model is checked on it
    // against CoolProp by tests/eos_reference.rs).
    const GRID: ValidatedRange = ValidatedRange { pressure_pa: (PRESSURE_RANGE_PA.0, 110.0e6), temperature_k: (233.15, 473.15) };
    // The reference model is checked against CoolProp beyond the grid too:
    // every pressure the solver accepts, from the lowest temperature of the
    // fixture (just above the triple point, 63.151 K) to the highest.
    const REFERENCE: ValidatedRange = ValidatedRange { pressure_pa: PRESSURE_RANGE_PA, temperature_k: (64.0, TEMPERATURE_RANGE_K.1) };
    match gas {
        Gas::Span => REFERENCE,
        Gas::Ideal | Gas::BwrCooperGoldfrank | Gas::BwrTextbook => GRID,
    }
}

/// Thermodynamic properties at one (density, temperature) state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GasProps {
    /// Pressure, Pa.
    pub p_pa: f64,
    /// `(dp/dT)` at constant density, Pa/K.
    pub dp_dt_pa_per_k: f64,
    /// `(dp/drho)` at constant temperature, Pa m^3/kg.
    pub dp_drho_pa_m3_per_kg: f64,
    /// Isochoric specific heat capacity (real gas), J/(kg K).
    pub cv_j_per_kg_k: f64,
}

/// An equation of state: everything the energy equation needs.
///
/// Implementors provide [`EquationOfState::props`]; the density solve is
/// shared. Inputs are not range-checked here (this sits on the integrator's
/// hot path); callers validate once at the boundary.
pub trait EquationOfState {
    /// Pressure, its derivatives and `c_v` at density `rho_kg_m3` and
    /// temperature `t_k`.
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps;

    /// Pressure in Pa at density `rho_kg_m3` and temperature `t_k`.
    fn pressure_pa(&self, rho_kg_m3: f64, t_k: f64) -> f64 {
        self.props(rho_kg_m3, t_k).p_pa
    }

    /// Pressure in Pa and `(dp/drho)_T` in Pa m^3/kg: what the density
    /// solve needs (models may compute it cheaper than [`EquationOfState::props`]).
    fn pressure_and_slope(&self, rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
        let p = self.props(rho_kg_m3, t_k);
        (p.p_pa, p.dp_drho_pa_m3_per_kg)
    }

    /// Where the density solve starts, kg/m^3; `None`: from the ideal gas.
    /// Below the critical temperature `p(rho)` has two branches, and the
    /// iteration converges to the one on the side it starts from.
    fn density_start_kg_m3(&self, _p_pa: f64, _t_k: f64) -> Option<f64> {
        None
    }

    /// Density in kg/m^3 at pressure `p_pa` and temperature `t_k`.
    ///
    /// A Newton iteration kept inside a bracket that always contains the
    /// root; where a Newton step would leave the bracket (or the slope is not
    /// positive) it bisects instead, so it cannot diverge or cycle. It gives
    /// up with [`Error::NoConvergence`] after a fixed number of iterations.
    ///
    /// ```
    /// use hp_core::gas::{EquationOfState, Gas};
    /// let rho = Gas::Ideal.density_kg_m3(1.0e7, 300.0).unwrap();
    /// assert!((Gas::Ideal.pressure_pa(rho, 300.0) / 1.0e7 - 1.0).abs() < 1e-12);
    /// ```
    fn density_kg_m3(&self, p_pa: f64, t_k: f64) -> Result<f64> {
        check_range("p_pa", p_pa, PRESSURE_RANGE_PA.0, PRESSURE_RANGE_PA.1)?;
        check_range("t_k", t_k, TEMPERATURE_RANGE_K.0, TEMPERATURE_RANGE_K.1)?;
        solve_density(|rho| self.pressure_and_slope(rho, t_k), p_pa, self.density_start_kg_m3(p_pa, t_k))
    }
}

/// The density at which `pressure_and_slope(rho) = (p, dp/drho)` reaches
/// `p_pa`, starting from `start` (or the ideal gas).
fn solve_density(pressure_and_slope: impl Fn(f64) -> (f64, f64), p_pa: f64, start: Option<f64>) -> Result<f64> {
    const MAX_ITERATIONS: usize = 100;
    let fail = Error::NoConvergence { what: "density from pressure and temperature", target: p_pa };
    // Bracket [lo, hi] with p(lo) < p_pa < p(hi); p(0) = 0 < p_pa.
    let mut lo = 0.0_f64;
    let mut hi = DENSITY_RANGE_KG_M3.1;
    let (p_hi, _) = pressure_and_slope(hi);
    if !(p_hi > p_pa) {
        return Err(fail);
    }
    // Start from the ideal gas: accurate to a few per cent where the unit works.
    let mut rho = match start {
        Some(rho) => rho.clamp(0.0, hi),
        None => {
            let (_, slope_dilute) = pressure_and_slope(1.0);
            if slope_dilute > 0.0 {
                (p_pa / slope_dilute).clamp(0.0, hi)
            } else {
                0.5 * hi
            }
        }
    };
    for _ in 0..MAX_ITERATIONS {
        let (p, slope) = pressure_and_slope(rho);
        let residual = p - p_pa;
        if !residual.is_finite() {
            return Err(fail);
        }
        if residual > 0.0 {
            hi = rho;
        } else {
            lo = rho;
        }
        if libm::fabs(residual) <= 1e-12 * p_pa {
            return Ok(rho);
        }
        let newton = rho - residual / slope;
        let next = if slope > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if libm::fabs(next - rho) <= 1e-14 * rho {
            return Ok(next);
        }
        rho = next;
    }
    Err(fail)
}

/// Moles per gram of N2 (the reciprocal, so the hot path multiplies).
const N2_MOL_PER_G: f64 = 1.0 / N2_MOLAR_MASS_G_PER_MOL;
/// Moles per kilogram of N2.
const N2_MOL_PER_KG: f64 = 1e3 / N2_MOLAR_MASS_G_PER_MOL;

/// Ideal-gas isobaric molar heat capacity of N2, J/(mol K): NIST's Shomate
/// equation (two temperature bands, 100-500 K and 500-2000 K).
pub fn cp0_molar_j_per_mol_k(t_k: f64) -> f64 {
    cp0_molar(t_k, 1.0 / (t_k * t_k))
}

/// [`cp0_molar_j_per_mol_k`] with `1/T^2` already at hand.
#[inline(always)]
fn cp0_molar(t_k: f64, inv_t2: f64) -> f64 {
    let (a, b, c, d, e) = if t_k <= 500.0 {
        (28.98641, 1.853978, -9.647459, 16.63537, 0.000117)
    } else {
        (19.50583, 19.88705, -8.598535, 1.369784, 0.527601)
    };
    let t = t_k * 1e-3; // the fit's temperature unit is kK
    a + t * (b + t * (c + t * d)) + e * 1e6 * inv_t2
}

/// Ideal-gas isochoric specific heat capacity of N2, J/(kg K).
pub fn cv0_j_per_kg_k(t_k: f64) -> f64 {
    cv0(t_k, 1.0 / (t_k * t_k))
}

#[inline(always)]
fn cv0(t_k: f64, inv_t2: f64) -> f64 {
    (cp0_molar(t_k, inv_t2) - MOLAR_GAS_CONSTANT_J_PER_MOL_K) * N2_MOL_PER_KG
}

/// Nitrogen as an ideal gas with temperature-dependent `c_v0(T)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IdealGas;

impl EquationOfState for IdealGas {
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        let r = N2_GAS_CONSTANT_J_PER_KG_K;
        GasProps {
            p_pa: rho_kg_m3 * r * t_k,
            dp_dt_pa_per_k: rho_kg_m3 * r,
            dp_drho_pa_m3_per_kg: r * t_k,
            cv_j_per_kg_k: cv0(t_k, 1.0 / (t_k * t_k)),
        }
    }
}

/// One published set of Benedict-Webb-Rubin constants, in the set's own
/// units: molar density in mol/L (= kmol/m^3), pressure in `pressure_unit_pa`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BwrConstants {
    /// Gas constant in the set's units.
    pub r: f64,
    pub a0: f64,
    pub b0: f64,
    pub c0: f64,
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub alpha: f64,
    pub gamma: f64,
    /// One pressure unit of the set, in Pa.
    pub pressure_unit_pa: f64,
}

/// Cooper & Goldfrank (1967) nitrogen, in atm, L, mol, K.
pub const BWR_COOPER_GOLDFRANK: BwrConstants = BwrConstants {
    r: 0.082_056_16,
    a0: 1.19250,
    b0: 0.0458000,
    c0: 5.8891e3,
    a: 0.0149000,
    b: 1.98154e-3,
    c: 548.064,
    alpha: 2.91545e-4,
    gamma: 7.5e-3,
    pressure_unit_pa: 101_325.0,
};

/// The textbook nitrogen set (kPa, m^3, kmol, K), as tabulated in
/// engineering thermodynamics texts.
pub const BWR_TEXTBOOK: BwrConstants = BwrConstants {
    r: 8.314,
    a0: 106.73,
    b0: 0.04074,
    c0: 8.164e5,
    a: 2.54,
    b: 0.002328,
    c: 7.379e4,
    alpha: 1.272e-4,
    gamma: 0.0053,
    pressure_unit_pa: 1_000.0,
};

/// Benedict-Webb-Rubin nitrogen with a chosen constant set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bwr {
    pub constants: BwrConstants,
}

impl EquationOfState for Bwr {
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        bwr_props(&self.constants, rho_kg_m3, t_k)
    }
}

/// BWR with the textbook set: its own function, so the constants fold.
#[inline]
fn bwr_textbook_props(rho_kg_m3: f64, t_k: f64) -> GasProps {
    bwr_props(&BWR_TEXTBOOK, rho_kg_m3, t_k)
}

/// BWR with the Cooper & Goldfrank set.
#[inline]
fn bwr_cooper_goldfrank_props(rho_kg_m3: f64, t_k: f64) -> GasProps {
    bwr_props(&BWR_COOPER_GOLDFRANK, rho_kg_m3, t_k)
}

// On the host, always inlined into the per-set functions above: with a
// constant set the compiler folds the products of constants, which is most
// of the arithmetic. On a bare-metal target one shared copy keeps the flash
// small (the ECU evaluates the gas only while building its tables), and
// inlining it into every caller there made one Cortex-M function too large
// for its literal pool.
#[cfg_attr(not(target_os = "none"), inline(always))]
fn bwr_props(k: &BwrConstants, rho_kg_m3: f64, t_k: f64) -> GasProps {
    // Divisions are slow and the compiler does not turn a division by a
    // constant into a multiplication: one reciprocal, then products.
    let d = rho_kg_m3 * N2_MOL_PER_G; // mol/L
    let t = t_k;
    let inv_t = 1.0 / t;
    let inv_t2 = inv_t * inv_t;
    let inv_t3 = inv_t2 * inv_t;
    let d2 = d * d;
    let d3 = d2 * d;
    let gd2 = k.gamma * d2;
    let e = libm::exp(-gd2);
    let rt = k.r * t;
    let second_virial = k.b0 * rt - k.a0 - k.c0 * inv_t2;
    let third = k.b * rt - k.a;
    let c_term = k.c * (1.0 + gd2) * e; // c (1 + gamma d^2) exp(-gamma d^2)
    let p = rt * d + second_virial * d2 + third * d3 + k.a * k.alpha * d3 * d3 + c_term * d3 * inv_t2;
    let dp_dt = k.r * d + (k.b0 * k.r + 2.0 * k.c0 * inv_t3) * d2 + k.b * k.r * d3 - 2.0 * c_term * d3 * inv_t3;
    let dp_dd = rt
        + 2.0 * second_virial * d
        + 3.0 * third * d2
        + 6.0 * k.a * k.alpha * d3 * d2
        + k.c * inv_t2 * (3.0 * d2 + 3.0 * gd2 * d2 - 2.0 * gd2 * gd2 * d2) * e;
    // Residual c_v from the Helmholtz energy: -T d2(a_res)/dT2.
    let cv_res = 6.0 * k.c0 * d * inv_t3 - (6.0 * k.c / k.gamma) * inv_t3 * (1.0 - (1.0 + 0.5 * gd2) * e);
    // (set pressure) x (L/mol) in J/mol, then per kg.
    let energy_j_per_kg = k.pressure_unit_pa * 1e-3 * N2_MOL_PER_KG;
    GasProps {
        p_pa: p * k.pressure_unit_pa,
        dp_dt_pa_per_k: dp_dt * k.pressure_unit_pa,
        dp_drho_pa_m3_per_kg: dp_dd * (k.pressure_unit_pa * N2_MOL_PER_G),
        cv_j_per_kg_k: cv0(t, inv_t2) + cv_res * energy_j_per_kg,
    }
}

/// Nitrogen's reference equation of state, Span et al. (2000), as CoolProp
/// implements it (see [`span`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span;

impl EquationOfState for Span {
    #[inline]
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        span::props(rho_kg_m3, t_k)
    }

    #[inline]
    fn pressure_and_slope(&self, rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
        span::pressure_and_slope(rho_kg_m3, t_k)
    }

    fn density_start_kg_m3(&self, p_pa: f64, t_k: f64) -> Option<f64> {
        span::density_start_kg_m3(p_pa, t_k)
    }
}

/// The selectable gas models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Gas {
    /// The reference equation of state, Span et al. (2000): CoolProp's
    /// nitrogen to rounding.
    #[default]
    Span,
    /// Ideal gas, `p = rho R T`, with `c_v0(T)`.
    Ideal,
    /// BWR with the Cooper & Goldfrank constants: best of the two sets below 30 MPa.
    BwrCooperGoldfrank,
    /// BWR with the textbook constants: the better set over 2-110 MPa.
    BwrTextbook,
}

impl Gas {
    /// Every model, for tables and sweeps (the default first).
    pub const ALL: [Gas; 4] = [Gas::Span, Gas::Ideal, Gas::BwrCooperGoldfrank, Gas::BwrTextbook];

    /// Stable short name (used on the command line and in files).
    pub fn name(self) -> &'static str {
        match self {
            Gas::Span => "span",
            Gas::Ideal => "ideal",
            Gas::BwrCooperGoldfrank => "bwr-cg",
            Gas::BwrTextbook => "bwr-textbook",
        }
    }

    /// The model with short name `name`, if any.
    pub fn from_name(name: &str) -> Option<Gas> {
        Gas::ALL.into_iter().find(|g| g.name() == name)
    }
}

impl EquationOfState for Gas {
    #[inline]
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        match self {
            Gas::Span => span::props(rho_kg_m3, t_k),
            Gas::Ideal => IdealGas.props(rho_kg_m3, t_k),
            Gas::BwrCooperGoldfrank => bwr_cooper_goldfrank_props(rho_kg_m3, t_k),
            Gas::BwrTextbook => bwr_textbook_props(rho_kg_m3, t_k),
        }
    }

    #[inline]
    fn pressure_and_slope(&self, rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
        match self {
            Gas::Span => span::pressure_and_slope(rho_kg_m3, t_k),
            _ => {
                let p = self.props(rho_kg_m3, t_k);
                (p.p_pa, p.dp_drho_pa_m3_per_kg)
            }
        }
    }

    fn density_start_kg_m3(&self, p_pa: f64, t_k: f64) -> Option<f64> {
        match self {
            Gas::Span => span::density_start_kg_m3(p_pa, t_k),
            _ => None,
        }
    }
}
