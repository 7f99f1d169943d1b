//! The clearance interface (micro subsystem of the reduced model) as an FMI 3.0 co-simulation FMU.
//!
//! The joint is scenario A's crank-pivot clearance (R_B = 10 mm, c = 100 µm, steel,
//! Lankarani–Nikravesh c_e = 0.9, Ambrósio friction μ = 0.01) with RK4 at h_r = 1e-5 s inside each
//! communication step. Inputs: effective mass and force with their rates, the bodies' angular
//! velocities; outputs: contact force, impulse, eccentricity, penetration, … (the variable table of
//! [`InterfaceSubsystem`](lash_micro::InterfaceSubsystem)); parameters: the joint's radii and law coefficients, named like the
//! scenario file (`journal_radius`, `contact.restitution`, `friction.coefficient`, …), settable
//! before initialization.

use lash_fmi::fmi3::Exportable;

/// Marker type of the exported model.
pub struct InterfaceFmu;

impl Exportable for InterfaceFmu {
    type Model = lash_micro::InterfaceSubsystem;

    fn info(
        resources: Option<&std::path::Path>,
        model: &Self::Model,
    ) -> Result<lash_fmi::ModelInfo, lash_fmi::fmi3::ExportError> {
        use lash_core::Subsystem;
        Ok(lash_catalog::interface_info(&lash_catalog::scenario(resources)?, model.variables()))
    }

    fn create(resources: Option<&std::path::Path>) -> Result<Self::Model, lash_fmi::fmi3::ExportError> {
        Ok(lash_catalog::interface(&lash_catalog::scenario(resources)?)?)
    }
}

lash_fmi::export_fmi3!(InterfaceFmu);
lash_fmi::export_fmi2!(InterfaceFmu);
