//! Scenario files of lash (the runners that build and drive their models live in lash-run).
//!
//! * [`schema`]: the TOML format (serde structs, units documented).
//! * [`parse`]: reads a file and returns either a valid [`Scenario`] or every problem, each with
//!   its field path (`bodies[1].mass: must be > 0, got -1`).
//! * [`builtin`]: scenarios A and B (and variants) by name; [`builtin_spatial`]: the spatial
//!   slider-crank E and its variants.
//! * [`spatial`]: spatial scenario files (`space = "spatial"`): schema, validation, channels.
//! * [`channels`](mod@channels): the output channels a scenario offers (names, units, what they sample).
//! * [`WithParameters`], [`paths`]: a scenario edited by named parameters or field paths.

pub mod builtin;
pub mod builtin_spatial;
pub mod channels;
mod format;
mod load;
pub mod parameters;
pub mod paths;
pub mod schema;
pub mod spatial;

pub use channels::{Channel, channel_names, channels};
pub use load::{
    AnyScenario, LoadError, any_by_name_or_file, by_name_or_file, parse, parse_any, parse_any_table, parse_table,
    read_any, read_file, validate,
};
pub use parameters::WithParameters;
pub use schema::Scenario;
pub use spatial::{SpatialScenario, parse_spatial, parse_spatial_table, validate_spatial};
