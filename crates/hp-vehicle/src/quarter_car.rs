//! The quarter car: a sprung mass on the unit, an unsprung mass (the wheel)
//! under it, and the tyre on the road, which can lift off.
//!
//! ```text
//!   body (sprung mass)      z_b
//!     | unit (strut, damper, S, L)
//!   wheel (unsprung mass)   z_w
//!     | tyre: k d + c d', d = d_0 + z_r - z_w > 0, else 0
//!   road                    z_r(t)
//! ```
//!
//! Displacements are from static equilibrium, positive up; the road is a
//! prescribed height over time (`hp_core::motion::Motion`, as the SDOF
//! rig's base). Same shape as the rigs: validated parameters, a state, a
//! rate function for hp-core's RK4, an allocation-free step.

use hp_core::error::{check_range, Error, Result};
use hp_core::motion::Motion;
use hp_core::ode::OdeSystem;
use hp_core::unit::{Unit, UnitState, Valves, STANDARD_GRAVITY_M_S2, UNIT_STATES};

use crate::corner::{self, CornerForces, CornerMotion};
use crate::stepping;
use crate::tyre::Tyre;

/// Number of states: the unit's, body and wheel displacement and velocity.
pub const QUARTER_CAR_STATES: usize = UNIT_STATES + 4;

/// The masses and the tyre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuarterCarParams {
    /// Sprung mass carried by this wheel, kg.
    pub sprung_mass_kg: f64,
    /// Unsprung mass (wheel, hub, brake, half the links), kg.
    pub unsprung_mass_kg: f64,
    pub tyre: Tyre,
}

/// The state of a quarter car.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct QuarterCarState {
    pub unit: UnitState,
    pub body_disp_m: f64,
    pub body_vel_m_s: f64,
    pub wheel_disp_m: f64,
    pub wheel_vel_m_s: f64,
}

impl QuarterCarState {
    fn to_array(self) -> [f64; QUARTER_CAR_STATES] {
        let mut out = [0.0; QUARTER_CAR_STATES];
        let u = self.unit.to_array();
        let tail = [self.body_disp_m, self.body_vel_m_s, self.wheel_disp_m, self.wheel_vel_m_s];
        for (o, v) in out.iter_mut().zip(u.iter().chain(tail.iter())) {
            *o = *v;
        }
        out
    }

    fn from_array(a: &[f64; QUARTER_CAR_STATES]) -> Self {
        let mut u = [0.0; UNIT_STATES];
        for (o, v) in u.iter_mut().zip(a.iter()) {
            *o = *v;
        }
        let [.., body_disp_m, body_vel_m_s, wheel_disp_m, wheel_vel_m_s] = *a;
        QuarterCarState { unit: UnitState::from_array(&u), body_disp_m, body_vel_m_s, wheel_disp_m, wheel_vel_m_s }
    }
}

/// Everything observed at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct QuarterCarSample {
    pub time_s: f64,
    pub body_disp_m: f64,
    pub body_vel_m_s: f64,
    /// Body acceleration, gravity removed, m/s^2.
    pub body_acc_m_s2: f64,
    pub wheel_disp_m: f64,
    pub wheel_vel_m_s: f64,
    pub wheel_acc_m_s2: f64,
    pub road_m: f64,
    pub valves: Valves,
    /// Strut, unit and tyre.
    pub corner: CornerForces,
}

/// A unit in a quarter car on a road: an ODE system for the integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuarterCar<'a> {
    unit: &'a Unit,
    params: QuarterCarParams,
    road: Motion<'a>,
    ambient_k: f64,
    /// Valve commands, held over each integration step.
    pub valves: Valves,
    static_disp_m: f64,
    tyre_static_deflection_m: f64,
}

impl<'a> QuarterCar<'a> {
    /// Checks the parameters and finds the static equilibrium with `valves`.
    pub fn new(unit: &'a Unit, params: QuarterCarParams, road: Motion<'a>, ambient_k: f64, valves: Valves) -> Result<Self> {
        check_range("ambient_k", ambient_k, 200.0, 600.0)?;
        check_range("sprung_mass_kg", params.sprung_mass_kg, 1.0, 1e6)?;
        check_range("unsprung_mass_kg", params.unsprung_mass_kg, 0.1, 1e5)?;
        params.tyre.validate()?;
        road.validate()?;
        let load_n = params.sprung_mass_kg * STANDARD_GRAVITY_M_S2;
        let static_disp_m = unit.static_disp_for_load_m(load_n, ambient_k, valves)?;
        let tyre_static_deflection_m =
            (params.sprung_mass_kg + params.unsprung_mass_kg) * STANDARD_GRAVITY_M_S2 / params.tyre.stiffness_n_per_m;
        Ok(QuarterCar { unit, params, road, ambient_k, valves, static_disp_m, tyre_static_deflection_m })
    }

    /// Strut compression at static equilibrium, m.
    pub fn static_disp_m(&self) -> f64 {
        self.static_disp_m
    }

    /// Tyre deflection at static equilibrium, m.
    pub fn tyre_static_deflection_m(&self) -> f64 {
        self.tyre_static_deflection_m
    }

    /// At rest in static equilibrium on the road's starting height.
    pub fn initial_state(&self) -> Result<QuarterCarState> {
        let unit = self.unit.state_at_rest(self.static_disp_m, self.ambient_k, self.valves)?;
        let (z0, _) = self.road.at(0.0);
        Ok(QuarterCarState { unit, body_disp_m: z0, body_vel_m_s: 0.0, wheel_disp_m: z0, wheel_vel_m_s: 0.0 })
    }

    #[inline]
    fn evaluate(&self, t_s: f64, s: &QuarterCarState) -> (QuarterCarState, QuarterCarSample) {
        let (road_m, road_vel_m_s) = self.road.at(t_s);
        let motion = CornerMotion {
            body_disp_m: s.body_disp_m,
            body_vel_m_s: s.body_vel_m_s,
            wheel_disp_m: s.wheel_disp_m,
            wheel_vel_m_s: s.wheel_vel_m_s,
            road_m,
            road_vel_m_s,
        };
        let (unit_rate, c) = corner::evaluate(
            self.unit,
            &self.params.tyre,
            &s.unit,
            &motion,
            self.static_disp_m,
            self.tyre_static_deflection_m,
            self.valves,
            self.ambient_k,
        );
        let p = &self.params;
        let body_acc = c.unit.force_true_n / p.sprung_mass_kg - STANDARD_GRAVITY_M_S2;
        let wheel_acc = (c.tyre_force_n - c.unit.force_true_n) / p.unsprung_mass_kg - STANDARD_GRAVITY_M_S2;
        let rate = QuarterCarState {
            unit: unit_rate,
            body_disp_m: s.body_vel_m_s,
            body_vel_m_s: body_acc,
            wheel_disp_m: s.wheel_vel_m_s,
            wheel_vel_m_s: wheel_acc,
        };
        let sample = QuarterCarSample {
            time_s: t_s,
            body_disp_m: s.body_disp_m,
            body_vel_m_s: s.body_vel_m_s,
            body_acc_m_s2: body_acc,
            wheel_disp_m: s.wheel_disp_m,
            wheel_vel_m_s: s.wheel_vel_m_s,
            wheel_acc_m_s2: wheel_acc,
            road_m,
            valves: self.valves,
            corner: c,
        };
        (rate, sample)
    }

    fn check(&self, t_s: f64, s: &QuarterCarState) -> Result<()> {
        self.unit.check_state(&s.unit, t_s)?;
        let sum = s.body_disp_m + s.body_vel_m_s + s.wheel_disp_m + s.wheel_vel_m_s;
        if sum.is_finite() {
            Ok(())
        } else {
            Err(Error::StateOutOfRange { name: "body_disp_m", value: sum, min: f64::MIN, max: f64::MAX, time_s: t_s })
        }
    }

    /// The state rate and the observed quantities at `(t_s, state)`.
    pub fn rate_and_sample(&self, t_s: f64, state: &QuarterCarState) -> Result<(QuarterCarState, QuarterCarSample)> {
        self.check(t_s, state)?;
        Ok(self.evaluate(t_s, state))
    }

    /// Advances from `t_s` to `t_end_s` with the current valves in equal RK4
    /// steps of at most `max_dt_s`; `rate` is the state rate at `t_s`.
    pub fn advance(&self, t_s: f64, t_end_s: f64, state: &QuarterCarState, rate: &QuarterCarState, max_dt_s: f64) -> Result<QuarterCarState> {
        let y = stepping::advance(self, t_s, t_end_s, &state.to_array(), &rate.to_array(), max_dt_s, |t, y| {
            let mut s = QuarterCarState::from_array(y);
            self.unit.project(&mut s.unit, self.ambient_k);
            self.check(t, &s)?;
            *y = s.to_array();
            Ok(())
        })?;
        Ok(QuarterCarState::from_array(&y))
    }
}

impl OdeSystem<QUARTER_CAR_STATES> for QuarterCar<'_> {
    fn derivatives(&self, t_s: f64, y: &[f64; QUARTER_CAR_STATES]) -> Result<[f64; QUARTER_CAR_STATES]> {
        Ok(self.evaluate(t_s, &QuarterCarState::from_array(y)).0.to_array())
    }
}
