//! The gas table of L and pump-free ride-height sequencing.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::{
    calm, held_offset_m, in_ride, large_offset_m, large_pressure_pa, seed, target_pressure_pa, DT_S,
    TABLE_HEIGHT_ACCURACY_M,
};
use hp_core::gas::EquationOfState;
use hp_ctrl::{diag, step, DriveMode, DriverMode, Inputs, Outputs, Params, SequencerState, SpringMode, State};

#[test]
fn the_table_reproduces_the_equation_of_state_both_ways() {
    let params = seed();
    let table = params.large_table();
    let m = params.config().monitor;
    let (u_min, u_max) = table.offset_range_m();
    let (u_min, u_max) = (f64::from(u_min), f64::from(u_max));
    // It covers the stroke widened by the largest request.
    let unit = params.config().unit;
    let request_max_m = params.config().ride_height.request_max_m;
    assert!(u_min <= -(unit.stroke_compression_m + request_max_m) + 1e-6, "{u_min}");
    assert!(u_max >= unit.stroke_extension_m + request_max_m - 1e-6, "{u_max}");
    let mut worst_m: f64 = 0.0;
    // Off-node points over the whole table and temperature range.
    for ti in 0..=43 {
        let t_k = m.temperature_min_k + (m.temperature_max_k - m.temperature_min_k) * ti as f64 / 43.0;
        for ui in 0..=97 {
            let u_m = u_min + (u_max - u_min) * ui as f64 / 97.0;
            let p_table = f64::from(table.pressure_pa(u_m as f32, t_k as f32));
            let forward_m = large_offset_m(&params, p_table, t_k) - u_m;
            let p_eos = large_pressure_pa(&params, u_m, t_k);
            let backward_m = f64::from(table.offset_m(p_eos as f32, t_k as f32)) - u_m;
            worst_m = worst_m.max(forward_m.abs()).max(backward_m.abs());
        }
    }
    assert!(worst_m < TABLE_HEIGHT_ACCURACY_M, "worst {worst_m} m");
}

#[test]
fn l_at_the_load_pressure_reads_as_zero_offset_at_any_temperature() {
    // Soft mode at rest: p_L = p_S = the load pressure. That is the zero of
    // the ride height, hot or cold: temperature alone is no offset.
    let params = seed();
    let unit = params.config().unit;
    let mut state = in_ride(&params);
    let out = step(&params, &mut state, &calm(&params), DT_S);
    assert!(out.ride_height_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{}", out.ride_height_m);
    // Cold and hot, up to beyond the temperature at which the soft spring's
    // rest state reaches the extension end stop (about 60 K above the
    // charge for the seed unit), as long as the zero is inside the table.
    for t_k in [unit.static_temperature_k - 60.0, unit.static_temperature_k + 40.0, unit.static_temperature_k + 70.0] {
        let inputs = Inputs { t_gas_k: t_k, ..calm(&params) };
        let mut state = State::new();
        let out = common::run(&params, &mut state, &inputs, 0.1);
        assert!(out.ride_height_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{t_k} K: {}", out.ride_height_m);
        // The target of a zero request is the load pressure itself, and of
        // -30 mm the pressure of L's gas squeezed by 30 mm of strut travel
        // from its volume at the load pressure (reference: the EOS).
        assert!((out.p_gas2_target_pa / unit.static_pressure_pa - 1.0).abs() < 2e-3, "{}", out.p_gas2_target_pa);
        let inputs = Inputs { ride_height_request_m: -0.03, ..inputs };
        let out = step(&params, &mut state, &inputs, DT_S);
        let expected_pa = target_pressure_pa(&params, -0.03, unit.static_pressure_pa, t_k);
        let error_m = held_offset_m(&params, out.p_gas2_target_pa, unit.static_pressure_pa, t_k) + 0.03;
        assert!(error_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{t_k} K: {} vs {expected_pa}", out.p_gas2_target_pa);
    }
}

#[test]
fn the_zero_offset_follows_the_measured_load() {
    // A heavier payload: the unit settles at rest with 10 % more pressure
    // in S (and, soft, in L). That is the new zero, not a lowering.
    let params = seed();
    let unit = params.config().unit;
    let p_heavy_pa = 1.1 * unit.static_pressure_pa;
    let heavy = Inputs { p_gas_pa: p_heavy_pa, p_gas2_pa: p_heavy_pa, ..calm(&params) };
    let mut state = State::new();
    let out = common::run(&params, &mut state, &heavy, 3.0);
    assert!((out.p_load_pa / p_heavy_pa - 1.0).abs() < 1e-6, "{}", out.p_load_pa);
    assert!(out.ride_height_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{}", out.ride_height_m);
    assert_eq!(out.sequencer, SequencerState::Idle);
    let inputs = Inputs { ride_height_request_m: 0.03, ..heavy };
    let out = step(&params, &mut state, &inputs, DT_S);
    let t_k = unit.static_temperature_k;
    let error_m = held_offset_m(&params, out.p_gas2_target_pa, p_heavy_pa, t_k) - 0.03;
    assert!(error_m.abs() < TABLE_HEIGHT_ACCURACY_M, "{error_m}");
}

/// Accumulator L behind an ideal-orifice valve 6, with S's pressure swung
/// by road input: enough plant to close the sequencing loop.
struct ToyUnit {
    gas_mass_kg: f64,
    v_gas2_m3: f64,
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
            v_gas2_m3: unit.large_acc_volume_m3,
            t_k: unit.static_temperature_k,
            time_s: 0.0,
            swing_pa: 2.0e6,
            swing_hz: 1.5,
        }
    }
    fn p_gas_pa(&self, params: &Params) -> f64 {
        params.config().unit.static_pressure_pa
            + self.swing_pa * (2.0 * std::f64::consts::PI * self.swing_hz * self.time_s).sin()
    }
    fn p_gas2_pa(&self, params: &Params) -> f64 {
        params.config().unit.gas.pressure_pa(self.gas_mass_kg / self.v_gas2_m3, self.t_k)
    }
    /// The offset L holds from the soft-mode rest state: L's gas volume
    /// against its volume at the (mean) load pressure, the static one.
    fn height_m(&self, params: &Params) -> f64 {
        let unit = params.config().unit;
        let u_m = (self.v_gas2_m3 - unit.large_acc_volume_m3) / unit.piston_area_m2;
        u_m - large_offset_m(params, unit.static_pressure_pa, self.t_k)
    }
    fn inputs(&self, params: &Params, request_m: f64, driver: DriverMode) -> Inputs {
        Inputs {
            p_gas_pa: self.p_gas_pa(params),
            p_gas2_pa: self.p_gas2_pa(params),
            t_gas_k: self.t_k,
            ride_height_request_m: request_m,
            driver_mode: driver,
            ..calm(params)
        }
    }
    /// Advances one period with valve 6 as commanded (oil into L lowers its gas volume).
    fn advance(&mut self, params: &Params, valve6_open: bool) {
        if valve6_open {
            let flow_m3_s = Self::CONDUCTANCE * (self.p_gas_pa(params) - self.p_gas2_pa(params));
            self.v_gas2_m3 -= flow_m3_s * DT_S;
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
            assert!(inputs.p_gas_pa - inputs.p_gas2_pa > margin);
        }
        if out.valve6_open && out.sequencer == SequencerState::Raising {
            assert!(inputs.p_gas2_pa - inputs.p_gas_pa > margin);
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
    // It stops once L's pressure reaches the target, i.e. at or just past
    // it; the target and the estimate are relative to the controller's load
    // estimate (a mean of the swinging p_S, close to the static pressure).
    let p_load_pa = out.p_load_pa;
    assert!((p_load_pa / params.config().unit.static_pressure_pa - 1.0).abs() < 0.01, "{p_load_pa}");
    let p_target = target_pressure_pa(&params, -0.03, p_load_pa, plant.t_k);
    assert!(plant.p_gas2_pa(&params) >= p_target - 1.0e3, "{} vs {p_target}", plant.p_gas2_pa(&params));
    let expected_m = held_offset_m(&params, plant.p_gas2_pa(&params), p_load_pa, plant.t_k);
    assert!((out.ride_height_m - expected_m).abs() < TABLE_HEIGHT_ACCURACY_M, "{} vs {expected_m}", out.ride_height_m);
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
fn returning_to_zero_is_sequenced_before_the_spring_goes_soft() {
    let params = seed();
    let rh = params.config().ride_height;
    let mut state = in_ride(&params);
    let mut plant = ToyUnit::new(&params);
    let (out, _) = sequence(&params, &mut state, &mut plant, -0.03, DriverMode::Auto, 60.0);
    assert_eq!(out.sequencer, SequencerState::Holding);
    // Back to a zero request in Ride: raise by sequencing (valve 6 only
    // while p_L > p_S), and open it for the soft spring only once the held
    // offset is within tolerance of zero.
    let mut raising_periods = 0;
    let mut idle_at = None;
    for k in 0..60_000 {
        let inputs = plant.inputs(&params, 0.0, DriverMode::Auto);
        let out = step(&params, &mut state, &inputs, DT_S);
        match out.sequencer {
            SequencerState::Raising => {
                raising_periods += 1;
                if out.valve6_open {
                    assert!(inputs.p_gas2_pa - inputs.p_gas_pa > rh.valve6_margin_pa);
                }
                assert_ne!(out.diag & diag::HEIGHT_HOLDS_SPRING, 0);
            }
            SequencerState::Idle => {
                assert_eq!(out.spring_mode, SpringMode::Soft);
                idle_at = Some(k);
                break;
            }
            other => assert!(matches!(other, SequencerState::Holding | SequencerState::Blocked), "{out:?}"),
        }
        plant.advance(&params, out.valve6_open);
    }
    assert!(raising_periods > 0 && idle_at.is_some(), "{raising_periods} {idle_at:?}");
    // Valve 6 opens for the soft spring once its minimum off time is over.
    let min_off_periods = (rh.valve6_min_off_s / DT_S).round() as usize;
    let opened = (0..=min_off_periods).any(|_| {
        let out = step(&params, &mut state, &plant.inputs(&params, 0.0, DriverMode::Auto), DT_S);
        out.valve6_open
    });
    assert!(opened);
    // The controller's estimate was within tolerance; the plant's offset
    // too, up to the error of the load estimate (a mean of the swing).
    assert!(plant.height_m(&params).abs() < rh.tolerance_m + 1.0e-3, "{}", plant.height_m(&params));
}

#[test]
fn in_handling_the_sequencer_keeps_the_zero_offset() {
    // Sport: valve 6 stays closed, so an offset locked into L is sequenced
    // back to the (zero) request instead of being equalised away.
    let params = seed();
    let tolerance_m = params.config().ride_height.tolerance_m;
    let mut state = in_ride(&params);
    let mut plant = ToyUnit::new(&params);
    plant.v_gas2_m3 -= 0.02 * params.config().unit.piston_area_m2; // 20 mm low
    let (out, _) = sequence(&params, &mut state, &mut plant, 0.0, DriverMode::Sport, 60.0);
    assert_eq!(out.sequencer, SequencerState::Holding);
    assert_eq!(out.drive_mode, DriveMode::Handling);
    assert!(plant.height_m(&params).abs() < tolerance_m, "{}", plant.height_m(&params));
}

#[test]
fn a_hot_unit_entering_handling_keeps_its_height() {
    // 40 K above the charge temperature, L's gas at the load pressure (where
    // the soft spring left it) is 57 mm of strut travel larger than at the
    // charge. Handling with a zero request must not sequence that away.
    let params = seed();
    let unit = params.config().unit;
    let mut plant = ToyUnit::new(&params);
    plant.t_k = unit.static_temperature_k + 40.0;
    let u_rest_m = large_offset_m(&params, unit.static_pressure_pa, plant.t_k);
    assert!(u_rest_m > 0.04, "{u_rest_m}");
    plant.v_gas2_m3 = unit.large_acc_volume_m3 + unit.piston_area_m2 * u_rest_m;
    let v_rest_m3 = plant.v_gas2_m3;
    let mut state = State::new();
    for _ in 0..20_000 {
        let out = step(&params, &mut state, &plant.inputs(&params, 0.0, DriverMode::Sport), DT_S);
        assert_eq!(out.drive_mode, DriveMode::Handling);
        assert!(!out.valve6_open, "{out:?}");
        assert!(matches!(out.sequencer, SequencerState::Holding | SequencerState::Blocked), "{out:?}");
        plant.advance(&params, out.valve6_open);
    }
    assert_eq!(plant.v_gas2_m3, v_rest_m3);
}

#[test]
fn the_load_pressure_is_a_slow_mean_of_calm_valid_periods() {
    let params = seed();
    let unit = params.config().unit;
    let rh = params.config().ride_height;
    let mut state = in_ride(&params);
    let p0_pa = 1.05 * unit.static_pressure_pa;
    let (amplitude_pa, f_hz) = (2.0e6, 1.2);
    let mut out = Outputs::default();
    let mut worst_pa: f64 = 0.0;
    for k in 0..160_000 {
        let t_s = k as f64 * DT_S;
        let p_s = p0_pa + amplitude_pa * (2.0 * std::f64::consts::PI * f_hz * t_s).sin();
        out = step(&params, &mut state, &Inputs { p_gas_pa: p_s, p_gas2_pa: p_s, ..calm(&params) }, DT_S);
        // After the start (a running mean including the 6 s at the static
        // pressure, then the low-pass) has decayed below 1 kPa.
        if t_s > 7.0 * rh.load_pressure_tau_s {
            worst_pa = worst_pa.max((out.p_load_pa - p0_pa).abs());
        }
    }
    // A first-order low-pass passes a sine at f reduced by 1/sqrt(1 + (2 pi f tau)^2).
    let ripple_pa = amplitude_pa / (1.0 + (2.0 * std::f64::consts::PI * f_hz * rh.load_pressure_tau_s).powi(2)).sqrt();
    assert!(worst_pa < 1.1 * ripple_pa + 5.0e3, "{worst_pa} vs {ripple_pa}");
    // Cornering, braking, and the safe state do not move it.
    let before = out.p_load_pa;
    let far = Inputs { p_gas_pa: 0.8 * p0_pa, p_gas2_pa: 0.8 * p0_pa, ..calm(&params) };
    for spoiler in [
        Inputs { lat_acc_m_s2: 1.1 * rh.block_lat_acc_m_s2, ..far },
        Inputs { long_acc_m_s2: -1.1 * rh.block_long_acc_m_s2, ..far },
        Inputs { brake_pressed: true, ..far },
        Inputs { link_fault: true, ..far },
        Inputs { t_gas_k: f64::NAN, ..far },
    ] {
        for _ in 0..1000 {
            out = step(&params, &mut state, &spoiler, DT_S);
        }
        assert_eq!(out.p_load_pa, before, "{spoiler:?}");
    }
}

#[test]
fn the_load_pressure_ignores_the_damper_and_the_body_acceleration() {
    // A body bouncing on the strut at 1.5 Hz over a fixed base, the gas
    // carrying the load and the body's inertia (p_strut = p_load (1 + a/g)),
    // a damper stronger in rebound than in compression between strut and S,
    // and an accelerometer reading 0.2 m/s^2 high. The mean of p_S is off
    // by the damper's asymmetry; the estimate must not be.
    let params = seed();
    let unit = params.config().unit;
    let g = 9.80665;
    let p_load_pa = 1.03 * unit.static_pressure_pa;
    let (amplitude_m, w) = (0.01, 2.0 * std::f64::consts::PI * 1.5);
    // Damper pressure drop per strut velocity, Pa s/m (30 and 40 kN s/m).
    let (k_compression, k_rebound) = (30.0e3 / unit.piston_area_m2, 40.0e3 / unit.piston_area_m2);
    let mut state = in_ride(&params);
    let (mut sum_pa, mut count) = (0.0, 0.0);
    let mut out = Outputs::default();
    for k in 0..150_000 {
        let t_s = k as f64 * DT_S;
        let x = amplitude_m * (w * t_s).sin();
        let v = amplitude_m * w * (w * t_s).cos();
        // Strut compression x means the body is at -x: a = -x''.
        let a = amplitude_m * w * w * (w * t_s).sin();
        let p_strut = p_load_pa * (1.0 + a / g);
        let p_s = if v > 0.0 { p_strut - k_compression * v } else { p_strut + k_rebound * -v };
        let inputs =
            Inputs { p_gas_pa: p_s, p_gas2_pa: p_s, strut_disp_m: x, body_acc_m_s2: a + 0.2, ..calm(&params) };
        out = step(&params, &mut state, &inputs, DT_S);
        if t_s > 100.0 {
            sum_pa += p_s;
            count += 1.0;
        }
    }
    let mean_bias_pa = sum_pa / count - p_load_pa;
    assert!(mean_bias_pa > 0.1e6, "the signal's mean is biased by {mean_bias_pa} Pa");
    let error_pa = out.p_load_pa - p_load_pa;
    assert!(error_pa.abs() < 10.0e3, "estimate off by {error_pa} Pa (mean of p_S off by {mean_bias_pa} Pa)");
}

#[test]
fn before_any_calm_period_the_load_pressure_is_the_configured_static_pressure() {
    let params = seed();
    let unit = params.config().unit;
    let mut state = State::new();
    let inputs = Inputs { p_gas_pa: 0.9 * unit.static_pressure_pa, ..calm(&params) };
    // Power-on is the safe state: no update, the configured value.
    let out = common::run(&params, &mut state, &inputs, 0.2);
    assert_eq!(out.p_load_pa, f64::from(unit.static_pressure_pa as f32));
    // After recovery the first calm sample replaces it (a running mean).
    let out = common::run(&params, &mut state, &inputs, 0.4);
    assert!((out.p_load_pa / (0.9 * unit.static_pressure_pa) - 1.0).abs() < 1e-6, "{}", out.p_load_pa);
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
        let inputs = Inputs { p_gas_pa: p_s, p_gas2_pa: p_l, ride_height_request_m: -0.03, ..calm(&params) };
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

#[test]
fn a_lowering_corner_moves_oil_only_while_valve_6_is_open() {
    // The vehicle's slope levelling waits until no corner moves oil
    // (`State::moving_oil`), not until no corner is in `Lowering`: a
    // pump-free corner at rest can sit in `Lowering` for ever waiting for
    // a pressure difference the road no longer gives.
    let params = seed();
    let unit = params.config().unit;
    let margin = params.config().ride_height.valve6_margin_pa;
    let mut state = in_ride(&params);
    let p_l = unit.static_pressure_pa;
    // At rest: S at L's pressure, the difference never reaches the margin.
    let still = Inputs { p_gas_pa: p_l, p_gas2_pa: p_l, ride_height_request_m: -0.03, ..calm(&params) };
    let mut lowering = 0;
    for _ in 0..3000 {
        let out = step(&params, &mut state, &still, DT_S);
        assert!(!out.valve6_open);
        if out.sequencer == SequencerState::Lowering {
            lowering += 1;
            assert!(!state.moving_oil(), "waiting in Lowering with valve 6 closed moves no oil");
        }
    }
    assert!(lowering > 0, "the request must put the sequencer in Lowering");
    // A road stroke gives S the difference: valve 6 opens and oil moves.
    let pushed = Inputs { p_gas_pa: p_l + margin + 1.0e5, ..still };
    let mut opened = false;
    for _ in 0..1000 {
        let out = step(&params, &mut state, &pushed, DT_S);
        assert_eq!(state.moving_oil(), out.valve6_open && out.sequencer == SequencerState::Lowering);
        opened |= out.valve6_open;
    }
    assert!(opened, "valve 6 never opened past the margin");
}
