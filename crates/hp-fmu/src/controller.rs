//! The controller FMU (`hpctl_controller`): `hp_ctrl::step` as a sampled
//! block.
//!
//! The controller ticks at every multiple of `period_s` from the start
//! time. At a communication point the outputs are those of the tick at that
//! instant with the inputs set there (computed when read, without delay,
//! as the ECU acts on the sample at the start of its period; see
//! `hp_vehicle::closed_loop`); `fmi2DoStep` commits that tick and runs the
//! ticks inside the step with the inputs held. The communication step must
//! be a whole number of periods.
//!
//! Parameters: `period_s` and every field of `hp_ctrl::Config` under its
//! block's name (`mode.handling_hold_s`, ...), start values the seed unit's
//! calibration; `Params::new` checks them when initialisation ends.

use crate::model::{Causality, Enumeration, Kind, Model, ModelError, ModelInfo, Values, Var};
use hp_ctrl::{diag, input_group, step, Config, DriverMode, Inputs, Outputs, Params, State};
use std::sync::OnceLock;

pub static DRIVER_MODE: Enumeration = Enumeration {
    name: "DriverMode",
    items: &[("auto", 0, "automatic ride/handling"), ("comfort", 1, "ride unless a safety trigger"), ("sport", 2, "forced handling")],
};
pub static DRIVE_MODE: Enumeration =
    Enumeration { name: "DriveMode", items: &[("ride", 0, "soft spring, skyhook damping"), ("handling", 1, "hard spring, high damping")] };
pub static SPRING_MODE: Enumeration =
    Enumeration { name: "SpringMode", items: &[("hard", 0, "valve 6 closed: S only"), ("soft", 1, "valve 6 open: S + L")] };
pub static DAMPER_MODE: Enumeration =
    Enumeration { name: "DamperMode", items: &[("high", 0, "valve 5 closed"), ("low", 1, "valve 5 open (bypass)")] };
pub static SEQUENCER: Enumeration = Enumeration {
    name: "SequencerState",
    items: &[
        ("idle", 0, "ride-height control not engaged"),
        ("lowering", 1, "moving oil from S into L"),
        ("raising", 2, "moving oil from L into S"),
        ("holding", 3, "target reached, valve 6 held closed"),
        ("blocked", 4, "engaged but paused, valve 6 held closed"),
    ],
};

type Field = fn(&mut Config) -> &mut f64;

/// `(block.field, accessor)` for the `f64` fields of one config block.
macro_rules! block {
    ($out:ident, $prefix:literal, $a:ident, [$($field:ident),* $(,)?]) => {
        $( $out.push((concat!($prefix, ".", stringify!($field)), (|c: &mut Config| &mut c.$a.$field) as Field)); )*
    };
    ($out:ident, $prefix:literal, $a:ident . $b:ident, [$($field:ident),* $(,)?]) => {
        $( $out.push((concat!($prefix, ".", stringify!($field)), (|c: &mut Config| &mut c.$a.$b.$field) as Field)); )*
    };
}

/// Every real field of the configuration, as FMU parameters.
#[allow(clippy::vec_init_then_push)]
fn config_fields() -> Vec<(&'static str, Field)> {
    let mut v: Vec<(&'static str, Field)> = Vec::new();
    block!(v, "unit", unit, [piston_area_m2, large_acc_volume_m3, static_pressure_pa, static_temperature_k, stroke_compression_m, stroke_extension_m]);
    block!(v, "monitor", monitor, [
        pressure_min_pa, pressure_max_pa, temperature_min_k, temperature_max_k, disp_margin_m, body_acc_max_m_s2,
        vehicle_acc_max_m_s2, speed_min_m_s, speed_max_m_s, steer_angle_max_rad, steer_rate_max_rad_s,
        pressure_rate_max_pa_s, disp_rate_max_m_s, temperature_rate_max_k_s, recovery_s, dt_max_s,
    ]);
    block!(v, "monitor.timeouts", monitor.timeouts, [pressures_s, strut_s, body_s, vehicle_s, steering_s, temperature_s, driver_s]);
    block!(v, "estimator", estimator, [strut_velocity_tau_s, body_velocity_tau_s, body_acc_bias_tau_s]);
    block!(v, "mode", mode, [
        lat_acc_enter_m_s2, lat_acc_exit_m_s2, steering_ratio, wheelbase_m, steer_rate_enter_rad_s, steer_rate_exit_rad_s,
        steer_min_speed_m_s, long_acc_enter_m_s2, long_acc_exit_m_s2, brake_min_speed_m_s, speed_enter_m_s, speed_exit_m_s,
        handling_hold_s,
    ]);
    block!(v, "damper", damper, [skyhook_deadband_m2_s2, valve5_min_interval_s]);
    block!(v, "ride_height", ride_height, [
        request_max_m, request_deadband_m, tolerance_m, valve6_margin_pa, valve6_min_off_s, block_lat_acc_m_s2,
        block_long_acc_m_s2, resume_s, load_pressure_tau_s, load_settle_s,
    ]);
    v
}

/// The SI unit of a quantity from its name's suffix (the project's naming
/// rule), "" for a dimensionless one.
pub fn unit_of(name: &str) -> &'static str {
    const SUFFIXES: &[(&str, &str)] = &[
        ("_m2_s2", "m2/s2"),
        ("_rad_s", "rad/s"),
        ("_pa_s", "Pa/s"),
        ("_k_s", "K/s"),
        ("_m_s2", "m/s2"),
        ("_m_s", "m/s"),
        ("_m2", "m2"),
        ("_m3", "m3"),
        ("_pa", "Pa"),
        ("_rad", "rad"),
        ("_k", "K"),
        ("_m", "m"),
        ("_s", "s"),
    ];
    SUFFIXES.iter().find(|(s, _)| name.ends_with(s)).map_or("", |(_, u)| u)
}

// Value references of the inputs, outputs and fixed parameters.
pub const P_GAS_PA: usize = 0;
pub const P_GAS2_PA: usize = 1;
pub const STRUT_DISP_M: usize = 2;
pub const BODY_ACC_M_S2: usize = 3;
pub const SPEED_M_S: usize = 4;
pub const LAT_ACC_M_S2: usize = 5;
pub const LONG_ACC_M_S2: usize = 6;
pub const STEER_ANGLE_RAD: usize = 7;
pub const STEER_RATE_RAD_S: usize = 8;
pub const BRAKE_PRESSED: usize = 9;
pub const T_GAS_K: usize = 10;
pub const DRIVER_MODE_VR: usize = 11;
pub const RIDE_HEIGHT_REQUEST_M: usize = 12;
pub const FRESH: usize = 13;
pub const LINK_FAULT: usize = 14;
pub const VALVE5_OPEN: usize = 15;
pub const VALVE6_OPEN: usize = 16;
pub const DRIVE_MODE_VR: usize = 17;
pub const SPRING_MODE_VR: usize = 18;
pub const DAMPER_MODE_VR: usize = 19;
pub const SEQUENCER_VR: usize = 20;
pub const DIAG: usize = 21;
pub const SAFE_STATE: usize = 22;
pub const RIDE_HEIGHT_M: usize = 23;
pub const P_GAS2_TARGET_PA: usize = 24;
pub const P_LOAD_PA: usize = 25;
pub const STRUT_VEL_M_S: usize = 26;
pub const BODY_VEL_M_S: usize = 27;
pub const PERIOD_S: usize = 28;
pub const GAS_MODEL: usize = 29;
pub const FIRST_CONFIG_PARAMETER: usize = 30;

fn build_info() -> ModelInfo {
    let seed = Config::seed_unit();
    let p = seed.unit.static_pressure_pa;
    let t = seed.unit.static_temperature_k;
    let input = |name, kind, start, description| Var::typed(name, kind, Causality::Input, start, description);
    let output = |name, kind, description| Var::typed(name, kind, Causality::Output, 0.0, description);
    let mut vars = vec![
        Var::input("p_gas_pa", p, "Pa", "gas pressure in S"),
        Var::input("p_gas2_pa", p, "Pa", "gas pressure in L"),
        Var::input("strut_disp_m", 0.0, "m", "strut compression from the nominal static position (positive = compression)"),
        Var::input("body_acc_m_s2", 0.0, "m/s2", "body vertical acceleration, gravity removed (positive = up)"),
        Var::input("speed_m_s", 0.0, "m/s", "vehicle speed"),
        Var::input("lat_acc_m_s2", 0.0, "m/s2", "lateral acceleration"),
        Var::input("long_acc_m_s2", 0.0, "m/s2", "longitudinal acceleration (negative = braking)"),
        Var::input("steer_angle_rad", 0.0, "rad", "steering-wheel angle"),
        Var::input("steer_rate_rad_s", 0.0, "rad/s", "steering-wheel rate"),
        input("brake_pressed", Kind::Boolean, 0.0, "brake pedal pressed"),
        Var::input("t_gas_k", t, "K", "gas temperature (as the sensor reads it)"),
        Var::enumerated("driver_mode", Causality::Input, 0, &DRIVER_MODE, "the driver's mode switch"),
        Var::input("ride_height_request_m", 0.0, "m", "requested ride height relative to the soft-mode rest height (negative = lower)"),
        input("fresh", Kind::Integer, f64::from(input_group::ALL), "bit mask of the input groups with a new value this period (hp_ctrl::input_group; 127 = all)"),
        input("link_fault", Kind::Boolean, 0.0, "the communication layer reports a fault"),
        output("valve5_open", Kind::Boolean, "valve 5 command: open = damper bypassed (low damping)"),
        output("valve6_open", Kind::Boolean, "valve 6 command: open = L connected"),
        Var::enumerated("drive_mode", Causality::Output, 0, &DRIVE_MODE, "selected driving mode"),
        Var::enumerated("spring_mode", Causality::Output, 0, &SPRING_MODE, "selected spring state"),
        Var::enumerated("damper_mode", Causality::Output, 0, &DAMPER_MODE, "selected damper state"),
        Var::enumerated("sequencer", Causality::Output, 0, &SEQUENCER, "ride-height sequencer state"),
        output("diag", Kind::Integer, "diagnostic flags (hp_ctrl::diag, docs/controller.md)"),
        output("safe_state", Kind::Boolean, "the outputs are the safe state (both valves de-energised): diag bit 0"),
        Var::output("ride_height_m", "m", "estimated ride-height offset held by the oil in L"),
        Var::output("p_gas2_target_pa", "Pa", "pressure in L that holds the requested ride height"),
        Var::output("p_load_pa", "Pa", "estimated static load pressure"),
        Var::output("strut_vel_m_s", "m/s", "estimated strut compression rate"),
        Var::output("body_vel_m_s", "m/s", "estimated body vertical velocity"),
        Var::parameter("period_s", 1e-3, "s", 1e-6, 1.0, "control period: the controller ticks at every multiple of it"),
        Var::enumerated("unit.gas", Causality::Parameter, crate::unit::gas_value(seed.unit.gas), &crate::unit::GAS, "equation of state of the gas table"),
    ];
    let mut template = seed;
    for (name, field) in config_fields() {
        vars.push(Var::parameter(name, *field(&mut template), unit_of(name), f64::NAN, f64::NAN, "see docs/controller.md"));
    }
    ModelInfo {
        identifier: "hpctl_controller",
        description: "hpctl valve-switching controller (hp_ctrl::step): mode selection, skyhook damping, pump-free ride height, safe state",
        vars: Box::leak(vars.into_boxed_slice()),
        default_stop_s: 10.0,
        default_step_s: 1e-3,
    }
}

/// The controller's configuration from the FMU's values.
pub fn config(values: &Values) -> Result<Config, ModelError> {
    let mut c = Config::seed_unit();
    let gas_index = values.get(GAS_MODEL) as i64 - 1;
    c.unit.gas = usize::try_from(gas_index)
        .ok()
        .and_then(|i| hp_core::gas::Gas::ALL.get(i).copied())
        .ok_or_else(|| ModelError(format!("unit.gas = {} is not a gas model (1..=4)", gas_index + 1)))?;
    for (i, (_, field)) in config_fields().into_iter().enumerate() {
        *field(&mut c) = values.get(FIRST_CONFIG_PARAMETER + i);
    }
    Ok(c)
}

/// The controller model: compiled parameters and state.
#[derive(Debug, Clone)]
pub struct ControllerModel {
    params: Params,
    state: State,
    period_s: f64,
}

fn inputs(v: &Values) -> Inputs {
    let driver_mode = match v.get(DRIVER_MODE_VR) as i64 {
        1 => DriverMode::Comfort,
        2 => DriverMode::Sport,
        _ => DriverMode::Auto,
    };
    Inputs {
        p_gas_pa: v.get(P_GAS_PA),
        p_gas2_pa: v.get(P_GAS2_PA),
        strut_disp_m: v.get(STRUT_DISP_M),
        body_acc_m_s2: v.get(BODY_ACC_M_S2),
        speed_m_s: v.get(SPEED_M_S),
        lat_acc_m_s2: v.get(LAT_ACC_M_S2),
        long_acc_m_s2: v.get(LONG_ACC_M_S2),
        steer_angle_rad: v.get(STEER_ANGLE_RAD),
        steer_rate_rad_s: v.get(STEER_RATE_RAD_S),
        brake_pressed: v.get_bool(BRAKE_PRESSED),
        t_gas_k: v.get(T_GAS_K),
        driver_mode,
        ride_height_request_m: v.get(RIDE_HEIGHT_REQUEST_M),
        // The FMI range of an Integer is wider than the mask: keep its bits.
        fresh: (v.get(FRESH) as i64 & i64::from(input_group::ALL)) as u16,
        link_fault: v.get_bool(LINK_FAULT),
    }
}

fn write_outputs(v: &mut Values, o: &Outputs) {
    v.set_bool(VALVE5_OPEN, o.valve5_open);
    v.set_bool(VALVE6_OPEN, o.valve6_open);
    v.set(DRIVE_MODE_VR, f64::from(o.drive_mode as u8));
    v.set(SPRING_MODE_VR, f64::from(o.spring_mode as u8));
    v.set(DAMPER_MODE_VR, f64::from(o.damper_mode as u8));
    v.set(SEQUENCER_VR, f64::from(o.sequencer as u8));
    v.set(DIAG, f64::from(o.diag));
    v.set_bool(SAFE_STATE, o.diag & diag::SAFE_STATE != 0);
    v.set(RIDE_HEIGHT_M, o.ride_height_m);
    v.set(P_GAS2_TARGET_PA, o.p_gas2_target_pa);
    v.set(P_LOAD_PA, o.p_load_pa);
    v.set(STRUT_VEL_M_S, o.strut_vel_m_s);
    v.set(BODY_VEL_M_S, o.body_vel_m_s);
}

impl ControllerModel {
    /// Ticks in one communication step of `step_s`.
    fn ticks(&self, step_s: f64) -> Result<u64, ModelError> {
        let n = (step_s / self.period_s).round();
        if !(n >= 1.0 && (n * self.period_s - step_s).abs() <= 1e-9 * step_s) {
            return Err(ModelError(format!(
                "communication step {step_s} s is not a whole number of controller periods (period_s = {} s)",
                self.period_s
            )));
        }
        Ok(n as u64)
    }
}

impl Model for ControllerModel {
    fn info() -> &'static ModelInfo {
        static INFO: OnceLock<ModelInfo> = OnceLock::new();
        INFO.get_or_init(build_info)
    }

    fn start(values: &Values, _time_s: f64) -> Result<Self, ModelError> {
        let params = Params::new(config(values)?).map_err(|e| ModelError(format!("controller configuration: {e}")))?;
        Ok(ControllerModel { params, state: State::new(), period_s: values.get(PERIOD_S) })
    }

    fn outputs(&mut self, values: &mut Values, _time_s: f64) -> Result<(), ModelError> {
        // The tick at this instant, on a copy: committed by the next step.
        let mut state = self.state;
        let out = step(&self.params, &mut state, &inputs(values), self.period_s);
        write_outputs(values, &out);
        Ok(())
    }

    fn do_step(&mut self, values: &Values, _time_s: f64, step_s: f64) -> Result<(), ModelError> {
        let n = self.ticks(step_s)?;
        let i = inputs(values);
        for _ in 0..n {
            step(&self.params, &mut self.state, &i, self.period_s);
        }
        Ok(())
    }
}
