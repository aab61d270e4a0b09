//! The gas in accumulator L: the pressure that holds a ride-height offset.
//!
//! With valve 6 closed, L holds a fixed mass of gas `m_L` and whatever oil
//! the sequencer moved into it. An offset `h` of the static position (negative
//! = lowered) means `-A h` more oil in L, so L's gas volume is
//! `V_L(h) = V_L0 + A h` and its pressure `p_L(h, T) = p(m_L / V_L(h), T)`
//! from the equation of state. `m_L` comes from the static charge
//! (`p_static`, `T_static`, `V_L0`).
//!
//! The step function must not solve the equation of state (a BWR pressure
//! costs thousands of instructions on the ECU's double-precision-less FPU),
//! so [`LargeTable::new`] tabulates `p_L(h, T)` once, over the whole stroke
//! and the whole valid temperature range, and the step interpolates
//! bilinearly in single precision: forwards for the target pressure of a
//! request, backwards (pressure to offset) for the ride-height estimate.
//! The same table serves both, so the estimate reaches the request exactly
//! when `p_L` reaches the target pressure.

use hp_core::gas::{EquationOfState, Gas};
use hp_core::presets;

use crate::config::{check, check_below, ParamError};

/// The spring-damper unit as the controller sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitConfig {
    /// Strut piston area, m^2.
    pub piston_area_m2: f64,
    /// Gas volume of L at the nominal static position, m^3.
    pub large_volume_m3: f64,
    /// Gas pressure at the nominal static position, Pa.
    pub static_pressure_pa: f64,
    /// Gas temperature of the static charge, K.
    pub static_temperature_k: f64,
    /// Equation of state of the gas.
    pub gas: Gas,
    /// Travel from the static position to the compression end stop, m.
    pub stroke_compression_m: f64,
    /// Travel from the static position to the extension end stop, m.
    pub stroke_extension_m: f64,
}

impl UnitConfig {
    /// The unit the plant model describes, so controller and plant share
    /// one set of numbers.
    pub fn from_unit(unit: &hp_core::unit::UnitParams) -> Self {
        UnitConfig {
            piston_area_m2: unit.piston_area_m2,
            large_volume_m3: unit.large_volume_m3,
            static_pressure_pa: unit.static_pressure_pa,
            static_temperature_k: unit.static_temperature_k,
            gas: unit.gas,
            stroke_compression_m: unit.stroke_compression_m,
            stroke_extension_m: unit.stroke_extension_m,
        }
    }

    /// The seed's unit, [`hp_core::presets::seed_unit`].
    pub fn seed_unit() -> Self {
        UnitConfig::from_unit(&presets::seed_unit())
    }

    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        check("unit.piston_area_m2", self.piston_area_m2, 1.0e-5, 0.1)?;
        check("unit.large_volume_m3", self.large_volume_m3, 1.0e-6, 0.1)?;
        check("unit.static_pressure_pa", self.static_pressure_pa, 1.0e5, 1.2e8)?;
        check("unit.static_temperature_k", self.static_temperature_k, 200.0, 600.0)?;
        check("unit.stroke_compression_m", self.stroke_compression_m, 1.0e-3, 1.0)?;
        check("unit.stroke_extension_m", self.stroke_extension_m, 1.0e-3, 1.0)?;
        // Lowering to the compression end stop must leave gas in L.
        check_below(
            "unit.piston_area_m2 * unit.stroke_compression_m",
            self.piston_area_m2 * self.stroke_compression_m,
            "unit.large_volume_m3",
            self.large_volume_m3,
        )
    }
}

/// Temperature nodes of the table.
pub const TABLE_TEMPERATURES: usize = 16;
/// Ride-height nodes of the table.
pub const TABLE_HEIGHTS: usize = 21;

/// `p_L(h, T)` on a regular grid, Pa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LargeTable {
    /// `p_pa[i][j]` at temperature node `i`, ride-height node `j`.
    p_pa: [[f32; TABLE_HEIGHTS]; TABLE_TEMPERATURES],
    t0_k: f32,
    t_step_k: f32,
    h0_m: f32,
    h_step_m: f32,
}

/// Position of a value on a regular grid: the lower node and the weight of
/// the upper one.
#[derive(Debug, Clone, Copy)]
struct GridPoint {
    node: usize,
    weight: f32,
}

impl GridPoint {
    /// `x` on the grid `x0 + k * step`, `k = 0..nodes`, clamped to its ends.
    fn locate(x: f32, x0: f32, step: f32, nodes: usize) -> Self {
        let last = (nodes - 1) as f32;
        // `max` first: a NaN `x` becomes node 0 instead of propagating.
        let k = ((x - x0) / step).max(0.0).min(last);
        let node = (k as usize).min(nodes - 2);
        GridPoint { node, weight: k - node as f32 }
    }
}

fn lerp(a: f32, b: f32, w: f32) -> f32 {
    a + w * (b - a)
}

/// `p_L` over the ride-height nodes at one temperature.
struct Column<'a> {
    lo: &'a [f32; TABLE_HEIGHTS],
    hi: &'a [f32; TABLE_HEIGHTS],
    weight: f32,
}

impl Column<'_> {
    fn at(&self, j: usize) -> f32 {
        // Callers pass j < TABLE_HEIGHTS; the fallback is never taken.
        match (self.lo.get(j), self.hi.get(j)) {
            (Some(&a), Some(&b)) => lerp(a, b, self.weight),
            _ => 0.0,
        }
    }
}

impl LargeTable {
    /// Tabulates `p_L` for heights over the whole stroke and temperatures
    /// over `[t_min_k, t_max_k]`.
    pub fn new(unit: &UnitConfig, t_min_k: f64, t_max_k: f64) -> Result<Self, ParamError> {
        let gas = unit.gas;
        let rho_static = gas
            .density_kg_m3(unit.static_pressure_pa, unit.static_temperature_k)
            .map_err(ParamError::Gas)?;
        let mass_kg = rho_static * unit.large_volume_m3;
        let t_step_k = (t_max_k - t_min_k) / (TABLE_TEMPERATURES - 1) as f64;
        let h0_m = -unit.stroke_compression_m;
        let h_step_m = (unit.stroke_compression_m + unit.stroke_extension_m) / (TABLE_HEIGHTS - 1) as f64;
        let mut p_pa = [[0.0_f32; TABLE_HEIGHTS]; TABLE_TEMPERATURES];
        for (i, row) in p_pa.iter_mut().enumerate() {
            let t_k = t_min_k + t_step_k * i as f64;
            let mut previous = f32::INFINITY;
            for (j, cell) in row.iter_mut().enumerate() {
                let h_m = h0_m + h_step_m * j as f64;
                let volume_m3 = unit.large_volume_m3 + unit.piston_area_m2 * h_m;
                let p = gas.pressure_pa(mass_kg / volume_m3, t_k);
                let p32 = p as f32;
                let usable = p.is_finite()
                    && p > hp_core::gas::PRESSURE_RANGE_PA.0
                    && p < hp_core::gas::PRESSURE_RANGE_PA.1
                    && p32 < previous;
                if !usable {
                    return Err(ParamError::GasTable { t_k, ride_height_m: h_m, p_pa: p });
                }
                *cell = p32;
                previous = p32;
            }
        }
        Ok(LargeTable {
            p_pa,
            t0_k: t_min_k as f32,
            t_step_k: t_step_k as f32,
            h0_m: h0_m as f32,
            h_step_m: h_step_m as f32,
        })
    }

    fn column(&self, t_k: f32) -> Column<'_> {
        let at = GridPoint::locate(t_k, self.t0_k, self.t_step_k, TABLE_TEMPERATURES);
        let first = &self.p_pa[0];
        Column {
            lo: self.p_pa.get(at.node).unwrap_or(first),
            hi: self.p_pa.get(at.node + 1).unwrap_or(first),
            weight: at.weight,
        }
    }

    /// Smallest and largest tabulated ride-height offset, m.
    pub fn height_range_m(&self) -> (f32, f32) {
        (self.h0_m, self.h0_m + self.h_step_m * (TABLE_HEIGHTS - 1) as f32)
    }

    /// Pressure in L that holds the offset `h_m` at gas temperature `t_k`, Pa.
    /// Arguments outside the table are clamped to its edges.
    pub fn pressure_pa(&self, h_m: f32, t_k: f32) -> f32 {
        let column = self.column(t_k);
        let at = GridPoint::locate(h_m, self.h0_m, self.h_step_m, TABLE_HEIGHTS);
        lerp(column.at(at.node), column.at(at.node + 1), at.weight)
    }

    /// The offset that L's pressure `p_pa` holds at gas temperature `t_k`,
    /// m: the inverse of [`LargeTable::pressure_pa`], clamped to the stroke.
    pub fn ride_height_m(&self, p_pa: f32, t_k: f32) -> f32 {
        let column = self.column(t_k);
        let (h_min, h_max) = self.height_range_m();
        // The pressure falls as the offset (L's gas volume) grows.
        let (mut lo, mut hi) = (0_usize, TABLE_HEIGHTS - 1);
        let (p_lo, p_hi) = (column.at(lo), column.at(hi));
        if p_pa >= p_lo || p_pa.is_nan() {
            return h_min;
        }
        if p_pa <= p_hi {
            return h_max;
        }
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if column.at(mid) >= p_pa {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (p_a, p_b) = (column.at(lo), column.at(hi));
        // p_a >= p_pa > p_b, and the table falls strictly, so p_a > p_b.
        let fraction = (p_a - p_pa) / (p_a - p_b);
        (self.h0_m + self.h_step_m * (lo as f32 + fraction)).clamp(h_min, h_max)
    }
}
