//! The controller's configuration: what a calibration engineer sets.
//!
//! [`Config`] is plain data in SI units (`f64`), one sub-struct per block of
//! the controller. [`crate::Params::new`] validates it and compiles it into
//! the form the step function uses; every rejected value is reported as a
//! [`ParamError`] naming the field, its value and the valid range.

use core::fmt;

use crate::damper::DamperConfig;
use crate::estimator::EstimatorConfig;
use crate::gas_table::UnitConfig;
use crate::mode::ModeConfig;
use crate::monitor::MonitorConfig;
use crate::ride_height::RideHeightConfig;

/// Everything that configures the controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// The spring-damper unit (geometry and gas charge).
    pub unit: UnitConfig,
    /// Input plausibility, staleness and recovery.
    pub monitor: MonitorConfig,
    /// Strut and body velocity estimation.
    pub estimator: EstimatorConfig,
    /// Ride/handling mode selection.
    pub mode: ModeConfig,
    /// Skyhook damping with valve 5.
    pub damper: DamperConfig,
    /// Pump-free ride-height sequencing with valve 6.
    pub ride_height: RideHeightConfig,
}

impl Config {
    /// The seed's unit (from `hp_core::presets`) with the default calibration.
    pub fn seed_unit() -> Self {
        Config {
            unit: UnitConfig::seed_unit(),
            monitor: MonitorConfig::default(),
            estimator: EstimatorConfig::default(),
            mode: ModeConfig::default(),
            damper: DamperConfig::default(),
            ride_height: RideHeightConfig::default(),
        }
    }

    /// Checks every field; the first invalid one is reported.
    ///
    /// ```
    /// use hp_ctrl::{Config, ParamError};
    /// let mut config = Config::seed_unit();
    /// assert!(config.validate().is_ok());
    /// config.mode.handling_hold_s = -1.0;
    /// assert!(matches!(
    ///     config.validate(),
    ///     Err(ParamError::OutOfRange { name: "mode.handling_hold_s", .. })
    /// ));
    /// ```
    pub fn validate(&self) -> Result<(), ParamError> {
        self.unit.validate()?;
        self.monitor.validate()?;
        self.estimator.validate(self.monitor.dt_max_s)?;
        self.mode.validate()?;
        self.damper.validate()?;
        self.ride_height.validate(&self.unit, self.monitor.dt_max_s)?;
        Ok(())
    }
}

/// Why a configuration was rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamError {
    /// A field is NaN, infinite or outside its valid range.
    OutOfRange {
        /// The field, as `block.field_unit`.
        name: &'static str,
        value: f64,
        /// Smallest valid value (inclusive).
        min: f64,
        /// Largest valid value (inclusive).
        max: f64,
    },
    /// A field must be strictly below another one (the exit threshold of a
    /// hysteresis below its entry threshold, a lower limit below an upper).
    NotBelow {
        name: &'static str,
        value: f64,
        /// The field it must be below.
        limit_name: &'static str,
        limit: f64,
    },
    /// The gas model failed at the static charge state.
    Gas(hp_core::Error),
    /// The gas model gave no usable pressure in L at this temperature and
    /// volume offset (see [`crate::gas_table`]; not finite, or not falling
    /// as L's gas volume grows): the unit is configured outside the gas
    /// model's range.
    GasTable { t_k: f64, volume_offset_m: f64, p_pa: f64 },
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ParamError::OutOfRange { name, value, min, max } => {
                write!(f, "{name} = {value:e} is outside the valid range [{min:e}, {max:e}]")
            }
            ParamError::NotBelow { name, value, limit_name, limit } => {
                write!(f, "{name} = {value:e} must be below {limit_name} = {limit:e}")
            }
            ParamError::Gas(e) => write!(f, "gas model at the static charge: {e}"),
            ParamError::GasTable { t_k, volume_offset_m, p_pa } => write!(
                f,
                "gas model gives no usable pressure in L at {t_k} K and volume offset {volume_offset_m} m \
                 (p = {p_pa:e} Pa): the unit is outside the gas model's range"
            ),
        }
    }
}

/// Checks that `value` is finite and within `[min, max]`.
pub(crate) fn check(name: &'static str, value: f64, min: f64, max: f64) -> Result<(), ParamError> {
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        Err(ParamError::OutOfRange { name, value, min, max })
    }
}

/// Checks that `value < limit` (both already checked to be finite).
pub(crate) fn check_below(
    name: &'static str,
    value: f64,
    limit_name: &'static str,
    limit: f64,
) -> Result<(), ParamError> {
    if value < limit {
        Ok(())
    } else {
        Err(ParamError::NotBelow { name, value, limit_name, limit })
    }
}
