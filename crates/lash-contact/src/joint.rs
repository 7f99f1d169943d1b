//! What every clearance joint is, whatever its shape: a named joint with a journal radius and a
//! clearance, whose contact is open or closed (with the approach velocity its contact began at).
//! The planar revolute joint ([`ClearanceJoint`]) and the spherical one ([`SphericalClearance`])
//! are clearance joints; so, for the micro model, is the flexible bushing (always loaded). The
//! full models' impact log (lash-full-model's `ImpactLog`) and the micro model
//! (lash-micro's `MicroJoint`) speak to a joint through this trait.
//!
//! A joint may hold several contacts, each with its own mode and impacts (a translational joint's
//! four corners): [`JointContacts`] says how many, where each is at its two bodies' poses, and
//! which [`Clearance`] holds each one's mode. The full models' events, impact records and blow-up
//! checks read every joint through it, whatever its shape.

use crate::clearance::{ClearanceJoint, PenetrationError};
use crate::spherical::SphericalClearance;
use crate::translational::{Corner, TranslationalClearance};
use lash_mech::{BodyId, Pose};
use lash_spatial::constraints::BodyFrame;

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

/// One contact's numbers at one state, as events and impact records read them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactNumbers {
    /// The contact's own indentation \[m\], positive when closed: the penetration δ, less the
    /// deflection s of a bush damped in series with the contact.
    pub indentation: f64,
    /// Its rate δ̇ − ṡ [m/s] (positive: approaching).
    pub indentation_rate: f64,
    /// The penetration δ the impact record keeps (a bush's deflection included) \[m\].
    pub penetration: f64,
    /// Normal force F_N \[N\].
    pub normal_force: f64,
}

impl ContactNumbers {
    /// The numbers of a contact with nothing in series: its indentation is its penetration.
    pub fn rigid(penetration: f64, penetration_rate: f64, normal_force: f64) -> Self {
        Self { indentation: penetration, indentation_rate: penetration_rate, penetration, normal_force }
    }
}

/// A clearance joint's contacts, each with its own mode and impacts: how many, and which
/// [`Clearance`] holds each one's mode — what the full models and the micro model switch.
pub trait ContactModes {
    /// What holds one contact's mode.
    type Contact: Clearance;
    /// Contacts of one joint: 1 (a journal in its bearing), 4 (a translational joint's corners).
    const CONTACTS: usize;
    /// Contact `k`'s mode.
    fn contact(&self, k: usize) -> &Self::Contact;
    /// Contact `k`'s mode, to switch.
    fn contact_mut(&mut self, k: usize) -> &mut Self::Contact;
}

/// A clearance joint's contacts where its two bodies are (see the module): each one's
/// [`ContactNumbers`].
pub trait JointContacts: ContactModes {
    /// A body's pose as the joint reads it (planar [`Pose`], spatial [`BodyFrame`]).
    type Frame;
    /// The two bodies the joint connects: the journal's (ball's, block's) first.
    fn bodies(&self) -> [BodyId; 2];
    /// Contact `k`'s numbers with the bodies at `frames` (in [`JointContacts::bodies`] order),
    /// under onset velocity `onset`, with the joint's bush damped in series deflected by
    /// `deflection` (None: no such bush).
    fn contact_numbers(
        &self,
        frames: [&Self::Frame; 2],
        k: usize,
        onset: f64,
        deflection: Option<f64>,
    ) -> ContactNumbers;
}

/// [`ContactModes`] of a joint of one contact whose mode it holds itself (a journal in its
/// bearing, a ball in its socket, a bushing).
#[macro_export]
macro_rules! one_contact {
    ($joint:ty) => {
        impl $crate::joint::ContactModes for $joint {
            type Contact = Self;
            const CONTACTS: usize = 1;
            #[inline(always)]
            fn contact(&self, _k: usize) -> &Self {
                self
            }
            #[inline(always)]
            fn contact_mut(&mut self, _k: usize) -> &mut Self {
                self
            }
        }
    };
}

one_contact!(ClearanceJoint);
one_contact!(SphericalClearance);

/// The items of [`JointContacts`] of a journal (ball) in its bearing.
macro_rules! journal_in_bearing {
    ($frame:ty) => {
        type Frame = $frame;
        fn bodies(&self) -> [BodyId; 2] {
            [self.journal_body, self.bearing_body]
        }
    };
}

impl JointContacts for ClearanceJoint {
    journal_in_bearing!(Pose);
    fn contact_numbers(&self, [pj, pb]: [&Pose; 2], _k: usize, onset: f64, deflection: Option<f64>) -> ContactNumbers {
        let (s, rate) = self.evaluate_with_bush(pj, pb, onset, deflection);
        ContactNumbers {
            indentation: s.penetration - deflection.unwrap_or(0.0),
            indentation_rate: s.penetration_rate - rate,
            penetration: s.penetration,
            normal_force: s.normal_force,
        }
    }
}

impl ContactModes for TranslationalClearance {
    type Contact = Corner;
    const CONTACTS: usize = 4;
    #[inline(always)]
    fn contact(&self, k: usize) -> &Corner {
        self.corner(k)
    }
    #[inline(always)]
    fn contact_mut(&mut self, k: usize) -> &mut Corner {
        self.corner_mut(k)
    }
}

impl JointContacts for TranslationalClearance {
    type Frame = Pose;
    fn bodies(&self) -> [BodyId; 2] {
        [self.block.body, self.guide.body]
    }
    /// (A translational joint has no bush: `deflection` is not read.)
    fn contact_numbers(&self, [pb, pg]: [&Pose; 2], k: usize, onset: f64, _deflection: Option<f64>) -> ContactNumbers {
        let s = self.evaluate_corner(pb, pg, k, onset);
        ContactNumbers::rigid(s.penetration, s.penetration_rate, s.normal_force)
    }
}

impl JointContacts for SphericalClearance {
    journal_in_bearing!(BodyFrame);
    /// (A spherical joint has no bush: `deflection` is not read.)
    fn contact_numbers(
        &self,
        [fj, fb]: [&BodyFrame; 2],
        _k: usize,
        onset: f64,
        _deflection: Option<f64>,
    ) -> ContactNumbers {
        let s = self.evaluate(fj, fb, onset);
        ContactNumbers::rigid(s.penetration, s.penetration_rate, s.normal_force)
    }
}
