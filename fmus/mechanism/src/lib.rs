//! The mechanism around the clearance joint (macro subsystem of the reduced model) as an FMI 3.0
//! co-simulation FMU: scenario A's slider-crank (crank driven at 5000 rpm, clearance joint at the
//! crank pivot made ideal for the motion, one-way coupling). Each communication point exports the
//! effective mass M̃ (2×2), the effective force f̃, the bodies' angular velocities and
//! accelerations, and the propagation maps of the slider acceleration and the motor torque
//! (`slider.acceleration_free`, `slider.acceleration_gain`, `motor.torque_free`, `motor.torque_gain`).

use lash_fmi::fmi3::Exportable;

/// Marker type of the exported model.
pub struct MechanismFmu;

impl Exportable for MechanismFmu {
    type Model = lash_catalog::ExportedMechanism;

    fn info(
        resources: Option<&std::path::Path>,
        model: &Self::Model,
    ) -> Result<lash_fmi::ModelInfo, lash_fmi::fmi3::ExportError> {
        use lash_core::Subsystem;
        Ok(lash_catalog::mechanism_info(&lash_catalog::scenario(resources)?, model.variables()))
    }

    fn create(resources: Option<&std::path::Path>) -> Result<Self::Model, lash_fmi::fmi3::ExportError> {
        Ok(lash_catalog::mechanism(&lash_catalog::scenario(resources)?)?)
    }
}

lash_fmi::export_fmi3!(MechanismFmu);
lash_fmi::export_fmi2!(MechanismFmu);
