//! The full model's right-hand side and its RK4 step allocate nothing (a counting global
//! allocator watches them after warm-up).
//!
//! Without the test harness (`harness = false` in Cargo.toml): the allocator counts every
//! thread, and libtest's main thread does its own bookkeeping while a test runs — on a loaded
//! machine that landed inside the watched region (4 allocations, none of them the stepper's).
//! Here the check runs on the only thread there is.

use lash_ode::OdeSystem;
use lash_run::{BuildOptions, bench::Rk4Stepper};
use lash_scenario::builtin;
use stats_alloc::{INSTRUMENTED_SYSTEM, Region, StatsAlloc};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    rhs_and_rk4_step_allocate_nothing();
    println!("test rhs_and_rk4_step_allocate_nothing ... ok");
}

fn rhs_and_rk4_step_allocate_nothing() {
    let s = builtin::by_name("B").unwrap();
    let mut model = lash_run::build_model(&s, BuildOptions::default());
    let y0 = model.initial_state(0.0).unwrap();
    let mut dydt = vec![0.0; y0.len()];
    model.rhs(0.0, &y0, &mut dydt);
    let region = Region::new(GLOBAL);
    for i in 0..1000 {
        model.rhs(i as f64 * 1e-6, &y0, &mut dydt);
    }
    assert_eq!(region.change().allocations, 0, "rhs allocated");
    let mut stepper = Rk4Stepper::new(&mut model, 1e-5);
    stepper.step();
    let region = Region::new(GLOBAL);
    // 1000 steps cover the first impacts of B (the stepper restarts every 3.6 ms).
    for _ in 0..1000 {
        stepper.step();
    }
    assert_eq!(region.change().allocations, 0, "RK4 step allocated");
}
