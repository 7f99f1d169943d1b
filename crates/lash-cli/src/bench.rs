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
use lash_run::{BuildOptions, FullRun, bench::Rk4Stepper};
use lash_scenario::builtin;
use std::hint::black_box;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub fn run(quick: bool) -> Result<(), CliError> {
    let reps = if quick { 3 } else { 7 };
    let b = full_model_figures(reps, quick)?;
    let (a_full_ms, a_reduced_ms) = scenario_times("A", reps)?;
    b.print(reps);
    println!("scenario A (c = 100 µm), 0.036 s, every channel sampled at 1e-5 s (rows discarded)");
    println!("  full model, converged adaptive                 {a_full_ms:9.2} ms");
    println!(
        "  reduced model (h_m = 1e-3, h_r = 1e-5)         {a_reduced_ms:9.2} ms   (speed-up {:.1}×)",
        a_full_ms / a_reduced_ms
    );
    reduced_section(reps, quick)?;
    film_section(reps)?;
    spatial_section(reps, quick)?;
    bush_section(reps)
}

/// The lubricated joint: one film force of each closed form, and scenario A-lubricated's runs.
fn film_section(reps: usize) -> Result<(), CliError> {
    use lash_contact::film::{BearingLength, Film};
    // States over the clearance (ε to 0.9, all directions) with squeeze and rotation.
    let states: Vec<([f64; 2], [f64; 2])> = (0..64)
        .map(|k| {
            let (a, r) = (k as f64 * 0.7, 0.9 * (k % 8) as f64 / 7.0 * 5e-5);
            ([r * a.cos(), r * a.sin()], [0.01 * (2.0 * a).sin(), 0.004 * a.cos()])
        })
        .collect();
    let per_call = |bearing| {
        let film = Film { viscosity: 0.2, length: 0.005, bearing, mixed_fraction: Film::MIXED_FRACTION };
        let mut times = Vec::new();
        for _ in 0..reps {
            let t = Instant::now();
            for _ in 0..100 {
                for (e, v) in &states {
                    black_box(film.force((0.0099, 1e-4), black_box(*e), black_box(*v), black_box(262.0)));
                }
            }
            times.push(t.elapsed().as_secs_f64() * 1e9 / (100 * states.len()) as f64);
        }
        median(times)
    };
    let (short_ns, long_ns) = (per_call(BearingLength::Short), per_call(BearingLength::Long));
    let (full_ms, reduced_ms) = scenario_times("A-lubricated", reps)?;
    println!("lubricated joint: the film's force, and scenario A-lubricated (0.036 s, every channel at 1e-5 s)");
    println!("  film force, short bearing (closed form)        {short_ns:9.1} ns");
    println!("  film force, long bearing (roots on 64 samples) {long_ns:9.1} ns");
    println!("  full model, converged adaptive                 {full_ms:9.2} ms");
    println!(
        "  reduced model (h_m = 1e-3, h_r = 1e-5 divided)  {reduced_ms:9.2} ms   (speed-up {:.1}×)",
        full_ms / reduced_ms
    );
    Ok(())
}

/// Scenario B's full-model figures: one right-hand side, one RK4 step, the converged adaptive
/// run (DOP853 and DOPRI5), the ideal mechanism; a dense LU for the machine's speed.
struct FullModelFigures {
    rhs_ns: f64,
    rk4_ns: f64,
    lu_ns: f64,
    full_ms: f64,
    full: lash_run::Summary,
    dopri5_ms: f64,
    dopri5_summary: lash_run::Summary,
    ideal_ms: f64,
    ideal: lash_run::Summary,
}

/// Measures [`FullModelFigures`], each the median of `reps` rounds.
fn full_model_figures(reps: usize, quick: bool) -> Result<FullModelFigures, CliError> {
    let s = builtin::by_name("B").expect("built-in");

    let mut model = lash_run::build_model(&s, BuildOptions::default());
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

    let time_run = |ideal: bool, method: lash_ode::Method| -> Result<(f64, lash_run::Summary), CliError> {
        let mut times = Vec::new();
        let mut last = None;
        let mut s = s.clone();
        s.simulation.integrator = method;
        for _ in 0..reps {
            let mut r = FullRun::new(&s, BuildOptions { ideal });
            let t = Instant::now();
            let summary = r.execute(&mut |row| Ok(black_box(row).len()).map(|_| ()), &mut |_| {});
            times.push(t.elapsed().as_secs_f64() * 1e3);
            last = Some(summary.map_err(|e| CliError::Failure(e.to_string()))?);
        }
        Ok((median(times), last.expect("reps > 0")))
    };
    let converged = s.simulation.integrator;
    let (full_ms, full) = time_run(false, converged)?;
    // The same tolerances with the 5th-order pair, interleaved in the same process: the ratio is
    // what the choice of DOP853 for the converged mode buys.
    let dopri5 = match converged {
        lash_ode::Method::Dop853(o) | lash_ode::Method::Dopri5(o) => lash_ode::Method::Dopri5(o),
        m => m,
    };
    let (dopri5_ms, dopri5_summary) = time_run(false, dopri5)?;
    let (ideal_ms, ideal) = time_run(true, converged)?;

    Ok(FullModelFigures { rhs_ns, rk4_ns, lu_ns, full_ms, full, dopri5_ms, dopri5_summary, ideal_ms, ideal })
}

impl FullModelFigures {
    /// The bench's first lines.
    fn print(&self, reps: usize) {
        let Self { rhs_ns, rk4_ns, lu_ns, full_ms, full, dopri5_ms, dopri5_summary, ideal_ms, ideal } = self;
        println!("lash bench (median of {reps}; scenario B, c = 0.5 mm, 5000 rpm)");
        print_profile();
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
            "    same tolerances with DOPRI5                  {dopri5_ms:9.2} ms   (DOP853 {:.2}× faster; {} steps, {} rejected, {} rhs)",
            dopri5_ms / full_ms,
            dopri5_summary.steps,
            dopri5_summary.rejected_steps,
            dopri5_summary.rhs_evaluations
        );
        println!(
            "  ideal mechanism, adaptive run of 0.036 s       {ideal_ms:9.2} ms   ({} steps, {} rhs)",
            ideal.steps, ideal.rhs_evaluations
        );
    }
}

/// Built-in `name` (scenario A: the main job): the converged full model and the reduced model at
/// its defaults over the scenario's horizon, every channel sampled every 1e-5 s, rows discarded
/// [ms], medians of `reps`.
fn scenario_times(name: &str, reps: usize) -> Result<(f64, f64), CliError> {
    let a = builtin::by_name(name).expect("built-in");
    let time_a = |reduced: bool| -> Result<f64, CliError> {
        let mut times = Vec::new();
        for _ in 0..reps {
            let mut r: Box<dyn lash_run::Runner> = if reduced {
                Box::new(
                    lash_run::ReducedRun::new(&a, lash_run::ReducedOptions::default())
                        .map_err(|e| CliError::Failure(e.to_string()))?,
                )
            } else {
                Box::new(FullRun::new(&a, BuildOptions::default()))
            };
            let t = Instant::now();
            r.execute(&mut |row| Ok(black_box(row).len()).map(|_| ()), &mut |_| {})
                .map_err(|e| CliError::Failure(e.to_string()))?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(median(times))
    };
    Ok((time_a(false)?, time_a(true)?))
}

/// The FE characterisation of the study's flexible bush: assembly, the two factorisations and
/// every load case of the default table, on the converged mesh.
fn bush_section(reps: usize) -> Result<(), CliError> {
    let file = lash_bush::BushFile::study();
    let mut last = None;
    let seconds = median(
        (0..reps.clamp(1, 3))
            .map(|_| {
                let t = Instant::now();
                last = Some(lash_bush::characterise(&file.bush, &file.loads));
                t.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let table = last.expect("one run").map_err(|e| CliError::Failure(e.to_string()))?;
    println!("flexible bush (FE, plane strain): the study's bronze bush, {} loads", file.loads.len());
    println!(
        "  characterisation, converged mesh               {:9.3} s    (target < 2 s; {} elements, {} unknowns, 2 factorisations)",
        seconds, table.elements, table.unknowns
    );
    // Scenario F (3000 rpm, three revolutions, every channel sampled every 1e-5 s): the rigid
    // bearing with 1 mm clearance and the same clearance in the bronze bush, full and reduced.
    let mut micro_ns = Vec::new();
    println!(
        "scenario F (3000 rpm, 0.06 s, every channel sampled every 1e-5 s; bush tables computed before timing; reduced: median of 5 runs)"
    );
    for name in ["F", "F-flexible-imperfect", "F-flexible-perfect"] {
        let s = builtin::by_name(name).expect("built-in");
        let mut full = lash_run::FullRun::new(&s, BuildOptions::default());
        let (full_ms, summary) = time_runner(&mut full)?;
        // (The reduced run is ~1 ms: the median of five runs, each built afresh.)
        let runs: Result<Vec<_>, _> =
            (0..5).map(|_| lash_run::ReducedRun::new(&s, lash_run::ReducedOptions::default())).collect();
        let reduced = match runs {
            Ok(runs) => {
                let (mut walls, mut per_step) = (Vec::new(), Vec::new());
                for mut r in runs {
                    let (ms, summary) = time_runner(&mut r)?;
                    let master = summary.reduced.as_ref().map(|r| r.master.clone()).unwrap_or_default();
                    walls.push(ms);
                    per_step.push(master.micro_seconds * 1e9 / master.micro_steps.max(1) as f64);
                }
                let (ms, ns) = (median(walls), median(per_step));
                micro_ns.push(ns);
                format!("reduced {ms:7.2} ms ({:.1}×; micro+observers {ns:.0} ns per micro step)", full_ms / ms)
            }
            Err(_) => "reduced: not for bushings without clearance".to_string(),
        };
        println!(
            "  {name:22} full {full_ms:8.2} ms ({} steps, {} rejected); {reduced}",
            summary.steps, summary.rejected_steps
        );
    }
    // The first two: the rigid clearance (F) and the same clearance in the bush (the third, the
    // bushing without clearance, is another kind of joint).
    if let [rigid, flexible, ..] = micro_ns[..] {
        println!(
            "  flexible-imperfect micro step against the rigid one: {:.2}× (target ≤ 1.5×; the series solve)",
            flexible / rigid
        );
    }
    Ok(())
}

/// Scenario E: one right-hand side of the spatial full model (3 bodies, 2 spherical clearance
/// joints in contact, stick–slip friction) and the converged run of two revolutions.
fn spatial_section(reps: usize, quick: bool) -> Result<(), CliError> {
    use lash_ode::OdeSystem;
    let fail = |e: &dyn std::fmt::Display| CliError::Failure(e.to_string());
    let e = lash_scenario::builtin_spatial::spatial_by_name("E-0.5mm-250rpm").expect("built-in");
    let mut model = lash_run::build_spatial(&e, false);
    let mut y = model.initial_state(0.0).map_err(|x| fail(&x))?;
    // Both balls pressed into their sockets (1 µm along the ball's offset from the socket
    // centre), so that the contact and friction code runs as in a contact phase.
    for k in 0..model.clearances.len() {
        let (body, clearance) = (model.clearances[k].journal_body, model.clearances[k].radial_clearance());
        let lash_mech::BodyId::Body(b) = body else { continue };
        let s = model.contact_state(k, &y, 0.0);
        let push = (clearance + 1e-6) * if s.eccentricity_norm > 0.0 { s.normal } else { lash_spatial::Vec3::y() };
        for a in 0..3 {
            y[7 * b + a] += push[a];
        }
    }
    let mut dydt = vec![0.0; y.len()];
    let n_eval = if quick { 50_000 } else { 200_000 };
    let rhs_ns = median(
        (0..reps)
            .map(|_| {
                let t = Instant::now();
                for i in 0..n_eval {
                    model.rhs(black_box(1e-4 + i as f64 * 1e-12), black_box(&y), &mut dydt);
                }
                black_box(&dydt);
                t.elapsed().as_secs_f64() / n_eval as f64 * 1e9
            })
            .collect(),
    );
    let in_contact = model.contacts.iter().filter(|c| c.normal_force > 0.0).count();
    let mut e_run = e.clone();
    e_run.output.measurements.clear();
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..if quick { 1 } else { reps.min(3) } {
        let (ms, summary) = time_runner(&mut lash_run::SpatialRun::new(&e_run, false))?;
        times.push(ms);
        last = Some(summary);
    }
    let full = last.expect("one run");
    let full_ms = median(times);
    // The reduced model (h_m = 1e-3, h_r = 1e-5, one-way) over the same run, every channel sampled.
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..if quick { 1 } else { reps.min(3) } {
        let mut r =
            lash_run::SpatialReducedRun::new(&e_run, lash_run::ReducedOptions::default()).map_err(|x| fail(&x))?;
        let (ms, summary) = time_runner(&mut r)?;
        times.push(ms);
        last = Some(summary);
    }
    let reduced = last.expect("one run");
    let reduced_ms = median(times);
    // The same with only the guide's reaction and the slider's acceleration sampled (what the
    // emulated measurement needs), both models.
    let mut few = e_run.clone();
    few.output.channels =
        ["slider.ax", "slider_guide.fx", "slider_guide.fy", "slider_guide.fz"].iter().map(|c| c.to_string()).collect();
    let (few_full_ms, _) = time_runner(&mut lash_run::SpatialRun::new(&few, false))?;
    let mut r = lash_run::SpatialReducedRun::new(&few, lash_run::ReducedOptions::default()).map_err(|x| fail(&x))?;
    let (few_reduced_ms, few_summary) = time_runner(&mut r)?;
    let few_master = few_summary.reduced.as_ref().map(|r| r.master.clone()).unwrap_or_default();
    // The same with the macro on a producer thread (one-way coupling needs nothing back from the
    // micro side): the wall time a user with two free cores sees; not equal work per core.
    let threaded = lash_run::ReducedOptions { execution: lash_orchestrate::Execution::Threaded, ..Default::default() };
    let mut r = lash_run::SpatialReducedRun::new(&few, threaded).map_err(|x| fail(&x))?;
    let (few_threaded_ms, _) = time_runner(&mut r)?;
    let master = reduced.reduced.as_ref().map(|r| r.master.clone()).unwrap_or_default();
    println!("spatial: scenario E (0.5 mm, 250 rpm; 3 bodies, 2 spherical clearance joints, ADAMS IMPACT, stick–slip)");
    println!(
        "  spatial full model, one right-hand side        {rhs_ns:9.1} ns   (target < 1500 ns; {in_contact} of 2 joints in contact)"
    );
    println!(
        "  converged full model, 2 revolutions (0.48 s)   {full_ms:9.2} ms   (target < 1000 ms; {} steps, {} rejected, {} rhs, {} events; every channel sampled every 1e-5 s)",
        full.steps, full.rejected_steps, full.rhs_evaluations, full.events
    );
    println!(
        "  reduced model (two coupled spherical joints)   {reduced_ms:9.2} ms   (speed-up {:.1}× with every channel sampled; macro {:.0} µs per macro step, micro+observers {:.0} ns per micro step)",
        full_ms / reduced_ms,
        master.macro_seconds * 1e6 / master.macro_steps.max(1) as f64,
        master.micro_seconds * 1e9 / master.micro_steps.max(1) as f64
    );
    println!(
        "  4 channels sampled (slider.ax, guide forces)   {few_reduced_ms:9.2} ms   (full model {few_full_ms:.2} ms: speed-up {:.1}×, target ≥ 20× (the channels the emulated measurement needs); macro {:.0} µs per macro step, micro+observers {:.0} ns per micro step)",
        few_full_ms / few_reduced_ms,
        few_master.macro_seconds * 1e6 / few_master.macro_steps.max(1) as f64,
        few_master.micro_seconds * 1e9 / few_master.micro_steps.max(1) as f64
    );
    println!(
        "  the same, macro on a second thread (2 cores)   {few_threaded_ms:9.2} ms   (wall-time ratio {:.1}×; two cores against the full model's one)",
        few_full_ms / few_threaded_ms
    );
    Ok(())
}

/// The cargo profile this binary was built with (set by lash-cli's build script).
pub const PROFILE: &str = env!("LASH_PROFILE");

/// Says which build the figures come from: docs/performance.md's are `dist`'s (fat LTO, the
/// published binaries), the one to compare with across commits.
fn print_profile() {
    if PROFILE == "dist" {
        println!("  built with profile dist (fat LTO): the build docs/performance.md's figures come from");
    } else {
        println!(
            "  built with profile {PROFILE}: docs/performance.md's figures come from `cargo run --profile dist -- bench` \
             (fat LTO); `release` (thin LTO) reads within 3 % of it on most lines (docs/performance.md)"
        );
    }
}

/// Runs `scenario` with `runner` and returns the wall time [ms] (rows discarded).
fn time_runner(r: &mut dyn lash_run::Runner) -> Result<(f64, lash_run::Summary), CliError> {
    let t = Instant::now();
    let summary = r
        .execute(&mut |row| Ok(black_box(row).len()).map(|_| ()), &mut |_| {})
        .map_err(|e| CliError::Failure(e.to_string()))?;
    Ok((t.elapsed().as_secs_f64() * 1e3, summary))
}

/// Median cost [ns] of one RK4 micro step of an interface model with the given constant inputs,
/// the journals released from their centres: impacts, then settled contacts (both branches of the
/// law). The steps run through the loop a run's micro subsystem uses (with its penetration
/// checks), so the figure is the one a run pays, in the instruction set a run gets.
fn time_micro_steps<const N: usize, const K: usize>(
    joints: Vec<lash_contact::ClearanceJoint>,
    inputs: lash_micro::PlanarInputs<N, K>,
    reps: usize,
    steps: usize,
) -> Result<f64, CliError> {
    let step = lash_core::Ticks::from_seconds(1e-5).expect("a valid step");
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        let mut m = lash_micro::PlanarInterfaceModel::<N, K>::new(joints.clone());
        m.inputs = inputs;
        let t0 = Instant::now();
        lash_micro::rk4_steps_as_in_a_run(&mut m, lash_core::Ticks(0), step, steps)
            .map_err(|(_, t, e)| CliError::Failure(format!("micro step benchmark at t = {t} s: {e}")))?;
        black_box(&m.states);
        times.push(t0.elapsed().as_secs_f64() / steps as f64 * 1e9);
    }
    Ok(median(times))
}

/// Median over `reps` of the cost per step and per lane [ns] of `steps` micro steps of copies
/// of `joint` advanced in lockstep (`lash_micro::lanes`), in intervals of 100 steps with
/// the penetration check after each step — the same work as four models stepped one by one.
fn time_lane_steps(
    joint: &lash_contact::ClearanceJoint,
    inputs: lash_micro::PlanarInputs<2, 1>,
    reps: usize,
    steps: usize,
) -> f64 {
    use lash_core::Ticks;
    use lash_micro::lanes;
    const LANES: usize = lanes::LANES;
    let step = Ticks::from_seconds(1e-5).expect("a valid step");
    let record = [false; 100];
    median(
        (0..reps)
            .map(|_| {
                let mut models: Vec<lanes::OneJoint> =
                    (0..LANES).map(|_| lash_micro::PlanarInterfaceModel::new(vec![joint.clone()])).collect();
                for m in &mut models {
                    m.inputs = inputs;
                }
                let laws = lanes::lane_laws(&models[0]).expect("scenario A's laws run in lanes");
                let t0 = Instant::now();
                for k in 0..steps / record.len() {
                    let mut group: [&mut lanes::OneJoint; LANES] =
                        models.iter_mut().collect::<Vec<_>>().try_into().unwrap_or_else(|_| unreachable!("the lanes"));
                    let t = Ticks(k as i64 * record.len() as i64 * step.0);
                    let outcome = lanes::advance(&mut group, laws, [t; LANES], step, &record, |_, _, _| {});
                    black_box(&outcome);
                }
                black_box(&models[0].states);
                t0.elapsed().as_secs_f64() / (steps * LANES) as f64 * 1e9
            })
            .collect(),
    )
}

/// The reduced model's figures: micro step cost, 1 s of scenario A, equal-step and converged
/// ratios against the full model, and scaling with body count.
fn reduced_section(reps: usize, quick: bool) -> Result<(), CliError> {
    use lash_run::{ReducedOptions, ReducedRun};
    let fail = |e: &dyn std::fmt::Display| CliError::Failure(e.to_string());

    // Micro step alone: scenario A's interface with the terms of its first macro node, journal
    // released from the centre: impacts, then a settled contact (both branches of the law).
    let a = builtin::by_name("A").expect("built-in");
    let joint = lash_run::build_model(&a, BuildOptions::default()).clearances[0].clone();
    let n = if quick { 100_000 } else { 400_000 };
    let mut a_inputs = lash_micro::PlanarInputs::<2, 1> {
        effective_mass: nalgebra::Matrix2::new(0.33, 0.01, 0.01, 0.21),
        effective_force: nalgebra::Vector2::new(-900.0, 300.0),
        friction_moment_force: nalgebra::Vector2::new(-20.0, 8.0),
        ..Default::default()
    };
    a_inputs.journal_angular_velocity[0] = builtin::CRANK_SPEED;
    let micro_ns = time_micro_steps(vec![joint.clone()], a_inputs, reps, n)?;
    // The same steps, runs side by side in lanes.
    let lane_ns = time_lane_steps(&joint, a_inputs, reps, n);
    // Two such joints coupled by off-diagonal blocks of M̃ (the 4 × 4 Cholesky path).
    let two_joint_ns = {
        let mut inputs = lash_micro::PlanarInputs::<4, 2> {
            effective_mass: nalgebra::Matrix4::new(
                0.33, 0.01, 0.05, 0.0, 0.01, 0.21, 0.0, 0.04, 0.05, 0.0, 0.40, 0.02, 0.0, 0.04, 0.02, 0.25,
            ),
            effective_force: nalgebra::Vector4::new(-900.0, 300.0, 700.0, -500.0),
            ..Default::default()
        };
        inputs.friction_moment_force[(0, 0)] = -20.0;
        inputs.friction_moment_force[(1, 0)] = 8.0;
        inputs.friction_moment_force[(2, 1)] = 12.0;
        inputs.friction_moment_force[(3, 1)] = -5.0;
        inputs.journal_angular_velocity[0] = builtin::CRANK_SPEED;
        inputs.bearing_angular_velocity[1] = -builtin::CRANK_SPEED;
        let mut second = joint.clone();
        second.name = "second".into();
        time_micro_steps(vec![joint.clone(), second], inputs, reps, n)?
    };

    // One second (0.2 s with --quick) of scenario A, slider.ax recorded at every micro step.
    let horizon = if quick { 0.2 } else { 1.0 };
    let mut a1 = a.clone();
    a1.simulation.horizon = horizon;
    a1.output.channels = vec!["slider.ax".into()];
    // The two-joint scenario C over the same time, recording the same channel.
    let mut c1 = builtin::by_name("C").expect("built-in");
    c1.simulation.horizon = horizon;
    c1.output.channels = vec!["slider.ax".into()];
    let reduced_of =
        |s: &lash_scenario::Scenario, options: ReducedOptions| -> Result<(f64, lash_run::Summary), CliError> {
            let mut best: Option<(f64, lash_run::Summary)> = None;
            let mut times = Vec::new();
            for _ in 0..reps {
                let (ms, s) = time_runner(&mut ReducedRun::new(s, options).map_err(|e| fail(&e))?)?;
                times.push(ms);
                best = Some((ms, s));
            }
            let (_, s) = best.expect("reps > 0");
            Ok((median(times), s))
        };
    let reduced = |options: ReducedOptions| reduced_of(&a1, options);
    let (red_ms, red) = reduced(ReducedOptions::default())?;
    // C at its resolved micro step: at 1e-5 s the slider's pin (60 g) in the rod's eye meets
    // contacts of ~5 steps and the run blows up within the second (lash's own warning); the
    // figure compared is the cost per micro step, which the step does not change.
    let (two_ms, two) = reduced_of(&c1, ReducedOptions { micro_step: 5e-6, ..Default::default() })?;
    let (thr_ms, _) =
        reduced(ReducedOptions { execution: lash_orchestrate::Execution::Threaded, ..Default::default() })?;
    let (two_way_ms, two_way) =
        reduced(ReducedOptions { coupling: lash_core::Coupling::TwoWay, ..Default::default() })?;
    // The macro step `lash run` and `lash compare` pick for A (at most 16° of crank per step).
    let fastest = lash_scenario::AnyScenario::Planar(a1.clone()).fastest_rotation();
    let defaults = ReducedOptions::default();
    let (picked, _) = lash_run::macro_step_for_rotation(defaults.macro_step, defaults.micro_step, fastest);
    let (picked_ms, _) = reduced(ReducedOptions { macro_step: picked, ..defaults })?;
    let master = red.reduced.as_ref().map(|r| r.master.clone()).unwrap_or_default();
    let mut full_rk4 = a1.clone();
    full_rk4.simulation.integrator = lash_ode::Method::Rk4 { step: 1e-5 };
    let (rk4_ms, _) = time_runner(&mut FullRun::new(&full_rk4, BuildOptions::default()))?;
    let (conv_ms, conv) = time_runner(&mut FullRun::new(&a1, BuildOptions::default()))?;

    println!("reduced interface model, scenario A, {horizon} s of mechanism time, slider.ax recorded every 1e-5 s");
    println!("  micro step alone (RK4, LN + Ambrósio, 4 law evaluations)  {micro_ns:8.1} ns   (target ≤ 100 ns)");
    println!(
        "  the same in {} lanes (runs in lockstep), per lane         {lane_ns:8.1} ns   ({:.2}× one run; with the penetration check)",
        lash_micro::lanes::LANES,
        micro_ns / lane_ns
    );
    println!(
        "  two coupled joints, micro step alone (4 × 4 M~)           {two_joint_ns:8.1} ns   ({:.2}× one joint; both joints always in contact: the worst case)",
        two_joint_ns / micro_ns
    );
    println!(
        "  reduced model, sequential                      {red_ms:9.2} ms   (target ≤ {:.0} ms; {:.0} ns per micro step; macro {:.2} ms, micro+observers {:.2} ms)",
        15.0 * horizon,
        red_ms * 1e6 / master.micro_steps.max(1) as f64,
        master.macro_seconds * 1e3,
        master.micro_seconds * 1e3
    );
    let per_micro = |ms: f64, s: &lash_run::Summary| {
        ms * 1e6 / s.reduced.as_ref().map_or(1, |r| r.master.micro_steps.max(1)) as f64
    };
    println!(
        "  two-joint scenario C (h_r = 5e-6 s), sequential{two_ms:8.2} ms   ({:.0} ns per micro step, {:.2}× scenario A's, target < 2×)",
        per_micro(two_ms, &two),
        per_micro(two_ms, &two) / per_micro(red_ms, &red)
    );
    println!("  reduced model, threaded pipeline               {thr_ms:9.2} ms");
    let two_way_macro = two_way.reduced.as_ref().map_or(0.0, |r| r.master.macro_seconds);
    println!(
        "  reduced model, two-way coupling                {two_way_ms:9.2} ms   ({:.1}× one-way; macro {:.2} ms: the mechanism integrated)",
        two_way_ms / red_ms,
        two_way_macro * 1e3
    );
    println!(
        "  full model, RK4 at the same step 1e-5 s        {rk4_ms:9.2} ms   (equal-step ratio {:.1}×, target ≥ 10×)",
        rk4_ms / red_ms
    );
    println!(
        "  full model, converged adaptive                 {conv_ms:9.2} ms   (ratio {:.1}×, target ≥ 40×; {} steps)",
        conv_ms / red_ms,
        conv.steps
    );
    println!(
        "  reduced model at the macro step lash picks ({picked:e} s) {picked_ms:6.2} ms   ({:.1}× the converged full model, {:.1}× at equal step)",
        conv_ms / picked_ms,
        rk4_ms / picked_ms
    );
    scaling(quick)
}

/// Full-model RK4 step and reduced-model cost per micro step against body count (radial engines
/// of 1…9 cylinders with the clearance at the crank–ground joint).
fn scaling(quick: bool) -> Result<(), CliError> {
    use lash_run::{ReducedOptions, ReducedRun};
    println!("scaling: radial engines, clearance at the crank–ground joint, 0.02 s, slider0.ax every 1e-5 s");
    println!(
        "  cylinders  bodies   full RK4 1e-5 [ms]   reduced [ms]   ratio   micro+observers [ns/micro step]   macro [µs/macro step]"
    );
    let horizon = if quick { 0.01 } else { 0.02 };
    for cylinders in [1, 3, 5, 7, 9] {
        let mut s = builtin::radial_engine(cylinders);
        s.simulation.horizon = horizon;
        s.output.channels = vec!["slider0.ax".into()];
        let mut rk4 = s.clone();
        rk4.simulation.integrator = lash_ode::Method::Rk4 { step: 1e-5 };
        let (full_ms, _) = time_runner(&mut FullRun::new(&rk4, BuildOptions::default()))?;
        let (red_ms, red) = time_runner(
            &mut ReducedRun::new(&s, ReducedOptions::default()).map_err(|e| CliError::Failure(e.to_string()))?,
        )?;
        let master = red.reduced.as_ref().map(|r| r.master.clone()).unwrap_or_default();
        println!(
            "  {cylinders:9}  {:6}   {full_ms:18.2}   {red_ms:12.2}   {:5.1}×   {:31.0}   {:21.1}",
            s.bodies.len(),
            full_ms / red_ms,
            master.micro_seconds * 1e9 / master.micro_steps.max(1) as f64,
            master.macro_seconds * 1e6 / master.macro_steps.max(1) as f64
        );
    }
    fmi_section(quick)
}

/// The reduced model of A coupled by lash's master in process and through its own FMUs (packed,
/// imported with libloading): same master, same signal, only the C boundary differs.
fn fmi_section(quick: bool) -> Result<(), CliError> {
    use lash_core::{Coupling, Subsystem, Ticks};
    use lash_orchestrate::{Execution, InterfaceMaster, Interpolation, MasterOptions, Observer, Signal};
    let fail = |e: &dyn std::fmt::Display| CliError::Failure(e.to_string());
    let dir = std::env::temp_dir().join(format!("lash-bench-fmu-{}", std::process::id()));
    let a = lash_scenario::AnyScenario::Planar(lash_catalog::default_scenario().map_err(|e| fail(&e))?);
    if let Err(e) = crate::fmu::pack_quiet(&a, &dir) {
        println!("FMI: skipped ({e})");
        return Ok(());
    }
    let horizon = if quick { 0.1 } else { 0.5 };
    let stop = Ticks::from_seconds(horizon).map_err(|e| fail(&e))?;
    let options = MasterOptions {
        start: Ticks::ZERO,
        stop,
        macro_step: Ticks::from_seconds(1e-3).map_err(|e| fail(&e))?,
        micro_step: Ticks::from_seconds(1e-5).map_err(|e| fail(&e))?,
        interpolation: Interpolation::Linear,
        coupling: Coupling::OneWay,
        execution: Execution::Sequential,
    };
    let signals = vec![Signal::Propagated {
        name: "slider.ax".into(),
        free: ("slider.acceleration_free".into(), 0),
        gain: ("slider.acceleration_gain".into(), 0),
    }];
    let run = |mech: &mut dyn Subsystem, micro: &mut dyn Subsystem| -> Result<(f64, f64), CliError> {
        mech.setup(Ticks::ZERO, Some(stop)).map_err(|e| fail(&e))?;
        micro.setup(Ticks::ZERO, Some(stop)).map_err(|e| fail(&e))?;
        let mut master = InterfaceMaster::new(mech, micro, options, signals.clone()).map_err(|e| fail(&e))?;
        let mut sum = 0.0;
        let mut observer = |_t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
            sum += v[0];
            Ok(())
        };
        let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut observer, options.micro_step)];
        let t = Instant::now();
        master.run(&mut observers).map_err(|e| fail(&e))?;
        Ok((t.elapsed().as_secs_f64() * 1e3, black_box(sum)))
    };
    let cache = dir.join("cache");
    let mut times = (Vec::new(), Vec::new());
    let mut sums = (0.0, 0.0);
    // Four rounds, the first one untimed: it pays the one-time costs of loading the libraries
    // (relocations, first page faults), which are not per-step costs.
    for round in 0..4 {
        let (mut m, mut i) =
            (lash_catalog::mechanism(&a).map_err(|e| fail(&e))?, lash_catalog::interface(&a).map_err(|e| fail(&e))?);
        let (ms, s) = run(&mut m, &mut i)?;
        if round > 0 {
            times.0.push(ms);
        }
        sums.0 = s;
        let open = |name: &str| lash_fmi::import::ImportedFmu::open(&dir.join(format!("{name}.fmu")), &cache, name);
        let (mut m, mut i) =
            (open("lash_mechanism").map_err(|e| fail(&e))?, open("lash_interface").map_err(|e| fail(&e))?);
        let (ms, s) = run(&mut m, &mut i)?;
        if round > 0 {
            times.1.push(ms);
        }
        sums.1 = s;
    }
    let (inproc, imported) = (median(times.0), median(times.1));
    let steps = (horizon / 1e-5).round();
    println!("FMI: scenario A, {horizon} s, lash's master in process vs through its own FMI 3.0 FMUs (imported)");
    println!("  in process                                     {inproc:9.2} ms");
    println!(
        "  through the FMUs                               {imported:9.2} ms   (ratio {:.2}, target ≤ 1.3; {:.0} ns per micro step at the C boundary; same result: {})",
        imported / inproc,
        (imported - inproc) * 1e6 / steps,
        sums.0.to_bits() == sums.1.to_bits()
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// `lash bench sweep`: throughput of a sweep of scenario A in the reduced model (runs × 0.1 s,
/// `slider.ax` at 10 kHz with noise, Latin hypercube over clearance and crank speed), then of
/// scenario E (two spherical clearance joints; runs × 0.1 s, `slider.ax` at 10 kHz, Latin
/// hypercube over both clearances and the crank speed), each executed with 1 and then 2 worker
/// threads, one run at a time and side by side, into temporary folders; the time split shows
/// whether the dataset writer limits it. "Per CPU s" divides by the process's CPU time over the
/// sweep (every thread: the workers, the thread that assembles the dataset, the kernel's time
/// writing files): the work per simulated second whatever the thread count.
pub fn sweep(quick: bool) -> Result<(), CliError> {
    let runs = if quick { 40 } else { 200 };
    // (The steps given, 1 ms and 10 µs, as every session's figure was measured: without them a
    // sweep of A takes the 0.5 ms macro step lash chooses at 5000 rpm.)
    let a = format!(
        r#"base = "A"
model = "reduced"
sampling = "latin_hypercube"
runs = {runs}
seed = 1
horizon = 0.1
[reduced]
macro_step = 1e-3
micro_step = 1e-5
[output]
channels = ["slider.ax"]
sample_rate = 10000.0
noise = {{ "slider.ax" = 10.0 }}
[[parameters]]
path = "clearances[0].bearing_radius"
uniform = {{ low = 0.00992, high = 0.0101 }}
[[parameters]]
path = "drivers[0].motion.omega"
uniform = {{ low = 400.0, high = 600.0 }}
"#
    );
    let title = format!(
        "scenario A, reduced model, {runs} runs × 0.1 s, slider.ax at 10 kHz (+ noise), LHS over clearance and speed"
    );
    sweep_table("a", &title, &a)?;
    let runs = if quick { 32 } else { 96 };
    let e = format!(
        r#"base = "E"
model = "reduced"
sampling = "latin_hypercube"
runs = {runs}
seed = 1
horizon = 0.1
[output]
channels = ["slider.ax"]
sample_rate = 10000.0
[[parameters]]
path = "clearances[0].bearing_radius"
uniform = {{ low = 0.00555, high = 0.0061 }}
[[parameters]]
path = "clearances[1].bearing_radius"
uniform = {{ low = 0.00555, high = 0.0061 }}
[[parameters]]
path = "drivers[0].motion.omega"
uniform = {{ low = 20.0, high = 32.0 }}
"#
    );
    let title = format!(
        "scenario E, reduced model, {runs} runs × 0.1 s, slider.ax at 10 kHz, LHS over both clearances and speed"
    );
    sweep_table("e", &title, &e)
}

/// One table of [`sweep`]: the sweep file `text` executed with 1 and 2 threads, one at a time and
/// side by side, and whether their datasets are the same bytes.
fn sweep_table(name: &str, title: &str, text: &str) -> Result<(), CliError> {
    let dir = std::env::temp_dir().join(format!("lash-bench-sweep-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).map_err(|e| CliError::Failure(format!("cannot create {}: {e}", dir.display())))?;
    let file = dir.join("sweep.toml");
    std::fs::write(&file, text).map_err(|e| CliError::Failure(e.to_string()))?;
    let plan = lash_sweep::load(&file).map_err(|e| CliError::Failure(e.to_string()))?;
    println!("lash bench sweep: {title}");
    print_profile();
    println!(
        "  threads   runs side by side   wall [s]   runs/s   simulated s per wall s   per core   per CPU s   simulate [s]   write parts [s]   assemble [s]"
    );
    // One at a time (the workload as it was first measured) and side by side (eight runs per
    // worker, their micro models in vector lanes), alternating, each with 1 and 2 threads.
    let mut walls = std::collections::BTreeMap::new();
    for side_by_side in [1usize, lash_sweep::SIDE_BY_SIDE] {
        for threads in [1usize, 2] {
            let out = dir.join(format!("out-{threads}-{side_by_side}"));
            let options =
                lash_sweep::ExecuteOptions { out, shard: None, threads: Some(threads), cancel: None, side_by_side };
            let cpu = cpu_time::ProcessTime::now();
            let r = lash_sweep::execute(&plan, &options, &|_| {}).map_err(|e| CliError::Failure(e.to_string()))?;
            let cpu_s = cpu.elapsed().as_secs_f64();
            let throughput = r.simulated_s / r.wall_s;
            println!(
                "  {threads:7}   {side_by_side:16}   {:8.3}   {:6.1}   {throughput:22.1}   {:8.1}   {:9.1}   {:12.3}   {:15.3}   {:12.3}",
                r.wall_s,
                r.ran as f64 / r.wall_s,
                throughput / threads as f64,
                r.simulated_s / cpu_s,
                r.simulate_s,
                r.write_s,
                r.assemble_s
            );
            walls.insert((threads, side_by_side), r.wall_s);
        }
    }
    let data = |threads: usize, side_by_side: usize| {
        std::fs::read(dir.join(format!("out-{threads}-{side_by_side}/data.parquet"))).ok()
    };
    let lanes = lash_sweep::SIDE_BY_SIDE;
    let same = data(1, 1).is_some() && [(2, 1), (1, lanes), (2, lanes)].iter().all(|&(t, s)| data(t, s) == data(1, 1));
    println!(
        "  side by side vs one at a time: {:.2}× (1 thread), {:.2}× (2 threads); scaling 1 → 2 threads: {:.2}× side by side (target ≥ 1.8×)",
        walls[&(1, 1)] / walls[&(1, lanes)],
        walls[&(2, 1)] / walls[&(2, lanes)],
        walls[&(1, lanes)] / walls[&(2, lanes)]
    );
    println!("  data.parquet byte-identical across thread counts and side by side or not: {same}");
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// `lash bench fmu <file.fmu>`: the cost of one co-simulation step of any FMU through lash's
/// importer (`ImportedFmu::do_step`: tick-to-seconds conversion, the C call, the status check),
/// alone and followed by reading every numeric output, at the FMU's default step size. Medians of
/// five rounds after an untimed warm-up round. With `isolate`, the same for the FMU in a child
/// process (`IsolatedFmu`), in the same run, and the ratio.
pub fn fmu(path: &std::path::Path, quick: bool, isolate: bool) -> Result<(), CliError> {
    use lash_core::{Causality, Subsystem, Ticks};
    let cache = lash_fmi::import::default_cache();
    let fmu = lash_fmi::import::ImportedFmu::open(path, &cache, "bench").map_err(|e| CliError::Input(e.to_string()))?;
    let (step, whence) = match fmu.description().default_step_size {
        Some(h) => (h, "the FMU's default step size"),
        None => (0.01, "no default step size in the FMU: 0.01 s"),
    };
    let h =
        Ticks::from_seconds(step).map_err(|e| CliError::Input(format!("{}: stepSize {step}: {e}", path.display())))?;
    let steps: i64 = if quick { 100_000 } else { 1_000_000 };
    println!(
        "{}: FMI {} model {:?}, {} steps of {} s ({whence}) per round, median of 5 rounds",
        path.display(),
        fmu.fmi_version(),
        fmu.description().model_name,
        steps,
        h.seconds()
    );
    // Steps `fmu` for five timed rounds (plus a warm-up); medians of (do_step alone, with reads).
    let measure = |fmu: &mut dyn Subsystem, steps: i64| -> Result<(f64, f64, usize), CliError> {
        let fail = |e: lash_core::SubsystemError| CliError::Failure(format!("{}: {e}", path.display()));
        let numeric = |v: &&lash_core::Variable| v.causality == Causality::Output && v.kind.is_numeric();
        let outputs: Vec<u32> = fmu.variables().iter().filter(numeric).map(|v| v.value_reference).collect();
        let mut values = vec![0.0; fmu.variables().iter().filter(numeric).map(|v| v.len()).sum()];
        fmu.setup(Ticks::ZERO, None).map_err(fail)?;
        fmu.initialize().map_err(fail)?;
        let mut t = Ticks::ZERO;
        let mut round = |read: bool, t: &mut Ticks| -> Result<f64, CliError> {
            let start = Instant::now();
            for _ in 0..steps {
                if let Some(stop) = fmu.do_step(*t, h).map_err(fail)?.stop(*t, h) {
                    return Err(CliError::Failure(format!(
                        "{}: the FMU {stop}; a benchmark needs {steps} steps per round",
                        path.display()
                    )));
                }
                *t = Ticks(t.0 + h.0);
                if read {
                    fmu.get_f64(&outputs, &mut values).map_err(fail)?;
                }
            }
            black_box(&values);
            Ok(start.elapsed().as_secs_f64() / steps as f64)
        };
        round(true, &mut t)?;
        let (mut alone, mut with_get) = (Vec::new(), Vec::new());
        for _ in 0..5 {
            alone.push(round(false, &mut t)?);
            with_get.push(round(true, &mut t)?);
        }
        Ok((median(alone), median(with_get), outputs.len()))
    };
    let mut fmu = fmu;
    let (a, g, n) = measure(&mut fmu, steps)?;
    drop(fmu);
    println!("  in process:  do_step alone {:>10.1} ns per step", a * 1e9);
    println!("               do_step + get all {n} numeric outputs {:>10.1} ns per step", g * 1e9);
    println!("  (target for a tiny FMU such as VanDerPol in process: ≤ 80 ns per step)");
    if isolate {
        let host = std::env::current_exe().map_err(|e| CliError::Failure(format!("the lash executable: {e}")))?;
        let mut isolated =
            lash_fmi::isolate::IsolatedFmu::spawn(&host, path, &cache, "bench", std::time::Duration::from_secs(60))
                .map_err(|e| CliError::Input(format!("{}: {}", path.display(), lash_core::error_chain(&e))))?;
        // A round trip between processes costs microseconds: a hundredth of the steps.
        let (ia, ig, _) = measure(&mut isolated, (steps / 100).max(1000))?;
        println!("  isolated:    do_step alone {:>10.1} ns per step ({:.0}× in process)", ia * 1e9, ia / a);
        println!(
            "               do_step + get all {n} numeric outputs {:>10.1} ns per step ({:.0}× in process)",
            ig * 1e9,
            ig / g
        );
    }
    Ok(())
}
