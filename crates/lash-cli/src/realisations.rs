//! `lash compare --realisations N`: the stated bounds held against N converged realisations of
//! the full model instead of one. Where a pin rattles, the full model is a chaotic oscillator:
//! two converged runs — same start, a tolerance apart — part after some dozens of impacts, and a
//! statistic over a finite run (an RMS level, a band power, onsets per revolution) is one draw.
//! Realisation k (k = 1…N−1) is the scenario with the integrator's absolute tolerance moved up
//! by k rounding steps: converged as the first, and on another path once the motion is chaotic.
//! Each check then reads "met against m of N": against all, the bound holds whatever the draw;
//! against some, the reduced run lies where the full model's own draws lie; against none, it
//! misses.

use crate::CliError;
use lash_metrics as compare;
use lash_scenario::AnyScenario;

/// The scenario of realisation `k`: its adaptive integrator's atol `k` rounding steps up.
fn realisation(s: &AnyScenario, k: usize) -> Result<AnyScenario, CliError> {
    let mut r = s.clone();
    match &mut r.simulation_mut().integrator {
        lash_ode::Method::Dopri5(o) | lash_ode::Method::Dop853(o) => {
            for _ in 0..k {
                o.atol = o.atol.next_up();
            }
            Ok(r)
        }
        lash_ode::Method::Rk4 { .. } => Err(CliError::Input(
            "--realisations: the full model's integrator is fixed-step RK4 (simulation.integrator), whose runs do \
             not differ; give it dop853 or dopri5"
                .into(),
        )),
    }
}

/// The full model of `s` run in memory over the compared `channels`: header and rows.
fn full_rows(s: &AnyScenario, channels: &[String]) -> Result<(Vec<String>, Vec<Vec<f64>>), CliError> {
    let mut s = s.clone();
    s.output_mut().channels = channels.to_vec();
    s.output_mut().measurements.clear();
    let mut runner = lash_run::runner(&s, lash_run::Model::Full { ideal: false })
        .map_err(|e| CliError::Failure(format!("a realisation of the full model: {e}")))?;
    let header = runner.header();
    let mut rows = Vec::new();
    runner
        .execute(
            &mut |row: &[f64]| {
                rows.push(row.to_vec());
                Ok(())
            },
            &mut |_| {},
        )
        .map_err(|e| CliError::Failure(format!("a realisation of the full model: {e}")))?;
    Ok((header, rows))
}

/// The checks of `first` (the bounds against the written full run, as `bounds_check` gives them)
/// held against `count` − 1 more realisations of the full model of `s` too: per check its full
/// value and verdict in each realisation, and how many of them it meets.
pub(crate) fn check(
    s: &AnyScenario,
    count: usize,
    first: &serde_json::Value,
    reduced: (&[String], &[Vec<f64>]),
    roles: &[(String, compare::Role)],
    window: &compare::Window,
) -> Result<serde_json::Value, CliError> {
    let Some(first) = first["checks"].as_array() else {
        return Ok(serde_json::json!({ "count": count, "error": "the bounds were not checked" }));
    };
    let mut per_check: Vec<(Vec<f64>, Vec<bool>)> =
        first.iter().map(|c| (vec![c["full"].as_f64().unwrap_or(f64::NAN)], vec![c["met"] == true])).collect();
    let channels: Vec<String> = roles.iter().map(|(c, _)| c.clone()).collect();
    for k in 1..count {
        let (header, rows) = full_rows(&realisation(s, k)?, &channels)?;
        let n = rows.len().min(reduced.1.len());
        let checks =
            compare::check_bounds((&header, &rows[..n]), (reduced.0, &reduced.1[..n]), roles, window, &compare::STATED)
                .map_err(|e| CliError::Failure(format!("realisation {k}: {e}")))?;
        for ((values, met), c) in per_check.iter_mut().zip(&checks) {
            values.push(c.full);
            met.push(c.met);
        }
    }
    let checks: Vec<serde_json::Value> = first
        .iter()
        .zip(&per_check)
        .map(|(c, (full, met))| {
            serde_json::json!({
                "quantity": c["quantity"],
                "kind": c["kind"],
                "bound": c["bound"],
                "reduced": c["reduced"],
                "full": full,
                "met": met,
                "met_count": met.iter().filter(|m| **m).count(),
            })
        })
        .collect();
    let tally =
        |f: &dyn Fn(usize) -> bool| checks.iter().filter(|c| f(c["met_count"].as_u64().unwrap_or(0) as usize)).count();
    Ok(serde_json::json!({
        "count": count,
        "perturbation": "realisation k: the full model's atol moved up by k rounding steps (k = 0: the written run)",
        "met_against_all": tally(&|m| m == count),
        "met_against_some": tally(&|m| m > 0 && m < count),
        "met_against_none": tally(&|m| m == 0),
        "checks": checks,
    }))
}

/// The realisations' line, and one per check not met against all of them.
pub(crate) fn print(r: &serde_json::Value) {
    let count = r["count"].as_u64().unwrap_or(1);
    let Some(checks) = r["checks"].as_array() else {
        eprintln!("  realisations: {}", r["error"].as_str().unwrap_or(""));
        return;
    };
    eprintln!(
        "  against {count} converged realisations of the full model: {} checks met against all, {} against some, {} against none",
        r["met_against_all"], r["met_against_some"], r["met_against_none"]
    );
    for c in checks.iter().filter(|c| c["met_count"].as_u64() != Some(count)) {
        let full: Vec<String> = c["full"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|v| format!("{:.4e}", v.as_f64().unwrap_or(f64::NAN)))
            .collect();
        eprintln!(
            "    {}: met against {} of {count} (full {}; reduced {:.4e})",
            c["quantity"].as_str().unwrap_or(""),
            c["met_count"],
            full.join(", "),
            c["reduced"].as_f64().unwrap_or(f64::NAN)
        );
    }
}
