//! The step function: parameters, state and one control period.

use crate::config::{Config, ParamError};
use crate::damper::{self, DamperParams, DamperState};
use crate::estimator::{self, EstimatorParams, EstimatorState};
use crate::gas_table::LargeTable;
use crate::input_group::{BODY, DRIVER, PRESSURES, STRUT, TEMPERATURE};
use crate::load::{self, LoadInputs, LoadParams, LoadState};
use crate::mode::{self, ModeInputs, ModeParams, ModeState};
use crate::monitor::{self, MonitorParams, MonitorState};
use crate::ride_height::{self, RideHeightInputs, RideHeightParams, RideHeightState};
use crate::{clock, diag, DamperMode, DriveMode, Inputs, Outputs};

/// Validated, compiled parameters: immutable while the controller runs.
///
/// Built from a [`Config`] by [`Params::new`], which validates it and
/// precomputes what the step needs (single-precision thresholds, integer
/// microsecond timers, the gas table of accumulator L), so the step itself
/// never solves the equation of state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub(crate) config: Config,
    pub(crate) table: LargeTable,
    pub(crate) monitor: MonitorParams,
    pub(crate) estimator: EstimatorParams,
    pub(crate) mode: ModeParams,
    pub(crate) damper: DamperParams,
    pub(crate) ride_height: RideHeightParams,
    pub(crate) load: LoadParams,
    /// The stroke as ride-height offsets (extension end, compression end), m.
    pub(crate) stroke_m: (f32, f32),
}

impl Params {
    /// Validates `config` ([`Config::validate`]) and compiles it.
    pub fn new(config: Config) -> Result<Self, ParamError> {
        config.validate()?;
        let table = LargeTable::new(
            &config.unit,
            config.monitor.temperature_min_k,
            config.monitor.temperature_max_k,
            config.ride_height.request_max_m,
        )?;
        Ok(Params {
            table,
            monitor: MonitorParams::new(&config.monitor, &config.unit),
            estimator: EstimatorParams::new(&config.estimator),
            mode: ModeParams::new(&config.mode),
            damper: DamperParams::new(&config.damper),
            ride_height: RideHeightParams::new(&config.ride_height),
            load: LoadParams::new(config.ride_height.load_pressure_tau_s, &config.unit),
            stroke_m: (-config.unit.stroke_compression_m as f32, config.unit.stroke_extension_m as f32),
            config,
        })
    }

    /// The seed's unit with the default calibration ([`Config::seed_unit`]).
    pub fn seed_unit() -> Result<Self, ParamError> {
        Params::new(Config::seed_unit())
    }

    /// The configuration these parameters were compiled from.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The gas table of accumulator L (reference, target pressures, height estimate).
    pub fn large_table(&self) -> &LargeTable {
        &self.table
    }
}

/// Everything the controller remembers between periods.
///
/// [`State::new`] (= `Default`) is the power-on state: the safe state, in
/// which the controller stays until every input has been good for the
/// recovery time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    monitor: MonitorState,
    estimator: EstimatorState,
    mode: ModeState,
    damper: DamperState,
    ride_height: RideHeightState,
    load: LoadState,
    /// Last valid ride-height estimate, m.
    ride_height_m: f32,
    /// Last valid target pressure of L, Pa.
    p_gas2_target_pa: f32,
    /// The gas table's density intervals of the last reference and held
    /// offset lookups, where the next ones start their walks
    /// ([`crate::gas_table::Isotherm::offset_near_m`]: the same offsets,
    /// found sooner).
    table_intervals: [u8; 2],
}

impl State {
    /// The power-on state.
    pub const fn new() -> Self {
        State {
            monitor: MonitorState::new(),
            estimator: EstimatorState::new(),
            mode: ModeState::new(),
            damper: DamperState::new(),
            ride_height: RideHeightState::new(),
            load: LoadState::new(),
            ride_height_m: 0.0,
            p_gas2_target_pa: 0.0,
            // Mid-table: any start finds the same interval.
            table_intervals: [(crate::gas_table::TABLE_DENSITIES / 2) as u8; 2],
        }
    }
}

impl State {
    /// The last valid ride-height estimate (`Outputs::ride_height_m`), m.
    pub fn ride_height_m(&self) -> f32 {
        self.ride_height_m
    }

    /// The ride-height change in progress (`Lowering`, `Raising`) or
    /// `Holding`.
    pub fn sequencer_phase(&self) -> crate::SequencerState {
        self.ride_height.phase()
    }

    /// Oil is flowing through valve 6 for a height change
    /// ([`crate::ride_height::RideHeightState::moving_oil`]).
    pub fn moving_oil(&self) -> bool {
        self.ride_height.moving_oil()
    }
}

impl Default for State {
    fn default() -> Self {
        Self::new()
    }
}

/// One control period: measured `inputs` in, valve commands out.
///
/// Pure, allocation-free, panic-free and deterministic. `dt_s` is the time
/// since the previous call; a `dt_s` that is not finite, below 1 us or above
/// `monitor.dt_max_s` gives the safe state. See `docs/controller.md`.
///
/// ```
/// use hp_ctrl::{input_group, step, DriveMode, Inputs, Params, SequencerState, State};
///
/// let params = Params::seed_unit().unwrap();
/// let p_static = params.config().unit.static_pressure_pa;
/// let mut state = State::new();
/// let inputs = Inputs {
///     p_gas_pa: p_static,
///     p_gas2_pa: p_static,
///     t_gas_k: params.config().unit.static_temperature_k,
///     speed_m_s: 10.0,
///     fresh: input_group::ALL,
///     ..Inputs::default()
/// };
/// // Power-on is the safe state: both valves closed.
/// let out = step(&params, &mut state, &inputs, 1e-3);
/// assert!(!out.valve5_open && !out.valve6_open);
/// assert_eq!(out.sequencer, SequencerState::Blocked);
/// // After good inputs for the recovery time (0.5 s) and the handling hold
/// // (2 s), a straight, calm road gives Ride: valve 6 open, soft spring.
/// let mut out = out;
/// for _ in 0..3000 {
///     out = step(&params, &mut state, &inputs, 1e-3);
/// }
/// assert_eq!(out.drive_mode, DriveMode::Ride);
/// assert!(out.valve6_open);
/// assert!(out.ride_height_m.abs() < 1e-3);
/// // A NaN reading gives the safe state in the same period.
/// let bad = Inputs { p_gas2_pa: f64::NAN, ..inputs };
/// let out = step(&params, &mut state, &bad, 1e-3);
/// assert!(!out.valve5_open && !out.valve6_open);
/// assert_ne!(out.diag & hp_ctrl::diag::SAFE_STATE, 0);
/// ```
pub fn step(params: &Params, state: &mut State, inputs: &Inputs, dt_s: f64) -> Outputs {
    let mut begun = begin(params, state, inputs, dt_s, monitor::step);
    estimate_height(params, state, inputs, &mut begun);
    finish(params, state, inputs, &begun)
}

/// [`step`] for several controllers with the same parameters (an ECU's
/// corners, or a vehicle simulation's): controller `k` takes `inputs[k]`
/// and `states[k]` and writes `outputs[k]`, exactly as `step` called for
/// each in turn would (controllers share nothing); the corners beyond the
/// shortest of the three slices are not stepped.
///
/// The step runs in three phases, each over up to eight controllers
/// before the next: the checks and filters, the gas-table lookups, the
/// modes and valves. A lookup is a chain of dependent divisions (the
/// temperature's location, the interval's fraction, the density, the
/// volume offset, the target's density); one controller after another,
/// each chain waited for the last, side by side the core overlaps them.
pub fn step_all(params: &Params, states: &mut [State], inputs: &[Inputs], dt_s: f64, outputs: &mut [Outputs]) {
    step_all_in(params, states, inputs, dt_s, outputs, monitor::step);
}

/// [`step_all`] compiled for x86-64 processors with AVX2 (feature `wide`,
/// host simulations only: the firmware never enables it): the same Rust
/// code with VEX encoding (three-operand instructions, fewer register
/// copies), so the same operations on the same values and the same
/// outputs and states to the bit; the compiler neither fuses nor reorders
/// floating-point operations. Kept out of line, as `step_all` is in the
/// baseline loop (inlined, it made the loop longer).
///
/// # Safety
///
/// A safe call needs the caller compiled for AVX2 itself (hp-vehicle's
/// AVX2 drive loop, chosen at run time when the processor has AVX2); the
/// compiler enforces it, and any other caller would need an `unsafe`
/// block and the processor's AVX2 checked first.
#[cfg(all(feature = "wide", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
#[inline(never)]
pub fn step_all_avx2(params: &Params, states: &mut [State], inputs: &[Inputs], dt_s: f64, outputs: &mut [Outputs]) {
    // The monitor in its AVX2 compilation too (a closure here inherits
    // this function's target features).
    let monitor_step = |p: &MonitorParams, s: &mut MonitorState, i: &Inputs, dt_us: Option<u32>| monitor::step_avx2(p, s, i, dt_us);
    step_all_in(params, states, inputs, dt_s, outputs, monitor_step);
}

/// [`step_all`]'s body, inlined into each of its compilations, with the
/// monitor's step of the same compilation.
#[inline(always)]
fn step_all_in(
    params: &Params,
    states: &mut [State],
    inputs: &[Inputs],
    dt_s: f64,
    outputs: &mut [Outputs],
    monitor_step: impl Fn(&MonitorParams, &mut MonitorState, &Inputs, Option<u32>) -> monitor::Health,
) {
    const BATCH: usize = 8;
    for ((states, inputs), outputs) in states.chunks_mut(BATCH).zip(inputs.chunks(BATCH)).zip(outputs.chunks_mut(BATCH)) {
        let mut begun = [None; BATCH];
        for ((b, state), i) in begun.iter_mut().zip(states.iter_mut()).zip(inputs) {
            *b = Some(begin(params, state, i, dt_s, &monitor_step));
        }
        for ((b, state), i) in begun.iter_mut().zip(states.iter_mut()).zip(inputs) {
            if let Some(b) = b {
                estimate_height(params, state, i, b);
            }
        }
        for (((b, state), i), o) in begun.iter().zip(states.iter_mut()).zip(inputs).zip(outputs.iter_mut()) {
            if let Some(b) = b {
                *o = finish(params, state, i, b);
            }
        }
    }
}

/// What the first phase of a step hands to the others.
#[derive(Debug, Clone, Copy)]
struct Begun {
    health: monitor::Health,
    flags: u32,
    dt_us: u32,
    request_m: f32,
    vehicle: ModeInputs,
    p_load_pa: f32,
    reference_settled: bool,
}

impl Begun {
    fn usable(&self, group: u16) -> bool {
        self.health.usable & group != 0
    }
}

/// The checks (`monitor_step`: [`monitor::step`] or its AVX2
/// compilation), the estimator and the load pressure.
#[inline(always)]
fn begin(
    params: &Params,
    state: &mut State,
    inputs: &Inputs,
    dt_s: f64,
    monitor_step: impl Fn(&MonitorParams, &mut MonitorState, &Inputs, Option<u32>) -> monitor::Health,
) -> Begun {
    let dt_us = clock::dt_us(dt_s, params.monitor.dt_max_s);
    let health = monitor_step(&params.monitor, &mut state.monitor, inputs, dt_us);
    let dt_us = dt_us.unwrap_or(0);
    let usable = |group: u16| health.usable & group != 0;
    let mut flags = health.diag;

    estimator::step(
        &params.estimator,
        &mut state.estimator,
        usable(STRUT).then_some(inputs.strut_disp_m as f32),
        usable(BODY).then_some(inputs.body_acc_m_s2 as f32),
        clock::us_to_seconds(dt_us),
    );

    let (request_m, clamped) = if usable(DRIVER) {
        params.ride_height.effective_request_m(inputs.ride_height_request_m)
    } else {
        (0.0, false)
    };
    if clamped {
        flags |= diag::REQUEST_CLAMPED;
    }
    let request_m = request_m as f32;
    let vehicle = ModeInputs {
        speed_m_s: inputs.speed_m_s as f32,
        lat_acc_m_s2: inputs.lat_acc_m_s2 as f32,
        long_acc_m_s2: inputs.long_acc_m_s2 as f32,
        steer_angle_rad: inputs.steer_angle_rad as f32,
        steer_rate_rad_s: inputs.steer_rate_rad_s as f32,
        brake_pressed: inputs.brake_pressed,
    };
    // The load pressure from calm, valid periods only (see `load`).
    let calm = !health.safe
        && usable(PRESSURES)
        && usable(STRUT)
        && usable(BODY)
        && !params.ride_height.manoeuvring(vehicle.lat_acc_m_s2, vehicle.long_acc_m_s2, vehicle.brake_pressed);
    let load_inputs = calm.then(|| LoadInputs {
        p_gas_pa: inputs.p_gas_pa as f32,
        strut_disp_m: inputs.strut_disp_m as f32,
        body_acc_m_s2: inputs.body_acc_m_s2 as f32 - state.estimator.body_acc_offset_m_s2(),
    });
    let p_load_pa = load::step(&params.load, &mut state.load, load_inputs, dt_us);
    let reference_settled = state.load.averaged_us() >= params.ride_height.load_settle_us;
    Begun { health, flags, dt_us, request_m, vehicle, p_load_pa, reference_settled }
}

/// The ride-height estimate and the target pressure from the gas table.
#[inline(always)]
fn estimate_height(params: &Params, state: &mut State, inputs: &Inputs, b: &mut Begun) {
    if b.usable(PRESSURES) && b.usable(TEMPERATURE) {
        // Volume offsets of L's gas: the soft-mode rest state, the request
        // relative to it, and what L holds now.
        // All three at the same temperature: located once.
        let table = params.table.isotherm(inputs.t_gas_k as f32);
        let [reference_near, height_near] = &mut state.table_intervals;
        let reference_m = table.offset_near_m(b.p_load_pa, reference_near);
        let (stroke_min_m, stroke_max_m) = params.stroke_m;
        state.ride_height_m =
            // max/min rather than clamp: clamp keeps a panic path for bounds
            // it cannot prove ordered, and the firmware must link none.
            (table.offset_near_m(inputs.p_gas2_pa as f32, height_near) - reference_m).max(stroke_min_m).min(stroke_max_m);
        state.p_gas2_target_pa = table.pressure_pa(reference_m + b.request_m);
    } else {
        b.flags |= diag::HEIGHT_ESTIMATE_HELD;
    }
}

/// The modes, the valves and the outputs.
#[inline(always)]
fn finish(params: &Params, state: &mut State, inputs: &Inputs, b: &Begun) -> Outputs {
    let Begun { health, mut flags, dt_us, request_m, vehicle, p_load_pa, reference_settled } = *b;
    let (drive_mode, triggers) =
        mode::step(&params.mode, &mut state.mode, &vehicle, inputs.driver_mode, health.safe, dt_us);
    flags |= triggers;

    let height = ride_height::step(
        &params.ride_height,
        &mut state.ride_height,
        &RideHeightInputs {
            request_m,
            height_m: state.ride_height_m,
            p_gas_pa: inputs.p_gas_pa,
            p_gas2_pa: inputs.p_gas2_pa,
            lat_acc_m_s2: vehicle.lat_acc_m_s2,
            long_acc_m_s2: vehicle.long_acc_m_s2,
            brake_pressed: vehicle.brake_pressed,
            soft_wanted: drive_mode == DriveMode::Ride,
            safe: health.safe,
            reference_settled,
        },
        dt_us,
    );
    flags |= height.diag;

    let damper_mode = damper::step(
        &params.damper,
        &mut state.damper,
        state.estimator.body_vel_m_s(),
        state.estimator.strut_vel_m_s(),
        health.safe || drive_mode == DriveMode::Handling,
        dt_us,
    );

    Outputs {
        valve5_open: damper_mode == DamperMode::Low,
        valve6_open: height.valve6_open,
        drive_mode,
        spring_mode: height.spring,
        damper_mode,
        sequencer: height.sequencer,
        diag: flags,
        ride_height_m: f64::from(state.ride_height_m),
        p_gas2_target_pa: f64::from(state.p_gas2_target_pa),
        p_load_pa: f64::from(p_load_pa),
        strut_vel_m_s: f64::from(state.estimator.strut_vel_m_s()),
        body_vel_m_s: f64::from(state.estimator.body_vel_m_s()),
    }
}
