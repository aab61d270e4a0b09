//! The linear algebra of the vehicle's ROS2 step ([`crate::vehicle::Stepping::Ros2`]):
//! `W = I - gamma h J` for the part of the Jacobian that sets the step's
//! accuracy at the control period, solved without allocation in O(corners).
//!
//! That part is, per corner, the gas volumes and temperatures of S and L
//! and the wheel (valve 6's exchange, the strut's gas spring and damper,
//! the tyre), and the body's heave, pitch and roll through the strut
//! forces. The wheel hop (a 400 kg wheel between the 1.2 MN/m tyre and the
//! strut: 8.7 Hz, lightly damped with the damper off) is what an explicit
//! step gets wrong at 1 ms; treating the corners alone implicitly (the body
//! explicit) leaves most of that error, because the body and the wheels
//! exchange the same strut forces. Everything else (the unit's other
//! states, the handling, the road's input) stays explicit: ROS2 is a
//! W-method, second order for any `W`.
//!
//! Solving `W x = r`: each corner's block is the identity less a rank-three
//! matrix (the Woodbury formula, a 3x3 inverse); the body's three
//! velocities couple the corners and are solved for first, by the Schur
//! complement (a 3x3 system).

use hp_core::unit::{Linearisation, UnitState};

use crate::vehicle::{CornerGeometry, BODY_STATES, CORNER_STATES, MAX_CORNERS, VEHICLE_STATES};

/// The states of a corner that the implicit part acts on: the gas
/// temperatures and volumes of S and L (the first four of the unit's state
/// array, [`unit_fast`]) and the wheel's displacement and velocity (the last
/// two of the corner's).
const FAST: usize = 6;
type Fast = [f64; FAST];
const UNIT_FAST: usize = 4;

/// A unit state's fast part, in the order of its state array.
fn unit_fast(s: &UnitState) -> [f64; UNIT_FAST] {
    [s.t_gas_k, s.t_gas2_k, s.v_gas_m3, s.v_gas2_m3]
}

/// The fast states of a corner's part of a state (or rate) array.
fn gather(cx: &[f64]) -> Fast {
    let [a, b, c, d] = cx.first_chunk::<UNIT_FAST>().copied().unwrap_or_default();
    let [z, v] = cx.last_chunk::<2>().copied().unwrap_or_default();
    [a, b, c, d, z, v]
}

fn scatter(cx: &mut [f64], x: &Fast) {
    let [a, b, c, d, z, v] = *x;
    if let Some(o) = cx.first_chunk_mut::<UNIT_FAST>() {
        *o = [a, b, c, d];
    }
    if let Some(o) = cx.last_chunk_mut::<2>() {
        *o = [z, v];
    }
}

fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `[u, 0, 0]`: a unit vector's fast part on a corner's fast states.
fn with_wheel(u: [f64; UNIT_FAST], z: f64, v: f64) -> Fast {
    let [a, b, c, d] = u;
    [a, b, c, d, z, v]
}

/// The inverse of a 3x3 matrix (None when singular or not finite).
fn inverse3(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let [[a00, a01, a02], [a10, a11, a12], [a20, a21, a22]] = *a;
    let c00 = a11 * a22 - a12 * a21;
    let c01 = a02 * a21 - a01 * a22;
    let c02 = a01 * a12 - a02 * a11;
    let det = a00 * c00 + a10 * c01 + a20 * c02;
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    let d = 1.0 / det;
    let inv = [
        [c00 * d, c01 * d, c02 * d],
        [(a12 * a20 - a10 * a22) * d, (a00 * a22 - a02 * a20) * d, (a02 * a10 - a00 * a12) * d],
        [(a10 * a21 - a11 * a20) * d, (a01 * a20 - a00 * a21) * d, (a00 * a11 - a01 * a10) * d],
    ];
    inv.iter().flatten().all(|x| x.is_finite()).then_some(inv)
}

fn mul3(a: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
    a.map(|row| dot(&row, x))
}

fn mul3_transposed(a: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
    let [[a00, a01, a02], [a10, a11, a12], [a20, a21, a22]] = *a;
    let [x0, x1, x2] = *x;
    [a00 * x0 + a10 * x1 + a20 * x2, a01 * x0 + a11 * x1 + a21 * x2, a02 * x0 + a12 * x1 + a22 * x2]
}

/// A corner's linearisation at one instant, on the fast states: what the
/// step's `W` needs from the evaluation at the step's start. Zero where a
/// part is absent (valve 6 closed, a cavitating strut, a tyre in the air):
/// that part is then explicit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CornerLinearisation {
    /// Valve 6: `d(fast unit rate)/d(q6)` and `d(q6)/d(fast unit state)`.
    valve6_rate: [f64; UNIT_FAST],
    valve6_flow: [f64; UNIT_FAST],
    /// `d(strut force)/d(fast unit state)`.
    force_per_state: [f64; UNIT_FAST],
    /// `d(fast unit rate)/d(strut velocity)`.
    rate_per_vel: [f64; UNIT_FAST],
    /// `d(strut force)/d(strut velocity)`, N s/m.
    force_per_vel: f64,
    /// `d(strut force)/d(strut compression)`, N/m.
    force_per_disp: f64,
    /// The tyre's stiffness and damping while it pushes.
    tyre_stiffness_n_per_m: f64,
    tyre_damping_n_s_per_m: f64,
}

impl CornerLinearisation {
    /// From the unit's linearisation and the tyre's slopes.
    pub fn new(unit: &Linearisation, tyre_stiffness_n_per_m: f64, tyre_damping_n_s_per_m: f64) -> Self {
        let (valve6_rate, valve6_flow) = unit.valve6.map_or(([0.0; UNIT_FAST], [0.0; UNIT_FAST]), |k| (unit_fast(&k.u), unit_fast(&k.v)));
        let mut lin = CornerLinearisation { valve6_rate, valve6_flow, tyre_stiffness_n_per_m, tyre_damping_n_s_per_m, ..CornerLinearisation::default() };
        if let Some(s) = unit.strut {
            lin.force_per_state = unit_fast(&s.force_per_state);
            lin.rate_per_vel = unit_fast(&s.rate_per_vel);
            lin.force_per_vel = s.force_per_vel_n_s_per_m;
            lin.force_per_disp = s.force_per_disp_n_per_m;
        }
        lin
    }
}

/// The body's side of `W`: its inverse inertias in heave, pitch and roll
/// (about the roll axis), and the roll stiffness its weight takes off
/// (`m g (h_cg - h_rc) / I_ra`, the one body term of the Jacobian that does
/// not come through a strut).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyInertia {
    pub inverse: [f64; 3],
    pub roll_weight_per_inertia: f64,
}

/// One corner's part of `W^-1`.
///
/// On the fast states `(T_S, T_L, V_S, V_L, z, v)` the corner's Jacobian
/// is `U V^T` with the columns
/// - `u6 v6^T`: valve 6's exchange (when open),
/// - `b e_v^T`: the strut velocity's column (the gas volume and
///   temperature it changes, `rate_per_vel`; and `z' = v`),
/// - `e_v a^T`: the wheel's acceleration row (the tyre and the strut force
///   over the unsprung mass),
///
/// so the block `I - c U V^T` has the inverse `I + U m V^T` with
/// `m = c (I - c V^T U)^-1` (Woodbury).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct CornerW {
    u6: [f64; UNIT_FAST],
    v6: [f64; UNIT_FAST],
    rate_per_vel: [f64; UNIT_FAST],
    a: Fast,
    m: [[f64; 3]; 3],
    /// The strut force's gradient over the fast states, times the block's
    /// inverse (`W_c^-T g`): the force the block's response to a
    /// right-hand side `r` makes is `force . r`.
    force: Fast,
    /// The block's inverse applied to `c` times the fast rates' derivatives
    /// by the body's velocity and displacement at the strut.
    per_body_vel: Fast,
    per_body_disp: Fast,
    /// An end stop is engaged (else `per_body_disp` and `delta` are zero).
    end_stop: bool,
    /// `d(force)/d(body displacement at the strut)` with the corner's
    /// response, and what the strut adds to the body's Schur complement.
    delta: f64,
    kappa: f64,
    /// Body displacement at the strut per heave, pitch and roll.
    lever: [f64; 3],
}

impl CornerW {
    /// `x <- (I + U m V^T) x`.
    #[inline]
    fn solve(&self, x: &mut Fast) {
        let [x0, x1, x2, x3, z, v] = *x;
        let [y0, y1, y2] = mul3(&self.m, &[dot(&self.v6, &[x0, x1, x2, x3]), v, dot(&self.a, x)]);
        let unit = [x0, x1, x2, x3];
        let mut out = [0.0; UNIT_FAST];
        for (((o, xi), u6), b) in out.iter_mut().zip(unit).zip(self.u6).zip(self.rate_per_vel) {
            *o = xi + y0 * u6 + y1 * b;
        }
        let [o0, o1, o2, o3] = out;
        *x = [o0, o1, o2, o3, z + y1, v + y2];
    }
}

/// `W^-1` for one step (see the module's description).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct W {
    corners: [CornerW; MAX_CORNERS],
    count: usize,
    c: f64,
    body: BodyInertia,
    /// The inverse of the body's Schur complement.
    body_inverse: [[f64; 3]; 3],
    /// False when a block was singular: then `W = I` (explicit).
    implicit: bool,
}

impl Default for W {
    /// The identity (no step has linearised anything yet).
    fn default() -> Self {
        W {
            corners: [CornerW::default(); MAX_CORNERS],
            count: 0,
            c: 0.0,
            body: BodyInertia { inverse: [0.0; 3], roll_weight_per_inertia: 0.0 },
            body_inverse: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            implicit: false,
        }
    }
}

impl W {
    /// A `W` built by [`W::rebuild`] (the tests' form).
    #[cfg(test)]
    pub fn new(corners: &[CornerLinearisation; MAX_CORNERS], geometry: &[CornerGeometry], body: BodyInertia, c: f64) -> Self {
        let mut w = W::default();
        w.rebuild(corners, geometry, body, c);
        w
    }

    /// `W = I - c J` for `J` the fast part of the Jacobian from each
    /// corner's linearisation (`corners` and `geometry` in the same order),
    /// built in place: the stepper keeps its `W` (4 KB) where it is
    /// instead of copying a returned one.
    pub fn rebuild(&mut self, corners: &[CornerLinearisation; MAX_CORNERS], geometry: &[CornerGeometry], body: BodyInertia, c: f64) {
        let count = geometry.len().min(MAX_CORNERS);
        let mut implicit = true;
        for (i, cw) in self.corners.iter_mut().enumerate() {
            *cw = match (corners.get(i), geometry.get(i)) {
                (Some(lin), Some(geo)) => corner_w(lin, geo, c).unwrap_or_else(|| {
                    implicit = false;
                    CornerW::default()
                }),
                _ => CornerW::default(),
            };
        }
        // The body's Schur complement, I - c M^-1 sum kappa e e^T (and the
        // weight's roll term, through the roll angle = r + c rate).
        let mut k = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0 - c * c * body.roll_weight_per_inertia]];
        for cw in self.corners.iter().take(count) {
            for ((row, m), e) in k.iter_mut().zip(&body.inverse).zip(&cw.lever) {
                let scale = c * m * cw.kappa * e;
                for (x, f) in row.iter_mut().zip(&cw.lever) {
                    *x -= scale * f;
                }
            }
        }
        self.body_inverse = inverse3(&k).unwrap_or_else(|| {
            implicit = false;
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        });
        self.count = count;
        self.c = c;
        self.body = body;
        self.implicit = implicit;
    }

    /// `x <- W^-1 x`.
    #[inline(always)]
    pub fn solve(&self, x: &mut [f64; VEHICLE_STATES]) {
        if !self.implicit {
            return;
        }
        let c = self.c;
        let (body, corner_x) = x.split_at_mut(BODY_STATES);
        let Some(b) = body.first_chunk_mut::<6>() else { return };
        let [r_heave, r_heave_vel, r_pitch, r_pitch_rate, r_roll, r_roll_rate] = *b;
        let r_pos = [r_heave, r_pitch, r_roll];
        // The strut forces each corner's response to its own right-hand side
        // makes, which drive the body.
        let mut rhs = [r_heave_vel, r_pitch_rate, r_roll_rate + c * self.body.roll_weight_per_inertia * r_roll];
        for (cw, cx) in self.corners.iter().zip(corner_x.chunks_exact(CORNER_STATES)).take(self.count) {
            let force = c * (dot(&cw.force, &gather(cx)) + cw.delta * dot(&cw.lever, &r_pos));
            for ((r, m), e) in rhs.iter_mut().zip(&self.body.inverse).zip(&cw.lever) {
                *r += m * e * force;
            }
        }
        let [v0, v1, v2] = mul3(&self.body_inverse, &rhs);
        let (vel, pos) = ([v0, v1, v2], [r_heave + c * v0, r_pitch + c * v1, r_roll + c * v2]);
        let [p0, p1, p2] = pos;
        *b = [p0, v0, p1, v1, p2, v2];
        // Each corner's response to its right-hand side and to the body's
        // motion at its strut.
        for (cw, cx) in self.corners.iter().zip(corner_x.chunks_exact_mut(CORNER_STATES)).take(self.count) {
            let mut x = gather(cx);
            cw.solve(&mut x);
            let body_vel = dot(&cw.lever, &vel);
            for (a, q) in x.iter_mut().zip(&cw.per_body_vel) {
                *a += body_vel * q;
            }
            if cw.end_stop {
                let body_disp = dot(&cw.lever, &pos);
                for (a, s) in x.iter_mut().zip(&cw.per_body_disp) {
                    *a += body_disp * s;
                }
            }
            scatter(cx, &x);
        }
    }
}

/// One corner's block of `W^-1` ([`CornerW`]; None when it is singular).
fn corner_w(lin: &CornerLinearisation, geo: &CornerGeometry, c: f64) -> Option<CornerW> {
    let m_u = geo.unsprung_mass_kg;
    let (f_vel, f_disp) = (lin.force_per_vel, lin.force_per_disp);
    let a = with_wheel(
        lin.force_per_state.map(|f| -f / m_u),
        -(lin.tyre_stiffness_n_per_m + f_disp) / m_u,
        -(lin.tyre_damping_n_s_per_m + f_vel) / m_u,
    );
    // V^T U for U = [u6, b, e_v], V = [v6, e_v, a]: v6 and u6 have no wheel
    // part, b = (rate_per_vel, 1, 0), e_v = (0, 0, 0, 0, 0, 1).
    let [.., a_z, a_v] = a;
    let a_unit = [a[0], a[1], a[2], a[3]];
    let (u6, v6, b) = (lin.valve6_rate, lin.valve6_flow, lin.rate_per_vel);
    let small = [
        [1.0 - c * dot(&v6, &u6), -c * dot(&v6, &b), 0.0],
        [0.0, 1.0, -c],
        [-c * dot(&a_unit, &u6), -c * (dot(&a_unit, &b) + a_z), 1.0 - c * a_v],
    ];
    let m = inverse3(&small)?.map(|row| row.map(|x| c * x));
    let force = with_wheel(lin.force_per_state, f_disp, f_vel);
    let mut cw = CornerW {
        u6,
        v6,
        rate_per_vel: b,
        a,
        m,
        force,
        per_body_vel: [0.0; FAST],
        per_body_disp: [0.0; FAST],
        end_stop: f_disp != 0.0,
        delta: 0.0,
        kappa: 0.0,
        lever: [1.0, -geo.x_m, geo.y_m],
    };
    // The body moves the strut's top: the strut velocity falls by the
    // body's velocity there (the gas and the wheel's force see it), and
    // the compression by its displacement (the end stops).
    let mut per_vel = with_wheel(b.map(|r| -c * r), 0.0, c * f_vel / m_u);
    cw.solve(&mut per_vel);
    let beta = dot(&force, &per_vel) - f_vel;
    cw.per_body_vel = per_vel;
    if cw.end_stop {
        let mut per_disp = with_wheel([0.0; UNIT_FAST], 0.0, c * f_disp / m_u);
        cw.solve(&mut per_disp);
        cw.delta = dot(&force, &per_disp) - f_disp;
        cw.per_body_disp = per_disp;
    }
    // The body's displacement is r + c times its velocity.
    cw.kappa = beta + c * cw.delta;
    // W_c^-T g = g + V m^T U^T g, for the solve's first pass.
    let [g0, g1, g2, g3, g_z, g_v] = force;
    let g_unit = [g0, g1, g2, g3];
    let [z0, z1, z2] = mul3_transposed(&m, &[dot(&u6, &g_unit), dot(&b, &g_unit) + g_z, g_v]);
    let [a0, a1, a2, a3, a_z, a_v] = a;
    let mut unit = g_unit;
    for ((f, v), ai) in unit.iter_mut().zip(v6).zip([a0, a1, a2, a3]) {
        *f += z0 * v + z2 * ai;
    }
    let fw = with_wheel(unit, g_z + z2 * a_z, g_v + z1 + z2 * a_v);
    cw.force = fw;
    Some(cw)
}

#[cfg(test)]
mod tests {
    // The dense reference is Gaussian elimination as the textbook writes
    // it, with index loops.
    #![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::needless_range_loop, clippy::manual_memcpy)]
    use super::*;

    #[test]
    fn the_fast_states_are_the_gas_and_the_wheel() {
        let s = UnitState { t_gas_k: 1.0, t_gas2_k: 2.0, v_gas_m3: 3.0, v_gas2_m3: 4.0, ..UnitState::default() };
        assert_eq!(unit_fast(&s), [1.0, 2.0, 3.0, 4.0]);
        let mut corner = [0.0; CORNER_STATES];
        corner[..18].copy_from_slice(&s.to_array());
        corner[18] = 5.0;
        corner[19] = 6.0;
        assert_eq!(gather(&corner), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let mut back = [0.0; CORNER_STATES];
        scatter(&mut back, &gather(&corner));
        assert_eq!(back, corner);
    }

    /// `I - c J` assembled densely on the body's (heave, pitch, roll) and
    /// every corner's fast states, independently of the Woodbury and Schur
    /// steps, solved by Gaussian elimination.
    fn dense_solve(corners: &[CornerLinearisation; MAX_CORNERS], geometry: &[CornerGeometry], body: BodyInertia, c: f64, x: &mut [f64; VEHICLE_STATES]) {
        let n = 6 + FAST * geometry.len();
        let mut j = vec![vec![0.0; n]; n];
        // Body: positions 0, 2, 4 (heave, pitch, roll), velocities 1, 3, 5.
        for k in 0..3 {
            j[2 * k][2 * k + 1] = 1.0;
        }
        j[5][4] = body.roll_weight_per_inertia;
        for (i, (lin, geo)) in corners.iter().zip(geometry).enumerate() {
            let o = 6 + FAST * i;
            let m_u = geo.unsprung_mass_kg;
            let s = lin;
            let lever = [1.0, -geo.x_m, geo.y_m];
            // The strut force's gradient: fast states, then body positions and velocities.
            let mut force = vec![0.0; n];
            for k in 0..4 {
                force[o + k] = s.force_per_state[k];
            }
            force[o + 4] = s.force_per_disp;
            force[o + 5] = s.force_per_vel;
            for k in 0..3 {
                force[2 * k] -= s.force_per_disp * lever[k];
                force[2 * k + 1] -= s.force_per_vel * lever[k];
            }
            // Strut velocity: the wheel's less the body's at the strut.
            let mut strut_vel = vec![0.0; n];
            strut_vel[o + 5] = 1.0;
            for k in 0..3 {
                strut_vel[2 * k + 1] = -lever[k];
            }
            for col in 0..n {
                for k in 0..4 {
                    j[o + k][col] += s.rate_per_vel[k] * strut_vel[col];
                }
                j[o + 5][col] -= force[col] / m_u;
                for k in 0..3 {
                    j[2 * k + 1][col] += body.inverse[k] * lever[k] * force[col];
                }
            }
            for a in 0..4 {
                for b in 0..4 {
                    j[o + a][o + b] += lin.valve6_rate[a] * lin.valve6_flow[b];
                }
            }
            j[o + 4][o + 5] += 1.0;
            j[o + 5][o + 4] -= lin.tyre_stiffness_n_per_m / m_u;
            j[o + 5][o + 5] -= lin.tyre_damping_n_s_per_m / m_u;
        }
        // Gather, solve, scatter.
        let index = |k: usize| -> usize {
            if k < 6 {
                k
            } else {
                let (i, f) = ((k - 6) / FAST, (k - 6) % FAST);
                BODY_STATES + i * CORNER_STATES + if f < 4 { f } else { CORNER_STATES - 6 + f }
            }
        };
        let mut m: Vec<Vec<f64>> = (0..n).map(|r| (0..n).map(|col| f64::from(u8::from(r == col)) - c * j[r][col]).collect()).collect();
        let mut b: Vec<f64> = (0..n).map(|k| x[index(k)]).collect();
        for col in 0..n {
            let p = (col..n).max_by(|&a, &bb| m[a][col].abs().total_cmp(&m[bb][col].abs())).unwrap();
            m.swap(col, p);
            b.swap(col, p);
            for r in col + 1..n {
                let f = m[r][col] / m[col][col];
                for k in col..n {
                    m[r][k] -= f * m[col][k];
                }
                b[r] -= f * b[col];
            }
        }
        for col in (0..n).rev() {
            let s: f64 = (col + 1..n).map(|k| m[col][k] * b[k]).sum();
            b[col] = (b[col] - s) / m[col][col];
        }
        for (k, v) in b.iter().enumerate() {
            x[index(k)] = *v;
        }
    }

    #[test]
    fn the_schur_and_woodbury_solve_is_the_dense_solve() {
        let vehicle = crate::vehicle::Vehicle::new(crate::presets::armoured_8x8(), 293.15, hp_core::unit::Valves::default()).unwrap();
        let geometry = vehicle.corners();
        // Magnitudes like the 8x8's at rest (soft spring): the gas's
        // slopes, the strut's volume rate, the damper, the tyre.
        let mut corners = [CornerLinearisation::default(); MAX_CORNERS];
        for (i, c) in corners.iter_mut().enumerate() {
            let f = 1.0 + 0.1 * i as f64;
            let open = i % 3 != 2;
            let strut = i != 5;
            let on = |x: f64, yes: bool| if yes { x } else { 0.0 };
            *c = CornerLinearisation {
                valve6_rate: [-40.0 * f, 30.0, 1.0, -1.0].map(|x| on(x, open)),
                valve6_flow: [2e-9, -1e-9, -5e-5 * f, 2e-5].map(|x| on(x, open)),
                force_per_state: [7e3, 0.0, -8e7 * f, 0.0].map(|x| on(x, strut)),
                rate_per_vel: [9e3 * f, 0.0, -8e-3, 0.0].map(|x| on(x, strut)),
                force_per_vel: on(1e4 * f, strut),
                force_per_disp: if i == 3 { 1e7 } else { 0.0 },
                tyre_stiffness_n_per_m: if i == 6 { 0.0 } else { 1.2e6 },
                tyre_damping_n_s_per_m: if i == 6 { 0.0 } else { 2e3 },
            };
        }
        let body = BodyInertia { inverse: [1.0 / 24e3, 1.0 / 1.1e5, 1.0 / 4e4], roll_weight_per_inertia: 2.0 };
        let c = 0.3e-3;
        let w = W::new(&corners, geometry, body, c);
        assert!(w.implicit);
        let mut x = [0.0; VEHICLE_STATES];
        for (k, v) in x.iter_mut().enumerate() {
            // Each state's own scale: temperatures, volumes, displacements, velocities.
            let scale = match (k < BODY_STATES, (k.max(BODY_STATES) - BODY_STATES) % CORNER_STATES) {
                (true, _) => 0.1,
                (false, 0 | 1) => 10.0,
                (false, 2 | 3) => 1e-4,
                (false, _) => 0.05,
            };
            *v = scale * (1.0 + (k as f64 * 0.7).sin());
        }
        let mut expected = x;
        dense_solve(&corners, geometry, body, c, &mut expected);
        w.solve(&mut x);
        for (k, (a, b)) in x.iter().zip(&expected).enumerate() {
            assert!((a - b).abs() <= 1e-10 * b.abs().max(1e-12), "state {k}: {a} against {b}");
        }
    }

    #[test]
    fn inverse3_inverts() {
        let a = [[4.0, 1.0, -2.0], [0.5, 3.0, 1.0], [-1.0, 2.0, 5.0]];
        let inv = inverse3(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-14);
            }
        }
        assert!(inverse3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
