//! A measured file, read as untrusted input.
//!
//! CSV (a header `time [s],slider.ax [m/s^2],…`, as `lash run` writes) or Parquet (Float64
//! columns with a `unit` in each field's metadata, as lash's Parquet time series). Each problem is
//! an error naming the column and, where it has one, the row: a missing or unknown unit, a unit
//! that does not match the channel's quantity, an empty field or NaN, time stamps that do not
//! increase or are not evenly spaced (a missing sample), a clipped channel (its extreme value held
//! for several samples), a sample rate below the one the estimator was prepared for, a record
//! shorter than a crank revolution or than the prepared window.
//!
//! Made safe where it is: units converted (`g`, `mm/s^2`, `ms`, `rpm`, …), and a sample rate that
//! is a whole multiple of the prepared one filtered (the prepared anti-alias cut-off) and
//! decimated. Any other rate is refused rather than interpolated.

use crate::EstimateError;
use crate::setup::SensorChannel;
use std::path::Path;

/// A measurement, checked and brought to the prepared sample rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Sample rate \[Hz\] (the prepared one).
    pub sample_rate: f64,
    /// The prepared channels, in the setup's order, in SI units.
    pub channels: Vec<Vec<f64>>,
    /// Mean crank speed from a tachometer column, when the file has one \[rad/s\].
    pub speed: Option<f64>,
    /// Notes on what was done to the data (conversion, decimation, the part used).
    pub notes: Vec<String>,
}

/// What the reader needs to know of the prepared estimator.
#[derive(Debug, Clone)]
pub struct Expect<'a> {
    /// The channels, in order.
    pub channels: &'a [SensorChannel],
    /// Prepared sample rate \[Hz\].
    pub sample_rate: f64,
    /// Anti-alias cut-off \[Hz\] for a decimation.
    pub anti_alias: f64,
    /// Length used \[s\] (the first this many seconds of a longer file).
    pub window: f64,
    /// Longest crank revolution of the prior \[s\].
    pub revolution: f64,
}

/// Names accepted for the tachometer column, and the time column.
const TACHOMETER: [&str; 3] = ["crank.speed", "crank.omega", "tachometer"];
const TIME: [&str; 2] = ["time", "t"];

/// The factor to SI of `unit` for a quantity of SI unit `si`, or `None` if it is not one of its units.
fn to_si(si: &str, unit: &str) -> Option<f64> {
    let unit = unit.trim().replace('²', "^2").replace(' ', "");
    let factor = match (si, unit.as_str()) {
        ("m/s^2", "m/s^2" | "m/s2" | "m s^-2") => 1.0,
        ("m/s^2", "mm/s^2" | "mm/s2") => 1e-3,
        ("m/s^2", "g" | "g0" | "gn") => 9.806_65,
        ("s", "s") => 1.0,
        ("s", "ms") => 1e-3,
        ("s", "us" | "µs") => 1e-6,
        ("rad/s", "rad/s") => 1.0,
        ("rad/s", "rpm" | "1/min") => std::f64::consts::TAU / 60.0,
        ("rad/s", "Hz" | "rev/s") => std::f64::consts::TAU,
        ("m/s", "m/s") => 1.0,
        ("m/s", "mm/s") => 1e-3,
        ("m", "m") => 1.0,
        ("m", "mm") => 1e-3,
        ("m", "um" | "µm") => 1e-6,
        ("N", "N") => 1.0,
        ("N", "kN") => 1e3,
        _ => return None,
    };
    Some(factor)
}

/// The columns of a file: (name, unit), values.
type Columns = (Vec<(String, Option<String>)>, Vec<Vec<f64>>);

/// A CSV or Parquet file's columns (the one reader of a time series, lash-sweep's), a unit
/// `None` where the header gives none.
fn read_columns(path: &Path) -> Result<Columns, EstimateError> {
    let (names, columns) = lash_sweep::dataset::read_any_series(path).map_err(EstimateError::Measurement)?;
    let names = names.into_iter().map(|(n, u)| (n, (!u.is_empty()).then_some(u))).collect();
    Ok((names, columns))
}

/// The column named `name` (converted to SI unit `si`), or `None` when the file has none.
fn column(path: &Path, file: &Columns, name: &str, si: &str) -> Result<Option<Vec<f64>>, EstimateError> {
    let Some(k) = file.0.iter().position(|(n, _)| n == name) else { return Ok(None) };
    let input = |m: String| EstimateError::Input(format!("{}: column {name:?}: {m}", path.display()));
    let unit = file.0[k].1.as_deref().ok_or_else(|| input(format!("no unit (write the header as `{name} [{si}]`)")))?;
    let factor = to_si(si, unit).ok_or_else(|| input(format!("unit {unit:?} is not a unit of {si}")))?;
    let values = &file.1[k];
    if let Some(row) = values.iter().position(|v| !v.is_finite()) {
        return Err(input(format!("sample {row} is {} (a missing or invalid sample)", values[row])));
    }
    Ok(Some(values.iter().map(|v| v * factor).collect()))
}

/// Refuses a channel that holds its extreme value for several samples in a row: a clipped
/// sensor or logger range, whose impacts are cut off.
fn check_clipping(path: &Path, name: &str, values: &[f64]) -> Result<(), EstimateError> {
    for (what, extreme) in [
        ("maximum", values.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
        ("minimum", values.iter().copied().fold(f64::INFINITY, f64::min)),
    ] {
        let mut longest = 0usize;
        let mut run = 0usize;
        let mut at = 0usize;
        for (i, &v) in values.iter().enumerate() {
            run = if v == extreme { run + 1 } else { 0 };
            if run > longest {
                (longest, at) = (run, i + 1 - run);
            }
        }
        if longest >= 3 {
            return Err(EstimateError::Input(format!(
                "{}: column {name:?}: clipped: its {what} {extreme} is held for {longest} samples from sample {at} (the sensor or logger range was exceeded; impacts are cut off)",
                path.display()
            )));
        }
    }
    Ok(())
}

/// The sample period of the time column, checked: increasing and evenly spaced within 1 %.
fn sample_period(path: &Path, name: &str, time: &[f64]) -> Result<f64, EstimateError> {
    let input = |m: String| EstimateError::Input(format!("{}: column {name:?}: {m}", path.display()));
    if time.len() < 2 {
        return Err(input(format!("{} samples: too few for a sample rate", time.len())));
    }
    let steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    if let Some(k) = steps.iter().position(|s| !(*s > 0.0)) {
        return Err(input(format!(
            "time stamps do not increase at sample {} ({} then {})",
            k + 1,
            time[k],
            time[k + 1]
        )));
    }
    let dt = {
        let mut sorted = steps.clone();
        sorted.sort_by(f64::total_cmp);
        sorted[sorted.len() / 2]
    };
    if let Some(k) = steps.iter().position(|s| (s - dt).abs() > 0.01 * dt) {
        return Err(input(format!(
            "irregular time stamps at sample {}: a step of {} s where the others are {dt} s (missing samples, or a logger that does not keep its rate)",
            k + 1,
            steps[k]
        )));
    }
    Ok(dt)
}

impl Measurement {
    /// Reads and checks `path` against what the estimator was prepared for.
    pub fn read(path: &Path, expect: &Expect<'_>) -> Result<Self, EstimateError> {
        let input = |m: String| EstimateError::Input(format!("{}: {m}", path.display()));
        let file = read_columns(path)?;
        let time_name = TIME
            .iter()
            .find(|t| file.0.iter().any(|(n, _)| n == *t))
            .ok_or_else(|| input("no time column (`time [s]`)".into()))?;
        let time = column(path, &file, time_name, "s")?.unwrap_or_default();
        let dt = sample_period(path, time_name, &time)?;
        let mut notes = Vec::new();
        let mut channels = Vec::new();
        for c in expect.channels {
            let values = column(path, &file, &c.name, &c.unit)?.ok_or_else(|| {
                let have: Vec<&str> = file.0.iter().map(|(n, _)| n.as_str()).collect();
                input(format!("no column {:?} (the estimator was prepared for it); the file has {have:?}", c.name))
            })?;
            check_clipping(path, &c.name, &values)?;
            channels.push(values);
        }
        let speed = match TACHOMETER.iter().find(|t| file.0.iter().any(|(n, _)| n == *t)) {
            Some(name) => {
                let w = column(path, &file, name, "rad/s")?.unwrap_or_default();
                Some(w.iter().sum::<f64>() / w.len().max(1) as f64)
            }
            None => None,
        };
        let rate = 1.0 / dt;
        let duration = dt * time.len() as f64;
        if duration < expect.revolution {
            return Err(input(format!(
                "{duration:.4} s of data: shorter than one crank revolution ({:.4} s at the slowest speed of the prior)",
                expect.revolution
            )));
        }
        let ratio = rate / expect.sample_rate;
        let factor = ratio.round();
        if ratio < 1.0 - 1e-6 {
            return Err(input(format!(
                "sample rate {rate:.6} Hz is below the {} Hz the estimator was prepared for (its features reach {} Hz)",
                expect.sample_rate, expect.anti_alias
            )));
        }
        if (ratio - factor).abs() > 1e-6 * ratio {
            return Err(input(format!(
                "sample rate {rate:.6} Hz is not a whole multiple of the prepared {} Hz: resample it first (lash does not interpolate measurements)",
                expect.sample_rate
            )));
        }
        if factor > 1.0 {
            let logger = lash_measure::Acquisition {
                sample_rate: expect.sample_rate,
                cutoff: expect.anti_alias,
                order: 4,
                settle: 0.0,
            };
            for values in channels.iter_mut() {
                *values = logger.acquire(values, dt, None).map_err(|e| input(e.to_string()))?;
            }
            notes.push(format!(
                "decimated from {rate:.1} Hz to {} Hz behind a {} Hz anti-alias filter",
                expect.sample_rate, expect.anti_alias
            ));
        }
        let needed = (expect.window * expect.sample_rate).round() as usize;
        let have = channels[0].len();
        if have < needed {
            return Err(input(format!(
                "{:.4} s of data: the estimator was prepared for windows of {} s",
                have as f64 / expect.sample_rate,
                expect.window
            )));
        }
        if have > needed {
            notes.push(format!("the first {} s of {:.3} s used", expect.window, have as f64 / expect.sample_rate));
            channels.iter_mut().for_each(|c| c.truncate(needed));
        }
        Ok(Self { sample_rate: expect.sample_rate, channels, speed, notes })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_convert_to_si_and_others_are_refused() {
        assert_eq!(to_si("m/s^2", "g"), Some(9.806_65));
        assert_eq!(to_si("m/s^2", "m/s²"), Some(1.0));
        assert_eq!(to_si("s", "ms"), Some(1e-3));
        assert!((to_si("rad/s", "rpm").unwrap() * 60.0 - std::f64::consts::TAU).abs() < 1e-12);
        assert_eq!(to_si("m/s^2", "m/s"), None);
        assert_eq!(to_si("m/s^2", "V"), None);
    }

    #[test]
    fn clipping_is_a_held_extreme() {
        let p = Path::new("m.csv");
        assert!(check_clipping(p, "a", &[0.0, 1.0, -1.0, 2.0, 0.5]).is_ok());
        let e = check_clipping(p, "a", &[0.0, 5.0, 5.0, 5.0, 1.0]).unwrap_err().to_string();
        assert!(e.contains("clipped") && e.contains("\"a\"") && e.contains("from sample 1"), "{e}");
    }

    #[test]
    fn uneven_and_decreasing_time_stamps_are_named() {
        let p = Path::new("m.csv");
        assert!((sample_period(p, "time", &[0.0, 0.1, 0.2, 0.3]).unwrap() - 0.1).abs() < 1e-12);
        let e = sample_period(p, "time", &[0.0, 0.1, 0.3, 0.4, 0.5]).unwrap_err().to_string();
        assert!(e.contains("irregular time stamps at sample 2"), "{e}");
        let e = sample_period(p, "time", &[0.0, 0.1, 0.1, 0.2]).unwrap_err().to_string();
        assert!(e.contains("do not increase at sample 2"), "{e}");
    }

    /// A CSV of `rows` (time, value) at `rate` Hz of a 50 Hz sine, edited by `edit`.
    fn file(
        tag: &str,
        header: &str,
        rate: f64,
        rows: usize,
        edit: impl Fn(usize, f64, f64) -> String,
    ) -> std::path::PathBuf {
        let path = std::env::temp_dir().join(format!("lash-measurement-{tag}-{}.csv", std::process::id()));
        let mut text = format!("{header}\n");
        for i in 0..rows {
            let t = i as f64 / rate;
            text.push_str(&edit(i, t, 1000.0 * (std::f64::consts::TAU * 50.0 * t).sin()));
            text.push('\n');
        }
        std::fs::write(&path, text).unwrap();
        path
    }

    fn read(path: &Path) -> Result<Measurement, EstimateError> {
        let channels = [SensorChannel { name: "slider.ax".into(), unit: "m/s^2".into() }];
        let expect =
            Expect { channels: &channels, sample_rate: 1000.0, anti_alias: 400.0, window: 0.5, revolution: 0.1 };
        let m = Measurement::read(path, &expect);
        let _ = std::fs::remove_file(path);
        m
    }

    /// Each problem of a measured file is an input error naming the column and what is wrong;
    /// units convert, and a whole multiple of the rate is decimated.
    #[test]
    fn bad_measurements_are_named_and_good_ones_brought_to_the_prepared_rate() {
        let plain = |_: usize, t: f64, v: f64| format!("{t},{v}");
        let header = "time [s],slider.ax [m/s^2]";
        let good = read(&file("good", header, 1000.0, 800, plain)).unwrap();
        assert_eq!(good.channels[0].len(), 500);
        assert!(good.notes.iter().any(|n| n.contains("first 0.5 s")));
        let in_g =
            read(&file("g", "time [ms],slider.ax [g]", 1000.0, 600, |_, t, v| format!("{},{}", t * 1e3, v / 9.806_65)))
                .unwrap();
        assert!((in_g.channels[0][100] - 1000.0 * (std::f64::consts::TAU * 5.0).sin()).abs() < 1e-6);
        let fast = read(&file("fast", header, 4000.0, 2400, plain)).unwrap();
        assert_eq!(fast.channels[0].len(), 500);
        assert!(fast.notes.iter().any(|n| n.contains("decimated from 4000.0 Hz")));
        let rms = (fast.channels[0].iter().map(|v| v * v).sum::<f64>() / 500.0).sqrt();
        assert!((rms - 1000.0 / 2f64.sqrt()).abs() < 20.0, "the 50 Hz line passes the filter: {rms}");
        let cases: Vec<(&str, std::path::PathBuf, &[&str])> = vec![
            (
                "nan",
                file(
                    "nan",
                    header,
                    1000.0,
                    600,
                    |i, t, v| if i == 7 { format!("{t},NaN") } else { format!("{t},{v}") },
                ),
                &["\"slider.ax\"", "sample 7", "NaN"],
            ),
            (
                "empty",
                file("empty", header, 1000.0, 600, |i, t, v| if i == 9 { format!("{t},") } else { format!("{t},{v}") }),
                &["\"slider.ax\"", "line 11", "not a number"],
            ),
            (
                "gap",
                file("gap", header, 1000.0, 600, |i, t, v| if i == 300 { String::new() } else { format!("{t},{v}") }),
                &["\"time\"", "irregular time stamps at sample 300"],
            ),
            (
                "clipped",
                file("clip", header, 1000.0, 600, |_, t, v| format!("{t},{}", v.min(800.0))),
                &["\"slider.ax\"", "clipped", "800"],
            ),
            ("slow", file("slow", header, 500.0, 600, plain), &["sample rate 500", "below the 1000 Hz"]),
            ("odd rate", file("odd", header, 1500.0, 900, plain), &["not a whole multiple"]),
            (
                "unit",
                file("unit", "time [s],slider.ax [m/s]", 1000.0, 600, plain),
                &["\"slider.ax\"", "\"m/s\" is not a unit of m/s^2"],
            ),
            ("no unit", file("nounit", "time [s],slider.ax", 1000.0, 600, plain), &["\"slider.ax\"", "no unit"]),
            ("short", file("short", header, 1000.0, 50, plain), &["shorter than one crank revolution"]),
            ("window", file("window", header, 1000.0, 300, plain), &["prepared for windows of 0.5 s"]),
            (
                "missing",
                file("missing", "time [s],housing.ay [m/s^2]", 1000.0, 600, plain),
                &["no column \"slider.ax\"", "housing.ay"],
            ),
        ];
        for (what, path, expected) in cases {
            let e = read(&path).unwrap_err();
            assert!(matches!(e, EstimateError::Input(_) | EstimateError::Measurement(_)), "{what}: {e}");
            let text = e.to_string();
            for part in expected {
                assert!(text.contains(part), "{what}: {part:?} missing from: {text}");
            }
        }
    }
}
