//! Valve 6's regularised orifice against its analytic limits: turbulent
//! `Cd A sqrt(2 dp / rho)` far above the transition pressure, linear
//! (`Cd A sqrt(2/rho) dp / sqrt(dp_t)`) far below it, odd in `dp`, and the
//! slope the linearly implicit steps use equal to the flow's derivative.

use hp_core::damper::Orifice;

const RHO_OIL: f64 = 870.0;

fn seed_valve() -> Orifice {
    Orifice { flow_area_m2: 0.62 * core::f64::consts::PI * 0.005 * 0.005, transition_pa: 1.0e5 }
}

/// `ratio` is `(1 + x^2)^(-1/4) = 1 - x^2/4 + 5 x^4/32 - ...` for small
/// `x` (the next term is below `x^6`), to a few ulps.
fn near_series(ratio: f64, x: f64) -> bool {
    let x2 = x * x;
    (ratio - (1.0 - 0.25 * x2 + 5.0 / 32.0 * x2 * x2)).abs() <= x2 * x2 * x2 + 1e-15
}

#[test]
fn turbulent_far_above_the_transition() {
    let o = seed_valve();
    let c = o.coefficient(RHO_OIL);
    for dp in [1e8_f64, 3e7, 1e7] {
        let turbulent = o.flow_area_m2 * (2.0 * dp / RHO_OIL).sqrt();
        let q = o.flow_m3_s(dp, c);
        assert!(near_series(q / turbulent, o.transition_pa / dp), "{dp}: {q} vs {turbulent}");
    }
}

#[test]
fn linear_far_below_the_transition() {
    let o = seed_valve();
    let c = o.coefficient(RHO_OIL);
    for dp in [1.0_f64, 10.0, 100.0] {
        let linear = c * dp / o.transition_pa.sqrt();
        let q = o.flow_m3_s(dp, c);
        assert!(near_series(q / linear, dp / o.transition_pa), "{dp}: {q} vs {linear}");
    }
}

#[test]
fn odd_and_zero_at_no_pressure_difference() {
    let o = seed_valve();
    let c = o.coefficient(RHO_OIL);
    assert_eq!(o.flow_m3_s(0.0, c), 0.0);
    for dp in [1.0, 5e4, 1e5, 2e6, 9e7] {
        assert_eq!(o.flow_m3_s(-dp, c), -o.flow_m3_s(dp, c));
    }
}

#[test]
fn slope_is_the_derivative_of_the_flow() {
    let o = seed_valve();
    let c = o.coefficient(RHO_OIL);
    for dp in [-3e7_f64, -2e5, -1e3, 0.0, 1e3, 5e4, 1e5, 2e6, 9e7] {
        let h = 1e-4 * (dp.abs() + o.transition_pa);
        let numeric = (o.flow_m3_s(dp + h, c) - o.flow_m3_s(dp - h, c)) / (2.0 * h);
        let slope = o.flow_slope_m3_s_pa(dp, c);
        assert!((slope - numeric).abs() <= 1e-7 * slope.abs(), "{dp}: {slope} vs {numeric}");
    }
}
