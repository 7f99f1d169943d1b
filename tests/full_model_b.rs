//! Scenario B end to end through the library: convergence of the first impacts, constraint drift,
//! the ideal mechanism against closed form, and the clearance → 0 limit.

use lash_contact::Impact;
use lash_ode::{AdaptiveOptions, Method};
mod common;
use common::{column, rows};
use lash_run::{BuildOptions, FullRun, Summary};
use lash_scenario::builtin;

const L1: f64 = builtin::CRANK_LENGTH;
const L2: f64 = builtin::ROD_LENGTH;
const OMEGA: f64 = builtin::CRANK_SPEED;

/// Runs a scenario, keeping every row.
fn run(s: &lash_scenario::Scenario, ideal: bool) -> (Summary, Vec<String>, Vec<Vec<f64>>) {
    rows(&mut FullRun::new(s, BuildOptions { ideal }))
}

fn tight(rtol: f64) -> AdaptiveOptions {
    AdaptiveOptions { rtol, atol: rtol * 1e-3, initial_step: 1e-7, max_step: 1e-4, min_step: 1e-12 }
}

fn first_impacts(method: Method, horizon: f64) -> Vec<Impact> {
    let mut s = builtin::by_name("B").unwrap();
    s.simulation.integrator = method;
    s.simulation.horizon = horizon;
    s.simulation.output_interval = 1e-4;
    let (summary, _, _) = run(&s, false);
    summary.clearances[0].first_impacts.clone()
}

#[test]
fn first_three_impacts_converge() {
    // The default (converged) setting, DOP853 at rtol 1e-9, against DOP853 at rtol 1e-11 (a factor
    // 100 tighter); a second method, DOPRI5, at 1e-11 and at 1e-9; and fixed-step RK4 at 1e-7 s
    // (100× below the usual 1e-5 s), all against the same reference. The first three impacts of B
    // end before 1 ms. Tolerances: docs/validation.md (convergence study).
    let horizon = 1.0e-3;
    let a = first_impacts(builtin::converged_integrator(), horizon);
    let b = first_impacts(Method::Dop853(tight(1e-11)), horizon);
    let d = first_impacts(Method::Dopri5(tight(1e-11)), horizon);
    let e = first_impacts(Method::Dopri5(tight(1e-9)), horizon);
    let c = first_impacts(Method::Rk4 { step: 1e-7 }, horizon);
    assert!(b.len() >= 3, "B must show at least three impacts in its first millisecond, got {}", b.len());
    for (name, other, onset_tol, rel_tol) in [
        ("DOP853 rtol 1e-9", &a, 2e-10, 1e-5),
        ("DOPRI5 rtol 1e-11", &d, 2e-10, 1e-5),
        ("DOPRI5 rtol 1e-9", &e, 2e-10, 1e-5),
        ("RK4 1e-7", &c, 5e-9, 1e-3),
    ] {
        assert!(other.len() >= 3, "{name}: {} impacts", other.len());
        for k in 0..3 {
            let (x, r) = (&other[k], &b[k]);
            eprintln!(
                "{name} impact {k}: onset {:.9e} vs {:.9e}, peak {:.6e} vs {:.6e}, duration {:.6e} vs {:.6e}",
                x.onset_time, r.onset_time, x.peak_force, r.peak_force, x.duration, r.duration
            );
            assert!((x.onset_time - r.onset_time).abs() < onset_tol, "{name} impact {k} onset");
            assert!((x.peak_force / r.peak_force - 1.0).abs() < rel_tol, "{name} impact {k} peak force");
            assert!((x.duration / r.duration - 1.0).abs() < rel_tol, "{name} impact {k} duration");
        }
    }
}

#[test]
fn constraint_drift_stays_small_over_the_horizon() {
    let s = builtin::by_name("B").unwrap();
    let (summary, header, rows) = run(&s, false);
    let k = column(&header, "constraint_error");
    let worst = rows.iter().map(|r| r[k]).fold(0.0, f64::max);
    assert_eq!(worst, summary.max_constraint_error);
    assert!(worst < 1e-10, "max |Φ| = {worst} m over 0.036 s");
}

#[test]
fn ideal_run_matches_closed_form_at_dead_centres() {
    let s = builtin::by_name("B").unwrap();
    let (summary, header, rows) = run(&s, true);
    assert_eq!(summary.model, "ideal");
    let ax = column(&header, "slider.ax");
    let half_turn = (std::f64::consts::PI / OMEGA / 1e-5).round() as usize;
    for (i, expected) in [
        (0, -OMEGA * OMEGA * L1 * (1.0 + L1 / L2)),
        (half_turn, OMEGA * OMEGA * L1 * (1.0 - L1 / L2)),
        (2 * half_turn, -OMEGA * OMEGA * L1 * (1.0 + L1 / L2)),
    ] {
        // Sample i is at crank angle ω t_i, within float noise of 0, π or 2π.
        let t = rows[i][0];
        let angle = OMEGA * t;
        assert!((angle - std::f64::consts::PI * (i / half_turn) as f64).abs() < 1e-9);
        let got = rows[i][ax];
        assert!((got / expected - 1.0).abs() < 1e-8, "t = {t}: {got} vs {expected}");
    }
}

#[test]
fn vanishing_clearance_approaches_the_ideal_mechanism() {
    // c = 1 µm with the (stiff) Hertz-based Lankarani–Nikravesh law of B, no friction: after the
    // first turn the slider acceleration follows the ideal one.
    let mut s = builtin::scenario_b(1e-6);
    s.clearances[0].friction = lash_contact::FrictionLaw::None;
    let (_, header, rows) = run(&s, false);
    let (_, header_i, rows_i) = run(&s, true);
    let (a, ai) = (column(&header, "slider.ax"), column(&header_i, "slider.ax"));
    let start = rows.len() / 3;
    let (mut err2, mut ref2) = (0.0, 0.0);
    for (r, ri) in rows[start..].iter().zip(&rows_i[start..]) {
        assert_eq!(r[0], ri[0]);
        err2 += (r[a] - ri[ai]).powi(2);
        ref2 += ri[ai].powi(2);
    }
    let rel = (err2 / ref2).sqrt();
    eprintln!("relative RMS difference of slider acceleration at c = 1 µm: {rel:e}");
    assert!(rel < 0.02, "relative RMS difference {rel}");
}

/// A fixed step of five per contact is flagged (its peaks are 20 % off, validation.md), one of
/// ten per contact and the converged adaptive run are not; the flag names the joint and the step.
#[test]
fn a_fixed_step_too_coarse_for_the_contacts_is_flagged() {
    let warnings = |method: Method| {
        let mut s = builtin::by_name("B").unwrap();
        s.simulation.integrator = method;
        s.simulation.horizon = 0.01;
        s.simulation.output_interval = 1e-4;
        let (summary, _, _) = run(&s, false);
        assert!(summary.clearances[0].impacts >= 3, "{:?}", summary.clearances[0].impacts);
        summary.warnings
    };
    let coarse = warnings(Method::Rk4 { step: 1e-5 });
    assert_eq!(coarse.len(), 1, "{coarse:?}");
    assert!(coarse[0].contains("rod_slider") && coarse[0].contains("steps of 1e-5 s"), "{}", coarse[0]);
    assert!(warnings(Method::Rk4 { step: 5e-6 }).is_empty());
    assert!(warnings(Method::Dop853(tight(1e-9))).is_empty());
}
