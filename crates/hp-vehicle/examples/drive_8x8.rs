//! Drives the 8x8 for a few seconds on a rough road (for profiling:
//! `perf stat` / `valgrind --tool=callgrind`), passive or semi-active, on
//! the default plant (ROS2 steps, tabulated gas) or the reference one (RK4
//! steps, the gas evaluated directly).
//!
//!     cargo run -p hp-vehicle --release --example drive_8x8 -- [passive|semi] [seconds] [fast|reference] [8x8|4x4]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
use hp_core::unit::Valves;
use hp_ctrl::{Params, State};
use hp_vehicle::closed_loop::Sensors;
use hp_vehicle::drive::{run, Driver, Suspension};
use hp_vehicle::presets;
use hp_vehicle::track::{Road, Track};
use hp_vehicle::vehicle::{Stepping, Vehicle, MAX_CORNERS};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let semi = args.get(1).is_some_and(|a| a == "semi");
    let seconds: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let n = (seconds * 12.0 / 0.02) as usize + 2000;
    let h: Vec<f64> = (0..n).map(|k| 0.02 * (0.5 * k as f64 * 0.02).sin() * (k as f64 / 1000.0).min(1.0)).collect();
    let road = Road { left: Track { start_m: -10.0, dx_m: 0.02, height_m: &h }, right: Track { start_m: -10.0, dx_m: 0.02, height_m: &h } };
    let p = if args.get(4).is_some_and(|a| a == "4x4") { presets::armoured_4x4() } else { presets::armoured_8x8() };
    let ctrl = Params::new(presets::controller_config(&p)).unwrap();
    let s = if semi { Suspension::SemiActive(&ctrl) } else { Suspension::Passive(Valves::from_modes(false, true)) };
    let reference = args.get(3).is_some_and(|a| a == "reference");
    let mut v = Vehicle::new(p, 293.15, s.initial_valves()).unwrap();
    if reference {
        v = v.with_direct_gas().with_stepping(Stepping::Rk4);
    }
    let mut states = [State::new(); MAX_CORNERS];
    let mut sum = 0.0;
    let start = std::time::Instant::now();
    run(&v, &road, s, &Sensors::default(), &mut states, (seconds * 1000.0) as usize, 1e-3, 1e-3, |_, _| Driver { speed_m_s: 12.0, ..Driver::default() }, |q| {
        sum += q.sample.body.heave_m;
        true
    })
    .unwrap();
    let el = start.elapsed().as_secs_f64();
    println!("{seconds} s simulated in {el:.3} s: {:.0} x real time (checksum {sum:e})", seconds / el);
}
