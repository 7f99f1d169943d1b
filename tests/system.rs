//! System files end to end: third-party FMUs (a C FMU written without lash, and a PythonFMU-built
//! FMU from PyPI's pythonfmu) run by `lash run system.toml` reproduce fmpy's results for them bit
//! for bit; a user plugin (examples/accelerometer-plugin) connected to an FMU output matches an
//! independent discretisation; the same system as an SSP `.ssd` + `.ssv` gives the same result;
//! bad system files are clear errors. fmpy and pythonfmu are installed from PyPI into
//! target/fmpy-venv on first use.

use std::path::Path;
use std::process::Command;

mod common;
use common::fmpy_python;

fn lash(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().unwrap()
}

/// (header, rows) of a CSV of numbers; header names without units or quotes.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    // RFC 4180 header: a quoted name may hold commas (`"o.m[1,2] [kg]"`).
    let mut header = Vec::new();
    let (mut field, mut quoted) = (String::new(), false);
    for c in lines.next().unwrap().chars().chain([',']) {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => header.push(std::mem::take(&mut field).split(" [").next().unwrap().to_string()),
            c => field.push(c),
        }
    }
    let rows = lines.map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect()).collect();
    (header, rows)
}

fn column(csv: &(Vec<String>, Vec<Vec<f64>>), name: &str) -> Vec<f64> {
    let k = csv.0.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {:?}", csv.0));
    csv.1.iter().map(|r| r[k]).collect()
}

/// The accelerometer driven by `input` held over steps of `h`, by exact zero-order-hold
/// discretisation through the exponential of the augmented matrix [[A, B], [0, 0]] (Taylor series
/// with scaling and squaring) — a formulation independent of the plugin's closed form.
fn sensor_reference(input: &[f64], h: f64, fn_hz: f64, zeta: f64) -> Vec<f64> {
    let wn = 2.0 * std::f64::consts::PI * fn_hz;
    let m = [[0.0, 1.0, 0.0], [-wn * wn, -2.0 * zeta * wn, wn * wn], [0.0, 0.0, 0.0]];
    let mul = |a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]| {
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        c
    };
    let squarings = 12;
    let scale = h / f64::from(1 << squarings);
    let x = m.map(|r| r.map(|v| v * scale));
    let mut e = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut term = e;
    for n in 1..20 {
        term = mul(&term, &x).map(|r| r.map(|v| v / n as f64));
        for i in 0..3 {
            for j in 0..3 {
                e[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..squarings {
        e = mul(&e, &e);
    }
    let mut state = [input[0], 0.0];
    let mut out = vec![state[0]];
    for &u in &input[1..] {
        state = [
            e[0][0] * state[0] + e[0][1] * state[1] + e[0][2] * u,
            e[1][0] * state[0] + e[1][1] * state[1] + e[1][2] * u,
        ];
        out.push(state[0]);
    }
    out
}

#[test]
fn third_party_fmus_and_a_plugin_in_a_system_file() {
    let plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("libaccelerometer.so");
    assert!(
        plugin.exists(),
        "{} is missing: run the build step of the test command (`cargo build --profile ci --workspace`) first",
        plugin.display()
    );
    let python = fmpy_python();
    let out = std::env::temp_dir().join(format!("lash-system-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run_py = |args: &[&str]| {
        let o = Command::new(&python).args(args).current_dir(&out).output().unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    };
    // The third-party FMUs: a C FMU built here with cc, and one built by pythonfmu.
    let build = root.join("tests/fmi/build_c_fmu.py");
    run_py(&[build.to_str().unwrap(), root.join("tests/fmi/vanderpol").to_str().unwrap(), "vanderpol.fmu"]);
    run_py(&[
        "-m",
        "pythonfmu",
        "build",
        "-f",
        root.join("tests/fmi/pythonfmu/vanderpol_py.py").to_str().unwrap(),
        "-d",
        ".",
    ]);
    for fmu in ["vanderpol.fmu", "vanderpol_py.fmu"] {
        for (interval, csv) in [("0.01", "10ms"), ("0.02", "20ms")] {
            let out_csv = format!("fmpy-{fmu}-{csv}.csv");
            run_py(&[
                "-m",
                "fmpy.cli",
                "simulate",
                fmu,
                "--stop-time",
                "2",
                "--output-interval",
                interval,
                "--start-values",
                "mu",
                "1.5",
                "--output-file",
                &out_csv,
            ]);
        }
    }
    let system = format!(
        r#"name = "vdp"
stop = 2.0
step = 0.01
algorithm = "ALGORITHM"
[[elements]]
name = "c"
fmu = "vanderpol.fmu"
parameters = {{ mu = 1.5 }}
[[elements]]
name = "py"
fmu = "vanderpol_py.fmu"
parameters = {{ mu = 1.5 }}
[[elements]]
name = "slow"
fmu = "vanderpol.fmu"
decimation = 2
parameters = {{ mu = 1.5 }}
[[elements]]
name = "sensor"
plugin = "{}"
parameters = {{ natural_frequency = 20.0, damping_ratio = 0.3, sensitivity = 1.0, bias = 0.0 }}
[[connections]]
from = "c.x0"
to = "sensor.acceleration"
"#,
        plugin.display()
    );
    for algorithm in ["gauss_seidel", "jacobi"] {
        let file = out.join(format!("vdp-{algorithm}.toml"));
        std::fs::write(&file, system.replace("ALGORITHM", algorithm)).unwrap();
        let dir = out.join(algorithm);
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let lash_csv = read_csv(&dir.join("timeseries.csv"));
        assert_eq!(lash_csv.1.len(), 201);
        // Each FMU run by lash equals fmpy's run of it, bit for bit (same steps, same calls).
        for (element, fmu) in [("c", "vanderpol.fmu"), ("py", "vanderpol_py.fmu")] {
            let fmpy = read_fmpy_csv(&out.join(format!("fmpy-{fmu}-10ms.csv")));
            for v in ["x0", "x1"] {
                let (a, b) = (column(&lash_csv, &format!("{element}.{v}")), column(&fmpy, v));
                assert_eq!(a.len(), b.len());
                assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{element}.{v} differs from fmpy");
            }
        }
        // Decimation 2: the element steps by 0.02 s every other point, like fmpy at 0.02 s.
        let fmpy20 = read_fmpy_csv(&out.join("fmpy-vanderpol.fmu-20ms.csv"));
        let slow = column(&lash_csv, "slow.x0");
        let even: Vec<f64> = slow.iter().step_by(2).copied().collect();
        assert_eq!(even, column(&fmpy20, "x0"));
        // The plugin: Gauss-Seidel gives the sensor x0 at the end of each step, Jacobi at its start.
        let x0 = column(&lash_csv, "c.x0");
        let input: Vec<f64> = if algorithm == "jacobi" {
            std::iter::once(x0[0]).chain(x0[..x0.len() - 1].iter().copied()).collect()
        } else {
            x0.clone()
        };
        let expected = sensor_reference(&input, 0.01, 20.0, 0.3);
        let measured = column(&lash_csv, "sensor.measured");
        let worst = measured.iter().zip(&expected).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        eprintln!("{algorithm}: sensor vs reference {worst:.2e}");
        assert!(worst < 1e-10, "{algorithm}: plugin sensor differs from the reference by {worst}");
    }

    // The same coupling as an SSP system structure with its parameter values in an .ssv file.
    std::fs::write(
        out.join("vdp.ssd"),
        format!(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="vdp-ssp">
  <ssd:System name="root">
    <ssd:Elements>
      <ssd:Component name="c" source="vanderpol.fmu" type="application/x-fmu-sharedlibrary">
        <ssd:ParameterBindings><ssd:ParameterBinding source="c.ssv"/></ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="sensor" source="{}">
        <ssd:ParameterBindings><ssd:ParameterBinding>
          <ssd:ParameterValues><ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="s">
            <ssv:Parameters>
              <ssv:Parameter name="natural_frequency"><ssv:Real value="20"/></ssv:Parameter>
              <ssv:Parameter name="damping_ratio"><ssv:Real value="0.3"/></ssv:Parameter>
            </ssv:Parameters>
          </ssv:ParameterSet></ssd:ParameterValues>
        </ssd:ParameterBinding></ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="c" startConnector="x0" endElement="sensor" endConnector="acceleration"/>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="2">
    <ssd:Annotations><ssc:Annotation type="org.lash"><lash:Step xmlns:lash="https://lash.dev" value="0.01"/></ssc:Annotation></ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>
"#,
            plugin.display()
        ),
    )
    .unwrap();
    std::fs::write(
        out.join("c.ssv"),
        r#"<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="c">
  <ssv:Parameters><ssv:Parameter name="mu"><ssv:Real value="1.5"/></ssv:Parameter></ssv:Parameters>
</ssv:ParameterSet>
"#,
    )
    .unwrap();
    let dir = out.join("ssp");
    let o = lash(&["run", out.join("vdp.ssd").to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ssp = read_csv(&dir.join("timeseries.csv"));
    let toml = read_csv(&out.join("gauss_seidel").join("timeseries.csv"));
    for name in ["c.x0", "c.x1", "sensor.measured"] {
        assert_eq!(column(&ssp, name), column(&toml, name), "{name}: .ssd and TOML systems differ");
    }
    // And packed as an .ssp archive (SystemStructure.ssd at its root, the FMU and .ssv beside it).
    let zip = "import sys, zipfile\nz = zipfile.ZipFile(sys.argv[1], 'w')\nz.write('vdp.ssd', 'SystemStructure.ssd')\nz.write('c.ssv', 'c.ssv')\nz.write('vanderpol.fmu', 'vanderpol.fmu')\nz.close()";
    run_py(&["-c", zip, "vdp.ssp"]);
    let dir = out.join("ssp-archive");
    let o = lash(&["run", out.join("vdp.ssp").to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let archive = read_csv(&dir.join("timeseries.csv"));
    for name in ["c.x0", "c.x1", "sensor.measured"] {
        assert_eq!(column(&archive, name), column(&toml, name), "{name}: .ssp and TOML systems differ");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_system_files_are_clear_errors() {
    let out = std::env::temp_dir().join(format!("lash-system-bad-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("libaccelerometer.so");
    let not_plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("liblash_full.so");
    let base = |extra: &str| {
        format!(
            "name = \"bad\"\nstop = 0.01\nstep = 0.001\n[[elements]]\nname = \"sensor\"\nplugin = \"{}\"\n{extra}",
            plugin.display()
        )
    };
    let cases = [
        (
            base("[[connections]]\nfrom = \"nowhere.x\"\nto = \"sensor.acceleration\"\n"),
            "connections[0].from: no element \"nowhere\"",
        ),
        (
            base("[[connections]]\nfrom = \"sensor.measured\"\nto = \"sensor.bias\"\n"),
            "connections[0].to: sensor.bias is Parameter",
        ),
        (base("[[connections]]\nfrom = \"sensor.measured\"\nto = \"sensor.speed\"\n"), "has no variable \"speed\""),
        (base("[elements.parameters]\ngain = 2.0\n"), "elements[0].parameters.gain: no such parameter"),
        (base("[elements.parameters]\nnatural_frequency = [1.0, 2.0]\n"), "2 value(s) for 1 element(s)"),
        (base("").replace("step = 0.001", "step = 0.003"), "step: 0.003 s does not divide"),
        (base("").replace("libaccelerometer.so", "libmissing.so"), "no such file"),
        (base("").replace(plugin.to_str().unwrap(), not_plugin.to_str().unwrap()), "not a lash plugin"),
        (base("fmu = \"x.fmu\"\n"), "elements[0]: give exactly one of fmu, plugin, builtin"),
        (base("decimation = 0\n"), "elements[0].decimation: must be ≥ 1"),
    ];
    for (k, (text, expected)) in cases.iter().enumerate() {
        let file = out.join(format!("bad{k}.toml"));
        std::fs::write(&file, text).unwrap();
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join("o").to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "case {k}: {err}");
        assert!(err.contains(expected), "case {k}: expected {expected:?} in: {err}");
    }
    // A micro step whose rows the master could not hold is refused by `validate` and `run` alike,
    // before anything is allocated (1e-12 s once made `run` allocate 80 GB).
    let tiny = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/systems/reduced-A.toml"))
        .unwrap()
        .replace("micro_step = 1e-5", "micro_step = 1e-12");
    let file = out.join("tiny.toml");
    std::fs::write(&file, tiny).unwrap();
    for args in [
        vec!["validate", file.to_str().unwrap()],
        vec!["run", file.to_str().unwrap(), "--quiet", "--out", out.join("o").to_str().unwrap()],
    ] {
        let o = lash(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("interface.micro_step") && err.contains("1000000000 micro steps per macro step"),
            "{args:?}: {err}"
        );
    }
    // A parameter the plugin refuses at initialization is a user error (exit 2) naming the field;
    // no output is left behind.
    let file = out.join("refused.toml");
    std::fs::write(&file, base("[elements.parameters]\ndamping_ratio = 2.0\n")).unwrap();
    let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join("o").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("elements[0].parameters") && err.contains("damping_ratio"), "{err}");
    assert!(!out.join("o/timeseries.csv").exists() && !out.join("o/timeseries.csv.partial").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// examples/systems/full-model-accelerometer.toml copied into `out`, its plugin path (where a
/// user's `cargo build --release` puts the library) replaced by the test build's library.
fn accelerometer_example(out: &Path) -> std::path::PathBuf {
    let plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("libaccelerometer.so");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/systems/full-model-accelerometer.toml");
    std::fs::create_dir_all(out).unwrap();
    let text = std::fs::read_to_string(&example).unwrap();
    let users = "\"../../target/release/libaccelerometer.so\"";
    assert!(text.contains(users), "the example's plugin path changed");
    let file = out.join("full-model-accelerometer.toml");
    std::fs::write(&file, text.replace(users, &format!("{:?}", plugin.display().to_string()))).unwrap();
    file
}

#[test]
fn the_example_system_runs() {
    let plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("libaccelerometer.so");
    assert!(
        plugin.exists(),
        "{} is missing: run the build step of the test command (`cargo build --profile ci --workspace`) first",
        plugin.display()
    );
    let out = std::env::temp_dir().join(format!("lash-system-example-{}", std::process::id()));
    let file = accelerometer_example(&out);
    let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&out.join("timeseries.csv"));
    assert_eq!(csv.1.len(), 3601);
    assert_eq!(csv.0, ["time", "mechanism.slider.ax", "sensor.measured", "mechanism.crank_pivot.force"]);
    // The sensor (5 kHz, ζ = 0.7) follows the slider acceleration's slow part: over the run its
    // mean equals the input's to a small fraction of the input's range.
    let (ax, m) = (column(&csv, "mechanism.slider.ax"), column(&csv, "sensor.measured"));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let range = ax.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(m.iter().all(|v| v.is_finite()));
    assert!((mean(&ax) - mean(&m)).abs() < 0.02 * range, "{} vs {}", mean(&ax), mean(&m));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_reduced_model_as_a_system_equals_lash_run_reduced_with_builtins_and_with_fmus() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("lash-system-reduced-{}", std::process::id()));
    // (At the system's communication step, 1 ms: `lash run` alone would choose 0.5 ms at 5000 rpm.)
    let reference_a = out.join("reference");
    let args = ["run", "A", "--model", "reduced", "--macro-step", "1e-3", "--quiet", "--out"];
    let o = lash(&[&args[..], &[reference_a.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = read_csv(&out.join("reference/timeseries.csv"));
    let o = lash(&["fmu", "pack", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let example = std::fs::read_to_string(root.join("examples/systems/reduced-A.toml")).unwrap();
    let variants = [
        ("builtins", example.clone()),
        (
            "fmi3",
            example
                .replace("builtin = \"lash_mechanism\"", "fmu = \"lash_mechanism.fmu\"")
                .replace("builtin = \"lash_interface\"", "fmu = \"lash_interface.fmu\""),
        ),
        (
            "fmi2",
            example
                .replace("builtin = \"lash_mechanism\"", "fmu = \"lash_mechanism-fmi2.fmu\"")
                .replace("builtin = \"lash_interface\"", "fmu = \"lash_interface-fmi2.fmu\""),
        ),
    ];
    for (tag, text) in variants {
        assert_ne!(text.contains("\nfmu ="), tag == "builtins");
        let file = out.join(format!("reduced-{tag}.toml"));
        std::fs::write(&file, text).unwrap();
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join(tag).to_str().unwrap()]);
        assert!(o.status.success(), "{tag}: {}", String::from_utf8_lossy(&o.stderr));
        let csv = read_csv(&out.join(tag).join("timeseries.csv"));
        assert_eq!(csv.1.len(), 3601);
        for name in ["slider.ax", "motor.torque", "crank_pivot.fx"] {
            let (a, b) = (column(&csv, name), column(&reference, name));
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{tag}: {name} differs from lash run");
        }
    }
    // The same system over scenario C's built-ins (`scenario = "C"`: two clearance joints, 4 × 4
    // M̃, the joints' parameters prefixed with their names) equals `lash run C --model reduced`.
    // (At the system's micro step, 1e-5 s: `lash run` would choose 5e-6 s for C's impacts.)
    let reference_c = out.join("reference-C");
    let o = lash(&[
        "run",
        "C",
        "--model",
        "reduced",
        "--macro-step",
        "1e-3",
        "--micro-step",
        "1e-5",
        "--quiet",
        "--out",
        reference_c.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = read_csv(&out.join("reference-C/timeseries.csv"));
    let text = example
        .replace("builtin = \"lash_mechanism\"", "builtin = \"lash_mechanism\"\nscenario = \"C\"")
        .replace("builtin = \"lash_interface\"", "builtin = \"lash_interface\"\nscenario = \"C\"")
        .replace("\"contact.restitution\" = 0.9", "\"rod_slider.contact.restitution\" = 0.9");
    let file = out.join("reduced-C.toml");
    std::fs::write(&file, &text).unwrap();
    let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join("C").to_str().unwrap()]);
    assert!(o.status.success(), "C: {}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&out.join("C/timeseries.csv"));
    for name in ["slider.ax", "motor.torque", "crank_pivot.fx"] {
        let (a, b) = (column(&csv, name), column(&reference, name));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "C: {name} differs from lash run C");
    }
    // A scenario on an FMU element is refused (the FMU carries its own).
    std::fs::write(&file, text.replacen("builtin = \"lash_mechanism\"", "fmu = \"lash_mechanism.fmu\"", 1)).unwrap();
    let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join("C-bad").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("only a built-in element takes a scenario"));
    // lash's own full-model FMU in an SSP system structure, its clearance parameter bound from an
    // .ssv file, driving the plugin: the same as the TOML example with the built-in full model.
    let plugin = Path::new(env!("CARGO_BIN_EXE_lash")).with_file_name("libaccelerometer.so");
    std::fs::write(
        out.join("full.ssv"),
        r#"<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="m">
  <ssv:Parameters><ssv:Parameter name="crank_pivot.contact.restitution"><ssv:Real value="0.8"/></ssv:Parameter></ssv:Parameters>
</ssv:ParameterSet>"#,
    )
    .unwrap();
    std::fs::write(
        out.join("full.ssd"),
        format!(
            r#"<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="full-ssp">
  <ssd:System name="root">
    <ssd:Elements>
      <ssd:Component name="mechanism" source="lash_full.fmu">
        <ssd:ParameterBindings><ssd:ParameterBinding source="full.ssv"/></ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="sensor" source="{}">
        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" name="s"><ssv:Parameters>
          <ssv:Parameter name="natural_frequency"><ssv:Real value="5000"/></ssv:Parameter>
          <ssv:Parameter name="damping_ratio"><ssv:Real value="0.7"/></ssv:Parameter>
        </ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="mechanism" startConnector="slider.ax" endElement="sensor" endConnector="acceleration"/>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="0.036">
    <ssd:Annotations><ssc:Annotation type="org.lash"><lash:Step xmlns:lash="https://lash.dev" value="1e-5"/></ssc:Annotation></ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>"#,
            plugin.display()
        ),
    )
    .unwrap();
    let o = lash(&[
        "run",
        out.join("full.ssd").to_str().unwrap(),
        "--quiet",
        "--out",
        out.join("full-ssp").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let accelerometer = accelerometer_example(&out);
    let o =
        lash(&["run", accelerometer.to_str().unwrap(), "--quiet", "--out", out.join("full-toml").to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ssp, toml) = (read_csv(&out.join("full-ssp/timeseries.csv")), read_csv(&out.join("full-toml/timeseries.csv")));
    for name in ["mechanism.slider.ax", "sensor.measured", "mechanism.crank_pivot.force"] {
        let (a, b) = (column(&ssp, name), column(&toml, name));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{name}: FMU in .ssd vs built-in in TOML");
    }
    // Misused interface masters are clear errors.
    let extra = example.clone() + "\n[[connections]]\nfrom = \"joint.contact_force\"\nto = \"mechanism.x\"\n";
    let no_signal = example.replace("propagated = \"motor.torque\"", "propagated = \"motor.speed\"");
    for (text, expected) in
        [(extra, "connections: the interface master"), (no_signal, "no variable \"motor.speed_free\"")]
    {
        let file = out.join("bad.toml");
        std::fs::write(&file, text).unwrap();
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", out.join("bad").to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.code() == Some(2) && err.contains(expected), "{expected}: {err}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A scratch folder holding the test FMUs built from C (`oscillator.fmu`, FMI 3.0;
/// `vanderpol.fmu`, FMI 2.0), and fmpy's Python to run there.
struct FmuScratch {
    out: std::path::PathBuf,
    python: std::path::PathBuf,
}

impl FmuScratch {
    fn new(tag: &str) -> Self {
        let out = std::env::temp_dir().join(format!("lash-system-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).unwrap();
        let scratch = Self { out, python: fmpy_python() };
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let build = root.join("tests/fmi/build_c_fmu.py");
        for (folder, fmu) in [("tests/fmi/oscillator", "oscillator.fmu"), ("tests/fmi/vanderpol", "vanderpol.fmu")] {
            scratch.py(&[build.to_str().unwrap(), root.join(folder).to_str().unwrap(), fmu]);
        }
        scratch
    }

    /// Runs fmpy's Python in the folder; it must succeed.
    fn py(&self, args: &[&str]) {
        let o = Command::new(&self.python).args(args).current_dir(&self.out).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }
}

/// Value references are looked up through one mapping: an FMI 3.0 FMU whose references are
/// sparse, out of order and aliased records the variables asked for (fmpy's values, bit for bit),
/// parameters included. FMUs that ask to stop (FMI 3.0 terminateSimulation, FMI 2.0 fmi2Discard
/// with fmi2Terminated) end the run cleanly with fmpy's rows; one that returns early is an error
/// that keeps the rows so far; a refused parameter value is a user error (exit 2).
#[test]
fn sparse_value_references_stop_requests_and_early_returns() {
    let scratch = FmuScratch::new("stop");
    let (out, run_py) = (&scratch.out, |args: &[&str]| scratch.py(args));
    let fmpy = |fmu: &str, csv: &str, start: &[&str]| {
        let mut args = vec!["-m", "fmpy.cli", "simulate", fmu, "--stop-time", "0.5", "--output-interval", "0.01"];
        args.extend(["--output-file", csv, "--start-values"]);
        args.extend(start);
        run_py(&args);
        read_fmpy_csv(&out.join(csv))
    };
    let system = |name: &str, element: &str, fmu: &str, parameters: &str, channels: &str| {
        let file = out.join(format!("{name}.toml"));
        let text = format!(
            "name = \"{name}\"\nstop = 0.5\nstep = 0.01\n[[elements]]\nname = \"{element}\"\nfmu = \"{fmu}\"\nparameters = {{ {parameters} }}\n[output]\nchannels = [{channels}]\n"
        );
        std::fs::write(&file, text).unwrap();
        let dir = out.join(name);
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]);
        (o, dir)
    };
    let bits = |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());

    // Sparse (1003, 17, 2, 5), unordered and aliased (x = position) references.
    let reference = fmpy("oscillator.fmu", "fmpy-osc.csv", &["k", "9"]);
    let (o, dir) =
        system("sparse", "o", "oscillator.fmu", "k = 9.0", r#""o.x", "o.v", "o.energy", "o.position", "o.k""#);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&dir.join("timeseries.csv"));
    assert_eq!(csv.0, ["time", "o.x", "o.v", "o.energy", "o.position", "o.k"]);
    assert_eq!(csv.1.len(), 51);
    for v in ["x", "v", "energy", "position"] {
        assert!(bits(&column(&csv, &format!("o.{v}")), &column(&reference, v)), "o.{v} differs from fmpy");
    }
    assert!(column(&csv, "o.k").iter().all(|&k| k == 9.0), "the parameter k is recorded as set");
    assert!(column(&csv, "o.x").iter().any(|x| x.abs() > 0.5) && column(&csv, "o.v").iter().any(|v| v.abs() > 0.5));

    // FMI 2.0 aliases: `position` shares x0's value reference.
    let (o, dir) = system("alias2", "v", "vanderpol.fmu", "mu = 1.5", r#""v.x0", "v.position""#);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&dir.join("timeseries.csv"));
    assert_eq!(column(&csv, "v.x0"), column(&csv, "v.position"));
    assert!(column(&csv, "v.x0").windows(2).any(|w| w[0] != w[1]));

    // Stop requests: FMI 3.0 and FMI 2.0. The run ends where fmpy's does, with its rows, exit 0.
    for (name, fmu, channels, vars) in [
        ("stop3", "oscillator.fmu", r#""o.x", "o.v""#, ["x", "v"]),
        ("stop2", "vanderpol.fmu", r#""o.x0", "o.x1""#, ["x0", "x1"]),
    ] {
        let reference = fmpy(fmu, &format!("fmpy-{name}.csv"), &["stop_at", "0.23"]);
        assert_eq!(reference.1.len(), 24, "fmpy stops after the step that reaches 0.23 s");
        let (o, dir) = system(name, "o", fmu, "stop_at = 0.23", channels);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{name}: {stderr}");
        assert!(
            stderr.contains("notice: element \"o\" asked to stop the simulation at t = 0.23 s"),
            "{name}: {stderr}"
        );
        let csv = read_csv(&dir.join("timeseries.csv"));
        assert_eq!(csv.1.len(), 24, "{name}");
        for v in vars {
            assert!(bits(&column(&csv, &format!("o.{v}")), &column(&reference, v)), "{name}: o.{v} differs from fmpy");
        }
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
        assert_eq!(summary["stopped"]["element"], "o");
        assert_eq!(summary["stopped"]["reached_s"], 0.23);
        assert_eq!(summary["steps"], 23);
    }

    // An early return (not allowed by lash, like fmpy) is an error naming the element and the
    // time; the rows up to the last whole step are kept as .partial.
    let (o, dir) = system("early", "o", "oscillator.fmu", "return_early_at = 0.125", r#""o.x""#);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("element \"o\" returned early at t = 0.125 s"), "{stderr}");
    assert!(!dir.join("timeseries.csv").exists() && !dir.join("summary.json").exists());
    let partial = read_csv(&dir.join("timeseries.csv.partial"));
    assert_eq!(partial.1.last().unwrap()[0], 0.12);
    let free = fmpy("oscillator.fmu", "fmpy-osc-k4.csv", &["k", "4"]);
    assert!(bits(&column(&partial, "o.x"), &column(&free, "x")[..13]), "the kept rows are fmpy's");

    // A refused parameter value: exit 2, naming the field.
    let (o, _) = system("bad", "o", "oscillator.fmu", "k = -1.0", r#""o.x""#);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("elements[0].parameters.k"), "{stderr}");
    let _ = std::fs::remove_dir_all(out);
}

/// (header, rows) of fmpy's CSV, Booleans read as 0 and 1, array columns ("1 2 3") as NaN.
fn read_fmpy_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header =
        lines.next().unwrap().split(',').map(|h| h.trim_matches('"').split(" [").next().unwrap().to_string()).collect();
    let value = |v: &str| match v {
        "True" => 1.0,
        "False" => 0.0,
        v => v.parse::<f64>().unwrap_or(f64::NAN),
    };
    let rows = lines.map(|l| l.split(',').map(value).collect()).collect();
    (header, rows)
}

/// Variables of every numeric type, FMI 3.0 and 2.0: imported, set as parameters (UInt8,
/// Enumeration, String, a Float64 input), recorded (Int32, Int64, Boolean, Float32) as fmpy
/// records them, connected across types (an FMI 2.0 Boolean output into an FMI 3.0 Int32
/// input); values that do not fit a type are refused naming the field.
#[test]
fn every_variable_type_is_imported_set_recorded_and_connected() {
    let scratch = FmuScratch::new("types");
    let (out, run_py) = (&scratch.out, |args: &[&str]| scratch.py(args));
    run_py(&[
        "-m",
        "fmpy.cli",
        "simulate",
        "oscillator.fmu",
        "--stop-time",
        "1.2",
        "--output-interval",
        "0.01",
        "--output-file",
        "fmpy-types.csv",
        "--start-values",
        "gain",
        "3",
        "gear",
        "2",
        "label",
        "hello",
        "force",
        "0.5",
    ]);
    let reference = read_fmpy_csv(&out.join("fmpy-types.csv"));
    let run = |name: &str, text: &str| {
        let file = out.join(format!("{name}.toml"));
        std::fs::write(&file, text).unwrap();
        let dir = out.join(name);
        (lash(&["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]), dir)
    };
    let system = |parameters: &str, channels: &str| {
        format!(
            "name = \"types\"\nstop = 1.2\nstep = 0.01\n[[elements]]\nname = \"o\"\nfmu = \"oscillator.fmu\"\nparameters = {{ {parameters} }}\n[output]\nchannels = [{channels}]\n"
        )
    };
    let (o, dir) = run(
        "types",
        &system(
            r#"gain = 3, gear = 2, label = "hello", force = 0.5"#,
            r#""o.x", "o.x32", "o.steps", "o.ticks", "o.moving", "o.kicks_seen", "o.gain", "o.gear", "o.wave8", "o.count16", "o.wave16", "o.count32""#,
        ),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&dir.join("timeseries.csv"));
    assert_eq!(csv.1.len(), 121);
    let same = |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
    for v in ["x", "steps", "ticks", "moving", "kicks_seen", "wave8", "count16", "wave16", "count32"] {
        assert!(same(&column(&csv, &format!("o.{v}")), &column(&reference, v)), "o.{v} differs from fmpy");
    }
    // Float32: the same single-precision values (fmpy prints them in their shortest f32 form).
    let as_f32 = |v: Vec<f64>| v.into_iter().map(|x| (x as f32).to_bits()).collect::<Vec<_>>();
    assert_eq!(as_f32(column(&csv, "o.x32")), as_f32(column(&reference, "x32")));
    assert!(column(&csv, "o.moving").contains(&1.0) && column(&csv, "o.moving").contains(&0.0));
    assert_eq!(*column(&csv, "o.ticks").last().unwrap(), 1200.0);
    // The integer outputs reach their types' extremes and wrap as the C types do.
    let lowest = |v: Vec<f64>| v.into_iter().fold(f64::MAX, f64::min);
    assert_eq!(lowest(column(&csv, "o.wave8")), -100.0);
    assert_eq!(lowest(column(&csv, "o.wave16")), -30000.0);
    assert!(column(&csv, "o.count32").iter().any(|&c| c > 4.0e9));
    assert!(
        column(&csv, "o.count16").windows(2).any(|w| w[1] < w[0])
            && column(&csv, "o.count32").windows(2).any(|w| w[1] < w[0])
    );
    assert!(column(&csv, "o.gain").iter().all(|&g| g == 3.0) && column(&csv, "o.gear").iter().all(|&g| g == 2.0));

    // The same parameters from SSP: an .ssv file with Integer, Enumeration, String and Real
    // values (and a Boolean one, which the FMU has no parameter for: refused, naming it).
    let ssv = |extra: &str| {
        format!(
            r#"<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="o">
  <ssv:Parameters>
    <ssv:Parameter name="gain"><ssv:Integer value="3"/></ssv:Parameter>
    <ssv:Parameter name="gear"><ssv:Enumeration value="2"/></ssv:Parameter>
    <ssv:Parameter name="label"><ssv:String value="hello"/></ssv:Parameter>
    <ssv:Parameter name="force"><ssv:Real value="0.5"/></ssv:Parameter>{extra}
  </ssv:Parameters>
</ssv:ParameterSet>"#
        )
    };
    let ssd = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="types">
  <ssd:System name="types">
    <ssd:Elements>
      <ssd:Component name="o" source="oscillator.fmu">
        <ssd:ParameterBindings><ssd:ParameterBinding source="o.ssv"/></ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="1.2">
    <ssd:Annotations><ssc:Annotation type="org.lash"><lash:Step xmlns:lash="https://lash.dev" value="0.01"/></ssc:Annotation></ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>"#;
    std::fs::write(out.join("types.ssd"), ssd).unwrap();
    std::fs::write(out.join("o.ssv"), ssv("")).unwrap();
    let ssp_dir = out.join("types-ssp");
    let o = lash(&["run", out.join("types.ssd").to_str().unwrap(), "--quiet", "--out", ssp_dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let from_ssp = read_csv(&ssp_dir.join("timeseries.csv"));
    for v in ["x", "steps", "wave8"] {
        assert!(same(&column(&from_ssp, &format!("o.{v}")), &column(&reference, v)), "SSP: o.{v} differs from fmpy");
    }
    std::fs::write(
        out.join("o.ssv"),
        ssv("\n    <ssv:Parameter name=\"moving\"><ssv:Boolean value=\"true\"/></ssv:Parameter>"),
    )
    .unwrap();
    let o = lash(&["run", out.join("types.ssd").to_str().unwrap(), "--quiet", "--out", ssp_dir.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("moving"), "{err}");

    // Across types and standards: FMI 2.0 Boolean `positive` into the FMI 3.0 Int32 input `kick`.
    // Gauss-Seidel: the oscillator's step k sees vdp's value at its step end, so its running sum
    // of kicks is the sum of `positive` over the rows after the first.
    let text = r#"name = "across"
stop = 4.0
step = 0.01
[[elements]]
name = "v"
fmu = "vanderpol.fmu"
parameters = { label = "first" }
[[elements]]
name = "o"
fmu = "oscillator.fmu"
[[connections]]
from = "v.positive"
to = "o.kick"
[output]
channels = ["v.positive", "v.steps", "o.kicks_seen"]
"#;
    let (o, dir) = run("across", text);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&dir.join("timeseries.csv"));
    let (positive, kicks) = (column(&csv, "v.positive"), column(&csv, "o.kicks_seen"));
    let mut sum = 0.0;
    for k in 1..positive.len() {
        sum += positive[k];
        assert_eq!(kicks[k], sum, "row {k}");
    }
    assert!(positive.contains(&0.0) && positive.contains(&1.0), "x0 changes sign within 4 s");
    assert_eq!(column(&csv, "v.steps"), (0..401).map(f64::from).collect::<Vec<_>>());

    // Strings through the importer: a parameter set before initialization, read back as output.
    let cache = out.join("cache");
    let mut fmu = lash_fmi::import::ImportedFmu::open(&out.join("oscillator.fmu"), &cache, "o").unwrap();
    use lash_core::Subsystem;
    let find = |name: &str| fmu.variables().iter().find(|v| v.name == name).unwrap().value_reference;
    let (label, label_out) = (find("label"), find("label_out"));
    fmu.setup(lash_core::Ticks::ZERO, None).unwrap();
    fmu.set_string(label, "spring–mass").unwrap();
    fmu.initialize().unwrap();
    assert_eq!(fmu.get_string(label_out).unwrap(), "spring–mass");
    assert!(fmu.get_f64(&[label_out], &mut [0.0]).unwrap_err().to_string().contains("String"));

    // Values that do not fit their type: exit 2, naming the field and the type.
    for (parameters, channels, expected) in [
        ("gain = 300", r#""o.x""#, "elements[0].parameters.gain: 300 is not a valid UInt8"),
        ("gear = 1.5", r#""o.x""#, "elements[0].parameters.gear: 1.5 is not a valid Enumeration"),
        ("label = 3", r#""o.x""#, "elements[0].parameters.label: a String parameter takes text"),
        ("k = \"stiff\"", r#""o.x""#, "elements[0].parameters.k: a Float64 parameter takes a number, not text"),
        ("", r#""o.label_out""#, "output.channels[0]: o.label_out is a String variable"),
    ] {
        let (o, _) = run("bad-type", &system(parameters, channels));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{parameters}: {err}");
        assert!(err.contains(expected), "expected {expected:?} in: {err}");
    }
    // Bytes: a Binary parameter (hexadecimal text) echoed by a Binary output, connected to the
    // Binary input of a second instance, which reports the length and first byte it received.
    let text = r#"name = "bytes"
stop = 0.1
step = 0.01
[[elements]]
name = "a"
fmu = "oscillator.fmu"
parameters = { blob = "ca fe 01" }
[[elements]]
name = "b"
fmu = "oscillator.fmu"
[[connections]]
from = "a.blob_out"
to = "b.blob_in"
[output]
channels = ["b.blob_in_length", "b.blob_in_first"]
"#;
    let (o, dir) = run("bytes", text);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = read_csv(&dir.join("timeseries.csv"));
    assert!(column(&csv, "b.blob_in_length").iter().all(|&n| n == 3.0));
    assert!(column(&csv, "b.blob_in_first").iter().all(|&b| b == f64::from(0xca)));
    let (o, _) = run("bad-bytes", &text.replace("ca fe 01", "cafe0"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("elements[0].parameters.blob") && err.contains("odd number"), "{err}");
    // A structural parameter sizes an array (FMI 3.0 configuration mode): `modes` has n
    // elements, (i + 1) x each, in and out of process; the default n is 3.
    for (isolate, n) in [("", None), ("", Some(5)), ("isolate = true", Some(7))] {
        let parameters = n.map_or(String::new(), |n| format!("n = {n}"));
        let text = system(&parameters, r#""o.x", "o.modes""#)
            .replace("fmu = \"oscillator.fmu\"\n", &format!("fmu = \"oscillator.fmu\"\n{isolate}\n"));
        let (o, dir) = run("structural", &text);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let csv = read_csv(&dir.join("timeseries.csv"));
        let n = n.unwrap_or(3);
        assert_eq!(csv.0.len(), 2 + n, "{:?}", csv.0);
        let x = column(&csv, "o.x");
        for i in 0..n {
            let modes = column(&csv, &format!("o.modes[{}]", i + 1));
            assert!(modes.iter().zip(&x).all(|(m, x)| m.to_bits() == ((i + 1) as f64 * x).to_bits()), "modes[{i}]");
        }
    }
    for (parameters, expected) in [
        ("n = 65", "structural parameters [\"n\"] refused"),
        ("n = 2.5", "elements[0].parameters.n: 2.5 is not a valid UInt64"),
    ] {
        let (o, _) = run("bad-structural", &system(parameters, r#""o.modes""#));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{parameters}: {err}");
        assert!(err.contains(expected), "expected {expected:?} in: {err}");
    }
    let _ = std::fs::remove_dir_all(out);
}

/// `isolate = true` runs an FMU in a child process: the results are the in-process ones bit for
/// bit, and an FMU that aborts, segfaults or hangs becomes an error naming the element, the FMU,
/// the time and the signal (or the timeout), with the rows so far kept. Without isolation such an
/// FMU takes lash down with it (documented; checked here for abort()).
#[test]
fn isolated_fmus_survive_crashes_and_hangs() {
    let scratch = FmuScratch::new("isolate");
    let out = &scratch.out;
    let run = |name: &str, isolate: &str, fault: &str| {
        let text = format!(
            "name = \"iso\"\nstop = 1.0\nstep = 0.01\n[[elements]]\nname = \"v\"\nfmu = \"vanderpol.fmu\"\n{isolate}\nparameters = {{ mu = 1.5{fault} }}\n[[elements]]\nname = \"o\"\nfmu = \"oscillator.fmu\"\n{isolate}\n[[connections]]\nfrom = \"v.x0\"\nto = \"o.force\"\n"
        );
        let file = out.join(format!("{name}.toml"));
        std::fs::write(&file, text).unwrap();
        let dir = out.join(name);
        (lash(&["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]), dir)
    };
    // Same bits in and out of process.
    let (a, dir_a) = run("inprocess", "", "");
    let (b, dir_b) = run("isolated", "isolate = true", "");
    assert!(a.status.success() && b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let (ca, cb) = (read_csv(&dir_a.join("timeseries.csv")), read_csv(&dir_b.join("timeseries.csv")));
    assert_eq!(ca.0, cb.0);
    assert_eq!(ca.1.len(), 101);
    for (ra, rb) in ca.1.iter().zip(&cb.1) {
        assert!(ra.iter().zip(rb).all(|(x, y)| x.to_bits() == y.to_bits()), "rows differ at t = {}", ra[0]);
    }
    // Crashes and a hang at 0.5 s.
    for (fault, expected) in [
        ("1", "the FMU crashed with signal 6 (SIGABRT)"),
        ("2", "the FMU crashed with signal 11 (SIGSEGV)"),
        ("3", "no answer within 1 s: the FMU hangs (its process was killed)"),
    ] {
        let (o, dir) = run(
            &format!("fault{fault}"),
            "isolate = true\ntimeout = 1.0",
            &format!(", fault = {fault}, fault_at = 0.5"),
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "fault {fault}: {err}");
        for part in ["element \"v\"", "vanderpol.fmu", "do_step at t = 0.5 s", expected, "timeseries.csv.partial"] {
            assert!(err.contains(part), "fault {fault}: {part:?} missing from: {err}");
        }
        let kept = read_csv(&dir.join("timeseries.csv.partial"));
        assert_eq!(kept.1.len(), 51, "fault {fault}: rows up to 0.5 s are kept");
        assert!(kept.1.iter().zip(&ca.1).all(|(x, y)| x == y), "fault {fault}: the kept rows are the healthy run's");
    }
    // `lash fmu check --isolate` runs the smoke simulation in a child process.
    let fmu = out.join("oscillator.fmu");
    let o = lash(&["fmu", "check", fmu.to_str().unwrap(), "--isolate", "--timeout", "5"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("isolated in a child process"));
    // Not isolated, abort() ends lash itself (by the signal, as it does fmpy and libcosim).
    let (o, _) = run("unisolated", "", ", fault = 1, fault_at = 0.5");
    assert_eq!(o.status.code(), None, "lash was ended by a signal");
    let _ = std::fs::remove_dir_all(out);
}

/// The process ids whose parent is `parent` and whose command line contains `needle`.
fn children_of(parent: u32, needle: &str) -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    entries
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()))
        .filter(|pid| {
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            // Fields after the command's closing parenthesis: state, parent id, …
            let ppid = stat.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().nth(1)?.parse::<u32>().ok());
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            ppid == Some(parent) && String::from_utf8_lossy(&cmdline).replace('\0', " ").contains(needle)
        })
        .collect()
}

/// Whether `pid` still runs (a zombie that nobody reaped has ended).
fn running(pid: u32) -> bool {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    stat.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().next()).is_some_and(|s| s != "Z" && s != "X")
}

/// An isolated FMU's host process ends with lash, however lash ends: SIGKILL (no handler runs),
/// SIGTERM twice (the second one exits at once, with the FMU mid-call), SIGINT twice. The FMU
/// hangs in its step, so lash itself never ends the host.
#[test]
fn an_isolated_fmus_host_dies_with_lash() {
    let scratch = FmuScratch::new("hygiene");
    let file = scratch.out.join("hang.toml");
    std::fs::write(
        &file,
        "name = \"hang\"\nstop = 1.0\nstep = 0.01\n[[elements]]\nname = \"v\"\nfmu = \"vanderpol.fmu\"\nisolate = true\ntimeout = 600.0\nparameters = { fault = 3, fault_at = 0.05 }\n",
    )
    .unwrap();
    for signals in [&["-KILL"][..], &["-TERM", "-TERM"], &["-INT", "-INT"]] {
        let out = scratch.out.join(format!("out{}", signals[0]));
        let mut child = Command::new(env!("CARGO_BIN_EXE_lash"))
            .args(["run", file.to_str().unwrap(), "--quiet", "--out", out.to_str().unwrap()])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let waited = std::time::Instant::now();
        let host = loop {
            if let Some(&pid) = children_of(child.id(), "fmu host").first() {
                break pid;
            }
            assert!(waited.elapsed().as_secs() < 60, "{signals:?}: no FMU host started");
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        // Let the FMU reach its hang.
        std::thread::sleep(std::time::Duration::from_millis(500));
        for signal in signals {
            let ok = Command::new("kill").args([*signal, &child.id().to_string()]).status().unwrap().success();
            assert!(ok, "{signals:?}: kill");
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
        let status = child.wait().unwrap();
        assert!(!status.success(), "{signals:?}: lash ended with {status}");
        let waited = std::time::Instant::now();
        while running(host) {
            assert!(waited.elapsed().as_secs() < 10, "{signals:?}: the FMU host {host} outlived lash by 10 s");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
    let _ = std::fs::remove_dir_all(&scratch.out);
}

/// `lash fmu check` applies the checks `lash run` applies and says the same thing: an FMU whose
/// description names two variables alike is refused by both, with one message (exit 2).
#[test]
fn fmu_check_refuses_what_run_refuses_with_the_same_words() {
    use std::io::{Read, Write};
    let scratch = FmuScratch::new("onecheck");
    let good = scratch.out.join("oscillator.fmu");
    let mut reader = zip::ZipArchive::new(std::fs::File::open(&good).unwrap()).unwrap();
    let dup = scratch.out.join("dup.fmu");
    let mut writer = zip::ZipWriter::new(std::fs::File::create(&dup).unwrap());
    for k in 0..reader.len() {
        let mut entry = reader.by_index(k).unwrap();
        if entry.is_dir() {
            continue;
        }
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).unwrap();
        if entry.name() == "modelDescription.xml" {
            bytes = String::from_utf8(bytes).unwrap().replace("name=\"energy\"", "name=\"v\"").into_bytes();
        }
        writer.start_file(entry.name(), zip::write::SimpleFileOptions::default()).unwrap();
        writer.write_all(&bytes).unwrap();
    }
    writer.finish().unwrap();
    let check = lash(&["fmu", "check", dup.to_str().unwrap()]);
    let system = scratch.out.join("dup.toml");
    std::fs::write(&system, "name = \"d\"\nstop = 0.1\nstep = 0.01\n[[elements]]\nname = \"o\"\nfmu = \"dup.fmu\"\n")
        .unwrap();
    let run = lash(&["run", system.to_str().unwrap(), "--quiet", "--out", scratch.out.join("o").to_str().unwrap()]);
    for (what, o) in [("fmu check", &check), ("run", &run)] {
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what}: {err}");
        assert!(err.contains("variable name \"v\" is used twice") && err.contains("dup.fmu"), "{what}: {err}");
    }
    let isolated = lash(&["fmu", "check", dup.to_str().unwrap(), "--isolate"]);
    assert_eq!(isolated.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&isolated.stderr).contains("variable name \"v\" is used twice"));
    let _ = std::fs::remove_dir_all(&scratch.out);
}

/// FMI 2.0 names mean one thing: lash's own FMI 2.0 FMUs (arrays written as 1-based scalars
/// `effective_mass[1,2]`) coupled by Jacobi, once array to array and once element by element
/// in a shuffled order, give the same bits; the CSV columns are the FMU's own scalar names; an SSP
/// whose connectors name the elements and which has no stop time runs with `--horizon` and equals
/// both; a misspelt element gets a short "did you mean".
#[test]
fn fmi2_element_names_reach_connections_csv_and_ssp_as_spelled() {
    let out = std::env::temp_dir().join(format!("lash-system-elements-{}", std::process::id()));
    let o = lash(&["fmu", "pack", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let toml = |connections: &str| {
        format!(
            "name = \"elements\"\nstart = 0.0\nstop = 0.03\nstep = 1e-3\nalgorithm = \"jacobi\"\ninitialization = \"iterated\"\n\n\
             [[elements]]\nname = \"mechanism\"\nfmu = \"lash_mechanism-fmi2.fmu\"\n\n\
             [[elements]]\nname = \"joint\"\nfmu = \"lash_interface-fmi2.fmu\"\n\n{connections}\n\
             [output]\nchannels = [\"joint.contact_force\", \"joint.eccentricity[2]\", \"mechanism.effective_force[1]\"]\n"
        )
    };
    let connection =
        |from: &str, to: &str| format!("[[connections]]\nfrom = \"mechanism.{from}\"\nto = \"joint.{to}\"\n");
    let whole = [("effective_mass", "effective_mass"), ("effective_force", "effective_force")];
    let elements = [
        ("effective_force[2]", "effective_force[2]"),
        ("effective_mass[2,1]", "effective_mass[2,1]"),
        ("effective_mass[1,1]", "effective_mass[1,1]"),
        ("effective_force[1]", "effective_force[1]"),
        ("effective_mass[2,2]", "effective_mass[2,2]"),
        ("effective_mass[1,2]", "effective_mass[1,2]"),
    ];
    let run = |tag: &str, text: &str, extra: &[&str]| {
        let file = out.join(format!("{tag}.{}", if text.starts_with('<') { "ssd" } else { "toml" }));
        std::fs::write(&file, text).unwrap();
        let dir = out.join(tag);
        let mut args = vec!["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()];
        args.extend(extra);
        let o = lash(&args);
        (o, dir)
    };
    let mut results = Vec::new();
    for (tag, pairs) in [("whole", &whole[..]), ("elements", &elements[..])] {
        let text = toml(&pairs.iter().map(|(f, t)| connection(f, t)).collect::<String>());
        let (o, dir) = run(tag, &text, &[]);
        assert!(o.status.success(), "{tag}: {}", String::from_utf8_lossy(&o.stderr));
        results.push(read_csv(&dir.join("timeseries.csv")));
    }
    let header = [
        "time",
        "joint.contact_force[1]",
        "joint.contact_force[2]",
        "joint.eccentricity[2]",
        "mechanism.effective_force[1]",
    ];
    assert_eq!(results[0].0, header, "the FMU's own scalar names");
    let force = column(&results[0], "mechanism.effective_force[1]");
    assert!(force.iter().any(|f| f.abs() > 1.0), "the mechanism is loaded: {force:?}");
    // The SSP: the same couplings named by element, no stopTime, the step from libcosim's
    // annotation (which also means Jacobi with iterated initialization, as the TOML files say).
    let connectors: String = elements
        .iter()
        .map(|(f, t)| {
            format!("<ssd:Connection startElement=\"mechanism\" startConnector=\"{f}\" endElement=\"joint\" endConnector=\"{t}\"/>\n")
        })
        .collect();
    let ssd = format!(
        "<?xml version=\"1.0\"?>\n<ssd:SystemStructureDescription name=\"elements\" version=\"1.0\" \
         xmlns:ssd=\"http://ssp-standard.org/SSP1/SystemStructureDescription\" \
         xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\">\n<ssd:System name=\"s\">\n\
         <ssd:Annotations><ssc:Annotation type=\"org.open-simulation-platform\"><osp:SimulationInformation>\
         <osp:FixedStepMaster description=\"FixedStepAlgorithm\" stepSize=\"1e-3\"/></osp:SimulationInformation>\
         </ssc:Annotation></ssd:Annotations>\n<ssd:Elements>\n\
         <ssd:Component name=\"mechanism\" source=\"lash_mechanism-fmi2.fmu\"/>\n\
         <ssd:Component name=\"joint\" source=\"lash_interface-fmi2.fmu\"/>\n</ssd:Elements>\n\
         <ssd:Connections>\n{connectors}</ssd:Connections>\n</ssd:System>\n\
         <ssd:DefaultExperiment startTime=\"0.0\"/>\n</ssd:SystemStructureDescription>\n"
    );
    let (o, _) = run("ssp-no-stop", &ssd, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no DefaultExperiment stopTime: add one, or pass --horizon"), "{err}");
    let (o, dir) = run("ssp", &ssd, &["--horizon", "0.03"]);
    assert!(o.status.success(), "ssp: {}", String::from_utf8_lossy(&o.stderr));
    let ssp = read_csv(&dir.join("timeseries.csv"));
    let names: Vec<&str> = ssp.0.iter().map(String::as_str).collect();
    assert!(names.contains(&"joint.contact_force[1]") && names.contains(&"mechanism.effective_force[2]"), "{names:?}");
    for other in [&results[1], &ssp] {
        assert_eq!(other.1.len(), 31);
        for name in &header[1..] {
            let (a, b) = (column(&results[0], name), column(other, name));
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{name} differs");
        }
    }
    // A misspelt element: a few close names, not the whole list.
    let text = toml(&connection("effective_mass[1,1]", "effective_mas[1,1]"));
    let (o, _) = run("misspelt", &text, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("connections[0].to: element \"joint\" has no variable \"effective_mas[1,1]\" (did you mean \"effective_mass[1,1]\""), "{err}");
    assert!(err.len() < 400, "{} bytes: {err}", err.len());
    let _ = std::fs::remove_dir_all(&out);
}

/// An `.ssp` archive is untrusted like an FMU: an entry that leaves the archive's folder is
/// refused by name (exit 2), and nothing is written beside it.
#[test]
fn an_ssp_archive_is_unpacked_confined() {
    let out = std::env::temp_dir().join(format!("lash-system-ssp-confined-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let ssp = out.join("hostile.ssp");
    let script = "import sys, zipfile\n\
                  with zipfile.ZipFile(sys.argv[1], 'w') as z:\n\
                  \x20   z.writestr('SystemStructure.ssd', '<ssd:SystemStructureDescription/>')\n\
                  \x20   z.writestr('../escaped.txt', 'outside')\n";
    let o = Command::new(fmpy_python()).args(["-c", script, ssp.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = lash(&["run", ssp.to_str().unwrap(), "--quiet", "--out", out.join("run").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("entry \"../escaped.txt\": not a plain relative path"), "{err}");
    let tmp = std::env::temp_dir();
    assert!(!tmp.join("escaped.txt").exists() && !out.join("escaped.txt").exists(), "written outside");
    let _ = std::fs::remove_dir_all(&out);
}

/// The initial exchange, explained against libcosim (libcosimpy from PyPI): two feedthrough FMUs
/// in a loop (tests/fmi/feedthrough: y = x + gain u, x = x_start + pull u until initialization
/// ends), crossed by element. An SSP carrying libcosim's fixed-step annotation runs in lash as in
/// libcosim (Jacobi, initial values iterated in initialization mode): the initial outputs equal
/// the iteration worked out by hand, and every later sample equals libcosim's bit for bit. The
/// same system with lash's ordered initialization starts elsewhere, and its first steps differ.
/// lash sets parameter values before initialization mode, libcosimpy 0.0.6 in it.
#[test]
fn the_initial_exchange_matches_libcosim() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("lash-system-libcosim-{}", std::process::id()));
    let ssp = out.join("ssp");
    std::fs::create_dir_all(&ssp).unwrap();
    let python = fmpy_python();
    let build = root.join("tests/fmi/build_c_fmu.py");
    let folder = root.join("tests/fmi/feedthrough");
    let o = Command::new(&python).arg(&build).arg(&folder).arg(ssp.join("feedthrough.fmu")).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ssd = std::fs::read_to_string(root.join("tests/fmi/feedthrough/SystemStructure.ssd")).unwrap();
    std::fs::write(ssp.join("SystemStructure.ssd"), &ssd).unwrap();
    let probes = ["a.y[1]", "a.y[2]", "b.y[1]", "b.y[2]"];
    let script = root.join("tests/fmi/feedthrough/libcosim_run.py");
    let reference = out.join("libcosim.csv");
    let mut args: Vec<String> = vec![script.display().to_string(), ssp.display().to_string(), "10".into()];
    args.extend([reference.display().to_string(), "10000000".into()]);
    args.extend(probes.iter().map(|p| format!("{p}={}", if p.ends_with("[1]") { 2 } else { 3 })));
    args.push("b.late_parameters=8".into());
    let o = Command::new(&python).args(&args).output().unwrap();
    assert!(o.status.success(), "libcosim: {}", String::from_utf8_lossy(&o.stderr));
    let libcosim = read_fmpy_csv(&reference);
    assert_eq!(libcosim.1.len(), 10);
    let run = |tag: &str, file: &Path| {
        let dir = out.join(tag);
        let o = lash(&["run", file.to_str().unwrap(), "--quiet", "--out", dir.to_str().unwrap()]);
        assert!(o.status.success(), "{tag}: {}", String::from_utf8_lossy(&o.stderr));
        read_csv(&dir.join("timeseries.csv"))
    };
    let iterated = run("ssp", &ssp.join("SystemStructure.ssd"));
    // lash sets b's three parameter values before initialization mode (where FMI 2.0 puts start
    // values, as fmpy does); libcosimpy 0.0.6's libcosim sets them in it. This FMU takes either,
    // so the results agree; one that reads its parameters on entering initialization would not.
    assert!(column(&iterated, "b.late_parameters").iter().all(|&n| n == 0.0), "lash set parameters late");
    assert!(column(&libcosim, "b.late_parameters").iter().all(|&n| n == 3.0), "libcosim's parameter timing changed");
    // By hand: y = x_start + (pull + gain) u in initialization mode; round 1 passes the outputs
    // at u = 0, round 2 those at the inputs round 1 gave; leaving, x = x_start + pull u.
    let (a, b) = (([1.0, 2.0], 1.0, 0.5), ([1.0, -0.5], 2.0, 0.25)); // (x_start, pull, gain)
    let y = |(xs, pull, gain): ([f64; 2], f64, f64), u: [f64; 2]| [0, 1].map(|i| xs[i] + (pull + gain) * u[i]);
    let (mut ua, mut ub) = ([0.0; 2], [0.0; 2]);
    for _ in 0..2 {
        let (ya, yb) = (y(a, ua), y(b, ub));
        (ua, ub) = ([yb[0], yb[1]], [ya[1], ya[0]]);
    }
    let start = |(xs, pull, gain): ([f64; 2], f64, f64), u: [f64; 2]| [0, 1].map(|i| xs[i] + pull * u[i] + gain * u[i]);
    let expected = [start(a, ua), start(b, ub)].concat();
    let at = |csv: &(Vec<String>, Vec<Vec<f64>>), k: usize| probes.map(|p| column(csv, p)[k]);
    assert_eq!(at(&iterated, 0).to_vec(), expected, "the iterated initial outputs");
    for k in 0..10 {
        let theirs = probes.map(|p| column(&libcosim, p)[k]);
        assert_eq!(
            at(&iterated, k + 1).map(f64::to_bits),
            theirs.map(f64::to_bits),
            "t = {}: lash vs libcosim",
            (k + 1) as f64 * 0.01
        );
    }
    // The same system as a TOML file: Jacobi with iterated initialization equals the SSP run;
    // with ordered initialization (lash's default) it starts elsewhere and the first step differs.
    let toml = |initialization: &str| {
        format!(
            "name = \"loop\"\nstart = 0.0\nstop = 0.1\nstep = 0.01\nalgorithm = \"jacobi\"\ninitialization = \"{initialization}\"\n\n\
             [[elements]]\nname = \"a\"\nfmu = \"feedthrough.fmu\"\n\n\
             [[elements]]\nname = \"b\"\nfmu = \"feedthrough.fmu\"\n\
             [elements.parameters]\ngain = 0.25\npull = 2.0\n\"x_start[2]\" = -0.5\n\n{}",
            [("a.y[1]", "b.u[2]"), ("a.y[2]", "b.u[1]"), ("b.y[1]", "a.u[1]"), ("b.y[2]", "a.u[2]")]
                .map(|(f, t)| format!("[[connections]]\nfrom = \"{f}\"\nto = \"{t}\"\n"))
                .concat()
        )
    };
    for initialization in ["iterated", "ordered"] {
        let file = ssp.join(format!("{initialization}.toml"));
        std::fs::write(&file, toml(initialization)).unwrap();
        let csv = run(initialization, &file);
        let same = (0..11).all(|k| at(&csv, k).map(f64::to_bits) == at(&iterated, k).map(f64::to_bits));
        assert_eq!(same, initialization == "iterated", "{initialization}");
        if initialization == "ordered" {
            assert_ne!(at(&csv, 0), at(&iterated, 0), "the initial values differ");
            assert_ne!(at(&csv, 1), probes.map(|p| column(&libcosim, p)[0]), "so does the first step");
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A system whose time series cannot fit is refused by `validate` and by `run` alike, with the
/// figures, before anything is written.
#[test]
fn a_system_too_large_for_the_disk_is_refused_before_work() {
    let out = std::env::temp_dir().join(format!("lash-system-huge-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let file = out.join("huge.toml");
    let text = "name = \"huge\"\nstart = 0.0\nstop = 1e6\nstep = 1e-5\n\n[[elements]]\nname = \"mechanism\"\nbuiltin = \"lash_mechanism\"\n";
    std::fs::write(&file, text).unwrap();
    let target = out.join("run");
    for args in [
        vec!["validate", file.to_str().unwrap()],
        vec!["run", file.to_str().unwrap(), "--out", target.to_str().unwrap()],
    ] {
        let o = lash(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("100000000001 rows") && err.contains("a shorter run (stop, or --horizon)"), "{err}");
    }
    assert!(!target.exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&out);
}
