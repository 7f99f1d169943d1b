//! What every clearance joint is, whatever its shape: a named joint with a journal radius and a
//! clearance, whose contact is open or closed (with the approach velocity its contact began at).
//! The planar revolute joint ([`ClearanceJoint`]) and the spherical one ([`SphericalClearance`])
//! are clearance joints; so, for the micro model, is the flexible bushing (always loaded). The
//! full models' impact log (lash-full-model's `ImpactLog`) and the micro model
//! (lash-micro's `MicroJoint`) speak to a joint through this trait.

use crate::clearance::{ClearanceJoint, PenetrationError};
use crate::spherical::SphericalClearance;

/// A clearance joint's name, size and contact mode.
pub trait Clearance {
    /// What kind of joint, in messages ("clearance joint", "spherical clearance joint").
    const KIND: &'static str;
    /// The radius the blow-up limit refers to, in messages ("journal radius", "ball radius").
    const RADIUS: &'static str;
    /// Name used in outputs and errors.
    fn name(&self) -> &str;
    /// Journal (ball) radius R_J \[m\].
    fn journal_radius(&self) -> f64;
    /// Radial clearance c \[m\].
    fn radial_clearance(&self) -> f64;
    /// Discrete state: contact closed.
    fn in_contact(&self) -> bool;
    /// Approach velocity δ̇⁻ of the current contact \[m/s\].
    fn onset_velocity(&self) -> f64;
    /// Sets the discrete state.
    fn set_mode(&mut self, in_contact: bool, onset_velocity: f64);
    /// The blow-up error of this joint at `penetration` (NaN: the state is no longer finite),
    /// blamed on `step` ("step", "the micro model's step").
    fn penetration_error(&self, penetration: f64, step: &'static str) -> PenetrationError {
        PenetrationError { joint: self.name().to_string(), penetration, kind: Self::KIND, radius: Self::RADIUS, step }
    }
}

/// [`Clearance`] of a joint type that holds its name, radii and mode as fields.
macro_rules! clearance_of_fields {
    ($joint:ty, $kind:literal, $radius:literal) => {
        impl Clearance for $joint {
            const KIND: &'static str = $kind;
            const RADIUS: &'static str = $radius;
            fn name(&self) -> &str {
                &self.name
            }
            fn journal_radius(&self) -> f64 {
                self.journal_radius
            }
            #[inline(always)]
            fn radial_clearance(&self) -> f64 {
                <$joint>::radial_clearance(self)
            }
            #[inline(always)]
            fn in_contact(&self) -> bool {
                self.in_contact
            }
            #[inline(always)]
            fn onset_velocity(&self) -> f64 {
                self.onset_velocity
            }
            fn set_mode(&mut self, in_contact: bool, onset_velocity: f64) {
                self.in_contact = in_contact;
                self.onset_velocity = onset_velocity;
            }
        }
    };
}

clearance_of_fields!(ClearanceJoint, "clearance joint", "journal radius");
clearance_of_fields!(SphericalClearance, "spherical clearance joint", "ball radius");
