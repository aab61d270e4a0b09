//! The valid range of every unit parameter but the effects' (each effect
//! declares its parameters' ranges next to its struct, [`crate::effect`]).
//!
//! [`Unit::new`](crate::unit::Unit::new) checks each parameter against its
//! [`Range`]; the bindings export [`ALL`] and the effects' ranges so that the
//! Python side (record schema, effect registry, command line) reads the same
//! names and limits instead of copying them.

use crate::error::{check_range, Result};
use crate::gas::PRESSURE_RANGE_PA;
use crate::thermal::MAX_FINITE_TAU_S;

/// A named parameter's valid range, inclusive; NaN and infinities are
/// outside every range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// The parameter's name, with its SI unit suffix.
    pub name: &'static str,
    /// Smallest valid value.
    pub min: f64,
    /// Largest valid value.
    pub max: f64,
}

impl Range {
    /// The range `[min, max]` of the parameter `name`.
    pub const fn new(name: &'static str, min: f64, max: f64) -> Self {
        Range { name, min, max }
    }

    /// `value` if it lies in the range, else an error naming the
    /// parameter, the value and the range.
    ///
    /// ```
    /// use hp_core::ranges::PISTON_AREA_M2;
    /// assert!(PISTON_AREA_M2.check(2.0e-3).is_ok());
    /// assert!(PISTON_AREA_M2.check(f64::NAN).is_err());
    /// ```
    pub fn check(&self, value: f64) -> Result<f64> {
        check_range(self.name, value, self.min, self.max)
    }
}

const fn r(name: &'static str, min: f64, max: f64) -> Range {
    Range::new(name, min, max)
}

pub const PISTON_AREA_M2: Range = r("piston_area_m2", 1e-5, 1.0);
pub const SMALL_ACC_VOLUME_M3: Range = r("small_acc_volume_m3", 1e-6, 1.0);
pub const LARGE_ACC_VOLUME_M3: Range = r("large_acc_volume_m3", 1e-6, 1.0);
pub const STATIC_PRESSURE_PA: Range = r("static_pressure_pa", 2.0e5, PRESSURE_RANGE_PA.1);
pub const STATIC_TEMPERATURE_K: Range = r("static_temperature_k", 200.0, 600.0);
pub const OIL_DENSITY_KG_M3: Range = r("oil_density_kg_m3", 500.0, 2000.0);
pub const VAPOUR_PRESSURE_PA: Range = r("vapour_pressure_pa", 0.0, 1.0e5);
pub const AMBIENT_PRESSURE_PA: Range = r("ambient_pressure_pa", 0.0, 2.0e5);
pub const STROKE_COMPRESSION_M: Range = r("stroke_compression_m", 1e-3, 2.0);
pub const STROKE_EXTENSION_M: Range = r("stroke_extension_m", 1e-3, 2.0);
pub const END_STOP_STIFFNESS_N_PER_M: Range = r("end_stop_stiffness_n_per_m", 0.0, 1e9);
pub const END_STOP_DAMPING_N_S_PER_M: Range = r("end_stop_damping_n_s_per_m", 0.0, 1e7);
pub const RATED_SPEED_M_S: Range = r("rated_speed_m_s", 1e-3, 100.0);
pub const TAU_S: Range = r("tau_s", 1e-6, MAX_FINITE_TAU_S);
pub const POLYTROPIC_EXPONENT: Range = r("polytropic_exponent", 1.0, 2.0);
/// Width of a damper curve's blow-off knee as a fraction of the blow-off
/// flow (0 = the sharp knee).
pub const DAMPER_BLOWOFF_KNEE: Range = r("blowoff_knee", 0.0, 2.0);
/// The SDOF rig's sprung mass.
pub const SPRUNG_MASS_KG: Range = r("sprung_mass_kg", 1.0, 1e6);
/// Valve 6's discharge coefficient times flow area
/// ([`crate::damper::Orifice`]).
pub const VALVE6_FLOW_AREA_M2: Range = r("valve6_flow_area_m2", 0.0, 1e-2);
/// Valve 6's laminar-turbulent transition pressure difference.
pub const VALVE6_TRANSITION_PA: Range = r("valve6_transition_pa", 1.0, 1e7);

/// Every range above, for the bindings. The effects' parameters have
/// theirs in their own tables ([`crate::effect`], declared in
/// [`crate::unit`]); [`crate::unit::Effects::visit`] lists them.
pub const ALL: [Range; 19] = [
    PISTON_AREA_M2,
    SMALL_ACC_VOLUME_M3,
    LARGE_ACC_VOLUME_M3,
    STATIC_PRESSURE_PA,
    STATIC_TEMPERATURE_K,
    OIL_DENSITY_KG_M3,
    VAPOUR_PRESSURE_PA,
    AMBIENT_PRESSURE_PA,
    STROKE_COMPRESSION_M,
    STROKE_EXTENSION_M,
    END_STOP_STIFFNESS_N_PER_M,
    END_STOP_DAMPING_N_S_PER_M,
    RATED_SPEED_M_S,
    TAU_S,
    POLYTROPIC_EXPONENT,
    DAMPER_BLOWOFF_KNEE,
    SPRUNG_MASS_KG,
    VALVE6_FLOW_AREA_M2,
    VALVE6_TRANSITION_PA,
];

#[cfg(test)]
mod tests {
    use super::ALL;

    #[test]
    fn names_are_unique_and_ranges_ordered() {
        for (i, a) in ALL.iter().enumerate() {
            assert!(a.min <= a.max, "{}", a.name);
            assert!(ALL.iter().skip(i + 1).all(|b| b.name != a.name), "{} twice", a.name);
        }
    }
}
