//! What a full model keeps of its contacts besides the state vector, whatever its joints' shape
//! (planar revolute, spherical): the impacts of each clearance joint (completed, and the one
//! open), whether a stage left its joint's contact mode, and the first error met inside a
//! right-hand side. The joints keep their own modes (in contact, onset velocity).

use crate::full_model::ModelError;
use lash_contact::clearance::{Impact, ImpactTracker, PENETRATION_LIMIT_FRACTION, PenetrationError, StepSearch};
use lash_contact::joint::Clearance;

/// The impacts and mode flags of a full model's clearance joints (see the module).
#[derive(Debug, Clone)]
pub struct ImpactLog {
    /// Completed impacts, per clearance joint.
    pub impacts: Vec<Vec<Impact>>,
    open: Vec<Option<ImpactTracker>>,
    violation: bool,
    error: Option<ModelError>,
}

impl ImpactLog {
    /// The log of `joints` clearance joints, empty. Impact records are reserved up front so that
    /// recording them does not allocate in the stepping loop (they grow beyond this only in very
    /// long runs).
    pub fn new(joints: usize) -> Self {
        Self {
            impacts: (0..joints).map(|_| Vec::with_capacity(1024)).collect(),
            open: vec![None; joints],
            violation: false,
            error: None,
        }
    }

    /// Empties the log for a new run (the joints' contacts are opened by their model).
    pub fn clear(&mut self) {
        self.impacts.iter_mut().for_each(Vec::clear);
        self.open.iter_mut().for_each(|o| *o = None);
        self.error = None;
        self.violation = false;
    }

    /// Joint `k` (`joint`)'s contact begins or ends at `t` (an event located, or a run starting in
    /// contact): its mode switches, an impact opens with the approach rate `penetration_rate` as
    /// its onset velocity (`searched`: its peak will be searched along the steps' dense output) or
    /// the open one is completed.
    pub fn switch(&mut self, (k, joint): (usize, &mut impl Clearance), t: f64, penetration_rate: f64, searched: bool) {
        if joint.in_contact() {
            joint.set_mode(false, joint.onset_velocity());
            if let Some(tr) = self.open[k].take() {
                self.impacts[k].push(tr.close(t));
            }
        } else {
            joint.set_mode(true, penetration_rate.max(0.0));
            self.open[k] = Some(ImpactTracker::open(t, penetration_rate, searched));
        }
    }

    /// A stage's contact disagreed with its joint's mode: the integrator is to cut or reject the
    /// step.
    pub fn flag_violation(&mut self) {
        self.violation = true;
    }

    /// Whether a stage left its mode since the last call.
    pub fn take_violation(&mut self) -> bool {
        std::mem::take(&mut self.violation)
    }

    /// Keeps the error `error` makes if it is the first met inside a right-hand side.
    pub fn note_error(&mut self, error: impl FnOnce() -> ModelError) {
        if self.error.is_none() {
            self.error = Some(error());
        }
    }

    /// The first error met inside a right-hand side, if any; cleared.
    pub fn take_error(&mut self) -> Option<ModelError> {
        self.error.take()
    }

    /// Whether any joint has an impact open (its peak is searched along the dense output).
    pub fn any_open(&self) -> bool {
        self.open.iter().any(Option::is_some)
    }

    /// Whether joint `k` has an impact open.
    pub fn is_open(&self, k: usize) -> bool {
        self.open[k].is_some()
    }

    /// Joint `k`'s open impact, as it stands at `t`.
    pub fn open_impact(&self, k: usize, t: f64) -> Option<Impact> {
        self.open[k].as_ref().map(|tr| tr.so_far(t))
    }

    /// Joint `k`'s open impact takes a step's dense-output search of its force.
    pub(crate) fn accept_search(&mut self, k: usize, search: StepSearch) {
        if let Some(tr) = self.open[k].as_mut() {
            tr.accept(search);
        }
    }

    /// At an accepted step end `t`: joint `k` (`joint`)'s penetration checked against the
    /// blow-up limit ([`PENETRATION_LIMIT_FRACTION`] of its journal radius) and its open impact
    /// sampled with the normal force.
    pub fn accept_step(
        &mut self,
        (k, joint): (usize, &impl Clearance),
        t: f64,
        (penetration, normal_force): (f64, f64),
    ) -> Result<(), PenetrationError> {
        if !(penetration <= PENETRATION_LIMIT_FRACTION * joint.journal_radius()) {
            return Err(joint.penetration_error(penetration, "step"));
        }
        if let Some(tr) = self.open[k].as_mut() {
            tr.sample(t, normal_force, penetration);
        }
        Ok(())
    }
}

/// The calls a full model answers from its `log` and `strict_modes` fields: the
/// [`lash_ode::OdeSystem`] mode flags and dense-output wish (`ode`), and the run's impacts and
/// pending error (`records`, with the model's error type).
macro_rules! log_calls {
    (ode) => {
        fn begin(&mut self, locates_events: bool) {
            self.strict_modes = locates_events;
        }

        fn take_mode_violation(&mut self) -> bool {
            self.log.take_violation()
        }

        fn wants_dense(&self) -> bool {
            self.log.any_open()
        }
    };
    (records) => {
        /// Completed impacts, per contact.
        pub fn impacts(&self) -> &[Vec<lash_contact::Impact>] {
            &self.log.impacts
        }

        /// Contact `k`'s impact still open at the end of a run (closed at `t` for reporting).
        pub fn open_impact(&self, k: usize, t: f64) -> Option<lash_contact::Impact> {
            self.log.open_impact(k, t)
        }

        /// The first error met inside a right-hand side (a singular solve), if any; cleared.
        pub fn take_error(&mut self) -> Option<crate::full_model::ModelError> {
            self.log.take_error()
        }
    };
}
pub(crate) use log_calls;
