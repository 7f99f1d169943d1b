//! What is estimated: a scenario, the measurement chain that observes it and the priors of the
//! unknowns. A setup is a TOML file (`lash estimate prepare my-setup.toml`) or a built-in
//! ([`builtin`]: `A`, `C`).

use crate::EstimateError;
use lash_scenario::AnyScenario;
use serde::{Deserialize, Serialize};

/// One measured channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorChannel {
    /// Channel name, as `lash run` names it (`slider.ax`) and as the measured file's column.
    pub name: String,
    /// Its SI unit (`m/s^2`).
    pub unit: String,
}

/// A nuisance parameter: a numeric field of the scenario the user does not know exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nuisance {
    /// Name in the results (`restitution`).
    pub name: String,
    /// Scenario path (`clearances[0].contact.restitution`).
    pub path: String,
    /// Prior: uniform from `low` to `high`.
    pub low: f64,
    /// Upper end of the prior.
    pub high: f64,
}

/// A setup: the scenario, its measurement chain and the priors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Setup {
    /// Name of the setup.
    pub name: String,
    /// What it estimates, in a sentence.
    pub description: String,
    /// Built-in scenario name or scenario file: the nominal mechanism.
    pub base: String,
    /// The measured channels (the first is the reference for the gain-free features).
    pub channels: Vec<SensorChannel>,
    /// Logger sample rate \[Hz\].
    pub sample_rate: f64,
    /// Anti-alias low-pass cut-off of the logger \[Hz\] (4th-order Butterworth).
    pub anti_alias: f64,
    /// Simulated time dropped at each run's start (the journal starts centred) \[s\].
    pub settle: f64,
    /// Read the crank orders in each channel's envelope, not in its own lines: a housing
    /// accelerometer on a soft mount passes a few per mille of the low orders and rings at its
    /// resonance after each impact (docs/theory.md §10).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub envelope: bool,
    /// Length of measurement the estimate uses \[s\] (a longer file: its first `window` seconds).
    pub window: f64,
    /// Prior of a worn joint's radial clearance, uniform \[m\]: `[low, high]`.
    pub clearance: [f64; 2],
    /// With several clearance joints, one is worn (each equally likely) and the others are
    /// healthy, their clearance uniform in this range \[m\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub healthy: Option<[f64; 2]>,
    /// Crank speed prior: nominal × (1 ± `speed_band`), uniform.
    pub speed_band: f64,
    /// Other parameters the user does not know exactly.
    #[serde(default)]
    pub nuisance: Vec<Nuisance>,
    /// Sensor gain prior: 1 ± `gain_error`, uniform.
    pub gain_error: f64,
    /// Signal-to-noise ratio prior \[dB\], uniform (white noise over the logged band).
    pub snr_db: [f64; 2],
    /// Macro step of the bank's reduced-model runs \[s\]. The default
    /// 1e-3 s interpolates the macro terms linearly over 30° of crank at 5000 rpm, which damps the
    /// low crank orders of the sensor signal by 2–9 % and puts kinks at the macro rate into its
    /// spectrum; 2e-4 s follows the converged full model's orders and impact counts.
    pub macro_step: f64,
    /// Micro step of the bank's reduced-model runs \[s\] (it must divide the scenario's output
    /// interval).
    pub micro_step: f64,
    /// Reduced-model runs of the preparation's bank.
    pub bank_runs: u64,
    /// Measurements emulated per bank run (fresh gain and noise each).
    pub measurements_per_run: u64,
    /// Full-model runs of the preparation's calibration.
    pub calibration_runs: u64,
    /// Full-model cases on which the hidden signals' bands are calibrated (0: none).
    #[serde(default = "default_hidden_runs")]
    pub hidden_calibration_runs: u64,
    /// Bank draws kept as the posterior sample of an estimate.
    pub neighbours: usize,
    /// Seed of the preparation (the validation's seeds are derived apart from it).
    pub seed: u64,
}

fn default_hidden_runs() -> u64 {
    60
}

/// The built-in setups.
pub const NAMES: [&str; 3] = ["A", "C", "E"];

/// A built-in setup by name.
pub fn builtin(name: &str) -> Option<Setup> {
    let chain = |name: &str, description: &str| Setup {
        name: name.into(),
        description: description.into(),
        base: name.into(),
        channels: vec![SensorChannel { name: "slider.ax".into(), unit: "m/s^2".into() }],
        sample_rate: 10_000.0,
        anti_alias: 4_000.0,
        settle: 0.1,
        envelope: false,
        window: 1.0,
        clearance: [50e-6, 300e-6],
        healthy: None,
        speed_band: 0.1,
        nuisance: vec![
            Nuisance {
                name: "restitution".into(),
                path: "clearances[0].contact.restitution".into(),
                low: 0.5,
                high: 0.95,
            },
            Nuisance {
                name: "friction".into(),
                path: "clearances[0].friction.coefficient".into(),
                low: 0.0,
                high: 0.1,
            },
        ],
        gain_error: 0.05,
        snr_db: [30.0, 60.0],
        macro_step: 2e-4,
        micro_step: 1e-5,
        bank_runs: 3000,
        measurements_per_run: 3,
        calibration_runs: 300,
        hidden_calibration_runs: default_hidden_runs(),
        neighbours: 150,
        seed: 1,
    };
    match name {
        "A" => Some(chain(
            "A",
            "Scenario A (one planar clearance joint, crank–ground): its radial clearance from the slider's accelerometer at 10 kHz",
        )),
        "C" => {
            let mut s = chain(
                "C",
                "Scenario C (two planar clearance joints): which one is worn and its clearance, from the slider's accelerometer at 10 kHz",
            );
            s.healthy = Some([10e-6, 30e-6]);
            // The slider's pin (60 g) in the rod's eye makes contacts too short for 1e-5 s: the
            // reduced model blows up within a second at it.
            s.micro_step = 5e-6;
            s.calibration_runs = 240;
            s.nuisance.push(Nuisance {
                name: "restitution_2".into(),
                path: "clearances[1].contact.restitution".into(),
                low: 0.5,
                high: 0.95,
            });
            Some(s)
        }
        "E" => Some(spatial_housing(chain(
            "E",
            "Scenario E (spatial, two spherical clearance joints): which one is worn and its clearance, from the guide housing's accelerometer at 500 Hz",
        ))),
        _ => None,
    }
}

/// Scenario E from the planar setups' `chain`: the spatial slider-crank's two spherical clearance
/// joints, seen by the housing accelerometer of the guide (its mount's natural frequency and
/// damping unknown within ±30 %), logged at 500 Hz behind a 200 Hz anti-alias filter as in the
/// spatial vibration study.
fn spatial_housing(chain: Setup) -> Setup {
    let nuisance =
        |name: &str, path: &str, low: f64, high: f64| Nuisance { name: name.into(), path: path.into(), low, high };
    Setup {
        channels: ["housing.ay", "housing.az"].map(|c| SensorChannel { name: c.into(), unit: "m/s^2".into() }).to_vec(),
        sample_rate: 500.0,
        anti_alias: 200.0,
        // One revolution at 250 rpm: the balls start centred.
        settle: 0.24,
        envelope: true,
        clearance: [100e-6, 600e-6],
        healthy: Some([20e-6, 60e-6]),
        nuisance: vec![
            nuisance("mount_frequency", "output.measurements[0].mount.natural_frequency", 105.0, 195.0),
            nuisance("mount_damping", "output.measurements[0].mount.damping_ratio", 0.035, 0.065),
            nuisance("friction", "clearances[0].friction.dynamic_coefficient", 0.05, 0.15),
            nuisance("friction_2", "clearances[1].friction.dynamic_coefficient", 0.05, 0.15),
        ],
        // 1.5° of crank at 250 rpm: the macro terms' interpolation is no concern here.
        macro_step: 1e-3,
        ..chain
    }
}

/// How an unknown is sampled and reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Scale {
    /// Estimated and reported on a log scale (a clearance: its relative error matters).
    Log,
    /// Linear.
    Linear,
}

/// An unknown of the estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unknown {
    /// Name in the results (`crank_pivot.clearance`, `crank_speed`, `restitution`, `sensor_gain`).
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Scale of the estimate.
    pub scale: Scale,
    /// Prior range.
    pub low: f64,
    /// Upper end of the prior range.
    pub high: f64,
}

/// What a setup resolves to against its scenario: the unknowns and how each run's parameters map
/// to scenario paths.
#[derive(Debug, Clone)]
pub struct Resolved {
    /// The nominal scenario.
    pub scenario: AnyScenario,
    /// Names of the clearance joints.
    pub joints: Vec<String>,
    /// Journal radius of each clearance joint \[m\].
    pub journal_radii: Vec<f64>,
    /// Nominal crank speed \[rad/s\].
    pub speed: f64,
    /// The unknowns: clearances (one per joint), crank speed, the nuisances, sensor gain, SNR
    /// and, with several joints, the worn joint's clearance.
    pub unknowns: Vec<Unknown>,
}

impl Setup {
    /// Every problem of the numbers, with its field.
    pub fn check(&self) -> Result<(), EstimateError> {
        let mut problems = Vec::new();
        let mut positive = |field: &str, v: f64| {
            if !(v > 0.0 && v.is_finite()) {
                problems.push(format!("{field}: must be a positive number, got {v}"));
            }
        };
        positive("sample_rate", self.sample_rate);
        positive("anti_alias", self.anti_alias);
        positive("window", self.window);
        positive("clearance[0]", self.clearance[0]);
        positive("speed_band", self.speed_band);
        positive("macro_step", self.macro_step);
        positive("micro_step", self.micro_step);
        if self.anti_alias >= 0.5 * self.sample_rate {
            problems.push(format!("anti_alias: {} Hz must be below half the sample rate", self.anti_alias));
        }
        if !(self.settle >= 0.0) {
            problems.push(format!("settle: must be ≥ 0, got {}", self.settle));
        }
        let ranges = [("clearance", self.clearance), ("snr_db", self.snr_db)]
            .into_iter()
            .chain(self.healthy.map(|h| ("healthy", h)))
            .chain(self.nuisance.iter().map(|n| ("nuisance", [n.low, n.high])));
        for (field, [low, high]) in ranges {
            if !(low.is_finite() && high.is_finite() && low < high) {
                problems.push(format!("{field}: [{low}, {high}] is not a range (low < high, finite)"));
            }
        }
        if !(self.speed_band < 1.0 && self.gain_error >= 0.0 && self.gain_error < 1.0) {
            problems.push("speed_band, gain_error: must be in [0, 1)".into());
        }
        if self.channels.is_empty() {
            problems.push("channels: give at least one measured channel".into());
        }
        if self.bank_runs < 100 || self.measurements_per_run == 0 || self.neighbours < 10 {
            problems.push("bank_runs ≥ 100, measurements_per_run ≥ 1 and neighbours ≥ 10 are needed".into());
        }
        if self.calibration_runs < 20 {
            problems.push("calibration_runs: at least 20 full-model runs calibrate the intervals".into());
        }
        if problems.is_empty() { Ok(()) } else { Err(EstimateError::Input(problems.join("; "))) }
    }

    /// Reads a setup: a built-in name or a TOML file.
    pub fn load(arg: &str) -> Result<Self, EstimateError> {
        if let Some(s) = builtin(arg) {
            return Ok(s);
        }
        let text = std::fs::read_to_string(arg).map_err(|e| {
            EstimateError::Input(format!(
                "{arg}: not a built-in setup ({}) and not a readable file: {e}",
                NAMES.join(", ")
            ))
        })?;
        let setup: Setup = toml::from_str(&text).map_err(|e| EstimateError::Input(format!("{arg}: {e}")))?;
        setup.check()?;
        Ok(setup)
    }

    /// The setup resolved against its scenario.
    pub fn resolve(&self) -> Result<Resolved, EstimateError> {
        self.check()?;
        let input = |m: String| EstimateError::Input(format!("setup {:?}: {m}", self.name));
        let scenario = lash_scenario::any_by_name_or_file(&self.base).map_err(|e| input(e.to_string()))?;
        let table = toml::Table::try_from(&scenario).map_err(|e| input(e.to_string()))?;
        let clearances = scenario.clearances();
        if clearances.is_empty() {
            return Err(input(format!("scenario {} has no clearance joint to estimate", self.base)));
        }
        if clearances.len() > 1 && self.healthy.is_none() {
            return Err(input("several clearance joints: give `healthy`, the range of the joints not worn".into()));
        }
        let speed = lash_scenario::paths::get_path(&table, "drivers[0].motion.omega")
            .map_err(|e| input(format!("the crank speed drivers[0].motion.omega: {e}")))?;
        for n in &self.nuisance {
            lash_scenario::paths::get_path(&table, &n.path).map_err(|e| input(format!("nuisance {}: {e}", n.name)))?;
        }
        let joints: Vec<String> = clearances.iter().map(|c| c.joint.clone()).collect();
        let journal_radii = clearances.iter().map(|c| c.journal_radius).collect();
        let linear = |name: &str, unit: &str, low: f64, high: f64| Unknown {
            name: name.into(),
            unit: unit.into(),
            scale: Scale::Linear,
            low,
            high,
        };
        let low = self.healthy.map_or(self.clearance[0], |h| h[0].min(self.clearance[0]));
        let mut unknowns: Vec<Unknown> = joints
            .iter()
            .map(|j| Unknown {
                name: format!("{j}.clearance"),
                unit: "m".into(),
                scale: Scale::Log,
                low,
                high: self.clearance[1],
            })
            .collect();
        unknowns.push(linear("crank_speed", "rad/s", speed * (1.0 - self.speed_band), speed * (1.0 + self.speed_band)));
        unknowns.extend(self.nuisance.iter().map(|n| linear(&n.name, "", n.low, n.high)));
        unknowns.push(linear("sensor_gain", "", 1.0 - self.gain_error, 1.0 + self.gain_error));
        unknowns.push(linear("snr", "dB", self.snr_db[0], self.snr_db[1]));
        if joints.len() > 1 {
            // The user's question with several joints: how much play has the worn one, whichever
            // it is (a target of its own: each joint's clearance alone mixes worn and healthy).
            unknowns.push(Unknown {
                name: "worn.clearance".into(),
                unit: "m".into(),
                scale: Scale::Log,
                low: self.clearance[0],
                high: self.clearance[1],
            });
        }
        Ok(Resolved { scenario, joints, journal_radii, speed, unknowns })
    }
}
