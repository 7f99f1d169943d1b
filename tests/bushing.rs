//! Bushings (revolute joints made flexible by a bush) in the full model, and scenario F's joint
//! configurations: a static closed form, the quasi-static limit against the rigid mechanism, the
//! stiff limit, and clear errors.

mod common;
use common::{column, rows};
use lash_run::{BuildOptions, FullRun};
use lash_scenario::builtin;

/// A block of `mass` hanging in gravity from a bushing (the `[[bushings]]` lines given) at its
/// centroid, the block's y and the bush's channels sampled every 1 ms.
fn hanging(mass: f64, bushing: &str) -> String {
    format!(
        r#"
name = "hanging"
gravity = [0.0, -9.81]
[[bodies]]
name = "block"
mass = {mass}
inertia = 0.01
position = [0.0, 0.0]
[[joints]]
name = "pin"
type = "revolute"
body1 = "block"
point1 = [0.0, 0.0]
body2 = "ground"
point2 = [0.0, 0.0]
[[bushings]]
joint = "pin"
{bushing}
[[sensors]]
name = "block"
body = "block"
point = [0.0, 0.0]
[simulation]
horizon = 0.02
output_interval = 1e-3
[simulation.integrator]
method = "dop853"
rtol = 1e-10
atol = 1e-14
initial_step = 1e-6
max_step = 1e-3
min_step = 1e-14
"#
    )
}

/// A 2 kg body hanging in gravity from a bushing (k = 1e6 N/m) at its centroid: it starts and
/// stays at the static deflection m g / k, and the bush carries m g.
#[test]
fn a_body_on_a_bushing_rests_at_its_static_deflection() {
    let text = hanging(2.0, "stiffness = 1e6\ndamping = 10.0");
    let s = lash_scenario::parse(&text).unwrap();
    let (_, header, rows) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let (y, force, deflection) =
        (column(&header, "block.y"), column(&header, "pin.force"), column(&header, "pin.deflection"));
    let static_deflection = 2.0 * 9.81 / 1e6;
    for r in &rows {
        assert!((r[y] + static_deflection).abs() < 1e-9 * static_deflection, "t = {}: y = {}", r[0], r[y]);
        assert!((r[deflection] / static_deflection - 1.0).abs() < 1e-9);
        assert!((r[force] / (2.0 * 9.81) - 1.0).abs() < 1e-9, "t = {}: {}", r[0], r[force]);
    }
}

/// The column `name` of every row.
fn series(header: &[String], rows: &[Vec<f64>], name: &str) -> Vec<f64> {
    let k = column(header, name);
    rows.iter().map(|r| r[k]).collect()
}

/// Scenario F with its bronze bush (20 kHz against a 50 Hz crank) follows the rigid mechanism
/// quasi-statically: the bush's force is the rigid joint's reaction (the load's harmonics excite it
/// far below resonance), its deflection is that force over the FE stiffness, and the crank
/// torque is the rigid one, to 0.2 % of their peaks. What is left is the ringing the start leaves:
/// the bush starts deflected by its load but not at its load's rate ḟ/k, so it rings with a
/// force amplitude ḟ/ω_n ∝ k^(−1/2), undamped (ζ ≈ 1e-6): a ten times stiffer bush comes
/// √10 closer.
#[test]
fn the_flexible_crank_slider_follows_the_rigid_one_quasi_statically() {
    // Tight tolerances: a position error ε of the integrator is a bush force error k ε.
    let tight = |mut s: lash_scenario::Scenario| {
        s.simulation.integrator = lash_ode::Method::Dop853(lash_ode::AdaptiveOptions {
            rtol: 1e-11,
            atol: 1e-14,
            initial_step: 1e-7,
            max_step: 1e-4,
            min_step: 1e-14,
        });
        s
    };
    let rigid = tight(builtin::by_name("F-rigid-perfect").unwrap());
    let (_, hr, rr) = rows(&mut FullRun::new(&rigid, BuildOptions::default()));
    let (fx, fy) = (series(&hr, &rr, "rod_slider.fx"), series(&hr, &rr, "rod_slider.fy"));
    let reaction: Vec<f64> = fx.iter().zip(&fy).map(|(x, y)| x.hypot(*y)).collect();
    let torque = series(&hr, &rr, "motor.torque");
    let peak = reaction.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let torque_peak = torque.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let flexible = tight(builtin::by_name("F-flexible-perfect").unwrap());
    let stiffness = flexible.bushings[0].stiffness_damping().unwrap().0;
    let worst = |s: &lash_scenario::Scenario| {
        let (_, h, r) = rows(&mut FullRun::new(s, BuildOptions::default()));
        let (force, deflection) = (series(&h, &r, "rod_slider.force"), series(&h, &r, "rod_slider.deflection"));
        let k = s.bushings[0].stiffness_damping().unwrap().0;
        for (f, d) in force.iter().zip(&deflection) {
            // The damping part is below 1e-6 of the force: the force is k |d|.
            assert!((f - k * d).abs() <= 1e-5 * peak, "{f} vs {}", k * d);
        }
        let t = series(&h, &r, "motor.torque");
        let force_error = force.iter().zip(&reaction).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / peak;
        let torque_error = t.iter().zip(&torque).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / torque_peak;
        eprintln!(
            "k = {k:e} N/m: largest differences from the rigid joint {force_error:e} (force), {torque_error:e} (torque) of the peaks"
        );
        (force_error, torque_error)
    };
    let (force_error, torque_error) = worst(&flexible);
    assert!(force_error < 2e-3 && torque_error < 2e-3, "{force_error} {torque_error}");
    let mut stiffer = flexible.clone();
    stiffer.bushings[0].bush = None;
    stiffer.bushings[0].stiffness = Some(10.0 * stiffness);
    stiffer.bushings[0].damping = Some(flexible.bushings[0].stiffness_damping().unwrap().1);
    let (force_error_10, torque_error_10) = worst(&stiffer);
    let expected = 10f64.sqrt().recip();
    for (a, b) in [(force_error, force_error_10), (torque_error, torque_error_10)] {
        assert!((b / a / expected - 1.0).abs() < 0.25, "{a} → {b}: ratio {} against {expected}", b / a);
    }
}

/// What a bushing cannot be, each with its field; the reduced model refuses bushings.
#[test]
fn bad_bushings_are_clear_errors() {
    let mut s = builtin::by_name("F-flexible-perfect").unwrap();
    s.bushings[0].stiffness = Some(1e9);
    let text = format!("{}", lash_scenario::validate(&s));
    assert!(text.contains("bushings[0].stiffness") && text.contains("not both"), "{text}");
    let mut s = builtin::by_name("F-flexible-perfect").unwrap();
    s.bushings[0].bush.as_mut().unwrap().inner_radius = 0.011;
    let text = format!("{}", lash_scenario::validate(&s));
    assert!(text.contains("bushings[0].bush.inner_radius") && text.contains("clearance"), "{text}");
    let mut s = builtin::by_name("F").unwrap();
    s.bushings.push(builtin::by_name("F-flexible-perfect").unwrap().bushings[0].clone());
    let text = format!("{}", lash_scenario::validate(&s));
    assert!(text.contains("bushings[0].joint") && text.contains("has a clearance"), "{text}");
    let mut s = builtin::by_name("F-flexible-imperfect").unwrap();
    s.clearances[0].bearing_material = Some("bronze".into());
    s.clearances[0].bush.as_mut().unwrap().inner_radius = 0.0105;
    let text = format!("{}", lash_scenario::validate(&s));
    assert!(text.contains("clearances[0].bearing_material") && text.contains("bush's"), "{text}");
    assert!(text.contains("clearances[0].bush.inner_radius") && text.contains("bearing radius"), "{text}");
    // Clearance joints and bushings in one reduced model: not yet, and said so.
    let mut s = builtin::by_name("F").unwrap();
    let mut bushing = builtin::by_name("F-flexible-perfect").unwrap().bushings[0].clone();
    bushing.joint = "crank_rod".into();
    bushing.bush.as_mut().unwrap().length = 0.03;
    s.bushings.push(bushing);
    assert!(lash_scenario::validate(&s).is_empty(), "{}", lash_scenario::validate(&s));
    let e = lash_run::ReducedRun::new(&s, lash_run::ReducedOptions::default()).err().unwrap();
    assert!(e.to_string().contains("not both"), "{e}");
}

/// A bushing scenario exports all three models as FMUs (FMI 3.0 and 2.0): the full model, the
/// mechanism with the bushing as an ideal joint, and the interface with the bushing as its micro
/// joint; lash's own checker instantiates and steps each.
#[test]
fn a_bushing_scenario_packs_its_fmus() {
    let out = std::env::temp_dir().join(format!("lash-bushing-fmu-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let lash =
        |args: &[&std::ffi::OsStr]| std::process::Command::new(env!("CARGO_BIN_EXE_lash")).args(args).output().unwrap();
    let o = lash(&["fmu".as_ref(), "pack".as_ref(), "F-flexible-perfect".as_ref(), "--out".as_ref(), out.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut files: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    files.sort();
    assert_eq!(
        files,
        [
            "lash_full-fmi2.fmu",
            "lash_full.fmu",
            "lash_interface-fmi2.fmu",
            "lash_interface.fmu",
            "lash_mechanism-fmi2.fmu",
            "lash_mechanism.fmu"
        ]
    );
    for f in ["lash_interface.fmu", "lash_interface-fmi2.fmu", "lash_mechanism.fmu"] {
        let o = lash(&["fmu".as_ref(), "check".as_ref(), out.join(f).as_os_str()]);
        assert!(o.status.success(), "{f}: {}", String::from_utf8_lossy(&o.stderr));
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// The reduced model of a bushing without clearance (the bush as the micro joint, the mechanism
/// with an ideal joint there) against the converged full model of F-flexible-perfect. Without a
/// clearance the response is not chaotic, so it is compared point by point, and it converges with
/// the macro step: at 3000 rpm a 1 ms macro step is 20 steps per revolution, and the linear
/// interpolation of f̃ across it cuts the load's harmonics by a few per cent; at 0.2 ms the
/// forces and the slider's acceleration agree to a fraction of a per cent (both models start with
/// the bush at its quasi-static deflection, so neither rings from the start).
#[test]
fn the_reduced_model_of_a_bushing_converges_to_the_full_model() {
    let s = builtin::by_name("F-flexible-perfect").unwrap();
    let (_, hf, rf) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut errors = Vec::new();
    for macro_step in [1e-3, 2e-4] {
        let options = lash_run::ReducedOptions { macro_step, ..Default::default() };
        let (summary, hr, rr) = rows(&mut lash_run::ReducedRun::new(&s, options).unwrap());
        assert!(summary.clearances.is_empty() && summary.reduced.is_some());
        assert_eq!(rf.len(), rr.len());
        let mut row = Vec::new();
        for name in ["motor.torque", "rod_slider.force", "slider.ax"] {
            let (f, r) = (series(&hf, &rf, name), series(&hr, &rr, name));
            let error: Vec<f64> = f.iter().zip(&r).map(|(a, b)| a - b).collect();
            let (e, dr, dp) = (rms(&error) / rms(&f), rms(&r) / rms(&f) - 1.0, peak(&r) / peak(&f) - 1.0);
            eprintln!(
                "h_m = {macro_step:e}, {name}: pointwise RMS error {e:.4} of the RMS, RMS {dr:+.4}, peak {dp:+.4}"
            );
            row.push((e, dr, dp));
        }
        // The bush's deflection starts on the full model's quasi-static one.
        let (f, r) = (series(&hf, &rf, "rod_slider.deflection"), series(&hr, &rr, "rod_slider.deflection"));
        assert!((r[0] - f[0]).abs() < 1e-3 * f[0], "initial deflection {} against {}", r[0], f[0]);
        errors.push(row);
    }
    let (coarse, fine) = (&errors[0], &errors[1]);
    for (k, name) in ["motor.torque", "rod_slider.force", "slider.ax"].iter().enumerate() {
        assert!(fine[k].0 < 0.01 && fine[k].1.abs() < 0.005 && fine[k].2.abs() < 0.005, "{name}: {:?}", fine[k]);
        assert!(coarse[k].0 > 2.0 * fine[k].0, "{name}: no convergence with the macro step");
    }
}

/// A clearance with a bush writes the interface's von Mises stress: the Hertz stress of its normal
/// force with the bush's FE correction, zero without contact, in the full and the reduced model.
#[test]
fn the_interface_stress_channel_follows_the_normal_force() {
    let mut s = builtin::by_name("F-flexible-imperfect").unwrap();
    s.simulation.horizon = 0.02;
    let model = lash_bush::InterfaceStress::of(s.clearances[0].bush.as_ref().unwrap()).unwrap();
    let (_, h, r) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let (stress, normal) = (series(&h, &r, "rod_slider.von_mises"), series(&h, &r, "rod_slider.normal_force"));
    assert!(normal.iter().any(|f| *f > 1e4), "impacts in the run");
    for (s, f) in stress.iter().zip(&normal) {
        assert_eq!(*s, model.von_mises(*f));
        assert_eq!(*s == 0.0, *f == 0.0);
    }
    let (_, h, r) = rows(&mut lash_run::ReducedRun::new(&s, lash_run::ReducedOptions::default()).unwrap());
    let (stress, normal) = (series(&h, &r, "rod_slider.von_mises"), series(&h, &r, "rod_slider.normal_force"));
    assert!(stress.iter().zip(&normal).all(|(s, f)| *s == model.von_mises(*f)));
    assert!(stress.iter().any(|s| *s > 1e8));
}

/// The reduced interface model of F's flexible imperfect joint (the micro subsystem evaluates the
/// contact in series with the bush) against the converged full model, over revolutions 2 and 3:
/// robust statistics within stated bounds (the rattling is chaotic: pointwise comparison is
/// meaningless), spectra, and the peaks of this one run within 15 %. Measured: mean joint force
/// −1.4 %, peak +5.8 %, peak torque +1.6 %, RMS torque −3.3 %, RMS slider a_x +0.6 %, contact
/// fraction −0.1 %; power below 500 Hz −6.5 % (torque), −2.2 % (a_x); torque spectral distance 0.17.
#[test]
fn the_reduced_model_of_the_flexible_imperfect_joint_meets_its_bounds() {
    let s = builtin::by_name("F-flexible-imperfect").unwrap();
    let c = reduced_meets_its_bounds(&s);
    let (full_summary, reduced_summary) = (&c.full, &c.reduced);
    for (what, (full, reduced)) in [("joint force", c.peak_force), ("crank torque", c.peak_torque)] {
        eprintln!("peak {what}: full {full:.0}, reduced {reduced:.0}");
        assert!((reduced / full - 1.0).abs() <= 0.15, "peak {what} {reduced} against {full}");
    }
    assert!(c.torque_spectral_distance <= 0.3, "crank torque's spectral distance {}", c.torque_spectral_distance);
    // The bronze bush's viscosities (c/k = 8 ns) are too fast for a state: both models say so.
    for summary in [full_summary, reduced_summary] {
        assert!(
            summary.warnings.iter().any(|w| w.contains("rod_slider") && w.contains("leaves out of the series")),
            "{:?}",
            summary.warnings
        );
    }
    assert!(
        rows(&mut FullRun::new(&builtin::by_name("F").unwrap(), BuildOptions::default())).0.warnings.is_empty(),
        "a rigid bearing has no bush to warn about"
    );
}

/// The same with a bush damped in series (20 GPa, its deflection a state of both models,
/// integrated by the micro RK4 with the eccentricity), over five relaxation times c/k from 15 to
/// 100 µs: each run within the bounds above, and the peak joint force — which scatters by ±15 %
/// from run to run in either model (full 66–92 kN here, across relaxation times that hardly move
/// the statistics) — and the peak crank torque compared as means over the five runs, within 10 %.
/// Measured: joint force 82.3 kN (full) and 84.3 kN (reduced), +2.4 %; torque 10 899 and
/// 10 948 N m, +0.4 %.
#[test]
fn the_reduced_model_of_a_bush_damped_in_series_meets_the_same_bounds() {
    let relaxation_times = [1.5e-5, 2e-5, 3e-5, 5e-5, 1e-4];
    let mut means = [[0.0; 2]; 2]; // [force, torque] × [full, reduced]
    for tau in relaxation_times {
        let c = reduced_meets_its_bounds(&damped_bush(20e9, tau, 0.06));
        for summary in [&c.full, &c.reduced] {
            assert!(summary.warnings.is_empty(), "{:?}", summary.warnings);
        }
        assert!(c.torque_spectral_distance <= 0.3, "crank torque's spectral distance {}", c.torque_spectral_distance);
        for (mean, peaks) in means.iter_mut().zip([c.peak_force, c.peak_torque]) {
            mean[0] += peaks.0 / relaxation_times.len() as f64;
            mean[1] += peaks.1 / relaxation_times.len() as f64;
        }
    }
    for (what, [full, reduced]) in ["joint force", "crank torque"].iter().zip(means) {
        eprintln!("mean peak {what}: full {full:.0}, reduced {reduced:.0}");
        assert!((reduced / full - 1.0).abs() <= 0.10, "mean peak {what} {reduced} against {full}");
    }
}

/// Scenario `s` in the reduced and the converged full model, compared over revolutions 2 and 3:
/// the mean joint force within 5 %, the RMS crank torque and slider acceleration within 10 %, the
/// contact fraction within 5 %. The peak joint force, a single sample of a chaotic impact train,
/// is returned for the caller to judge.
fn reduced_meets_its_bounds(s: &lash_scenario::Scenario) -> Compared {
    let (full_summary, hf, rf) = rows(&mut FullRun::new(s, BuildOptions::default()));
    let (reduced_summary, hr, rr) =
        rows(&mut lash_run::ReducedRun::new(s, lash_run::ReducedOptions::default()).unwrap());
    let window = |h: &[String], r: &[Vec<f64>], name: &str| -> Vec<f64> {
        let k = column(h, name);
        r.iter().filter(|row| row[0] >= 0.02).map(|row| row[k]).collect()
    };
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let relative = |a: f64, b: f64| (b / a - 1.0).abs();
    let (ff, fr) = (window(&hf, &rf, "rod_slider.force"), window(&hr, &rr, "rod_slider.force"));
    let (tf, tr) = (window(&hf, &rf, "motor.torque"), window(&hr, &rr, "motor.torque"));
    let (af, ar) = (window(&hf, &rf, "slider.ax"), window(&hr, &rr, "slider.ax"));
    let checks = [
        ("mean joint force", relative(mean(&ff), mean(&fr)), 0.05),
        ("RMS crank torque", relative(rms(&tf), rms(&tr)), 0.10),
        ("RMS slider a_x", relative(rms(&af), rms(&ar)), 0.10),
        (
            "contact fraction",
            relative(full_summary.clearances[0].contact_fraction, reduced_summary.clearances[0].contact_fraction),
            0.05,
        ),
    ];
    for (what, difference, bound) in checks {
        eprintln!("{what}: {:.1} % (bound {:.0} %)", 100.0 * difference, 100.0 * bound);
        assert!(difference <= bound, "{what}: {difference} > {bound}");
    }
    // Spectra (Hann-windowed amplitude spectra of revolutions 2 and 3): the power below 500 Hz
    // (the crank's first ten harmonics) within 10 %, and the spectral distance.
    let rows_after = |r: &[Vec<f64>]| r.iter().filter(|row| row[0] >= 0.02).cloned().collect::<Vec<_>>();
    let channels: Vec<String> = ["motor.torque", "slider.ax", "rod_slider.force"].map(String::from).to_vec();
    let spectra = lash_metrics::compare_series(&hf, &rows_after(&rf), &hr, &rows_after(&rr), &channels, 0.01).unwrap();
    let mut distances = Vec::new();
    for (name, c) in &spectra {
        let low = c.band_powers_reduced[0] / c.band_powers_full[0];
        eprintln!("{name}: power below 500 Hz ratio {low:.3}, spectral distance {:.3}", c.spectral_distance);
        assert!((low - 1.0).abs() <= 0.10, "{name}: power below 500 Hz, ratio {low:.3}");
        distances.push(c.spectral_distance);
    }
    Compared {
        full: full_summary,
        reduced: reduced_summary,
        peak_force: (peak(&ff), peak(&fr)),
        peak_torque: (peak(&tf), peak(&tr)),
        torque_spectral_distance: spectra["motor.torque"].spectral_distance,
    }
}

/// Both models' summaries and their peak joint forces over revolutions 2 and 3.
struct Compared {
    full: lash_run::Summary,
    reduced: lash_run::Summary,
    /// (full, reduced) \[N\].
    peak_force: (f64, f64),
    /// Peak crank torques (full, reduced) [N m].
    peak_torque: (f64, f64),
    /// The spectral distance of the crank torque (relative RMS difference of the amplitude
    /// spectra).
    torque_spectral_distance: f64,
}

/// A bushing whose radial force follows a curve (power laws between its points): a block hanging
/// from it whose weight is one of the curve's forces starts and stays at that point's deflection,
/// and the bush carries the weight; between points the static deflection is the power law's.
#[test]
fn a_body_on_a_curved_bushing_rests_at_the_curves_deflection() {
    let curve = "damping = 50.0\ncurve = { deflections = [1e-6, 3e-6, 8e-6], forces = [5.0, 19.62, 80.0] }";
    let text = |mass: f64| hanging(mass, curve);
    // 2 kg: m g = 19.62 N, the curve's second point (3 µm). 5 kg: m g = 49.05 N, on the power law
    // between 3 and 8 µm: u = 3e-6 (49.05/19.62)^(1/p), p = ln(80/19.62)/ln(8/3).
    let p = (80.0f64 / 19.62).ln() / (8.0f64 / 3.0).ln();
    for (mass, expected) in [(2.0, 3e-6), (5.0, 3e-6 * (5.0f64 * 9.81 / 19.62).powf(1.0 / p))] {
        let s = lash_scenario::parse(&text(mass)).unwrap();
        let (_, header, rows) = rows(&mut FullRun::new(&s, BuildOptions::default()));
        let (y, force, deflection) =
            (column(&header, "block.y"), column(&header, "pin.force"), column(&header, "pin.deflection"));
        for r in &rows {
            assert!((r[y] + expected).abs() < 1e-9 * expected, "{mass} kg, t = {}: y = {}", r[0], r[y]);
            assert!((r[deflection] / expected - 1.0).abs() < 1e-9, "{mass} kg: {}", r[deflection]);
            assert!((r[force] / (mass * 9.81) - 1.0).abs() < 1e-9, "{mass} kg, t = {}: {}", r[0], r[force]);
        }
    }
    // The reduced model (the bushing as its micro joint, the same curve): it starts settled on the
    // curve and stays there.
    for (mass, expected) in [(2.0, 3e-6), (5.0, 3e-6 * (5.0f64 * 9.81 / 19.62).powf(1.0 / p))] {
        let s = lash_scenario::parse(&text(mass)).unwrap();
        let (_, header, rows) = rows(&mut lash_run::ReducedRun::new(&s, lash_run::ReducedOptions::default()).unwrap());
        let (force, deflection) = (column(&header, "pin.force"), column(&header, "pin.deflection"));
        for r in &rows {
            assert!((r[deflection] / expected - 1.0).abs() < 1e-9, "reduced, {mass} kg: {}", r[deflection]);
            assert!((r[force] / (mass * 9.81) - 1.0).abs() < 1e-9, "reduced, {mass} kg, t = {}: {}", r[0], r[force]);
        }
    }
    // A curve with a stiffness too, or decreasing points: the field is named.
    let bad = text(2.0).replace("damping = 50.0", "stiffness = 1e6").replace("80.0]", "10.0]");
    let e = lash_scenario::parse(&bad).unwrap_err().to_string();
    assert!(e.contains("bushings[0].curve") && e.contains("give one of stiffness, bush or curve"), "{e}");
    assert!(e.contains("bushings[0].curve.forces") && e.contains("increasing"), "{e}");
}

/// F-flexible-imperfect with its bush's modulus `modulus` \[Pa\] and viscosities scaled so that c/k = `relaxation` \[s\], over
/// `horizon` \[s\].
fn damped_bush(modulus: f64, relaxation: f64, horizon: f64) -> lash_scenario::Scenario {
    let mut s = builtin::by_name("F-flexible-imperfect").unwrap();
    s.simulation.horizon = horizon;
    let bush = s.clearances[0].bush.as_mut().unwrap();
    bush.material.young_modulus = modulus;
    let b = lash_bush::bonded_pin(bush).unwrap();
    let scale = relaxation / (b.damping / b.stiffness);
    bush.material.shear_viscosity *= scale;
    bush.material.bulk_viscosity *= scale;
    s
}

/// A bush whose relaxation time c/k reaches 1e-7 s carries its damping in series with the contact
/// as a state (no warning), and the reduced model refuses one faster than its micro step. Across
/// that threshold the first impact of a 20 GPa bush hardly changes (the loss factor the
/// quasi-static bush leaves out is under 2 %); a slow bush (c/k = 20 µs) changes it several times
/// more (by under 1 %: damping in series does not soften an impact much; docs/validation.md).
#[test]
fn a_bush_damped_in_series_is_a_state_of_the_full_model() {
    let first_peak = |relaxation: f64| {
        let s = damped_bush(20e9, relaxation, 0.0015);
        let (summary, _, _) = rows(&mut FullRun::new(&s, BuildOptions::default()));
        let series_warning = summary.warnings.iter().any(|w| w.contains("leaves out of the series"));
        (summary.clearances[0].first_impacts[0].peak_force, series_warning)
    };
    let (below, warned_below) = first_peak(0.9e-7);
    let (above, warned_above) = first_peak(1.1e-7);
    let (slow, warned_slow) = first_peak(2e-5);
    assert!(warned_below && !warned_above && !warned_slow);
    // Measured (20 GPa): 213 645 → 213 865 N across the threshold, 212 118 N at 20 µs.
    let across = (above / below - 1.0).abs();
    assert!(across < 0.01, "first impact's peak across the threshold: {below} → {above}");
    assert!((slow / below - 1.0).abs() > 3.0 * across, "a slow bush changes the first impact: {slow} against {below}");
    // The reduced model integrates the deflection with its micro RK4: a bush relaxing faster than
    // the micro step is refused by name.
    let e = lash_run::ReducedRun::new(&damped_bush(110e9, 5e-6, 0.06), lash_run::ReducedOptions::default()).err();
    let e = e.expect("refused").to_string();
    assert!(e.contains("rod_slider") && e.contains("micro_step") && e.contains("5.00e-6"), "{e}");
}
