//! Configuration validation and the seed unit.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use hp_ctrl::{Config, ParamError, Params};

#[test]
fn the_seed_unit_is_the_plant_models_unit() {
    let params = Params::seed_unit().unwrap();
    let unit = hp_core::presets::seed_unit();
    let c = params.config().unit;
    assert_eq!(c.piston_area_m2, unit.piston_area_m2);
    assert_eq!(c.large_acc_volume_m3, hp_core::presets::SEED_LARGE_VOLUME_M3);
    assert_eq!(c.static_temperature_k, hp_core::presets::SEED_STATIC_TEMPERATURE_K);
    // p = p_atm + m g / A for the 3000 kg sprung mass.
    let expected = 101_325.0 + 3000.0 * 9.80665 / unit.piston_area_m2;
    assert!((c.static_pressure_pa / expected - 1.0).abs() < 1e-12);
    // A 1 kHz controller.
    assert!(params.config().monitor.dt_max_s >= 1e-3);
}

#[test]
fn every_error_names_the_field_its_value_and_the_range() {
    let mut config = Config::seed_unit();
    config.ride_height.valve6_margin_pa = f64::NAN;
    let err = Params::new(config).unwrap_err();
    match err {
        ParamError::OutOfRange { name, value, min, max } => {
            assert_eq!(name, "ride_height.valve6_margin_pa");
            assert!(value.is_nan());
            assert!(min <= 0.0 && max > 0.0);
        }
        other => panic!("{other:?}"),
    }
    let text = err.to_string();
    assert!(text.contains("ride_height.valve6_margin_pa") && text.contains("NaN"), "{text}");
}

/// A field name and how to spoil it.
type Spoiler = (&'static str, fn(&mut Config));

#[test]
fn out_of_range_fields_are_rejected() {
    let seed = Config::seed_unit();
    let cases: [Spoiler; 9] = [
        ("unit.piston_area_m2", |c| c.unit.piston_area_m2 = 0.0),
        ("unit.static_temperature_k", |c| c.unit.static_temperature_k = f64::INFINITY),
        ("monitor.recovery_s", |c| c.monitor.recovery_s = -0.1),
        ("monitor.timeouts.body_s", |c| c.monitor.timeouts.body_s = 1e-4),
        ("estimator.strut_velocity_tau_s", |c| c.estimator.strut_velocity_tau_s = 1e-4),
        ("mode.handling_hold_s", |c| c.mode.handling_hold_s = 1e9),
        ("damper.valve5_min_interval_s", |c| c.damper.valve5_min_interval_s = -1.0),
        ("ride_height.request_max_m", |c| c.ride_height.request_max_m = 0.2),
        ("ride_height.load_pressure_tau_s", |c| c.ride_height.load_pressure_tau_s = 0.0),
    ];
    for (field, spoil) in cases {
        let mut config = seed;
        spoil(&mut config);
        match Params::new(config) {
            Err(ParamError::OutOfRange { name, .. }) => assert_eq!(name, field),
            other => panic!("{field}: {other:?}"),
        }
    }
}

#[test]
fn hysteresis_pairs_must_be_ordered() {
    let mut config = Config::seed_unit();
    config.mode.lat_acc_exit_m_s2 = config.mode.lat_acc_enter_m_s2;
    match config.validate() {
        Err(ParamError::NotBelow { name, limit_name, .. }) => {
            assert_eq!((name, limit_name), ("mode.lat_acc_exit_m_s2", "mode.lat_acc_enter_m_s2"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_large_accumulator_too_small_for_the_stroke_is_rejected() {
    let mut config = Config::seed_unit();
    config.unit.large_acc_volume_m3 = 0.9 * config.unit.piston_area_m2 * config.unit.stroke_compression_m;
    assert!(matches!(config.validate(), Err(ParamError::NotBelow { limit_name: "unit.large_acc_volume_m3", .. })));
}

#[test]
fn the_gas_table_must_leave_gas_in_l_beyond_the_stroke_by_the_largest_request() {
    // The table spans the stroke widened by request_max_m on both sides.
    let mut config = Config::seed_unit();
    let a = config.unit.piston_area_m2;
    config.unit.large_acc_volume_m3 = a * (config.unit.stroke_compression_m + 0.5 * config.ride_height.request_max_m);
    assert!(matches!(config.validate(), Err(ParamError::NotBelow { limit_name: "unit.large_acc_volume_m3", .. })));
    config.ride_height.request_max_m *= 0.4;
    assert!(config.validate().is_ok(), "{:?}", config.validate());
}

#[test]
fn a_unit_outside_the_gas_models_range_is_rejected_not_tabulated() {
    // L nearly emptied of gas at full lowering: above 300 MPa.
    let mut config = Config::seed_unit();
    config.unit.large_acc_volume_m3 = 1.02 * config.unit.piston_area_m2 * config.unit.stroke_compression_m;
    config.unit.static_pressure_pa = 1.0e8;
    config.ride_height.request_max_m = 0.0;
    config.ride_height.request_deadband_m = 0.0;
    assert!(matches!(Params::new(config), Err(ParamError::GasTable { .. })), "{:?}", Params::new(config).err());
}
