//! The `lash` binary end to end: the main job, bad input, blow-ups, example files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lash(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().expect("lash runs")
}

/// A test's scratch folder: removed when the test passes (some write hundreds of MB), kept for a
/// look when it fails.
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn scratch(name: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("lash-cli-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A JSON file the command wrote (summary.json, comparison.json).
fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The RMS of column `name` of a written time series (CSV) over the rows at t ≥ `from` \[s\].
fn column_rms(file: &Path, name: &str, from: f64) -> f64 {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines();
    let k = lines.next().unwrap().split(',').position(|h| h.starts_with(&format!("{name} ["))).unwrap();
    let values: Vec<f64> = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>())
        .filter(|row| row[0] >= from)
        .map(|row| row[k])
        .collect();
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

fn files_in(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default()
}

#[test]
fn full_run_writes_csv_and_summary() {
    let dir = scratch("main");
    let out = dir.join("A");
    let o = lash(&["run", "A", "--out", out.to_str().unwrap(), "--horizon", "0.004", "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in
        ["time [s]", "slider.ax [m/s^2]", "crank_pivot.force [N]", "crank_pivot.eccentricity [m]", "motor.torque [N m]"]
    {
        assert!(header.contains(col), "header lacks {col}: {header}");
    }
    assert_eq!(csv.lines().count(), 1 + 401, "401 samples at 1e-5 s over 4 ms");
    let summary: serde_json::Value = read_json(&out.join("summary.json"));
    for key in ["cpu_time_s", "steps", "rejected_steps", "channels", "clearances"] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    assert!(summary["clearances"][0]["impacts"].as_u64().unwrap() > 0);
    assert!(out.join("scenario.toml").exists());
    assert!(!out.join("timeseries.csv.partial").exists());
}

const VALID_BASE: &str = r#"
name = "test"
[materials.steel]
young_modulus = 207e9
poisson_ratio = 0.3
[[bodies]]
name = "crank"
mass = 0.17
inertia = 1e-4
position = [0.025, 0.0]
[[bodies]]
name = "rod"
mass = 0.15
inertia = 2.5e-4
position = [0.11, 0.0]
[[bodies]]
name = "slider"
mass = 0.06
inertia = 1e-5
position = [0.17, 0.0]
[[joints]]
name = "crank_pivot"
type = "revolute"
body1 = "crank"
point1 = [-0.025, 0.0]
body2 = "ground"
point2 = [0.0, 0.0]
[[joints]]
name = "crank_rod"
type = "revolute"
body1 = "crank"
point1 = [0.025, 0.0]
body2 = "rod"
point2 = [-0.06, 0.0]
[[joints]]
name = "rod_slider"
type = "revolute"
body1 = "slider"
point1 = [0.0, 0.0]
body2 = "rod"
point2 = [0.06, 0.0]
[[joints]]
name = "guide"
type = "prismatic"
body1 = "slider"
point1 = [0.0, 0.0]
body2 = "ground"
point2 = [0.0, 0.0]
axis = [1.0, 0.0]
[[drivers]]
name = "motor"
body = "crank"
motion = { type = "constant_speed", omega = 523.5987755982989 }
[[sensors]]
name = "slider"
body = "slider"
point = [0.0, 0.0]
[[clearances]]
joint = "rod_slider"
journal = "slider"
journal_radius = 0.0095
bearing_radius = 0.010
journal_material = "steel"
bearing_material = "steel"
contact = { law = "lankarani_nikravesh", restitution = 0.9, velocity_floor = 1e-5 }
friction = { law = "ambrosio", coefficient = 0.01, v0 = 1e-4, v1 = 1e-3 }
[simulation]
horizon = 0.002
output_interval = 1e-5
integrator = { method = "dopri5", rtol = 1e-9, atol = 1e-12 }
"#;

/// Runs `lash run` on a scenario text; returns the output and the (would-be) output folder.
/// The output folder of [`run_text`], inside its scratch folder (removed with it).
struct RunOut {
    _scratch: Scratch,
    out: PathBuf,
}

impl std::ops::Deref for RunOut {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.out
    }
}

/// Runs the scenario `text` into a scratch folder: the output and its folder.
fn run_text(name: &str, text: &str) -> (Output, RunOut) {
    let dir = scratch(name);
    let file = dir.join("scenario.toml");
    std::fs::write(&file, text).unwrap();
    let out = dir.join("out");
    let o = lash(&["run", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]);
    (o, RunOut { _scratch: dir, out })
}

#[test]
fn reduced_model_runs_from_the_command_line() {
    let dir = scratch("reduced-run");
    let out = dir.join("A");
    let o = lash(&["run", "A", "--model", "reduced", "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = read_json(&out.join("summary.json"));
    assert_eq!(summary["model"], "reduced");
    assert_eq!(summary["samples"], 3601);
}

#[test]
fn main_job_compare_writes_both_runs_metrics_and_figures() {
    // The README's main job, `compare A`, over a shorter horizon.
    let dir = scratch("compare");
    let out = dir.join("cmp");
    let o = lash(&["compare", "A", "--horizon", "0.006", "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("full/timeseries.csv").exists() && out.join("reduced/timeseries.csv").exists());
    let c: serde_json::Value = read_json(&out.join("comparison.json"));
    // Timings on one clock, simulation and output apart, and the three ratios.
    for model in ["full", "reduced", "full_rk4_at_micro_step"] {
        let t = &c["timing"][model];
        let (sim, out, total) =
            (t["simulation_s"].as_f64().unwrap(), t["output_s"].as_f64().unwrap(), t["total_s"].as_f64().unwrap());
        assert!(sim > 0.0 && out > 0.0 && (sim + out - total).abs() <= 1e-9 * total, "{model}: {t}");
    }
    let s = &c["speedup"];
    let converged = s["simulation_vs_converged_full"].as_f64().unwrap();
    assert!(converged > 1.0, "{c}");
    // The headline ratios come from rounds in which the models take turns (at least three),
    // each the median of the rounds' ratios; the ratio of the median times agrees with it.
    let steady = &c["steady_timing"];
    assert!(steady["rounds"].as_u64().unwrap() >= 3, "{steady}");
    for (key, model) in
        [("simulation_vs_converged_full", "converged_full"), ("simulation_at_equal_step", "full_rk4_at_micro_step")]
    {
        let ratio = s[key].as_f64().unwrap();
        assert_eq!(ratio, steady[model]["ratio_to_first"].as_f64().unwrap(), "{key}");
        let of_medians = steady[model]["median_s"].as_f64().unwrap() / steady["reduced"]["median_s"].as_f64().unwrap();
        assert!((0.5..2.0).contains(&(ratio / of_medians)), "{key}: {ratio} vs {of_medians}");
    }
    assert!(s["whole_run_equal_recording"].as_f64().unwrap() > 0.0);
    let summary: serde_json::Value = read_json(&out.join("reduced/summary.json"));
    assert_eq!(summary["timing"], c["timing"]["reduced"], "summary.json carries the same split");
    let ax = &c["channels"]["slider.ax"];
    for key in ["peak_full", "peak_reduced", "relative_rms_error", "spectral_distance", "band_powers_full"] {
        assert!(!ax[key].is_null(), "comparison lacks channels.slider.ax.{key}");
    }
    assert!(c["channels"].get("slider.ay").is_none(), "a zero channel is left out");
    assert!(c["clearances"][0]["impacts"]["full"].as_u64().unwrap() > 0);
    // 6 ms is within the first revolution (12 ms): no window of steady running, said so.
    assert!(c["bounds"]["error"].as_str().unwrap().contains("steady running"), "{}", c["bounds"]);
    let figures: Vec<&str> = c["figures"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    assert!(figures.contains(&"figures/slider.ax.svg") && figures.contains(&"figures/slider.ax_spectrum.svg"));
    for f in figures {
        let svg = std::fs::read_to_string(out.join(f)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("<polyline"), "{f} is not a drawn SVG");
        // Every figure says which curve is which, with the ideal mechanism as the reference.
        for label in ["full model (converged)", "reduced interface model"] {
            assert!(svg.contains(label), "{f} lacks the legend entry {label:?}");
        }
        // The ideal mechanism has no contact force; it has every other compared channel.
        assert_eq!(svg.contains("(clearance joint closed)"), !f.contains("crank_pivot.force"), "{f}");
        assert!(!svg.contains("100000.0"), "{f}: tick labels in engineering notation");
    }
    let time_figure = std::fs::read_to_string(out.join("figures/slider.ax.svg")).unwrap();
    assert!(time_figure.contains("crank angle [°]") && time_figure.contains("time [ms]"));
}

/// `lash compare E`: the spatial scenario's bearing force and emulated housing acceleration, with
/// clearance (full, reduced) against without (the ideal mechanism), as figures and as the
/// measurements' analysis of all three runs.
#[test]
fn compare_of_the_spatial_scenario_draws_the_bearing_force_and_the_housing_vibration() {
    let dir = scratch("compare-E");
    let out = dir.join("cmp");
    // 0.3 s: the housing's steady-state window opens at 0.24 s, 500 Hz logging.
    let o = lash(&["compare", "E", "--horizon", "0.3", "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&out.join("comparison.json"));
    let figures: Vec<&str> = c["figures"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    for f in ["slider_guide.fy", "slider_guide.fz", "housing.ay", "housing.az"] {
        for file in [format!("figures/{f}.svg"), format!("figures/{f}_spectrum.svg")] {
            assert!(figures.contains(&file.as_str()), "{file} missing from {figures:?}");
            let svg = std::fs::read_to_string(out.join(&file)).unwrap();
            assert!(svg.contains("<polyline") && svg.contains("(clearance joint closed)"), "{file}");
        }
    }
    assert!(!c["channels"]["slider_guide.fy"].is_null(), "the bearing force is a compared channel");
    // The clearance makes the vibration: the ideal mechanism's housing barely moves at 150 Hz.
    let rms = |run: &str, axis: usize| {
        let a = &c["measurements"][run][0]["axes"][axis]["logged"];
        assert_eq!(a["samples"].as_u64().unwrap(), 31, "{run}: 0.24–0.3 s at 500 Hz, both ends");
        a["rms"].as_f64().unwrap()
    };
    for axis in [1, 2] {
        let (full, reduced, ideal) = (rms("full", axis), rms("reduced", axis), rms("ideal", axis));
        assert!(full > 0.1 && reduced > 0.1, "axis {axis}: {full} {reduced}");
        assert!(ideal < 0.01 * full, "axis {axis}: ideal {ideal} against {full} with clearance");
    }
    stated_bounds_are_the_written_runs_statistics(&out, &c);
}

/// The stated bounds of a comparison (`bounds` in comparison.json, over the emulated
/// measurement's steady window, bands below its anti-alias cut-off) recomputed from the two
/// written time series: each load's mean and RMS, each joint's contact onsets per revolution, and
/// each check's verdict against its bound.
fn stated_bounds_are_the_written_runs_statistics(out: &Path, c: &serde_json::Value) {
    let b = &c["bounds"];
    assert_eq!(b["window"]["start"].as_f64(), Some(0.24), "{b}");
    assert_eq!(b["window"]["sensor_band_hz"].as_f64(), Some(200.0), "{b}");
    let checks = b["checks"].as_array().unwrap();
    let check = |q: &str| checks.iter().find(|c| c["quantity"] == q).unwrap_or_else(|| panic!("{q}: {b}"));
    let read = |model: &str| {
        let text = std::fs::read_to_string(out.join(model).join("timeseries.csv")).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .filter(|r: &Vec<f64>| r[0] >= 0.24)
            .collect();
        (header, rows)
    };
    for model in ["full", "reduced"] {
        let (header, rows) = read(model);
        let column = |name: &str| {
            let k = header.iter().position(|h| h.starts_with(&format!("{name} ["))).unwrap();
            rows.iter().map(|r| r[k]).collect::<Vec<f64>>()
        };
        let fy = column("slider_guide.fy");
        let mean = fy.iter().sum::<f64>() / fy.len() as f64;
        let rms = (fy.iter().map(|x| x * x).sum::<f64>() / fy.len() as f64).sqrt();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-12);
        assert!(close(check("slider_guide.fy mean")[model].as_f64().unwrap(), mean), "{model} mean {mean}");
        assert!(close(check("slider_guide.fy rms")[model].as_f64().unwrap(), rms), "{model} rms {rms}");
        // Onsets: samples where the contact force becomes non-zero; 0.06 s is a quarter turn at 250 rpm.
        let force = column("crank_rod.force");
        let onsets = force.windows(2).filter(|w| w[0] <= 0.0 && w[1] > 0.0).count() as f64;
        let per_revolution = check("crank_rod.force impacts_per_revolution")[model].as_f64().unwrap();
        assert!(close(per_revolution, onsets / (rows.len() as f64 * 1e-5 / 0.24)), "{model}: {onsets} onsets");
    }
    for c in checks {
        let (error, bound) = (c["error"].as_f64().unwrap_or(f64::INFINITY), c["bound"].as_f64().unwrap());
        let q = c["quantity"].as_str().unwrap();
        if !(q.contains("power") || q.contains("impacts")) {
            assert_eq!(c["met"], error.abs() <= bound, "{c}");
        }
        assert!(!q.contains("power") || q.contains("0-500 Hz"), "only the band below the 200 Hz cut-off: {q}");
    }
    assert_eq!(b["met"], checks.iter().all(|c| c["met"] == true));
}

/// `lash bush`: the study's bush characterised, the example file read, bad files refused with
/// every field named.
#[test]
fn bush_prints_the_fe_table_and_names_bad_fields() {
    let o = lash(&["bush"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        text.contains("bonded pin: stiffness") && text.contains("closed form") && text.contains("FE/Hertz"),
        "{text}"
    );
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/bush.toml");
    let o = lash(&["bush", example, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bonded = &j["table"]["bonded"];
    let ratio = bonded["stiffness"].as_f64().unwrap() / bonded["stiffness_closed_form"].as_f64().unwrap();
    assert!((ratio - 1.0).abs() < 1e-5, "{bonded}");
    assert_eq!(j["table"]["pressure"].as_array().unwrap().len(), 7);
    let dir = scratch("bush");
    let bad = dir.join("bad.toml");
    let text = std::fs::read_to_string(example).unwrap();
    std::fs::write(
        &bad,
        text.replace("poisson_ratio = 0.34", "poisson_ratio = 0.6").replace("length = 0.032", "length = -1.0"),
    )
    .unwrap();
    let o = lash(&["bush", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("bush.length") && stderr(&o).contains("bush.material.poisson"), "{}", stderr(&o));
}

#[test]
fn reduced_options_reach_the_summary() {
    let dir = scratch("reduced_options");
    let out = dir.join("r");
    let o = lash(&[
        "run",
        "A-motor",
        "--model",
        "reduced",
        "--coupling",
        "two-way",
        "--interpolation",
        "hermite",
        "--macro-step",
        "1e-3",
        "--horizon",
        "0.004",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s: serde_json::Value = read_json(&out.join("summary.json"));
    assert_eq!(s["reduced"]["options"]["coupling"], "two_way");
    assert_eq!(s["reduced"]["options"]["interpolation"], "cubic_hermite");
    assert_eq!(s["reduced"]["kinematic_macro"], false);
    assert_eq!(s["reduced"]["master"]["macro_steps"], 8, "predictor and corrector per macro step");
    let o = lash(&[
        "run",
        "A",
        "--model",
        "reduced",
        "--coupling",
        "two-way",
        "--threaded",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("two-way coupling runs sequentially"), "{}", stderr(&o));
}

#[test]
fn the_valid_base_file_runs() {
    let (o, out) = run_text("base", VALID_BASE);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("summary.json").exists());
}

#[test]
fn value_problems_are_all_listed_with_their_fields() {
    let text = VALID_BASE
        .replace("mass = 0.17", "mass = -0.17")
        .replace("inertia = 2.5e-4", "inertia = nan")
        .replace("position = [0.17, 0.0]", "position = [inf, 0.0]")
        .replace("journal_radius = 0.0095", "journal_radius = 0.0105")
        .replace("restitution = 0.9", "restitution = 1.5");
    let (o, out) = run_text("values", &text);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    for field in [
        "bodies[0].mass",
        "bodies[1].inertia",
        "bodies[2].position",
        "clearances[0].journal_radius",
        "clearances[0].contact.restitution",
    ] {
        assert!(err.contains(field), "error does not name {field}:\n{err}");
    }
    assert!(err.contains("5 problems"), "{err}");
    assert!(files_in(&out).is_empty(), "output left behind: {:?}", files_in(&out));
}

#[test]
fn structural_problems_are_all_listed_with_their_fields() {
    let text = VALID_BASE
        .replace("law = \"lankarani_nikravesh\"", "law = \"lankarani_nikravezh\"")
        .replacen("mass = 0.15\n", "", 1)
        .replace("horizon = 0.002", "horizon = 0.002\nhorizont = 1.0");
    let (o, out) = run_text("structure", &text);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    for needle in ["clearances[0].contact", "lankarani_nikravezh", "bodies[1].mass", "simulation.horizont"] {
        assert!(err.contains(needle), "error does not mention {needle}:\n{err}");
    }
    assert!(files_in(&out).is_empty());
}

#[test]
fn clearance_on_a_missing_joint_is_named() {
    let text = VALID_BASE.replace("joint = \"rod_slider\"", "joint = \"rod_slidr\"");
    let (o, _) = run_text("joint", &text);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("clearances[0].joint") && err.contains("rod_slidr"), "{err}");
}

#[test]
fn syntax_errors_and_unknown_names_fail_cleanly() {
    let (o, _) = run_text("syntax", "name = \"x\"\n[[bodies]\n");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not valid TOML"), "{}", stderr(&o));
    let o = lash(&["run", "no-such-scenario", "--out", scratch("none").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("neither a file nor a built-in"));
    let o = lash(&["run", "A", "--model", "reduced", "--ideal", "--out", scratch("reduced").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let o =
        lash(&["run", "A", "--model", "reduced", "--micro-step", "3e-5", "--out", scratch("micro").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("whole multiple"), "{}", stderr(&o));
    let o = lash(&["run", "A", "--horizon=-1", "--out", scratch("horizon").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("simulation.horizon"), "{}", stderr(&o));
    let o = lash(&["run", "A", "--frobnicate"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn a_blow_up_stops_with_time_and_quantity() {
    // RK4 at 1e-4 s against a contact stiffness of ~1e11 N/m^1.5: the journal tunnels through.
    let text = VALID_BASE
        .replace(
            "integrator = { method = \"dopri5\", rtol = 1e-9, atol = 1e-12 }",
            "integrator = { method = \"rk4\", step = 1e-4 }",
        )
        .replace("output_interval = 1e-5", "output_interval = 1e-4")
        .replace("horizon = 0.002", "horizon = 0.01");
    let (o, out) = run_text("blowup", &text);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("t = "), "{err}");
    assert!(err.contains("penetration") || err.contains("became"), "{err}");
    assert!(!out.join("summary.json").exists());
    assert!(!out.join("timeseries.csv").exists());
    assert!(out.join("timeseries.csv.partial").exists());
}

#[test]
fn example_files_are_the_builtin_scenarios() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    for name in lash_scenario::builtin::NAMES {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let parsed = lash_scenario::parse(&text).unwrap_or_else(|p| panic!("{name}: {p}"));
        assert_eq!(
            parsed,
            lash_scenario::builtin::by_name(name).unwrap(),
            "examples/{name}.toml differs from the built-in"
        );
    }
    let text = std::fs::read_to_string(dir.join("E.toml")).unwrap();
    let parsed = lash_scenario::parse_spatial(&text).unwrap_or_else(|p| panic!("E: {p}"));
    assert_eq!(
        parsed,
        lash_scenario::builtin_spatial::spatial_by_name("E").unwrap(),
        "examples/E.toml differs from the built-in"
    );
}

/// SIGINT and SIGTERM end `lash run` with a message saying where the rows so far are (exit 130),
/// never a complete-looking folder.
#[test]
fn an_interrupted_run_says_what_it_kept() {
    for signal in ["-INT", "-TERM"] {
        let dir = scratch(&format!("interrupt{signal}"));
        let out = dir.join("A");
        let child = Command::new(env!("CARGO_BIN_EXE_lash"))
            .args(["run", "A", "--horizon", "20", "--quiet", "--out", out.to_str().unwrap()])
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Wait until rows are being written (header and at least one flushed buffer).
        let partial = out.join("timeseries.csv.partial");
        let waited = std::time::Instant::now();
        while std::fs::metadata(&partial).map_or(0, |m| m.len()) < 10_000 {
            assert!(waited.elapsed().as_secs() < 120, "the run wrote nothing");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let ok = Command::new("kill").args([signal, &child.id().to_string()]).status().unwrap().success();
        assert!(ok);
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(130), "{signal}: {err}");
        assert!(err.contains("interrupted") && err.contains("timeseries.csv.partial"), "{signal}: {err}");
        assert!(partial.exists() && !out.join("timeseries.csv").exists() && !out.join("summary.json").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn a_spatial_scenario_runs_and_writes_its_emulated_measurement() {
    let dir = scratch("spatial");
    let out = dir.join("E");
    let o =
        lash(&["run", "E-0.25mm-250rpm-frictionless", "--out", out.to_str().unwrap(), "--horizon", "0.3", "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "slider.az [m/s^2]",
        "crank_rod.fz [N]",
        "rod_slider.eccentricity [m]",
        "slider_guide.fy [N]",
        "crank_drive.torque [N m]",
    ] {
        assert!(header.contains(col), "header lacks {col}: {header}");
    }
    // The logger keeps 500 Hz samples from the end of the first revolution (0.24 s) on.
    let logged = std::fs::read_to_string(out.join("measurement_housing.csv")).unwrap();
    assert_eq!(logged.lines().next().unwrap(), "time [s],housing.ax [m/s^2],housing.ay [m/s^2],housing.az [m/s^2]");
    assert_eq!(logged.lines().count(), 1 + 31, "0.24 … 0.30 s at 2 ms");
    let summary: serde_json::Value = read_json(&out.join("summary.json"));
    assert_eq!(summary["measurements"][0]["axes"][2]["channel"], "housing.az");
    // The spatial scenario is written back as run, and reads again.
    let o = lash(&["validate", out.join("scenario.toml").to_str().unwrap()]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("spatial"), "{}", stderr(&o));
}

#[test]
fn spatial_scenarios_get_clear_errors_where_a_command_does_not_take_them_yet() {
    // (`lash compare E` runs: full, reduced, RK4 at the micro step and ideal, with its figures.)
    // (Two-way coupling of its spherical joints runs too: refused until session 35.)
    let dir = scratch("spatial-errors");
    let out = dir.join("r");
    let o = lash(&[
        "run",
        "E",
        "--model",
        "reduced",
        "--coupling",
        "two-way",
        "--horizon",
        "0.02",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("timeseries.csv").exists());
    // A spatial file with mistakes: every one with its field path.
    let text = std::process::Command::new(env!("CARGO_BIN_EXE_lash")).args(["show", "E"]).output().unwrap().stdout;
    let text = String::from_utf8(text)
        .unwrap()
        .replacen("mass = 0.25", "mass = -0.25", 1)
        .replacen("orientation = [1.0, 0.0, 0.0, 0.0]", "orientation = [2.0, 0.0, 0.0, 0.0]", 1)
        .replacen("joint = \"crank_rod\"", "joint = \"crank_pivot\"", 1)
        .replacen("\"slider_guide.fz\"", "\"slider.az\"", 1);
    let file = dir.join("bad.toml");
    std::fs::write(&file, text).unwrap();
    let o = lash(&["validate", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    for field in ["bodies[1].mass", "bodies[2].orientation", "clearances[0].joint", "output.measurements[0].forces[2]"]
    {
        assert!(e.contains(field), "{field} missing from: {e}");
    }
}

#[test]
fn what_cannot_fit_is_refused_before_any_work() {
    let dir = scratch("limits");
    // A run of 1e6 s sampled every 1e-5 s: ~65 TB of CSV.
    let out = dir.join("huge");
    let o = lash(&["run", "A", "--horizon", "1e6", "--out", out.to_str().unwrap(), "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("TB") && e.contains("free") && e.contains("simulation.output_interval"), "{e}");
    assert!(!out.join("timeseries.csv").exists() && !out.join("timeseries.csv.partial").exists());
    // A sweep of 10⁸ runs × 10 s at 100 kHz, refused at once (before its design is listed).
    let sweep = dir.join("big.toml");
    std::fs::write(
        &sweep,
        "base = \"A\"\nmodel = \"reduced\"\nsampling = \"latin_hypercube\"\nruns = 100000000\nseed = 1\nhorizon = 10.0\n\
         [output]\nchannels = [\"slider.ax\"]\nsample_rate = 100000.0\n\
         [[parameters]]\npath = \"drivers[0].motion.omega\"\nuniform = { low = 400.0, high = 600.0 }\n",
    )
    .unwrap();
    let started = std::time::Instant::now();
    let o = lash(&["sweep", sweep.to_str().unwrap(), "--out", dir.join("big").to_str().unwrap(), "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("fewer runs"), "{}", stderr(&o));
    assert!(started.elapsed().as_secs() < 30, "refused only after {:?}", started.elapsed());
    assert!(!dir.join("big").exists());
    // An output interval below the time resolution.
    let text = String::from_utf8(lash(&["show", "A"]).stdout).unwrap();
    let tiny = dir.join("tiny.toml");
    std::fs::write(&tiny, text.replace("output_interval = 0.00001", "output_interval = 1e-16")).unwrap();
    let o = lash(&["validate", tiny.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("simulation.output_interval") && stderr(&o).contains("time resolution"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn validate_understands_sweep_and_system_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let o = lash(&["validate", root.join("examples/sweep-lhs.toml").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("valid (sweep of A; 64 runs"));
    let o = lash(&["validate", root.join("examples/systems/reduced-A.toml").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("valid (system"));
    // A sweep whose values make one run's scenario invalid: that run is named.
    let dir = scratch("validate-sweep");
    let text = std::fs::read_to_string(root.join("examples/sweep-bush.toml")).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, text.replace("values = [110e9", "values = [-5.0, 110e9")).unwrap();
    let o = lash(&["validate", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("run 0") && e.contains("young_modulus") && e.contains("must be > 0"), "{e}");
}

#[test]
fn a_run_written_as_parquet_holds_the_csv_values_bit_for_bit() {
    let dir = scratch("parquet");
    let (csv_dir, pq_dir) = (dir.join("csv"), dir.join("pq"));
    for (out, format) in [(&csv_dir, "csv"), (&pq_dir, "parquet")] {
        let o = lash(&[
            "run",
            "A",
            "--model",
            "reduced",
            "--horizon",
            "0.01",
            "--format",
            format,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(!pq_dir.join("timeseries.csv").exists() && pq_dir.join("summary.json").exists());
    let (columns, values) = lash_sweep::dataset::read_series(&pq_dir.join("timeseries.parquet")).unwrap();
    let text = std::fs::read_to_string(csv_dir.join("timeseries.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(header.len(), columns.len());
    for (h, (name, unit)) in header.iter().zip(&columns) {
        assert_eq!(*h, format!("{name} [{unit}]"));
    }
    let rows: Vec<Vec<f64>> =
        text.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 1001);
    for (i, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            assert_eq!(v.to_bits(), values[c][i].to_bits(), "row {i}, {}", header[c]);
        }
    }
    // Writing the other format removes the earlier one: no stale table passes for this run's.
    let o =
        lash(&["run", "A", "--model", "reduced", "--horizon", "0.01", "--out", pq_dir.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success());
    assert!(pq_dir.join("timeseries.csv").exists() && !pq_dir.join("timeseries.parquet").exists());
}

/// A reader that stops early (`lash scenarios | head -1`) ends lash quietly (exit 141, as a Unix
/// tool on SIGPIPE), without a panic report; and every built-in's listed description says what
/// sets it apart from its siblings (no two alike).
#[test]
fn a_closed_pipe_ends_lash_quietly_and_descriptions_differ() {
    // lash starts after the reader has gone (a shell waits, then becomes lash), so its first
    // line meets a closed pipe.
    let mut child = std::process::Command::new("sh")
        .args(["-c", &format!("sleep 0.3; exec {:?} scenarios", env!("CARGO_BIN_EXE_lash"))])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(141), "{err}");
    let o = lash(&["scenarios"]);
    let listed = String::from_utf8_lossy(&o.stdout);
    let descriptions: Vec<&str> = listed.lines().map(|l| l[30..].trim()).collect();
    for (i, d) in descriptions.iter().enumerate() {
        assert!(!descriptions[..i].contains(d), "two built-ins read {d:?}");
    }
}

/// `compare` of a scenario with two clearance joints reports each of them, full against reduced
/// (impacts, contact fraction, loads), in comparison.json and on the terminal.
#[test]
fn compare_reports_every_clearance_joint() {
    let dir = scratch("compare-c");
    let out = dir.join("cmp");
    let o = lash(&["compare", "C", "--horizon", "0.01", "--micro-step", "5e-6", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&out.join("comparison.json"));
    let joints: Vec<&str> = c["clearances"].as_array().unwrap().iter().map(|j| j["joint"].as_str().unwrap()).collect();
    assert_eq!(joints, ["crank_pivot", "rod_slider"]);
    for j in c["clearances"].as_array().unwrap() {
        for key in ["impacts", "contact_fraction", "mean_contact_force", "peak_normal_force"] {
            assert!(!j[key]["full"].is_null() && !j[key]["reduced"].is_null(), "{key}: {j}");
        }
    }
    let printed = stderr(&o);
    assert!(printed.contains("rod_slider") && printed.contains("impacts full"), "{printed}");
}

/// A reduced run carries an error estimate: the converged full model over its first quarter
/// (at least 20 macro steps), compared on the main channels. It equals what `compare` measures
/// over that window by its own path (both runs written to CSV and read back), and
/// `--no-error-estimate` leaves it out.
#[test]
fn a_reduced_run_estimates_its_error_as_compare_measures_it() {
    let dir = scratch("probe");
    let run = dir.join("run");
    let o = lash(&["run", "A", "--model", "reduced", "--horizon", "0.036", "--out", run.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("error estimate"), "{}", stderr(&o));
    let summary: serde_json::Value = read_json(&run.join("summary.json"));
    let estimate = &summary["error_estimate"];
    // A quarter of the run, but at least 20 macro steps (the step lash chose: 0.5 ms at 5000 rpm).
    let macro_step = summary["reduced"]["options"]["macro_step"].as_f64().unwrap();
    let window = estimate["window_s"].as_f64().unwrap();
    assert!((window - (0.25 * 0.036f64).max(20.0 * macro_step)).abs() < 1e-12, "{estimate}");
    let cmp = dir.join("cmp");
    let o = lash(&["compare", "A", "--horizon", &window.to_string(), "--out", cmp.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&cmp.join("comparison.json"));
    let names: Vec<&str> =
        estimate["channels"].as_array().unwrap().iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert!(names.contains(&"slider.ax") && names.contains(&"crank_pivot.force"), "{names:?}");
    assert!(!names.contains(&"slider.ay"), "a channel at round-off has no level error");
    for channel in estimate["channels"].as_array().unwrap() {
        let name = channel["name"].as_str().unwrap();
        let m = &c["channels"][name];
        let (full, reduced) = (m["rms_full"].as_f64().unwrap(), m["rms_reduced"].as_f64().unwrap());
        let measured = (reduced - full).abs() / full;
        let estimated = channel["rms_level_error"].as_f64().unwrap();
        assert!((estimated - measured).abs() <= 1e-9 * measured.max(1e-12), "{name}: {estimated} vs {measured}");
    }
    let quiet = dir.join("quiet");
    let o = lash(&["run", "A", "--model", "reduced", "--no-error-estimate", "--out", quiet.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = std::fs::read_to_string(quiet.join("summary.json")).unwrap();
    assert!(!summary.contains("error_estimate"));
}

/// The estimate's coupling term is the distance of the one-way run's RMS levels from the two-way
/// run's over the whole run, recomputed here from both runs' written CSVs; on B (whose rod–slider
/// pin stops rattling in the one-way run after the probe window while the full model's goes on)
/// the window term alone stays below the whole run's measured error on the slider and the pin,
/// and the sum brackets it (docs/validation.md §6).
#[test]
fn the_error_estimate_adds_the_coupling_error_over_the_whole_run() {
    let dir = scratch("coupling-term");
    let cmp = dir.join("cmp");
    // (At the macro step of 1 ms, where B's one-way coupling term is past the stated bound.)
    let args =
        ["compare", "B", "--horizon", "0.2", "--coupling", "one-way", "--macro-step", "1e-3", "--quiet", "--out"];
    let o = lash(&[&args[..], &[cmp.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&cmp.join("comparison.json"));
    let h = c["reduced_options"]["micro_step"].as_f64().unwrap().to_string();
    let two_way = dir.join("two-way");
    let args = [
        "run",
        "B",
        "--model",
        "reduced",
        "--coupling",
        "two-way",
        "--horizon",
        "0.2",
        "--macro-step",
        "1e-3",
        "--no-error-estimate",
    ];
    let o = lash(&[&args[..], &["--micro-step", &h, "--out", two_way.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let rms_of = |file: &Path, name: &str| column_rms(file, name, f64::NEG_INFINITY);
    let e = &c["error_estimate"];
    for channel in e["estimate"]["channels"].as_array().unwrap() {
        let name = channel["name"].as_str().unwrap();
        let one = rms_of(&cmp.join("reduced/timeseries.csv"), name);
        let two = rms_of(&two_way.join("timeseries.csv"), name);
        let coupling = channel["coupling_error"].as_f64().unwrap();
        let expected = (one - two).abs() / two;
        assert!((coupling - expected).abs() <= 1e-9 * expected.max(1e-12), "{name}: {coupling} vs {expected}");
        let window = channel["rms_level_error"].as_f64().unwrap();
        assert!((channel["estimated_error"].as_f64().unwrap() - (window + coupling)).abs() < 1e-15, "{channel}");
        if name == "slider.ax" || name == "rod_slider.force" {
            let measured = e["whole_run_rms_level_error"][name].as_f64().unwrap();
            assert!(window < measured && window + coupling >= measured, "{name}: {window} + {coupling} vs {measured}");
        }
    }
    // Above the stated 10 %, a one-way run says so and names the way out; A's coupling term is small.
    let said = "one-way coupling moves";
    for (name, warned) in [("B", true), ("A", false)] {
        let run = dir.join(name);
        let args = [
            "run",
            name,
            "--model",
            "reduced",
            "--horizon",
            "0.2",
            "--coupling",
            "one-way",
            "--macro-step",
            "1e-3",
            "--out",
        ];
        let o = lash(&[&args[..], &[run.to_str().unwrap()]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        let s: serde_json::Value = read_json(&run.join("summary.json"));
        let in_summary = s["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().starts_with(said));
        assert_eq!((stderr(&o).contains(said), in_summary), (warned, warned), "{name}: {}", stderr(&o));
        if warned {
            assert!(stderr(&o).contains("--coupling auto takes the coupling closer"), "{}", stderr(&o));
        }
    }
}

/// A two-way run's second term is the step term: the run against itself at half the macro step
/// over the whole run, twice their distance (first-order extrapolation), recomputed here from the
/// written CSVs. Its order is measured too: on A-200um the two-way run's RMS levels move by about
/// half as much again at each halving of the macro step (first order). The window term alone
/// stays below the whole run's measured error on every main channel, the sum brackets it
/// (docs/validation.md §6).
#[test]
fn a_two_way_run_is_estimated_with_its_step_error() {
    let dir = scratch("step-term");
    let cmp = dir.join("cmp");
    let args =
        ["compare", "A-200um", "--horizon", "0.2", "--coupling", "two-way", "--macro-step", "1e-3", "--quiet", "--out"];
    let o = lash(&[&args[..], &[cmp.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&cmp.join("comparison.json"));
    let h = c["reduced_options"]["micro_step"].as_f64().unwrap().to_string();
    let halved = |macro_step: &str| {
        let out = dir.join(macro_step);
        let args = ["run", "A-200um", "--model", "reduced", "--coupling", "two-way", "--horizon", "0.2"];
        let extra = ["--no-error-estimate", "--micro-step", &h, "--macro-step", macro_step, "--out"];
        let o = lash(&[&args[..], &extra[..], &[out.to_str().unwrap()]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        out.join("timeseries.csv")
    };
    let (half, quarter) = (halved("5e-4"), halved("2.5e-4"));
    let rms_of = |file: &Path, name: &str| column_rms(file, name, f64::NEG_INFINITY);
    let e = &c["error_estimate"];
    for channel in e["estimate"]["channels"].as_array().unwrap() {
        let name = channel["name"].as_str().unwrap();
        let (own, h2, h4) =
            (rms_of(&cmp.join("reduced/timeseries.csv"), name), rms_of(&half, name), rms_of(&quarter, name));
        let step = channel["step_error"].as_f64().unwrap();
        let expected = 2.0 * (own - h2).abs() / h2;
        assert!((step - expected).abs() <= 1e-9 * expected, "{name}: {step} vs {expected}");
        assert!(channel["coupling_error"].is_null(), "{channel}");
        let order = (own - h2).abs() / (h2 - h4).abs();
        assert!((1.5..3.0).contains(&order), "{name}: successive differences' ratio {order} (first order: 2)");
        let window = channel["rms_level_error"].as_f64().unwrap();
        assert!((channel["estimated_error"].as_f64().unwrap() - (window + step)).abs() < 1e-15, "{channel}");
        let measured = e["whole_run_rms_level_error"][name].as_f64().unwrap();
        assert!(window < measured && window + step >= measured, "{name}: {window} + {step} vs {measured}");
    }
}

/// By default (`--coupling auto`), where the estimate's coupling term is past the stated 10 % the
/// run takes the coupling closer to the converged full model over the probe window: over 0.2 s F
/// turns two-way — its written run is the two-way run's to the bit, with the choice and the
/// two-way run's estimate in summary.json — and B stays one-way (its two-way run is further off
/// over the window), each as the window terms of runs made in the other coupling say; A's
/// coupling term is small and it stays one-way without a choice; without the estimate the run
/// stays one-way and says why. `lash compare F` makes the same choice.
#[test]
fn the_default_coupling_is_the_one_closer_to_the_full_model() {
    let dir = scratch("coupling-auto");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(format!("{name}{}", extra.join("")));
        // (At the macro step of 1 ms, where F's one-way coupling term is past the bound.)
        let args = [
            "run",
            name,
            "--model",
            "reduced",
            "--horizon",
            "0.2",
            "--macro-step",
            "1e-3",
            "--out",
            out.to_str().unwrap(),
        ];
        let o = lash(&[&args[..], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        (o, read_json(&out.join("summary.json")), std::fs::read(out.join("timeseries.csv")).unwrap())
    };
    let worst = |s: &serde_json::Value| {
        let channels = s["error_estimate"]["channels"].as_array().unwrap().clone();
        channels.iter().map(|c| c["rms_level_error"].as_f64().unwrap()).fold(0.0, f64::max)
    };
    let micro_step = |s: &serde_json::Value| s["reduced"]["options"]["micro_step"].as_f64().unwrap().to_string();
    for (name, turns) in [("F", true), ("B", false)] {
        let (o, s, auto_rows) = run(name, &[]);
        let why = s["coupling_choice"].as_str().unwrap();
        let h = micro_step(&s);
        let (other, chosen) = if turns { ("one-way", "two_way") } else { ("two-way", "one_way") };
        assert_eq!(s["reduced"]["options"]["coupling"], chosen, "{name}: {s}");
        let (_, s_other, _) = run(name, &["--coupling", other, "--micro-step", &h]);
        // The window terms the choice compared, each from a run made in that coupling.
        let (one_way, two_way) = if turns { (worst(&s_other), worst(&s)) } else { (worst(&s), worst(&s_other)) };
        let figures = format!("{:.1} % one-way, {:.1} % two-way", 100.0 * one_way, 100.0 * two_way);
        assert!(why.contains(&figures) && (two_way < one_way) == turns, "{name}: {why} / {figures}");
        if turns {
            assert!(why.starts_with("two-way coupling, chosen") && stderr(&o).contains(why), "{}", stderr(&o));
            let channels = s["error_estimate"]["channels"].as_array().unwrap().clone();
            assert!(channels.iter().all(|c| c["coupling_error"].is_null() && c["step_error"].is_f64()), "{s}");
            let (_, _, two_way_rows) = run(name, &["--coupling", "two-way", "--no-error-estimate", "--micro-step", &h]);
            assert!(auto_rows == two_way_rows, "the written run is the two-way run");
            let cmp = dir.join("cmp");
            let args = ["compare", name, "--horizon", "0.2", "--macro-step", "1e-3", "--quiet", "--out"];
            let o = lash(&[&args[..], &[cmp.to_str().unwrap()]].concat());
            assert!(o.status.success(), "{}", stderr(&o));
            let c: serde_json::Value = read_json(&cmp.join("comparison.json"));
            assert_eq!(c["reduced_options"]["coupling"], "two_way", "{c}");
            assert_eq!(c["coupling_choice"].as_str(), Some(why));
            assert!(std::fs::read(cmp.join("reduced/timeseries.csv")).unwrap() == auto_rows, "compare writes that run");
        } else {
            assert!(why.starts_with("one-way coupling, kept"), "{why}");
            assert!(stderr(&o).contains("one-way coupling moves"), "the coupling warning stays: {}", stderr(&o));
        }
    }
    let (_, s, _) = run("A", &[]);
    assert_eq!((s["reduced"]["options"]["coupling"].as_str(), s.get("coupling_choice")), (Some("one_way"), None));
    let (_, s, _) = run("F", &["--no-error-estimate"]);
    assert_eq!(s["reduced"]["options"]["coupling"], "one_way", "{s}");
    assert!(s["coupling_choice"].as_str().unwrap().contains("--no-error-estimate"), "{s}");
}

/// Without `--micro-step`, a reduced run takes the largest step up to 1e-5 s that gives each
/// clearance joint's impacts (their median duration in the converged full model over the probe
/// window) seven steps: B's rod–slider impacts (~50 µs) get 5e-6 s, and the reduced run's own
/// impacts then last seven steps or more — no resolution warning; A's (~95 µs) keep 1e-5 s. A
/// step the user gives is kept, and the check after the run still warns about it.
#[test]
fn the_default_micro_step_resolves_the_impacts_it_meets() {
    let dir = scratch("micro-step");
    let summary = |d: &std::path::Path| -> serde_json::Value { read_json(&d.join("summary.json")) };
    let b = dir.join("b");
    let o = lash(&["run", "B", "--model", "reduced", "--out", b.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = summary(&b);
    let h = s["reduced"]["options"]["micro_step"].as_f64().unwrap();
    assert_eq!(h, 5e-6, "{}", stderr(&o));
    assert!(s["micro_step_choice"].as_str().unwrap().contains("rod_slider"), "{}", s["micro_step_choice"]);
    let median = s["clearances"][0]["median_impact_duration"].as_f64().unwrap();
    assert!(median / h >= 7.0, "the reduced run's impacts last {} steps", median / h);
    assert!(!stderr(&o).contains("not converged"), "{}", stderr(&o));

    let given = dir.join("given");
    let o = lash(&[
        "run",
        "B",
        "--model",
        "reduced",
        "--micro-step",
        "1e-5",
        "--no-error-estimate",
        "--out",
        given.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(summary(&given)["reduced"]["options"]["micro_step"].as_f64(), Some(1e-5));
    assert!(summary(&given).get("micro_step_choice").is_none());
    assert!(stderr(&o).contains("not converged"), "{}", stderr(&o));

    let a = dir.join("a");
    let o = lash(&["run", "A", "--model", "reduced", "--out", a.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(summary(&a)["reduced"]["options"]["micro_step"].as_f64(), Some(1e-5));
    assert!(summary(&a).get("micro_step_choice").is_none());
}

/// At its defaults, `lash run --model reduced` resolves the impacts of every built-in scenario:
/// each clearance joint's median impact in the reduced run itself lasts at least seven micro
/// steps (the convergence threshold of the peak forces), with no resolution warning. (The
/// built-ins without a clearance interface are refused with exit code 2.)
#[test]
fn every_builtin_resolves_its_impacts_at_the_defaults() {
    let dir = scratch("builtins-resolved");
    let listed = lash(&["scenarios"]);
    let names: Vec<String> = String::from_utf8_lossy(&listed.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(String::from)
        .collect();
    assert!(names.len() >= 20, "{names:?}");
    let mut checked = 0;
    for name in &names {
        let out = dir.join(name);
        let o = lash(&[
            "run",
            name,
            "--model",
            "reduced",
            "--no-error-estimate",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        if o.status.code() == Some(2) {
            assert!(stderr(&o).contains("couples"), "{name}: {}", stderr(&o));
            continue;
        }
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(!stderr(&o).contains("not converged"), "{name}: {}", stderr(&o));
        // A pressed contact the step does not hold (docs/validation.md §6): C's rod–slider pin and
        // F-0.25mm's, over their default horizons; said, and the run made again at a tenth of the
        // step, which holds it. A step given is kept.
        let (unloaded, again) = ("carries no force", "the run was made again at a tenth of the step");
        let refined = ["C", "F-0.25mm"].contains(&name.as_str());
        assert_eq!(stderr(&o).contains(unloaded), refined, "{name}: {}", stderr(&o));
        let s: serde_json::Value = read_json(&out.join("summary.json"));
        assert_eq!(s["micro_step_refined"].is_string(), refined, "{name}: {s}");
        if name == "F-0.25mm" {
            assert_eq!(s["reduced"]["options"]["micro_step"].as_f64(), Some(1e-6), "{s}");
            assert!(s["warnings"].as_array().unwrap().is_empty(), "{s}");
            let given = dir.join("F-0.25mm-given");
            let args = ["run", name, "--model", "reduced", "--micro-step", "1e-5", "--no-error-estimate", "--out"];
            let o = lash(&[&args[..], &[given.to_str().unwrap()]].concat());
            assert!(
                o.status.success() && stderr(&o).contains(unloaded) && !stderr(&o).contains(again),
                "{}",
                stderr(&o)
            );
            // The warning is the summary's counts, read back: more than 1 % of the samples in
            // contact carried no force.
            let g: serde_json::Value = read_json(&given.join("summary.json"));
            let counts = &g["clearances"][0]["contact_samples"];
            let (n, z) = (counts["in_contact"].as_f64().unwrap(), counts["unloaded"].as_f64().unwrap());
            assert!(n > 0.0 && z > 0.01 * n, "{counts}");
        }
        let h = s["reduced"]["options"]["micro_step"].as_f64().unwrap();
        for c in s["clearances"].as_array().unwrap() {
            // At the defaults every contact is held: at most 1 % of its samples in contact unloaded.
            let counts = &c["contact_samples"];
            let (n, z) = (counts["in_contact"].as_f64().unwrap(), counts["unloaded"].as_f64().unwrap());
            assert!(z <= 0.01 * n, "{name} {}: {counts}", c["name"]);
            if let Some(d) = c["median_impact_duration"].as_f64() {
                assert!(d / h >= 7.0, "{name} {}: {:.1} steps of {h:e} s", c["name"], d / h);
            }
        }
        checked += 1;
    }
    assert!(checked >= 20, "{checked} scenarios checked");
}

/// `--tolerance` takes finer steps until the reduced model's RMS level error on the main channels,
/// against the converged full model over the error estimate's window, is within it: on A the
/// settings it takes, run through `lash compare` over that window (its own path, through the
/// written CSVs), are within the tolerance on every main channel; on B, whose rattling joint
/// keeps a larger error at any step, it says so and takes the closest setting; a tolerance that
/// is not a positive fraction, or one without the probe, is refused naming the flag.
#[test]
fn a_tolerance_gets_the_settings_that_meet_it_or_says_it_cannot() {
    let dir = scratch("tolerance");
    let summary = |d: &std::path::Path| -> serde_json::Value { read_json(&d.join("summary.json")) };
    let a = dir.join("a");
    let o = lash(&["run", "A", "--model", "reduced", "--tolerance", "0.05", "--out", a.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = summary(&a);
    assert_eq!(s["tolerance"]["met"], true, "{}", s["tolerance"]);
    let (hm, hr) = (
        s["reduced"]["options"]["macro_step"].as_f64().unwrap(),
        s["reduced"]["options"]["micro_step"].as_f64().unwrap(),
    );
    let window = s["error_estimate"]["window_s"].as_f64().unwrap();
    let cmp = dir.join("cmp");
    let o = lash(&[
        "compare",
        "A",
        "--horizon",
        &window.to_string(),
        "--macro-step",
        &hm.to_string(),
        "--micro-step",
        &hr.to_string(),
        "--out",
        cmp.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value = read_json(&cmp.join("comparison.json"));
    for channel in s["error_estimate"]["channels"].as_array().unwrap() {
        let m = &c["channels"][channel["name"].as_str().unwrap()];
        let (full, reduced) = (m["rms_full"].as_f64().unwrap(), m["rms_reduced"].as_f64().unwrap());
        assert!(
            (reduced - full).abs() / full <= 0.05,
            "{}: {reduced} vs {full} at h_m {hm}, h_r {hr}",
            channel["name"]
        );
    }

    let b = dir.join("b");
    let o = lash(&["run", "B", "--model", "reduced", "--tolerance", "0.01", "--out", b.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("not met"), "{}", stderr(&o));
    let t = &summary(&b)["tolerance"];
    assert_eq!(t["met"], false);
    let tried = t["tried"].as_array().unwrap();
    let errors: Vec<f64> = tried.iter().map(|x| x["worst_rms_level_error"].as_f64().unwrap()).collect();
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "each setting taken lowers the error: {errors:?}");

    let bad = dir.join("bad");
    for (args, said) in [
        (&["--tolerance", "0"][..], "positive fraction"),
        (&["--tolerance", "0.05", "--no-error-estimate"][..], "--no-error-estimate"),
    ] {
        let mut all = vec!["run", "A", "--model", "reduced", "--out", bad.to_str().unwrap()];
        all.extend_from_slice(args);
        let o = lash(&all);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--tolerance") && stderr(&o).contains(said), "{}", stderr(&o));
    }
}

/// `lash compare --realisations N` holds the bounds against N converged realisations of the full
/// model: realisation 0 is the written run (its figures are the bounds'), realisation 1 the
/// scenario at atol one rounding step up — recomputed here from `lash run` of that scenario file:
/// its slider RMS over the window of steady running is the one compare reports, and on B over
/// 0.2 s (a rattling pin) it is not realisation 0's. Each check's count is its verdicts' count.
/// A fixed-step full model has no realisations to give: a clear error.
#[test]
fn compare_holds_the_bounds_against_realisations_of_the_full_model() {
    let dir = scratch("realisations");
    let cmp = dir.join("cmp");
    let o =
        lash(&["compare", "B", "--horizon", "0.2", "--realisations", "3", "--out", cmp.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("against 3 converged realisations of the full model"), "{}", stderr(&o));
    let c = read_json(&cmp.join("comparison.json"));
    let (bounds, r) = (&c["bounds"]["checks"], &c["realisations"]);
    assert_eq!(r["count"], 3);
    let checks = r["checks"].as_array().unwrap();
    assert_eq!(checks.len(), bounds.as_array().unwrap().len());
    for (c, b) in checks.iter().zip(bounds.as_array().unwrap()) {
        assert_eq!((&c["quantity"], &c["full"][0], &c["met"][0]), (&b["quantity"], &b["full"], &b["met"]));
        let met = c["met"].as_array().unwrap();
        assert_eq!(met.len(), 3);
        assert_eq!(c["met_count"].as_u64().unwrap() as usize, met.iter().filter(|m| **m == true).count());
    }
    let tallies = ["met_against_all", "met_against_some", "met_against_none"].map(|k| r[k].as_u64().unwrap());
    assert_eq!(tallies.iter().sum::<u64>() as usize, checks.len());
    // Realisation 1, made by hand: the scenario's atol one rounding step up, run and read back.
    let shown = String::from_utf8(lash(&["show", "B"]).stdout).unwrap();
    let atol: f64 = 1e-12;
    assert!(shown.contains("\natol = 0.000000000001\n"), "the built-in's atol: {shown}");
    let file = dir.join("B-atol.toml");
    std::fs::write(&file, shown.replace("\natol = 0.000000000001\n", &format!("\natol = {:?}\n", atol.next_up())))
        .unwrap();
    let run = dir.join("full-1");
    let o = lash(&["run", file.to_str().unwrap(), "--horizon", "0.2", "--out", run.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let start = c["bounds"]["window"]["start"].as_f64().unwrap();
    let rms = column_rms(&run.join("timeseries.csv"), "slider.ax", start);
    let slider = checks.iter().find(|c| c["quantity"] == "slider.ax rms").unwrap();
    let (first, second) = (slider["full"][0].as_f64().unwrap(), slider["full"][1].as_f64().unwrap());
    assert!((second - rms).abs() <= 1e-9 * rms, "realisation 1: {second} against {rms} recomputed");
    assert!((first - second).abs() > 1e-3 * first, "B's rattling pin: realisations {first} and {second}");
    // A fixed-step full model: refused, naming the option and the field.
    let rk4 = dir.join("B-rk4.toml");
    let (mut fixed, mut inside) = (String::new(), false);
    for line in shown.lines() {
        if line.starts_with('[') {
            inside = line == "[simulation.integrator]";
            fixed += line;
            fixed += if inside { "\nmethod = \"rk4\"\nstep = 0.000001\n" } else { "\n" };
        } else if !inside {
            fixed += line;
            fixed += "\n";
        }
    }
    std::fs::write(&rk4, fixed).unwrap();
    let o =
        lash(&["compare", rk4.to_str().unwrap(), "--realisations", "2", "--out", dir.join("rk4").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--realisations") && stderr(&o).contains("simulation.integrator"), "{}", stderr(&o));
}
