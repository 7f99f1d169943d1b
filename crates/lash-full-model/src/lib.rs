//! The full (monolithic) models of lash: a planar or spatial mechanism with its clearance joints
//! integrated as one stiff system, contacts switched at located events — the reference the
//! reduced model is measured against.
//!
//! [`FullModel`] holds a planar mechanism with revolute clearance joints and translational ones
//! (a block in a guide); [`SpatialFullModel`] a spatial mechanism with spherical clearance joints.
//! Both are [`lash_ode::OdeSystem`]s whose impacts and blow-up checks go through one
//! [`impact_log::ImpactLog`]. The joints and laws they evaluate are lash-contact's.

mod contacts;
pub mod full_model;
pub mod impact_log;
pub mod spatial_model;

pub use full_model::{FullModel, ModelError};
pub use spatial_model::{SpatialFullModel, SpatialFullModelState};
