//! The equations of motion as an ODE on `y = [q; v]`.

use crate::Vec3;
use crate::model::SpatialMechanism;
use crate::solver::SpatialSolver;
use lash_core::PrescribedInterface;
use lash_mech::BodyId;
use lash_mech::MechError;
use lash_ode::OdeSystem;

/// The closed spherical clearance joints of an ideal mechanism, as two-way coupling moves them:
/// each ball centre held at e(t) from its socket centre (the joint's three rows shifted) and the
/// mean friction load's torques, R_J L̄ on the ball's body and −R_B L̄ on the socket's, applied.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedJoints {
    /// Each joint's first row in the ideal mechanism (its three rows: Φ = (P_J − P_B)·e_x, e_y, e_z).
    pub rows: Vec<usize>,
    /// Each joint's (ball body, R_J) and (socket body, −R_B): where the friction load's torque acts
    /// and its arm.
    pub torque_arms: Vec<[(BodyId, f64); 2]>,
}

impl ClosedJoints {
    /// Shifts the joints' rows to e(t) of `targets` (3k coordinates, 3k friction loads, world) and
    /// adds the friction torques to the applied forces (after [`SpatialSolver::set_state`] at `t`).
    pub fn apply(&self, targets: &PrescribedInterface, solver: &mut SpatialSolver, t: f64) {
        for (j, &row) in self.rows.iter().enumerate() {
            for c in 0..3 {
                let [e, v, a] = targets.at(t, 3 * j + c);
                let r = &mut solver.rows[row + c];
                r.phi -= e;
                r.nu += v;
                r.gamma += a;
            }
        }
        for (j, arms) in self.torque_arms.iter().enumerate() {
            let load = Vec3::from_column_slice(&targets.friction[3 * j..3 * j + 3]);
            for &(body, arm) in arms {
                if let BodyId::Body(k) = body {
                    solver.add_force(k, Vec3::zeros(), load * arm);
                }
            }
        }
    }
}

/// A spatial mechanism with its solver: `ṙ = v`, `ṗ = ½ p ⊗ (0, ω')`, `v̇` from the KKT solve.
pub struct SpatialSystem {
    /// The mechanism.
    pub mechanism: SpatialMechanism,
    /// Its solver (frames, rows, v̇ and λ of the last evaluation).
    pub solver: SpatialSolver,
    /// The first failed solve, if any (the right side is NaN from then on).
    pub failure: Option<MechError>,
    /// Right-hand-side evaluations.
    pub evaluations: u64,
    /// The clearance joints two-way coupling moves ([`SpatialSystem::close_joints`]) and their
    /// prescription now ([`SpatialSystem::prescribe`]).
    closed: Option<ClosedJoints>,
    prescribed: Option<PrescribedInterface>,
    /// The last evaluation's (t, y, ẏ), kept when [`SpatialSystem::remember_last_evaluation`] asked
    /// for it.
    last: Option<(f64, Vec<f64>, Vec<f64>)>,
}

impl SpatialSystem {
    /// The system of a validated mechanism.
    pub fn new(mechanism: SpatialMechanism) -> Self {
        let solver = SpatialSolver::new(&mechanism);
        Self { mechanism, solver, failure: None, evaluations: 0, closed: None, prescribed: None, last: None }
    }

    /// From now on, a right-hand side asked for at exactly the (t, y) of the previous one (bit for
    /// bit) returns the kept derivative without a solve. An integrator restarted where it stopped
    /// asks for that derivative first (the reduced model's macro side, one communication step
    /// after the other: one KKT solve saved per step, 10 % of them for E). The solver is then left
    /// as that evaluation (or a later `set_state` by its owner) left it.
    pub fn remember_last_evaluation(&mut self) {
        let n = self.mechanism.coordinate_count() + self.mechanism.velocity_count();
        self.last = Some((f64::NAN, vec![f64::NAN; n], vec![0.0; n]));
    }

    /// The clearance joints a prescription moves (once, before any [`SpatialSystem::prescribe`]).
    pub fn close_joints(&mut self, joints: ClosedJoints) {
        self.closed = Some(joints);
    }

    /// Moves the closed clearance joints as `prescribed` says from now on (`None`: held centred);
    /// forgets the kept evaluation, which was made under the previous prescription.
    pub fn prescribe(&mut self, prescribed: Option<PrescribedInterface>) {
        self.prescribed = prescribed;
        if let Some(last) = &mut self.last {
            last.0 = f64::NAN;
        }
    }

    /// The joints' current prescription.
    pub fn prescribed(&self) -> Option<&PrescribedInterface> {
        self.prescribed.as_ref()
    }

    /// Frames, rows and applied forces at `(t, q, v)`, the prescription applied.
    pub fn set_state(&mut self, t: f64, q: &[f64], v: &[f64]) {
        self.solver.set_state(&self.mechanism, t, q, v);
        if let (Some(joints), Some(p)) = (&self.closed, &self.prescribed) {
            joints.apply(p, &mut self.solver, t);
        }
    }

    /// Position coordinates.
    pub fn coordinates(&self) -> usize {
        self.mechanism.coordinate_count()
    }

    /// Solves at `(t, y)`: frames, rows, v̇ and λ in the solver.
    pub fn evaluate(&mut self, t: f64, y: &[f64]) -> Result<(), MechError> {
        let n = self.coordinates();
        self.set_state(t, &y[..n], &y[n..]);
        self.solver.solve(&self.mechanism)
    }

    /// The largest | |p| − 1 | of the bodies' quaternions in `y` (integration drift).
    pub fn quaternion_drift(&self, y: &[f64]) -> f64 {
        (0..self.mechanism.bodies.len()).fold(0.0, |m, k| {
            let p = &y[7 * k + 3..7 * k + 7];
            m.max(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]).sqrt() - 1.0).abs())
        })
    }
}

impl OdeSystem for SpatialSystem {
    fn dim(&self) -> usize {
        self.mechanism.coordinate_count() + self.mechanism.velocity_count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        if let Some((lt, ly, ld)) = &self.last
            && lt.to_bits() == t.to_bits()
            && ly.iter().zip(y).all(|(a, b)| a.to_bits() == b.to_bits())
        {
            dydt.copy_from_slice(ld);
            return;
        }
        self.evaluations += 1;
        let n = self.coordinates();
        if let Err(e) = self.evaluate(t, y) {
            self.failure.get_or_insert(e);
            dydt.fill(f64::NAN);
            if let Some(last) = &mut self.last {
                last.0 = f64::NAN; // nothing kept from a failed solve
            }
            return;
        }
        crate::position_rates(self.mechanism.bodies.len(), &y[..n], &y[n..], &mut dydt[..n]);
        dydt[n..].copy_from_slice(&self.solver.accelerations);
        if let Some((lt, ly, ld)) = &mut self.last {
            *lt = t;
            ly.copy_from_slice(y);
            ld.copy_from_slice(dydt);
        }
    }
}
