//! The vehicle driven along a road with its suspension passive (fixed
//! valves) or semi-active: one `hp-ctrl` controller per wheel, the same
//! code and calibration as the firmware, each seeing its own unit.
//!
//! Every control period the vehicle is sampled; each wheel's controller
//! gets that wheel's measured gas pressures, strut compression and the
//! body's vertical acceleration above the wheel, the gas temperature of its
//! L through a lagged sensor ([`crate::closed_loop::Sensors`]), and the
//! vehicle signals every ECU on the bus sees (speed, the vehicle model's
//! lateral acceleration, the longitudinal acceleration, steering-wheel
//! angle and rate, brake pedal, the driver's switch and ride-height
//! request). The commands hold over the period while the vehicle is
//! integrated to the next one. As in [`crate::closed_loop`], the controller
//! acts on the sample at the start of the period without computation delay.

use hp_core::error::{check_range, Result};
use hp_core::unit::Valves;
use hp_ctrl::{input_group, step_all, DriverMode, Inputs, Outputs, Params, State};

use crate::closed_loop::Sensors;
use crate::track::Road;
use crate::vehicle::{same_valves, DriveInputs, Rate, StepMemory, Vehicle, VehicleSample, VehicleState, MAX_CORNERS};

/// What the driver does in one period, and what the bus carries of it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Driver {
    pub speed_m_s: f64,
    pub long_acc_m_s2: f64,
    /// Steering-wheel angle, rad (left positive).
    pub steer_angle_rad: f64,
    pub steer_rate_rad_s: f64,
    pub brake_pressed: bool,
    pub driver_mode: DriverMode,
    /// Ride-height request for every wheel, m (negative = lower).
    pub ride_height_request_m: f64,
}

impl Driver {
    /// The plant's part of it.
    pub fn drive_inputs(&self) -> DriveInputs {
        DriveInputs { speed_m_s: self.speed_m_s, long_acc_m_s2: self.long_acc_m_s2, steer_angle_rad: self.steer_angle_rad }
    }
}

/// How the valves are set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Suspension<'p> {
    /// The same fixed valve states on every wheel.
    Passive(Valves),
    /// One controller per wheel with these parameters.
    SemiActive(&'p Params),
}

impl Suspension<'_> {
    /// The valves the vehicle starts with (its static equilibrium should be
    /// found with them): the passive setting, or the controller's power-on
    /// safe state (both valves closed).
    pub fn initial_valves(&self) -> Valves {
        match self {
            Suspension::Passive(v) => *v,
            Suspension::SemiActive(_) => Valves::default(),
        }
    }
}

/// What controller `corner` measures on the vehicle.
///
/// ```
/// use hp_core::unit::Valves;
/// use hp_vehicle::drive::{sensed, Driver};
/// use hp_vehicle::{presets, track::Road, vehicle::{Vehicle, MAX_CORNERS}};
/// let v = Vehicle::new(presets::armoured_4x4(), 293.15, Valves::default()).unwrap();
/// let valves = [Valves::default(); MAX_CORNERS];
/// let x = v.initial_state(&valves).unwrap();
/// let driver = Driver { speed_m_s: 10.0, ..Driver::default() };
/// let mut sample = Default::default();
/// v.dynamics(&Road::FLAT, driver.drive_inputs(), valves).rate_and_sample(0.0, &x, &mut sample).unwrap();
/// let inputs = sensed(&sample, 1, 293.15, &driver);
/// assert_eq!(inputs.p_gas_pa, sample.corners[1].forces.unit.p_gas_pa);
/// assert_eq!(inputs.speed_m_s, 10.0);
/// ```
pub fn sensed(sample: &VehicleSample, corner: usize, t_gas_k: f64, driver: &Driver) -> Inputs {
    let c = sample.corners.get(corner).copied().unwrap_or_default();
    Inputs {
        p_gas_pa: c.forces.unit.p_gas_pa,
        p_gas2_pa: c.forces.unit.p_gas2_pa,
        strut_disp_m: c.forces.strut.disp_m,
        body_acc_m_s2: c.body_acc_m_s2,
        speed_m_s: driver.speed_m_s,
        lat_acc_m_s2: sample.lat_acc_m_s2,
        long_acc_m_s2: driver.long_acc_m_s2,
        steer_angle_rad: driver.steer_angle_rad,
        steer_rate_rad_s: driver.steer_rate_rad_s,
        brake_pressed: driver.brake_pressed,
        t_gas_k,
        driver_mode: driver.driver_mode,
        ride_height_request_m: driver.ride_height_request_m,
        fresh: input_group::ALL,
        link_fault: false,
    }
}

/// One control period as the callback sees it.
#[derive(Debug, Clone, Copy)]
pub struct DrivePeriod<'a> {
    pub index: usize,
    /// The vehicle at the start of the period.
    pub sample: &'a VehicleSample,
    /// Per wheel: what its controller was given and commanded (passive:
    /// the controllers do not run and the outputs are the default).
    pub inputs: &'a [Inputs; MAX_CORNERS],
    pub outputs: &'a [Outputs; MAX_CORNERS],
    /// The valves in force over the period.
    pub valves: &'a [Valves; MAX_CORNERS],
}

/// Runs `periods` control periods of `dt_s` from the vehicle's static
/// equilibrium (with [`Suspension::initial_valves`]) along `road`,
/// integrating with steps of at most `max_dt_s`. `driver_at(k, t_s)` gives
/// period `k`'s driver; `on_period` sees every period and may stop the run
/// by returning `false`. The controllers start from `states` (normally
/// [`State::new`], power-on) and leave them there.
///
/// Errors are the plant's (a state leaving the model's range); the
/// controllers cannot fail.
///
/// On an x86-64 processor with AVX2 the loop runs in code compiled for it
/// ([`crate::wide`]): the same operations on the same values (the compiler
/// does not fuse or reorder floating-point operations), so the same
/// results to the bit, in fewer instructions (three-operand forms, fewer
/// register copies and spills).
#[allow(clippy::too_many_arguments)]
pub fn run(
    vehicle: &Vehicle,
    road: &Road<'_>,
    suspension: Suspension<'_>,
    sensors: &Sensors,
    states: &mut [State; MAX_CORNERS],
    periods: usize,
    dt_s: f64,
    max_dt_s: f64,
    driver_at: impl FnMut(usize, f64) -> Driver,
    on_period: impl FnMut(&DrivePeriod<'_>) -> bool,
) -> Result<()> {
    #[cfg(target_arch = "x86_64")]
    if crate::wide::available() {
        // SAFETY: the processor has the features `run_wide` is compiled
        // for (checked at run time just now).
        return unsafe { run_wide(vehicle, road, suspension, sensors, states, periods, dt_s, max_dt_s, driver_at, on_period) };
    }
    run_loop(vehicle, road, suspension, sensors, states, periods, dt_s, max_dt_s, driver_at, on_period, step_all)
}

/// [`run`] compiled for the processors [`crate::wide`] names, with the
/// controllers' own AVX2 compilation (`hp_ctrl::step_all_avx2`, out of
/// line as `step_all` is).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn run_wide(
    vehicle: &Vehicle,
    road: &Road<'_>,
    suspension: Suspension<'_>,
    sensors: &Sensors,
    states: &mut [State; MAX_CORNERS],
    periods: usize,
    dt_s: f64,
    max_dt_s: f64,
    driver_at: impl FnMut(usize, f64) -> Driver,
    on_period: impl FnMut(&DrivePeriod<'_>) -> bool,
) -> Result<()> {
    // The closure is compiled for AVX2 as well (it inherits `run_wide`'s
    // target features), so it may call `step_all_avx2`.
    let controllers = |p: &Params, s: &mut [State], i: &[Inputs], dt: f64, o: &mut [Outputs]| hp_ctrl::step_all_avx2(p, s, i, dt, o);
    run_loop(vehicle, road, suspension, sensors, states, periods, dt_s, max_dt_s, driver_at, on_period, controllers)
}

/// [`run`]'s loop, inlined into each of its two compilations (with it the
/// plant's evaluation, steps and checks, all `inline(always)`); `step_all`
/// is [`hp_ctrl::step_all`] or its AVX2 compilation.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn run_loop(
    vehicle: &Vehicle,
    road: &Road<'_>,
    suspension: Suspension<'_>,
    sensors: &Sensors,
    states: &mut [State; MAX_CORNERS],
    periods: usize,
    dt_s: f64,
    max_dt_s: f64,
    mut driver_at: impl FnMut(usize, f64) -> Driver,
    mut on_period: impl FnMut(&DrivePeriod<'_>) -> bool,
    step_all: impl Fn(&Params, &mut [State], &[Inputs], f64, &mut [Outputs]),
) -> Result<()> {
    check_range("dt_s", dt_s, 1e-6, 10.0)?;
    check_range("t_gas_tau_s", sensors.t_gas_tau_s, 0.0, 1e3)?;
    road.validate()?;
    let t_gas_weight = if sensors.t_gas_tau_s > 0.0 { 1.0 - libm::exp(-dt_s / sensors.t_gas_tau_s) } else { 1.0 };
    let mut valves = [suspension.initial_valves(); MAX_CORNERS];
    let mut x: VehicleState = vehicle.initial_state(&valves)?;
    let mut t_gas_k: Option<[f64; MAX_CORNERS]> = None;
    let mut inputs = [Inputs::default(); MAX_CORNERS];
    let mut outputs = [Outputs::default(); MAX_CORNERS];
    let mut sample = VehicleSample::default();
    // The integrator's storage, reused period after period (ROS2 keeps its
    // W over a few steps: StepMemory).
    let mut rate = Rate::default();
    let mut memory = StepMemory::new();
    let corners = vehicle.corner_count();
    for index in 0..periods {
        let t_s = index as f64 * dt_s;
        let driver = driver_at(index, t_s);
        let dynamics = vehicle.dynamics(road, driver.drive_inputs(), valves);
        // x is the initial state or one advance checked.
        dynamics.rate_into(t_s, &x, Some(&mut sample), memory.rebuilds(&valves), &mut rate);
        let mut read = [0.0; MAX_CORNERS];
        for (k, (r, c)) in read.iter_mut().zip(sample.corners.iter()).enumerate().take(corners) {
            let t_true = c.forces.unit.t_gas2_k;
            *r = match &t_gas_k {
                Some(prev) => {
                    let p = prev.get(k).copied().unwrap_or(t_true);
                    p + t_gas_weight * (t_true - p)
                }
                None => t_true,
            };
        }
        t_gas_k = Some(read);
        let mut next_valves = valves;
        for (k, i) in inputs.iter_mut().enumerate().take(corners) {
            *i = sensed(&sample, k, read.get(k).copied().unwrap_or(0.0), &driver);
        }
        match suspension {
            Suspension::Passive(p) => next_valves.iter_mut().take(corners).for_each(|v| *v = p),
            Suspension::SemiActive(params) => {
                // All corners' controllers together (`step_all`: the same
                // as one `step` per corner, with their gas-table lookups
                // overlapping).
                let n = corners.min(MAX_CORNERS);
                if let (Some(s), Some(i), Some(o)) = (states.get_mut(..n), inputs.get(..n), outputs.get_mut(..n)) {
                    step_all(params, s, i, dt_s, o);
                }
                for (v, o) in next_valves.iter_mut().zip(&outputs).take(corners) {
                    *v = Valves { valve5_open: o.valve5_open, valve6_open: o.valve6_open };
                }
            }
        }
        if !on_period(&DrivePeriod { index, sample: &sample, inputs: &inputs, outputs: &outputs, valves: &next_valves }) {
            break;
        }
        if !same_valves(&next_valves, &valves) {
            // The new commands change the flows: the first stage must see them.
            valves = next_valves;
            vehicle.dynamics(road, driver.drive_inputs(), valves).rate_into(t_s, &x, None, memory.rebuilds(&valves), &mut rate);
        }
        let dynamics = vehicle.dynamics(road, driver.drive_inputs(), valves);
        dynamics.advance_in_place(t_s, (index + 1) as f64 * dt_s, &mut x, &mut rate, max_dt_s, &mut memory)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::presets;
    use crate::track::Track;

    /// [`run`] in its AVX2 compilation (where the processor has AVX2:
    /// [`crate::wide`]) gives the baseline compilation's every sample,
    /// input, output and valve to the bit: the 8x8 and the 4x4,
    /// semi-active through a lane change on a rough road (valve switches,
    /// `W` rebuilt) and passive.
    #[test]
    fn the_wide_compilation_gives_the_same_results_to_the_bit() {
        let h: Vec<f64> = (0..3000).map(|k| 0.02 * (0.5 * k as f64 * 0.02).sin() + 0.005 * (0.37 * k as f64).sin()).collect();
        let road = Road { left: Track { start_m: -10.0, dx_m: 0.02, height_m: &h }, right: Track { start_m: -9.99, dx_m: 0.02, height_m: &h } };
        for p in [presets::armoured_8x8(), presets::armoured_4x4()] {
            let params = Params::new(presets::controller_config(&p)).unwrap();
            for suspension in [Suspension::SemiActive(&params), Suspension::Passive(Valves::from_modes(false, true))] {
                let v = Vehicle::new(p, 293.15, suspension.initial_valves()).unwrap();
                let record = |wide: bool| {
                    let mut states = [State::new(); MAX_CORNERS];
                    let mut seen = Vec::new();
                    let driver = |_: usize, t: f64| {
                        let steer = if (1.5..3.0).contains(&t) { 1.5 * (std::f64::consts::TAU * (t - 1.5) / 1.5).sin() } else { 0.0 };
                        Driver { speed_m_s: 12.0, steer_angle_rad: steer, ..Driver::default() }
                    };
                    let on_period = |q: &DrivePeriod<'_>| {
                        seen.push(format!("{:?} {:?} {:?} {:?}", q.sample, q.inputs, q.outputs, q.valves));
                        true
                    };
                    let periods = 4000;
                    if wide {
                        run(&v, &road, suspension, &Sensors::default(), &mut states, periods, 1e-3, 1e-3, driver, on_period).unwrap();
                    } else {
                        run_loop(&v, &road, suspension, &Sensors::default(), &mut states, periods, 1e-3, 1e-3, driver, on_period, step_all).unwrap();
                    }
                    seen
                };
                let (wide, baseline) = (record(true), record(false));
                assert_eq!(wide.len(), baseline.len());
                for (k, (a, b)) in wide.iter().zip(&baseline).enumerate() {
                    assert!(a == b, "period {k} differs (wide compilation: {})", crate::wide::available());
                }
            }
        }
    }
}
