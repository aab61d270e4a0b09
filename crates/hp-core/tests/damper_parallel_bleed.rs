//! The damper curve's bleed in parallel with the orifice: the flows of the
//! two passages add at one pressure drop (checked against that definition,
//! not against the curve's own closed form), the curve stays monotone with
//! the knee and the second stage, its slope and inverse are exact, and no
//! parallel bleed is the series curve bit for bit.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use hp_core::damper::DamperCurve;

/// The nominal curve of the knee tests (R = 3e9 Pa s/m^3) with a parallel
/// conductance `g`.
fn curve(g: f64, knee: f64) -> DamperCurve {
    let mut c = DamperCurve::from_strut(2e-3, 12_000.0, 64_000.0, 7_000.0, 16_000.0);
    c.bleed_parallel_m3_per_s_pa = g;
    c.blowoff_knee = knee;
    c
}

fn flows() -> impl Iterator<Item = f64> {
    (0..=400).map(|i| 1e-8 * libm::pow(10.0, f64::from(i) * 6.0 / 400.0))
}

/// The series passage's flow at a pressure drop, by bisection on its own
/// definition `R y + K y^2 = dp` (no shared closed form).
fn series_flow(r: f64, k: f64, dp: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid * (r + k * mid) < dp {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn below_blowoff_the_passages_flows_add_at_one_pressure_drop() {
    for g in [1e-12, 1e-10, 3e-10, 1e-8] {
        let c = curve(g, 0.0);
        for dp in [1.0, 1e3, 1e5, 1e6, 3e6, 0.999 * c.blowoff_pa] {
            let expected = g * dp + series_flow(c.bleed_pa_s_per_m3, c.orifice_pa_s2_per_m6, dp);
            let q = c.flow_m3_s(dp);
            assert!((q - expected).abs() <= 1e-10 * expected, "G {g}, dp {dp}: {q} against {expected}");
            let back = c.pressure_drop_pa(expected);
            assert!((back - dp).abs() <= 1e-9 * dp, "G {g}: {back} against {dp}");
        }
        // Above the (sharp) blow-off: the blow-off slope from the knee's
        // flow, which the parallel bleed moves to G p_b + y(p_b).
        let q_b = g * c.blowoff_pa + series_flow(c.bleed_pa_s_per_m3, c.orifice_pa_s2_per_m6, c.blowoff_pa);
        let q = 2.0 * q_b;
        let expected = c.blowoff_pa + c.blowoff_slope_pa_s_per_m3 * (q - q_b);
        assert!((c.pressure_drop_pa(q) - expected).abs() <= 1e-9 * expected, "G {g}");
    }
}

#[test]
fn at_no_flow_the_slope_is_the_two_laminar_paths_in_parallel() {
    let g = 2e-10;
    let c = curve(g, 0.5);
    let slope = c.pressure_drop_slope_pa_s_per_m3(0.0);
    let expected = 1.0 / (1.0 / c.bleed_pa_s_per_m3 + g);
    assert!((slope - expected).abs() <= 1e-12 * expected, "{slope} against {expected}");
    // Two passages pass more than either alone: below the blow-off the
    // drop lies under the series curve and under the bleed's line q / G.
    let (series, sharp) = (curve(0.0, 0.0), curve(g, 0.0));
    for q in flows().filter(|&q| q < 0.9 * sharp.flow_m3_s(sharp.blowoff_pa)) {
        let dp = sharp.pressure_drop_pa(q);
        assert!(dp < series.pressure_drop_pa(q) && dp < q / g, "q {q}");
    }
}

#[test]
fn with_a_parallel_bleed_the_curve_is_monotone_its_slope_exact_and_its_inverse_exact() {
    for g in [1e-11, 3e-10, 1e-8] {
        for knee in [0.0, 0.3, 2.0] {
            for stage2 in [false, true] {
                let mut c = curve(g, knee);
                if stage2 {
                    c.blowoff2_pa = 2.0 * c.blowoff_pa;
                    c.blowoff2_slope_pa_s_per_m3 = 0.3 * c.blowoff_slope_pa_s_per_m3;
                }
                c.validate().unwrap();
                assert_eq!(c.pressure_drop_pa(0.0), 0.0);
                assert_eq!(c.flow_m3_s(0.0), 0.0);
                let mut last = 0.0;
                for q in flows() {
                    let dp = c.pressure_drop_pa(q);
                    assert!(dp > last, "G {g} knee {knee} stage2 {stage2}: not increasing at q = {q}");
                    last = dp;
                    let back = c.flow_m3_s(dp);
                    assert!((back - q).abs() <= 1e-9 * q, "G {g} knee {knee} stage2 {stage2}: inverse {back} at {q}");
                    // The slope against a central difference (step 1e-6 q).
                    let h = 1e-6 * q;
                    let fd = (c.pressure_drop_pa(q + h) - c.pressure_drop_pa(q - h)) / (2.0 * h);
                    let slope = c.pressure_drop_slope_pa_s_per_m3(q);
                    assert!((slope - fd).abs() <= 1e-5 * slope, "G {g} knee {knee} stage2 {stage2}: slope {slope} against {fd} at {q}");
                }
            }
        }
    }
}

#[test]
fn no_parallel_bleed_is_the_series_curve_and_a_bad_one_is_refused() {
    let c = curve(0.0, 0.0);
    for q in flows() {
        let dp = c.pressure_drop_pa(q);
        let q_b = c.flow_m3_s(c.blowoff_pa);
        let series = if q <= q_b { q * (c.bleed_pa_s_per_m3 + c.orifice_pa_s2_per_m6 * q) } else { c.blowoff_pa + c.blowoff_slope_pa_s_per_m3 * (q - q_b) };
        assert_eq!(dp.to_bits(), series.to_bits(), "q {q}");
    }
    for bad in [-1e-12, f64::NAN, f64::INFINITY, 1.0] {
        let mut c = curve(0.0, 0.0);
        c.bleed_parallel_m3_per_s_pa = bad;
        let err = c.validate().unwrap_err();
        assert!(format!("{err}").contains("bleed_parallel_m3_per_s_pa"), "{err}");
    }
}
