//! The macro subsystem of the reduced interface model for spatial mechanisms: the ideal
//! mechanism around its k spherical clearance joints (n = 3k interface coordinates), as a
//! [`Subsystem`] — the spatial counterpart of `lash_mech::MechanismSubsystem`, with the same
//! variable names, so that the same master and micro subsystem run it.
//!
//! The ideal mechanism is integrated (DOPRI5, rtol 1e-6) over each communication step: in
//! one-way coupling with its balls centred, in two-way coupling with each ball moved to the
//! eccentricity the micro model reached (the cubic Hermite across the step between the nodes'
//! e and ė, inputs `eccentricity`, `eccentricity_rate`) and the mean friction loads' torques
//! applied (input `friction_force`: each joint's mean n × F_T over the step), as the planar
//! macro subsystem does. At each communication point the subsystem exports the cut
//! system's effective terms (M̃, f̃, W, a_free), H = M̃ W_τ for the friction loads (each joint's
//! n × F_T, world frame, whose torques are R_J n × F_T on the ball's body and −R_B n × F_T on the
//! socket's), the journal and bearing bodies' world angular velocities and accelerations, and for
//! every probe its propagation map (`…_free` at no interface load, `…_gain` per unit load: the contact forces, then the
//! friction loads).

use crate::interface::{SpatialCoupledTerms, SphericalInterface, spatial_effective_terms_into};
use crate::model::SpatialMechanism;
use crate::solver::SpatialSolver;
use crate::system::{ClosedJoints, SpatialSystem};
use crate::{Vec3, assemble, velocity_analysis};
use lash_core::subsystem::{Causality, Phase, Variability, VariableTable, per_joint_shape};
use lash_core::{
    Coupling, MacroPorts, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, TwoWayInputs, ValueReference,
    Variable,
};
use lash_mech::BodyId;
use lash_mech::subsystem::{add_propagated, linear_in_loads};
use lash_ode::{AdaptiveOptions, Method};

/// A quantity of the spatial mechanism exported with its propagation map.
#[derive(Debug, Clone, PartialEq)]
pub enum SpatialProbe {
    /// A body point: `name.position`, `name.velocity`, `name.acceleration…` (3 each).
    Point {
        /// Prefix of the variable names.
        name: String,
        /// Moving body index.
        body: usize,
        /// Point (body frame, from the centroid) \[m\].
        point: Vec3,
    },
    /// Reaction force of ideal joint `joint` of the cut mechanism on its body I: `name.reaction…`.
    JointReaction {
        /// Prefix of the variable names.
        name: String,
        /// Joint index in the cut mechanism.
        joint: usize,
    },
    /// Torque of driver `driver` about its joint's axis on body J: `name.torque…`.
    DriverTorque {
        /// Prefix of the variable names.
        name: String,
        /// Driver index.
        driver: usize,
    },
    /// A body's angular velocity in its own frame: `name.angular_velocity` with its derivative
    /// `name.angular_acceleration` (the macro's own motion; not propagated).
    BodyRates {
        /// Prefix of the variable names.
        name: String,
        /// Moving body index.
        body: usize,
    },
    /// A body's pose: `name.pose` (centroid x, y, z, then the orientation quaternion w, x, y,
    /// z; see [`crate::constraints::BodyFrame::pose`]) and `name.centroid_velocity` (the
    /// centroid's rate). The macro's own motion; not propagated.
    Body {
        /// Prefix of the variable names.
        name: String,
        /// Moving body index.
        body: usize,
    },
}

/// Largest Baumgarte gain (α and β) of the macro's own integration [1/s].
pub const MACRO_STABILISATION: f64 = 100.0;

/// Fixed value references (probe variables follow in probe order).
pub mod vr {
    lash_core::value_references! {
        /// Output M̃ (n × n) \[kg\].
        EFFECTIVE_MASS,
        /// Output f̃ (n) \[N\].
        EFFECTIVE_FORCE,
        /// Output W = M̃⁻¹ (n × n) [1/kg].
        MOBILITY,
        /// Output a_free (n) [m/s²].
        FREE_ACCELERATION,
        /// Output H = M̃ W_τ (n × 3k).
        FRICTION_MOMENT_FORCE,
        /// Output G = W_τ = W H (n × 3k) [1/kg]: the interface acceleration per unit friction load.
        FRICTION_MOBILITY,
        /// Output ω of each journal body (3k, world frame).
        JOURNAL_ANGULAR_VELOCITY,
        /// Output α of each journal body (3k).
        JOURNAL_ANGULAR_ACCELERATION,
        /// Output ω of each bearing body (3k).
        BEARING_ANGULAR_VELOCITY,
        /// Output α of each bearing body (3k).
        BEARING_ANGULAR_ACCELERATION,
        /// Output max |Φ| of the ideal mechanism.
        CONSTRAINT_ERROR,
        /// Input (two-way coupling): eccentricities at the end of the next step (n) \[m\].
        ECCENTRICITY,
        /// Input (two-way coupling): their rates (n) [m/s].
        ECCENTRICITY_RATE,
        /// Input (two-way coupling): each joint's mean friction load n × F_T over the next step
        /// (3k) \[N\].
        FRICTION_FORCE,
    }
}

/// The spatial mechanism around its spherical clearance joints as the macro [`Subsystem`].
pub struct SpatialMechanismSubsystem {
    /// Name, variables and values, clock, phase and two-way inputs.
    ports: MacroPorts,
    cut: SpatialMechanism,
    ideal: SpatialSystem,
    joints: Vec<SphericalInterface>,
    probes: Vec<SpatialProbe>,
    integrator: AdaptiveOptions,
    coupling: Coupling,
    y: Vec<f64>,
    cut_solver: SpatialSolver,
    /// The effective terms at the current communication point.
    pub terms: Option<SpatialCoupledTerms>,
    /// Work storage of `refresh` (kept between communication points).
    work: RefreshWork,
    /// Steps and right-hand-side evaluations of the integration.
    pub integration_stats: lash_ode::Stats,
}

/// Work vectors of the spatial macro's refresh at each communication point.
#[derive(Default)]
struct RefreshWork {
    /// H = M̃ W_τ.
    moment_force: nalgebra::DMatrix<f64>,
    /// The macro's own interface loads and generalized accelerations.
    own_load: Vec<f64>,
    own: Vec<f64>,
    /// The bodies' frames at the communication point.
    frames: Vec<crate::constraints::BodyFrame>,
    /// One probe's gains.
    gains: Vec<f64>,
    /// Rows of each cut joint.
    ranges: Vec<std::ops::Range<usize>>,
}

fn body_index(id: BodyId) -> Option<usize> {
    match id {
        BodyId::Body(k) => Some(k),
        BodyId::Ground => None,
    }
}

/// The spatial macro subsystem's variables for `k` spherical clearance joints and `probes`: the
/// interface terms, the bodies' rates and the constraint error (outputs), the two-way inputs,
/// then each probe's outputs.
fn spatial_variables(k: usize, probes: &[SpatialProbe]) -> Vec<Variable> {
    use Causality::{Input, Output};
    use Variability::Continuous as C;
    let (n, m) = (3 * k, 3 * k);
    let g = n + m;
    let rotations = per_joint_shape(3 * k, &[]);
    let mut t = VariableTable::new();
    let moment_force = "force on the balls equivalent to a unit friction load n x F_T of each joint (M~ W_tau)";
    let moment_mobility = "interface acceleration per unit friction load n x F_T of each joint (W_tau = W H)";
    let terms: [(ValueReference, &str, &str, &str, &[usize]); 6] = [
        (vr::EFFECTIVE_MASS, "effective_mass", "kg", "effective mass M~ of the interface", &[n, n]),
        (vr::EFFECTIVE_FORCE, "effective_force", "N", "effective force f~ (M~ w'' = f~ + f_c + H L)", &[n]),
        (vr::MOBILITY, "mobility", "1/kg", "W = inverse of M~", &[n, n]),
        (vr::FREE_ACCELERATION, "free_acceleration", "m/s^2", "interface acceleration with f_c = 0", &[n]),
        (vr::FRICTION_MOMENT_FORCE, "friction_moment_force", "1", moment_force, &[n, m]),
        (vr::FRICTION_MOBILITY, "friction_mobility", "1/kg", moment_mobility, &[n, m]),
    ];
    for (at, name, unit, description, shape) in terms {
        t.add_at(at, name, Output, C, unit, description, shape, &[0.0]);
    }
    lash_mech::subsystem::add_body_rates(
        &mut t,
        [
            vr::JOURNAL_ANGULAR_VELOCITY,
            vr::JOURNAL_ANGULAR_ACCELERATION,
            vr::BEARING_ANGULAR_VELOCITY,
            vr::BEARING_ANGULAR_ACCELERATION,
        ],
        Output,
        &rotations,
    );
    t.add_at(vr::CONSTRAINT_ERROR, "constraint_error", Output, C, "m", "max |constraint violation|", &[], &[0.0]);
    let two_way = [
        (vr::ECCENTRICITY, "eccentricity", "m", "ball minus socket centres at the step end (two-way)"),
        (vr::ECCENTRICITY_RATE, "eccentricity_rate", "m/s", "their rates at the step end (two-way)"),
        (vr::FRICTION_FORCE, "friction_force", "N", "mean friction load n x F_T over the next step (two-way)"),
    ];
    for (at, name, unit, description) in two_way {
        t.add_at(at, name, Input, C, unit, description, &[n], &[0.0]);
    }
    let gains = (g, "per unit contact force (f_c), then per unit friction load (n x F_T)");
    for p in probes {
        match p {
            SpatialProbe::Point { name, .. } => {
                t.add(format!("{name}.position"), Output, C, "m", "point position", &[3], &[0.0]);
                t.add(format!("{name}.velocity"), Output, C, "m/s", "point velocity", &[3], &[0.0]);
                add_propagated(&mut t, (name, "acceleration"), ("m/s^2", "m/s^2/N"), &[3], gains);
            }
            SpatialProbe::JointReaction { name, .. } => {
                add_propagated(&mut t, (name, "reaction"), ("N", "1"), &[3], gains);
            }
            SpatialProbe::DriverTorque { name, .. } => {
                add_propagated(&mut t, (name, "torque"), ("N.m", "m"), &[], gains);
            }
            SpatialProbe::BodyRates { name, .. } => {
                t.add(format!("{name}.angular_velocity"), Output, C, "rad/s", "in the body frame", &[3], &[0.0]);
                t.add(format!("{name}.angular_acceleration"), Output, C, "rad/s^2", "its rate", &[3], &[0.0]);
            }
            SpatialProbe::Body { name, .. } => {
                t.add(format!("{name}.pose"), Output, C, "m, 1", "centroid, orientation quaternion", &[7], &[0.0]);
                t.add(format!("{name}.centroid_velocity"), Output, C, "m/s", "the centroid's rate", &[3], &[0.0]);
            }
        }
    }
    t.into_checked_variables().expect("the spatial mechanism subsystem's variables follow `vr`")
}

impl SpatialMechanismSubsystem {
    /// A macro subsystem for the cut mechanism `cut` (every spherical clearance joint removed) and
    /// the ideal one `ideal` (with them, as its last joints, in the same order), the interfaces,
    /// the probes and the coupling.
    pub fn new(
        name: &str,
        cut: SpatialMechanism,
        ideal: SpatialMechanism,
        joints: Vec<SphericalInterface>,
        probes: Vec<SpatialProbe>,
        coupling: Coupling,
    ) -> Self {
        let k = joints.len();
        let (n, m) = (3 * k, 3 * k);
        let variables = spatial_variables(k, &probes);
        let dim = ideal.coordinate_count() + ideal.velocity_count();
        // The ideal motion is smooth: integrated with steps up to the communication step, it
        // needs no stiffer stabilisation than a 10 ms time constant. (E's α = β = 1000 1/s, chosen
        // for the full model's contact phases, held the macro's integrator — then DOP853 at 1e-10 — to
        // 0.17 ms steps here: 123 right-hand sides per 1 ms step against 16 at 100 1/s.)
        let first_closed_row = cut.joints.iter().map(|j| j.kind.equations()).sum::<usize>();
        let mut ideal = ideal;
        ideal.baumgarte = lash_mech::Baumgarte {
            alpha: ideal.baumgarte.alpha.min(MACRO_STABILISATION),
            beta: ideal.baumgarte.beta.min(MACRO_STABILISATION),
        };
        Self {
            ports: MacroPorts::new(name, variables, TwoWayInputs::new(vr::ECCENTRICITY, n, m)),
            cut_solver: SpatialSolver::new(&cut),
            cut,
            ideal: {
                // Each communication step's integration starts where the last one stopped: its
                // first right-hand side is the last one's final stage.
                let mut system = SpatialSystem::new(ideal);
                system.remember_last_evaluation();
                // The closed clearance joints are the ideal mechanism's last ones, three rows each.
                system.close_joints(ClosedJoints {
                    rows: (0..joints.len()).map(|j| first_closed_row + 3 * j).collect(),
                    torque_arms: joints
                        .iter()
                        .map(|j| [(j.journal_body, j.journal_radius), (j.bearing_body, -j.bearing_radius)])
                        .collect(),
                });
                system
            },
            joints,
            probes,
            // DOPRI5 at 1e-6: for E one step and 6.1 solves per 1 ms communication step. The
            // slider stays within 3e-11 m of its closed form at the nodes (tests/spatial.rs), as
            // at 1e-7 (1.4 steps, 8.6 solves) and at 1e-5, so that error is not the integrator's;
            // it is far below the micro model's. (DOP853 at 1e-10: 16 right-hand sides; DOPRI5 at
            // 1e-8: 13.)
            integrator: AdaptiveOptions { rtol: 1e-6, atol: 1e-9, initial_step: 1e-5, max_step: 1e-3, min_step: 1e-12 },
            coupling,
            y: vec![0.0; dim],
            terms: None,
            work: RefreshWork::default(),
            integration_stats: lash_ode::Stats::default(),
        }
    }

    /// Two-way: moves the closed clearance joints over the step from `start` over `span`, from
    /// the current eccentricities to the targets, under the mean friction loads given.
    fn prescribe(&mut self, start: f64, span: f64) {
        self.ideal.prescribe(Some(self.ports.two_way.prescription(start, span)));
    }

    /// The value of an output by value reference.
    pub fn output(&self, vr: ValueReference) -> &[f64] {
        self.ports.output(vr)
    }

    /// Terms and every output at the current state.
    fn refresh(&mut self) -> Result<(), String> {
        let t = self.ports.time.seconds();
        let nq = self.cut.coordinate_count();
        let (q, v) = self.y.split_at(nq);
        let k = self.joints.len();
        let mut terms =
            self.terms.take().unwrap_or_else(|| SpatialCoupledTerms::zeros(v.len(), self.cut.constraint_count(), k));
        spatial_effective_terms_into(&self.cut, &mut self.cut_solver, &self.joints, t, q, v, &mut terms)
            .map_err(|e| e.to_string())?;
        let Some(mass) = terms.effective_mass.as_ref() else {
            return Err(format!(
                "the interface mobility W = {} is singular: the cut mechanism cannot move the balls freely in every \
                 direction",
                terms.mobility
            ));
        };
        let g = 6 * k; // loads: 3k contact forces, then 3k friction loads n × F_T
        let work = &mut self.work;
        if work.moment_force.shape() != terms.moment_mobility.shape() {
            work.moment_force = nalgebra::DMatrix::zeros(3 * k, 3 * k);
        }
        mass.mul_to(&terms.moment_mobility, &mut work.moment_force);
        let moment_force = &work.moment_force;
        // The macro's own motion has ẅ = 0 (one-way: its interface load is −f̃, no friction) or
        // the prescribed ẅ with the mean friction loads L̄ (two-way: M̃ (ẅ − a_free) − H L̄).
        work.own_load.clear();
        work.own_load.resize(g, 0.0);
        let own_load = &mut work.own_load;
        let two_way =
            self.ideal.prescribed().map(|p| (nalgebra::DVector::from_fn(3 * k, |i, _| p.at(t, i)[2]), &p.friction[..]));
        lash_mech::own_interface_load(
            own_load,
            &terms.effective_force,
            two_way,
            (mass, &terms.free_acceleration, moment_force),
        );
        accelerations_under(&mut work.own, &terms.free_accelerations, &terms.gain, own_load);
        let (own_load, own) = (&*own_load, &*work.own);
        work.frames.clone_from(&self.cut_solver.frames);
        let frames = &work.frames;
        let world = |b: BodyId, x: &[f64], angular: bool| -> Vec3 {
            match body_index(b) {
                None => Vec3::zeros(),
                Some(k) if angular => frames[k].rotation * Vec3::new(x[6 * k + 3], x[6 * k + 4], x[6 * k + 5]),
                Some(k) => Vec3::new(x[6 * k], x[6 * k + 1], x[6 * k + 2]),
            }
        };
        let omega = |b: BodyId| body_index(b).map_or(Vec3::zeros(), |k| frames[k].angular_velocity);
        let (values, offsets) = self.ports.values_and_offsets();
        let range = |vr: ValueReference| offsets[vr as usize]..offsets[vr as usize + 1];
        // Matrices go out row-major.
        let mut put_matrix = |vr: ValueReference, m: &nalgebra::DMatrix<f64>| {
            lash_core::subsystem::row_major(&mut values[range(vr)], m.as_slice(), m.nrows())
        };
        put_matrix(vr::EFFECTIVE_MASS, mass);
        put_matrix(vr::MOBILITY, &terms.mobility);
        put_matrix(vr::FRICTION_MOMENT_FORCE, moment_force);
        put_matrix(vr::FRICTION_MOBILITY, &terms.moment_mobility);
        let mut stack = |vr: ValueReference, f: &dyn Fn(&SphericalInterface) -> Vec3| {
            for (out, j) in values[range(vr)].chunks_exact_mut(3).zip(&self.joints) {
                out.copy_from_slice(f(j).as_slice());
            }
        };
        stack(vr::JOURNAL_ANGULAR_VELOCITY, &|j| omega(j.journal_body));
        stack(vr::JOURNAL_ANGULAR_ACCELERATION, &|j| world(j.journal_body, own, true));
        stack(vr::BEARING_ANGULAR_VELOCITY, &|j| omega(j.bearing_body));
        stack(vr::BEARING_ANGULAR_ACCELERATION, &|j| world(j.bearing_body, own, true));
        let mut put = |vr: ValueReference, v: &[f64]| values[range(vr)].copy_from_slice(v);
        put(vr::EFFECTIVE_FORCE, terms.effective_force.as_slice());
        put(vr::FREE_ACCELERATION, terms.free_acceleration.as_slice());
        self.ideal.set_state(t, q, v);
        put(vr::CONSTRAINT_ERROR, &[self.ideal.solver.constraint_error()]);
        work.gains.clear();
        work.gains.resize(3 * g, 0.0);
        let state = ProbeState { v, own, own_load, frames, cut: &self.cut, solver: &mut self.cut_solver };
        write_probes(&self.probes, state, &terms, (&mut work.gains, &mut work.ranges), &mut put);
        self.ports.check_finite().map_err(|e| e.to_string())?;
        self.terms = Some(terms);
        Ok(())
    }
}

/// The macro's accelerations under the interface loads `loads`: the free ones plus each load's
/// column of `gain` times the load, into `own`.
fn accelerations_under(own: &mut Vec<f64>, free: &[f64], gain: &[Vec<f64>], loads: &[f64]) {
    own.clear();
    own.extend_from_slice(free);
    for (column, &f) in gain.iter().zip(loads) {
        for (a, c) in own.iter_mut().zip(column) {
            *a += c * f;
        }
    }
}

/// What a probe reads: the macro's velocities `v`, its own accelerations and interface loads, the
/// bodies' frames, and the cut mechanism with its solver at that state.
struct ProbeState<'a> {
    v: &'a [f64],
    own: &'a [f64],
    own_load: &'a [f64],
    frames: &'a [crate::constraints::BodyFrame],
    cut: &'a SpatialMechanism,
    solver: &'a mut SpatialSolver,
}

/// Every probe's outputs, in the order of `probes`, through `put` from the first value
/// reference after the fixed ones; `terms` give the free values and the gains, written through
/// `gains` (three rows of one gain per load); `ranges` holds each cut joint's rows.
fn write_probes(
    probes: &[SpatialProbe],
    s: ProbeState<'_>,
    terms: &SpatialCoupledTerms,
    (gains, ranges): (&mut [f64], &mut Vec<std::ops::Range<usize>>),
    put: &mut dyn FnMut(ValueReference, &[f64]),
) {
    let mut next = vr::FRICTION_FORCE + 1;
    let g = gains.len() / 3;
    // What a reaction or a torque is at no load (λ free) and per unit load (each λ column).
    let multipliers = (&terms.free_lambda[..], &terms.lambda_gain[..]);
    let (v, own, own_load, frames) = (s.v, s.own, s.own_load, s.frames);
    // Rows of each cut joint and the first driver row.
    ranges.clear();
    let mut row = 0;
    for j in &s.cut.joints {
        ranges.push(row..row + j.kind.equations());
        row += j.kind.equations();
    }
    let ranges = &*ranges;
    for p in probes {
        match p {
            SpatialProbe::Point { body, point, .. } => {
                put_point_probe((&frames[*body], *body, point), terms, own, gains, &mut *put, next);
                next += 5;
            }
            SpatialProbe::JointReaction { joint, .. } => {
                let jt = &s.cut.joints[*joint];
                let solver = &mut *s.solver;
                let reaction = |lambda: &[f64]| -> Vec3 {
                    solver.lambda.copy_from_slice(lambda);
                    match (body_index(jt.i.body), body_index(jt.j.body)) {
                        (Some(b), _) => solver.reaction(ranges[*joint].clone(), b).0,
                        (None, Some(b)) => -solver.reaction(ranges[*joint].clone(), b).0,
                        (None, None) => Vec3::zeros(),
                    }
                };
                let (total, free) = linear_in_loads(multipliers, own_load, reaction, |c, r: Vec3| {
                    for i in 0..3 {
                        gains[i * g + c] = r[i];
                    }
                });
                put(next, total.as_slice());
                put(next + 1, free.as_slice());
                put(next + 2, gains);
                next += 3;
            }
            SpatialProbe::DriverTorque { driver, .. } => {
                let jt = &s.cut.joints[s.cut.drivers[*driver].joint];
                let axis = crate::constraints::marker_world(&jt.i, frames).2;
                let driver_row = row + driver;
                let solver = &mut *s.solver;
                let torque = |lambda: &[f64]| -> f64 {
                    solver.lambda.copy_from_slice(lambda);
                    body_index(jt.j.body).map_or(0.0, |b| solver.reaction(driver_row..driver_row + 1, b).1.dot(&axis))
                };
                let (total, free) = linear_in_loads(multipliers, own_load, torque, |c, torque| gains[c] = torque);
                put(next, &[total]);
                put(next + 1, &[free]);
                put(next + 2, &gains[..g]);
                next += 3;
            }
            SpatialProbe::BodyRates { body, .. } => {
                let b = *body;
                put(next, &v[6 * b + 3..6 * b + 6]);
                put(next + 1, &own[6 * b + 3..6 * b + 6]);
                next += 2;
            }
            SpatialProbe::Body { body, .. } => {
                put(next, &frames[*body].pose());
                put(next + 1, frames[*body].velocity.as_slice());
                next += 2;
            }
        }
    }
}

/// A point probe's outputs from value reference `next` on: the position, velocity and own
/// acceleration of `point` on body `body` (frame `f`), its free acceleration and its
/// acceleration per unit load (three rows of one gain per load, through `gains`).
fn put_point_probe(
    (f, body, point): (&crate::constraints::BodyFrame, usize, &Vec3),
    terms: &SpatialCoupledTerms,
    own: &[f64],
    gains: &mut [f64],
    put: &mut dyn FnMut(ValueReference, &[f64]),
    next: ValueReference,
) {
    let g = gains.len() / 3;
    let s = f.rotation * point;
    let w = f.angular_velocity;
    let accel = |x: &[f64], centripetal: bool| -> Vec3 {
        let linear = Vec3::new(x[6 * body], x[6 * body + 1], x[6 * body + 2]);
        let alpha = f.rotation * Vec3::new(x[6 * body + 3], x[6 * body + 4], x[6 * body + 5]);
        linear + alpha.cross(&s) + if centripetal { w.cross(&w.cross(&s)) } else { Vec3::zeros() }
    };
    for (c, column) in terms.gain.iter().enumerate() {
        let a = accel(column, false);
        for i in 0..3 {
            gains[i * g + c] = a[i];
        }
    }
    put(next, (f.position + s).as_slice());
    put(next + 1, (f.velocity + w.cross(&s)).as_slice());
    put(next + 2, accel(own, true).as_slice());
    put(next + 3, accel(&terms.free_accelerations, true).as_slice());
    put(next + 4, gains);
}

impl Subsystem for SpatialMechanismSubsystem {
    lash_core::subsystem_calls_of_ports!();

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.ports.phase.require("initialize", &[Phase::Configured])?;
        let t = self.ports.time.seconds();
        let mech = &self.ideal.mechanism;
        self.y = mech.initial_state();
        let nq = mech.coordinate_count();
        let (q, v) = self.y.split_at_mut(nq);
        let r = assemble(mech, t, q, 1e-13).and_then(|_| velocity_analysis(mech, t, q, v));
        if let Err(e) = r {
            return Err(self.ports.fail(format!("initial conditions: {e}")));
        }
        if let Err(m) = self.refresh() {
            return Err(self.ports.fail(m));
        }
        self.ports.phase = Phase::Stepping;
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.ports.check_step(t, h)?;
        let (t0, t1) = (t.seconds(), Ticks(t.0 + h.0).seconds());
        if self.coupling == Coupling::TwoWay {
            self.prescribe(t0, t1 - t0);
        }
        let method =
            Method::Dopri5(AdaptiveOptions { max_step: self.integrator.max_step.min(t1 - t0), ..self.integrator });
        let mut y = self.y.clone();
        // Each step goes on with the step size the last one proposed (no ramp-up from the initial
        // step at every communication point).
        let first = (self.integration_stats.next_step > 0.0).then_some(self.integration_stats.next_step);
        let result = lash_ode::integrate_from(
            &method,
            &mut self.ideal,
            t0,
            &mut y,
            t1,
            t1 - t0,
            &mut |_: &mut SpatialSystem, _: f64, _: &[f64]| Ok(()),
            first,
        );
        let result = match result {
            Ok(stats) => {
                self.y = y;
                self.integration_stats.add(&stats);
                self.integration_stats.next_step = stats.next_step;
                Ok(())
            }
            Err(e) => Err(format!("macro integration: {}", lash_core::error_chain(&e))),
        };
        self.ports.step_ended(t, h, self.coupling);
        if let Err(m) = result.and_then(|_| self.refresh()) {
            return Err(self.ports.fail(m));
        }
        Ok(StepOutcome::Completed)
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new(Snapshot {
            y: self.y.clone(),
            ports: self.ports.saved(),
            prescribed: self.ideal.prescribed().cloned(),
            next_step: self.integration_stats.next_step,
        })))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let s = state
            .0
            .downcast_ref::<Snapshot>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not a spatial mechanism subsystem's".into()))?;
        self.y.clone_from(&s.y);
        self.ports.restore(&s.ports);
        self.ideal.prescribe(s.prescribed.clone());
        self.integration_stats.next_step = s.next_step;
        Ok(())
    }
}

/// What [`SpatialMechanismSubsystem::save_state`] keeps: the state, the outputs, the two-way
/// targets and the prescription in force, the integrator's next step.
struct Snapshot {
    y: Vec<f64>,
    ports: lash_core::SavedPorts,
    prescribed: Option<lash_core::PrescribedInterface>,
    next_step: f64,
}
