//! The micro subsystem of the reduced interface model: the clearance interface alone,
//! `ẅ = a_free(t) + W(t) f_c(e, ė)` (equivalently `M̃ ẅ = f̃ + f_c` with `M̃ = W⁻¹`, `f̃ = M̃ a_free`),
//! integrated with a small fixed RK4 step between two macro nodes.
//!
//! Across a macro step the mobility W, the free interface acceleration a_free and the bodies'
//! angular velocities are interpolated linearly between the two nodes (the macro runs one step
//! ahead: one-way coupling), or held at the first node (zero-order hold, for study only: physics.md
//! §5.1). Interpolating W and a_free rather than M̃ and f̃ needs no 2×2 inversion per stage and stays
//! defined when W is singular. The micro step allocates nothing and factors nothing.

use crate::clearance::{ClearanceJoint, ContactState, Impact, ImpactTracker};
use lash_mech::Vec2;
use nalgebra::Matrix2;

/// The macro subsystem's export at one node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeTerms {
    /// Node time [s].
    pub time: f64,
    /// Mobility W = M̃⁻¹ [1/kg].
    pub mobility: Matrix2<f64>,
    /// Free interface acceleration a_free [m/s²].
    pub free_acceleration: Vec2,
    /// Angular velocity of the journal body [rad/s].
    pub journal_angular_velocity: f64,
    /// Angular velocity of the bearing body [rad/s].
    pub bearing_angular_velocity: f64,
}

/// How the micro subsystem sees the macro terms inside a macro step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Linear between the nodes at both ends of the macro step (the default).
    #[default]
    Linear,
    /// Held at the node at the start of the macro step (produces spurious impacts: for study).
    ZeroOrderHold,
}

/// The clearance interface as a 2-DOF system with state (e, ė).
pub struct InterfaceModel {
    /// Geometry, contact and friction laws (its discrete contact state is used too).
    pub joint: ClearanceJoint,
    /// Interpolation across the macro step.
    pub interpolation: Interpolation,
    /// Eccentricity e [m].
    pub eccentricity: Vec2,
    /// Its rate ė [m/s].
    pub eccentricity_rate: Vec2,
    /// Completed impacts.
    pub impacts: Vec<Impact>,
    open: Option<ImpactTracker>,
}

impl InterfaceModel {
    /// A centred, resting interface.
    pub fn new(joint: ClearanceJoint, interpolation: Interpolation) -> Self {
        Self {
            joint,
            interpolation,
            eccentricity: Vec2::zeros(),
            eccentricity_rate: Vec2::zeros(),
            impacts: Vec::new(),
            open: None,
        }
    }

    /// Contact state at (e, ė) with the bodies' angular velocities, using the current mode.
    #[inline]
    fn contact(&self, e: Vec2, ed: Vec2, wj: f64, wb: f64) -> ContactState {
        let s = self.joint.evaluate_relative(e, ed, wj, wb, self.joint.onset_velocity);
        if !self.joint.in_contact && s.penetration > 0.0 {
            // A stage ahead of the onset: the local approach velocity stands in for δ̇⁻.
            self.joint.evaluate_relative(e, ed, wj, wb, s.penetration_rate.max(0.0))
        } else {
            s
        }
    }

    #[inline]
    fn derivative(&self, a: &NodeTerms, b: &NodeTerms, theta: f64, e: Vec2, ed: Vec2) -> Vec2 {
        let th = match self.interpolation {
            Interpolation::Linear => theta,
            Interpolation::ZeroOrderHold => 0.0,
        };
        let w = a.mobility + (b.mobility - a.mobility) * th;
        let af = a.free_acceleration + (b.free_acceleration - a.free_acceleration) * th;
        let wj = a.journal_angular_velocity + (b.journal_angular_velocity - a.journal_angular_velocity) * th;
        let wb = a.bearing_angular_velocity + (b.bearing_angular_velocity - a.bearing_angular_velocity) * th;
        let s = self.contact(e, ed, wj, wb);
        af + w * s.force_on_journal
    }

    /// One RK4 step of size `h` from `t` inside the macro step `[a.time, b.time]`. Returns the
    /// contact state at the end of the step.
    pub fn step(&mut self, a: &NodeTerms, b: &NodeTerms, t: f64, h: f64) -> ContactState {
        let span = b.time - a.time;
        let th = |t: f64| (t - a.time) / span;
        let (e0, v0) = (self.eccentricity, self.eccentricity_rate);
        let k1v = self.derivative(a, b, th(t), e0, v0);
        let k1e = v0;
        let k2e = v0 + k1v * (0.5 * h);
        let k2v = self.derivative(a, b, th(t + 0.5 * h), e0 + k1e * (0.5 * h), k2e);
        let k3e = v0 + k2v * (0.5 * h);
        let k3v = self.derivative(a, b, th(t + 0.5 * h), e0 + k2e * (0.5 * h), k3e);
        let k4e = v0 + k3v * h;
        let k4v = self.derivative(a, b, th(t + h), e0 + k3e * h, k4e);
        let e1 = e0 + (k1e + (k2e + k3e) * 2.0 + k4e) * (h / 6.0);
        let v1 = v0 + (k1v + (k2v + k3v) * 2.0 + k4v) * (h / 6.0);
        // Mode switches at the step end; the onset is placed by linear interpolation.
        let c = self.joint.radial_clearance();
        let (d0, d1) = (e0.norm() - c, e1.norm() - c);
        let t1 = t + h;
        if !self.joint.in_contact && d1 > 0.0 {
            let frac = if d1 - d0 > 0.0 { (-d0 / (d1 - d0)).clamp(0.0, 1.0) } else { 1.0 };
            let (ec, vc) = (e0 + (e1 - e0) * frac, v0 + (v1 - v0) * frac);
            let rate = vc.dot(&(ec / ec.norm().max(f64::MIN_POSITIVE)));
            self.joint.in_contact = true;
            self.joint.onset_velocity = rate.max(0.0);
            self.open = Some(ImpactTracker::open(t + frac * h, rate));
        } else if self.joint.in_contact && d1 <= 0.0 {
            let frac = if d0 - d1 > 0.0 { (d0 / (d0 - d1)).clamp(0.0, 1.0) } else { 1.0 };
            self.joint.in_contact = false;
            if let Some(tr) = self.open.take() {
                self.impacts.push(tr.close(t + frac * h));
            }
        }
        self.eccentricity = e1;
        self.eccentricity_rate = v1;
        let th1 = match self.interpolation {
            Interpolation::Linear => th(t1),
            Interpolation::ZeroOrderHold => 0.0,
        };
        let wj = a.journal_angular_velocity + (b.journal_angular_velocity - a.journal_angular_velocity) * th1;
        let wb = a.bearing_angular_velocity + (b.bearing_angular_velocity - a.bearing_angular_velocity) * th1;
        let s = self.contact(e1, v1, wj, wb);
        if let Some(tr) = self.open.as_mut() {
            tr.sample(t1, s.normal_force, s.penetration);
        }
        s
    }

    /// Impacts still open (closed at `t` for reporting, exit time NaN).
    pub fn open_impacts(&self, t: f64) -> Vec<Impact> {
        self.open.iter().map(|tr| tr.so_far(t)).collect()
    }
}
