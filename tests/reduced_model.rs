//! The reduced interface model (one-way coupling) against the converged full model, and the
//! zero-order-hold trap (holding M̃ and f̃ over a macro step produces spurious impacts).

use lash_orchestrate::Interpolation;
mod common;
use common::{column, rows};
use lash_run::{BuildOptions, FullRun, ReducedOptions, ReducedRun};
use lash_scenario::builtin;

#[test]
fn small_clearance_reduced_matches_full_within_three_percent() {
    // c = 0.02 mm: continuous contact after the first turn's transient. Compared over turns 2–3.
    let s = builtin::by_name("B-0.02mm").unwrap();
    let (_, hf, full) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let (summary, hr, red) = rows(&mut ReducedRun::new(&s, ReducedOptions::default()).unwrap());
    assert_eq!(summary.model, "reduced");
    assert_eq!(full.len(), red.len());
    let start = full.len() / 3;
    for name in ["slider.ax", "rod_slider.normal_force"] {
        let (kf, kr) = (column(&hf, name), column(&hr, name));
        let peak = |rows: &[Vec<f64>], k: usize| rows[start..].iter().map(|r| r[k].abs()).fold(0.0, f64::max);
        let (pf, pr) = (peak(&full, kf), peak(&red, kr));
        let (mut e2, mut r2) = (0.0, 0.0);
        for (a, b) in full[start..].iter().zip(&red[start..]) {
            assert!((a[0] - b[0]).abs() < 1e-12, "sample times {} vs {}", a[0], b[0]);
            e2 += (a[kf] - b[kr]).powi(2);
            r2 += a[kf].powi(2);
        }
        eprintln!("{name}: peak full {pf:.1}, reduced {pr:.1}; pointwise relative RMS error {:.3}", (e2 / r2).sqrt());
        assert!((pr / pf - 1.0).abs() < 0.03, "{name}: peak {pr} vs {pf}");
    }
}

#[test]
fn zero_order_hold_makes_spurious_impacts_that_interpolation_does_not() {
    let s = builtin::by_name("B-0.02mm").unwrap();
    let impacts_after = |interpolation| {
        // h_r = 1e-6 s keeps the fixed-step micro model stable under the held (jumping) terms.
        let options = ReducedOptions { micro_step: 1e-6, interpolation, ..Default::default() };
        let (summary, _, _) = rows(&mut ReducedRun::new(&s, options).unwrap());
        let c = &summary.clearances[0];
        (c.impacts, c.first_impacts.iter().filter(|i| i.onset_time > 0.004).count())
    };
    let (linear_total, linear_late) = impacts_after(Interpolation::Linear);
    let (zoh_total, zoh_late) = impacts_after(Interpolation::ZeroOrderHold);
    eprintln!(
        "impacts: linear {linear_total} ({linear_late} after 4 ms), zero-order hold {zoh_total} ({zoh_late} after 4 ms)"
    );
    assert_eq!(linear_late, 0, "interpolated terms: only the start-up transient has impacts");
    assert!(zoh_total >= linear_total + 30, "held terms: spurious impacts expected");
    assert!(zoh_late >= 1);
}

#[test]
fn unsupported_scenarios_are_refused_clearly() {
    let mut s = builtin::by_name("B").unwrap();
    s.clearances.clear();
    let e = ReducedRun::new(&s, ReducedOptions::default()).err().expect("no clearance joint: nothing to reduce");
    assert!(e.to_string().contains("1 to 6 clearance joints; the scenario has 0"), "{e}");
    let s = builtin::by_name("B").unwrap();
    let e = ReducedRun::new(&s, ReducedOptions { micro_step: 3e-5, ..Default::default() }).err().unwrap();
    assert!(e.to_string().contains("whole multiple"), "{e}");
    // A guide beside a revolute clearance joint: two micro models of different kinds.
    let mut s = builtin::by_name("G").unwrap();
    s.clearances = builtin::by_name("B").unwrap().clearances;
    let e = ReducedRun::new(&s, ReducedOptions::default()).err().expect("a guide and a clearance joint");
    assert!(e.to_string().contains("one translational clearance joint alone (guide \"slider_guide\")"), "{e}");
    // The error-controlled micro model does not locate a corner's events yet.
    let s = builtin::by_name("G").unwrap();
    let e = ReducedRun::new(&s, ReducedOptions { error_controlled_micro: true, ..Default::default() }).err().unwrap();
    assert!(e.to_string().contains("DOPRI5 micro integrator"), "{e}");
}

#[test]
fn two_clearance_joints_reduced_against_full() {
    // Scenario C: clearances at the crank–ground and rod–slider joints, coupled through the
    // mechanism (4 × 4 effective mass). Chaotic impact response: compared by peaks and impact
    // counts over the whole run, not pointwise.
    let s = builtin::by_name("C").unwrap();
    let (full_summary, hf, full) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let (summary, hr, red) = rows(&mut ReducedRun::new(&s, ReducedOptions::default()).unwrap());
    assert_eq!(summary.clearances.len(), 2);
    for name in ["slider.ax", "crank_pivot.force", "rod_slider.force"] {
        let (kf, kr) = (column(&hf, name), column(&hr, name));
        let peak = |rows: &[Vec<f64>], k: usize| rows.iter().map(|r| r[k].abs()).fold(0.0, f64::max);
        let (pf, pr) = (peak(&full, kf), peak(&red, kr));
        eprintln!("{name}: peak full {pf:.4e}, reduced {pr:.4e} ({:+.1} %)", (pr / pf - 1.0) * 100.0);
        assert!((pr / pf - 1.0).abs() < 0.10, "{name}: peak {pr} vs {pf}");
    }
    // Robust statistics and spectra (Hann-windowed amplitude spectra of the whole run): RMS within
    // 15 % and the power of the band below 500 Hz (over 80 % of every channel's power) within
    // 15 %; the spectral distance of the slider acceleration below 0.5. The bands above 500 Hz are
    // printed, not bounded: the reduced model puts 2–7× the full model's power there on C (half
    // of it on A), which refining h_r and h_m shrinks but does not remove (docs/validation.md §6).
    let channels: Vec<String> = ["slider.ax", "crank_pivot.force", "rod_slider.force"].map(String::from).to_vec();
    let compared = lash_metrics::compare_series(&hf, &full, &hr, &red, &channels, 0.01).unwrap();
    for (name, c) in &compared {
        let total: f64 = c.band_powers_full.iter().sum();
        let ratios: Vec<String> =
            c.band_powers_full.iter().zip(&c.band_powers_reduced).map(|(f, r)| format!("{:.2}", r / f)).collect();
        eprintln!(
            "{name}: RMS full {:.4e}, reduced {:.4e} ({:+.1} %); spectral distance {:.2}; band power ratios {ratios:?}",
            c.rms_full,
            c.rms_reduced,
            (c.rms_reduced / c.rms_full - 1.0) * 100.0,
            c.spectral_distance,
        );
        assert!((c.rms_reduced / c.rms_full - 1.0).abs() < 0.15, "{name}: RMS");
        assert!(c.band_powers_full[0] > 0.8 * total, "{name}: the low band dominates");
        let low = c.band_powers_reduced[0] / c.band_powers_full[0];
        assert!((low - 1.0).abs() < 0.15, "{name}: power below 500 Hz, ratio {low:.2}");
    }
    assert!(compared["slider.ax"].spectral_distance < 0.5);
    for (f, r) in full_summary.clearances.iter().zip(&summary.clearances) {
        eprintln!("{}: impacts full {}, reduced {}", f.name, f.impacts, r.impacts);
        assert_eq!(f.name, r.name);
        assert!(r.impacts * 2 >= f.impacts && r.impacts <= 2 * f.impacts, "{}: impacts", f.name);
    }
}

#[test]
fn runs_executed_together_equal_each_run_alone() {
    // Nineteen reduced runs of A, differing in clearance, restitution, friction and crank speed:
    // eight with Ambrósio friction and eight without (each eight stepped in vector lanes), one
    // with Coulomb friction (the only one of its kind: stepped alone), two with laws the lanes do
    // not take (alone in the same group); their macro steps analysed in lanes, eight at a time.
    // Every run's rows and summary (but for its times) must be what it gives run alone, bit for
    // bit.
    use lash_contact::{ContactLaw, FrictionLaw};
    let base = builtin::by_name("A").unwrap();
    let mut scenarios = Vec::new();
    for k in 0..19 {
        let mut s = base.clone();
        s.simulation.horizon = 0.06;
        if let lash_mech::Motion::ConstantSpeed { omega, .. } = &mut s.drivers[0].motion {
            *omega *= 0.9 + 0.013 * k as f64;
        }
        let c = &mut s.clearances[0];
        c.journal_radius = c.bearing_radius - (0.05e-3 + 0.02e-3 * k as f64);
        if let ContactLaw::LankaraniNikravesh(p) = &mut c.contact {
            p.restitution = 0.5 + 0.02 * k as f64;
        }
        c.friction = match k {
            0..8 => FrictionLaw::Ambrosio { coefficient: 0.02 * (k + 1) as f64, v0: 1e-4, v1: 1e-3 },
            16 => FrictionLaw::Coulomb { coefficient: 0.05 },
            _ => FrictionLaw::None,
        };
        if k == 17 {
            c.contact = ContactLaw::KelvinVoigt { stiffness: 1e8, damping: 1e3 };
        }
        if k == 18
            && let ContactLaw::LankaraniNikravesh(p) = &mut c.contact
        {
            p.exponent = 1.3;
        }
        scenarios.push(lash_scenario::AnyScenario::Planar(s));
    }
    let impacts = together_against_alone(&scenarios);
    assert!(impacts > 20, "the runs have impacts to compare ({impacts})");
}

#[test]
fn spatial_runs_executed_together_equal_each_run_alone() {
    // Seventeen reduced runs of E (two spherical clearance joints), differing in the clearance of
    // each joint and the crank speed: nine with ADAMS stick–slip friction (eight stepped in
    // vector lanes, one alone) and eight frictionless (stepped in lanes). Every run's rows and
    // summary (but for its times) must be what it gives run alone, bit for bit.
    let mut scenarios = Vec::new();
    for k in 0..17 {
        let x = k as f64;
        let mut s = lash_scenario::builtin_spatial::scenario_e(0.25e-3 + 0.02e-3 * x, 60.0 + 10.0 * x, k % 2 == 0);
        s.simulation.horizon = 0.08;
        let c = &mut s.clearances[1];
        c.journal_radius = c.bearing_radius - (0.1e-3 + 0.03e-3 * x);
        scenarios.push(lash_scenario::AnyScenario::Spatial(s));
    }
    let impacts = together_against_alone(&scenarios);
    assert!(impacts > 20, "the runs have impacts to compare ({impacts})");
}

/// Runs the reduced models of `scenarios` together ([`lash_run::execute_together`]) and each
/// alone, asserts that each run's rows and summary (but for its times) are the same bit for bit,
/// and returns their impacts.
fn together_against_alone(scenarios: &[lash_scenario::AnyScenario]) -> usize {
    let model = lash_run::Model::Reduced(ReducedOptions::default());
    // Without the run's times (the group's, shared).
    let comparable = |s: &lash_run::Summary| {
        let mut v = serde_json::to_value(s).unwrap();
        v["cpu_time_s"] = 0.into();
        v["wall_time_s"] = 0.into();
        v["reduced"]["master"]["macro_seconds"] = 0.into();
        v["reduced"]["master"]["micro_seconds"] = 0.into();
        v
    };
    let alone: Vec<_> = scenarios
        .iter()
        .map(|s| {
            let mut runner = lash_run::runner(s, model).unwrap();
            let (summary, _, rows) = rows(&mut runner);
            (comparable(&summary), rows)
        })
        .collect();
    let mut runners: Vec<_> = scenarios.iter().map(|s| lash_run::runner(s, model).unwrap()).collect();
    let mut together: Vec<Vec<Vec<f64>>> = vec![Vec::new(); runners.len()];
    let mut sinks: Vec<_> = together
        .iter_mut()
        .map(|rows| {
            move |r: &[f64]| -> Result<(), lash_core::BoxError> {
                rows.push(r.to_vec());
                Ok(())
            }
        })
        .collect();
    let summaries =
        lash_run::execute_together(&mut runners, sinks.iter_mut().map(|s| s as lash_run::Sink<'_>).collect());
    drop(sinks);
    let mut impacts = 0;
    for (k, ((summary, rows), (expected, expected_rows))) in
        summaries.into_iter().zip(&together).zip(&alone).enumerate()
    {
        let summary = summary.unwrap();
        impacts += summary.clearances.iter().map(|c| c.impacts).sum::<usize>();
        assert_eq!(rows.len(), expected_rows.len(), "run {k}: rows");
        for (a, b) in rows.iter().zip(expected_rows) {
            assert!(
                a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "run {k} at t = {}: {a:?} vs {b:?}",
                a[0]
            );
        }
        assert!(&comparable(&summary) == expected, "run {k}: the summary differs from the run's alone");
    }
    impacts
}

/// A run that computes its channels only (as a sweep's runs do) writes the same rows, bit for bit,
/// as a run that also keeps statistics and the clearance summary, and its summary says it kept
/// neither.
#[test]
fn channels_only_writes_the_same_rows_and_no_statistics() {
    let mut s = builtin::by_name("A").unwrap();
    s.simulation.horizon = 0.02;
    s.output.channels = vec!["slider.ax".into(), "crank_pivot.normal_force".into()];
    let run =
        |channels_only| rows(&mut ReducedRun::new(&s, ReducedOptions { channels_only, ..Default::default() }).unwrap());
    let (full_summary, header, all) = run(false);
    let (lean_summary, lean_header, lean) = run(true);
    assert_eq!(header, lean_header);
    assert_eq!(all.len(), lean.len());
    assert!(all.len() > 100);
    for (a, b) in all.iter().zip(&lean) {
        assert_eq!(
            a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
    assert!(!full_summary.channels.is_empty() && !full_summary.clearances.is_empty());
    assert!(full_summary.clearances[0].impacts > 0, "the 20 ms should hold impacts");
    assert!(lean_summary.channels.is_empty() && lean_summary.clearances.is_empty());
    assert_eq!(lean_summary.samples, full_summary.samples);
}

/// Scenario G (a block in a guide with 1 mm play either side, free motion, 0.2 s): the reduced
/// model — the guide's interface the prismatic joint's rows, the corners a micro joint of four
/// contacts — against the converged full model. One-way at its default steps: the same impacts
/// at each corner (±1), their peak normal forces within 2 % and median contact durations within
/// 2 %, and over the steady window (t ≥ 0.05 s) the RMS levels of the slider's lateral
/// acceleration, the guide's lateral force and the block's offset within 3 %. Two-way coupling
/// meets the same RMS bound once its macro step is short against the corners' 0.2 ms contacts
/// (h_m = 1e-4 s; at the default 1e-3 s its correction, prescribed over a step that holds whole
/// impacts, takes a third off the lateral acceleration).
#[test]
fn a_translational_clearance_joint_reduced_against_full() {
    let s = builtin::by_name("G").unwrap();
    let (full_summary, hf, full) = rows(&mut FullRun::new(&s, BuildOptions::default()));
    let rms = |header: &[String], rows: &[Vec<f64>], name: &str| {
        let k = column(header, name);
        let steady: Vec<f64> = rows.iter().filter(|r| r[0] >= 0.05).map(|r| r[k]).collect();
        (steady.iter().map(|v| v * v).sum::<f64>() / steady.len() as f64).sqrt()
    };
    let channels = ["slider.ay", "slider_guide.fy", "slider_guide.offset"];
    let compare = |options: ReducedOptions, contacts: bool| {
        let (summary, hr, red) = rows(&mut ReducedRun::new(&s, options).unwrap());
        assert_eq!(full.len(), red.len());
        for name in channels {
            let (f, r) = (rms(&hf, &full, name), rms(&hr, &red, name));
            eprintln!("{name} RMS: full {f:.4e}, reduced {r:.4e} ({options:?})");
            assert!((r / f - 1.0).abs() < 0.03, "{name}: RMS {r} vs {f}");
        }
        if !contacts {
            return;
        }
        assert_eq!(summary.clearances.len(), 4, "one contact per corner");
        for (f, r) in full_summary.clearances.iter().zip(&summary.clearances) {
            assert_eq!(f.name, r.name);
            eprintln!(
                "{}: impacts {} / {}, peak {:.1} / {:.1} N",
                f.name, f.impacts, r.impacts, f.peak_normal_force, r.peak_normal_force
            );
            assert!(f.impacts.abs_diff(r.impacts) <= 1, "{}: {} vs {} impacts", f.name, r.impacts, f.impacts);
            assert!((r.peak_normal_force / f.peak_normal_force - 1.0).abs() < 0.02, "{}: peak", f.name);
            let (df, dr) = (f.median_impact_duration.unwrap(), r.median_impact_duration.unwrap());
            assert!((dr / df - 1.0).abs() < 0.02, "{}: contact {dr} s vs {df} s", f.name);
        }
    };
    compare(ReducedOptions::default(), true);
    compare(ReducedOptions { coupling: lash_core::Coupling::TwoWay, macro_step: 1e-4, ..Default::default() }, false);
}

/// A guide's joint anywhere in the joint list: its reduced run names every other joint's
/// reaction as when the guide's joint is last — the same rows, bit for bit.
#[test]
fn a_guide_anywhere_in_the_joint_list_gives_the_same_reduced_run() {
    let mut s = builtin::by_name("G-driven").unwrap();
    s.simulation.horizon = 0.02;
    s.output.channels = vec!["rod_slider.fx".into(), "crank_rod.fy".into(), "slider_guide.fy".into()];
    let (_, header, last) = rows(&mut ReducedRun::new(&s, ReducedOptions::default()).unwrap());
    let guide = s.joints.iter().position(|j| j.name == "slider_guide").unwrap();
    let joint = s.joints.remove(guide);
    s.joints.insert(0, joint);
    let (_, moved_header, first) = rows(&mut ReducedRun::new(&s, ReducedOptions::default()).unwrap());
    assert_eq!(header, moved_header);
    assert_eq!(last, first, "the guide's place in the joint list changes nothing");
    assert!(last.iter().any(|r| r[1].abs() > 1.0), "the rod–slider reaction is there");
}
