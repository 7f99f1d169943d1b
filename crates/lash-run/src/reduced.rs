//! The reduced interface model of a scenario (docs/theory.md §6): builds the macro
//! subsystem ([`lash_mech::MechanismSubsystem`]), the micro subsystem
//! ([`lash_micro::InterfaceSubsystem`]) and runs them with the multirate master
//! ([`lash_orchestrate::InterfaceMaster`]), recording the same channels as the full model:
//!
//! * sensor positions and velocities: macro outputs, cubic Hermite in time (with their exported
//!   derivatives);
//! * sensor accelerations, joint reactions, driver torques: propagated, `free + gain · f_c` at every
//!   micro step (no solve in the micro loop);
//! * clearance quantities: micro outputs.
//!
//! Every clearance joint of the scenario is coupled at once (the micro subsystem integrates all
//! eccentricities with the coupled effective mass). The loads propagated are the contact forces
//! through the joint centres and the friction forces, whose moments (R_J F_T on the journal body,
//! R_B F_T on the bearing body) act in the micro model and in every propagated channel.

use crate::build::{BuildOptions, build_model};
use crate::run::{RunError, Sink, Summary, driver_period};
use lash_core::{BoxError, Coupling, Subsystem, Ticks};
use lash_mech::{ClearanceInterface, Interface, MechanismSubsystem, Probe, Vec2};
use lash_micro::{InterfaceSubsystem, MicroIntegrator};
use lash_ode::AdaptiveOptions;
use lash_orchestrate::{Execution, InterfaceMaster, Interpolation, MasterOptions, MasterStats, Observer, Signal};
use lash_scenario::channels::{CLEARANCE_QUANTITIES, Channel, Source, channel_sources};
use lash_scenario::schema::Scenario;

/// Step sizes, interpolation, coupling and execution of the reduced model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ReducedOptions {
    /// Macro step h_m \[s\].
    pub macro_step: f64,
    /// Micro step h_r \[s\] (the RK4 step, or the communication step of the error-controlled micro).
    pub micro_step: f64,
    /// Interpolation of the macro terms across a macro step.
    pub interpolation: Interpolation,
    /// One-way (as in the reduced-interface-model papers) or two-way coupling.
    pub coupling: Coupling,
    /// Sequential or threaded.
    pub execution: Execution,
    /// Error-controlled micro model (DOPRI5 with contact events) instead of fixed-step RK4.
    pub error_controlled_micro: bool,
    /// Compute the written channels only: no channel statistics and no clearance summary (the
    /// summary's `channels` and `clearances` are then empty), so nothing but the written channels
    /// is evaluated at each sample. A sweep's runs keep their channels and nothing else. (Planar
    /// runs; the spatial reduced run keeps its statistics either way.)
    #[serde(skip)]
    pub channels_only: bool,
}

impl Default for ReducedOptions {
    fn default() -> Self {
        Self {
            macro_step: 1e-3,
            micro_step: 1e-5,
            interpolation: Interpolation::Linear,
            coupling: Coupling::OneWay,
            execution: Execution::Sequential,
            error_controlled_micro: false,
            channels_only: false,
        }
    }
}

impl ReducedOptions {
    /// The micro model's integrator these options ask for: RK4 at the micro step, or DOPRI5
    /// with contact events at tolerances far below the coupling's error, its steps up to the
    /// micro step.
    pub fn micro_integrator(&self) -> MicroIntegrator {
        if self.error_controlled_micro {
            MicroIntegrator::Dopri5(AdaptiveOptions {
                rtol: 1e-9,
                atol: 1e-12,
                initial_step: 1e-7,
                max_step: self.micro_step,
                min_step: 1e-14,
            })
        } else {
            MicroIntegrator::Rk4 { step: self.micro_step }
        }
    }
}

/// Details of a reduced run (in summary.json).
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReducedDetails {
    /// The options used.
    pub options: ReducedOptions,
    /// Whether the macro motion came from kinematic analysis (fully driven, one-way).
    pub kinematic_macro: bool,
    /// Counters and time split.
    pub master: MasterStats,
}

/// The pieces of a prepared reduced-model run ([`ReducedRun::into_parts`]).
pub struct ReducedParts {
    /// The mechanism (macro subsystem).
    pub macro_sub: MechanismSubsystem,
    /// The clearance interface (micro subsystem).
    pub micro_sub: InterfaceSubsystem,
    /// The master's steps, time span, coupling and execution.
    pub master: MasterOptions,
    /// The recorded channels as the master's signals.
    pub signals: Vec<Signal>,
}

/// A prepared reduced-model run.
pub struct ReducedRun {
    scenario: Scenario,
    options: ReducedOptions,
    macro_sub: MechanismSubsystem,
    micro_sub: InterfaceSubsystem,
    sources: Vec<(Channel, Source)>,
    selected: Vec<usize>,
    signals: Vec<Signal>,
    master_options: MasterOptions,
    stresses: Vec<Option<std::sync::Arc<lash_bush::InterfaceStress>>>,
}

fn ticks(v: f64, what: &str) -> Result<Ticks, RunError> {
    Ticks::from_seconds(v).map_err(|e| RunError::Unsupported(format!("{what}: {e}")))
}

impl ReducedRun {
    /// Prepares a run; refuses scenarios and settings the reduced model does not cover.
    pub fn new(scenario: &Scenario, options: ReducedOptions) -> Result<Self, RunError> {
        refuse_uncovered(scenario)?;
        let master_options = master_options(&scenario.simulation, options)?;
        let full = build_model(scenario, BuildOptions { ideal: false });
        let ideal = full.ideal_mechanism();
        let mut cut = full.mechanism.clone();
        let (interfaces, micro_joints) = interfaces(scenario, &full, &mut cut)?;
        // Loads per propagated value: the contact forces (n = 2k), then the friction forces (k).
        let loads = interfaces.len() * (lash_micro::PLANAR_JOINT_COORDINATES + 1);

        let sources = channel_sources(scenario, false);
        let selected = lash_scenario::channels::selected_channels(scenario, &sources);
        let joint_names: Vec<&str> =
            scenario.joints.iter().filter(|j| !scenario.is_cut(&j.name)).map(|j| j.name.as_str()).collect();
        let recorded = recorded_channels(scenario, &sources, &selected, options.channels_only);
        let signals = recorded
            .iter()
            .map(|&k| signal(scenario, &joint_names, loads, &sources[k].0, sources[k].1))
            .collect::<Vec<_>>();
        let sources_recorded: Vec<(Channel, Source)> = recorded.iter().map(|&k| sources[k].clone()).collect();
        let probes = probes(scenario, &cut, &joint_names, &sources_recorded);
        let selected_positions = (0..selected.len()).collect();

        let macro_sub = MechanismSubsystem::new("mechanism", cut, ideal, interfaces, probes, options.coupling);
        let integrator = options.micro_integrator();
        let micro_sub = match micro_joints {
            MicroJoints::Bushings(bushings) => InterfaceSubsystem::new(bushings, integrator),
            MicroJoints::Guides(guides) => InterfaceSubsystem::new(guides, integrator),
            // The joints' definitions as written, so that their radii and law coefficients are
            // parameters of the micro subsystem (and of its FMU).
            MicroJoints::Clearances(joints) => {
                let definitions =
                    scenario.clearances.iter().map(|c| crate::build::clearance_definition(scenario, c)).collect();
                InterfaceSubsystem::with_definitions(joints, integrator, definitions)
            }
        }
        .map_err(|e| RunError::Unsupported(e.to_string()))?;
        Ok(Self {
            scenario: scenario.clone(),
            options,
            macro_sub,
            micro_sub,
            sources: sources_recorded,
            selected: selected_positions,
            signals,
            master_options,
            // The bushes' FE tables before the clock starts.
            stresses: crate::build::interface_stresses(scenario),
        })
    }

    /// Header of the written columns (the same channels as the full model).
    pub fn header(&self) -> Vec<String> {
        lash_scenario::channels::header(&self.sources, &self.selected)
    }

    /// What a run records: the channels, the clearance summary's, the measurements, the stresses.
    fn recording(&self) -> Recording {
        let quantity = |j: usize, name: &str| {
            self.sources
                .iter()
                .position(|(_, s)| matches!(s, Source::Clearance(c, q) if *c == j && CLEARANCE_QUANTITIES[*q as usize].0 == name))
                .expect("recorded")
        };
        // The clearance summary is the clearance joints' (a bushing has no impacts to count), or
        // a guide's corners' (the block's offset, the corner's normal force and penetration).
        let joints = if self.options.channels_only { 0 } else { self.scenario.clearances.len() };
        let guides = if self.options.channels_only { 0 } else { self.scenario.guides.len() };
        let guide_quantity =
            |g: usize, q: u8| self.sources.iter().position(|(_, s)| *s == Source::Guide(g, q)).expect("recorded");
        let corners = (0..guides).flat_map(|g| {
            (0..4u8).map(move |k| JointSignals {
                eccentricity: guide_quantity(g, 2),
                force: guide_quantity(g, 4 + k),
                penetration: guide_quantity(g, 8 + k),
            })
        });
        Recording {
            channels: self.sources.iter().map(|(c, _)| c.clone()).collect(),
            written: self.selected.len(),
            statistics: !self.options.channels_only,
            summary: (0..joints)
                .map(|j| JointSignals {
                    eccentricity: quantity(j, "eccentricity"),
                    force: quantity(j, "force"),
                    penetration: quantity(j, "penetration"),
                })
                .chain(corners)
                .collect(),
            measurements: self.scenario.output.measurements.clone(),
            stresses: {
                let models = &self.stresses;
                self.sources
                    .iter()
                    .enumerate()
                    .filter_map(|(i, (_, s))| match *s {
                        Source::InterfaceStress(k) => models[k].clone().map(|m| (i, m)),
                        _ => None,
                    })
                    .collect()
            },
        }
    }

    /// The two subsystems with what the master and the summary need.
    fn coupled<'a>(&'a mut self, recording: &'a Recording) -> Coupled<'a, MechanismSubsystem> {
        Coupled {
            macro_sub: &mut self.macro_sub,
            micro_sub: &mut self.micro_sub,
            master: self.master_options,
            signals: &self.signals,
            recording,
            simulation: &self.scenario.simulation,
            scenario: &self.scenario.name,
            period: driver_period(self.scenario.drivers.iter().map(|d| &d.motion)),
        }
    }

    /// The details in the summary.
    fn details(&self) -> impl Fn(MasterStats) -> ReducedDetails + use<> {
        let (options, kinematic_macro) = (self.options, self.macro_sub.is_kinematic());
        move |master| ReducedDetails { options, kinematic_macro, master }
    }

    /// Runs the horizon; rows go to `sink`, the fraction done to `progress`.
    pub fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
        let recording = self.recording();
        let details = self.details();
        let summary = run_reduced(self.coupled(&recording), details, sink, progress)?;
        Ok(Summary {
            warnings: [summary.warnings, crate::run::series_bush_warnings(&self.scenario)].concat(),
            ..summary
        })
    }

    /// Runs several prepared runs side by side, run i's rows to `sinks[i]`: the micro models of
    /// one-joint RK4 runs are stepped eight at a time in vector lanes. Each run's rows and summary
    /// are those of its own [`ReducedRun::execute`], bit for bit, but for the CPU and wall times
    /// (the group's, shared equally); runs that cannot go together (two-way coupling, threads,
    /// cubic Hermite, different steps or output intervals) run one after the other.
    pub fn execute_together(runs: &mut [&mut ReducedRun], sinks: Vec<Sink<'_>>) -> Vec<Result<Summary, RunError>> {
        let recordings: Vec<Recording> = runs.iter().map(|r| r.recording()).collect();
        let details: Vec<_> = runs.iter().map(|r| r.details()).collect();
        let group: Vec<Coupled<'_, MechanismSubsystem>> =
            runs.iter_mut().zip(&recordings).map(|(r, rec)| r.coupled(rec)).collect();
        let mut work = lash_mech::lanes::KinematicLanes::default();
        let mut ahead = |subs: &mut [&mut MechanismSubsystem], t, h| {
            lash_mech::subsystem::kinematic_steps_ahead(subs, t, h, &mut work);
        };
        let results = run_reduced_together(group, sinks, &mut ahead, |i, master| details[i](master));
        results
            .into_iter()
            .zip(runs.iter())
            .map(|(result, run)| {
                result.map(|summary| Summary {
                    warnings: [summary.warnings, crate::run::series_bush_warnings(&run.scenario)].concat(),
                    ..summary
                })
            })
            .collect()
    }

    /// The micro subsystem (impacts, final state) after a run.
    pub fn micro(&self) -> &InterfaceSubsystem {
        &self.micro_sub
    }

    /// The two subsystems, unstarted (for export as FMUs or for another master).
    pub fn into_subsystems(self) -> (MechanismSubsystem, InterfaceSubsystem) {
        (self.macro_sub, self.micro_sub)
    }

    /// Everything a master needs to run this model itself: the two subsystems (unstarted), the
    /// master's options and the signals of the recorded channels (in `header` order but for
    /// the time column), for a caller that wraps a subsystem or observes other signals.
    pub fn into_parts(self) -> ReducedParts {
        ReducedParts {
            macro_sub: self.macro_sub,
            micro_sub: self.micro_sub,
            master: self.master_options,
            signals: self.signals,
        }
    }

    /// The macro subsystem after a run.
    pub fn macro_subsystem(&self) -> &MechanismSubsystem {
        &self.macro_sub
    }
}

/// The master's options for a scenario's time span and the reduced model's steps, checked: the
/// steps, the horizon and the output interval must fit the integer time grid.
pub(crate) fn master_options(
    sim: &lash_scenario::schema::SimulationSpec,
    options: ReducedOptions,
) -> Result<MasterOptions, RunError> {
    let master_options = MasterOptions {
        start: ticks(sim.start_time, "simulation.start_time")?,
        stop: ticks(sim.start_time + sim.horizon, "simulation.horizon")?,
        macro_step: ticks(options.macro_step, "macro step")?,
        micro_step: ticks(options.micro_step, "micro step")?,
        interpolation: options.interpolation,
        coupling: options.coupling,
        execution: options.execution,
    };
    let refuse = |e: lash_orchestrate::StepError| RunError::Unsupported(e.to_string());
    master_options.check().map_err(refuse)?;
    master_options.check_sampling(ticks(sim.output_interval, "simulation.output_interval")?).map_err(refuse)?;
    Ok(master_options)
}

/// Refuses the interfaces the reduced model does not couple: a guide beside anything else (a
/// guide is a micro model of its own kind), clearance joints beside bushings, too many or none.
fn refuse_uncovered(scenario: &Scenario) -> Result<(), RunError> {
    if let Some(g) = scenario.guides.first()
        && (scenario.guides.len() > 1 || !scenario.clearances.is_empty() || !scenario.bushings.is_empty())
    {
        return Err(RunError::Unsupported(format!(
            "the reduced model couples one translational clearance joint alone (guide {:?}), not yet beside other \
             clearance joints, bushings or guides; run the full model",
            g.joint
        )));
    }
    // The interface is either the clearance joints or the bushings (each a micro model of its
    // own kind); both at once is not there yet.
    let bushed = !scenario.bushings.is_empty();
    if bushed && !scenario.clearances.is_empty() {
        return Err(RunError::Unsupported(format!(
            "the reduced model takes clearance joints or bushings, not both yet (clearance joint {:?}, bushing {:?}); \
             run the full model",
            scenario.clearances[0].joint, scenario.bushings[0].joint
        )));
    }
    let max_joints = if bushed { 3 } else { lash_micro::MAX_COORDINATES / lash_micro::PLANAR_JOINT_COORDINATES };
    let count = scenario.clearances.len() + scenario.bushings.len() + scenario.guides.len();
    if count == 0 || count > max_joints {
        return Err(RunError::Unsupported(format!(
            "the reduced model couples 1 to {max_joints} {}; the scenario has {count}",
            if bushed { "bushings" } else { "clearance joints" }
        )));
    }
    Ok(())
}

/// The micro joints of a reduced run: of one kind.
enum MicroJoints {
    Clearances(Vec<lash_contact::ClearanceJoint>),
    Bushings(Vec<lash_micro::BushingJoint>),
    Guides(Vec<lash_micro::GuideJoint>),
}

/// The macro side's interfaces and the micro side's joints of the full model `full` of
/// `scenario`; a bushing's load leaves the cut mechanism `cut` (its two points are the interface,
/// its force the micro side's, with the same law).
fn interfaces(
    scenario: &Scenario,
    full: &lash_full_model::FullModel,
    cut: &mut lash_mech::Mechanism,
) -> Result<(Vec<ClearanceInterface>, MicroJoints), RunError> {
    let between = |journal_body, journal_point, bearing_body, bearing_point| Interface {
        journal_body,
        journal_point,
        bearing_body,
        bearing_point,
    };
    let mut interfaces: Vec<ClearanceInterface> = full
        .clearances
        .iter()
        .map(|j| ClearanceInterface {
            interface: between(j.journal_body, j.journal_point, j.bearing_body, j.bearing_point),
            journal_radius: j.journal_radius,
            bearing_radius: j.bearing_radius,
            guide: None,
        })
        .collect();
    let mut bushings = Vec::new();
    cut.loads.retain(|l| match l {
        lash_mech::Load::Bushing { body_i, point_i, body_j, point_j, stiffness, damping, curve } => {
            interfaces.push(ClearanceInterface {
                interface: between(*body_i, *point_i, *body_j, *point_j),
                journal_radius: 0.0,
                bearing_radius: 0.0,
                guide: None,
            });
            bushings.push(lash_micro::BushingJoint {
                name: scenario.bushings[bushings.len()].joint.clone(),
                stiffness: *stiffness,
                damping: *damping,
                curve: curve.clone(),
            });
            false
        }
        _ => true,
    });
    for slot in &full.slots {
        // (The micro side reads the corners' forces in the guide's frame: the world's, for a
        // guide on the ground along x.)
        if slot.guide.body != lash_mech::BodyId::Ground || slot.guide.axis.y != 0.0 || slot.guide.axis.x <= 0.0 {
            return Err(RunError::Unsupported(format!(
                "the reduced model takes a guide on the ground along +x; guide {:?} is not; run the full model",
                slot.name
            )));
        }
        interfaces.push(ClearanceInterface {
            interface: between(slot.block.body, slot.block.centre, slot.guide.body, slot.guide.point),
            journal_radius: 0.0,
            bearing_radius: 0.0,
            guide: Some(lash_mech::GuideAxis { axis: slot.guide.axis, angle_offset: slot.aligned_angle() }),
        });
    }
    let joints = if !bushings.is_empty() {
        MicroJoints::Bushings(bushings)
    } else if !full.slots.is_empty() {
        MicroJoints::Guides(full.slots.iter().map(lash_micro::GuideJoint::new).collect())
    } else {
        MicroJoints::Clearances(full.clearances.clone())
    };
    Ok((interfaces, joints))
}

/// The channels a reduced run records (positions in `sources`): the selected ones, then, for
/// the summary (unless only the channels are wanted), every clearance joint's eccentricity,
/// force magnitude and penetration and every guide's offset and corners' normal forces and
/// penetrations, then the force channels of the emulated measurements.
fn recorded_channels(
    scenario: &Scenario,
    sources: &[(Channel, Source)],
    selected: &[usize],
    channels_only: bool,
) -> Vec<usize> {
    let mut recorded: Vec<usize> = selected.to_vec();
    let summarised = if channels_only { 0 } else { scenario.clearances.len() };
    crate::record::record_joint_summaries(&mut recorded, sources, summarised, |s| match *s {
        Source::Clearance(j, q) => Some((j, CLEARANCE_QUANTITIES[q as usize].0)),
        _ => None,
    });
    let guides = if channels_only { 0 } else { scenario.guides.len() };
    for g in 0..guides {
        for q in guide_summary_quantities() {
            let k = sources.iter().position(|(_, s)| *s == Source::Guide(g, q)).expect("guide channels");
            if !recorded.contains(&k) {
                recorded.push(k);
            }
        }
    }
    let names: Vec<&str> = sources.iter().map(|(c, _)| c.name.as_str()).collect();
    crate::measure::record_forces(&mut recorded, &names, &scenario.output.measurements);
    recorded
}

/// The probes (propagation maps exported by the macro subsystem) of the recorded channels.
fn probes(
    scenario: &Scenario,
    cut: &lash_mech::Mechanism,
    joint_names: &[&str],
    recorded: &[(Channel, Source)],
) -> Vec<Probe> {
    let mut probes: Vec<Probe> = Vec::new();
    for (_, src) in recorded {
        let probe = match *src {
            Source::Sensor(k, _) => {
                let sen = &scenario.sensors[k];
                let body = cut.body_id(&sen.body).expect("validated");
                Probe::Point { name: sen.name.clone(), body, point: Vec2::new(sen.point[0], sen.point[1]) }
            }
            Source::JointReaction(k, _) => Probe::JointReaction { name: joint_names[k].to_string(), joint: k },
            Source::DriverTorque(k) => Probe::DriverTorque { name: scenario.drivers[k].name.clone(), driver: k },
            Source::BodyPose(k, _) => {
                let name = scenario.bodies[k].name.clone();
                Probe::Body { body: cut.body_id(&name).expect("validated"), name }
            }
            Source::Clearance(..)
            | Source::ConstraintError
            | Source::Bushing(..)
            | Source::InterfaceStress(..)
            | Source::Guide(..) => continue,
        };
        if !probes.contains(&probe) {
            probes.push(probe);
        }
    }
    probes
}

/// A guide's channels its corners' summaries read (its [`lash_scenario::channels::GUIDE_QUANTITIES`]):
/// the offset, each corner's normal force, each corner's penetration.
fn guide_summary_quantities() -> impl Iterator<Item = u8> {
    std::iter::once(2).chain(4..12)
}

/// Where a clearance joint's signals are among the recorded ones, for its summary.
#[derive(Debug, Clone, Copy)]
pub(crate) struct JointSignals {
    pub eccentricity: usize,
    /// The contact force's magnitude.
    pub force: usize,
    pub penetration: usize,
}

/// The channels a reduced run records: all of them (name, unit), the first `written` of which
/// go to the rows, and for each joint the positions of the signals its summary needs.
pub(crate) struct Recording {
    pub channels: Vec<Channel>,
    pub written: usize,
    /// Whether the channel statistics are kept.
    pub statistics: bool,
    pub summary: Vec<JointSignals>,
    pub measurements: Vec<lash_scenario::schema::MeasurementSpec>,
    /// Recorded signals that are a clearance's normal force standing for its interface stress:
    /// (position, the stress model).
    pub stresses: Vec<(usize, std::sync::Arc<lash_bush::InterfaceStress>)>,
}

/// A macro subsystem (of type `Ma`: planar or spatial) and a micro subsystem with what the master
/// and the summary need.
pub(crate) struct Coupled<'a, Ma: Subsystem> {
    pub macro_sub: &'a mut Ma,
    pub micro_sub: &'a mut InterfaceSubsystem,
    pub master: MasterOptions,
    pub signals: &'a [Signal],
    pub recording: &'a Recording,
    pub simulation: &'a lash_scenario::schema::SimulationSpec,
    pub scenario: &'a str,
    pub period: Option<f64>,
}

/// What a reduced run records while it runs — the rows to its sink, the channel statistics, the
/// measurements and the clearance summary — as the master's observer.
struct Recorder<'c, 's> {
    recording: &'c Recording,
    start_time: f64,
    per_horizon: f64,
    stats: crate::record::RunningStats,
    measurements: crate::measure::MeasurementRecorder,
    row: Vec<f64>,
    mapped: Vec<f64>,
    samples: u64,
    max_ecc: Vec<f64>,
    sum_force: Vec<f64>,
    /// Per joint: samples in contact, and those of them at which the contact carries no force.
    contact_samples: Vec<crate::run::ContactSamples>,
    sink: Sink<'s>,
    progress: Option<&'s mut dyn FnMut(f64)>,
}

impl<'c, 's> Recorder<'c, 's> {
    fn new<Ma: Subsystem>(c: &Coupled<'c, Ma>, sink: Sink<'s>, progress: Option<&'s mut dyn FnMut(f64)>) -> Self {
        let recording = c.recording;
        let joints = recording.summary.len();
        let names: Vec<&str> = recording.channels.iter().map(|ch| ch.name.as_str()).collect();
        Self {
            recording,
            start_time: c.simulation.start_time,
            per_horizon: 1.0 / c.simulation.horizon,
            stats: crate::record::RunningStats::new(c.signals.len()),
            measurements: crate::measure::MeasurementRecorder::new(&recording.measurements, &names),
            row: vec![0.0; recording.written + 1],
            mapped: vec![0.0; c.signals.len()],
            samples: 0,
            max_ecc: vec![0.0; joints],
            sum_force: vec![0.0; joints],
            contact_samples: vec![Default::default(); joints],
            sink,
            progress,
        }
    }
}

impl Observer for Recorder<'_, '_> {
    fn observe(&mut self, t: Ticks, values: &[f64]) -> Result<(), BoxError> {
        // Normal forces that stand for interface stresses become the stresses (a copy only then).
        let values = if self.recording.stresses.is_empty() {
            values
        } else {
            self.mapped.copy_from_slice(values);
            for (i, model) in &self.recording.stresses {
                self.mapped[*i] = model.von_mises(values[*i]);
            }
            &self.mapped[..]
        };
        self.measurements.record(values);
        if self.recording.statistics {
            self.stats.add(values);
        }
        for (j, signals) in self.recording.summary.iter().enumerate() {
            self.max_ecc[j] = self.max_ecc[j].max(values[signals.eccentricity]);
            let force = values[signals.force];
            self.sum_force[j] += force;
            if values[signals.penetration] > 0.0 {
                let counts = &mut self.contact_samples[j];
                counts.in_contact += 1;
                counts.unloaded += u64::from(force == 0.0);
            }
        }
        self.samples += 1;
        self.row[0] = t.seconds();
        self.row[1..].copy_from_slice(&values[..self.recording.written]);
        // The progress callback every 64 samples (it is a call through a pointer).
        if self.samples & 63 == 1
            && let Some(progress) = self.progress.as_mut()
        {
            progress(((t.seconds() - self.start_time) * self.per_horizon).clamp(0.0, 1.0));
        }
        (self.sink)(&self.row)
    }
}

/// Sets both subsystems of `c` up for its time span.
fn setup<Ma: Subsystem>(c: &mut Coupled<'_, Ma>) -> Result<(), RunError> {
    let (start, stop) = (c.master.start, c.master.stop);
    let t = c.simulation.start_time;
    let failed = |e: lash_core::SubsystemError| RunError::Simulation { t, message: e.to_string() };
    c.macro_sub.setup(start, Some(stop)).map_err(failed)?;
    c.micro_sub.setup(start, Some(stop)).map_err(failed)
}

/// Runs a reduced model (planar or spatial) on the interface master over the horizon: rows to
/// `sink`, statistics and the clearance summary from the micro subsystem's impacts.
pub(crate) fn run_reduced<Ma: Subsystem>(
    mut c: Coupled<'_, Ma>,
    details: impl FnOnce(MasterStats) -> ReducedDetails,
    sink: Sink<'_>,
    progress: &mut dyn FnMut(f64),
) -> Result<Summary, RunError> {
    setup(&mut c)?;
    let interval = ticks(c.simulation.output_interval, "simulation.output_interval")?;
    let mut recorder = Recorder::new(&c, sink, Some(progress));
    let cpu0 = cpu_time::ProcessTime::now();
    let wall0 = std::time::Instant::now();
    let master_stats = {
        let mut master = InterfaceMaster::new(&mut *c.macro_sub, &mut *c.micro_sub, c.master, c.signals.to_vec())
            .map_err(|e| RunError::Unsupported(e.to_string()))?;
        let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut recorder, interval)];
        master.run(&mut observers)
    };
    let times = (cpu0.elapsed().as_secs_f64(), wall0.elapsed().as_secs_f64());
    summarise(&c, recorder, master_stats, times, details)
}

/// Runs several reduced models side by side ([`InterfaceMaster::run_together`]), their micro
/// subsystems stepped together — the one-joint RK4 ones eight at a time in vector lanes
/// ([`lash_micro::do_steps_together`]). Each run's rows and summary are what
/// [`run_reduced`] gives it, bit for bit, but for its CPU and wall times: the group's, shared
/// equally. Runs whose settings cannot go together (two-way coupling, threads, cubic Hermite,
/// different steps or output intervals) run one after the other, as [`run_reduced`] runs them.
pub(crate) fn run_reduced_together<'c, 's, Ma: Subsystem>(
    mut group: Vec<Coupled<'c, Ma>>,
    sinks: Vec<Sink<'s>>,
    ahead: &mut lash_orchestrate::GroupAhead<'_, Ma>,
    details: impl Fn(usize, MasterStats) -> ReducedDetails,
) -> Vec<Result<Summary, RunError>> {
    assert_eq!(group.len(), sinks.len(), "one sink per run");
    let mut results: Vec<Option<Result<Summary, RunError>>> = group.iter().map(|_| None).collect();
    let mut recorders: Vec<Option<(Recorder<'c, 's>, Ticks)>> = Vec::with_capacity(group.len());
    for (i, (c, sink)) in group.iter_mut().zip(sinks).enumerate() {
        match setup(c).and_then(|()| ticks(c.simulation.output_interval, "simulation.output_interval")) {
            Ok(interval) => recorders.push(Some((Recorder::new(c, sink, None), interval))),
            Err(e) => {
                results[i] = Some(Err(e));
                recorders.push(None);
            }
        }
    }
    let cpu0 = cpu_time::ProcessTime::now();
    let wall0 = std::time::Instant::now();
    let ran: Vec<(usize, Result<MasterStats, lash_orchestrate::MasterError>)> = {
        let (mut members, mut masters, mut observers) = (Vec::new(), Vec::new(), Vec::new());
        for (i, (c, r)) in group.iter_mut().zip(recorders.iter_mut()).enumerate() {
            let Some((recorder, interval)) = r else { continue };
            match InterfaceMaster::new(&mut *c.macro_sub, &mut *c.micro_sub, c.master, c.signals.to_vec()) {
                Ok(m) => {
                    members.push(i);
                    masters.push(m);
                    observers.push([(recorder as &mut dyn Observer, *interval)]);
                }
                Err(e) => results[i] = Some(Err(RunError::Unsupported(e.to_string()))),
            }
        }
        let mut lists: Vec<&mut [(&mut dyn Observer, Ticks)]> = observers.iter_mut().map(|o| &mut o[..]).collect();
        let mut step = lash_micro::do_steps_together;
        let stats = InterfaceMaster::run_together(&mut masters, &mut lists, &mut step, ahead);
        members.into_iter().zip(stats).collect()
    };
    let share = 1.0 / ran.len().max(1) as f64;
    let times = (cpu0.elapsed().as_secs_f64() * share, wall0.elapsed().as_secs_f64() * share);
    for (i, master_stats) in ran {
        let (recorder, _) = recorders[i].take().expect("ran");
        results[i] = Some(summarise(&group[i], recorder, master_stats, times, |m| details(i, m)));
    }
    results.into_iter().map(|r| r.expect("every run ends")).collect()
}

/// The run's error for the master's `e` (a subsystem's failure at its time, else at `start`).
fn run_error(e: lash_orchestrate::MasterError, start: f64) -> RunError {
    match e {
        lash_orchestrate::MasterError::Observer(e) => RunError::Output(e),
        lash_orchestrate::MasterError::Subsystem { subsystem, source } => {
            let (t, message) = match source {
                lash_core::SubsystemError::Simulation { t, message } => (t, message),
                other => (start, other.to_string()),
            };
            RunError::Simulation { t, message: format!("{subsystem} subsystem: {message}") }
        }
        e => RunError::Unsupported(e.to_string()),
    }
}

/// The summary of a run of `c` that `recorder` observed: its channel statistics, the clearance
/// summary from the micro subsystem's impacts, the master's counters; or the run's error.
fn summarise(
    c: &Coupled<'_, impl Subsystem>,
    recorder: Recorder<'_, '_>,
    master_stats: Result<MasterStats, lash_orchestrate::MasterError>,
    (cpu, wall): (f64, f64),
    details: impl FnOnce(MasterStats) -> ReducedDetails,
) -> Result<Summary, RunError> {
    let sim = c.simulation;
    let Recorder { stats, measurements, samples, max_ecc, sum_force, contact_samples, recording, .. } = recorder;
    let master_stats = master_stats.map_err(|e| run_error(e, sim.start_time))?;
    let horizon = sim.horizon;
    let t_end = sim.start_time + sim.horizon;
    let (measurements, measured) = measurements
        .finish(sim.start_time, sim.output_interval)
        .map_err(|e| RunError::Simulation { t: t_end, message: e.to_string() })?;
    let micro = &*c.micro_sub;
    let m = samples.max(1) as f64;
    let joints = recording.summary.len();
    let mut events = 0;
    let mut clearances = Vec::with_capacity(joints);
    // Each contact: a joint where each has one, a guide's corners where it is the interface.
    let contacts = micro.contact_names();
    let per_joint = contacts.len() / micro.joint_count().max(1);
    for (j, name) in contacts.into_iter().enumerate().take(joints) {
        let mut impacts = micro.impacts(j).to_vec();
        let open = micro.open_impacts(j, t_end);
        events += 2 * impacts.len() as u64 + open.len() as u64;
        impacts.extend(open);
        clearances.push(crate::run::ClearanceSummary {
            contact_samples: Some(contact_samples[j]),
            ..crate::run::ClearanceSummary::from_impacts(
                name,
                micro.radial_clearance(j / per_joint),
                impacts,
                horizon,
                c.period,
                max_ecc[j],
                sum_force[j] / m,
            )
        });
    }
    let channels =
        if recording.statistics { stats.channel_stats(&recording.channels, samples) } else { Default::default() };
    let max_constraint_error = channels.get("constraint_error").map_or(0.0, |c| c.max_abs);
    let integrator = match micro.integrator() {
        MicroIntegrator::Rk4 { step } => lash_ode::Method::Rk4 { step },
        MicroIntegrator::Dopri5(o) => lash_ode::Method::Dopri5(o),
    };
    // (The micro model's figures: its steps, four right-hand sides each, its impacts.)
    let micro_stats = lash_ode::Stats {
        steps: master_stats.micro_steps,
        rhs_evaluations: 4 * master_stats.micro_steps,
        events,
        ..Default::default()
    };
    Ok(Summary {
        samples,
        max_constraint_error,
        channels,
        warnings: [
            crate::run::resolution_warnings(&integrator, &clearances),
            crate::run::unloaded_contact_warnings(&integrator, &clearances),
        ]
        .concat(),
        clearances,
        reduced: Some(details(master_stats)),
        measurements,
        measured,
        ..Summary::new(c.scenario, "reduced", integrator, sim, (cpu, wall), &micro_stats)
    })
}

/// The master signal of quantity `q` of sensor `p`, whose position, velocity and acceleration
/// have `dimension` components each (2 planar, 3 spatial), in that order: position and velocity
/// from the macro outputs with their derivatives (Hermite between the nodes), the acceleration
/// propagated (`loads` gains per component). One home for the planar and the spatial run.
pub(crate) fn sensor_signal(name: String, p: &str, q: usize, dimension: usize, loads: usize) -> Signal {
    match q / dimension {
        0 => Signal::Macro {
            name,
            variable: format!("{p}.position"),
            element: q,
            derivative: Some((format!("{p}.velocity"), q)),
        },
        1 => Signal::Macro {
            name,
            variable: format!("{p}.velocity"),
            element: q - dimension,
            derivative: Some((format!("{p}.acceleration"), q - dimension)),
        },
        _ => Signal::Propagated {
            name,
            free: (format!("{p}.acceleration_free"), q - 2 * dimension),
            gain: (format!("{p}.acceleration_gain"), (q - 2 * dimension) * loads),
        },
    }
}

/// The master signal that computes channel `c`; `loads` = n + k gains per propagated value.
fn signal(s: &Scenario, joint_names: &[&str], loads: usize, c: &Channel, src: Source) -> Signal {
    let name = c.name.clone();
    match src {
        Source::Sensor(k, q) => sensor_signal(name, &s.sensors[k].name, q as usize, 2, loads),
        Source::Clearance(j, q) => {
            // Interface vectors: elements 2j, 2j + 1; per-joint quantities: element j.
            let (variable, element) = match CLEARANCE_QUANTITIES[q as usize].0 {
                "fx" => ("contact_force", 2 * j),
                "fy" => ("contact_force", 2 * j + 1),
                "force" => ("contact_force_magnitude", j),
                "ex" => ("eccentricity", 2 * j),
                "ey" => ("eccentricity", 2 * j + 1),
                "eccentricity" => ("eccentricity_norm", j),
                other => (other, j),
            };
            Signal::Micro { name, variable: variable.into(), element }
        }
        Source::DriverTorque(k) => {
            let d = &s.drivers[k].name;
            Signal::Propagated { name, free: (format!("{d}.torque_free"), 0), gain: (format!("{d}.torque_gain"), 0) }
        }
        Source::JointReaction(k, comp) => {
            let j = joint_names[k];
            let comp = comp as usize;
            Signal::Propagated {
                name,
                free: (format!("{j}.reaction_free"), comp),
                gain: (format!("{j}.reaction_gain"), comp * loads),
            }
        }
        Source::ConstraintError => {
            Signal::Macro { name, variable: "constraint_error".into(), element: 0, derivative: None }
        }
        // A bushing is micro joint k (the interface is the bushings alone): its force on body1 is
        // the micro side's force on the journal, its deflection the eccentricity's norm.
        Source::Bushing(k, q) => {
            let (variable, element) = match q {
                0 => ("contact_force", 2 * k),
                1 => ("contact_force", 2 * k + 1),
                2 => ("contact_force_magnitude", k),
                _ => ("eccentricity_norm", k),
            };
            Signal::Micro { name, variable: variable.into(), element }
        }
        // The micro side's normal force, turned into the stress when recorded (Recording::stresses).
        Source::InterfaceStress(k) => Signal::Micro { name, variable: "normal_force".into(), element: k },
        // A guide is micro joint k (the interface is the guide alone): its coordinates are the
        // tilt and the offset, the corners' force across it their generalized force, along it
        // the friction load.
        Source::Guide(k, q) => {
            let (variable, element) = match q {
                0 => ("friction_load", k),
                1 => ("contact_force", 2 * k + 1),
                2 => ("eccentricity", 2 * k + 1),
                3 => ("eccentricity", 2 * k),
                4..=7 => ("contact_normal_force", 4 * k + q as usize - 4),
                _ => ("contact_penetration", 4 * k + q as usize - 8),
            };
            Signal::Micro { name, variable: variable.into(), element }
        }
        Source::BodyPose(k, q) => {
            let b = &s.bodies[k].name;
            let q = q as usize;
            Signal::Macro {
                name,
                variable: format!("{b}.pose"),
                element: q,
                derivative: Some((format!("{b}.pose_rate"), q)),
            }
        }
    }
}
