//! Valve-switching controller of the hydro-pneumatic unit.
//!
//! One pure function, [`step`], in the shape `step(&params, &mut state,
//! &inputs, dt) -> outputs`: immutable parameters, mutable state, measured
//! inputs in, valve commands out. It is `no_std`, allocation-free,
//! panic-free and deterministic, so the same code runs on the host (tests,
//! simulation, Python) and on the ECU.
//!
//! The blocks, each with its configuration, compiled parameters and state:
//!
//! - [`monitor`]: input plausibility, staleness, the safe state and recovery.
//! - [`estimator`]: strut and body velocity for the skyhook law.
//! - [`mode`]: ride/handling selection with hysteresis and a hold time.
//! - [`damper`]: valve 5, on-off skyhook.
//! - [`ride_height`]: valve 6, pump-free ride-height sequencing and the
//!   spring mode.
//! - [`load`]: the static load pressure, the ride height's zero reference.
//! - [`gas_table`]: the gas in accumulator L, tabulated once.
//! - [`gas_charge`]: gas-charge loss detection from the same table.
//!
//! - [`vehicle`]: one ECU for 4 to 8 corners: per-corner controllers,
//!   vehicle-level ride height, gas-charge diagnostics.
//!
//! The closed loop with the plant model (host simulation) lives in the
//! host-side crate `hp-vehicle`, so this crate holds only what flies.
//!
//! Numerics: the ECU (Cortex-M4F) has a single-precision FPU only, where a
//! double-precision operation costs about a hundred instructions, so the
//! filters, thresholds and the gas table work in `f32` (inputs are rounded
//! to `f32` on entry). The checks whose edges matter exactly are done on
//! the `f64` inputs as given: the plausibility ranges and the valve-6
//! pressure comparison. Timers count whole microseconds.
//!
//! `docs/controller.md` documents the modes, thresholds, the safe state and
//! every diagnostic flag.
#![no_std]

pub mod calibration;
pub mod can;
pub mod clock;
pub mod config;
mod controller;
pub mod damper;
pub mod diag;
pub mod estimator;
pub mod gas_charge;
pub mod gas_table;
mod io;
pub mod load;
pub mod mode;
pub mod monitor;
pub mod ride_height;
pub mod vehicle;

pub use config::{Config, ParamError};
pub use controller::{step, step_all, Params, State};
#[cfg(all(feature = "wide", target_arch = "x86_64"))]
pub use controller::step_all_avx2;
pub use io::{input_group, DamperMode, DriveMode, DriverMode, Inputs, Outputs, SequencerState, SpringMode};
