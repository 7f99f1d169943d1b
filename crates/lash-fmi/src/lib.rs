//! The FMI layer of lash: FMI 3.0 and FMI 2.0 co-simulation export from one code path, and FMI 3.0
//! and 2.0 co-simulation import.
//!
//! * [`description`]: `modelDescription.xml` generated from any [`Subsystem`](lash_core::Subsystem)'s
//!   variable table.
//! * [`fmi3`]: the complete set of `fmi3Functions.h` symbols for any [`fmi3::Exportable`] model,
//!   written into an FMU's cdylib by [`export_fmi3!`]. Every function checks its pointers and the
//!   instance's state, catches panics, and reports errors through the importer's logger.
//! * [`fmi2`]: the `fmi2Functions.h` symbols ([`export_fmi2!`]) over the same instances; arrays
//!   become one scalar per element.
//! * [`archive`]: an FMU archive unpacked as untrusted input (confined, sized, streamed).
//! * [`import`]: any FMI 3.0 or 2.0 co-simulation FMU as a `Subsystem` (cached unpacking, lenient
//!   description parsing, a typed function table loaded with libloading; FMI 2.0 array scalars
//!   regrouped).
//!
//! This crate knows nothing of clearances: the physics crates implement `Subsystem`, an FMU crate
//! under `fmus/` implements [`fmi3::Exportable`] and calls the macro.

pub mod archive;
pub mod description;
pub mod fmi2;
pub mod fmi3;
pub mod import;
pub mod isolate;

pub use description::{ModelInfo, instantiation_token};
