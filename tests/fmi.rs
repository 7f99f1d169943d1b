//! FMI 3.0 export judged by fmpy: both packed FMUs are validated; the interface FMU is simulated
//! and driven by a Python master through fmpy's low-level API (tests/fmi/interface_fmu.py); a
//! Python master co-simulates the mechanism and interface FMUs with lash's multirate scheme and
//! must reproduce lash's in-process slider acceleration (tests/fmi/reduced_cosim.py). fmpy is
//! installed from PyPI into target/fmpy-venv on first use.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::fmpy_python;

#[test]
fn fmpy_validates_simulates_and_cosimulates_the_fmus() {
    // The FMU's shared library is a cdylib that `cargo test` does not link anywhere: the README's
    // test command builds it first (`cargo build --profile ci --workspace`).
    let lib = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("liblash_interface.so");
    assert!(
        lib.exists(),
        "{} is missing: run the build step of the test command (`cargo build --profile ci --workspace`) first",
        lib.display()
    );
    let out = std::env::temp_dir().join(format!("lash-fmi-{}", std::process::id()));
    let pack = Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "pack", "--out"]).arg(&out).output().unwrap();
    assert!(pack.status.success(), "{}", String::from_utf8_lossy(&pack.stderr));
    let fmu_path = out.join("lash_interface.fmu");
    let python = fmpy_python();
    let run = |args: &[&str]| {
        let o = Command::new(&python).args(args).output().unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert!(o.status.success(), "{args:?}: {text}");
        text
    };
    let fmu_str = fmu_path.to_str().unwrap();
    let validate = run(&["-m", "fmpy.cli", "validate", fmu_str]);
    assert!(validate.contains("No problems found"), "{validate}");
    let csv = out.join("simulate.csv");
    run(&["-m", "fmpy.cli", "simulate", fmu_str, "--output-file", csv.to_str().unwrap()]);
    let rows = std::fs::read_to_string(&csv).unwrap().lines().count();
    assert_eq!(rows, 1 + 1001, "0.01 s at 1e-5 s, both ends");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmi/interface_fmu.py");
    let text = run(&[script.to_str().unwrap(), fmu_str]);
    assert!(text.contains("OK"), "{text}");
    let mechanism = out.join("lash_mechanism.fmu");
    for name in [
        "lash_mechanism.fmu",
        "lash_interface-fmi2.fmu",
        "lash_mechanism-fmi2.fmu",
        "lash_full.fmu",
        "lash_full-fmi2.fmu",
    ] {
        let validate = run(&["-m", "fmpy.cli", "validate", out.join(name).to_str().unwrap()]);
        assert!(validate.contains("No problems found"), "{name}: {validate}");
    }
    let csv2 = out.join("simulate2.csv");
    let fmi2 = out.join("lash_interface-fmi2.fmu");
    run(&["-m", "fmpy.cli", "simulate", fmi2.to_str().unwrap(), "--output-file", csv2.to_str().unwrap()]);
    // The mechanism FMU, both versions, over its default experiment (0.036 s at 1e-3 s).
    for name in ["lash_mechanism.fmu", "lash_mechanism-fmi2.fmu"] {
        let csv = out.join(format!("{name}.csv"));
        run(&["-m", "fmpy.cli", "simulate", out.join(name).to_str().unwrap(), "--output-file", csv.to_str().unwrap()]);
        let rows = std::fs::read_to_string(&csv).unwrap().lines().count();
        assert_eq!(rows, 1 + 37, "{name}: 0.036 s at 1e-3 s, both ends");
    }
    let header = std::fs::read_to_string(&csv2).unwrap();
    assert!(header.contains("\"contact_force[1]\""), "FMI 2.0 flattens arrays: {}", &header[..200.min(header.len())]);

    // A Python master co-simulating both FMUs reproduces lash's in-process reduced run (at the
    // FMUs' communication step, 1 ms: `lash run` alone would choose 0.5 ms at 5000 rpm).
    let reduced = out.join("reduced");
    let o = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args(["run", "A", "--model", "reduced", "--macro-step", "1e-3", "--quiet", "--out"])
        .arg(&reduced)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmi/reduced_cosim.py");
    for (mech, micro) in [(mechanism.clone(), fmu_path.clone()), (out.join("lash_mechanism-fmi2.fmu"), fmi2.clone())] {
        let text = run(&[
            script.to_str().unwrap(),
            mech.to_str().unwrap(),
            micro.to_str().unwrap(),
            reduced.join("timeseries.csv").to_str().unwrap(),
        ]);
        eprintln!("{text}");
        assert!(text.contains("bit-identical"), "{text}");
    }
    // The same Python master through the FMUs of the two-joint scenario C (4 × 4 M~, two friction
    // forces; the scenario in the archives' resources) reproduces `lash run C --model reduced` at the
    // FMU's micro step, 1e-5 s.
    let c_fmus = out.join("C");
    let pack =
        Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "pack", "C", "--out"]).arg(&c_fmus).output().unwrap();
    assert!(pack.status.success(), "{}", String::from_utf8_lossy(&pack.stderr));
    let c_reduced = out.join("C-reduced");
    let o = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args(["run", "C", "--model", "reduced", "--macro-step", "1e-3", "--micro-step", "1e-5", "--quiet", "--out"])
        .arg(&c_reduced)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in ["lash_mechanism.fmu", "lash_interface.fmu", "lash_full.fmu", "lash_interface-fmi2.fmu"] {
        let validate = run(&["-m", "fmpy.cli", "validate", c_fmus.join(name).to_str().unwrap()]);
        assert!(validate.contains("No problems found"), "C {name}: {validate}");
    }
    for (mech, micro) in
        [("lash_mechanism.fmu", "lash_interface.fmu"), ("lash_mechanism-fmi2.fmu", "lash_interface-fmi2.fmu")]
    {
        let text = run(&[
            script.to_str().unwrap(),
            c_fmus.join(mech).to_str().unwrap(),
            c_fmus.join(micro).to_str().unwrap(),
            c_reduced.join("timeseries.csv").to_str().unwrap(),
        ]);
        eprintln!("C: {text}");
        assert!(text.contains("bit-identical: True"), "C: {text}");
    }
    // The clearance joint's coefficients are FMU parameters: set before initialization, they must
    // give what lash computes for a scenario file written with the same values.
    let shown = Command::new(env!("CARGO_BIN_EXE_lash")).args(["show", "A"]).output().unwrap();
    let text = String::from_utf8(shown.stdout).unwrap();
    assert_eq!(text.matches("restitution = 0.9").count(), 1);
    assert_eq!(text.matches("coefficient = 0.01").count(), 1);
    let edited =
        text.replace("restitution = 0.9", "restitution = 0.6").replace("coefficient = 0.01", "coefficient = 0.08");
    let scenario = out.join("A-edited.toml");
    std::fs::write(&scenario, edited).unwrap();
    let reference = out.join("edited");
    let o = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args([
            "run",
            scenario.to_str().unwrap(),
            "--model",
            "reduced",
            "--macro-step",
            "1e-3",
            "--quiet",
            "--horizon",
            "0.036",
            "--out",
        ])
        .arg(&reference)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_ne!(
        std::fs::read(reference.join("timeseries.csv")).unwrap(),
        std::fs::read(reduced.join("timeseries.csv")).unwrap(),
        "the edited coefficients must change the response, or this check proves nothing"
    );
    for (mech, micro) in [(mechanism.clone(), fmu_path.clone()), (out.join("lash_mechanism-fmi2.fmu"), fmi2.clone())] {
        let text = run(&[
            script.to_str().unwrap(),
            mech.to_str().unwrap(),
            micro.to_str().unwrap(),
            reference.join("timeseries.csv").to_str().unwrap(),
            "contact.restitution=0.6,friction.coefficient=0.08",
        ]);
        eprintln!("parameters set: {text}");
        assert!(text.contains("bit-identical"), "{text}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Packs the FMUs (of `scenario`, or the default ones) into a fresh temporary folder.
fn packed_scenario(tag: &str, scenario: Option<&str>) -> PathBuf {
    let out = std::env::temp_dir().join(format!("lash-fmi-{tag}-{}", std::process::id()));
    let pack = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args(["fmu", "pack"])
        .args(scenario)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(pack.status.success(), "{}", String::from_utf8_lossy(&pack.stderr));
    out
}

/// Packs the default FMUs (scenario A) into a fresh temporary folder.
fn packed(tag: &str) -> PathBuf {
    packed_scenario(tag, None)
}

/// The FMUs of the two-joint scenario C (one generic binary per kind, the scenario in the
/// archive's resources): the interface FMU has 4 interface coordinates, and lash's master through
/// the imported mechanism and interface FMUs reproduces the in-process reduced run bit for bit,
/// in FMI 3.0 and 2.0.
#[test]
fn fmus_packed_for_the_two_joint_scenario_reproduce_its_in_process_run() {
    use lash_core::{Subsystem, Ticks};
    use lash_fmi::import::ImportedFmu;
    use lash_orchestrate::Execution;
    let out = packed_scenario("two-joint", Some("C"));
    let cache = out.join("cache");
    let reference = in_process_slider_acceleration(&lash_scenario::builtin::by_name("C").unwrap());
    for (mech_file, micro_file) in
        [("lash_mechanism.fmu", "lash_interface.fmu"), ("lash_mechanism-fmi2.fmu", "lash_interface-fmi2.fmu")]
    {
        let mut mechanism = ImportedFmu::open(&out.join(mech_file), &cache, "mechanism").unwrap();
        let mut interface = ImportedFmu::open(&out.join(micro_file), &cache, "interface").unwrap();
        let shape = |name: &str| interface.variables().iter().find(|v| v.name == name).unwrap().shape.clone();
        assert_eq!(shape("effective_mass"), vec![4, 4], "{micro_file}: two planar joints");
        assert_eq!(shape("friction_force"), vec![2], "{micro_file}: one friction force per joint");
        let stop = Ticks::from_seconds(0.036).unwrap();
        mechanism.setup(Ticks::ZERO, Some(stop)).unwrap();
        interface.setup(Ticks::ZERO, Some(stop)).unwrap();
        let imported = master_slider_acceleration(&mut mechanism, &mut interface, stop, Execution::Sequential);
        assert_eq!(imported.len(), reference.len());
        let differing = imported.iter().zip(&reference).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        assert_eq!(differing, 0, "{mech_file}: the imported FMUs of C must reproduce the in-process run bit for bit");
        assert!(reference.iter().any(|a| a.abs() > 1e3), "C's impacts reach the slider");
    }
    // An archive whose scenario was edited into something the binary cannot build is refused at
    // instantiation with the resource named.
    let archive = std::fs::read(out.join("lash_interface.fmu")).unwrap();
    let mut original = zip::ZipArchive::new(std::io::Cursor::new(archive)).unwrap();
    let bad = out.join("edited.fmu");
    let mut edited = zip::ZipWriter::new(std::fs::File::create(&bad).unwrap());
    for i in 0..original.len() {
        let mut entry = original.by_index(i).unwrap();
        let name = entry.name().to_string();
        edited.start_file(name.as_str(), zip::write::SimpleFileOptions::default()).unwrap();
        if name == "resources/scenario.toml" {
            std::io::Write::write_all(&mut edited, b"name = \"edited\"\n").unwrap();
        } else {
            std::io::copy(&mut entry, &mut edited).unwrap();
        }
    }
    edited.finish().unwrap();
    let e = ImportedFmu::open(&bad, &cache, "edited").err().map(|e| e.to_string());
    assert!(e.as_deref().is_some_and(|e| e.contains("scenario.toml")), "{e:?}");
    let _ = std::fs::remove_dir_all(&out);
}

/// The FMUs of scenario G-driven (a translational clearance joint): the interface FMU's
/// coordinates are the block's tilt and offset, with a normal force per corner, and lash's master
/// through the imported mechanism and interface FMUs reproduces the in-process reduced run's
/// lateral slider acceleration bit for bit.
#[test]
fn fmus_packed_for_a_guide_reproduce_its_in_process_run() {
    use lash_core::{Subsystem, Ticks};
    use lash_fmi::import::ImportedFmu;
    use lash_orchestrate::Execution;
    let out = packed_scenario("guide", Some("G-driven"));
    let cache = out.join("cache");
    let mut g = lash_scenario::builtin::by_name("G-driven").unwrap();
    g.simulation.horizon = 0.036;
    g.simulation.output_interval = 1e-5;
    let reference = in_process_channel(&g, "slider.ay");
    let mut mechanism = ImportedFmu::open(&out.join("lash_mechanism.fmu"), &cache, "mechanism").unwrap();
    let mut interface = ImportedFmu::open(&out.join("lash_interface.fmu"), &cache, "interface").unwrap();
    let shape = |name: &str| interface.variables().iter().find(|v| v.name == name).unwrap().shape.clone();
    assert_eq!(shape("effective_mass"), vec![2, 2], "tilt and offset");
    assert_eq!(shape("contact_normal_force"), vec![4], "one normal force per corner");
    let stop = Ticks::from_seconds(0.036).unwrap();
    mechanism.setup(Ticks::ZERO, Some(stop)).unwrap();
    interface.setup(Ticks::ZERO, Some(stop)).unwrap();
    let imported = master_slider_acceleration_along(&mut mechanism, &mut interface, stop, Execution::Sequential, 1);
    assert_eq!(imported.len(), reference.len());
    let differing = imported.iter().zip(&reference).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
    assert_eq!(differing, 0, "the imported FMUs of G-driven must reproduce the in-process run bit for bit");
    assert!(reference.iter().any(|a| a.abs() > 1e3), "the corners' impacts reach the slider");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn lash_coupling_its_own_imported_fmus_equals_the_in_process_run() {
    use lash_core::{Subsystem, Ticks};
    use lash_fmi::import::ImportedFmu;
    use lash_orchestrate::Execution;
    let lib = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("liblash_interface.so");
    assert!(
        lib.exists(),
        "{} is missing: run the build step of the test command (`cargo build --profile ci --workspace`) first",
        lib.display()
    );
    let out = packed("import");
    let cache = out.join("cache");

    // In process: scenario A's reduced model, slider acceleration every micro step.
    let reference = in_process_slider_acceleration(&lash_scenario::builtin::by_name("A").unwrap());

    let versions =
        [("lash_mechanism.fmu", "lash_interface.fmu"), ("lash_mechanism-fmi2.fmu", "lash_interface-fmi2.fmu")];
    for ((mech_file, micro_file), execution) in
        versions.iter().flat_map(|v| [Execution::Sequential, Execution::Threaded].map(|e| (*v, e)))
    {
        let mut mechanism = ImportedFmu::open(&out.join(mech_file), &cache, "mechanism").unwrap();
        let mut interface = ImportedFmu::open(&out.join(micro_file), &cache, "interface").unwrap();
        eprintln!("importing {mech_file} + {micro_file} (FMI {}), {execution:?}", mechanism.fmi_version());
        let stop = Ticks::from_seconds(0.036).unwrap();
        mechanism.setup(Ticks::ZERO, Some(stop)).unwrap();
        interface.setup(Ticks::ZERO, Some(stop)).unwrap();
        let imported = master_slider_acceleration(&mut mechanism, &mut interface, stop, execution);
        assert_eq!(imported.len(), reference.len());
        let same = imported.iter().zip(&reference).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{mech_file}, {execution:?}: the imported FMUs must reproduce the in-process run bit for bit");
    }

    // `lash fmu check` accepts both, and refuses a broken archive with exit code 2.
    for name in [
        "lash_mechanism.fmu",
        "lash_interface.fmu",
        "lash_mechanism-fmi2.fmu",
        "lash_interface-fmi2.fmu",
        "lash_full.fmu",
        "lash_full-fmi2.fmu",
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "check"]).arg(out.join(name)).output().unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success() && text.contains(": OK"), "{name}: {text}{}", String::from_utf8_lossy(&o.stderr));
    }
    // Broken FMUs are clear errors.
    let not_zip = out.join("broken.fmu");
    std::fs::write(&not_zip, "not a zip").unwrap();
    let e = ImportedFmu::open(&not_zip, &cache, "x").err().expect("refused").to_string();
    assert!(e.contains("broken.fmu") && e.contains("not a zip archive"), "{e}");
    let o = Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "check"]).arg(&not_zip).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a zip archive"));
    let e = lash_fmi::import::parse_description("<fmiModelDescription><CoSimulation/>").unwrap_err().to_string();
    assert!(e.contains("fmiVersion"), "{e}");
    let _ = std::fs::remove_dir_all(&out);
}

/// Slider acceleration at every micro step of lash's master coupling two set-up subsystems
/// (scenario A's settings: h_m = 1e-3 s, h_r = 1e-5 s, linear, one-way).
fn master_slider_acceleration(
    mechanism: &mut dyn lash_core::Subsystem,
    interface: &mut dyn lash_core::Subsystem,
    stop: lash_core::Ticks,
    execution: lash_orchestrate::Execution,
) -> Vec<f64> {
    master_slider_acceleration_along(mechanism, interface, stop, execution, 0)
}

/// The slider's acceleration along x (`axis` 0) or y (1) at every micro step of lash's master
/// coupling `mechanism` and `interface` one-way (three loads per propagated value: one joint's
/// two interface forces and its friction load).
fn master_slider_acceleration_along(
    mechanism: &mut dyn lash_core::Subsystem,
    interface: &mut dyn lash_core::Subsystem,
    stop: lash_core::Ticks,
    execution: lash_orchestrate::Execution,
    axis: usize,
) -> Vec<f64> {
    use lash_core::Ticks;
    use lash_orchestrate::{InterfaceMaster, Observer, Signal};
    let options = common::one_way_options(stop, execution);
    let signals = vec![Signal::Propagated {
        name: "slider.a".into(),
        free: ("slider.acceleration_free".into(), axis),
        gain: ("slider.acceleration_gain".into(), 3 * axis),
    }];
    let mut master = InterfaceMaster::new(mechanism, interface, options, signals).unwrap();
    let mut values = Vec::new();
    let mut observer = |_t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
        values.push(v[0]);
        Ok(())
    };
    let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut observer, options.micro_step)];
    master.run(&mut observers).unwrap();
    values
}

/// Slider acceleration at every micro step of scenario A's reduced model run in process.
fn in_process_slider_acceleration(a: &lash_scenario::Scenario) -> Vec<f64> {
    in_process_channel(a, "slider.ax")
}

/// Channel `channel` at every micro step of a scenario's reduced model run in process.
fn in_process_channel(a: &lash_scenario::Scenario, channel: &str) -> Vec<f64> {
    let mut a = a.clone();
    a.output.channels = vec![channel.into()];
    let mut values = Vec::new();
    lash_run::ReducedRun::new(&a, lash_run::ReducedOptions::default())
        .unwrap()
        .execute(
            &mut |row| {
                values.push(row[1]);
                Ok(())
            },
            &mut |_| {},
        )
        .unwrap();
    values
}

#[test]
fn link_data_set_as_fmu_parameters_equals_the_edited_scenario() {
    use lash_core::{Subsystem, Ticks};
    use lash_fmi::import::ImportedFmu;
    use lash_orchestrate::Execution;
    let out = packed("links");
    let cache = out.join("cache");
    // The edited scenario: a longer rod (120 → 140 mm), a heavier slider, a faster crank.
    let mut edited = lash_scenario::builtin::by_name("A").unwrap();
    edited.joints[1].point2 = [-0.07, 0.0];
    edited.joints[2].point2 = [0.07, 0.0];
    edited.bodies[2].mass = 0.08;
    if let lash_mech::Motion::ConstantSpeed { omega, .. } = &mut edited.drivers[0].motion {
        *omega = 450.0;
    }
    let reference = in_process_slider_acceleration(&edited);
    let original = in_process_slider_acceleration(&lash_scenario::builtin::by_name("A").unwrap());
    assert_ne!(reference, original, "the edits must change the response, or this check proves nothing");

    for (mech_file, micro_file) in
        [("lash_mechanism.fmu", "lash_interface.fmu"), ("lash_mechanism-fmi2.fmu", "lash_interface-fmi2.fmu")]
    {
        let mut mechanism = ImportedFmu::open(&out.join(mech_file), &cache, "mechanism").unwrap();
        let mut interface = ImportedFmu::open(&out.join(micro_file), &cache, "interface").unwrap();
        let stop = Ticks::from_seconds(0.036).unwrap();
        mechanism.setup(Ticks::ZERO, Some(stop)).unwrap();
        interface.setup(Ticks::ZERO, Some(stop)).unwrap();
        let vr = |name: &str| {
            mechanism.variables().iter().find(|v| v.name == name).unwrap_or_else(|| panic!("{name}")).value_reference
        };
        let refs = [vr("crank_rod.point2"), vr("rod_slider.point2"), vr("slider.mass"), vr("motor.motion.omega")];
        mechanism.set_f64(&refs, &[-0.07, 0.0, 0.07, 0.0, 0.08, 450.0]).unwrap();
        let mut back = [0.0; 6];
        mechanism.get_f64(&refs, &mut back).unwrap();
        assert_eq!(back, [-0.07, 0.0, 0.07, 0.0, 0.08, 450.0]);
        let imported = master_slider_acceleration(&mut mechanism, &mut interface, stop, Execution::Sequential);
        assert_eq!(imported.len(), reference.len());
        let same = imported.iter().zip(&reference).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{mech_file}: link data set as parameters must reproduce the edited scenario bit for bit");
        // After initialization the parameters are fixed.
        let e = mechanism.set_f64(&[refs[2]], &[0.1]).unwrap_err().to_string();
        assert!(e.contains("slider.mass") || e.contains("parameter"), "{e}");
    }
    // A parameter value that makes the scenario invalid is refused at initialization, naming it.
    let mut mechanism = ImportedFmu::open(&out.join("lash_mechanism.fmu"), &cache, "bad").unwrap();
    mechanism.setup(Ticks::ZERO, None).unwrap();
    let r = mechanism.variables().iter().find(|v| v.name == "rod.mass").unwrap().value_reference;
    mechanism.set_f64(&[r], &[-1.0]).unwrap();
    let e = mechanism.initialize().unwrap_err().to_string();
    assert!(e.contains("rod.mass") && e.contains("bodies[1].mass"), "{e}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn fmpy_simulates_the_full_model_fmu_like_lash_run() {
    let python = fmpy_python();
    let out = packed("full");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmi/full_fmu.py");
    let lash_run = |scenario: &str, dir: &Path| {
        let o = Command::new(env!("CARGO_BIN_EXE_lash")).args(["run", scenario, "--quiet", "--out"]).arg(dir).output();
        let o = o.unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir.join("timeseries.csv")
    };
    let plain = lash_run("A", &out.join("run-A"));
    // The same scenario with a heavier rod and a less elastic contact, as a file and as parameters.
    let shown = Command::new(env!("CARGO_BIN_EXE_lash")).args(["show", "A"]).output().unwrap();
    let text = String::from_utf8(shown.stdout).unwrap();
    assert_eq!((text.matches("mass = 0.15\n").count(), text.matches("restitution = 0.9\n").count()), (1, 1));
    let edited_file = out.join("A-edited.toml");
    std::fs::write(
        &edited_file,
        text.replace("mass = 0.15\n", "mass = 0.2\n").replace("restitution = 0.9\n", "restitution = 0.6\n"),
    )
    .unwrap();
    let edited = lash_run(edited_file.to_str().unwrap(), &out.join("run-edited"));
    for fmu in ["lash_full.fmu", "lash_full-fmi2.fmu"] {
        let fmu = out.join(fmu);
        for (reference, parameters) in
            [(&plain, None), (&edited, Some("rod.mass=0.2,crank_pivot.contact.restitution=0.6"))]
        {
            let mut cmd = Command::new(&python);
            cmd.arg(&script).arg(&fmu).arg(reference);
            cmd.args(parameters);
            let o = cmd.output().unwrap();
            let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
            eprintln!("{} {parameters:?}: {text}", fmu.display());
            assert!(o.status.success() && text.contains("OK"), "{text}");
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn broken_fmus_are_clear_errors_naming_the_fmu_and_the_cause() {
    use lash_fmi::import::ImportedFmu;
    let out = std::env::temp_dir().join(format!("lash-fmi-broken-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let good = out.join("vanderpol.fmu");
    let build = root.join("tests/fmi/build_c_fmu.py");
    let o = Command::new("python3").arg(&build).arg(root.join("tests/fmi/vanderpol")).arg(&good).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let empty_c = out.join("empty.c");
    std::fs::write(&empty_c, "int not_an_fmu(void) { return 0; }\n").unwrap();
    let empty_so = out.join("empty.so");
    let o = Command::new("cc").args(["-shared", "-fPIC", "-o"]).arg(&empty_so).arg(&empty_c).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let xml = std::fs::read_to_string(root.join("tests/fmi/vanderpol/modelDescription.xml")).unwrap();
    // Each broken archive: (file name, [(entry, source file or literal text)], expected in the error).
    let so = |name: &str| {
        let unpacked = out.join("unpacked");
        let o = Command::new("python3")
            .args(["-c", "import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])"])
            .arg(&good)
            .arg(&unpacked)
            .output()
            .unwrap();
        assert!(o.status.success());
        unpacked.join("binaries/linux64").join(name)
    };
    let real_so = so("vanderpol.so");
    type Entries<'a> = Vec<(&'a str, Vec<u8>)>;
    let cases: Vec<(&str, Entries, Vec<&str>)> = vec![
        (
            "bad-xml.fmu",
            vec![("modelDescription.xml", b"<fmiModelDescription fmiVersion=\"2.0\"><CoSim".to_vec())],
            vec!["bad-xml.fmu", "modelDescription"],
        ),
        (
            "wrong-platform.fmu",
            vec![("modelDescription.xml", xml.clone().into_bytes()), ("binaries/win64/vanderpol.dll", b"MZ".to_vec())],
            vec!["wrong-platform.fmu", "no binary for linux64", "win64"],
        ),
        (
            "not-elf.fmu",
            vec![
                ("modelDescription.xml", xml.clone().into_bytes()),
                ("binaries/linux64/vanderpol.so", b"not an ELF file".to_vec()),
            ],
            vec!["not-elf.fmu", "vanderpol.so", "cannot load", "dlopen failed"],
        ),
        (
            "missing-symbol.fmu",
            vec![
                ("modelDescription.xml", xml.clone().into_bytes()),
                ("binaries/linux64/vanderpol.so", std::fs::read(&empty_so).unwrap()),
            ],
            vec!["missing-symbol.fmu", "missing symbol fmi2"],
        ),
        (
            "wrong-guid.fmu",
            vec![
                (
                    "modelDescription.xml",
                    xml.replace("{8c4e810f-3df3-4a00-8276-176fa3c9f000}", "{00000000-0000-0000-0000-000000000000}")
                        .into_bytes(),
                ),
                ("binaries/linux64/vanderpol.so", std::fs::read(&real_so).unwrap()),
            ],
            vec!["wrong-guid.fmu", "fmi2Instantiate failed"],
        ),
    ];
    for (name, entries, expected) in cases {
        let fmu = out.join(name);
        let dir = out.join(format!("{name}.d"));
        std::fs::create_dir_all(&dir).unwrap();
        let mut args = vec![fmu.to_str().unwrap().to_string()];
        for (entry, bytes) in &entries {
            let file = dir.join(entry.replace('/', "_"));
            std::fs::write(&file, bytes).unwrap();
            args.push(entry.to_string());
            args.push(file.to_str().unwrap().to_string());
        }
        let zip = "import sys, zipfile\nz = zipfile.ZipFile(sys.argv[1], 'w')\nfor a, f in zip(sys.argv[2::2], sys.argv[3::2]): z.write(f, a)\nz.close()";
        let o = Command::new("python3").args(["-c", zip]).args(&args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let e = ImportedFmu::open(&fmu, &out.join("cache"), "broken").err().expect("refused").to_string();
        for x in &expected {
            assert!(e.contains(x), "{name}: expected {x:?} in {e:?}");
        }
        let o = Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "check"]).arg(&fmu).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        eprintln!("{name}: {e}");
    }
    // The intact FMU passes the same checks.
    let o = Command::new(env!("CARGO_BIN_EXE_lash")).args(["fmu", "check"]).arg(&good).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_full_model_fmu_rolls_back_through_get_and_set_fmu_state() {
    use lash_core::{Causality, Subsystem, Ticks};
    use lash_fmi::import::ImportedFmu;
    let out = packed("rollback");
    for name in ["lash_full.fmu", "lash_full-fmi2.fmu"] {
        let mut fmu = ImportedFmu::open(&out.join(name), &out.join("cache"), "full").unwrap();
        let outputs: Vec<u32> =
            fmu.variables().iter().filter(|v| v.causality == Causality::Output).map(|v| v.value_reference).collect();
        let h = Ticks::from_seconds(1e-4).unwrap();
        fmu.setup(Ticks::ZERO, None).unwrap();
        fmu.initialize().unwrap();
        let mut t = Ticks::ZERO;
        // Up to just before the first impacts, save, run across them, go back and run again.
        for _ in 0..100 {
            assert_eq!(fmu.do_step(t, h).unwrap(), lash_core::StepOutcome::Completed);
            t = Ticks(t.0 + h.0);
        }
        let saved = fmu.save_state().unwrap();
        let saved_at = t;
        let run = |fmu: &mut ImportedFmu, mut t: Ticks| {
            let mut trace = Vec::new();
            let mut values = vec![0.0; outputs.len()];
            for _ in 0..150 {
                assert_eq!(fmu.do_step(t, h).unwrap(), lash_core::StepOutcome::Completed);
                t = Ticks(t.0 + h.0);
                fmu.get_f64(&outputs, &mut values).unwrap();
                trace.extend_from_slice(&values);
            }
            trace
        };
        let first = run(&mut fmu, saved_at);
        fmu.restore_state(&saved).unwrap();
        assert_eq!(fmu.time(), saved_at);
        let again = run(&mut fmu, saved_at);
        assert!(first.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: replay differs");
        let force = outputs.iter().position(|&r| fmu.variables()[r as usize].name == "crank_pivot.force").unwrap();
        let peak = first.iter().skip(force).step_by(outputs.len()).fold(0.0f64, |a, v| a.max(*v));
        assert!(peak > 0.0, "{name}: the replayed window must contain an impact");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// The FMUs of the spatial scenario E (two spherical clearance joints: a 6 × 6 M̃, 12 friction
/// loads; the same three generic binaries, E in the archives' resources): fmpy validates all six
/// archives; a Python master through the mechanism and interface FMUs reproduces
/// `lash run E --model reduced` bit for bit in FMI 3.0 and 2.0; fmpy simulates the full-model FMU
/// like `lash run E`, as packed and with the rod's mass set as a parameter (against the edited
/// file), within the bound tests/fmi/full_fmu.py argues for E's chattering contacts.
#[test]
fn the_spatial_scenario_e_exports_fmus_that_reproduce_its_runs() {
    let python = fmpy_python();
    let out = packed_scenario("spatial", Some("E"));
    let run = |args: &[&str]| {
        let o = Command::new(&python).args(args).output().unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert!(o.status.success(), "{args:?}: {text}");
        text
    };
    for name in [
        "lash_mechanism.fmu",
        "lash_interface.fmu",
        "lash_full.fmu",
        "lash_mechanism-fmi2.fmu",
        "lash_interface-fmi2.fmu",
        "lash_full-fmi2.fmu",
    ] {
        let validate = run(&["-m", "fmpy.cli", "validate", out.join(name).to_str().unwrap()]);
        assert!(validate.contains("No problems found"), "E {name}: {validate}");
    }
    let lash_run = |scenario: &str, model: &str, dir: &Path| {
        let o = Command::new(env!("CARGO_BIN_EXE_lash"))
            .args(["run", scenario, "--model", model, "--horizon", "0.036", "--quiet", "--out"])
            .arg(dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir.join("timeseries.csv")
    };
    let reduced = lash_run("E", "reduced", &out.join("E-reduced"));
    let cosim = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmi/reduced_cosim.py");
    for (mech, micro) in
        [("lash_mechanism.fmu", "lash_interface.fmu"), ("lash_mechanism-fmi2.fmu", "lash_interface-fmi2.fmu")]
    {
        let text = run(&[
            cosim.to_str().unwrap(),
            out.join(mech).to_str().unwrap(),
            out.join(micro).to_str().unwrap(),
            reduced.to_str().unwrap(),
        ]);
        eprintln!("E: {text}");
        assert!(text.contains("bit-identical: True"), "E: {text}");
    }
    let shown = Command::new(env!("CARGO_BIN_EXE_lash")).args(["show", "E"]).output().unwrap();
    let text = String::from_utf8(shown.stdout).unwrap();
    assert_eq!(text.matches("mass = 0.25\n").count(), 1, "the rod's mass, once");
    let edited_file = out.join("E-edited.toml");
    std::fs::write(&edited_file, text.replace("mass = 0.25\n", "mass = 0.35\n")).unwrap();
    let plain = lash_run("E", "full", &out.join("E-full"));
    let edited = lash_run(edited_file.to_str().unwrap(), "full", &out.join("E-edited"));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmi/full_fmu.py");
    for fmu in ["lash_full.fmu", "lash_full-fmi2.fmu"] {
        for (reference, parameters) in [(&plain, None), (&edited, Some("rod.mass=0.35"))] {
            let fmu = out.join(fmu);
            let mut args = vec![script.to_str().unwrap(), fmu.to_str().unwrap(), reference.to_str().unwrap()];
            args.extend(parameters);
            args.extend(["--bound", "2e-3"]);
            let text = run(&args);
            eprintln!("E {} {parameters:?}: {text}", fmu.display());
            assert!(text.contains("OK"), "{text}");
        }
    }
    // The edit matters: the edited run is not the plain one.
    assert_ne!(std::fs::read(&plain).unwrap(), std::fs::read(&edited).unwrap());
    let _ = std::fs::remove_dir_all(&out);
}
