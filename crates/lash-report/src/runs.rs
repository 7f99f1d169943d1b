//! The folders a report reads: one run (`lash run --out`: `timeseries.csv` or `.parquet`,
//! `summary.json`, `scenario.toml`) or a comparison (`lash compare --out`: `comparison.json` and
//! the runs `full/`, `reduced/`, `ideal/`).

use crate::ReportError;
use lash_scenario::AnyScenario;
use std::path::{Path, PathBuf};

/// The runs of a comparison a report overlays, in drawing order (the full model's fixed-step run
/// is a timing reference and is left out).
pub const COMPARED: [&str; 3] = ["full", "reduced", "ideal"];

/// One run read back.
#[derive(Debug, Clone)]
pub struct Run {
    /// `full`, `reduced`, `ideal` (a comparison's folders), or a single run's model.
    pub label: String,
    /// Its folder.
    pub dir: PathBuf,
    /// Channel names, time first.
    pub names: Vec<String>,
    /// Their units.
    pub units: Vec<String>,
    /// The columns, time first.
    pub columns: Vec<Vec<f64>>,
    /// Its `summary.json`.
    pub summary: serde_json::Value,
}

impl Run {
    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|k| self.columns[k].as_slice())
    }

    /// The sample times \[s\].
    pub fn time(&self) -> &[f64] {
        &self.columns[0]
    }

    fn read(label: &str, dir: &Path) -> Result<Self, ReportError> {
        let input = |m: String| ReportError::Input(format!("{}: {m}", dir.display()));
        let file = ["timeseries.csv", "timeseries.parquet"]
            .iter()
            .map(|f| dir.join(f))
            .find(|p| p.is_file())
            .ok_or_else(|| input("no timeseries.csv or timeseries.parquet".into()))?;
        let (header, columns) = lash_sweep::dataset::read_any_series(&file)?;
        if header.first().is_none_or(|(n, _)| n != "time") {
            return Err(input(format!("{}: the first column is not `time [s]`", file.display())));
        }
        if columns[0].len() < 2 {
            return Err(input(format!("{}: {} samples (a run of at least two)", file.display(), columns[0].len())));
        }
        let summary_path = dir.join("summary.json");
        let text = std::fs::read_to_string(&summary_path)
            .map_err(|e| ReportError::Input(format!("{}: {e}", summary_path.display())))?;
        let summary =
            serde_json::from_str(&text).map_err(|e| ReportError::Input(format!("{}: {e}", summary_path.display())))?;
        let (names, units) = header.into_iter().unzip();
        Ok(Self { label: label.to_string(), dir: dir.to_path_buf(), names, units, columns, summary })
    }
}

/// A run's or a comparison's folder, read.
#[derive(Debug, Clone)]
pub struct RunFolder {
    /// The folder.
    pub dir: PathBuf,
    /// The scenario the runs ran (the first run's `scenario.toml`).
    pub scenario: AnyScenario,
    /// The runs, in drawing order.
    pub runs: Vec<Run>,
    /// `comparison.json` of a comparison.
    pub comparison: Option<serde_json::Value>,
}

impl RunFolder {
    /// Reads `dir`; a folder that is neither a run's nor a comparison's is an error saying what
    /// makes one.
    pub fn read(dir: &Path) -> Result<Self, ReportError> {
        let input = |m: String| ReportError::Input(format!("{}: {m}", dir.display()));
        if !dir.is_dir() {
            return Err(input("no such folder".into()));
        }
        let comparison_path = dir.join("comparison.json");
        let (runs, comparison) = if comparison_path.is_file() {
            let text = std::fs::read_to_string(&comparison_path).map_err(|e| input(e.to_string()))?;
            let value: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| input(format!("comparison.json: {e}")))?;
            let mut runs = Vec::new();
            for label in COMPARED {
                let sub = dir.join(label);
                // The ideal run may have failed (a comparison goes on without it).
                if sub.join("summary.json").is_file() {
                    runs.push(Run::read(label, &sub)?);
                }
            }
            (runs, Some(value))
        } else if dir.join("summary.json").is_file() {
            let mut run = Run::read("run", dir)?;
            if let Some(model) = run.summary["model"].as_str() {
                run.label = model.to_string();
            }
            (vec![run], None)
        } else {
            return Err(input(
                "neither a run's folder (summary.json, timeseries.csv: `lash run … --out DIR`) nor a comparison's \
                 (comparison.json: `lash compare … --out DIR`)"
                    .into(),
            ));
        };
        let first = runs.first().ok_or_else(|| input("a comparison without any run's folder".into()))?;
        let scenario =
            lash_scenario::read_any(&first.dir.join("scenario.toml")).map_err(|e| ReportError::Input(e.to_string()))?;
        Ok(Self { dir: dir.to_path_buf(), scenario, runs, comparison })
    }
}
