//! One ECU for the whole vehicle: `N` corners (4 to 8), each a unit with
//! its spring valve (6) and damper valve (5), run by the corner controller
//! ([`crate::step`]) with vehicle-level ride height and gas-charge
//! diagnostics on top.
//!
//! Same shape as every block: [`VehicleParams`] (validated, compiled once),
//! [`VehicleState`] (power-on = every corner in its safe state),
//! [`VehicleInputs`] in, [`VehicleOutputs`] out of [`step`]; `no_std`,
//! allocation-free, panic-free, fixed size by the const generic `N`.
//!
//! **Corners.** Each corner has its own sensors (pressures, strut
//! position, body acceleration above it, gas temperature) and its own
//! controller state: its own plausibility checks and safe state, its own
//! load pressure, ride-height sequencer and skyhook. A corner whose sensor
//! fails goes to its safe state (both valves de-energised) while the others
//! keep working. Vehicle signals (speed, accelerations, steering, the
//! driver's switches) are shared: losing them puts every corner in its safe
//! state, as for the single unit. All corners share one set of parameters
//! (one unit type; each corner learns its own load).
//!
//! **Vehicle-level ride height** ([`HeightMode`]): the driver's height mode
//! becomes one request per corner for the seed's pump-free sequencing
//! (`docs/controller.md`). Corner heights always form a plane over the
//! corner positions, so the rigid body is not asked to twist:
//!
//! - `Normal`: every corner at the free offset `RideHeightRequest` (0 =
//!   nominal);
//! - `Lower` / `Raise`: every corner at `-lower_m` / `+raise_m`;
//! - `KneelFront` / `KneelRear`: the front (rear) axle down by `kneel_m`,
//!   the opposite axle at the offset, the axles between on the line;
//! - `SlopeLevel`: keep the body level on a slope: from the measured body
//!   pitch and roll, each corner's correction `-(x - x0) tan(pitch) - (y -
//!   y0) tan(roll)` (corner position relative to the centroid), re-latched
//!   whenever the body is still tilted beyond `slope_tolerance_rad` once
//!   no corner has moved oil for `settle_s` (a corner waiting in its
//!   lowering step at rest moves none), from the corners' present heights.
//!   At rest a pump-free unit can only move towards its zero offset (oil
//!   flows only down the pressure difference a held offset keeps), so the
//!   corrections' plane is shifted to lie between each corner's height and
//!   zero: from a lowered vehicle the low side rises, and the range is the
//!   lowering (`SLOPE_LIMITED` beyond it, or from the zero height). The
//!   base offset is not used while levelling: the vehicle levels from
//!   where it stands.
//!
//! **Mode selection from vehicle signals**: kneeling and slope levelling
//! only at standstill (below `standstill_speed_m_s`; above it they give
//! way to `Normal`); raising only below `raise_max_speed_m_s`; above
//! `auto_lower_speed_m_s` the vehicle lowers by `auto_lower_m` by itself
//! (the body's lower centre of gravity and drag at speed), with hysteresis.
//! [`VehicleOutputs::height_mode`] reports what is applied.
//!
//! **Gas charge** ([`crate::gas_charge`]): each corner's charge estimate
//! runs on that corner's valid samples.

use crate::clock::{dt_us, seconds_to_us};
use crate::config::{check, ParamError};
use crate::gas_charge::{self, GasCharge, GasChargeConfig, GasChargeParams, GasChargeState};
use crate::input_group::{DRIVER, PRESSURES, STEERING, STRUT, TEMPERATURE, VEHICLE};
use crate::{diag, Config, DriverMode, Inputs, Outputs, Params, State};

/// Largest number of corners (four axles).
pub const MAX_CORNERS: usize = 8;

/// Vehicle-level input groups: [`crate::input_group`]'s VEHICLE, STEERING
/// and DRIVER, and the body inclination.
pub mod vehicle_group {
    pub use crate::input_group::{DRIVER, STEERING, VEHICLE};
    /// Body pitch and roll.
    pub const INCLINATION: u16 = 1 << 7;
    /// Every vehicle-level group.
    pub const ALL: u16 = VEHICLE | STEERING | DRIVER | INCLINATION;
}

/// Where a corner sits, m, in the vehicle's axes: `x` forward, `y` to the
/// left, from any reference point (only differences matter).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerGeometry {
    pub x_m: f64,
    pub y_m: f64,
}

/// The driver's ride-height mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum HeightMode {
    /// Every corner at the free offset (0 = nominal).
    #[default]
    Normal = 0,
    /// Lowered by `lower_m` (e.g. a stable firing platform, entry).
    Lower = 1,
    /// Raised by `raise_m` (ground clearance off road).
    Raise = 2,
    /// Front axle lowered by `kneel_m` (standstill only).
    KneelFront = 3,
    /// Rear axle lowered by `kneel_m` (standstill only).
    KneelRear = 4,
    /// Body kept level on a slope (standstill only).
    SlopeLevel = 5,
    /// Lowered by the ECU itself at speed (reported only, not a request).
    AutoLower = 6,
}

impl HeightMode {
    /// From its DBC value.
    pub fn from_u8(raw: u8) -> Option<Self> {
        Some(match raw {
            0 => HeightMode::Normal,
            1 => HeightMode::Lower,
            2 => HeightMode::Raise,
            3 => HeightMode::KneelFront,
            4 => HeightMode::KneelRear,
            5 => HeightMode::SlopeLevel,
            6 => HeightMode::AutoLower,
            _ => return None,
        })
    }
}

/// Vehicle-level ride-height tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevellingConfig {
    /// Lowering of `Lower`, m (positive).
    pub lower_m: f64,
    /// Raising of `Raise`, m.
    pub raise_m: f64,
    /// Lowering of the kneeling axle, m.
    pub kneel_m: f64,
    /// Kneeling and slope levelling only below this speed, m/s.
    pub standstill_speed_m_s: f64,
    /// Raising only below this speed, m/s.
    pub raise_max_speed_m_s: f64,
    /// Automatic lowering above this speed, m/s ...
    pub auto_lower_speed_m_s: f64,
    /// ... until the speed is this much lower again, m/s.
    pub auto_lower_hysteresis_m_s: f64,
    /// Automatic lowering, m (positive).
    pub auto_lower_m: f64,
    /// Body tilt (pitch or roll) left after levelling, rad.
    pub slope_tolerance_rad: f64,
    /// Largest plausible body pitch or roll, rad.
    pub inclination_max_rad: f64,
    /// Time constant of the inclination filter, s.
    pub inclination_tau_s: f64,
    /// Quiet time (no corner moving) before the tilt is looked at again, s.
    pub settle_s: f64,
}

impl Default for LevellingConfig {
    fn default() -> Self {
        LevellingConfig {
            lower_m: 0.04,
            raise_m: 0.04,
            kneel_m: 0.05,
            standstill_speed_m_s: 1.0,
            raise_max_speed_m_s: 15.0,
            auto_lower_speed_m_s: 25.0,
            auto_lower_hysteresis_m_s: 3.0,
            auto_lower_m: 0.02,
            // 0.3 degrees: a few millimetres across a truck's track.
            slope_tolerance_rad: 0.005,
            inclination_max_rad: 0.6,
            inclination_tau_s: 0.5,
            settle_s: 1.5,
        }
    }
}

impl LevellingConfig {
    fn validate(&self, request_max_m: f64) -> Result<(), ParamError> {
        check("levelling.lower_m", self.lower_m, 0.0, request_max_m)?;
        check("levelling.raise_m", self.raise_m, 0.0, request_max_m)?;
        check("levelling.kneel_m", self.kneel_m, 0.0, request_max_m)?;
        check("levelling.standstill_speed_m_s", self.standstill_speed_m_s, 0.0, 10.0)?;
        check("levelling.raise_max_speed_m_s", self.raise_max_speed_m_s, 0.0, 80.0)?;
        check("levelling.auto_lower_speed_m_s", self.auto_lower_speed_m_s, 1.0, 80.0)?;
        check("levelling.auto_lower_hysteresis_m_s", self.auto_lower_hysteresis_m_s, 0.0, self.auto_lower_speed_m_s)?;
        check("levelling.auto_lower_m", self.auto_lower_m, 0.0, request_max_m)?;
        check("levelling.slope_tolerance_rad", self.slope_tolerance_rad, 1.0e-4, 0.1)?;
        check("levelling.inclination_max_rad", self.inclination_max_rad, 0.01, 1.5)?;
        check("levelling.inclination_tau_s", self.inclination_tau_s, 0.0, 60.0)?;
        check("levelling.settle_s", self.settle_s, 0.0, 60.0)
    }
}

/// Everything that configures the vehicle ECU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleConfig<const N: usize> {
    /// The corner controller, shared by every corner.
    pub corner: Config,
    /// Corner positions; corners are numbered axle by axle from the front,
    /// left before right.
    pub geometry: [CornerGeometry; N],
    pub levelling: LevellingConfig,
    pub gas_charge: GasChargeConfig,
}

impl<const N: usize> VehicleConfig<N> {
    /// The seed's unit at every corner of a vehicle with `N / 2` axles
    /// `axle_spacing_m` apart and `track_m` wide.
    pub fn seed_vehicle(axle_spacing_m: f64, track_m: f64) -> Self {
        let mut geometry = [CornerGeometry::default(); N];
        for (i, g) in geometry.iter_mut().enumerate() {
            let axle = (i / 2) as f64;
            *g = CornerGeometry {
                x_m: -axle * axle_spacing_m,
                y_m: if i % 2 == 0 { 0.5 * track_m } else { -0.5 * track_m },
            };
        }
        VehicleConfig { corner: Config::seed_unit(), geometry, levelling: LevellingConfig::default(), gas_charge: GasChargeConfig::default() }
    }

    /// Checks every field; the first invalid one is reported.
    pub fn validate(&self) -> Result<(), ParamError> {
        check("corners", N as f64, 4.0, MAX_CORNERS as f64)?;
        self.corner.validate()?;
        for g in &self.geometry {
            check("geometry.x_m", g.x_m, -50.0, 50.0)?;
            check("geometry.y_m", g.y_m, -10.0, 10.0)?;
        }
        self.levelling.validate(self.corner.ride_height.request_max_m)?;
        self.gas_charge.validate()
    }
}

/// [`LevellingConfig`] compiled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LevellingParams {
    pub(crate) lower_m: f32,
    pub(crate) raise_m: f32,
    pub(crate) kneel_m: f32,
    pub(crate) standstill_speed_m_s: f32,
    pub(crate) raise_max_speed_m_s: f32,
    pub(crate) auto_lower_on_m_s: f32,
    pub(crate) auto_lower_off_m_s: f32,
    pub(crate) auto_lower_m: f32,
    pub(crate) slope_tolerance_rad: f32,
    pub(crate) inclination_max_rad: f32,
    pub(crate) inv_inclination_tau_per_s: f32,
    pub(crate) settle_us: u32,
    pub(crate) request_max_m: f32,
}

/// Validated, compiled parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleParams<const N: usize> {
    pub(crate) corner: Params,
    pub(crate) gas: GasChargeParams,
    pub(crate) levelling: LevellingParams,
    /// Corner positions relative to the centroid, m.
    pub(crate) x_m: [f32; N],
    pub(crate) y_m: [f32; N],
    /// Kneeling weight of each corner: 1 on the front axle, 0 on the rear.
    pub(crate) front_weight: [f32; N],
}

impl<const N: usize> VehicleParams<N> {
    /// Validates `config` and compiles it.
    pub fn new(config: VehicleConfig<N>) -> Result<Self, ParamError> {
        config.validate()?;
        let corner = Params::new(config.corner)?;
        let n = N as f64;
        let x0 = config.geometry.iter().map(|g| g.x_m).sum::<f64>() / n;
        let y0 = config.geometry.iter().map(|g| g.y_m).sum::<f64>() / n;
        let x_max = config.geometry.iter().map(|g| g.x_m).fold(f64::NEG_INFINITY, f64::max);
        let x_min = config.geometry.iter().map(|g| g.x_m).fold(f64::INFINITY, f64::min);
        let span = x_max - x_min;
        if span.partial_cmp(&0.1) != Some(core::cmp::Ordering::Greater) {
            return Err(ParamError::OutOfRange { name: "geometry (front to rear axle)", value: span, min: 0.1, max: 100.0 });
        }
        let l = &config.levelling;
        Ok(VehicleParams {
            corner,
            gas: GasChargeParams::new(&config.gas_charge, &config.corner.unit),
            levelling: LevellingParams {
                lower_m: l.lower_m as f32,
                raise_m: l.raise_m as f32,
                kneel_m: l.kneel_m as f32,
                standstill_speed_m_s: l.standstill_speed_m_s as f32,
                raise_max_speed_m_s: l.raise_max_speed_m_s as f32,
                auto_lower_on_m_s: l.auto_lower_speed_m_s as f32,
                auto_lower_off_m_s: (l.auto_lower_speed_m_s - l.auto_lower_hysteresis_m_s) as f32,
                auto_lower_m: l.auto_lower_m as f32,
                slope_tolerance_rad: l.slope_tolerance_rad as f32,
                inclination_max_rad: l.inclination_max_rad as f32,
                inv_inclination_tau_per_s: if l.inclination_tau_s > 0.0 { (1.0 / l.inclination_tau_s) as f32 } else { 1.0e6 },
                settle_us: seconds_to_us(l.settle_s),
                request_max_m: config.corner.ride_height.request_max_m as f32,
            },
            x_m: config.geometry.map(|g| (g.x_m - x0) as f32),
            y_m: config.geometry.map(|g| (g.y_m - y0) as f32),
            front_weight: config.geometry.map(|g| ((g.x_m - x_min) / span) as f32),
        })
    }

    /// The corner controller's parameters.
    pub fn corner(&self) -> &Params {
        &self.corner
    }

    /// The gas-charge detector's parameters.
    pub fn gas(&self) -> &GasChargeParams {
        &self.gas
    }
}

/// One corner's sensors.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerInputs {
    pub p_gas_pa: f64,
    pub p_gas2_pa: f64,
    pub strut_disp_m: f64,
    pub body_acc_m_s2: f64,
    pub t_gas_k: f64,
    /// Fresh groups this period: PRESSURES, STRUT, BODY, TEMPERATURE.
    pub fresh: u16,
    /// The corner's sensor frames are stale or rejected.
    pub link_fault: bool,
}

/// The vehicle's signals and the driver's switches.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VehicleSignals {
    pub speed_m_s: f64,
    pub lat_acc_m_s2: f64,
    pub long_acc_m_s2: f64,
    pub brake_pressed: bool,
    pub steer_angle_rad: f64,
    pub steer_rate_rad_s: f64,
    pub driver_mode: DriverMode,
    pub height_mode: HeightMode,
    /// The free ride-height offset of `Normal` (and the base of kneeling
    /// and levelling), m.
    pub ride_height_request_m: f64,
    /// Body pitch, nose up positive, rad.
    pub pitch_rad: f64,
    /// Body roll, left side up positive, rad.
    pub roll_rad: f64,
}

/// What the ECU measures in one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleInputs<const N: usize> {
    pub corners: [CornerInputs; N],
    pub vehicle: VehicleSignals,
    /// Fresh vehicle-level groups ([`vehicle_group`]).
    pub fresh: u16,
    /// Vehicle-level link fault (vehicle frames stale, too many rejects).
    pub link_fault: bool,
    /// The inclination frames are stale (only slope levelling needs them,
    /// so they are not part of the link fault).
    pub inclination_stale: bool,
}

impl<const N: usize> Default for VehicleInputs<N> {
    fn default() -> Self {
        VehicleInputs { corners: [CornerInputs::default(); N], vehicle: VehicleSignals::default(), fresh: 0, link_fault: true, inclination_stale: true }
    }
}

/// Vehicle-level diagnostic flags of [`VehicleOutputs::diag`].
pub mod vehicle_diag {
    /// The inclination is stale, not finite or beyond its plausible range:
    /// slope levelling holds its corrections.
    pub const INCLINATION_FAULT: u32 = 1 << 0;
    /// Slope levelling needs more than its range (at rest: the base
    /// offset, see [`step`]): the body is levelled only as far as that.
    pub const SLOPE_LIMITED: u32 = 1 << 1;
    /// The requested height mode is not allowed at this speed.
    pub const MODE_REFUSED: u32 = 1 << 2;
}

/// What the vehicle step commands and reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleOutputs<const N: usize> {
    pub corners: [Outputs; N],
    pub gas: [GasCharge; N],
    /// The ride-height mode applied.
    pub height_mode: HeightMode,
    /// [`vehicle_diag`] flags.
    pub diag: u32,
}

impl<const N: usize> VehicleOutputs<N> {
    /// Every corner in its safe state (what the outputs are before the
    /// first step).
    pub fn safe() -> Self {
        VehicleOutputs {
            corners: [Outputs { diag: diag::SAFE_STATE, ..Outputs::default() }; N],
            gas: [GasCharge { charge_ratio: 1.0, ..GasCharge::default() }; N],
            height_mode: HeightMode::Normal,
            diag: 0,
        }
    }
}

/// Slope-levelling state.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Levelling<const N: usize> {
    /// Each corner's ride-height request while levelling, m.
    request_m: [f32; N],
    pitch_rad: f32,
    roll_rad: f32,
    /// Time since the last inclination sample, us.
    inclination_age_us: u32,
    /// Time no corner has been moving, us.
    quiet_us: u32,
    active: bool,
    auto_lowered: bool,
}

/// Everything the vehicle ECU remembers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleState<const N: usize> {
    corners: [State; N],
    gas: [GasChargeState; N],
    levelling: Levelling<N>,
}

impl<const N: usize> VehicleState<N> {
    /// Power-on: every corner in its safe state.
    pub const fn new() -> Self {
        VehicleState {
            corners: [State::new(); N],
            gas: [GasChargeState::new(); N],
            levelling: Levelling {
                request_m: [0.0; N],
                pitch_rad: 0.0,
                roll_rad: 0.0,
                inclination_age_us: 0,
                quiet_us: 0,
                active: false,
                auto_lowered: false,
            },
        }
    }

    /// The corners' controller states.
    pub fn corners(&self) -> &[State; N] {
        &self.corners
    }
}

impl<const N: usize> Default for VehicleState<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// `tan(x)` for `|x| <= 0.6` rad (the plausible inclinations) within
/// 5e-4 relative, from its Taylor series to `x^7`: libm's `tanf` would add
/// 3 KB of flash for angles the levelling never sees.
///
/// ```
/// # use hp_ctrl::vehicle::tan_small;
/// for x in [-0.6_f32, -0.2, 0.0, 0.05, 0.3, 0.6] {
///     assert!((tan_small(x) - x.tan()).abs() <= 5e-4 * x.tan().abs() + 1e-7);
/// }
/// ```
pub fn tan_small(x: f32) -> f32 {
    let x2 = x * x;
    x * (1.0 + x2 * (1.0 / 3.0 + x2 * (2.0 / 15.0 + x2 * (17.0 / 315.0))))
}

/// The body's tilt and the corner positions (relative to the centroid).
struct Tilt<'a, const N: usize> {
    tan_pitch: f32,
    tan_roll: f32,
    x_m: &'a [f32; N],
    y_m: &'a [f32; N],
}

/// Slope levelling's requests from the corners' present ride heights
/// `heights`: each corner moves by `-x tan(pitch) - y tan(roll)` plus one
/// shift common to all (the plane keeps its tilt), chosen so that every
/// corner moves towards its zero offset: at rest a pump-free unit moves oil
/// only down a pressure difference, and the only one there is what a held
/// offset keeps (a lowered corner can rise, a raised one sink, neither go
/// further). So from a lowered vehicle the low side rises and the lowest
/// corner stays; each request is limited to between its height and zero.
/// Returns true if that limit (or `request_max`) cut a request: the body
/// is levelled only as far as the held offsets allow.
///
/// ```text
/// heights -30 mm, moves -8, +4, +10 mm -> shift +8: requests -30, -18, -12 mm
/// ```
fn level_towards_zero<const N: usize>(requests: &mut [f32; N], heights: &[f32; N], tilt: &Tilt<'_, N>, request_max: f32) -> bool {
    let moves = core::array::from_fn::<f32, N, _>(|k| {
        let (x, y) = (tilt.x_m.get(k).copied().unwrap_or(0.0), tilt.y_m.get(k).copied().unwrap_or(0.0));
        -(x * tilt.tan_pitch + y * tilt.tan_roll)
    });
    let mean_height = heights.iter().sum::<f32>() / N as f32;
    // Lowered: every corner rises, the one that moves least stays.
    // Raised: every corner sinks, the one that moves most stays.
    let shift = if mean_height < 0.0 {
        -moves.iter().copied().fold(f32::INFINITY, f32::min)
    } else {
        -moves.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    };
    let mut limited = false;
    for ((r, &h), m) in requests.iter_mut().zip(heights).zip(moves) {
        let wanted = h + m + shift;
        let (lo, hi) = (h.min(0.0).max(-request_max), h.max(0.0).min(request_max));
        *r = wanted.max(lo).min(hi);
        limited |= *r != wanted;
    }
    limited
}

/// The applied height mode and the base offset of every corner.
fn select_mode(p: &LevellingParams, v: &VehicleSignals, driver_ok: bool, flags: &mut u32) -> (HeightMode, f32) {
    let speed = (v.speed_m_s as f32).abs();
    let (mode, offset) = if driver_ok {
        (v.height_mode, v.ride_height_request_m as f32)
    } else {
        (HeightMode::Normal, 0.0)
    };
    let standstill = speed < p.standstill_speed_m_s;
    let mode = match mode {
        HeightMode::KneelFront | HeightMode::KneelRear | HeightMode::SlopeLevel if !standstill => {
            *flags |= vehicle_diag::MODE_REFUSED;
            HeightMode::Normal
        }
        HeightMode::Raise if speed > p.raise_max_speed_m_s => {
            *flags |= vehicle_diag::MODE_REFUSED;
            HeightMode::Normal
        }
        HeightMode::AutoLower => HeightMode::Normal,
        m => m,
    };
    let base = match mode {
        HeightMode::Lower => -p.lower_m,
        HeightMode::Raise => p.raise_m,
        _ => if offset.is_finite() { offset } else { 0.0 },
    };
    (mode, base)
}

/// One control period of the whole vehicle.
///
/// ```
/// use hp_ctrl::vehicle::{self, CornerInputs, VehicleConfig, VehicleInputs, VehicleParams, VehicleState, vehicle_group};
/// use hp_ctrl::input_group;
/// let params = VehicleParams::<4>::new(VehicleConfig::seed_vehicle(3.5, 2.0)).unwrap();
/// let unit = &params.corner().config().unit;
/// let mut state = VehicleState::<4>::new();
/// let corner = CornerInputs {
///     p_gas_pa: unit.static_pressure_pa,
///     p_gas2_pa: unit.static_pressure_pa,
///     t_gas_k: unit.static_temperature_k,
///     fresh: input_group::PRESSURES | input_group::STRUT | input_group::BODY | input_group::TEMPERATURE,
///     ..Default::default()
/// };
/// let mut inputs = VehicleInputs::<4> { corners: [corner; 4], fresh: vehicle_group::ALL, link_fault: false, ..Default::default() };
/// inputs.vehicle.speed_m_s = 10.0;
/// let mut out = vehicle::step(&params, &mut state, &inputs, 1e-3);
/// for _ in 0..3000 {
///     out = vehicle::step(&params, &mut state, &inputs, 1e-3);
/// }
/// // Every corner left its safe state: soft spring, valve 6 open.
/// assert!(out.corners.iter().all(|c| c.valve6_open && c.diag & hp_ctrl::diag::SAFE_STATE == 0));
/// // One corner's pressure sensor fails: that corner alone is safe.
/// inputs.corners[2].p_gas_pa = f64::NAN;
/// let out = vehicle::step(&params, &mut state, &inputs, 1e-3);
/// assert!(out.corners[2].diag & hp_ctrl::diag::SAFE_STATE != 0 && !out.corners[2].valve6_open);
/// assert!(out.corners[0].valve6_open && out.corners[3].valve6_open);
/// ```
pub fn step<const N: usize>(p: &VehicleParams<N>, s: &mut VehicleState<N>, i: &VehicleInputs<N>, dt_s: f64) -> VehicleOutputs<N> {
    let lp = &p.levelling;
    let dt_us = dt_us(dt_s, p.corner.config().monitor.dt_max_s).unwrap_or(0);
    let v = &i.vehicle;
    let mut flags = 0;
    let vehicle_fresh = i.fresh & (VEHICLE | STEERING | DRIVER);

    // The inclination: received in time and plausible (NaN fails too).
    let (pitch, roll) = (v.pitch_rad as f32, v.roll_rad as f32);
    let inclination_ok = !i.inclination_stale && pitch.abs() <= lp.inclination_max_rad && roll.abs() <= lp.inclination_max_rad;
    let lev = &mut s.levelling;
    lev.inclination_age_us = lev.inclination_age_us.saturating_add(dt_us);
    if inclination_ok && i.fresh & vehicle_group::INCLINATION != 0 {
        // Weighted by the time since the previous sample (the inclination
        // arrives every 10 ms, not every period).
        let k = (crate::clock::us_to_seconds(lev.inclination_age_us) * lp.inv_inclination_tau_per_s).min(1.0);
        lev.inclination_age_us = 0;
        lev.pitch_rad += k * (pitch - lev.pitch_rad);
        lev.roll_rad += k * (roll - lev.roll_rad);
    } else if !inclination_ok {
        flags |= vehicle_diag::INCLINATION_FAULT;
    }

    let driver_ok = !i.link_fault && v.ride_height_request_m.is_finite();
    let (mut mode, mut base) = select_mode(lp, v, driver_ok, &mut flags);
    // Automatic lowering at speed, with hysteresis, unless already lower.
    let speed = (v.speed_m_s as f32).abs();
    lev.auto_lowered = if lev.auto_lowered { speed > lp.auto_lower_off_m_s } else { speed > lp.auto_lower_on_m_s };
    if lev.auto_lowered && base > -lp.auto_lower_m {
        base = -lp.auto_lower_m;
        mode = HeightMode::AutoLower;
    }

    // Slope levelling: re-latch the corrections once no oil has moved for
    // the settling time. Not "no corner in `Lowering` or `Raising`": a
    // corner still lowering when the vehicle stops waits at rest for road
    // pressure differences that never come, and would block levelling for
    // ever (seen in the processor-in-the-loop runs on the rigid-body
    // vehicle, where the corners finish lowering later than on separate rigs).
    let moving = s.corners.iter().any(State::moving_oil);
    lev.quiet_us = if moving { 0 } else { lev.quiet_us.saturating_add(dt_us) };
    if mode == HeightMode::SlopeLevel {
        let heights: [f32; N] = core::array::from_fn(|k| s.corners.get(k).map_or(0.0, State::ride_height_m));
        if !lev.active {
            // Every corner holds where it stands until the first look.
            lev.active = true;
            lev.quiet_us = 0;
            lev.request_m = heights;
        }
        // Never away from zero from where a corner stands, also when its
        // held offset drifts (L's gas cooling after a drive moves it by
        // millimetres): a request it cannot reach at rest would keep it
        // waiting in `Lowering` (or `Raising`) for ever.
        for (r, &h) in lev.request_m.iter_mut().zip(&heights) {
            *r = r.max(h.min(0.0)).min(h.max(0.0));
        }
        let tilted = lev.pitch_rad.abs() > lp.slope_tolerance_rad || lev.roll_rad.abs() > lp.slope_tolerance_rad;
        if inclination_ok && tilted && lev.quiet_us >= lp.settle_us {
            let tilt = Tilt { tan_pitch: tan_small(lev.pitch_rad), tan_roll: tan_small(lev.roll_rad), x_m: &p.x_m, y_m: &p.y_m };
            if level_towards_zero(&mut lev.request_m, &heights, &tilt, lp.request_max_m) {
                flags |= vehicle_diag::SLOPE_LIMITED;
            }
            lev.quiet_us = 0;
        }
    } else {
        lev.active = false;
    }

    let mut corners = [Outputs::default(); N];
    let mut gas = [GasCharge::default(); N];
    let per_corner = corners.iter_mut().zip(gas.iter_mut()).zip(s.corners.iter_mut().zip(s.gas.iter_mut()));
    for (n, ((out, gas_out), (state, gas_state))) in per_corner.enumerate() {
        let Some(c) = i.corners.get(n) else { continue };
        let kneel = match mode {
            HeightMode::KneelFront => -lp.kneel_m * p.front_weight.get(n).copied().unwrap_or(0.0),
            HeightMode::KneelRear => -lp.kneel_m * (1.0 - p.front_weight.get(n).copied().unwrap_or(1.0)),
            _ => 0.0,
        };
        let request = if mode == HeightMode::SlopeLevel { lev.request_m.get(n).copied().unwrap_or(base) } else { base + kneel };
        let inputs = Inputs {
            p_gas_pa: c.p_gas_pa,
            p_gas2_pa: c.p_gas2_pa,
            strut_disp_m: c.strut_disp_m,
            body_acc_m_s2: c.body_acc_m_s2,
            speed_m_s: v.speed_m_s,
            lat_acc_m_s2: v.lat_acc_m_s2,
            long_acc_m_s2: v.long_acc_m_s2,
            steer_angle_rad: v.steer_angle_rad,
            steer_rate_rad_s: v.steer_rate_rad_s,
            brake_pressed: v.brake_pressed,
            t_gas_k: c.t_gas_k,
            driver_mode: v.driver_mode,
            ride_height_request_m: f64::from(request),
            fresh: (c.fresh & (PRESSURES | STRUT | crate::input_group::BODY | TEMPERATURE)) | vehicle_fresh,
            link_fault: c.link_fault || i.link_fault,
        };
        *out = crate::step(&p.corner, state, &inputs, dt_s);
        let sample = p.gas.corner_sample(p.corner.large_table(), &inputs, out.diag);
        *gas_out = gas_charge::step(&p.gas, gas_state, sample, dt_us);
    }
    VehicleOutputs { corners, gas, height_mode: mode, diag: flags }
}
