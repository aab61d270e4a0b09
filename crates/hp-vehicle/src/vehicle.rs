//! The full vehicle: a rigid body in heave, pitch and roll on two to four
//! axles, one hydro-pneumatic unit and one tyre per wheel, each unit with
//! its own valves, and the single-track handling model
//! ([`crate::handling`]) for the lateral motion.
//!
//! Axes (ISO 8855): x forward, y left, z up. Displacements are from static
//! equilibrium. Pitch is positive nose down, roll positive left side up
//! (the body rolls that way in a left turn). Small angles: the body point
//! above a wheel at `(x_i, y_i)` moves by `z - x_i pitch + y_i roll`.
//!
//! ```text
//! heave:  m_s z''        = sum F_i - m_s g
//! pitch:  I_yy pitch''   = -sum x_i F_i - m_s a_x h_cg
//! roll:   I_ra roll''    = sum y_i F_i + m_s (a_y + g roll) (h_cg - h_rc)
//! wheel:  m_u z_w,i''    = T_i - F_i - m_u g - dF_i
//! ```
//!
//! `F_i` is strut `i`'s force (compression positive), `T_i` its tyre's
//! (point contact, lifts off: [`crate::tyre`]). Roll is about the roll axis
//! at height `h_rc` (`I_ra = I_xx + m_s (h_cg - h_rc)^2`): the springs carry
//! the roll moment of the sprung mass's lateral inertia above it, with the
//! destabilising shift of its weight; the part below it goes straight to
//! the tyres through the links as the geometric load transfer `dF_i` (the
//! sprung mass share of the axle at `h_rc` and the unsprung masses at the
//! wheel centre, over the track). Pitch is about the centre of gravity
//! with the braking or driving force at the ground (no anti-dive
//! geometry). The lateral acceleration `a_y` comes from the single-track
//! model; the longitudinal `a_x` and the speed are inputs.
//!
//! Static loads: the body sits at its nominal position with each wheel's
//! share of the sprung weight distributed as equal linear springs would
//! carry it (`L_i = a + b x_i`, with `sum L_i = m_s g` and no pitch moment);
//! each unit sits where it carries its share ([`Unit::static_disp_for_load_m`]).
//! The built-in vehicles put the centre of gravity at the middle of the
//! axles, so every wheel carries the same load and the units sit at their
//! static position.

use hp_core::error::{check_range, Error, Result};
use hp_core::gas::table::TabulatedGas;
use hp_core::gas::{EquationOfState, Gas, Span};
use hp_core::ode::OdeSystem;
use hp_core::unit::{Unit, UnitParams, UnitState, Valves, STANDARD_GRAVITY_M_S2, UNIT_STATES};

use crate::corner::{self, CornerForces, CornerMotion};
use crate::handling::{self, HandlingAxle, HandlingState};
use crate::ros2::{BodyInertia, CornerLinearisation, W};
use crate::stepping;
use crate::track::Road;
use crate::tyre::Tyre;

const G: f64 = STANDARD_GRAVITY_M_S2;

/// Most axles a vehicle can have.
pub const MAX_AXLES: usize = 4;
/// Most wheels (two per axle).
pub const MAX_CORNERS: usize = 2 * MAX_AXLES;
/// States per corner: the unit's, wheel displacement and velocity.
pub const CORNER_STATES: usize = UNIT_STATES + 2;
/// States of the body: heave, pitch, roll with their rates; lateral
/// velocity, yaw rate, heading, lateral position and distance travelled.
pub const BODY_STATES: usize = 11;
/// All states (unused corners stay at zero).
pub const VEHICLE_STATES: usize = BODY_STATES + MAX_CORNERS * CORNER_STATES;

/// The sprung mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Sprung mass, kg.
    pub mass_kg: f64,
    /// Roll inertia about the centre of gravity, kg m^2.
    pub roll_inertia_kg_m2: f64,
    /// Pitch inertia about the centre of gravity, kg m^2.
    pub pitch_inertia_kg_m2: f64,
    /// Yaw inertia of the whole vehicle, kg m^2.
    pub yaw_inertia_kg_m2: f64,
    /// Height of the centre of gravity above the ground, m.
    pub cg_height_m: f64,
    /// Height of the roll axis above the ground, m.
    pub roll_centre_height_m: f64,
}

/// One axle: two wheels, each with its unit, tyre and unsprung mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axle {
    /// Position ahead of the centre of gravity, m (front axle first).
    pub x_m: f64,
    /// Track width (between the wheel centres), m.
    pub track_m: f64,
    /// Unsprung mass per wheel, kg.
    pub unsprung_mass_kg: f64,
    /// Wheel centre height (loaded radius), m.
    pub wheel_radius_m: f64,
    pub tyre: Tyre,
    /// Cornering stiffness of the axle (both tyres), N/rad.
    pub cornering_stiffness_n_per_rad: f64,
    /// Road-wheel angle per unit of the front axle's (1 front, 0 unsteered).
    pub steer_ratio: f64,
    /// The unit at each wheel of this axle.
    pub unit: UnitParams,
}

/// Where ride comfort is measured (ISO 2631-1 at the seat).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Seat {
    /// Ahead of the centre of gravity, m.
    pub x_m: f64,
    /// Left of the centre line, m.
    pub y_m: f64,
    /// Height of the seat surface above the ground, m.
    pub height_m: f64,
}

/// Everything that defines a vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleParams {
    pub body: Body,
    /// The axles, front first; only the first `axle_count` are used.
    pub axles: [Axle; MAX_AXLES],
    pub axle_count: usize,
    /// Steering-wheel angle per front road-wheel angle.
    pub steering_ratio: f64,
    pub seat: Seat,
}

/// A wheel station's geometry and static state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerGeometry {
    /// Index of its axle.
    pub axle: usize,
    /// Left wheel (else right).
    pub left: bool,
    pub x_m: f64,
    pub y_m: f64,
    /// Static share of the sprung weight, N.
    pub static_load_n: f64,
    /// Static strut compression, m.
    pub static_disp_m: f64,
    /// Static tyre deflection, m.
    pub tyre_static_deflection_m: f64,
    /// Geometric load transfer: extra downward force on the wheel per unit
    /// of lateral acceleration, N / (m/s^2).
    pub lateral_transfer_kg: f64,
    /// Unsprung mass, kg.
    pub unsprung_mass_kg: f64,
    pub tyre: Tyre,
}

/// The inputs of one control period, held over it: what the driver does.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveInputs {
    /// Forward speed, m/s.
    pub speed_m_s: f64,
    /// Longitudinal acceleration, m/s^2 (negative = braking).
    pub long_acc_m_s2: f64,
    /// Steering-wheel angle, rad (left positive).
    pub steer_angle_rad: f64,
}

/// How the vehicle is advanced between two control instants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stepping {
    /// Classical RK4, four evaluations a step: the reference the faster
    /// method is checked against (and what the vehicles used before).
    Rk4,
    /// ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999, SIAM J. Sci. Comput.
    /// 20): a two-stage, second-order, L-stable Rosenbrock-W method, linearly
    /// implicit in the fast coupled part of the vehicle (each corner's gas
    /// volumes and temperatures with valve 6, strut and tyre, the wheel,
    /// and the body through the strut forces: `ros2.rs`), so that
    /// one step per 1 ms control period follows the wheel hop and valve 6
    /// does not limit the step; everything else is explicit. Two
    /// evaluations a step instead of RK4's four.
    #[default]
    Ros2,
}

/// ROS2's `gamma = 1 - 1/sqrt(2)`, the smaller of the two that make it
/// L-stable: with the corners and the body in `W` its error constant on
/// the wheel hop is a quarter of an explicit two-stage method's, where
/// `1 + 1/sqrt(2)` makes it eight times larger (measured on the 8x8's rough
/// road, soft spring and damper off, after 1 s: 1.5 um against 46 um from
/// RK4 at 1 ms with the whole Jacobian in `W`; BENCHMARKS.md).
const ROS2_GAMMA: f64 = 1.0 - core::f64::consts::FRAC_1_SQRT_2;

/// The state rate at one instant, with each corner's linearisation when
/// it was asked for and the stepping is linearly implicit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    pub state: VehicleState,
    couplings: Couplings,
    linearised: bool,
}

impl Default for Rate {
    fn default() -> Self {
        Rate { state: VehicleState { y: [0.0; VEHICLE_STATES] }, couplings: [CornerLinearisation::default(); MAX_CORNERS], linearised: false }
    }
}

type Couplings = [CornerLinearisation; MAX_CORNERS];

/// A validated vehicle with its static equilibrium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    params: VehicleParams,
    /// The unit of each corner (a copy per wheel keeps the hot loop flat).
    units: [Unit; MAX_CORNERS],
    corners: [CornerGeometry; MAX_CORNERS],
    handling: [HandlingAxle; MAX_AXLES],
    ambient_k: f64,
    total_mass_kg: f64,
    roll_arm_m: f64,
    roll_axis_inertia_kg_m2: f64,
    /// The reference gas's table, used for the units whose gas is the
    /// reference one (None: every unit evaluates its equation directly).
    gas_table: Option<TabulatedGas<'static, Span>>,
    stepping: Stepping,
}

/// The state of a vehicle: a flat array for the integrator, read through
/// accessors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleState {
    pub y: [f64; VEHICLE_STATES],
}

impl VehicleState {
    /// Corner `i`'s unit state (None beyond the array).
    pub fn unit(&self, i: usize) -> Option<UnitState> {
        corner_chunks(&self.y).nth(i).map(|c| split_corner(c).0)
    }

    /// Distance travelled, m.
    pub fn distance_m(&self) -> f64 {
        self.y.get(10).copied().unwrap_or(0.0)
    }
}

/// The body's motion at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodySample {
    pub heave_m: f64,
    pub heave_vel_m_s: f64,
    pub heave_acc_m_s2: f64,
    pub pitch_rad: f64,
    pub pitch_rate_rad_s: f64,
    pub pitch_acc_rad_s2: f64,
    pub roll_rad: f64,
    pub roll_rate_rad_s: f64,
    pub roll_acc_rad_s2: f64,
}

/// One wheel station at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerSample {
    /// Strut, unit and tyre (the tyre force is the wheel load on the road).
    pub forces: CornerForces,
    pub wheel_disp_m: f64,
    pub wheel_vel_m_s: f64,
    pub wheel_acc_m_s2: f64,
    /// Road height under the wheel, m.
    pub road_m: f64,
    /// Vertical acceleration of the body above the wheel, gravity removed, m/s^2.
    pub body_acc_m_s2: f64,
    /// Gas volumes of S and L, m^3.
    pub v_gas_m3: f64,
    pub v_gas2_m3: f64,
    pub valves: Valves,
}

/// Everything observed at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VehicleSample {
    pub time_s: f64,
    pub distance_m: f64,
    pub speed_m_s: f64,
    pub long_acc_m_s2: f64,
    pub steer_angle_rad: f64,
    /// Lateral acceleration of the centre of gravity, m/s^2.
    pub lat_acc_m_s2: f64,
    pub lat_vel_m_s: f64,
    pub yaw_rate_rad_s: f64,
    pub heading_rad: f64,
    /// Lateral position of the centre of gravity, m.
    pub lateral_pos_m: f64,
    pub body: BodySample,
    /// Specific force at the seat in body axes (what an accelerometer on the
    /// seat reads, gravity removed from z), m/s^2.
    pub seat_acc_x_m_s2: f64,
    pub seat_acc_y_m_s2: f64,
    pub seat_acc_z_m_s2: f64,
    pub corners: [CornerSample; MAX_CORNERS],
    pub corner_count: usize,
}

impl Vehicle {
    /// Checks every parameter, builds the units and finds the static
    /// equilibrium with every unit's valves at `valves`, at ambient
    /// temperature `ambient_k` (also the initial gas temperature).
    pub fn new(params: VehicleParams, ambient_k: f64, valves: Valves) -> Result<Self> {
        check_range("ambient_k", ambient_k, 200.0, 600.0)?;
        let b = &params.body;
        check_range("axle_count", params.axle_count as f64, 2.0, MAX_AXLES as f64)?;
        check_range("body_mass_kg", b.mass_kg, 10.0, 1e6)?;
        check_range("roll_inertia_kg_m2", b.roll_inertia_kg_m2, 1.0, 1e8)?;
        check_range("pitch_inertia_kg_m2", b.pitch_inertia_kg_m2, 1.0, 1e8)?;
        check_range("yaw_inertia_kg_m2", b.yaw_inertia_kg_m2, 1.0, 1e8)?;
        check_range("cg_height_m", b.cg_height_m, 0.05, 10.0)?;
        check_range("roll_centre_height_m", b.roll_centre_height_m, -1.0, b.cg_height_m)?;
        check_range("steering_ratio", params.steering_ratio, 1.0, 100.0)?;
        check_range("seat_x_m", params.seat.x_m, -50.0, 50.0)?;
        check_range("seat_y_m", params.seat.y_m, -10.0, 10.0)?;
        check_range("seat_height_m", params.seat.height_m, 0.0, 10.0)?;
        let axles = params.axles.get(..params.axle_count).unwrap_or(&[]);
        let mut last_x = f64::INFINITY;
        for a in axles {
            check_range("axle_x_m", a.x_m, -50.0, last_x)?;
            if a.x_m == last_x {
                return Err(Error::OutOfRange { name: "axle_x_m (front axle first, distinct)", value: a.x_m, min: -50.0, max: last_x });
            }
            last_x = a.x_m;
            check_range("track_m", a.track_m, 0.2, 10.0)?;
            check_range("unsprung_mass_kg", a.unsprung_mass_kg, 0.1, 1e5)?;
            check_range("wheel_radius_m", a.wheel_radius_m, 0.05, 5.0)?;
            a.tyre.validate()?;
            check_range("cornering_stiffness_n_per_rad", a.cornering_stiffness_n_per_rad, 1e2, 1e8)?;
            check_range("steer_ratio", a.steer_ratio, -1.0, 1.0)?;
        }
        // Static loads of equal linear springs: L_i = a + b x_i per wheel,
        // sum L = m g, sum x L = 0 (two wheels per axle).
        let n = 2.0 * axles.len() as f64;
        let sx: f64 = axles.iter().map(|a| 2.0 * a.x_m).sum();
        let sxx: f64 = axles.iter().map(|a| 2.0 * a.x_m * a.x_m).sum();
        let weight = b.mass_kg * G;
        let det = n * sxx - sx * sx;
        let (ca, cb) = (weight * sxx / det, -weight * sx / det);
        let [first, ..] = params.axles;
        let mut units = [Unit::new(first.unit)?; MAX_CORNERS];
        let unused = CornerGeometry {
            axle: 0,
            left: true,
            x_m: 0.0,
            y_m: 0.0,
            static_load_n: 0.0,
            static_disp_m: 0.0,
            tyre_static_deflection_m: 0.0,
            lateral_transfer_kg: 0.0,
            unsprung_mass_kg: first.unsprung_mass_kg,
            tyre: first.tyre,
        };
        let mut corners = [unused; MAX_CORNERS];
        let mut handling = [HandlingAxle::default(); MAX_AXLES];
        let mut unsprung_total = 0.0;
        for (k, a) in axles.iter().enumerate() {
            let unit = Unit::new(a.unit)?;
            let load = ca + cb * a.x_m;
            if !(load > 0.0) {
                return Err(Error::OutOfRange { name: "axle_x_m (centre of gravity outside the axles)", value: a.x_m, min: f64::NAN, max: f64::NAN });
            }
            let static_disp_m = unit.static_disp_for_load_m(load, ambient_k, valves)?;
            let axle_sprung_kg = 2.0 * load / G;
            let transfer = (axle_sprung_kg * b.roll_centre_height_m + 2.0 * a.unsprung_mass_kg * a.wheel_radius_m) / a.track_m;
            for (side, left) in [(0usize, true), (1usize, false)] {
                let y = if left { 0.5 * a.track_m } else { -0.5 * a.track_m };
                if let Some(c) = corners.get_mut(2 * k + side) {
                    *c = CornerGeometry {
                        axle: k,
                        left,
                        x_m: a.x_m,
                        y_m: y,
                        static_load_n: load,
                        static_disp_m,
                        tyre_static_deflection_m: (load + a.unsprung_mass_kg * G) / a.tyre.stiffness_n_per_m,
                        // A left turn (a_y > 0) loads the right wheels.
                        lateral_transfer_kg: if left { -transfer } else { transfer },
                        unsprung_mass_kg: a.unsprung_mass_kg,
                        tyre: a.tyre,
                    };
                }
                if let Some(u) = units.get_mut(2 * k + side) {
                    *u = unit;
                }
            }
            if let Some(h) = handling.get_mut(k) {
                *h = HandlingAxle { x_m: a.x_m, cornering_stiffness_n_per_rad: a.cornering_stiffness_n_per_rad, steer_ratio: a.steer_ratio };
            }
            unsprung_total += 2.0 * a.unsprung_mass_kg;
        }
        let roll_arm_m = b.cg_height_m - b.roll_centre_height_m;
        Ok(Vehicle {
            params,
            units,
            corners,
            handling,
            ambient_k,
            total_mass_kg: b.mass_kg + unsprung_total,
            roll_arm_m,
            roll_axis_inertia_kg_m2: b.roll_inertia_kg_m2 + b.mass_kg * roll_arm_m * roll_arm_m,
            gas_table: crate::gas_table::span(),
            stepping: Stepping::default(),
        })
    }

    /// The same vehicle with every unit's gas evaluated directly from its
    /// equation of state instead of the table ([`crate::gas_table`]): the
    /// reference the tabulated runs are checked against.
    pub fn with_direct_gas(mut self) -> Self {
        self.gas_table = None;
        self
    }

    /// The same vehicle with corner `i`'s unit built from `unit` instead of
    /// its axle's (e.g. the axle's unit with a gas leak, `Effects::leakage`),
    /// at rest where it carries the corner's static load with `valves` (as
    /// [`Vehicle::new`] places every unit). The other corners are unchanged.
    ///
    /// ```
    /// use hp_core::unit::{Effects, Leakage, Valves};
    /// use hp_vehicle::{presets::armoured_4x4, vehicle::Vehicle};
    /// let p = armoured_4x4();
    /// let v = Vehicle::new(p, 293.15, Valves::default()).unwrap();
    /// let leaky = hp_core::unit::UnitParams { effects: Effects { leakage: Some(Leakage { time_constant_s: 100.0, pressure_exponent: 0.0, mass_exponent: 1.0 }), ..p.axles[0].unit.effects }, ..p.axles[0].unit };
    /// let w = v.with_corner_unit(3, leaky, Valves::default()).unwrap();
    /// assert_eq!(w.unit(3).unwrap().params().effects.leakage, Some(Leakage { time_constant_s: 100.0, pressure_exponent: 0.0, mass_exponent: 1.0 }));
    /// assert_eq!(w.unit(2), v.unit(2));
    /// assert!(v.with_corner_unit(4, leaky, Valves::default()).is_err()); // a 4x4 has corners 0-3
    /// ```
    pub fn with_corner_unit(mut self, i: usize, unit: UnitParams, valves: Valves) -> Result<Self> {
        let count = self.corner_count();
        let unit = Unit::new(unit)?;
        let ambient_k = self.ambient_k;
        let (Some(c), Some(u)) = (self.corners.get_mut(..count).and_then(|c| c.get_mut(i)), self.units.get_mut(..count).and_then(|u| u.get_mut(i))) else {
            return Err(Error::OutOfRange { name: "corner", value: i as f64, min: 0.0, max: count as f64 - 1.0 });
        };
        c.static_disp_m = unit.static_disp_for_load_m(c.static_load_n, ambient_k, valves)?;
        *u = unit;
        Ok(self)
    }

    /// The same vehicle advanced with `stepping`.
    pub fn with_stepping(mut self, stepping: Stepping) -> Self {
        self.stepping = stepping;
        self
    }

    /// How the vehicle is advanced.
    pub fn stepping(&self) -> Stepping {
        self.stepping
    }

    /// True when the units on the reference gas use its table.
    pub fn gas_tabulated(&self) -> bool {
        self.gas_table.is_some()
    }

    /// The parameters it was built from.
    pub fn params(&self) -> &VehicleParams {
        &self.params
    }

    /// Number of wheels.
    pub fn corner_count(&self) -> usize {
        2 * self.params.axle_count
    }

    /// The wheel stations (the first [`Vehicle::corner_count`] are used):
    /// axle by axle from the front, left wheel first.
    pub fn corners(&self) -> &[CornerGeometry] {
        self.corners.get(..self.corner_count()).unwrap_or(&[])
    }

    /// The unit of corner `i`.
    pub fn unit(&self, i: usize) -> Option<&Unit> {
        self.units.get(..self.corner_count()).and_then(|u| u.get(i))
    }

    /// Ambient temperature, K.
    pub fn ambient_k(&self) -> f64 {
        self.ambient_k
    }

    /// The body's side of the ROS2 step's `W` ([`crate::ros2`]).
    fn body_inertia(&self) -> BodyInertia {
        let b = &self.params.body;
        BodyInertia {
            inverse: [1.0 / b.mass_kg, 1.0 / b.pitch_inertia_kg_m2, 1.0 / self.roll_axis_inertia_kg_m2],
            roll_weight_per_inertia: b.mass_kg * G * self.roll_arm_m / self.roll_axis_inertia_kg_m2,
        }
    }

    /// Total mass (sprung and unsprung), kg.
    pub fn total_mass_kg(&self) -> f64 {
        self.total_mass_kg
    }

    /// At rest in static equilibrium on a level road at height zero, every
    /// unit's valves at `valves`.
    pub fn initial_state(&self, valves: &[Valves; MAX_CORNERS]) -> Result<VehicleState> {
        let mut y = [0.0; VEHICLE_STATES];
        let (_, corner_y) = y.split_at_mut(BODY_STATES);
        for (((c, unit), v), cy) in self.corners().iter().zip(&self.units).zip(valves).zip(corner_y.chunks_exact_mut(CORNER_STATES)) {
            let s = unit.state_at_rest(c.static_disp_m, self.ambient_k, *v)?.to_array();
            if let Some(o) = cy.first_chunk_mut::<UNIT_STATES>() {
                *o = s;
            }
        }
        Ok(VehicleState { y })
    }

    /// The vehicle on `road` with the period's `drive` inputs and valve
    /// commands: the ODE system the integrator steps.
    pub fn dynamics<'a>(&'a self, road: &'a Road<'a>, drive: DriveInputs, valves: [Valves; MAX_CORNERS]) -> Dynamics<'a> {
        Dynamics { vehicle: self, road, drive, valves }
    }
}

/// A vehicle on a road with the inputs and valves of one period.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics<'a> {
    vehicle: &'a Vehicle,
    road: &'a Road<'a>,
    pub drive: DriveInputs,
    pub valves: [Valves; MAX_CORNERS],
}

/// The corners' parts of a state (or rate) array.
fn corner_chunks(y: &[f64; VEHICLE_STATES]) -> core::slice::ChunksExact<'_, f64> {
    y.get(BODY_STATES..).unwrap_or(&[]).chunks_exact(CORNER_STATES)
}

/// One corner's [`corner::evaluate`] with its unit's rate written into
/// `out` and the corner's linearisation into `slot` (when wanted), so
/// that no large tuple is returned through the gas's two code paths.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn corner_into(
    gas: &impl EquationOfState,
    unit: &Unit,
    c: &CornerGeometry,
    outputs: bool,
    slot: Option<&mut CornerLinearisation>,
    unit_state: &UnitState,
    motion: &CornerMotion,
    valves: Valves,
    ambient_k: f64,
    out: &mut [f64; UNIT_STATES],
) -> CornerForces {
    let (rate, f, coupled) =
        corner::evaluate(unit, gas, outputs, slot.is_some(), &c.tyre, unit_state, motion, c.static_disp_m, c.tyre_static_deflection_m, valves, ambient_k);
    if let Some(s) = slot {
        // The tyre's slopes while it pushes (a tyre in the air, or one whose
        // damping would pull, exerts no force).
        let pushing = f.tyre_force_n > 0.0;
        let slope = |x: f64| if pushing { x } else { 0.0 };
        *s = CornerLinearisation::new(&coupled, slope(c.tyre.stiffness_n_per_m), slope(c.tyre.damping_n_s_per_m));
    }
    *out = rate.to_array();
    f
}

/// A corner's unit state and wheel displacement and velocity.
#[inline]
fn split_corner(cy: &[f64]) -> (UnitState, f64, f64) {
    let unit = cy.first_chunk::<UNIT_STATES>().map(UnitState::from_array).unwrap_or_default();
    let [wheel_disp, wheel_vel] = cy.last_chunk::<2>().copied().unwrap_or_default();
    (unit, wheel_disp, wheel_vel)
}

impl Dynamics<'_> {
    /// The state rate, and the sample when one is asked for.
    #[inline]
    fn evaluate(
        &self,
        t_s: f64,
        y: &[f64; VEHICLE_STATES],
        sample: Option<&mut VehicleSample>,
        couplings: Option<&mut Couplings>,
    ) -> [f64; VEHICLE_STATES] {
        let mut rate = [0.0; VEHICLE_STATES];
        self.evaluate_into(t_s, y, &mut rate, sample, couplings);
        rate
    }

    /// [`Dynamics::evaluate`] writing the rate into `rate` (every element:
    /// the unused corners' are zero), so that the stepper reuses its
    /// arrays instead of copying a returned one.
    ///
    /// Compiled once for each combination of a sample and a linearisation
    /// asked for or not, so that the stages that want neither (a ROS2
    /// step's second stage, most first stages) carry no code or live
    /// values for them: the same operations for what they compute.
    #[inline(always)]
    fn evaluate_into(
        &self,
        t_s: f64,
        y: &[f64; VEHICLE_STATES],
        rate: &mut [f64; VEHICLE_STATES],
        sample: Option<&mut VehicleSample>,
        couplings: Option<&mut Couplings>,
    ) {
        match (sample, couplings) {
            (None, None) => self.evaluate_into_for::<false, false>(t_s, y, rate, None, None),
            (None, c @ Some(_)) => self.evaluate_into_for::<false, true>(t_s, y, rate, None, c),
            (s @ Some(_), None) => self.evaluate_into_for::<true, false>(t_s, y, rate, s, None),
            (s @ Some(_), c @ Some(_)) => self.evaluate_into_for::<true, true>(t_s, y, rate, s, c),
        }
    }

    /// [`Dynamics::evaluate_into`] with `sample` and `couplings` known to
    /// be `Some` (`SAMPLE`, `LINEARISE`) or `None`.
    #[inline(always)]
    fn evaluate_into_for<const SAMPLE: bool, const LINEARISE: bool>(
        &self,
        t_s: f64,
        y: &[f64; VEHICLE_STATES],
        rate: &mut [f64; VEHICLE_STATES],
        sample: Option<&mut VehicleSample>,
        couplings: Option<&mut Couplings>,
    ) {
        let mut sample = if SAMPLE { sample } else { None };
        let mut couplings = if LINEARISE { couplings } else { None };
        let v = self.vehicle;
        let b = &v.params.body;
        let [heave, heave_vel, pitch, pitch_rate, roll, roll_rate, lat_vel, yaw_rate, heading, lateral_pos, distance, ..] = *y;
        let u = self.drive.speed_m_s;
        let steer = self.drive.steer_angle_rad / v.params.steering_ratio;
        let lateral = handling::rate(
            v.handling.get(..v.params.axle_count).unwrap_or(&[]),
            v.total_mass_kg,
            b.yaw_inertia_kg_m2,
            u,
            steer,
            &HandlingState { lat_vel_m_s: lat_vel, yaw_rate_rad_s: yaw_rate },
        );
        let a_y = lateral.lat_acc_m_s2;
        let (mut force, mut moment_pitch, mut moment_roll) = (0.0, 0.0, 0.0);
        let (_, corner_rate) = rate.split_at_mut(BODY_STATES);
        // Every element is written: the used corners' below, the rest zero.
        for cr in corner_rate.chunks_exact_mut(CORNER_STATES).skip(v.corner_count()) {
            cr.fill(0.0);
        }
        let corners = v.corners().iter().zip(&v.units).zip(&self.valves).zip(corner_chunks(y).zip(corner_rate.chunks_exact_mut(CORNER_STATES)));
        for (i, (((c, unit), valves), (cy, cr))) in corners.enumerate() {
            let (unit_state, wheel_disp, wheel_vel) = split_corner(cy);
            let track = if c.left { &self.road.left } else { &self.road.right };
            let (road_m, slope) = track.at(distance + c.x_m);
            let motion = CornerMotion {
                body_disp_m: heave - c.x_m * pitch + c.y_m * roll,
                body_vel_m_s: heave_vel - c.x_m * pitch_rate + c.y_m * roll_rate,
                wheel_disp_m: wheel_disp,
                wheel_vel_m_s: wheel_vel,
                road_m,
                road_vel_m_s: slope * u,
            };
            // Every output only for a sample; the stages need the rate and forces.
            let outputs = sample.is_some();
            let slot = couplings.as_deref_mut().and_then(|k| k.get_mut(i));
            let (unit_out, wheel_out) = cr.split_at_mut(UNIT_STATES);
            let Some(unit_out) = unit_out.first_chunk_mut::<UNIT_STATES>() else { continue };
            let f = match &v.gas_table {
                Some(table) if unit.params().gas == Gas::Span => {
                    corner_into(table, unit, c, outputs, slot, &unit_state, &motion, *valves, v.ambient_k, unit_out)
                }
                _ => corner_into(&unit.params().gas, unit, c, outputs, slot, &unit_state, &motion, *valves, v.ambient_k, unit_out),
            };
            let strut = f.unit.force_true_n;
            let wheel_acc = (f.tyre_force_n - strut - c.lateral_transfer_kg * a_y) / c.unsprung_mass_kg - G;
            force += strut;
            moment_pitch -= c.x_m * strut;
            moment_roll += c.y_m * strut;
            if let Some(o) = wheel_out.first_chunk_mut::<2>() {
                *o = [wheel_vel, wheel_acc];
            }
            if let Some(s) = sample.as_deref_mut().and_then(|s| s.corners.get_mut(i)) {
                s.forces = f;
                s.wheel_disp_m = wheel_disp;
                s.wheel_vel_m_s = wheel_vel;
                s.wheel_acc_m_s2 = wheel_acc;
                s.road_m = road_m;
                s.v_gas_m3 = unit_state.v_gas_m3;
                s.v_gas2_m3 = unit_state.v_gas2_m3;
                s.valves = *valves;
            }
        }
        let m = b.mass_kg;
        let heave_acc = force / m - G;
        let pitch_acc = (moment_pitch - m * self.drive.long_acc_m_s2 * b.cg_height_m) / b.pitch_inertia_kg_m2;
        let roll_acc = (moment_roll + m * (a_y + G * roll) * v.roll_arm_m) / v.roll_axis_inertia_kg_m2;
        let (sin_h, cos_h) = (libm::sin(heading), libm::cos(heading));
        if let Some(o) = rate.first_chunk_mut::<BODY_STATES>() {
            *o = [
                heave_vel,
                heave_acc,
                pitch_rate,
                pitch_acc,
                roll_rate,
                roll_acc,
                lateral.lat_vel_m_s2,
                lateral.yaw_acc_rad_s2,
                yaw_rate,
                u * sin_h + lat_vel * cos_h,
                u,
            ];
        }
        if let Some(s) = sample {
            let seat = &v.params.seat;
            let a_x = self.drive.long_acc_m_s2;
            s.time_s = t_s;
            s.distance_m = distance;
            s.speed_m_s = u;
            s.long_acc_m_s2 = a_x;
            s.steer_angle_rad = self.drive.steer_angle_rad;
            s.lat_acc_m_s2 = a_y;
            s.lat_vel_m_s = lat_vel;
            s.yaw_rate_rad_s = yaw_rate;
            s.heading_rad = heading;
            s.lateral_pos_m = lateral_pos;
            s.body = BodySample {
                heave_m: heave,
                heave_vel_m_s: heave_vel,
                heave_acc_m_s2: heave_acc,
                pitch_rad: pitch,
                pitch_rate_rad_s: pitch_rate,
                pitch_acc_rad_s2: pitch_acc,
                roll_rad: roll,
                roll_rate_rad_s: roll_rate,
                roll_acc_rad_s2: roll_acc,
            };
            // Specific force in body axes: the body's acceleration at the
            // seat (roll about the roll axis, pitch about the centre of
            // gravity, yaw) and gravity's share along the tilted axes.
            s.seat_acc_x_m_s2 = a_x - G * pitch + (seat.height_m - b.cg_height_m) * pitch_acc - seat.y_m * lateral.yaw_acc_rad_s2;
            s.seat_acc_y_m_s2 = a_y + G * roll - (seat.height_m - b.roll_centre_height_m) * roll_acc + seat.x_m * lateral.yaw_acc_rad_s2;
            s.seat_acc_z_m_s2 = heave_acc - seat.x_m * pitch_acc + seat.y_m * roll_acc;
            s.corner_count = v.corner_count();
            for (cs, c) in s.corners.iter_mut().zip(v.corners()) {
                cs.body_acc_m_s2 = heave_acc - c.x_m * pitch_acc + c.y_m * roll_acc;
            }
        }
    }

    fn check(&self, t_s: f64, y: &[f64; VEHICLE_STATES]) -> Result<()> {
        let v = self.vehicle;
        for (unit, cy) in v.units.iter().take(v.corner_count()).zip(corner_chunks(y)) {
            unit.check_state(&split_corner(cy).0, t_s)?;
        }
        finite(t_s, y)
    }

    /// Projects a step's result onto the units' constraints and checks it
    /// ([`Unit::project`], [`Dynamics::check`]), each unit's state in
    /// place in the array ([`Unit::project_and_check`]).
    #[inline(always)]
    fn finish(&self, t_s: f64, y: &mut [f64; VEHICLE_STATES]) -> Result<()> {
        let v = self.vehicle;
        let (_, corner_y) = y.split_at_mut(BODY_STATES);
        for (unit, cy) in v.units.iter().take(v.corner_count()).zip(corner_y.chunks_exact_mut(CORNER_STATES)) {
            if let Some(a) = cy.first_chunk_mut::<UNIT_STATES>() {
                unit.project_and_check(a, v.ambient_k, t_s)?;
            }
        }
        finite(t_s, y)
    }

    /// The state rate at `(t_s, state)`, with the observed quantities
    /// written into `sample`; fails if the state is outside the model's
    /// valid region.
    pub fn rate_and_sample(&self, t_s: f64, state: &VehicleState, sample: &mut VehicleSample) -> Result<Rate> {
        self.check(t_s, &state.y)?;
        let mut rate = Rate::default();
        self.rate_into(t_s, state, Some(sample), true, &mut rate);
        Ok(rate)
    }

    /// The state rate at `(t_s, state)`.
    pub fn rate(&self, t_s: f64, state: &VehicleState) -> Result<Rate> {
        self.check(t_s, &state.y)?;
        let mut rate = Rate::default();
        self.rate_into(t_s, state, None, true, &mut rate);
        Ok(rate)
    }

    /// [`Dynamics::rate`] (or, with a sample, [`Dynamics::rate_and_sample`])
    /// for a step that continues with `memory`: the linearisation that
    /// ROS2's `W` is built from is computed only when `memory` will build a
    /// new one ([`StepMemory`]).
    pub fn rate_for(&self, t_s: f64, state: &VehicleState, sample: Option<&mut VehicleSample>, memory: &StepMemory) -> Result<Rate> {
        self.check(t_s, &state.y)?;
        let mut rate = Rate::default();
        self.rate_into(t_s, state, sample, memory.rebuilds(&self.valves), &mut rate);
        Ok(rate)
    }

    /// The rate at `(t_s, state)` written into `rate`, for a state already
    /// checked: one [`Dynamics::advance`] returned, or
    /// [`Vehicle::initial_state`] (valid by construction). The drive loop
    /// would otherwise check every state twice, and copy a returned rate.
    /// With `linearise` (and ROS2 stepping) each corner's linearisation
    /// comes with it.
    #[inline(always)]
    pub(crate) fn rate_into(&self, t_s: f64, state: &VehicleState, sample: Option<&mut VehicleSample>, linearise: bool, rate: &mut Rate) {
        rate.linearised = linearise && self.vehicle.stepping == Stepping::Ros2;
        let couplings = if rate.linearised { Some(&mut rate.couplings) } else { None };
        self.evaluate_into(t_s, &state.y, &mut rate.state.y, sample, couplings);
    }

    /// Advances from `t_s` to `t_end_s` in equal steps of at most
    /// `max_dt_s` with the vehicle's [`Stepping`]; `rate` is the state rate
    /// at `t_s` with these inputs and valves (from
    /// [`Dynamics::rate_and_sample`] or [`Dynamics::rate`]). ROS2 builds
    /// its `W` from `rate`'s linearisation; a run that advances period
    /// after period keeps it with [`Dynamics::advance_with`].
    pub fn advance(&self, t_s: f64, t_end_s: f64, state: &VehicleState, rate: &Rate, max_dt_s: f64) -> Result<VehicleState> {
        let mut next = *state;
        let mut rate = *rate;
        self.advance_in_place(t_s, t_end_s, &mut next, &mut rate, max_dt_s, &mut StepMemory::new())?;
        Ok(next)
    }

    /// [`Dynamics::advance`] keeping ROS2's `W` in `memory` from one call
    /// to the next ([`StepMemory`]); `rate` from [`Dynamics::rate_for`]
    /// with the same memory (or any rate with a linearisation).
    pub fn advance_with(&self, t_s: f64, t_end_s: f64, state: &VehicleState, rate: &Rate, max_dt_s: f64, memory: &mut StepMemory) -> Result<VehicleState> {
        let mut next = *state;
        let mut rate = *rate;
        self.advance_in_place(t_s, t_end_s, &mut next, &mut rate, max_dt_s, memory)?;
        Ok(next)
    }

    /// [`Dynamics::advance_with`] overwriting `state`, with `rate` as the
    /// first stage's storage (the drive loop's form: nothing copied in or
    /// out). On an error `state` is left part way.
    #[inline(always)]
    pub(crate) fn advance_in_place(
        &self,
        t_s: f64,
        t_end_s: f64,
        state: &mut VehicleState,
        rate: &mut Rate,
        max_dt_s: f64,
        memory: &mut StepMemory,
    ) -> Result<()> {
        match self.vehicle.stepping {
            Stepping::Rk4 => {
                state.y = stepping::advance(self, t_s, t_end_s, &state.y, &rate.state.y, max_dt_s, |t, y| self.finish(t, y))?;
                Ok(())
            }
            Stepping::Ros2 => self.advance_ros2(t_s, t_end_s, &mut state.y, rate, max_dt_s, memory),
        }
    }

    /// ROS2 steps ([`Stepping::Ros2`]): per step, with `W = I - gamma h J`
    /// and `J` the fast coupled part of the Jacobian ([`crate::ros2`]) at
    /// the start of the step that built it ([`StepMemory`]),
    ///
    /// ```text
    /// W k1 = f(t, y)
    /// W k2 = f(t + h, y + h k1) - 2 k1
    /// y'   = y + h (3/2 k1 + 1/2 k2)
    /// ```
    ///
    /// `y` itself holds the second stage's state `y + h k1` (so the result
    /// is `y + h k1 + h (1/2 k1 + 1/2 k2)`), and `rate` is `k1`'s storage.
    #[inline(always)]
    fn advance_ros2(&self, t_s: f64, t_end_s: f64, y: &mut [f64; VEHICLE_STATES], rate: &mut Rate, max_dt_s: f64, memory: &mut StepMemory) -> Result<()> {
        let (n, h) = hp_core::ode::steps(t_s, t_end_s, max_dt_s)?;
        let gh = ROS2_GAMMA * h;
        for k in 0..n {
            let t = t_s + h * k as f64;
            // A new W needs the linearisation at the step's start: the first
            // step's comes with the rate if its caller asked for it (else it
            // is evaluated again, with it), a later step's with its first
            // stage.
            // The step size of a period from `k dt` to `(k + 1) dt` differs
            // from the last one by a few ulps (more the longer the run: at
            // 20 s it did so nearly every period and W was rebuilt nearly
            // every step, 30k instead of 22k instructions per period); a W
            // built for `gamma h` times (1 + 1e-9) is the W-method's `W`
            // with its matrix scaled by as much, of the same order. Only a
            // real change of the step size rebuilds it.
            let rebuild = memory.rebuilds(&self.valves) || !((memory.c - gh).abs() <= 1e-9 * gh);
            if k > 0 || (rebuild && !rate.linearised) {
                rate.linearised = rebuild;
                let couplings = if rebuild { Some(&mut rate.couplings) } else { None };
                self.evaluate_into(t, y, &mut rate.state.y, None, couplings);
            }
            if rebuild {
                memory.w.rebuild(&rate.couplings, self.vehicle.corners(), self.vehicle.body_inertia(), gh);
                memory.valves = Some(self.valves);
                memory.c = gh;
                memory.age = 0;
            }
            memory.age += 1;
            let k1 = &mut rate.state.y;
            memory.w.solve(k1);
            for (a, b) in y.iter_mut().zip(k1.iter()) {
                *a += h * b;
            }
            let k2 = &mut memory.k2;
            self.evaluate_into(t + h, y, k2, None, None);
            for (a, b) in k2.iter_mut().zip(k1.iter()) {
                *a -= 2.0 * b;
            }
            memory.w.solve(k2);
            for ((a, b), c) in y.iter_mut().zip(k1.iter()).zip(k2.iter()) {
                *a += h * (0.5 * b + 0.5 * c);
            }
            self.finish(t + h, y)?;
        }
        Ok(())
    }
}

/// Steps one ROS2 `W` serves before it is rebuilt from the linearisation
/// at a step's start (sooner when a valve switches, which changes the
/// Jacobian's structure, or the step size changes by more than a relative
/// 1e-9, not by the ulps in which one 1 ms period's differs from the
/// next). ROS2 is a W-method: second order for any `W`, which only has to
/// keep the stiff part stable and the wheel hop's error small. Measured on
/// the 8x8's rough road (`tests/stepping.rs`, um from RK4 at 1 ms after 1
/// s; soft and hard spring with the damper on, soft with it off; bound 5
/// um): rebuilt every step 0.61 / 0.52 / 1.51, every 2nd 0.64 / 0.52 /
/// 1.53, every 4th 0.64 / 0.58 / 1.56, every 8th 0.90 / 0.82 / 1.76, every
/// 16th 1.10 / 1.00 / 2.17 (BENCHMARKS.md). Building it and the
/// linearisation it needs cost about 7.4k instructions (8x8 passive: 22.6k
/// per period with every 4th, 21.7k with every 8th, 21.2k with every
/// 16th); every 8th takes most of the saving for a third of the error
/// that every 16th adds.
const ROS2_W_STEPS: u32 = 8;

/// What ROS2 keeps from one step to the next: its `W^-1`, what it was
/// built for, and the second stage's storage. One per simulated vehicle,
/// kept by whoever advances it period after period ([`crate::drive::run`]
/// keeps one): [`Dynamics::rate_for`] says from it whether the rate must
/// carry the linearisation, [`Dynamics::advance_with`] updates it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepMemory {
    w: W,
    /// The valves `w` was built with (None: no `W` yet), its `gamma h`,
    /// and the steps it has served.
    valves: Option<[Valves; MAX_CORNERS]>,
    c: f64,
    age: u32,
    k2: [f64; VEHICLE_STATES],
}

impl Default for StepMemory {
    fn default() -> Self {
        StepMemory { w: W::default(), valves: None, c: 0.0, age: 0, k2: [0.0; VEHICLE_STATES] }
    }
}

impl StepMemory {
    /// Nothing kept yet: the first step builds its `W`.
    pub fn new() -> Self {
        StepMemory::default()
    }

    /// True when the next step with `valves` builds a new `W` (at the same
    /// step size), so its rate must carry the linearisation.
    #[inline]
    pub fn rebuilds(&self, valves: &[Valves; MAX_CORNERS]) -> bool {
        !self.valves.as_ref().is_some_and(|built| same_valves(built, valves)) || self.age >= ROS2_W_STEPS
    }
}

/// Whether every corner's valve commands are the same in `a` and `b`
/// (`a == b`): all sixteen compared, without the derived comparison's
/// early exit, so that the compiler compares them side by side instead of
/// in sixteen compares and branches (about 50 instructions; twice a
/// period in the drive loop and once in each ROS2 step).
#[inline(always)]
pub(crate) fn same_valves(a: &[Valves; MAX_CORNERS], b: &[Valves; MAX_CORNERS]) -> bool {
    a.iter().zip(b).fold(true, |same, (x, y)| same & (x.valve5_open == y.valve5_open) & (x.valve6_open == y.valve6_open))
}

/// Fails unless every state is finite.
fn finite(t_s: f64, y: &[f64; VEHICLE_STATES]) -> Result<()> {
    // x * 0 is 0 for a finite x, NaN otherwise; four partial sums (which
    // the compiler vectorises) instead of one chain of 171 adds. Whole
    // chunks of a known length, so that the loop has no bounds checks left
    // and becomes a few vector adds.
    let mut lanes = [0.0; 4];
    let mut chunks = y.chunks_exact(4);
    for chunk in chunks.by_ref() {
        if let Some(c) = chunk.first_chunk::<4>() {
            for (a, x) in lanes.iter_mut().zip(c) {
                *a += x * 0.0;
            }
        }
    }
    let tail: f64 = chunks.remainder().iter().map(|x| x * 0.0).sum();
    if lanes.iter().sum::<f64>() + tail == 0.0 {
        Ok(())
    } else {
        let bad = y.iter().copied().find(|x| !x.is_finite()).unwrap_or(f64::NAN);
        Err(Error::StateOutOfRange { name: "vehicle_state", value: bad, min: f64::MIN, max: f64::MAX, time_s: t_s })
    }
}

impl OdeSystem<VEHICLE_STATES> for Dynamics<'_> {
    #[inline]
    fn derivatives(&self, t_s: f64, y: &[f64; VEHICLE_STATES]) -> Result<[f64; VEHICLE_STATES]> {
        Ok(self.evaluate(t_s, y, None, None))
    }
}
