//! Valve 6: pump-free ride-height sequencing and the spring mode.
//!
//! The seed's section 3.6: with valve 6 closed the oil in L is out of the
//! circuit. To lower, valve 6 is opened only while `p_S > p_L` (oil flows
//! into L and stays there when the valve closes) until `p_L` reaches the
//! pressure that holds the requested lowering; to raise, it is opened only
//! while `p_L > p_S`. Road motion makes the pressures differ; the valve is
//! timed on the measured pressures, period by period, so it closes in the
//! same period the pressure difference stops pointing the right way. A
//! margin keeps sensor noise and offsets from opening it: *valve 6 is never
//! open in `Lowering` unless `p_S - p_L > valve6_margin_pa`, nor in
//! `Raising` unless `p_L - p_S > valve6_margin_pa`*. After it closes it
//! stays closed for `valve6_min_off_s` (about its response time), so it
//! cannot chatter.
//!
//! **The zero of the ride height** is the state valve 6 would leave at rest
//! in soft mode: L's gas at the load pressure ([`crate::load`], a slow
//! low-pass of `p_S`), at the measured temperature. In volume offsets of
//! L's gas ([`crate::gas_table`]) that is `u_ref = u(p_load, T)`; a request
//! `h` (negative = lower) targets `u_ref + h`, i.e.
//! `V_L = V_L(p_load, T) + A h`, and the held offset is `u(p_L, T) - u_ref`. With the load
//! carried by S at the same pressure either way, S's gas and hence the
//! strut sit `h` from where the soft spring would leave them. So a
//! temperature change alone never moves the body through a mode change
//! (hot gas expands in soft and hard mode alike), while an offset locked
//! into L by closing valve 6 mid-stroke is still sequenced away. Progress
//! compares the held offset with the request, which is comparing `p_L`
//! with the target pressure, because both come from the same table. A
//! change starts when the held offset is more than `tolerance_m` from the
//! request and runs until it reaches the request.
//!
//! Valve 6 is also the spring switch, and an open valve 6 lets S and L
//! equalise, which undoes any offset. So a non-zero ride height can only be
//! held with valve 6 closed: **the ride height has priority over the soft
//! spring**. While an offset is requested (or the spring is hard anyway, in
//! Handling, when the sequencer keeps the zero offset), ride-height
//! control is engaged and the spring is hard except for the sequencing
//! pulses. The driver asked for the height explicitly (ground clearance, a
//! low silhouette, a stable platform); silently giving it up for comfort
//! would surprise them, and the hard spring is the safer of the two. With
//! no offset requested in Ride mode the sequencer is `Idle` and valve 6 is
//! open (the soft spring). It gets there only once the held offset is
//! within `tolerance_m` of zero: an offset still held when the request
//! returns to zero (or when Handling ends, or at power-on) is first
//! sequenced back, so releasing valve 6 never makes the body jump.
//!
//! Sequencing pauses (`Blocked`, valve 6 closed) while cornering, braking
//! or accelerating hard, and resumes after `resume_s` of calm, as air
//! suspensions do: moving oil during a manoeuvre would change the height
//! under load transfer and lock in a wrong one. After power-on it also
//! waits until the load-pressure estimate has averaged `load_settle_s` of
//! calm driving: before that the zero is not known well enough.

use crate::clock::seconds_to_us;
use crate::config::{check, check_below, ParamError};
use crate::diag;
use crate::gas_table::UnitConfig;
use crate::{SequencerState, SpringMode};

/// Ride-height sequencing tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RideHeightConfig {
    /// Largest ride-height request magnitude, m; larger ones are clamped.
    pub request_max_m: f64,
    /// Requests smaller than this in magnitude count as nominal (0), m.
    pub request_deadband_m: f64,
    /// A change starts when the estimate is this far from the request, m.
    pub tolerance_m: f64,
    /// Pressure difference in the wanted direction needed to open valve 6, Pa.
    pub valve6_margin_pa: f64,
    /// Minimum time valve 6 stays closed before it reopens, s.
    pub valve6_min_off_s: f64,
    /// Lateral acceleration magnitude that pauses sequencing, m/s^2.
    pub block_lat_acc_m_s2: f64,
    /// Longitudinal acceleration magnitude that pauses sequencing, m/s^2.
    pub block_long_acc_m_s2: f64,
    /// Calm time after a pause (or the safe state) before sequencing resumes, s.
    pub resume_s: f64,
    /// Time constant of the load-pressure estimate ([`crate::load`]), s.
    pub load_pressure_tau_s: f64,
    /// Calm time the load-pressure estimate must have averaged (since
    /// power-on) before sequencing starts, s.
    pub load_settle_s: f64,
}

impl Default for RideHeightConfig {
    fn default() -> Self {
        RideHeightConfig {
            request_max_m: 0.06,
            request_deadband_m: 0.002,
            tolerance_m: 0.003,
            // Covers the offset between two 0.2 %-of-100-MPa transducers;
            // road input makes the pressures differ by megapascals.
            valve6_margin_pa: 0.2e6,
            valve6_min_off_s: 0.02,
            block_lat_acc_m_s2: 1.5,
            block_long_acc_m_s2: 1.5,
            resume_s: 1.0,
            // The body modes are at 1-1.5 Hz: 20 s passes 1/125 of a 1 Hz
            // swing (2 MPa -> 16 kPa, 0.35 mm of height) and follows a
            // payload change within a minute.
            load_pressure_tau_s: 20.0,
            // A +-2 MPa swing at 1.5 Hz averaged over 5 s leaves at most
            // 85 kPa (1.9 mm of height), within the 3 mm tolerance.
            load_settle_s: 5.0,
        }
    }
}

impl RideHeightConfig {
    pub(crate) fn validate(&self, unit: &UnitConfig, dt_max_s: f64) -> Result<(), ParamError> {
        let stroke = unit.stroke_compression_m.min(unit.stroke_extension_m);
        check("ride_height.request_max_m", self.request_max_m, 0.0, 0.9 * stroke)?;
        // The gas table spans the stroke widened by the largest request:
        // L's gas must not vanish at its compressed end.
        check_below(
            "unit.piston_area_m2 * (unit.stroke_compression_m + ride_height.request_max_m)",
            unit.piston_area_m2 * (unit.stroke_compression_m + self.request_max_m),
            "unit.large_acc_volume_m3",
            unit.large_acc_volume_m3,
        )?;
        check("ride_height.request_deadband_m", self.request_deadband_m, 0.0, self.request_max_m)?;
        check("ride_height.tolerance_m", self.tolerance_m, 1.0e-4, 0.05)?;
        check("ride_height.valve6_margin_pa", self.valve6_margin_pa, 0.0, 1.0e7)?;
        check("ride_height.valve6_min_off_s", self.valve6_min_off_s, 0.0, 1.0)?;
        check("ride_height.block_lat_acc_m_s2", self.block_lat_acc_m_s2, 0.0, 30.0)?;
        check("ride_height.block_long_acc_m_s2", self.block_long_acc_m_s2, 0.0, 30.0)?;
        check("ride_height.resume_s", self.resume_s, 0.0, 60.0)?;
        check("ride_height.load_pressure_tau_s", self.load_pressure_tau_s, dt_max_s, 3600.0)?;
        check("ride_height.load_settle_s", self.load_settle_s, 0.0, self.load_pressure_tau_s)
    }
}

/// [`RideHeightConfig`] compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RideHeightParams {
    pub(crate) request_max_m: f64,
    pub(crate) request_deadband_m: f64,
    pub(crate) tolerance_m: f32,
    pub(crate) valve6_margin_pa: f64,
    pub(crate) min_off_us: u32,
    pub(crate) block_lat_acc_m_s2: f32,
    pub(crate) block_long_acc_m_s2: f32,
    pub(crate) resume_us: u32,
    pub(crate) load_settle_us: u32,
}

impl RideHeightParams {
    pub(crate) fn new(c: &RideHeightConfig) -> Self {
        RideHeightParams {
            request_max_m: c.request_max_m,
            request_deadband_m: c.request_deadband_m,
            tolerance_m: c.tolerance_m as f32,
            valve6_margin_pa: c.valve6_margin_pa,
            min_off_us: seconds_to_us(c.valve6_min_off_s),
            block_lat_acc_m_s2: c.block_lat_acc_m_s2 as f32,
            block_long_acc_m_s2: c.block_long_acc_m_s2 as f32,
            resume_us: seconds_to_us(c.resume_s),
            load_settle_us: seconds_to_us(c.load_settle_s),
        }
    }

    /// Cornering, braking or accelerating hard: sequencing pauses, and the
    /// load-pressure estimate does not take the load transfer in.
    pub(crate) fn manoeuvring(&self, lat_acc_m_s2: f32, long_acc_m_s2: f32, brake_pressed: bool) -> bool {
        lat_acc_m_s2.abs() > self.block_lat_acc_m_s2 || long_acc_m_s2.abs() > self.block_long_acc_m_s2 || brake_pressed
    }

    /// The request the sequencer works to: clamped to `request_max_m`, 0
    /// inside the deadband or when not finite; `true` when it was clamped.
    pub(crate) fn effective_request_m(&self, request_m: f64) -> (f64, bool) {
        if !request_m.is_finite() || request_m.abs() <= self.request_deadband_m {
            (0.0, false)
        } else if request_m.abs() > self.request_max_m {
            // max/min rather than clamp, which keeps a panic path.
            (request_m.max(-self.request_max_m).min(self.request_max_m), true)
        } else {
            (request_m, false)
        }
    }
}

/// What the sequencer works from this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RideHeightInputs {
    /// Effective request, m (see [`RideHeightParams::effective_request_m`]).
    pub request_m: f32,
    /// Ride-height offset held by the oil in L (from the soft-mode rest
    /// state, see the module docs), m.
    pub height_m: f32,
    /// The pressures exactly as measured (the valve-timing comparison runs
    /// in double precision so its margin is exact).
    pub p_gas_pa: f64,
    pub p_gas2_pa: f64,
    pub lat_acc_m_s2: f32,
    pub long_acc_m_s2: f32,
    pub brake_pressed: bool,
    /// The drive mode wants the soft spring (Ride).
    pub soft_wanted: bool,
    /// The outputs are the safe state.
    pub safe: bool,
    /// The load-pressure estimate (the zero reference) has averaged long
    /// enough to sequence to.
    pub reference_settled: bool,
}

/// The sequencer's commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RideHeightOutputs {
    pub sequencer: SequencerState,
    pub spring: SpringMode,
    pub valve6_open: bool,
    /// [`diag`] flags.
    pub diag: u32,
}

/// Sequencer and valve-6 state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RideHeightState {
    /// `Lowering`, `Raising` or `Holding`: the change in progress.
    phase: SequencerState,
    valve6_open: bool,
    /// Time since valve 6 last closed, us.
    since_close_us: u32,
    /// Time without driving dynamics that pause sequencing, us.
    calm_us: u32,
    /// Ride-height control engaged (valve 6 held closed except for
    /// sequencing); kept through the safe state.
    engaged: bool,
}

impl RideHeightState {
    /// Power-on: valve 6 closed, holding whatever L holds (a vehicle parked
    /// lowered stays lowered until it is sequenced back).
    pub const fn new() -> Self {
        RideHeightState {
            phase: SequencerState::Holding,
            valve6_open: false,
            since_close_us: 0,
            calm_us: 0,
            engaged: true,
        }
    }
}

impl RideHeightState {
    /// The change in progress: `Lowering`, `Raising` or `Holding`.
    pub fn phase(&self) -> SequencerState {
        self.phase
    }

    /// Oil is flowing for a height change: `Lowering` or `Raising` with
    /// valve 6 open. A sequence waiting for a pressure difference that does
    /// not come (a pump-free unit at rest short of its target) moves
    /// nothing.
    pub fn moving_oil(&self) -> bool {
        self.valve6_open && matches!(self.phase, SequencerState::Lowering | SequencerState::Raising)
    }
}

impl Default for RideHeightState {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs the sequencer and commands valve 6.
pub fn step(p: &RideHeightParams, s: &mut RideHeightState, i: &RideHeightInputs, dt_us: u32) -> RideHeightOutputs {
    s.since_close_us = s.since_close_us.saturating_add(dt_us);
    let dynamics = p.manoeuvring(i.lat_acc_m_s2, i.long_acc_m_s2, i.brake_pressed);
    s.calm_us = if i.safe || dynamics { 0 } else { s.calm_us.saturating_add(dt_us) };
    // Engaged while an offset is requested or the spring is hard anyway;
    // released to the soft spring only once the held offset is back within
    // tolerance of zero, so that releasing never makes the body jump.
    if !i.safe {
        let wants_soft_at_zero = i.request_m == 0.0 && i.soft_wanted;
        let in_motion = matches!(s.phase, SequencerState::Lowering | SequencerState::Raising);
        let at_zero = i.height_m.abs() <= p.tolerance_m && !in_motion;
        s.engaged = !wants_soft_at_zero || (s.engaged && !at_zero);
    }
    let engaged = s.engaged;
    let mut flags = 0;
    let (sequencer, want_open) = if i.safe {
        s.phase = SequencerState::Holding;
        (SequencerState::Blocked, false)
    } else if !engaged {
        s.phase = SequencerState::Holding;
        (SequencerState::Idle, true)
    } else if dynamics || s.calm_us < p.resume_us || !i.reference_settled {
        s.phase = SequencerState::Holding;
        flags |= diag::SEQUENCER_PAUSED;
        (SequencerState::Blocked, false)
    } else {
        // Positive: higher than requested, oil must go into L.
        let error_m = i.height_m - i.request_m;
        s.phase = match s.phase {
            SequencerState::Lowering if error_m > 0.0 => SequencerState::Lowering,
            SequencerState::Raising if error_m < 0.0 => SequencerState::Raising,
            _ if error_m > p.tolerance_m => SequencerState::Lowering,
            _ if error_m < -p.tolerance_m => SequencerState::Raising,
            _ => SequencerState::Holding,
        };
        let want_open = match s.phase {
            SequencerState::Lowering => i.p_gas_pa - i.p_gas2_pa > p.valve6_margin_pa,
            SequencerState::Raising => i.p_gas2_pa - i.p_gas_pa > p.valve6_margin_pa,
            _ => false,
        };
        (s.phase, want_open)
    };
    if engaged && i.soft_wanted && !i.safe {
        flags |= diag::HEIGHT_HOLDS_SPRING;
    }
    let open = want_open && (s.valve6_open || s.since_close_us >= p.min_off_us);
    if s.valve6_open && !open {
        s.since_close_us = 0;
    }
    s.valve6_open = open;
    let spring = if sequencer == SequencerState::Idle { SpringMode::Soft } else { SpringMode::Hard };
    RideHeightOutputs { sequencer, spring, valve6_open: open, diag: flags }
}
