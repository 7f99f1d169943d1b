//! Several interface masters side by side, a macro step at a time (sweeps' lanes).

use super::*;

/// What is done with the macro subsystems of runs stepped together before each of their macro
/// steps (the same `t` and `h` for all): nothing, or work that their `do_step(t, h)` then takes
/// instead of doing it alone — e.g. lash-mech's `kinematic_steps_ahead`, which analyses fully
/// driven mechanisms in lanes. It must leave each subsystem's results as its own `do_step` would
/// make them.
pub type GroupAhead<'f, Ma = dyn Subsystem> = dyn FnMut(&mut [&mut Ma], Ticks, Ticks) + 'f;

impl<'a, Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized> InterfaceMaster<'a, Ma, Mi> {
    /// Runs several masters side by side, a macro step at a time, their micro subsystems advanced
    /// together by `step` once per macro step: each run's result is what its own
    /// [`InterfaceMaster::run`] gives (the same calls in the same order on its subsystems and
    /// observers). Runs together only masters with the same options, one-way coupling,
    /// sequential execution, inputs held as value and rate (not cubic Hermite), the same observer
    /// intervals and the same micro outputs; otherwise each runs alone.
    pub fn run_together(
        masters: &mut [InterfaceMaster<'a, Ma, Mi>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        step: &mut GroupStep<'_, Mi>,
        ahead: &mut GroupAhead<'_, Ma>,
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
        let mut group = Group::start(masters, observers, o.start);
        let macro_steps = group.lanes.iter().flatten().next().map_or(0, |s| s.p.macro_steps);
        let mut due = Vec::new();
        for step_index in 0..macro_steps {
            let t_k = Ticks(o.start.0 + step_index as i64 * o.macro_step.0);
            // Each run: its macro step. (Timed for the group and shared, as the micro steps are:
            // two clock reads per run and macro step were ~1 % of a sweep of scenario A.)
            let started = Instant::now();
            let stepping = group.lanes.iter().flatten().count();
            group.macro_steps(masters, step_index, &o, ahead);
            let share = started.elapsed().as_secs_f64() / (stepping.max(1) as f64);
            group.set_micro_inputs(masters, o.interpolation, share);
            // The steps at which an observer is due (the same countdowns in every run): each
            // run plans its own, the first one's go to the group's step.
            let mut lanes = group.lanes.iter_mut().flatten();
            let Some(first) = lanes.next() else { break };
            let per_macro = first.p.per_macro;
            due.clear();
            due.extend_from_slice(first.plan(per_macro));
            lanes.for_each(|s| _ = s.plan(per_macro));
            group.micro_interval(masters, observers, step, (t_k, o.micro_step), &due);
        }
        group.finish()
    }
}

/// A run ended by `e`: a stop is a clean end (the observers keep what they have), anything else
/// the run's error.
fn ended(e: MasterError, stats: &mut MasterStats) -> Result<MasterStats, MasterError> {
    match e {
        MasterError::Stopped { subsystem, reason } => {
            stats.stopped = Some((subsystem.to_string(), reason));
            Ok(stats.clone())
        }
        other => Err(other),
    }
}

/// The runs of [`InterfaceMaster::run_together`]: each one's lane while it runs, its result
/// once it has ended.
struct Group {
    lanes: Vec<Option<Stepper>>,
    results: Vec<Option<Result<MasterStats, MasterError>>>,
    /// The micro outputs read from every micro subsystem (one list for the group call).
    refs: Vec<ValueReference>,
}

impl Group {
    /// Each run prepared and its observers' samples at the start taken; runs that read other
    /// micro outputs than the first are refused.
    fn start<Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized>(
        masters: &mut [InterfaceMaster<'_, Ma, Mi>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        start: Ticks,
    ) -> Self {
        let mut g = Group {
            lanes: Vec::with_capacity(masters.len()),
            results: masters.iter().map(|_| None).collect(),
            refs: Vec::new(),
        };
        for (i, (m, obs)) in masters.iter_mut().zip(observers.iter_mut()).enumerate() {
            let lane = m.prepare(obs).and_then(|p| Stepper::start(p, obs, start));
            match lane {
                Ok(l) => g.lanes.push(Some(l)),
                Err(e) => {
                    g.results[i] = Some(Err(e));
                    g.lanes.push(None);
                }
            }
        }
        g.refs = g.lanes.iter().flatten().next().map(|l| l.p.micro_outputs.clone()).unwrap_or_default();
        if g.lanes.iter().flatten().any(|l| l.p.micro_outputs != g.refs) {
            for (i, lane) in g.lanes.iter_mut().enumerate() {
                if lane.take().is_some() {
                    g.results[i] = Some(Err(MasterError::Settings(
                        "runs stepped together must read the same micro outputs".into(),
                    )));
                }
            }
        }
        g
    }

    /// Ends run `i` with `e`.
    fn end(&mut self, i: usize, e: MasterError) {
        if let Some(mut l) = self.lanes[i].take() {
            self.results[i] = Some(ended(e, l.stats()));
        }
    }

    /// Each run's macro frames up to what macro step `step_index` needs, macro step by macro
    /// step (the runs produce the same steps: same options), each preceded by the group's
    /// `ahead`.
    fn macro_steps<Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized>(
        &mut self,
        masters: &mut [InterfaceMaster<'_, Ma, Mi>],
        step_index: usize,
        o: &MasterOptions,
        ahead: &mut GroupAhead<'_, Ma>,
    ) {
        while let Some(t) = self.lanes.iter().flatten().filter_map(|s| s.wants_frame(step_index, o)).min() {
            {
                let mut subs: Vec<&mut Ma> = Vec::with_capacity(self.lanes.len());
                for (lane, m) in self.lanes.iter().zip(masters.iter_mut()) {
                    if lane.as_ref().is_some_and(|s| s.wants_frame(step_index, o) == Some(t)) {
                        subs.push(&mut *m.macro_sub);
                    }
                }
                ahead(&mut subs, t, o.macro_step);
            }
            for (i, m) in masters.iter_mut().enumerate() {
                let Some(s) = self.lanes[i].as_mut() else { continue };
                if s.wants_frame(step_index, o) != Some(t) {
                    continue;
                }
                let spare = s.take_spare();
                match step_macro(
                    m.macro_sub.as_subsystem_mut(),
                    &s.p.all_macro,
                    s.p.width,
                    t,
                    o.macro_step,
                    None,
                    spare,
                ) {
                    Ok(frame) => s.push_frame(frame),
                    Err(e) => self.end(i, e),
                }
            }
        }
    }

    /// Each run: its share of the macro time and its micro inputs for the interval.
    fn set_micro_inputs<Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized>(
        &mut self,
        masters: &mut [InterfaceMaster<'_, Ma, Mi>],
        kind: Interpolation,
        share: f64,
    ) {
        for (i, m) in masters.iter_mut().enumerate() {
            let Some(s) = self.lanes[i].as_mut() else { continue };
            s.stats().macro_seconds += share;
            s.begin_interval();
            if let Err(e) = s.set_inputs(m.micro_sub.as_subsystem_mut(), kind, 0) {
                self.end(i, e);
            }
        }
    }

    /// Every run's micro interval in one call of `step`, then each run's samples, in order, to
    /// its observers.
    fn micro_interval<Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized>(
        &mut self,
        masters: &mut [InterfaceMaster<'_, Ma, Mi>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        step: &mut GroupStep<'_, Mi>,
        (t_k, h): (Ticks, Ticks),
        due: &[bool],
    ) {
        let started = Instant::now();
        let members: Vec<usize> = (0..self.lanes.len()).filter(|&i| self.lanes[i].is_some()).collect();
        let outcomes = {
            let mut subs: Vec<&mut Mi> = Vec::with_capacity(members.len());
            let mut rows: Vec<&mut [f64]> = Vec::with_capacity(members.len());
            for (m, lane) in masters.iter_mut().zip(self.lanes.iter_mut()) {
                if let Some(l) = lane {
                    subs.push(&mut *m.micro_sub);
                    rows.push(&mut l.rows[..]);
                }
            }
            step(&mut subs, t_k, h, due, &self.refs, &mut rows)
        };
        let share = started.elapsed().as_secs_f64() / members.len().max(1) as f64;
        for (&i, steps) in members.iter().zip(outcomes) {
            let (Some(l), obs) = (self.lanes[i].as_mut(), &mut observers[i]) else { continue };
            let (completed, outcome) = steps_outcome(steps, "micro", t_k, h, due.len());
            let absorbed = l.absorb(obs, (due.len(), completed), (t_k, 0), h, outcome);
            l.stats().micro_seconds += share;
            match absorbed {
                Err(e) => self.end(i, e),
                Ok(()) => l.end_step(),
            }
        }
    }

    /// Every run's result.
    fn finish(self) -> Vec<Result<MasterStats, MasterError>> {
        let mut results = self.results;
        for (i, lane) in self.lanes.into_iter().enumerate() {
            if let Some(mut s) = lane {
                results[i] = Some(Ok(s.stats().clone()));
            }
        }
        results.into_iter().map(|r| r.expect("every run ends")).collect()
    }
}
