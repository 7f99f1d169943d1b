//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use lash_run::{Runner, Summary};

/// Runs to the end, keeping every row.
pub fn rows(runner: &mut dyn Runner) -> (Summary, Vec<String>, Vec<Vec<f64>>) {
    let header = runner.header();
    let mut rows = Vec::new();
    let summary = runner
        .execute(
            &mut |r| {
                rows.push(r.to_vec());
                Ok(())
            },
            &mut |_| {},
        )
        .unwrap();
    (summary, header, rows)
}

/// Index of the column called `name` (units stripped).
pub fn column(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h.starts_with(&format!("{name} ["))).unwrap_or_else(|| panic!("no column {name}"))
}

/// The Python of target/fmpy-venv with fmpy 0.3.32, pythonfmu 0.7.0 and libcosimpy 0.0.6 (the
/// Open Simulation Platform's libcosim) from PyPI, made on first use. Tests of one binary run in parallel threads: one makes it, the others wait.
pub fn fmpy_python() -> std::path::PathBuf {
    use std::process::Command;
    static MADE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _made = MADE.lock().unwrap_or_else(|e| e.into_inner());
    let venv = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target").join("fmpy-venv");
    let python = venv.join("bin/python");
    if !python.exists() {
        let ok = Command::new("python3").args(["-m", "venv"]).arg(&venv).status().expect("python3 is needed").success();
        assert!(ok, "creating {}", venv.display());
    }
    let has =
        |m: &str| Command::new(&python).args(["-c", &format!("import {m}")]).output().is_ok_and(|o| o.status.success());
    if !has("fmpy") || !has("pythonfmu") || !has("libcosimpy") {
        let ok = Command::new(&python)
            .args(["-m", "pip", "install", "--quiet", "fmpy==0.3.32", "pythonfmu==0.7.0", "libcosimpy==0.0.6"])
            .status()
            .expect("pip")
            .success();
        assert!(ok, "installing fmpy, pythonfmu and libcosimpy from PyPI into {}", venv.display());
    }
    python
}

/// The master options of A's reduced model to `stop`: h_m = 1 ms, h_r = 10 µs, linear, one-way,
/// run as `execution` says.
pub fn one_way_options(
    stop: lash_core::Ticks,
    execution: lash_orchestrate::Execution,
) -> lash_orchestrate::MasterOptions {
    use lash_core::Ticks;
    lash_orchestrate::MasterOptions {
        start: Ticks::ZERO,
        stop,
        macro_step: Ticks::from_seconds(1e-3).unwrap(),
        micro_step: Ticks::from_seconds(1e-5).unwrap(),
        interpolation: lash_orchestrate::Interpolation::Linear,
        coupling: lash_core::Coupling::OneWay,
        execution,
    }
}
