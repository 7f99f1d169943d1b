//! What the page's plots draw, reduced to what a reader can see: every channel of every run
//! (min–max decimated, so that no impact peak is lost), its amplitude spectrum, the crank angle,
//! each clearance joint's orbit, the animation, and the runs' key figures.

use crate::mechanism::Animation;
use crate::runs::{Run, RunFolder};
use lash_scenario::AnyScenario;
use serde::Serialize;
use std::collections::BTreeMap;

/// The points the page embeds over time for all runs and channels together, at most (each
/// channel then keeps at least [`MIN_POINTS`]): a page of some 12 MB at most.
pub const POINT_BUDGET: usize = 600_000;
/// Fewest points a channel keeps over time.
pub const MIN_POINTS: usize = 1_000;
/// Most points a channel keeps over time.
pub const MAX_POINTS: usize = 10_000;
/// Most points of a spectrum (the largest amplitude of each group of bins is kept).
pub const SPECTRUM_POINTS: usize = 1_500;
/// Most points of an orbit or of the crank angle's table.
pub const PATH_POINTS: usize = 8_000;

/// A channel's samples as drawn: `t` only when decimated (else the run's `time`).
#[derive(Debug, Clone, Serialize)]
pub struct Trace {
    /// Sample times \[s\] (absent: the run's time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t: Option<Vec<f32>>,
    /// Values.
    pub y: Vec<f32>,
    /// Amplitude spectrum: frequencies \[Hz\].
    pub f: Vec<f32>,
    /// Amplitudes (the channel's unit).
    pub a: Vec<f32>,
}

/// One run's data.
#[derive(Debug, Clone, Serialize)]
pub struct RunData {
    /// `full`, `reduced`, `ideal` or the model's name.
    pub label: String,
    /// Sample times \[s\] when the channels are not decimated (else empty).
    pub time: Vec<f32>,
    /// Channel → its trace.
    pub channels: BTreeMap<String, Trace>,
    /// Crank angle table: times \[s\] and the unwrapped angle \[°\] (empty: no crank).
    pub crank_t: Vec<f32>,
    /// See `crank_t`.
    pub crank_deg: Vec<f32>,
    /// Key figures from its summary.json.
    pub summary: serde_json::Value,
}

/// One clearance joint's orbit: the eccentricity of each run inside the circle of radius c.
#[derive(Debug, Clone, Serialize)]
pub struct Orbit {
    /// The joint.
    pub joint: String,
    /// Radial clearance c = R_B − R_J \[m\].
    pub clearance: f64,
    /// The eccentricity's components drawn (`ex`, `ey` or, spatial, the two of largest spread).
    pub axes: [String; 2],
    /// Per run: (label, horizontal, vertical) \[m\].
    pub runs: Vec<(String, Vec<f32>, Vec<f32>)>,
}

/// Everything the page draws.
#[derive(Debug, Clone, Serialize)]
pub struct Content {
    /// Scenario name.
    pub scenario: String,
    /// Its description.
    pub description: String,
    /// Channel names in display order, with units.
    pub channels: Vec<(String, String)>,
    /// The channel shown first.
    pub first_channel: String,
    /// Runs.
    pub runs: Vec<RunData>,
    /// Orbits.
    pub orbits: Vec<Orbit>,
    /// The animation (absent: see `notes`).
    pub animation: Option<Animation>,
    /// A comparison's speed-ups (comparison.json).
    pub speedup: serde_json::Value,
    /// What could not be shown, and why.
    pub notes: Vec<String>,
}

/// Min–max decimation to about `points` points: each group of samples keeps its smallest and
/// largest value in time order. Returns the kept indices (all when there are few enough).
pub fn min_max_indices(y: &[f64], points: usize) -> Vec<usize> {
    let n = y.len();
    if n <= points {
        return (0..n).collect();
    }
    let groups = (points / 2).max(1);
    let mut kept = Vec::with_capacity(2 * groups);
    for g in 0..groups {
        let (a, b) = (g * n / groups, ((g + 1) * n / groups).max(g * n / groups + 1));
        let (mut lo, mut hi) = (a, a);
        for i in a..b {
            if y[i] < y[lo] {
                lo = i;
            }
            if y[i] > y[hi] {
                hi = i;
            }
        }
        kept.push(lo.min(hi));
        if hi != lo {
            kept.push(lo.max(hi));
        }
    }
    kept
}

/// Every `n / points`-th index (all when there are few enough), the last one included.
fn even_indices(n: usize, points: usize) -> Vec<usize> {
    if n <= points {
        return (0..n).collect();
    }
    (0..points).map(|k| k * (n - 1) / (points - 1)).collect()
}

/// The amplitude spectrum of uniformly sampled `y`, its bins grouped to [`SPECTRUM_POINTS`] by
/// their largest amplitude (a log-scale plot shows the peaks).
fn spectrum(y: &[f64], dt: f64) -> (Vec<f32>, Vec<f32>) {
    let (f, a) = lash_metrics::amplitude_spectrum(y, dt);
    if f.len() < 2 {
        return (vec![], vec![]);
    }
    // The mean is removed (bin 0 is 0): the plot starts at the first bin.
    let (f, a) = (&f[1..], &a[1..]);
    let groups = SPECTRUM_POINTS.min(f.len());
    (0..groups)
        .map(|g| {
            let (lo, hi) = (g * f.len() / groups, ((g + 1) * f.len() / groups).max(g * f.len() / groups + 1));
            let k = (lo..hi).max_by(|&i, &j| a[i].total_cmp(&a[j])).unwrap_or(lo);
            (f[k] as f32, a[k] as f32)
        })
        .unzip()
}

/// The names of the scenario's pose channels (animated, not plotted), from its channel list.
fn pose_channels(s: &AnyScenario) -> Vec<String> {
    use lash_scenario::channels::Source;
    use lash_scenario::spatial::SpatialSource;
    match s {
        AnyScenario::Planar(p) => lash_scenario::channels::channel_sources(p, false)
            .into_iter()
            .filter(|(_, src)| matches!(src, Source::BodyPose(..)))
            .map(|(c, _)| c.name)
            .collect(),
        AnyScenario::Spatial(p) => lash_scenario::spatial::spatial_channels(p, false)
            .into_iter()
            .filter(|(_, src)| matches!(src, SpatialSource::BodyPose(..)))
            .map(|(c, _)| c.name)
            .collect(),
    }
}

/// The crank angle of `run` at each sample \[rad\]: the first driver's prescribed angle, else
/// (planar) the angle of the first body pinned to the ground.
fn crank_angle(s: &AnyScenario, run: &Run) -> Option<Vec<f64>> {
    let time = run.time();
    match s {
        AnyScenario::Planar(p) => {
            let body = p.drivers.first().map(|d| d.body.clone()).or_else(|| {
                p.joints
                    .iter()
                    .find(|j| {
                        j.kind == lash_scenario::schema::JointType::Revolute
                            && (j.body1 == "ground") != (j.body2 == "ground")
                    })
                    .map(|j| if j.body1 == "ground" { j.body2.clone() } else { j.body1.clone() })
            })?;
            let angle_quantity = lash_scenario::channels::POSE_QUANTITIES[2].0;
            if let Some(angle) = run.column(&format!("{body}.{angle_quantity}")) {
                return Some(angle.to_vec());
            }
            p.drivers.first().map(|d| time.iter().map(|&t| d.motion.eval(t).0).collect())
        }
        AnyScenario::Spatial(p) => p.drivers.first().map(|d| time.iter().map(|&t| d.motion.eval(t).0).collect()),
    }
}

/// The orbits of every clearance joint over the runs that have them.
fn orbits(s: &AnyScenario, runs: &[Run]) -> Vec<Orbit> {
    let spatial = matches!(s, AnyScenario::Spatial(_));
    let components: &[&str] = if spatial { &["ex", "ey", "ez"] } else { &["ex", "ey"] };
    s.clearances()
        .iter()
        .map(|c| {
            let columns: Vec<(String, Vec<&[f64]>)> = runs
                .iter()
                .filter_map(|r| {
                    let cs: Option<Vec<&[f64]>> =
                        components.iter().map(|q| r.column(&format!("{}.{q}", c.joint))).collect();
                    cs.map(|cs| (r.label.clone(), cs))
                })
                .collect();
            // The two components of largest spread (planar: ex, ey).
            let spread =
                |k: usize| columns.iter().flat_map(|(_, cs)| cs[k].iter()).fold(0.0_f64, |m, v| m.max(v.abs()));
            let mut order: Vec<usize> = (0..components.len()).collect();
            order.sort_by(|&a, &b| spread(b).total_cmp(&spread(a)));
            let mut axes = [order[0], order[1]];
            axes.sort_unstable();
            Orbit {
                joint: c.joint.clone(),
                clearance: c.bearing_radius - c.journal_radius,
                axes: axes.map(|k| components[k].to_string()),
                runs: columns
                    .iter()
                    .map(|(label, cs)| {
                        let idx = even_indices(cs[0].len(), PATH_POINTS);
                        let pick = |k: usize| idx.iter().map(|&i| cs[axes[k]][i] as f32).collect();
                        (label.clone(), pick(0), pick(1))
                    })
                    .collect(),
            }
        })
        .collect()
}

fn run_data(s: &AnyScenario, run: &Run, channels: &[(String, String)], points: usize) -> RunData {
    let time = run.time();
    let dt = (time[time.len() - 1] - time[0]) / (time.len() - 1) as f64;
    let decimated = time.len() > points;
    let mut traces = BTreeMap::new();
    for (name, _) in channels {
        let Some(y) = run.column(name) else { continue };
        let (f, a) = spectrum(y, dt);
        let trace = if decimated {
            let idx = min_max_indices(y, points);
            Trace {
                t: Some(idx.iter().map(|&i| time[i] as f32).collect()),
                y: idx.iter().map(|&i| y[i] as f32).collect(),
                f,
                a,
            }
        } else {
            Trace { t: None, y: y.iter().map(|&v| v as f32).collect(), f, a }
        };
        traces.insert(name.clone(), trace);
    }
    let (crank_t, crank_deg) = crank_angle(s, run).map_or((vec![], vec![]), |angle| {
        even_indices(time.len(), PATH_POINTS).iter().map(|&i| (time[i] as f32, angle[i].to_degrees() as f32)).unzip()
    });
    let keys = ["model", "wall_time_s", "cpu_time_s", "samples", "steps", "horizon", "clearances", "warnings"];
    let summary = keys.iter().map(|k| (k.to_string(), run.summary[*k].clone())).collect::<serde_json::Map<_, _>>();
    RunData {
        label: run.label.clone(),
        time: if decimated { vec![] } else { time.iter().map(|&t| t as f32).collect() },
        channels: traces,
        crank_t,
        crank_deg,
        summary: serde_json::Value::Object(summary),
    }
}

impl Content {
    /// What the page shows of `folder`.
    pub fn of(folder: &RunFolder) -> Self {
        let s = &folder.scenario;
        let poses = pose_channels(s);
        let mut channels: Vec<(String, String)> = Vec::new();
        for run in &folder.runs {
            for (name, unit) in run.names.iter().zip(&run.units).skip(1) {
                if !poses.contains(name) && !channels.iter().any(|(n, _)| n == name) {
                    channels.push((name.clone(), unit.clone()));
                }
            }
        }
        let per_channel = POINT_BUDGET / (channels.len() * folder.runs.len()).max(1);
        let points = per_channel.clamp(MIN_POINTS, MAX_POINTS);
        let mut notes = Vec::new();
        let animation = match crate::mechanism::animation(s, &folder.runs[0]) {
            Ok(a) => Some(a),
            Err(e) => {
                notes.push(e.to_string());
                None
            }
        };
        notes.extend(folder.comparison.as_ref().and_then(bounds_note));
        // The first sensor's acceleration (what the papers plot), else the first channel.
        let first_channel = channels
            .iter()
            .map(|(n, _)| n)
            .find(|n| n.ends_with(".ax"))
            .or(channels.first().map(|(n, _)| n))
            .cloned()
            .unwrap_or_default();
        let (scenario, description) = match s {
            AnyScenario::Planar(p) => (p.name.clone(), p.description.clone()),
            AnyScenario::Spatial(p) => (p.name.clone(), p.description.clone()),
        };
        Content {
            scenario,
            description,
            runs: folder.runs.iter().map(|r| run_data(s, r, &channels, points)).collect(),
            orbits: orbits(s, &folder.runs),
            channels,
            first_channel,
            animation,
            speedup: folder.comparison.as_ref().map_or(serde_json::Value::Null, |c| c["speedup"].clone()),
            notes,
        }
    }
}

/// A comparison's stated bounds in one line: how many hold over the window of steady running,
/// and the ones that do not.
fn bounds_note(comparison: &serde_json::Value) -> Option<String> {
    let bounds = &comparison["bounds"];
    let checks = bounds["checks"].as_array()?;
    let missed: Vec<String> = checks
        .iter()
        .filter(|c| c["met"] == false)
        .map(|c| {
            let q = c["quantity"].as_str().unwrap_or("");
            let (full, reduced) = (c["full"].as_f64().unwrap_or(f64::NAN), c["reduced"].as_f64().unwrap_or(f64::NAN));
            if c["kind"] != "relative" {
                format!("{q} (full {full:.3e}, reduced {reduced:.3e})")
            } else {
                format!("{q} {:+.1} %", 100.0 * c["error"].as_f64().unwrap_or(f64::NAN))
            }
        })
        .collect();
    let start = bounds["window"]["start"].as_f64().unwrap_or(0.0);
    let head = format!(
        "Stated bounds of the reduced model over t ≥ {start:.4} s (steady running): {} of {} met",
        checks.len() - missed.len(),
        checks.len()
    );
    Some(if missed.is_empty() { head } else { format!("{head}; not met: {}", missed.join(", ")) })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds' note reads each missed check by its kind: a relative error in per cent, a
    /// ratio (band power, onsets) by both values.
    #[test]
    fn the_bounds_note_reads_each_check_by_its_kind() {
        let check = |quantity: &str, kind: lash_metrics::CheckKind, error: f64, met: bool| lash_metrics::Check {
            quantity: quantity.into(),
            kind,
            full: 2.0,
            reduced: 5.0,
            error,
            bound: 2.0,
            met,
        };
        use lash_metrics::CheckKind::{Onsets, Ratio, Relative};
        let checks = [
            check("slider.ax rms", Relative, 0.123, false),
            check("slider.ax power 500-1000 Hz", Ratio, 2.5, false),
            check("pin.force impacts_per_revolution", Onsets, 2.5, false),
            check("pin.force mean", Relative, 0.01, true),
        ];
        let comparison = serde_json::json!({ "bounds": { "window": { "start": 0.012 }, "checks": checks } });
        let note = bounds_note(&comparison).expect("a note");
        assert!(note.contains("over t ≥ 0.0120 s (steady running): 1 of 4 met"), "{note}");
        assert!(note.contains("slider.ax rms +12.3 %"), "{note}");
        assert!(note.contains("slider.ax power 500-1000 Hz (full 2.000e0, reduced 5.000e0)"), "{note}");
        assert!(note.contains("pin.force impacts_per_revolution (full 2.000e0, reduced 5.000e0)"), "{note}");
        assert!(!note.contains("pin.force mean"), "{note}");
    }

    #[test]
    fn min_max_decimation_keeps_every_extreme_in_time_order() {
        // A quiet signal with two one-sample spikes: both survive a 100-fold decimation.
        let mut y: Vec<f64> = (0..100_000).map(|i| (i as f64 * 1e-3).sin()).collect();
        y[31_337] = 50.0;
        y[77_777] = -40.0;
        let idx = min_max_indices(&y, 1_000);
        assert!(idx.len() <= 1_000);
        assert!(idx.windows(2).all(|w| w[0] < w[1]), "time order");
        assert!(idx.contains(&31_337) && idx.contains(&77_777));
        assert_eq!(min_max_indices(&y[..10], 1_000), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn spectrum_grouping_keeps_the_peak_of_a_sine() {
        // 1 s of a 1234 Hz sine of amplitude 3 at 50 kHz: the grouped spectrum's largest point is
        // at the sine's frequency with (Hann, amplitude-corrected) about its amplitude.
        let dt = 2e-5;
        let y: Vec<f64> = (0..50_000).map(|i| 3.0 * (std::f64::consts::TAU * 1234.0 * i as f64 * dt).sin()).collect();
        let (f, a) = spectrum(&y, dt);
        assert!(f.len() <= SPECTRUM_POINTS);
        let k = (0..a.len()).max_by(|&i, &j| a[i].total_cmp(&a[j])).unwrap();
        assert!((f[k] - 1234.0).abs() <= 1.0, "peak at {} Hz", f[k]);
        assert!((a[k] - 3.0).abs() < 0.05, "amplitude {}", a[k]);
    }
}
