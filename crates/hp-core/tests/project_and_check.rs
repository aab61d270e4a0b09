//! `Unit::project_and_check` (the vehicle's step finish, in place on the
//! state array) against `project` and then `check_state` on a `UnitState`:
//! the same state to the bit and the same result, for plain and other
//! units, with voids to close, valve fractions out of range, NaNs and
//! states out of range.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::unit_with;
use hp_core::thermal::HeatTransfer;
use hp_core::unit::{Unit, UnitState, ValveLag, Valves, UNIT_STATES};

fn reference(unit: &Unit, a: &[f64; UNIT_STATES], ambient_k: f64, t_s: f64) -> (hp_core::error::Result<()>, [f64; UNIT_STATES]) {
    let mut s = UnitState::from_array(a);
    unit.project(&mut s, ambient_k);
    (unit.check_state(&s, t_s), s.to_array())
}

#[test]
fn project_and_check_is_project_then_check_state() {
    let units = [
        ("seed (plain)", unit_with(|_| {})),
        ("isothermal", unit_with(|p| p.heat = HeatTransfer::from_tau_s(0.0).unwrap())),
        ("valve lag", unit_with(|p| p.effects.valve_lag = Some(ValveLag { time_constant_s: 0.02 }))),
    ];
    assert!(units[0].1.is_plain() && !units[1].1.is_plain() && !units[2].1.is_plain());
    let ambient_k = 288.0;
    let mut cases = 0;
    for (name, unit) in &units {
        let rest = unit.state_at_rest(0.0, 293.15, Valves::default()).unwrap().to_array();
        // (element, value) changes from the state at rest, alone and in pairs.
        let changes: Vec<(usize, f64)> = vec![
            (6, -1e-6),
            (6, 2e-6),
            (6, f64::NAN),
            (10, 1.5),
            (10, -0.25),
            (11, 2.0),
            (11, -1.0),
            (11, 0.5),
            (0, 150.0),
            (1, f64::NAN),
            (2, -1e-3),
            (3, f64::INFINITY),
            (7, f64::NAN),
            (8, 1000.0),
            (9, 100.0),
            (12, f64::INFINITY),
            (13, 1e6),
        ];
        let mut states = vec![rest];
        for &(i, x) in &changes {
            let mut a = rest;
            a[i] = x;
            states.push(a);
            for &(j, y) in &changes {
                let mut b = a;
                b[j] = y;
                states.push(b);
            }
        }
        for a in states {
            let (want, projected) = reference(unit, &a, ambient_k, 1.5);
            let mut got_state = a;
            let got = unit.project_and_check(&mut got_state, ambient_k, 1.5);
            // As text: an error may carry a NaN.
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "{name}: {a:?}");
            if want.is_ok() {
                for (k, (g, w)) in got_state.iter().zip(&projected).enumerate() {
                    assert_eq!(g.to_bits(), w.to_bits(), "{name}: element {k} of {a:?}");
                }
            }
            cases += 1;
        }
    }
    assert!(cases > 900);
}
