//! Shared helpers of the vehicle tests.
#![allow(dead_code, clippy::unwrap_used, clippy::indexing_slicing)]

use hp_core::damper::{Damper, DamperCurve};
use hp_core::thermal::HeatTransfer;
use hp_core::unit::{Unit, UnitParams, Valves};

/// The seed's unit with isothermal gas and a damper of almost no
/// resistance: a conservative, linearisable spring whose static rate is
/// also its dynamic one.
pub fn spring_only_unit() -> UnitParams {
    let mut p = hp_core::presets::seed_unit();
    p.heat = HeatTransfer::Isothermal;
    let weak = DamperCurve::from_strut(p.piston_area_m2, 20.0, 0.0, 1e6, 20.0);
    p.damper = Damper { on_compression: weak, on_rebound: weak, off_compression: weak, off_rebound: weak };
    p
}

/// The static (isothermal) rate of a unit at compression `disp_m`, N/m, by
/// a central difference of its static force.
pub fn static_rate_n_per_m(unit: &Unit, disp_m: f64, t_k: f64, valves: Valves) -> f64 {
    let h = 1e-5;
    (unit.static_force_n(disp_m + h, t_k, valves).unwrap() - unit.static_force_n(disp_m - h, t_k, valves).unwrap()) / (2.0 * h)
}

/// Frequency of the largest peak of `x` (sampled at `dt_s`) between
/// `lo_hz` and `hi_hz`: a Hann-windowed DFT on a 10 mHz grid, refined to
/// 0.1 mHz around the best bin.
pub fn peak_frequency_hz(x: &[f64], dt_s: f64, lo_hz: f64, hi_hz: f64) -> f64 {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let w: Vec<f64> = (0..n)
        .map(|k| (x[k] - mean) * 0.5 * (1.0 - (2.0 * std::f64::consts::PI * k as f64 / (n - 1) as f64).cos()))
        .collect();
    let power = |f: f64| {
        let (mut re, mut im) = (0.0, 0.0);
        let dphi = 2.0 * std::f64::consts::PI * f * dt_s;
        for (k, v) in w.iter().enumerate() {
            let phi = dphi * k as f64;
            re += v * phi.cos();
            im += v * phi.sin();
        }
        re * re + im * im
    };
    let scan = |lo: f64, hi: f64, step: f64| {
        let mut best = (f64::NEG_INFINITY, lo);
        let mut f = lo;
        while f <= hi {
            let p = power(f);
            if p > best.0 {
                best = (p, f);
            }
            f += step;
        }
        best.1
    };
    let coarse = scan(lo_hz, hi_hz, 0.01);
    scan(coarse - 0.01, coarse + 0.01, 1e-4)
}
