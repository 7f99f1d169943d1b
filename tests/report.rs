//! `lash report` and `lash compare --report`, end to end: the pose channels place every sensor
//! where the runner's own point kinematics put it (planar and spatial), and the page, opened by a
//! real browser (headless Chromium from the distribution's packages, installed here when
//! missing), draws its figures — checked by the screenshot's pixels, against the same page
//! without its drawing code as a control.

use std::path::{Path, PathBuf};
use std::process::Command;

fn lash(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().expect("lash runs");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "lash {args:?} failed:\n{text}");
    text
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Every sensor's position rebuilt from its body's pose channels and the sensor's local point
/// equals the sensor's own position channels (computed by the runner from the state, apart from
/// the pose channels) at every sample: the poses an animation draws are the run's.
fn sensors_sit_where_the_poses_put_them(dir: &Path) {
    let folder = lash_report::RunFolder::read(dir).expect("the run's folder reads");
    let sensors: Vec<(String, String, [f64; 3])> = match &folder.scenario {
        lash_scenario::AnyScenario::Planar(s) => {
            s.sensors.iter().map(|x| (x.name.clone(), x.body.clone(), [x.point[0], x.point[1], 0.0])).collect()
        }
        lash_scenario::AnyScenario::Spatial(s) => {
            s.sensors.iter().map(|x| (x.name.clone(), x.body.clone(), x.point)).collect()
        }
    };
    let spatial = matches!(folder.scenario, lash_scenario::AnyScenario::Spatial(_));
    assert!(!sensors.is_empty());
    for run in &folder.runs {
        for (name, body, local) in &sensors {
            let axes: &[&str] = if spatial { &["x", "y", "z"] } else { &["x", "y"] };
            let measured: Vec<&[f64]> =
                axes.iter().map(|a| run.column(&format!("{name}.{a}")).expect("sensor channel")).collect();
            for i in 0..run.time().len() {
                let p = lash_report::mechanism::place(run, spatial, body, i, *local).expect("pose channels recorded");
                for (k, m) in measured.iter().enumerate() {
                    assert!(
                        (p[k] - m[i]).abs() < 1e-9,
                        "{}: {name}.{} at sample {i}: {} from the pose, {} measured",
                        run.label,
                        axes[k],
                        p[k],
                        m[i]
                    );
                }
            }
        }
    }
}

/// (body1, point1, body2, point2) of a joint.
type Pin = (String, [f64; 3], String, [f64; 3]);

/// The two points of every pin-like ideal joint (planar revolute; spatial spherical, revolute,
/// universal), each placed by its own body's pose, coincide to within the run's constraint
/// error: the angles and quaternions are right, not only the centroids.
fn joints_hold_together_in_the_poses(dir: &Path) {
    let folder = lash_report::RunFolder::read(dir).expect("the run's folder reads");
    let clearance = |name: &str| folder.scenario.clearances().iter().any(|c| c.joint == name);
    let (spatial, joints): (bool, Vec<Pin>) = match &folder.scenario {
        lash_scenario::AnyScenario::Planar(s) => (
            false,
            s.joints
                .iter()
                .filter(|j| j.kind == lash_scenario::schema::JointType::Revolute && !clearance(&j.name))
                .map(|j| {
                    (j.body1.clone(), [j.point1[0], j.point1[1], 0.0], j.body2.clone(), [j.point2[0], j.point2[1], 0.0])
                })
                .collect(),
        ),
        lash_scenario::AnyScenario::Spatial(s) => (
            true,
            s.joints
                .iter()
                .filter(|j| {
                    use lash_spatial::SpatialJointKind as K;
                    matches!(j.kind, K::Spherical | K::Revolute | K::Universal) && !clearance(&j.name)
                })
                .map(|j| (j.body1.clone(), j.point1, j.body2.clone(), j.point2))
                .collect(),
        ),
    };
    let mut checked = 0;
    for run in &folder.runs {
        // The reduced model's poses are the macro's at its communication points and the
        // master's interpolation between them (where the joints open by its error, ~10 µm on
        // A): they are checked at the communication points.
        let macro_step = run.summary["reduced"]["options"]["macro_step"].as_f64();
        let at_macro = |t: f64| macro_step.is_none_or(|h| ((t / h) - (t / h).round()).abs() < 1e-6);
        let mut widest: f64 = 0.0;
        for (b1, p1, b2, p2) in &joints {
            let at = |body: &str, p: [f64; 3], i: usize| {
                if body == "ground" {
                    p
                } else {
                    lash_report::mechanism::place(run, spatial, body, i, p).expect("pose")
                }
            };
            for i in (0..run.time().len()).filter(|&i| at_macro(run.time()[i])) {
                let (a, b) = (at(b1, *p1, i), at(b2, *p2, i));
                let gap = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
                assert!(gap < 1e-6, "{}: joint {b1}–{b2} apart by {gap} m at sample {i}", run.label);
                widest = widest.max(gap);
                checked += 1;
            }
        }
        eprintln!("{}: joints apart by at most {widest:.3e} m", run.label);
    }
    assert!(checked > 0, "no joint checked");
}

/// A headless Chromium: on PATH, or installed from the distribution's packages (the test command
/// installs what it needs, as it does the Python tools). Found once: the tests run in parallel
/// and two package installs at once would fight over the package manager's lock.
fn chromium() -> PathBuf {
    static BROWSER: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BROWSER.get_or_init(find_or_install_chromium).clone()
}

fn find_or_install_chromium() -> PathBuf {
    const NAMES: [&str; 4] = ["chromium-headless-shell", "chromium", "chromium-browser", "google-chrome"];
    let find = || {
        std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths).flat_map(|d| NAMES.iter().map(move |n| d.join(n))).find(|p| p.is_file())
        })
    };
    if let Some(found) = find() {
        return found;
    }
    let install = Command::new("apt-get")
        .args(["install", "-y", "--no-install-recommends", "chromium-headless-shell"])
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status();
    if !install.is_ok_and(|s| s.success()) {
        // The package lists may be missing on a fresh machine.
        let _ = Command::new("apt-get").arg("update").status();
        let _ = Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends", "chromium-headless-shell"])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status();
    }
    find().expect(
        "no headless Chromium: install it with `apt-get install chromium-headless-shell` (Debian) or put chromium on PATH",
    )
}

/// A screenshot of `page` (1100 px wide, long enough for every figure) as RGB pixels.
fn screenshot(browser: &Path, page: &Path, png: &Path) -> Vec<[u8; 3]> {
    let mut args = vec![
        "--headless".to_string(),
        "--no-sandbox".into(),
        "--disable-gpu".into(),
        "--hide-scrollbars".into(),
        "--window-size=1100,2600".into(),
        format!("--screenshot={}", png.display()),
    ];
    args.push(format!("file://{}", page.canonicalize().expect("page").display()));
    let out = Command::new(browser).args(&args).output().expect("the browser runs");
    assert!(png.is_file(), "no screenshot from {}:\n{}", browser.display(), String::from_utf8_lossy(&out.stderr));
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).expect("png")));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buffer = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buffer).expect("one frame");
    let channels = info.color_type.samples();
    assert!(channels >= 3, "a colour screenshot");
    buffer[..info.buffer_size()].chunks(channels).map(|p| [p[0], p[1], p[2]]).collect()
}

/// Pixels within 40 (sum of channel differences) of `color`.
fn count(pixels: &[[u8; 3]], color: [u8; 3]) -> usize {
    pixels.iter().filter(|p| (0..3).map(|k| (p[k] as i32 - color[k] as i32).abs()).sum::<i32>() < 40).count()
}

const FULL_BLUE: [u8; 3] = [0x1f, 0x77, 0xb4];
const REDUCED_RED: [u8; 3] = [0xd6, 0x27, 0x28];
const IDEAL_GREEN: [u8; 3] = [0x2c, 0xa0, 0x2c];
const BODY_BROWN: [u8; 3] = [0x8c, 0x56, 0x4b];

#[test]
fn a_comparison_report_draws_the_mechanism_orbits_channels_and_spectra_in_a_browser() {
    let dir = scratch("report-A");
    let dir_str = dir.to_str().expect("utf-8 path");
    let said = lash(&["compare", "A", "--out", dir_str, "--report", "--quiet"]);
    assert!(said.contains("report.html"), "{said}");
    sensors_sit_where_the_poses_put_them(&dir);
    joints_hold_together_in_the_poses(&dir);
    let page = dir.join("report.html");
    let html = std::fs::read_to_string(&page).expect("report.html");
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"), "the page loads nothing from the network");
    // The page says how the reduced model stands against its stated bounds (comparison.json's).
    assert!(html.contains("Stated bounds of the reduced model over t ≥ 0.0120 s"), "the bounds' note");
    let browser = chromium();
    let drawn = screenshot(&browser, &page, &dir.join("drawn.png"));
    // The control: the same page and data without its drawing code.
    let (head, rest) = html.rsplit_once("<script>").expect("the drawing code");
    let tail = rest.split_once("</script>").expect("its end").1;
    let blank = dir.join("control.html");
    std::fs::write(&blank, format!("{head}<script></script>{tail}")).expect("control page");
    let control = screenshot(&browser, &blank, &dir.join("control.png"));
    for (name, color) in
        [("full", FULL_BLUE), ("reduced", REDUCED_RED), ("ideal", IDEAL_GREEN), ("mechanism", BODY_BROWN)]
    {
        let (with, without) = (count(&drawn, color), count(&control, color));
        assert!(with > 1_000, "{name}: {with} pixels of its colour drawn");
        assert!(without < 100, "{name}: {without} pixels of its colour without the drawing code (the control)");
    }
}

#[test]
fn a_spatial_run_report_animates_the_mechanism_from_its_quaternions() {
    let dir = scratch("report-E");
    let dir_str = dir.to_str().expect("utf-8 path");
    lash(&["run", "E", "--model", "full", "--horizon", "0.05", "--out", dir_str, "--quiet"]);
    sensors_sit_where_the_poses_put_them(&dir);
    joints_hold_together_in_the_poses(&dir);
    let said = lash(&["report", dir_str]);
    assert!(said.contains("(full)"), "{said}");
    let drawn = screenshot(&chromium(), &dir.join("report.html"), &dir.join("drawn.png"));
    assert!(count(&drawn, BODY_BROWN) > 2_000, "the spatial mechanism drawn");
    assert!(count(&drawn, FULL_BLUE) > 2_000, "the full run's orbits and channels drawn");
}

#[test]
fn a_folder_that_is_no_run_is_refused_with_what_makes_one() {
    let dir = scratch("report-empty");
    std::fs::create_dir_all(&dir).expect("dir");
    let out = Command::new(env!("CARGO_BIN_EXE_lash")).args(["report"]).arg(&dir).output().expect("lash runs");
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(text.contains("summary.json") && text.contains("comparison.json"), "{text}");
}
