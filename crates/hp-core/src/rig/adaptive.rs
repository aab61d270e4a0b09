//! Running a rig with error-controlled steps ([`crate::adaptive`]): the
//! samples come from the integrator's dense output, so the steps follow
//! the dynamics rather than the output rate; valve switches are hit
//! exactly (the integration restarts there); the unit's stiff flows (the
//! valve-6 exchange, and the damper flow that relieves the compressible
//! oil) are integrated linearly implicitly, so they do not limit the step;
//! and only the states the unit's effects use are integrated.

use super::{Rig, RigKind, RigSample, RigState, RIG_STATES};
use crate::adaptive::{AdaptiveSystem, Control, Integrator, LowRank, RankOne, Stats, StiffMethod};
use super::check_lead;
use crate::error::{check_range, Error, Result};
use crate::ode::OdeSystem;
use crate::thermal::HeatTransfer;
use crate::unit::{Linearisation, Needs, UnitOutputs, UnitState, Valves};

/// The relative tolerance the plant is integrated to unless a caller asks
/// for another: the global error of the seed's experiments is then below
/// 1e-6 of each quantity's scale (tests/adaptive_rig.rs), far below any
/// rig's noise, and small enough that a fit's finite-difference Jacobian
/// (parameter steps of 1e-4) is not disturbed by the step-size selection.
pub const DEFAULT_RTOL: f64 = 1e-8;

/// Settings of an adaptive run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Relative error tolerance per step. Each state's absolute tolerance
    /// is this times its scale (the static gas volumes, the static
    /// pressure, 1 K, the stroke, ...).
    pub rtol: f64,
    /// Largest step, s (`f64::INFINITY`: none).
    pub max_dt_s: f64,
    /// Where between two outputs the valves switch, as the fraction of the
    /// interval before the first output that has the new valves, in [0, 1)
    /// (see [`run_with_lead`](super::run_with_lead)): 0 switches at that
    /// output (a controller's period), 0.5 midway (a logged valve state).
    pub switch_lead: f64,
}

impl Default for Adaptive {
    fn default() -> Self {
        Adaptive { rtol: DEFAULT_RTOL, max_dt_s: f64::INFINITY, switch_lead: 0.0 }
    }
}

/// What each sample holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleDetail {
    /// Everything ([`RigSample`] in full).
    Full,
    /// Only what the state gives without evaluating the unit: time, strut
    /// and body motion, base, valves, gas volumes, energies. The unit's
    /// outputs and the body acceleration are NaN.
    States,
}

/// How the steps are chosen.
pub enum Steps<'s> {
    /// By the error control.
    Controlled,
    /// By the error control, each accepted step's end time handed to the
    /// callback (to replay them).
    Record(&'s mut dyn FnMut(f64)),
    /// Exactly these step ends, recorded from a run with the same output
    /// times, valves and motion, without error control: the solution then
    /// depends smoothly on the unit's parameters, as a finite-difference
    /// derivative with respect to them needs (the error control's
    /// accept/reject decisions and step sizes would otherwise change with
    /// the parameter and swamp a small sensitivity).
    Replay(&'s [f64]),
}

/// Largest number of steps between two output samples.
const MAX_STEPS_PER_SAMPLE: u64 = 10_000_000;

/// Which states a rig integrates: their positions in the full state and
/// their scales (for the absolute tolerances).
#[derive(Debug, Clone, Copy)]
struct Layout {
    index: [usize; RIG_STATES],
    scale: [f64; RIG_STATES],
    len: usize,
}

impl Layout {
    fn new(rig: &Rig<'_>) -> Self {
        let p = rig.unit.params();
        let e = &p.effects;
        let (m_s, m_l) = rig.unit.gas_masses_kg();
        let stroke = 0.5 * (p.stroke_compression_m + p.stroke_extension_m);
        let energy = p.static_pressure_pa * p.small_acc_volume_m3;
        let force = p.piston_area_m2 * p.static_pressure_pa;
        // Scale of each state, zero where it is not integrated.
        let on = |used: bool, scale: f64| if used { scale } else { 0.0 };
        let thermal = p.heat != HeatTransfer::Isothermal;
        let lagging_sensor = matches!(e.sensor, Some(s) if s.time_constant_s > 0.0);
        let sdof = matches!(rig.kind, RigKind::Sdof { .. });
        let scales = RigState {
            unit: UnitState {
                t_gas_k: on(thermal, 1.0),
                t_gas2_k: on(thermal, 1.0),
                v_gas_m3: p.small_acc_volume_m3,
                v_gas2_m3: p.large_acc_volume_m3,
                m_small_kg: on(e.leakage.is_some(), m_s),
                m_large_kg: on(e.leakage.is_some(), m_l),
                v_void_m3: p.small_acc_volume_m3,
                p_strut_pa: match e.oil_compliance {
                    // On a characterisation rig, weighed by the oil volume
                    // an error in it compresses (`V_oil / B` per pascal)
                    // against the small gas volume's scale, as the gas
                    // volumes are: what such an error moves between the gas
                    // and the oil (the error itself decays at the damper's
                    // rate), and in the force a share of it the force noise
                    // never sees (90 Pa, 0.18 N on the seed's piston, at
                    // 3 GPa, 1 L and rtol 1e-7). The static pressure where
                    // the oil is softer (below 49 MPa with 1 L, the seed's unit).
                    // Held to the static pressure's scale, the strut
                    // pressure's tolerance was 20-60 times finer at 1-3 GPa
                    // than the gas volumes' and set the steps (oil compliance's
                    // runs of the 75-minute heat run: 1.05 million steps at
                    // 3 GPa, 0.65 million so). On an SDOF rig the strut
                    // pressure drives the body, whose displacement
                    // integrates its error twice: there it stays at the
                    // pressure's scale (weighed by the volume, the damper-
                    // off step's body moved by half its noise at rtol 1e-7).
                    Some(c) if !sdof => (c.bulk_modulus_pa / c.oil_volume_m3 * p.small_acc_volume_m3).max(p.static_pressure_pa),
                    Some(_) => p.static_pressure_pa,
                    None => 0.0,
                },
                t_oil_k: on(e.oil_node.is_some(), 1.0),
                t_wall_k: on(e.oil_node.is_some(), 1.0),
                valve5_open_frac: on(e.valve_lag.is_some(), 1.0),
                valve6_open_frac: on(e.valve_lag.is_some(), 1.0),
                force_sensor_n: on(lagging_sensor, force),
                p_small_sensor_pa: on(lagging_sensor, p.static_pressure_pa),
                p_large_sensor_pa: on(lagging_sensor, p.static_pressure_pa),
                e_damper_j: energy,
                e_friction_j: on(e.friction.is_some(), energy),
                e_valve6_j: energy,
            },
            body_disp_m: on(sdof, stroke),
            body_vel_m_s: on(sdof, stroke),
        }
        .to_array();
        let mut layout = Layout { index: [0; RIG_STATES], scale: [0.0; RIG_STATES], len: 0 };
        for (full, &scale) in scales.iter().enumerate() {
            if scale > 0.0 {
                if let (Some(i), Some(s)) = (layout.index.get_mut(layout.len), layout.scale.get_mut(layout.len)) {
                    *i = full;
                    *s = scale;
                }
                layout.len += 1;
            }
        }
        layout
    }

    fn compress(&self, full: &[f64; RIG_STATES]) -> [f64; RIG_STATES] {
        let mut out = [0.0; RIG_STATES];
        for (o, &i) in out.iter_mut().zip(&self.index).take(self.len) {
            *o = full.get(i).copied().unwrap_or(0.0);
        }
        out
    }

    /// The full state: `base` with the integrated entries from `compact`.
    fn expand(&self, compact: &[f64; RIG_STATES], base: &[f64; RIG_STATES]) -> [f64; RIG_STATES] {
        let mut out = *base;
        for (&c, &i) in compact.iter().zip(&self.index).take(self.len) {
            if let Some(o) = out.get_mut(i) {
                *o = c;
            }
        }
        out
    }
}

/// The rig as the integrator sees it: the integrated states only.
struct System<'r, 'a> {
    rig: Rig<'a>,
    layout: &'r Layout,
    /// Values of the states that are not integrated.
    base: [f64; RIG_STATES],
    atol: [f64; RIG_STATES],
}

impl System<'_, '_> {
    fn state(&self, y: &[f64; RIG_STATES]) -> RigState {
        RigState::from_array(&self.layout.expand(y, &self.base))
    }

    /// The integrated states' rate; with `coupling`, the stiff part too.
    /// Dormand-Prince's first five stages ask for the rate alone, so it is
    /// returned without a [`LowRank`] (648 bytes built, moved and dropped
    /// at every stage: a fifth of a run's copying, perf, stop 60).
    fn rate(&self, t_s: f64, y: &[f64; RIG_STATES], coupling: bool) -> ([f64; RIG_STATES], Linearisation) {
        let s = self.state(y);
        let (rate, _, _, _, _, lin) = self.rig.rate_parts(t_s, &s, Needs { outputs: false, coupling, strut: false, rates: true });
        (self.layout.compress(&rate.to_array()), lin)
    }

    fn stiff_part(&self, lin: &Linearisation) -> LowRank<RIG_STATES> {
        let full = |unit: UnitState| RigState { unit, body_disp_m: 0.0, body_vel_m_s: 0.0 }.to_array();
        let mut stiff = LowRank::NONE;
        // The unit has two stiff flows, MAX_RANK: both always fit.
        for c in [lin.valve6, lin.damper].into_iter().flatten() {
            stiff.push(RankOne { u: self.layout.compress(&full(c.u)), v: self.layout.compress(&full(c.v)) });
        }
        stiff
    }
}

impl OdeSystem<RIG_STATES> for System<'_, '_> {
    fn derivatives(&self, t_s: f64, y: &[f64; RIG_STATES]) -> Result<[f64; RIG_STATES]> {
        Ok(self.rate(t_s, y, false).0)
    }
}

impl AdaptiveSystem<RIG_STATES> for System<'_, '_> {
    fn integrated_len(&self) -> usize {
        self.layout.len
    }

    fn abs_tolerance(&self) -> [f64; RIG_STATES] {
        self.atol
    }

    fn derivatives_with_stiff_part(&self, t_s: f64, y: &[f64; RIG_STATES]) -> Result<([f64; RIG_STATES], LowRank<RIG_STATES>)> {
        let (f, lin) = self.rate(t_s, y, true);
        Ok((f, self.stiff_part(&lin)))
    }

    fn project(&self, _t_s: f64, y: &mut [f64; RIG_STATES]) -> bool {
        let mut s = self.state(y);
        self.rig.unit.project(&mut s.unit, self.rig.ambient_k);
        let projected = self.layout.compress(&s.to_array());
        let changed = projected.iter().zip(y.iter()).any(|(a, b)| a != b);
        *y = projected;
        changed
    }

    fn check(&self, t_s: f64, y: &[f64; RIG_STATES]) -> Result<()> {
        self.rig.check(t_s, &self.state(y))
    }
}

/// Runs `rig` from its initial state through the output times `times_s`
/// (strictly increasing, starting at or after 0) with error-controlled
/// steps, each sample from the dense output of the step that covers it.
/// The valves at output `i` (time `t_i`) are `valves_at(i, t_i)` (which
/// must not depend on the samples: it is asked ahead, to find where the
/// valves switch); they hold over the interval that follows `t_i`, and
/// where they differ from the previous output's they took over
/// `settings.switch_lead` of the interval before it already;
/// `valves_at(0, t_0)` also holds before the first output. Each sample is
/// handed to `on_sample` (return `false` to stop). `steps` chooses, records
/// or replays the steps. Returns the integrator's work counts.
///
/// ```
/// use hp_core::{presets, motion::Motion, unit::{Unit, Valves}};
/// use hp_core::rig::{run_adaptive, Adaptive, Rig, RigKind, SampleDetail, Steps};
/// let unit = Unit::new(presets::seed_unit()).unwrap();
/// let kind = RigKind::Sdof { sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG,
///     base: Motion::Step { height_m: 0.043, start_s: 0.1, rise_s: 0.05 } };
/// // Soft spring: valve 6 open, its orifice integrated implicitly.
/// let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(false, true)).unwrap();
/// let times: Vec<f64> = (0..=3000).map(|i| i as f64 * 1e-3).collect();
/// let mut last = 0.0;
/// let stats = run_adaptive(&rig, &times, Adaptive::default(), SampleDetail::Full, Steps::Controlled,
///     |_, _| Valves::from_modes(false, true), |_, s| { last = s.body_disp_m; true }).unwrap();
/// assert!((last - 0.043).abs() < 0.005); // settled on the new base level
/// assert!(stats.accepted < 1000); // far fewer steps than samples
/// ```
pub fn run_adaptive<'a>(
    rig: &Rig<'a>,
    times_s: &[f64],
    settings: Adaptive,
    detail: SampleDetail,
    steps: Steps<'_>,
    valves_at: impl Fn(usize, f64) -> Valves,
    mut on_sample: impl FnMut(usize, &RigSample) -> bool,
) -> Result<Stats> {
    check_range("rtol", settings.rtol, 1e-14, 1e-2)?;
    check_lead(settings.switch_lead)?;
    if !(settings.max_dt_s >= 1e-9) {
        return Err(Error::OutOfRange { name: "dt_s", value: settings.max_dt_s, min: 1e-9, max: f64::INFINITY });
    }
    let Some(&t0) = times_s.first() else { return Ok(Stats::default()) };
    check_range("time_s", t0, 0.0, 1e9)?;
    let mut last = t0;
    for &t in times_s.iter().skip(1) {
        if !(t > last) || !t.is_finite() {
            return Err(Error::OutOfRange { name: "time_s (strictly increasing)", value: t, min: last, max: f64::MAX });
        }
        last = t;
    }
    let time = |i: usize| times_s.get(i).copied().unwrap_or(last);
    let n = times_s.len();

    let mut rig = *rig;
    rig.valves = valves_at(0, t0);
    let initial = rig.initial_state()?;
    let layout = Layout::new(&rig);
    let base = initial.to_array();
    let mut atol = layout.scale;
    for a in atol.iter_mut() {
        *a *= settings.rtol;
    }
    let mut system = System { rig, layout: &layout, base, atol };
    let mut control = Control::new(settings.rtol, settings.max_dt_s);
    // With oil compliance the damper's stiff mode is there at every step,
    // valve 6 open or not, but stiff only against slow motion: on fast
    // motion Dormand-Prince resolves it at about the steps ROS34PW2's
    // third order needs at the default tolerance (see StiffMethod::Switching).
    // Without it only valve 6's exchange is stiff, and ROS34PW2 takes every
    // step it is in.
    if rig.unit.params().effects.oil_compliance.is_some() {
        control.stiff = StiffMethod::Switching;
    }
    let first_step = settings.max_dt_s.min(1e-4);
    let mut integrator = Integrator::new(&system, 0.0, layout.compress(&base), first_step, control)?;
    let mut stepper = Stepper { steps, cursor: 0 };
    // Settle from rest at t = 0 to the first output time.
    stepper.advance(&mut integrator, &system, t0, t0)?;

    let mut index = 0usize;
    loop {
        // The segment of outputs with the valves of output `index`: up to
        // the next switch, where the integration stops and restarts.
        let valves = system.rig.valves;
        let mut end = index + 1;
        let mut next_valves = valves;
        while end < n {
            next_valves = valves_at(end, time(end));
            if next_valves != valves {
                break;
            }
            end += 1;
        }
        // Where the valves switch: `switch_lead` of the interval before
        // output `end`, after output `end - 1` (which keeps the old valves).
        let t_stop = if end < n {
            let t_end = time(end);
            t_end - settings.switch_lead * (t_end - time(end - 1))
        } else {
            last
        };
        for i in index..end {
            let t = time(i);
            stepper.advance(&mut integrator, &system, t, t_stop)?;
            let y = integrator.dense(t);
            let state = system.state(&y);
            let sample = match detail {
                SampleDetail::Full => system.rig.sample_outputs(t, &state)?,
                SampleDetail::States => states_sample(&system.rig, t, &state),
            };
            if !on_sample(i, &sample) {
                return Ok(integrator.stats());
            }
        }
        if end >= n {
            return Ok(integrator.stats());
        }
        stepper.advance(&mut integrator, &system, t_stop, t_stop)?;
        system.rig.valves = next_valves;
        integrator.restart(&system)?;
        index = end;
    }
}

/// The step choice of one run, with its place in a replayed sequence.
struct Stepper<'s> {
    steps: Steps<'s>,
    cursor: usize,
}

impl Stepper<'_> {
    /// Steps until the integrator's last step covers `t_s`; steps may go
    /// past it, but not past `t_stop` (where the valves switch, or the last
    /// output), nor past a breakpoint of the motion, and no longer than it
    /// resolves.
    fn advance(&mut self, integrator: &mut Integrator<RIG_STATES>, system: &System<'_, '_>, t_s: f64, t_stop: f64) -> Result<()> {
        let motion = match system.rig.kind {
            RigKind::Characterisation { strut } => strut,
            RigKind::Sdof { base, .. } => base,
        };
        let mut taken = 0u64;
        while integrator.t() < t_s {
            if let Steps::Replay(ends) = self.steps {
                let end = ends.get(self.cursor).copied().unwrap_or(f64::NAN);
                if !(end <= t_stop) {
                    return Err(Error::OutOfRange { name: "replayed step end", value: end, min: integrator.t(), max: t_stop });
                }
                integrator.step_exact(system, end)?;
                self.cursor += 1;
            } else {
                let t = integrator.t();
                let end = match motion.next_breakpoint_s(t) {
                    Some(b) if b < t_stop => b,
                    _ => t_stop,
                };
                integrator.limit_step(motion.max_dt_s(t));
                integrator.step(system, end)?;
                if let Steps::Record(record) = &mut self.steps {
                    record(integrator.t());
                }
            }
            taken += 1;
            if taken > MAX_STEPS_PER_SAMPLE {
                return Err(Error::NoConvergence { what: "adaptive integration (more than 1e7 steps between two outputs)", target: t_s });
            }
        }
        Ok(())
    }
}

/// A sample with what the state gives alone (see [`SampleDetail::States`]).
fn states_sample(rig: &Rig<'_>, t_s: f64, s: &RigState) -> RigSample {
    let (motion, base) = rig.strut_motion(t_s, s);
    let nan = f64::NAN;
    RigSample {
        time_s: t_s,
        disp_m: motion.disp_m,
        vel_m_s: motion.vel_m_s,
        body_disp_m: s.body_disp_m,
        body_vel_m_s: s.body_vel_m_s,
        body_acc_m_s2: nan,
        base_disp_m: base,
        valves: rig.valves,
        v_gas_m3: s.unit.v_gas_m3,
        v_gas2_m3: s.unit.v_gas2_m3,
        v_void_m3: s.unit.v_void_m3,
        e_damper_j: s.unit.e_damper_j,
        e_friction_j: s.unit.e_friction_j,
        e_valve6_j: s.unit.e_valve6_j,
        unit: UnitOutputs {
            force_true_n: nan,
            force_n: nan,
            p_strut_pa: nan,
            p_gas_true_pa: nan,
            p_gas2_true_pa: nan,
            p_gas_pa: nan,
            p_gas2_pa: nan,
            t_gas_k: nan,
            t_gas2_k: nan,
            t_wall_k: nan,
            t_oil_k: nan,
            damper_force_n: nan,
            damper_power_w: nan,
            friction_force_n: nan,
            friction_power_w: nan,
            valve6_power_w: nan,
            flow_damper_m3_s: nan,
            flow_valve6_m3_s: nan,
            cavitating: false,
        },
    }
}
