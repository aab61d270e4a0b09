//! FMI 2.0 co-simulation FMUs of the hydro-pneumatic unit and its
//! controller.
//!
//! - [`model`]: what a model author writes (a variable table, the
//!   [`model::Model`] trait).
//! - [`fmi2`], `export`: the standard's C API, written once: life cycle,
//!   value references, logging, FMU state, panics caught at the boundary.
//! - [`description`]: `modelDescription.xml`, generated from the table.
//! - [`unit`], [`controller`]: the two models, on `hp-core` and `hp-ctrl`.
//!
//! One shared library serves both FMUs (the GUID picks the model);
//! `scripts/build-fmu.sh` packs it into `hpctl_unit.fmu` and
//! `hpctl_controller.fmu`. See `docs/fmu.md`.

// `!(x > y)` is how NaN is rejected together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod controller;
pub mod description;
mod export;
pub mod fmi2;
pub mod model;
pub mod unit;

use model::Model;

/// The models of this library, by the GUID of their model description.
pub fn registry(guid: &str) -> Option<Box<dyn fmi2::Component>> {
    if guid == unit::UnitModel::info().guid() {
        Some(Box::new(fmi2::Core::<unit::UnitModel>::new()))
    } else if guid == controller::ControllerModel::info().guid() {
        Some(Box::new(fmi2::Core::<controller::ControllerModel>::new()))
    } else {
        None
    }
}

/// The model with FMI `identifier` (`hpctl_unit`, `hpctl_controller`).
pub fn model_info(identifier: &str) -> Option<&'static model::ModelInfo> {
    [unit::UnitModel::info(), controller::ControllerModel::info()].into_iter().find(|i| i.identifier == identifier)
}
