//! The per-run state machine of the interface master, written once: a single run
//! ([`InterfaceMaster::run`]) and every run of a group ([`InterfaceMaster::run_together`]) step
//! through the same [`Stepper`] — start, take the macro frames a step needs, set the micro
//! inputs, absorb the micro rows into the observers, and (two-way) predict and correct.
//! The drivers differ only in who advances the micro subsystem (itself, or the group's lane
//! step) and where the macro frames come from (in place, a producer thread, or the group).

use super::*;

/// One run between macro steps.
pub(crate) struct Stepper {
    pub(crate) p: Prepared,
    /// The macro nodes of the current step onwards (the step's start first).
    window: VecDeque<Vec<f64>>,
    /// The node before the window (cubic Hermite slopes).
    prev: Option<Vec<f64>>,
    /// A frame done with, whose storage the next macro frame takes (no allocation per step).
    spare: Option<Vec<f64>>,
    /// Macro frames produced so far (after the first).
    produced: usize,
    micro_count: u64,
    inputs: Vec<f64>,
    /// Countdown of each observer to its next sample (in micro steps): no division per step.
    left: Vec<u64>,
    /// Which micro steps of an interval any observer samples (the micro outputs are read only
    /// there), and the rows the micro subsystem records at them.
    due: Vec<bool>,
    scratch: Vec<u64>,
    pub(crate) rows: Vec<f64>,
    /// Two-way: the targets (e, ė at the step end, mean F_T over the step), the friction
    /// impulses at the step start and the last step's mean friction forces.
    targets: Vec<f64>,
    impulse_start: Vec<f64>,
    mean_friction: Vec<f64>,
}

/// The node window of `window` (its first node the step's start), `prev` before it.
fn window_of<'f>(window: &'f VecDeque<Vec<f64>>, prev: &'f Option<Vec<f64>>, h: f64) -> Window<'f> {
    Window { prev: prev.as_deref(), a: &window[0], b: &window[1], next: window.get(2).map(|v| v.as_slice()), h }
}

impl Stepper {
    /// A run prepared by [`InterfaceMaster::prepare`], its observers' samples at `start` taken.
    pub(crate) fn start(
        mut p: Prepared,
        observers: &mut [(&mut dyn Observer, Ticks)],
        start: Ticks,
    ) -> Result<Self, MasterError> {
        p.observe_start(observers, start)?;
        let mut window = VecDeque::with_capacity(4);
        window.push_back(p.first.clone());
        Ok(Stepper {
            window,
            prev: None,
            spare: None,
            produced: 0,
            micro_count: 0,
            inputs: vec![0.0; p.width_in],
            left: p.decimation.clone(),
            due: vec![false; p.per_macro],
            scratch: p.decimation.clone(),
            rows: vec![0.0; p.per_macro * p.micro_width],
            targets: vec![0.0; 2 * p.n + p.k],
            impulse_start: vec![0.0; p.k],
            mean_friction: vec![0.0; p.k],
            p,
        })
    }

    /// The start time of the next macro frame this run needs before it can take macro step
    /// `step` (one node ahead, two for cubic Hermite), or `None` when it has them all.
    pub(crate) fn wants_frame(&self, step: usize, o: &MasterOptions) -> Option<Ticks> {
        (self.produced < (step + self.p.ahead).min(self.p.macro_steps))
            .then(|| Ticks(o.start.0 + self.produced as i64 * o.macro_step.0))
    }

    /// Storage for the next macro frame.
    pub(crate) fn take_spare(&mut self) -> Option<Vec<f64>> {
        self.spare.take()
    }

    /// The next macro frame.
    pub(crate) fn push_frame(&mut self, frame: Vec<f64>) {
        self.window.push_back(frame);
        self.produced += 1;
        self.p.stats.macro_steps += 1;
    }

    /// The macro step is over: its start node becomes the one before, the one before is spare.
    pub(crate) fn end_step(&mut self) {
        self.spare = std::mem::replace(&mut self.prev, self.window.pop_front());
    }

    /// Ready for the micro interval of the current macro step: the signal table's macro
    /// interpolation set up (once per step).
    pub(crate) fn begin_interval(&mut self) {
        self.p.table.prepare(&window_of(&self.window, &self.prev, self.p.h_m));
    }

    /// The micro inputs at micro step `j` of the current macro step, set on `micro_sub`.
    pub(crate) fn set_inputs(
        &mut self,
        micro_sub: &mut dyn Subsystem,
        kind: Interpolation,
        j: usize,
    ) -> Result<(), MasterError> {
        let w = window_of(&self.window, &self.prev, self.p.h_m);
        self.p.index.fill(&w, kind, self.p.fractions[j], &mut self.inputs);
        micro_sub.set_f64(&self.p.micro_inputs, &self.inputs).map_err(micro_err)
    }

    /// Which of the next `len` micro steps any observer samples.
    pub(crate) fn plan(&mut self, len: usize) -> &[bool] {
        due_steps(&self.left, &self.p.decimation, &mut self.scratch, &mut self.due[..len]);
        &self.due[..len]
    }

    /// The rows of `completed` micro steps from micro step `first` of the macro step from
    /// `t_k` (sampled where the last [`Stepper::plan`] of `len` steps said), to the observers;
    /// `outcome` is how the micro call ended.
    pub(crate) fn absorb(
        &mut self,
        observers: &mut [(&mut dyn Observer, Ticks)],
        (len, completed): (usize, usize),
        (t_k, first): (Ticks, usize),
        h: Ticks,
        outcome: Result<Option<StopReason>, MasterError>,
    ) -> Result<(), MasterError> {
        self.micro_count += completed as u64;
        self.p.stats.micro_steps = self.micro_count;
        self.p.deliver(observers, &mut self.left, (&self.due[..len], completed), &self.rows, (t_k, first), h)?;
        match outcome? {
            Some(reason) => Err(MasterError::Stopped { subsystem: "micro", reason }),
            None => Ok(()),
        }
    }

    /// The micro subsystem of a run alone over the macro step from `t_k`, its samples to the
    /// observers. Linear and held inputs are exact as value + rate from the macro node: the
    /// micro subsystem extrapolates u(t_k) + u̇ (τ − t_k) itself, so they are set once and the
    /// whole interval is one call (as FMI input derivatives); cubic Hermite inputs are set
    /// before every micro step.
    #[inline(always)]
    pub(crate) fn micro_interval(
        &mut self,
        o: &MasterOptions,
        micro_sub: &mut dyn Subsystem,
        observers: &mut [(&mut dyn Observer, Ticks)],
        t_k: Ticks,
    ) -> Result<(), MasterError> {
        let started = Instant::now();
        let _span = tracing::trace_span!("micro_interval", t = t_k.seconds()).entered();
        self.begin_interval();
        let per_macro = self.p.per_macro;
        let batch = if o.interpolation == Interpolation::CubicHermite { 1 } else { per_macro };
        let mut j = 0;
        let result = loop {
            if j >= per_macro {
                break Ok(());
            }
            if let Err(e) = self.set_inputs(micro_sub, o.interpolation, j) {
                break Err(e);
            }
            self.plan(batch);
            let t = Ticks(t_k.0 + j as i64 * o.micro_step.0);
            let due = &self.due[..batch];
            let (completed, outcome) =
                advance_steps(micro_sub, "micro", t, o.micro_step, due, &self.p.micro_outputs, &mut self.rows);
            if let Err(e) = self.absorb(observers, (batch, completed), (t_k, j), o.micro_step, outcome) {
                break Err(e);
            }
            j += batch;
        };
        if result.is_ok() {
            self.p.stats.micro_seconds += started.elapsed().as_secs_f64();
        }
        result
    }

    /// Two-way predictor: e + ė h_m, ė, and the last step's mean friction forces.
    pub(crate) fn predict(&mut self) {
        let (p, n, k) = (&self.p, self.p.n, self.p.k);
        let c = &p.coupling_values;
        for i in 0..n {
            let (e, v) = (c[p.ecc_at + i], c[p.rate_at + i]);
            self.targets[i] = e + v * p.h_m;
            self.targets[n + i] = v;
        }
        self.targets[2 * n..].copy_from_slice(&self.mean_friction);
        self.impulse_start.copy_from_slice(&c[p.impulse_at..p.impulse_at + k]);
    }

    /// Two-way corrector targets: the micro's e and ė at the step end (read from `micro_sub`),
    /// its mean friction forces over the step.
    pub(crate) fn correct(&mut self, micro_sub: &dyn Subsystem) -> Result<(), MasterError> {
        let p = &mut self.p;
        micro_sub.get_f64(&p.coupling_outputs, &mut p.coupling_values).map_err(micro_err)?;
        let (n, c) = (p.n, &p.coupling_values);
        self.targets[..2 * n].copy_from_slice(&c[..2 * n]);
        for j in 0..p.k {
            self.mean_friction[j] = (c[p.impulse_at + j] - self.impulse_start[j]) / p.h_m;
        }
        self.targets[2 * n..].copy_from_slice(&self.mean_friction);
        Ok(())
    }

    /// The two-way targets of the macro step (after [`Stepper::predict`] or
    /// [`Stepper::correct`]).
    pub(crate) fn targets(&self) -> &[f64] {
        &self.targets
    }

    /// The corrected end node of the current macro step, in place of the predicted one.
    pub(crate) fn replace_end(&mut self, frame: Vec<f64>) {
        self.window[1] = frame;
        self.p.stats.macro_steps += 1;
    }

    /// The run's counters and time split.
    pub(crate) fn stats(&mut self) -> &mut MasterStats {
        &mut self.p.stats
    }
}

/// Which of the next `due.len()` micro steps an observer samples: a dry run of the countdowns
/// `left` (each observer's steps to its next sample; `decimation`, its interval in steps) in
/// `scratch`.
fn due_steps(left: &[u64], decimation: &[u64], scratch: &mut [u64], due: &mut [bool]) {
    scratch.copy_from_slice(left);
    for d in due.iter_mut() {
        *d = false;
        for (l, p) in scratch.iter_mut().zip(decimation) {
            *l -= 1;
            if *l == 0 {
                *d = true;
                *l = *p;
            }
        }
    }
}

impl Prepared {
    /// The observers' samples at the start.
    fn observe_start(&mut self, observers: &mut [(&mut dyn Observer, Ticks)], start: Ticks) -> Result<(), MasterError> {
        let w = Window { prev: None, a: &self.first, b: &self.first, next: None, h: self.h_m };
        self.table.prepare(&w);
        self.table.fill(0.0, &self.micro_values[..self.loads], &self.micro_values, &mut self.signals);
        for (obs, _) in observers.iter_mut() {
            obs.observe(start, &self.signals).map_err(MasterError::Observer)?;
        }
        Ok(())
    }

    /// The samples of the first `completed` micro steps of one call of the micro subsystem
    /// that began at micro step `first` of the macro step from `t_k`, in order, to the observers
    /// whose countdown (`left`) reaches zero. `due` flags the steps at which any observer
    /// samples; `rows` holds their micro outputs, one row per flagged step. The countdowns reach
    /// zero only at flagged steps, so each is taken down to the next one at once (what one step
    /// at a time gives).
    #[inline(always)]
    fn deliver(
        &mut self,
        observers: &mut [(&mut dyn Observer, Ticks)],
        left: &mut [u64],
        (due, completed): (&[bool], usize),
        rows: &[f64],
        (t_k, first): (Ticks, usize),
        micro_step: Ticks,
    ) -> Result<(), MasterError> {
        let width = self.micro_width;
        let mut counted = 0;
        let flagged = due[..completed].iter().enumerate().filter(|&(_, &d)| d).map(|(j, _)| j);
        for (row, j) in flagged.enumerate() {
            let steps = (j + 1 - counted) as u64;
            counted = j + 1;
            for c in left.iter_mut() {
                *c -= steps;
            }
            let micro = &rows[row * width..(row + 1) * width];
            self.table.fill(self.fractions[first + j + 1], &micro[..self.loads], micro, &mut self.signals);
            let t1 = Ticks(t_k.0 + (first + j) as i64 * micro_step.0 + micro_step.0);
            for (((ob, _), c), d) in observers.iter_mut().zip(left.iter_mut()).zip(&self.decimation) {
                if *c == 0 {
                    *c = *d;
                    ob.observe(t1, &self.signals).map_err(MasterError::Observer)?;
                }
            }
        }
        for c in left.iter_mut() {
            *c -= (completed - counted) as u64;
        }
        Ok(())
    }
}
