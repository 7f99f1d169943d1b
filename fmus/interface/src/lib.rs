//! The clearance interface (micro subsystem of the reduced model) as an FMI 3.0 co-simulation FMU.
//!
//! The joint is scenario A's crank-pivot clearance (R_B = 10 mm, c = 100 µm, steel,
//! Lankarani–Nikravesh c_e = 0.9, Ambrósio friction μ = 0.01) with RK4 at h_r = 1e-5 s inside each
//! communication step. Inputs: effective mass and force with their rates, the bodies' angular
//! velocities; outputs: contact force, impulse, eccentricity, penetration, … (the variable table of
//! [`InterfaceSubsystem`]). Exposing the joint's parameters as FMI parameters is the next step.

use lash_contact::micro::{InterfaceSubsystem, MicroIntegrator};
use lash_core::{Subsystem, SubsystemError, Ticks};
use lash_fmi::{ModelInfo, fmi3::Exportable, instantiation_token};

/// The exported model: a newtype so that the FMU crate owns the `Exportable` impl.
pub struct InterfaceFmu(pub InterfaceSubsystem);

/// Model identifier (the shared library is `lib{MODEL_IDENTIFIER}.so` before packaging).
pub const MODEL_IDENTIFIER: &str = "lash_interface";

fn subsystem() -> Result<InterfaceSubsystem, String> {
    let a = lash_scenario::builtin::by_name("A").ok_or("built-in scenario A is missing")?;
    let joint = lash_scenario::build_model(&a, lash_scenario::BuildOptions::default()).clearances[0].clone();
    InterfaceSubsystem::new(joint, MicroIntegrator::Rk4 { step: 1e-5 }).map_err(|e| e.to_string())
}

impl Exportable for InterfaceFmu {
    fn info() -> ModelInfo {
        let vars = subsystem().map(|s| s.variables().to_vec()).unwrap_or_default();
        ModelInfo {
            model_name: "lash clearance interface".into(),
            model_identifier: MODEL_IDENTIFIER.into(),
            instantiation_token: instantiation_token("lash clearance interface", &vars),
            description: "Micro subsystem of lash's reduced interface model: M~ w'' = f~ + f_c(e, e') for a \
                          revolute clearance joint (scenario A's crank pivot), RK4 at 1e-5 s"
                .into(),
            default_experiment: (0.0, 0.01, 1e-5),
        }
    }

    fn create(_resources: Option<&std::path::Path>) -> Result<Self, String> {
        subsystem().map(InterfaceFmu)
    }
}

impl Subsystem for InterfaceFmu {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn variables(&self) -> &[lash_core::Variable] {
        self.0.variables()
    }
    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.0.setup(start, stop)
    }
    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.0.initialize()
    }
    fn set_f64(&mut self, refs: &[u32], values: &[f64]) -> Result<(), SubsystemError> {
        self.0.set_f64(refs, values)
    }
    fn get_f64(&self, refs: &[u32], values: &mut [f64]) -> Result<(), SubsystemError> {
        self.0.get_f64(refs, values)
    }
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<lash_core::StepOutcome, SubsystemError> {
        self.0.do_step(t, h)
    }
    fn time(&self) -> Ticks {
        self.0.time()
    }
    fn save_state(&self) -> Result<lash_core::SavedState, SubsystemError> {
        self.0.save_state()
    }
    fn restore_state(&mut self, state: &lash_core::SavedState) -> Result<(), SubsystemError> {
        self.0.restore_state(state)
    }
}

/// The FMU's `modelDescription.xml`.
pub fn model_description() -> String {
    let vars = subsystem().map(|s| s.variables().to_vec()).unwrap_or_default();
    lash_fmi::description::fmi3(&InterfaceFmu::info(), &vars)
}

lash_fmi::export_fmi3!(InterfaceFmu);
