//! Properties over arbitrary input sequences (proptest).
//!
//! Each case is a random configuration (the timers that shape the
//! behaviour, short enough for a few hundred periods to exercise them) and
//! a random sequence of periods: pressures swinging around the static
//! charge, random vehicle signals and requests, mixed step sizes, dropped
//! fresh flags, and injected NaN/infinite/out-of-range values, link faults
//! and invalid step sizes. The checks use the documented rules
//! (docs/controller.md), restated here independently of the code.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use hp_ctrl::{
    diag, input_group, step, Config, DamperMode, DriveMode, DriverMode, Inputs, Outputs, Params, SequencerState,
    SpringMode, State,
};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Largest step size of the generated configurations, s.
const DT_MAX_S: f64 = 0.005;

fn config_strategy() -> impl Strategy<Value = Config> {
    (
        (0.0..0.05_f64, 0.0..0.1_f64, 0.0..0.05_f64),
        (0.0..0.02_f64, 0.0..0.02_f64, 0.0..1.0e6_f64),
        proptest::array::uniform7(DT_MAX_S..0.03_f64),
        prop_oneof![Just(false), Just(true)],
    )
        .prop_map(|((recovery, hold, resume), (v5, v6, margin), timeouts, hot)| {
            let mut c = Config::seed_unit();
            c.monitor.dt_max_s = DT_MAX_S;
            c.monitor.recovery_s = recovery;
            c.mode.handling_hold_s = hold;
            c.ride_height.resume_s = resume;
            c.ride_height.load_settle_s = 0.5 * resume;
            c.ride_height.load_pressure_tau_s = 0.5;
            c.damper.valve5_min_interval_s = v5;
            c.ride_height.valve6_min_off_s = v6;
            c.ride_height.valve6_margin_pa = margin;
            let t = &mut c.monitor.timeouts;
            [t.pressures_s, t.strut_s, t.body_s, t.vehicle_s, t.steering_s, t.temperature_s, t.driver_s] = timeouts;
            if hot {
                c.unit.static_temperature_k = 330.0;
            }
            c
        })
}

/// One control period: the inputs (possibly with an injected fault) and
/// the step size.
#[derive(Debug, Clone, Copy)]
struct Period {
    inputs: Inputs,
    dt_s: f64,
}

fn bad_value() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(1.0e9), Just(-1.0e9), Just(1.0e300)]
}

fn bad_dt() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(0.0), Just(-1.0e-3), Just(1.0), Just(f64::INFINITY), Just(1.0e-7)]
}

fn good_dt() -> impl Strategy<Value = f64> {
    prop_oneof![60 => Just(1.0e-3), 10 => Just(0.5e-3), 10 => Just(2.0e-3), 15 => Just(DT_MAX_S), 5 => 0.5e-3..DT_MAX_S]
}

fn driver_strategy() -> impl Strategy<Value = DriverMode> {
    prop_oneof![90 => Just(DriverMode::Auto), 5 => Just(DriverMode::Comfort), 5 => Just(DriverMode::Sport)]
}

fn fresh_strategy() -> impl Strategy<Value = u16> {
    prop_oneof![80 => Just(input_group::ALL), 20 => (0..7_u16).prop_map(|g| input_group::ALL & !(1 << g))]
}

/// What a whole sequence is like.
#[derive(Debug, Clone, Copy)]
struct Scenario {
    p_static_pa: f64,
    t_k: f64,
    request_m: f64,
    /// Probability of an injected fault per period.
    fault_p: f64,
    /// Scale of the driving dynamics: small keeps the vehicle calm (Ride,
    /// sequencing), 1 manoeuvres hard (Handling, sequencing blocked).
    dynamics: f64,
}

fn period_strategy(sc: Scenario) -> impl Strategy<Value = Period> {
    let d = sc.dynamics;
    (
        // Pressures within +-4 MPa, displacement within +-2 mm and the
        // temperature within +-0.02 K: even between 0.5 ms periods these
        // move slower than the rate limits, so only injected values fault.
        (-4.0e6..4.0e6_f64, -4.0e6..4.0e6_f64, -0.002..0.002_f64, -20.0..20.0_f64, -0.02..0.02_f64),
        (
            -5.0..(30.0 + 10.0 * d),
            -5.0 * d..5.0 * d,
            -5.0 * d..5.0 * d,
            -3.0 * d..3.0 * d,
            -5.0 * d..5.0 * d,
            prop::bool::weighted(0.1 * d * d),
        ),
        (driver_strategy(), prop::bool::weighted(0.05), fresh_strategy(), prop::bool::weighted(sc.fault_p / 5.0)),
        (prop::bool::weighted(sc.fault_p / 2.0), good_dt(), bad_dt()).prop_map(|(bad, g, b)| if bad { b } else { g }),
        (prop::bool::weighted(sc.fault_p), 0..11_usize, bad_value())
            .prop_map(|(inject, field, value)| inject.then_some((field, value))),
    )
        .prop_map(
            move |(
                (dp_s, dp_l, disp, body, dt_k),
                (speed, lat, long, angle, rate, brake),
                (driver, other_request, fresh, link_fault),
                dt_s,
                fault,
            )| {
                let mut inputs = Inputs {
                    p_gas_pa: sc.p_static_pa + dp_s,
                    p_gas2_pa: sc.p_static_pa + dp_l,
                    strut_disp_m: disp,
                    body_acc_m_s2: body,
                    speed_m_s: speed,
                    lat_acc_m_s2: lat,
                    long_acc_m_s2: long,
                    steer_angle_rad: angle,
                    steer_rate_rad_s: rate,
                    brake_pressed: brake,
                    t_gas_k: sc.t_k + dt_k,
                    driver_mode: driver,
                    ride_height_request_m: if other_request { -sc.request_m } else { sc.request_m },
                    fresh,
                    link_fault,
                };
                if let Some((field, value)) = fault {
                    let slot = match field {
                        0 => &mut inputs.p_gas_pa,
                        1 => &mut inputs.p_gas2_pa,
                        2 => &mut inputs.strut_disp_m,
                        3 => &mut inputs.body_acc_m_s2,
                        4 => &mut inputs.speed_m_s,
                        5 => &mut inputs.lat_acc_m_s2,
                        6 => &mut inputs.long_acc_m_s2,
                        7 => &mut inputs.steer_angle_rad,
                        8 => &mut inputs.steer_rate_rad_s,
                        9 => &mut inputs.t_gas_k,
                        _ => &mut inputs.ride_height_request_m,
                    };
                    *slot = value;
                }
                Period { inputs, dt_s }
            },
        )
}

/// A configuration and a sequence of periods for it.
fn case_strategy() -> impl Strategy<Value = (Config, Vec<Period>)> {
    (
        config_strategy(),
        prop_oneof![Just(0.0), Just(-0.03), Just(0.03), -0.08..0.08_f64],
        prop_oneof![Just(0.0), Just(0.001), Just(0.01), Just(0.05)],
        prop_oneof![Just(0.2), Just(1.0)],
    )
        .prop_flat_map(|(config, request_m, fault_p, dynamics)| {
            let scenario = Scenario {
                p_static_pa: config.unit.static_pressure_pa,
                t_k: config.unit.static_temperature_k,
                request_m,
                fault_p,
                dynamics,
            };
            (Just(config), proptest::collection::vec(period_strategy(scenario), 40..300))
        })
}

fn run(params: &Params, periods: &[Period]) -> Vec<Outputs> {
    let mut state = State::new();
    periods.iter().map(|p| step(params, &mut state, &p.inputs, p.dt_s)).collect()
}

/// The controller clock: each valid step advances by `dt_s` rounded to
/// whole microseconds; an invalid one advances nothing.
fn dt_us(config: &Config, dt_s: f64) -> Option<u64> {
    (dt_s.is_finite() && dt_s >= 1.0e-6 && dt_s <= config.monitor.dt_max_s).then(|| (dt_s * 1.0e6).round() as u64)
}

fn us(seconds: f64) -> u64 {
    (seconds * 1.0e6).round() as u64
}

/// The documented input faults of one period, from the values alone
/// (not-finite or outside the inclusive physical ranges).
fn value_fault(config: &Config, i: &Inputs) -> bool {
    let m = &config.monitor;
    let u = &config.unit;
    let within = |x: f64, lo: f64, hi: f64| x.is_finite() && x >= lo && x <= hi;
    let sym = |x: f64, max: f64| within(x, -max, max);
    !(within(i.p_gas_pa, m.pressure_min_pa, m.pressure_max_pa)
        && within(i.p_gas2_pa, m.pressure_min_pa, m.pressure_max_pa)
        && within(i.strut_disp_m, -(u.stroke_extension_m + m.disp_margin_m), u.stroke_compression_m + m.disp_margin_m)
        && sym(i.body_acc_m_s2, m.body_acc_max_m_s2)
        && within(i.speed_m_s, m.speed_min_m_s, m.speed_max_m_s)
        && sym(i.lat_acc_m_s2, m.vehicle_acc_max_m_s2)
        && sym(i.long_acc_m_s2, m.vehicle_acc_max_m_s2)
        && sym(i.steer_angle_rad, m.steer_angle_max_rad)
        && sym(i.steer_rate_rad_s, m.steer_rate_max_rad_s)
        && within(i.t_gas_k, m.temperature_min_k, m.temperature_max_k)
        && i.ride_height_request_m.is_finite())
}

/// Outputs are the safe state exactly when the documented rules say: in
/// the same period as a NaN/inf/out-of-range/stale input, a link fault or
/// a bad step size, and until the inputs have been good for the recovery
/// time.
fn check_safe_state(config: &Config, periods: &[Period], outs: &[Outputs]) -> Result<(), TestCaseError> {
    let t = config.monitor.timeouts;
    let timeouts_us =
        [t.pressures_s, t.strut_s, t.body_s, t.vehicle_s, t.steering_s, t.temperature_s, t.driver_s].map(us);
    let recovery_us = us(config.monitor.recovery_s);
    let mut age_us = [u64::MAX; 7];
    let mut good_us = 0_u64;
    for (k, (period, out)) in periods.iter().zip(outs).enumerate() {
        let i = &period.inputs;
        let dt = dt_us(config, period.dt_s);
        let mut fault = value_fault(config, i) || i.link_fault || dt.is_none();
        if let Some(dt) = dt {
            for (g, (age, timeout)) in age_us.iter_mut().zip(timeouts_us).enumerate() {
                *age = if i.fresh & (1 << g) != 0 { 0 } else { age.saturating_add(dt) };
                fault |= *age > timeout;
            }
        }
        good_us = match dt {
            Some(dt) if !fault => good_us + dt,
            _ => 0,
        };
        let expect_safe = fault || good_us < recovery_us;
        prop_assert_eq!(common::is_safe(out), expect_safe, "period {}: {:?} -> {:?}", k, period, out);
        prop_assert_eq!(out.diag & diag::SAFE_STATE != 0, expect_safe);
        prop_assert_eq!(out.diag & diag::RECOVERING != 0, expect_safe && !fault);
    }
    Ok(())
}

/// THE safety property of pump-free sequencing: valve 6 is open in
/// Lowering only while p_S - p_L exceeds the margin, in Raising only while
/// p_L - p_S does, and otherwise only as the soft spring (Idle).
fn check_valve6_direction(config: &Config, periods: &[Period], outs: &[Outputs]) -> Result<(), TestCaseError> {
    let margin = config.ride_height.valve6_margin_pa;
    for (period, out) in periods.iter().zip(outs).filter(|(_, out)| out.valve6_open) {
        let i = &period.inputs;
        match out.sequencer {
            SequencerState::Lowering => prop_assert!(i.p_gas_pa > i.p_gas2_pa + margin, "{:?} {:?}", i, out),
            SequencerState::Raising => prop_assert!(i.p_gas2_pa > i.p_gas_pa + margin, "{:?} {:?}", i, out),
            other => prop_assert_eq!(other, SequencerState::Idle),
        }
    }
    Ok(())
}

/// Sequencing pauses (valve 6 closed) while cornering, braking or
/// accelerating hard: the sequencer is then Idle (not engaged) or Blocked.
fn check_sequencer_pauses(config: &Config, periods: &[Period], outs: &[Outputs]) -> Result<(), TestCaseError> {
    let rh = &config.ride_height;
    for (period, out) in periods.iter().zip(outs) {
        let i = &period.inputs;
        let manoeuvre = i.lat_acc_m_s2.abs() > rh.block_lat_acc_m_s2 * 1.001
            || i.long_acc_m_s2.abs() > rh.block_long_acc_m_s2 * 1.001
            || i.brake_pressed;
        if manoeuvre {
            prop_assert!(matches!(out.sequencer, SequencerState::Idle | SequencerState::Blocked), "{:?} {:?}", i, out);
        }
    }
    Ok(())
}

/// Ride never returns sooner than the hold after Handling was entered, nor
/// after the last period a trigger fired or the outputs were safe; a
/// lateral acceleration past the entry threshold gives Handling at once.
fn check_mode_hold(config: &Config, periods: &[Period], outs: &[Outputs]) -> Result<(), TestCaseError> {
    let hold_us = us(config.mode.handling_hold_s);
    let enter = config.mode.lat_acc_enter_m_s2 * 1.001;
    let mut clock_us = 0_u64;
    let mut entered_us = 0_u64;
    let mut last_trigger_us = 0_u64;
    let mut previous = DriveMode::Handling;
    for (period, out) in periods.iter().zip(outs) {
        clock_us += dt_us(config, period.dt_s).unwrap_or(0);
        if out.diag & (diag::TRIGGERS | diag::SAFE_STATE) != 0 {
            last_trigger_us = clock_us;
        }
        if previous == DriveMode::Ride && out.drive_mode == DriveMode::Handling {
            entered_us = clock_us;
        }
        if previous == DriveMode::Handling && out.drive_mode == DriveMode::Ride {
            prop_assert!(clock_us - entered_us >= hold_us, "{} us after entering", clock_us - entered_us);
            prop_assert!(clock_us - last_trigger_us >= hold_us);
        }
        if out.diag & diag::SAFE_STATE == 0 && period.inputs.lat_acc_m_s2.abs() > enter {
            prop_assert_eq!(out.drive_mode, DriveMode::Handling);
        }
        previous = out.drive_mode;
    }
    Ok(())
}

/// Valve 5 never opens sooner than its interval after its last change;
/// valve 6 never reopens sooner than its minimum off time.
fn check_valve_intervals(config: &Config, periods: &[Period], outs: &[Outputs]) -> Result<(), TestCaseError> {
    let v5_us = us(config.damper.valve5_min_interval_s);
    let v6_us = us(config.ride_height.valve6_min_off_s);
    let mut clock_us = 0_u64;
    let (mut v5_open, mut v5_changed_us) = (false, 0_u64);
    let (mut v6_open, mut v6_closed_us) = (false, 0_u64);
    for (period, out) in periods.iter().zip(outs) {
        clock_us += dt_us(config, period.dt_s).unwrap_or(0);
        if out.valve5_open != v5_open {
            if out.valve5_open {
                prop_assert!(clock_us - v5_changed_us >= v5_us);
            }
            v5_changed_us = clock_us;
            v5_open = out.valve5_open;
        }
        if out.valve6_open != v6_open {
            if out.valve6_open {
                prop_assert!(clock_us - v6_closed_us >= v6_us);
            } else {
                v6_closed_us = clock_us;
            }
            v6_open = out.valve6_open;
        }
    }
    Ok(())
}

/// Every output is finite, in range and consistent, whatever came in.
fn check_outputs_valid(config: &Config, outs: &[Outputs]) -> Result<(), TestCaseError> {
    let u = config.unit;
    let defined = diag::SAFE_STATE
        | diag::RECOVERING
        | diag::BAD_DT
        | diag::LINK_FAULT
        | diag::NOT_FINITE
        | diag::OUT_OF_RANGE
        | diag::RATE_LIMIT
        | diag::STALE
        | diag::GROUP_MASK
        | diag::REQUEST_CLAMPED
        | diag::SEQUENCER_PAUSED
        | diag::HEIGHT_HOLDS_SPRING
        | diag::HEIGHT_ESTIMATE_HELD
        | diag::TRIGGERS
        | diag::HANDLING_HOLD;
    for out in outs {
        prop_assert!(out.ride_height_m.is_finite());
        prop_assert!(
            out.ride_height_m >= -u.stroke_compression_m - 1e-6 && out.ride_height_m <= u.stroke_extension_m + 1e-6
        );
        prop_assert!(out.p_gas2_target_pa.is_finite() && out.p_gas2_target_pa >= 0.0);
        // The load pressure is a mean of valid pressures (or the configured one).
        let m = &config.monitor;
        prop_assert!(out.p_load_pa >= m.pressure_min_pa.min(u.static_pressure_pa) * 0.999);
        prop_assert!(out.p_load_pa <= m.pressure_max_pa.max(u.static_pressure_pa) * 1.001);
        prop_assert!(out.strut_vel_m_s.is_finite() && out.body_vel_m_s.is_finite());
        prop_assert_eq!(out.valve5_open, out.damper_mode == DamperMode::Low);
        prop_assert_eq!(out.diag & !defined, 0);
        if out.drive_mode == DriveMode::Handling {
            prop_assert_eq!(out.damper_mode, DamperMode::High);
            prop_assert_eq!(out.spring_mode, SpringMode::Hard);
        }
        prop_assert_eq!(out.spring_mode == SpringMode::Soft, out.sequencer == SequencerState::Idle);
    }
    Ok(())
}

/// Cases per run: each case checks every property above over one sequence
/// (generating the sequences is what costs, so they share them).
const CASES: u32 = 2000;

proptest! {
    #![proptest_config(ProptestConfig { cases: CASES, ..ProptestConfig::default() })]

    #[test]
    fn every_property_holds_for_any_input_sequence((config, periods) in case_strategy()) {
        let params = Params::new(config).unwrap();
        let outs = run(&params, &periods);
        check_safe_state(&config, &periods, &outs)?;
        check_valve6_direction(&config, &periods, &outs)?;
        check_sequencer_pauses(&config, &periods, &outs)?;
        check_mode_hold(&config, &periods, &outs)?;
        check_valve_intervals(&config, &periods, &outs)?;
        check_outputs_valid(&config, &outs)?;
        // Determinism: same configuration and inputs, same outputs.
        prop_assert_eq!(&outs, &run(&Params::new(config).unwrap(), &periods));
    }
}

/// The generated sequences do reach what the properties are about (so the
/// properties are not vacuously true): sequencing pulses in both
/// directions, mode changes both ways, the skyhook opening valve 5,
/// recovery from faults.
#[test]
fn the_generated_sequences_exercise_every_behaviour() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let mut seen = [0_usize; 6];
    for _ in 0..300 {
        let (config, periods) = case_strategy().new_tree(&mut runner).unwrap().current();
        let outs = run(&Params::new(config).unwrap(), &periods);
        for pair in outs.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            seen[0] += usize::from(b.valve6_open && b.sequencer == SequencerState::Lowering);
            seen[1] += usize::from(b.valve6_open && b.sequencer == SequencerState::Raising);
            seen[2] += usize::from(a.drive_mode == DriveMode::Ride && b.drive_mode == DriveMode::Handling);
            seen[3] += usize::from(a.drive_mode == DriveMode::Handling && b.drive_mode == DriveMode::Ride);
            seen[4] += usize::from(!a.valve5_open && b.valve5_open);
            seen[5] += usize::from(a.diag & diag::SAFE_STATE != 0 && b.diag & diag::SAFE_STATE == 0);
        }
    }
    assert!(seen.iter().all(|&n| n >= 100), "{seen:?}");
}
