//! `lash sweep` end to end: thread-count invariance, resumption after a kill, shards + merge equal
//! to one machine, per-run failures recorded, bad input refused before any work, the dataset read
//! back by pyarrow/pandas, and a real Dask `LocalCluster` with two workers running the shards
//! (tests/sweep/check_dataset.py, examples/dask_sweep.py; Python packages from PyPI into
//! target/data-venv on first use).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lash(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().expect("lash runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lash-sweep-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small random sweep of scenario A (reduced model) with measurement noise.
fn sweep_file(dir: &Path, runs: u32, horizon: f64) -> PathBuf {
    let f = dir.join("sweep.toml");
    std::fs::write(
        &f,
        format!(
            r#"base = "A"
sampling = "random"
runs = {runs}
seed = 11
horizon = {horizon}
[output]
channels = ["slider.ax", "crank_pivot.force"]
sample_rate = 10000.0
noise = {{ "slider.ax" = 25.0 }}
[[parameters]]
path = "clearances[0].bearing_radius"
uniform = {{ low = 0.00992, high = 0.0101 }}
[[parameters]]
path = "drivers[0].motion.omega"
values = [400.0, 450.0, 523.6]
"#
        ),
    )
    .unwrap();
    f
}

fn run_sweep(file: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["sweep", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"];
    args.extend_from_slice(extra);
    lash(&args)
}

fn bytes(p: PathBuf) -> Vec<u8> {
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn results_do_not_depend_on_threads_shards_or_interruptions() {
    let dir = scratch("invariance");
    let file = sweep_file(&dir, 24, 0.02);
    // One thread simulating one run at a time; two threads, each eight runs side by side (their
    // micro models in vector lanes); one thread, eight side by side.
    let one = dir.join("one");
    let o = run_sweep(&file, &one, &["--threads", "1", "--side-by-side", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (name, extra) in
        [("two", ["--threads", "2", "--side-by-side", "8"]), ("lanes", ["--threads", "1", "--side-by-side", "8"])]
    {
        let other = dir.join(name);
        let o = run_sweep(&file, &other, &extra);
        assert!(o.status.success(), "{}", stderr(&o));
        for f in ["data.parquet", "params.parquet"] {
            assert!(bytes(one.join(f)) == bytes(other.join(f)), "{f} differs between one at a time and {extra:?}");
        }
    }
    let o = run_sweep(&file, &dir.join("none"), &["--side-by-side", "0"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--side-by-side must be ≥ 1"), "{}", stderr(&o));
    // Noise is really there and seeded per run: the same parameters twice would differ only by it.
    let manifest: serde_json::Value = serde_json::from_slice(&bytes(one.join("manifest.json"))).unwrap();
    let runs = manifest["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 24);
    assert!(runs.iter().all(|r| r["status"] == "ok" && r["rows"] == 201), "{runs:?}");
    let seeds: std::collections::HashSet<u64> = runs.iter().map(|r| r["seed"].as_u64().unwrap()).collect();
    assert_eq!(seeds.len(), 24);

    // Shards 0/3, 1/3, 2/3 merged equal the single-machine dataset.
    let mut shards = Vec::new();
    for i in 0..3 {
        let s = dir.join(format!("shard{i}"));
        let o = run_sweep(&file, &s, &["--shard", &format!("{i}/3")]);
        assert!(o.status.success(), "{}", stderr(&o));
        shards.push(s.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged");
    let mut args = vec!["sweep", "merge"];
    args.extend(shards.iter().map(String::as_str));
    args.extend(["--out", merged.to_str().unwrap()]);
    let o = lash(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["data.parquet", "params.parquet"] {
        assert!(bytes(one.join(f)) == bytes(merged.join(f)), "{f}: merged shards differ from one machine");
    }
    // An incomplete set of shards is refused, naming the missing one.
    let o = lash(&["sweep", "merge", &shards[0], &shards[2], "--out", dir.join("m2").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("1/3"), "{}", stderr(&o));
}

#[test]
fn a_killed_sweep_resumes_and_loses_only_the_runs_in_flight() {
    let dir = scratch("resume");
    // Enough short runs that a worker closes several parts (64 runs each) before the end.
    let file = sweep_file(&dir, 400, 0.02);
    let clean = dir.join("clean");
    let o = run_sweep(&file, &clean, &[]);
    // A run may blow up in the micro model (a grazing impact whose approach speed is below the
    // law's velocity floor makes the hysteresis damping too stiff for RK4 at 1e-5 s; DOPRI5, or
    // h_r = 2e-6 s, runs it; see docs/validation.md): the sweep records it, finishes, and exits 1
    // — here and resumed alike, with the same count.
    let failures = |o: &Output| {
        let text = stderr(o);
        let count = text.split(" failed)").next().and_then(|t| t.rsplit(' ').next()).map(str::to_string);
        (o.status.code(), count)
    };
    let expected = failures(&o);
    assert!(matches!(expected, (Some(0 | 1), Some(_))), "{}", stderr(&o));

    let out = dir.join("killed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args(["sweep", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet", "--threads", "1"])
        .spawn()
        .unwrap();
    let journal = out.join("runs.jsonl");
    let started = std::time::Instant::now();
    let lines = || std::fs::read_to_string(&journal).map(|t| t.lines().count()).unwrap_or(0);
    loop {
        if lines() >= 64 {
            child.kill().unwrap();
            child.wait().unwrap();
            break;
        }
        assert!(started.elapsed().as_secs() < 60, "the sweep never got going");
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the sweep finished ({status}) before it could be killed; make it longer");
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let finished_before_kill = lines();
    // The finished runs are kept several to a part file, not one file each.
    let parts = std::fs::read_dir(out.join("parts"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "parquet"))
        .count();
    assert!(parts >= 1 && parts < finished_before_kill, "{parts} part files for {finished_before_kill} journaled runs");
    assert!(!out.join("data.parquet").exists(), "a killed sweep must not leave a dataset that looks complete");
    let o = run_sweep(&file, &out, &[]);
    assert_eq!(failures(&o), expected, "{}", stderr(&o));
    let text = stderr(&o);
    let skipped: usize =
        text.split(" already complete").next().unwrap().rsplit('(').next().unwrap().trim().parse().unwrap();
    assert!(skipped >= finished_before_kill, "resumed run skipped {skipped}, {finished_before_kill} were done: {text}");
    for f in ["data.parquet", "params.parquet"] {
        assert!(bytes(clean.join(f)) == bytes(out.join(f)), "{f}: resumed sweep differs from an uninterrupted one");
    }
    // Running it once more does nothing.
    let o = run_sweep(&file, &out, &[]);
    assert!(stderr(&o).contains("400 already complete, 0 run now"), "{}", stderr(&o));
    assert_eq!(failures(&o), expected, "{}", stderr(&o));
}

#[test]
fn an_invalid_combination_is_a_recorded_failure_not_a_stop() {
    let dir = scratch("failure");
    let file = dir.join("sweep.toml");
    // A bearing radius below the journal radius (9.9 mm) is invalid for that run only.
    std::fs::write(
        &file,
        r#"base = "A"
horizon = 0.01
[output]
channels = ["slider.ax"]
sample_rate = 10000.0
[[parameters]]
path = "clearances[0].bearing_radius"
values = [0.01, 0.0098, 0.00995]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = run_sweep(&file, &out, &[]);
    // The sweep finishes every run and writes the dataset, then exits 1 saying how many failed.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 failed") && stderr(&o).contains("1 of 3 runs failed"), "{}", stderr(&o));
    assert!(out.join("data.parquet").exists(), "the dataset of the other runs is written");
    let m: serde_json::Value = serde_json::from_slice(&bytes(out.join("manifest.json"))).unwrap();
    let runs = m["runs"].as_array().unwrap();
    assert_eq!(runs[0]["status"], "ok");
    assert_eq!(runs[1]["status"], "failed");
    assert!(runs[1]["error"].as_str().unwrap().contains("bearing_radius"), "{}", runs[1]["error"]);
    assert_eq!(runs[2]["status"], "ok");
    // Shards merged into a dataset that holds the failure exit as the sweep does.
    let shards: Vec<String> = (0..2)
        .map(|i| {
            let shard = dir.join(format!("shard{i}"));
            let o = run_sweep(&file, &shard, &["--shard", &format!("{i}/2")]);
            assert!(o.status.code().is_some(), "{}", stderr(&o));
            shard.to_str().unwrap().to_string()
        })
        .collect();
    let merged = dir.join("merged");
    let o = lash(&["sweep", "merge", &shards[0], &shards[1], "--out", merged.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 of 3 runs failed"), "{}", stderr(&o));
    assert!(merged.join("data.parquet").exists());
}

#[test]
fn bad_input_is_refused_before_any_work() {
    let dir = scratch("bad");
    let file = sweep_file(&dir, 4, 0.01);
    let text = std::fs::read_to_string(&file).unwrap();
    let check = |name: &str, content: &str, extra: &[&str], expect: &[&str]| {
        let f = dir.join(format!("{name}.toml"));
        std::fs::write(&f, content).unwrap();
        let out = dir.join(format!("out-{name}"));
        let o = run_sweep(&f, &out, extra);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", stderr(&o));
        for e in expect {
            assert!(stderr(&o).contains(e), "{name}: {e:?} not in {}", stderr(&o));
        }
        assert!(!out.join("data.parquet").exists(), "{name}: output written");
    };
    check(
        "path",
        &text.replace("drivers[0].motion.omega", "drivers[0].motion.omga"),
        &[],
        &["parameters[1].path", "omga", "omega"],
    );
    check("channel", &text.replace("\"crank_pivot.force\"", "\"crank_pivot.farce\""), &[], &["output.channels[1]"]);
    check("range", &text.replace("low = 0.00992", "low = 0.02"), &[], &["parameters[0].uniform", "low < high"]);
    check("shard", &text, &["--shard", "3/3"], &["--shard", "0 ≤ i < N"]);
    check("rate", &text.replace("10000.0", "30000.0"), &[], &["output.sample_rate", "output_interval"]);
    // A folder holding another sweep's data.
    let out = dir.join("taken");
    assert!(run_sweep(&file, &out, &[]).status.success());
    let other = dir.join("other.toml");
    std::fs::write(&other, text.replace("seed = 11", "seed = 12")).unwrap();
    let o = run_sweep(&other, &out, &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("another sweep"), "{}", stderr(&o));
    // A folder with foreign files.
    let foreign = dir.join("foreign");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
    let o = run_sweep(&file, &foreign, &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not empty"), "{}", stderr(&o));
}

/// A Python virtual environment with pyarrow, pandas and Dask distributed, made once.
fn data_python() -> PathBuf {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target").join("data-venv");
    let python = venv.join("bin/python");
    if !python.exists() {
        let ok = Command::new("python3").args(["-m", "venv"]).arg(&venv).status().expect("python3 is needed").success();
        assert!(ok, "creating {}", venv.display());
    }
    let ready = Command::new(&python)
        .args(["-c", "import pyarrow, pandas, dask.distributed"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ready {
        let ok = Command::new(&python)
            .args(["-m", "pip", "install", "--quiet", "pyarrow", "pandas", "dask[distributed]"])
            .status()
            .expect("pip")
            .success();
        assert!(ok, "installing pyarrow, pandas and dask[distributed] from PyPI into {}", venv.display());
    }
    python
}

#[test]
fn pandas_reads_the_dataset_and_a_dask_cluster_reproduces_it() {
    let dir = scratch("dask");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = sweep_file(&dir, 16, 0.02);
    let single = dir.join("single");
    let o = run_sweep(&file, &single, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let python = data_python();
    let cluster = Command::new(&python)
        .arg(root.join("examples/dask_sweep.py"))
        .arg(&file)
        .args([
            "--out",
            dir.join("dask").to_str().unwrap(),
            "--shards",
            "4",
            "--local-workers",
            "2",
            "--lash",
            env!("CARGO_BIN_EXE_lash"),
        ])
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&cluster.stdout), String::from_utf8_lossy(&cluster.stderr));
    assert!(cluster.status.success(), "dask runner: {text}");
    assert!(text.contains("4 shards on 2 Dask workers"), "{text}");
    let check = Command::new(&python)
        .arg(root.join("tests/sweep/check_dataset.py"))
        .arg(&single)
        .arg(dir.join("dask/merged"))
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&check.stdout), String::from_utf8_lossy(&check.stderr));
    assert!(check.status.success(), "pyarrow/pandas check: {text}");
    assert!(text.contains("equal tables"), "{text}");
}

#[test]
fn the_example_sweeps_run() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["sweep-grid", "sweep-lhs", "sweep-bush"] {
        let out = scratch(name).join("out");
        let o = run_sweep(&root.join(format!("examples/{name}.toml")), &out, &[]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(" 0 failed"), "{name}: {}", stderr(&o));
        let m: serde_json::Value = serde_json::from_slice(&bytes(out.join("manifest.json"))).unwrap();
        assert_eq!(m["status"], "complete");
    }
}

#[test]
fn a_spatial_scenario_sweeps_like_a_planar_one() {
    let dir = scratch("spatial");
    let file = dir.join("sweep.toml");
    std::fs::write(
        &file,
        r#"base = "E-0.5mm-250rpm-frictionless"
model = "full"
horizon = 0.02
[output]
channels = ["slider_guide.fy", "rod_slider.eccentricity"]
sample_rate = 10000.0
[[parameters]]
path = "clearances[1].journal_radius"
values = [0.0055, 0.00575, 0.0061]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = run_sweep(&file, &out, &[]);
    // The third ball is larger than its socket: that run fails with the field named.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&bytes(out.join("manifest.json"))).unwrap();
    let runs = m["runs"].as_array().unwrap();
    assert_eq!((runs[0]["status"].as_str(), runs[1]["status"].as_str()), (Some("ok"), Some("ok")));
    assert!(runs[2]["error"].as_str().unwrap().contains("journal_radius"), "{}", runs[2]["error"]);
    assert_eq!(m["channels"][1]["unit"], "m");
    assert!(out.join("data.parquet").exists());
    // The reduced model sweeps it too, with the same failing run.
    std::fs::write(&file, std::fs::read_to_string(&file).unwrap().replace("model = \"full\"", "model = \"reduced\""))
        .unwrap();
    let o = run_sweep(&file, &dir.join("reduced"), &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&bytes(dir.join("reduced").join("manifest.json"))).unwrap();
    let runs = m["runs"].as_array().unwrap();
    assert_eq!((runs[0]["status"].as_str(), runs[1]["status"].as_str()), (Some("ok"), Some("ok")));
    assert_eq!(runs[2]["status"], "failed");
}

#[test]
fn a_dataset_can_hold_anti_aliased_clean_and_measured_channels() {
    let dir = scratch("anti-alias");
    let file = dir.join("sweep.toml");
    std::fs::write(
        &file,
        r#"base = "A"
sampling = "grid"
horizon = 0.05
[output]
channels = ["slider.ax"]
sample_rate = 2000.0
noise = { "slider.ax" = 25.0 }
anti_alias = { cutoff = 800.0 }
clean = true
csv = true
[[parameters]]
path = "drivers[0].motion.omega"
values = [450.0, 523.6]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = run_sweep(&file, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("data.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (measured, clean) = (
        header.iter().position(|h| *h == "slider.ax").expect("measured column"),
        header.iter().position(|h| *h == "slider.ax.clean").expect("clean column"),
    );
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect()).collect();
    assert_eq!(rows.len(), 2 * 101, "0 … 0.05 s at 2 kHz for each run");
    // The noise is what separates the measured channel from the clean one.
    let d: Vec<f64> = rows.iter().map(|r| r[measured] - r[clean]).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len() - 1) as f64).sqrt();
    assert!((sd / 25.0 - 1.0).abs() < 0.2, "noise standard deviation {sd}");
    // The filter ran: the clean channel is not the point-sampled one.
    std::fs::write(&file, std::fs::read_to_string(&file).unwrap().replace("anti_alias = { cutoff = 800.0 }\n", ""))
        .unwrap();
    let o = run_sweep(&file, &dir.join("point"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let point = std::fs::read_to_string(dir.join("point").join("data.csv")).unwrap();
    let point: Vec<f64> = point.lines().skip(1).map(|l| l.split(',').nth(clean).unwrap().parse().unwrap()).collect();
    let differs = rows.iter().zip(&point).filter(|(r, p)| (r[clean] - **p).abs() > 1e-6).count();
    assert!(differs > 100, "{differs} of {} samples changed by the anti-alias filter", point.len());
}

/// A design too large to list is refused by `lash validate` as by `lash sweep`, before a run is
/// listed (a grid of 2.4e14 points once aborted `validate` allocating them).
#[test]
fn validate_sizes_a_huge_design_before_listing_it() {
    let dir = scratch("huge");
    let file = dir.join("huge.toml");
    let mut text = String::from(
        "base = \"A\"\nsampling = \"grid\"\nhorizon = 0.01\n[output]\nchannels = [\"slider.ax\"]\nsample_rate = 10000.0\n",
    );
    for path in ["clearances[0].bearing_radius", "drivers[0].motion.omega", "clearances[0].contact.restitution"] {
        text.push_str(&format!(
            "[[parameters]]\npath = \"{path}\"\nlinspace = {{ start = 1.0, stop = 2.0, count = 62000 }}\n"
        ));
    }
    std::fs::write(&file, text).unwrap();
    for args in [
        vec!["validate", file.to_str().unwrap()],
        vec!["sweep", file.to_str().unwrap(), "--out", dir.join("o").to_str().unwrap(), "--quiet"],
    ] {
        let o = lash(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        // validate: the design's memory; sweep: its output's disk first.
        let what = if args[0] == "validate" { "memory" } else { "would write" };
        assert!(stderr(&o).contains(what), "{args:?}: {}", stderr(&o));
    }
}

/// A sweep logs a scenario's emulated housing accelerometer (`housing.ay`) from its force through
/// each run's own mount, as `lash run` measures it: the same samples (after the settle time, mean
/// removed) at a mount frequency the sweep varies.
#[test]
fn a_sweep_logs_the_housing_accelerometer_as_a_run_measures_it() {
    let dir = scratch("housing");
    let file = dir.join("sweep.toml");
    std::fs::write(
        &file,
        r#"base = "E-0.5mm-250rpm"
model = "full"
sampling = "grid"
horizon = 0.3
[output]
channels = ["housing.ay", "slider_guide.fy"]
sample_rate = 500.0
anti_alias = { cutoff = 200.0 }
csv = true
[[parameters]]
path = "output.measurements[0].mount.natural_frequency"
values = [120.0]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = run_sweep(&file, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&bytes(out.join("manifest.json"))).unwrap();
    assert_eq!(m["channels"][0]["unit"], "m/s^2");
    let csv = std::fs::read_to_string(out.join("data.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let (t, ay) =
        (header.iter().position(|h| *h == "t").unwrap(), header.iter().position(|h| *h == "housing.ay").unwrap());
    let rows: Vec<Vec<f64>> =
        csv.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect()).collect();
    let swept: Vec<f64> = rows.iter().filter(|r| r[t] >= 0.24 - 1e-9).map(|r| r[ay]).collect();
    let mean = swept.iter().sum::<f64>() / swept.len() as f64;
    // The scenario with that mount, run and measured by `lash run`.
    let shown = lash(&["show", "E-0.5mm-250rpm"]);
    let text = String::from_utf8(shown.stdout)
        .unwrap()
        .replace("natural_frequency = 150.0", "natural_frequency = 120.0")
        .replace("horizon = 0.48", "horizon = 0.3");
    let scenario = dir.join("E.toml");
    std::fs::write(&scenario, text).unwrap();
    let o = lash(&["run", scenario.to_str().unwrap(), "--out", dir.join("run").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let measured = std::fs::read_to_string(dir.join("run").join("measurement_housing.csv")).unwrap();
    let logged: Vec<f64> = measured.lines().skip(1).map(|l| l.split(',').nth(2).unwrap().parse().unwrap()).collect();
    assert_eq!(logged.len(), swept.len());
    let scale = logged.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    assert!(scale > 1.0, "the housing vibrates: {scale} m/s²");
    for (a, b) in swept.iter().zip(&logged) {
        assert!((a - mean - b).abs() < 1e-9 * scale, "{a} − {mean} against {b}");
    }
}
