//! One self-contained HTML page of a run or a comparison (`lash report`): the mechanism animated
//! from its bodies' poses, each clearance joint's journal orbit inside its clearance circle, every
//! channel over time and over crank angle (drag to zoom), and amplitude spectra on a log scale;
//! for a comparison the full, reduced and ideal runs overlaid. Data and drawing code are inline:
//! the page opens without network access.
//!
//! The reading of the run folders is [`runs`], the geometry of the animation [`mechanism`], what
//! the plots draw [`figures`], the page itself [`page`].

pub mod figures;
pub mod mechanism;
pub mod page;
pub mod runs;

use std::path::{Path, PathBuf};

pub use runs::{Run, RunFolder};

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The folder is not a run's or a comparison's, or a file in it is unreadable.
    #[error("{0}")]
    Input(String),
    /// A run's time series in the folder cannot be read.
    #[error(transparent)]
    Series(#[from] lash_sweep::dataset::DatasetError),
    /// Writing the page failed.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The page's path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone)]
pub struct Written {
    /// The page.
    pub path: PathBuf,
    /// The runs it shows (`full`, `reduced`, `ideal`, or a single run's model).
    pub runs: Vec<String>,
    /// Its size \[bytes\].
    pub bytes: u64,
    /// What the page could not show, and why (e.g. a run without its bodies' poses).
    pub notes: Vec<String>,
}

/// Writes the report of `dir` (a run's folder, from `lash run --out`, or a comparison's, from
/// `lash compare --out`) to `out` (default `dir/report.html`).
pub fn write_report(dir: &Path, out: Option<&Path>) -> Result<Written, ReportError> {
    let folder = RunFolder::read(dir)?;
    let content = figures::Content::of(&folder);
    let html = page::html(&folder, &content);
    let path = out.map_or_else(|| dir.join("report.html"), Path::to_path_buf);
    std::fs::write(&path, &html).map_err(|source| ReportError::Write { path: path.clone(), source })?;
    Ok(Written {
        path,
        runs: folder.runs.iter().map(|r| r.label.clone()).collect(),
        bytes: html.len() as u64,
        notes: content.notes,
    })
}
