//! The gas table of L and pump-free ride-height sequencing.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::{calm, in_ride, large_height_m, large_pressure_pa, seed, DT_S, TABLE_HEIGHT_ACCURACY_M};
use hp_core::gas::EquationOfState;
use hp_ctrl::{diag, step, DriveMode, DriverMode, Inputs, Outputs, Params, SequencerState, SpringMode, State};

#[test]
fn the_table_reproduces_the_equation_of_state_both_ways() {
    let params = seed();
    let table = params.large_table();
    let unit = params.config().unit;
    let m = params.config().monitor;
    let mut worst_m: f64 = 0.0;
    // Off-node points over the whole stroke and temperature range.
    for ti in 0..=43 {
        let t_k = m.temperature_min_k + (m.temperature_max_k - m.temperature_min_k) * ti as f64 / 43.0;
        for hi in 0..=97 {
            let h_m = -unit.stroke_compression_m
                + (unit.stroke_compression_m + unit.stroke_extension_m) * hi as f64 / 97.0;
            let p_table = f64::from(table.pressure_pa(h_m as f32, t_k as f32));
            let forward_m = large_height_m(&params, p_table, t_k) - h_m;
            let p_eos = large_pressure_pa(&params, h_m, t_k);
            let backward_m = f64::from(table.ride_height_m(p_eos as f32, t_k as f32)) - h_m;
            worst_m = worst_m.max(forward_m.abs()).max(backward_m.abs());
        }
    }
    assert!(worst_m < TABLE_HEIGHT_ACCURACY_M, "worst {worst_m} m");
}

#[test]
fn the_static_charge_reads_as_nominal_and_hot_gas_as_raised() {
    let params = seed();
    let unit = params.config().unit;
    let mut state = in_ride(&params);
    let out = step(&params, &mut state, &calm(&params), DT_S);
    assert!(out.ride_height_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{}", out.ride_height_m);
    // The same pressure in hotter gas means more gas volume: more oil in
    // S and the strut, a raised body. Reference: the gas law directly.
    let t_hot_k = unit.static_temperature_k + 60.0;
    let hot = Inputs { t_gas_k: t_hot_k, ..calm(&params) };
    let mut state = State::new();
    let out = common::run(&params, &mut state, &hot, 0.1);
    let expected_m = large_height_m(&params, unit.static_pressure_pa, t_hot_k);
    assert!(expected_m > 0.01, "{expected_m}");
    assert!((out.ride_height_m - expected_m).abs() < TABLE_HEIGHT_ACCURACY_M, "{} vs {expected_m}", out.ride_height_m);
    // And the target pressure of a zero request is temperature compensated.
    let expected_pa = large_pressure_pa(&params, 0.0, t_hot_k);
    assert!(large_height_m(&params, out.p_large_target_pa, t_hot_k).abs() < TABLE_HEIGHT_ACCURACY_M);
    assert!(out.p_large_target_pa > unit.static_pressure_pa && expected_pa > unit.static_pressure_pa);
}

/// Accumulator L behind an ideal-orifice valve 6, with S's pressure swung
/// by road input: enough plant to close the sequencing loop.
struct ToyUnit {
    gas_mass_kg: f64,
    v_large_m3: f64,
    t_k: f64,
    time_s: f64,
    /// Amplitude and frequency of S's pressure swing.
    swing_pa: f64,
    swing_hz: f64,
}

impl ToyUnit {
    /// Flow conductance of valve 6, m^3/(s Pa): S and L equalise in about 5 ms.
    const CONDUCTANCE: f64 = 1.2e-8;

    fn new(params: &Params) -> Self {
        let unit = params.config().unit;
        ToyUnit {
            gas_mass_kg: common::large_gas_mass_kg(params),
            v_large_m3: unit.large_volume_m3,
            t_k: unit.static_temperature_k,
            time_s: 0.0,
            swing_pa: 2.0e6,
            swing_hz: 1.5,
        }
    }
    fn p_small_pa(&self, params: &Params) -> f64 {
        params.config().unit.static_pressure_pa
            + self.swing_pa * (2.0 * std::f64::consts::PI * self.swing_hz * self.time_s).sin()
    }
    fn p_large_pa(&self, params: &Params) -> f64 {
        params.config().unit.gas.pressure_pa(self.gas_mass_kg / self.v_large_m3, self.t_k)
    }
    fn height_m(&self, params: &Params) -> f64 {
        let unit = params.config().unit;
        (self.v_large_m3 - unit.large_volume_m3) / unit.piston_area_m2
    }
    fn inputs(&self, params: &Params, request_m: f64, driver: DriverMode) -> Inputs {
        Inputs {
            p_small_pa: self.p_small_pa(params),
            p_large_pa: self.p_large_pa(params),
            t_gas_k: self.t_k,
            ride_height_request_m: request_m,
            driver_mode: driver,
            ..calm(params)
        }
    }
    /// Advances one period with valve 6 as commanded (oil into L lowers its gas volume).
    fn advance(&mut self, params: &Params, valve6_open: bool) {
        if valve6_open {
            let flow_m3_s = Self::CONDUCTANCE * (self.p_small_pa(params) - self.p_large_pa(params));
            self.v_large_m3 -= flow_m3_s * DT_S;
        }
        self.time_s += DT_S;
    }
}

/// Runs the loop until the sequencer holds (or `max_s`), checking the
/// valve-direction rule in every period; returns the last outputs.
fn sequence(
    params: &Params,
    state: &mut State,
    plant: &mut ToyUnit,
    request_m: f64,
    driver: DriverMode,
    max_s: f64,
) -> (Outputs, f64) {
    let margin = params.config().ride_height.valve6_margin_pa;
    let mut out = Outputs::default();
    let mut t = 0.0;
    let mut moved = false;
    while t < max_s {
        let inputs = plant.inputs(params, request_m, driver);
        out = step(params, state, &inputs, DT_S);
        match out.sequencer {
            SequencerState::Lowering | SequencerState::Raising => moved = true,
            SequencerState::Holding if moved => return (out, t),
            _ => {}
        }
        if out.valve6_open && out.sequencer == SequencerState::Lowering {
            assert!(inputs.p_small_pa - inputs.p_large_pa > margin);
        }
        if out.valve6_open && out.sequencer == SequencerState::Raising {
            assert!(inputs.p_large_pa - inputs.p_small_pa > margin);
        }
        assert_eq!(out.spring_mode, SpringMode::Hard);
        plant.advance(params, out.valve6_open);
        t += DT_S;
    }
    (out, t)
}

#[test]
fn lowering_then_raising_by_30_mm_without_a_pump() {
    let params = seed();
    let tolerance_m = params.config().ride_height.tolerance_m;
    let mut state = in_ride(&params);
    let mut plant = ToyUnit::new(&params);

    let (out, took_s) = sequence(&params, &mut state, &mut plant, -0.03, DriverMode::Auto, 60.0);
    assert_eq!(out.sequencer, SequencerState::Holding, "not done after {took_s} s");
    let height_m = plant.height_m(&params);
    assert!((height_m + 0.03).abs() < tolerance_m, "lowered to {height_m}");
    // It stops once L's pressure reaches the target, i.e. at or just past it.
    let p_target = large_pressure_pa(&params, -0.03, plant.t_k);
    assert!(plant.p_large_pa(&params) >= p_target - 1.0e3, "{} vs {p_target}", plant.p_large_pa(&params));
    assert!((out.ride_height_m - height_m).abs() < TABLE_HEIGHT_ACCURACY_M);
    // Ride mode, but the height holds the spring hard.
    assert_eq!(out.drive_mode, DriveMode::Ride);
    assert_ne!(out.diag & diag::HEIGHT_HOLDS_SPRING, 0);

    // Holding keeps valve 6 closed and the oil where it is.
    for _ in 0..2000 {
        let out = step(&params, &mut state, &plant.inputs(&params, -0.03, DriverMode::Auto), DT_S);
        assert_eq!(out.sequencer, SequencerState::Holding);
        assert!(!out.valve6_open);
        plant.advance(&params, out.valve6_open);
    }

    // Back up to +30 mm.
    let (out, took_s) = sequence(&params, &mut state, &mut plant, 0.03, DriverMode::Auto, 60.0);
    assert_eq!(out.sequencer, SequencerState::Holding, "not done after {took_s} s");
    let height_m = plant.height_m(&params);
    assert!((height_m - 0.03).abs() < tolerance_m, "raised to {height_m}");
}

#[test]
fn in_handling_the_sequencer_keeps_the_nominal_height() {
    // Sport: valve 6 stays closed, so an offset locked into L is sequenced
    // back to the (zero) request instead of being equalised away.
    let params = seed();
    let tolerance_m = params.config().ride_height.tolerance_m;
    let mut state = in_ride(&params);
    let mut plant = ToyUnit::new(&params);
    plant.v_large_m3 -= 0.02 * params.config().unit.piston_area_m2; // 20 mm low
    let (out, _) = sequence(&params, &mut state, &mut plant, 0.0, DriverMode::Sport, 60.0);
    assert_eq!(out.sequencer, SequencerState::Holding);
    assert_eq!(out.drive_mode, DriveMode::Handling);
    assert!(plant.height_m(&params).abs() < tolerance_m, "{}", plant.height_m(&params));
}

#[test]
fn nominal_request_in_ride_is_idle_with_the_soft_spring() {
    let params = seed();
    let mut state = in_ride(&params);
    let out = step(&params, &mut state, &calm(&params), DT_S);
    assert_eq!(out.sequencer, SequencerState::Idle);
    assert_eq!(out.spring_mode, SpringMode::Soft);
    assert!(out.valve6_open);
    // Within the deadband is nominal too.
    let deadband_m = params.config().ride_height.request_deadband_m;
    let inputs = Inputs { ride_height_request_m: -0.9 * deadband_m, ..calm(&params) };
    let out = step(&params, &mut state, &inputs, DT_S);
    assert_eq!(out.sequencer, SequencerState::Idle);
}

#[test]
fn sequencing_pauses_while_cornering_braking_or_accelerating_and_resumes_after_calm() {
    let params = seed();
    let rh = params.config().ride_height;
    let spoilers = [
        Inputs { lat_acc_m_s2: 1.1 * rh.block_lat_acc_m_s2, ..Inputs::default() },
        Inputs { long_acc_m_s2: -1.1 * rh.block_long_acc_m_s2, ..Inputs::default() },
        Inputs { long_acc_m_s2: 1.1 * rh.block_long_acc_m_s2, ..Inputs::default() },
        Inputs { brake_pressed: true, ..Inputs::default() },
    ];
    for spoiler in spoilers {
        let mut state = in_ride(&params);
        let mut plant = ToyUnit::new(&params);
        // Start lowering.
        let mut out = Outputs::default();
        while out.sequencer != SequencerState::Lowering {
            out = step(&params, &mut state, &plant.inputs(&params, -0.03, DriverMode::Auto), DT_S);
            plant.advance(&params, out.valve6_open);
        }
        let manoeuvre = |plant: &ToyUnit| Inputs {
            lat_acc_m_s2: spoiler.lat_acc_m_s2,
            long_acc_m_s2: spoiler.long_acc_m_s2,
            brake_pressed: spoiler.brake_pressed,
            ..plant.inputs(&params, -0.03, DriverMode::Auto)
        };
        for _ in 0..1000 {
            let out = step(&params, &mut state, &manoeuvre(&plant), DT_S);
            assert_eq!(out.sequencer, SequencerState::Blocked, "{spoiler:?}");
            assert!(!out.valve6_open);
            assert_ne!(out.diag & diag::SEQUENCER_PAUSED, 0);
            plant.advance(&params, out.valve6_open);
        }
        // Calm again: still paused for the resume time, then it goes on.
        let resume_periods = (rh.resume_s / DT_S).round() as usize;
        for k in 1..resume_periods {
            let out = step(&params, &mut state, &plant.inputs(&params, -0.03, DriverMode::Auto), DT_S);
            assert_eq!(out.sequencer, SequencerState::Blocked, "period {k}");
            plant.advance(&params, out.valve6_open);
        }
        let out = step(&params, &mut state, &plant.inputs(&params, -0.03, DriverMode::Auto), DT_S);
        assert_eq!(out.sequencer, SequencerState::Lowering);
    }
}

#[test]
fn the_valve_opens_only_past_the_margin_in_the_wanted_direction() {
    let params = seed();
    let unit = params.config().unit;
    let margin = params.config().ride_height.valve6_margin_pa;
    let mut state = in_ride(&params);
    // Lowering from nominal: p_L at its static value, S swept across it.
    let p_l = unit.static_pressure_pa;
    let mut opened_at = None;
    for k in 0..4000 {
        let p_s = p_l - 1.0e6 + 1.0e3 * k as f64;
        let inputs = Inputs { p_small_pa: p_s, p_large_pa: p_l, ride_height_request_m: -0.03, ..calm(&params) };
        let out = step(&params, &mut state, &inputs, DT_S);
        if out.sequencer == SequencerState::Lowering && out.valve6_open && opened_at.is_none() {
            opened_at = Some(p_s - p_l);
        }
    }
    let opened_at = opened_at.unwrap();
    assert!(opened_at > margin && opened_at <= margin + 1.0e3, "opened at {opened_at}");
}

#[test]
fn sequencing_pauses_during_manoeuvres_even_without_a_resume_time() {
    let mut config = hp_ctrl::Config::seed_unit();
    config.ride_height.resume_s = 0.0;
    let params = Params::new(config).unwrap();
    let mut state = in_ride(&params);
    let plant = ToyUnit::new(&params);
    let request = plant.inputs(&params, -0.03, DriverMode::Auto);
    assert_eq!(step(&params, &mut state, &request, DT_S).sequencer, SequencerState::Lowering);
    let cornering = Inputs { lat_acc_m_s2: 1.1 * config.ride_height.block_lat_acc_m_s2, ..request };
    let out = step(&params, &mut state, &cornering, DT_S);
    assert_eq!(out.sequencer, SequencerState::Blocked);
    assert!(!out.valve6_open);
    assert_eq!(step(&params, &mut state, &request, DT_S).sequencer, SequencerState::Lowering);
}
