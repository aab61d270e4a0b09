//! Plant physics of a two-state hydro-pneumatic spring-damper unit.
#![no_std]
#![cfg_attr(not(test), deny(clippy::float_cmp_const))]

pub mod error;
pub mod gas;

pub use error::{Error, Result};
