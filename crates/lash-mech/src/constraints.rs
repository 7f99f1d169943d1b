//! Constraint equations Φ(q, t) = 0 joint by joint, with Φ_q, ν (Φ_q q̇ = ν) and γ (Φ_q q̈ = γ).
//!
//! Planar identities used throughout: a body-fixed vector a = A(θ)s has ȧ = θ̇ ⊥a and
//! ä = θ̈ ⊥a − θ̇² a, with ⊥(x, y) = (−y, x).

use crate::model::{BodyId, JointKind, Mechanism};
use crate::{Pose, Vec2, perp};

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

/// The row of Φ = v·d, d = r_i + a_i − r_j − a_j: the distance of point a_i of body i from the
/// line through point a_j of body j along a direction fixed on body j, whose normal is v (world
/// components) — its Jacobian row, its value and γ (0 unless `GAMMA`). A prismatic joint's second
/// row (v normal to its axis); with v along the axis, the slide of a translational clearance
/// joint's block along its guide.
#[inline(always)]
pub(crate) fn line_row<const GAMMA: bool>(
    (body_i, body_j): (BodyId, BodyId),
    (pi, pj): (&Pose, &Pose),
    (ai, aj): (Vec2, Vec2),
    v: Vec2,
) -> (JacobianRow, f64, f64) {
    let (wi, wj) = (pi.angular_velocity, pj.angular_velocity);
    let d = pi.position + ai - pj.position - aj;
    let pv = perp(v);
    let row = [blk(body_i, v, v.dot(&perp(ai))), blk(body_j, -v, pv.dot(&d) - v.dot(&perp(aj)))];
    let gamma = if GAMMA {
        let d_dot = pi.velocity + perp(ai) * wi - pj.velocity - perp(aj) * wj;
        wj * wj * v.dot(&d) - 2.0 * wj * pv.dot(&d_dot) + wi * wi * v.dot(&ai) - wj * wj * v.dot(&aj)
    } else {
        0.0
    };
    (row, v.dot(&d), gamma)
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
        let pi = pose_of(poses, joint.body_i);
        let pj = pose_of(poses, joint.body_j);
        let ai = pi.rotate(joint.point_i);
        let aj = pj.rotate(joint.point_j);
        let (wi, wj) = (pi.angular_velocity, pj.angular_velocity);
        match &joint.kind {
            JointKind::Revolute => {
                let d = pi.position + ai - pj.position - aj;
                let (pai, paj) = (perp(ai), perp(aj));
                jac[row] =
                    [blk(joint.body_i, Vec2::new(1.0, 0.0), pai.x), blk(joint.body_j, Vec2::new(-1.0, 0.0), -paj.x)];
                jac[row + 1] =
                    [blk(joint.body_i, Vec2::new(0.0, 1.0), pai.y), blk(joint.body_j, Vec2::new(0.0, -1.0), -paj.y)];
                phi[row] = d.x;
                phi[row + 1] = d.y;
                nu[row] = 0.0;
                nu[row + 1] = 0.0;
                if GAMMA {
                    let g = ai * (wi * wi) - aj * (wj * wj);
                    gamma[row] = g.x;
                    gamma[row + 1] = g.y;
                }
            }
            JointKind::Prismatic { axis_j, angle_offset } => {
                // Φ1 = θ_i − θ_j − θ0
                jac[row] = [blk(joint.body_i, Vec2::zeros(), 1.0), blk(joint.body_j, Vec2::zeros(), -1.0)];
                phi[row] = pi.angle - pj.angle - angle_offset;
                nu[row] = 0.0;
                if GAMMA {
                    gamma[row] = 0.0;
                }
                // Φ2 = v·d, v = A_j ⊥u (unit normal to the axis), d = r_i + a_i − r_j − a_j
                let u = axis_j / axis_j.norm();
                let v = pj.rotate(perp(u));
                let (r, value, g) = line_row::<GAMMA>((joint.body_i, joint.body_j), (&pi, &pj), (ai, aj), v);
                jac[row + 1] = r;
                phi[row + 1] = value;
                nu[row + 1] = 0.0;
                if GAMMA {
                    gamma[row + 1] = g;
                }
            }
        }
        row += joint.equations();
    }
    for driver in &mech.drivers {
        let pi = pose_of(poses, driver.body);
        let pj = pose_of(poses, driver.reference);
        let (f, fd, fdd) = driver.motion.eval(t);
        jac[row] = [blk(driver.body, Vec2::zeros(), 1.0), blk(driver.reference, Vec2::zeros(), -1.0)];
        phi[row] = pi.angle - pj.angle - f;
        nu[row] = fd;
        if GAMMA {
            gamma[row] = fdd;
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
