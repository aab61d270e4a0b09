//! The full vehicle against what it was not written from: statics, the
//! steady roll and pitch of its linearised springs in series with the tyres
//! (with the roll axis and the geometric load transfer worked out by hand),
//! the wheelbase delay, which way it rolls, and the steady turn of the
//! single-track model against the understeer-gradient formula.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use hp_core::unit::{Unit, Valves, STANDARD_GRAVITY_M_S2};
use hp_vehicle::handling::{rate, HandlingAxle, HandlingState};
use hp_vehicle::presets;
use hp_vehicle::track::{Road, Track};
use hp_vehicle::vehicle::{DriveInputs, Vehicle, VehicleParams, VehicleSample, MAX_CORNERS};

const G: f64 = STANDARD_GRAVITY_M_S2;
const T_K: f64 = 293.15;

fn drive(vehicle: &Vehicle, road: &Road<'_>, valves: Valves, seconds: f64, dt: f64, inputs: impl Fn(f64) -> DriveInputs) -> Vec<VehicleSample> {
    let v = [valves; MAX_CORNERS];
    let mut x = vehicle.initial_state(&v).unwrap();
    let mut out = Vec::new();
    for k in 0..(seconds / dt) as usize {
        let t = k as f64 * dt;
        let d = vehicle.dynamics(road, inputs(t), v);
        let mut s = VehicleSample::default();
        let rate = d.rate_and_sample(t, &x, &mut s).unwrap();
        out.push(s);
        x = d.advance(t, t + dt, &x, &rate, dt).unwrap();
    }
    out
}

fn both() -> [(&'static str, VehicleParams); 2] {
    [("4x4", presets::armoured_4x4()), ("8x8", presets::armoured_8x8())]
}

#[test]
fn at_rest_the_tyres_carry_the_weight_and_nothing_moves() {
    for (name, p) in both() {
        for valves in [Valves::from_modes(true, true), Valves::from_modes(false, false)] {
            // The statics are solved with the gas's equation; the default
            // plant's table of it (1.3e-8 in pressure) moves the equilibrium
            // by about a nanometre, so the exact check runs on the direct gas.
            let tabulated = Vehicle::new(p, T_K, valves).unwrap();
            let s = drive(&tabulated, &Road::FLAT, valves, 2.0, 1e-3, |_| DriveInputs { speed_m_s: 10.0, ..DriveInputs::default() });
            let b = s.last().unwrap().body;
            assert!(b.heave_m.abs() < 1e-8 && b.pitch_rad.abs() < 1e-9 && b.roll_rad.abs() < 1e-9, "{name}, tabulated gas: {b:?}");
            let v = tabulated.with_direct_gas();
            let s = drive(&v, &Road::FLAT, valves, 2.0, 1e-3, |_| DriveInputs { speed_m_s: 10.0, ..DriveInputs::default() });
            let last = s.last().unwrap();
            let b = last.body;
            assert!(b.heave_m.abs() < 1e-9 && b.pitch_rad.abs() < 1e-9 && b.roll_rad.abs() < 1e-9, "{name}: {b:?}");
            let tyres: f64 = last.corners[..last.corner_count].iter().map(|c| c.forces.tyre_force_n).sum();
            let weight = v.total_mass_kg() * G;
            assert!((tyres / weight - 1.0).abs() < 1e-9, "{name}: tyres {tyres} N, weight {weight} N");
            assert!((last.distance_m - 10.0 * last.time_s).abs() < 1e-9);
        }
    }
}

/// Static rate of the (soft) unit at the preset's static position, in series with the tyre.
fn wheel_rate_n_per_m(v: &Vehicle, valves: Valves) -> f64 {
    let unit: &Unit = v.unit(0).unwrap();
    let k_s = common::static_rate_n_per_m(unit, v.corners()[0].static_disp_m, T_K, valves);
    let k_t = presets::TYRE.stiffness_n_per_m;
    1.0 / (1.0 / k_s + 1.0 / k_t)
}

#[test]
fn steady_roll_in_a_turn_is_the_linear_roll_stiffness_s() {
    // Steady turn at about 1 m/s^2: each wheel station is the strut's static
    // rate in series with the tyre's; the roll axis carries the sprung
    // mass's lateral inertia above it (with its weight shifting), the links
    // carry the rest to the tyres. By hand, with k the series rate,
    //   phi = a_y (m_s h + (k/k_t) sum_axles (m_axle h_rc + 2 m_u r)) / (k sum y^2 - m_s g h)
    // (h = h_cg - h_rc). After 20 s the gas has settled to the wall
    // temperature, so the static rate is the one that holds.
    for (name, p) in both() {
        for valves in [Valves::from_modes(false, true), Valves::from_modes(true, true)] {
            let v = Vehicle::new(p, T_K, valves).unwrap();
            let steer = 0.04 * p.steering_ratio * presets::effective_wheelbase_m(&p) / 15.0_f64.powi(2) * 15.0;
            let s = drive(&v, &Road::FLAT, valves, 20.0, 2e-3, |_| DriveInputs { speed_m_s: 15.0, long_acc_m_s2: 0.0, steer_angle_rad: steer });
            let last = s.last().unwrap();
            let a_y = last.lat_acc_m_s2;
            assert!(a_y > 0.5 && a_y < 2.0, "{name}: a_y {a_y}");
            let k = wheel_rate_n_per_m(&v, valves);
            let b = p.body;
            let h = b.cg_height_m - b.roll_centre_height_m;
            let axles = &p.axles[..p.axle_count];
            let sum_y2: f64 = axles.iter().map(|a| 2.0 * (0.5 * a.track_m).powi(2)).sum();
            let m_axle = b.mass_kg / p.axle_count as f64;
            let links: f64 = axles.iter().map(|a| m_axle * b.roll_centre_height_m + 2.0 * a.unsprung_mass_kg * a.wheel_radius_m).sum();
            let phi = a_y * (b.mass_kg * h + k / presets::TYRE.stiffness_n_per_m * links) / (k * sum_y2 - b.mass_kg * G * h);
            let got = last.body.roll_rad;
            assert!((got / phi - 1.0).abs() < 0.03, "{name} {valves:?}: roll {got} rad, linear {phi} rad");
            assert!(got > 0.0, "a left turn rolls the left side up");
        }
    }
}

#[test]
fn steady_braking_pitches_the_nose_down_by_the_linear_pitch_stiffness() {
    // theta = -m_s a_x h_cg / (k sum x^2), no anti-dive geometry.
    for (name, p) in both() {
        let valves = Valves::from_modes(false, true);
        let v = Vehicle::new(p, T_K, valves).unwrap();
        let a_x = -2.0;
        let s = drive(&v, &Road::FLAT, valves, 20.0, 2e-3, |_| DriveInputs { speed_m_s: 10.0, long_acc_m_s2: a_x, steer_angle_rad: 0.0 });
        let k = wheel_rate_n_per_m(&v, valves);
        let sum_x2: f64 = p.axles[..p.axle_count].iter().map(|a| 2.0 * a.x_m * a.x_m).sum();
        let theta = -p.body.mass_kg * a_x * p.body.cg_height_m / (k * sum_x2);
        let got = s.last().unwrap().body.pitch_rad;
        assert!((got / theta - 1.0).abs() < 0.03, "{name}: pitch {got} rad, linear {theta} rad");
    }
}

/// A 4 cm, 0.5 m long cosine bump at 5 m on the given tracks (2 cm grid).
fn bump(on: bool) -> Vec<f64> {
    (0..1000)
        .map(|k| {
            let x = k as f64 * 0.02;
            if on && (x - 5.0).abs() < 0.25 {
                0.02 * (1.0 + (2.0 * std::f64::consts::PI * (x - 5.0) / 0.5).cos())
            } else {
                0.0
            }
        })
        .collect()
}

#[test]
fn the_rear_wheels_meet_the_bump_one_wheelbase_later() {
    let (left, right) = (bump(true), bump(true));
    let road = Road { left: Track { start_m: 0.0, dx_m: 0.02, height_m: &left }, right: Track { start_m: 0.0, dx_m: 0.02, height_m: &right } };
    for (name, p) in both() {
        let valves = Valves::from_modes(false, true);
        let v = Vehicle::new(p, T_K, valves).unwrap();
        let speed = 8.0;
        let s = drive(&v, &road, valves, 2.0, 1e-3, |_| DriveInputs { speed_m_s: speed, ..DriveInputs::default() });
        let peak = |i: usize| s.iter().max_by(|a, b| a.corners[i].road_m.total_cmp(&b.corners[i].road_m)).unwrap().time_s;
        let n = v.corner_count();
        let (front, rear) = (p.axles[0].x_m, p.axles[p.axle_count - 1].x_m);
        let delay = peak(n - 2) - peak(0);
        assert!((delay - (front - rear) / speed).abs() < 1.5e-3, "{name}: {delay} s");
        assert_eq!(peak(0), peak(1), "left and right front meet a full-width bump together");
    }
}

#[test]
fn a_bump_under_the_left_wheels_rolls_the_left_side_up() {
    let (left, right) = (bump(true), bump(false));
    let road = Road { left: Track { start_m: 0.0, dx_m: 0.02, height_m: &left }, right: Track { start_m: 0.0, dx_m: 0.02, height_m: &right } };
    let p = presets::armoured_4x4();
    let valves = Valves::from_modes(false, true);
    let v = Vehicle::new(p, T_K, valves).unwrap();
    let s = drive(&v, &road, valves, 1.5, 1e-3, |_| DriveInputs { speed_m_s: 8.0, ..DriveInputs::default() });
    // The first clear roll response, while only the front left wheel is on it.
    let first = s.iter().find(|x| x.body.roll_rad.abs() > 1e-4).unwrap();
    assert!(first.body.roll_rad > 0.0 && first.body.pitch_rad < 0.0, "{:?}", first.body);
    assert!(first.corners[0].forces.strut.disp_m > first.corners[1].forces.strut.disp_m);
}

#[test]
fn the_single_track_model_turns_as_the_understeer_gradient_says() {
    // Two axles, a = 1.2 m, b = 1.8 m, C_f < C_r: steady yaw rate
    // r = u delta / (L + K u^2), K = m (b / C_f - a / C_r) / L.
    let (a, b, c_f, c_r, m, i_z) = (1.2, 1.8, 8.0e4, 1.2e5, 1500.0, 2500.0);
    let axles = [
        HandlingAxle { x_m: a, cornering_stiffness_n_per_rad: c_f, steer_ratio: 1.0 },
        HandlingAxle { x_m: -b, cornering_stiffness_n_per_rad: c_r, steer_ratio: 0.0 },
    ];
    let length = a + b;
    let k = m * (b / c_f - a / c_r) / length;
    for u in [5.0, 15.0, 30.0] {
        let delta = 0.01;
        let mut s = HandlingState::default();
        let dt = 1e-4;
        for _ in 0..100_000 {
            let r = rate(&axles, m, i_z, u, delta, &s);
            s.lat_vel_m_s += dt * r.lat_vel_m_s2;
            s.yaw_rate_rad_s += dt * r.yaw_acc_rad_s2;
        }
        let expected = u * delta / (length + k * u * u);
        assert!((s.yaw_rate_rad_s / expected - 1.0).abs() < 1e-6, "u = {u}: r {} rad/s, expected {expected}", s.yaw_rate_rad_s);
        let a_y = rate(&axles, m, i_z, u, delta, &s).lat_acc_m_s2;
        assert!((a_y - u * expected).abs() < 1e-6 * a_y.abs());
    }
}

#[test]
fn the_vehicles_turn_steadily_as_the_single_track_model_says() {
    // The 4x4 has equal axle loads and cornering stiffnesses at equal
    // distances from the centre of gravity: neutral steer, r = u delta / L
    // at any speed. The 8x8's steady state solves, with its four axles
    // (positions x_i, steer ratios rho_i, stiffness C each),
    //   sum C (rho_i delta - (v + x_i r) / u) = m u r
    //   sum C x_i (rho_i delta - (v + x_i r) / u) = 0
    // which Cramer's rule gives in closed form. The vehicle integrates body,
    // wheels and units along, so this also checks the steering ratio and
    // the mass it hands the handling model.
    for (name, p) in both() {
        let valves = Valves::from_modes(false, true);
        let v = Vehicle::new(p, T_K, valves).unwrap();
        let (u, delta) = (12.0, 0.01);
        let s = drive(&v, &Road::FLAT, valves, 8.0, 2e-3, |_| DriveInputs {
            speed_m_s: u,
            long_acc_m_s2: 0.0,
            steer_angle_rad: delta * p.steering_ratio,
        });
        let r = s.last().unwrap().yaw_rate_rad_s;
        let axles = &p.axles[..p.axle_count];
        let c = axles[0].cornering_stiffness_n_per_rad;
        let m = v.total_mass_kg();
        let n = axles.len() as f64;
        let sx: f64 = axles.iter().map(|a| a.x_m).sum();
        let sxx: f64 = axles.iter().map(|a| a.x_m * a.x_m).sum();
        let sr: f64 = axles.iter().map(|a| a.steer_ratio).sum();
        let sxr: f64 = axles.iter().map(|a| a.x_m * a.steer_ratio).sum();
        // Unknowns (v, r): [n C/u, C sx/u + m u; C sx/u, C sxx/u] (v, r) = C delta (sr, sxr).
        let (a11, a12, a21, a22) = (n * c / u, c * sx / u + m * u, c * sx / u, c * sxx / u);
        let (b1, b2) = (c * delta * sr, c * delta * sxr);
        let expected = (a11 * b2 - a21 * b1) / (a11 * a22 - a12 * a21);
        assert!((r / expected - 1.0).abs() < 1e-4, "{name}: yaw rate {r}, steady state {expected}");
        if name == "4x4" {
            assert!((r / (u * delta / 3.5) - 1.0).abs() < 1e-4, "the 4x4 steers neutrally");
        }
    }
}

#[test]
fn a_state_that_is_not_finite_anywhere_is_refused_naming_it() {
    // Every element is checked, including the last ones (the scan runs over
    // whole 4-lane chunks and a remainder: VEHICLE_STATES is not a multiple
    // of 4) and the unused corners of a 4x4.
    use hp_core::error::Error;
    use hp_vehicle::vehicle::VEHICLE_STATES;
    let valves = Valves::from_modes(false, true);
    let vehicle = Vehicle::new(presets::armoured_4x4(), T_K, valves).unwrap();
    let x = vehicle.initial_state(&[valves; MAX_CORNERS]).unwrap();
    let d = vehicle.dynamics(&Road::FLAT, DriveInputs::default(), [valves; MAX_CORNERS]);
    assert!(d.rate(0.0, &x).is_ok());
    for i in [0, 1, 10, 11 + 18, 11 + 19, VEHICLE_STATES - 4, VEHICLE_STATES - 3, VEHICLE_STATES - 2, VEHICLE_STATES - 1] {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut y = x;
            y.y[i] = bad;
            match d.rate(0.5, &y) {
                Err(Error::StateOutOfRange { name, value, time_s, .. }) => {
                    assert_eq!(name, "vehicle_state", "element {i}");
                    assert!(!value.is_finite() && time_s == 0.5, "element {i}: {value} at {time_s}");
                }
                other => panic!("element {i} = {bad}: {other:?}"),
            }
        }
    }
}
