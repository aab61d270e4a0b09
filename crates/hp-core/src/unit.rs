//! The spring-damper unit: strut, damper pack with bypass valve 5,
//! accumulator S (always connected) and accumulator L behind valve 6.
//!
//! ```text
//! strut --damper pack / valve 5--> S (gas) --valve 6 (orifice)--> L (gas)
//! ```
//!
//! Compressing the strut pushes oil through the damper into S; oil moves
//! between S and L through valve 6 when it is open, driven by their pressure
//! difference, so the two pressures can differ during fast motion. The oil is
//! incompressible unless the oil-compliance effect is switched on; then the
//! strut pressure becomes a state. Rebound is limited by cavitation: the
//! strut pressure cannot fall below the oil's vapour pressure; when it would,
//! a vapour void opens in the strut and closes again on compression.
//!
//! The optional [`Effects`] are the model terms `hpctl diagnose` can add or
//! remove; with all of them off the unit is the seed's model.

use crate::damper::{Damper, Orifice, PreparedDamper};
use crate::effect::{EffectParams, EffectVisitor};
use crate::effect_params;
use crate::error::{check_range, Error, Result};
use crate::gas::{EquationOfState, Gas, GasProps, DENSITY_RANGE_KG_M3, TEMPERATURE_RANGE_K};
use crate::lag::{self, Lag, LagState};
use crate::ranges::{self, Range};
use crate::thermal::{gas_temperature_k, temperature_rate_k_s, temperature_rate_per_volume_rate, HeatTransfer};

/// Standard gravity, m/s^2.
pub const STANDARD_GRAVITY_M_S2: f64 = 9.80665;

/// The oil node's wall heat capacity at which the gas's heat does not warm
/// the wall (the rate skips the term): the default, J/K.
pub const NO_WALL_WARMING_J_PER_K: f64 = 1e12;

/// The temperature difference at which `OilNode::oil_to_ambient_tau_s`
/// holds when its exponent is not 0, K.
pub const OIL_COOLING_REFERENCE_K: f64 = 100.0;

effect_params! {
    /// Seal friction between strut piston and cylinder.
    Friction = "friction" {
        /// Coulomb (dry) friction force, N.
        coulomb_n: [Range::new("friction_coulomb_n", 0.0, 1e6)],
        /// Viscous friction coefficient, N s/m.
        viscous_n_s_per_m: [Range::new("friction_viscous_n_s_per_m", 0.0, 1e7), default 0.0],
        /// Velocity over which the Coulomb force builds up (tanh), m/s: the
        /// seal's pre-sliding compliance, and what keeps the model smooth.
        smoothing_velocity_m_s: [Range::new("friction_smoothing_velocity_m_s", 1e-6, 1.0), default 1e-3],
        /// Static over kinetic friction, `F_s / F_c` (1 = no Stribeck peak).
        stribeck_ratio: [Range::new("friction_stribeck_ratio", 1.0, 10.0), default 1.0],
        /// Velocity over which the static excess decays, `exp(-(v/v_s)^2)`, m/s.
        stribeck_velocity_m_s: [Range::new("friction_stribeck_velocity_m_s", 1e-5, 1.0), default 0.01],
    }
}

impl Friction {
    /// Coulomb and viscous friction with the seed-era defaults: no Stribeck
    /// peak.
    pub fn new(coulomb_n: f64, viscous_n_s_per_m: f64, smoothing_velocity_m_s: f64) -> Self {
        Friction { coulomb_n, viscous_n_s_per_m, smoothing_velocity_m_s, stribeck_ratio: 1.0, stribeck_velocity_m_s: 0.01 }
    }

    /// Friction force at strut velocity `vel_m_s`, N:
    /// `[F_c + (F_s - F_c) exp(-(v/v_s)^2)] tanh(v/v_e) + c v`, the smoothed
    /// Stribeck curve (with `stribeck_ratio` 1 exactly the smoothed Coulomb
    /// plus viscous law).
    ///
    /// ```
    /// use hp_core::unit::Friction;
    /// let mut f = Friction::new(400.0, 300.0, 1e-3);
    /// let plain = f.force_n(0.5);
    /// assert!((plain - (400.0 * libm::tanh(500.0) + 150.0)).abs() < 1e-9);
    /// f.stribeck_ratio = 1.5;
    /// f.stribeck_velocity_m_s = 0.01;
    /// assert!(f.force_n(0.005) > Friction::new(400.0, 300.0, 1e-3).force_n(0.005));
    /// assert!((f.force_n(0.5) - plain).abs() < 1e-6);
    /// ```
    pub fn force_n(&self, vel_m_s: f64) -> f64 {
        let x = vel_m_s / self.stribeck_velocity_m_s;
        let level = self.coulomb_n * (1.0 + (self.stribeck_ratio - 1.0) * libm::exp(-x * x));
        level * libm::tanh(vel_m_s / self.smoothing_velocity_m_s) + self.viscous_n_s_per_m * vel_m_s
    }

    /// `d(force_n)/d(vel_m_s)`, N s/m.
    pub fn slope_n_s_per_m(&self, vel_m_s: f64) -> f64 {
        let x = vel_m_s / self.stribeck_velocity_m_s;
        let peak = self.coulomb_n * (self.stribeck_ratio - 1.0) * libm::exp(-x * x);
        let level = self.coulomb_n + peak;
        let th = libm::tanh(vel_m_s / self.smoothing_velocity_m_s);
        -2.0 * x / self.stribeck_velocity_m_s * peak * th + level * (1.0 - th * th) / self.smoothing_velocity_m_s + self.viscous_n_s_per_m
    }
}

effect_params! {
    /// Oil compressibility and hose compliance between strut and damper.
    OilCompliance = "oil_compliance" {
        /// Effective bulk modulus of oil plus hoses, Pa.
        bulk_modulus_pa: [Range::new("oil_bulk_modulus_pa", 1e6, 1e11)],
        /// Oil volume on the strut side of the damper, m^3.
        oil_volume_m3: [Range::new("oil_volume_m3", 1e-6, 1.0)],
    }
}

effect_params! {
    /// Lumped thermal nodes for damper heat build-up: the damper heats the oil,
    /// the oil warms the gas accumulators' wall slowly, both lose heat to ambient.
    OilNode = "oil_node" {
        /// Heat capacity of the oil and the steel around it, J/K.
        heat_capacity_j_per_k: [Range::new("oil_heat_capacity_j_per_k", 1.0, 1e9)],
        /// Oil-to-ambient time constant, s (at a 100 K difference when
        /// `oil_to_ambient_exponent` is not 0).
        oil_to_ambient_tau_s: [Range::new("oil_to_ambient_tau_s", 1e-3, 1e9)],
        /// Time constant of the gas wall following the oil, s.
        wall_to_oil_tau_s: [Range::new("wall_to_oil_tau_s", 1e-3, 1e9)],
        /// Time constant of the gas wall following ambient, s.
        wall_to_ambient_tau_s: [Range::new("wall_to_ambient_tau_s", 1e-3, 1e9)],
        /// Heat capacity of the gas accumulators' wall, J/K: the heat the
        /// gas gives its wall (a working gas spring's hysteresis, hundreds
        /// of W on a heat run) warms it, and the wall and the oil exchange
        /// heat both ways. The default, 1e12, is a wall the gas cannot warm
        /// and that follows the oil without cooling it (the seed's
        /// calibration, which lumps the gas's heat into that coupling).
        wall_heat_capacity_j_per_k: [Range::new("wall_heat_capacity_j_per_k", 1.0, NO_WALL_WARMING_J_PER_K), default NO_WALL_WARMING_J_PER_K],
        /// How the oil's time constant to ambient grows as the difference
        /// falls (natural convection: the seed measured 3000 s at 100 K and
        /// 6500 s below 20 K, an exponent of 0.48): at a difference dT it is
        /// `oil_to_ambient_tau_s (100 K / |dT|)^n`. 0, the default: constant.
        oil_to_ambient_exponent: [Range::new("oil_to_ambient_exponent", 0.0, 3.0), default 0.0],
    }
}

effect_params! {
    /// Slow loss of gas from both accumulators (past the floating piston
    /// seals): `dm/dt = -(m0 / tau) (m / m0)^k r^n`, `m0` the accumulator's
    /// gas mass at the static state and `r = (p - p_amb) / (p_static -
    /// p_amb)` its gauge pressure over the static one. The defaults, `k = 1`
    /// and `n = 0`, are a decay at the time constant whatever the pressure
    /// (`dm/dt = -m / tau`); `n = 1` a leak driven by the pressure
    /// difference, so the compressed accumulator leaks faster; `k = 0` a
    /// flow that does not follow the gas's mass beyond its pressure (seal
    /// permeation: `k = 0, n = 1` is `dm/dt = -(m0 / tau) r`).
    Leakage = "leakage" {
        /// Time constant of the gas mass decay at the static pressure, s.
        time_constant_s: [Range::new("leak_time_constant_s", 1.0, 1e12)],
        /// Exponent `n` of the gauge-pressure ratio the rate goes with.
        pressure_exponent: [Range::new("leak_pressure_exponent", 0.0, 4.0), default 0.0],
        /// Exponent `k` of the gas mass over the static one the rate goes
        /// with (a fitted shape: below 0 the rate rises as the gas is lost,
        /// which a fit of a leak with `k = 0` may find within its errors;
        /// a leak's mass never falls below 0). Declared last so that the older positional form (time
        /// constant, pressure exponent) keeps its meaning.
        mass_exponent: [Range::new("leak_mass_exponent", -4.0, 4.0), default 1.0],
    }
}

effect_params! {
    /// The solenoid valves follow their command with a first-order lag.
    ValveLag = "valve_lag" {
        /// Valve response time constant, s.
        time_constant_s: [Range::new("valve_time_constant_s", 1e-5, 10.0)],
    }
}

effect_params! {
    /// Gas-wall heat transfer through a wall conductance `h A` that does not
    /// follow the gas's heat capacity: the thermal time constant
    /// `tau = m c_v / (h A)` moves with `m c_v` as
    /// `tau_s (m c_v / (m c_v)_static)^n` instead of staying at `tau_s`
    /// (`c_v` of real nitrogen rises 2-3 % from 15 to 30 MPa; `m` falls
    /// with a leak). `n = 0` is the seed's constant time constant, `n = 1`
    /// a constant conductance. Acts only with a finite time constant.
    WallConductance = "wall_conductance" {
        /// The exponent `n` of `m c_v` in the time constant (1 = constant `h A`).
        cv_exponent: [Range::new("tau_cv_exponent", -10.0, 10.0), default 1.0],
    }
}

effect_params! {
    /// Imperfect transducers on the measured force and pressures.
    Sensor = "sensor" {
        /// Offset added to the measured strut force, N.
        force_offset_n: [Range::new("sensor_force_offset_n", -1e6, 1e6), default 0.0],
        /// Offset added to the measured gas pressure of S (its own transducer), Pa.
        pressure_offset_pa: [Range::new("sensor_pressure_offset_pa", -1e8, 1e8), default 0.0],
        /// First-order lag of all measured channels ([`crate::lag`]), s (0 = none).
        time_constant_s: [lag::TIME_CONSTANT_S, default 0.0],
        /// Offset added to the measured gas pressure of L (a second transducer,
        /// with its own zero error), Pa. Declared last so that the older
        /// positional form (force, pressure, lag) keeps its meaning.
        pressure2_offset_pa: [Range::new("sensor_pressure2_offset_pa", -1e8, 1e8), default 0.0],
    }
}

/// The switchable model terms. `None` = the effect is absent.
///
/// Adding an effect: its parameter struct with [`effect_params!`] above (the
/// fields, their ranges and defaults), a field here and a line in
/// [`Effects::visit`], its term in the unit's equations; the bindings and
/// the Python parameter classes follow from the table (docs/architecture.md).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effects {
    pub friction: Option<Friction>,
    pub oil_compliance: Option<OilCompliance>,
    pub oil_node: Option<OilNode>,
    pub leakage: Option<Leakage>,
    pub valve_lag: Option<ValveLag>,
    pub sensor: Option<Sensor>,
    pub wall_conductance: Option<WallConductance>,
}

/// Every effect absent (what [`Effects::default`] gives), as a constant.
const NO_EFFECTS: Effects = Effects { friction: None, oil_compliance: None, oil_node: None, leakage: None, valve_lag: None, sensor: None, wall_conductance: None };

impl Effects {
    /// Calls `v` on every effect slot, in declaration order: the one list of
    /// the effects that checking, the bindings' conversions and the
    /// exported parameter tables walk.
    pub fn visit<V: EffectVisitor>(&mut self, v: &mut V) -> core::result::Result<(), V::Error> {
        v.visit(&mut self.friction)?;
        v.visit(&mut self.oil_compliance)?;
        v.visit(&mut self.oil_node)?;
        v.visit(&mut self.leakage)?;
        v.visit(&mut self.valve_lag)?;
        v.visit(&mut self.sensor)?;
        v.visit(&mut self.wall_conductance)?;
        Ok(())
    }

    /// Every present effect's parameters in their ranges.
    pub fn validate(&self) -> Result<()> {
        struct Check;
        impl EffectVisitor for Check {
            type Error = Error;
            fn visit<T: EffectParams>(&mut self, slot: &mut Option<T>) -> Result<()> {
                slot.as_ref().map_or(Ok(()), EffectParams::validate)
            }
        }
        let mut copy = *self;
        copy.visit(&mut Check)
    }
}

/// Everything that defines a unit, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitParams {
    /// Strut piston area, m^2.
    pub piston_area_m2: f64,
    /// Gas volume of accumulator S at the static position, m^3.
    pub small_acc_volume_m3: f64,
    /// Gas volume of accumulator L at the static position, m^3.
    pub large_acc_volume_m3: f64,
    /// Gas pressure in both accumulators at the static position, Pa.
    pub static_pressure_pa: f64,
    /// Gas temperature at the static position, K.
    pub static_temperature_k: f64,
    /// Equation of state of the gas.
    pub gas: Gas,
    /// Heat exchange between gas and wall.
    pub heat: HeatTransfer,
    /// Valve 6 as an orifice.
    pub valve6: Orifice,
    /// The damper pack and bypass valve 5.
    pub damper: Damper,
    /// Oil density, kg/m^3.
    pub oil_density_kg_m3: f64,
    /// Lowest absolute pressure the oil in the strut can have, Pa.
    pub vapour_pressure_pa: f64,
    /// Pressure on the other side of the strut piston, Pa.
    pub ambient_pressure_pa: f64,
    /// Travel from the static position to the compression end stop, m.
    pub stroke_compression_m: f64,
    /// Travel from the static position to the extension end stop, m.
    pub stroke_extension_m: f64,
    /// Stiffness of the end stops, N/m.
    pub end_stop_stiffness_n_per_m: f64,
    /// Damping of the end stops, N s/m.
    pub end_stop_damping_n_s_per_m: f64,
    /// Highest strut speed the unit is rated for (its damper
    /// characterised up to), m/s. The model does not use it: a run beyond
    /// it is outside what the unit's data describe, which the front ends
    /// report as a warning.
    pub rated_speed_m_s: f64,
    /// Optional model terms.
    pub effects: Effects,
}

/// Valve commands: `true` = energised open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Valves {
    /// Valve 5 open: damper bypassed (low damping, "damper off").
    pub valve5_open: bool,
    /// Valve 6 open: L connected (soft spring).
    pub valve6_open: bool,
}

impl Valves {
    /// From the modes a test engineer names.
    pub fn from_modes(spring_hard: bool, damper_on: bool) -> Self {
        Valves { valve5_open: !damper_on, valve6_open: !spring_hard }
    }
    /// True when valve 6 is closed (S alone).
    pub fn spring_hard(self) -> bool {
        !self.valve6_open
    }
    /// True when valve 5 is closed (oil through the damper pack).
    pub fn damper_on(self) -> bool {
        !self.valve5_open
    }
}

/// Number of states of the unit.
pub const UNIT_STATES: usize = 18;

/// The unit's state. The temperature states are unused (and reported as the
/// wall temperature) when the heat transfer is isothermal.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UnitState {
    pub t_gas_k: f64,
    pub t_gas2_k: f64,
    /// Gas volume in S, m^3.
    pub v_gas_m3: f64,
    /// Gas volume in L, m^3.
    pub v_gas2_m3: f64,
    pub m_small_kg: f64,
    pub m_large_kg: f64,
    /// Vapour void in the strut, m^3.
    pub v_void_m3: f64,
    /// Strut oil pressure (a state only with oil compliance), Pa.
    pub p_strut_pa: f64,
    pub t_oil_k: f64,
    /// Gas wall temperature (a state only with the oil node), K.
    pub t_wall_k: f64,
    /// Valve 5 opening, 0..1 (a state only with valve lag).
    pub valve5_open_frac: f64,
    /// Valve 6 opening, 0..1 (a state only with valve lag).
    pub valve6_open_frac: f64,
    /// Lagged force transducer reading (without offset), N.
    pub force_sensor_n: f64,
    /// Lagged pressure transducer readings (without offset), Pa.
    pub p_small_sensor_pa: f64,
    pub p_large_sensor_pa: f64,
    /// Energy dissipated in the damper pack, J.
    pub e_damper_j: f64,
    /// Energy dissipated by seal friction, J.
    pub e_friction_j: f64,
    /// Energy dissipated in valve 6, J.
    pub e_valve6_j: f64,
}

impl UnitState {
    /// As a flat array (the integrator's view).
    pub fn to_array(&self) -> [f64; UNIT_STATES] {
        [
            self.t_gas_k,
            self.t_gas2_k,
            self.v_gas_m3,
            self.v_gas2_m3,
            self.m_small_kg,
            self.m_large_kg,
            self.v_void_m3,
            self.p_strut_pa,
            self.t_oil_k,
            self.t_wall_k,
            self.valve5_open_frac,
            self.valve6_open_frac,
            self.force_sensor_n,
            self.p_small_sensor_pa,
            self.p_large_sensor_pa,
            self.e_damper_j,
            self.e_friction_j,
            self.e_valve6_j,
        ]
    }

    /// From a flat array, the inverse of [`UnitState::to_array`].
    pub fn from_array(a: &[f64; UNIT_STATES]) -> Self {
        let [t_gas_k, t_gas2_k, v_gas_m3, v_gas2_m3, m_small_kg, m_large_kg, v_void_m3, p_strut_pa, t_oil_k, t_wall_k, valve5_open_frac, valve6_open_frac, force_sensor_n, p_small_sensor_pa, p_large_sensor_pa, e_damper_j, e_friction_j, e_valve6_j] =
            *a;
        UnitState {
            t_gas_k,
            t_gas2_k,
            v_gas_m3,
            v_gas2_m3,
            m_small_kg,
            m_large_kg,
            v_void_m3,
            p_strut_pa,
            t_oil_k,
            t_wall_k,
            valve5_open_frac,
            valve6_open_frac,
            force_sensor_n,
            p_small_sensor_pa,
            p_large_sensor_pa,
            e_damper_j,
            e_friction_j,
            e_valve6_j,
        }
    }
}

/// Prescribed strut motion at one instant: compression from the static
/// position (positive = compression) and its rate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StrutMotion {
    pub disp_m: f64,
    pub vel_m_s: f64,
}

/// What the unit does at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UnitOutputs {
    /// Strut force (positive = compression force), N.
    pub force_true_n: f64,
    /// Strut force as the transducer reports it, N.
    pub force_n: f64,
    /// Absolute strut oil pressure, Pa.
    pub p_strut_pa: f64,
    /// Gas pressure in S, Pa.
    pub p_gas_true_pa: f64,
    /// Gas pressure in L, Pa.
    pub p_gas2_true_pa: f64,
    /// Gas pressures as the transducers report them, Pa.
    pub p_gas_pa: f64,
    pub p_gas2_pa: f64,
    /// Gas temperatures, K.
    pub t_gas_k: f64,
    pub t_gas2_k: f64,
    /// Gas wall temperature, K.
    pub t_wall_k: f64,
    /// Oil temperature (ambient when the oil node is off), K.
    pub t_oil_k: f64,
    /// Force from the pressure drop over the damper, `A (p_strut - p_S)`, N.
    pub damper_force_n: f64,
    /// Power dissipated in the damper pack, W.
    pub damper_power_w: f64,
    /// Seal friction force, N.
    pub friction_force_n: f64,
    /// Power dissipated in seal friction, W.
    pub friction_power_w: f64,
    /// Power dissipated in valve 6, W.
    pub valve6_power_w: f64,
    /// Flow out of the strut through the damper, m^3/s.
    pub flow_damper_m3_s: f64,
    /// Flow from S to L through valve 6, m^3/s.
    pub flow_valve6_m3_s: f64,
    /// True while a vapour void is open in the strut.
    pub cavitating: bool,
}

/// The linearisation of a stiff flow: the state rate depends on the flow
/// `q` through `u = d(rate)/d(q)`, the flow on the state through
/// `v = d(q)/d(state)`, so `u v^T` is a stiff part of the Jacobian (see
/// [`crate::adaptive`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlowCoupling {
    pub u: UnitState,
    pub v: UnitState,
}

/// The valve-6 exchange linearised: the orifice equalises S and L within
/// about a millisecond.
pub type Valve6Coupling = FlowCoupling;

/// The strut's linearisation: how the strut force depends on the unit's
/// state and on the strut's motion, and how the state rate depends on the
/// strut velocity. Whoever moves the strut (a wheel, a body) closes the
/// loop through it: the unit's spring (the gas volume the strut
/// velocity changes, whose pressure is the force) and its damper become a
/// low-rank part of that system's Jacobian, which a linearly implicit step
/// can treat implicitly. Given for the incompressible oil while the strut
/// does not cavitate (else None: the rate does not then depend on the gas
/// through the force).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StrutCoupling {
    /// `d(force_true_n)/d(state)`.
    pub force_per_state: UnitState,
    /// `d(force_true_n)/d(strut velocity)`, N s/m: damper, friction, end stop.
    pub force_per_vel_n_s_per_m: f64,
    /// `d(force_true_n)/d(strut compression)`, N/m: the end stop (the gas
    /// spring acts through the volume states).
    pub force_per_disp_n_per_m: f64,
    /// `d(state rate)/d(strut velocity)`.
    pub rate_per_vel: UnitState,
}

/// The unit's linearisations, as [`Unit::evaluate_parts`] returns them
/// when [`Needs`] asks: the stiff flows ([`Needs::coupling`]) for a
/// Rosenbrock-W's `W` on the unit's own states (the adaptive rig), the
/// strut ([`Needs::strut`]) for whoever moves the strut and puts it in its
/// `W` (the vehicle's ROS2).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Linearisation {
    /// The valve-6 exchange (when valve 6 is open).
    pub valve6: Option<Valve6Coupling>,
    /// The damper flow with oil compliance (when the strut pressure is a
    /// state, not pinned at the vapour pressure): the oil spring relaxes
    /// through the damper pack in `V_oil / (B dq/dp)`, about 0.5-10 ms
    /// (oil volume `V_oil`, bulk modulus `B`, the pack's `dq/dp`), far
    /// faster than the motion the steps must follow.
    pub damper: Option<FlowCoupling>,
    /// The strut (see [`StrutCoupling`]).
    pub strut: Option<StrutCoupling>,
}

/// What [`Unit::evaluate_parts`] must produce besides the state rate and
/// the strut force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needs {
    /// Every output (else only `force_true_n`, `p_gas_true_pa`, `p_strut_pa` and
    /// the flows are meaningful in the returned outputs, and L's gas is
    /// evaluated only where the rate needs it).
    pub outputs: bool,
    /// The stiff flows' linearisations ([`Linearisation::valve6`],
    /// [`Linearisation::damper`]).
    pub coupling: bool,
    /// The strut's linearisation ([`StrutCoupling`]).
    pub strut: bool,
    /// The state rate (else only the outputs are meaningful, and the gas is
    /// evaluated for its pressure alone: an output sample).
    pub rates: bool,
}

/// Placeholder properties for a gas whose properties nothing reads:
/// finite, so that terms multiplied by a zero rate stay zero.
const UNUSED_PROPS: GasProps = GasProps { p_pa: 0.0, dp_dt_pa_per_k: 0.0, dp_drho_pa_m3_per_kg: 0.0, cv_j_per_kg_k: 1.0 };

/// The gradient of an accumulator's gas pressure `p(m/V, T)` over its
/// states: `dp/dT`, `dp/dV = -(m/V^2) dp/drho`, `dp/dm = (1/V) dp/drho`.
/// Every linearisation through a gas pressure (valve 6's flow, the damper
/// flow with oil compliance, the strut force) takes it from here.
#[derive(Debug, Clone, Copy)]
struct PressureGradient {
    per_t: f64,
    per_v: f64,
    per_m: f64,
}

/// One accumulator's gas mass and volume: what the linearisations read
/// of the state (passed by value, so that the state need not be kept in
/// memory for them).
#[derive(Debug, Clone, Copy)]
struct GasMass {
    mass_kg: f64,
    volume_m3: f64,
}

impl GasMass {
    #[inline(always)]
    fn small(s: &UnitState) -> Self {
        GasMass { mass_kg: s.m_small_kg, volume_m3: s.v_gas_m3 }
    }
    #[inline(always)]
    fn large(s: &UnitState) -> Self {
        GasMass { mass_kg: s.m_large_kg, volume_m3: s.v_gas2_m3 }
    }
}

impl PressureGradient {
    fn of(heat: HeatTransfer, props: &GasProps, mass_kg: f64, volume_m3: f64) -> Self {
        let per_m = props.dp_drho_pa_m3_per_kg / volume_m3;
        // Isothermal gas sits at the wall temperature, whatever its
        // temperature state holds: the pressure does not depend on it.
        let per_t = if heat == HeatTransfer::Isothermal { 0.0 } else { props.dp_dt_pa_per_k };
        PressureGradient { per_t, per_v: -per_m * mass_kg / volume_m3, per_m }
    }
}

/// A validated unit with its derived gas masses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    params: UnitParams,
    small_mass_kg: f64,
    large_mass_kg: f64,
    valve6_coefficient: f64,
    /// The damper with its curves' knees computed once (it is evaluated at
    /// every stage of every step).
    damper: PreparedDamper,
    /// `c_v` of the gas at the static state, J/(kg K): the reference of a
    /// time constant that moves with the heat capacity ([`WallConductance`]).
    static_cv_j_per_kg_k: f64,
    /// No optional effects and a finite thermal time constant: the model
    /// the vehicles run, evaluated with those choices known
    /// ([`Unit::evaluate_parts_plain_with`]).
    plain: bool,
}

/// `x^n` for `x >= 0`, as `exp(n ln x)`: the effects' power laws are
/// evaluated at every stage of every step, and fdlibm's `pow` (the `libm`
/// crate's) took 26 ns a call against 10 ns for its `log` and `exp`, 15 %
/// of a flexible fit's model time (perf, stop 60). Within a few ulp of
/// `pow` (the bases here lie within a decade or two of 1, so `n ln x` is a
/// few units at most); `x` itself for `n = 1` and 1 for `n = 0`, exactly,
/// as `pow` (including `0^0 = 1`); `0^n` is 0 for `n > 0` and infinite
/// for `n < 0`, as `pow`.
///
/// ```
/// # use hp_core::unit::power;
/// for (x, n) in [(0.97, 0.9066), (1.03, -2.0), (0.3, 0.4804), (2.5, 3.0), (1e-3, 0.5)] {
///     let (ours, reference) = (power(x, n), libm::pow(x, n));
///     assert!((ours / reference - 1.0).abs() < 1e-15, "{x}^{n}: {ours} vs {reference}");
/// }
/// assert_eq!(power(0.7, 1.0), 0.7);
/// assert_eq!(power(0.0, 0.0), 1.0);
/// assert_eq!(power(0.0, 0.5), 0.0);
/// assert_eq!(power(0.0, -1.0), f64::INFINITY);
/// ```
#[inline(always)]
pub fn power(x: f64, n: f64) -> f64 {
    if n == 1.0 {
        x
    } else if n == 0.0 {
        1.0
    } else {
        libm::exp(n * libm::log(x))
    }
}

/// A gas volume the model can evaluate holding `m` kg: positive mass,
/// density below the range's top, under 10 m^3. `v rho_max > m` rather
/// than `v > m / rho_max`: the same bound without a division on the hot
/// path (every unit, every step); [`Unit::check_state`] and the error it
/// builds share it, so the error always names the variable that failed.
#[inline(always)]
fn volume_ok(v: f64, m: f64) -> bool {
    m > 0.0 && v * DENSITY_RANGE_KG_M3.1 > m && v < 10.0
}

/// [`Unit::check_state`]'s test: the four temperatures (gas S, gas L,
/// wall, oil) in range, the two gas volumes with their masses plausible,
/// and the sum of the other checked states (strut pressure, void, the
/// three sensors) finite. One cheap test on the hot path; the error is
/// built only on failure.
#[inline(always)]
fn values_ok(temperatures: [f64; 4], volumes: [(f64, f64); 2], finite: [f64; 5]) -> bool {
    let (t_min, t_max) = TEMPERATURE_RANGE_K;
    let temperature_ok = |t: f64| t >= t_min && t <= t_max;
    let [t_gas, t_gas2, t_wall, t_oil] = temperatures;
    let [(v_gas, m_small), (v_gas2, m_large)] = volumes;
    let [p_strut, v_void, force_sensor, p_small_sensor, p_large_sensor] = finite;
    temperature_ok(t_gas)
        && temperature_ok(t_gas2)
        && temperature_ok(t_wall)
        && temperature_ok(t_oil)
        && volume_ok(v_gas, m_small)
        && volume_ok(v_gas2, m_large)
        && (p_strut + v_void + force_sensor + p_small_sensor + p_large_sensor).is_finite()
}

/// [`values_ok`] for a state.
#[inline(always)]
fn state_ok(s: &UnitState) -> bool {
    values_ok(
        [s.t_gas_k, s.t_gas2_k, s.t_wall_k, s.t_oil_k],
        [(s.v_gas_m3, s.m_small_kg), (s.v_gas2_m3, s.m_large_kg)],
        [s.p_strut_pa, s.v_void_m3, s.force_sensor_n, s.p_small_sensor_pa, s.p_large_sensor_pa],
    )
}

impl Unit {
    /// Checks every parameter and derives the gas masses from the static
    /// state. Errors name the parameter, its value and the valid range.
    pub fn new(params: UnitParams) -> Result<Self> {
        let p = &params;
        ranges::PISTON_AREA_M2.check(p.piston_area_m2)?;
        ranges::SMALL_ACC_VOLUME_M3.check(p.small_acc_volume_m3)?;
        ranges::LARGE_ACC_VOLUME_M3.check(p.large_acc_volume_m3)?;
        ranges::STATIC_PRESSURE_PA.check(p.static_pressure_pa)?;
        ranges::STATIC_TEMPERATURE_K.check(p.static_temperature_k)?;
        ranges::OIL_DENSITY_KG_M3.check(p.oil_density_kg_m3)?;
        ranges::VAPOUR_PRESSURE_PA.check(p.vapour_pressure_pa)?;
        ranges::AMBIENT_PRESSURE_PA.check(p.ambient_pressure_pa)?;
        ranges::STROKE_COMPRESSION_M.check(p.stroke_compression_m)?;
        ranges::STROKE_EXTENSION_M.check(p.stroke_extension_m)?;
        ranges::END_STOP_STIFFNESS_N_PER_M.check(p.end_stop_stiffness_n_per_m)?;
        ranges::END_STOP_DAMPING_N_S_PER_M.check(p.end_stop_damping_n_s_per_m)?;
        ranges::RATED_SPEED_M_S.check(p.rated_speed_m_s)?;
        match p.heat {
            HeatTransfer::TimeConstant(tau) => {
                ranges::TAU_S.check(tau)?;
            }
            HeatTransfer::Polytropic(n) => {
                ranges::POLYTROPIC_EXPONENT.check(n)?;
            }
            _ => {}
        }
        p.valve6.validate()?;
        p.damper.validate()?;
        p.effects.validate()?;
        let rho = p.gas.density_kg_m3(p.static_pressure_pa, p.static_temperature_k)?;
        Ok(Unit {
            params,
            small_mass_kg: rho * p.small_acc_volume_m3,
            large_mass_kg: rho * p.large_acc_volume_m3,
            valve6_coefficient: p.valve6.coefficient(p.oil_density_kg_m3),
            damper: PreparedDamper::new(&p.damper),
            static_cv_j_per_kg_k: p.gas.props(rho, p.static_temperature_k).cv_j_per_kg_k,
            plain: p.effects == NO_EFFECTS && matches!(p.heat, HeatTransfer::TimeConstant(_)),
        })
    }

    /// True when the unit has no optional effect and a finite thermal
    /// time constant ([`HeatTransfer::TimeConstant`]): the seed's model, the
    /// one [`Unit::evaluate_parts_plain_with`] evaluates with those choices
    /// known.
    pub fn is_plain(&self) -> bool {
        self.plain
    }

    /// The parameters the unit was built from.
    pub fn params(&self) -> &UnitParams {
        &self.params
    }

    /// Gas masses in S and L, kg.
    pub fn gas_masses_kg(&self) -> (f64, f64) {
        (self.small_mass_kg, self.large_mass_kg)
    }

    /// The state at rest at strut compression `disp_m` from the static
    /// position, with the gas at wall temperature `t_k` and oil, wall and
    /// sensors settled. With valve 6 open the two accumulators share the
    /// volume change at equal pressure; closed, S takes it alone.
    pub fn state_at_rest(&self, disp_m: f64, t_k: f64, valves: Valves) -> Result<UnitState> {
        check_range("t_k", t_k, TEMPERATURE_RANGE_K.0, TEMPERATURE_RANGE_K.1)?;
        let p = &self.params;
        let (m_s, m_l) = (self.small_mass_kg, self.large_mass_kg);
        let displaced = p.piston_area_m2 * disp_m;
        let (v_s, v_l) = if valves.valve6_open {
            let total = p.small_acc_volume_m3 + p.large_acc_volume_m3 - displaced;
            (total * m_s / (m_s + m_l), total * m_l / (m_s + m_l))
        } else {
            (p.small_acc_volume_m3 - displaced, p.large_acc_volume_m3)
        };
        let min_v = m_s / DENSITY_RANGE_KG_M3.1;
        if !(v_s > min_v) {
            return Err(Error::OutOfRange {
                name: "disp_m",
                value: disp_m,
                min: -p.stroke_extension_m,
                max: (p.small_acc_volume_m3 - min_v) / p.piston_area_m2,
            });
        }
        let p_s = p.gas.pressure_pa(m_s / v_s, t_k);
        let p_l = p.gas.pressure_pa(m_l / v_l, t_k);
        Ok(UnitState {
            t_gas_k: t_k,
            t_gas2_k: t_k,
            v_gas_m3: v_s,
            v_gas2_m3: v_l,
            m_small_kg: m_s,
            m_large_kg: m_l,
            v_void_m3: 0.0,
            p_strut_pa: p_s,
            t_oil_k: t_k,
            t_wall_k: t_k,
            valve5_open_frac: if valves.valve5_open { 1.0 } else { 0.0 },
            valve6_open_frac: if valves.valve6_open { 1.0 } else { 0.0 },
            force_sensor_n: p.piston_area_m2 * (p_s - p.ambient_pressure_pa),
            p_small_sensor_pa: p_s,
            p_large_sensor_pa: p_l,
            e_damper_j: 0.0,
            e_friction_j: 0.0,
            e_valve6_j: 0.0,
        })
    }

    /// Static strut force at rest at compression `disp_m`, N (see
    /// [`Unit::state_at_rest`]).
    pub fn static_force_n(&self, disp_m: f64, t_k: f64, valves: Valves) -> Result<f64> {
        let s = self.state_at_rest(disp_m, t_k, valves)?;
        Ok(self.params.piston_area_m2 * (s.p_strut_pa - self.params.ambient_pressure_pa))
    }

    /// The gas pressure that carries `load_n` at rest (the strut oil
    /// pressure with no flow): ambient pressure plus load over piston
    /// area, Pa.
    pub fn load_pressure_pa(&self, load_n: f64) -> Result<f64> {
        check_range("load_n", load_n, 0.0, 1e8)?;
        Ok(self.params.ambient_pressure_pa + load_n / self.params.piston_area_m2)
    }

    /// The compression at which the static force carries `load_n`, m:
    /// the ride height under a given load. Bisection over the stroke.
    pub fn static_disp_for_load_m(&self, load_n: f64, t_k: f64, valves: Valves) -> Result<f64> {
        check_range("load_n", load_n, 0.0, 1e8)?;
        let p = &self.params;
        let mut lo = -p.stroke_extension_m;
        // The gas alone limits compression in the hard setting.
        let mut hi = p.stroke_compression_m;
        while self.state_at_rest(hi, t_k, valves).is_err() && hi > lo {
            hi = lo + 0.99 * (hi - lo);
            if hi - lo < 1e-9 {
                break;
            }
        }
        let f_lo = self.static_force_n(lo, t_k, valves)?;
        let f_hi = self.static_force_n(hi, t_k, valves)?;
        if !(f_lo <= load_n && load_n <= f_hi) {
            return Err(Error::OutOfRange { name: "load_n", value: load_n, min: f_lo, max: f_hi });
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.static_force_n(mid, t_k, valves)? > load_n {
                hi = mid;
            } else {
                lo = mid;
            }
            if hi - lo < 1e-12 {
                break;
            }
        }
        Ok(0.5 * (lo + hi))
    }

    /// Checks that a state is one the model can evaluate.
    #[inline]
    pub fn check_state(&self, s: &UnitState, time_s: f64) -> Result<()> {
        if state_ok(s) {
            Ok(())
        } else {
            Err(self.state_error(s, time_s))
        }
    }

    /// [`Unit::project`] and then [`Unit::check_state`] on a state in its
    /// array form ([`UnitState::to_array`]), in place: the same operations,
    /// the same state and the same result. For a plain unit
    /// ([`Unit::is_plain`]) with no vapour void to close (the usual step)
    /// the projection only clamps the valve fractions and sets the oil and
    /// wall temperatures to ambient: those four elements are written and
    /// the others read where they are, instead of the whole state copied
    /// out and back (on the 8x8, eight units a step: about 300
    /// instructions of a period's 20k). Any other case goes through
    /// [`UnitState`].
    #[inline(always)]
    pub fn project_and_check(&self, a: &mut [f64; UNIT_STATES], ambient_k: f64, time_s: f64) -> Result<()> {
        let [_, _, _, _, _, _, v_void_m3, ..] = *a;
        // As in `project`: a NaN void is not below zero either.
        let closes_void = v_void_m3 < 0.0;
        if self.plain && !closes_void {
            // `project` for a plain unit: no oil compliance, no oil node,
            // a time constant (not isothermal).
            let [_, _, _, _, _, _, _, _, t_oil_k, t_wall_k, valve5_open_frac, valve6_open_frac, ..] = a;
            *valve5_open_frac = valve5_open_frac.clamp(0.0, 1.0);
            *valve6_open_frac = valve6_open_frac.clamp(0.0, 1.0);
            *t_oil_k = ambient_k;
            *t_wall_k = ambient_k;
            // `check_state`'s test on the projected state; the state is
            // built only for the error.
            let [t_gas_k, t_gas2_k, v_gas_m3, v_gas2_m3, m_small_kg, m_large_kg, v_void_m3, p_strut_pa, t_oil_k, t_wall_k, _, _, force_sensor_n, p_small_sensor_pa, p_large_sensor_pa, ..] =
                *a;
            let ok = values_ok(
                [t_gas_k, t_gas2_k, t_wall_k, t_oil_k],
                [(v_gas_m3, m_small_kg), (v_gas2_m3, m_large_kg)],
                [p_strut_pa, v_void_m3, force_sensor_n, p_small_sensor_pa, p_large_sensor_pa],
            );
            return if ok { Ok(()) } else { Err(self.state_error(&UnitState::from_array(a), time_s)) };
        }
        let mut s = UnitState::from_array(a);
        self.project(&mut s, ambient_k);
        self.check_state(&s, time_s)?;
        *a = s.to_array();
        Ok(())
    }

    /// The first state variable out of range, as an error.
    #[cold]
    fn state_error(&self, s: &UnitState, time_s: f64) -> Error {
        let bad = |name, value, min, max| Error::StateOutOfRange { name, value, min, max, time_s };
        let (t_min, t_max) = TEMPERATURE_RANGE_K;
        for (name, t) in [
            ("t_gas_k", s.t_gas_k),
            ("t_gas2_k", s.t_gas2_k),
            ("t_wall_k", s.t_wall_k),
            ("t_oil_k", s.t_oil_k),
        ] {
            if !(t >= t_min && t <= t_max) {
                return bad(name, t, t_min, t_max);
            }
        }
        for (name, v, m) in [
            ("v_gas_m3", s.v_gas_m3, s.m_small_kg),
            ("v_gas2_m3", s.v_gas2_m3, s.m_large_kg),
        ] {
            if !volume_ok(v, m) {
                return bad(name, v, m / DENSITY_RANGE_KG_M3.1, 10.0);
            }
        }
        for (name, x) in [
            ("p_strut_pa", s.p_strut_pa),
            ("v_void_m3", s.v_void_m3),
            ("force_sensor_n", s.force_sensor_n),
            ("p_small_sensor_pa", s.p_small_sensor_pa),
            ("p_large_sensor_pa", s.p_large_sensor_pa),
        ] {
            if !x.is_finite() {
                return bad(name, x, f64::MIN, f64::MAX);
            }
        }
        // The sum overflowed although every term is finite.
        bad("p_strut_pa", s.p_strut_pa, f64::MIN, f64::MAX)
    }

    /// The unit's state derivative and outputs at one instant.
    ///
    /// `state` must have passed [`Unit::check_state`]; `ambient_k` is the
    /// temperature of the surroundings.
    #[inline]
    pub fn evaluate(
        &self,
        state: &UnitState,
        motion: StrutMotion,
        valves: Valves,
        ambient_k: f64,
    ) -> (UnitState, UnitOutputs) {
        let (rate, outputs, _) = self.evaluate_parts(state, motion, valves, ambient_k, Needs { outputs: true, coupling: false, strut: false, rates: true });
        (rate, outputs)
    }

    /// [`Unit::evaluate`] computing only what `needs` asks for beyond the
    /// state rate and strut force: with valve 6 closed and neither
    /// leakage nor lagging transducers, L's gas does not enter the rate and
    /// its equation of state is skipped unless the outputs are wanted.
    #[inline(always)]
    pub fn evaluate_parts(
        &self,
        state: &UnitState,
        motion: StrutMotion,
        valves: Valves,
        ambient_k: f64,
        needs: Needs,
    ) -> (UnitState, UnitOutputs, Linearisation) {
        self.evaluate_parts_with(&self.params.gas, state, motion, valves, ambient_k, needs)
    }

    /// [`Unit::evaluate_parts`] with the gas's properties from `gas`
    /// instead of the parameters' equation of state: the same gas in a
    /// faster form (e.g. [`crate::gas::table::TabulatedGas`] of it). The
    /// caller keeps the two the same gas.
    #[inline(always)]
    pub fn evaluate_parts_with(
        &self,
        gas: &impl EquationOfState,
        state: &UnitState,
        motion: StrutMotion,
        valves: Valves,
        ambient_k: f64,
        needs: Needs,
    ) -> (UnitState, UnitOutputs, Linearisation) {
        self.evaluate_terms::<false>(gas, state, motion, valves, ambient_k, needs)
    }

    /// [`Unit::evaluate_parts_with`], for a unit that [`Unit::is_plain`]
    /// with the absent effects and the heat transfer's kind known to the
    /// compiler (the branches on them and what they keep alive go; every
    /// operation that is left is the same, so are the results to the bit),
    /// for any other unit the general form. The vehicles' hot path: the
    /// caller gets both forms' code.
    #[inline(always)]
    pub fn evaluate_parts_plain_with(
        &self,
        gas: &impl EquationOfState,
        state: &UnitState,
        motion: StrutMotion,
        valves: Valves,
        ambient_k: f64,
        needs: Needs,
    ) -> (UnitState, UnitOutputs, Linearisation) {
        if self.plain {
            self.evaluate_terms::<true>(gas, state, motion, valves, ambient_k, needs)
        } else {
            self.evaluate_terms::<false>(gas, state, motion, valves, ambient_k, needs)
        }
    }

    /// The evaluation; with `PLAIN` (only for a unit that
    /// [`Unit::is_plain`]) the effects are known absent and the heat
    /// transfer a time constant (its value still the parameters').
    #[inline(always)]
    fn evaluate_terms<const PLAIN: bool>(
        &self,
        gas: &impl EquationOfState,
        state: &UnitState,
        motion: StrutMotion,
        valves: Valves,
        ambient_k: f64,
        needs: Needs,
    ) -> (UnitState, UnitOutputs, Linearisation) {
        let p = &self.params;
        let (heat, e) = if PLAIN { (HeatTransfer::TimeConstant(p.heat.tau_s()), &NO_EFFECTS) } else { (p.heat, &p.effects) };
        let area = p.piston_area_m2;
        let mut rate = UnitState::default();

        // Thermal boundary of the gas.
        let t_wall = if e.oil_node.is_some() { state.t_wall_k } else { ambient_k };
        let t_oil = if e.oil_node.is_some() { state.t_oil_k } else { ambient_k };

        // Valve positions: commanded, or lagging behind the command.
        let command = |open: bool| if open { 1.0 } else { 0.0 };
        let (s5, s6) = match e.valve_lag {
            Some(lag) => {
                rate.valve5_open_frac = (command(valves.valve5_open) - state.valve5_open_frac) / lag.time_constant_s;
                rate.valve6_open_frac = (command(valves.valve6_open) - state.valve6_open_frac) / lag.time_constant_s;
                (state.valve5_open_frac.clamp(0.0, 1.0), state.valve6_open_frac.clamp(0.0, 1.0))
            }
            None => (command(valves.valve5_open), command(valves.valve6_open)),
        };

        // Gas states.
        let t_s = gas_temperature_k(heat, state.t_gas_k, t_wall);
        let t_l = gas_temperature_k(heat, state.t_gas2_k, t_wall);
        let (rho_s, rho_l) = (state.m_small_kg / state.v_gas_m3, state.m_large_kg / state.v_gas2_m3);
        let gas = |rho: f64, t: f64| {
            if needs.rates {
                gas.props(rho, t)
            } else {
                let (p_pa, dp_drho_pa_m3_per_kg) = gas.pressure_and_slope(rho, t);
                GasProps { p_pa, dp_drho_pa_m3_per_kg, ..UNUSED_PROPS }
            }
        };
        let props_s = gas(rho_s, t_s);
        let lagging_sensor = matches!(e.sensor, Some(s) if s.time_constant_s > 0.0);
        // A time constant that moves with L's heat capacity needs L's c_v
        // whenever L's temperature relaxes.
        let conductance = e.wall_conductance.filter(|_| needs.rates && matches!(heat, HeatTransfer::TimeConstant(_)));
        // A wall the gas can warm takes the heat of both volumes (L's needs its c_v).
        let warms_wall = needs.rates && e.oil_node.is_some_and(|n| n.wall_heat_capacity_j_per_k < NO_WALL_WARMING_J_PER_K);
        let large_needed = needs.outputs || s6 > 0.0 || e.leakage.is_some() || lagging_sensor || conductance.is_some() || warms_wall;
        let props_l = if large_needed { gas(rho_l, t_l) } else { UNUSED_PROPS };
        let (p_s, p_l) = (props_s.p_pa, props_l.p_pa);

        // Valve 6.
        let q6 = if s6 > 0.0 { s6 * p.valve6.flow_m3_s(p_s - p_l, self.valve6_coefficient) } else { 0.0 };

        // Strut pressure and damper flow, with cavitation.
        let displaced_rate = area * motion.vel_m_s; // oil pushed out of the strut volume
        let cavitation_flow = || self.damper.flow_m3_s(p.vapour_pressure_pa - p_s, s5);
        // With oil compliance and the strut not pinned: `B / V_oil`, the
        // strut pressure's rate per net oil flow into the strut side.
        let mut oil_stiffness_pa_per_m3 = None;
        let (p_strut, q_damper, cavitating) = match e.oil_compliance {
            None => {
                if state.v_void_m3 > 0.0 {
                    (p.vapour_pressure_pa, cavitation_flow(), true)
                } else {
                    let p_strut = p_s + self.damper.pressure_drop_pa(displaced_rate, s5);
                    if p_strut < p.vapour_pressure_pa {
                        (p.vapour_pressure_pa, cavitation_flow(), true)
                    } else {
                        (p_strut, displaced_rate, false)
                    }
                }
            }
            Some(c) => {
                let q = self.damper.flow_m3_s(state.p_strut_pa - p_s, s5);
                let net = displaced_rate - q; // net oil volume squeezed into the strut side
                let pinned = state.p_strut_pa <= p.vapour_pressure_pa && (state.v_void_m3 > 0.0 || net < 0.0);
                if pinned {
                    (p.vapour_pressure_pa, cavitation_flow(), true)
                } else {
                    let oil_volume = c.oil_volume_m3 - state.v_void_m3.max(0.0);
                    let stiffness = c.bulk_modulus_pa / oil_volume;
                    rate.p_strut_pa = stiffness * net;
                    oil_stiffness_pa_per_m3 = Some(stiffness);
                    (state.p_strut_pa, q, false)
                }
            }
        };
        rate.v_void_m3 = if cavitating { q_damper - displaced_rate } else { 0.0 };

        // Gas volumes and masses.
        rate.v_gas_m3 = -(q_damper - q6);
        rate.v_gas2_m3 = -q6;
        if let Some(l) = e.leakage {
            // The gauge-pressure ratio's power, exactly 1 for the default
            // exponent (no pow on the hot path); never negative below
            // ambient pressure.
            let drive = |p_pa: f64| {
                if l.pressure_exponent == 0.0 {
                    1.0
                } else {
                    let r = (p_pa - p.ambient_pressure_pa) / (p.static_pressure_pa - p.ambient_pressure_pa).max(1.0);
                    power(r.max(0.0), l.pressure_exponent)
                }
            };
            // m0 (m / m0)^k: the current mass itself for the default k = 1
            // (no pow on the hot path, and the exact exponential decay);
            // nothing leaks from an empty accumulator (with k <= 0 the law
            // alone would go on, or diverge).
            let mass = |m_kg: f64, m0_kg: f64| {
                if l.mass_exponent == 1.0 {
                    m_kg
                } else if m_kg <= 0.0 {
                    0.0
                } else {
                    m0_kg * power(m_kg / m0_kg, l.mass_exponent)
                }
            };
            rate.m_small_kg = -mass(state.m_small_kg, self.small_mass_kg) / l.time_constant_s * drive(p_s);
            rate.m_large_kg = -mass(state.m_large_kg, self.large_mass_kg) / l.time_constant_s * drive(p_l);
        }
        let (heat_s, heat_l) = match conductance {
            Some(w) => {
                let factor = |m_kg: f64, m0_kg: f64, props: &GasProps| {
                    power(m_kg * props.cv_j_per_kg_k / (m0_kg * self.static_cv_j_per_kg_k), w.cv_exponent)
                };
                (
                    heat.with_tau_factor(factor(state.m_small_kg, self.small_mass_kg, &props_s)),
                    heat.with_tau_factor(factor(state.m_large_kg, self.large_mass_kg, &props_l)),
                )
            }
            None => (heat, heat),
        };
        rate.t_gas_k = temperature_rate_k_s(
            heat_s,
            &props_s,
            t_s,
            t_wall,
            state.m_small_kg,
            state.v_gas_m3,
            rate.v_gas_m3,
            rate.m_small_kg,
        );
        rate.t_gas2_k = temperature_rate_k_s(
            heat_l,
            &props_l,
            t_l,
            t_wall,
            state.m_large_kg,
            state.v_gas2_m3,
            rate.v_gas2_m3,
            rate.m_large_kg,
        );

        // Forces and dissipation.
        let damper_force = area * (p_strut - p_s);
        let damper_power = (p_strut - p_s) * q_damper;
        let valve6_power = if s6 > 0.0 { (p_s - p_l) * q6 } else { 0.0 };
        let (friction_force, friction_power) = match e.friction {
            Some(f) => {
                let v = motion.vel_m_s;
                let force = f.force_n(v);
                (force, force * v)
            }
            None => (0.0, 0.0),
        };
        let end_stop = self.end_stop_force_n(motion);
        let force = area * (p_strut - p.ambient_pressure_pa) + friction_force + end_stop;
        rate.e_damper_j = damper_power;
        rate.e_friction_j = friction_power;
        rate.e_valve6_j = valve6_power;

        // Heat build-up.
        if let Some(n) = e.oil_node {
            let heat = damper_power + friction_power + valve6_power;
            let above = state.t_oil_k - ambient_k;
            let convection = if n.oil_to_ambient_exponent == 0.0 {
                1.0
            } else {
                power(libm::fabs(above) / OIL_COOLING_REFERENCE_K, n.oil_to_ambient_exponent)
            };
            rate.t_oil_k = heat / n.heat_capacity_j_per_k - above * convection / n.oil_to_ambient_tau_s;
            rate.t_wall_k = (state.t_oil_k - state.t_wall_k) / n.wall_to_oil_tau_s
                + (ambient_k - state.t_wall_k) / n.wall_to_ambient_tau_s;
            if warms_wall {
                // The heat each gas volume gives its wall: m c_v (T - T_wall) / tau,
                // what its own temperature rate loses to the wall.
                let given = |h: HeatTransfer, props: &GasProps, t: f64, m: f64| match h {
                    HeatTransfer::TimeConstant(tau) => m * props.cv_j_per_kg_k * (t - t_wall) / tau,
                    _ => 0.0,
                };
                let gas_heat_w = given(heat_s, &props_s, t_s, state.m_small_kg) + given(heat_l, &props_l, t_l, state.m_large_kg);
                rate.t_wall_k += gas_heat_w / n.wall_heat_capacity_j_per_k;
                // A wall of finite capacity gives the oil what the oil gives
                // it (an unbounded one would give it without limit: its
                // coupling is then one-way, the seed's calibration).
                let wall_to_oil_w = n.wall_heat_capacity_j_per_k * (state.t_wall_k - state.t_oil_k) / n.wall_to_oil_tau_s;
                rate.t_oil_k += wall_to_oil_w / n.heat_capacity_j_per_k;
            }
        }

        // Transducers.
        let (force_measured, p_s_measured, p_l_measured) = match e.sensor {
            Some(s) if s.time_constant_s > 0.0 => {
                let lag = Lag { time_constant_s: s.time_constant_s };
                let follow = |output: f64, input: f64| lag::rate(&lag, &LagState { output }, input);
                rate.force_sensor_n = follow(state.force_sensor_n, force);
                rate.p_small_sensor_pa = follow(state.p_small_sensor_pa, p_s);
                rate.p_large_sensor_pa = follow(state.p_large_sensor_pa, p_l);
                (
                    state.force_sensor_n + s.force_offset_n,
                    state.p_small_sensor_pa + s.pressure_offset_pa,
                    state.p_large_sensor_pa + s.pressure2_offset_pa,
                )
            }
            Some(s) => (force + s.force_offset_n, p_s + s.pressure_offset_pa, p_l + s.pressure2_offset_pa),
            None => (force, p_s, p_l),
        };

        let outputs = UnitOutputs {
            force_true_n: force,
            force_n: force_measured,
            p_strut_pa: p_strut,
            p_gas_true_pa: p_s,
            p_gas2_true_pa: p_l,
            p_gas_pa: p_s_measured,
            p_gas2_pa: p_l_measured,
            t_gas_k: t_s,
            t_gas2_k: t_l,
            t_wall_k: t_wall,
            t_oil_k: t_oil,
            damper_force_n: damper_force,
            damper_power_w: damper_power,
            friction_force_n: friction_force,
            friction_power_w: friction_power,
            valve6_power_w: valve6_power,
            flow_damper_m3_s: q_damper,
            flow_valve6_m3_s: q6,
            cavitating,
        };
        let valve6 = if needs.coupling && s6 > 0.0 {
            Some(self.valve6_coupling(heat, e, GasMass::small(state), GasMass::large(state), &props_s, &props_l, (t_s, t_l), s6, e.valve_lag.is_some()))
        } else {
            None
        };
        let damper = match oil_stiffness_pa_per_m3 {
            Some(stiffness) if needs.coupling => Some(self.damper_coupling(heat, e, GasMass::small(state), &props_s, t_s, q_damper, p_strut - p_s, s5, stiffness)),
            _ => None,
        };
        // The strut's linearisation assumes the incompressible oil's force
        // `A (p_S + dp(A v) - p_0)`: with oil compliance the force is the
        // strut pressure, a state of its own, whose stiff flow is `damper`.
        let strut = if needs.strut && !cavitating && e.oil_compliance.is_none() {
            Some(self.strut_coupling(heat, e, GasMass::small(state), &props_s, t_s, motion, s5, p_strut - p_s))
        } else {
            None
        };
        (rate, outputs, Linearisation { valve6, damper, strut })
    }

    /// The damper flow with oil compliance linearised (see
    /// [`Linearisation::damper`]): `q = Q(p_strut - p_S)`, the pack's
    /// curve inverted, at flow `q_m3_s` and pressure drop `dp_pa`;
    /// `oil_stiffness_pa_per_m3` is `B / V_oil`.
    #[allow(clippy::too_many_arguments)]
    fn damper_coupling(
        &self,
        heat: HeatTransfer,
        e: &Effects,
        gas_s: GasMass,
        props_s: &GasProps,
        t_s: f64,
        q_m3_s: f64,
        dp_pa: f64,
        s5: f64,
        oil_stiffness_pa_per_m3: f64,
    ) -> FlowCoupling {
        // A curve without bleed stands vertical at no flow: no finite
        // linearisation there, and the error control does without.
        let slope = 1.0 / self.damper.pressure_drop_slope_pa_s_per_m3(q_m3_s, s5);
        let slope = if slope.is_finite() { slope } else { 0.0 };
        let g = PressureGradient::of(heat, props_s, gas_s.mass_kg, gas_s.volume_m3);
        // The flow grows with the strut pressure and falls with S's. The
        // bypass valve's opening (valve lag) moves the flow too, but the
        // flow does not move the valve: a one-way coupling that leaves the
        // stiff mode as it is, so it stays out.
        let v = UnitState {
            p_strut_pa: slope,
            t_gas_k: -slope * g.per_t,
            v_gas_m3: -slope * g.per_v,
            m_small_kg: -slope * g.per_m,
            ..UnitState::default()
        };
        // The rate: the flow relieves the strut pressure, fills S (whose
        // gas it compresses) and dissipates dp q in the pack.
        let mut u = UnitState {
            p_strut_pa: -oil_stiffness_pa_per_m3,
            v_gas_m3: -1.0,
            t_gas_k: -temperature_rate_per_volume_rate(heat, props_s, t_s, gas_s.mass_kg, gas_s.volume_m3),
            e_damper_j: dp_pa,
            ..UnitState::default()
        };
        if let Some(n) = e.oil_node {
            u.t_oil_k = dp_pa / n.heat_capacity_j_per_k;
        }
        FlowCoupling { u, v }
    }

    /// The strut linearised (see [`StrutCoupling`]), for the incompressible
    /// oil while it does not cavitate: the force is `A (p_S + dp(A v) -
    /// p_0) + friction + end stop`, the gas volume in S falls by `A v`.
    #[allow(clippy::too_many_arguments)]
    fn strut_coupling(&self, heat: HeatTransfer, e: &Effects, gas_s: GasMass, props_s: &GasProps, t_s: f64, motion: StrutMotion, s5: f64, damper_dp_pa: f64) -> StrutCoupling {
        let p = &self.params;
        let area = p.piston_area_m2;
        let q = area * motion.vel_m_s;
        let dp_dv = area * self.damper.pressure_drop_slope_pa_s_per_m3(q, s5);
        let g = PressureGradient::of(heat, props_s, gas_s.mass_kg, gas_s.volume_m3);
        let force_per_state = UnitState {
            t_gas_k: area * g.per_t,
            v_gas_m3: area * g.per_v,
            m_small_kg: area * g.per_m,
            ..UnitState::default()
        };
        let friction = e.friction.map_or(0.0, |f| f.slope_n_s_per_m(motion.vel_m_s));
        let (k_stop, c_stop) = self.end_stop_slopes(motion);
        // The damper's power dp q: d/dv = A (dp + q dp'/dq).
        let rate_per_vel = UnitState {
            v_gas_m3: -area,
            t_gas_k: -area * temperature_rate_per_volume_rate(heat, props_s, t_s, gas_s.mass_kg, gas_s.volume_m3),
            e_damper_j: area * damper_dp_pa + q * dp_dv,
            ..UnitState::default()
        };
        StrutCoupling { force_per_state, force_per_vel_n_s_per_m: area * dp_dv + friction + c_stop, force_per_disp_n_per_m: k_stop, rate_per_vel }
    }

    /// The valve-6 exchange linearised (see [`Valve6Coupling`]).
    #[allow(clippy::too_many_arguments)]
    fn valve6_coupling(
        &self,
        heat: HeatTransfer,
        e: &Effects,
        gas_s: GasMass,
        gas_l: GasMass,
        props_s: &GasProps,
        props_l: &GasProps,
        (t_s, t_l): (f64, f64),
        s6: f64,
        lagging_valve: bool,
    ) -> Valve6Coupling {
        let p = &self.params;
        let dp = props_s.p_pa - props_l.p_pa;
        // q6 = s6 Q(p_S - p_L).
        let slope = s6 * p.valve6.flow_slope_m3_s_pa(dp, self.valve6_coefficient);
        let g_s = PressureGradient::of(heat, props_s, gas_s.mass_kg, gas_s.volume_m3);
        let g_l = PressureGradient::of(heat, props_l, gas_l.mass_kg, gas_l.volume_m3);
        let mut v = UnitState {
            t_gas_k: slope * g_s.per_t,
            v_gas_m3: slope * g_s.per_v,
            m_small_kg: slope * g_s.per_m,
            t_gas2_k: -slope * g_l.per_t,
            v_gas2_m3: -slope * g_l.per_v,
            m_large_kg: -slope * g_l.per_m,
            ..UnitState::default()
        };
        if lagging_valve {
            v.valve6_open_frac = p.valve6.flow_m3_s(dp, self.valve6_coefficient);
        }
        // The rate: V_S gains and V_L loses q6; each gas is compressed or
        // expanded by it; valve 6 dissipates dp q6.
        let mut u = UnitState {
            v_gas_m3: 1.0,
            v_gas2_m3: -1.0,
            t_gas_k: temperature_rate_per_volume_rate(heat, props_s, t_s, gas_s.mass_kg, gas_s.volume_m3),
            t_gas2_k: -temperature_rate_per_volume_rate(heat, props_l, t_l, gas_l.mass_kg, gas_l.volume_m3),
            e_valve6_j: dp,
            ..UnitState::default()
        };
        if let Some(n) = e.oil_node {
            u.t_oil_k = dp / n.heat_capacity_j_per_k;
        }
        Valve6Coupling { u, v }
    }

    /// `d/d(compression)` and `d/d(velocity)` of [`Unit::end_stop_force_n`].
    fn end_stop_slopes(&self, motion: StrutMotion) -> (f64, f64) {
        let p = &self.params;
        let force = self.end_stop_force_n(motion);
        let engaged = motion.disp_m - p.stroke_compression_m > 0.0 || -p.stroke_extension_m - motion.disp_m > 0.0;
        // Zero where the damping part would pull the stop back (clamped).
        if engaged && force != 0.0 {
            (p.end_stop_stiffness_n_per_m, p.end_stop_damping_n_s_per_m)
        } else {
            (0.0, 0.0)
        }
    }

    /// Force of the end stops when the strut is beyond its stroke, N. The
    /// damping part never pulls the stop back (no sticking).
    fn end_stop_force_n(&self, motion: StrutMotion) -> f64 {
        let p = &self.params;
        let (k, c) = (p.end_stop_stiffness_n_per_m, p.end_stop_damping_n_s_per_m);
        let over = motion.disp_m - p.stroke_compression_m;
        let under = -p.stroke_extension_m - motion.disp_m;
        if over > 0.0 {
            (k * over + c * motion.vel_m_s).max(0.0)
        } else if under > 0.0 {
            (-k * under + c * motion.vel_m_s).min(0.0)
        } else {
            0.0
        }
    }

    /// Keeps a state inside its constraints after an integration step: the
    /// void and valve openings cannot go negative, the pinned strut
    /// pressure stays at the vapour pressure, and an unused isothermal
    /// temperature state tracks the wall.
    ///
    /// A void that fills within a step ends it negative: the step ran the
    /// cavitation flow (oil from S back into the strut) to its end, past
    /// the instant the void was full. That surplus is oil S gave and the
    /// strut has no room for, so it goes back to S (with the heat of
    /// compressing S's gas by it). Clipping the void to zero alone would
    /// destroy it: about 0.4 cm^3 per closure at 1 ms steps, which adds up
    /// to tens of cm^3 within an hour of a strut that cavitates on every
    /// rebound (a unit on its end stop on a cold day), lowering the gas
    /// pressure as if gas had leaked. With it the oil volume
    /// `V_S + V_L + A x - V_void` is kept exactly (a linear invariant of
    /// the rates, which RK4 preserves).
    #[inline]
    pub fn project(&self, s: &mut UnitState, ambient_k: f64) {
        let p = &self.params;
        if s.v_void_m3 < 0.0 {
            let surplus_m3 = -s.v_void_m3;
            if p.heat != HeatTransfer::Isothermal {
                let props = p.gas.props(s.m_small_kg / s.v_gas_m3, s.t_gas_k);
                s.t_gas_k -= temperature_rate_per_volume_rate(p.heat, &props, s.t_gas_k, s.m_small_kg, s.v_gas_m3) * surplus_m3;
            }
            s.v_gas_m3 -= surplus_m3;
            s.v_void_m3 = 0.0;
        }
        s.valve5_open_frac = s.valve5_open_frac.clamp(0.0, 1.0);
        s.valve6_open_frac = s.valve6_open_frac.clamp(0.0, 1.0);
        if p.effects.oil_compliance.is_some() {
            s.p_strut_pa = s.p_strut_pa.max(p.vapour_pressure_pa);
        }
        if p.heat == HeatTransfer::Isothermal {
            let wall = if p.effects.oil_node.is_some() { s.t_wall_k } else { ambient_k };
            s.t_gas_k = wall;
            s.t_gas2_k = wall;
        }
        if p.effects.oil_node.is_none() {
            s.t_oil_k = ambient_k;
            s.t_wall_k = ambient_k;
        }
    }
}
