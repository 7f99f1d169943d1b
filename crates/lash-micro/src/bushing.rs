//! The bushing as the micro model sees it: a revolute joint made flexible (a bush pressed around a
//! pin, no clearance), whose interface coordinates are the deflection d = p_journal − p_bearing of
//! its two points and whose force on the journal is −F(|d|) d/|d| − c ḋ, F(u) = k u or a radial
//! curve — the same law as the full model's bushing load (`lash_mech::bushing_state`). It is
//! always loaded (no contact to open or close, no friction load), and it starts at rest where it
//! alone holds the interface force (the quasi-static deflection), as the full model starts.

use super::MicroJoint;
use lash_contact::clearance::ContactState;
use lash_contact::joint::Clearance;
use lash_mech::{RadialCurve, Vec2};

/// A bushing of the micro model.
#[derive(Debug, Clone, PartialEq)]
pub struct BushingJoint {
    /// The joint's name.
    pub name: String,
    /// Radial stiffness k [N/m] (the curve's secant at its first point when there is a curve).
    pub stiffness: f64,
    /// Radial damping c [N s/m].
    pub damping: f64,
    /// The radial force as a curve of the deflection (None: linear).
    pub curve: Option<RadialCurve>,
}

impl BushingJoint {
    /// The spring force F(|d|) d/|d| at deflection `d`.
    #[inline(always)]
    fn spring(&self, d: Vec2) -> Vec2 {
        match &self.curve {
            None => d * self.stiffness,
            Some(c) => {
                let u = d.norm();
                if u > 0.0 { d * (c.force(u) / u) } else { Vec2::zeros() }
            }
        }
    }
}

/// A bushing is always loaded: in contact from the start, with nothing to indent.
impl Clearance for BushingJoint {
    const KIND: &'static str = "bushing";
    const RADIUS: &'static str = "journal radius";
    fn name(&self) -> &str {
        &self.name
    }
    /// No journal: the penetration check (0.1 × this radius) holds for any deflection, since a
    /// bushing's penetration is 0.
    fn journal_radius(&self) -> f64 {
        0.0
    }
    #[inline(always)]
    fn radial_clearance(&self) -> f64 {
        0.0
    }
    #[inline(always)]
    fn in_contact(&self) -> bool {
        true
    }
    #[inline(always)]
    fn onset_velocity(&self) -> f64 {
        0.0
    }
    fn set_mode(&mut self, _in_contact: bool, _onset_velocity: f64) {}
}

lash_contact::one_contact!(BushingJoint);

impl MicroJoint for BushingJoint {
    const COORDINATES: usize = 2;
    const FRICTION_LOADS: usize = 1;
    const ROTATIONS: usize = 1;
    type State = ContactState;

    #[inline(always)]
    fn evaluate<const SERIES: bool>(
        &self,
        e: &[f64],
        e_dot: &[f64],
        _wj: &[f64],
        _wb: &[f64],
        _onset: f64,
    ) -> ContactState {
        let (d, d_dot) = (Vec2::new(e[0], e[1]), Vec2::new(e_dot[0], e_dot[1]));
        let force = -(self.spring(d) + d_dot * self.damping);
        let u = d.norm();
        let normal = if u > 0.0 { d / u } else { Vec2::zeros() };
        ContactState {
            journal_centre: d,
            eccentricity: d,
            eccentricity_norm: u,
            normal,
            penetration: 0.0,
            penetration_rate: 0.0,
            slip_velocity: 0.0,
            normal_force: force.norm(),
            friction_force: 0.0,
            force_on_journal: force,
        }
    }
    #[inline(always)]
    fn loads(&self, s: &ContactState, force: &mut [f64], friction: &mut [f64]) {
        force[0] = s.force_on_journal.x;
        force[1] = s.force_on_journal.y;
        friction[0] = 0.0;
    }
    /// At rest (ḋ = 0) the bushing holds `force` (the interface force it must balance) at
    /// d = f/|f| u(|f|): F(|d|) = |f|, the spring pushing the journal back by −f.
    fn rest_under(&self, force: &[f64], e: &mut [f64]) -> bool {
        let f = Vec2::new(force[0], force[1]);
        let d = match &self.curve {
            None => f / self.stiffness,
            Some(c) => {
                let load = f.norm();
                if load > 0.0 { f * (c.deflection(load) / load) } else { Vec2::zeros() }
            }
        };
        e[0] = d.x;
        e[1] = d.y;
        true
    }
    super::joint::planar_state_accessors!();
}
