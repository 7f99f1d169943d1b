//! The catalogue of exported models: for each FMU, the subsystem it wraps and its FMI identity.
//!
//! The FMU crates under `fmus/` (cdylibs with the C symbols) and `lash fmu pack` (which writes the
//! `modelDescription.xml`) both take the model from here, so the description and the binary are
//! built from the same variable table and carry the same instantiation token. This crate holds no
//! FFI: linking it twice is harmless, unlike the FMU crates' exported symbols.
//!
//! One binary per kind serves every scenario: an archive carries its scenario in
//! `resources/scenario.toml`, from which the instance builds its model (sized by the scenario's
//! clearance joints) and its identity (name, instantiation token).

use lash_core::Subsystem;
use lash_fmi::{ModelInfo, instantiation_token};
use lash_micro::InterfaceSubsystem;
use lash_run::FullSubsystem;
use lash_scenario::parameters::{BuildError, ParameterError, clearance_parameters, mechanism_parameters};
use lash_scenario::{AnyScenario, LoadError, Scenario, WithParameters};
use std::path::Path;

/// Why an exported model could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    /// The built-in default scenario is missing (a build without it).
    #[error("built-in scenario {0} is missing")]
    MissingBuiltin(&'static str),
    /// The FMU's scenario resource could not be read.
    #[error(transparent)]
    Scenario(#[from] LoadError),
    /// The reduced model refuses the scenario (e.g. bushings without clearance).
    #[error("the reduced model of this scenario")]
    Reduced(#[source] lash_run::RunError),
    /// The model's scenario parameters.
    #[error(transparent)]
    Parameters(#[from] ParameterError),
}

/// Where an FMU carries its scenario: `resources/scenario.toml` (written by `lash fmu pack`).
pub const SCENARIO_RESOURCE: &str = "scenario.toml";

/// The scenario of FMUs packed without one: scenario A with the channels the exported mechanism
/// probes (slider acceleration and motor torque).
pub fn default_scenario() -> Result<Scenario, CatalogError> {
    let mut a = lash_scenario::builtin::by_name("A").ok_or(CatalogError::MissingBuiltin("A"))?;
    a.output.channels = vec!["slider.ax".into(), "slider.ay".into(), "motor.torque".into()];
    Ok(a)
}

/// The scenario of an FMU instance: its resources' `scenario.toml` when there is one, else
/// [`default_scenario`] (a plugin loaded straight from its library, an archive of an older lash).
pub fn scenario(resources: Option<&Path>) -> Result<AnyScenario, CatalogError> {
    let Some(file) = resources.map(|r| r.join(SCENARIO_RESOURCE)).filter(|f| f.is_file()) else {
        return default_scenario().map(AnyScenario::Planar);
    };
    Ok(lash_scenario::read_any(&file)?)
}

/// The reduced model's two subsystems of a scenario, planar or spatial: the mechanism (boxed: a
/// planar or a spatial macro subsystem) and the interface of its clearance joints.
fn reduced_subsystems(s: &AnyScenario) -> Result<(Box<dyn Subsystem>, InterfaceSubsystem), lash_run::RunError> {
    let options = lash_run::ReducedOptions::default();
    Ok(match s {
        AnyScenario::Planar(s) => {
            let (m, i) = lash_run::ReducedRun::new(s, options)?.into_subsystems();
            (Box::new(m), i)
        }
        AnyScenario::Spatial(s) => {
            let (m, i) = lash_run::SpatialReducedRun::new(s, options)?.into_subsystems();
            (Box::new(m), i)
        }
    })
}

/// Model identifier of the clearance-interface FMU.
pub const INTERFACE: &str = "lash_interface";
/// Model identifier of the mechanism FMU.
pub const MECHANISM: &str = "lash_mechanism";
/// Model identifier of the full-model FMU.
pub const FULL: &str = "lash_full";

/// The exported mechanism: the macro subsystem (planar or spatial) with the scenario's link data,
/// masses, inertias, drivers and gravity as FMI parameters.
pub type ExportedMechanism = WithParameters<Box<dyn Subsystem>>;
/// The exported full model: the scenario's mechanism with its clearance joints, all its numbers
/// as FMI parameters.
pub type ExportedFullModel = WithParameters<FullSubsystem>;

/// The clearance interface (micro subsystem) of the scenario's clearance joints, sized by them
/// (n = 2 per planar revolute joint, 3 per spherical joint), RK4 at the scenario's micro step.
pub fn interface(s: &AnyScenario) -> Result<InterfaceSubsystem, CatalogError> {
    reduced_subsystems(s).map(|x| x.1).map_err(CatalogError::Reduced)
}

/// The scenario's mechanism with ideal joints (macro subsystem, one-way), probing the scenario's
/// output channels, its numbers as parameters.
pub fn mechanism(s: &AnyScenario) -> Result<ExportedMechanism, CatalogError> {
    let build = |s: &AnyScenario| reduced_subsystems(s).map(|x| x.0).map_err(BuildError::from);
    Ok(WithParameters::new(s, mechanism_parameters(s)?, build)?)
}

/// The scenario's full model (its integrator settings) with every channel as an output and the
/// mechanism's and the clearance joints' numbers as parameters.
pub fn full(s: &AnyScenario) -> Result<ExportedFullModel, CatalogError> {
    let mut parameters = mechanism_parameters(s)?;
    parameters.extend(clearance_parameters(s)?);
    Ok(WithParameters::new(s, parameters, |s| Ok(FullSubsystem::new(s)))?)
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

/// "scenario A's crank_pivot" / "scenario C's crank_pivot and rod_slider".
fn joints_of(s: &AnyScenario) -> String {
    let guides = match s {
        AnyScenario::Planar(p) => p.guides.iter().map(|g| g.joint.as_str()).collect(),
        AnyScenario::Spatial(_) => Vec::new(),
    };
    let names: Vec<&str> = s.clearances().iter().map(|c| c.joint.as_str()).chain(guides).collect();
    let list = match names.as_slice() {
        [] => "no joint".to_string(),
        [one] => one.to_string(),
        [head @ .., last] => format!("{} and {last}", head.join(", ")),
    };
    format!("scenario {}'s {list}", s.name())
}

/// FMI identity of the interface FMU of `s` (its variables are `vars`).
pub fn interface_info(s: &AnyScenario, vars: &[lash_core::Variable]) -> ModelInfo {
    let (kind, per_joint) = match s {
        AnyScenario::Planar(p) if !p.guides.is_empty() => ("translational", 2),
        AnyScenario::Planar(_) => ("revolute", 2),
        AnyScenario::Spatial(_) => ("spherical", 3),
    };
    info(
        &format!("lash clearance interface ({})", s.name()),
        INTERFACE,
        &format!(
            "Micro subsystem of lash's reduced interface model: M~ w'' = f~ + f_c(w, w') + H L for the {kind} \
             clearance joints {} ({} coordinates), RK4 at the micro step",
            joints_of(s),
            per_joint * s.interface_count()
        ),
        vars,
        s.simulation().horizon.min(0.01),
        1e-5,
    )
}

/// FMI identity of the mechanism FMU of `s`.
pub fn mechanism_info(s: &AnyScenario, vars: &[lash_core::Variable]) -> ModelInfo {
    info(
        &format!("lash mechanism ({})", s.name()),
        MECHANISM,
        &format!(
            "Macro subsystem of lash's reduced interface model: scenario {}'s mechanism (ideal motion), exporting \
             M~, f~ and the propagation maps of {} at each communication point",
            s.name(),
            joints_of(s)
        ),
        vars,
        s.simulation().horizon,
        1e-3,
    )
}

/// FMI identity of the full-model FMU of `s`.
pub fn full_info(s: &AnyScenario, vars: &[lash_core::Variable]) -> ModelInfo {
    info(
        &format!("lash full model ({})", s.name()),
        FULL,
        &format!(
            "Scenario {}'s mechanism with its clearance joints integrated as one stiff system: every channel of \
             `lash run` as an output, link data and clearance laws as parameters",
            s.name()
        ),
        vars,
        s.simulation().horizon,
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

/// Why the reduced model's two FMUs (mechanism, interface) cannot be made for `s`, if they cannot
/// (a scenario the reduced model refuses, e.g. bushings without clearance): its full-model FMU
/// is still exported.
pub fn reduced_refusal(s: &AnyScenario) -> Option<lash_run::RunError> {
    reduced_subsystems(s).err()
}

/// `(model identifier, version, modelDescription.xml)` of every exported FMU of `s`, in both
/// versions: the interface, the mechanism and the full model, or the full model alone when
/// [`reduced_refusal`] says why the other two cannot be made.
pub fn descriptions(s: &AnyScenario) -> Result<Vec<(&'static str, FmiVersion, String)>, CatalogError> {
    use lash_fmi::description::{fmi2, fmi3};
    let f = full(s)?;
    let mut reduced = None;
    if reduced_refusal(s).is_none() {
        reduced = Some((interface(s)?, mechanism(s)?));
    }
    let mut infos = Vec::with_capacity(3);
    if let Some((i, m)) = &reduced {
        infos.push((INTERFACE, interface_info(s, i.variables()), i.variables()));
        infos.push((MECHANISM, mechanism_info(s, m.variables()), m.variables()));
    }
    infos.push((FULL, full_info(s, f.variables()), f.variables()));
    let mut out = Vec::with_capacity(6);
    for (version, write) in
        [(FmiVersion::V3, fmi3 as fn(&ModelInfo, &[lash_core::Variable]) -> String), (FmiVersion::V2, fmi2)]
    {
        for (identifier, info, vars) in &infos {
            out.push((*identifier, version, write(info, vars)));
        }
    }
    Ok(out)
}
