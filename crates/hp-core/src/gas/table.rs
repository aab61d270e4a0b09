//! A tabulated equation of state: bicubic Hermite interpolation of the
//! pressure and `c_v` on a uniform (density, temperature) grid, with the
//! exact equation outside the grid.
//!
//! The reference equation ([`super::span`]) costs about eighteen `exp` per
//! state; a host model that evaluates many units at a fixed step (the
//! 8x8 vehicle: 64 gas states per 1 ms period) spends most of its time
//! there. The table replaces it inside its grid by a few dozen
//! multiply-adds on four nodes:
//!
//! - each node holds the pressure and `c_v` with their first derivatives
//!   and the mixed second derivative (`f, f_rho, f_T, f_rhoT`): the pressure
//!   derivatives are the equation's own, the others central differences of
//!   them, so the interpolant is C1 and reproduces cubic polynomials;
//! - `(dp/drho)_T` and `(dp/dT)_rho` are the derivatives of the pressure
//!   interpolant (so the density solve and the energy equation see one
//!   consistent surface);
//! - outside the grid (and for NaN) the wrapped equation is evaluated
//!   directly, so the table never limits where the model can go.
//!
//! Its error against the direct evaluation, over the unit's validated
//! envelope, is measured by `tests/gas_table.rs` (on [`SPAN_GRID`] at most
//! 9.4e-10 relative in pressure, 9.3e-8 in `(dp/drho)_T`, 2.1e-8 in
//! `(dp/dT)_rho`, 4.5e-9 in `c_v`): far below the 0.01 % the reference gas is
//! trusted to.
//!
//! `no_std` and no allocator: the caller owns the node storage
//! ([`TableNode`] slices of [`TableGrid::len`]) and fills it once with
//! [`fill`]. Hand-written because the interpolation crates allocate or
//! interpolate one value without the derivatives this needs.

use super::{EquationOfState, GasProps};
use crate::error::{Error, Result};

/// A uniform grid in density and temperature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableGrid {
    /// First density node, kg/m^3.
    pub rho_min_kg_m3: f64,
    /// Density spacing, kg/m^3.
    pub rho_step_kg_m3: f64,
    /// Number of density nodes.
    pub rho_count: usize,
    /// First temperature node, K.
    pub t_min_k: f64,
    /// Temperature spacing, K.
    pub t_step_k: f64,
    /// Number of temperature nodes.
    pub t_count: usize,
}

impl TableGrid {
    /// Number of nodes (the length of the storage [`fill`] needs).
    pub const fn len(&self) -> usize {
        self.rho_count * self.t_count
    }

    /// True for a grid without nodes.
    pub const fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Density and temperature of node `(i, j)`.
    fn node(&self, i: usize, j: usize) -> (f64, f64) {
        (self.rho_min_kg_m3 + i as f64 * self.rho_step_kg_m3, self.t_min_k + j as f64 * self.t_step_k)
    }
}

/// The grid for nitrogen in the unit: 2-802 kg/m^3 (about 0.17 MPa up to
/// beyond 300 MPa at 233 K) and 200-600 K, 4 kg/m^3 and 4 K apart:
/// 201 x 101 nodes, 1.3 MB.
pub const SPAN_GRID: TableGrid =
    TableGrid { rho_min_kg_m3: 2.0, rho_step_kg_m3: 4.0, rho_count: 201, t_min_k: 200.0, t_step_k: 4.0, t_count: 101 };

/// One node: pressure and `c_v`, each as value, density derivative,
/// temperature derivative and mixed derivative (SI).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TableNode {
    pub p: [f64; 4],
    pub cv: [f64; 4],
}

/// Fills `nodes` (node `(i, j)` at `i + j * rho_count`) from `gas`.
/// Fails when the storage has the wrong length or a node is not finite.
pub fn fill(grid: &TableGrid, gas: &impl EquationOfState, nodes: &mut [TableNode]) -> Result<()> {
    if nodes.len() != grid.len() || grid.rho_count < 2 || grid.t_count < 2 {
        return Err(Error::OutOfRange { name: "table_nodes", value: nodes.len() as f64, min: grid.len() as f64, max: grid.len() as f64 });
    }
    if !(grid.rho_min_kg_m3 > 0.0 && grid.rho_step_kg_m3 > 0.0 && grid.t_min_k > 0.0 && grid.t_step_k > 0.0) {
        return Err(Error::OutOfRange { name: "table_grid", value: grid.rho_step_kg_m3, min: 0.0, max: f64::INFINITY });
    }
    // Central differences of the exact first derivatives: steps small
    // against the grid (truncation ~ (step / scale)^2 ~ 1e-10) and large
    // against rounding (~ 1e-16 / 1e-5).
    for (k, node) in nodes.iter_mut().enumerate() {
        let (rho, t) = grid.node(k % grid.rho_count, k / grid.rho_count);
        let (dr, dt) = (1e-5 * rho, 1e-5 * t);
        let c = gas.props(rho, t);
        let (r_hi, r_lo) = (gas.props(rho + dr, t), gas.props(rho - dr, t));
        let (t_hi, t_lo) = (gas.props(rho, t + dt), gas.props(rho, t - dt));
        let (rt_hh, rt_hl, rt_lh, rt_ll) =
            (gas.props(rho + dr, t + dt), gas.props(rho + dr, t - dt), gas.props(rho - dr, t + dt), gas.props(rho - dr, t - dt));
        let p_rt = (t_hi.dp_drho_pa_m3_per_kg - t_lo.dp_drho_pa_m3_per_kg) / (2.0 * dt);
        let cv_r = (r_hi.cv_j_per_kg_k - r_lo.cv_j_per_kg_k) / (2.0 * dr);
        let cv_t = (t_hi.cv_j_per_kg_k - t_lo.cv_j_per_kg_k) / (2.0 * dt);
        let cv_rt = (rt_hh.cv_j_per_kg_k - rt_hl.cv_j_per_kg_k - rt_lh.cv_j_per_kg_k + rt_ll.cv_j_per_kg_k) / (4.0 * dr * dt);
        *node = TableNode {
            p: [c.p_pa, c.dp_drho_pa_m3_per_kg, c.dp_dt_pa_per_k, p_rt],
            cv: [c.cv_j_per_kg_k, cv_r, cv_t, cv_rt],
        };
        if !node.p.iter().chain(&node.cv).all(|x| x.is_finite()) {
            return Err(Error::NoConvergence { what: "gas table node", target: rho });
        }
    }
    Ok(())
}

/// `gas` tabulated on `grid` in `nodes` (filled by [`fill`] from the same
/// gas), evaluated directly outside the grid.
#[derive(Clone, Copy)]
pub struct TabulatedGas<'a, E> {
    pub grid: TableGrid,
    pub nodes: &'a [TableNode],
    pub direct: E,
}

impl<E: core::fmt::Debug> core::fmt::Debug for TabulatedGas<'_, E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TabulatedGas").field("grid", &self.grid).field("nodes", &self.nodes.len()).field("direct", &self.direct).finish()
    }
}

impl<E: PartialEq> PartialEq for TabulatedGas<'_, E> {
    /// Same grid, same gas and the same storage.
    fn eq(&self, other: &Self) -> bool {
        self.grid == other.grid && self.direct == other.direct && core::ptr::eq(self.nodes, other.nodes)
    }
}

/// Cubic Hermite basis on [0, 1] with the tangent terms scaled by the
/// spacing `h`: weights of `(f0, f0', f1, f1')` for the value, and for the
/// derivative (already divided by `h`).
#[inline(always)]
fn hermite(s: f64, h: f64) -> ([f64; 4], [f64; 4]) {
    let s2 = s * s;
    let s3 = s2 * s;
    let value = [2.0 * s3 - 3.0 * s2 + 1.0, (s3 - 2.0 * s2 + s) * h, 3.0 * s2 - 2.0 * s3, (s3 - s2) * h];
    let inv_h = 1.0 / h;
    let slope = [(6.0 * s2 - 6.0 * s) * inv_h, 3.0 * s2 - 4.0 * s + 1.0, (6.0 * s - 6.0 * s2) * inv_h, 3.0 * s2 - 2.0 * s];
    (value, slope)
}

#[inline(always)]
fn dot(w: &[f64; 4], a: f64, b: f64, c: f64, d: f64) -> f64 {
    let [w0, w1, w2, w3] = *w;
    w0 * a + w1 * b + w2 * c + w3 * d
}

/// The four nodes of a cell and the weights in it.
struct Cell<'a> {
    n00: &'a TableNode,
    n10: &'a TableNode,
    n01: &'a TableNode,
    n11: &'a TableNode,
    wr: [f64; 4],
    dwr: [f64; 4],
    wt: [f64; 4],
    dwt: [f64; 4],
}

impl<E: EquationOfState> TabulatedGas<'_, E> {
    /// The cell containing `(rho, t)`, None outside the grid.
    #[inline(always)]
    fn cell(&self, rho_kg_m3: f64, t_k: f64) -> Option<Cell<'_>> {
        let g = &self.grid;
        let x = (rho_kg_m3 - g.rho_min_kg_m3) / g.rho_step_kg_m3;
        let y = (t_k - g.t_min_k) / g.t_step_k;
        // NaN fails these tests too.
        if !(x >= 0.0 && y >= 0.0 && x < (g.rho_count - 1) as f64 && y < (g.t_count - 1) as f64) {
            return None;
        }
        let (i, j) = (x as usize, y as usize);
        let k = i + j * g.rho_count;
        let row = self.nodes.get(k..k + 2)?;
        let next = self.nodes.get(k + g.rho_count..k + g.rho_count + 2)?;
        let ([n00, n10], [n01, n11]) = (row.first_chunk::<2>()?, next.first_chunk::<2>()?);
        let (wr, dwr) = hermite(x - i as f64, g.rho_step_kg_m3);
        let (wt, dwt) = hermite(y - j as f64, g.t_step_k);
        Some(Cell { n00, n10, n01, n11, wr, dwr, wt, dwt })
    }
}

impl Cell<'_> {
    /// Value and (when `slopes`) density and temperature derivatives of
    /// the quantity `q` picks from a node.
    #[inline(always)]
    fn interpolate(&self, q: impl Fn(&TableNode) -> [f64; 4]) -> (f64, f64, f64) {
        let ([f00, r00, t00, rt00], [f10, r10, t10, rt10]) = (q(self.n00), q(self.n10));
        let ([f01, r01, t01, rt01], [f11, r11, t11, rt11]) = (q(self.n01), q(self.n11));
        // Along density at both temperatures: the value and its T-derivative.
        let (g0, gt0) = (dot(&self.wr, f00, r00, f10, r10), dot(&self.wr, t00, rt00, t10, rt10));
        let (g1, gt1) = (dot(&self.wr, f01, r01, f11, r11), dot(&self.wr, t01, rt01, t11, rt11));
        let (dg0, dgt0) = (dot(&self.dwr, f00, r00, f10, r10), dot(&self.dwr, t00, rt00, t10, rt10));
        let (dg1, dgt1) = (dot(&self.dwr, f01, r01, f11, r11), dot(&self.dwr, t01, rt01, t11, rt11));
        (dot(&self.wt, g0, gt0, g1, gt1), dot(&self.wt, dg0, dgt0, dg1, dgt1), dot(&self.dwt, g0, gt0, g1, gt1))
    }

    #[inline(always)]
    fn value(&self, q: impl Fn(&TableNode) -> [f64; 4]) -> f64 {
        let ([f00, r00, t00, rt00], [f10, r10, t10, rt10]) = (q(self.n00), q(self.n10));
        let ([f01, r01, t01, rt01], [f11, r11, t11, rt11]) = (q(self.n01), q(self.n11));
        let (g0, gt0) = (dot(&self.wr, f00, r00, f10, r10), dot(&self.wr, t00, rt00, t10, rt10));
        let (g1, gt1) = (dot(&self.wr, f01, r01, f11, r11), dot(&self.wr, t01, rt01, t11, rt11));
        dot(&self.wt, g0, gt0, g1, gt1)
    }
}

impl<E: EquationOfState> EquationOfState for TabulatedGas<'_, E> {
    #[inline]
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        match self.cell(rho_kg_m3, t_k) {
            Some(c) => {
                let (p_pa, dp_drho_pa_m3_per_kg, dp_dt_pa_per_k) = c.interpolate(|n| n.p);
                GasProps { p_pa, dp_dt_pa_per_k, dp_drho_pa_m3_per_kg, cv_j_per_kg_k: c.value(|n| n.cv) }
            }
            None => self.direct.props(rho_kg_m3, t_k),
        }
    }

    #[inline]
    fn pressure_and_slope(&self, rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
        match self.cell(rho_kg_m3, t_k) {
            Some(c) => {
                let (p, p_rho, _) = c.interpolate(|n| n.p);
                (p, p_rho)
            }
            None => self.direct.pressure_and_slope(rho_kg_m3, t_k),
        }
    }

    fn density_start_kg_m3(&self, p_pa: f64, t_k: f64) -> Option<f64> {
        self.direct.density_start_kg_m3(p_pa, t_k)
    }
}
