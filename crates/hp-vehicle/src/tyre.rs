//! The tyre as a radial spring and damper at a point contact that can lift
//! off the road.
//!
//! The force is `k d + c d'` for a deflection `d > 0` (compression of the
//! tyre), never negative: a tyre pushes on the road, it cannot pull. With
//! `d <= 0` the wheel is off the ground and the force is zero. Point
//! contact: the tyre's enveloping of short obstacles is left to the road
//! (the Python side filters a profile over the contact length).

use hp_core::error::{check_range, Result};

/// Radial stiffness and damping of one tyre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tyre {
    /// Radial stiffness, N/m.
    pub stiffness_n_per_m: f64,
    /// Radial damping, N s/m.
    pub damping_n_s_per_m: f64,
}

impl Tyre {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        check_range("tyre_stiffness_n_per_m", self.stiffness_n_per_m, 1e3, 1e9)?;
        check_range("tyre_damping_n_s_per_m", self.damping_n_s_per_m, 0.0, 1e7)?;
        Ok(())
    }

    /// Vertical force of the road on the tyre, N (>= 0), at deflection
    /// `deflection_m` (positive = compressed) and its rate.
    ///
    /// ```
    /// use hp_vehicle::tyre::Tyre;
    /// let t = Tyre { stiffness_n_per_m: 1.0e6, damping_n_s_per_m: 2.0e3 };
    /// assert_eq!(t.force_n(0.01, 0.0), 1.0e4);
    /// assert_eq!(t.force_n(-0.001, -1.0), 0.0); // off the ground
    /// assert_eq!(t.force_n(0.001, -1.0), 0.0);  // the damper cannot pull it down
    /// ```
    #[inline]
    pub fn force_n(&self, deflection_m: f64, rate_m_s: f64) -> f64 {
        if deflection_m > 0.0 {
            (self.stiffness_n_per_m * deflection_m + self.damping_n_s_per_m * rate_m_s).max(0.0)
        } else {
            0.0
        }
    }
}
