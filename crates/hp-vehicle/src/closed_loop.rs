//! The controller in closed loop with one unit on the SDOF rig
//! (`hp_core::rig`): for host simulation, tests and the Python closed-loop
//! runner. (The whole vehicle with one controller per wheel is
//! [`crate::drive`].)
//!
//! Every control period the rig is sampled, the [`sensed`] inputs go
//! through [`hp_ctrl::step`], and the valve commands hold over the period
//! while the rig is integrated to the next one. No allocation and no
//! panics, like the rest of the crate; the caller owns the road samples
//! and receives each period through a callback.
//!
//! The sensor model ([`sensed`]): the ECU sees the measured gas pressures
//! of S and L (ideal apart from the unit model's optional pressure-sensor
//! effects), the strut compression from the nominal position, the body's
//! vertical acceleration (gravity removed) and the temperature of the gas
//! in L (the gas whose state the ride-height table describes) through a
//! first-order lag of [`Sensors::t_gas_tau_s`]: a real temperature sensor
//! cannot follow the gas's adiabatic swings (tens of kelvin within
//! milliseconds as valve 6 lets oil in), and the controller's plausibility
//! limit on the temperature rate (200 K/s) assumes it does not. Vehicle
//! signals and the driver's inputs come from a scenario ([`VehicleSignals`]).
//! Every input group is fresh every period.
//!
//! Timing: the controller acts on the sample at the start of a period and
//! its commands take effect at once (no computation delay); the unit
//! model's optional valve lag is the actuator's response.

use hp_core::rig::{Rig, RigSample};
use hp_core::unit::Valves;

use hp_ctrl::{input_group, step, DriverMode, Inputs, Outputs, Params, State};

/// The scenario's inputs of one period: what the vehicle and the driver do.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VehicleSignals {
    pub speed_m_s: f64,
    pub lat_acc_m_s2: f64,
    pub long_acc_m_s2: f64,
    pub steer_angle_rad: f64,
    pub steer_rate_rad_s: f64,
    pub brake_pressed: bool,
    pub driver_mode: DriverMode,
    pub ride_height_request_m: f64,
}

/// The sensors' dynamics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensors {
    /// Time constant of the gas-temperature sensor, s.
    pub t_gas_tau_s: f64,
    /// Offset of the gas-temperature sensor (its calibration error), K.
    pub t_gas_offset_k: f64,
}

impl Default for Sensors {
    /// A sheathed thermocouple or a wall sensor: about a second.
    fn default() -> Self {
        Sensors { t_gas_tau_s: 1.0, t_gas_offset_k: 0.0 }
    }
}

/// What the ECU measures on the rig, with the gas temperature as the
/// sensor reads it (`t_gas_k`) and the scenario's vehicle signals.
///
/// ```
/// use hp_core::{presets, motion::Motion, rig::{Rig, RigKind}, unit::{Unit, Valves}};
/// use hp_vehicle::closed_loop::{sensed, VehicleSignals};
/// let unit = Unit::new(presets::seed_unit()).unwrap();
/// let kind = RigKind::Sdof { sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG, base: Motion::Hold { disp_m: 0.0 } };
/// let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(false, true)).unwrap();
/// let sample = rig.sample(0.0, &rig.initial_state().unwrap()).unwrap();
/// let inputs = sensed(&sample, 293.15, &VehicleSignals { speed_m_s: 10.0, ..VehicleSignals::default() });
/// assert_eq!(inputs.p_gas_pa, sample.unit.p_gas_pa);
/// assert_eq!(inputs.speed_m_s, 10.0);
/// ```
pub fn sensed(sample: &RigSample, t_gas_k: f64, vehicle: &VehicleSignals) -> Inputs {
    Inputs {
        p_gas_pa: sample.unit.p_gas_pa,
        p_gas2_pa: sample.unit.p_gas2_pa,
        strut_disp_m: sample.disp_m,
        body_acc_m_s2: sample.body_acc_m_s2,
        speed_m_s: vehicle.speed_m_s,
        lat_acc_m_s2: vehicle.lat_acc_m_s2,
        long_acc_m_s2: vehicle.long_acc_m_s2,
        steer_angle_rad: vehicle.steer_angle_rad,
        steer_rate_rad_s: vehicle.steer_rate_rad_s,
        brake_pressed: vehicle.brake_pressed,
        t_gas_k,
        driver_mode: vehicle.driver_mode,
        ride_height_request_m: vehicle.ride_height_request_m,
        fresh: input_group::ALL,
        link_fault: false,
    }
}

/// One control period as the callback sees it.
#[derive(Debug, Clone, Copy)]
pub struct Period<'a> {
    /// Period number, from 0.
    pub index: usize,
    /// The rig at the start of the period.
    pub sample: &'a RigSample,
    /// What the controller was given.
    pub inputs: &'a Inputs,
    /// What it commanded for this period.
    pub outputs: &'a Outputs,
}

/// Runs `periods` control periods of `dt_s` from the rig's initial state
/// with the `sensors`,
/// integrating the rig with steps of at most `max_dt_s`. `vehicle_at(k,
/// t_s)` gives the scenario's inputs of period `k`; `on_period` sees every
/// period and may stop the run by returning `false`. The controller starts
/// from `state` (normally [`State::new`], power-on) and leaves it there.
///
/// Errors are the plant's (a state leaving the model's range); the
/// controller itself cannot fail.
///
/// ```
/// use hp_core::{presets, motion::Motion, rig::{Rig, RigKind}, unit::{Unit, Valves}};
/// use hp_vehicle::closed_loop::{run, Sensors, VehicleSignals};
/// use hp_ctrl::{DriveMode, Params, State};
/// let unit = Unit::new(presets::seed_unit()).unwrap();
/// let kind = RigKind::Sdof { sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG, base: Motion::Hold { disp_m: 0.0 } };
/// let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(true, true)).unwrap();
/// let params = Params::seed_unit().unwrap();
/// let mut state = State::new();
/// let mut last = None;
/// let vehicle = VehicleSignals { speed_m_s: 10.0, ..VehicleSignals::default() };
/// let sensors = Sensors::default();
/// run(&rig, &params, &sensors, &mut state, 3000, 1e-3, 1e-3, |_, _| vehicle, |p| {
///     last = Some(*p.outputs);
///     true
/// })
/// .unwrap();
/// // At rest on a level road: past recovery and the hold, Ride.
/// assert_eq!(last.unwrap().drive_mode, DriveMode::Ride);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn run(
    rig: &Rig<'_>,
    params: &Params,
    sensors: &Sensors,
    state: &mut State,
    periods: usize,
    dt_s: f64,
    max_dt_s: f64,
    mut vehicle_at: impl FnMut(usize, f64) -> VehicleSignals,
    mut on_period: impl FnMut(&Period<'_>) -> bool,
) -> Result<(), hp_core::Error> {
    hp_core::error::check_range("dt_s", dt_s, 1e-6, 10.0)?;
    hp_core::error::check_range("t_gas_tau_s", sensors.t_gas_tau_s, 0.0, 1e3)?;
    hp_core::error::check_range("t_gas_offset_k", sensors.t_gas_offset_k, -50.0, 50.0)?;
    // The lag's weight per period (exact for a signal held over the period).
    let t_gas_weight = if sensors.t_gas_tau_s > 0.0 { 1.0 - libm::exp(-dt_s / sensors.t_gas_tau_s) } else { 1.0 };
    let mut rig = *rig;
    let mut x = rig.initial_state()?;
    let mut t_gas_k = None;
    for index in 0..periods {
        // Times as multiples of the period, so they do not drift.
        let t_s = index as f64 * dt_s;
        let (rate, sample) = rig.rate_and_sample(t_s, &x)?;
        let t_true_k = sample.unit.t_gas2_k;
        let t_read_k = t_gas_k.map_or(t_true_k, |t: f64| t + t_gas_weight * (t_true_k - t));
        t_gas_k = Some(t_read_k);
        let inputs = sensed(&sample, t_read_k + sensors.t_gas_offset_k, &vehicle_at(index, t_s));
        let outputs = step(params, state, &inputs, dt_s);
        if !on_period(&Period { index, sample: &sample, inputs: &inputs, outputs: &outputs }) {
            break;
        }
        let valves = Valves { valve5_open: outputs.valve5_open, valve6_open: outputs.valve6_open };
        let rate = if valves == rig.valves {
            rate
        } else {
            // The new commands change the flows: the first integration
            // stage must see them.
            rig.valves = valves;
            rig.rate_and_sample(t_s, &x)?.0
        };
        x = rig.advance(t_s, (index + 1) as f64 * dt_s, &x, &rate, max_dt_s)?;
    }
    Ok(())
}
