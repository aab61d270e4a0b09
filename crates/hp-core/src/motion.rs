//! Prescribed motions: strut displacement on the characterisation rig,
//! base (road) displacement on the single-degree-of-freedom rig.

use crate::error::{check_range, Error, Result};

/// A displacement history `x(t)` with its rate, in m and m/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion<'a> {
    /// Stay at `disp_m`.
    Hold { disp_m: f64 },
    /// `x = offset + amplitude sin(2 pi f t)`.
    Sine { amplitude_m: f64, frequency_hz: f64, offset_m: f64 },
    /// A smooth step (raised cosine) of `height_m` starting at `start_s`,
    /// reaching the new level after `rise_s`.
    Step { height_m: f64, start_s: f64, rise_s: f64 },
    /// Slow increments: `count` steps of `increment_m` up, then `count` back
    /// down, each a raised-cosine ramp of `ramp_s` followed by a dwell of
    /// `dwell_s` (so the gas settles to the wall temperature).
    Steps { increment_m: f64, count: u32, ramp_s: f64, dwell_s: f64 },
    /// Measured or generated samples, interpolated by a C1 cubic Hermite
    /// curve (Catmull-Rom tangents, valid for irregular spacing); held
    /// constant outside the samples. `time_s` must increase strictly.
    Sampled { time_s: &'a [f64], disp_m: &'a [f64] },
    /// Samples with their velocities (the curve's tangents), interpolated
    /// by the cubic Hermite curve through both: for measured data whose
    /// velocity the caller estimated to higher order than three points give.
    SampledVelocity { time_s: &'a [f64], disp_m: &'a [f64], vel_m_s: &'a [f64] },
}

/// Raised-cosine ramp from 0 to 1 over `[0, 1]` and its derivative.
fn ramp(u: f64) -> (f64, f64) {
    if u <= 0.0 {
        (0.0, 0.0)
    } else if u >= 1.0 {
        (1.0, 0.0)
    } else {
        let w = core::f64::consts::PI * u;
        (0.5 * (1.0 - libm::cos(w)), 0.5 * core::f64::consts::PI * libm::sin(w))
    }
}

impl<'a> Motion<'a> {
    /// Checks the parameters (for `Sampled`: equal lengths, at least two
    /// samples, finite values, strictly increasing time).
    pub fn validate(&self) -> Result<()> {
        match *self {
            Motion::Hold { disp_m } => check_range("disp_m", disp_m, -10.0, 10.0).map(|_| ()),
            Motion::Sine { amplitude_m, frequency_hz, offset_m } => {
                check_range("amplitude_m", amplitude_m, 0.0, 10.0)?;
                check_range("frequency_hz", frequency_hz, 0.0, 1e4)?;
                check_range("offset_m", offset_m, -10.0, 10.0).map(|_| ())
            }
            Motion::Step { height_m, start_s, rise_s } => {
                check_range("height_m", height_m, -10.0, 10.0)?;
                check_range("start_s", start_s, 0.0, 1e9)?;
                check_range("rise_s", rise_s, 1e-6, 1e6).map(|_| ())
            }
            Motion::Steps { increment_m, count, ramp_s, dwell_s } => {
                check_range("increment_m", increment_m, -10.0, 10.0)?;
                check_range("count", f64::from(count), 1.0, 1e6)?;
                check_range("ramp_s", ramp_s, 1e-6, 1e6)?;
                check_range("dwell_s", dwell_s, 0.0, 1e6).map(|_| ())
            }
            Motion::SampledVelocity { time_s, disp_m, vel_m_s } => {
                if vel_m_s.len() != time_s.len() {
                    return Err(Error::OutOfRange {
                        name: "vel_m_s.len",
                        value: vel_m_s.len() as f64,
                        min: time_s.len() as f64,
                        max: time_s.len() as f64,
                    });
                }
                for &v in vel_m_s {
                    check_range("vel_m_s", v, -1e3, 1e3)?;
                }
                Motion::Sampled { time_s, disp_m }.validate()
            }
            Motion::Sampled { time_s, disp_m } => {
                if time_s.len() != disp_m.len() {
                    return Err(Error::OutOfRange {
                        name: "disp_m.len",
                        value: disp_m.len() as f64,
                        min: time_s.len() as f64,
                        max: time_s.len() as f64,
                    });
                }
                check_range("time_s.len", time_s.len() as f64, 2.0, f64::MAX)?;
                for &x in disp_m {
                    check_range("disp_m", x, -10.0, 10.0)?;
                }
                let mut last = f64::NEG_INFINITY;
                for &t in time_s {
                    check_range("time_s", t, last, f64::MAX)?;
                    if t == last {
                        return Err(Error::OutOfRange { name: "time_s (strictly increasing)", value: t, min: last, max: f64::MAX });
                    }
                    last = t;
                }
                Ok(())
            }
        }
    }

    /// Displacement and velocity at time `t_s`.
    pub fn at(&self, t_s: f64) -> (f64, f64) {
        match *self {
            Motion::Hold { disp_m } => (disp_m, 0.0),
            Motion::Sine { amplitude_m, frequency_hz, offset_m } => {
                let w = 2.0 * core::f64::consts::PI * frequency_hz;
                (offset_m + amplitude_m * libm::sin(w * t_s), amplitude_m * w * libm::cos(w * t_s))
            }
            Motion::Step { height_m, start_s, rise_s } => {
                let (r, dr) = ramp((t_s - start_s) / rise_s);
                (height_m * r, height_m * dr / rise_s)
            }
            Motion::Steps { increment_m, count, ramp_s, dwell_s } => {
                let period = ramp_s + dwell_s;
                let n = f64::from(count);
                let k = libm::floor(t_s / period).clamp(0.0, 2.0 * n);
                let (r, dr) = ramp((t_s - k * period) / ramp_s);
                let (level, dir) = if k < n { (k, 1.0) } else { (2.0 * n - k, -1.0) };
                if k >= 2.0 * n {
                    return (0.0, 0.0);
                }
                (increment_m * (level + dir * r), increment_m * dir * dr / ramp_s)
            }
            Motion::Sampled { time_s, disp_m } => hermite(time_s, disp_m, None, t_s),
            Motion::SampledVelocity { time_s, disp_m, vel_m_s } => hermite(time_s, disp_m, Some(vel_m_s), t_s),
        }
    }

    /// The next time after `t_s` at which the motion's smoothness breaks
    /// (a ramp starts or ends, or a sample of sampled data: there the
    /// interpolating cubic changes and the velocity's slope jumps), if any.
    /// An adaptive integrator stops there, so that a step from a quiet
    /// stretch cannot jump over a ramp, and no step spans a kink: its error
    /// estimate sees a kink only in part, and the errors of many steps
    /// across sample kinks add up instead of cancelling (a gas volume
    /// integrated from a sampled velocity drifted by 1e-3 of itself over a
    /// 600 s record at rtol 1e-8; within one cubic piece the integrator is
    /// exact for the volume).
    pub fn next_breakpoint_s(&self, t_s: f64) -> Option<f64> {
        match *self {
            Motion::Sampled { time_s, .. } | Motion::SampledVelocity { time_s, .. } => next_sample_s(time_s, t_s),
            Motion::Step { start_s, rise_s, .. } => [start_s, start_s + rise_s].into_iter().find(|&b| b > t_s),
            Motion::Steps { count, ramp_s, dwell_s, .. } => {
                let period = ramp_s + dwell_s;
                let end = 2.0 * f64::from(count) * period;
                if !(t_s < end) {
                    return None;
                }
                let k = libm::floor(t_s / period).max(0.0);
                [k * period, k * period + ramp_s, (k + 1.0) * period].into_iter().find(|&b| b > t_s && b <= end)
            }
            _ => None,
        }
    }

    /// The largest step that resolves the motion at `t_s`, s: a quarter of
    /// a ramp while one runs, an eighth of a sine's period, four sample
    /// intervals of sampled data; unlimited where the motion is at rest.
    pub fn max_dt_s(&self, t_s: f64) -> f64 {
        match *self {
            Motion::Hold { .. } => f64::INFINITY,
            Motion::Sine { frequency_hz, .. } => {
                if frequency_hz > 0.0 {
                    0.125 / frequency_hz
                } else {
                    f64::INFINITY
                }
            }
            Motion::Step { start_s, rise_s, .. } => {
                if t_s >= start_s && t_s < start_s + rise_s {
                    0.25 * rise_s
                } else {
                    f64::INFINITY
                }
            }
            Motion::Steps { ramp_s, dwell_s, .. } => {
                let period = ramp_s + dwell_s;
                if t_s - libm::floor(t_s / period) * period < ramp_s {
                    0.25 * ramp_s
                } else {
                    f64::INFINITY
                }
            }
            Motion::Sampled { time_s, .. } | Motion::SampledVelocity { time_s, .. } => {
                match (time_s.first(), time_s.last()) {
                    (Some(&first), Some(&last)) if time_s.len() > 1 => 4.0 * (last - first) / (time_s.len() - 1) as f64,
                    _ => f64::INFINITY,
                }
            }
        }
    }

    /// Time at which the motion's own schedule ends (for `Steps`), if it has one.
    pub fn natural_duration_s(&self) -> Option<f64> {
        match *self {
            Motion::Steps { count, ramp_s, dwell_s, .. } => Some(2.0 * f64::from(count) * (ramp_s + dwell_s)),
            Motion::Sampled { time_s, .. } | Motion::SampledVelocity { time_s, .. } => time_s.last().copied(),
            _ => None,
        }
    }
}

/// The interval `i` with `ts[i] <= t <= ts[i+1]` of the first `n >= 1`
/// times (the last interval includes its end), for `t` within them.
/// Sampled motions are mostly uniform: the guess from the mean spacing is
/// checked and taken if right (a long drive's base is millions of samples,
/// where a bisection per evaluation missed the cache for a tenth of a
/// drive's time), else the bisection decides.
#[inline]
fn interval(ts: &[f64], n: usize, t_first: f64, t_last: f64, t: f64) -> usize {
    let last = n.saturating_sub(2);
    let is = |i: usize| {
        let below = ts.get(i).is_some_and(|&a| a <= t);
        let above = i == last || ts.get(i + 1).is_some_and(|&b| b > t);
        below && above
    };
    if t_last > t_first {
        // Truncation towards zero of a value in [0, n - 1]; NaN gives 0.
        let guess = (((t - t_first) / (t_last - t_first)) * (n - 1) as f64) as usize;
        let guess = guess.min(last);
        for i in [guess, guess.saturating_sub(1), guess + 1] {
            if i <= last && is(i) {
                return i;
            }
        }
    }
    ts.get(..n).unwrap_or(ts).partition_point(|&ti| ti <= t).saturating_sub(1).min(last)
}

/// The first of the (non-decreasing) times `ts` after `t`: from the
/// interval's guess ([`interval`]) where it is checked to hold `t`, else by
/// bisection. Asked at every step of a sampled drive: the bisection over a
/// heat run's 45,000 samples was 2 % of its runs (perf, stop 61).
fn next_sample_s(ts: &[f64], t: f64) -> Option<f64> {
    let n = ts.len();
    if let (Some(&t_first), Some(&t_last)) = (ts.first(), ts.last()) {
        if t >= t_first && t < t_last {
            let i = interval(ts, n, t_first, t_last, t);
            if let (Some(&a), Some(&b)) = (ts.get(i), ts.get(i + 1)) {
                if a <= t && b > t {
                    return Some(b);
                }
            }
        }
    }
    ts.get(ts.partition_point(|&ti| ti <= t)).copied()
}

/// Cubic Hermite interpolation, with the given tangents or else
/// Catmull-Rom (three-point) ones.
fn hermite(ts: &[f64], xs: &[f64], tangents: Option<&[f64]>, t: f64) -> (f64, f64) {
    let n = ts.len().min(xs.len());
    let (Some(&t_first), Some(&t_last)) = (ts.first(), ts.get(n.wrapping_sub(1))) else {
        return (0.0, 0.0);
    };
    if t < t_first {
        return (xs.first().copied().unwrap_or(0.0), 0.0);
    }
    if t > t_last {
        return (xs.get(n - 1).copied().unwrap_or(0.0), 0.0);
    }
    let i = interval(ts, n, t_first, t_last, t);
    let pt = |j: usize| (ts.get(j).copied().unwrap_or(0.0), xs.get(j).copied().unwrap_or(0.0));
    let (t0, x0) = pt(i);
    let (t1, x1) = pt(i + 1);
    let slope = |ta: f64, xa: f64, tb: f64, xb: f64| (xb - xa) / (tb - ta);
    let s01 = slope(t0, x0, t1, x1);
    let (m0, m1) = match tangents {
        Some(v) => (v.get(i).copied().unwrap_or(s01), v.get(i + 1).copied().unwrap_or(s01)),
        None => {
            let m0 = if i == 0 {
                s01
            } else {
                let (tm, xm) = pt(i - 1);
                slope(tm, xm, t1, x1)
            };
            let m1 = if i + 2 >= n {
                s01
            } else {
                let (tp, xp) = pt(i + 2);
                slope(t0, x0, tp, xp)
            };
            (m0, m1)
        }
    };
    let h = t1 - t0;
    let u = (t - t0) / h;
    let (u2, u3) = (u * u, u * u * u);
    let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
    let h10 = u3 - 2.0 * u2 + u;
    let h01 = -2.0 * u3 + 3.0 * u2;
    let h11 = u3 - u2;
    let x = h00 * x0 + h10 * h * m0 + h01 * x1 + h11 * h * m1;
    let dx = ((6.0 * u2 - 6.0 * u) * x0 + (3.0 * u2 - 4.0 * u + 1.0) * h * m0 + (-6.0 * u2 + 6.0 * u) * x1
        + (3.0 * u2 - 2.0 * u) * h * m1)
        / h;
    (x, dx)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    extern crate std;
    use super::{interval, next_sample_s};
    use std::vec::Vec;

    /// The bisection `interval` replaces where its guess is right.
    fn bisection(ts: &[f64], t: f64) -> usize {
        ts.partition_point(|&ti| ti <= t).saturating_sub(1).min(ts.len() - 2)
    }

    #[test]
    fn interval_agrees_with_bisection_on_uniform_and_uneven_grids() {
        let uniform: Vec<f64> = (0..1001).map(|i| 0.1 + i as f64 * 0.005).collect();
        // Uneven: spacing growing tenfold along the grid.
        let uneven: Vec<f64> = (0..1001).map(|i| { let x = i as f64 / 1000.0; 2.0 * x + 9.0 * x * x * x }).collect();
        for ts in [&uniform, &uneven] {
            let (first, last) = (ts[0], ts[ts.len() - 1]);
            let mut t = first;
            // Every node exactly (the boundary cases) and points between.
            let points = ts.iter().copied().chain((0..20_000).map(|k| first + (last - first) * k as f64 / 19_999.0)).chain([last]);
            for p in points {
                t = p;
                assert_eq!(interval(ts, ts.len(), first, last, t), bisection(ts, t), "t = {t}");
            }
            assert_eq!(interval(ts, ts.len(), first, last, t), ts.len() - 2);
        }
        // Two samples: the one interval.
        assert_eq!(interval(&[0.0, 1.0], 2, 0.0, 1.0, 0.5), 0);
    }

    #[test]
    fn next_sample_agrees_with_bisection_everywhere() {
        let uniform: Vec<f64> = (0..1001).map(|i| 0.1 + i as f64 * 0.005).collect();
        let uneven: Vec<f64> = (0..1001).map(|i| { let x = i as f64 / 1000.0; 2.0 * x + 9.0 * x * x * x }).collect();
        // Repeated times (a non-decreasing grid), and the shortest grids.
        let repeated = [0.0, 1.0, 1.0, 1.0, 2.0, 3.0, 3.0];
        for ts in [&uniform[..], &uneven[..], &repeated[..], &[0.5][..], &[][..]] {
            let (first, last) = (ts.first().copied().unwrap_or(0.0), ts.last().copied().unwrap_or(1.0));
            // Every node exactly, points between, outside and NaN.
            let points = ts.iter().copied().chain((0..20_000).map(|k| first - 1.0 + (last - first + 2.0) * k as f64 / 19_999.0)).chain([f64::NAN]);
            for t in points {
                let expected = ts.get(ts.partition_point(|&ti| ti <= t)).copied();
                assert_eq!(next_sample_s(ts, t), expected, "t = {t}");
            }
        }
    }
}
