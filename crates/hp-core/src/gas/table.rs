//! A tabulated equation of state: bicubic Hermite interpolation of the
//! pressure and `c_v` on a uniform (density, temperature) grid, with the
//! exact equation outside the grid.
//!
//! The reference equation ([`super::span`]) costs about eighteen `exp` per
//! state; a host model that evaluates many units at a fixed step (the
//! 8x8 vehicle: 64 gas states per 1 ms period) spends most of its time
//! there. The table replaces it inside its grid by a few dozen
//! multiply-adds on one cell:
//!
//! - at each node the pressure and `c_v` with their first derivatives and
//!   the mixed second derivative (`f, f_rho, f_T, f_rhoT`) define a bicubic
//!   Hermite polynomial per cell (the pressure derivatives are the
//!   equation's own, the others central differences of them), so the
//!   interpolant is C1 and reproduces cubic polynomials; each cell stores
//!   its polynomials' 2 x 16 coefficients, so an evaluation is Horner's
//!   rule on one cell (about 60 multiply-adds);
//! - `(dp/drho)_T` and `(dp/dT)_rho` are the derivatives of the pressure
//!   interpolant (so the density solve and the energy equation see one
//!   consistent surface);
//! - outside the grid (and for NaN) the wrapped equation is evaluated
//!   directly, so the table never limits where the model can go.
//!
//! Its error against the direct evaluation, over the unit's validated
//! envelope, is measured by `tests/gas_table.rs` (on [`SPAN_GRID`] at most
//! 1.3e-8 relative in pressure, 7.2e-7 in `(dp/drho)_T`, 3.1e-7 in
//! `(dp/dT)_rho`, 5e-8 in `c_v`): far below the 0.01 % the reference gas is
//! trusted to.
//!
//! `no_std` and no allocator: the caller owns the cell storage
//! ([`TableCell`] slices of [`TableGrid::len`]) and fills it once with
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
    /// Number of cells (the length of the storage [`fill`] needs).
    pub const fn len(&self) -> usize {
        self.rho_count.saturating_sub(1) * self.t_count.saturating_sub(1)
    }

    /// True for a grid without cells.
    pub const fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Density and temperature of node `(i, j)`.
    fn node(&self, i: usize, j: usize) -> (f64, f64) {
        (self.rho_min_kg_m3 + i as f64 * self.rho_step_kg_m3, self.t_min_k + j as f64 * self.t_step_k)
    }
}

/// Most density nodes a grid can have (the fill keeps two rows of nodes on
/// the stack).
pub const MAX_RHO_COUNT: usize = 512;

/// The grid for nitrogen in the unit: 2-802 kg/m^3 (about 0.17 MPa up to
/// beyond 300 MPa at 233 K) and 200-600 K, 8 kg/m^3 and 8 K apart:
/// 101 x 51 nodes, 5,000 cells of 256 bytes (1.3 MB, so that it stays in
/// a core's cache; halving the spacing would divide the error by 16 and
/// cost four times the memory).
pub const SPAN_GRID: TableGrid =
    TableGrid { rho_min_kg_m3: 2.0, rho_step_kg_m3: 8.0, rho_count: 101, t_min_k: 200.0, t_step_k: 8.0, t_count: 51 };

/// One node: pressure and `c_v`, each as value, density derivative,
/// temperature derivative and mixed derivative (SI).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct TableNode {
    p: [f64; 4],
    cv: [f64; 4],
}

/// One cell: the bicubic polynomials of the pressure and `c_v` in the
/// cell's local coordinates `s, r` in [0, 1) (density, temperature),
/// coefficient of `s^i r^j` at `4 i + j`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableCell {
    pub p: [f64; 16],
    pub cv: [f64; 16],
}

impl Default for TableCell {
    fn default() -> Self {
        TableCell { p: [0.0; 16], cv: [0.0; 16] }
    }
}

/// The node data of `gas` at `(rho, t)`.
fn node(gas: &impl EquationOfState, rho: f64, t: f64) -> TableNode {
    // Central differences of the exact first derivatives: steps small
    // against the grid (truncation ~ (step / scale)^2 ~ 1e-10) and large
    // against rounding (~ 1e-16 / 1e-5).
    let (dr, dt) = (1e-5 * rho, 1e-5 * t);
    let c = gas.props(rho, t);
    let (r_hi, r_lo) = (gas.props(rho + dr, t), gas.props(rho - dr, t));
    let (t_hi, t_lo) = (gas.props(rho, t + dt), gas.props(rho, t - dt));
    let (hh, hl, lh, ll) = (gas.props(rho + dr, t + dt), gas.props(rho + dr, t - dt), gas.props(rho - dr, t + dt), gas.props(rho - dr, t - dt));
    let p_rt = (t_hi.dp_drho_pa_m3_per_kg - t_lo.dp_drho_pa_m3_per_kg) / (2.0 * dt);
    let cv_r = (r_hi.cv_j_per_kg_k - r_lo.cv_j_per_kg_k) / (2.0 * dr);
    let cv_t = (t_hi.cv_j_per_kg_k - t_lo.cv_j_per_kg_k) / (2.0 * dt);
    let cv_rt = (hh.cv_j_per_kg_k - hl.cv_j_per_kg_k - lh.cv_j_per_kg_k + ll.cv_j_per_kg_k) / (4.0 * dr * dt);
    TableNode { p: [c.p_pa, c.dp_drho_pa_m3_per_kg, c.dp_dt_pa_per_k, p_rt], cv: [c.cv_j_per_kg_k, cv_r, cv_t, cv_rt] }
}

/// The bicubic Hermite polynomial's coefficients from the four corners'
/// `[f, f_rho, f_T, f_rhoT]` (spacings `hr`, `ht`): `A = M F M^T` with `F`
/// the corner data in local units and `M` the cubic Hermite matrix.
fn bicubic(c00: [f64; 4], c10: [f64; 4], c01: [f64; 4], c11: [f64; 4], hr: f64, ht: f64) -> [f64; 16] {
    let local = |[f, fr, ft, frt]: [f64; 4]| (f, fr * hr, ft * ht, frt * hr * ht);
    let (f00, r00, t00, rt00) = local(c00);
    let (f10, r10, t10, rt10) = local(c10);
    let (f01, r01, t01, rt01) = local(c01);
    let (f11, r11, t11, rt11) = local(c11);
    let f = [[f00, f01, t00, t01], [f10, f11, t10, t11], [r00, r01, rt00, rt01], [r10, r11, rt10, rt11]];
    const M: [[f64; 4]; 4] = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [-3.0, 3.0, -2.0, -1.0], [2.0, -2.0, 1.0, 1.0]];
    let mut mf = [[0.0; 4]; 4];
    for (row, m) in mf.iter_mut().zip(&M) {
        for (k, out) in row.iter_mut().enumerate() {
            *out = m.iter().zip(&f).map(|(a, fr)| a * fr.get(k).copied().unwrap_or(0.0)).sum();
        }
    }
    let mut a = [0.0; 16];
    for (i, row) in mf.iter().enumerate() {
        for (j, m) in M.iter().enumerate() {
            if let Some(out) = a.get_mut(4 * i + j) {
                *out = row.iter().zip(m).map(|(x, y)| x * y).sum();
            }
        }
    }
    a
}

/// Fills `cells` (cell `(i, j)` at `i + j * (rho_count - 1)`) from `gas`.
/// Fails when the storage has the wrong length, the grid is degenerate or
/// too wide ([`MAX_RHO_COUNT`]), or a node is not finite.
pub fn fill(grid: &TableGrid, gas: &impl EquationOfState, cells: &mut [TableCell]) -> Result<()> {
    if cells.len() != grid.len() || grid.rho_count < 2 || grid.t_count < 2 || grid.rho_count > MAX_RHO_COUNT {
        return Err(Error::OutOfRange { name: "table_cells", value: cells.len() as f64, min: grid.len() as f64, max: grid.len() as f64 });
    }
    if !(grid.rho_min_kg_m3 > 0.0 && grid.rho_step_kg_m3 > 0.0 && grid.t_min_k > 0.0 && grid.t_step_k > 0.0) {
        return Err(Error::OutOfRange { name: "table_grid", value: grid.rho_step_kg_m3, min: 0.0, max: f64::INFINITY });
    }
    let (hr, ht) = (grid.rho_step_kg_m3, grid.t_step_k);
    let row = |j: usize, out: &mut [TableNode; MAX_RHO_COUNT]| -> Result<()> {
        for (i, n) in out.iter_mut().take(grid.rho_count).enumerate() {
            let (rho, t) = grid.node(i, j);
            *n = node(gas, rho, t);
            if !n.p.iter().chain(&n.cv).all(|x| x.is_finite()) {
                return Err(Error::NoConvergence { what: "gas table node", target: rho });
            }
        }
        Ok(())
    };
    let mut below = [TableNode::default(); MAX_RHO_COUNT];
    let mut above = [TableNode::default(); MAX_RHO_COUNT];
    row(0, &mut below)?;
    for (j, cell_row) in cells.chunks_exact_mut(grid.rho_count - 1).enumerate() {
        row(j + 1, &mut above)?;
        for ((cell, lo), hi) in cell_row.iter_mut().zip(below.windows(2)).zip(above.windows(2)) {
            let (Some([n00, n10]), Some([n01, n11])) = (lo.first_chunk::<2>(), hi.first_chunk::<2>()) else { continue };
            *cell = TableCell { p: bicubic(n00.p, n10.p, n01.p, n11.p, hr, ht), cv: bicubic(n00.cv, n10.cv, n01.cv, n11.cv, hr, ht) };
        }
        core::mem::swap(&mut below, &mut above);
    }
    Ok(())
}

/// `gas` tabulated on `grid` in `cells` (filled by [`fill`] from the same
/// gas), evaluated directly outside the grid.
#[derive(Clone, Copy)]
pub struct TabulatedGas<'a, E> {
    pub grid: TableGrid,
    pub cells: &'a [TableCell],
    pub direct: E,
}

impl<E: core::fmt::Debug> core::fmt::Debug for TabulatedGas<'_, E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TabulatedGas").field("grid", &self.grid).field("cells", &self.cells.len()).field("direct", &self.direct).finish()
    }
}

impl<E: PartialEq> PartialEq for TabulatedGas<'_, E> {
    /// Same grid, same gas and the same storage.
    fn eq(&self, other: &Self) -> bool {
        self.grid == other.grid && self.direct == other.direct && core::ptr::eq(self.cells, other.cells)
    }
}

// The polynomials are evaluated by Estrin's scheme, `(c0 + c1 x) + x^2 (c2
// + c3 x)`, not Horner's rule: two dependent multiply-adds per cubic
// instead of three. Every gas state of a vehicle's step waits on this
// chain (measured: a quarter of the 8x8's time in the table), and the
// rounding differs from Horner's by an ulp or so.

/// `sum_j b_j r^j` and its derivative in `r`, for `b = [b0, b1, b2, b3]`.
#[inline(always)]
fn cubic(b: [f64; 4], r: f64) -> (f64, f64) {
    let [b0, b1, b2, b3] = b;
    let r2 = r * r;
    ((b0 + b1 * r) + r2 * (b2 + b3 * r), (b1 + 2.0 * b2 * r) + r2 * (3.0 * b3))
}

/// The coefficients' rows `a[4 i .. 4 i + 4]` (the `s^i` terms of the four
/// powers of `r`), so that the polynomials in `s` run on all four `r`
/// powers at once.
#[inline(always)]
fn rows(a: &[f64; 16]) -> [[f64; 4]; 4] {
    let [a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, a30, a31, a32, a33] = *a;
    [[a00, a01, a02, a03], [a10, a11, a12, a13], [a20, a21, a22, a23], [a30, a31, a32, a33]]
}

/// The four cubics in `s` whose coefficients are the rows' columns.
#[inline(always)]
fn in_s(a: &[f64; 16], s: f64) -> [f64; 4] {
    let [a0, a1, a2, a3] = rows(a);
    let s2 = s * s;
    let mut b = [0.0; 4];
    for ((((o, c0), c1), c2), c3) in b.iter_mut().zip(a0).zip(a1).zip(a2).zip(a3) {
        *o = (c0 + c1 * s) + s2 * (c2 + c3 * s);
    }
    b
}

/// `sum_ij a_ij s^i r^j` for the coefficients `a` of a cell (the unit
/// test's reference for [`all_in_cell`]).
#[cfg(test)]
fn value(a: &[f64; 16], s: f64, r: f64) -> f64 {
    cubic(in_s(a, s), r).0
}

/// The value and its derivatives in `s` and `r`.
#[inline(always)]
fn value_and_slopes(a: &[f64; 16], s: f64, r: f64) -> (f64, f64, f64) {
    let [_, a1, a2, a3] = rows(a);
    let s2 = s * s;
    // d/ds of each cubic in s: a1 + 2 a2 s + 3 a3 s^2.
    let mut d = [0.0; 4];
    for (((o, c1), c2), c3) in d.iter_mut().zip(a1).zip(a2).zip(a3) {
        *o = (c1 + 2.0 * c2 * s) + s2 * (3.0 * c3);
    }
    let (f, f_r) = cubic(in_s(a, s), r);
    let (f_s, _) = cubic(d, r);
    (f, f_s, f_r)
}

/// Two lanes of f64: an SSE2 register on x86-64, a plain pair elsewhere
/// (the firmware's targets). Every lane's operation is the scalar one, so
/// both give the scalar results to the bit. The compiler does not pair the
/// plain form's lanes by itself (measured: it stays scalar), hence the
/// intrinsics.
///
/// The crate's `unsafe` (with `damper`'s square root): the SSE2 intrinsics are `unsafe fn`s because
/// they need the CPU feature; this module is compiled only where the build
/// enables `sse2` (`cfg(target_feature)`, on in every x86-64 target's
/// baseline), and none of them touches memory, so every call is sound.
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod lanes {
    use core::arch::x86_64::{
        __m128d, _mm_add_pd, _mm_cvtsd_f64, _mm_mul_pd, _mm_set1_pd, _mm_set_pd, _mm_unpackhi_pd, _mm_unpacklo_pd,
    };

    pub type Pair = __m128d;

    #[inline(always)]
    pub fn pair(lo: f64, hi: f64) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_set_pd(hi, lo) }
    }
    #[inline(always)]
    pub fn splat(x: f64) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_set1_pd(x) }
    }
    #[inline(always)]
    pub fn add(a: Pair, b: Pair) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_add_pd(a, b) }
    }
    #[inline(always)]
    pub fn mul(a: Pair, b: Pair) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_mul_pd(a, b) }
    }
    /// `[a_0, b_0]`.
    #[inline(always)]
    pub fn lows(a: Pair, b: Pair) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_unpacklo_pd(a, b) }
    }
    /// `[a_1, b_1]`.
    #[inline(always)]
    pub fn highs(a: Pair, b: Pair) -> Pair {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { _mm_unpackhi_pd(a, b) }
    }
    #[inline(always)]
    pub fn lanes(a: Pair) -> (f64, f64) {
        // SAFETY: sse2 is enabled (the module's cfg); no memory access.
        unsafe { (_mm_cvtsd_f64(a), _mm_cvtsd_f64(_mm_unpackhi_pd(a, a))) }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
mod lanes {
    pub type Pair = [f64; 2];

    #[inline(always)]
    pub fn pair(lo: f64, hi: f64) -> Pair {
        [lo, hi]
    }
    #[inline(always)]
    pub fn splat(x: f64) -> Pair {
        [x, x]
    }
    #[inline(always)]
    pub fn add([a0, a1]: Pair, [b0, b1]: Pair) -> Pair {
        [a0 + b0, a1 + b1]
    }
    #[inline(always)]
    pub fn mul([a0, a1]: Pair, [b0, b1]: Pair) -> Pair {
        [a0 * b0, a1 * b1]
    }
    #[inline(always)]
    pub fn lows([a0, _]: Pair, [b0, _]: Pair) -> Pair {
        [a0, b0]
    }
    #[inline(always)]
    pub fn highs([_, a1]: Pair, [_, b1]: Pair) -> Pair {
        [a1, b1]
    }
    #[inline(always)]
    pub fn lanes([a0, a1]: Pair) -> (f64, f64) {
        (a0, a1)
    }
}

/// The pressure, its derivatives in `s` and `r`, and `c_v` in one cell:
/// [`value_and_slopes`] of `p` and `value` of `c_v` with every operation
/// the same (so the same results to the bit; the unit test checks it),
/// arranged in pairs of lanes: the cubics in `s` two columns at a time,
/// the cubics in `r` as `[p, c_v]` and `[p_s, p_r]`. The compiler had
/// vectorised the separate forms only in part (on the 8x8, 32 evaluations
/// per period: about 140 instructions each against about 95).
#[inline(always)]
fn all_in_cell(c: &TableCell, s: f64, r: f64) -> (f64, f64, f64, f64) {
    use lanes::{add, highs, lanes, lows, mul, pair, splat, Pair};
    let (ss, s2) = (splat(s), splat(s * s));
    let [a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, a30, a31, a32, a33] = c.p;
    let [g00, g01, g02, g03, g10, g11, g12, g13, g20, g21, g22, g23, g30, g31, g32, g33] = c.cv;
    // Columns j, j + 1 of the cubics in s: (c0 + c1 s) + s^2 (c2 + c3 s),
    // and for p their derivatives (c1 + 2 c2 s) + s^2 (3 c3).
    let cubic_s = |c0: Pair, c1: Pair, c2: Pair, c3: Pair| add(add(c0, mul(c1, ss)), mul(s2, add(c2, mul(c3, ss))));
    let slope_s = |c1: Pair, c2: Pair, c3: Pair| add(add(c1, mul(mul(splat(2.0), c2), ss)), mul(s2, mul(splat(3.0), c3)));
    let (p1_lo, p2_lo, p3_lo) = (pair(a10, a11), pair(a20, a21), pair(a30, a31));
    let (p1_hi, p2_hi, p3_hi) = (pair(a12, a13), pair(a22, a23), pair(a32, a33));
    let b_lo = cubic_s(pair(a00, a01), p1_lo, p2_lo, p3_lo); // [b0, b1]
    let b_hi = cubic_s(pair(a02, a03), p1_hi, p2_hi, p3_hi); // [b2, b3]
    let d_lo = slope_s(p1_lo, p2_lo, p3_lo); // [d0, d1]
    let d_hi = slope_s(p1_hi, p2_hi, p3_hi); // [d2, d3]
    let e_lo = cubic_s(pair(g00, g01), pair(g10, g11), pair(g20, g21), pair(g30, g31));
    let e_hi = cubic_s(pair(g02, g03), pair(g12, g13), pair(g22, g23), pair(g32, g33));
    let (rr, r2) = (splat(r), splat(r * r));
    // [p, c_v] = (b0 + b1 r) + r^2 (b2 + b3 r) for b and e.
    let value = add(add(lows(b_lo, e_lo), mul(highs(b_lo, e_lo), rr)), mul(r2, add(lows(b_hi, e_hi), mul(highs(b_hi, e_hi), rr))));
    // [p_s, p_r] = [(d0 + d1 r) + r^2 (d2 + d3 r), (b1 + 2 b2 r) + r^2 (3 b3)].
    let ((d0, d1), (d2, d3), (_, b1), (b2, b3)) = (lanes(d_lo), lanes(d_hi), lanes(b_lo), lanes(b_hi));
    let slopes = add(add(pair(d0, b1), mul(pair(d1, 2.0 * b2), rr)), mul(r2, pair(d2 + d3 * r, 3.0 * b3)));
    let ((p, cv), (p_s, p_r)) = (lanes(value), lanes(slopes));
    (p, p_s, p_r, cv)
}

impl<E: EquationOfState> TabulatedGas<'_, E> {
    /// The cell containing `(rho, t)` and the local coordinates in it,
    /// None outside the grid.
    #[inline(always)]
    fn cell(&self, rho_kg_m3: f64, t_k: f64) -> Option<(&TableCell, f64, f64)> {
        let g = &self.grid;
        // Times the reciprocal: its division does not wait for the state,
        // so it leaves the chain every gas evaluation waits on.
        let x = (rho_kg_m3 - g.rho_min_kg_m3) * (1.0 / g.rho_step_kg_m3);
        let y = (t_k - g.t_min_k) * (1.0 / g.t_step_k);
        // NaN fails this test too.
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        // The cell's indices through i64, not usize: x86-64 converts
        // between f64 and i64 in one instruction each way, between f64 and
        // usize in about a dozen (two conversions each way per evaluation,
        // 32 evaluations per 8x8 period). For x >= 0 the truncation is the
        // floor, and (saturating) i < n - 1 exactly when x < n - 1, so the
        // cells and the local coordinates are those of the usize form.
        let (i, j) = (x as i64, y as i64);
        let (rho_cells, t_cells) = ((g.rho_count as i64).saturating_sub(1), (g.t_count as i64).saturating_sub(1));
        if i >= rho_cells || j >= t_cells {
            return None;
        }
        let cell = self.cells.get(usize::try_from(i + j * rho_cells).ok()?)?;
        Some((cell, x - i as f64, y - j as f64))
    }
}

impl<E: EquationOfState> EquationOfState for TabulatedGas<'_, E> {
    #[inline(always)]
    fn props(&self, rho_kg_m3: f64, t_k: f64) -> GasProps {
        match self.cell(rho_kg_m3, t_k) {
            Some((c, s, r)) => {
                let (p_pa, p_s, p_r, cv) = all_in_cell(c, s, r);
                GasProps {
                    p_pa,
                    dp_dt_pa_per_k: p_r * (1.0 / self.grid.t_step_k),
                    dp_drho_pa_m3_per_kg: p_s * (1.0 / self.grid.rho_step_kg_m3),
                    cv_j_per_kg_k: cv,
                }
            }
            None => self.direct.props(rho_kg_m3, t_k),
        }
    }

    #[inline]
    fn pressure_and_slope(&self, rho_kg_m3: f64, t_k: f64) -> (f64, f64) {
        match self.cell(rho_kg_m3, t_k) {
            Some((c, s, r)) => {
                let (p, p_s, _) = value_and_slopes(&c.p, s, r);
                (p, p_s * (1.0 / self.grid.rho_step_kg_m3))
            }
            None => self.direct.pressure_and_slope(rho_kg_m3, t_k),
        }
    }

    fn density_start_kg_m3(&self, p_pa: f64, t_k: f64) -> Option<f64> {
        self.direct.density_start_kg_m3(p_pa, t_k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paired form gives the separate forms' results to the bit, on
    /// cells of arbitrary coefficients (a fixed pseudo-random sequence) at
    /// points all over the cell and on its edges.
    #[test]
    fn all_in_cell_is_the_scalar_evaluation_to_the_bit() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..200 {
            let mut cell = TableCell::default();
            for (k, c) in cell.p.iter_mut().chain(cell.cv.iter_mut()).enumerate() {
                *c = (next() - 0.5) * 10f64.powi((k % 7) as i32 * 2 - 4);
            }
            for _ in 0..20 {
                let (s, r) = (next(), next());
                for (s, r) in [(s, r), (0.0, r), (s, 0.0), (0.0, 0.0)] {
                    let (p, p_s, p_r, cv) = all_in_cell(&cell, s, r);
                    let (p0, p_s0, p_r0) = value_and_slopes(&cell.p, s, r);
                    let cv0 = value(&cell.cv, s, r);
                    for (a, b) in [(p, p0), (p_s, p_s0), (p_r, p_r0), (cv, cv0)] {
                        assert_eq!(a.to_bits(), b.to_bits(), "s {s} r {r}: {a} against {b}");
                    }
                }
            }
        }
    }
}
