//! Contact mechanics of lash: normal contact laws, friction laws, and the clearance joints —
//! planar revolute, translational (a block in a guide) and spatial spherical — that the full
//! models (lash-full-model) and the micro interface model evaluate.
//!
//! Sign conventions (docs/theory.md): eccentricity e = r_J − r_B (journal centre minus bearing
//! centre), penetration δ = |e| − c, normal n = e/|e|, tangent t = ⊥n, penetration rate δ̇ = ė·n,
//! slip v_t = ė·t + ω_J R_J − ω_B R_B; the force on the journal is f_J = −F_N n − F_T t, applied at
//! P_J = r_J + R_J n; the bearing receives −f_J at P_B = r_B + R_B n.

pub mod clearance;
pub mod film;
pub mod friction;
pub mod joint;
pub mod law;
pub mod parameters;
pub mod spherical;
pub mod translational;

pub use clearance::{ClearanceJoint, ContactState, Impact, PenetrationError};
pub use film::{BearingLength, Film};
pub use friction::FrictionLaw;
pub use joint::{Clearance, ContactModes, ContactNumbers, JointContacts};
pub use law::{ContactLaw, Material, NormalForce, hertz_stiffness, step_of};
pub use parameters::ClearanceDefinition;
pub use spherical::{SphericalClearance, SphericalContactState};
pub use translational::{Block, CornerState, Guide, SlotState, TranslationalClearance};
