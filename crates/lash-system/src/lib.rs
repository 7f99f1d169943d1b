//! Coupled systems described in a file and run by a generic co-simulation master.
//!
//! A system names its elements (FMUs, lash plugins, built-in lash subsystems), their parameter
//! values, the connections between outputs and inputs, the communication step and each element's
//! decimation (an element with decimation `d` steps every `d`-th communication point, by `d`
//! communication steps: a multirate system). Two file forms:
//!
//! * lash's TOML ([`spec::SystemSpec`], `lash run system.toml`);
//! * an SSP system structure ([`ssp`]): `.ssd` with its `.ssv` parameter values, as OMSimulator
//!   and libcosim read them, or an `.ssp` archive holding them.
//!
//! [`System::run`] steps the elements in file order (Gauss–Seidel: an element sees the outputs its
//! predecessors computed for the end of the step) or all from the same values (Jacobi), and
//! samples the chosen outputs.

pub mod spec;
pub mod ssp;
mod system;

pub use spec::{
    Algorithm, ConnectionSpec, ElementSource, ElementSpec, InterfaceSpec, OutputSpec, SignalSpec, SystemSpec,
};
pub use system::{RunSummary, System, SystemError};
