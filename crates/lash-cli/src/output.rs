//! The one time-series writer of the command line: `timeseries.csv` (or `timeseries.parquet`)
//! streamed into `timeseries.csv.partial` and renamed only when the run finished, so a folder
//! never holds a complete-looking result of a failed or interrupted run. CSV numbers are written
//! in the shortest form that reads back to the same `f64` (Ryū: plain from 1e-5 to 1e16,
//! exponent otherwise); Parquet holds the doubles themselves, a column per channel with its unit.

use crate::CliError;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by SIGINT/SIGTERM: the next row ends the run, which then says what it kept.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The message of a run ended by a signal.
pub const INTERRUPTED_MESSAGE: &str = "interrupted (SIGINT/SIGTERM)";

/// Why a row was not taken by a [`SeriesOutput`].
#[derive(Debug, thiserror::Error)]
pub enum RowError {
    /// The run was interrupted (SIGINT/SIGTERM).
    #[error("{INTERRUPTED_MESSAGE}")]
    Interrupted,
    /// A row of another width than the table's.
    #[error("output: a row of {values} values in a table of {columns} columns")]
    Width {
        /// Values in the row.
        values: usize,
        /// Columns of the table.
        columns: usize,
    },
    /// Writing the file failed.
    #[error("output: {0}")]
    Write(std::io::Error),
}

/// Installs the SIGINT/SIGTERM handler (once; later calls do nothing). A run writing through a
/// [`SeriesOutput`] then stops at its next row, keeps the rows so far and exits with a message.
pub fn catch_interrupts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, Ordering::SeqCst) {
                // A second signal: the user insists.
                std::process::exit(130);
            }
        });
    });
}

/// True once a signal asked the process to stop.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// The file format of a run's time series.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Format {
    /// `timeseries.csv`: text, a header with units.
    #[default]
    Csv,
    /// `timeseries.parquet`: binary doubles (Snappy), the units in the columns' metadata; what
    /// sweeps write, and read by pandas, polars, arrow.
    Parquet,
}

/// Where the rows go.
enum Sink {
    Csv(std::io::BufWriter<std::fs::File>),
    /// `None` once finished.
    Parquet(Option<Box<lash_sweep::dataset::SeriesWriter>>),
}

/// A time series being written into an output folder.
pub struct SeriesOutput {
    sink: Sink,
    partial: PathBuf,
    done: PathBuf,
    line: String,
    rows: u64,
    /// Rows received but not yet formatted (one batch, flat).
    pending: Vec<f64>,
    /// Values per row (set by the first row).
    width: usize,
    /// Wall time spent formatting and writing.
    busy: std::time::Duration,
}

/// Rows formatted together: the writer's clock is read once per batch, not per row (two clock
/// reads per row cost more than a micro step of the reduced model).
const BATCH_ROWS: usize = 256;

fn io(what: &str, e: std::io::Error) -> CliError {
    CliError::Failure(format!("{what}: {e}"))
}

impl SeriesOutput {
    /// Creates `out` if needed, removes an earlier run's `timeseries.csv`, `timeseries.parquet` and
    /// `stale` files (they must not survive as if they belonged to this run), and starts
    /// `timeseries.<format>` (a CSV with its header).
    pub fn create_as(out: &Path, header: &[String], stale: &[&str], format: Format) -> Result<Self, CliError> {
        let (name, other) = match format {
            Format::Csv => ("timeseries.csv", "timeseries.parquet"),
            Format::Parquet => ("timeseries.parquet", "timeseries.csv"),
        };
        let stale: Vec<&str> = stale.iter().copied().chain([other]).collect();
        if format == Format::Csv {
            return Self::create_named(out, name, header, &stale);
        }
        let (partial, done) = Self::prepare(out, name, &stale)?;
        // "name [unit]" → (name, unit).
        let columns: Vec<(String, String)> = header
            .iter()
            .map(|h| match h.split_once(" [") {
                Some((name, unit)) => (name.to_string(), unit.trim_end_matches(']').to_string()),
                None => (h.clone(), String::new()),
            })
            .collect();
        let writer = lash_sweep::dataset::SeriesWriter::create(&partial, &columns)?;
        Ok(Self::with_sink(Sink::Parquet(Some(Box::new(writer))), partial, done))
    }

    /// Creates `out` if needed and removes `name` and `stale` there; returns the paths of the
    /// table while it is written and once it is complete.
    fn prepare(out: &Path, name: &str, stale: &[&str]) -> Result<(PathBuf, PathBuf), CliError> {
        std::fs::create_dir_all(out).map_err(|e| io(&format!("cannot create {}", out.display()), e))?;
        let done = out.join(name);
        for p in std::iter::once(done.clone()).chain(stale.iter().map(|s| out.join(s))) {
            if p.exists() {
                std::fs::remove_file(&p).map_err(|e| io(&format!("cannot remove old {}", p.display()), e))?;
            }
        }
        Ok((out.join(format!("{name}.partial")), done))
    }

    /// A CSV table called `name` (streamed into `name.partial`), header first.
    pub fn create_named(out: &Path, name: &str, header: &[String], stale: &[&str]) -> Result<Self, CliError> {
        let (partial, done) = Self::prepare(out, name, stale)?;
        let file =
            std::fs::File::create(&partial).map_err(|e| io(&format!("cannot create {}", partial.display()), e))?;
        let mut writer = std::io::BufWriter::new(file);
        writeln!(writer, "{}", lash_core::csv_header(header)).map_err(|e| io("writing the CSV header", e))?;
        Ok(Self::with_sink(Sink::Csv(writer), partial, done))
    }

    fn with_sink(sink: Sink, partial: PathBuf, done: PathBuf) -> Self {
        Self {
            sink,
            partial,
            done,
            line: String::with_capacity(1024),
            rows: 0,
            pending: Vec::new(),
            width: 0,
            busy: std::time::Duration::ZERO,
        }
    }

    /// Takes one row (written in batches; [`SeriesOutput::finish`] and [`SeriesOutput::abandon`] write
    /// what is pending). Every row of a file has the width of the first.
    pub fn row(&mut self, row: &[f64]) -> Result<(), RowError> {
        if interrupted() {
            return Err(RowError::Interrupted);
        }
        if self.rows == 0 && self.pending.is_empty() {
            self.width = row.len();
            self.pending.reserve(BATCH_ROWS * row.len().max(1));
        } else if row.len() != self.width {
            return Err(RowError::Width { values: row.len(), columns: self.width });
        }
        self.pending.extend_from_slice(row);
        if self.pending.len() >= BATCH_ROWS * self.width.max(1) {
            self.write_pending().map_err(RowError::Write)?;
        }
        Ok(())
    }

    /// Wall time spent so far formatting and writing rows (the rest of a run is simulation).
    pub fn busy(&self) -> std::time::Duration {
        self.busy
    }

    /// Formats and writes the pending rows.
    fn write_pending(&mut self) -> std::io::Result<()> {
        use std::fmt::Write as _;
        let started = std::time::Instant::now();
        let width = self.width.max(1);
        let mut result = Ok(());
        match &mut self.sink {
            Sink::Parquet(writer) => {
                if let Some(w) = writer {
                    result = w.append(&self.pending).map_err(std::io::Error::other);
                    if result.is_ok() {
                        self.rows += (self.pending.len() / width) as u64;
                    }
                }
            }
            Sink::Csv(writer) => {
                let mut number = ryu::Buffer::new();
                for row in self.pending.chunks(width) {
                    self.line.clear();
                    for (k, &v) in row.iter().enumerate() {
                        if k > 0 {
                            self.line.push(',');
                        }
                        if v.is_finite() {
                            // The shortest text that reads back to the same double (Ryū): plain
                            // from 1e-5 to 1e16, scientific outside; whole numbers without ".0".
                            let text = number.format_finite(v);
                            self.line.push_str(text.strip_suffix(".0").unwrap_or(text));
                        } else {
                            let _ = write!(self.line, "{v}");
                        }
                    }
                    self.line.push('\n');
                    result = writer.write_all(self.line.as_bytes());
                    if result.is_err() {
                        break;
                    }
                    self.rows += 1;
                }
            }
        }
        self.pending.clear();
        self.busy += started.elapsed();
        result
    }

    /// The run finished: flushes and renames to its final name, which it returns.
    pub fn finish(mut self) -> Result<PathBuf, CliError> {
        self.write_pending().map_err(|e| io("writing the time series", e))?;
        self.close().map_err(|e| io("writing the time series", e))?;
        std::fs::rename(&self.partial, &self.done).map_err(|e| io("finishing the CSV", e))?;
        Ok(self.done)
    }

    /// The run failed or was interrupted: flushes what was written and returns the partial
    /// file's path (for the message that says what was kept), or removes it and returns `None`
    /// when no row was written (a run refused before it started leaves nothing behind).
    pub fn abandon(mut self) -> Option<PathBuf> {
        let _ = self.write_pending();
        let _ = self.close();
        if self.rows == 0 {
            let _ = std::fs::remove_file(&self.partial);
            return None;
        }
        Some(self.partial)
    }

    /// Flushes the CSV, or writes the Parquet file's last row group and footer (a partial Parquet
    /// file is then readable too).
    fn close(&mut self) -> std::io::Result<()> {
        match &mut self.sink {
            Sink::Csv(w) => w.flush(),
            Sink::Parquet(w) => w.take().map_or(Ok(()), |w| w.finish().map_err(std::io::Error::other)),
        }
    }

    /// The words for a message about what an abandoned run kept.
    pub fn kept(partial: Option<&Path>) -> String {
        match partial {
            Some(p) => format!("the samples so far are in {}; no summary was written", p.display()),
            None => "no sample was written".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every finite double written reads back to the same bits (Rust's own parser as the
    /// independent check), with whole numbers written without a fraction.
    #[test]
    fn written_values_read_back_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("lash-csv-test-{}", std::process::id()));
        let mut values = vec![0.0, -0.0, 1.0, -12.0, 1e-5, 1.2345e-5, 0.1, 1e15, 1e16, 1e300, -1e-300, 5e-324];
        let mut x = 0.123_456_789_f64;
        for i in 0..2000 {
            // A deterministic spread over many decades and signs.
            x = (x * 3.987_654_321).fract();
            values.push((x - 0.5) * 10f64.powi(i % 40 - 20));
        }
        let header = vec!["a".to_string(), "b".to_string()];
        let mut csv = SeriesOutput::create_as(&dir, &header, &[], Format::Csv).unwrap();
        for pair in values.chunks(2) {
            csv.row(pair).unwrap();
        }
        let path = csv.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let back: Vec<f64> =
            text.lines().skip(1).flat_map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap())).collect();
        assert_eq!(back.len(), values.len());
        for (a, b) in values.iter().zip(&back) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a:e} read back as {b:e}");
        }
        assert_eq!(text.lines().nth(1).unwrap(), "0,-0");
        assert_eq!(text.lines().nth(2).unwrap(), "1,-12");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
