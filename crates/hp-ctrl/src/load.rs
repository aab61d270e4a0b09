//! The static load pressure: the zero-offset reference of the ride height.
//!
//! At rest the gas carries the load, `p_S A = m g`, whatever valve 6 does,
//! and with valve 6 open L's gas sits at that same pressure. So the state
//! valve 6 would leave at rest in soft mode is "L's gas at the load
//! pressure", and the ride-height sequencer works relative to it (see
//! [`crate::ride_height`]). The load pressure is not a constant of the
//! unit: it changes with the payload, and the configured static pressure
//! is only the nominal one. It is estimated on line as a slow low-pass of
//! samples of `p_S` that stand for the static load.
//!
//! **Samples.** On the move `p_S` differs from the load pressure by the
//! body's acceleration and by the damper's pressure drop. A plain mean of
//! `p_S` removes the first but not the second: dampers are stronger in
//! rebound than in compression, so on a rough road the mean of `p_S` sits
//! above the load pressure (+0.29 MPa, 6 mm of ride height, for the seed
//! unit on an ISO 8608 class C road at 10 m/s). So the estimator samples
//! `p_S` only where the damper's drop vanishes, when the strut does not
//! move: at every turning point of the measured displacement (the period
//! before its change between periods reverses sign, taken one period late;
//! or a period in which it does not change, which includes rest), and
//! corrects the sample for the body's acceleration `a` (offset removed,
//! see [`crate::estimator`]): `p_S / (1 + a / g)`. In the same closed
//! loop that leaves 0.05 MPa (1 mm). No sample is taken with `|a| > g / 2`
//! or with the strut beyond its stroke (an end stop then carries part of
//! the load). The correction neglects the atmospheric part of the absolute
//! pressure (0.1 MPa times `a / g`, which averages out with `a`).
//!
//! **Filter.** Only calm, valid periods count: not in the safe state,
//! pressures, strut and body usable, and no manoeuvre that pauses
//! sequencing (the load transfer of cornering or braking is not the static
//! load). Each sample is weighted by the calm time since the previous one.
//! Before the first sample the estimate is the configured static pressure.
//! Until it has averaged `ride_height.load_pressure_tau_s` (20 s) it is the
//! time-weighted mean of all samples, so the first ones are not weighed
//! against a guessed start value; after that it is a first-order low-pass
//! with that time constant. Sequencing waits until it has averaged
//! `ride_height.load_settle_s` (5 s), see [`crate::ride_height`].
//!
//! Numerics: times count whole microseconds like every timer; the estimate
//! is kept in `f32` as the deviation from the configured static pressure,
//! so that the small increments of a long time constant (5e-5 of the
//! error per 1 ms period at 20 s) are not lost to rounding at 15 MPa: near
//! a 3 MPa deviation one `f32` step is 0.25 Pa, so the estimate settles
//! within 5 kPa (0.1 mm of ride height) of a constant pressure.

use crate::clock::seconds_to_us;
use crate::gas_table::UnitConfig;

/// Standard gravity, m/s^2.
const GRAVITY_M_S2: f32 = 9.806_65;

/// The load-pressure estimator compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadParams {
    /// The configured static pressure: start value and offset of the state.
    pub(crate) static_pressure_pa: f32,
    pub(crate) tau_us: u32,
    /// The stroke (extension end, compression end) as strut compression, m.
    pub(crate) stroke_m: (f32, f32),
}

impl LoadParams {
    /// `tau_s` is `ride_height.load_pressure_tau_s`; the unit gives the
    /// configured static pressure and the stroke.
    pub fn new(tau_s: f64, unit: &UnitConfig) -> Self {
        LoadParams {
            static_pressure_pa: unit.static_pressure_pa as f32,
            tau_us: seconds_to_us(tau_s),
            stroke_m: (-unit.stroke_extension_m as f32, unit.stroke_compression_m as f32),
        }
    }
}

/// One calm, valid period's measurements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadInputs {
    /// Gas pressure in S, Pa.
    pub p_gas_pa: f32,
    /// Strut compression, m.
    pub strut_disp_m: f32,
    /// Body vertical acceleration with the sensor's offset removed, m/s^2.
    pub body_acc_m_s2: f32,
}

/// The previous calm period, kept to sample it once its displacement
/// turns out to have been an extremum.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Previous {
    disp_m: f32,
    /// Its load-pressure sample, `p_S / (1 + a / g)`, Pa (`None`: `|a| > g/2`
    /// or the strut on an end stop).
    sample_pa: Option<f32>,
}

/// The estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadState {
    /// Estimate minus the configured static pressure, Pa.
    deviation_pa: f32,
    /// Calm time averaged so far, us (stops growing at the time constant).
    averaged_us: u32,
    /// Calm time since the last sample, us.
    since_sample_us: u32,
    /// The previous calm period (`None`: none since the last gap).
    previous: Option<Previous>,
    /// Direction of the last displacement change: -1, 0 (none yet) or 1.
    direction: i8,
}

impl LoadState {
    /// No sample yet: the configured static pressure.
    pub const fn new() -> Self {
        LoadState { deviation_pa: 0.0, averaged_us: 0, since_sample_us: 0, previous: None, direction: 0 }
    }

    /// The estimated load pressure, Pa.
    pub fn pressure_pa(&self, p: &LoadParams) -> f32 {
        p.static_pressure_pa + self.deviation_pa
    }

    /// Calm time the estimate has averaged, us, up to the time constant.
    pub fn averaged_us(&self) -> u32 {
        self.averaged_us
    }

    fn add_sample(&mut self, p: &LoadParams, sample_pa: f32) {
        if self.since_sample_us == 0 {
            return;
        }
        self.averaged_us = self.averaged_us.saturating_add(self.since_sample_us).min(p.tau_us.max(self.since_sample_us));
        // Time-weighted mean while young, then the low-pass: the weight of
        // the sample is the time it stands for over the averaged time (<= 1).
        let weight = self.since_sample_us as f32 / self.averaged_us as f32;
        self.deviation_pa += weight * ((sample_pa - p.static_pressure_pa) - self.deviation_pa);
        self.since_sample_us = 0;
    }
}

/// Updates the estimate with a calm, valid period of `dt_us` microseconds
/// (`None` for any other period) and returns the estimate, Pa.
///
/// ```
/// use hp_ctrl::load::{self, LoadInputs, LoadParams, LoadState};
/// use hp_ctrl::gas_table::UnitConfig;
/// let unit = UnitConfig { static_pressure_pa: 15.0e6, ..UnitConfig::seed_unit() };
/// let p = LoadParams::new(20.0, &unit);
/// let mut s = LoadState::new();
/// assert_eq!(load::step(&p, &mut s, None, 1000), 15.0e6);
/// // At rest every period after the first (which starts the turning-point
/// // detection) is a sample, weighted by the calm time it stands for.
/// let at_rest = |p_gas_pa| Some(LoadInputs { p_gas_pa, strut_disp_m: 0.0, body_acc_m_s2: 0.0 });
/// load::step(&p, &mut s, at_rest(16.0e6), 1000);
/// load::step(&p, &mut s, at_rest(16.0e6), 1000);
/// load::step(&p, &mut s, at_rest(17.0e6), 1000);
/// let estimate = load::step(&p, &mut s, at_rest(17.0e6), 1000);
/// assert!((estimate - 16.5e6).abs() < 1.0);
/// ```
pub fn step(p: &LoadParams, s: &mut LoadState, inputs: Option<LoadInputs>, dt_us: u32) -> f32 {
    let Some(i) = inputs else {
        // The turning-point detection restarts after a gap.
        s.previous = None;
        s.direction = 0;
        return s.pressure_pa(p);
    };
    s.since_sample_us = s.since_sample_us.saturating_add(dt_us);
    let acc_g = i.body_acc_m_s2 / GRAVITY_M_S2;
    let (stroke_min_m, stroke_max_m) = p.stroke_m;
    let off_the_stops = i.strut_disp_m >= stroke_min_m && i.strut_disp_m <= stroke_max_m;
    let now = Previous {
        disp_m: i.strut_disp_m,
        sample_pa: (acc_g.abs() <= 0.5 && off_the_stops).then(|| i.p_gas_pa / (1.0 + acc_g)),
    };
    if let Some(previous) = s.previous.replace(now) {
        let direction = if now.disp_m > previous.disp_m {
            1
        } else if now.disp_m < previous.disp_m {
            -1
        } else {
            0
        };
        if direction == 0 {
            // Not moving: this period is a sample.
            if let Some(sample_pa) = now.sample_pa {
                s.add_sample(p, sample_pa);
            }
        } else {
            if s.direction != 0 && direction != s.direction {
                // The previous period was an extremum: sample it.
                if let Some(sample_pa) = previous.sample_pa {
                    s.add_sample(p, sample_pa);
                }
            }
            s.direction = direction;
        }
    }
    s.pressure_pa(p)
}
