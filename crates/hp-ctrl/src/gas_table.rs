//! The gas in accumulator L: its pressure as a function of how much oil it
//! holds.
//!
//! With valve 6 closed, L holds a fixed mass of gas `m_L` (from the static
//! charge: `p_static`, `T_static`, `V_L0`) and whatever oil the sequencer
//! moved into it. The table measures L's gas volume as strut travel, the
//! *volume offset* `u = (V_L - V_L0) / A`: `u = -30 mm` means 30 mm of
//! strut travel worth of oil more in L than at the static charge. Its
//! pressure is `p_L(u, T) = p(m_L / (V_L0 + A u), T)` from the equation of
//! state.
//!
//! The ride-height sequencer ([`crate::ride_height`]) works with
//! differences of `u`: the reference `u_ref` is where L's gas sits at the
//! estimated load pressure (the soft-mode rest state), a request `h` is the
//! target `u_ref + h`, and the held offset is `u(p_L) - u_ref`.
//!
//! The step function must not solve the equation of state (a pressure of
//! the reference model costs thousands of instructions on the ECU), so
//! [`LargeTable::new`] tabulates `p_L` once, over the volume offsets of
//! the stroke widened by the largest request on both sides (so any
//! reference within the stroke plus any request is inside the table) and
//! the whole valid temperature range, on a grid of gas density (where the
//! pressure is nearly linear) and temperature, and the step interpolates
//! bilinearly in single precision: forwards for a target pressure, backwards (pressure to
//! volume offset) for the reference and the held offset. The same table
//! serves all three, so the held offset reaches the request exactly when
//! `p_L` reaches the target pressure.
//!
//! The table is built with the reference equation of state in single
//! precision ([`hp_core::gas::span::single`]): the ECU's FPU has no double
//! precision, and the double-precision model in software would not fit its
//! flash (it made the firmware 21 KiB larger). The other models are
//! evaluated as the core has them. Its error against the double-precision
//! model and the cost of a lookup are in docs/firmware.md.

use hp_core::gas::{span, Bwr, EquationOfState, Gas, IdealGas, BWR_COOPER_GOLDFRANK, BWR_TEXTBOOK};
use hp_core::presets;

use crate::config::{check, check_below, ParamError};

/// The spring-damper unit as the controller sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitConfig {
    /// Strut piston area, m^2.
    pub piston_area_m2: f64,
    /// Gas volume of S at the nominal static position, m^3.
    pub small_acc_volume_m3: f64,
    /// Gas volume of L at the nominal static position, m^3.
    pub large_acc_volume_m3: f64,
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
            small_acc_volume_m3: unit.small_acc_volume_m3,
            large_acc_volume_m3: unit.large_acc_volume_m3,
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
        check("unit.small_acc_volume_m3", self.small_acc_volume_m3, 1.0e-6, 0.1)?;
        check("unit.large_acc_volume_m3", self.large_acc_volume_m3, 1.0e-6, 0.1)?;
        check("unit.static_pressure_pa", self.static_pressure_pa, 1.0e5, 1.2e8)?;
        check("unit.static_temperature_k", self.static_temperature_k, 200.0, 600.0)?;
        check("unit.stroke_compression_m", self.stroke_compression_m, 1.0e-3, 1.0)?;
        check("unit.stroke_extension_m", self.stroke_extension_m, 1.0e-3, 1.0)?;
        // Compressing L's gas by the whole stroke must leave gas in L (the
        // table's widening by the largest request is checked with it).
        check_below(
            "unit.piston_area_m2 * unit.stroke_compression_m",
            self.piston_area_m2 * self.stroke_compression_m,
            "unit.large_acc_volume_m3",
            self.large_acc_volume_m3,
        )
    }
}

/// Temperature nodes of the table.
pub const TABLE_TEMPERATURES: usize = 16;
/// Density nodes of the table.
pub const TABLE_DENSITIES: usize = 21;

/// `p_L` on a regular grid of gas density and temperature, Pa.
///
/// The grid is in density, not volume: the pressure of a gas is nearly
/// linear in its density (exactly, bilinear in density and temperature,
/// for an ideal gas), so bilinear interpolation leaves only the real-gas
/// curvature as error. Volume offsets convert to densities through the
/// fixed gas mass, `rho = m_L / (V_L0 + A u)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LargeTable {
    /// `p_pa[i][j]` at temperature node `i`, density node `j`.
    pub(crate) p_pa: [[f32; TABLE_DENSITIES]; TABLE_TEMPERATURES],
    pub(crate) t0_k: f32,
    pub(crate) t_step_k: f32,
    pub(crate) rho0_kg_m3: f32,
    pub(crate) rho_step_kg_m3: f32,
    /// Gas mass, volume at the static charge and piston area, for the
    /// conversion between volume offsets and densities.
    pub(crate) mass_kg: f32,
    pub(crate) v0_m3: f32,
    pub(crate) area_m2: f32,
    /// The tabulated volume offsets, m.
    pub(crate) u_range_m: (f32, f32),
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
        // Through u32: the same node (0 <= k <= nodes - 1), and on x86-64
        // one conversion instruction instead of the dozen f32 -> u64 takes
        // (the firmware's usize is u32 already).
        let node = (k as u32 as usize).min(nodes - 2);
        GridPoint { node, weight: k - node as f32 }
    }
}

fn lerp(a: f32, b: f32, w: f32) -> f32 {
    a + w * (b - a)
}

/// `p_L` over the density nodes at one temperature.
struct Column<'a> {
    lo: &'a [f32; TABLE_DENSITIES],
    hi: &'a [f32; TABLE_DENSITIES],
    weight: f32,
}

impl Column<'_> {
    fn at(&self, j: usize) -> f32 {
        // Callers pass j < TABLE_DENSITIES; the fallback is never taken.
        match (self.lo.get(j), self.hi.get(j)) {
            (Some(&a), Some(&b)) => lerp(a, b, self.weight),
            _ => 0.0,
        }
    }

    /// The interval `j` with `p(j) <= p_pa < p(j + 1)`, for `p_first =
    /// p(0) < p_pa < p_last = p(last)`: exactly the one a bisection finds
    /// (the column rises strictly; a unit test compares the two), walked to
    /// from where the pressure would put it if it were linear in the
    /// density. The real gas's curvature leaves that guess a few nodes off
    /// at most, so the walk reads fewer nodes than a bisection of the 20
    /// intervals (measured on the 8x8's controllers: 145 instead of 176
    /// instructions per lookup; cachegrind's model counts fewer
    /// mispredictions too, 881 against 1,009 per simulated second).
    #[cfg(test)]
    fn interval(&self, p_pa: f32, p_first: f32, p_last: f32) -> usize {
        self.walk(p_pa, Column::guess(p_pa, p_first, p_last))
    }

    /// Where the walk of [`Column::interval`] starts.
    fn guess(p_pa: f32, p_first: f32, p_last: f32) -> usize {
        let last = TABLE_DENSITIES - 1;
        let guess = (p_pa - p_first) / (p_last - p_first) * last as f32;
        // 0 < guess < last for a p_pa inside; through u32 as in
        // `GridPoint::locate`, and a NaN guess is node 0.
        (guess as u32 as usize).min(last - 1)
    }

    /// The same interval as [`Column::interval`], walked to from the
    /// interval `start` (any: the column rises strictly, so the walk ends
    /// on the one interval holding `p_pa` wherever it starts; a unit test
    /// checks every start against a bisection).
    #[cfg(test)]
    fn walk(&self, p_pa: f32, start: usize) -> usize {
        self.walk_to(p_pa, start).0
    }

    /// [`Column::walk`] with the pressures at the interval's ends, which
    /// the walk has read on its way (`(j, p(j), p(j + 1))`).
    fn walk_to(&self, p_pa: f32, start: usize) -> (usize, f32, f32) {
        let last = TABLE_DENSITIES - 1;
        let mut j = start.min(last - 1);
        let mut p_j = self.at(j);
        while j > 0 && p_j > p_pa {
            j -= 1;
            p_j = self.at(j);
        }
        let mut p_next = self.at(j + 1);
        while j + 1 < last && p_next <= p_pa {
            j += 1;
            p_j = p_next;
            p_next = self.at(j + 1);
        }
        (j, p_j, p_next)
    }
}

/// Pressure of `gas` at `rho_kg_m3` and `t_k`, Pa, as the table is built
/// from it (each model by name, so that a firmware links only what it
/// evaluates: the reference model in single precision).
fn table_pressure_pa(gas: Gas, rho_kg_m3: f64, t_k: f64) -> f64 {
    match gas {
        Gas::Span => f64::from(span::single::pressure_and_slope(rho_kg_m3 as f32, t_k as f32).0),
        Gas::Ideal => IdealGas.pressure_pa(rho_kg_m3, t_k),
        Gas::BwrCooperGoldfrank => Bwr { constants: BWR_COOPER_GOLDFRANK }.pressure_pa(rho_kg_m3, t_k),
        Gas::BwrTextbook => Bwr { constants: BWR_TEXTBOOK }.pressure_pa(rho_kg_m3, t_k),
    }
}

/// Density of `gas` at `p_pa` and `t_k`, kg/m^3 (see [`table_pressure_pa`]).
fn table_density_kg_m3(gas: Gas, p_pa: f64, t_k: f64) -> hp_core::Result<f64> {
    let fail = hp_core::Error::NoConvergence { what: "density from pressure and temperature", target: p_pa };
    match gas {
        Gas::Span => span::single::density_kg_m3(p_pa as f32, t_k as f32).map(f64::from).ok_or(fail),
        Gas::Ideal => IdealGas.density_kg_m3(p_pa, t_k),
        Gas::BwrCooperGoldfrank => Bwr { constants: BWR_COOPER_GOLDFRANK }.density_kg_m3(p_pa, t_k),
        Gas::BwrTextbook => Bwr { constants: BWR_TEXTBOOK }.density_kg_m3(p_pa, t_k),
    }
}

impl LargeTable {
    /// Tabulates `p_L` for volume offsets over the stroke widened by
    /// `margin_m` on both sides (the largest ride-height request) and
    /// temperatures over `[t_min_k, t_max_k]`.
    pub fn new(unit: &UnitConfig, t_min_k: f64, t_max_k: f64, margin_m: f64) -> Result<Self, ParamError> {
        let gas = unit.gas;
        let rho_static =
            table_density_kg_m3(gas, unit.static_pressure_pa, unit.static_temperature_k).map_err(ParamError::Gas)?;
        let mass_kg = rho_static * unit.large_acc_volume_m3;
        let u_range_m = (-(unit.stroke_compression_m + margin_m), unit.stroke_extension_m + margin_m);
        let volume_m3 = |u_m: f64| unit.large_acc_volume_m3 + unit.piston_area_m2 * u_m;
        let rho0 = mass_kg / volume_m3(u_range_m.1);
        let rho_step = (mass_kg / volume_m3(u_range_m.0) - rho0) / (TABLE_DENSITIES - 1) as f64;
        let t_step_k = (t_max_k - t_min_k) / (TABLE_TEMPERATURES - 1) as f64;
        let mut p_pa = [[0.0_f32; TABLE_DENSITIES]; TABLE_TEMPERATURES];
        for (i, row) in p_pa.iter_mut().enumerate() {
            let t_k = t_min_k + t_step_k * i as f64;
            let mut previous = 0.0_f32;
            for (j, cell) in row.iter_mut().enumerate() {
                let rho = rho0 + rho_step * j as f64;
                let p = table_pressure_pa(gas, rho, t_k);
                let p32 = p as f32;
                let usable = rho.is_finite()
                    && rho > 0.0
                    && p.is_finite()
                    && p > hp_core::gas::PRESSURE_RANGE_PA.0
                    && p < hp_core::gas::PRESSURE_RANGE_PA.1
                    && p32 > previous;
                if !usable {
                    let volume_offset_m = (mass_kg / rho - unit.large_acc_volume_m3) / unit.piston_area_m2;
                    return Err(ParamError::GasTable { t_k, volume_offset_m, p_pa: p });
                }
                *cell = p32;
                previous = p32;
            }
        }
        Ok(LargeTable {
            p_pa,
            t0_k: t_min_k as f32,
            t_step_k: t_step_k as f32,
            rho0_kg_m3: rho0 as f32,
            rho_step_kg_m3: rho_step as f32,
            mass_kg: mass_kg as f32,
            v0_m3: unit.large_acc_volume_m3 as f32,
            area_m2: unit.piston_area_m2 as f32,
            u_range_m: (u_range_m.0 as f32, u_range_m.1 as f32),
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

    /// The table at one gas temperature `t_k`, for several lookups at it:
    /// the controller makes three per period at the same temperature, and
    /// locating the temperature and the column's ends once serves them all
    /// (each lookup gives exactly what [`LargeTable::pressure_pa`] and
    /// [`LargeTable::offset_m`] give).
    pub fn isotherm(&self, t_k: f32) -> Isotherm<'_> {
        let column = self.column(t_k);
        let ends_pa = (column.at(0), column.at(TABLE_DENSITIES - 1));
        Isotherm { table: self, column, ends_pa }
    }

    /// Smallest and largest tabulated volume offset, m.
    pub fn offset_range_m(&self) -> (f32, f32) {
        self.u_range_m
    }

    /// Pressure of L's gas at the volume offset `u_m` and gas temperature
    /// `t_k`, Pa. Arguments outside the table are clamped to its edges.
    pub fn pressure_pa(&self, u_m: f32, t_k: f32) -> f32 {
        // Not through `isotherm`: a single forward lookup needs no column ends.
        self.pressure_in_pa(&self.column(t_k), u_m)
    }

    /// [`LargeTable::pressure_pa`] in the column at the temperature.
    fn pressure_in_pa(&self, column: &Column<'_>, u_m: f32) -> f32 {
        let (u_min, u_max) = self.u_range_m;
        // `max` first: a NaN offset becomes the table's edge.
        let u_m = u_m.max(u_min).min(u_max);
        let rho = self.mass_kg / (self.v0_m3 + self.area_m2 * u_m);
        let at = GridPoint::locate(rho, self.rho0_kg_m3, self.rho_step_kg_m3, TABLE_DENSITIES);
        lerp(column.at(at.node), column.at(at.node + 1), at.weight)
    }

    /// The volume offset at which L's gas has the pressure `p_pa` at gas
    /// temperature `t_k`, m: the inverse of [`LargeTable::pressure_pa`],
    /// clamped to the table.
    pub fn offset_m(&self, p_pa: f32, t_k: f32) -> f32 {
        self.isotherm(t_k).offset_m(p_pa)
    }
}

/// [`LargeTable`] at one gas temperature ([`LargeTable::isotherm`]).
pub struct Isotherm<'a> {
    table: &'a LargeTable,
    column: Column<'a>,
    /// The pressures at the first and the last density node, Pa.
    ends_pa: (f32, f32),
}

impl Isotherm<'_> {
    /// [`LargeTable::pressure_pa`] at this temperature.
    pub fn pressure_pa(&self, u_m: f32) -> f32 {
        self.table.pressure_in_pa(&self.column, u_m)
    }

    /// [`LargeTable::offset_m`] at this temperature.
    pub fn offset_m(&self, p_pa: f32) -> f32 {
        let (p_first, p_last) = self.ends_pa;
        // Below TABLE_DENSITIES, far below u8::MAX.
        let mut near = Column::guess(p_pa, p_first, p_last) as u8;
        self.offset_near_m(p_pa, &mut near)
    }

    /// [`Isotherm::offset_m`] (the same value) with the table's interval
    /// walked to from `*near`, the interval of an earlier lookup, which is
    /// then set to this one's (left as it was for a pressure outside the
    /// table). A controller's pressures move by a fraction of an interval
    /// per period, so the walk nearly always stops at once: the linear
    /// guess [`Isotherm::offset_m`] starts from costs a division and lands
    /// a few intervals off (the walk's branches then mispredict), on the
    /// period's longest chain of dependent operations (the gas table
    /// lookups were 14 % of the semi-active 8x8's time by `perf`).
    pub fn offset_near_m(&self, p_pa: f32, near: &mut u8) -> f32 {
        let table = self.table;
        let (u_min, u_max) = table.u_range_m;
        // The pressure rises with the density.
        let (p_first, p_last) = self.ends_pa;
        if p_pa <= p_first || p_pa.is_nan() {
            return u_max;
        }
        if p_pa >= p_last {
            return u_min;
        }
        let (lo, p_a, p_b) = self.column.walk_to(p_pa, usize::from(*near));
        // lo < TABLE_DENSITIES, far below u8::MAX.
        *near = lo as u8;
        // p_a <= p_pa < p_b, and the table rises strictly, so p_b > p_a.
        let fraction = (p_pa - p_a) / (p_b - p_a);
        let rho = table.rho0_kg_m3 + table.rho_step_kg_m3 * (lo as f32 + fraction);
        // max/min rather than clamp, which keeps a panic path.
        ((table.mass_kg / rho - table.v0_m3) / table.area_m2).max(u_min).min(u_max)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// The interval by bisection, the search `Column::interval` replaced.
    fn bisection(column: &Column<'_>, p_pa: f32) -> usize {
        let (mut lo, mut hi) = (0, TABLE_DENSITIES - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if column.at(mid) <= p_pa {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    #[test]
    fn a_lookup_from_an_earlier_interval_gives_the_same_offset() {
        let params = crate::Params::seed_unit().unwrap();
        let table = params.large_table();
        let m = params.config().monitor;
        let mut checked = 0;
        for ti in 0..=37 {
            let t_k = (m.temperature_min_k + (m.temperature_max_k - m.temperature_min_k) * f64::from(ti) / 37.0) as f32;
            let isotherm = table.isotherm(t_k);
            let (first_pa, last_pa) = isotherm.ends_pa;
            let mut pressures: Vec<f32> = (-10..1010).map(|k| first_pa + (last_pa - first_pa) * k as f32 / 1000.0).collect();
            pressures.extend([f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -1.0, first_pa, last_pa]);
            for (k, &p_pa) in pressures.iter().enumerate() {
                let expected = table.offset_m(p_pa, t_k);
                assert_eq!(isotherm.offset_m(p_pa).to_bits(), expected.to_bits());
                for start in [0_u8, 1, 9, 19, 20, 21, 200, (k % 23) as u8] {
                    let mut near = start;
                    let u_m = isotherm.offset_near_m(p_pa, &mut near);
                    assert_eq!(u_m.to_bits(), expected.to_bits(), "t {t_k} K, p {p_pa} Pa, from {start}");
                    // Kept when the pressure is outside the table.
                    assert!(near == start || usize::from(near) < TABLE_DENSITIES - 1);
                    checked += 1;
                }
            }
        }
        assert!(checked > 300_000, "{checked}");
    }

    #[test]
    fn the_walk_finds_the_interval_a_bisection_finds() {
        let params = crate::Params::seed_unit().unwrap();
        let table = params.large_table();
        let m = params.config().monitor;
        let mut checked = 0;
        for ti in 0..=97 {
            let t_k = (m.temperature_min_k + (m.temperature_max_k - m.temperature_min_k) * f64::from(ti) / 97.0) as f32;
            let column = table.column(t_k);
            let last = TABLE_DENSITIES - 1;
            let (first_pa, last_pa) = (column.at(0), column.at(last));
            // Every node, its neighbouring floats, and a dense sweep.
            let mut pressures: Vec<f32> = (0..=last)
                .flat_map(|j| {
                    let p = column.at(j);
                    [f32::from_bits(p.to_bits() - 1), p, f32::from_bits(p.to_bits() + 1)]
                })
                .collect();
            pressures.extend((1..2000).map(|k| first_pa + (last_pa - first_pa) * k as f32 / 2000.0));
            for p_pa in pressures.into_iter().filter(|&p| p > first_pa && p < last_pa) {
                let j = column.interval(p_pa, first_pa, last_pa);
                assert_eq!(j, bisection(&column, p_pa), "t {t_k} K, p {p_pa} Pa");
                for start in (0..=last + 1).step_by(if checked % 16 == 0 { 1 } else { 7 }) {
                    let (walked, p_j, p_next) = column.walk_to(p_pa, start);
                    assert_eq!(walked, j, "t {t_k} K, p {p_pa} Pa, from {start}");
                    assert_eq!((p_j.to_bits(), p_next.to_bits()), (column.at(j).to_bits(), column.at(j + 1).to_bits()));
                }
                assert!(column.at(j) <= p_pa && p_pa < column.at(j + 1));
                checked += 1;
            }
        }
        assert!(checked > 190_000, "{checked}");
    }
}
