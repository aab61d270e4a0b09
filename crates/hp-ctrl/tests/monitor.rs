//! Safe state, input plausibility, staleness and recovery.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::{calm, in_ride, is_safe, run, seed, DT_S};
use hp_ctrl::{diag, input_group, step, Inputs, State};

/// Every way to spoil one input field, with the group it belongs to.
fn spoil(inputs: &Inputs, field: usize, value: f64) -> (Inputs, u16) {
    let mut i = *inputs;
    let group = match field {
        0 => {
            i.p_gas_pa = value;
            input_group::PRESSURES
        }
        1 => {
            i.p_gas2_pa = value;
            input_group::PRESSURES
        }
        2 => {
            i.strut_disp_m = value;
            input_group::STRUT
        }
        3 => {
            i.body_acc_m_s2 = value;
            input_group::BODY
        }
        4 => {
            i.speed_m_s = value;
            input_group::VEHICLE
        }
        5 => {
            i.lat_acc_m_s2 = value;
            input_group::VEHICLE
        }
        6 => {
            i.long_acc_m_s2 = value;
            input_group::VEHICLE
        }
        7 => {
            i.steer_angle_rad = value;
            input_group::STEERING
        }
        8 => {
            i.steer_rate_rad_s = value;
            input_group::STEERING
        }
        9 => {
            i.t_gas_k = value;
            input_group::TEMPERATURE
        }
        _ => {
            i.ride_height_request_m = value;
            input_group::DRIVER
        }
    };
    (i, group)
}

#[test]
fn power_on_is_safe_until_inputs_good_for_the_recovery_time() {
    let params = seed();
    let recovery_s = params.config().monitor.recovery_s;
    let mut state = State::new();
    let inputs = calm(&params);
    let steps = (recovery_s / DT_S).round() as usize;
    for k in 1..steps {
        let out = step(&params, &mut state, &inputs, DT_S);
        assert!(is_safe(&out), "period {k}");
        assert_ne!(out.diag & diag::RECOVERING, 0);
    }
    // The period that completes the recovery time leaves the safe state.
    let out = step(&params, &mut state, &inputs, DT_S);
    assert_eq!(out.diag & diag::SAFE_STATE, 0, "{out:?}");
}

#[test]
fn not_finite_inputs_give_the_safe_state_in_the_same_period() {
    let params = seed();
    let base = in_ride(&params);
    for field in 0..=10 {
        for value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut state = base;
            let (inputs, group) = spoil(&calm(&params), field, value);
            let out = step(&params, &mut state, &inputs, DT_S);
            assert!(is_safe(&out), "field {field} = {value}: {out:?}");
            assert_ne!(out.diag & diag::NOT_FINITE, 0);
            assert_ne!(out.diag & diag::group(group), 0, "field {field}");
            assert!(out.ride_height_m.is_finite() && out.p_gas2_target_pa.is_finite());
        }
    }
}

#[test]
fn values_just_outside_their_physical_range_give_the_safe_state() {
    let params = seed();
    let c = params.config();
    let m = &c.monitor;
    let stroke_c = c.unit.stroke_compression_m + m.disp_margin_m;
    let stroke_e = c.unit.stroke_extension_m + m.disp_margin_m;
    let base = in_ride(&params);
    // (field, lowest valid, highest valid)
    let limits = [
        (0, m.pressure_min_pa, m.pressure_max_pa),
        (1, m.pressure_min_pa, m.pressure_max_pa),
        (2, -stroke_e, stroke_c),
        (3, -m.body_acc_max_m_s2, m.body_acc_max_m_s2),
        (4, m.speed_min_m_s, m.speed_max_m_s),
        (5, -m.vehicle_acc_max_m_s2, m.vehicle_acc_max_m_s2),
        (6, -m.vehicle_acc_max_m_s2, m.vehicle_acc_max_m_s2),
        (7, -m.steer_angle_max_rad, m.steer_angle_max_rad),
        (8, -m.steer_rate_max_rad_s, m.steer_rate_max_rad_s),
        (9, m.temperature_min_k, m.temperature_max_k),
    ];
    for (field, lo, hi) in limits {
        for value in [lo.next_down(), hi.next_up(), -1e300, 1e300] {
            let mut state = base;
            let (inputs, group) = spoil(&calm(&params), field, value);
            let out = step(&params, &mut state, &inputs, DT_S);
            assert!(is_safe(&out), "field {field} = {value:e}: {out:?}");
            assert_ne!(out.diag & diag::OUT_OF_RANGE, 0);
            assert_ne!(out.diag & diag::group(group), 0);
        }
    }
    // The limits themselves are valid, as documented (inclusive ranges).
    // Only the values without rate limits can jump there in one period.
    for (field, lo, hi) in limits.into_iter().filter(|l| (3..=8).contains(&l.0)) {
        for value in [lo, hi] {
            let mut state = base;
            let (inputs, _) = spoil(&calm(&params), field, value);
            let out = step(&params, &mut state, &inputs, DT_S);
            assert_eq!(out.diag & diag::SAFE_STATE, 0, "field {field} = {value:e}");
        }
    }
}

#[test]
fn a_finite_oversized_request_is_clamped_not_a_fault() {
    let params = seed();
    let max = params.config().ride_height.request_max_m;
    let mut state = in_ride(&params);
    let inputs = Inputs { ride_height_request_m: -10.0 * max, ..calm(&params) };
    let out = step(&params, &mut state, &inputs, DT_S);
    assert_eq!(out.diag & diag::SAFE_STATE, 0);
    assert_ne!(out.diag & diag::REQUEST_CLAMPED, 0);
    let target_height_m = common::held_offset_m(&params, out.p_gas2_target_pa, out.p_load_pa, inputs.t_gas_k);
    assert!((target_height_m + max).abs() < common::TABLE_HEIGHT_ACCURACY_M, "{target_height_m}");
}

#[test]
fn jumps_faster_than_physics_give_the_safe_state() {
    let params = seed();
    let m = params.config().monitor;
    let base = in_ride(&params);
    let calm_inputs = calm(&params);
    // Twice the largest plausible change in one period, and half of it.
    let cases = [
        (0, calm_inputs.p_gas_pa, m.pressure_rate_max_pa_s, input_group::PRESSURES),
        (1, calm_inputs.p_gas2_pa, m.pressure_rate_max_pa_s, input_group::PRESSURES),
        (2, 0.0, m.disp_rate_max_m_s, input_group::STRUT),
        (9, calm_inputs.t_gas_k, m.temperature_rate_max_k_s, input_group::TEMPERATURE),
    ];
    for (field, start, rate, group) in cases {
        let mut state = base;
        let (inputs, _) = spoil(&calm_inputs, field, start + 2.0 * rate * DT_S);
        let out = step(&params, &mut state, &inputs, DT_S);
        assert!(is_safe(&out), "field {field}: {out:?}");
        assert_ne!(out.diag & diag::RATE_LIMIT, 0);
        assert_ne!(out.diag & diag::group(group), 0);

        let mut state = base;
        let (inputs, _) = spoil(&calm_inputs, field, start + 0.5 * rate * DT_S);
        let out = step(&params, &mut state, &inputs, DT_S);
        assert_eq!(out.diag & diag::SAFE_STATE, 0, "field {field}: {out:?}");
    }
}

#[test]
fn rate_is_judged_over_the_time_since_the_last_fresh_sample() {
    // A slow CAN signal: fresh every 10th period, moving 5 rate-limit-periods
    // between samples, is plausible (it moved over 10 periods).
    let params = seed();
    let m = params.config().monitor;
    let mut state = in_ride(&params);
    let mut inputs = calm(&params);
    for k in 1..=200 {
        if k % 10 == 0 {
            inputs.t_gas_k += 5.0 * m.temperature_rate_max_k_s * DT_S * if k % 20 == 0 { 1.0 } else { -1.0 };
            inputs.fresh = input_group::ALL;
        } else {
            inputs.fresh = input_group::ALL & !input_group::TEMPERATURE;
        }
        let out = step(&params, &mut state, &inputs, DT_S);
        assert_eq!(out.diag & diag::SAFE_STATE, 0, "period {k}: {out:?}");
    }
}

#[test]
fn a_group_without_fresh_values_beyond_its_timeout_gives_the_safe_state() {
    let params = seed();
    let t = params.config().monitor.timeouts;
    let timeouts = [
        (input_group::PRESSURES, t.pressures_s),
        (input_group::STRUT, t.strut_s),
        (input_group::BODY, t.body_s),
        (input_group::VEHICLE, t.vehicle_s),
        (input_group::STEERING, t.steering_s),
        (input_group::TEMPERATURE, t.temperature_s),
        (input_group::DRIVER, t.driver_s),
    ];
    let base = in_ride(&params);
    for (group, timeout_s) in timeouts {
        let mut state = base;
        let inputs = Inputs { fresh: input_group::ALL & !group, ..calm(&params) };
        let periods = (timeout_s / DT_S).round() as usize;
        // Exactly the timeout without a fresh value is still fine...
        for k in 1..=periods {
            let out = step(&params, &mut state, &inputs, DT_S);
            assert_eq!(out.diag & diag::SAFE_STATE, 0, "group {group:#x}, period {k}");
        }
        // ...one period more is stale.
        let out = step(&params, &mut state, &inputs, DT_S);
        assert!(is_safe(&out), "group {group:#x}: {out:?}");
        assert_eq!(out.diag & (diag::STALE | diag::GROUP_MASK), diag::STALE | diag::group(group));
    }
}

#[test]
fn link_fault_and_bad_step_sizes_give_the_safe_state() {
    let params = seed();
    let base = in_ride(&params);
    let mut state = base;
    let out = step(&params, &mut state, &Inputs { link_fault: true, ..calm(&params) }, DT_S);
    assert!(is_safe(&out));
    assert_ne!(out.diag & diag::LINK_FAULT, 0);
    let dt_max_s = params.config().monitor.dt_max_s;
    for dt_s in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -1e-3, 1e-7, dt_max_s.next_up(), 1e300] {
        let mut state = base;
        let out = step(&params, &mut state, &calm(&params), dt_s);
        assert!(is_safe(&out), "dt = {dt_s}");
        assert_ne!(out.diag & diag::BAD_DT, 0);
    }
    let mut state = base;
    let out = step(&params, &mut state, &calm(&params), dt_max_s);
    assert_eq!(out.diag & diag::SAFE_STATE, 0);
}

#[test]
fn recovery_needs_the_inputs_good_continuously() {
    let params = seed();
    let recovery_s = params.config().monitor.recovery_s;
    let mut state = in_ride(&params);
    let good = calm(&params);
    let bad = Inputs { p_gas_pa: f64::NAN, ..good };
    assert!(is_safe(&step(&params, &mut state, &bad, DT_S)));
    // Good for most of the recovery time, then one bad period: start again.
    let out = run(&params, &mut state, &good, recovery_s - 10.0 * DT_S);
    assert!(is_safe(&out) && out.diag & diag::RECOVERING != 0);
    assert!(is_safe(&step(&params, &mut state, &bad, DT_S)));
    let out = run(&params, &mut state, &good, recovery_s - DT_S);
    assert!(is_safe(&out), "{out:?}");
    let out = step(&params, &mut state, &good, DT_S);
    assert_eq!(out.diag & diag::SAFE_STATE, 0, "{out:?}");
}

#[test]
fn the_estimates_are_held_while_their_inputs_are_invalid() {
    let params = seed();
    let mut state = in_ride(&params);
    let good = calm(&params);
    let before = step(&params, &mut state, &good, DT_S);
    let out = step(&params, &mut state, &Inputs { p_gas2_pa: f64::NAN, ..good }, DT_S);
    assert_eq!(out.ride_height_m, before.ride_height_m);
    assert_eq!(out.p_gas2_target_pa, before.p_gas2_target_pa);
    assert_ne!(out.diag & diag::HEIGHT_ESTIMATE_HELD, 0);
}
