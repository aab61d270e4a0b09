//! The two test rigs of the seed, as ODE systems, and the loop that runs them.
//!
//! - Characterisation rig: the strut displacement is prescribed; the rig
//!   measures force, pressures and temperatures.
//! - Single-degree-of-freedom (SDOF) rig: a sprung mass rests on the unit,
//!   the base under the strut is displaced (e.g. the seed's 43 mm step).
//!
//! Both share one state layout (the unit's states plus the body's position
//! and velocity, unused on the characterisation rig) so one integrator loop
//! and one sample type serve both.

use crate::error::{check_range, Error, Result};
use crate::gas::table::TabulatedGas;
use crate::gas::{Gas, Span};
use crate::motion::Motion;
use crate::ode::{rk4_step, rk4_step_from, steps, OdeSystem};
use crate::unit::{Linearisation, Needs, StrutMotion, Unit, UnitOutputs, UnitState, Valves, STANDARD_GRAVITY_M_S2, UNIT_STATES};

mod adaptive;
pub use adaptive::{run_adaptive, Adaptive, SampleDetail, Steps, DEFAULT_RTOL};

/// Number of states of a rig: the unit's plus body position and velocity.
pub const RIG_STATES: usize = UNIT_STATES + 2;

/// Which rig, with its excitation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RigKind<'a> {
    /// Prescribed strut compression (positive = compression).
    Characterisation { strut: Motion<'a> },
    /// Sprung mass on the unit; prescribed base displacement (positive = up).
    Sdof { sprung_mass_kg: f64, base: Motion<'a> },
}

/// The state of a rig.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RigState {
    pub unit: UnitState,
    /// Sprung-mass displacement from its static position, m (positive = up).
    pub body_disp_m: f64,
    /// Sprung-mass velocity, m/s.
    pub body_vel_m_s: f64,
}

impl RigState {
    /// As a flat array (the integrator's view): the unit's states, then
    /// the body's position and velocity.
    pub fn to_array(self) -> [f64; RIG_STATES] {
        let mut out = [0.0; RIG_STATES];
        let u = self.unit.to_array();
        for (o, v) in out.iter_mut().zip(u.iter().chain([self.body_disp_m, self.body_vel_m_s].iter())) {
            *o = *v;
        }
        out
    }

    /// From a flat array, the inverse of [`RigState::to_array`].
    pub fn from_array(a: &[f64; RIG_STATES]) -> Self {
        let mut u = [0.0; UNIT_STATES];
        for (o, v) in u.iter_mut().zip(a.iter()) {
            *o = *v;
        }
        let [.., body_disp_m, body_vel_m_s] = *a;
        RigState { unit: UnitState::from_array(&u), body_disp_m, body_vel_m_s }
    }
}

/// Everything observed at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RigSample {
    pub time_s: f64,
    /// Strut compression from the static position, m.
    pub disp_m: f64,
    /// Strut compression rate, m/s.
    pub vel_m_s: f64,
    /// Body displacement (SDOF), m.
    pub body_disp_m: f64,
    /// Body velocity (SDOF), m/s.
    pub body_vel_m_s: f64,
    /// Body acceleration (SDOF), m/s^2.
    pub body_acc_m_s2: f64,
    /// Base displacement (SDOF), m.
    pub base_disp_m: f64,
    /// Valve commands in force.
    pub valves: Valves,
    /// Gas volumes, m^3.
    pub v_gas_m3: f64,
    pub v_gas2_m3: f64,
    /// Vapour void in the strut, m^3 (the oil balance: `v_gas_m3 +
    /// v_gas2_m3 + v_void_m3` is the accumulators' volume less what the
    /// strut displaced).
    pub v_void_m3: f64,
    /// Energies dissipated so far, J.
    pub e_damper_j: f64,
    pub e_friction_j: f64,
    pub e_valve6_j: f64,
    /// The unit's outputs.
    pub unit: UnitOutputs,
}

/// A unit mounted on a rig: an ODE system for the integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rig<'a> {
    unit: &'a Unit,
    kind: RigKind<'a>,
    ambient_k: f64,
    /// Valve commands, held over each integration step.
    pub valves: Valves,
    /// SDOF: strut compression at which the unit carries the sprung mass at
    /// rest (zero when the charge matches the load), m.
    static_disp_m: f64,
    /// The reference gas tabulated ([`Rig::with_gas_table`]), used for the
    /// rates and samples instead of the direct equation; None: direct.
    gas_table: Option<TabulatedGas<'a, Span>>,
}

impl<'a> Rig<'a> {
    /// Mounts `unit` on a rig at ambient temperature `ambient_k` (also the
    /// initial gas, oil and wall temperature) with initial `valves`. Checks
    /// the rig's parameters; on the SDOF rig finds the static equilibrium.
    pub fn new(unit: &'a Unit, kind: RigKind<'a>, ambient_k: f64, valves: Valves) -> Result<Self> {
        check_range("ambient_k", ambient_k, 200.0, 600.0)?;
        let static_disp_m = match kind {
            RigKind::Characterisation { strut } => {
                strut.validate()?;
                0.0
            }
            RigKind::Sdof { sprung_mass_kg, base } => {
                crate::ranges::SPRUNG_MASS_KG.check(sprung_mass_kg)?;
                base.validate()?;
                unit.static_disp_for_load_m(sprung_mass_kg * STANDARD_GRAVITY_M_S2, ambient_k, valves)?
            }
        };
        Ok(Rig { unit, kind, ambient_k, valves, static_disp_m, gas_table: None })
    }

    /// A rig rebuilt from the parts of one made by [`Rig::new`] (its unit,
    /// kind, ambient temperature and [`Rig::static_disp_m`]), without
    /// checking them again or solving for the equilibrium: for stepping
    /// APIs that cannot hold the borrow between steps.
    pub fn resume(unit: &'a Unit, kind: RigKind<'a>, ambient_k: f64, valves: Valves, static_disp_m: f64) -> Self {
        Rig { unit, kind, ambient_k, valves, static_disp_m, gas_table: None }
    }

    /// The rig evaluating its unit's gas through `table` (the reference
    /// gas tabulated, [`crate::gas::table`]: pressure within 1.3e-8 of the
    /// direct equation, several times cheaper) for its rates and samples.
    /// The equilibrium and the initial state stay the direct equation's.
    /// Fails if the unit's gas is not the reference one (the table would be
    /// another gas).
    pub fn with_gas_table(mut self, table: TabulatedGas<'a, Span>) -> Result<Self> {
        if self.unit.params().gas != Gas::Span {
            // The value is the unit's gas's place in Gas::ALL; the table's
            // gas is the first.
            let index = Gas::ALL.iter().position(|&g| g == self.unit.params().gas).unwrap_or(Gas::ALL.len());
            return Err(Error::OutOfRange { name: "gas (index in Gas::ALL; a table of the reference gas needs span)", value: index as f64, min: 0.0, max: 0.0 });
        }
        self.gas_table = Some(table);
        Ok(self)
    }

    /// The unit on the rig.
    pub fn unit(&self) -> &'a Unit {
        self.unit
    }

    /// The rig and its excitation.
    pub fn kind(&self) -> RigKind<'a> {
        self.kind
    }

    /// Ambient temperature, K.
    pub fn ambient_k(&self) -> f64 {
        self.ambient_k
    }

    /// SDOF: the strut compression at static equilibrium under the sprung
    /// mass, m (how far the ride height sits below nominal).
    pub fn static_disp_m(&self) -> f64 {
        self.static_disp_m
    }

    fn strut_motion(&self, t_s: f64, s: &RigState) -> (StrutMotion, f64) {
        match self.kind {
            RigKind::Characterisation { strut } => {
                let (x, v) = strut.at(t_s);
                (StrutMotion { disp_m: x, vel_m_s: v }, 0.0)
            }
            RigKind::Sdof { base, .. } => {
                let (zb, vb) = base.at(t_s);
                let disp_m = self.static_disp_m + zb - s.body_disp_m;
                (StrutMotion { disp_m, vel_m_s: vb - s.body_vel_m_s }, zb)
            }
        }
    }

    /// Checks that a state is one the model can evaluate.
    fn check(&self, t_s: f64, s: &RigState) -> Result<()> {
        self.unit.check_state(&s.unit, t_s)?;
        if !(s.body_disp_m.is_finite() && s.body_vel_m_s.is_finite()) {
            return Err(Error::StateOutOfRange {
                name: "body_disp_m",
                value: s.body_disp_m,
                min: f64::MIN,
                max: f64::MAX,
                time_s: t_s,
            });
        }
        Ok(())
    }

    /// The state rate and what the unit does, for a state that passed
    /// [`Rig::check`] (or an integrator stage between two that did: a stage
    /// outside the valid region gives a bad step, which the check of the
    /// step's result catches; the arithmetic cannot panic).
    #[inline]
    fn rate(&self, t_s: f64, s: &RigState) -> (RigState, StrutMotion, f64, f64, UnitOutputs) {
        let (rate, motion, base, body_acc, out, _) = self.rate_parts(t_s, s, Needs { outputs: true, coupling: false, strut: false, rates: true });
        (rate, motion, base, body_acc, out)
    }

    /// [`Rig::rate`] with only what `needs` asks for (see [`Unit::evaluate_parts`]).
    #[inline(always)]
    fn rate_parts(
        &self,
        t_s: f64,
        s: &RigState,
        needs: Needs,
    ) -> (RigState, StrutMotion, f64, f64, UnitOutputs, Linearisation) {
        let (motion, base) = self.strut_motion(t_s, s);
        let (unit_rate, out, coupling) = match &self.gas_table {
            Some(table) => self.unit.evaluate_parts_with(table, &s.unit, motion, self.valves, self.ambient_k, needs),
            None => self.unit.evaluate_parts(&s.unit, motion, self.valves, self.ambient_k, needs),
        };
        let body_acc = match self.kind {
            RigKind::Characterisation { .. } => 0.0,
            RigKind::Sdof { sprung_mass_kg, .. } => out.force_true_n / sprung_mass_kg - STANDARD_GRAVITY_M_S2,
        };
        let rate = match self.kind {
            RigKind::Characterisation { .. } => RigState { unit: unit_rate, body_disp_m: 0.0, body_vel_m_s: 0.0 },
            RigKind::Sdof { .. } => RigState { unit: unit_rate, body_disp_m: s.body_vel_m_s, body_vel_m_s: body_acc },
        };
        (rate, motion, base, body_acc, out, coupling)
    }

    fn evaluate(&self, t_s: f64, s: &RigState) -> Result<(RigState, RigSample)> {
        self.check(t_s, s)?;
        Ok(self.evaluate_checked(t_s, s))
    }

    /// [`Rig::evaluate`] for a state already checked (every state a step
    /// returns was).
    fn evaluate_checked(&self, t_s: f64, s: &RigState) -> (RigState, RigSample) {
        let (rate, motion, base, body_acc, out) = self.rate(t_s, s);
        (rate, self.sample_from(t_s, s, motion, base, body_acc, out))
    }

    /// The observed quantities at `(t_s, state)` without the state rate
    /// (the gas evaluated for its pressure alone).
    fn sample_outputs(&self, t_s: f64, s: &RigState) -> Result<RigSample> {
        self.check(t_s, s)?;
        let (_, motion, base, body_acc, out, _) = self.rate_parts(t_s, s, Needs { outputs: true, coupling: false, strut: false, rates: false });
        Ok(self.sample_from(t_s, s, motion, base, body_acc, out))
    }

    fn sample_from(&self, t_s: f64, s: &RigState, motion: StrutMotion, base: f64, body_acc: f64, out: UnitOutputs) -> RigSample {
        RigSample {
            time_s: t_s,
            disp_m: motion.disp_m,
            vel_m_s: motion.vel_m_s,
            body_disp_m: s.body_disp_m,
            body_vel_m_s: s.body_vel_m_s,
            body_acc_m_s2: body_acc,
            base_disp_m: base,
            valves: self.valves,
            v_gas_m3: s.unit.v_gas_m3,
            v_gas2_m3: s.unit.v_gas2_m3,
            v_void_m3: s.unit.v_void_m3,
            e_damper_j: s.unit.e_damper_j,
            e_friction_j: s.unit.e_friction_j,
            e_valve6_j: s.unit.e_valve6_j,
            unit: out,
        }
    }

    /// The initial state: at rest, gas at ambient temperature. On the
    /// characterisation rig the strut starts where the motion starts; on the
    /// SDOF rig the body rests in static equilibrium on the base, and its
    /// displacement is measured from there (a charge that does not match
    /// the load shows as [`Rig::static_disp_m`], not as a body offset).
    pub fn initial_state(&self) -> Result<RigState> {
        let (x0, body) = match self.kind {
            RigKind::Characterisation { strut } => (strut.at(0.0).0, 0.0),
            RigKind::Sdof { base, .. } => (self.static_disp_m, base.at(0.0).0),
        };
        let unit = self.unit.state_at_rest(x0, self.ambient_k, self.valves)?;
        Ok(RigState { unit, body_disp_m: body, body_vel_m_s: 0.0 })
    }

    /// The observed quantities at `(t_s, state)`.
    pub fn sample(&self, t_s: f64, state: &RigState) -> Result<RigSample> {
        self.evaluate(t_s, state).map(|(_, s)| s)
    }

    /// Advances `state` by one RK4 step of `dt_s` with the current valves;
    /// fails if the result is outside the model's valid region.
    pub fn step(&self, t_s: f64, state: &RigState, dt_s: f64) -> Result<RigState> {
        let y = rk4_step(self, t_s, &state.to_array(), dt_s)?;
        self.projected(t_s + dt_s, &y)
    }

    /// [`Rig::step`] reusing the state rate at `t_s` from [`Rig::rate_and_sample`].
    fn step_from(&self, t_s: f64, state: &RigState, dt_s: f64, rate: &RigState) -> Result<RigState> {
        let y = rk4_step_from(self, t_s, &state.to_array(), dt_s, &rate.to_array())?;
        self.projected(t_s + dt_s, &y)
    }

    fn projected(&self, t_s: f64, y: &[f64; RIG_STATES]) -> Result<RigState> {
        let mut next = RigState::from_array(y);
        self.unit.project(&mut next.unit, self.ambient_k);
        self.check(t_s, &next)?;
        Ok(next)
    }

    /// The state rate and the observed quantities at `(t_s, state)`.
    pub fn rate_and_sample(&self, t_s: f64, state: &RigState) -> Result<(RigState, RigSample)> {
        self.evaluate(t_s, state)
    }

    /// Advances `state` from `t_s` to `t_end_s` in equal RK4 steps of at
    /// most `max_dt_s`; `rate` is the state rate at `t_s` (from
    /// [`Rig::rate_and_sample`], reused as the first stage of the first step).
    pub fn advance(&self, t_s: f64, t_end_s: f64, state: &RigState, rate: &RigState, max_dt_s: f64) -> Result<RigState> {
        let (n, h) = steps(t_s, t_end_s, max_dt_s)?;
        let mut next = self.step_from(t_s, state, h, rate)?;
        for k in 1..n {
            next = self.step(t_s + h * k as f64, &next, h)?;
        }
        Ok(next)
    }
}

impl OdeSystem<RIG_STATES> for Rig<'_> {
    fn derivatives(&self, t_s: f64, y: &[f64; RIG_STATES]) -> Result<[f64; RIG_STATES]> {
        let (rate, ..) = self.rate(t_s, &RigState::from_array(y));
        Ok(rate.to_array())
    }
}

pub use crate::ode::MAX_SUBSTEPS;

/// Runs `rig` from its initial state through the output times `times_s`
/// (strictly increasing, starting at or after 0), integrating with steps of
/// at most `max_dt_s` that land exactly on every output time. The valves at
/// output `i` (time `t_i`) and over the interval that follows it are
/// `valves_at(i, t_i)`; `valves_at(0, t_0)` also holds before the first
/// output. Each sample is handed to `on_sample` (return `false` to stop).
///
/// ```
/// use hp_core::{presets, motion::Motion, rig::{run, Rig, RigKind}, unit::{Unit, Valves}};
/// let unit = Unit::new(presets::seed_unit()).unwrap();
/// let kind = RigKind::Sdof { sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG,
///     base: Motion::Step { height_m: 0.043, start_s: 0.1, rise_s: 0.05 } };
/// let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(true, true)).unwrap();
/// let times: Vec<f64> = (0..=300).map(|i| i as f64 * 0.01).collect();
/// let mut last = 0.0;
/// run(&rig, times.iter().copied(), 1e-3, |_, _| Valves::from_modes(true, true), |_, s| { last = s.body_disp_m; true }).unwrap();
/// assert!((last - 0.043).abs() < 0.005); // settled on the new base level
/// ```
pub fn run<'a>(
    rig: &Rig<'a>,
    times_s: impl IntoIterator<Item = f64>,
    max_dt_s: f64,
    valves_at: impl FnMut(usize, f64) -> Valves,
    on_sample: impl FnMut(usize, &RigSample) -> bool,
) -> Result<()> {
    run_with_lead(rig, times_s, max_dt_s, 0.0, valves_at, on_sample)
}

/// The largest valid switch lead: the largest `f64` below 1 (a lead of a
/// whole interval would put the switch on the output before, which then
/// shows the old valves: the switch would not be the first output's).
/// [`Error::OutOfRange`]'s bounds are inclusive, so the error names this
/// value, not 1.
pub const MAX_SWITCH_LEAD: f64 = 1.0 - f64::EPSILON / 2.0;

/// Checks a switch lead (the fraction of an output interval by which a
/// valve switch precedes the first output that shows it): in [0, 1).
pub(crate) fn check_lead(lead: f64) -> Result<f64> {
    if (0.0..=MAX_SWITCH_LEAD).contains(&lead) {
        Ok(lead)
    } else {
        Err(Error::OutOfRange { name: "switch_lead", value: lead, min: 0.0, max: MAX_SWITCH_LEAD })
    }
}

/// [`run`], with each valve switch `switch_lead` of the interval before the
/// first output that has the new valves (`valves_at(i, t_i)` differs from
/// `valves_at(i - 1, ..)`), instead of at that output.
///
/// A record's valve column is the valve state at each sample; where it
/// changes, the valve switched somewhere in the interval before, and
/// taking it midway (0.5) halves the largest timing error and quarters its
/// mean square (against the sample that shows it: an error uniform on
/// [0, dt], mean square dt^2/3; midway dt^2/12). A controller's valves,
/// commanded at its period's start, switch at the output (0).
///
/// ```
/// use hp_core::{presets, motion::Motion, rig::{run, run_with_lead, Rig, RigKind}, unit::{Unit, Valves}};
/// let unit = Unit::new(presets::seed_unit()).unwrap();
/// let kind = RigKind::Characterisation { strut: Motion::Sine { amplitude_m: 0.03, frequency_hz: 0.5, offset_m: 0.0 } };
/// let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(true, true)).unwrap();
/// let valves = |i: usize, _| Valves::from_modes(i < 50, true);
/// // Switched midway between the outputs at 0.49 s and 0.50 s: the same as
/// // switching at an output placed there.
/// let (mut a, mut b) = (0.0, 0.0);
/// run_with_lead(&rig, (0..=100).map(|i| f64::from(i) * 0.01), 1e-3, 0.5, valves, |i, s| { if i == 100 { a = s.unit.p_gas_pa; } true }).unwrap();
/// let fine: Vec<f64> = (0..=200).map(|i| f64::from(i) * 0.005).collect();
/// run(&rig, fine.iter().copied(), 1e-3, |i, _| Valves::from_modes(i < 99, true), |i, s| { if i == 200 { b = s.unit.p_gas_pa; } true }).unwrap();
/// assert!((a - b).abs() < 1e-6 * b);
/// ```
pub fn run_with_lead<'a>(
    rig: &Rig<'a>,
    times_s: impl IntoIterator<Item = f64>,
    max_dt_s: f64,
    switch_lead: f64,
    mut valves_at: impl FnMut(usize, f64) -> Valves,
    mut on_sample: impl FnMut(usize, &RigSample) -> bool,
) -> Result<()> {
    check_range("dt_s", max_dt_s, 1e-9, 10.0)?;
    check_lead(switch_lead)?;
    let mut times = times_s.into_iter();
    let Some(t0) = times.next() else { return Ok(()) };
    check_range("time_s", t0, 0.0, 1e9)?;
    let mut rig = *rig;
    rig.valves = valves_at(0, t0);
    let mut state = rig.initial_state()?;
    let mut t = 0.0;
    if t0 > 0.0 {
        // Settle from rest at t = 0 to the first output time.
        let (rate, _) = rig.evaluate(t, &state)?;
        state = rig.advance(t, t0, &state, &rate, max_dt_s)?;
        t = t0;
    }
    let mut index = 0usize;
    loop {
        // The valves of the interval that starts here are already set; the
        // rate evaluated for the sample is the first RK4 stage of the interval.
        // The initial state is valid by construction and every step's
        // result has been checked.
        let (rate, sample) = rig.evaluate_checked(t, &state);
        if !on_sample(index, &sample) {
            return Ok(());
        }
        let Some(next) = times.next() else { return Ok(()) };
        if !(next > t) || !next.is_finite() {
            return Err(Error::OutOfRange { name: "time_s (strictly increasing)", value: next, min: t, max: f64::MAX });
        }
        index += 1;
        let next_valves = valves_at(index, next);
        if next_valves != rig.valves && switch_lead > 0.0 {
            let t_switch = next - switch_lead * (next - t);
            state = rig.advance(t, t_switch, &state, &rate, max_dt_s)?;
            rig.valves = next_valves;
            let (rate, _) = rig.evaluate(t_switch, &state)?;
            state = rig.advance(t_switch, next, &state, &rate, max_dt_s)?;
        } else {
            state = rig.advance(t, next, &state, &rate, max_dt_s)?;
            rig.valves = next_valves;
        }
        t = next;
    }
}
