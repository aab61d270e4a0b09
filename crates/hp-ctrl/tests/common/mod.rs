//! Helpers shared by the integration tests.
#![allow(dead_code, clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use hp_ctrl::{diag, input_group, step, DamperMode, DriveMode, Inputs, Outputs, Params, SequencerState, SpringMode, State};

/// The control period the tests run at, s.
pub const DT_S: f64 = 1.0e-3;

pub fn seed() -> Params {
    Params::seed_unit().unwrap()
}

/// A vehicle driving straight and steadily at 10 m/s with the unit at rest
/// at its static position: nothing should trigger anything.
pub fn calm(params: &Params) -> Inputs {
    let unit = &params.config().unit;
    Inputs {
        p_gas_pa: unit.static_pressure_pa,
        p_gas2_pa: unit.static_pressure_pa,
        t_gas_k: unit.static_temperature_k,
        speed_m_s: 10.0,
        fresh: input_group::ALL,
        ..Inputs::default()
    }
}

/// Runs `seconds` of periods with the same inputs; returns the last outputs.
pub fn run(params: &Params, state: &mut State, inputs: &Inputs, seconds: f64) -> Outputs {
    let steps = (seconds / DT_S).round() as usize;
    let mut out = Outputs::default();
    for _ in 0..steps {
        out = step(params, state, inputs, DT_S);
    }
    out
}

/// A controller past recovery, the handling hold and the load-pressure
/// settling time (0.5 + 5 s), in Ride on a calm road.
pub fn in_ride(params: &Params) -> State {
    let mut state = State::new();
    let out = run(params, &mut state, &calm(params), 6.0);
    assert_eq!(out.drive_mode, DriveMode::Ride);
    assert_eq!(out.diag & diag::SAFE_STATE, 0);
    state
}

/// The documented safe state: both valves de-energised, hard spring, high
/// damping, sequencer blocked, flagged.
pub fn is_safe(out: &Outputs) -> bool {
    !out.valve5_open
        && !out.valve6_open
        && out.drive_mode == DriveMode::Handling
        && out.spring_mode == SpringMode::Hard
        && out.damper_mode == DamperMode::High
        && out.sequencer == SequencerState::Blocked
        && out.diag & diag::SAFE_STATE != 0
}

/// Mass of gas in L from the static charge, straight from the equation of
/// state (the reference the controller's table is checked against).
pub fn large_gas_mass_kg(params: &Params) -> f64 {
    use hp_core::gas::EquationOfState;
    let unit = &params.config().unit;
    unit.gas.density_kg_m3(unit.static_pressure_pa, unit.static_temperature_k).unwrap() * unit.large_acc_volume_m3
}

/// Pressure of L's gas at the volume offset `u_m` (L's gas volume change
/// as strut travel, see `hp_ctrl::gas_table`) at `t_k`, from the equation
/// of state.
pub fn large_pressure_pa(params: &Params, u_m: f64, t_k: f64) -> f64 {
    use hp_core::gas::EquationOfState;
    let unit = &params.config().unit;
    let volume_m3 = unit.large_acc_volume_m3 + unit.piston_area_m2 * u_m;
    unit.gas.pressure_pa(large_gas_mass_kg(params) / volume_m3, t_k)
}

/// The volume offset at which L's gas has the pressure `p_pa` at `t_k`,
/// from the equation of state (density solve).
pub fn large_offset_m(params: &Params, p_pa: f64, t_k: f64) -> f64 {
    use hp_core::gas::EquationOfState;
    let unit = &params.config().unit;
    let volume_m3 = large_gas_mass_kg(params) / unit.gas.density_kg_m3(p_pa, t_k).unwrap();
    (volume_m3 - unit.large_acc_volume_m3) / unit.piston_area_m2
}

/// The ride-height offset L's pressure `p_pa` holds relative to the
/// soft-mode rest state at the load pressure `p_load_pa` (L's gas at the
/// load pressure), from the equation of state.
pub fn held_offset_m(params: &Params, p_pa: f64, p_load_pa: f64, t_k: f64) -> f64 {
    large_offset_m(params, p_pa, t_k) - large_offset_m(params, p_load_pa, t_k)
}

/// The pressure in L that holds the offset `h_m` from the soft-mode rest
/// state at the load pressure `p_load_pa`, from the equation of state.
pub fn target_pressure_pa(params: &Params, h_m: f64, p_load_pa: f64, t_k: f64) -> f64 {
    large_pressure_pa(params, large_offset_m(params, p_load_pa, t_k) + h_m, t_k)
}

/// How closely the controller's gas table must reproduce the equation of
/// state, expressed as ride height, m (a tenth of the sequencer's
/// tolerance, and below what a 0.2 % pressure transducer resolves).
pub const TABLE_HEIGHT_ACCURACY_M: f64 = 0.3e-3;
