//! Constraint equations Φ(q, t) = 0 joint by joint, with Φ_q, ν (Φ_q q̇ = ν) and γ (Φ_q q̈ = γ).
//!
//! Planar identities used throughout: a body-fixed vector a = A(θ)s has ȧ = θ̇ ⊥a and
//! ä = θ̈ ⊥a − θ̇² a, with ⊥(x, y) = (−y, x).

use crate::model::{BodyId, JointKind, Mechanism};
use crate::{Pose, Vec2};
use lash_core::lane::Real;

/// The Jacobian entries of one body in one constraint row: ∂Φ_row/∂(x, y, θ) of that body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// Moving body index, or [`Block::NONE`] for the ground (no coordinates).
    pub body: usize,
    /// ∂Φ/∂x, ∂Φ/∂y, ∂Φ/∂θ.
    pub d: [f64; 3],
}

impl Block {
    /// Marker of an unused block (the ground side of a joint).
    pub const NONE: usize = usize::MAX;
    /// An empty block.
    pub const EMPTY: Block = Block { body: Block::NONE, d: [0.0; 3] };
}

/// One row of Φ_q: a planar constraint touches at most two bodies.
pub type JacobianRow = [Block; 2];

/// Pose of `id` from a slice of body poses.
#[inline]
pub fn pose_of(poses: &[Pose], id: BodyId) -> Pose {
    match id {
        BodyId::Ground => Pose::GROUND,
        BodyId::Body(k) => poses[k],
    }
}

/// The sine and cosine of each body's angle at the last [`fill_poses`], with the angle they
/// belong to.
#[derive(Debug, Clone)]
pub struct Rotations(pub(crate) Vec<(u64, f64, f64)>);

impl Rotations {
    /// For `bodies` bodies, none known yet.
    pub fn new(bodies: usize) -> Self {
        // (A NaN angle is always recomputed, so no angle matches these entries.)
        Self(vec![(f64::NAN.to_bits(), f64::NAN, f64::NAN); bodies])
    }

    /// Takes `other`'s known sines and cosines (each stays tied to its angle's bits, so any
    /// solver's serve), when both have as many bodies.
    pub fn take_from(&mut self, other: &Rotations) {
        if self.0.len() == other.0.len() {
            self.0.copy_from_slice(&other.0);
        }
    }
}

/// Fills `poses` (one per moving body, as [`Pose::of`]) from coordinates and velocities, taking the
/// sine and cosine of an angle whose bits have not changed since the last call from `rotations`
/// (the same numbers: `sin_cos` of the same argument). In a position analysis a driven angle is
/// exact after the first Newton correction and keeps its bits in every later iteration; `sin_cos`
/// was ~4 % of a sweep of scenario A.
pub fn fill_poses(q: &[f64], qd: &[f64], poses: &mut [Pose], rotations: &mut Rotations) {
    for (k, (p, r)) in poses.iter_mut().zip(rotations.0.iter_mut()).enumerate() {
        let angle = q[3 * k + 2];
        if angle.to_bits() != r.0 || angle.is_nan() {
            let (sin, cos) = angle.sin_cos();
            *r = (angle.to_bits(), sin, cos);
        }
        *p = Pose {
            position: Vec2::new(q[3 * k], q[3 * k + 1]),
            angle,
            cos: r.2,
            sin: r.1,
            velocity: Vec2::new(qd[3 * k], qd[3 * k + 1]),
            angular_velocity: qd[3 * k + 2],
        };
    }
}

/// The Jacobian block of one body.
#[inline]
fn blk(id: BodyId, dr: Vec2, dtheta: f64) -> Block {
    match id {
        BodyId::Body(k) => Block { body: k, d: [dr.x, dr.y, dtheta] },
        BodyId::Ground => Block::EMPTY,
    }
}

/// A body's pose and velocity as the constraint rows read them (a [`Pose`]'s numbers), for one
/// mechanism or several side by side ([`Real`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct BodyState<R> {
    pub(crate) position: [R; 2],
    pub(crate) angle: R,
    pub(crate) cos: R,
    pub(crate) sin: R,
    pub(crate) velocity: [R; 2],
    pub(crate) angular_velocity: R,
}

impl BodyState<f64> {
    /// A pose's numbers.
    #[inline(always)]
    pub(crate) fn of(p: &Pose) -> Self {
        Self {
            position: [p.position.x, p.position.y],
            angle: p.angle,
            cos: p.cos,
            sin: p.sin,
            velocity: [p.velocity.x, p.velocity.y],
            angular_velocity: p.angular_velocity,
        }
    }
}

impl<R: Real> BodyState<R> {
    /// A body-fixed vector in world components, A(θ) s ([`Pose::rotate`]).
    #[inline(always)]
    pub(crate) fn rotate(&self, [x, y]: [R; 2]) -> [R; 2] {
        [self.cos * x - self.sin * y, self.sin * x + self.cos * y]
    }
}

/// One constraint row: ∂Φ/∂(x, y, θ) of body i and of body j (a ground side's block is its
/// caller's to empty), Φ and γ (zero unless asked for).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Row<R> {
    pub(crate) i: [R; 3],
    pub(crate) j: [R; 3],
    pub(crate) phi: R,
    pub(crate) gamma: R,
}

/// d = r_i + a_i − r_j − a_j.
#[inline(always)]
fn separation<R: Real>((bi, bj): (&BodyState<R>, &BodyState<R>), (ai, aj): ([R; 2], [R; 2])) -> [R; 2] {
    [bi.position[0] + ai[0] - bj.position[0] - aj[0], bi.position[1] + ai[1] - bj.position[1] - aj[1]]
}

/// The row of Φ = v·d, d = r_i + a_i − r_j − a_j: the distance of point a_i of body i from the
/// line through point a_j of body j along a direction fixed on body j, whose normal is v (world
/// components) — its Jacobian row, its value and γ (0 unless `GAMMA`); for one mechanism or
/// several side by side. A prismatic joint's second row (v normal to its axis); with v along the
/// axis, the slide of a translational clearance joint's block along its guide.
#[inline(always)]
pub(crate) fn line<R: Real, const GAMMA: bool>(
    (bi, bj): (&BodyState<R>, &BodyState<R>),
    (ai, aj): ([R; 2], [R; 2]),
    v: [R; 2],
) -> Row<R> {
    let dot = |a: [R; 2], b: [R; 2]| a[0] * b[0] + a[1] * b[1];
    let perp = |a: [R; 2]| [-a[1], a[0]];
    let (wi, wj) = (bi.angular_velocity, bj.angular_velocity);
    let d = separation((bi, bj), (ai, aj));
    let pv = perp(v);
    let gamma = if GAMMA {
        let (pai, paj) = (perp(ai), perp(aj));
        let d_dot: [R; 2] = std::array::from_fn(|k| bi.velocity[k] + pai[k] * wi - bj.velocity[k] - paj[k] * wj);
        wj * wj * dot(v, d) - R::splat(2.0) * wj * dot(pv, d_dot) + wi * wi * dot(v, ai) - wj * wj * dot(v, aj)
    } else {
        R::splat(0.0)
    };
    Row { i: [v[0], v[1], dot(v, perp(ai))], j: [-v[0], -v[1], dot(pv, d) - dot(v, perp(aj))], phi: dot(v, d), gamma }
}

/// The two rows of a joint between bodies `bi` and `bj` at their points `points` (body frames):
/// a revolute joint's d = r_i + a_i − r_j − a_j = 0, or, given its unit axis on body j and its
/// angle offset (`prismatic`), a prismatic joint's θ_i − θ_j − θ₀ = 0 and [`line`] along the
/// axis' normal — for one mechanism ([`evaluate_as`]) or several side by side (the macro step's
/// lanes), the same operations in the same order.
#[inline(always)]
pub(crate) fn joint_rows<R: Real, const GAMMA: bool>(
    (bi, bj): (&BodyState<R>, &BodyState<R>),
    (point_i, point_j): ([R; 2], [R; 2]),
    prismatic: Option<([R; 2], R)>,
) -> [Row<R>; 2] {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let (ai, aj) = (bi.rotate(point_i), bj.rotate(point_j));
    match prismatic {
        None => {
            let d = separation((bi, bj), (ai, aj));
            let (wi, wj) = (bi.angular_velocity, bj.angular_velocity);
            let gamma = |k: usize| if GAMMA { ai[k] * (wi * wi) - aj[k] * (wj * wj) } else { zero };
            [
                Row { i: [one, zero, -ai[1]], j: [-one, zero, aj[1]], phi: d[0], gamma: gamma(0) },
                Row { i: [zero, one, ai[0]], j: [zero, -one, -aj[0]], phi: d[1], gamma: gamma(1) },
            ]
        }
        Some((u, offset)) => {
            let angle =
                Row { i: [zero, zero, one], j: [zero, zero, -one], phi: bi.angle - bj.angle - offset, gamma: zero };
            [angle, line::<R, GAMMA>((bi, bj), (ai, aj), bj.rotate([-u[1], u[0]]))]
        }
    }
}

/// A driver's row, θ_i − θ_j − f(t) = 0, for the motion's f, ḟ, f̈ at the instant: the row and ν
/// (= ḟ; γ = f̈).
#[inline(always)]
pub(crate) fn driver_row<R: Real>((bi, bj): (&BodyState<R>, &BodyState<R>), [f, fd, fdd]: [R; 3]) -> (Row<R>, R) {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    (Row { i: [zero, zero, one], j: [zero, zero, -one], phi: bi.angle - bj.angle - f, gamma: fdd }, fd)
}

/// [`line`] of one mechanism as a Jacobian row, Φ and γ.
#[inline(always)]
pub(crate) fn line_row<const GAMMA: bool>(
    (body_i, body_j): (BodyId, BodyId),
    (pi, pj): (&Pose, &Pose),
    (ai, aj): (Vec2, Vec2),
    v: Vec2,
) -> (JacobianRow, f64, f64) {
    let r = line::<f64, GAMMA>((&BodyState::of(pi), &BodyState::of(pj)), ([ai.x, ai.y], [aj.x, aj.y]), [v.x, v.y]);
    (jacobian_row((body_i, body_j), &r), r.phi, r.gamma)
}

/// A row's two blocks as one mechanism's Jacobian row (the ground's block empty).
#[inline(always)]
fn jacobian_row((body_i, body_j): (BodyId, BodyId), r: &Row<f64>) -> JacobianRow {
    let blk = |id: BodyId, d: [f64; 3]| blk(id, Vec2::new(d[0], d[1]), d[2]);
    [blk(body_i, r.i), blk(body_j, r.j)]
}

/// The constraint terms at one state.
pub struct ConstraintTerms<'a> {
    /// Φ_q by rows (sparse: two body blocks per row); every row is overwritten.
    pub jacobian: &'a mut [JacobianRow],
    /// Φ (one per equation).
    pub phi: &'a mut [f64],
    /// ν, the velocity right side.
    pub nu: &'a mut [f64],
    /// γ, the acceleration right side (without stabilisation).
    pub gamma: &'a mut [f64],
}

/// Evaluates Φ, Φ_qᵀ, ν and γ of all joints (then drivers) at time `t`.
pub fn evaluate(mech: &Mechanism, t: f64, poses: &[Pose], out: ConstraintTerms<'_>) {
    evaluate_as::<true>(mech, t, poses, out);
}

/// [`evaluate`], γ only if `GAMMA` (else `out.gamma` is left as it was): the same numbers for
/// what is written.
#[inline(always)]
pub(crate) fn evaluate_as<const GAMMA: bool>(mech: &Mechanism, t: f64, poses: &[Pose], out: ConstraintTerms<'_>) {
    let ConstraintTerms { jacobian: jac, phi, nu, gamma } = out;
    let mut row = 0;
    for joint in &mech.joints {
        let (pi, pj) = (pose_of(poses, joint.body_i), pose_of(poses, joint.body_j));
        let prismatic = match joint.kind {
            JointKind::Revolute => None,
            JointKind::Prismatic { axis_j, angle_offset } => {
                let u = axis_j / axis_j.norm();
                Some(([u.x, u.y], angle_offset))
            }
        };
        let points = ([joint.point_i.x, joint.point_i.y], [joint.point_j.x, joint.point_j.y]);
        let rows = joint_rows::<f64, GAMMA>((&BodyState::of(&pi), &BodyState::of(&pj)), points, prismatic);
        for (k, r) in rows.iter().enumerate() {
            jac[row + k] = jacobian_row((joint.body_i, joint.body_j), r);
            phi[row + k] = r.phi;
            nu[row + k] = 0.0;
            if GAMMA {
                gamma[row + k] = r.gamma;
            }
        }
        row += joint.equations();
    }
    for driver in &mech.drivers {
        let (pi, pj) = (pose_of(poses, driver.body), pose_of(poses, driver.reference));
        let (f, fd, fdd) = driver.motion.eval(t);
        let (r, rate) = driver_row((&BodyState::of(&pi), &BodyState::of(&pj)), [f, fd, fdd]);
        jac[row] = jacobian_row((driver.body, driver.reference), &r);
        phi[row] = r.phi;
        nu[row] = rate;
        if GAMMA {
            gamma[row] = r.gamma;
        }
        row += 1;
    }
    debug_assert_eq!(row, mech.constraint_count());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reused sines and cosines are those `Pose::of` computes, bit for bit, through repeated,
    /// changed, signed-zero and NaN angles.
    #[test]
    fn reused_rotations_equal_fresh_ones() {
        let angles = [0.3, 0.3, -0.0, 0.0, 0.0, f64::NAN, f64::NAN, 2.0, 0.3, 1e-300, 1e-300];
        let mut rotations = Rotations::new(2);
        let mut reused = vec![Pose::GROUND; 2];
        for (i, &a) in angles.iter().enumerate() {
            let q = [1.0, 2.0, a, 3.0, 4.0, angles[(i + 3) % angles.len()]];
            let qd = [0.1, 0.2, 0.3, 0.4, 0.5, i as f64];
            fill_poses(&q, &qd, &mut reused, &mut rotations);
            let bits = |p: &Pose| {
                [p.position.x, p.position.y, p.angle, p.cos, p.sin, p.velocity.x, p.velocity.y, p.angular_velocity]
                    .map(f64::to_bits)
            };
            for k in 0..2 {
                assert_eq!(bits(&reused[k]), bits(&Pose::of(BodyId::Body(k), &q, &qd)), "state {i}, body {k}");
            }
        }
    }
}
