//! The catalogue of exported models: for each FMU, the subsystem it wraps and its FMI identity.
//!
//! The FMU crates under `fmus/` (cdylibs with the C symbols) and `lash fmu pack` (which writes the
//! `modelDescription.xml`) both take the model from here, so the description and the binary are
//! built from the same variable table and carry the same instantiation token. This crate holds no
//! FFI: linking it twice is harmless, unlike the FMU crates' exported symbols.

use lash_contact::micro::InterfaceSubsystem;
use lash_core::Subsystem;
use lash_fmi::{ModelInfo, instantiation_token};
use lash_mech::MechanismSubsystem;
use lash_scenario::parameters::{clearance_parameters, mechanism_parameters};
use lash_scenario::{FullSubsystem, Scenario, WithParameters};

/// Scenario A with the channels the exported mechanism probes.
fn scenario_a() -> Result<Scenario, String> {
    let mut a = lash_scenario::builtin::by_name("A").ok_or("built-in scenario A is missing")?;
    a.output.channels = vec!["slider.ax".into(), "slider.ay".into(), "motor.torque".into()];
    Ok(a)
}

/// The reduced model's two subsystems of a scenario.
fn reduced_subsystems(s: &Scenario) -> Result<(MechanismSubsystem, InterfaceSubsystem), String> {
    let run = lash_scenario::ReducedRun::new(s, lash_scenario::ReducedOptions::default()).map_err(|e| e.to_string())?;
    Ok(run.into_subsystems())
}

/// Scenario A's reduced model, with the probes the exported mechanism carries.
fn scenario_a_subsystems() -> Result<(MechanismSubsystem, InterfaceSubsystem), String> {
    reduced_subsystems(&scenario_a()?)
}

/// Model identifier of the clearance-interface FMU.
pub const INTERFACE: &str = "lash_interface";
/// Model identifier of the mechanism FMU.
pub const MECHANISM: &str = "lash_mechanism";
/// Model identifier of the full-model FMU.
pub const FULL: &str = "lash_full";

/// The exported mechanism: the macro subsystem with scenario A's link data, masses, inertias,
/// driver and gravity as FMI parameters.
pub type ExportedMechanism = WithParameters<MechanismSubsystem>;
/// The exported full model: scenario A's mechanism with its clearance joint, all its numbers as
/// FMI parameters.
pub type ExportedFullModel = WithParameters<FullSubsystem>;

/// The clearance interface (micro subsystem) of scenario A: RK4 at 1e-5 s.
pub fn interface() -> Result<InterfaceSubsystem, String> {
    scenario_a_subsystems().map(|s| s.1)
}

/// The slider-crank of scenario A (macro subsystem, one-way) with the slider and motor probes,
/// its scenario numbers as parameters.
pub fn mechanism() -> Result<ExportedMechanism, String> {
    let a = scenario_a()?;
    WithParameters::new(&a, mechanism_parameters(&a)?, |s| reduced_subsystems(s).map(|x| x.0))
}

/// Scenario A's full model (DOP853, rtol 1e-9) with every channel as an output and the
/// mechanism's and the clearance joint's numbers as parameters.
pub fn full() -> Result<ExportedFullModel, String> {
    let a = lash_scenario::builtin::by_name("A").ok_or("built-in scenario A is missing")?;
    let mut parameters = mechanism_parameters(&a)?;
    parameters.extend(clearance_parameters(&a)?);
    WithParameters::new(&a, parameters, FullSubsystem::new)
}

fn info(
    name: &str,
    identifier: &str,
    description: &str,
    vars: &[lash_core::Variable],
    stop: f64,
    step: f64,
) -> ModelInfo {
    ModelInfo {
        model_name: name.into(),
        model_identifier: identifier.into(),
        instantiation_token: instantiation_token(name, vars),
        description: description.into(),
        default_experiment: (0.0, stop, step),
    }
}

/// FMI identity of the interface FMU.
pub fn interface_info() -> ModelInfo {
    let vars = interface().map(|s| s.variables().to_vec()).unwrap_or_default();
    info(
        "lash clearance interface",
        INTERFACE,
        "Micro subsystem of lash's reduced interface model: M~ w'' = f~ + f_c(e, e') for a revolute clearance \
         joint (scenario A's crank pivot), RK4 at 1e-5 s",
        &vars,
        0.01,
        1e-5,
    )
}

/// FMI identity of the mechanism FMU.
pub fn mechanism_info() -> ModelInfo {
    let vars = mechanism().map(|s| s.variables().to_vec()).unwrap_or_default();
    info(
        "lash slider-crank mechanism",
        MECHANISM,
        "Macro subsystem of lash's reduced interface model: scenario A's slider-crank (ideal motion), exporting \
         M~, f~ and the propagation maps at each communication point",
        &vars,
        0.036,
        1e-3,
    )
}

/// FMI identity of the full-model FMU.
pub fn full_info() -> ModelInfo {
    let vars = full().map(|s| s.variables().to_vec()).unwrap_or_default();
    info(
        "lash full model",
        FULL,
        "Scenario A's slider-crank with its clearance joint integrated as one stiff system (DOP853 with event \
         location, rtol 1e-9): every channel of `lash run A` as an output, link data and clearance law as parameters",
        &vars,
        0.036,
        1e-4,
    )
}

/// FMI version of an archive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmiVersion {
    /// FMI 3.0 (binaries/x86_64-linux).
    V3,
    /// FMI 2.0 (binaries/linux64).
    V2,
}

/// `(model identifier, version, modelDescription.xml)` of every exported FMU, in both versions.
pub fn descriptions() -> Result<Vec<(&'static str, FmiVersion, String)>, String> {
    use lash_fmi::description::{fmi2, fmi3};
    let (i, m, f) = (interface()?, mechanism()?, full()?);
    Ok(vec![
        (INTERFACE, FmiVersion::V3, fmi3(&interface_info(), i.variables())),
        (MECHANISM, FmiVersion::V3, fmi3(&mechanism_info(), m.variables())),
        (FULL, FmiVersion::V3, fmi3(&full_info(), f.variables())),
        (INTERFACE, FmiVersion::V2, fmi2(&interface_info(), i.variables())),
        (MECHANISM, FmiVersion::V2, fmi2(&mechanism_info(), m.variables())),
        (FULL, FmiVersion::V2, fmi2(&full_info(), f.variables())),
    ])
}
