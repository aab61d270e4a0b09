//! The thermal limits: tau = 0 is exactly isothermal, tau = infinity
//! follows the real-gas isentrope (checked against CoolProp's entropy).
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::{fixture, run_uniform, sine, unit_with};
use hp_core::gas::{EquationOfState, Gas};
use hp_core::motion::Motion;
use hp_core::rig::RigKind;
use hp_core::thermal::HeatTransfer;
use hp_core::unit::Valves;

const HARD_ON: Valves = Valves { valve5_open: false, valve6_open: false };

#[test]
fn tau_zero_is_exactly_isothermal_even_at_high_speed() {
    let unit = unit_with(|p| p.heat = HeatTransfer::from_tau_s(0.0).unwrap());
    let t_wall = unit.params().static_temperature_k;
    // 2 Hz, 50 mm: far faster than any heat transfer could follow.
    let samples = run_uniform(&unit, sine(0.05, 2.0), HARD_ON, 1.0, 0.01, 1e-4);
    let (m_s, _) = unit.gas_masses_kg();
    for s in &samples {
        assert_eq!(s.unit.t_gas_k, t_wall);
        // Pressure is the isotherm's at the current volume, to rounding.
        let p_iso = unit.params().gas.pressure_pa(m_s / s.v_gas_m3, t_wall);
        assert!((s.unit.p_gas_true_pa / p_iso - 1.0).abs() < 1e-12);
    }
}

#[test]
fn slow_compression_follows_the_reference_isotherm() {
    // Slow steps with long dwells at the seed's tau: the gas settles to the
    // wall temperature, and the pressure must then be the reference
    // isotherm's within the equation of state's own error there.
    let unit = unit_with(|p| p.gas = Gas::BwrTextbook);
    let t = unit.params().static_temperature_k;
    let (m_s, _) = unit.gas_masses_kg();
    let motion = Motion::Steps { increment_m: 0.02, count: 4, ramp_s: 1.0, dwell_s: 30.0 };
    let kind = RigKind::Characterisation { strut: motion };
    let samples = run_uniform(&unit, kind, HARD_ON, 8.0 * 31.0, 0.5, 5e-3);
    // At the end of each dwell on the way up.
    for k in 1..=4 {
        let time = k as f64 * 31.0 - 0.25;
        let s = samples.iter().min_by(|a, b| (a.time_s - time).abs().total_cmp(&(b.time_s - time).abs())).unwrap();
        assert!((s.unit.t_gas_k - t).abs() < 1e-4 * t, "not settled: {}", s.unit.t_gas_k);
        let rho = m_s / s.v_gas_m3;
        let p_ref = coolprop_isotherm_pa(rho, t);
        let eos_error = (Gas::BwrTextbook.pressure_pa(rho, t) / p_ref - 1.0).abs();
        let sim_error = (s.unit.p_gas_true_pa / p_ref - 1.0).abs();
        assert!(sim_error <= eos_error + 1e-4, "rho={rho}: sim {sim_error} vs eos {eos_error}");
        assert!(sim_error < 0.02);
    }
}

/// CoolProp's pressure at 293.15 K for density `rho`, interpolated (cubic
/// in log density) from the reference grid's isotherm.
fn coolprop_isotherm_pa(rho: f64, t: f64) -> f64 {
    let mut pts: Vec<(f64, f64)> = fixture("n2_grid.csv")
        .into_iter()
        .filter(|r| (r["t_k"] - t).abs() < 1e-9)
        .map(|r| (r["rho_kg_m3"], r["p_pa"]))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Lagrange interpolation over the four nearest points (smooth isotherm).
    let i = pts.partition_point(|p| p.0 < rho).clamp(2, pts.len() - 2);
    let near = &pts[i - 2..i + 2];
    let mut p = 0.0;
    for (j, &(rj, pj)) in near.iter().enumerate() {
        let mut w = 1.0;
        for (k, &(rk, _)) in near.iter().enumerate() {
            if k != j {
                w *= (rho - rk) / (rj - rk);
            }
        }
        p += w * pj;
    }
    p
}

#[test]
fn tau_infinity_follows_the_reference_isentrope() {
    let unit = unit_with(|p| {
        p.gas = Gas::BwrTextbook;
        p.heat = HeatTransfer::from_tau_s(f64::INFINITY).unwrap();
    });
    let (m_s, _) = unit.gas_masses_kg();
    let v0 = unit.params().small_acc_volume_m3;
    let area = unit.params().piston_area_m2;
    let rows: Vec<_> = fixture("n2_isentropes.csv").into_iter().filter(|r| r["case"] == 0.0).collect();
    let t0 = rows[0]["t_k"];
    let mut checked = 0;
    for r in &rows[1..] {
        // Compress S to the reference density with a smooth ramp.
        let v = m_s / r["rho_kg_m3"];
        let x = (v0 - v) / area;
        if x > 0.11 {
            continue;
        }
        let kind = RigKind::Characterisation { strut: Motion::Step { height_m: x, start_s: 0.0, rise_s: 0.5 } };
        let s = *run_uniform(&unit, kind, HARD_ON, 0.6, 0.1, 1e-4).last().unwrap();
        // The EOS's own error along the isentrope: dT/drho|s = T (dp/dT)/(rho^2 c_v),
        // so the temperature rise carries the relative error of (dp/dT)/c_v,
        // taken at the worst point of the path.
        let ratio_error = rows
            .iter()
            .filter(|q| q["rho_kg_m3"] <= r["rho_kg_m3"])
            .map(|q| {
                let props = Gas::BwrTextbook.props(q["rho_kg_m3"], q["t_k"]);
                let model = props.dp_dt_pa_per_k / props.cv_j_per_kg_k;
                let reference = q["dp_dt_pa_per_k"] / q["cv_j_per_kg_k"];
                (model / reference - 1.0).abs()
            })
            .fold(0.0, f64::max);
        let rise_ref = r["t_k"] - t0;
        let allowed = ratio_error * rise_ref + 0.05;
        assert!(
            (s.unit.t_gas_k - r["t_k"]).abs() <= allowed,
            "rho={}: T {} vs CoolProp {} (allowed {allowed})",
            r["rho_kg_m3"],
            s.unit.t_gas_k,
            r["t_k"]
        );
        checked += 1;
    }
    assert!(checked >= 3);
}

#[test]
fn polytropic_ideal_gas_keeps_p_v_to_the_n_constant() {
    for n in [1.0, 1.25, 1.4] {
        let unit = unit_with(|p| {
            p.gas = Gas::Ideal;
            p.heat = HeatTransfer::polytropic(n).unwrap();
        });
        let samples = run_uniform(&unit, sine(0.08, 0.5), HARD_ON, 4.0, 0.01, 1e-3);
        let invariant = |s: &hp_core::rig::RigSample| s.unit.p_gas_true_pa * s.v_gas_m3.powf(n);
        let first = invariant(&samples[0]);
        for s in &samples {
            assert!((invariant(s) / first - 1.0).abs() < 1e-9, "n={n}: {}", invariant(s) / first);
        }
    }
}
