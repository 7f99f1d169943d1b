//! The translational clearance joint (a block in a guide) as the micro model sees it. Its two
//! interface coordinates are those of the macro side's guide interface: the block's tilt θ
//! against the guide and its centre's offset y from the guide's mid-line; the block's speed
//! along the guide ẋ comes from the macro side as the joint's one rotation input (the
//! "journal's" rate). Each of the block's four corners is a contact of its own, with its mode,
//! its onset velocity and its impacts, evaluated by lash-contact's corner law
//! ([`TranslationalClearance::evaluate_corner`], the full model's) in the guide's frame: the
//! guide is the ground along x, the block's centre at (0, y) turned by θ.
//!
//! The corners' forces F_k on the block, at arms r_k from its centre, load the coordinates with
//! the tilt's generalized force Σ r_k × F_k and the offset's Σ F_k·m, and the guide with the
//! friction load Σ F_k·u (the force along it), which the macro side applies through its slide.

use crate::joint::MicroJoint;
use lash_contact::joint::{Clearance, ContactModes};
use lash_contact::translational::{Corner, CornerState, TranslationalClearance};
use lash_mech::{Pose, Vec2, cross};

/// A translational clearance joint in its guide's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct GuideJoint {
    slot: TranslationalClearance,
}

/// The corners and the loads they put on the interface at one state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GuideState {
    /// Each corner's contact.
    pub corners: [CornerState; 4],
    /// The tilt's and the offset's generalized forces (moment about the block's centre \[N m\],
    /// force across the guide \[N\]).
    pub generalized: [f64; 2],
    /// The corners' force along the guide on the block \[N\].
    pub along: f64,
    /// The corner deepest into its face.
    pub deepest: usize,
    /// The block's speed along the guide [m/s].
    pub slide: f64,
    /// The block centre's offset from the guide's mid-line \[m\].
    pub offset: f64,
}

impl GuideJoint {
    /// The micro joint of `joint`: the same block, clearance and laws, every corner open.
    pub fn new(joint: &TranslationalClearance) -> Self {
        let size = (joint.block.half_length, joint.block.half_height);
        let slot = TranslationalClearance::in_guide_frame(
            joint.name.clone(),
            size,
            joint.clearance,
            joint.law,
            joint.friction,
        );
        Self { slot }
    }

    /// The joint in the guide's frame.
    pub fn slot(&self) -> &TranslationalClearance {
        &self.slot
    }

    /// The block's pose in the guide's frame at tilt and offset `e`, their rates `e_dot` and the
    /// speed along the guide `slide`.
    #[inline(always)]
    fn block(e: &[f64], e_dot: &[f64], slide: f64) -> Pose {
        let (sin, cos) = e[0].sin_cos();
        Pose {
            position: Vec2::new(0.0, e[1]),
            angle: e[0],
            cos,
            sin,
            velocity: Vec2::new(slide, e_dot[1]),
            angular_velocity: e_dot[0],
        }
    }
}

impl Clearance for GuideJoint {
    const KIND: &'static str = "translational clearance joint";
    const RADIUS: &'static str = "block's half-height";
    fn name(&self) -> &str {
        &self.slot.name
    }
    fn journal_radius(&self) -> f64 {
        self.slot.block.half_height
    }
    fn radial_clearance(&self) -> f64 {
        self.slot.clearance
    }
    /// Any corner in contact.
    fn in_contact(&self) -> bool {
        (0..4).any(|k| self.slot.corner(k).in_contact)
    }
    fn onset_velocity(&self) -> f64 {
        (0..4).map(|k| self.slot.corner(k).onset_velocity).fold(0.0, f64::max)
    }
    /// Every corner's mode.
    fn set_mode(&mut self, in_contact: bool, onset_velocity: f64) {
        for k in 0..4 {
            self.slot.corner_mut(k).set_mode(in_contact, onset_velocity);
        }
    }
}

/// The slot's corners.
impl ContactModes for GuideJoint {
    type Contact = Corner;
    const CONTACTS: usize = 4;
    #[inline(always)]
    fn contact(&self, k: usize) -> &Corner {
        self.slot.contact(k)
    }
    #[inline(always)]
    fn contact_mut(&mut self, k: usize) -> &mut Corner {
        self.slot.contact_mut(k)
    }
}

impl MicroJoint for GuideJoint {
    const COORDINATES: usize = 2;
    const FRICTION_LOADS: usize = 1;
    const ROTATIONS: usize = 1;
    type State = GuideState;

    /// Each corner under its own mode: a closed corner under its contact's onset velocity, an
    /// open one that a stage finds past its face under its own approach velocity (as the micro
    /// model treats a journal ahead of its onset).
    fn evaluate<const SERIES: bool>(&self, e: &[f64], e_dot: &[f64], slide: &[f64], _: &[f64], _: f64) -> GuideState {
        let block = Self::block(e, e_dot, slide[0]);
        let mut state = GuideState { slide: slide[0], offset: e[1], ..GuideState::default() };
        let centre = block.position;
        for k in 0..4 {
            let corner = self.slot.corner(k);
            let mut c = self.slot.evaluate_corner(&block, &Pose::GROUND, k, corner.onset_velocity);
            if !corner.in_contact && c.penetration > 0.0 {
                c = self.slot.evaluate_corner(&block, &Pose::GROUND, k, c.penetration_rate.max(0.0));
            }
            let f = c.force_on_block;
            state.generalized[0] += cross(c.point - centre, f);
            state.generalized[1] += f.y;
            state.along += f.x;
            if c.penetration > state.corners[state.deepest].penetration || k == 0 {
                state.deepest = k;
            }
            state.corners[k] = c;
        }
        state
    }
    /// |y| + a |θ| > c: a corner can reach its face only then (a|sin θ| ≤ a|θ|, and b cos θ ≤ b).
    #[inline(always)]
    fn may_touch(&self, e: &[f64]) -> bool {
        e[1].abs() + self.slot.block.half_length * e[0].abs() > self.slot.clearance
    }
    fn contact_gap(&self, e: &[f64], e_dot: &[f64], k: usize) -> (f64, f64) {
        let c = self.slot.evaluate_corner(&Self::block(e, e_dot, 0.0), &Pose::GROUND, k, f64::INFINITY);
        (c.penetration, c.penetration_rate)
    }
    fn contact_sample(s: &GuideState, k: usize) -> (f64, f64) {
        (s.corners[k].normal_force, s.corners[k].penetration)
    }
    fn loads(&self, s: &GuideState, force: &mut [f64], friction: &mut [f64]) {
        force.copy_from_slice(&s.generalized);
        friction[0] = s.along;
    }
    /// The deepest corner's.
    fn penetration(s: &GuideState) -> f64 {
        s.corners[s.deepest].penetration
    }
    fn penetration_rate(s: &GuideState) -> f64 {
        s.corners[s.deepest].penetration_rate
    }
    /// The corners' together.
    fn normal_force(s: &GuideState) -> f64 {
        s.corners.iter().map(|c| c.normal_force).sum()
    }
    fn friction_force(s: &GuideState) -> f64 {
        s.corners.iter().map(|c| c.friction_force).sum()
    }
    /// |y|, the block centre's offset.
    fn eccentricity_norm(s: &GuideState) -> f64 {
        s.offset.abs()
    }
    fn slip(s: &GuideState) -> f64 {
        s.slide
    }
    fn force_component(s: &GuideState, i: usize) -> f64 {
        s.generalized[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::InterfaceModel;
    use lash_contact::friction::FrictionLaw;
    use lash_contact::law::NormalForce;
    use nalgebra::{Matrix2, Vector2};

    const M: f64 = 0.5;
    const A: f64 = 0.05;
    const B: f64 = 0.025;
    const C: f64 = 1e-3;
    const K: f64 = 1e9;

    /// A block of 0.5 kg (its rectangle's inertia) in a fixed guide, as a micro model whose
    /// macro terms are the free block's: M̃ = diag(I, m), f̃ = 0.
    fn block(e: [f64; 2], e_dot: [f64; 2]) -> InterfaceModel<GuideJoint, 2, 1, 1, 1> {
        let law = NormalForce::Power { stiffness: K, exponent: 1.5 };
        let slot = TranslationalClearance::in_guide_frame("slot", (A, B), C, law, FrictionLaw::None);
        let mut m = InterfaceModel::new(vec![GuideJoint::new(&slot)]);
        let inertia = M * (4.0 * A * A + 4.0 * B * B) / 12.0;
        m.inputs.effective_mass = Matrix2::new(inertia, 0.0, 0.0, M);
        m.eccentricity = Vector2::from(e);
        m.eccentricity_rate = Vector2::from(e_dot);
        m.reset_contacts(0.0);
        m
    }

    /// Dropped flat at 0.5 m/s onto the bottom face: both bottom corners land together, the
    /// deepest penetration is that of m δ̈ = −2K δ^1.5, (5 m v²/(8K))^(2/5), and the block leaves
    /// at its landing speed without turning.
    #[test]
    fn a_block_dropped_flat_lands_on_both_bottom_corners_as_the_closed_form_says() {
        let v0 = 0.5;
        let mut m = block([0.0, 0.0], [0.0, -v0]);
        let (h, mut t, mut deepest) = (1e-6, 0.0, 0.0f64);
        while t < 4e-3 {
            m.rk4_step(t, h);
            t += h;
            deepest = deepest.max(-m.eccentricity[1] - C);
        }
        let expected = (5.0 * M * v0 * v0 / (8.0 * K)).powf(0.4);
        // (Read at step ends: the peak may fall up to h/2 from one, ½ δ̈ (h/2)² ≈ 5e-6 of it.)
        assert!((deepest - expected).abs() < 1e-5 * expected, "{deepest} vs {expected}");
        assert!((m.eccentricity_rate[1] - v0).abs() < 1e-6 * v0, "rebound {}", m.eccentricity_rate[1]);
        assert_eq!(m.eccentricity[0], 0.0, "no turn");
        let counts: Vec<usize> = m.impacts.iter().map(Vec::len).collect();
        assert_eq!(counts, [0, 0, 1, 1], "one impact at each bottom corner");
    }

    /// Rattling without friction or damping (turning, across the guide, hitting both faces):
    /// kinetic energy ½ ẇᵀ M̃ ẇ plus each penetrating corner's K δ^2.5 / 2.5 stays constant —
    /// the corners' generalized forces are the gradient of that potential only if the tilt's is
    /// their moment about the block's centre.
    #[test]
    fn rattling_without_damping_keeps_its_energy() {
        let mut m = block([0.0, 0.0], [4.0, 0.3]);
        let energy = |m: &InterfaceModel<GuideJoint, 2, 1, 1, 1>| {
            let v = m.eccentricity_rate;
            let kinetic = 0.5 * (v.transpose() * m.inputs.effective_mass * v)[0];
            let elastic: f64 = m.states[0].corners.iter().map(|c| K * c.penetration.max(0.0).powf(2.5) / 2.5).sum();
            kinetic + elastic
        };
        let (h, e0) = (1e-6, energy(&m));
        let mut worst = 0.0f64;
        for i in 0..50_000 {
            m.rk4_step(i as f64 * h, h);
            worst = worst.max((energy(&m) - e0).abs() / e0);
        }
        let impacts: usize = m.impacts.iter().map(Vec::len).sum();
        assert!(impacts >= 10 && m.impacts.iter().all(|i| !i.is_empty()), "impacts at every corner: {impacts}");
        assert!(worst < 1e-6, "energy drift {worst:e}");
    }
}
