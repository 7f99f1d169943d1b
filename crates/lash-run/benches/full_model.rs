//! Criterion benchmarks of the full model of scenario B (c = 0.5 mm):
//! one right-hand-side evaluation, one fixed RK4 step (h = 1e-5 s) along the trajectory, and the
//! converged adaptive run over 0.036 s with all channels sampled every 1e-5 s (no file output).

use criterion::{Criterion, criterion_group, criterion_main};
use lash_ode::OdeSystem;
use lash_run::{BuildOptions, FullRun};
use lash_scenario::builtin;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let s = builtin::by_name("B").unwrap();
    let mut model = lash_run::build_model(&s, BuildOptions::default());
    let y0 = model.initial_state(0.0).unwrap();
    let mut dydt = vec![0.0; y0.len()];
    c.bench_function("full_model_B/rhs_evaluation", |b| {
        b.iter(|| {
            model.rhs(black_box(1e-4), black_box(&y0), &mut dydt);
            black_box(&dydt);
        })
    });
    c.bench_function("full_model_B/rk4_step_1e-5", |b| {
        let mut stepper = lash_run::bench::Rk4Stepper::new(&mut model, 1e-5);
        b.iter(|| black_box(stepper.step()))
    });
    let mut group = c.benchmark_group("full_model_B");
    group.sample_size(20);
    group.bench_function("converged_adaptive_run_0.036s", |b| {
        b.iter(|| {
            let mut run = FullRun::new(&s, BuildOptions::default());
            black_box(run.execute(&mut |_row| Ok(()), &mut |_| {}).unwrap())
        })
    });
    group.finish();
}

criterion_group!(full_model, benches);
criterion_main!(full_model);
