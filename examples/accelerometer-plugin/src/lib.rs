//! An example lash plugin: an accelerometer model in a user's own crate.
//!
//! The sensor is a second-order system driven by the true acceleration `a` (input
//! `acceleration`):
//!
//! ```text
//! ÿ = ω_n² (a − y) − 2 ζ ω_n ẏ,        measured = sensitivity · y + bias
//! ```
//!
//! with the natural frequency `f_n = ω_n / 2π` and the damping ratio `ζ < 1` as parameters. The
//! input is held over each step (zero-order hold, as a co-simulation master delivers it) and the
//! step is exact: the homogeneous solution of the deviation `z = y − a`,
//!
//! ```text
//! z(h) = e^{−σh} [ z₀ cos ω_d h + (ż₀ + σ z₀)/ω_d · sin ω_d h ]
//! ż(h) = e^{−σh} [ ż₀ cos ω_d h − (σ ż₀ + ω_n² z₀)/ω_d · sin ω_d h ],   σ = ζ ω_n, ω_d = ω_n √(1 − ζ²)
//! ```
//!
//! so the result does not depend on the step size. The transition matrix is computed once per
//! step size and reused.
//!
//! Everything lash needs is the [`Subsystem`] implementation and one line,
//! `lash_fmi::export_plugin!(AccelerometerPlugin)`.

use lash_core::subsystem::{Phase, element_count};
use lash_core::{
    Causality, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variability, Variable,
    VariableTable,
};

/// Value references.
pub mod vr {
    use lash_core::ValueReference;
    /// Input: true acceleration [m/s²].
    pub const ACCELERATION: ValueReference = 0;
    /// Output: the sensor's reading [m/s²].
    pub const MEASURED: ValueReference = 1;
    /// Parameter: natural frequency \[Hz\].
    pub const NATURAL_FREQUENCY: ValueReference = 2;
    /// Parameter: damping ratio \[1\].
    pub const DAMPING_RATIO: ValueReference = 3;
    /// Parameter: sensitivity \[1\].
    pub const SENSITIVITY: ValueReference = 4;
    /// Parameter: bias [m/s²].
    pub const BIAS: ValueReference = 5;
}

/// The accelerometer.
#[derive(Clone)]
pub struct Accelerometer {
    variables: Vec<Variable>,
    /// acceleration, measured, natural_frequency, damping_ratio, sensitivity, bias.
    values: [f64; 6],
    /// Sensor deflection y and its rate.
    state: [f64; 2],
    /// Transition matrix for the cached step size.
    transition: Option<(Ticks, [[f64; 2]; 2])>,
    time: Ticks,
    phase: Phase,
}

impl Default for Accelerometer {
    fn default() -> Self {
        Self::new()
    }
}

impl Accelerometer {
    /// A sensor at 2 kHz natural frequency, ζ = 0.6, unit sensitivity, no bias.
    pub fn new() -> Self {
        use Causality::*;
        let mut t = VariableTable::new();
        let c = Variability::Continuous;
        t.add("acceleration", Input, c, "m/s2", "true acceleration at the sensor", &[], &[0.0]);
        t.add("measured", Output, c, "m/s2", "sensor reading", &[], &[0.0]);
        t.add("natural_frequency", Parameter, Variability::Fixed, "Hz", "natural frequency f_n", &[], &[2000.0]);
        t.add("damping_ratio", Parameter, Variability::Fixed, "1", "damping ratio (< 1)", &[], &[0.6]);
        t.add("sensitivity", Parameter, Variability::Fixed, "1", "scale factor", &[], &[1.0]);
        t.add("bias", Parameter, Variability::Fixed, "m/s2", "offset", &[], &[0.0]);
        Self {
            variables: t.into_variables(),
            values: [0.0, 0.0, 2000.0, 0.6, 1.0, 0.0],
            state: [0.0; 2],
            transition: None,
            time: Ticks::ZERO,
            phase: Phase::Instantiated,
        }
    }

    fn measured(&self) -> f64 {
        self.values[4] * self.state[0] + self.values[5]
    }

    /// Transition matrix of (z, ż) over `h` seconds.
    fn transition(&self, h: f64) -> [[f64; 2]; 2] {
        let wn = 2.0 * std::f64::consts::PI * self.values[2];
        let zeta = self.values[3];
        let sigma = zeta * wn;
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let (s, c) = (wd * h).sin_cos();
        let e = (-sigma * h).exp();
        [[e * (c + sigma / wd * s), e * s / wd], [-e * wn * wn / wd * s, e * (c - sigma / wd * s)]]
    }
}

impl Subsystem for Accelerometer {
    fn name(&self) -> &str {
        "accelerometer"
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, _stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.phase.require("setup", &[Phase::Instantiated, Phase::Configured])?;
        self.time = start;
        self.phase = Phase::Configured;
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.phase.require("initialize", &[Phase::Configured])?;
        let bad = |name: &str, problem: String| Err(SubsystemError::BadValue { name: name.into(), problem });
        if !(self.values[2] > 0.0) {
            return bad("natural_frequency", format!("must be > 0, got {}", self.values[2]));
        }
        if !(self.values[3] >= 0.0 && self.values[3] < 1.0) {
            return bad("damping_ratio", format!("must be in [0, 1) (an underdamped sensor), got {}", self.values[3]));
        }
        // At rest and settled on the initial input.
        self.state = [self.values[0], 0.0];
        self.values[1] = self.measured();
        self.phase = Phase::Stepping;
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        if element_count(&self.variables, refs)? != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} references", values.len(), refs.len())));
        }
        for (&r, &v) in refs.iter().zip(values) {
            let name = self.variables[r as usize].name.clone();
            if !v.is_finite() {
                return Err(SubsystemError::BadValue { name, problem: format!("{v} is not finite") });
            }
            match self.variables[r as usize].causality {
                Causality::Output => return Err(SubsystemError::BadValue { name, problem: "is an output".into() }),
                Causality::Parameter if self.phase == Phase::Stepping => {
                    return Err(SubsystemError::BadValue {
                        name,
                        problem: "is a parameter: set it before initialization".into(),
                    });
                }
                _ => self.values[r as usize] = v,
            }
        }
        Ok(())
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        if element_count(&self.variables, refs)? != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} references", values.len(), refs.len())));
        }
        for (v, &r) in values.iter_mut().zip(refs) {
            *v = self.values[r as usize];
        }
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.phase.require("do_step", &[Phase::Stepping])?;
        if t != self.time || h.0 <= 0 {
            return Err(SubsystemError::BadArguments(format!(
                "do_step({} s, {} s) but the sensor is at {} s",
                t.seconds(),
                h.seconds(),
                self.time.seconds()
            )));
        }
        let phi = match self.transition {
            Some((cached, phi)) if cached == h => phi,
            _ => {
                let phi = self.transition(h.seconds());
                self.transition = Some((h, phi));
                phi
            }
        };
        let a = self.values[0];
        let (z, zd) = (self.state[0] - a, self.state[1]);
        self.state = [a + phi[0][0] * z + phi[0][1] * zd, phi[1][0] * z + phi[1][1] * zd];
        self.values[1] = self.measured();
        self.time = Ticks(t.0 + h.0);
        Ok(StepOutcome::Completed)
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new(self.clone())))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let saved = state.0.downcast_ref::<Self>().ok_or_else(|| SubsystemError::Other("not a sensor state".into()))?;
        *self = saved.clone();
        Ok(())
    }
}

/// The plugin's marker type: how lash creates the model and names it.
pub struct AccelerometerPlugin;

impl lash_fmi::fmi3::Exportable for AccelerometerPlugin {
    type Model = Accelerometer;

    fn info(
        _resources: Option<&std::path::Path>,
        model: &Accelerometer,
    ) -> Result<lash_fmi::ModelInfo, lash_fmi::fmi3::ExportError> {
        let vars = model.variables();
        Ok(lash_fmi::ModelInfo {
            model_name: "accelerometer".into(),
            model_identifier: "accelerometer".into(),
            instantiation_token: lash_fmi::instantiation_token("accelerometer", vars),
            description: "second-order accelerometer (example lash plugin)".into(),
            default_experiment: (0.0, 0.01, 1e-5),
        })
    }

    fn create(_resources: Option<&std::path::Path>) -> Result<Accelerometer, lash_fmi::fmi3::ExportError> {
        Ok(Accelerometer::new())
    }
}

lash_fmi::export_plugin!(AccelerometerPlugin);

#[cfg(test)]
mod tests {
    use super::*;

    /// The step response against the closed form of an underdamped second-order system.
    #[test]
    fn step_response_is_the_closed_form_at_any_step_size() {
        for h in [1e-6, 1e-5, 3e-4] {
            let mut s = Accelerometer::new();
            s.setup(Ticks::ZERO, None).unwrap();
            s.initialize().unwrap();
            s.set_f64(&[vr::ACCELERATION], &[9.81]).unwrap();
            let step = Ticks::from_seconds(h).unwrap();
            let mut t = Ticks::ZERO;
            let (wn, zeta) = (2.0 * std::f64::consts::PI * 2000.0, 0.6);
            let wd = wn * (1.0f64 - zeta * zeta).sqrt();
            for _ in 0..(3e-3 / h) as usize {
                assert_eq!(s.do_step(t, step).unwrap(), lash_core::StepOutcome::Completed);
                t = Ticks(t.0 + step.0);
                let x = t.seconds();
                let exact = 9.81
                    * (1.0
                        - (-zeta * wn * x).exp()
                            * ((wd * x).cos() + zeta / (1.0f64 - zeta * zeta).sqrt() * (wd * x).sin()));
                let mut m = [0.0];
                s.get_f64(&[vr::MEASURED], &mut m).unwrap();
                assert!((m[0] - exact).abs() < 1e-9 * 9.81, "h = {h}, t = {x}: {} vs {exact}", m[0]);
            }
        }
    }

    #[test]
    fn an_overdamped_setting_is_refused_naming_the_parameter() {
        let mut s = Accelerometer::new();
        s.setup(Ticks::ZERO, None).unwrap();
        s.set_f64(&[vr::DAMPING_RATIO], &[1.5]).unwrap();
        let e = s.initialize().unwrap_err().to_string();
        assert!(e.contains("damping_ratio"), "{e}");
    }
}
