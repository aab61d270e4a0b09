//! The energy equation of one gas volume (the seed's Eq. 1).
//!
//! `dT/dt = (T_w - T)/tau - (T/c_v) (dp/dT)_v dv/dt`, with `v` the specific
//! volume. `tau` is the thermal time constant `m c_v / (h A_w)`, taken
//! constant as the seed found it fits well (or moving with `m c_v` at a
//! fixed wall conductance, [`crate::unit::WallConductance`]). The two limits are separate
//! variants so that they hold exactly rather than through a huge or tiny
//! number: isothermal pins the gas to the wall temperature, adiabatic drops
//! the heat term (the real-gas isentrope).

use crate::error::{check_range, Result};
use crate::gas::GasProps;

/// Largest finite time constant accepted, s (about 30 years).
pub const MAX_FINITE_TAU_S: f64 = 1.0e9;

/// How the gas exchanges heat with its wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeatTransfer {
    /// `tau = 0`: the gas is always at the wall temperature.
    Isothermal,
    /// `tau = infinity`: no heat exchange, the gas follows its isentrope.
    Adiabatic,
    /// A finite, positive thermal time constant in seconds.
    TimeConstant(f64),
    /// The classical model: a polytropic process `p v^n = const` of an
    /// ideal gas, i.e. `T v^(n-1) = const`, with no wall temperature. With a
    /// real-gas equation of state it is the same temperature law (an
    /// approximation). `n = 1` is isothermal, `n = c_p/c_v` adiabatic.
    Polytropic(f64),
}

impl HeatTransfer {
    /// From a time constant in seconds: `0` is isothermal, `+inf` adiabatic.
    ///
    /// ```
    /// use hp_core::thermal::HeatTransfer;
    /// assert_eq!(HeatTransfer::from_tau_s(0.0).unwrap(), HeatTransfer::Isothermal);
    /// assert_eq!(HeatTransfer::from_tau_s(f64::INFINITY).unwrap(), HeatTransfer::Adiabatic);
    /// assert!(HeatTransfer::from_tau_s(-1.0).is_err());
    /// ```
    pub fn from_tau_s(tau_s: f64) -> Result<Self> {
        if tau_s == f64::INFINITY {
            Ok(HeatTransfer::Adiabatic)
        } else if tau_s == 0.0 {
            Ok(HeatTransfer::Isothermal)
        } else {
            check_range("tau_s", tau_s, 0.0, MAX_FINITE_TAU_S).map(HeatTransfer::TimeConstant)
        }
    }

    /// The classical polytropic model with exponent `n` in [1, 2].
    pub fn polytropic(n: f64) -> Result<Self> {
        check_range("polytropic_exponent", n, 1.0, 2.0).map(HeatTransfer::Polytropic)
    }

    /// The same heat transfer with its time constant multiplied by
    /// `factor` (a time constant that moves with the gas's state, see
    /// [`crate::unit::WallConductance`]); the limits and the polytropic law
    /// have none to scale and are returned as they are.
    ///
    /// ```
    /// use hp_core::thermal::HeatTransfer;
    /// assert_eq!(HeatTransfer::TimeConstant(2.0).with_tau_factor(1.5), HeatTransfer::TimeConstant(3.0));
    /// assert_eq!(HeatTransfer::Adiabatic.with_tau_factor(1.5), HeatTransfer::Adiabatic);
    /// ```
    #[inline]
    pub fn with_tau_factor(self, factor: f64) -> Self {
        match self {
            HeatTransfer::TimeConstant(tau) => HeatTransfer::TimeConstant(tau * factor),
            other => other,
        }
    }

    /// The time constant in seconds (`0` or `+inf` for the limits; NaN for
    /// the polytropic model, which has none).
    pub fn tau_s(self) -> f64 {
        match self {
            HeatTransfer::Isothermal => 0.0,
            HeatTransfer::Adiabatic => f64::INFINITY,
            HeatTransfer::TimeConstant(tau) => tau,
            HeatTransfer::Polytropic(_) => f64::NAN,
        }
    }
}

/// The temperature the gas actually has: the wall's when isothermal,
/// otherwise its own state.
#[inline]
pub fn gas_temperature_k(heat: HeatTransfer, state_t_k: f64, wall_t_k: f64) -> f64 {
    match heat {
        HeatTransfer::Isothermal => wall_t_k,
        _ => state_t_k,
    }
}

/// `dT/dt` of one gas volume, K/s, given its properties `props` at the
/// temperature `t_k` it actually has (see [`gas_temperature_k`]), while its
/// volume changes at `volume_rate_m3_s` and its mass at `mass_rate_kg_s`
/// (leakage: the remaining gas expands into the room the leaked gas left,
/// which the specific-volume rate `dv/dt` captures).
///
/// Zero when isothermal: the temperature state is unused then.
#[allow(clippy::too_many_arguments)]
pub fn temperature_rate_k_s(
    heat: HeatTransfer,
    props: &GasProps,
    t_k: f64,
    wall_t_k: f64,
    mass_kg: f64,
    volume_m3: f64,
    volume_rate_m3_s: f64,
    mass_rate_kg_s: f64,
) -> f64 {
    let dv_dt = || volume_rate_m3_s / mass_kg - volume_m3 * mass_rate_kg_s / (mass_kg * mass_kg);
    let compression = || -(t_k / props.cv_j_per_kg_k) * props.dp_dt_pa_per_k * dv_dt();
    match heat {
        HeatTransfer::Isothermal => 0.0,
        HeatTransfer::Adiabatic => compression(),
        HeatTransfer::TimeConstant(tau) => (wall_t_k - t_k) / tau + compression(),
        HeatTransfer::Polytropic(n) => -(n - 1.0) * t_k * dv_dt() * mass_kg / volume_m3,
    }
}

/// `d(dT/dt) / d(dV/dt)`: how the temperature rate of one gas volume
/// changes with its volume rate (the compression term is linear in it),
/// K/m^3. Used for the linearisation of the stiff valve-6 exchange.
pub fn temperature_rate_per_volume_rate(heat: HeatTransfer, props: &GasProps, t_k: f64, mass_kg: f64, volume_m3: f64) -> f64 {
    match heat {
        HeatTransfer::Isothermal => 0.0,
        HeatTransfer::Adiabatic | HeatTransfer::TimeConstant(_) => -(t_k / props.cv_j_per_kg_k) * props.dp_dt_pa_per_k / mass_kg,
        HeatTransfer::Polytropic(n) => -(n - 1.0) * t_k / volume_m3,
    }
}
