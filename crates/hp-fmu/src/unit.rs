//! The unit FMU (`hpctl_unit`): the strut with its damper and two gas
//! accumulators, driven by the strut motion and the valve commands.
//!
//! Inputs: the strut compression and its rate (positive = compression,
//! from the static position), the two valve commands. Within a
//! communication step the motion follows the velocity input (and its first
//! and second time derivatives, when the master sets them with
//! `fmi2SetRealInputDerivatives`; without them the velocity is held)
//! from the displacement at the start of the step: the velocity is what
//! the gas integrates, the displacement places the end stops. The
//! integration is `hp_core::rig`'s, with steps of at most `max_dt_s`
//! landing on every communication point.
//!
//! Parameters: the unit's (the core's names and valid ranges, start values
//! the built-in unit's), the ambient temperature and the integration step.
//! The optional model effects (friction, oil compliance, ...) are not
//! exposed: the FMU is the seed's model.

use crate::model::{Causality, Enumeration, Kind, Model, ModelError, ModelInfo, Values, Var};
use hp_core::gas::Gas;
use hp_core::motion::Motion;
use hp_core::rig::{Rig, RigKind, RigState};
use hp_core::thermal::HeatTransfer;
use hp_core::unit::{StrutMotion, Unit, UnitOutputs, UnitParams, Valves};
use hp_core::{presets, ranges};
use std::sync::OnceLock;

/// The gas models, as an FMI enumeration (values are the positions in
/// `Gas::ALL` plus one).
pub static GAS: Enumeration = Enumeration {
    name: "Gas",
    items: &[
        ("span", 1, "reference equation of state, Span et al. 2000 (the default)"),
        ("ideal", 2, "ideal gas"),
        ("bwr-cg", 3, "Benedict-Webb-Rubin, Cooper & Goldfrank constants (best below 30 MPa)"),
        ("bwr-textbook", 4, "Benedict-Webb-Rubin, textbook constants (2-110 MPa)"),
    ],
};

type Field = fn(&mut UnitParams) -> &mut f64;
/// A real unit parameter: name, unit, valid range, accessor, description.
type Parameter = (&'static str, &'static str, (f64, f64), Field, &'static str);

/// The real unit parameters: name (the core's), unit, range, accessor.
fn real_parameters() -> Vec<Parameter> {
    use ranges as r;
    let rng = |x: r::Range| (x.min, x.max);
    vec![
        ("piston_area_m2", "m2", rng(r::PISTON_AREA_M2), |p| &mut p.piston_area_m2, "strut piston area"),
        ("small_acc_volume_m3", "m3", rng(r::SMALL_ACC_VOLUME_M3), |p| &mut p.small_acc_volume_m3, "gas volume of S (always connected) at the static position"),
        ("large_acc_volume_m3", "m3", rng(r::LARGE_ACC_VOLUME_M3), |p| &mut p.large_acc_volume_m3, "gas volume of L (behind valve 6) at the static position"),
        ("static_pressure_pa", "Pa", rng(r::STATIC_PRESSURE_PA), |p| &mut p.static_pressure_pa, "gas pressure at the static position (the charge)"),
        ("static_temperature_k", "K", rng(r::STATIC_TEMPERATURE_K), |p| &mut p.static_temperature_k, "gas temperature of the static charge"),
        ("valve6_flow_area_m2", "m2", (0.0, 1e-2), |p| &mut p.valve6.flow_area_m2, "valve 6: discharge coefficient times flow area"),
        ("valve6_transition_pa", "Pa", (1.0, 1e7), |p| &mut p.valve6.transition_pa, "valve 6: pressure difference below which the flow turns laminar"),
        ("oil_density_kg_m3", "kg/m3", rng(r::OIL_DENSITY_KG_M3), |p| &mut p.oil_density_kg_m3, "oil density"),
        ("vapour_pressure_pa", "Pa", rng(r::VAPOUR_PRESSURE_PA), |p| &mut p.vapour_pressure_pa, "lowest absolute oil pressure in the strut (cavitation)"),
        ("ambient_pressure_pa", "Pa", rng(r::AMBIENT_PRESSURE_PA), |p| &mut p.ambient_pressure_pa, "pressure on the other side of the piston"),
        ("stroke_compression_m", "m", rng(r::STROKE_COMPRESSION_M), |p| &mut p.stroke_compression_m, "travel from the static position to the compression end stop"),
        ("stroke_extension_m", "m", rng(r::STROKE_EXTENSION_M), |p| &mut p.stroke_extension_m, "travel from the static position to the extension end stop"),
        ("end_stop_stiffness_n_per_m", "N/m", rng(r::END_STOP_STIFFNESS_N_PER_M), |p| &mut p.end_stop_stiffness_n_per_m, "end-stop stiffness"),
        ("end_stop_damping_n_s_per_m", "N.s/m", rng(r::END_STOP_DAMPING_N_S_PER_M), |p| &mut p.end_stop_damping_n_s_per_m, "end-stop damping"),
        ("damper.on_compression.bleed_pa_s_per_m3", "Pa.s/m3", (0.0, 1e14), |p| &mut p.damper.on_compression.bleed_pa_s_per_m3, "damper on (valve 5 closed), compression: laminar coefficient"),
        ("damper.on_compression.orifice_pa_s2_per_m6", "Pa.s2/m6", (0.0, 1e18), |p| &mut p.damper.on_compression.orifice_pa_s2_per_m6, "damper on, compression: turbulent coefficient"),
        ("damper.on_compression.blowoff_pa", "Pa", (0.0, 1e9), |p| &mut p.damper.on_compression.blowoff_pa, "damper on, compression: blow-off pressure drop"),
        ("damper.on_compression.blowoff_slope_pa_s_per_m3", "Pa.s/m3", (1e3, 1e14), |p| &mut p.damper.on_compression.blowoff_slope_pa_s_per_m3, "damper on, compression: slope above blow-off"),
        ("damper.on_rebound.bleed_pa_s_per_m3", "Pa.s/m3", (0.0, 1e14), |p| &mut p.damper.on_rebound.bleed_pa_s_per_m3, "damper on, rebound: laminar coefficient"),
        ("damper.on_rebound.orifice_pa_s2_per_m6", "Pa.s2/m6", (0.0, 1e18), |p| &mut p.damper.on_rebound.orifice_pa_s2_per_m6, "damper on, rebound: turbulent coefficient"),
        ("damper.on_rebound.blowoff_pa", "Pa", (0.0, 1e9), |p| &mut p.damper.on_rebound.blowoff_pa, "damper on, rebound: blow-off pressure drop"),
        ("damper.on_rebound.blowoff_slope_pa_s_per_m3", "Pa.s/m3", (1e3, 1e14), |p| &mut p.damper.on_rebound.blowoff_slope_pa_s_per_m3, "damper on, rebound: slope above blow-off"),
        ("damper.off_compression.bleed_pa_s_per_m3", "Pa.s/m3", (0.0, 1e14), |p| &mut p.damper.off_compression.bleed_pa_s_per_m3, "damper off (valve 5 open), compression: laminar coefficient"),
        ("damper.off_compression.orifice_pa_s2_per_m6", "Pa.s2/m6", (0.0, 1e18), |p| &mut p.damper.off_compression.orifice_pa_s2_per_m6, "damper off, compression: turbulent coefficient"),
        ("damper.off_compression.blowoff_pa", "Pa", (0.0, 1e9), |p| &mut p.damper.off_compression.blowoff_pa, "damper off, compression: blow-off pressure drop"),
        ("damper.off_compression.blowoff_slope_pa_s_per_m3", "Pa.s/m3", (1e3, 1e14), |p| &mut p.damper.off_compression.blowoff_slope_pa_s_per_m3, "damper off, compression: slope above blow-off"),
        ("damper.off_rebound.bleed_pa_s_per_m3", "Pa.s/m3", (0.0, 1e14), |p| &mut p.damper.off_rebound.bleed_pa_s_per_m3, "damper off, rebound: laminar coefficient"),
        ("damper.off_rebound.orifice_pa_s2_per_m6", "Pa.s2/m6", (0.0, 1e18), |p| &mut p.damper.off_rebound.orifice_pa_s2_per_m6, "damper off, rebound: turbulent coefficient"),
        ("damper.off_rebound.blowoff_pa", "Pa", (0.0, 1e9), |p| &mut p.damper.off_rebound.blowoff_pa, "damper off, rebound: blow-off pressure drop"),
        ("damper.off_rebound.blowoff_slope_pa_s_per_m3", "Pa.s/m3", (1e3, 1e14), |p| &mut p.damper.off_rebound.blowoff_slope_pa_s_per_m3, "damper off, rebound: slope above blow-off"),
    ]
}

// Value references of the fixed variables (the unit's real parameters follow
// them, from FIRST_UNIT_PARAMETER on). Tests check them against the table.
pub const DISP_M: usize = 0;
pub const VEL_M_S: usize = 1;
pub const VALVE5_OPEN: usize = 2;
pub const VALVE6_OPEN: usize = 3;
pub const FORCE_N: usize = 4;
pub const FORCE_TRUE_N: usize = 5;
pub const P_STRUT_PA: usize = 6;
pub const P_GAS_PA: usize = 7;
pub const P_GAS2_PA: usize = 8;
pub const T_GAS_K: usize = 9;
pub const T_GAS2_K: usize = 10;
pub const T_OIL_K: usize = 11;
pub const V_GAS_M3: usize = 12;
pub const V_GAS2_M3: usize = 13;
pub const DAMPER_FORCE_N: usize = 14;
pub const DAMPER_POWER_W: usize = 15;
pub const VALVE6_POWER_W: usize = 16;
pub const DISSIPATED_POWER_W: usize = 17;
pub const E_DISSIPATED_J: usize = 18;
pub const FLOW_VALVE6_M3_S: usize = 19;
pub const CAVITATING: usize = 20;
pub const AT_END_STOP: usize = 21;
pub const AMBIENT_K: usize = 22;
pub const MAX_DT_S: usize = 23;
pub const GAS_MODEL: usize = 24;
pub const TAU_S: usize = 25;
pub const FIRST_UNIT_PARAMETER: usize = 26;

fn build_info() -> ModelInfo {
    let seed = presets::seed_unit();
    let b = |name, description| Var::typed(name, Kind::Boolean, Causality::Output, 0.0, description);
    let mut vars = vec![
        Var::input("disp_m", 0.0, "m", "strut compression from the static position (positive = compression); its start value is the initial position"),
        Var::input("vel_m_s", 0.0, "m/s", "strut compression rate (positive = compressing)"),
        Var::typed("valve5_open", Kind::Boolean, Causality::Input, 0.0, "valve 5 energised open: damper bypassed (low damping)"),
        Var::typed("valve6_open", Kind::Boolean, Causality::Input, 0.0, "valve 6 energised open: L connected (soft spring)"),
        Var::output("force_n", "N", "strut force as the transducer reports it (positive = compression)"),
        Var::output("force_true_n", "N", "strut force"),
        Var::output("p_strut_pa", "Pa", "absolute strut oil pressure"),
        Var::output("p_gas_pa", "Pa", "gas pressure in S"),
        Var::output("p_gas2_pa", "Pa", "gas pressure in L"),
        Var::output("t_gas_k", "K", "gas temperature in S"),
        Var::output("t_gas2_k", "K", "gas temperature in L"),
        Var::output("t_oil_k", "K", "oil temperature"),
        Var::output("v_gas_m3", "m3", "gas volume in S"),
        Var::output("v_gas2_m3", "m3", "gas volume in L"),
        Var::output("damper_force_n", "N", "force from the pressure drop over the damper"),
        Var::output("damper_power_w", "W", "power dissipated in the damper pack"),
        Var::output("valve6_power_w", "W", "power dissipated in valve 6"),
        Var::output("dissipated_power_w", "W", "total power dissipated (damper, valve 6)"),
        Var::output("e_dissipated_j", "J", "energy dissipated since the start"),
        Var::output("flow_valve6_m3_s", "m3/s", "oil flow from S to L through valve 6"),
        b("cavitating", "a vapour void is open in the strut"),
        b("at_end_stop", "the strut is beyond its stroke (on an end stop): outside the unit's working range"),
        Var::parameter("ambient_k", seed.static_temperature_k, "K", 200.0, 600.0, "ambient temperature (the initial gas, oil and wall temperature)"),
        Var::parameter("max_dt_s", 1e-3, "s", 1e-7, 1e-2, "largest integration step inside a communication step"),
        Var::enumerated("gas", Causality::Parameter, gas_value(seed.gas), &GAS, "equation of state of the nitrogen"),
        Var::parameter("tau_s", seed.heat.tau_s(), "s", 0.0, f64::INFINITY, "thermal time constant of the gas (0 = isothermal, INF = adiabatic)"),
    ];
    let mut template = seed;
    for (name, unit, (min, max), field, description) in real_parameters() {
        vars.push(Var::parameter(name, *field(&mut template), unit, min, max, description));
    }
    ModelInfo {
        identifier: "hpctl_unit",
        description: "hpctl hydro-pneumatic spring-damper unit (switchable gas spring S + L, two-state damper) driven by strut motion",
        vars: Box::leak(vars.into_boxed_slice()),
        default_stop_s: 3.0,
        default_step_s: 1e-3,
    }
}

pub(crate) fn gas_value(gas: Gas) -> i32 {
    Gas::ALL.iter().position(|&g| g == gas).map_or(1, |i| i as i32 + 1)
}

/// The unit's parameters from the FMU's values.
pub fn unit_params(values: &Values) -> Result<UnitParams, ModelError> {
    let mut p = presets::seed_unit();
    let gas_index = values.get(GAS_MODEL) as i64 - 1;
    p.gas = usize::try_from(gas_index)
        .ok()
        .and_then(|i| Gas::ALL.get(i).copied())
        .ok_or_else(|| ModelError(format!("gas = {gas_index} is not a gas model (1..=4)")))?;
    p.heat = HeatTransfer::from_tau_s(values.get(TAU_S))?;
    for (i, (_, _, _, field, _)) in real_parameters().into_iter().enumerate() {
        *field(&mut p) = values.get(FIRST_UNIT_PARAMETER + i);
    }
    Ok(p)
}

/// The unit model's state.
#[derive(Debug, Clone)]
pub struct UnitModel {
    unit: Unit,
    ambient_k: f64,
    max_dt_s: f64,
    state: RigState,
    /// The strut was on an end stop at the last warning check.
    on_end_stop: bool,
}

impl UnitModel {
    fn valves(values: &Values) -> Valves {
        Valves { valve5_open: values.get_bool(VALVE5_OPEN), valve6_open: values.get_bool(VALVE6_OPEN) }
    }

    fn motion(values: &Values) -> Result<StrutMotion, ModelError> {
        let (disp_m, vel_m_s) = (values.get(DISP_M), values.get(VEL_M_S));
        if !(disp_m.is_finite() && vel_m_s.is_finite()) {
            return Err(ModelError(format!("strut motion disp_m = {disp_m} m, vel_m_s = {vel_m_s} m/s is not finite")));
        }
        Ok(StrutMotion { disp_m, vel_m_s })
    }

    fn at_end_stop(&self, disp_m: f64) -> bool {
        let p = self.unit.params();
        disp_m > p.stroke_compression_m || disp_m < -p.stroke_extension_m
    }
}

impl Model for UnitModel {
    fn info() -> &'static ModelInfo {
        static INFO: OnceLock<ModelInfo> = OnceLock::new();
        INFO.get_or_init(build_info)
    }

    fn start(values: &Values, _time_s: f64) -> Result<Self, ModelError> {
        let unit = Unit::new(unit_params(values)?)?;
        let ambient_k = values.get(AMBIENT_K);
        let motion = Self::motion(values)?;
        let state = RigState {
            unit: unit.state_at_rest(motion.disp_m, ambient_k, Self::valves(values))?,
            body_disp_m: 0.0,
            body_vel_m_s: 0.0,
        };
        unit.check_state(&state.unit, 0.0)?;
        Ok(UnitModel { unit, ambient_k, max_dt_s: values.get(MAX_DT_S), state, on_end_stop: false })
    }

    fn outputs(&mut self, values: &mut Values, time_s: f64) -> Result<(), ModelError> {
        let motion = Self::motion(values)?;
        self.unit.check_state(&self.state.unit, time_s)?;
        let (_, out): (_, UnitOutputs) = self.unit.evaluate(&self.state.unit, motion, Self::valves(values), self.ambient_k);
        let s = &self.state.unit;
        for (vr, x) in [
            (FORCE_N, out.force_n),
            (FORCE_TRUE_N, out.force_true_n),
            (P_STRUT_PA, out.p_strut_pa),
            (P_GAS_PA, out.p_gas_pa),
            (P_GAS2_PA, out.p_gas2_pa),
            (T_GAS_K, out.t_gas_k),
            (T_GAS2_K, out.t_gas2_k),
            (T_OIL_K, out.t_oil_k),
            (V_GAS_M3, s.v_gas_m3),
            (V_GAS2_M3, s.v_gas2_m3),
            (DAMPER_FORCE_N, out.damper_force_n),
            (DAMPER_POWER_W, out.damper_power_w),
            (VALVE6_POWER_W, out.valve6_power_w),
            (DISSIPATED_POWER_W, out.damper_power_w + out.valve6_power_w + out.friction_power_w),
            (E_DISSIPATED_J, s.e_damper_j + s.e_valve6_j + s.e_friction_j),
            (FLOW_VALVE6_M3_S, out.flow_valve6_m3_s),
        ] {
            values.set(vr, x);
        }
        values.set_bool(CAVITATING, out.cavitating);
        values.set_bool(AT_END_STOP, self.at_end_stop(motion.disp_m));
        Ok(())
    }

    fn do_step(&mut self, values: &Values, time_s: f64, step_s: f64) -> Result<(), ModelError> {
        let m = Self::motion(values)?;
        // The motion over the step: the velocity and its first two
        // derivatives, from the displacement at the start (the cubic
        // Hermite curve through the two ends reproduces this cubic exactly).
        let (acc, jerk) = (values.derivative(VEL_M_S, 1), values.derivative(VEL_M_S, 2));
        let h = step_s;
        let t = [time_s, time_s + h];
        let x = [m.disp_m, m.disp_m + h * (m.vel_m_s + h * (acc / 2.0 + h * jerk / 6.0))];
        let v = [m.vel_m_s, m.vel_m_s + h * (acc + h * jerk / 2.0)];
        let strut = Motion::SampledVelocity { time_s: &t, disp_m: &x, vel_m_s: &v };
        let rig = Rig::resume(&self.unit, RigKind::Characterisation { strut }, self.ambient_k, Self::valves(values), 0.0);
        let (rate, _) = rig.rate_and_sample(time_s, &self.state)?;
        // A master's step that exceeds max_dt_s by rounding only (0.001000000000000112
        // from summed times) is one step, not two (`hp_core::ode::steps`):
        // the integration stays the native run's.
        self.state = rig.advance(time_s, time_s + step_s, &self.state, &rate, self.max_dt_s)?;
        Ok(())
    }

    fn warning(&mut self, values: &Values) -> Option<String> {
        // Once per stay on an end stop (the output at_end_stop says it all along).
        let entered = values.get_bool(AT_END_STOP) && !self.on_end_stop;
        self.on_end_stop = values.get_bool(AT_END_STOP);
        entered.then(|| {
            format!(
                "the strut is on an end stop (disp_m = {} m, stroke -{} .. +{} m): the end stops are a stiff spring, not the unit's model",
                values.get(DISP_M),
                self.unit.params().stroke_extension_m,
                self.unit.params().stroke_compression_m
            )
        })
    }
}
