//! FMI 2.0 co-simulation FMUs of the hydro-pneumatic unit and its
//! controller.
//!
//! - [`model`]: what a model author writes (a variable table, the
//!   [`model::Model`] trait).
//! - [`fmi2`], `export`: the standard's C API, written once: life cycle,
//!   value references, logging, FMU state, panics caught at the boundary.
//! - [`description`]: `modelDescription.xml`, generated from the table.
//! - [`unit`], [`controller`]: the two models, on `hp-core` and `hp-ctrl`.
//!
//! One shared library serves both FMUs (the GUID picks the model);
//! `scripts/build-fmu.sh` packs it into `hpctl_unit.fmu` and
//! `hpctl_controller.fmu`. See `docs/fmu.md`.

// `!(x > y)` is how NaN is rejected together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod controller;
pub mod description;
mod export;
pub mod fmi2;
pub mod model;
pub mod unit;

use model::Model;

/// The models of this library, by the GUID of their model description.
pub fn registry(guid: &str) -> Option<Box<dyn fmi2::Component>> {
    if guid == unit::UnitModel::info().guid() {
        Some(Box::new(fmi2::Core::<unit::UnitModel>::new()))
    } else if guid == controller::ControllerModel::info().guid() {
        Some(Box::new(fmi2::Core::<controller::ControllerModel>::new()))
    } else {
        None
    }
}

/// The model with FMI `identifier` (`hpctl_unit`, `hpctl_controller`).
pub fn model_info(identifier: &str) -> Option<&'static model::ModelInfo> {
    [unit::UnitModel::info(), controller::ControllerModel::info()].into_iter().find(|i| i.identifier == identifier)
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller::ControllerModel;
    use unit::UnitModel;

    /// The value-reference constants the models use are their tables' positions.
    #[test]
    fn value_references_match_the_tables() {
        let u = UnitModel::info();
        for (vr, name) in [
            (unit::DISP_M, "disp_m"),
            (unit::VEL_M_S, "vel_m_s"),
            (unit::VALVE5_OPEN, "valve5_open"),
            (unit::VALVE6_OPEN, "valve6_open"),
            (unit::FORCE_N, "force_n"),
            (unit::FORCE_TRUE_N, "force_true_n"),
            (unit::P_STRUT_PA, "p_strut_pa"),
            (unit::P_GAS_PA, "p_gas_pa"),
            (unit::P_GAS2_PA, "p_gas2_pa"),
            (unit::T_GAS_K, "t_gas_k"),
            (unit::T_GAS2_K, "t_gas2_k"),
            (unit::T_OIL_K, "t_oil_k"),
            (unit::V_GAS_M3, "v_gas_m3"),
            (unit::V_GAS2_M3, "v_gas2_m3"),
            (unit::DAMPER_FORCE_N, "damper_force_n"),
            (unit::DAMPER_POWER_W, "damper_power_w"),
            (unit::VALVE6_POWER_W, "valve6_power_w"),
            (unit::DISSIPATED_POWER_W, "dissipated_power_w"),
            (unit::E_DISSIPATED_J, "e_dissipated_j"),
            (unit::FLOW_VALVE6_M3_S, "flow_valve6_m3_s"),
            (unit::CAVITATING, "cavitating"),
            (unit::AT_END_STOP, "at_end_stop"),
            (unit::AMBIENT_K, "ambient_k"),
            (unit::MAX_DT_S, "max_dt_s"),
            (unit::GAS_MODEL, "gas"),
            (unit::TAU_S, "tau_s"),
            (unit::FIRST_UNIT_PARAMETER, "piston_area_m2"),
        ] {
            assert_eq!(u.vars.get(vr).map(|v| v.name), Some(name));
        }
        let c = ControllerModel::info();
        for (vr, name) in [
            (controller::P_GAS_PA, "p_gas_pa"),
            (controller::P_GAS2_PA, "p_gas2_pa"),
            (controller::STRUT_DISP_M, "strut_disp_m"),
            (controller::BODY_ACC_M_S2, "body_acc_m_s2"),
            (controller::SPEED_M_S, "speed_m_s"),
            (controller::LAT_ACC_M_S2, "lat_acc_m_s2"),
            (controller::LONG_ACC_M_S2, "long_acc_m_s2"),
            (controller::STEER_ANGLE_RAD, "steer_angle_rad"),
            (controller::STEER_RATE_RAD_S, "steer_rate_rad_s"),
            (controller::BRAKE_PRESSED, "brake_pressed"),
            (controller::T_GAS_K, "t_gas_k"),
            (controller::DRIVER_MODE_VR, "driver_mode"),
            (controller::RIDE_HEIGHT_REQUEST_M, "ride_height_request_m"),
            (controller::FRESH, "fresh"),
            (controller::LINK_FAULT, "link_fault"),
            (controller::VALVE5_OPEN, "valve5_open"),
            (controller::VALVE6_OPEN, "valve6_open"),
            (controller::DRIVE_MODE_VR, "drive_mode"),
            (controller::SPRING_MODE_VR, "spring_mode"),
            (controller::DAMPER_MODE_VR, "damper_mode"),
            (controller::SEQUENCER_VR, "sequencer"),
            (controller::DIAG, "diag"),
            (controller::SAFE_STATE, "safe_state"),
            (controller::RIDE_HEIGHT_M, "ride_height_m"),
            (controller::P_GAS2_TARGET_PA, "p_gas2_target_pa"),
            (controller::P_LOAD_PA, "p_load_pa"),
            (controller::STRUT_VEL_M_S, "strut_vel_m_s"),
            (controller::BODY_VEL_M_S, "body_vel_m_s"),
            (controller::PERIOD_S, "period_s"),
            (controller::GAS_MODEL, "unit.gas"),
            (controller::FIRST_CONFIG_PARAMETER, "unit.piston_area_m2"),
        ] {
            assert_eq!(c.vars.get(vr).map(|v| v.name), Some(name));
        }
    }

    /// Start values round-trip: the FMU's defaults are the seed unit and the
    /// seed calibration exactly.
    #[test]
    fn start_values_are_the_seed() {
        let v = model::Values::new(unit::UnitModel::info());
        assert_eq!(unit::unit_params(&v).ok(), Some(hp_core::presets::seed_unit()));
        let v = model::Values::new(controller::ControllerModel::info());
        assert_eq!(controller::config(&v).ok(), Some(hp_ctrl::Config::seed_unit()));
    }

    /// Names are unique and GUIDs differ between the models.
    #[test]
    fn names_unique_and_guids_distinct() {
        for info in [unit::UnitModel::info(), controller::ControllerModel::info()] {
            let mut names: Vec<_> = info.vars.iter().map(|v| v.name).collect();
            names.sort_unstable();
            let n = names.len();
            names.dedup();
            assert_eq!(names.len(), n, "{}", info.identifier);
        }
        assert_ne!(unit::UnitModel::info().guid(), controller::ControllerModel::info().guid());
    }
}
