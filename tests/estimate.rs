//! `lash estimate` end to end on a small preparation: prepare (reduced-model bank, full-model
//! calibration), emulate measurements of the converged full model at two clearances, estimate
//! each (answer, estimate.json, posterior.svg), validate on held-out cases, and refuse bad input
//! with exit 2. The estimator's accuracy and calibration are measured by `lash estimate validate`
//! at full size (docs/validation.md), not here: this checks that every piece is connected and
//! that more clearance reads as more clearance.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lash(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lash-estimate-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The clearance estimate of a measured file: (median, low, high) from estimate.json.
fn clearance(dir: &Path, measured: &Path, prepared: &Path, tag: &str) -> (f64, f64, f64) {
    let out = dir.join(tag);
    let o = lash(&[
        "estimate",
        measured.to_str().unwrap(),
        "--prepared",
        prepared.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(printed.contains("crank_pivot.clearance") && printed.contains("90 % interval"), "{printed}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("estimate.json")).unwrap()).unwrap();
    let svg = std::fs::read_to_string(out.join("posterior.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("crank_pivot.clearance"));
    // The hidden signals: every sample of the window, the median inside its band.
    let hidden = std::fs::read_to_string(out.join("hidden.csv")).unwrap();
    let mut lines = hidden.lines();
    assert!(lines.next().unwrap().starts_with("time [s],crank_pivot.force.median [N],crank_pivot.force.low [N]"));
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 10_000);
    assert!(rows.iter().all(|r| r[2] <= r[1] && r[1] <= r[3] && r[5] <= r[4] && r[4] <= r[6]));
    assert!(std::fs::read_to_string(out.join("hidden.svg")).unwrap().contains("crank_pivot.force"));
    let u = &json["unknowns"][0];
    assert_eq!(u["name"], "crank_pivot.clearance");
    let (m, lo, hi) = (u["median"].as_f64().unwrap(), u["low"].as_f64().unwrap(), u["high"].as_f64().unwrap());
    assert!(50e-6 <= lo && lo <= m && m <= hi && hi <= 300e-6, "{lo} {m} {hi}");
    (m, lo, hi)
}

#[test]
fn prepare_emulate_estimate_validate_and_refuse_bad_input() {
    let dir = scratch();
    let prepared = dir.join("A.json");
    let p = prepared.to_str().unwrap();
    let o = lash(&[
        "estimate",
        "prepare",
        "A",
        "--out",
        p,
        "--bank-runs",
        "240",
        "--calibration-runs",
        "24",
        "--hidden-runs",
        "8",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut estimates = Vec::new();
    for (tag, c) in [("small", "80e-6"), ("large", "260e-6")] {
        let measured = dir.join(format!("{tag}.csv"));
        let o = lash(&[
            "estimate",
            "emulate",
            "--prepared",
            p,
            "--clearance",
            c,
            "--snr",
            "45",
            "--out",
            measured.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        estimates.push(clearance(&dir, &measured, &prepared, tag));
    }
    assert!(estimates[1].0 > 1.5 * estimates[0].0, "260 µm reads as more play than 80 µm: {estimates:?}");
    let o = lash(&[
        "estimate",
        "validate",
        "--prepared",
        p,
        "--cases",
        "6",
        "--quiet",
        "--out",
        dir.join("val").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let printed = String::from_utf8_lossy(&o.stdout);
    for part in ["6 held-out full-model cases", "coverage", "crank_pivot.clearance", "wall time per estimate"] {
        assert!(printed.contains(part), "{part}: {printed}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("val/validation.json")).unwrap()).unwrap();
    assert_eq!(report["cases"], 6);
    // The virtual sensor against the full model's own force on held-out cases at 40 dB.
    let o = lash(&[
        "estimate",
        "validate",
        "--prepared",
        p,
        "--hidden",
        "40",
        "--cases",
        "4",
        "--track-impacts",
        "32",
        "--track-draws",
        "2",
        "--quiet",
        "--out",
        dir.join("hidden").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("hidden/hidden-validation.json")).unwrap()).unwrap();
    assert_eq!(report["cases"], 4);
    let rms_error = report["force_rms_error"][0].as_f64().unwrap();
    assert!(rms_error < 0.15, "the contact force's RMS within 15 % even from a small bank: {report}");
    // The impact tracking ran on every case, its particles spread over two draws (its particles,
    // and how many cases it followed).
    assert_eq!(report["tracking"][0], 32, "{report}");
    assert!(report["tracking"][1].as_u64().is_some_and(|f| f <= 4), "{report}");
    // Bad input: exit 2 with the field named.
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "time [s],slider.ax [m/s^2]\n0,1\n0.0001,nan\n").unwrap();
    let m = bad.to_str().unwrap();
    for (args, expected) in [
        (vec!["estimate", m, "--prepared", p], "\"slider.ax\""),
        (vec!["estimate", m, "--prepared", "/nonexistent.json"], "--prepared /nonexistent.json"),
        (vec!["estimate", "prepare", "Z", "--out", p], "not a built-in setup"),
        (
            vec!["estimate", "emulate", "--prepared", p, "--clearance", "1e-4,2e-4", "--out", m],
            "--clearance: 2 values for 1",
        ),
        (vec!["estimate", "validate", "--prepared", p, "--cases", "0"], "--cases"),
        (vec!["estimate", m, "--prepared", p, "--track-impacts", "1"], "--track-impacts: 2 to 100000 particles"),
        (
            vec!["estimate", m, "--prepared", p, "--track-impacts", "8", "--track-draws", "9"],
            "--track-draws: 1 to 8 posterior draws",
        ),
        (vec!["estimate", m, "--prepared", p, "--track-draws", "2"], "--track-impacts"),
    ] {
        let o = lash(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expected), "{args:?}: {}", stderr(&o));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Scenario E end to end on a small preparation: the spatial mechanism's two spherical joints
/// seen by the guide housing's accelerometer at 500 Hz (its force through the mount, the orders
/// read in the envelope). A measurement of the converged full model with the rod–slider ball worn
/// is estimated: every unknown answered with an interval inside its prior, the joints' worn
/// probabilities summing to one, the hidden signals written for both joints.
#[test]
fn a_spatial_housing_accelerometer_is_estimated() {
    let dir = std::env::temp_dir().join(format!("lash-estimate-e-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let prepared = dir.join("E.json");
    let p = prepared.to_str().unwrap();
    let o = lash(&[
        "estimate",
        "prepare",
        "E",
        "--out",
        p,
        "--bank-runs",
        "300",
        "--calibration-runs",
        "20",
        "--hidden-runs",
        "6",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let measured = dir.join("worn.csv");
    let o = lash(&[
        "estimate",
        "emulate",
        "--prepared",
        p,
        "--clearance",
        "30e-6,450e-6",
        "--snr",
        "45",
        "--out",
        measured.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let header = std::fs::read_to_string(&measured).unwrap();
    assert!(header.starts_with("time [s],housing.ay [m/s^2],housing.az [m/s^2]"), "{}", &header[..80]);
    let out = dir.join("answer");
    let o = lash(&["estimate", measured.to_str().unwrap(), "--prepared", p, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("estimate.json")).unwrap()).unwrap();
    for u in json["unknowns"].as_array().unwrap() {
        let (lo, m, hi) = (u["low"].as_f64().unwrap(), u["median"].as_f64().unwrap(), u["high"].as_f64().unwrap());
        let (a, b) = (u["prior"][0].as_f64().unwrap(), u["prior"][1].as_f64().unwrap());
        assert!(a <= lo && lo <= m && m <= hi && hi <= b, "{u}");
    }
    let worn: f64 = json["worn"].as_array().unwrap().iter().map(|w| w[1].as_f64().unwrap()).sum();
    assert!((worn - 1.0).abs() < 1e-9, "{}", json["worn"]);
    // The hidden signals: each column what its header says (a runner orders its own columns).
    let hidden = std::fs::read_to_string(out.join("hidden.csv")).unwrap();
    let header: Vec<&str> = hidden.lines().next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> =
        hidden.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 500);
    let column = |name: &str| header.iter().position(|h| h.starts_with(name)).unwrap_or_else(|| panic!("{name}"));
    let (force, eccentricity) = (column("rod_slider.force.median"), column("rod_slider.eccentricity.median"));
    let mean_force = rows.iter().map(|r| r[force]).sum::<f64>() / 500.0;
    assert!(mean_force > 1.0, "the worn ball carries the rod's load: {mean_force} N");
    assert!(rows.iter().all(|r| r[eccentricity].abs() < 1e-3), "eccentricities are below a millimetre");
    let _ = std::fs::remove_dir_all(&dir);
}
