//! Input plausibility, staleness and recovery: decides when the outputs
//! must be the safe state.
//!
//! Every period each input group is checked for values that are NaN or
//! infinite, outside their physical range, changing faster than physics
//! allows (between consecutive fresh samples), or stale (no fresh sample for
//! longer than the group's timeout). Any fault, a link fault or an invalid
//! `dt_s` makes the outputs the safe state in the same period; they return
//! to normal only after every input has been good continuously for the
//! recovery time.
//!
//! The range checks run in double precision, on the values exactly as
//! given, so a value just outside a limit is always caught. The rate checks
//! run in single precision: their limits are physical bounds with wide
//! margins, not sharp edges.

use crate::clock::seconds_to_us;
use crate::config::{check, check_below, ParamError};
use crate::diag;
use crate::gas_table::UnitConfig;
use crate::input_group::{self, COUNT as GROUPS};
use crate::Inputs;

/// Staleness timeout of each input group, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupTimeouts {
    pub pressures_s: f64,
    pub strut_s: f64,
    pub body_s: f64,
    pub vehicle_s: f64,
    pub steering_s: f64,
    pub temperature_s: f64,
    pub driver_s: f64,
}

impl GroupTimeouts {
    /// In the bit order of [`input_group`].
    fn in_group_order(&self) -> [(&'static str, f64); GROUPS] {
        [
            ("monitor.timeouts.pressures_s", self.pressures_s),
            ("monitor.timeouts.strut_s", self.strut_s),
            ("monitor.timeouts.body_s", self.body_s),
            ("monitor.timeouts.vehicle_s", self.vehicle_s),
            ("monitor.timeouts.steering_s", self.steering_s),
            ("monitor.timeouts.temperature_s", self.temperature_s),
            ("monitor.timeouts.driver_s", self.driver_s),
        ]
    }
}

impl Default for GroupTimeouts {
    /// Ten samples of the ECU's own 1 kHz channels, five of 50 Hz vehicle
    /// CAN signals, a few of the slow ones.
    fn default() -> Self {
        GroupTimeouts {
            pressures_s: 0.01,
            strut_s: 0.01,
            body_s: 0.01,
            vehicle_s: 0.1,
            steering_s: 0.1,
            temperature_s: 1.0,
            driver_s: 1.0,
        }
    }
}

/// Physical limits of the inputs and the recovery time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonitorConfig {
    /// Valid gas pressures (both accumulators), Pa.
    pub pressure_min_pa: f64,
    pub pressure_max_pa: f64,
    /// Valid gas temperatures, K. Also the range of the gas table.
    pub temperature_min_k: f64,
    pub temperature_max_k: f64,
    /// How far the measured strut displacement may go beyond the end stops, m.
    pub disp_margin_m: f64,
    /// Largest plausible body vertical acceleration magnitude, m/s^2.
    pub body_acc_max_m_s2: f64,
    /// Largest plausible lateral and longitudinal acceleration magnitude, m/s^2.
    pub vehicle_acc_max_m_s2: f64,
    /// Valid vehicle speeds, m/s (negative = reversing).
    pub speed_min_m_s: f64,
    pub speed_max_m_s: f64,
    /// Largest plausible steering-wheel angle and rate magnitudes.
    pub steer_angle_max_rad: f64,
    pub steer_rate_max_rad_s: f64,
    /// Fastest plausible change of either gas pressure, Pa/s.
    pub pressure_rate_max_pa_s: f64,
    /// Fastest plausible strut velocity, m/s.
    pub disp_rate_max_m_s: f64,
    /// Fastest plausible change of the measured gas temperature, K/s.
    pub temperature_rate_max_k_s: f64,
    /// Staleness timeouts.
    pub timeouts: GroupTimeouts,
    /// How long every input must be good before the safe state is left, s.
    pub recovery_s: f64,
    /// Largest accepted step size, s.
    pub dt_max_s: f64,
}

impl Default for MonitorConfig {
    fn default() -> Self {
        MonitorConfig {
            pressure_min_pa: 0.1e6,
            pressure_max_pa: 120.0e6,
            temperature_min_k: 223.0,
            temperature_max_k: 523.0,
            disp_margin_m: 0.01,
            body_acc_max_m_s2: 50.0,
            vehicle_acc_max_m_s2: 30.0,
            speed_min_m_s: -20.0,
            speed_max_m_s: 80.0,
            steer_angle_max_rad: 20.0,
            steer_rate_max_rad_s: 30.0,
            // kappa p A v / V_gas at 100 MPa, 35 cm^3 of gas left in S,
            // A = 2e-3 m^2 and 2 m/s: 1.6e10 Pa/s, rounded up.
            pressure_rate_max_pa_s: 2.0e10,
            disp_rate_max_m_s: 10.0,
            temperature_rate_max_k_s: 200.0,
            timeouts: GroupTimeouts::default(),
            recovery_s: 0.5,
            dt_max_s: 0.01,
        }
    }
}

impl MonitorConfig {
    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        check("monitor.pressure_min_pa", self.pressure_min_pa, 1.0e3, 3.0e8)?;
        check("monitor.pressure_max_pa", self.pressure_max_pa, 1.0e3, 3.0e8)?;
        check_below("monitor.pressure_min_pa", self.pressure_min_pa, "monitor.pressure_max_pa", self.pressure_max_pa)?;
        let (t_lo, t_hi) = hp_core::gas::TEMPERATURE_RANGE_K;
        check("monitor.temperature_min_k", self.temperature_min_k, t_lo, t_hi)?;
        check("monitor.temperature_max_k", self.temperature_max_k, t_lo, t_hi)?;
        check_below(
            "monitor.temperature_min_k",
            self.temperature_min_k,
            "monitor.temperature_max_k",
            self.temperature_max_k,
        )?;
        check("monitor.disp_margin_m", self.disp_margin_m, 0.0, 1.0)?;
        check("monitor.body_acc_max_m_s2", self.body_acc_max_m_s2, 1.0, 1.0e3)?;
        check("monitor.vehicle_acc_max_m_s2", self.vehicle_acc_max_m_s2, 1.0, 1.0e3)?;
        check("monitor.speed_min_m_s", self.speed_min_m_s, -200.0, 0.0)?;
        check("monitor.speed_max_m_s", self.speed_max_m_s, 1.0, 200.0)?;
        check("monitor.steer_angle_max_rad", self.steer_angle_max_rad, 0.1, 100.0)?;
        check("monitor.steer_rate_max_rad_s", self.steer_rate_max_rad_s, 0.1, 1.0e3)?;
        check("monitor.pressure_rate_max_pa_s", self.pressure_rate_max_pa_s, 1.0e6, 1.0e13)?;
        check("monitor.disp_rate_max_m_s", self.disp_rate_max_m_s, 0.01, 1.0e3)?;
        check("monitor.temperature_rate_max_k_s", self.temperature_rate_max_k_s, 0.01, 1.0e5)?;
        check("monitor.dt_max_s", self.dt_max_s, crate::clock::MIN_DT_S, 1.0)?;
        for (name, timeout_s) in self.timeouts.in_group_order() {
            check(name, timeout_s, self.dt_max_s, 60.0)?;
        }
        check("monitor.recovery_s", self.recovery_s, 0.0, 60.0)
    }
}

/// [`MonitorConfig`] compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonitorParams {
    pub(crate) pressure_pa: (f64, f64),
    pub(crate) temperature_k: (f64, f64),
    pub(crate) disp_m: (f64, f64),
    pub(crate) body_acc_max_m_s2: f64,
    pub(crate) vehicle_acc_max_m_s2: f64,
    pub(crate) speed_m_s: (f64, f64),
    pub(crate) steer_angle_max_rad: f64,
    pub(crate) steer_rate_max_rad_s: f64,
    pub(crate) pressure_rate_pa_per_us: f32,
    pub(crate) disp_rate_m_per_us: f32,
    pub(crate) temperature_rate_k_per_us: f32,
    pub(crate) timeouts_us: [u32; GROUPS],
    pub(crate) recovery_us: u32,
    pub(crate) dt_max_s: f64,
}

impl MonitorParams {
    pub(crate) fn new(c: &MonitorConfig, unit: &UnitConfig) -> Self {
        MonitorParams {
            pressure_pa: (c.pressure_min_pa, c.pressure_max_pa),
            temperature_k: (c.temperature_min_k, c.temperature_max_k),
            disp_m: (
                -(unit.stroke_extension_m + c.disp_margin_m),
                unit.stroke_compression_m + c.disp_margin_m,
            ),
            body_acc_max_m_s2: c.body_acc_max_m_s2,
            vehicle_acc_max_m_s2: c.vehicle_acc_max_m_s2,
            speed_m_s: (c.speed_min_m_s, c.speed_max_m_s),
            steer_angle_max_rad: c.steer_angle_max_rad,
            steer_rate_max_rad_s: c.steer_rate_max_rad_s,
            pressure_rate_pa_per_us: (c.pressure_rate_max_pa_s * 1.0e-6) as f32,
            disp_rate_m_per_us: (c.disp_rate_max_m_s * 1.0e-6) as f32,
            temperature_rate_k_per_us: (c.temperature_rate_max_k_s * 1.0e-6) as f32,
            timeouts_us: c.timeouts.in_group_order().map(|(_, s)| seconds_to_us(s)),
            recovery_us: seconds_to_us(c.recovery_s),
            dt_max_s: c.dt_max_s,
        }
    }
}

/// The last sample of a rate-checked signal.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RateTrack {
    last: f32,
    /// Time since `last` was taken, us (`u32::MAX`: no sample yet).
    since_us: u32,
}

impl RateTrack {
    const NONE: RateTrack = RateTrack { last: 0.0, since_us: u32::MAX };

    /// Takes a fresh sample; false if it moved faster than `limit_per_us`
    /// since the last one.
    fn sample(&mut self, x: f32, limit_per_us: f32) -> bool {
        let plausible = self.since_us == u32::MAX || (x - self.last).abs() <= limit_per_us * self.since_us as f32;
        *self = RateTrack { last: x, since_us: 0 };
        plausible
    }

    fn advance(&mut self, dt_us: u32) {
        self.since_us = self.since_us.saturating_add(dt_us);
    }
}

/// What the monitor remembers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonitorState {
    /// Time since each group's last fresh sample, us (`u32::MAX`: never).
    age_us: [u32; GROUPS],
    /// How long every input has been good, us.
    good_us: u32,
    p_small: RateTrack,
    p_large: RateTrack,
    disp: RateTrack,
    t_gas: RateTrack,
}

impl MonitorState {
    /// Nothing received yet: every group is stale.
    pub const fn new() -> Self {
        MonitorState {
            age_us: [u32::MAX; GROUPS],
            good_us: 0,
            p_small: RateTrack::NONE,
            p_large: RateTrack::NONE,
            disp: RateTrack::NONE,
            t_gas: RateTrack::NONE,
        }
    }
}

impl Default for MonitorState {
    fn default() -> Self {
        Self::new()
    }
}

/// The verdict on this period's inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Health {
    /// Diagnostic flags: the safe-state bits and per-group bits of [`diag`].
    pub diag: u32,
    /// Groups whose values are finite, in range and plausible this period
    /// (stale groups included: their held values are still usable).
    pub usable: u16,
    /// The outputs must be the safe state.
    pub safe: bool,
}

/// `NOT_FINITE`, `OUT_OF_RANGE` or 0 for one value.
fn value_fault(x: f64, min: f64, max: f64) -> u32 {
    if !x.is_finite() {
        diag::NOT_FINITE
    } else if x < min || x > max {
        diag::OUT_OF_RANGE
    } else {
        0
    }
}

/// Whether every value is in its range (then [`value_faults`] are all
/// zero): the usual period's check, two comparisons per value and no
/// branch. A NaN fails its comparisons, and every limit is finite
/// ([`MonitorConfig::validate`]), so a value in range is finite.
#[inline(always)]
fn all_in_range(p: &MonitorParams, i: &Inputs) -> bool {
    let within = |x: f64, (min, max): (f64, f64)| (x >= min) & (x <= max);
    let symmetric = |x: f64, max: f64| (x >= -max) & (x <= max);
    within(i.p_gas_pa, p.pressure_pa)
        & within(i.p_gas2_pa, p.pressure_pa)
        & within(i.strut_disp_m, p.disp_m)
        & symmetric(i.body_acc_m_s2, p.body_acc_max_m_s2)
        & within(i.speed_m_s, p.speed_m_s)
        & symmetric(i.lat_acc_m_s2, p.vehicle_acc_max_m_s2)
        & symmetric(i.long_acc_m_s2, p.vehicle_acc_max_m_s2)
        & symmetric(i.steer_angle_rad, p.steer_angle_max_rad)
        & symmetric(i.steer_rate_rad_s, p.steer_rate_max_rad_s)
        & within(i.t_gas_k, p.temperature_k)
        & i.ride_height_request_m.is_finite()
}

/// The value faults of each group, in the bit order of [`input_group`].
// Cold on the host (the usual period does not call it; measured on the
// 8x8: 260 instructions per period fewer), not on the ECU, where the hint
// makes the firmware about 300 B larger and its flash is nearly full
// (scripts/firmware-build.sh's budget). The same code either way.
#[cfg_attr(not(target_os = "none"), cold)]
fn value_faults(p: &MonitorParams, i: &Inputs) -> [u32; GROUPS] {
    let symmetric = |x: f64, max: f64| value_fault(x, -max, max);
    [
        value_fault(i.p_gas_pa, p.pressure_pa.0, p.pressure_pa.1)
            | value_fault(i.p_gas2_pa, p.pressure_pa.0, p.pressure_pa.1),
        value_fault(i.strut_disp_m, p.disp_m.0, p.disp_m.1),
        symmetric(i.body_acc_m_s2, p.body_acc_max_m_s2),
        value_fault(i.speed_m_s, p.speed_m_s.0, p.speed_m_s.1)
            | symmetric(i.lat_acc_m_s2, p.vehicle_acc_max_m_s2)
            | symmetric(i.long_acc_m_s2, p.vehicle_acc_max_m_s2),
        symmetric(i.steer_angle_rad, p.steer_angle_max_rad) | symmetric(i.steer_rate_rad_s, p.steer_rate_max_rad_s),
        value_fault(i.t_gas_k, p.temperature_k.0, p.temperature_k.1),
        // The request is clamped, not rejected, when finite but too large.
        if i.ride_height_request_m.is_finite() { 0 } else { diag::NOT_FINITE },
    ]
}

/// Checks this period's inputs; `dt_us` is `None` when `dt_s` was invalid.
pub fn step(p: &MonitorParams, s: &mut MonitorState, inputs: &Inputs, dt_us: Option<u32>) -> Health {
    step_in(p, s, inputs, dt_us)
}

/// [`step`] compiled for x86-64 with AVX2, for
/// [`crate::controller::step_all_avx2`] (feature `wide`): the same code,
/// the same verdicts and states.
#[cfg(all(feature = "wide", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(crate) fn step_avx2(p: &MonitorParams, s: &mut MonitorState, inputs: &Inputs, dt_us: Option<u32>) -> Health {
    step_in(p, s, inputs, dt_us)
}

/// [`step`]'s body, inlined into each of its compilations.
#[inline(always)]
fn step_in(p: &MonitorParams, s: &mut MonitorState, inputs: &Inputs, dt_us: Option<u32>) -> Health {
    let mut faults = if all_in_range(p, inputs) { [0; GROUPS] } else { value_faults(p, inputs) };
    let mut flags = 0;
    match dt_us {
        Some(dt_us) => {
            let fresh = |group: u16| inputs.fresh & group != 0;
            let value_ok = |faults: &[u32; GROUPS], group: u16| {
                faults.get(group.trailing_zeros() as usize).is_some_and(|&f| f == 0)
            };
            // Rate checks between consecutive good fresh samples.
            let rate_checked = [
                (&mut s.p_small, inputs.p_gas_pa, input_group::PRESSURES, p.pressure_rate_pa_per_us),
                (&mut s.p_large, inputs.p_gas2_pa, input_group::PRESSURES, p.pressure_rate_pa_per_us),
                (&mut s.disp, inputs.strut_disp_m, input_group::STRUT, p.disp_rate_m_per_us),
                (&mut s.t_gas, inputs.t_gas_k, input_group::TEMPERATURE, p.temperature_rate_k_per_us),
            ];
            let mut rate_faults = 0_u16;
            for (track, x, group, limit) in rate_checked {
                track.advance(dt_us);
                if !value_ok(&faults, group) {
                    *track = RateTrack::NONE;
                } else if fresh(group) && !track.sample(x as f32, limit) {
                    rate_faults |= group;
                }
            }
            if inputs.fresh & input_group::ALL == input_group::ALL {
                // Every group fresh (the usual period): every age is zero,
                // and zero is never beyond a timeout, so nothing is stale.
                s.age_us = [0; GROUPS];
            } else {
                for ((fault, age), (bit, timeout)) in faults
                    .iter_mut()
                    .zip(s.age_us.iter_mut())
                    .zip((0..GROUPS).map(|n| 1_u16 << n).zip(p.timeouts_us))
                {
                    *age = if fresh(bit) { 0 } else { age.saturating_add(dt_us) };
                    if *age > timeout {
                        *fault |= diag::STALE;
                    }
                }
            }
            if rate_faults != 0 {
                for (n, fault) in faults.iter_mut().enumerate() {
                    if rate_faults & (1 << n) != 0 {
                        *fault |= diag::RATE_LIMIT;
                    }
                }
            }
        }
        None => {
            flags |= diag::BAD_DT;
            // Without a valid step size the time between samples is unknown.
            for track in [&mut s.p_small, &mut s.p_large, &mut s.disp, &mut s.t_gas] {
                *track = RateTrack::NONE;
            }
        }
    }
    if inputs.link_fault {
        flags |= diag::LINK_FAULT;
    }
    let mut usable = input_group::ALL;
    for (n, fault) in faults.iter().enumerate() {
        if *fault != 0 {
            let bit = 1_u16 << n;
            flags |= fault | diag::group(bit);
            if *fault & !diag::STALE != 0 {
                usable &= !bit;
            }
        }
    }
    let faulted = flags != 0;
    match dt_us {
        Some(dt_us) if !faulted => s.good_us = s.good_us.saturating_add(dt_us),
        _ => s.good_us = 0,
    }
    let safe = faulted || s.good_us < p.recovery_us;
    if safe {
        flags |= diag::SAFE_STATE;
        if !faulted {
            flags |= diag::RECOVERING;
        }
    }
    Health { diag: flags, usable, safe }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    /// The step as it was before its fast paths (every value classified,
    /// every age counted), the reference the fast paths must match.
    fn reference_value_faults(p: &MonitorParams, i: &Inputs) -> [u32; GROUPS] {
        let symmetric = |x: f64, max: f64| value_fault(x, -max, max);
        [
            value_fault(i.p_gas_pa, p.pressure_pa.0, p.pressure_pa.1)
                | value_fault(i.p_gas2_pa, p.pressure_pa.0, p.pressure_pa.1),
            value_fault(i.strut_disp_m, p.disp_m.0, p.disp_m.1),
            symmetric(i.body_acc_m_s2, p.body_acc_max_m_s2),
            value_fault(i.speed_m_s, p.speed_m_s.0, p.speed_m_s.1)
                | symmetric(i.lat_acc_m_s2, p.vehicle_acc_max_m_s2)
                | symmetric(i.long_acc_m_s2, p.vehicle_acc_max_m_s2),
            symmetric(i.steer_angle_rad, p.steer_angle_max_rad) | symmetric(i.steer_rate_rad_s, p.steer_rate_max_rad_s),
            value_fault(i.t_gas_k, p.temperature_k.0, p.temperature_k.1),
            // The request is clamped, not rejected, when finite but too large.
            if i.ride_height_request_m.is_finite() { 0 } else { diag::NOT_FINITE },
        ]
    }

    fn reference_step(p: &MonitorParams, s: &mut MonitorState, inputs: &Inputs, dt_us: Option<u32>) -> Health {
        let mut faults = reference_value_faults(p, inputs);
        let mut flags = 0;
        match dt_us {
            Some(dt_us) => {
                let fresh = |group: u16| inputs.fresh & group != 0;
                let value_ok = |faults: &[u32; GROUPS], group: u16| {
                    faults.get(group.trailing_zeros() as usize).is_some_and(|&f| f == 0)
                };
                // Rate checks between consecutive good fresh samples.
                let rate_checked = [
                    (&mut s.p_small, inputs.p_gas_pa, input_group::PRESSURES, p.pressure_rate_pa_per_us),
                    (&mut s.p_large, inputs.p_gas2_pa, input_group::PRESSURES, p.pressure_rate_pa_per_us),
                    (&mut s.disp, inputs.strut_disp_m, input_group::STRUT, p.disp_rate_m_per_us),
                    (&mut s.t_gas, inputs.t_gas_k, input_group::TEMPERATURE, p.temperature_rate_k_per_us),
                ];
                let mut rate_faults = 0_u16;
                for (track, x, group, limit) in rate_checked {
                    track.advance(dt_us);
                    if !value_ok(&faults, group) {
                        *track = RateTrack::NONE;
                    } else if fresh(group) && !track.sample(x as f32, limit) {
                        rate_faults |= group;
                    }
                }
                for ((fault, age), (bit, timeout)) in faults
                    .iter_mut()
                    .zip(s.age_us.iter_mut())
                    .zip((0..GROUPS).map(|n| 1_u16 << n).zip(p.timeouts_us))
                {
                    *age = if fresh(bit) { 0 } else { age.saturating_add(dt_us) };
                    if *age > timeout {
                        *fault |= diag::STALE;
                    }
                    if rate_faults & bit != 0 {
                        *fault |= diag::RATE_LIMIT;
                    }
                }
            }
            None => {
                flags |= diag::BAD_DT;
                // Without a valid step size the time between samples is unknown.
                for track in [&mut s.p_small, &mut s.p_large, &mut s.disp, &mut s.t_gas] {
                    *track = RateTrack::NONE;
                }
            }
        }
        if inputs.link_fault {
            flags |= diag::LINK_FAULT;
        }
        let mut usable = input_group::ALL;
        for (n, fault) in faults.iter().enumerate() {
            if *fault != 0 {
                let bit = 1_u16 << n;
                flags |= fault | diag::group(bit);
                if *fault & !diag::STALE != 0 {
                    usable &= !bit;
                }
            }
        }
        let faulted = flags != 0;
        match dt_us {
            Some(dt_us) if !faulted => s.good_us = s.good_us.saturating_add(dt_us),
            _ => s.good_us = 0,
        }
        let safe = faulted || s.good_us < p.recovery_us;
        if safe {
            flags |= diag::SAFE_STATE;
            if !faulted {
                flags |= diag::RECOVERING;
            }
        }
        Health { diag: flags, usable, safe }
    }

    /// A deterministic sequence of periods with every kind of input: good
    /// values, values at, just beyond and far beyond their limits, NaN and
    /// infinities, jumps, dropped fresh flags, link faults and bad steps.
    #[test]
    fn the_fast_paths_decide_as_the_full_checks_do() {
        // A short recovery, so that the sequence is out of the safe state too.
        let config = MonitorConfig { recovery_s: 0.005, ..MonitorConfig::default() };
        let p = MonitorParams::new(&config, &UnitConfig::seed_unit());
        let (mut fast, mut full) = (MonitorState::new(), MonitorState::new());
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let good = Inputs {
            p_gas_pa: 8.0e6,
            p_gas2_pa: 8.0e6,
            t_gas_k: 300.0,
            speed_m_s: 10.0,
            fresh: input_group::ALL,
            ..Inputs::default()
        };
        let mut inputs = good;
        let (mut safe_periods, mut faulted_kinds) = (0, 0);
        for _ in 0..200_000 {
            let r = next();
            if r % 13 == 0 {
                inputs = good;
            }
            let field = (r >> 8) % 16;
            let value = match (r >> 16) % 12 {
                0 => f64::NAN,
                1 => f64::INFINITY,
                2 => f64::NEG_INFINITY,
                3 => config.pressure_max_pa,
                4 => config.pressure_min_pa * (1.0 - 1e-15),
                5 => -config.body_acc_max_m_s2,
                6 => config.temperature_max_k * (1.0 + 1e-15),
                7 => -(config.disp_margin_m + 0.2),
                _ => ((r >> 24) % 2000) as f64 * 1.0e4 - 2.0e6,
            };
            if (r >> 40) % 16 == 0 {
                match field {
                    0 => inputs.p_gas_pa = value,
                    1 => inputs.p_gas2_pa = value,
                    2 => inputs.strut_disp_m = value * 1e-8,
                    3 => inputs.body_acc_m_s2 = value * 1e-6,
                    4 => inputs.speed_m_s = value * 1e-6,
                    5 => inputs.lat_acc_m_s2 = value * 1e-6,
                    6 => inputs.long_acc_m_s2 = value * 1e-6,
                    7 => inputs.steer_angle_rad = value * 1e-7,
                    8 => inputs.steer_rate_rad_s = value * 1e-7,
                    9 => inputs.t_gas_k = value * 1e-4 + 300.0,
                    10 => inputs.ride_height_request_m = value,
                    11 => inputs.fresh = (r >> 48) as u16 & input_group::ALL,
                    12 => inputs.fresh = input_group::ALL,
                    13 => inputs.link_fault = !inputs.link_fault,
                    14 => inputs.p_gas_pa = 8.0e6 + value,
                    _ => inputs.t_gas_k = 300.0 + value * 1e-6,
                }
            }
            let dt_us = match (r >> 52) % 50 {
                0 => None,
                1 => Some(50_000),
                n => Some(n as u32 * 100),
            };
            let a = step(&p, &mut fast, &inputs, dt_us);
            let b = reference_step(&p, &mut full, &inputs, dt_us);
            assert_eq!(a, b, "{inputs:?} {dt_us:?}");
            assert_eq!(fast, full);
            safe_periods += usize::from(a.safe);
            faulted_kinds |= a.diag;
        }
        // The sequence reached every verdict.
        assert!(safe_periods > 1000 && safe_periods < 199_000, "{safe_periods}");
        let kinds = diag::NOT_FINITE | diag::OUT_OF_RANGE | diag::RATE_LIMIT | diag::STALE | diag::BAD_DT | diag::LINK_FAULT;
        assert_eq!(faulted_kinds & kinds, kinds, "{faulted_kinds:#x}");
    }
}
