//! A road track: height over distance on a uniform grid.
//!
//! The vehicle reads the road under each wheel at its own distance (so the
//! rear axles see what the front saw, delayed by the wheelbase over the
//! speed) and needs its height and slope at any point an integrator stage
//! asks for. A uniform grid makes the look-up O(1); the curve between the
//! points is a C1 cubic Hermite curve with Catmull-Rom tangents (the same
//! interpolation as `hp_core::motion::Motion::Sampled`), so the road's
//! vertical velocity under a wheel, slope times speed, is continuous.
//! Before the first point and after the last the road is flat at the end
//! height.

use hp_core::error::{check_range, Error, Result};

/// Road height `height_m[k]` at distance `start_m + k dx_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Track<'a> {
    /// Distance of the first point, m.
    pub start_m: f64,
    /// Spacing of the points, m.
    pub dx_m: f64,
    /// Heights, m (positive = up).
    pub height_m: &'a [f64],
}

impl Track<'_> {
    /// A flat track (no points: height zero everywhere).
    pub const FLAT: Track<'static> = Track { start_m: 0.0, dx_m: 1.0, height_m: &[] };

    /// Checks the grid and that every height is finite and within +-10 m.
    pub fn validate(&self) -> Result<()> {
        check_range("track_start_m", self.start_m, -1e7, 1e7)?;
        check_range("track_dx_m", self.dx_m, 1e-4, 100.0)?;
        check_range("track_points", self.height_m.len() as f64, 0.0, 1e9)?;
        for &h in self.height_m {
            if !(h.is_finite() && h.abs() <= 10.0) {
                return Err(Error::OutOfRange { name: "track_height_m", value: h, min: -10.0, max: 10.0 });
            }
        }
        Ok(())
    }

    /// Height (m) and slope (m/m) at distance `x_m`.
    ///
    /// ```
    /// use hp_vehicle::track::Track;
    /// let h = [0.0, 0.1, 0.2, 0.3];
    /// let t = Track { start_m: 0.0, dx_m: 0.5, height_m: &h };
    /// let (z, slope) = t.at(0.75);
    /// assert!((z - 0.15).abs() < 1e-12 && (slope - 0.2).abs() < 1e-12);
    /// assert_eq!(t.at(5.0), (0.3, 0.0)); // flat beyond the last point
    /// ```
    #[inline(always)]
    pub fn at(&self, x_m: f64) -> (f64, f64) {
        let h = self.height_m;
        let u_all = (x_m - self.start_m) / self.dx_m;
        if u_all >= 1.0 {
            // Inside: the four points around the interval (the fast path).
            // The interval through i64, not usize (one instruction per
            // conversion on x86-64 instead of about a dozen): for u_all >= 1
            // the truncation is the floor, and (saturating) i < n - 2
            // exactly when u_all < n - 2.
            let i = u_all as i64;
            if i < (h.len() as i64).saturating_sub(2) {
                let j = i as usize; // 1 <= i < n - 2
                if let Some(&[a, x0, x1, d]) = h.get(j - 1..j + 3).and_then(|w| w.first_chunk::<4>()) {
                    return hermite(x0, x1, 0.5 * (x1 - a), 0.5 * (d - x0), u_all - i as f64, self.dx_m);
                }
            }
        }
        self.at_edge(u_all)
    }

    /// [`Track::at`] near and beyond the ends.
    #[cold]
    fn at_edge(&self, u_all: f64) -> (f64, f64) {
        let h = self.height_m;
        let n = h.len();
        let (Some(&first), Some(&last)) = (h.first(), h.last()) else {
            return (0.0, 0.0);
        };
        if !(u_all > 0.0) || n < 2 {
            return (first, 0.0);
        }
        if u_all >= (n - 1) as f64 {
            return (last, 0.0);
        }
        let i = (u_all as usize).min(n - 2);
        let at = |j: usize| h.get(j).copied().unwrap_or(0.0);
        let (x0, x1) = (at(i), at(i + 1));
        // Catmull-Rom tangents per grid step; one-sided at the ends.
        let m0 = if i == 0 { x1 - x0 } else { 0.5 * (x1 - at(i - 1)) };
        let m1 = if i + 2 >= n { x1 - x0 } else { 0.5 * (at(i + 2) - x0) };
        hermite(x0, x1, m0, m1, u_all - i as f64, self.dx_m)
    }
}

/// The cubic Hermite curve from `x0` to `x1` with tangents `m0`, `m1` (per
/// grid step) at `u` in [0, 1]: height and slope per metre. In the power
/// basis (Horner's rule: a quarter of the basis functions' arithmetic, on
/// the hot path of every wheel's every stage).
#[inline]
fn hermite(x0: f64, x1: f64, m0: f64, m1: f64, u: f64, dx_m: f64) -> (f64, f64) {
    let rise = x1 - x0;
    let c2 = 3.0 * rise - 2.0 * m0 - m1;
    let c3 = m0 + m1 - 2.0 * rise;
    let z = x0 + u * (m0 + u * (c2 + u * c3));
    let dz_du = m0 + u * (2.0 * c2 + u * 3.0 * c3);
    (z, dz_du / dx_m)
}

/// The two wheel tracks of a road, left and right (as seen driving along it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Road<'a> {
    pub left: Track<'a>,
    pub right: Track<'a>,
}

impl Road<'_> {
    /// A flat road.
    pub const FLAT: Road<'static> = Road { left: Track::FLAT, right: Track::FLAT };

    /// Checks both tracks.
    pub fn validate(&self) -> Result<()> {
        self.left.validate()?;
        self.right.validate()
    }
}
