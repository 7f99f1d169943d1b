//! Limits before work: what a run or a sweep will write to disk and hold in memory, estimated
//! from its file before anything starts, against the free space of the output folder and the
//! memory the machine has available. What cannot fit is refused (exit 2) with the figures and the
//! fields that set them, instead of failing hours later or allocating until the machine gives out.

use crate::CliError;
use std::path::Path;

/// Bytes of one CSV value as `lash run` writes it, at most: a shortest round-trip float
/// (`-1.2345678901234567e-123`, 24 characters) and its separator.
pub const CSV_BYTES_PER_VALUE: u64 = 25;

/// What a job will write and hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Output rows (samples of one run, or of all runs of a sweep).
    pub rows: u64,
    /// Values per row, time included.
    pub columns: u64,
    /// Bytes written to the output folder (an upper bound).
    pub disk_bytes: u64,
    /// Bytes held in memory at once, beyond the model itself.
    pub memory_bytes: u64,
}

/// Samples of a run from 0 to `horizon` every `interval` (both ends included).
pub fn samples(horizon: f64, interval: f64) -> u64 {
    let ratio = horizon / interval;
    // A horizon that is a whole number of intervals up to rounding counts its last sample.
    let n = if (ratio - ratio.round()).abs() <= 1e-9 * ratio { ratio.round() } else { ratio.floor() };
    if n.is_finite() && n >= 0.0 { n as u64 + 1 } else { u64::MAX }
}

/// Bytes a value takes on disk at most in `format` (Parquet: the double, before compression).
pub fn bytes_per_value(format: crate::output::Format) -> u64 {
    match format {
        crate::output::Format::Csv => CSV_BYTES_PER_VALUE,
        crate::output::Format::Parquet => 8,
    }
}

/// `lash run`: rows of `columns` values every `output_interval` over `horizon`, `per_value` bytes
/// each; in memory, the force series of the measurement chains (`measured_forces` of them), kept
/// whole for their filters and spectra.
pub fn run_estimate(
    horizon: f64,
    output_interval: f64,
    columns: usize,
    measured_forces: usize,
    per_value: u64,
) -> Estimate {
    let rows = samples(horizon, output_interval);
    Estimate {
        rows,
        columns: columns as u64,
        disk_bytes: rows.saturating_mul(columns as u64).saturating_mul(per_value),
        memory_bytes: rows.saturating_mul(measured_forces as u64).saturating_mul(8),
    }
}

/// `lash sweep`: `runs` runs whose dataset rows come every `1/sample_rate` over `horizon`, each
/// run's rows held until its part is written (`at_once` runs at once, `channels` values each,
/// doubled with the clean copies; an anti-alias filter streams the simulation's samples, so only
/// the logged rows are held); on disk the parts and the assembled data.parquet (8 bytes a
/// value, uncompressed: an upper bound), and the CSV copy if asked for.
pub fn sweep_estimate(
    runs: u64,
    at_once: u64,
    horizon: f64,
    sample_rate: f64,
    channels: usize,
    clean: bool,
    csv: bool,
) -> Estimate {
    let copies = if clean { 2 } else { 1 };
    let per_run = samples(horizon, 1.0 / sample_rate);
    let columns = (channels * copies) as u64 + 2;
    let rows = runs.saturating_mul(per_run);
    let values = rows.saturating_mul(columns);
    let mut disk = values.saturating_mul(16);
    if csv {
        disk = disk.saturating_add(values.saturating_mul(CSV_BYTES_PER_VALUE));
    }
    Estimate {
        rows,
        columns,
        disk_bytes: disk,
        memory_bytes: per_run
            .saturating_mul((channels * copies) as u64 + 1)
            .saturating_mul(8)
            .saturating_mul(at_once.min(runs).max(1)),
    }
}

/// Human-readable bytes.
pub fn bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e12 {
        format!("{:.1} TB", b / 1e12)
    } else if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.0} kB", (b / 1e3).max(1.0))
    }
}

/// Free space where `out` is or will be (its nearest existing ancestor).
fn free_space(out: &Path) -> Option<u64> {
    let mut at = if out.is_absolute() { out.to_path_buf() } else { std::env::current_dir().ok()?.join(out) };
    while !at.exists() {
        at = at.parent()?.to_path_buf();
    }
    fs4::available_space(&at).ok()
}

/// Memory available to a new allocation (free plus reclaimable caches).
fn available_memory() -> Option<u64> {
    let mut system = sysinfo::System::new_with_specifics(
        sysinfo::RefreshKind::nothing().with_memory(sysinfo::MemoryRefreshKind::nothing().with_ram()),
    );
    system.refresh_memory();
    Some(system.available_memory()).filter(|&m| m > 0)
}

/// Refuses `e` when it cannot fit: more disk than `out` has free, or more memory than is
/// available. `what` names the job, `fix` says which fields to change.
pub fn check(what: &str, e: &Estimate, out: &Path, fix: &str) -> Result<(), CliError> {
    check_against(what, e, out, fix, free_space(out), available_memory())
}

fn check_against(
    what: &str,
    e: &Estimate,
    out: &Path,
    fix: &str,
    free: Option<u64>,
    memory: Option<u64>,
) -> Result<(), CliError> {
    if let Some(free) = free
        && e.disk_bytes > free
    {
        return Err(CliError::Input(format!(
            "{what} would write up to {} ({} rows × {} values) into {}, which has {} free: {fix}",
            bytes(e.disk_bytes),
            e.rows,
            e.columns,
            out.display(),
            bytes(free)
        )));
    }
    if let Some(memory) = memory
        && e.memory_bytes > memory
    {
        return Err(CliError::Input(format!(
            "{what} would hold {} in memory ({} rows), more than the {} available: {fix}",
            bytes(e.memory_bytes),
            e.rows,
            bytes(memory)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_that_cannot_fit_is_refused_with_its_figures() {
        // 1e6 s at 1e-5 s: 1e11 rows of 28 values.
        let e = run_estimate(1e6, 1e-5, 28, 2, CSV_BYTES_PER_VALUE);
        assert_eq!(e.rows, 100_000_000_001);
        assert_eq!(e.disk_bytes, 100_000_000_001 * 28 * CSV_BYTES_PER_VALUE);
        let out = Path::new("/data/out");
        let fix = "shorten simulation.horizon";
        let m = check_against("lash run X", &e, out, fix, Some(50_000_000_000), None).unwrap_err().to_string();
        assert!(m.contains("70.0 TB") && m.contains("50.0 GB free") && m.contains(fix), "{m}");
        let m = check_against("lash run X", &e, out, fix, Some(u64::MAX), Some(1 << 30)).unwrap_err().to_string();
        assert!(m.contains("1.6 TB in memory") && m.contains("1.1 GB available"), "{m}");
        // What fits passes, and unknown figures do not refuse anything.
        let small = run_estimate(0.036, 1e-5, 28, 0, CSV_BYTES_PER_VALUE);
        assert_eq!(small.rows, 3601);
        assert!(check_against("run", &small, out, fix, Some(1 << 30), Some(1 << 30)).is_ok());
        assert!(check_against("run", &e, out, fix, None, None).is_ok());
        // The real machine answers (this test's folder exists and has some space).
        assert!(free_space(&std::env::temp_dir().join("not/yet/there")).is_some_and(|f| f > 0));
        assert!(available_memory().is_some_and(|m| m > 0));
    }
}
