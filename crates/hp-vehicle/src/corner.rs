//! One wheel station: the unit between the body and the wheel, the tyre
//! between the wheel and the road. Shared by the quarter car and the full
//! vehicle, so both have the same strut kinematics and tyre contact.
//!
//! Displacements are measured from static equilibrium, positive up. The
//! strut is vertical with a motion ratio of one (the seed's unit is
//! mounted per wheel): its compression is the static compression plus the
//! wheel's rise relative to the body above it.

use hp_core::gas::EquationOfState;
use hp_core::unit::{Linearisation, Needs, StrutMotion, Unit, UnitOutputs, UnitState, Valves};

use crate::tyre::Tyre;

/// Where a corner's parts are at one instant (m, m/s; positive up).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerMotion {
    /// The body at the strut's top mount.
    pub body_disp_m: f64,
    pub body_vel_m_s: f64,
    /// The wheel (unsprung mass).
    pub wheel_disp_m: f64,
    pub wheel_vel_m_s: f64,
    /// The road under the wheel.
    pub road_m: f64,
    pub road_vel_m_s: f64,
}

/// What a corner does at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerForces {
    /// Strut compression from the static position of the unit and its rate.
    pub strut: StrutMotion,
    /// The unit's outputs (strut force `unit.force_true_n`, compression positive).
    pub unit: UnitOutputs,
    /// Tyre deflection, m (<= 0: the wheel is off the ground).
    pub tyre_deflection_m: f64,
    /// Vertical force of the road on the tyre, N (>= 0).
    pub tyre_force_n: f64,
}

/// The unit's state rate and the corner's forces.
///
/// `static_disp_m` is the strut compression and `tyre_static_deflection_m`
/// the tyre deflection at static equilibrium. The unit's gas properties
/// come from `gas` (the unit's own equation of state, or a table of it);
/// with `outputs` false only the rate, the strut force and the pressures
/// are computed (see [`Needs`]); with `coupling` the unit's linearisations
/// that the vehicle's ROS2 puts in its `W` are returned: valve 6's exchange
/// (when open) and the strut's (see [`Linearisation`]). The damper flow's,
/// there only with oil compliance, is not used: the strut pressure is not
/// among the states that `W` treats implicitly.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn evaluate(
    unit: &Unit,
    gas: &impl EquationOfState,
    outputs: bool,
    coupling: bool,
    tyre: &Tyre,
    state: &UnitState,
    motion: &CornerMotion,
    static_disp_m: f64,
    tyre_static_deflection_m: f64,
    valves: Valves,
    ambient_k: f64,
) -> (UnitState, CornerForces, Linearisation) {
    let strut = StrutMotion {
        disp_m: static_disp_m + motion.wheel_disp_m - motion.body_disp_m,
        vel_m_s: motion.wheel_vel_m_s - motion.body_vel_m_s,
    };
    let (rate, unit_out, linear) = unit.evaluate_parts_plain_with(gas, state, strut, valves, ambient_k, Needs { outputs, coupling, strut: coupling, rates: true });
    let deflection = tyre_static_deflection_m + motion.road_m - motion.wheel_disp_m;
    let tyre_force = tyre.force_n(deflection, motion.road_vel_m_s - motion.wheel_vel_m_s);
    (rate, CornerForces { strut, unit: unit_out, tyre_deflection_m: deflection, tyre_force_n: tyre_force }, linear)
}
