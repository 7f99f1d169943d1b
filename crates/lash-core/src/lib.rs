//! Core vocabulary shared by every lash crate: exact integer time ([`Ticks`]) and validation
//! problems that name the field they concern ([`Problem`], [`Problems`]).
//!
//! No physics and no FFI live here.

mod problems;
mod time;

pub use problems::{Problem, Problems};
pub use time::{Ticks, TicksError};
