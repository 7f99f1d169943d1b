//! The full model of a spatial mechanism with spherical clearance joints: the equations of motion
//! with the joints' contact forces and moments, as an [`OdeSystem`] with one event function per
//! joint (δ in free flight, −δ in contact), like the planar [`crate::FullModel`].

use crate::contacts::{self, Frames, SpatialFrames};
use crate::impact_log::{ImpactLog, log_calls};
use lash_contact::spherical::{SphericalClearance, SphericalContactState};
use lash_mech::{BodyId, MechError};
use lash_ode::OdeSystem;
use lash_spatial::constraints::BodyFrame;
use lash_spatial::{
    Marker, SpatialJoint, SpatialJointKind, SpatialMechanism, SpatialSolver, Vec3, assemble, velocity_analysis,
};

/// Spatial mechanism + spherical clearance joints, ready to integrate. State y = [q; v].
pub struct SpatialFullModel {
    /// The mechanism with the clearance joints removed (cut system).
    pub mechanism: SpatialMechanism,
    /// The clearance joints.
    pub clearances: Vec<SphericalClearance>,
    /// KKT workspace; after an evaluation it holds v̇ and λ.
    pub solver: SpatialSolver,
    /// Contact states at the last evaluation, one per clearance joint.
    pub contacts: Vec<SphericalContactState>,
    log: ImpactLog,
    strict_modes: bool,
    dense_buffer: Vec<f64>,
    frames: Vec<BodyFrame>,
}

/// A [`SpatialFullModel::snapshot`]: contact modes, impacts and pending error.
#[derive(Debug, Clone)]
pub struct SpatialFullModelState {
    clearances: Vec<SphericalClearance>,
    contacts: Vec<SphericalContactState>,
    log: ImpactLog,
}

/// The bodies' frames of a state `y = [q; v]` (without a solve).
fn frames_of(mech: &SpatialMechanism, y: &[f64], out: &mut [BodyFrame]) {
    let n = mech.coordinate_count();
    let (q, v) = y.split_at(n);
    for (k, f) in out.iter_mut().enumerate() {
        let rotation = *lash_spatial::orientation(&q[7 * k + 3..7 * k + 7]).to_rotation_matrix().matrix();
        *f = BodyFrame {
            position: Vec3::new(q[7 * k], q[7 * k + 1], q[7 * k + 2]),
            rotation,
            velocity: Vec3::new(v[6 * k], v[6 * k + 1], v[6 * k + 2]),
            angular_velocity: rotation * Vec3::new(v[6 * k + 3], v[6 * k + 4], v[6 * k + 5]),
        };
    }
}

impl SpatialFullModel {
    /// Builds the model. The mechanism must already be valid.
    pub fn new(mechanism: SpatialMechanism, clearances: Vec<SphericalClearance>) -> Self {
        let solver = SpatialSolver::new(&mechanism);
        let k = clearances.len();
        let dim = mechanism.coordinate_count() + mechanism.velocity_count();
        let bodies = mechanism.bodies.len();
        Self {
            mechanism,
            clearances,
            solver,
            contacts: vec![SphericalContactState::default(); k],
            log: ImpactLog::new(k),
            strict_modes: false,
            dense_buffer: vec![0.0; dim],
            frames: vec![BodyFrame::ground(); bodies],
        }
    }

    /// The mechanism with every clearance joint replaced by an ideal spherical joint (ball centred).
    pub fn ideal_mechanism(&self) -> SpatialMechanism {
        let mut m = self.mechanism.clone();
        for c in &self.clearances {
            m.joints.push(SpatialJoint {
                name: c.name.clone(),
                kind: SpatialJointKind::Spherical,
                i: Marker::at(c.journal_body, c.journal_point),
                j: Marker::at(c.bearing_body, c.bearing_point),
            });
        }
        m
    }

    /// Consistent initial state at `t0`: the ideal mechanism (balls centred) assembled from the
    /// bodies' initial poses and driven to its velocities. Resets contact modes and impacts.
    pub fn initial_state(&mut self, t0: f64) -> Result<Vec<f64>, MechError> {
        let ideal = self.ideal_mechanism();
        let mut y = ideal.initial_state();
        let n = ideal.coordinate_count();
        let (q, v) = y.split_at_mut(n);
        assemble(&ideal, t0, q, 1e-13)?;
        velocity_analysis(&ideal, t0, q, v)?;
        self.reset(t0, &y);
        Ok(y)
    }

    /// Prepares a run from a state chosen by the caller (contact modes from the state).
    pub fn reset(&mut self, t0: f64, y: &[f64]) {
        self.log.clear();
        contacts::open_all(&mut self.clearances);
        frames_of(&self.mechanism, y, &mut self.frames);
        let (frames, at) = (SpatialFrames(&self.frames), (t0, self.strict_modes));
        contacts::start((&mut self.clearances, 0), &frames, |_| None, &mut self.log, at);
    }

    /// Evaluates contact forces, v̇ and λ at `(t, y)`; results in `solver` and `contacts`.
    pub fn evaluate(&mut self, t: f64, y: &[f64]) -> Result<(), MechError> {
        let n = self.mechanism.coordinate_count();
        let (q, v) = y.split_at(n);
        let Self { mechanism, clearances, solver, contacts, log, strict_modes, .. } = self;
        solver.set_state(mechanism, t, q, v);
        for (c, state) in clearances.iter().zip(contacts.iter_mut()) {
            let frames = SpatialFrames(&solver.frames);
            let (fj, fb) = (frames.frame(c.journal_body), frames.frame(c.bearing_body));
            let onset = if c.in_contact { c.onset_velocity } else { f64::INFINITY };
            let s = c.evaluate(&fj, &fb, onset);
            let free = |s| SphericalContactState {
                normal_force: 0.0,
                friction_force: 0.0,
                force_on_journal: Vec3::zeros(),
                ..s
            };
            let at = |onset| c.evaluate(&fj, &fb, onset);
            let s = contacts::in_mode(c, (s.penetration, s.penetration_rate), (log, *strict_modes), s, free, at);
            if s.normal_force != 0.0 || s.friction_force != 0.0 {
                let (arm_j, arm_b) = c.arms(&fj, &fb, &s);
                let f = s.force_on_journal;
                if let BodyId::Body(k) = c.journal_body {
                    solver.add_force(k, f, arm_j.cross(&f));
                }
                if let BodyId::Body(k) = c.bearing_body {
                    solver.add_force(k, -f, arm_b.cross(&-f));
                }
            }
            *state = s;
        }
        solver.solve(mechanism)
    }

    /// The model's history (contact modes, impacts, pending error) for [`SpatialFullModel::restore`]:
    /// together with the state vector, everything a co-simulation step can be repeated from.
    pub fn snapshot(&self) -> SpatialFullModelState {
        SpatialFullModelState {
            clearances: self.clearances.clone(),
            contacts: self.contacts.clone(),
            log: self.log.clone(),
        }
    }

    /// Returns to a [`SpatialFullModel::snapshot`] of this model.
    pub fn restore(&mut self, state: &SpatialFullModelState) {
        self.clearances.clone_from(&state.clearances);
        self.contacts.clone_from(&state.contacts);
        self.log.clone_from(&state.log);
    }

    log_calls!(records);

    /// Joint `k`'s contact state at `y` with onset velocity `onset` (no solve).
    pub fn contact_state(&mut self, k: usize, y: &[f64], onset: f64) -> SphericalContactState {
        frames_of(&self.mechanism, y, &mut self.frames);
        let (c, frames) = (&self.clearances[k], SpatialFrames(&self.frames));
        c.evaluate(&frames.frame(c.journal_body), &frames.frame(c.bearing_body), onset)
    }
}

impl OdeSystem for SpatialFullModel {
    log_calls!(ode);

    fn dim(&self) -> usize {
        self.mechanism.coordinate_count() + self.mechanism.velocity_count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let n = self.mechanism.coordinate_count();
        if let Err(e) = self.evaluate(t, y) {
            self.log.note_error(|| e.into());
            dydt.fill(f64::NAN);
            return;
        }
        lash_spatial::position_rates(self.mechanism.bodies.len(), &y[..n], &y[n..], &mut dydt[..n]);
        dydt[n..].copy_from_slice(&self.solver.accelerations);
    }

    fn event_count(&self) -> usize {
        self.clearances.len()
    }

    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        frames_of(&self.mechanism, y, &mut self.frames);
        contacts::events(&self.clearances, &SpatialFrames(&self.frames), |_| None, g);
    }

    fn on_event(&mut self, k: usize, t: f64, y: &[f64]) {
        frames_of(&self.mechanism, y, &mut self.frames);
        let frames = SpatialFrames(&self.frames);
        contacts::switch((&mut self.clearances, 0), k, &frames, |_| None, &mut self.log, t, self.strict_modes);
    }

    fn accept_dense(&mut self, t: f64, h: f64, dense: &lash_ode::Dense<'_>) {
        if !self.wants_dense() {
            return;
        }
        let mut y = std::mem::take(&mut self.dense_buffer);
        let Self { mechanism, clearances, log, frames, .. } = self;
        contacts::search_open((clearances, 0), log, (t, h), |theta, k, onset| {
            dense.eval(theta, &mut y);
            frames_of(mechanism, &y, frames);
            contacts::numbers(clearances, k, &SpatialFrames(frames), |_| None, onset)
        });
        self.dense_buffer = y;
    }

    fn accept_step(&mut self, t: f64, y: &[f64]) -> Result<(), lash_ode::BoxError> {
        if let Some(e) = self.log.take_error() {
            return Err(e.into());
        }
        frames_of(&self.mechanism, y, &mut self.frames);
        contacts::accept_step((&self.clearances, 0), &SpatialFrames(&self.frames), |_| None, &mut self.log, t)?;
        Ok(())
    }
}
