//! `step_all` against `step` called for each controller in turn.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use hp_ctrl::{step, step_all, DriverMode, Inputs, Outputs, State};

/// Eleven controllers (one batch of eight and one of three) over 12 s of
/// periods: pressures and strut travel moving differently per corner, the
/// temperature drifting, ride-height requests (lowering, raising), a
/// manoeuvre, NaN and out-of-range values, stale groups and bad step
/// sizes now and then; every period's outputs and every state the same
/// (compared through `Debug`, so that NaN equals NaN).
#[test]
fn step_all_steps_each_controller_as_step_does() {
    let params = common::seed();
    let calm = common::calm(&params);
    const N: usize = 11;
    let (mut one, mut all) = ([State::new(); N], [State::new(); N]);
    let mut out_all = [Outputs::default(); N];
    let (mut valve6_switches, mut safe_periods) = (0, 0);
    let mut last_valve6 = [false; N];
    for k in 0..12_000_u32 {
        let t = f64::from(k) * common::DT_S;
        let inputs: [Inputs; N] = core::array::from_fn(|c| {
            let phase = c as f64 * 0.7;
            let mut i = Inputs {
                p_gas_pa: calm.p_gas_pa * (1.0 + 0.2 * (9.0 * t + phase).sin()),
                p_gas2_pa: calm.p_gas2_pa * (1.0 + 0.05 * (0.5 * t + phase).sin()),
                strut_disp_m: 0.03 * (9.0 * t + phase).sin(),
                body_acc_m_s2: 2.0 * (1.3 * t + phase).cos(),
                t_gas_k: calm.t_gas_k + 20.0 * (0.1 * t).sin() + c as f64,
                ride_height_request_m: if t > 6.0 { 0.02 } else if t > 3.0 { -0.03 } else { 0.0 },
                lat_acc_m_s2: if (8.0..8.5).contains(&t) { 5.0 } else { 0.0 },
                driver_mode: if t > 10.0 { DriverMode::Comfort } else { DriverMode::Auto },
                ..calm
            };
            let r = (k as usize).wrapping_mul(2_654_435_761).wrapping_add(c * 40_503) % 20_011;
            match r {
                0 => i.p_gas2_pa = f64::NAN,
                1 => i.t_gas_k = 1.0e4,
                2 => i.fresh = 0,
                3 => i.strut_disp_m = f64::INFINITY,
                _ => {}
            }
            i
        });
        let dt_s = if k % 4_999 == 2_500 { f64::NAN } else { common::DT_S };
        let out_one: [Outputs; N] = core::array::from_fn(|c| step(&params, &mut one[c], &inputs[c], dt_s));
        step_all(&params, &mut all, &inputs, dt_s, &mut out_all);
        assert_eq!(format!("{out_one:?}"), format!("{out_all:?}"), "period {k}");
        assert_eq!(format!("{one:?}"), format!("{all:?}"), "period {k}");
        for (c, o) in out_one.iter().enumerate() {
            valve6_switches += usize::from(o.valve6_open != last_valve6[c]);
            last_valve6[c] = o.valve6_open;
            safe_periods += usize::from(o.diag & hp_ctrl::diag::SAFE_STATE != 0);
        }
    }
    // The run reached the safe state, its recovery and valve 6's switching.
    assert!(valve6_switches > 20, "{valve6_switches}");
    assert!(safe_periods > 1000 && safe_periods < 11 * 11_000, "{safe_periods}");
}

/// Slices of different lengths: the controllers beyond the shortest are
/// not stepped.
#[test]
fn step_all_steps_only_as_many_as_every_slice_holds() {
    let params = common::seed();
    let inputs = [common::calm(&params); 3];
    let mut states = [State::new(); 5];
    let mut outputs = [Outputs::default(); 4];
    step_all(&params, &mut states, &inputs, common::DT_S, &mut outputs);
    let mut stepped = State::new();
    let expected = step(&params, &mut stepped, &inputs[0], common::DT_S);
    assert_eq!(states[..3], [stepped; 3]);
    assert_eq!(states[3..], [State::new(); 2]);
    assert_eq!(outputs[..3], [expected; 3]);
    assert_eq!(outputs[3], Outputs::default());
}
