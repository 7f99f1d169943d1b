//! The spatial full-model runner: a spatial scenario built into a [`SpatialFullModel`] (or its
//! ideal mechanism), integrated, every channel sampled at the output interval, and the same
//! [`Summary`] as the planar runners.

use crate::run::{ClearanceSummary, RunError, Sink, Summary};
use lash_contact::{Material, SphericalClearance};
use lash_core::BoxError;
use lash_full_model::SpatialFullModel;
use lash_mech::BodyId;
use lash_scenario::Channel;
use lash_scenario::spatial::{
    SPATIAL_CLEARANCE_QUANTITIES, SpatialLoadSpec, SpatialScenario, SpatialSource, inertia_tensor, spatial_channels,
};
use lash_spatial::{
    Baumgarte, Marker, Orientation, SpatialBody, SpatialDriver, SpatialJoint, SpatialLoad, SpatialMechanism, Vec3,
    point_kinematics,
};

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::from(a)
}

/// A unit vector perpendicular to `a`: the axis least aligned with `a`, its part across `a`.
fn perpendicular(a: Vec3) -> Vec3 {
    let k = (0..3).min_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs())).expect("three axes");
    let e = Vec3::ith(k, 1.0);
    (e - a * a.dot(&e)).normalize()
}

/// The spatial mechanism of a validated scenario: every joint as written when `ideal`, else the
/// joints with a clearance left out (they become [`SphericalClearance`]s).
pub fn build_spatial(s: &SpatialScenario, ideal: bool) -> SpatialFullModel {
    let id = |name: &str| -> BodyId {
        if name == "ground" {
            BodyId::Ground
        } else {
            BodyId::Body(s.bodies.iter().position(|b| b.name == name).expect("validated"))
        }
    };
    let mechanism = spatial_mechanism(s, ideal, &id);
    let clearances = if ideal { Vec::new() } else { spherical_clearances(s, &id) };
    SpatialFullModel::new(mechanism, clearances)
}

/// The body of a scenario's `[[bodies]]` entry.
fn spatial_body(b: &lash_scenario::spatial::SpatialBodySpec) -> SpatialBody {
    let [w, x, y, z] = b.orientation;
    SpatialBody {
        name: b.name.clone(),
        mass: b.mass,
        inertia: inertia_tensor(b),
        position: v3(b.position),
        orientation: Orientation::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)),
        velocity: v3(b.velocity),
        angular_velocity: v3(b.angular_velocity),
    }
}

/// The spatial mechanism of `s` with its clearance joints left out (kept as written with
/// `ideal`); `id` maps a body's name to its id.
fn spatial_mechanism(s: &SpatialScenario, ideal: bool, id: &dyn Fn(&str) -> BodyId) -> SpatialMechanism {
    let bodies: Vec<SpatialBody> = s.bodies.iter().map(spatial_body).collect();
    let rotation = |body: BodyId| match body {
        BodyId::Ground => Orientation::identity(),
        BodyId::Body(k) => bodies[k].orientation,
    };
    let has_clearance = |name: &str| !ideal && s.clearances.iter().any(|c| c.joint == name);
    let mut joints = Vec::new();
    for j in s.joints.iter().filter(|j| !has_clearance(&j.name)) {
        let (b1, b2) = (id(&j.body1), id(&j.body2));
        let z1 = j.axis1.map_or(Vec3::z(), |a| v3(a).normalize());
        let z2 = j.axis2.map_or(Vec3::z(), |a| v3(a).normalize());
        let x1 = j.reference1.map_or_else(|| perpendicular(z1), |r| v3(r).normalize());
        let x2 = match j.reference2 {
            Some(r) => v3(r).normalize(),
            None => {
                // reference1 carried into body2's frame through the initial poses.
                let carried = rotation(b2).inverse() * (rotation(b1) * x1);
                let across = carried - z2 * z2.dot(&carried);
                if across.norm() > 1e-9 { across.normalize() } else { perpendicular(z2) }
            }
        };
        joints.push(SpatialJoint {
            name: j.name.clone(),
            kind: j.kind,
            i: Marker { body: b1, point: v3(j.point1), z: z1, x: x1 },
            j: Marker { body: b2, point: v3(j.point2), z: z2, x: x2 },
        });
    }
    let joint_index = |name: &str| joints.iter().position(|j| j.name == name).expect("validated");
    let drivers = s
        .drivers
        .iter()
        .map(|d| SpatialDriver { name: d.name.clone(), joint: joint_index(&d.joint), motion: d.motion.clone() })
        .collect();
    let body_index = |name: &str| match id(name) {
        BodyId::Body(k) => k,
        BodyId::Ground => unreachable!("validated: loads act on moving bodies"),
    };
    let loads = s
        .loads
        .iter()
        .map(|l| match l {
            SpatialLoadSpec::Force { body, point, force } => {
                SpatialLoad::Force { body: body_index(body), point: v3(*point), force: v3(*force) }
            }
            SpatialLoadSpec::Torque { body, torque } => {
                SpatialLoad::Torque { body: body_index(body), torque: v3(*torque) }
            }
            SpatialLoadSpec::Motor { joint, stall_torque, no_load_speed } => SpatialLoad::Motor {
                joint: joint_index(joint),
                stall_torque: *stall_torque,
                no_load_speed: *no_load_speed,
            },
        })
        .collect();
    SpatialMechanism {
        bodies,
        joints,
        drivers,
        loads,
        gravity: v3(s.gravity),
        baumgarte: Baumgarte { ..s.simulation.baumgarte },
    }
}

/// The spherical clearance joints of `s`'s `[[clearances]]`, the ball on the body the file names.
fn spherical_clearances(s: &SpatialScenario, id: &dyn Fn(&str) -> BodyId) -> Vec<SphericalClearance> {
    let material = |m: &Option<String>| m.as_ref().map_or(Material::STEEL, |n| s.materials[n]);
    s.clearances
        .iter()
        .map(|c| {
            let j = s.joints.iter().find(|j| j.name == c.joint).expect("validated");
            let (journal, bearing) = if c.journal == j.body1 {
                ((&j.body1, j.point1), (&j.body2, j.point2))
            } else {
                ((&j.body2, j.point2), (&j.body1, j.point1))
            };
            SphericalClearance {
                name: c.joint.clone(),
                journal_body: id(journal.0),
                journal_point: v3(journal.1),
                bearing_body: id(bearing.0),
                bearing_point: v3(bearing.1),
                journal_radius: c.journal_radius,
                bearing_radius: c.bearing_radius,
                law: c.contact.resolve(
                    &material(&c.journal_material),
                    &material(&c.bearing_material),
                    c.journal_radius,
                    c.bearing_radius,
                ),
                friction: c.friction,
                in_contact: false,
                onset_velocity: 0.0,
            }
        })
        .collect()
}

/// Computes a spatial full model's channels from its last evaluation: the one sampling routine of
/// `lash run` and of the full-model FMU.
pub(crate) struct SpatialSampler {
    /// Row range of each joint's equations in the solver (joints first, in order).
    ranges: Vec<std::ops::Range<usize>>,
    /// Row of each driver's equation (after the joints').
    driver_rows: Vec<usize>,
    /// Body and body-frame point of each sensor.
    sensors: Vec<(usize, Vec3)>,
}

impl SpatialSampler {
    /// The rows and sensor points of `model` built from `scenario`.
    pub(crate) fn new(scenario: &SpatialScenario, model: &SpatialFullModel) -> Self {
        let mech = &model.mechanism;
        let mut ranges = Vec::new();
        let mut at = 0;
        for j in &mech.joints {
            ranges.push(at..at + j.kind.equations());
            at += j.kind.equations();
        }
        let driver_rows = (0..mech.drivers.len()).map(|k| at + k).collect();
        let sensors = scenario
            .sensors
            .iter()
            .map(|x| (scenario.bodies.iter().position(|b| b.name == x.body).expect("validated"), v3(x.point)))
            .collect();
        Self { ranges, driver_rows, sensors }
    }

    /// The value of each of `sources` after `model.evaluate(t, y)`.
    pub(crate) fn sample(&self, model: &SpatialFullModel, sources: &[(Channel, SpatialSource)], values: &mut [f64]) {
        let (mech, solver) = (&model.mechanism, &model.solver);
        let reaction_on_body1 = |k: usize| -> Vec3 {
            let j = &mech.joints[k];
            match (j.i.body, j.j.body) {
                (BodyId::Body(b), _) => solver.reaction(self.ranges[k].clone(), b).0,
                (BodyId::Ground, BodyId::Body(b)) => -solver.reaction(self.ranges[k].clone(), b).0,
                (BodyId::Ground, BodyId::Ground) => Vec3::zeros(),
            }
        };
        let mut pose = (usize::MAX, [0.0; 7]);
        for (v, (_, src)) in values.iter_mut().zip(sources.iter()) {
            *v = match *src {
                SpatialSource::Sensor(k, q) => {
                    let (body, point) = self.sensors[k];
                    let p = point_kinematics(solver, body, point);
                    let q = q as usize;
                    [p.position, p.velocity, p.acceleration][q / 3][q % 3]
                }
                SpatialSource::Clearance(k, q) => {
                    let c = &model.contacts[k];
                    match SPATIAL_CLEARANCE_QUANTITIES[q as usize].0 {
                        "fx" => c.force_on_journal.x,
                        "fy" => c.force_on_journal.y,
                        "fz" => c.force_on_journal.z,
                        "force" => c.force_on_journal.norm(),
                        "normal_force" => c.normal_force,
                        "friction_force" => c.friction_force,
                        "ex" => c.eccentricity.x,
                        "ey" => c.eccentricity.y,
                        "ez" => c.eccentricity.z,
                        "eccentricity" => c.eccentricity_norm,
                        "penetration" => c.penetration,
                        "penetration_rate" => c.penetration_rate,
                        _ => c.slip_velocity.norm(),
                    }
                }
                SpatialSource::DriverTorque(k) => {
                    let d = &mech.drivers[k];
                    let jt = &mech.joints[d.joint];
                    let axis = lash_spatial::constraints::marker_world(&jt.i, &solver.frames).2;
                    match jt.j.body {
                        BodyId::Body(b) => {
                            solver.reaction(self.driver_rows[k]..self.driver_rows[k] + 1, b).1.dot(&axis)
                        }
                        BodyId::Ground => 0.0,
                    }
                }
                SpatialSource::JointReaction(k, q) => reaction_on_body1(k)[q as usize],
                SpatialSource::AngularVelocity(k, q) => solver.angular_velocities[k][q as usize],
                SpatialSource::ConstraintError => solver.constraint_error(),
                SpatialSource::BodyPose(k, q) => {
                    // A body's seven pose channels come together: one rotation-to-quaternion each.
                    if pose.0 != k {
                        pose = (k, solver.frames[k].pose());
                    }
                    pose.1[q as usize]
                }
            };
        }
    }
}

/// A prepared spatial run (full model, or the ideal mechanism).
pub struct SpatialRun {
    /// The model.
    pub model: SpatialFullModel,
    scenario: SpatialScenario,
    ideal: bool,
    sources: Vec<(Channel, SpatialSource)>,
    selected: Vec<usize>,
}

impl SpatialRun {
    /// Prepares a run of a validated spatial scenario.
    pub fn new(scenario: &SpatialScenario, ideal: bool) -> Self {
        let sources = spatial_channels(scenario, ideal);
        let selected = (0..sources.len())
            .filter(|&k| scenario.output.channels.is_empty() || scenario.output.channels.contains(&sources[k].0.name))
            .collect();
        Self { model: build_spatial(scenario, ideal), scenario: scenario.clone(), ideal, sources, selected }
    }

    /// Header of the written columns (time first), with units.
    pub fn header(&self) -> Vec<String> {
        std::iter::once("time [s]".to_string())
            .chain(self.selected.iter().map(|&k| format!("{} [{}]", self.sources[k].0.name, self.sources[k].0.unit)))
            .collect()
    }

    /// Integrates over the horizon; rows go to `sink`, the fraction done to `progress`.
    pub fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
        let sim = self.scenario.simulation.clone();
        let (t0, t_end) = (sim.start_time, sim.start_time + sim.horizon);
        let mut y = self
            .model
            .initial_state(t0)
            .map_err(|e| RunError::Simulation { t: t0, message: format!("initial conditions: {e}") })?;
        let sampler = SpatialSampler::new(&self.scenario, &self.model);
        let nc = self.model.clearances.len();
        let (sources, selected) = (&self.sources, &self.selected);
        let mut values = vec![0.0; sources.len()];
        let mut row = vec![0.0; selected.len() + 1];
        let mut stats = crate::record::RunningStats::new(sources.len());
        let (mut samples, mut max_constraint_error) = (0u64, 0.0f64);
        let (mut max_eccentricity, mut sum_force) = (vec![0.0f64; nc], vec![0.0f64; nc]);
        let names: Vec<&str> = sources.iter().map(|(c, _)| c.name.as_str()).collect();
        let mut measurements = crate::measure::MeasurementRecorder::new(&self.scenario.output.measurements, &names);
        let horizon = sim.horizon;
        let mut observer = |model: &mut SpatialFullModel, t: f64, y: &[f64]| -> Result<(), BoxError> {
            model.evaluate(t, y)?;
            sampler.sample(model, sources, &mut values);
            let solver = &model.solver;
            for (k, c) in model.contacts.iter().enumerate() {
                max_eccentricity[k] = max_eccentricity[k].max(c.eccentricity_norm);
                sum_force[k] += c.force_on_journal.norm();
            }
            max_constraint_error = max_constraint_error.max(solver.constraint_error());
            stats.add(&values);
            measurements.record(&values);
            samples += 1;
            row[0] = t;
            for (r, &k) in row[1..].iter_mut().zip(selected.iter()) {
                *r = values[k];
            }
            progress(((t - t0) / horizon).clamp(0.0, 1.0));
            sink(&row).map_err(crate::run::SinkFailed::boxed)
        };
        let (result, (cpu, wall)) = crate::run::timed_integration(
            &sim.integrator,
            &mut self.model,
            (t0, t_end, sim.output_interval),
            &mut y,
            &mut observer,
        );
        let non_finite =
            |index: usize, value: f64| format!("state component {index} became {value}: the simulation blew up");
        let ode = result.map_err(|e| crate::run::integration_error(e, t0, non_finite, "a blow-up?"))?;
        let (measurements, measured) = measurements
            .finish(t0, sim.output_interval)
            .map_err(|e| RunError::Simulation { t: t_end, message: e.to_string() })?;
        let mean_force: Vec<f64> = sum_force.iter().map(|f| f / samples.max(1) as f64).collect();
        let clearances = self.clearance_summaries((t_end, horizon), &max_eccentricity, &mean_force);
        let channels = stats.channel_stats(sources.iter().map(|(c, _)| c), samples);
        let model = if self.ideal { "ideal" } else { "full" };
        Ok(Summary {
            samples,
            max_constraint_error,
            channels,
            warnings: crate::run::resolution_warnings(&sim.integrator, &clearances),
            clearances,
            measurements,
            measured,
            ..Summary::new(&self.scenario.name, model, sim.integrator, &sim, (cpu, wall), &ode)
        })
    }

    /// Each spherical joint's summary of a run that ended at `t_end` after `horizon`: its
    /// impacts (the open one closed there), largest eccentricity and mean contact force.
    fn clearance_summaries(
        &self,
        (t_end, horizon): (f64, f64),
        max_eccentricity: &[f64],
        mean_force: &[f64],
    ) -> Vec<ClearanceSummary> {
        let period = crate::run::driver_period(self.scenario.drivers.iter().map(|d| &d.motion));
        let model = &self.model;
        (0..model.clearances.len())
            .map(|k| {
                let c = &model.clearances[k];
                let mut impacts = model.impacts()[k].clone();
                impacts.extend(model.open_impact(k, t_end));
                ClearanceSummary::from_impacts(
                    c.name.clone(),
                    c.radial_clearance(),
                    impacts,
                    horizon,
                    period,
                    max_eccentricity[k],
                    mean_force[k],
                )
            })
            .collect()
    }
}

/// A prepared reduced-model run of a spatial scenario: the ideal mechanism (macro, with the cut
/// mechanism's effective terms of every spherical clearance joint) and the joints' interface
/// (micro) on the interface master, one-way coupled.
pub struct SpatialReducedRun {
    scenario: SpatialScenario,
    options: crate::ReducedOptions,
    macro_sub: lash_spatial::SpatialMechanismSubsystem,
    micro_sub: lash_micro::InterfaceSubsystem,
    recording: crate::reduced::Recording,
    signals: Vec<lash_orchestrate::Signal>,
    master_options: lash_orchestrate::MasterOptions,
}

/// The micro subsystem's variable and element of spherical joint `j`'s channel `quantity`.
fn micro_element(quantity: &str, j: usize) -> (&str, usize) {
    match quantity {
        "fx" => ("contact_force", 3 * j),
        "fy" => ("contact_force", 3 * j + 1),
        "fz" => ("contact_force", 3 * j + 2),
        "force" => ("contact_force_magnitude", j),
        "ex" => ("eccentricity", 3 * j),
        "ey" => ("eccentricity", 3 * j + 1),
        "ez" => ("eccentricity", 3 * j + 2),
        "eccentricity" => ("eccentricity_norm", j),
        other => (other, j),
    }
}

/// The probe a recorded channel needs of the spatial macro subsystem (none: a micro or a fixed
/// macro output), and the master signal that reads it; `loads`: the interface loads (3k contact
/// forces, then 3k friction loads).
fn spatial_probe_signal(
    scenario: &SpatialScenario,
    (name, src): (String, SpatialSource),
    cut_joint_names: &[&str],
    loads: usize,
) -> Result<(Option<lash_spatial::SpatialProbe>, lash_orchestrate::Signal), RunError> {
    use lash_orchestrate::Signal;
    Ok(match src {
        SpatialSource::Sensor(s, q) => {
            let sen = &scenario.sensors[s];
            let body = scenario.bodies.iter().position(|b| b.name == sen.body);
            let Some(body) = body else {
                return Err(RunError::Unsupported(
                    "a sensor on the ground in the reduced model (its channels are constant)".into(),
                ));
            };
            let p = &sen.name;
            let signal = crate::reduced::sensor_signal(name, p, q as usize, 3, loads);
            (Some(lash_spatial::SpatialProbe::Point { name: p.clone(), body, point: Vec3::from(sen.point) }), signal)
        }
        SpatialSource::Clearance(j, q) => {
            let (variable, element) = micro_element(SPATIAL_CLEARANCE_QUANTITIES[q as usize].0, j);
            (None, Signal::Micro { name, variable: variable.into(), element })
        }
        SpatialSource::DriverTorque(d) => {
            let p = &scenario.drivers[d].name;
            (
                Some(lash_spatial::SpatialProbe::DriverTorque { name: p.clone(), driver: d }),
                Signal::Propagated {
                    name,
                    free: (format!("{p}.torque_free"), 0),
                    gain: (format!("{p}.torque_gain"), 0),
                },
            )
        }
        SpatialSource::JointReaction(j, comp) => {
            let p = cut_joint_names[j];
            let comp = comp as usize;
            (
                Some(lash_spatial::SpatialProbe::JointReaction { name: p.to_string(), joint: j }),
                Signal::Propagated {
                    name,
                    free: (format!("{p}.reaction_free"), comp),
                    gain: (format!("{p}.reaction_gain"), comp * loads),
                },
            )
        }
        SpatialSource::AngularVelocity(b, q) => {
            let p = &scenario.bodies[b].name;
            let q = q as usize;
            (
                Some(lash_spatial::SpatialProbe::BodyRates { name: p.clone(), body: b }),
                Signal::Macro {
                    name,
                    variable: format!("{p}.angular_velocity"),
                    element: q,
                    derivative: Some((format!("{p}.angular_acceleration"), q)),
                },
            )
        }
        SpatialSource::ConstraintError => {
            (None, Signal::Macro { name, variable: "constraint_error".into(), element: 0, derivative: None })
        }
        SpatialSource::BodyPose(b, q) => {
            let p = &scenario.bodies[b].name;
            let q = q as usize;
            // The centroid with its rate; the quaternion without (interpolated linearly).
            let derivative = (q < 3).then(|| (format!("{p}.centroid_velocity"), q));
            (
                Some(lash_spatial::SpatialProbe::Body { name: p.clone(), body: b }),
                Signal::Macro { name, variable: format!("{p}.pose"), element: q, derivative },
            )
        }
    })
}

/// What the spatial reduced run records: the `recorded` channels of `sources` (the first
/// `written` of them written), with each of the `k` joints' summary signals.
fn spatial_recording(
    scenario: &SpatialScenario,
    sources: &[(Channel, SpatialSource)],
    (recorded, written): (&[usize], usize),
    k: usize,
) -> crate::reduced::Recording {
    crate::reduced::Recording {
        channels: recorded.iter().map(|&i| sources[i].0.clone()).collect(),
        written,
        statistics: true,
        summary: (0..k)
            .map(|j| {
                let at = |name: &str| {
                    recorded
                        .iter()
                        .position(|&i| matches!(sources[i].1, SpatialSource::Clearance(c, q) if c == j && SPATIAL_CLEARANCE_QUANTITIES[q as usize].0 == name))
                        .expect("recorded")
                };
                crate::reduced::JointSignals {
                    eccentricity: at("eccentricity"),
                    force: at("force"),
                    penetration: at("penetration"),
                }
            })
            .collect(),
        measurements: scenario.output.measurements.clone(),
        stresses: Vec::new(),
    }
}

impl SpatialReducedRun {
    /// Prepares a run; refuses what the spatial reduced model does not cover (no spherical
    /// clearance joint, more than four, a sensor on the ground).
    pub fn new(scenario: &SpatialScenario, options: crate::ReducedOptions) -> Result<Self, RunError> {
        let max_joints = lash_micro::MAX_COORDINATES / 3;
        if scenario.clearances.is_empty() || scenario.clearances.len() > max_joints {
            return Err(RunError::Unsupported(format!(
                "the reduced model couples 1 to {max_joints} spherical clearance joints; the scenario has {}",
                scenario.clearances.len()
            )));
        }
        let master_options = crate::reduced::master_options(&scenario.simulation, options)?;
        let full = build_spatial(scenario, false);
        let cut = full.mechanism.clone();
        let ideal = full.ideal_mechanism();
        let joints = full.clearances.clone();
        let interfaces: Vec<lash_spatial::SphericalInterface> = joints
            .iter()
            .map(|c| lash_spatial::SphericalInterface {
                journal_body: c.journal_body,
                journal_point: c.journal_point,
                bearing_body: c.bearing_body,
                bearing_point: c.bearing_point,
                journal_radius: c.journal_radius,
                bearing_radius: c.bearing_radius,
            })
            .collect();
        let k = joints.len();
        let loads = 6 * k; // 3k contact forces, then 3k friction loads n × F_T
        // Every channel, in file order, as in the full model.
        let sources = spatial_channels(scenario, false);
        let written: Vec<usize> = (0..sources.len())
            .filter(|&i| scenario.output.channels.is_empty() || scenario.output.channels.contains(&sources[i].0.name))
            .collect();
        let mut recorded = written.clone();
        crate::record::record_joint_summaries(&mut recorded, &sources, k, |s| match *s {
            SpatialSource::Clearance(j, q) => Some((j, SPATIAL_CLEARANCE_QUANTITIES[q as usize].0)),
            _ => None,
        });
        let names: Vec<&str> = sources.iter().map(|(c, _)| c.name.as_str()).collect();
        crate::measure::record_forces(&mut recorded, &names, &scenario.output.measurements);
        let cut_joint_names: Vec<&str> = cut.joints.iter().map(|j| j.name.as_str()).collect();
        let mut probes: Vec<lash_spatial::SpatialProbe> = Vec::new();
        let mut signals = Vec::with_capacity(recorded.len());
        for &i in &recorded {
            let (channel, src) = &sources[i];
            let name = channel.name.clone();
            let (probe, signal) = spatial_probe_signal(scenario, (name, *src), &cut_joint_names, loads)?;
            if let Some(p) = probe
                && !probes.contains(&p)
            {
                probes.push(p);
            }
            signals.push(signal);
        }
        let recording = spatial_recording(scenario, &sources, (&recorded, written.len()), k);
        let macro_sub =
            lash_spatial::SpatialMechanismSubsystem::new("mechanism", cut, ideal, interfaces, probes, options.coupling);
        let integrator = options.micro_integrator();
        let material = |m: &Option<String>| m.as_ref().map_or(Material::STEEL, |n| scenario.materials[n]);
        let definitions = scenario
            .clearances
            .iter()
            .map(|c| lash_contact::ClearanceDefinition {
                journal_radius: c.journal_radius,
                bearing_radius: c.bearing_radius,
                contact: c.contact.clone(),
                friction: c.friction,
                journal_material: material(&c.journal_material),
                bearing_material: material(&c.bearing_material),
                film: None,
            })
            .collect();
        let micro_sub = lash_micro::InterfaceSubsystem::with_definitions(joints, integrator, definitions)
            .map_err(|e| RunError::Unsupported(e.to_string()))?;
        Ok(Self { scenario: scenario.clone(), options, macro_sub, micro_sub, recording, signals, master_options })
    }

    /// The two subsystems, unstarted (for export as FMUs or for another master).
    pub fn into_subsystems(self) -> (lash_spatial::SpatialMechanismSubsystem, lash_micro::InterfaceSubsystem) {
        (self.macro_sub, self.micro_sub)
    }

    /// Header of the written columns (the same channels as the full model).
    pub fn header(&self) -> Vec<String> {
        std::iter::once("time [s]".to_string())
            .chain(self.recording.channels[..self.recording.written].iter().map(|c| format!("{} [{}]", c.name, c.unit)))
            .collect()
    }

    /// Runs the horizon; rows go to `sink`, the fraction done to `progress`.
    pub fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
        let details = self.details();
        crate::reduced::run_reduced(self.coupled(), details, sink, progress)
    }

    /// Runs several prepared runs side by side, run i's rows to `sinks[i]`: their micro models
    /// are stepped eight at a time in vector lanes where they can be
    /// ([`lash_micro::do_steps_together`]). Each run's rows and summary are those of its own
    /// [`SpatialReducedRun::execute`], bit for bit, but for the CPU and wall times (the group's,
    /// shared equally); runs whose settings cannot go together run one after the other.
    pub fn execute_together(
        runs: &mut [&mut SpatialReducedRun],
        sinks: Vec<Sink<'_>>,
    ) -> Vec<Result<Summary, RunError>> {
        let details: Vec<_> = runs.iter().map(|r| r.details()).collect();
        let group: Vec<_> = runs.iter_mut().map(|r| r.coupled()).collect();
        // (The spatial macro steps are not taken ahead in lanes: each run takes its own.)
        let mut ahead = |_: &mut [&mut lash_spatial::SpatialMechanismSubsystem], _, _| {};
        crate::reduced::run_reduced_together(group, sinks, &mut ahead, |i, master| details[i](master))
    }

    /// The two subsystems and what the run records, for the interface master.
    fn coupled(&mut self) -> crate::reduced::Coupled<'_, lash_spatial::SpatialMechanismSubsystem> {
        crate::reduced::Coupled {
            macro_sub: &mut self.macro_sub,
            micro_sub: &mut self.micro_sub,
            master: self.master_options,
            signals: &self.signals,
            recording: &self.recording,
            simulation: &self.scenario.simulation,
            scenario: &self.scenario.name,
            period: crate::run::driver_period(self.scenario.drivers.iter().map(|d| &d.motion)),
        }
    }

    /// The run's details from the master's statistics.
    fn details(&self) -> impl Fn(lash_orchestrate::MasterStats) -> crate::reduced::ReducedDetails + use<> {
        let options = self.options;
        move |master| crate::reduced::ReducedDetails { options, kinematic_macro: false, master }
    }
}
