//! A time constant that moves with the gas's heat capacity
//! (`WallConductance`): with exponent 1 the wall conductance `h A` is the
//! same in every state (checked with CoolProp's `c_v`, not the core's);
//! with exponent 0 the unit is the seed's, bit for bit.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::{fixture, unit_with};
use hp_core::gas::Gas;
use hp_core::thermal::HeatTransfer;
use hp_core::unit::{Effects, Leakage, StrutMotion, Unit, UnitState, Valves, WallConductance};

const HARD: Valves = Valves { valve5_open: false, valve6_open: false };
const AT_REST: StrutMotion = StrutMotion { disp_m: 0.0, vel_m_s: 0.0 };
const TAU_S: f64 = 1.7;

/// A row of a CoolProp fixture, by column.
type Row = std::collections::HashMap<String, f64>;

fn with_conductance(gas: Gas, exponent: Option<f64>, leakage: Option<Leakage>, static_p_pa: f64, static_t_k: f64) -> Unit {
    unit_with(|p| {
        p.gas = gas;
        p.heat = HeatTransfer::TimeConstant(TAU_S);
        p.static_pressure_pa = static_p_pa;
        p.static_temperature_k = static_t_k;
        p.effects = Effects { wall_conductance: exponent.map(|cv_exponent| WallConductance { cv_exponent }), leakage, ..Effects::default() };
    })
}

/// S's gas at density `rho` and temperature `t_k` (L at rest), strut still.
fn state_at(unit: &Unit, rho: f64, t_k: f64) -> UnitState {
    let mut s = unit.state_at_rest(0.0, t_k, HARD).unwrap();
    s.v_gas_m3 = unit.gas_masses_kg().0 / rho;
    s
}

/// The conductance `m c_v dT/dt / (T_w - T)` the unit implies at rest, 12 K
/// below its wall, in each row of CoolProp's grid between 5 and 40 MPa and
/// 230 and 380 K (`c_v` the grid's): at rest the temperature rate is the
/// heat flow alone, `m c_v dT/dt = hA (T_w - T)`.
fn implied_conductances<'g>(unit: &Unit, grid: &'g [Row]) -> Vec<(&'g Row, f64)> {
    let m = unit.gas_masses_kg().0;
    grid.iter()
        .filter(|r| (5e6..=40e6).contains(&r["p_pa"]) && r["t_k"] > 230.0 && r["t_k"] < 380.0)
        .map(|row| {
            let wall_k = row["t_k"] + 12.0;
            let (rate, _) = unit.evaluate(&state_at(unit, row["rho_kg_m3"], row["t_k"]), AT_REST, HARD, wall_k);
            (row, m * row["cv_j_per_kg_k"] * rate.t_gas_k / (wall_k - row["t_k"]))
        })
        .collect()
}

#[test]
fn exponent_one_keeps_the_wall_conductance_fixed_in_every_state() {
    // The static state is one row of CoolProp's grid, the gas then taken to
    // other rows (densities 2-4x apart, 233-373 K): at rest the temperature
    // rate is the heat flow alone, `m c_v dT/dt = hA (T_w - T)`, so
    // m c_v(row) dT/dt / (T_w - T) must be the static m c_v / tau_s for all.
    let grid = fixture("n2_grid.csv");
    let reference = grid.iter().find(|r| r["p_pa"] == 15e6 && (r["t_k"] - 293.15).abs() < 1e-9).unwrap();
    let unit = with_conductance(Gas::Span, Some(1.0), None, reference["p_pa"], reference["t_k"]);
    let m = unit.gas_masses_kg().0;
    let conductance = m * reference["cv_j_per_kg_k"] / TAU_S;
    let mut checked = 0;
    for (row, implied) in implied_conductances(&unit, &grid) {
        // The core's c_v against CoolProp's: within 1e-4 (docs/accuracy.md).
        assert!((implied / conductance - 1.0).abs() < 2e-4, "{row:?}: hA {implied} vs {conductance}");
        checked += 1;
    }
    assert!(checked >= 20, "{checked} grid rows");
    // And c_v does change over those rows, so the check means something:
    // a constant time constant gives a conductance off by more.
    let seed = with_conductance(Gas::Span, None, None, reference["p_pa"], reference["t_k"]);
    let row = grid.iter().find(|r| r["p_pa"] == 40e6 && (r["t_k"] - 293.15).abs() < 1e-9).unwrap();
    let (rate, _) = seed.evaluate(&state_at(&seed, row["rho_kg_m3"], row["t_k"]), AT_REST, HARD, row["t_k"] + 12.0);
    let implied = m * row["cv_j_per_kg_k"] * rate.t_gas_k / 12.0;
    assert!((implied / conductance - 1.0).abs() > 0.02, "constant tau at 40 MPa: hA off by {}", implied / conductance - 1.0);
}

#[test]
fn exponent_zero_is_the_seeds_constant_time_constant_bit_for_bit() {
    let seed = with_conductance(Gas::Span, None, None, 15e6, 293.15);
    let zero = with_conductance(Gas::Span, Some(0.0), None, 15e6, 293.15);
    for (rho, t_k, vel) in [(150.0, 300.0, 0.1), (260.0, 350.0, -0.3), (90.0, 260.0, 0.0)] {
        let motion = StrutMotion { disp_m: 0.01, vel_m_s: vel };
        let a = seed.evaluate(&state_at(&seed, rho, t_k), motion, HARD, 296.0);
        let b = zero.evaluate(&state_at(&zero, rho, t_k), motion, HARD, 296.0);
        assert_eq!(a, b);
    }
}

#[test]
fn with_an_ideal_gas_only_the_gas_mass_moves_the_time_constant() {
    // c_v of the ideal gas depends on the temperature alone: at the static
    // temperature, whatever the density, the time constant follows the
    // mass alone (a leaking accumulator relaxes faster), tau = tau_s m / m0.
    // The heat part of the rate is its change with the wall temperature
    // (leakage adds an expansion term that does not depend on the wall).
    let unit = with_conductance(Gas::Ideal, Some(1.0), Some(Leakage { time_constant_s: 1e4, pressure_exponent: 0.0, mass_exponent: 1.0 }), 15e6, 293.15);
    let heat_part = |s: &UnitState| unit.evaluate(s, AT_REST, HARD, 303.15).0.t_gas_k - unit.evaluate(s, AT_REST, HARD, 293.15).0.t_gas_k;
    let mut state = state_at(&unit, 180.0, 293.15);
    assert!((heat_part(&state) - 10.0 / TAU_S).abs() < 1e-12, "{} vs {}", heat_part(&state), 10.0 / TAU_S);
    state.m_small_kg *= 0.8;
    state.v_gas_m3 *= 0.8; // the same density and temperature
    assert!((heat_part(&state) - 10.0 / (0.8 * TAU_S)).abs() < 1e-12, "{}", heat_part(&state));
}

#[test]
fn any_exponent_moves_the_conductance_as_that_power_of_the_heat_capacity() {
    // tau = tau_s (m c_v / (m c_v)_static)^n, so the implied conductance
    // m c_v / tau is the static one times (c_v / c_v,static)^(1 - n) (the
    // mass does not move without a leak), c_v taken from CoolProp's grid.
    // The core's power (exp(n ln r), not pow: stop 60) is checked by it.
    let grid = fixture("n2_grid.csv");
    let reference = grid.iter().find(|r| r["p_pa"] == 15e6 && (r["t_k"] - 293.15).abs() < 1e-9).unwrap();
    for exponent in [0.5, 0.9066172447224166, -2.0, 3.0] {
        let unit = with_conductance(Gas::Span, Some(exponent), None, reference["p_pa"], reference["t_k"]);
        let conductance = unit.gas_masses_kg().0 * reference["cv_j_per_kg_k"] / TAU_S;
        let mut moved = 0.0_f64;
        for (row, implied) in implied_conductances(&unit, &grid) {
            let expected = conductance * (row["cv_j_per_kg_k"] / reference["cv_j_per_kg_k"]).powf(1.0 - exponent);
            // The core's c_v within 1e-4 of CoolProp's, raised to 1 - n.
            let tolerance = 2e-4 * (1.0 - exponent).abs().max(1.0);
            assert!((implied / expected - 1.0).abs() < tolerance, "n = {exponent}, {row:?}: hA {implied} vs {expected}");
            moved = moved.max((expected / conductance - 1.0).abs());
        }
        // The rows move the conductance by more than the tolerance.
        assert!(moved > 10.0 * 2e-4, "n = {exponent}: moved by {moved}");
    }
}
