//! Lateral dynamics: the linear single-track ("bicycle") model with any
//! number of axles.
//!
//! Speed and steering in, lateral acceleration out. Each axle `i` at `x_i`
//! ahead of the centre of gravity, steered by `ratio_i` times the front
//! road-wheel angle `delta`, with cornering stiffness `C_i` (both tyres):
//!
//! ```text
//! alpha_i = ratio_i delta - (v + x_i r) / u          slip angle
//! F_i     = C_i alpha_i                              lateral force
//! m (v' + u r) = sum F_i,    I_z r' = sum x_i F_i,    a_y = v' + u r
//! ```
//!
//! with `u` the speed, `v` the lateral velocity, `r` the yaw rate (left
//! positive). Linear tyres: valid while the tyres are far from saturation,
//! which for a heavy vehicle means below about 0.4-0.5 g; the vehicle
//! reports the lateral acceleration so callers can flag runs beyond that.
//! Below [`MIN_SPEED_M_S`] the model is singular (slip angles divide by the
//! speed): the lateral velocity and yaw rate then decay with
//! [`LOW_SPEED_TAU_S`], which is what a vehicle crawling straight does.

/// Below this speed the lateral states decay instead (see the module docs), m/s.
pub const MIN_SPEED_M_S: f64 = 0.5;
/// Decay time constant of the lateral states below [`MIN_SPEED_M_S`], s.
pub const LOW_SPEED_TAU_S: f64 = 0.1;

/// One axle as the single-track model sees it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HandlingAxle {
    /// Position ahead of the centre of gravity, m.
    pub x_m: f64,
    /// Cornering stiffness of the axle (both tyres), N/rad.
    pub cornering_stiffness_n_per_rad: f64,
    /// Road-wheel angle per unit of the front axle's road-wheel angle.
    pub steer_ratio: f64,
}

/// The lateral states.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HandlingState {
    /// Lateral velocity of the centre of gravity in vehicle axes, m/s (left positive).
    pub lat_vel_m_s: f64,
    /// Yaw rate, rad/s (left turn positive).
    pub yaw_rate_rad_s: f64,
}

/// The lateral state rates and the lateral acceleration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HandlingRate {
    pub lat_vel_m_s2: f64,
    pub yaw_acc_rad_s2: f64,
    /// Lateral acceleration of the centre of gravity, m/s^2 (left positive).
    pub lat_acc_m_s2: f64,
}

/// The rates of the single-track model of `axles` with total `mass_kg` and
/// yaw inertia `yaw_inertia_kg_m2` at `speed_m_s` and front road-wheel
/// angle `steer_rad`.
///
/// ```
/// use hp_vehicle::handling::{rate, HandlingAxle, HandlingState};
/// // A neutral-steer two-axle car in a steady turn: r = u delta / L,
/// // lateral velocity v = (C delta - m u r) u / (2 C), a_y = u r.
/// let (c, m) = (1.0e5, 2000.0);
/// let axles = [
///     HandlingAxle { x_m: 1.5, cornering_stiffness_n_per_rad: c, steer_ratio: 1.0 },
///     HandlingAxle { x_m: -1.5, cornering_stiffness_n_per_rad: c, steer_ratio: 0.0 },
/// ];
/// let (u, delta, length) = (20.0, 0.01, 3.0);
/// let r = u * delta / length;
/// let steady = HandlingState { lat_vel_m_s: (c * delta - m * u * r) * u / (2.0 * c), yaw_rate_rad_s: r };
/// let r = rate(&axles, m, 3000.0, u, delta, &steady);
/// assert!(r.lat_vel_m_s2.abs() < 1e-9 && r.yaw_acc_rad_s2.abs() < 1e-9);
/// assert!((r.lat_acc_m_s2 - u * u * delta / length).abs() < 1e-9);
/// ```
#[inline]
pub fn rate(axles: &[HandlingAxle], mass_kg: f64, yaw_inertia_kg_m2: f64, speed_m_s: f64, steer_rad: f64, s: &HandlingState) -> HandlingRate {
    let u = speed_m_s;
    if !(u.abs() >= MIN_SPEED_M_S) {
        let lat_vel_m_s2 = -s.lat_vel_m_s / LOW_SPEED_TAU_S;
        return HandlingRate {
            lat_vel_m_s2,
            yaw_acc_rad_s2: -s.yaw_rate_rad_s / LOW_SPEED_TAU_S,
            lat_acc_m_s2: lat_vel_m_s2 + u * s.yaw_rate_rad_s,
        };
    }
    let (mut force, mut moment) = (0.0, 0.0);
    for a in axles {
        let alpha = a.steer_ratio * steer_rad - (s.lat_vel_m_s + a.x_m * s.yaw_rate_rad_s) / u;
        let f = a.cornering_stiffness_n_per_rad * alpha;
        force += f;
        moment += a.x_m * f;
    }
    let lat_acc = force / mass_kg;
    HandlingRate { lat_vel_m_s2: lat_acc - u * s.yaw_rate_rad_s, yaw_acc_rad_s2: moment / yaw_inertia_kg_m2, lat_acc_m_s2: lat_acc }
}
