//! A mock macro and micro subsystem for the interface master's own tests: the macro exports a
//! ramp force f̃(t) = F0 + F1 t on a constant M̃, the micro reports as its contact force the
//! force input it sees at the end of each of its steps (value + rate × time since it was set),
//! so what an observer records can be written down in closed form.

use super::*;
use lash_core::{SavedState, StepOutcome, Variability, VariableTable};

/// Force at t = 0 \[N\].
pub const F0: f64 = 100.0;
/// Its slope \[N/s\].
pub const F1: f64 = 2000.0;

/// The calls both mocks answer alike from their variables and their clock alone (a saved state
/// is the time).
macro_rules! clock_calls {
    ($name:literal) => {
        fn name(&self) -> &str {
            $name
        }
        fn variables(&self) -> &[Variable] {
            &self.variables
        }
        fn setup(&mut self, start: Ticks, _stop: Option<Ticks>) -> Result<(), SubsystemError> {
            self.t = start;
            Ok(())
        }
        fn initialize(&mut self) -> Result<(), SubsystemError> {
            Ok(())
        }
        fn time(&self) -> Ticks {
            self.t
        }
        fn save_state(&self) -> Result<SavedState, SubsystemError> {
            Ok(SavedState(Box::new(self.t)))
        }
        fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
            self.t = *state.0.downcast_ref::<Ticks>().expect("a mock state");
            Ok(())
        }
    };
}

/// The mock mechanism: one planar joint (n = 2, one friction load, one angular velocity each).
pub struct Macro {
    variables: Vec<Variable>,
    t: Ticks,
    /// Two-way inputs received: (eccentricity[0], time of the step that followed).
    pub received: Vec<(f64, Ticks)>,
    eccentricity: f64,
}

impl Macro {
    pub fn new() -> Self {
        let mut v = VariableTable::new();
        let (out, inp, c) = (Causality::Output, Causality::Input, Variability::Continuous);
        for (name, shape) in [
            ("effective_mass", &[2, 2][..]),
            ("effective_force", &[2]),
            ("friction_moment_force", &[2, 1]),
            ("journal_angular_velocity", &[1]),
            ("journal_angular_acceleration", &[1]),
            ("bearing_angular_velocity", &[1]),
            ("bearing_angular_acceleration", &[1]),
            ("free", &[1]),
            ("gain", &[3]),
        ] {
            v.add(name, out, c, "1", name, shape, &[0.0]);
        }
        for (name, shape) in [("eccentricity", &[2][..]), ("eccentricity_rate", &[2]), ("friction_force", &[1])] {
            v.add(name, inp, c, "1", name, shape, &[0.0]);
        }
        Macro { variables: v.into_variables(), t: Ticks::ZERO, received: Vec::new(), eccentricity: 0.0 }
    }

    fn value(&self, vr: ValueReference) -> Vec<f64> {
        let t = self.t.seconds();
        match self.variables[vr as usize].name.as_str() {
            "effective_mass" => vec![0.5, 0.0, 0.0, 0.5],
            "effective_force" => vec![F0 + F1 * t, 0.0],
            "free" => vec![t],
            "gain" => vec![1.0, 0.0, 0.0],
            name => vec![0.0; self.variables.iter().find(|v| v.name == name).expect("declared").len()],
        }
    }
}

impl Subsystem for Macro {
    clock_calls!("mock macro");
    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            if self.variables[r as usize].name == "eccentricity" {
                self.eccentricity = values[at];
            }
            at += self.variables[r as usize].len();
        }
        Ok(())
    }
    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            let v = self.value(r);
            values[at..at + v.len()].copy_from_slice(&v);
            at += v.len();
        }
        Ok(())
    }
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.received.push((self.eccentricity, t));
        self.t = Ticks(t.0 + h.0);
        Ok(StepOutcome::Completed)
    }
}

/// The mock interface: reports the force input it sees at the end of each step.
pub struct Micro {
    variables: Vec<Variable>,
    t: Ticks,
    /// When the force input was set, its value and rate.
    set_at: Ticks,
    force: (f64, f64),
    seen: f64,
}

impl Micro {
    pub fn new() -> Self {
        let mut v = VariableTable::new();
        let (out, inp, c) = (Causality::Output, Causality::Input, Variability::Continuous);
        for (name, shape) in [
            ("effective_mass", &[2, 2][..]),
            ("effective_force", &[2]),
            ("friction_moment_force", &[2, 1]),
            ("journal_angular_velocity", &[1]),
            ("bearing_angular_velocity", &[1]),
        ] {
            v.add(name, inp, c, "1", name, shape, &[0.0]);
            let rate = if name.ends_with("_velocity") {
                name.replace("velocity", "acceleration")
            } else {
                format!("{name}_rate")
            };
            v.add(rate, inp, c, "1", name, shape, &[0.0]);
        }
        for (name, shape) in [
            ("contact_force", &[2][..]),
            ("friction_load", &[1]),
            ("eccentricity", &[2]),
            ("eccentricity_rate", &[2]),
            ("friction_impulse", &[1]),
        ] {
            v.add(name, out, c, "1", name, shape, &[0.0]);
        }
        Micro { variables: v.into_variables(), t: Ticks::ZERO, set_at: Ticks::ZERO, force: (0.0, 0.0), seen: 0.0 }
    }
}

impl Subsystem for Micro {
    clock_calls!("mock micro");
    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            match self.variables[r as usize].name.as_str() {
                "effective_force" => {
                    self.force.0 = values[at];
                    self.set_at = self.t;
                    self.seen = values[at];
                }
                "effective_force_rate" => self.force.1 = values[at],
                _ => {}
            }
            at += self.variables[r as usize].len();
        }
        Ok(())
    }
    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            let v = &self.variables[r as usize];
            let out = &mut values[at..at + v.len()];
            out.fill(0.0);
            match v.name.as_str() {
                "contact_force" => out[0] = self.seen,
                // The time as the eccentricity: what two-way coupling hands back to the macro.
                "eccentricity" => out[0] = self.t.seconds(),
                _ => {}
            }
            at += v.len();
        }
        Ok(())
    }
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.t = Ticks(t.0 + h.0);
        self.seen = self.force.0 + self.force.1 * Ticks(self.t.0 - self.set_at.0).seconds();
        Ok(StepOutcome::Completed)
    }
}

/// One-way, sequential and threaded: every observer sample at its own interval, at the exact
/// tick, with the micro signal (the force the micro saw: the linear interpolant of a ramp is the
/// ramp) and the propagated one (free + gain · loads = t + f̃) in closed form; both executions
/// alike bit for bit; the counts of macro and micro steps.
#[test]
fn the_master_couples_a_mock_pair_as_the_closed_form_says() {
    let t = |s: f64| Ticks::from_seconds(s).unwrap();
    let record = |execution: Execution| {
        let (mut mac, mut mic) = (Macro::new(), Micro::new());
        mac.setup(Ticks::ZERO, None).unwrap();
        mic.setup(Ticks::ZERO, None).unwrap();
        let options = MasterOptions {
            start: Ticks::ZERO,
            stop: t(0.01),
            macro_step: t(1e-3),
            micro_step: t(1e-4),
            interpolation: Interpolation::Linear,
            coupling: Coupling::OneWay,
            execution,
        };
        let signals = vec![
            Signal::Micro { name: "seen".into(), variable: "contact_force".into(), element: 0 },
            Signal::Propagated { name: "propagated".into(), free: ("free".into(), 0), gain: ("gain".into(), 0) },
        ];
        let mut master = InterfaceMaster::new(&mut mac, &mut mic, options, signals).unwrap();
        let (mut every, mut sparse) = (Vec::new(), Vec::new());
        let mut a = |t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
            every.push((t, v.to_vec()));
            Ok(())
        };
        let mut b = |t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
            sparse.push((t, v.to_vec()));
            Ok(())
        };
        let stats = master.run(&mut [(&mut a, t(1e-4)), (&mut b, t(5e-4))]).unwrap();
        (every, sparse, stats)
    };
    let (every, sparse, stats) = record(Execution::Sequential);
    assert_eq!((stats.macro_steps, stats.micro_steps), (10, 100));
    assert_eq!(every.len(), 101);
    assert_eq!(sparse.len(), 21);
    for (i, (time, v)) in every.iter().enumerate() {
        assert_eq!(time.0, i as i64 * t(1e-4).0, "sample {i} at its tick");
        let s = time.seconds();
        let f = F0 + F1 * s;
        assert!((v[0] - f).abs() <= 1e-12 * f, "t = {s}: the micro saw {} for f̃ = {f}", v[0]);
        assert!((v[1] - (s + f)).abs() <= 1e-12 * f, "t = {s}: propagated {} for {}", v[1], s + f);
    }
    for (time, v) in &sparse {
        let k = (time.0 / t(1e-4).0) as usize;
        assert_eq!(time.0 % t(5e-4).0, 0);
        assert_eq!(v, &every[k].1);
    }
    let (every_threaded, sparse_threaded, _) = record(Execution::Threaded);
    assert_eq!(every, every_threaded);
    assert_eq!(sparse, sparse_threaded);
}

/// Two-way: the macro steps each interval twice (predictor, then corrector after a rollback),
/// and the corrector gets the micro's eccentricity at the interval's end.
#[test]
fn two_way_coupling_hands_the_micro_state_back_to_the_corrector() {
    let t = |s: f64| Ticks::from_seconds(s).unwrap();
    let (mut mac, mut mic) = (Macro::new(), Micro::new());
    mac.setup(Ticks::ZERO, None).unwrap();
    mic.setup(Ticks::ZERO, None).unwrap();
    let options = MasterOptions {
        start: Ticks::ZERO,
        stop: t(0.005),
        macro_step: t(1e-3),
        micro_step: t(2.5e-4),
        interpolation: Interpolation::Linear,
        coupling: Coupling::TwoWay,
        execution: Execution::Sequential,
    };
    let stats = {
        let mut master = InterfaceMaster::new(&mut mac, &mut mic, options, Vec::new()).unwrap();
        master.run(&mut []).unwrap()
    };
    assert_eq!((stats.macro_steps, stats.micro_steps), (10, 20));
    // Steps alternate: the predictor from t_k, then the corrector from t_k again.
    assert_eq!(mac.received.len(), 10);
    for (k, pair) in mac.received.chunks(2).enumerate() {
        let t_k = Ticks(k as i64 * t(1e-3).0);
        assert_eq!((pair[0].1, pair[1].1), (t_k, t_k), "step {k}: predictor and corrector from t_k");
        // The predictor extrapolates e(t_k) + ė h_m (the mock reports ė = 0): e = t_k.
        assert!((pair[0].0 - t_k.seconds()).abs() < 1e-15, "step {k}: the predictor got e = {}", pair[0].0);
        let end = (k + 1) as f64 * 1e-3;
        assert!((pair[1].0 - end).abs() < 1e-15, "step {k}: the corrector got e = {}, the micro's {end}", pair[1].0);
    }
}

/// Options of the group test: 10 ms in macro steps of 1 ms and micro steps of 0.1 ms.
fn group_options(interpolation: Interpolation) -> MasterOptions {
    let t = |s: f64| Ticks::from_seconds(s).unwrap();
    MasterOptions {
        start: Ticks::ZERO,
        stop: t(0.01),
        macro_step: t(1e-3),
        micro_step: t(1e-4),
        interpolation,
        coupling: Coupling::OneWay,
        execution: Execution::Sequential,
    }
}

/// The micro signal and the propagated one.
fn group_signals() -> Vec<Signal> {
    vec![
        Signal::Micro { name: "seen".into(), variable: "contact_force".into(), element: 0 },
        Signal::Propagated { name: "propagated".into(), free: ("free".into(), 0), gain: ("gain".into(), 0) },
    ]
}

/// Three mock pairs, set up.
fn mock_pairs() -> Vec<(Macro, Micro)> {
    (0..3)
        .map(|_| {
            let (mut mac, mut mic) = (Macro::new(), Micro::new());
            mac.setup(Ticks::ZERO, None).unwrap();
            mic.setup(Ticks::ZERO, None).unwrap();
            (mac, mic)
        })
        .collect()
}

type Samples = Vec<(Ticks, Vec<f64>)>;

/// Runs stepped together go through the same stepper as a run alone: three mock pairs in one
/// group (their micro subsystems advanced by the group's step, each by its own `do_steps`) give
/// every sample and count of a run alone, bit for bit; a group the lanes cannot take (cubic
/// Hermite inputs) runs each alone with the same results.
#[test]
fn a_group_of_runs_steps_each_as_it_steps_alone() {
    let t = |s: f64| Ticks::from_seconds(s).unwrap();
    let (options, signals, pairs) = (group_options, group_signals, mock_pairs);
    for interpolation in [Interpolation::Linear, Interpolation::CubicHermite] {
        let alone: Vec<(Samples, MasterStats)> = pairs()
            .iter_mut()
            .map(|(mac, mic)| {
                let mut master = InterfaceMaster::new(mac, mic, options(interpolation), signals()).unwrap();
                let mut samples = Vec::new();
                let mut obs = |t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
                    samples.push((t, v.to_vec()));
                    Ok(())
                };
                let stats = master.run(&mut [(&mut obs, t(2e-4))]).unwrap();
                (samples, stats)
            })
            .collect();
        let mut subsystems = pairs();
        let mut samples: Vec<Samples> = vec![Vec::new(); 3];
        let (mut calls, mut aheads) = (0, 0);
        let results = {
            let mut masters: Vec<InterfaceMaster<'_, Macro, Micro>> = subsystems
                .iter_mut()
                .map(|(mac, mic)| InterfaceMaster::new(mac, mic, options(interpolation), signals()).unwrap())
                .collect();
            let mut observers: Vec<_> = samples
                .iter_mut()
                .map(|s| {
                    move |t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
                        s.push((t, v.to_vec()));
                        Ok(())
                    }
                })
                .collect();
            let mut lists: Vec<Vec<(&mut dyn Observer, Ticks)>> =
                observers.iter_mut().map(|o| vec![(o as &mut dyn Observer, t(2e-4))]).collect();
            let mut lists: Vec<&mut [(&mut dyn Observer, Ticks)]> = lists.iter_mut().map(|l| &mut l[..]).collect();
            let mut step = |subs: &mut [&mut Micro],
                            t: Ticks,
                            h: Ticks,
                            due: &[bool],
                            refs: &[ValueReference],
                            rows: &mut [&mut [f64]]| {
                calls += 1;
                subs.iter_mut().zip(rows.iter_mut()).map(|(s, r)| s.do_steps(t, h, due, refs, r)).collect()
            };
            let mut ahead = |subs: &mut [&mut Macro], _: Ticks, _: Ticks| aheads += subs.len();
            InterfaceMaster::run_together(&mut masters, &mut lists, &mut step, &mut ahead)
        };
        for (i, (result, (alone_samples, alone_stats))) in results.into_iter().zip(&alone).enumerate() {
            let stats = result.unwrap();
            assert_eq!((stats.macro_steps, stats.micro_steps), (alone_stats.macro_steps, alone_stats.micro_steps));
            assert_eq!(&samples[i], alone_samples, "{interpolation:?}: run {i}'s samples");
            assert_eq!(alone_samples.len(), 51);
        }
        let together = interpolation != Interpolation::CubicHermite;
        assert_eq!((calls, aheads), if together { (10, 30) } else { (0, 0) }, "{interpolation:?}");
    }
}
