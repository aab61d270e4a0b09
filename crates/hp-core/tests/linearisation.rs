//! The unit's linearisations (what a linearly implicit step puts in its
//! `W`) against central differences of the unit's own force and state rate:
//! the strut's ([`StrutCoupling`]) and valve 6's ([`Valve6Coupling`]),
//! damper on and off, compression and rebound, below and above the blow-off,
//! on an end stop, with seal friction.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use hp_core::presets;
use hp_core::unit::{Friction, Linearisation, Needs, StrutMotion, Unit, UnitOutputs, UnitState, Valves, UNIT_STATES};

const T_K: f64 = 293.15;

fn evaluate(unit: &Unit, s: &UnitState, m: StrutMotion, valves: Valves) -> (UnitState, UnitOutputs, Linearisation) {
    unit.evaluate_parts(s, m, valves, T_K, Needs { outputs: true, coupling: true, strut: true, rates: true })
}

/// `(force, rate)` with one state perturbed by `d`.
fn perturbed(unit: &Unit, s: &UnitState, m: StrutMotion, valves: Valves, i: usize, d: f64) -> (f64, [f64; UNIT_STATES]) {
    let mut a = s.to_array();
    a[i] += d;
    let (rate, out, _) = evaluate(unit, &UnitState::from_array(&a), m, valves);
    (out.force_true_n, rate.to_array())
}

fn close(got: f64, want: f64, scale: f64, what: &str) {
    assert!((got - want).abs() <= 1e-5 * want.abs() + 1e-9 * scale, "{what}: {got} against {want} (differences)");
}

/// Indices of the state array (UnitState::to_array's order).
const T_GAS: usize = 0;
const T_GAS2: usize = 1;
const V_GAS: usize = 2;
const V_GAS2: usize = 3;
const M_SMALL: usize = 4;
const M_LARGE: usize = 5;

fn check(unit: &Unit, disp_m: f64, vel_m_s: f64, valves: Valves) {
    let mut s = unit.state_at_rest(disp_m.clamp(-0.1, 0.1), T_K, valves).unwrap();
    // Off equilibrium: S warmer and compressed against L, so valve 6 flows.
    s.t_gas_k += 4.0;
    s.v_gas_m3 *= 0.97;
    let m = StrutMotion { disp_m, vel_m_s };
    let (rate, out, lin) = evaluate(unit, &s, m, valves);
    assert!(!out.cavitating);
    let strut = lin.strut.expect("the strut's linearisation");
    let base = s.to_array();
    // d(force)/d(state) and d(force)/d(motion).
    for i in [T_GAS, V_GAS, M_SMALL, T_GAS2, V_GAS2] {
        let d = 1e-6 * base[i].abs();
        let (f_hi, _) = perturbed(unit, &s, m, valves, i, d);
        let (f_lo, _) = perturbed(unit, &s, m, valves, i, -d);
        close(strut.force_per_state.to_array()[i], (f_hi - f_lo) / (2.0 * d), out.force_true_n / base[i].abs(), &format!("dF/dx[{i}]"));
    }
    let dv = 1e-7;
    let at = |m: StrutMotion| evaluate(unit, &s, m, valves);
    let (r_hi, o_hi, _) = at(StrutMotion { vel_m_s: vel_m_s + dv, ..m });
    let (r_lo, o_lo, _) = at(StrutMotion { vel_m_s: vel_m_s - dv, ..m });
    close(strut.force_per_vel_n_s_per_m, (o_hi.force_true_n - o_lo.force_true_n) / (2.0 * dv), 1e5, "dF/dv");
    let (a_hi, a_lo) = (r_hi.to_array(), r_lo.to_array());
    for i in [V_GAS, T_GAS] {
        close(strut.rate_per_vel.to_array()[i], (a_hi[i] - a_lo[i]) / (2.0 * dv), rate.to_array()[i].abs() / 0.1, &format!("d(rate[{i}])/dv"));
    }
    let dx = 1e-7;
    let (_, d_hi, _) = at(StrutMotion { disp_m: disp_m + dx, ..m });
    let (_, d_lo, _) = at(StrutMotion { disp_m: disp_m - dx, ..m });
    close(strut.force_per_disp_n_per_m, (d_hi.force_true_n - d_lo.force_true_n) / (2.0 * dx), 1e5, "dF/dx_strut");
    // Valve 6: J = u v^T on the gas states, the volumes' and temperatures' rows.
    if valves.valve6_open {
        let k = lin.valve6.expect("valve 6's linearisation");
        let (u, v) = (k.u.to_array(), k.v.to_array());
        for j in [T_GAS, T_GAS2, V_GAS, V_GAS2, M_SMALL, M_LARGE] {
            let d = 1e-6 * base[j].abs();
            let (_, hi) = perturbed(unit, &s, m, valves, j, d);
            let (_, lo) = perturbed(unit, &s, m, valves, j, -d);
            for i in [V_GAS, V_GAS2] {
                // The volumes change only through the flows: their Jacobian is
                // valve 6's coupling exactly (the damper flow is the strut's).
                close(u[i] * v[j], (hi[i] - lo[i]) / (2.0 * d), rate.to_array()[i].abs() / base[j].abs() + 1e-12, &format!("d(rate[{i}])/dx[{j}]"));
            }
        }
    }
}

#[test]
fn the_strut_and_valve6_linearisations_are_the_units_derivatives() {
    let seed = presets::seed_unit();
    let plain = Unit::new(seed).unwrap();
    let rubbing = Unit::new(hp_core::unit::UnitParams { effects: hp_core::unit::Effects { friction: Some(Friction::new(400.0, 300.0, 1e-2)), ..seed.effects }, ..seed }).unwrap();
    for unit in [&plain, &rubbing] {
        for (spring_hard, damper_on) in [(false, true), (false, false), (true, true), (true, false)] {
            let valves = Valves::from_modes(spring_hard, damper_on);
            // Compression and rebound, slow (orifice) and fast (blow-off).
            for vel in [0.03, -0.05, 0.6, -0.8] {
                check(unit, 0.02, vel, valves);
            }
        }
        // On the compression end stop (its spring and damper engaged).
        check(unit, seed.stroke_compression_m + 0.002, 0.05, Valves::from_modes(false, true));
    }
}
