//! The full (monolithic) model: the mechanism's equations of motion with the clearance joints'
//! contact forces, as an [`OdeSystem`] with one event function per clearance joint.
//!
//! Contacts: one per revolute clearance joint, then four per translational clearance joint (its
//! block's corners, [`lash_contact::translational::CORNER_SIGNS`] order); event function, impact record
//! and contact mode are per contact.
//!
//! State y = [q; q̇; s], s the deflections of the bushes whose damping is in series with their
//! contact (one per such clearance joint, in joint order; none for rigid bearings and quasi-static
//! bushes). Event function k is the contact's own indentation δ_k − s_k in free flight and its
//! negative in contact, so the adaptive integrator locates every onset and exit; the approach
//! velocity δ̇⁻ of the hysteresis laws is captured at the located onset.

use crate::contacts::{self, PlanarFrames};
use crate::impact_log::{ImpactLog, log_calls};
use lash_contact::clearance::{ClearanceJoint, ContactState};
use lash_contact::translational::{CornerState, SlotState, TranslationalClearance};
use lash_mech::constraints::pose_of;
use lash_mech::{Joint, JointKind, MechError, Mechanism, Solver, Vec2, assemble, kinematics, velocity_analysis};
use lash_ode::OdeSystem;

/// Errors of building or running the full model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// The mechanics layer (planar or spatial) failed.
    #[error(transparent)]
    Mech(#[from] MechError),
}

/// Mechanism + clearance joints, ready to integrate.
pub struct FullModel {
    /// The mechanism with the clearance joints removed (cut system).
    pub mechanism: Mechanism,
    /// The clearance joints.
    pub clearances: Vec<ClearanceJoint>,
    /// KKT workspace; after an evaluation it holds q̈ and λ.
    pub solver: Solver,
    /// Contact states at the last evaluation, one per clearance joint.
    pub contacts: Vec<ContactState>,
    /// The translational clearance joints.
    pub slots: Vec<TranslationalClearance>,
    /// Their corners' states at the last evaluation, one per translational clearance joint.
    pub slot_contacts: Vec<SlotState>,
    log: ImpactLog,
    strict_modes: bool,
    dense_buffer: Vec<f64>,
    n: usize,
    /// Per clearance joint, the index in y of its bush's deflection (a bush damped in series).
    bush_states: Vec<Option<usize>>,
    /// ṡ of each clearance joint's damped bush at the last evaluation (0 for the others).
    bush_rates: Vec<f64>,
}

/// The evolving part of a [`FullModel`] (see [`FullModel::snapshot`]).
#[derive(Debug, Clone)]
pub struct FullModelState {
    clearances: Vec<ClearanceJoint>,
    contacts: Vec<ContactState>,
    slots: Vec<TranslationalClearance>,
    slot_contacts: Vec<SlotState>,
    log: ImpactLog,
}

impl FullModel {
    /// Builds the model. The mechanism must already be valid.
    pub fn new(mechanism: Mechanism, clearances: Vec<ClearanceJoint>) -> Self {
        let solver = Solver::new(&mechanism);
        let n = mechanism.coordinate_count();
        let k = clearances.len();
        let mut next = 2 * n;
        let bush_states = clearances
            .iter()
            .map(|c| {
                c.damped_in_series().then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect();
        Self {
            mechanism,
            clearances,
            solver,
            contacts: vec![ContactState::default(); k],
            slots: Vec::new(),
            slot_contacts: Vec::new(),
            log: ImpactLog::new(k),
            strict_modes: false,
            dense_buffer: vec![0.0; next],
            n,
            bush_states,
            bush_rates: vec![0.0; k],
        }
    }

    /// The model with translational clearance joints too (their contacts follow the revolute
    /// joints').
    pub fn with_slots(mut self, slots: Vec<TranslationalClearance>) -> Self {
        self.slot_contacts = vec![SlotState::default(); slots.len()];
        self.log = ImpactLog::new(self.clearances.len() + 4 * slots.len());
        self.slots = slots;
        self
    }

    /// The number of contacts (events, impact records): one per revolute clearance joint, four
    /// per translational one.
    pub fn contact_count(&self) -> usize {
        self.clearances.len() + 4 * self.slots.len()
    }

    /// The mechanism with every clearance joint replaced by an ideal revolute joint at the bearing
    /// centre (journal centred), and every bushing by an ideal revolute joint (undeflected): the
    /// consistent start of a run, and the reduced model's macro mechanism.
    pub fn ideal_mechanism(&self) -> Mechanism {
        let mut m = self.mechanism.clone();
        for c in &self.clearances {
            m.joints.push(Joint {
                name: c.name.clone(),
                kind: JointKind::Revolute,
                body_i: c.journal_body,
                point_i: c.journal_point,
                body_j: c.bearing_body,
                point_j: c.bearing_point,
            });
        }
        // A translational clearance joint by an ideal prismatic joint holding the block centred
        // and aligned in its guide.
        for s in &self.slots {
            m.joints.push(Joint {
                name: s.name.clone(),
                kind: JointKind::Prismatic { axis_j: s.guide.axis, angle_offset: s.aligned_angle() },
                body_i: s.block.body,
                point_i: s.block.centre,
                body_j: s.guide.body,
                point_j: s.guide.point,
            });
        }
        // Bushings closed too: their two points joined by an ideal revolute joint.
        let mut k = 0;
        m.loads.retain(|l| match *l {
            lash_mech::Load::Bushing { body_i, point_i, body_j, point_j, .. } => {
                k += 1;
                let joint =
                    Joint { name: format!("bushing {k}"), kind: JointKind::Revolute, body_i, point_i, body_j, point_j };
                m.joints.push(joint);
                false
            }
            _ => true,
        });
        m
    }

    /// Consistent initial state at `t0`: the ideal mechanism (journals centred) assembled from the
    /// bodies' guesses and driven to its velocities; bushings deflected by their quasi-static load
    /// (the ideal joint's reaction over the stiffness), so that a stiff, lightly damped bush does
    /// not ring from an unloaded start. Resets contact modes and impact records.
    pub fn initial_state(&mut self, t0: f64) -> Result<Vec<f64>, ModelError> {
        let mut ideal = self.ideal_mechanism();
        let mut solver = Solver::new(&ideal);
        let (mut q, mut qd) = kinematics::initial_guess(&ideal);
        assemble(&ideal, t0, &mut q, &mut solver, 1e-13)?;
        velocity_analysis(&ideal, t0, &q, &mut qd, &mut solver)?;
        let springs: Vec<(f64, Option<lash_mech::RadialCurve>)> = self
            .mechanism
            .loads
            .iter()
            .filter_map(|l| match l {
                lash_mech::Load::Bushing { stiffness, curve, .. } => Some((*stiffness, curve.clone())),
                _ => None,
            })
            .collect();
        if !springs.is_empty() {
            // The bushings' joints are the ideal mechanism's last ones (see ideal_mechanism).
            solver.set_state(&ideal, t0, &q, &qd);
            solver.factor()?;
            solver.solve(&ideal, &qd);
            let first = ideal.joints.len() - springs.len();
            for (k, (stiff, curve)) in springs.iter().enumerate() {
                // The bush carries the joint's force f on body i: −k d = f, d = p_i − p_j = −f / k
                // (along a curve: d = −f/|f| u(|f|)). The joint then holds body i's point shifted
                // by −A_iᵀ d on body j's point, which leaves the bush's own two points apart by d.
                let reaction = kinematics::joint_reaction(&ideal, &solver, first + k);
                let deflection = match curve {
                    None => -reaction / *stiff,
                    Some(c) if reaction.norm() > 0.0 => -reaction * (c.deflection(reaction.norm()) / reaction.norm()),
                    Some(_) => lash_mech::Vec2::zeros(),
                };
                let joint = &mut ideal.joints[first + k];
                let pose = lash_mech::Pose::of(joint.body_i, &q, &qd);
                let local = lash_mech::Vec2::new(
                    pose.cos * deflection.x + pose.sin * deflection.y,
                    -pose.sin * deflection.x + pose.cos * deflection.y,
                );
                joint.point_i -= local;
            }
            assemble(&ideal, t0, &mut q, &mut solver, 1e-13)?;
            velocity_analysis(&ideal, t0, &q, &mut qd, &mut solver)?;
        }
        q.extend_from_slice(&qd);
        // Damped bushes start undeflected (the journals are centred, their contacts open).
        q.resize(self.dim(), 0.0);
        self.reset(t0, &q);
        Ok(q)
    }

    /// Prepares a run from a state `y = [q; q̇; s]` chosen by the caller: clears impact records and
    /// sets each contact mode from the state (a journal already penetrating starts in contact,
    /// with its current approach velocity as onset velocity).
    pub fn reset(&mut self, t0: f64, y: &[f64]) {
        self.log.clear();
        contacts::open_all(&mut self.clearances);
        contacts::open_all(&mut self.slots);
        let (frames, bushes) = Self::frames_and_bushes(self.n, &self.bush_states, y);
        let (log, at, first) = (&mut self.log, (t0, self.strict_modes), self.clearances.len());
        contacts::start((&mut self.clearances, 0), &frames, bushes, log, at);
        contacts::start((&mut self.slots, first), &frames, |_| None, log, at);
    }

    /// A copy of everything in the model that evolves during a run (contact modes, onset
    /// velocities, open and completed impacts), for rollback.
    pub fn snapshot(&self) -> FullModelState {
        FullModelState {
            clearances: self.clearances.clone(),
            contacts: self.contacts.clone(),
            slots: self.slots.clone(),
            slot_contacts: self.slot_contacts.clone(),
            log: self.log.clone(),
        }
    }

    /// Returns to a [`FullModel::snapshot`] of this model.
    pub fn restore(&mut self, state: &FullModelState) {
        self.clearances.clone_from(&state.clearances);
        self.contacts.clone_from(&state.contacts);
        self.slots.clone_from(&state.slots);
        self.slot_contacts.clone_from(&state.slot_contacts);
        self.log.clone_from(&state.log);
    }

    /// Evaluates contact forces, q̈ and λ at `(t, y)`; results in `solver` and `contacts` (and the
    /// damped bushes' deflection rates).
    pub fn evaluate(&mut self, t: f64, y: &[f64]) -> Result<(), MechError> {
        let n = self.n;
        let (q, qd) = (&y[..n], &y[n..2 * n]);
        let FullModel {
            mechanism,
            clearances,
            solver,
            contacts,
            slots,
            slot_contacts,
            log,
            strict_modes,
            bush_states,
            bush_rates,
            ..
        } = self;
        solver.set_state(mechanism, t, q, qd);
        for (k, (c, state)) in clearances.iter().zip(contacts.iter_mut()).enumerate() {
            let pj = pose_of(&solver.poses, c.journal_body);
            let pb = pose_of(&solver.poses, c.bearing_body);
            let deflection = bush_states[k].map(|i| y[i]);
            let evaluate = |onset: f64| c.evaluate_with_bush(&pj, &pb, onset, deflection);
            // Probe geometry first, then keep to the contact's mode (its own indentation δ − s
            // and approach rate δ̇ − ṡ, ṡ of the relaxing bush).
            let onset = if c.in_contact { c.onset_velocity } else { f64::INFINITY };
            let (s, rate) = evaluate(onset);
            let own = (s.penetration - deflection.unwrap_or(0.0), s.penetration_rate - rate);
            let free = |(s, _): (ContactState, f64)| {
                let s = ContactState { normal_force: 0.0, friction_force: 0.0, force_on_journal: Vec2::zeros(), ..s };
                (s, c.bush_relaxation_rate(deflection.unwrap_or(0.0)))
            };
            let (mut s, rate) = contacts::in_mode(c, own, (log, *strict_modes), (s, rate), free, evaluate);
            if s.normal_force != 0.0 || s.friction_force != 0.0 {
                let (arm_j, arm_b) = c.arms(&pj, &pb, &s);
                solver.add_force(c.journal_body, arm_j, s.force_on_journal);
                solver.add_force(c.bearing_body, arm_b, -s.force_on_journal);
            }
            // A lubricated joint's film, in every mode, through the two centres.
            if let Some((film, arm_j, arm_b)) = c.film_at(&pj, &pb) {
                solver.add_force(c.journal_body, arm_j, film);
                solver.add_force(c.bearing_body, arm_b, -film);
                s.force_on_journal += film;
            }
            *state = s;
            bush_rates[k] = rate;
        }
        for (slot, state) in slots.iter().zip(slot_contacts.iter_mut()) {
            evaluate_slot(slot, state, solver, log, *strict_modes);
        }
        solver.factor()?;
        solver.solve(mechanism, qd);
        Ok(())
    }

    log_calls!(records);

    /// Generalized accelerations of the last evaluation.
    pub fn accelerations(&self) -> &[f64] {
        &self.solver.accelerations
    }

    /// The poses of state `y` and each clearance joint's bush deflection in it (None: no bush
    /// damped in series).
    fn frames_and_bushes<'a>(
        n: usize,
        bush_states: &'a [Option<usize>],
        y: &'a [f64],
    ) -> (PlanarFrames<'a>, impl Fn(usize) -> Option<f64> + 'a) {
        (PlanarFrames { q: &y[..n], qd: &y[n..2 * n] }, move |j: usize| bush_states[j].map(|i| y[i]))
    }

    /// The deflection of clearance joint `k`'s bush in series at `y` when it is a state (a bush
    /// damped in series), None otherwise.
    pub fn bush_deflection(&self, k: usize, y: &[f64]) -> Option<f64> {
        self.bush_states[k].map(|i| y[i])
    }
}

impl OdeSystem for FullModel {
    log_calls!(ode);

    fn dim(&self) -> usize {
        2 * self.n + self.bush_states.iter().flatten().count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let n = self.n;
        match self.evaluate(t, y) {
            Ok(()) => {
                dydt[..n].copy_from_slice(&y[n..2 * n]);
                dydt[n..2 * n].copy_from_slice(&self.solver.accelerations);
                for (state, rate) in self.bush_states.iter().zip(&self.bush_rates) {
                    if let Some(i) = *state {
                        dydt[i] = *rate;
                    }
                }
            }
            Err(e) => {
                self.log.note_error(|| e.into());
                dydt.fill(f64::NAN);
            }
        }
    }

    fn event_count(&self) -> usize {
        self.contact_count()
    }

    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        let (frames, bushes) = Self::frames_and_bushes(self.n, &self.bush_states, y);
        let (revolute, translational) = g.split_at_mut(self.clearances.len());
        contacts::events(&self.clearances, &frames, bushes, revolute);
        contacts::events(&self.slots, &frames, |_| None, translational);
    }

    fn on_event(&mut self, k: usize, t: f64, y: &[f64]) {
        let (frames, bushes) = Self::frames_and_bushes(self.n, &self.bush_states, y);
        let (log, searched, first) = (&mut self.log, self.strict_modes, self.clearances.len());
        if k < first {
            contacts::switch((&mut self.clearances, 0), k, &frames, bushes, log, t, searched);
        } else {
            contacts::switch((&mut self.slots, first), k - first, &frames, |_| None, log, t, searched);
        }
    }

    fn accept_dense(&mut self, t: f64, h: f64, dense: &lash_ode::Dense<'_>) {
        if !self.wants_dense() {
            return;
        }
        // Search each open contact's force along the step's continuous extension (samples θ = k/8,
        // refined where the step holds the peak); the samples also update the largest penetration.
        let mut y = std::mem::take(&mut self.dense_buffer);
        y.resize(self.dim(), 0.0);
        let (n, bush_states, first) = (self.n, &self.bush_states, self.clearances.len());
        let (clearances, slots) = (&self.clearances, &self.slots);
        contacts::search_open((clearances, 0), &mut self.log, (t, h), |theta, k, onset| {
            dense.eval(theta, &mut y);
            let (frames, bushes) = Self::frames_and_bushes(n, bush_states, &y);
            contacts::numbers(clearances, k, &frames, bushes, onset)
        });
        contacts::search_open((slots, first), &mut self.log, (t, h), |theta, k, onset| {
            dense.eval(theta, &mut y);
            let frames = PlanarFrames { q: &y[..n], qd: &y[n..2 * n] };
            contacts::numbers(slots, k, &frames, |_| None, onset)
        });
        self.dense_buffer = y;
    }

    fn accept_step(&mut self, t: f64, y: &[f64]) -> Result<(), lash_ode::BoxError> {
        if let Some(e) = self.log.take_error() {
            return Err(e.into());
        }
        let (frames, bushes) = Self::frames_and_bushes(self.n, &self.bush_states, y);
        contacts::accept_step((&self.clearances, 0), &frames, bushes, &mut self.log, t)?;
        contacts::accept_step((&self.slots, self.clearances.len()), &frames, |_| None, &mut self.log, t)?;
        Ok(())
    }
}

/// Adds translational joint `slot`'s corner forces to the solver's load (the revolute joints'
/// evaluation in [`FullModel::evaluate`], for a joint of four contacts without a bush).
fn evaluate_slot(
    slot: &TranslationalClearance,
    state: &mut SlotState,
    solver: &mut Solver,
    log: &mut ImpactLog,
    strict_modes: bool,
) {
    let pb = pose_of(&solver.poses, slot.block.body);
    let pg = pose_of(&solver.poses, slot.guide.body);
    for (k, corner_state) in state.corners.iter_mut().enumerate() {
        let corner = slot.corner(k);
        let onset = if corner.in_contact { corner.onset_velocity } else { f64::INFINITY };
        let s = slot.evaluate_corner(&pb, &pg, k, onset);
        let free = |s| CornerState { normal_force: 0.0, friction_force: 0.0, force_on_block: Vec2::zeros(), ..s };
        let at = |onset| slot.evaluate_corner(&pb, &pg, k, onset);
        let s = contacts::in_mode(corner, (s.penetration, s.penetration_rate), (log, strict_modes), s, free, at);
        if s.normal_force != 0.0 || s.friction_force != 0.0 {
            solver.add_force(slot.block.body, s.point - pb.position, s.force_on_block);
            solver.add_force(slot.guide.body, s.point - pg.position, -s.force_on_block);
        }
        *corner_state = s;
    }
    (state.offset, state.tilt) = slot.placement(&pb, &pg);
}
