//! The 8x8's default plant (ROS2, one step per 1 ms period) against RK4 on
//! the rough road of `tests/stepping.rs`, for the four passive settings:
//! the displacement difference after 1 s (what the test bounds), the
//! largest over the run, and the largest against RK4 at 0.125 ms (the
//! integrator's error alone); RK4 at 1 ms's own. BENCHMARKS.md's figures.
//!
//!     cargo run -p hp-vehicle --release --example rough_road_errors
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]
use hp_core::unit::Valves;
use hp_vehicle::presets;
use hp_vehicle::track::{Road, Track};
use hp_vehicle::vehicle::{DriveInputs, StepMemory, Stepping, Vehicle, VehicleState, BODY_STATES, CORNER_STATES, MAX_CORNERS};

#[path = "../tests/common/rough_road.rs"]
mod rough_road;
use rough_road::rough;

/// Every period's state over 1 s at 12 m/s with the test's steering.
fn run(vehicle: &Vehicle, road: &Road<'_>, valves: Valves, max_dt: f64) -> Vec<VehicleState> {
    let v = [valves; MAX_CORNERS];
    let mut x = vehicle.initial_state(&v).unwrap();
    // As the drive loop steps: ROS2 keeps its W over a few steps.
    let mut memory = StepMemory::new();
    (0..1000)
        .map(|k| {
            let t = k as f64 * 1e-3;
            let inputs = DriveInputs { speed_m_s: 12.0, long_acc_m_s2: 0.0, steer_angle_rad: 0.5 * (1.5 * t).sin() };
            let d = vehicle.dynamics(road, inputs, v);
            let rate = d.rate_for(t, &x, None, &memory).unwrap();
            x = d.advance_with(t, t + 1e-3, &x, &rate, max_dt, &mut memory).unwrap();
            x
        })
        .collect()
}

/// Largest difference in the body's heave, pitch, roll and the wheels' displacements.
fn distance(a: &VehicleState, b: &VehicleState) -> f64 {
    let wheels = (0..MAX_CORNERS).map(|c| BODY_STATES + c * CORNER_STATES + CORNER_STATES - 2);
    [0usize, 2, 4].into_iter().chain(wheels).map(|i| (a.y[i] - b.y[i]).abs()).fold(0.0, f64::max)
}

fn largest(a: &[VehicleState], b: &[VehicleState]) -> f64 {
    a.iter().zip(b).map(|(x, y)| distance(x, y)).fold(0.0, f64::max)
}

fn main() {
    let (l, r) = rough();
    let road = Road { left: Track { start_m: -1.0, dx_m: 0.02, height_m: &l }, right: Track { start_m: -1.0, dx_m: 0.02, height_m: &r } };
    println!("um: ROS2 at 1 ms against RK4 at 1 ms (direct gas) after 1 s / largest over the run / largest against RK4 at 0.125 ms; RK4 at 1 ms against 0.125 ms");
    for (spring_hard, damper_on) in [(false, true), (true, true), (false, false), (true, false)] {
        let valves = Valves::from_modes(spring_hard, damper_on);
        let fast = Vehicle::new(presets::armoured_8x8(), 293.15, valves).unwrap();
        let ros2 = run(&fast, &road, valves, 1e-3);
        let rk4 = run(&fast.with_direct_gas().with_stepping(Stepping::Rk4), &road, valves, 1e-3);
        let fine = run(&fast.with_stepping(Stepping::Rk4), &road, valves, 1.25e-4);
        let end = distance(&ros2[999], &rk4[999]);
        let um = 1e6;
        println!(
            "spring {}, damper {}: {:.2} / {:.2} / {:.2}; RK4 {:.2}",
            if spring_hard { "hard" } else { "soft" },
            if damper_on { "on" } else { "off" },
            end * um,
            largest(&ros2, &rk4) * um,
            largest(&ros2, &fine) * um,
            largest(&rk4, &fine) * um,
        );
    }
}
