//! The planar translational clearance joint (docs/theory.md §2b): a rectangular block (the
//! slider) moving in a guide whose two parallel faces stand a clearance c off the block's long
//! faces. Each of the block's four corners meets the face on its own side: corner k is a contact
//! of its own, with its penetration δ_k, its contact mode and its impacts, under the joint's
//! normal and friction laws (the corner-on-face model of Flores, Ambrósio, Claro & Lankarani,
//! J. Comput. Nonlinear Dyn. 3:011007, 2008).
//!
//! Sign conventions: the guide's mid-line passes through `guide.point` along `guide.axis` (both
//! on the guide body); its left normal m = ⊥u. Corner k sits at the block centre + s_k a u_s +
//! σ_k b ⊥u_s (u_s the block's long axis, a and b its half-length and half-height, signs
//! [`CORNER_SIGNS`]) and meets the face σ_k (b + c) along m, whose outward normal is N_k = σ_k m.
//! Penetration δ_k = N_k·(p_k − o) − (b + c) (o the mid-line point), rate δ̇_k = N_k·v_rel, slip
//! v_t = u·v_rel, v_rel the corner's velocity relative to the guide's material point under it. The
//! force on the block at the corner is −F_N N_k − F_T u; the guide receives its opposite at the same
//! point.
//!
//! A corner meets only the face on its side: crossing to the other face would take the block a
//! tilt of about 90°, which a clearance small against the block's height excludes.

use crate::clearance::{OneContact, contact_forces};
use crate::friction::FrictionLaw;
use crate::joint::Clearance;
use crate::law::NormalForce;
use lash_mech::{BodyId, Pose, Vec2, perp};
use serde::Serialize;

/// The corners' signs (along the block's axis, across it), in corner order: rear top, front top,
/// front bottom, rear bottom ("top" is the side of the guide's left normal).
pub const CORNER_SIGNS: [(f64, f64); 4] = [(-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)];

/// The block: a rectangle on the slider body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// The body carrying the block.
    pub body: BodyId,
    /// The block's centre on its body (local, from the centroid) \[m\].
    pub centre: Vec2,
    /// The block's long axis in its body's frame (unit).
    pub axis: Vec2,
    /// Half the block's length a \[m\].
    pub half_length: f64,
    /// Half the block's height b \[m\].
    pub half_height: f64,
}

/// The guide: two parallel faces on the guide body, symmetric about a mid-line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guide {
    /// The body carrying the guide (often the ground).
    pub body: BodyId,
    /// A point of the mid-line on its body (local, from the centroid) \[m\].
    pub point: Vec2,
    /// The mid-line's direction in its body's frame (unit).
    pub axis: Vec2,
}

/// One corner's contact mode.
#[derive(Debug, Clone, PartialEq)]
pub struct Corner {
    name: String,
    half_height: f64,
    clearance: f64,
    /// Discrete state: contact closed.
    pub in_contact: bool,
    /// Approach velocity δ̇⁻ captured at the last onset [m/s].
    pub onset_velocity: f64,
}

/// A prismatic joint with clearance: a block sliding in a guide.
#[derive(Debug, Clone, PartialEq)]
pub struct TranslationalClearance {
    /// Name used in outputs (usually the prismatic joint it replaces).
    pub name: String,
    /// The block (slider).
    pub block: Block,
    /// The guide.
    pub guide: Guide,
    /// Clearance c between each long face of the block and the guide face opposite \[m\].
    pub clearance: f64,
    /// Normal contact law of a corner on a face.
    pub law: NormalForce,
    /// Friction law along the guide.
    pub friction: FrictionLaw,
    corners: [Corner; 4],
}

/// One corner's geometry and forces at one state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct CornerState {
    /// The corner's position \[m\].
    pub point: Vec2,
    /// Outward normal N of the face it meets.
    pub normal: Vec2,
    /// Penetration δ into that face \[m\] (negative: clear of it).
    pub penetration: f64,
    /// Penetration rate δ̇ [m/s] (positive: approaching).
    pub penetration_rate: f64,
    /// Slip velocity along the guide v_t [m/s].
    pub slip_velocity: f64,
    /// Normal force F_N ≥ 0 \[N\].
    pub normal_force: f64,
    /// Friction force F_T (signed like v_t) \[N\].
    pub friction_force: f64,
    /// Force on the block at the corner, −F_N N − F_T u \[N\].
    pub force_on_block: Vec2,
}

/// The block's place in the guide at one state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct SlotState {
    /// Each corner's contact.
    pub corners: [CornerState; 4],
    /// The block centre's offset from the mid-line along its left normal \[m\].
    pub offset: f64,
    /// The block axis' angle to the guide's mid-line \[rad\].
    pub tilt: f64,
}

impl SlotState {
    /// The resultant force of the corners on the block \[N\].
    pub fn force_on_block(&self) -> Vec2 {
        self.corners.iter().map(|c| c.force_on_block).sum()
    }
}

impl TranslationalClearance {
    /// A joint with every corner's contact open.
    pub fn new(
        name: impl Into<String>,
        block: Block,
        guide: Guide,
        clearance: f64,
        law: NormalForce,
        friction: FrictionLaw,
    ) -> Self {
        let name = name.into();
        let corners = std::array::from_fn(|k| Corner {
            name: format!("{name} corner {}", k + 1),
            half_height: block.half_height,
            clearance,
            in_contact: false,
            onset_velocity: 0.0,
        });
        Self { name, block, guide, clearance, law, friction, corners }
    }

    /// A joint in its guide's frame: the block centred on body 0's centroid along its x axis, the
    /// guide the ground's x axis through the origin (the micro model's view, and the tests').
    pub fn in_guide_frame(
        name: impl Into<String>,
        (half_length, half_height): (f64, f64),
        clearance: f64,
        law: NormalForce,
        friction: FrictionLaw,
    ) -> Self {
        let x = Vec2::new(1.0, 0.0);
        let block = Block { body: BodyId::Body(0), centre: Vec2::zeros(), axis: x, half_length, half_height };
        let guide = Guide { body: BodyId::Ground, point: Vec2::zeros(), axis: x };
        Self::new(name, block, guide, clearance, law, friction)
    }

    /// Corner `k`'s contact mode (corner order of [`CORNER_SIGNS`]).
    pub fn corner(&self, k: usize) -> &Corner {
        &self.corners[k]
    }

    /// Corner `k`'s contact mode, to switch.
    pub fn corner_mut(&mut self, k: usize) -> &mut Corner {
        &mut self.corners[k]
    }

    /// The relative angle θ_block − θ_guide at which the block's axis lies along the guide's.
    pub fn aligned_angle(&self) -> f64 {
        let (u, s) = (self.guide.axis, self.block.axis);
        u.y.atan2(u.x) - s.y.atan2(s.x)
    }

    /// Corner `k` at the body poses, under the onset velocity `onset` of its current contact.
    #[inline]
    pub fn evaluate_corner(&self, block: &Pose, guide: &Pose, k: usize, onset: f64) -> CornerState {
        let (along, across) = CORNER_SIGNS[k];
        let (u, m, origin) = self.mid_line(guide);
        let us = block.rotate(self.block.axis);
        let arm = block.rotate(self.block.centre)
            + us * (along * self.block.half_length)
            + perp(us) * (across * self.block.half_height);
        let point = block.position + arm;
        let normal = m * across;
        let v_point = block.velocity + perp(arm) * block.angular_velocity;
        let v_guide = guide.velocity + perp(point - guide.position) * guide.angular_velocity;
        let v_rel = v_point - v_guide;
        let penetration = normal.dot(&(point - origin)) - (self.block.half_height + self.clearance);
        let penetration_rate = normal.dot(&v_rel);
        let slip_velocity = u.dot(&v_rel);
        let laws = OneContact::<false> { law: &self.law, friction: &self.friction, onset, series: f64::INFINITY };
        let (normal_force, friction_force) = contact_forces(&laws, (penetration, penetration_rate), slip_velocity);
        CornerState {
            point,
            normal,
            penetration,
            penetration_rate,
            slip_velocity,
            normal_force,
            friction_force,
            force_on_block: -(normal * normal_force) - u * friction_force,
        }
    }

    /// Every corner at the body poses, each under its own contact's onset velocity (a corner in
    /// free flight is evaluated as at first touch, `f64::INFINITY`).
    pub fn evaluate(&self, block: &Pose, guide: &Pose) -> SlotState {
        let corners = std::array::from_fn(|k| {
            let c = &self.corners[k];
            self.evaluate_corner(block, guide, k, if c.in_contact { c.onset_velocity } else { f64::INFINITY })
        });
        let (offset, tilt) = self.placement(block, guide);
        SlotState { corners, offset, tilt }
    }

    /// The block centre's offset from the mid-line (along its left normal) and the block axis'
    /// angle to it, at the body poses.
    pub fn placement(&self, block: &Pose, guide: &Pose) -> (f64, f64) {
        let (u, m, origin) = self.mid_line(guide);
        let centre = block.position + block.rotate(self.block.centre);
        let us = block.rotate(self.block.axis);
        (m.dot(&(centre - origin)), u.perp(&us).atan2(u.dot(&us)))
    }

    /// The guide's mid-line direction u, its left normal m and its point o, in the world.
    #[inline(always)]
    fn mid_line(&self, guide: &Pose) -> (Vec2, Vec2, Vec2) {
        let u = guide.rotate(self.guide.axis);
        (u, perp(u), guide.position + guide.rotate(self.guide.point))
    }
}

impl Clearance for Corner {
    const KIND: &'static str = "translational clearance joint's";
    const RADIUS: &'static str = "block's half-height";
    fn name(&self) -> &str {
        &self.name
    }
    /// The length the blow-up limit refers to: the block's half-height.
    fn journal_radius(&self) -> f64 {
        self.half_height
    }
    fn radial_clearance(&self) -> f64 {
        self.clearance
    }
    fn in_contact(&self) -> bool {
        self.in_contact
    }
    fn onset_velocity(&self) -> f64 {
        self.onset_velocity
    }
    fn set_mode(&mut self, in_contact: bool, onset_velocity: f64) {
        self.in_contact = in_contact;
        self.onset_velocity = onset_velocity;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: f64 = 0.05;
    const B: f64 = 0.025;
    const C: f64 = 0.001;

    fn joint(guide_angle: f64) -> TranslationalClearance {
        let law = NormalForce::Power { stiffness: 1e9, exponent: 1.5 };
        let mut j =
            TranslationalClearance::in_guide_frame("slot", (A, B), C, law, FrictionLaw::Coulomb { coefficient: 0.1 });
        j.guide.axis = Vec2::new(guide_angle.cos(), guide_angle.sin());
        j
    }

    fn pose(x: f64, y: f64, angle: f64, v: Vec2, omega: f64) -> Pose {
        let (sin, cos) = angle.sin_cos();
        Pose { position: Vec2::new(x, y), angle, cos, sin, velocity: v, angular_velocity: omega }
    }

    #[test]
    fn a_block_lowered_by_more_than_the_clearance_presses_its_bottom_corners_only() {
        let j = joint(0.0);
        let s = j.evaluate(&pose(0.3, -C - 1e-5, 0.0, Vec2::zeros(), 0.0), &Pose::GROUND);
        for k in [2, 3] {
            assert!((s.corners[k].penetration - 1e-5).abs() < 1e-15, "{:?}", s.corners[k]);
            assert!((s.corners[k].normal_force - 1e9 * 1e-5f64.powf(1.5)).abs() < 1e-6);
            assert_eq!(s.corners[k].normal, Vec2::new(0.0, -1.0));
        }
        for k in [0, 1] {
            assert!((s.corners[k].penetration + 2.0 * C + 1e-5).abs() < 1e-15);
            assert_eq!(s.corners[k].normal_force, 0.0);
        }
        // Pushed up by the bottom face.
        assert!(s.force_on_block().y > 0.0 && s.force_on_block().x == 0.0);
        assert!((s.offset + C + 1e-5).abs() < 1e-15 && s.tilt == 0.0);
    }

    #[test]
    fn a_tilted_block_meets_the_faces_with_two_opposite_corners() {
        // Tilted by the angle that brings corners 1 (front top) and 4 (rear bottom) to the faces.
        let j = joint(0.0);
        // Corner 1 (front top) at a sinθ + b cosθ = b + c.
        let theta = {
            let mut t = 0.0f64;
            for _ in 0..50 {
                t -= (A * t.sin() + B * t.cos() - B - C) / (A * t.cos() - B * t.sin());
            }
            t
        };
        let s = j.evaluate(&pose(0.0, 0.0, theta, Vec2::zeros(), 0.0), &Pose::GROUND);
        assert!(s.corners[1].penetration.abs() < 1e-15 && s.corners[3].penetration.abs() < 1e-15);
        assert!(s.corners[0].penetration < -C && s.corners[2].penetration < -C);
        assert!((s.tilt - theta).abs() < 1e-15);
    }

    #[test]
    fn rates_are_the_derivatives_of_the_penetrations_also_on_a_moving_guide() {
        // A block and a guide both moving and turning: δ̇ and the slip against central differences
        // of the penetration and of the corner's place along the guide.
        let mut j = joint(0.4);
        j.guide.body = BodyId::Body(1);
        j.guide.point = Vec2::new(0.02, -0.01);
        let (vb, wb, vg, wg) = (Vec2::new(0.7, -0.3), 5.0, Vec2::new(-0.2, 0.4), -3.0);
        let at = |t: f64| {
            let b = pose(0.1 + vb.x * t, 0.05 + vb.y * t, 0.41 + wb * t, vb, wb);
            let g = pose(0.08 + vg.x * t, 0.06 + vg.y * t, 0.02 + wg * t, vg, wg);
            (b, g)
        };
        let h = 1e-6;
        for k in 0..4 {
            let state = |t: f64| {
                let (b, g) = at(t);
                j.evaluate_corner(&b, &g, k, f64::INFINITY)
            };
            let along = |t: f64| {
                let (b, g) = at(t);
                let (u, _, o) = j.mid_line(&g);
                let s = j.evaluate_corner(&b, &g, k, f64::INFINITY);
                u.dot(&(s.point - o))
            };
            let rate = (state(h).penetration - state(-h).penetration) / (2.0 * h);
            assert!((state(0.0).penetration_rate - rate).abs() < 1e-7, "corner {k}: {rate}");
            // The slip is d/dt of the corner's place along the mid-line: the guide's turning moves
            // the mid-line point under the corner exactly as it turns the axis.
            let expected = (along(h) - along(-h)) / (2.0 * h);
            let s0 = state(0.0);
            assert!((s0.slip_velocity - expected).abs() < 1e-7, "corner {k}: {} vs {expected}", s0.slip_velocity);
        }
    }
}
