//! Built-in vehicles: an armoured-vehicle class 4x4 and 8x8 near the seed's
//! 3 t per wheel, each wheel on the seed's unit (`hp_core::presets`).
//!
//! They are classes, not particular vehicles: the masses, inertias and
//! geometry are of the order of wheeled armoured vehicles of 13 t (4x4) and
//! 27 t (8x8) combat weight, chosen so that every wheel carries the seed's
//! 3000 kg of sprung mass (the unit's charge then matches its load and it
//! sits at its static position). The numbers are assumptions and are listed
//! here with their reasoning; the ride and handling results depend on them.
//!
//! - Tyres: large off-road tyres (14.00 R20 / 395/85 R20 class) at road
//!   pressure: radial stiffness 1.2 MN/m, damping 3 kN s/m; cornering
//!   stiffness about 6 times the static wheel load per radian.
//! - Unsprung mass 400 kg per wheel (wheel, hub reduction, brake, half the
//!   links): wheel hop near 8.7 Hz.
//! - Centre of gravity high (armour, turret ring): 1.3-1.4 m, roll axis
//!   0.5 m. Inertias of a uniform box of the hull's size.
//! - The 8x8 steers its first two axles (the second at the Ackermann ratio
//!   for a turn centre between the rear two).

use hp_core::presets::{seed_unit, SEED_SPRUNG_MASS_KG};
use hp_core::unit::STANDARD_GRAVITY_M_S2;

use crate::quarter_car::QuarterCarParams;
use crate::tyre::Tyre;
use crate::vehicle::{Axle, Body, Seat, VehicleParams, MAX_AXLES};

/// The tyre of the built-in vehicles.
pub const TYRE: Tyre = Tyre { stiffness_n_per_m: 1.2e6, damping_n_s_per_m: 3.0e3 };
/// Unsprung mass per wheel, kg.
pub const UNSPRUNG_MASS_KG: f64 = 400.0;
/// Loaded wheel radius, m.
pub const WHEEL_RADIUS_M: f64 = 0.6;
/// Cornering stiffness per tyre over its static load, 1/rad.
pub const CORNERING_STIFFNESS_PER_LOAD: f64 = 6.0;

/// The seed's unit under one wheel of the built-in vehicles.
pub fn quarter_car() -> QuarterCarParams {
    QuarterCarParams { sprung_mass_kg: SEED_SPRUNG_MASS_KG, unsprung_mass_kg: UNSPRUNG_MASS_KG, tyre: TYRE }
}

fn axle(x_m: f64, track_m: f64, steer_ratio: f64) -> Axle {
    let wheel_load_n = (SEED_SPRUNG_MASS_KG + UNSPRUNG_MASS_KG) * STANDARD_GRAVITY_M_S2;
    Axle {
        x_m,
        track_m,
        unsprung_mass_kg: UNSPRUNG_MASS_KG,
        wheel_radius_m: WHEEL_RADIUS_M,
        tyre: TYRE,
        cornering_stiffness_n_per_rad: 2.0 * CORNERING_STIFFNESS_PER_LOAD * wheel_load_n,
        steer_ratio,
        unit: seed_unit(),
    }
}

/// A 4x4 armoured vehicle: 12 t sprung (3 t per wheel), 3.5 m wheelbase,
/// 2.1 m track; driver's seat front left.
pub fn armoured_4x4() -> VehicleParams {
    let a = axle(0.0, 2.1, 0.0);
    VehicleParams {
        body: Body {
            mass_kg: 4.0 * SEED_SPRUNG_MASS_KG,
            roll_inertia_kg_m2: 1.2e4,
            pitch_inertia_kg_m2: 4.0e4,
            yaw_inertia_kg_m2: 4.5e4,
            cg_height_m: 1.3,
            roll_centre_height_m: 0.5,
        },
        axles: [axle(1.75, 2.1, 1.0), axle(-1.75, 2.1, 0.0), a, a],
        axle_count: 2,
        steering_ratio: 20.0,
        seat: Seat { x_m: 0.9, y_m: 0.5, height_m: 1.6 },
    }
}

/// An 8x8 armoured vehicle: 24 t sprung (3 t per wheel), axles 1.45 /
/// 2.05 / 1.45 m apart, 2.4 m track, first two axles steered; a crew seat
/// in the troop compartment, behind the centre of gravity.
pub fn armoured_8x8() -> VehicleParams {
    // Second axle at the Ackermann ratio for a turn centre midway between
    // the rear two: (x_2 - x_c) / (x_1 - x_c) with x_c = -1.75 m.
    let steer_2 = (1.025 + 1.75) / (2.475 + 1.75);
    VehicleParams {
        body: Body {
            mass_kg: 8.0 * SEED_SPRUNG_MASS_KG,
            roll_inertia_kg_m2: 2.8e4,
            pitch_inertia_kg_m2: 1.3e5,
            yaw_inertia_kg_m2: 1.4e5,
            cg_height_m: 1.4,
            roll_centre_height_m: 0.5,
        },
        axles: [axle(2.475, 2.4, 1.0), axle(1.025, 2.4, steer_2), axle(-1.025, 2.4, 0.0), axle(-2.475, 2.4, 0.0)],
        axle_count: MAX_AXLES,
        steering_ratio: 20.0,
        seat: Seat { x_m: -1.5, y_m: 0.7, height_m: 1.5 },
    }
}

/// The distance from the front axle to the centre of the unsteered axles,
/// m: the wheelbase of the equivalent two-axle vehicle for the kinematic
/// steering relation `a_y = v^2 delta / L` the controller's steering
/// trigger uses.
///
/// ```
/// use hp_vehicle::presets::{armoured_4x4, armoured_8x8, effective_wheelbase_m};
/// assert!((effective_wheelbase_m(&armoured_4x4()) - 3.5).abs() < 1e-12);
/// assert!((effective_wheelbase_m(&armoured_8x8()) - 4.225).abs() < 1e-12);
/// ```
pub fn effective_wheelbase_m(p: &VehicleParams) -> f64 {
    let axles = p.axles.get(..p.axle_count).unwrap_or(&[]);
    let front = axles.first().map_or(0.0, |a| a.x_m);
    let (sum, n) = axles.iter().filter(|a| a.steer_ratio == 0.0).fold((0.0, 0.0), |(s, n), a| (s + a.x_m, n + 1.0));
    if n > 0.0 {
        front - sum / n
    } else {
        front - axles.last().map_or(0.0, |a| a.x_m)
    }
}

/// The controller's configuration for a vehicle: the seed unit's
/// calibration with the vehicle's steering ratio and effective wheelbase
/// (the steering trigger's kinematic prediction).
pub fn controller_config(p: &VehicleParams) -> hp_ctrl::Config {
    let mut c = hp_ctrl::Config::seed_unit();
    c.mode.steering_ratio = p.steering_ratio;
    c.mode.wheelbase_m = effective_wheelbase_m(p);
    c
}
