//! The stepping test's rough road, shared with the example that prints
//! its figures (`examples/rough_road_errors.rs`, by `#[path]`).

/// A rough two-track road (sum of sines, class D-like amplitudes, faded in
/// over 5 m), 2 cm grid.
pub fn rough() -> (Vec<f64>, Vec<f64>) {
    let track = |phase: f64| -> Vec<f64> {
        (0..4000)
            .map(|k| {
                let x = k as f64 * 0.02;
                let fade = (x / 5.0).min(1.0);
                fade * (0.03 * (0.5 * x + phase).sin() + 0.01 * (2.1 * x + 2.0 * phase).sin() + 0.004 * (7.3 * x + phase).sin())
            })
            .collect()
    };
    (track(0.0), track(1.3))
}
