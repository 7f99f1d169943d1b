//! The full model of scenario A as an FMI 3.0 and 2.0 co-simulation FMU: the slider-crank with
//! its clearance joint integrated as one stiff system (DOP853 with event location, rtol 1e-9)
//! between communication points. Every channel `lash run A` writes is an output (slider
//! kinematics, contact force and eccentricity, motor torque, joint reactions); the scenario's
//! numbers (link data, masses, inertias, driver speed, radii, contact and friction coefficients)
//! are FMI parameters.

use lash_fmi::fmi3::Exportable;

/// Marker type of the exported model.
pub struct FullModelFmu;

impl Exportable for FullModelFmu {
    type Model = lash_catalog::ExportedFullModel;

    fn info(
        resources: Option<&std::path::Path>,
        model: &Self::Model,
    ) -> Result<lash_fmi::ModelInfo, lash_fmi::fmi3::ExportError> {
        use lash_core::Subsystem;
        Ok(lash_catalog::full_info(&lash_catalog::scenario(resources)?, model.variables()))
    }

    fn create(resources: Option<&std::path::Path>) -> Result<Self::Model, lash_fmi::fmi3::ExportError> {
        Ok(lash_catalog::full(&lash_catalog::scenario(resources)?)?)
    }
}

lash_fmi::export_fmi3!(FullModelFmu);
lash_fmi::export_fmi2!(FullModelFmu);
