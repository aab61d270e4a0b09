//! Closed cycles and energy: the adiabatic gas returns to its start, the
//! thermal loop follows the linearised theory and peaks at omega tau = 1,
//! and the dissipated energy balances the work put in.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::{loop_integral, run_uniform, sine, unit_with};
use hp_core::damper::DamperCurve;
use hp_core::gas::{cp0_molar_j_per_mol_k, Gas, MOLAR_GAS_CONSTANT_J_PER_MOL_K};
use hp_core::rig::RigSample;
use hp_core::thermal::HeatTransfer;
use hp_core::unit::Valves;

const HARD_ON: Valves = Valves { valve5_open: false, valve6_open: false };
const SOFT_ON: Valves = Valves { valve5_open: false, valve6_open: true };

/// Samples of the last whole period of a run of `periods` periods.
fn last_period(samples: &[RigSample], frequency_hz: f64, periods: f64) -> &[RigSample] {
    let start = (periods - 1.0) / frequency_hz;
    let i = samples.iter().position(|s| s.time_s >= start - 1e-9).unwrap();
    &samples[i..]
}

#[test]
fn adiabatic_cycle_returns_to_its_start() {
    let unit = unit_with(|p| p.heat = HeatTransfer::Adiabatic);
    let samples = run_uniform(&unit, sine(0.05, 1.0), HARD_ON, 5.0, 0.01, 1e-4);
    let (first, last) = (samples[0], samples[samples.len() - 1]);
    assert!((last.unit.t_gas_k / first.unit.t_gas_k - 1.0).abs() < 1e-9);
    assert!((last.unit.p_gas_true_pa / first.unit.p_gas_true_pa - 1.0).abs() < 1e-9);
    // ... even though the gas heated by tens of kelvin within each cycle.
    let t_max = samples.iter().map(|s| s.unit.t_gas_k).fold(0.0, f64::max);
    assert!(t_max - first.unit.t_gas_k > 30.0);
}

/// Work done on the gas spring alone over the last period, J: the loop area
/// of `A (p_S - p_atm)` over strut compression.
fn spring_loop_area_j(unit: &hp_core::unit::Unit, amplitude_m: f64, frequency_hz: f64, tau_s: f64) -> f64 {
    let periods = (12.0 * tau_s * frequency_hz).max(3.0).ceil();
    let out_dt = 1.0 / (frequency_hz * 400.0);
    let dt = out_dt.min(1e-3);
    let samples = run_uniform(unit, sine(amplitude_m, frequency_hz), HARD_ON, periods / frequency_hz, out_dt, dt);
    let area = unit.params().piston_area_m2;
    let p_atm = unit.params().ambient_pressure_pa;
    loop_integral(last_period(&samples, frequency_hz, periods).iter().map(|s| (s.disp_m, area * (s.unit.p_gas_true_pa - p_atm))))
}

#[test]
fn ideal_gas_loop_area_matches_linear_theory_and_peaks_at_omega_tau_one() {
    // Small amplitude, ideal gas: the linearised energy equation gives the
    // complex stiffness (A^2 p0 / V0) (1 + i gamma x) / (1 + i x), x = omega tau,
    // so the loop area is pi X^2 (A^2 p0 / V0) (gamma - 1) x / (1 + x^2).
    let tau = 2.0;
    let unit = unit_with(|p| {
        p.gas = Gas::Ideal;
        p.heat = HeatTransfer::TimeConstant(tau);
    });
    let p = unit.params();
    let cp = cp0_molar_j_per_mol_k(p.static_temperature_k);
    let gamma = cp / (cp - MOLAR_GAS_CONSTANT_J_PER_MOL_K);
    let amp = 5e-4;
    let scale = std::f64::consts::PI * amp * amp * p.piston_area_m2 * p.piston_area_m2 * p.static_pressure_pa / p.small_acc_volume_m3;
    let mut best = (0.0, 0.0);
    for x in [0.1, 0.3, 0.6, 0.8, 1.0, 1.25, 1.6, 3.0, 10.0] {
        let f = x / (2.0 * std::f64::consts::PI * tau);
        let w = spring_loop_area_j(&unit, amp, f, tau);
        let theory = scale * (gamma - 1.0) * x / (1.0 + x * x);
        assert!((w / theory - 1.0).abs() < 0.01, "x={x}: loop {w} J vs theory {theory} J");
        if w > best.1 {
            best = (x, w);
        }
    }
    assert_eq!(best.0, 1.0, "loop area must peak at omega tau = 1");
}

#[test]
fn real_gas_loop_area_rises_and_falls_with_frequency() {
    let tau = 2.0;
    let unit = unit_with(|p| p.heat = HeatTransfer::TimeConstant(tau));
    let f_peak = 1.0 / (2.0 * std::f64::consts::PI * tau);
    let freqs = [f_peak / 100.0, f_peak / 3.0, f_peak, f_peak * 3.0, f_peak * 100.0];
    let areas: Vec<f64> = freqs.iter().map(|&f| spring_loop_area_j(&unit, 0.05, f, tau)).collect();
    let (imax, &max) = areas.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
    assert_eq!(imax, 2, "areas {areas:?}");
    assert!(areas[0] < 0.1 * max && areas[4] < 0.1 * max, "areas {areas:?}");
    assert!(areas[1] < max && areas[3] < max && areas[1] > areas[0] && areas[3] > areas[4]);
}

#[test]
fn damper_energy_state_equals_integral_of_damper_force_times_velocity() {
    let unit = unit_with(|_| {});
    // 1 Hz, 60 mm: up to 0.38 m/s, through blow-off in both directions.
    let samples = run_uniform(&unit, sine(0.06, 1.0), SOFT_ON, 3.0, 1e-3, 1e-4);
    let integral: f64 = samples
        .windows(2)
        .map(|w| 0.5 * (w[0].unit.damper_force_n * w[0].vel_m_s + w[1].unit.damper_force_n * w[1].vel_m_s) * (w[1].time_s - w[0].time_s))
        .sum();
    let state = samples.last().unwrap().e_damper_j;
    assert!(samples.iter().all(|s| !s.unit.cavitating));
    assert!(state > 100.0);
    assert!((integral / state - 1.0).abs() < 1e-4, "{integral} vs {state}");
}

#[test]
fn adiabatic_cycle_work_equals_energy_dissipated() {
    // Over a steady cycle with no heat transfer, the gas stores and returns
    // all its work, so the work of the actuator is what the damper pack and
    // valve 6 dissipated.
    let unit = unit_with(|p| p.heat = HeatTransfer::Adiabatic);
    let f = 1.5;
    let periods = 4.0;
    let samples = run_uniform(&unit, sine(0.05, f), SOFT_ON, periods / f, 1e-4, 1e-4);
    let cycle = last_period(&samples, f, periods);
    let work = loop_integral(cycle.iter().map(|s| (s.disp_m, s.unit.force_true_n)));
    let (a, b) = (cycle[0], cycle[cycle.len() - 1]);
    let dissipated = (b.e_damper_j - a.e_damper_j) + (b.e_valve6_j - a.e_valve6_j);
    assert!(b.e_valve6_j - a.e_valve6_j > 0.0);
    assert!((work / dissipated - 1.0).abs() < 2e-3, "work {work} J vs dissipated {dissipated} J");
}

#[test]
fn damper_curve_inverse_is_exact() {
    let c = DamperCurve::from_strut(2e-3, 30_000.0, 60_000.0, 11_000.0, 15_000.0);
    for q in [0.0, 1e-5, 1e-4, 4e-4, 5e-4, 1e-3, 3e-3] {
        let dp = c.pressure_drop_pa(q);
        assert!((c.flow_m3_s(dp) - q).abs() <= 1e-12 + 1e-9 * q);
    }
}
