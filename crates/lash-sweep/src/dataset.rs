//! The dataset on disk: Parquet tables through arrow-rs, the manifest and the run journal.
//!
//! Layout of an output folder:
//! * `manifest.json` — lash version, sweep and scenario hashes, the sweep file, seeds, shard,
//!   channels with units, per-run status, error and timing;
//! * `data.parquet` — one long table `run_id, t, <channels…>`, one row group per run, in run order;
//! * `params.parquet` — `run_id, seed, status, <parameter paths…>`;
//! * while a sweep runs: `parts/runs-<id>.parquet` (finished runs, one row group each, in a file
//!   closed — footer written, temporary name renamed — after 64 runs or about a second of work,
//!   [`PartWriter`]) and `runs.jsonl` (one line per run in a closed part, or per failed run,
//!   flushed): a killed sweep resumes from these and loses only the runs in flight and those in
//!   the open part (at most about a second of finished runs).

use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray, UInt64Array};
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why reading or writing a dataset or a time series failed: the file, and the cause as its
/// source.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file could not be created, opened, read, written or renamed.
    #[error("cannot {action} {}: {source}", .path.display())]
    Io {
        /// What was being done ("create", "open", "read", "write", "rename").
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Parquet could not encode or decode the file.
    #[error("{}: {source}", .path.display())]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: parquet::errors::ParquetError,
    },
    /// Arrow arrays did not fit the table's schema.
    #[error("{}: {source}", .path.display())]
    Arrow {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: arrow_schema::ArrowError,
    },
    /// The manifest is not a lash sweep manifest (or could not be written as JSON).
    #[error("{} is not a lash sweep manifest: {source}", .path.display())]
    Manifest {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
    },
    /// A run's samples do not fit the dataset's table.
    #[error("a run's samples do not fit the dataset's table: {0}")]
    Batch(#[source] arrow_schema::ArrowError),
    /// The file reads, but its content is not what lash expects (the column, line or size named).
    #[error("{}: {message}", .path.display())]
    Content {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// An I/O error while doing `action` to `path`.
fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> DatasetError + 'a {
    move |source| DatasetError::Io { action, path: path.to_path_buf(), source }
}

/// A Parquet or Arrow error in `path`.
fn at<E: Into<Cause>>(path: &Path) -> impl FnOnce(E) -> DatasetError + '_ {
    move |e| match e.into() {
        Cause::Parquet(source) => DatasetError::Parquet { path: path.to_path_buf(), source },
        Cause::Arrow(source) => DatasetError::Arrow { path: path.to_path_buf(), source },
    }
}

/// The two library causes [`at`] attaches a path to.
enum Cause {
    Parquet(parquet::errors::ParquetError),
    Arrow(arrow_schema::ArrowError),
}

impl From<parquet::errors::ParquetError> for Cause {
    fn from(e: parquet::errors::ParquetError) -> Self {
        Cause::Parquet(e)
    }
}

impl From<arrow_schema::ArrowError> for Cause {
    fn from(e: arrow_schema::ArrowError) -> Self {
        Cause::Arrow(e)
    }
}

/// A content error of `path`.
fn content(path: &Path, message: impl Into<String>) -> DatasetError {
    DatasetError::Content { path: path.to_path_buf(), message: message.into() }
}

/// A channel of the dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelInfo {
    /// Name (as in `lash run` outputs).
    pub name: String,
    /// SI unit.
    pub unit: String,
}

/// Status of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Run id.
    pub run_id: u64,
    /// Noise seed of the run.
    pub seed: u64,
    /// "ok" or "failed".
    pub status: String,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Rows written.
    pub rows: u64,
    /// Wall time of the simulation \[s\].
    pub simulate_s: f64,
    /// Wall time of writing its part \[s\].
    pub write_s: f64,
    /// Journal only: the part file (in `parts/`) that holds its rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    /// Journal only: its row group in that part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row_group: Option<usize>,
}

/// The shard of a sweep an output folder holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 0-based index.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl Shard {
    /// Whether run `id` belongs to this shard (ids dealt round-robin).
    pub fn holds(&self, id: u64) -> bool {
        id % self.count == self.index
    }
}

/// manifest.json.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Version of lash that wrote it.
    pub lash_version: String,
    /// Identity of the sweep (sweep file, base scenario, lash version).
    pub sweep_hash: String,
    /// SHA-256 of the base scenario as serialized.
    pub scenario_hash: String,
    /// The sweep file's text.
    pub sweep_file: String,
    /// Sweep seed.
    pub seed: u64,
    /// Runs in the whole sweep.
    pub total_runs: u64,
    /// The shard held here (None: the whole sweep).
    pub shard: Option<Shard>,
    /// Channels (data columns after run_id and t).
    pub channels: Vec<ChannelInfo>,
    /// Parameter paths (params columns after run_id, seed, status).
    pub parameters: Vec<String>,
    /// The reduced model's steps the runs took (the file's, or those lash chose for the base);
    /// absent for the full model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduced: Option<crate::spec::ReducedSteps>,
    /// "running" or "complete".
    pub status: String,
    /// Runs held here, by id (complete manifests).
    pub runs: Vec<RunRecord>,
}

impl Manifest {
    /// Reads `dir/manifest.json`, if present.
    pub fn read(dir: &Path) -> Result<Option<Self>, DatasetError> {
        let path = dir.join("manifest.json");
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(io("read", &path))?;
        serde_json::from_str(&text).map(Some).map_err(|source| DatasetError::Manifest { path: path.clone(), source })
    }

    /// Writes `dir/manifest.json` atomically.
    pub fn write(&self, dir: &Path) -> Result<(), DatasetError> {
        let path = dir.join("manifest.json");
        let text = serde_json::to_string_pretty(self)
            .map_err(|source| DatasetError::Manifest { path: path.clone(), source })?;
        write_atomic(&path, text.as_bytes())
    }
}

/// Writes a file under a temporary name and renames it into place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(io("write", &tmp))?;
    std::fs::rename(&tmp, path).map_err(io("rename", &tmp))
}

/// Arrow schema of the data table.
pub fn data_schema(channels: &[ChannelInfo]) -> SchemaRef {
    let mut fields = vec![
        Field::new("run_id", DataType::UInt64, false),
        Field::new("t", DataType::Float64, false).with_metadata(HashMap::from([("unit".to_string(), "s".to_string())])),
    ];
    for c in channels {
        fields.push(
            Field::new(&c.name, DataType::Float64, false)
                .with_metadata(HashMap::from([("unit".to_string(), c.unit.clone())])),
        );
    }
    Arc::new(Schema::new(fields))
}

/// The dataset's tables: Snappy, and a dictionary only for `run_id` (constant within a row
/// group); measured doubles never repeat enough for one to pay, and encoding them through it cost
/// more than the compression.
fn properties() -> WriterProperties {
    WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_dictionary_enabled(false)
        .set_column_dictionary_enabled(ColumnPath::from("run_id"), true)
        .set_created_by(format!("lash {}", env!("CARGO_PKG_VERSION")))
        .build()
}

/// One run's samples, column-major.
pub struct RunData {
    /// Run id.
    pub run_id: u64,
    /// Sample times \[s\].
    pub time: Vec<f64>,
    /// One vector per channel.
    pub columns: Vec<Vec<f64>>,
}

impl RunData {
    /// The run as an Arrow record batch (the vectors move in; no copy).
    pub fn into_batch(self, schema: &SchemaRef) -> Result<RecordBatch, DatasetError> {
        let n = self.time.len();
        let mut arrays: Vec<ArrayRef> =
            vec![Arc::new(UInt64Array::from(vec![self.run_id; n])), Arc::new(Float64Array::from(self.time))];
        for c in self.columns {
            arrays.push(Arc::new(Float64Array::from(c)));
        }
        RecordBatch::try_new(schema.clone(), arrays).map_err(DatasetError::Batch)
    }
}

/// A file written through a 1 MiB buffer. Parquet's writer buffers 8 KiB, so a sweep that
/// writes every run twice (its part, the dataset) made a `write` call per 8 KiB: ~2 400 calls for
/// the benchmark workload with 400 runs, whose time this buffer cut by ~3 %. Nothing is lost by holding more:
/// a part counts only once it is closed (journaled), the dataset only once renamed into place.
type Buffered = std::io::BufWriter<File>;

fn buffered(file: File) -> Buffered {
    std::io::BufWriter::with_capacity(1 << 20, file)
}

/// Finishes a Parquet file written through a [`Buffered`] file: the footer, then the buffer's
/// last bytes (whose write error would otherwise be lost when the buffer is dropped).
fn close_buffered(writer: ArrowWriter<Buffered>, path: &Path) -> Result<(), DatasetError> {
    let buffer = writer.into_inner().map_err(at(path))?;
    buffer.into_inner().map(drop).map_err(|e| io("write", path)(e.into_error()))
}

/// A part file being filled while a sweep runs (by the thread that assembles the dataset): one row group per finished run,
/// written under a temporary name and renamed into place by [`PartWriter::close`] (a Parquet
/// file is readable only once its footer is written). One file per run cost more than writing
/// its rows: creating, renaming and finally deleting a file per run was ~10 % of a sweep of short
/// runs (docs/performance.md).
pub struct PartWriter {
    name: String,
    dir: PathBuf,
    writer: ArrowWriter<Buffered>,
    runs: Vec<RunRecord>,
    opened: std::time::Instant,
}

impl PartWriter {
    /// Starts `parts/runs-<first_run>.parquet` in `parts` (the first run's id makes the name: a
    /// run is written once per execution, and one that a resumed sweep runs again was never
    /// journaled, so no journaled run points to a file of that name).
    pub fn create(parts: &Path, first_run: u64, schema: &SchemaRef) -> Result<Self, DatasetError> {
        let name = format!("runs-{first_run:09}.parquet");
        let tmp = parts.join(format!("{name}.tmp"));
        let file = File::create(&tmp).map_err(io("create", &tmp))?;
        // Temporary: no compression, no dictionary, no statistics (nothing filters on them; the
        // assembled dataset has its own).
        let properties = WriterProperties::builder()
            .set_compression(Compression::UNCOMPRESSED)
            .set_dictionary_enabled(false)
            .set_statistics_enabled(parquet::file::properties::EnabledStatistics::None)
            .set_created_by(format!("lash {}", env!("CARGO_PKG_VERSION")))
            .build();
        let writer = ArrowWriter::try_new(buffered(file), schema.clone(), Some(properties)).map_err(at(&tmp))?;
        Ok(Self { name, dir: parts.to_path_buf(), writer, runs: Vec::new(), opened: std::time::Instant::now() })
    }

    /// Appends one finished run as a row group; `record` will point to it.
    /// Its `write_s` is the time this took.
    pub fn append(&mut self, batch: &RecordBatch, record: RunRecord) -> Result<(), DatasetError> {
        let started = std::time::Instant::now();
        let tmp = self.dir.join(format!("{}.tmp", self.name));
        self.writer.write(batch).map_err(at(&tmp))?;
        self.writer.flush().map_err(at(&tmp))?;
        let (part, row_group) = (Some(self.name.clone()), Some(self.runs.len()));
        self.runs.push(RunRecord { part, row_group, write_s: started.elapsed().as_secs_f64(), ..record });
        Ok(())
    }

    /// Runs held.
    pub fn len(&self) -> usize {
        self.runs.len()
    }

    /// Whether it holds no run.
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }

    /// Seconds since it was started.
    pub fn age(&self) -> f64 {
        self.opened.elapsed().as_secs_f64()
    }

    /// Writes the footer and renames the file into place; returns the records of its runs, to be
    /// journaled (the last one's `write_s` counts the closing too).
    pub fn close(mut self) -> Result<Vec<RunRecord>, DatasetError> {
        let started = std::time::Instant::now();
        let (tmp, path) = (self.dir.join(format!("{}.tmp", self.name)), self.dir.join(&self.name));
        close_buffered(self.writer, &tmp)?;
        std::fs::rename(&tmp, &path).map_err(io("rename", &tmp))?;
        if let Some(last) = self.runs.last_mut() {
            last.write_s += started.elapsed().as_secs_f64();
        }
        Ok(self.runs)
    }
}

/// One run's time series streamed into a Parquet file (`lash run --format parquet`): a column
/// `t` \[s\] and one per channel, each with its unit in the field metadata, as the sweeps' tables;
/// rows are buffered column by column and written as a row group every [`SeriesWriter::GROUP`]
/// rows, so memory stays bounded however long the run.
pub struct SeriesWriter {
    path: PathBuf,
    schema: SchemaRef,
    writer: ArrowWriter<File>,
    columns: Vec<Vec<f64>>,
    rows: u64,
}

impl SeriesWriter {
    /// Rows per row group.
    pub const GROUP: usize = 65_536;

    /// Starts `path` with the columns `(name, unit)` (time first).
    pub fn create(path: &Path, columns: &[(String, String)]) -> Result<Self, DatasetError> {
        let fields: Vec<Field> = columns
            .iter()
            .map(|(name, unit)| {
                Field::new(name, DataType::Float64, false)
                    .with_metadata(HashMap::from([("unit".to_string(), unit.clone())]))
            })
            .collect();
        let schema: SchemaRef = Arc::new(Schema::new(fields));
        let file = File::create(path).map_err(io("create", path))?;
        // Doubles of a time series: no dictionary (it never pays for measured values and costs
        // its hashing), the bytes of each double split into streams so that Snappy finds the
        // repeated sign/exponent bytes.
        let properties = WriterProperties::builder()
            .set_compression(Compression::SNAPPY)
            .set_dictionary_enabled(false)
            .set_encoding(parquet::basic::Encoding::BYTE_STREAM_SPLIT)
            .set_created_by(format!("lash {}", env!("CARGO_PKG_VERSION")))
            .build();
        let writer = ArrowWriter::try_new(file, schema.clone(), Some(properties)).map_err(at(path))?;
        let columns = vec![Vec::with_capacity(Self::GROUP); columns.len()];
        Ok(Self { path: path.to_path_buf(), schema, writer, columns, rows: 0 })
    }

    /// Appends rows given one after the other (`values.len()` a multiple of the column count).
    pub fn append(&mut self, values: &[f64]) -> Result<(), DatasetError> {
        let width = self.columns.len().max(1);
        for row in values.chunks(width) {
            for (c, &v) in self.columns.iter_mut().zip(row) {
                c.push(v);
            }
            if self.columns[0].len() == Self::GROUP {
                self.flush_group()?;
            }
        }
        Ok(())
    }

    fn flush_group(&mut self) -> Result<(), DatasetError> {
        if self.columns.first().is_none_or(Vec::is_empty) {
            return Ok(());
        }
        let arrays: Vec<ArrayRef> = self
            .columns
            .iter_mut()
            .map(|c| Arc::new(Float64Array::from(std::mem::replace(c, Vec::with_capacity(Self::GROUP)))) as ArrayRef)
            .collect();
        let batch = RecordBatch::try_new(self.schema.clone(), arrays).map_err(at(&self.path))?;
        self.rows += batch.num_rows() as u64;
        self.writer.write(&batch).map_err(at(&self.path))?;
        self.writer.flush().map_err(at(&self.path))
    }

    /// Rows written so far (buffered ones included).
    pub fn rows(&self) -> u64 {
        self.rows + self.columns.first().map_or(0, |c| c.len() as u64)
    }

    /// Writes what is buffered and the file's footer: a complete Parquet file.
    pub fn finish(mut self) -> Result<(), DatasetError> {
        self.flush_group()?;
        self.writer.close().map(|_| ()).map_err(at(&self.path))
    }
}

/// A time series read back: each column's (name, unit), and the columns.
pub type Series = (Vec<(String, String)>, Vec<Vec<f64>>);

/// Reads a time series written by [`SeriesWriter`]: the column names, their units and the columns.
pub fn read_series(path: &Path) -> Result<Series, DatasetError> {
    let file = File::open(path).map_err(io("open", path))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).and_then(|b| b.build()).map_err(at(path))?;
    let mut names = Vec::new();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    for batch in reader {
        let batch = batch.map_err(at(path))?;
        if names.is_empty() {
            names = batch
                .schema()
                .fields()
                .iter()
                .map(|f| (f.name().clone(), f.metadata().get("unit").cloned().unwrap_or_default()))
                .collect();
            columns = vec![Vec::new(); names.len()];
        }
        for (c, array) in columns.iter_mut().zip(batch.columns()) {
            let values = array
                .as_any()
                .downcast_ref::<Float64Array>()
                .ok_or_else(|| content(path, "a column is not Float64"))?;
            c.extend(values.values().iter());
        }
    }
    Ok((names, columns))
}

/// (name, unit) of a CSV header cell `name [unit]` (the unit empty when the cell has none).
fn split_header(cell: &str) -> (String, String) {
    let cell = cell.trim().trim_matches('"');
    match cell.split_once(" [") {
        Some((name, unit)) => (name.trim().to_string(), unit.trim_end_matches(']').to_string()),
        None => (cell.to_string(), String::new()),
    }
}

/// Largest time-series file read back (a measurement or a run's output) \[bytes\].
pub const MAX_SERIES_BYTES: u64 = 4 << 30;

/// Reads a time series written as CSV (`timeseries.csv`, or a measurement): a header of `name
/// [unit]` cells, then rows of numbers. Blank lines are skipped; a row with a missing or
/// non-numeric field is an error naming the column and the line. The file is sized first.
pub fn read_csv_series(path: &Path) -> Result<Series, DatasetError> {
    let at = |m: String| content(path, m);
    let size = std::fs::metadata(path).map_err(io("read", path))?.len();
    if size > MAX_SERIES_BYTES {
        return Err(at(format!("{size} bytes: more than the {MAX_SERIES_BYTES} a time series may have")));
    }
    let text = std::fs::read_to_string(path).map_err(io("read", path))?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| at("empty file".into()))?;
    let names: Vec<(String, String)> = header.split(',').map(split_header).collect();
    let mut columns = vec![Vec::new(); names.len()];
    for (line, row) in lines {
        let cells: Vec<&str> = row.split(',').collect();
        if cells.len() != names.len() {
            return Err(at(format!("line {}: {} fields, the header has {}", line + 1, cells.len(), names.len())));
        }
        for ((cell, column), (name, _)) in cells.iter().zip(columns.iter_mut()).zip(&names) {
            let value = cell.trim().parse::<f64>().map_err(|_| {
                at(format!("column {name:?}, line {}: {:?} is not a number (a missing sample?)", line + 1, cell.trim()))
            })?;
            column.push(value);
        }
    }
    Ok((names, columns))
}

/// Reads a time series from CSV or Parquet (by the file's extension, `.parquet` or anything
/// else as CSV).
pub fn read_any_series(path: &Path) -> Result<Series, DatasetError> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("parquet")) {
        read_series(path)
    } else {
        read_csv_series(path)
    }
}

/// A source of one run's rows for [`write_data`]: a file and, optionally, one row group in it.
pub struct RunSource {
    /// Parquet file.
    pub file: PathBuf,
    /// Row group (None: the whole file).
    pub row_group: Option<usize>,
}

/// Writes `data.parquet` (and `data.csv` if asked) run by run, one row group per run, under
/// temporary names renamed into place by [`DataWriter::finish`].
pub struct DataWriter {
    dir: PathBuf,
    schema: SchemaRef,
    parquet: ArrowWriter<Buffered>,
    csv: Option<std::io::BufWriter<File>>,
    rows: u64,
}

impl DataWriter {
    /// Starts the files in `dir`.
    pub fn create(dir: &Path, schema: &SchemaRef, csv: bool) -> Result<Self, DatasetError> {
        let tmp = dir.join("data.parquet.tmp");
        let file = File::create(&tmp).map_err(io("create", &tmp))?;
        let parquet = ArrowWriter::try_new(buffered(file), schema.clone(), Some(properties())).map_err(at(&tmp))?;
        let csv = if csv {
            let csv_tmp = dir.join("data.csv.tmp");
            let f = File::create(&csv_tmp).map_err(io("create", &csv_tmp))?;
            let mut out = std::io::BufWriter::new(f);
            let header: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
            use std::io::Write;
            writeln!(out, "{}", lash_core::csv_header(&header)).map_err(io("write", &csv_tmp))?;
            Some(out)
        } else {
            None
        };
        Ok(Self { dir: dir.to_path_buf(), schema: schema.clone(), parquet, csv, rows: 0 })
    }

    fn write_batch(&mut self, batch: &RecordBatch) -> Result<(), DatasetError> {
        self.rows += batch.num_rows() as u64;
        if let Some(out) = self.csv.as_mut() {
            write_csv_rows(out, batch).map_err(io("write", &self.dir.join("data.csv.tmp")))?;
        }
        self.parquet.write(batch).map_err(at(&self.dir.join("data.parquet.tmp")))
    }

    /// Appends one run held in memory (a row group of its own).
    pub fn append(&mut self, batch: &RecordBatch) -> Result<(), DatasetError> {
        self.write_batch(batch)?;
        self.parquet.flush().map_err(at(&self.dir.join("data.parquet.tmp")))
    }

    /// Appends one run read from a Parquet file (a part, or a row group of a shard's data).
    pub fn append_file(&mut self, src: &RunSource) -> Result<(), DatasetError> {
        let f = File::open(&src.file).map_err(io("open", &src.file))?;
        let mut builder = ParquetRecordBatchReaderBuilder::try_new(f).map_err(at(&src.file))?;
        if let Some(rg) = src.row_group {
            builder = builder.with_row_groups(vec![rg]);
        }
        let reader = builder.build().map_err(at(&src.file))?;
        for batch in reader {
            let batch = batch.map_err(at(&src.file))?;
            let batch = RecordBatch::try_new(self.schema.clone(), batch.columns().to_vec()).map_err(at(&src.file))?;
            self.write_batch(&batch)?;
        }
        self.parquet.flush().map_err(at(&self.dir.join("data.parquet.tmp")))
    }

    /// Closes the files and moves them into place; returns the number of rows.
    pub fn finish(self) -> Result<u64, DatasetError> {
        let tmp = self.dir.join("data.parquet.tmp");
        close_buffered(self.parquet, &tmp)?;
        std::fs::rename(&tmp, self.dir.join("data.parquet")).map_err(io("rename", &tmp))?;
        if let Some(mut out) = self.csv {
            use std::io::Write;
            let tmp = self.dir.join("data.csv.tmp");
            out.flush().map_err(io("write", &tmp))?;
            drop(out);
            std::fs::rename(&tmp, self.dir.join("data.csv")).map_err(io("rename", &tmp))?;
        }
        Ok(self.rows)
    }
}

/// Writes `data.parquet` (and `data.csv` if asked) from runs in the given order, one row group
/// per run. Returns the number of rows.
pub fn write_data(dir: &Path, schema: &SchemaRef, sources: &[RunSource], csv: bool) -> Result<u64, DatasetError> {
    let mut w = DataWriter::create(dir, schema, csv)?;
    for src in sources {
        w.append_file(src)?;
    }
    w.finish()
}

/// Writes a data batch's rows as CSV (`run_id` then doubles, as [`data_schema`] makes them).
fn write_csv_rows(out: &mut impl std::io::Write, batch: &RecordBatch) -> std::io::Result<()> {
    let not =
        |what: &str| std::io::Error::new(std::io::ErrorKind::InvalidData, format!("{what} column of another type"));
    let ids = batch.column(0).as_any().downcast_ref::<UInt64Array>().ok_or_else(|| not("run_id"))?;
    let cols: Vec<&Float64Array> = batch.columns()[1..]
        .iter()
        .map(|c| c.as_any().downcast_ref::<Float64Array>().ok_or_else(|| not("a value")))
        .collect::<Result<_, _>>()?;
    for r in 0..batch.num_rows() {
        let mut line = ids.value(r).to_string();
        for c in &cols {
            line.push(',');
            line.push_str(&c.value(r).to_string());
        }
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// One row of the params table.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamsRow {
    /// Run id.
    pub run_id: u64,
    /// Noise seed.
    pub seed: u64,
    /// "ok" or "failed".
    pub status: String,
    /// Parameter values.
    pub values: Vec<f64>,
    /// Why the run failed ("" for a run that did not).
    pub error: String,
}

/// Writes `params.parquet`.
pub fn write_params(dir: &Path, parameters: &[String], rows: &[ParamsRow]) -> Result<(), DatasetError> {
    let mut fields = vec![
        Field::new("run_id", DataType::UInt64, false),
        Field::new("seed", DataType::UInt64, false),
        Field::new("status", DataType::Utf8, false),
    ];
    fields.extend(parameters.iter().map(|p| {
        Field::new(p, DataType::Float64, false)
            .with_metadata(HashMap::from([("unit".to_string(), parameter_unit(p).to_string())]))
    }));
    fields.push(Field::new("error", DataType::Utf8, false));
    let schema = Arc::new(Schema::new(fields));
    let mut arrays: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from(rows.iter().map(|r| r.run_id).collect::<Vec<_>>())),
        Arc::new(UInt64Array::from(rows.iter().map(|r| r.seed).collect::<Vec<_>>())),
        Arc::new(StringArray::from(rows.iter().map(|r| r.status.as_str()).collect::<Vec<_>>())),
    ];
    for k in 0..parameters.len() {
        arrays.push(Arc::new(Float64Array::from(rows.iter().map(|r| r.values[k]).collect::<Vec<_>>())));
    }
    arrays.push(Arc::new(StringArray::from(rows.iter().map(|r| r.error.as_str()).collect::<Vec<_>>())));
    let tmp = dir.join("params.parquet.tmp");
    let batch = RecordBatch::try_new(schema.clone(), arrays).map_err(at(&tmp))?;
    let file = File::create(&tmp).map_err(io("create", &tmp))?;
    let mut w = ArrowWriter::try_new(file, schema, Some(properties())).map_err(at(&tmp))?;
    w.write(&batch).map_err(at(&tmp))?;
    w.close().map_err(at(&tmp))?;
    std::fs::rename(&tmp, dir.join("params.parquet")).map_err(io("rename", &tmp))
}

/// The SI unit of a varied parameter, from the last key of its scenario path (`drivers[0].motion.omega`
/// → `rad/s`, `bodies[1].point1[0]` → `m`) in lash's one table of field units; empty where the
/// table does not know the key.
pub fn parameter_unit(path: &str) -> &'static str {
    let last = path.rsplit('.').next().unwrap_or(path);
    let key = last.split('[').next().unwrap_or(last);
    lash_core::units::field_unit(key)
}

/// Reads `params.parquet`.
pub fn read_params(dir: &Path, parameters: usize) -> Result<Vec<ParamsRow>, DatasetError> {
    let path = dir.join("params.parquet");
    let f = File::open(&path).map_err(io("open", &path))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(f).and_then(|b| b.build()).map_err(at(&path))?;
    let mut rows = Vec::new();
    for batch in reader {
        let batch = batch.map_err(at(&path))?;
        let not = |what: &str| content(&path, format!("the {what} column is of another type"));
        let u = |i: usize| batch.column(i).as_any().downcast_ref::<UInt64Array>().cloned();
        let (ids, seeds) = (u(0).ok_or_else(|| not("run_id"))?, u(1).ok_or_else(|| not("seed"))?);
        let status = batch.column(2).as_any().downcast_ref::<StringArray>().ok_or_else(|| not("status"))?;
        let vals: Vec<&Float64Array> = (0..parameters)
            .map(|k| batch.column(3 + k).as_any().downcast_ref::<Float64Array>().ok_or_else(|| not("a parameter")))
            .collect::<Result<_, _>>()?;
        // The error column follows the parameters (datasets of earlier versions have none).
        let errors = (batch.num_columns() > 3 + parameters)
            .then(|| batch.column(3 + parameters).as_any().downcast_ref::<StringArray>().cloned())
            .flatten();
        for r in 0..batch.num_rows() {
            rows.push(ParamsRow {
                run_id: ids.value(r),
                seed: seeds.value(r),
                status: status.value(r).to_string(),
                values: vals.iter().map(|v| v.value(r)).collect(),
                error: errors.as_ref().map(|e| e.value(r).to_string()).unwrap_or_default(),
            });
        }
    }
    Ok(rows)
}

/// The parameters table of a dataset: each varied parameter's path and unit, and one row per run
/// (failed runs included, with their error).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamsTable {
    /// (path, SI unit) of each parameter, in column order.
    pub parameters: Vec<(String, String)>,
    /// One row per run.
    pub rows: Vec<ParamsRow>,
}

/// Reads `params.parquet` with its parameter names and units (from the file's own schema).
pub fn read_params_table(dir: &Path) -> Result<ParamsTable, DatasetError> {
    let path = dir.join("params.parquet");
    let f = File::open(&path).map_err(io("open", &path))?;
    let schema = ParquetRecordBatchReaderBuilder::try_new(f).map_err(at(&path))?.schema().clone();
    let fields = schema.fields();
    let has_error = fields.last().is_some_and(|f| f.name() == "error");
    let end = fields.len() - usize::from(has_error);
    if end < 3 {
        return Err(content(&path, format!("not a lash params table (columns: {})", fields.len())));
    }
    let parameters: Vec<(String, String)> = fields[3..end]
        .iter()
        .map(|f| (f.name().clone(), f.metadata().get("unit").cloned().unwrap_or_default()))
        .collect();
    let rows = read_params(dir, parameters.len())?;
    Ok(ParamsTable { parameters, rows })
}

/// A dataset's samples as one array: the runs that completed, each with the same sample times.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetArrays {
    /// Run ids, in the order of `values`.
    pub run_ids: Vec<u64>,
    /// Sample times of every run \[s\].
    pub time: Vec<f64>,
    /// (name, SI unit) of each channel, in the order of `values`' last axis.
    pub channels: Vec<(String, String)>,
    /// Samples, runs × samples × channels, row-major (channels fastest).
    pub values: Vec<f64>,
}

/// The error of a run (the last of `run_ids`) whose sample count differs from the first run's.
fn short(path: &Path, run_ids: &[u64], samples: usize, first: usize) -> DatasetError {
    let message = format!(
        "run {} has {samples} samples, run {} has {first}: runs of one array need the same sample times",
        run_ids[run_ids.len() - 1],
        run_ids[0]
    );
    content(path, message)
}

/// Reads `data.parquet` of a sweep's output folder into one runs × samples × channels array,
/// filled in place from the Parquet column chunks (each sample is written once). Every run must
/// have the same sample times, as a sweep writes them (one horizon, one sample rate); a failed run
/// has no rows and is not in the array (it is in [`read_params_table`] with its error).
pub fn read_dataset(dir: &Path) -> Result<DatasetArrays, DatasetError> {
    read_runs(dir, None)
}

/// The row groups of `data.parquet` (one per completed run, in run order), each with its run id
/// and row count, from the manifest and the file's footer (no sample is read).
pub fn read_layout(dir: &Path) -> Result<Vec<(u64, usize)>, DatasetError> {
    let manifest = Manifest::read(dir)?.ok_or_else(|| content(dir, "no manifest.json (not a lash dataset)"))?;
    let path = dir.join("data.parquet");
    let file = File::open(&path).map_err(io("open", &path))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(at(&path))?;
    let groups: Vec<usize> = builder.metadata().row_groups().iter().map(|g| g.num_rows().max(0) as usize).collect();
    let ok: Vec<(u64, usize)> =
        manifest.runs.iter().filter(|r| r.status == "ok" && r.rows > 0).map(|r| (r.run_id, r.rows as usize)).collect();
    if ok.len() != groups.len() || ok.iter().zip(&groups).any(|((_, rows), g)| rows != g) {
        return Err(content(
            dir,
            format!(
                "the manifest's {} completed runs do not match data.parquet's {} row groups",
                ok.len(),
                groups.len()
            ),
        ));
    }
    Ok(ok)
}

/// [`read_dataset`] of the row groups `groups` only (None: all), in the order given — the runs of
/// one training batch, read without the rest of the file.
pub fn read_runs(dir: &Path, groups: Option<&[usize]>) -> Result<DatasetArrays, DatasetError> {
    let path = dir.join("data.parquet");
    let file = File::open(&path).map_err(io("open", &path))?;
    let mut builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(at(&path))?;
    let count = builder.metadata().num_row_groups();
    if let Some(groups) = groups {
        if let Some(bad) = groups.iter().find(|g| **g >= count) {
            return Err(content(&path, format!("no row group {bad} (the file has {count}: one per completed run)")));
        }
        builder = builder.with_row_groups(groups.to_vec());
    }
    let schema = builder.schema().clone();
    if schema.fields().len() < 2 || schema.field(0).name() != "run_id" || schema.field(1).name() != "t" {
        return Err(content(&path, "not a lash dataset (its first columns must be run_id, t)"));
    }
    let channels: Vec<(String, String)> = schema.fields()[2..]
        .iter()
        .map(|f| (f.name().clone(), f.metadata().get("unit").cloned().unwrap_or_default()))
        .collect();
    let rows: i64 = match groups {
        Some(groups) => groups.iter().map(|&g| builder.metadata().row_group(g).num_rows()).sum(),
        None => builder.metadata().row_groups().iter().map(|g| g.num_rows()).sum(),
    };
    let width = channels.len();
    let mut values = Vec::with_capacity(rows.max(0) as usize * width);
    let (mut run_ids, mut time, mut this_run) = (Vec::new(), Vec::new(), 0usize);
    let reader = builder.build().map_err(at(&path))?;
    for batch in reader {
        let batch = batch.map_err(at(&path))?;
        let ids = batch
            .column(0)
            .as_any()
            .downcast_ref::<UInt64Array>()
            .ok_or_else(|| content(&path, "run_id is not UInt64"))?;
        let f64s = |i: usize| {
            batch
                .column(i)
                .as_any()
                .downcast_ref::<Float64Array>()
                .map(|a| a.values())
                .ok_or_else(|| content(&path, format!("column {} is not Float64", schema.field(i).name())))
        };
        let t = f64s(1)?;
        let columns: Vec<&[f64]> = (2..2 + width).map(|i| f64s(i).map(|v| &v[..])).collect::<Result<_, _>>()?;
        for r in 0..batch.num_rows() {
            let id = ids.value(r);
            if run_ids.last() != Some(&id) {
                // The first run's times are every run's: each later run is checked against them.
                if run_ids.len() > 1 && this_run != time.len() {
                    return Err(short(&path, &run_ids, this_run, time.len()));
                }
                run_ids.push(id);
                this_run = 0;
            }
            if run_ids.len() == 1 {
                time.push(t[r]);
            } else if this_run >= time.len() || time[this_run].to_bits() != t[r].to_bits() {
                return Err(content(
                    &path,
                    format!(
                        "run {id}'s sample {this_run} is at t = {} s, run {}'s at {}: runs of one array need the same sample times",
                        t[r],
                        run_ids[0],
                        time.get(this_run).map_or("(none)".to_string(), |v| format!("{v} s"))
                    ),
                ));
            }
            this_run += 1;
            values.extend(columns.iter().map(|c| c[r]));
        }
    }
    if run_ids.len() > 1 && this_run != time.len() {
        return Err(short(&path, &run_ids, this_run, time.len()));
    }
    Ok(DatasetArrays { run_ids, time, channels, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_parquet_carries_each_parameters_unit() {
        assert_eq!(parameter_unit("drivers[0].motion.omega"), "rad/s");
        assert_eq!(parameter_unit("joints[1].point1[0]"), "m");
        assert_eq!(parameter_unit("clearances[0].bush.material.young_modulus"), "Pa");
        let dir = std::env::temp_dir().join(format!("lash-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let parameters = vec!["clearances[0].bearing_radius".to_string(), "drivers[0].motion.omega".to_string()];
        let rows = vec![ParamsRow {
            run_id: 0,
            seed: 1,
            status: "failed".into(),
            values: vec![0.01, 500.0],
            error: "penetration exceeds 0.1 × the journal radius".into(),
        }];
        write_params(&dir, &parameters, &rows).unwrap();
        let file = File::open(dir.join("params.parquet")).unwrap();
        let schema = ParquetRecordBatchReaderBuilder::try_new(file).unwrap().schema().clone();
        let unit = |name: &str| schema.field_with_name(name).unwrap().metadata().get("unit").cloned();
        assert_eq!(unit("clearances[0].bearing_radius").as_deref(), Some("m"));
        assert_eq!(unit("drivers[0].motion.omega").as_deref(), Some("rad/s"));
        assert_eq!(read_params(&dir, 2).unwrap(), rows);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_series_of_several_row_groups_reads_back_bit_for_bit() {
        let path = std::env::temp_dir().join(format!("lash-series-{}.parquet", std::process::id()));
        let columns = vec![("time".to_string(), "s".to_string()), ("x".to_string(), "m".to_string())];
        let mut w = SeriesWriter::create(&path, &columns).unwrap();
        let n = SeriesWriter::GROUP * 2 + 17;
        let rows: Vec<f64> = (0..n).flat_map(|i| [i as f64 * 1e-5, (i as f64).sin() * 1e-7]).collect();
        for chunk in rows.chunks(2 * 1000) {
            w.append(chunk).unwrap();
        }
        assert_eq!(w.rows(), n as u64);
        w.finish().unwrap();
        let (names, back) = read_series(&path).unwrap();
        assert_eq!(names, columns);
        assert_eq!(back[0].len(), n);
        for i in 0..n {
            assert_eq!(back[0][i].to_bits(), rows[2 * i].to_bits());
            assert_eq!(back[1][i].to_bits(), rows[2 * i + 1].to_bits());
        }
        let _ = std::fs::remove_file(&path);
    }

    /// Errors are typed and chain to their cause: a missing file is an I/O error whose source
    /// is the operating system's "not found"; a bad cell names the file, the column and the
    /// line; a CSV given as Parquet is Parquet's own error, with the file.
    #[test]
    fn reading_errors_name_the_file_and_chain_to_their_cause() {
        use std::error::Error;
        let dir = std::env::temp_dir().join(format!("lash-dataset-errors-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("missing.csv");
        let e = read_any_series(&missing).unwrap_err();
        assert!(matches!(&e, DatasetError::Io { action: "read", path, .. } if path == &missing), "{e:?}");
        let cause = e.source().and_then(|s| s.downcast_ref::<std::io::Error>()).expect("an io::Error source");
        assert_eq!(cause.kind(), std::io::ErrorKind::NotFound);

        let bad = dir.join("bad.csv");
        std::fs::write(&bad, "time [s],slider.ax [m/s^2]\n0,1\n1e-4,\n").unwrap();
        let e = read_any_series(&bad).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, DatasetError::Content { .. }), "{e:?}");
        assert!(text.contains("bad.csv") && text.contains("\"slider.ax\"") && text.contains("line 3"), "{text}");

        let fake = dir.join("fake.parquet");
        std::fs::write(&fake, "time,x\n0,1\n").unwrap();
        let e = read_any_series(&fake).unwrap_err();
        assert!(matches!(&e, DatasetError::Parquet { path, .. } if path == &fake), "{e:?}");
        assert!(e.source().is_some_and(|s| s.is::<parquet::errors::ParquetError>()));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_part_holds_each_run_as_a_row_group_and_appears_only_when_closed() {
        let dir = std::env::temp_dir().join(format!("lash-part-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let channels = vec![ChannelInfo { name: "slider.ax".into(), unit: "m/s^2".into() }];
        let schema = data_schema(&channels);
        let record = |id| RunRecord {
            run_id: id,
            seed: 0,
            status: "ok".into(),
            error: None,
            rows: 0,
            simulate_s: 0.0,
            write_s: 0.0,
            part: None,
            row_group: None,
        };
        let batches: Vec<RecordBatch> = [(3u64, 5usize), (8, 1), (9, 7)]
            .iter()
            .map(|&(id, n)| {
                let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-4).collect();
                let x: Vec<f64> = (0..n).map(|i| (id as f64 + i as f64).sin() * 1e3).collect();
                RunData { run_id: id, time: t, columns: vec![x] }.into_batch(&schema).unwrap()
            })
            .collect();
        let mut part = PartWriter::create(&dir, 3, &schema).unwrap();
        for b in &batches {
            let id = b.column(0).as_any().downcast_ref::<UInt64Array>().unwrap().value(0);
            part.append(b, record(id)).unwrap();
        }
        assert_eq!(part.len(), 3);
        let path = dir.join("runs-000000003.parquet");
        assert!(!path.exists(), "an open part must not look finished");
        let records = part.close().unwrap();
        assert!(path.exists());
        for (g, (r, b)) in records.iter().zip(&batches).enumerate() {
            assert_eq!((r.part.as_deref(), r.row_group), (Some("runs-000000003.parquet"), Some(g)));
            let file = File::open(&path).unwrap();
            let reader =
                ParquetRecordBatchReaderBuilder::try_new(file).unwrap().with_row_groups(vec![g]).build().unwrap();
            let back: Vec<RecordBatch> = reader.map(Result::unwrap).collect();
            assert_eq!(back.len(), 1);
            assert_eq!(&back[0], b, "row group {g}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
