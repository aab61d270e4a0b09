//! The reference equation of state (Span et al. 2000) against CoolProp's
//! golden values (`tests/data/n2_span_golden.csv`, written by
//! `tests/reference/make_n2_reference.py`): a dense grid over the unit's
//! envelope (2-110 MPa, 233-473 K) and states beyond it, 1 kPa - 300 MPa
//! and the triple point - 1000 K, gas and liquid.
//!
//! The targets are 1e-4 in pressure and density and 1e-3 in c_v and
//! (dp/dT)_rho; the model is the same formulation as CoolProp's, so the
//! bounds asserted are the rounding level it actually reaches.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::fixture;
use hp_core::gas::span::{self, GAUSSIAN, RESIDUAL_D, RESIDUAL_L, RESIDUAL_N, RESIDUAL_T};
use hp_core::gas::{EquationOfState, Gas, Span};

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

#[derive(Debug, Default)]
struct Worst {
    p: f64,
    rho: f64,
    dp_dt: f64,
    dp_drho: f64,
    cv: f64,
    rows: usize,
}

fn worst(region: f64) -> Worst {
    let mut w = Worst::default();
    for row in fixture("n2_span_golden.csv").into_iter().filter(|r| r["region"] == region) {
        let (p, t, rho) = (row["p_pa"], row["t_k"], row["rho_kg_m3"]);
        let props = Span.props(rho, t);
        let solved = Span.density_kg_m3(p, t).unwrap_or_else(|e| panic!("{p} Pa, {t} K: {e}"));
        w.p = w.p.max(rel(props.p_pa, p));
        w.rho = w.rho.max(rel(solved, rho));
        w.dp_dt = w.dp_dt.max(rel(props.dp_dt_pa_per_k, row["dp_dt_pa_per_k"]));
        w.dp_drho = w.dp_drho.max(rel(props.dp_drho_pa_m3_per_kg, row["dp_drho_pa_m3_per_kg"]));
        w.cv = w.cv.max(rel(props.cv_j_per_kg_k, row["cv_j_per_kg_k"]));
        w.rows += 1;
    }
    w
}

#[test]
fn matches_coolprop_to_rounding_on_the_dense_envelope_grid() {
    let w = worst(0.0);
    assert!(w.rows >= 600, "{w:?}");
    // Measured: p 2e-15, density 2e-12 (the solve's own tolerance), the
    // derivatives and c_v 1e-14.
    assert!(w.p < 1e-13 && w.rho < 1e-10, "{w:?}");
    assert!(w.dp_dt < 1e-12 && w.dp_drho < 1e-12 && w.cv < 1e-12, "{w:?}");
}

#[test]
fn matches_coolprop_beyond_the_envelope_to_the_accepted_limits() {
    // 1 kPa - 300 MPa, 64 - 1000 K, where CoolProp has a fluid state
    // (below about 114 K it is solid at the highest pressures). Liquid
    // states included: the density solve starts on the liquid side above
    // the vapour pressure.
    let w = worst(1.0);
    assert!(w.rows >= 190, "{w:?}");
    assert!(w.p < 1e-11 && w.rho < 1e-10, "{w:?}");
    assert!(w.dp_dt < 1e-12 && w.dp_drho < 1e-12 && w.cv < 1e-12, "{w:?}");
}

#[test]
fn the_default_gas_is_the_reference() {
    assert_eq!(Gas::default(), Gas::Span);
    assert_eq!(Gas::from_name("span"), Some(Gas::Span));
    assert_eq!(hp_core::presets::seed_unit().gas, Gas::Span);
}

/// The residual derivatives by a plain loop over the coefficient tables as
/// transcribed from CoolProp's file, with `libm::pow` for every power: an
/// independent check of the hand-unrolled evaluation.
fn residual_plain(delta: f64, tau: f64) -> span::Residual {
    let mut r = span::Residual::default();
    for i in 0..RESIDUAL_N.len() {
        let (n, d, t, l) = (RESIDUAL_N[i], f64::from(RESIDUAL_D[i]), RESIDUAL_T[i], f64::from(RESIDUAL_L[i]));
        let dl = if l > 0.0 { libm::pow(delta, l) } else { 0.0 };
        let term = n * libm::pow(delta, d) * libm::pow(tau, t) * libm::exp(-dl);
        let u = l * dl;
        r.d += term * (d - u);
        r.dd += term * ((d - u) * (d - 1.0 - u) - l * u);
        r.tt += term * t * (t - 1.0);
        r.dt += term * t * (d - u);
    }
    for g in GAUSSIAN {
        let term = g.n
            * libm::pow(delta, g.d)
            * libm::pow(tau, g.t)
            * libm::exp(-g.eta * (delta - 1.0) * (delta - 1.0) - g.beta * (tau - g.gamma) * (tau - g.gamma));
        let fd = g.d - 2.0 * g.eta * delta * (delta - 1.0);
        let ft = g.t - 2.0 * g.beta * tau * (tau - g.gamma);
        r.d += term * fd;
        r.dd += term * (fd * fd - g.d - 2.0 * g.eta * delta * delta);
        r.tt += term * (ft * ft - g.t - 2.0 * g.beta * tau * tau);
        r.dt += term * fd * ft;
    }
    r
}

#[test]
fn unrolled_evaluation_equals_a_plain_loop_over_the_tables() {
    // Near the critical point (the Gaussian terms active), in the envelope
    // and at high density.
    for delta in [0.01, 0.3, 1.0, 1.7, 2.3, 3.0] {
        for tau in [0.13, 0.27, 0.45, 0.6, 0.9, 1.0, 1.16, 1.5, 1.9] {
            let fast = span::residual(delta, tau);
            let plain = residual_plain(delta, tau);
            // Absolute on the reduced derivatives (which are O(1) where
            // they matter); relative where they are large.
            for (a, b) in [(fast.d, plain.d), (fast.dd, plain.dd), (fast.tt, plain.tt), (fast.dt, plain.dt)] {
                assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "delta={delta} tau={tau}: {fast:?} vs {plain:?}");
            }
        }
    }
}

#[test]
fn vapour_pressure_separates_the_liquid_and_vapour_roots() {
    // Just above the vapour pressure the liquid root, just below the vapour
    // root; both have the pressure asked for and a positive slope.
    for t in [70.0, 90.0, 110.0, 125.0] {
        let p_sat = span::saturation_pressure_pa(t).unwrap();
        let liquid = Span.density_kg_m3(p_sat * 1.01, t).unwrap();
        let vapour = Span.density_kg_m3(p_sat * 0.99, t).unwrap();
        assert!(liquid > span::RHO_C_KG_M3 && vapour < span::RHO_C_KG_M3, "{t} K: {liquid} {vapour}");
        for (rho, p) in [(liquid, p_sat * 1.01), (vapour, p_sat * 0.99)] {
            let (p_model, slope) = Span.pressure_and_slope(rho, t);
            assert!(rel(p_model, p) < 1e-10 && slope > 0.0, "{t} K: {rho}");
        }
    }
    assert!(span::saturation_pressure_pa(200.0).is_none());
}

#[test]
fn single_precision_model_is_within_a_few_1e6_of_the_double_precision_one() {
    // What the ECU builds its gas table with: the dense envelope grid and
    // the gas and supercritical states beyond it. The terms partly cancel,
    // so a few single-precision roundings show at the highest densities.
    let mut worst = [[0.0_f64; 3]; 2]; // [envelope, beyond] x [p, slope, rho]
    for row in fixture("n2_span_golden.csv") {
        let (p, t, rho) = (row["p_pa"], row["t_k"], row["rho_kg_m3"]);
        if rho > span::RHO_C_KG_M3 && t < span::T_C_K {
            continue; // liquid: the single-precision solve covers gas states only
        }
        let (p32, slope32) = span::single::pressure_and_slope(rho as f32, t as f32);
        let (p64, slope64) = Span.pressure_and_slope(f64::from(rho as f32), f64::from(t as f32));
        let rho32 = span::single::density_kg_m3(p as f32, t as f32).unwrap();
        let w = &mut worst[row["region"] as usize];
        w[0] = w[0].max(rel(f64::from(p32), p64));
        w[1] = w[1].max(rel(f64::from(slope32), slope64));
        w[2] = w[2].max(rel(f64::from(rho32), rho));
    }
    // Measured: envelope 1.2e-6, 1.4e-6, 5.3e-7; beyond 2.0e-6, 4.8e-6, 1.4e-6.
    let [envelope, beyond] = worst;
    assert!(envelope[0] < 2e-6 && envelope[1] < 3e-6 && envelope[2] < 1e-6, "{envelope:?}");
    assert!(beyond.iter().all(|&e| e < 1e-5), "{beyond:?}");
}
