//! Several interface masters side by side, a macro step at a time (sweeps' lanes).

use super::*;

/// What is done with the macro subsystems of runs stepped together before each of their macro
/// steps (the same `t` and `h` for all): nothing, or work that their `do_step(t, h)` then takes
/// instead of doing it alone — e.g. lash-mech's `kinematic_steps_ahead`, which analyses fully
/// driven mechanisms in lanes. It must leave each subsystem's results as its own `do_step` would
/// make them.
pub type GroupAhead<'f> = dyn FnMut(&mut [&mut dyn Subsystem], Ticks, Ticks) + 'f;

/// One run of [`InterfaceMaster::run_together`] between macro steps.
struct Lane {
    p: Prepared,
    window: VecDeque<Vec<f64>>,
    prev: Option<Vec<f64>>,
    /// A frame done with, whose storage the next macro frame takes.
    spare: Option<Vec<f64>>,
    produced: usize,
    inputs: Vec<f64>,
    left: Vec<u64>,
    rows: Vec<f64>,
    micro_count: u64,
}

impl<'a> InterfaceMaster<'a> {
    /// Runs several masters side by side, a macro step at a time, their micro subsystems advanced
    /// together by `step` once per macro step: each run's result is what its own
    /// [`InterfaceMaster::run`] gives (the same calls in the same order on its subsystems and
    /// observers). Runs together only masters with the same options, one-way coupling,
    /// sequential execution, inputs held as value and rate (not cubic Hermite), the same observer
    /// intervals and the same micro outputs; otherwise each runs alone.
    pub fn run_together(
        masters: &mut [InterfaceMaster<'a>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        step: &mut GroupStep<'_>,
        ahead: &mut GroupAhead<'_>,
    ) -> Vec<Result<MasterStats, MasterError>> {
        assert_eq!(masters.len(), observers.len(), "one observer list per master");
        let o = masters.first().map(|m| m.options);
        let intervals = |obs: &[(&mut dyn Observer, Ticks)]| obs.iter().map(|(_, t)| *t).collect::<Vec<_>>();
        let alike = o.is_some_and(|o| {
            o.coupling == Coupling::OneWay
                && o.execution == Execution::Sequential
                && o.interpolation != Interpolation::CubicHermite
                && masters.iter().all(|m| m.options == o)
                && observers.iter().all(|obs| intervals(obs) == intervals(observers[0]))
        });
        if !alike {
            return masters.iter_mut().zip(observers.iter_mut()).map(|(m, obs)| m.run(obs)).collect();
        }
        let o = o.expect("masters");
        let mut results: Vec<Option<Result<MasterStats, MasterError>>> = masters.iter().map(|_| None).collect();
        let mut lanes: Vec<Option<Lane>> = Vec::with_capacity(masters.len());
        for (i, (m, obs)) in masters.iter_mut().zip(observers.iter_mut()).enumerate() {
            let lane = m.prepare(obs).and_then(|mut p| {
                let w = Window { prev: None, a: &p.first, b: &p.first, next: None, h: p.h_m };
                p.table.prepare(&w);
                p.table.fill(0.0, &p.micro_values[..p.loads], &p.micro_values, &mut p.signals);
                for (ob, _) in obs.iter_mut() {
                    ob.observe(o.start, &p.signals).map_err(MasterError::Observer)?;
                }
                let mut window = VecDeque::with_capacity(4);
                window.push_back(p.first.clone());
                Ok(Lane {
                    inputs: vec![0.0; p.width_in],
                    left: p.decimation.clone(),
                    rows: vec![0.0; p.per_macro * p.micro_width],
                    window,
                    prev: None,
                    spare: None,
                    produced: 0,
                    micro_count: 0,
                    p,
                })
            });
            match lane {
                Ok(l) => lanes.push(Some(l)),
                Err(e) => {
                    results[i] = Some(Err(e));
                    lanes.push(None);
                }
            }
        }
        // The same outputs read from every micro subsystem (one list for the group call).
        let refs = lanes.iter().flatten().next().map(|l| l.p.micro_outputs.clone()).unwrap_or_default();
        if lanes.iter().flatten().any(|l| l.p.micro_outputs != refs) {
            for (i, lane) in lanes.iter_mut().enumerate() {
                if lane.take().is_some() {
                    results[i] = Some(Err(MasterError::Settings(
                        "runs stepped together must read the same micro outputs".into(),
                    )));
                }
            }
        }
        let (per_macro, macro_steps) = match lanes.iter().flatten().next() {
            Some(l) => (l.p.per_macro, l.p.macro_steps),
            None => (0, 0),
        };
        let kind = o.interpolation;
        let (mut due, mut scratch) = (vec![false; per_macro], Vec::new());
        for step_index in 0..macro_steps {
            let t_k = Ticks(o.start.0 + step_index as i64 * o.macro_step.0);
            // Each run: its macro step. (Timed for the group and shared, as the micro steps are:
            // two clock reads per run and macro step were ~1 % of a sweep of scenario A.)
            let started = Instant::now();
            let stepping = lanes.iter().flatten().count();
            // Macro step by macro step (the runs produce the same steps: same options), each
            // preceded by the group's `ahead`.
            loop {
                let due = |l: &Lane| l.produced < (step_index + l.p.ahead).min(macro_steps);
                let Some(produced) = lanes.iter().flatten().filter(|l| due(l)).map(|l| l.produced).min() else {
                    break;
                };
                let t = Ticks(o.start.0 + produced as i64 * o.macro_step.0);
                {
                    let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(lanes.len());
                    for (lane, m) in lanes.iter().zip(masters.iter_mut()) {
                        if lane.as_ref().is_some_and(|l| due(l) && l.produced == produced) {
                            subs.push(&mut *m.macro_sub);
                        }
                    }
                    ahead(&mut subs, t, o.macro_step);
                }
                for (i, (lane, m)) in lanes.iter_mut().zip(masters.iter_mut()).enumerate() {
                    let Some(l) = lane else { continue };
                    if !due(l) || l.produced != produced {
                        continue;
                    }
                    let stepped =
                        step_macro(&mut *m.macro_sub, &l.p.all_macro, l.p.width, t, o.macro_step, None, l.spare.take());
                    match stepped {
                        Ok(frame) => {
                            l.window.push_back(frame);
                            l.produced += 1;
                            l.p.stats.macro_steps += 1;
                        }
                        Err(e) => {
                            results[i] = Some(Self::ended(e, &mut l.p.stats));
                            *lane = None;
                        }
                    }
                }
            }
            let share = started.elapsed().as_secs_f64() / (stepping.max(1) as f64);
            // Each run: its micro inputs for the interval.
            for (i, (lane, m)) in lanes.iter_mut().zip(masters.iter_mut()).enumerate() {
                let Some(l) = lane else { continue };
                l.p.stats.macro_seconds += share;
                let prepared = {
                    let w = Window {
                        prev: l.prev.as_deref(),
                        a: &l.window[0],
                        b: &l.window[1],
                        next: l.window.get(2).map(|v| v.as_slice()),
                        h: l.p.h_m,
                    };
                    l.p.table.prepare(&w);
                    l.p.index.fill(&w, kind, 0.0, &mut l.inputs);
                    m.micro_sub.set_f64(&l.p.micro_inputs, &l.inputs).map_err(micro_err)
                };
                if let Err(e) = prepared {
                    results[i] = Some(Self::ended(e, &mut l.p.stats));
                    *lane = None;
                }
            }
            // The steps at which an observer is due (the same countdowns in every run).
            let Some(first) = lanes.iter().flatten().next() else { break };
            scratch.resize(first.left.len(), 0);
            due_steps(&first.left, &first.p.decimation, &mut scratch, &mut due);
            // Every run's micro interval in one call.
            let started = Instant::now();
            let members: Vec<usize> = (0..lanes.len()).filter(|&i| lanes[i].is_some()).collect();
            let outcomes = {
                let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(members.len());
                let mut rows: Vec<&mut [f64]> = Vec::with_capacity(members.len());
                for (m, lane) in masters.iter_mut().zip(lanes.iter_mut()) {
                    if let Some(l) = lane {
                        subs.push(&mut *m.micro_sub);
                        rows.push(&mut l.rows[..]);
                    }
                }
                let t = t_k;
                step(&mut subs, t, o.micro_step, &due, &refs, &mut rows)
            };
            let share = started.elapsed().as_secs_f64() / members.len().max(1) as f64;
            // Each run: its samples, in order, to its observers.
            for (&i, steps) in members.iter().zip(outcomes) {
                let (Some(l), obs) = (lanes[i].as_mut(), &mut observers[i]) else { continue };
                l.p.stats.micro_seconds += share;
                let processed = (|| -> Result<(), MasterError> {
                    let (completed, outcome) = steps_outcome(steps, "micro", t_k, o.micro_step, due.len());
                    l.micro_count += completed as u64;
                    l.p.deliver(obs, &mut l.left, (&due, completed), &l.rows, (t_k, 0), o.micro_step)?;
                    l.p.stats.micro_steps = l.micro_count;
                    if let Some(reason) = outcome? {
                        return Err(MasterError::Stopped { subsystem: "micro", reason });
                    }
                    Ok(())
                })();
                if let Err(e) = processed {
                    results[i] = Some(Self::ended(e, &mut l.p.stats));
                    lanes[i] = None;
                    continue;
                }
                l.spare = std::mem::replace(&mut l.prev, l.window.pop_front());
            }
        }
        for (i, lane) in lanes.into_iter().enumerate() {
            if let Some(mut l) = lane {
                l.p.stats.micro_steps = l.micro_count;
                results[i] = Some(Ok(l.p.stats));
            }
        }
        results.into_iter().map(|r| r.expect("every run ends")).collect()
    }

    /// A run ended by `e`: a stop is a clean end (the observers keep what they have), anything
    /// else the run's error.
    fn ended(e: MasterError, stats: &mut MasterStats) -> Result<MasterStats, MasterError> {
        match e {
            MasterError::Stopped { subsystem, reason } => {
                stats.stopped = Some((subsystem.to_string(), reason));
                Ok(stats.clone())
            }
            other => Err(other),
        }
    }
}
