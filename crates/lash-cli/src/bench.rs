//! `lash bench`: the speed figures of docs/performance.md, measured in one process.
//!
//! * cost of one right-hand-side evaluation and of one fixed RK4 step (h = 1e-5 s) of the full
//!   model of scenario B, stepping along the real trajectory (free flight and impacts);
//! * wall time of the converged adaptive run of scenario B over 0.036 s with every channel sampled
//!   every 1e-5 s (rows discarded: no file output);
//! * the same for the ideal mechanism, for scale.
//!
//! Each figure is the median of several repetitions; ratios are only meaningful within one run.

use crate::CliError;
use lash_ode::OdeSystem;
use lash_scenario::{BuildOptions, Run, bench::Rk4Stepper, builtin};
use std::hint::black_box;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub fn run(quick: bool) -> Result<(), CliError> {
    let reps = if quick { 3 } else { 7 };
    let s = builtin::by_name("B").expect("built-in");

    let mut model = lash_scenario::build_model(&s, BuildOptions::default());
    let y0 = model.initial_state(0.0).map_err(|e| CliError::Failure(e.to_string()))?;
    let mut dydt = vec![0.0; y0.len()];
    // Warm-up (~0.5 s of the measured work): lets the CPU leave its idle clock before timing.
    let warm = Instant::now();
    while warm.elapsed().as_secs_f64() < 0.5 {
        for i in 0..10_000 {
            model.rhs(black_box(1e-4 + i as f64 * 1e-12), black_box(&y0), &mut dydt);
        }
    }
    let n_eval = if quick { 100_000 } else { 400_000 };
    let rhs_ns = median(
        (0..reps)
            .map(|_| {
                let t = Instant::now();
                for i in 0..n_eval {
                    model.rhs(black_box(1e-4 + i as f64 * 1e-12), black_box(&y0), &mut dydt);
                }
                black_box(&dydt);
                t.elapsed().as_secs_f64() / n_eval as f64 * 1e9
            })
            .collect(),
    );

    let n_steps = if quick { 36_000 } else { 144_000 };
    let rk4_ns = median(
        (0..reps)
            .map(|_| {
                let mut stepper = Rk4Stepper::new(&mut model, 1e-5);
                let t = Instant::now();
                for _ in 0..n_steps {
                    black_box(stepper.step());
                }
                t.elapsed().as_secs_f64() / n_steps as f64 * 1e9
            })
            .collect(),
    );

    // Machine-speed reference quoted in the foundation issue: a plain dense 16×16 LU factorisation
    // and solve (nalgebra), "~1.3 µs here". Reported so figures from noisy shared machines can be
    // compared across runs.
    let kkt =
        nalgebra::DMatrix::<f64>::from_fn(16, 16, |i, j| if i == j { 4.0 } else { 1.0 / (1.0 + (i + 2 * j) as f64) });
    let rhs = nalgebra::DVector::<f64>::from_fn(16, |i, _| i as f64);
    let n_lu = if quick { 50_000 } else { 200_000 };
    let lu_ns = median(
        (0..reps)
            .map(|_| {
                let t = Instant::now();
                for _ in 0..n_lu {
                    let lu = black_box(&kkt).clone().lu();
                    black_box(lu.solve(black_box(&rhs)));
                }
                t.elapsed().as_secs_f64() / n_lu as f64 * 1e9
            })
            .collect(),
    );

    let time_run = |ideal: bool| -> Result<(f64, lash_scenario::Summary), CliError> {
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..reps {
            let mut r = Run::new(&s, BuildOptions { ideal });
            let t = Instant::now();
            let summary = r.execute(&mut |row| Ok(black_box(row).len()).map(|_| ()), &mut |_| {});
            times.push(t.elapsed().as_secs_f64() * 1e3);
            last = Some(summary.map_err(|e| CliError::Failure(e.to_string()))?);
        }
        Ok((median(times), last.expect("reps > 0")))
    };
    let (full_ms, full) = time_run(false)?;
    let (ideal_ms, ideal) = time_run(true)?;

    // Scenario A (the main job): converged full model against the reduced model, 0.036 s, all
    // channels sampled every 1e-5 s, rows discarded.
    let a = builtin::by_name("A").expect("built-in");
    let time_a = |reduced: bool| -> Result<f64, CliError> {
        let mut times = Vec::new();
        for _ in 0..reps {
            let mut r: Box<dyn lash_scenario::Runner> = if reduced {
                Box::new(
                    lash_scenario::ReducedRun::new(&a, lash_scenario::ReducedOptions::default())
                        .map_err(|e| CliError::Failure(e.to_string()))?,
                )
            } else {
                Box::new(Run::new(&a, BuildOptions::default()))
            };
            let t = Instant::now();
            r.execute(&mut |row| Ok(black_box(row).len()).map(|_| ()), &mut |_| {})
                .map_err(|e| CliError::Failure(e.to_string()))?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(median(times))
    };
    let (a_full_ms, a_reduced_ms) = (time_a(false)?, time_a(true)?);

    println!("lash bench (median of {reps}; scenario B, c = 0.5 mm, 5000 rpm)");
    println!(
        "  reference: dense 16×16 LU + solve (nalgebra)   {lu_ns:9.1} ns   (issue's figure for this machine kind: ~1300 ns)"
    );
    println!("  full model, one right-hand-side evaluation     {rhs_ns:9.1} ns");
    println!(
        "  full model, one RK4 step (h = 1e-5 s)          {rk4_ns:9.1} ns   (target ≤ 2000 ns; {:.2} LU-equivalents)",
        rk4_ns / lu_ns
    );
    println!(
        "  full model, converged adaptive run of 0.036 s  {full_ms:9.2} ms   (target ≤ 50 ms; {} steps, {} rejected, {} rhs, {} events)",
        full.steps, full.rejected_steps, full.rhs_evaluations, full.events
    );
    println!(
        "  ideal mechanism, adaptive run of 0.036 s       {ideal_ms:9.2} ms   ({} steps, {} rhs)",
        ideal.steps, ideal.rhs_evaluations
    );
    println!("scenario A (c = 100 µm), 0.036 s, every channel sampled at 1e-5 s (rows discarded)");
    println!("  full model, converged adaptive                 {a_full_ms:9.2} ms");
    println!(
        "  reduced model (h_m = 1e-3, h_r = 1e-5)         {a_reduced_ms:9.2} ms   (speed-up {:.1}×)",
        a_full_ms / a_reduced_ms
    );
    Ok(())
}
