//! Ride/handling selection and the skyhook damper.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::{calm, in_ride, run, seed, DT_S};
use hp_ctrl::{diag, step, DamperMode, DriveMode, DriverMode, Inputs, Params, SpringMode};

/// Periods in `seconds` at the test period.
fn periods(seconds: f64) -> usize {
    (seconds / DT_S).round() as usize
}

/// Applies `trigger` for one period from Ride, then `after` until Ride
/// returns; returns the number of `after` periods that took.
fn hold_after(params: &Params, trigger: &Inputs, after: &Inputs) -> (u32, usize) {
    let mut state = in_ride(params);
    let out = step(params, &mut state, trigger, DT_S);
    assert_eq!(out.drive_mode, DriveMode::Handling, "{trigger:?}");
    let flags = out.diag & diag::TRIGGERS;
    for k in 1..=periods(60.0) {
        if step(params, &mut state, after, DT_S).drive_mode == DriveMode::Ride {
            return (flags, k);
        }
    }
    panic!("never returned to Ride");
}

#[test]
fn each_trigger_enters_handling_at_once_and_ride_returns_after_the_hold() {
    let params = seed();
    let c = params.config().mode;
    let hold = periods(c.handling_hold_s);
    let base = calm(&params);
    // The steering-predicted lateral acceleration v^2 delta / (i_s L).
    let speed = 20.0;
    let predicted_angle = 1.2 * c.lat_acc_enter_m_s2 * c.steering_ratio * c.wheelbase_m / (speed * speed);
    let cases = [
        (Inputs { lat_acc_m_s2: -1.01 * c.lat_acc_enter_m_s2, ..base }, diag::TRIGGER_LATERAL),
        (Inputs { speed_m_s: speed, steer_angle_rad: predicted_angle, ..base }, diag::TRIGGER_LATERAL),
        (
            Inputs { speed_m_s: 1.5 * c.steer_min_speed_m_s, steer_rate_rad_s: 1.01 * c.steer_rate_enter_rad_s, ..base },
            diag::TRIGGER_STEER_RATE,
        ),
        (Inputs { long_acc_m_s2: -1.01 * c.long_acc_enter_m_s2, ..base }, diag::TRIGGER_LONGITUDINAL),
        (Inputs { long_acc_m_s2: 1.01 * c.long_acc_enter_m_s2, ..base }, diag::TRIGGER_LONGITUDINAL),
        (Inputs { brake_pressed: true, speed_m_s: 1.5 * c.brake_min_speed_m_s, ..base }, diag::TRIGGER_BRAKE),
        (Inputs { speed_m_s: 1.01 * c.speed_enter_m_s, ..base }, diag::TRIGGER_SPEED),
        (Inputs { driver_mode: DriverMode::Sport, ..base }, diag::TRIGGER_SPORT),
    ];
    for (trigger, flag) in cases {
        let (flags, k) = hold_after(&params, &trigger, &base);
        assert_eq!(flags, flag, "{trigger:?}");
        assert_eq!(k, hold, "{trigger:?}");
    }
}

#[test]
fn below_the_entry_thresholds_nothing_triggers() {
    let params = seed();
    let c = params.config().mode;
    let base = calm(&params);
    let near_misses = [
        Inputs { lat_acc_m_s2: 0.99 * c.lat_acc_enter_m_s2, ..base },
        Inputs { speed_m_s: 0.9 * c.steer_min_speed_m_s, steer_rate_rad_s: 3.0 * c.steer_rate_enter_rad_s, ..base },
        Inputs { long_acc_m_s2: -0.99 * c.long_acc_enter_m_s2, ..base },
        Inputs { brake_pressed: true, speed_m_s: 0.9 * c.brake_min_speed_m_s, ..base },
        Inputs { speed_m_s: 0.99 * c.speed_enter_m_s, ..base },
    ];
    for inputs in near_misses {
        let mut state = in_ride(&params);
        let out = run(&params, &mut state, &inputs, 1.0);
        assert_eq!(out.drive_mode, DriveMode::Ride, "{inputs:?}");
    }
}

#[test]
fn hysteresis_keeps_handling_between_exit_and_entry_and_the_hold_counts_from_the_exit() {
    let params = seed();
    let c = params.config().mode;
    let base = calm(&params);
    let mut state = in_ride(&params);
    let enter = Inputs { lat_acc_m_s2: 1.01 * c.lat_acc_enter_m_s2, ..base };
    let between = Inputs { lat_acc_m_s2: 0.5 * (c.lat_acc_enter_m_s2 + c.lat_acc_exit_m_s2), ..base };
    assert_eq!(step(&params, &mut state, &enter, DT_S).drive_mode, DriveMode::Handling);
    // Ten hold times between the thresholds: the trigger stays latched.
    let out = run(&params, &mut state, &between, 10.0 * c.handling_hold_s);
    assert_eq!(out.drive_mode, DriveMode::Handling);
    assert_ne!(out.diag & diag::TRIGGER_LATERAL, 0);
    // Below exit: Ride after exactly the hold.
    let below = Inputs { lat_acc_m_s2: 0.99 * c.lat_acc_exit_m_s2, ..base };
    let first = step(&params, &mut state, &below, DT_S);
    assert_eq!(first.drive_mode, DriveMode::Handling);
    assert_ne!(first.diag & diag::HANDLING_HOLD, 0);
    let out = run(&params, &mut state, &below, c.handling_hold_s - 2.0 * DT_S);
    assert_eq!(out.drive_mode, DriveMode::Handling);
    assert_eq!(step(&params, &mut state, &below, DT_S).drive_mode, DriveMode::Ride);
}

#[test]
fn comfort_ignores_the_anticipating_triggers_but_not_body_motion() {
    let params = seed();
    let c = params.config().mode;
    let comfort = Inputs { driver_mode: DriverMode::Comfort, ..calm(&params) };
    let ignored = [
        Inputs { speed_m_s: 20.0, steer_rate_rad_s: 2.0 * c.steer_rate_enter_rad_s, ..comfort },
        Inputs { brake_pressed: true, speed_m_s: 20.0, ..comfort },
        Inputs { speed_m_s: 1.1 * c.speed_enter_m_s, ..comfort },
    ];
    for inputs in ignored {
        let mut state = in_ride(&params);
        assert_eq!(run(&params, &mut state, &inputs, 0.5).drive_mode, DriveMode::Ride, "{inputs:?}");
    }
    let honoured = [
        Inputs { lat_acc_m_s2: 1.1 * c.lat_acc_enter_m_s2, ..comfort },
        Inputs { long_acc_m_s2: -1.1 * c.long_acc_enter_m_s2, ..comfort },
    ];
    for inputs in honoured {
        let mut state = in_ride(&params);
        assert_eq!(step(&params, &mut state, &inputs, DT_S).drive_mode, DriveMode::Handling, "{inputs:?}");
    }
}

#[test]
fn leaving_sport_waits_for_the_hold() {
    let params = seed();
    let hold = periods(params.config().mode.handling_hold_s);
    let mut state = in_ride(&params);
    let sport = Inputs { driver_mode: DriverMode::Sport, ..calm(&params) };
    let out = run(&params, &mut state, &sport, 5.0);
    assert_eq!((out.drive_mode, out.spring_mode, out.damper_mode), (DriveMode::Handling, SpringMode::Hard, DamperMode::High));
    assert!(!out.valve5_open && !out.valve6_open);
    let comfort = Inputs { driver_mode: DriverMode::Comfort, ..calm(&params) };
    for k in 1..hold {
        assert_eq!(step(&params, &mut state, &comfort, DT_S).drive_mode, DriveMode::Handling, "period {k}");
    }
    assert_eq!(step(&params, &mut state, &comfort, DT_S).drive_mode, DriveMode::Ride);
}

/// Body heave and strut motion as sinusoids with a chosen phase between the
/// body velocity and the strut compression rate.
fn heave(params: &Params, time_s: f64, phase_rad: f64) -> Inputs {
    let w = 2.0 * std::f64::consts::PI * 1.0;
    Inputs {
        // Body velocity 0.1 sin(w t): acceleration 0.1 w cos(w t).
        body_acc_m_s2: 0.1 * w * (w * time_s).cos(),
        // Compression rate 0.1 sin(w t + phase), starting from the static position.
        strut_disp_m: -0.1 / w * ((w * time_s + phase_rad).cos() - phase_rad.cos()),
        ..calm(params)
    }
}

#[test]
fn skyhook_damps_high_when_the_damper_pushes_against_the_body_velocity() {
    let params = seed();
    // In phase: body moving up while the strut compresses; the damper
    // force would push the body up, with its velocity: low damping wanted.
    // In antiphase (body up, strut extending) it pushes against it: high.
    for (phase_rad, want) in [(0.0, DamperMode::Low), (std::f64::consts::PI, DamperMode::High)] {
        let mut state = in_ride(&params);
        let mut agree = 0;
        let mut total = 0;
        for k in 0..periods(10.0) {
            let t = k as f64 * DT_S;
            let out = step(&params, &mut state, &heave(&params, t, phase_rad), DT_S);
            assert_eq!(out.drive_mode, DriveMode::Ride);
            // Judge away from the zero crossings and after the filters settle.
            let v_body = 0.1 * (2.0 * std::f64::consts::PI * t).sin();
            if t > 5.0 && v_body.abs() > 0.05 {
                total += 1;
                agree += usize::from(out.damper_mode == want);
            }
            assert_eq!(out.valve5_open, out.damper_mode == DamperMode::Low);
        }
        assert!(agree as f64 > 0.95 * total as f64, "phase {phase_rad}: {agree}/{total}");
    }
}

#[test]
fn the_velocity_estimates_follow_the_motion() {
    let params = seed();
    let mut state = in_ride(&params);
    let phase = 0.7;
    let mut worst_strut: f64 = 0.0;
    let mut worst_body: f64 = 0.0;
    let w = 2.0 * std::f64::consts::PI;
    for k in 0..periods(20.0) {
        let t = k as f64 * DT_S;
        let out = step(&params, &mut state, &heave(&params, t, phase), DT_S);
        if t > 10.0 {
            worst_strut = worst_strut.max((out.strut_vel_m_s - 0.1 * (w * t + phase).sin()).abs());
            worst_body = worst_body.max((out.body_vel_m_s - 0.1 * (w * t).sin()).abs());
        }
    }
    // First-order filters at 16 Hz and 0.16 Hz cost a few per cent of
    // amplitude and a few degrees of phase at 1 Hz: a 0.1 m/s sine is
    // followed within 0.02 m/s.
    assert!(worst_strut < 0.02 && worst_body < 0.02, "strut {worst_strut}, body {worst_body}");
}

#[test]
fn valve5_never_switches_faster_than_its_interval_under_skyhook() {
    let params = seed();
    let interval = periods(params.config().damper.valve5_min_interval_s);
    let mut state = in_ride(&params);
    let mut last_change: Option<usize> = None;
    let mut previous = step(&params, &mut state, &calm(&params), DT_S).valve5_open;
    let mut changes = 0;
    // A 20 Hz body/strut chatter the law would follow every 25 ms.
    for k in 0..periods(5.0) {
        let w = 2.0 * std::f64::consts::PI * 20.0;
        let t = k as f64 * DT_S;
        let inputs = Inputs {
            body_acc_m_s2: 2.0 * (0.37 * w * t).cos(),
            strut_disp_m: 0.002 * (w * t).sin(),
            ..calm(&params)
        };
        let out = step(&params, &mut state, &inputs, DT_S);
        if out.valve5_open != previous {
            if let Some(last) = last_change {
                assert!(k - last >= interval, "changed after {} periods", k - last);
            }
            last_change = Some(k);
            changes += 1;
        }
        previous = out.valve5_open;
    }
    assert!(changes > 20, "the law should have switched often: {changes}");
}

#[test]
fn handling_and_the_safe_state_close_valve5_at_once() {
    let params = seed();
    let mut state = in_ride(&params);
    // Get valve 5 open (low damping) first.
    let mut out = step(&params, &mut state, &heave(&params, 0.0, 0.0), DT_S);
    let mut k = 0;
    while !out.valve5_open {
        k += 1;
        out = step(&params, &mut state, &heave(&params, k as f64 * DT_S, 0.0), DT_S);
        assert!(k < 5000);
    }
    let mut trigger = heave(&params, k as f64 * DT_S, 0.0);
    trigger.lat_acc_m_s2 = 5.0;
    let mut s2 = state;
    assert!(!step(&params, &mut s2, &trigger, DT_S).valve5_open);
    let mut s3 = state;
    trigger.lat_acc_m_s2 = f64::NAN;
    assert!(!step(&params, &mut s3, &trigger, DT_S).valve5_open);
}
