//! Plant physics of a two-state hydro-pneumatic spring-damper unit.
//!
//! `no_std`, no allocator, no panics: every fallible operation returns
//! [`Result`]. All quantities are SI with the unit in the name.
//!
//! - [`gas`]: nitrogen equations of state (ideal, Benedict-Webb-Rubin).
//! - [`thermal`]: the energy equation of a gas volume (the seed's Eq. 1).
//! - [`damper`]: the damper pack, bypass valve 5 and the valve-6 orifice.
//! - [`unit`]: the spring-damper unit and its optional effects.
//! - [`lag`]: the first-order lag of the transducers (in the ODE and on samples).
//! - [`motion`], [`rig`]: the characterisation and SDOF rigs.
//! - [`ode`]: fixed-step RK4; [`adaptive`]: error-controlled steps
//!   (Dormand-Prince 5(4), and Rosenbrock-W for the stiff valve-6 exchange)
//!   with dense output.
//! - [`presets`]: the seed's unit.
//! - [`ranges`]: the valid range of every unit parameter.
#![no_std]
// `!(x > y)` is how NaN is rejected together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod adaptive;
pub mod damper;
pub mod effect;
pub mod error;
pub mod gas;
pub mod lag;
pub mod motion;
pub mod ode;
pub mod presets;
pub mod ranges;
pub mod rig;
pub mod thermal;
pub mod unit;

pub use error::{Error, Result};
