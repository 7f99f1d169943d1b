//! The macro subsystem of the reduced interface model: the mechanism around its k clearance joints
//! (all coupled: n = 2k interface coordinates), as a [`Subsystem`].
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

use crate::interface::{ClearanceInterface, CoupledTerms, coupled_effective_terms_into};
use crate::kinematics::{assemble_and_project, driver_torque, initial_guess, joint_reaction, point_kinematics_at};
use crate::model::{BodyId, Mechanism};
use crate::solver::Solver;
use crate::{Pose, Vec2};
use lash_core::subsystem::{Causality, Phase, Variability, VariableTable, per_joint_shape};
use lash_core::{
    Coupling, MacroPorts, PrescribedInterface as Prescribed, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks,
    TwoWayInputs, ValueReference, Variable,
};
use lash_ode::{AdaptiveOptions, Method, OdeSystem};

/// A quantity of the mechanism exported with its propagation map.
#[derive(Debug, Clone, PartialEq)]
pub enum Probe {
    /// A body point: `name.position`, `name.velocity` (with derivatives), `name.acceleration…`.
    Point {
        /// Prefix of the variable names.
        name: String,
        /// Body.
        body: BodyId,
        /// Point (local, from the centroid) \[m\].
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
    /// A body's pose: `name.pose` (centroid x, y and angle) and its rate `name.pose_rate`. Not
    /// propagated: the ideal mechanism's pose is the reduced model's (the clearance's play is
    /// the micro side's eccentricity).
    Body {
        /// Prefix of the variable names.
        name: String,
        /// Body.
        body: BodyId,
    },
}

/// e, ė, ë of joint `j`'s eccentricity at `t`.
fn joint_at(p: &Prescribed, t: f64, j: usize) -> [Vec2; 3] {
    let (x, y) = (p.at(t, 2 * j), p.at(t, 2 * j + 1));
    [Vec2::new(x[0], y[0]), Vec2::new(x[1], y[1]), Vec2::new(x[2], y[2])]
}

/// Shifts the rows of the closed clearance joints so that r_J − r_B = e(t) as `p` prescribes and
/// adds the friction moments to the generalized forces (two-way coupling).
fn apply_prescribed(p: &Prescribed, solver: &mut Solver, rows: &[usize], joints: &[ClearanceInterface], t: f64) {
    for (j, &row) in rows.iter().enumerate() {
        let [e, v, a] = joint_at(p, t, j);
        solver.phi[row] -= e.x;
        solver.phi[row + 1] -= e.y;
        solver.nu[row] += v.x;
        solver.nu[row + 1] += v.y;
        solver.gamma[row] += a.x;
        solver.gamma[row + 1] += a.y;
    }
    for (joint, &f) in joints.iter().zip(&p.friction) {
        joint.add_friction_load(&solver.poses, f, &mut solver.forces);
    }
}

/// The mechanism ODE integrated by a dynamic macro subsystem: the ideal mechanism, its clearance
/// joints optionally moved by prescribed eccentricities.
struct MechanismOde<'a> {
    mech: &'a Mechanism,
    solver: &'a mut Solver,
    prescribed: Option<(&'a Prescribed, &'a [usize], &'a [ClearanceInterface])>,
    error: Option<String>,
}

impl OdeSystem for MechanismOde<'_> {
    fn dim(&self) -> usize {
        2 * self.mech.coordinate_count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let n = y.len() / 2;
        let (q, qd) = y.split_at(n);
        let prescribed = self.prescribed;
        let r = self.solver.accelerations(self.mech, t, q, qd, |s| {
            if let Some((p, rows, joints)) = prescribed {
                apply_prescribed(p, s, rows, joints, t);
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

    fn accept_step(&mut self, _t: f64, _y: &[f64]) -> Result<(), lash_ode::BoxError> {
        self.error.take().map_or(Ok(()), |message| Err(message.into()))
    }
}

/// Fixed value references of the mechanism subsystem (probe variables follow in probe order).
/// n = 2k interface coordinates for k clearance joints; per-joint quantities have k elements
/// (scalars when k = 1).
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
        /// Output H = M̃ W_T (n × k): interface force equivalent to each joint's friction moments.
        FRICTION_MOMENT_FORCE,
        /// Output ω of each journal body (k).
        JOURNAL_ANGULAR_VELOCITY,
        /// Output α of each journal body (k).
        JOURNAL_ANGULAR_ACCELERATION,
        /// Output ω of each bearing body (k).
        BEARING_ANGULAR_VELOCITY,
        /// Output α of each bearing body (k).
        BEARING_ANGULAR_ACCELERATION,
        /// Output max |Φ| of the macro's own constraints.
        CONSTRAINT_ERROR,
        /// Input (two-way coupling): eccentricities at the end of the next step (n) \[m\].
        ECCENTRICITY,
        /// Input (two-way coupling): their rates (n) [m/s].
        ECCENTRICITY_RATE,
        /// Input (two-way coupling): each joint's mean friction force over the next step (k) \[N\].
        FRICTION_FORCE,
    }
}

/// A probe's quantity that is linear in the cut mechanism's multipliers λ (a joint's reaction, a
/// driver's torque), `at(λ)`: its value at no interface load (λ = `free_lambda`), its gain per
/// unit load (λ = each column of `lambda_gain`, handed to `gain` with its index), and its value
/// at the macro's own loads `own`, free + Σ gain·own. Returns (own value, free value).
pub fn linear_in_loads<V>(
    (free_lambda, lambda_gain): (&[f64], &[Vec<f64>]),
    own: &[f64],
    mut at: impl FnMut(&[f64]) -> V,
    mut gain: impl FnMut(usize, V),
) -> (V, V)
where
    V: Copy + std::ops::AddAssign + std::ops::Mul<f64, Output = V>,
{
    let free = at(free_lambda);
    let mut total = free;
    for (c, column) in lambda_gain.iter().enumerate() {
        let r = at(column);
        gain(c, r);
        total += r * own[c];
    }
    (total, free)
}

/// Adds a probe's quantity that the interface loads move, as three outputs: `name.quantity`
/// (the macro's own value), `name.quantity_free` (at no interface load) and
/// `name.quantity_gain` (per unit load: the `loads` columns are the contact forces, then the
/// friction loads — `gain_description` says which). `unit` is the quantity's, `gain_unit` its
/// gain's; `shape` the quantity's (the gain's adds the loads' axis). The planar and the spatial
/// macro subsystems declare their probes here.
pub fn add_propagated(
    t: &mut VariableTable,
    (name, quantity): (&str, &str),
    (unit, gain_unit): (&str, &str),
    shape: &[usize],
    (loads, gain_description): (usize, &str),
) {
    use Causality::Output;
    use Variability::Continuous as C;
    let gain_shape: Vec<usize> = shape.iter().copied().chain([loads]).collect();
    t.add(format!("{name}.{quantity}"), Output, C, unit, "macro's own", shape, &[0.0]);
    t.add(format!("{name}.{quantity}_free"), Output, C, unit, "at no interface load", shape, &[0.0]);
    t.add(format!("{name}.{quantity}_gain"), Output, C, gain_unit, gain_description, &gain_shape, &[0.0]);
}

/// Adds, at the value references `at` (journal ω, journal α, bearing ω, bearing α), the angular
/// velocities and accelerations of each clearance joint's journal and bearing bodies: the macro
/// subsystem's outputs and the micro subsystem's inputs, declared in one place.
pub fn add_body_rates(t: &mut VariableTable, at: [ValueReference; 4], causality: Causality, shape: &[usize]) {
    use Variability::Continuous as C;
    t.add_at(
        at[0],
        "journal_angular_velocity",
        causality,
        C,
        "rad/s",
        "angular velocity of the journal body",
        shape,
        &[0.0],
    );
    t.add_at(at[1], "journal_angular_acceleration", causality, C, "rad/s^2", "its rate", shape, &[0.0]);
    t.add_at(
        at[2],
        "bearing_angular_velocity",
        causality,
        C,
        "rad/s",
        "angular velocity of the bearing body",
        shape,
        &[0.0],
    );
    t.add_at(at[3], "bearing_angular_acceleration", causality, C, "rad/s^2", "its rate", shape, &[0.0]);
}

/// The planar macro subsystem's variables for `k` clearance joints and `probes`: the interface
/// terms, the bodies' rates and the constraint error (outputs), the two-way inputs, then each
/// probe's outputs.
fn mechanism_variables(k: usize, probes: &[Probe]) -> Vec<Variable> {
    use Causality::{Input, Output};
    use Variability::Continuous as C;
    let n = 2 * k;
    let g = n + k;
    let pj = per_joint_shape(k, &[]);
    let mut t = VariableTable::new();
    let friction_description =
        "force on the journals equivalent to each joint's friction moments, per unit friction force (M~ W_T)";
    let terms: [(ValueReference, &str, &str, &str, Vec<usize>); 5] = [
        (vr::EFFECTIVE_MASS, "effective_mass", "kg", "effective mass M~ of the interface", vec![n, n]),
        (vr::EFFECTIVE_FORCE, "effective_force", "N", "effective force f~ (M~ w'' = f~ + f_c + H F_T)", vec![n]),
        (vr::MOBILITY, "mobility", "1/kg", "W = inverse of M~", vec![n, n]),
        (vr::FREE_ACCELERATION, "free_acceleration", "m/s^2", "interface acceleration with f_c = 0", vec![n]),
        (vr::FRICTION_MOMENT_FORCE, "friction_moment_force", "1", friction_description, per_joint_shape(k, &[n])),
    ];
    for (at, name, unit, description, shape) in terms {
        t.add_at(at, name, Output, C, unit, description, &shape, &[0.0]);
    }
    add_body_rates(
        &mut t,
        [
            vr::JOURNAL_ANGULAR_VELOCITY,
            vr::JOURNAL_ANGULAR_ACCELERATION,
            vr::BEARING_ANGULAR_VELOCITY,
            vr::BEARING_ANGULAR_ACCELERATION,
        ],
        Output,
        &pj,
    );
    t.add_at(vr::CONSTRAINT_ERROR, "constraint_error", Output, C, "m", "max |constraint violation|", &[], &[0.0]);
    let two_way: [(ValueReference, &str, &str, &str, &[usize]); 3] = [
        (vr::ECCENTRICITY, "eccentricity", "m", "journal minus bearing centres at the step end (two-way)", &[n]),
        (vr::ECCENTRICITY_RATE, "eccentricity_rate", "m/s", "their rates at the step end (two-way)", &[n]),
        (vr::FRICTION_FORCE, "friction_force", "N", "mean friction force over the next step (two-way)", &pj),
    ];
    for (at, name, unit, description, shape) in two_way {
        t.add_at(at, name, Input, C, unit, description, shape, &[0.0]);
    }
    // Gains per unit load: the contact forces (n), then the friction forces (k).
    let gains = (g, "per unit contact force (f_c), then per unit friction force (F_T)");
    for p in probes {
        match p {
            Probe::Point { name, .. } => {
                t.add(format!("{name}.position"), Output, C, "m", "point position", &[2], &[0.0]);
                t.add(format!("{name}.velocity"), Output, C, "m/s", "point velocity", &[2], &[0.0]);
                add_propagated(&mut t, (name, "acceleration"), ("m/s^2", "m/s^2/N"), &[2], gains);
            }
            Probe::JointReaction { name, .. } => add_propagated(&mut t, (name, "reaction"), ("N", "1"), &[2], gains),
            Probe::Body { name, .. } => {
                t.add(format!("{name}.pose"), Output, C, "m, m, rad", "centroid x, y and angle", &[3], &[0.0]);
                t.add(format!("{name}.pose_rate"), Output, C, "m/s, m/s, rad/s", "their rates", &[3], &[0.0]);
            }
            Probe::DriverTorque { name, .. } => add_propagated(&mut t, (name, "torque"), ("N.m", "m"), &[], gains),
        }
    }
    // The fixed variables are added in the order of `vr` (checked; every construction in the
    // tests would fail on a misplaced one).
    t.into_checked_variables().expect("the mechanism subsystem's variables follow `vr`")
}

/// Work vectors of [`MechanismSubsystem`]'s refresh at each communication point.
#[derive(Default)]
struct RefreshWork {
    /// H = M̃ W_T.
    friction_moment_force: nalgebra::DMatrix<f64>,
    /// The interface loads of the macro's own motion [f; F_T].
    own: Vec<f64>,
    /// One probe's gains.
    gains: Vec<f64>,
}

/// The mechanism around its clearance joints as the macro [`Subsystem`].
pub struct MechanismSubsystem {
    /// Name, variables and values, clock, phase and two-way inputs.
    ports: MacroPorts,
    cut: Mechanism,
    ideal: Mechanism,
    joints: Vec<ClearanceInterface>,
    probes: Vec<Probe>,
    coupling: Coupling,
    kinematic: bool,
    integrator: AdaptiveOptions,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    offset_rows: Vec<usize>,
    last_prescribed: Option<Prescribed>,
    ideal_solver: Solver,
    cut_solver: Solver,
    /// The cut mechanism's S is the leading block of the ideal one's
    /// ([`Solver::is_leading_block_of`]): at a position where the ideal solver has just factored
    /// (the velocity projection of a kinematic step), the cut solver takes its factor from it.
    cut_factor_shared: bool,
    /// The effective terms at the current communication point.
    pub terms: Option<CoupledTerms>,
    /// Work storage of `refresh` (kept: a communication point allocates nothing).
    work: RefreshWork,
    /// Steps and right-hand-side evaluations of the dynamic integration.
    pub integration_stats: lash_ode::Stats,
    /// A kinematic step's motion analysed ahead, in lanes with other subsystems'
    /// ([`kinematic_steps_ahead`]), with the coordinates and velocities in `ahead_q`,
    /// `ahead_qd`; the next `do_step` over that step takes it instead of analysing.
    ahead: Option<Ahead>,
    ahead_q: Vec<f64>,
    ahead_qd: Vec<f64>,
    /// The ideal mechanism's structure ([`crate::lanes::signature`]), and the cut one's for its
    /// terms ([`crate::lanes::terms_signature`]): who goes in lanes with whom.
    signature: Vec<u64>,
    terms_signature: Option<Vec<u64>>,
}

impl MechanismSubsystem {
    /// A macro subsystem for the cut mechanism `cut` (every clearance joint removed) and the ideal
    /// mechanism `ideal` (the joints closed: its last `joints.len()` joints, in the same order),
    /// with the given probes.
    pub fn new(
        name: &str,
        cut: Mechanism,
        ideal: Mechanism,
        joints: Vec<ClearanceInterface>,
        probes: Vec<Probe>,
        coupling: Coupling,
    ) -> Self {
        let (k, n) = (joints.len(), 2 * joints.len());
        let variables = mechanism_variables(k, &probes);
        let kinematic = coupling == Coupling::OneWay && ideal.constraint_count() == ideal.coordinate_count();
        // The closed clearance joints are the ideal mechanism's last joints.
        let first = ideal.joints.len() - k;
        let offset_rows = (0..k).map(|j| ideal.joint_row(first + j)).collect();
        let coordinates = cut.coordinate_count();
        let (ideal_solver, cut_solver) = (Solver::new(&ideal), Solver::new(&cut));
        let cut_factor_shared = cut_solver.is_leading_block_of(&cut, &ideal_solver, &ideal);
        let signature = crate::lanes::signature(&ideal, &ideal_solver);
        let terms_signature = crate::lanes::terms_signature(&cut, &cut_solver, &joints, cut_factor_shared);
        Self {
            signature,
            terms_signature,
            ports: MacroPorts::new(name, variables, TwoWayInputs::new(vr::ECCENTRICITY, n, k)),
            ideal_solver,
            cut_solver,
            cut_factor_shared,
            cut,
            ideal,
            joints,
            probes,
            coupling,
            kinematic,
            // Far below the coupling's own error (the interface terms are interpolated across a
            // 1 ms step): a pin that stays in contact reads the same to five digits as at rtol
            // 1e-10, at half the macro's time; the spatial macro uses 1e-6 (docs/theory.md §8).
            integrator: AdaptiveOptions {
                rtol: 1e-8,
                atol: 1e-10,
                initial_step: 1e-5,
                max_step: 1e-3,
                min_step: 1e-12,
            },
            q: vec![0.0; coordinates],
            qd: vec![0.0; coordinates],
            qdd: vec![0.0; coordinates],
            offset_rows,
            last_prescribed: None,
            terms: None,
            work: RefreshWork::default(),
            integration_stats: lash_ode::Stats::default(),
            ahead: None,
            ahead_q: vec![0.0; coordinates],
            ahead_qd: vec![0.0; coordinates],
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
        self.ports.output(vr)
    }

    /// All output values, flattened in value-reference order, and each variable's offset.
    pub fn values(&self) -> (&[f64], &[usize]) {
        (&self.ports.values, self.ports.offsets())
    }

    /// Motion at `t` of a fully driven mechanism: position and velocity analysis. Returns the
    /// assembled position's constraint error (max |Φ|).
    fn kinematic_motion(&mut self, t: f64) -> Result<f64, String> {
        predict(&mut self.q, &self.qd, &self.qdd, t - self.ports.time.seconds());
        assemble_and_project(&self.ideal, t, &mut self.q, &mut self.qd, &mut self.ideal_solver, ASSEMBLY_TOLERANCE)
            .map_err(|e| e.to_string())?;
        Ok(self.ideal_solver.constraint_error())
    }

    /// Terms and every output at the current state; `assembled_error`: the constraint error of a
    /// position analysis just done at this state (else it is evaluated); `solved`: the terms'
    /// solves were done at this state ahead ([`kinematic_steps_ahead`]), the cut solver holds it.
    fn refresh(&mut self, assembled_error: Option<f64>, solved: bool) -> Result<(), String> {
        let t = self.ports.time.seconds();
        let (k, n) = (self.joints.len(), 2 * self.joints.len());
        let terms = self.solve_terms(solved)?;
        let Some(mass) = terms.effective_mass.as_ref() else {
            return Err(format!(
                "the interface mobility W = {} is singular: the cut mechanism cannot move the journals freely in \
                 every direction",
                terms.mobility
            ));
        };
        let work = &mut self.work;
        // The macro's own motion has ẅ = 0 (one-way) or ẅ of the prescribed eccentricities
        // (two-way, with the friction forces F̄_T); the interface force that produces it is
        // M̃ (ẅ − a_free) − H F̄_T, which is −f̃ in one-way coupling.
        if work.friction_moment_force.shape() != (n, k) {
            work.friction_moment_force = nalgebra::DMatrix::zeros(n, k);
        }
        mass.mul_to(&terms.friction_mobility, &mut work.friction_moment_force);
        let friction_moment_force = &work.friction_moment_force;
        work.own.clear();
        work.own.resize(n + k, 0.0);
        let own = &mut work.own;
        let two_way = match (self.coupling, &self.last_prescribed) {
            (Coupling::TwoWay, Some(p)) => {
                let mut wdd = nalgebra::DVector::zeros(n);
                for j in 0..k {
                    let a = joint_at(p, t, j)[2];
                    wdd[2 * j] = a.x;
                    wdd[2 * j + 1] = a.y;
                }
                Some((wdd, &p.friction[..]))
            }
            _ => None,
        };
        crate::own_interface_load(
            own,
            &terms.effective_force,
            two_way,
            (mass, &terms.free_acceleration, friction_moment_force),
        );
        terms.accelerations(&own[..n], &own[n..], &mut self.qdd);
        let (values, offsets) = self.ports.values_and_offsets();
        let range = |vr: ValueReference| offsets[vr as usize]..offsets[vr as usize + 1];
        // Matrices go out row-major.
        let mut put_matrix = |vr: ValueReference, m: &nalgebra::DMatrix<f64>| {
            lash_core::subsystem::row_major(&mut values[range(vr)], m.as_slice(), m.nrows())
        };
        put_matrix(vr::EFFECTIVE_MASS, mass);
        put_matrix(vr::MOBILITY, &terms.mobility);
        put_matrix(vr::FRICTION_MOMENT_FORCE, friction_moment_force);
        let mut put = |vr: ValueReference, v: &[f64]| values[range(vr)].copy_from_slice(v);
        put(vr::EFFECTIVE_FORCE, terms.effective_force.as_slice());
        put(vr::FREE_ACCELERATION, terms.free_acceleration.as_slice());
        write_rotation_rates((&mut *values, offsets), &self.joints, &self.cut_solver.poses, &self.qd, &self.qdd);
        let mut put = |vr: ValueReference, v: &[f64]| values[range(vr)].copy_from_slice(v);
        // Constraint error of the macro's own mechanism (the cut one's rows are a subset of the
        // ideal one's; the cut solver holds the current state).
        // (After a position analysis its last residual check holds it: Φ depends on q and t only.)
        let phi = match assembled_error {
            Some(phi) => phi,
            None => {
                self.ideal_solver.set_state(&self.ideal, t, &self.q, &self.qd);
                if let (Coupling::TwoWay, Some(p)) = (self.coupling, &self.last_prescribed) {
                    apply_prescribed(p, &mut self.ideal_solver, &self.offset_rows, &self.joints, t);
                }
                self.ideal_solver.constraint_error()
            }
        };
        put(vr::CONSTRAINT_ERROR, &[phi]);
        work.gains.clear();
        work.gains.resize(2 * (n + k), 0.0);
        let state =
            ProbeState { q: &self.q, qd: &self.qd, qdd: &self.qdd, cut: &self.cut, solver: &mut self.cut_solver };
        write_probes(&self.probes, state, (&terms, own), &mut work.gains, &mut put);
        self.ports.check_finite().map_err(|e| e.to_string())?;
        self.terms = Some(terms);
        Ok(())
    }

    /// The effective terms at the current state (`solved`: their solves were done ahead, the
    /// cut solver holds them; else solved here, from the ideal solver's rotations and factor
    /// where it has them).
    fn solve_terms(&mut self, solved: bool) -> Result<CoupledTerms, String> {
        let t = self.ports.time.seconds();
        let k = self.joints.len();
        let mut terms =
            self.terms.take().unwrap_or_else(|| CoupledTerms::zeros(self.q.len(), self.cut.constraint_count(), k));
        if solved {
            crate::interface::coupled_rates_into(&self.cut_solver, &self.joints, &mut terms);
        } else {
            // (The ideal mechanism's solver was last set at this position: its sines and cosines
            // serve.)
            self.cut_solver.share_rotations(&self.ideal_solver);
            if self.cut_factor_shared {
                // (And its factor, where the ideal one's was formed at this position.)
                self.cut_solver.share_factor(&self.ideal_solver);
            }
            coupled_effective_terms_into(
                &self.cut,
                &mut self.cut_solver,
                &self.joints,
                t,
                &self.q,
                &self.qd,
                &mut terms,
            )
            .map_err(|e| e.to_string())?;
        }
        Ok(terms)
    }
}

impl Subsystem for MechanismSubsystem {
    lash_core::subsystem_calls_of_ports!();

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.ports.phase.require("initialize", &[Phase::Configured])?;
        // Consistent initial conditions of the ideal mechanism (the journals centred, ideal
        // velocities): the cut mechanism starts from the same state.
        let t = self.ports.time.seconds();
        let (q, qd) = initial_guess(&self.ideal);
        self.q = q;
        self.qd = qd;
        let r = assemble_and_project(&self.ideal, t, &mut self.q, &mut self.qd, &mut self.ideal_solver, 1e-13);
        if let Err(e) = r {
            return Err(self.ports.fail(format!("initial conditions: {e}")));
        }
        if let Err(m) = self.refresh(Some(self.ideal_solver.constraint_error()), false) {
            return Err(self.ports.fail(m));
        }
        self.ports.phase = Phase::Stepping;
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.ports.check_step(t, h)?;
        let (t0, t1) = (t.seconds(), Ticks(t.0 + h.0).seconds());
        let mut solved = false;
        let result = if self.kinematic {
            match self.ahead.take() {
                Some(a) if a.from == t && a.to == Ticks(t.0 + h.0) => {
                    self.q.copy_from_slice(&self.ahead_q);
                    self.qd.copy_from_slice(&self.ahead_qd);
                    solved = a.solved;
                    Ok(Some(a.error))
                }
                _ => self.kinematic_motion(t1).map(Some),
            }
        } else {
            self.last_prescribed =
                (self.coupling == Coupling::TwoWay).then(|| self.ports.two_way.prescription(t0, t1 - t0));
            let prescribed = self.last_prescribed.as_ref().map(|p| (p, &self.offset_rows[..], &self.joints[..]));
            let mut ode = MechanismOde { mech: &self.ideal, solver: &mut self.ideal_solver, prescribed, error: None };
            let mut y: Vec<f64> = self.q.iter().chain(&self.qd).copied().collect();
            let method =
                Method::Dopri5(AdaptiveOptions { max_step: self.integrator.max_step.min(t1 - t0), ..self.integrator });
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
                    self.integration_stats.add(&stats);
                    Ok(None)
                }
                Err(e) => Err(format!("macro integration: {}", lash_core::error_chain(&e))),
            }
        };
        self.ports.step_ended(t, h, self.coupling);
        if let Err(m) = result.and_then(|assembled_error| self.refresh(assembled_error, solved)) {
            return Err(self.ports.fail(m));
        }
        Ok(StepOutcome::Completed)
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new(Snapshot {
            q: self.q.clone(),
            qd: self.qd.clone(),
            ports: self.ports.saved(),
            last_prescribed: self.last_prescribed.clone(),
        })))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let s = state
            .0
            .downcast_ref::<Snapshot>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not a mechanism subsystem's".into()))?;
        self.ahead = None;
        self.q.clone_from(&s.q);
        self.qd.clone_from(&s.qd);
        self.ports.restore(&s.ports);
        self.last_prescribed.clone_from(&s.last_prescribed);
        if self.ports.phase == Phase::Stepping {
            let t = self.ports.time.seconds();
            self.refresh(None, false).map_err(|m| SubsystemError::Simulation { t, message: m })?;
        }
        Ok(())
    }
}

/// The journals' and bearings' angular velocities and accelerations of every joint at (q̇, q̈)
/// into their outputs (`values` at `offsets`); a guide's "journal" rates are its block's speed
/// and acceleration along it, its bearing's zero.
fn write_rotation_rates(
    (values, offsets): (&mut [f64], &[usize]),
    joints: &[ClearanceInterface],
    poses: &[Pose],
    qd: &[f64],
    qdd: &[f64],
) {
    let range = |vr: ValueReference| offsets[vr as usize]..offsets[vr as usize + 1];
    let omega = |b: BodyId, v: &[f64]| match b {
        BodyId::Body(k) => v[3 * k + 2],
        BodyId::Ground => 0.0,
    };
    let mut each = |vr: ValueReference, f: &dyn Fn(&ClearanceInterface) -> f64| {
        for (o, j) in values[range(vr)].iter_mut().zip(joints) {
            *o = f(j);
        }
    };
    let slide = |j: &ClearanceInterface| j.slide_rates(poses, qd, qdd);
    each(vr::JOURNAL_ANGULAR_VELOCITY, &|j| slide(j).map_or_else(|| omega(j.interface.journal_body, qd), |s| s.0));
    each(vr::JOURNAL_ANGULAR_ACCELERATION, &|j| slide(j).map_or_else(|| omega(j.interface.journal_body, qdd), |s| s.1));
    each(vr::BEARING_ANGULAR_VELOCITY, &|j| {
        if j.guide.is_some() { 0.0 } else { omega(j.interface.bearing_body, qd) }
    });
    each(vr::BEARING_ANGULAR_ACCELERATION, &|j| {
        if j.guide.is_some() { 0.0 } else { omega(j.interface.bearing_body, qdd) }
    });
}

/// What a probe reads: the macro's coordinates, velocities and accelerations, and the cut
/// mechanism with its solver at that state.
struct ProbeState<'a> {
    q: &'a [f64],
    qd: &'a [f64],
    qdd: &'a [f64],
    cut: &'a Mechanism,
    solver: &'a mut Solver,
}

/// Every probe's outputs, in the order of `probes`, through `put` from the first value
/// reference after the fixed ones; `terms` and `own` (the macro's own interface loads) give the
/// free values and the gains, written through `gains` (two rows of one gain per load).
fn write_probes(
    probes: &[Probe],
    s: ProbeState<'_>,
    (terms, own): (&CoupledTerms, &[f64]),
    gains: &mut [f64],
    put: &mut dyn FnMut(ValueReference, &[f64]),
) {
    let mut next = vr::FRICTION_FORCE + 1;
    let g = gains.len() / 2;
    // What a reaction or a torque is at no load (λ free) and per unit load (each λ column).
    let multipliers = (&terms.free_lambda[..], &terms.lambda_gain[..]);
    for p in probes {
        match *p {
            Probe::Point { body, point, .. } => {
                // (One pose, one sine and cosine, for the five: at q̇ and at rest.)
                let pose = Pose::of(body, s.q, s.qd);
                let at_rest = Pose { velocity: Vec2::zeros(), angular_velocity: 0.0, ..pose };
                let own_kin = point_kinematics_at(&pose, s.qdd, body, point);
                let free = point_kinematics_at(&pose, &terms.free_accelerations, body, point);
                for (c, column) in terms.gain.iter().enumerate() {
                    let a = point_kinematics_at(&at_rest, column, body, point).acceleration;
                    gains[c] = a.x;
                    gains[g + c] = a.y;
                }
                put(next, own_kin.position.as_slice());
                put(next + 1, own_kin.velocity.as_slice());
                put(next + 2, own_kin.acceleration.as_slice());
                put(next + 3, free.acceleration.as_slice());
                put(next + 4, gains);
                next += 5;
            }
            Probe::JointReaction { joint, .. } => {
                let (cut, solver) = (s.cut, &mut *s.solver);
                let at = |lambda: &[f64]| {
                    solver.lambda.copy_from_slice(lambda);
                    joint_reaction(cut, solver, joint)
                };
                let (total, free) = linear_in_loads(multipliers, own, at, |c, r: Vec2| {
                    gains[c] = r.x;
                    gains[g + c] = r.y;
                });
                put(next, total.as_slice());
                put(next + 1, free.as_slice());
                put(next + 2, gains);
                next += 3;
            }
            Probe::Body { body, .. } => {
                let pose = Pose::of(body, s.q, s.qd);
                put(next, &[pose.position.x, pose.position.y, pose.angle]);
                put(next + 1, &[pose.velocity.x, pose.velocity.y, pose.angular_velocity]);
                next += 2;
            }
            Probe::DriverTorque { driver, .. } => {
                let (cut, solver) = (s.cut, &mut *s.solver);
                let at = |lambda: &[f64]| {
                    solver.lambda.copy_from_slice(lambda);
                    driver_torque(cut, solver, driver)
                };
                let (total, free) = linear_in_loads(multipliers, own, at, |c, torque| gains[c] = torque);
                put(next, &[total]);
                put(next + 1, &[free]);
                put(next + 2, &gains[..g]);
                next += 3;
            }
        }
    }
}

/// A kinematic step analysed ahead ([`kinematic_steps_ahead`]).
#[derive(Debug, Clone, Copy)]
struct Ahead {
    /// The step, from and to.
    from: Ticks,
    to: Ticks,
    /// The assembled constraint error (max |Φ|).
    error: f64,
    /// The effective terms' solves were done too, at its end state (`terms` and the cut solver
    /// hold them).
    solved: bool,
}

/// The position analysis's tolerance on max |Φ| at a kinematic step [m or rad].
const ASSEMBLY_TOLERANCE: f64 = 1e-13;

/// Second-order Taylor prediction of the coordinates `h` ahead from the last node: Newton then
/// needs two or three corrections instead of several across a 30° step.
fn predict(q: &mut [f64], qd: &[f64], qdd: &[f64], h: f64) {
    for k in 0..q.len() {
        q[k] += h * qd[k] + 0.5 * h * h * qdd[k];
    }
}

/// Analyses ahead the next kinematic step, from `t` over `h`, of the fully driven mechanism
/// subsystems among `subs` (those that are not are left alone), up to [`crate::lanes::LANES`] of
/// one structure at a time in vector lanes ([`crate::lanes::assemble_and_project_lanes`]): the
/// position and velocity analysis their `do_step(t, h)` would do, bit for bit, which that
/// `do_step` then takes. A subsystem whose analysis does not end cleanly in lanes (or that has
/// no partner of its structure) analyses in its `do_step` as usual, meeting the same error. (The
/// interface master of runs stepped together hands them over by their type: lash-orchestrate's
/// `GroupAhead`.)
pub fn kinematic_steps_ahead(
    subs: &mut [&mut MechanismSubsystem],
    t: Ticks,
    h: Ticks,
    work: &mut crate::lanes::KinematicLanes,
) {
    use crate::lanes::{LANES, LaneInput, TermsInput, assemble_and_project_lanes, effective_solves_lanes};
    let mut ready: Vec<&mut MechanismSubsystem> = subs
        .iter_mut()
        .map(|s| &mut **s)
        .filter(|m| m.kinematic && m.ports.phase == Phase::Stepping && m.ports.time == t && h.0 > 0)
        .collect();
    let to = Ticks(t.0 + h.0);
    let t1 = to.seconds();
    while ready.len() >= 2 {
        // The first subsystem and those of its structure (up to LANES).
        let mut group: Vec<&mut MechanismSubsystem> = Vec::with_capacity(LANES);
        let mut rest = Vec::with_capacity(ready.len());
        for m in ready {
            let fits = group.len() < LANES && group.first().is_none_or(|g| g.signature == m.signature);
            if fits { group.push(m) } else { rest.push(m) }
        }
        ready = rest;
        if group.len() < 2 {
            continue;
        }
        // The effective terms' solves too, in the same lanes, where every member's fit: then the
        // analysed solvers' state but for their sines and cosines is not read before it is set
        // again (the cut solvers hold what the terms need).
        let solve =
            group[0].terms_signature.is_some() && group.iter().all(|m| m.terms_signature == group[0].terms_signature);
        let mut lanes: Vec<LaneInput<'_>> = group
            .iter_mut()
            .map(|m| {
                let m = &mut **m;
                m.ahead = None;
                m.ahead_q.copy_from_slice(&m.q);
                m.ahead_qd.copy_from_slice(&m.qd);
                predict(&mut m.ahead_q, &m.qd, &m.qdd, t1 - m.ports.time.seconds());
                LaneInput { mech: &m.ideal, solver: &mut m.ideal_solver, q: &mut m.ahead_q, qd: &mut m.ahead_qd }
            })
            .collect();
        let errors = assemble_and_project_lanes(&mut lanes, t1, ASSEMBLY_TOLERANCE, !solve, work);
        drop(lanes);
        if solve {
            let mut lanes: Vec<TermsInput<'_>> = group
                .iter_mut()
                .map(|m| {
                    let m = &mut **m;
                    let terms = m.terms.get_or_insert_with(|| {
                        CoupledTerms::zeros(m.q.len(), m.cut.constraint_count(), m.joints.len())
                    });
                    TermsInput { cut: &m.cut, solver: &mut m.cut_solver, joints: &m.joints, terms }
                })
                .collect();
            effective_solves_lanes(&mut lanes, &errors, t1, work);
        }
        for (m, error) in group.into_iter().zip(errors) {
            m.ahead = error.map(|error| Ahead { from: t, to, error, solved: solve });
        }
    }
}

/// A saved state of the mechanism subsystem.
struct Snapshot {
    q: Vec<f64>,
    qd: Vec<f64>,
    ports: lash_core::SavedPorts,
    last_prescribed: Option<Prescribed>,
}
