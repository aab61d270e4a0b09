//! Vehicles on the hydro-pneumatic unit, for the host (simulation, tuning,
//! the Python bindings): not flown, so it may use `std`; the step functions
//! allocate nothing all the same.
//!
//! Same style as `hp-core` and `hp-ctrl`: validated, immutable parameters,
//! a state, pure rate and step functions.
//!
//! - [`tyre`]: the tyre as a radial spring and damper that can lift off.
//! - [`corner`]: one wheel station, unit and tyre, shared by both models.
//! - [`quarter_car`]: sprung mass, unit, wheel, tyre, road.
//! - [`handling`]: the single-track model (speed, steering -> lateral
//!   acceleration) with any number of axles.
//! - [`vehicle`]: the rigid body in heave, pitch and roll on 2-4 axles, a
//!   unit with its own valves per wheel, the handling model.
//! - [`gas_table`]: the reference gas tabulated once per process for the
//!   vehicles' fixed steps.
//! - [`track`]: road height over distance, left and right.
//! - [`presets`]: an armoured-vehicle class 4x4 and 8x8.
//! - [`closed_loop`]: the controller (`hp-ctrl`) on the SDOF rig.
//! - [`drive`]: the vehicle with one controller per wheel (or passive).
//! - [`wide`]: whether the drive loop runs in its AVX2 compilation.
//!
//! `hp-ctrl`'s closed-loop runner used to live in that crate; it moved here
//! so the controller crate holds only what flies.

// `!(x > y)` is how NaN is rejected together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod closed_loop;
pub mod corner;
pub mod drive;
pub mod gas_table;
pub mod handling;
pub mod presets;
pub mod quarter_car;
mod ros2;
mod stepping;
pub mod track;
pub mod tyre;
pub mod vehicle;
pub mod wide;
