//! The macro subsystem of the reduced interface model: the mechanism around one clearance joint,
//! as a [`Subsystem`].
//!
//! * **One-way coupling** (the reduced-interface-model papers' method): the ideal mechanism (clearance joint closed) is the
//!   motion. Fully driven mechanisms take the exact kinematic analysis at each communication point;
//!   mechanisms with degrees of freedom are integrated (DOPRI5, tight tolerances, no events needed).
//! * **Two-way coupling**: the mechanism is integrated with the clearance joint replaced by a
//!   *prescribed-eccentricity* joint, r_J − r_B = e(t), where e(t) is the cubic Hermite between the
//!   eccentricity and its rate at the step start and the inputs `eccentricity`, `eccentricity_rate`
//!   (the micro subsystem's values at the step end). The joint's reaction is then the contact force
//!   the micro subsystem computed (M̃ ë = f̃ + f_c), so the clearance changes the motion (a
//!   torque-driven crank slows down) without the interface drifting (docs/theory.md explains why
//!   feeding an averaged force to the cut mechanism drifts).
//!
//! At each communication point the subsystem exports the cut system's effective terms (M̃, f̃, W,
//! a_free) at the current state, the bodies' angular velocities and accelerations, and for every
//! probe its propagation map: a value linear in f_c is exported as `…_free` (f_c = 0) and `…_gain`
//! (per unit f_c along x and y), so a master computes `free + gain · f_c` at any rate without a
//! solve. Positions and velocities of probe points are exported with their time derivatives for
//! Hermite interpolation. One KKT factorisation per communication point serves all of it.

use crate::Vec2;
use crate::interface::{EffectiveTerms, Interface, effective_terms};
use crate::kinematics::{assemble, driver_torque, initial_guess, joint_reaction, point_kinematics, velocity_analysis};
use crate::model::{BodyId, Mechanism};
use crate::solver::Solver;
use lash_core::subsystem::{Causality, Phase, Variability, VariableTable, element_count};
use lash_core::{Coupling, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use lash_ode::{Dopri5Options, Method, OdeSystem};

/// A quantity of the mechanism exported with its propagation map.
#[derive(Debug, Clone, PartialEq)]
pub enum Probe {
    /// A body point: `name.position`, `name.velocity` (with derivatives), `name.acceleration…`.
    Point {
        /// Prefix of the variable names.
        name: String,
        /// Body.
        body: BodyId,
        /// Point (local, from the centroid) [m].
        point: Vec2,
    },
    /// Reaction of ideal joint `joint` of the cut mechanism on its first body: `name.reaction…`.
    JointReaction {
        /// Prefix of the variable names.
        name: String,
        /// Joint index in the cut mechanism.
        joint: usize,
    },
    /// Torque of driver `driver`: `name.torque…`.
    DriverTorque {
        /// Prefix of the variable names.
        name: String,
        /// Driver index.
        driver: usize,
    },
}

/// The eccentricity prescribed across a step: cubic Hermite from (e, ė) at `start` to (e, ė) at
/// `start + span`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PrescribedEccentricity {
    start: f64,
    span: f64,
    from: [Vec2; 2],
    to: [Vec2; 2],
}

impl PrescribedEccentricity {
    /// e, ė, ë at `t`.
    fn at(&self, t: f64) -> [Vec2; 3] {
        let h = self.span;
        let s = ((t - self.start) / h).clamp(0.0, 1.0);
        let (s2, s3) = (s * s, s * s * s);
        let [ea, va] = self.from;
        let [eb, vb] = self.to;
        let e = ea * (2.0 * s3 - 3.0 * s2 + 1.0)
            + va * (h * (s3 - 2.0 * s2 + s))
            + eb * (-2.0 * s3 + 3.0 * s2)
            + vb * (h * (s3 - s2));
        let v = (ea * (6.0 * s2 - 6.0 * s)
            + va * (h * (3.0 * s2 - 4.0 * s + 1.0))
            + eb * (-6.0 * s2 + 6.0 * s)
            + vb * (h * (3.0 * s2 - 2.0 * s)))
            / h;
        let a =
            (ea * (12.0 * s - 6.0) + va * (h * (6.0 * s - 4.0)) + eb * (-12.0 * s + 6.0) + vb * (h * (6.0 * s - 2.0)))
                / (h * h);
        [e, v, a]
    }
}

/// Shifts the two rows of the closed clearance joint so that r_J − r_B = e(t).
fn apply_offset(solver: &mut Solver, row: usize, [e, v, a]: [Vec2; 3]) {
    solver.phi[row] -= e.x;
    solver.phi[row + 1] -= e.y;
    solver.nu[row] += v.x;
    solver.nu[row + 1] += v.y;
    solver.gamma[row] += a.x;
    solver.gamma[row + 1] += a.y;
}

/// The mechanism ODE integrated by a dynamic macro subsystem: the ideal mechanism, its clearance
/// joint optionally moved by a prescribed eccentricity.
struct MechanismOde<'a> {
    mech: &'a Mechanism,
    solver: &'a mut Solver,
    offset: Option<(usize, PrescribedEccentricity)>,
    error: Option<String>,
}

impl OdeSystem for MechanismOde<'_> {
    fn dim(&self) -> usize {
        2 * self.mech.coordinate_count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let n = y.len() / 2;
        let (q, qd) = y.split_at(n);
        let offset = self.offset;
        let r = self.solver.accelerations(self.mech, t, q, qd, |s| {
            if let Some((row, e)) = offset {
                apply_offset(s, row, e.at(t));
            }
        });
        match r {
            Ok(()) => {
                dydt[..n].copy_from_slice(qd);
                dydt[n..].copy_from_slice(&self.solver.accelerations);
            }
            Err(e) => {
                self.error.get_or_insert(e.to_string());
                dydt.fill(f64::NAN);
            }
        }
    }

    fn accept_step(&mut self, _t: f64, _y: &[f64]) -> Result<(), String> {
        self.error.take().map_or(Ok(()), Err)
    }
}

/// Fixed value references of the mechanism subsystem (probe variables follow in probe order).
pub mod vr {
    use lash_core::ValueReference;
    /// Output M̃ (2×2) [kg].
    pub const EFFECTIVE_MASS: ValueReference = 0;
    /// Output f̃ (2) [N].
    pub const EFFECTIVE_FORCE: ValueReference = 1;
    /// Output W = M̃⁻¹ (2×2) [1/kg].
    pub const MOBILITY: ValueReference = 2;
    /// Output a_free (2) [m/s²].
    pub const FREE_ACCELERATION: ValueReference = 3;
    /// Output ω of the journal body.
    pub const JOURNAL_ANGULAR_VELOCITY: ValueReference = 4;
    /// Output α of the journal body.
    pub const JOURNAL_ANGULAR_ACCELERATION: ValueReference = 5;
    /// Output ω of the bearing body.
    pub const BEARING_ANGULAR_VELOCITY: ValueReference = 6;
    /// Output α of the bearing body.
    pub const BEARING_ANGULAR_ACCELERATION: ValueReference = 7;
    /// Output max |Φ| of the macro's own constraints.
    pub const CONSTRAINT_ERROR: ValueReference = 8;
    /// Input (two-way coupling): eccentricity at the end of the next step (2) [m].
    pub const ECCENTRICITY: ValueReference = 9;
    /// Input (two-way coupling): its rate (2) [m/s].
    pub const ECCENTRICITY_RATE: ValueReference = 10;
}

/// The mechanism around one clearance joint as the macro [`Subsystem`].
pub struct MechanismSubsystem {
    name: String,
    variables: Vec<Variable>,
    offsets: Vec<usize>,
    values: Vec<f64>,
    cut: Mechanism,
    ideal: Mechanism,
    interface: Interface,
    probes: Vec<Probe>,
    coupling: Coupling,
    kinematic: bool,
    integrator: Dopri5Options,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    time: Ticks,
    phase: Phase,
    /// (e, ė) at the current time and the targets at the end of the next step (two-way).
    eccentricity: [Vec2; 2],
    eccentricity_target: [Vec2; 2],
    offset_row: usize,
    last_offset: Option<PrescribedEccentricity>,
    ideal_solver: Solver,
    cut_solver: Solver,
    /// The effective terms at the current communication point.
    pub terms: Option<EffectiveTerms>,
    /// Steps and right-hand-side evaluations of the dynamic integration.
    pub integration_stats: lash_ode::Stats,
}

impl MechanismSubsystem {
    /// A macro subsystem for the cut mechanism `cut` (clearance joint removed) and the ideal
    /// mechanism `ideal` (joint closed), with the given probes.
    pub fn new(
        name: &str,
        cut: Mechanism,
        ideal: Mechanism,
        interface: Interface,
        probes: Vec<Probe>,
        coupling: Coupling,
    ) -> Self {
        use Causality::{Input, Output};
        use Variability::Continuous as C;
        let mut t = VariableTable::new();
        t.add("effective_mass", Output, C, "kg", "effective mass M~ of the interface", &[2, 2], &[0.0]);
        t.add("effective_force", Output, C, "N", "effective force f~ (M~ w'' = f~ + f_c)", &[2], &[0.0]);
        t.add("mobility", Output, C, "1/kg", "W = inverse of M~", &[2, 2], &[0.0]);
        t.add("free_acceleration", Output, C, "m/s^2", "interface acceleration with f_c = 0", &[2], &[0.0]);
        t.add("journal_angular_velocity", Output, C, "rad/s", "angular velocity of the journal body", &[], &[0.0]);
        t.add("journal_angular_acceleration", Output, C, "rad/s^2", "its rate", &[], &[0.0]);
        t.add("bearing_angular_velocity", Output, C, "rad/s", "angular velocity of the bearing body", &[], &[0.0]);
        t.add("bearing_angular_acceleration", Output, C, "rad/s^2", "its rate", &[], &[0.0]);
        t.add("constraint_error", Output, C, "m", "max |constraint violation|", &[], &[0.0]);
        t.add("eccentricity", Input, C, "m", "journal minus bearing centre at the step end (two-way)", &[2], &[0.0]);
        t.add("eccentricity_rate", Input, C, "m/s", "its rate at the step end (two-way)", &[2], &[0.0]);
        for p in &probes {
            match p {
                Probe::Point { name, .. } => {
                    t.add(format!("{name}.position"), Output, C, "m", "point position", &[2], &[0.0]);
                    t.add(format!("{name}.velocity"), Output, C, "m/s", "point velocity", &[2], &[0.0]);
                    t.add(format!("{name}.acceleration"), Output, C, "m/s^2", "macro's own", &[2], &[0.0]);
                    t.add(format!("{name}.acceleration_free"), Output, C, "m/s^2", "at f_c = 0", &[2], &[0.0]);
                    t.add(format!("{name}.acceleration_gain"), Output, C, "m/s^2/N", "per unit f_c", &[2, 2], &[0.0]);
                }
                Probe::JointReaction { name, .. } => {
                    t.add(format!("{name}.reaction"), Output, C, "N", "macro's own", &[2], &[0.0]);
                    t.add(format!("{name}.reaction_free"), Output, C, "N", "at f_c = 0", &[2], &[0.0]);
                    t.add(format!("{name}.reaction_gain"), Output, C, "1", "per unit f_c", &[2, 2], &[0.0]);
                }
                Probe::DriverTorque { name, .. } => {
                    t.add(format!("{name}.torque"), Output, C, "N.m", "macro's own", &[], &[0.0]);
                    t.add(format!("{name}.torque_free"), Output, C, "N.m", "at f_c = 0", &[], &[0.0]);
                    t.add(format!("{name}.torque_gain"), Output, C, "m", "per unit f_c", &[2], &[0.0]);
                }
            }
        }
        let variables = t.into_variables();
        let mut offsets = Vec::with_capacity(variables.len() + 1);
        let mut at = 0;
        for v in &variables {
            offsets.push(at);
            at += v.len();
        }
        offsets.push(at);
        let kinematic = coupling == Coupling::OneWay && ideal.constraint_count() == ideal.coordinate_count();
        // The closed clearance joint is the ideal mechanism's last joint.
        let offset_row = ideal.joint_row(ideal.joints.len() - 1);
        let n = cut.coordinate_count();
        Self {
            name: name.to_string(),
            variables,
            offsets,
            values: vec![0.0; at],
            ideal_solver: Solver::new(&ideal),
            cut_solver: Solver::new(&cut),
            cut,
            ideal,
            interface,
            probes,
            coupling,
            kinematic,
            integrator: Dopri5Options { rtol: 1e-10, atol: 1e-12, initial_step: 1e-5, max_step: 1e-3, min_step: 1e-12 },
            q: vec![0.0; n],
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            time: Ticks::ZERO,
            phase: Phase::Instantiated,
            eccentricity: [Vec2::zeros(); 2],
            eccentricity_target: [Vec2::zeros(); 2],
            offset_row,
            last_offset: None,
            terms: None,
            integration_stats: lash_ode::Stats::default(),
        }
    }

    /// True if the motion comes from kinematic analysis (fully driven, one-way).
    pub fn is_kinematic(&self) -> bool {
        self.kinematic
    }

    /// Coordinates and velocities of the current communication point.
    pub fn state(&self) -> (&[f64], &[f64]) {
        (&self.q, &self.qd)
    }

    /// The value of an output by value reference (elements).
    pub fn output(&self, vr: ValueReference) -> &[f64] {
        &self.values[self.offsets[vr as usize]..self.offsets[vr as usize + 1]]
    }

    /// All output values, flattened in value-reference order, and each variable's offset.
    pub fn values(&self) -> (&[f64], &[usize]) {
        (&self.values, &self.offsets)
    }

    fn simulation_error(&mut self, message: String) -> SubsystemError {
        self.phase = Phase::Failed;
        SubsystemError::Simulation { t: self.time.seconds(), message }
    }

    /// Motion at `t` of a fully driven mechanism: position and velocity analysis.
    fn kinematic_motion(&mut self, t: f64) -> Result<(), String> {
        // Second-order Taylor prediction from the last node: Newton then needs one or two
        // iterations instead of several across a 30° step.
        let h = t - self.time.seconds();
        for k in 0..self.q.len() {
            self.q[k] += h * self.qd[k] + 0.5 * h * h * self.qdd[k];
        }
        assemble(&self.ideal, t, &mut self.q, &mut self.ideal_solver, 1e-13).map_err(|e| e.to_string())?;
        velocity_analysis(&self.ideal, t, &self.q, &mut self.qd, &mut self.ideal_solver).map_err(|e| e.to_string())
    }

    /// Terms and every output at the current state.
    fn refresh(&mut self) -> Result<(), String> {
        let t = self.time.seconds();
        let terms = effective_terms(&self.cut, &mut self.cut_solver, &self.interface, t, &self.q, &self.qd)
            .map_err(|e| e.to_string())?;
        let Some(mass) = terms.effective_mass else {
            return Err(format!(
                "the interface mobility W = {:?} is singular: the cut mechanism cannot move the journal freely in \
                 both directions",
                terms.mobility
            ));
        };
        // The macro's own motion has ë = 0 (one-way) or ë of the prescribed eccentricity (two-way);
        // the interface force that produces it is M̃ (ë − a_free), which is −f̃ in one-way coupling.
        let own = match (self.coupling, self.last_offset) {
            (Coupling::TwoWay, Some(e)) => mass * (e.at(t)[2] - terms.free_acceleration),
            _ => -terms.effective_force,
        };
        terms.accelerations(own, &mut self.qdd);
        let omega = |b: BodyId, v: &[f64]| match b {
            BodyId::Body(k) => v[3 * k + 2],
            BodyId::Ground => 0.0,
        };
        let iface = self.interface;
        let mut put = |vr: ValueReference, v: &[f64]| {
            self.values[self.offsets[vr as usize]..self.offsets[vr as usize + 1]].copy_from_slice(v)
        };
        put(vr::EFFECTIVE_MASS, &[mass[(0, 0)], mass[(0, 1)], mass[(1, 0)], mass[(1, 1)]]);
        put(vr::EFFECTIVE_FORCE, terms.effective_force.as_slice());
        let w = terms.mobility;
        put(vr::MOBILITY, &[w[(0, 0)], w[(0, 1)], w[(1, 0)], w[(1, 1)]]);
        put(vr::FREE_ACCELERATION, terms.free_acceleration.as_slice());
        put(vr::JOURNAL_ANGULAR_VELOCITY, &[omega(iface.journal_body, &self.qd)]);
        put(vr::JOURNAL_ANGULAR_ACCELERATION, &[omega(iface.journal_body, &self.qdd)]);
        put(vr::BEARING_ANGULAR_VELOCITY, &[omega(iface.bearing_body, &self.qd)]);
        put(vr::BEARING_ANGULAR_ACCELERATION, &[omega(iface.bearing_body, &self.qdd)]);
        // Constraint error of the macro's own mechanism (the cut one's rows are a subset of the
        // ideal one's; the cut solver holds the current state).
        self.ideal_solver.set_state(&self.ideal, t, &self.q, &self.qd);
        if let (Coupling::TwoWay, Some(e)) = (self.coupling, self.last_offset) {
            apply_offset(&mut self.ideal_solver, self.offset_row, e.at(t));
        }
        let phi = self.ideal_solver.constraint_error();
        put(vr::CONSTRAINT_ERROR, &[phi]);
        let mut next = vr::ECCENTRICITY_RATE + 1;
        let zeros = vec![0.0; self.q.len()];
        let lambda_of = |solver: &mut Solver, lambda: &[f64]| solver.lambda.copy_from_slice(lambda);
        for p in &self.probes {
            match *p {
                Probe::Point { body, point, .. } => {
                    let own = point_kinematics(&self.q, &self.qd, &self.qdd, body, point);
                    let free = point_kinematics(&self.q, &self.qd, &terms.free_accelerations, body, point);
                    let gx = point_kinematics(&self.q, &zeros, &terms.gain[0], body, point).acceleration;
                    let gy = point_kinematics(&self.q, &zeros, &terms.gain[1], body, point).acceleration;
                    put(next, own.position.as_slice());
                    put(next + 1, own.velocity.as_slice());
                    put(next + 2, own.acceleration.as_slice());
                    put(next + 3, free.acceleration.as_slice());
                    put(next + 4, &[gx.x, gy.x, gx.y, gy.y]);
                    next += 5;
                }
                Probe::JointReaction { joint, .. } => {
                    let solver = &mut self.cut_solver;
                    let mut r = [Vec2::zeros(); 3];
                    for (k, l) in [&terms.free_lambda, &terms.lambda_gain[0], &terms.lambda_gain[1]].iter().enumerate()
                    {
                        lambda_of(solver, l);
                        r[k] = joint_reaction(&self.cut, solver, joint);
                    }
                    let own_r = r[0] + r[1] * own.x + r[2] * own.y;
                    put(next, own_r.as_slice());
                    put(next + 1, r[0].as_slice());
                    put(next + 2, &[r[1].x, r[2].x, r[1].y, r[2].y]);
                    next += 3;
                }
                Probe::DriverTorque { driver, .. } => {
                    let solver = &mut self.cut_solver;
                    let mut tq = [0.0; 3];
                    for (k, l) in [&terms.free_lambda, &terms.lambda_gain[0], &terms.lambda_gain[1]].iter().enumerate()
                    {
                        lambda_of(solver, l);
                        tq[k] = driver_torque(&self.cut, solver, driver);
                    }
                    put(next, &[tq[0] + tq[1] * own.x + tq[2] * own.y]);
                    put(next + 1, &[tq[0]]);
                    put(next + 2, &[tq[1], tq[2]]);
                    next += 3;
                }
            }
        }
        if let Some(bad) = self.values.iter().position(|v| !v.is_finite()) {
            let name = self.variables[self.offsets.partition_point(|&o| o <= bad) - 1].name.clone();
            return Err(format!("output {name} became {}", self.values[bad]));
        }
        self.terms = Some(terms);
        Ok(())
    }
}

impl Subsystem for MechanismSubsystem {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, _stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.phase.require("setup", &[Phase::Instantiated])?;
        self.time = start;
        self.phase = Phase::Configured;
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.phase.require("initialize", &[Phase::Configured])?;
        // Consistent initial conditions of the ideal mechanism (the journal centred, ideal
        // velocities): the cut mechanism starts from the same state.
        let t = self.time.seconds();
        let (q, qd) = initial_guess(&self.ideal);
        self.q = q;
        self.qd = qd;
        let r = assemble(&self.ideal, t, &mut self.q, &mut self.ideal_solver, 1e-13)
            .and_then(|_| velocity_analysis(&self.ideal, t, &self.q, &mut self.qd, &mut self.ideal_solver));
        if let Err(e) = r {
            return Err(self.simulation_error(format!("initial conditions: {e}")));
        }
        if let Err(m) = self.refresh() {
            return Err(self.simulation_error(m));
        }
        self.phase = Phase::Stepping;
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        self.phase.require("set_f64", &[Phase::Configured, Phase::Stepping])?;
        let n = element_count(&self.variables, refs)?;
        if n != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), n)));
        }
        let mut at = 0;
        for &r in refs {
            let var = &self.variables[r as usize];
            if r != vr::ECCENTRICITY && r != vr::ECCENTRICITY_RATE {
                return Err(SubsystemError::BadValue { name: var.name.clone(), problem: "is not an input".into() });
            }
            let v = &values[at..at + 2];
            at += 2;
            if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
                return Err(SubsystemError::BadValue {
                    name: var.name.clone(),
                    problem: format!("{bad} is not finite"),
                });
            }
            self.eccentricity_target[(r - vr::ECCENTRICITY) as usize] = Vec2::new(v[0], v[1]);
        }
        Ok(())
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let n = element_count(&self.variables, refs)?;
        if n != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), n)));
        }
        let mut at = 0;
        for &r in refs {
            let target;
            let v = if r == vr::ECCENTRICITY || r == vr::ECCENTRICITY_RATE {
                let e = self.eccentricity_target[(r - vr::ECCENTRICITY) as usize];
                target = [e.x, e.y];
                &target[..]
            } else {
                self.output(r)
            };
            values[at..at + v.len()].copy_from_slice(v);
            at += v.len();
        }
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.phase.require("do_step", &[Phase::Stepping])?;
        if t != self.time || h.0 <= 0 {
            return Err(SubsystemError::BadArguments(format!(
                "do_step(t = {} s, h = {} s) but the subsystem is at {} s",
                t.seconds(),
                h.seconds(),
                self.time.seconds()
            )));
        }
        let (t0, t1) = (t.seconds(), Ticks(t.0 + h.0).seconds());
        let result = if self.kinematic {
            self.kinematic_motion(t1)
        } else {
            let prescribed = PrescribedEccentricity {
                start: t0,
                span: t1 - t0,
                from: self.eccentricity,
                to: self.eccentricity_target,
            };
            let offset = (self.coupling == Coupling::TwoWay).then_some((self.offset_row, prescribed));
            self.last_offset = offset.map(|o| o.1);
            let mut ode = MechanismOde { mech: &self.ideal, solver: &mut self.ideal_solver, offset, error: None };
            let mut y: Vec<f64> = self.q.iter().chain(&self.qd).copied().collect();
            let method =
                Method::Dopri5(Dopri5Options { max_step: self.integrator.max_step.min(t1 - t0), ..self.integrator });
            match lash_ode::integrate(
                &method,
                &mut ode,
                t0,
                &mut y,
                t1,
                t1 - t0,
                &mut |_: &mut MechanismOde<'_>, _: f64, _: &[f64]| Ok(()),
            ) {
                Ok(stats) => {
                    let n = self.q.len();
                    self.q.copy_from_slice(&y[..n]);
                    self.qd.copy_from_slice(&y[n..]);
                    self.integration_stats.steps += stats.steps;
                    self.integration_stats.rejected += stats.rejected;
                    self.integration_stats.rhs_evaluations += stats.rhs_evaluations;
                    Ok(())
                }
                Err(e) => Err(format!("macro integration: {e}")),
            }
        };
        self.time = Ticks(t.0 + h.0);
        if self.coupling == Coupling::TwoWay {
            self.eccentricity = self.eccentricity_target;
        }
        if let Err(m) = result.and_then(|_| self.refresh()) {
            return Err(self.simulation_error(m));
        }
        Ok(StepOutcome::Completed)
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new((
            self.q.clone(),
            self.qd.clone(),
            self.time,
            self.phase,
            [self.eccentricity, self.eccentricity_target],
            self.last_offset,
            self.values.clone(),
        ))))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        type Snapshot = (Vec<f64>, Vec<f64>, Ticks, Phase, [[Vec2; 2]; 2], Option<PrescribedEccentricity>, Vec<f64>);
        let (q, qd, time, phase, [e, target], last, values) = state
            .0
            .downcast_ref::<Snapshot>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not a mechanism subsystem's".into()))?;
        self.q.clone_from(q);
        self.qd.clone_from(qd);
        self.time = *time;
        self.phase = *phase;
        self.eccentricity = *e;
        self.eccentricity_target = *target;
        self.last_offset = *last;
        self.values.clone_from(values);
        if self.phase == Phase::Stepping {
            self.refresh().map_err(|m| SubsystemError::Simulation { t: time.seconds(), message: m })?;
        }
        Ok(())
    }
}
