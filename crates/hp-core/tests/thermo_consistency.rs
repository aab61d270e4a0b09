//! The analytic derivatives and c_v of every equation of state agree with
//! finite differences of its own pressure, i.e. the model is
//! thermodynamically consistent (a wrong sign or factor in a hand-derived
//! derivative shows here, independent of any reference data).
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
use hp_core::gas::{EquationOfState, Gas};

fn states() -> impl Iterator<Item = (f64, f64)> {
    [5.0, 30.0, 120.0, 250.0, 400.0, 550.0]
        .into_iter()
        .flat_map(|rho| [233.15, 293.15, 373.15, 473.15].into_iter().map(move |t| (rho, t)))
}

#[test]
fn analytic_pressure_derivatives_match_central_differences() {
    for gas in Gas::ALL {
        for (rho, t) in states() {
            let props = gas.props(rho, t);
            let (hr, ht) = (rho * 1e-6, t * 1e-6);
            let dp_drho = (gas.pressure_pa(rho + hr, t) - gas.pressure_pa(rho - hr, t)) / (2.0 * hr);
            let dp_dt = (gas.pressure_pa(rho, t + ht) - gas.pressure_pa(rho, t - ht)) / (2.0 * ht);
            assert!((props.dp_drho_pa_m3_per_kg / dp_drho - 1.0).abs() < 1e-6, "{gas:?} {rho} {t}");
            assert!((props.dp_dt_pa_per_k / dp_dt - 1.0).abs() < 1e-6, "{gas:?} {rho} {t}");
        }
    }
}

/// c_v from the pressure alone: c_v = c_v0 - T * integral_0^rho (d2p/dT2) / rho'^2 drho'
/// (from the Helmholtz energy), with the model's own ideal-gas part c_v0
/// (its c_v in the dilute limit). Composite midpoint rule, which never
/// evaluates at rho' = 0 where the difference quotient is all rounding noise;
/// second derivative by central differences.
fn cv_from_pressure(gas: Gas, rho: f64, t: f64) -> f64 {
    let n = 4000;
    let h = rho / n as f64;
    let ht = 0.5;
    let integral: f64 = (0..n)
        .map(|i| {
            let r = (i as f64 + 0.5) * h;
            let d2p_dt2 = (gas.pressure_pa(r, t + ht) - 2.0 * gas.pressure_pa(r, t) + gas.pressure_pa(r, t - ht)) / (ht * ht);
            d2p_dt2 / (r * r) * h
        })
        .sum();
    gas.props(1e-9, t).cv_j_per_kg_k - t * integral
}

#[test]
fn heat_capacity_is_consistent_with_the_pressure_equation() {
    for gas in Gas::ALL {
        for (rho, t) in states() {
            let analytic = gas.props(rho, t).cv_j_per_kg_k;
            let numeric = cv_from_pressure(gas, rho, t);
            assert!((analytic / numeric - 1.0).abs() < 2e-4, "{gas:?} rho={rho} T={t}: {analytic} vs {numeric}");
        }
    }
}
