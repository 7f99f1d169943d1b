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
        let mut group = Group::start(masters, observers, o.start);
        let (per_macro, macro_steps) = match group.lanes.iter().flatten().next() {
            Some(l) => (l.p.per_macro, l.p.macro_steps),
            None => (0, 0),
        };
        let (mut due, mut scratch) = (vec![false; per_macro], Vec::new());
        for step_index in 0..macro_steps {
            let t_k = Ticks(o.start.0 + step_index as i64 * o.macro_step.0);
            // Each run: its macro step. (Timed for the group and shared, as the micro steps are:
            // two clock reads per run and macro step were ~1 % of a sweep of scenario A.)
            let started = Instant::now();
            let stepping = group.lanes.iter().flatten().count();
            group.macro_steps(masters, (step_index, macro_steps), &o, ahead);
            let share = started.elapsed().as_secs_f64() / (stepping.max(1) as f64);
            group.set_micro_inputs(masters, o.interpolation, share);
            // The steps at which an observer is due (the same countdowns in every run).
            let Some(first) = group.lanes.iter().flatten().next() else { break };
            scratch.resize(first.left.len(), 0);
            due_steps(&first.left, &first.p.decimation, &mut scratch, &mut due);
            group.micro_interval(masters, observers, step, (t_k, o.micro_step), &due);
        }
        group.finish()
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

/// The runs of [`InterfaceMaster::run_together`]: each one's lane while it runs, its result
/// once it has ended.
struct Group {
    lanes: Vec<Option<Lane>>,
    results: Vec<Option<Result<MasterStats, MasterError>>>,
    /// The micro outputs read from every micro subsystem (one list for the group call).
    refs: Vec<ValueReference>,
}

impl Group {
    /// Each run prepared and its observers' samples at the start taken; runs that read other
    /// micro outputs than the first are refused.
    fn start(
        masters: &mut [InterfaceMaster<'_>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        start: Ticks,
    ) -> Self {
        let mut g = Group {
            lanes: Vec::with_capacity(masters.len()),
            results: masters.iter().map(|_| None).collect(),
            refs: Vec::new(),
        };
        for (i, (m, obs)) in masters.iter_mut().zip(observers.iter_mut()).enumerate() {
            let lane = m.prepare(obs).and_then(|mut p| {
                p.observe_start(obs, start)?;
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
            self.results[i] = Some(InterfaceMaster::ended(e, &mut l.p.stats));
        }
    }

    /// Each run's macro frames up to what macro step `step_index` needs, macro step by macro
    /// step (the runs produce the same steps: same options), each preceded by the group's
    /// `ahead`.
    fn macro_steps(
        &mut self,
        masters: &mut [InterfaceMaster<'_>],
        (step_index, macro_steps): (usize, usize),
        o: &MasterOptions,
        ahead: &mut GroupAhead<'_>,
    ) {
        loop {
            let due = |l: &Lane| l.produced < (step_index + l.p.ahead).min(macro_steps);
            let Some(produced) = self.lanes.iter().flatten().filter(|l| due(l)).map(|l| l.produced).min() else {
                break;
            };
            let t = Ticks(o.start.0 + produced as i64 * o.macro_step.0);
            {
                let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(self.lanes.len());
                for (lane, m) in self.lanes.iter().zip(masters.iter_mut()) {
                    if lane.as_ref().is_some_and(|l| due(l) && l.produced == produced) {
                        subs.push(&mut *m.macro_sub);
                    }
                }
                ahead(&mut subs, t, o.macro_step);
            }
            for (i, m) in masters.iter_mut().enumerate() {
                let Some(l) = self.lanes[i].as_mut() else { continue };
                if !due(l) || l.produced != produced {
                    continue;
                }
                match step_macro(&mut *m.macro_sub, &l.p.all_macro, l.p.width, t, o.macro_step, None, l.spare.take()) {
                    Ok(frame) => {
                        l.window.push_back(frame);
                        l.produced += 1;
                        l.p.stats.macro_steps += 1;
                    }
                    Err(e) => self.end(i, e),
                }
            }
        }
    }

    /// Each run: its share of the macro time and its micro inputs for the interval.
    fn set_micro_inputs(&mut self, masters: &mut [InterfaceMaster<'_>], kind: Interpolation, share: f64) {
        for (i, m) in masters.iter_mut().enumerate() {
            let Some(l) = self.lanes[i].as_mut() else { continue };
            l.p.stats.macro_seconds += share;
            let w = Window {
                prev: l.prev.as_deref(),
                a: &l.window[0],
                b: &l.window[1],
                next: l.window.get(2).map(|v| v.as_slice()),
                h: l.p.h_m,
            };
            l.p.table.prepare(&w);
            l.p.index.fill(&w, kind, 0.0, &mut l.inputs);
            if let Err(e) = m.micro_sub.set_f64(&l.p.micro_inputs, &l.inputs).map_err(micro_err) {
                self.end(i, e);
            }
        }
    }

    /// Every run's micro interval in one call of `step`, then each run's samples, in order, to
    /// its observers.
    fn micro_interval(
        &mut self,
        masters: &mut [InterfaceMaster<'_>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        step: &mut GroupStep<'_>,
        (t_k, h): (Ticks, Ticks),
        due: &[bool],
    ) {
        let started = Instant::now();
        let members: Vec<usize> = (0..self.lanes.len()).filter(|&i| self.lanes[i].is_some()).collect();
        let outcomes = {
            let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(members.len());
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
            l.p.stats.micro_seconds += share;
            let processed = (|| -> Result<(), MasterError> {
                let (completed, outcome) = steps_outcome(steps, "micro", t_k, h, due.len());
                l.micro_count += completed as u64;
                l.p.deliver(obs, &mut l.left, (due, completed), &l.rows, (t_k, 0), h)?;
                l.p.stats.micro_steps = l.micro_count;
                if let Some(reason) = outcome? {
                    return Err(MasterError::Stopped { subsystem: "micro", reason });
                }
                Ok(())
            })();
            match processed {
                Err(e) => self.end(i, e),
                Ok(()) => l.spare = std::mem::replace(&mut l.prev, l.window.pop_front()),
            }
        }
    }

    /// Every run's result.
    fn finish(self) -> Vec<Result<MasterStats, MasterError>> {
        let mut results = self.results;
        for (i, lane) in self.lanes.into_iter().enumerate() {
            if let Some(mut l) = lane {
                l.p.stats.micro_steps = l.micro_count;
                results[i] = Some(Ok(l.p.stats));
            }
        }
        results.into_iter().map(|r| r.expect("every run ends")).collect()
    }
}
