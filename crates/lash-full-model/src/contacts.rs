//! A full model's contact bookkeeping, written once for every shape of clearance joint (planar
//! revolute, translational, spherical) through [`JointContacts`]: the event functions, the mode
//! switches, the impacts' dense-output search and the checks at an accepted step.
//!
//! A model numbers its contacts kind of joint after kind of joint; each function here takes one
//! kind's joints (`joints`, contacts `J::CONTACTS` each) with `first`, the model's number of their
//! first contact, under which the [`ImpactLog`] keeps them.

use crate::impact_log::ImpactLog;
use lash_contact::clearance::{PenetrationError, StepSearch};
use lash_contact::joint::{Clearance, ContactNumbers, JointContacts};
use lash_mech::{BodyId, Pose};
use lash_spatial::constraints::BodyFrame;

/// The bodies' poses at one state, as joints whose frames are `F` read them.
pub(crate) trait Frames<F> {
    /// The pose of `body`.
    fn frame(&self, body: BodyId) -> F;
}

/// A planar state's poses, each computed from (q, q̇) when a joint asks.
pub(crate) struct PlanarFrames<'a> {
    pub q: &'a [f64],
    pub qd: &'a [f64],
}

impl Frames<Pose> for PlanarFrames<'_> {
    fn frame(&self, body: BodyId) -> Pose {
        Pose::of(body, self.q, self.qd)
    }
}

/// A spatial state's frames, computed beforehand (one per body).
pub(crate) struct SpatialFrames<'a>(pub &'a [BodyFrame]);

impl Frames<BodyFrame> for SpatialFrames<'_> {
    fn frame(&self, body: BodyId) -> BodyFrame {
        match body {
            BodyId::Body(k) => self.0[k],
            BodyId::Ground => BodyFrame::ground(),
        }
    }
}

/// The number of contacts of `joints`.
pub(crate) fn count<J: JointContacts>(joints: &[J]) -> usize {
    joints.len() * J::CONTACTS
}

/// Contact `k` of `joints` (contact `k % CONTACTS` of joint `k / CONTACTS`).
pub(crate) fn contact<J: JointContacts>(joints: &[J], k: usize) -> &J::Contact {
    joints[k / J::CONTACTS].contact(k % J::CONTACTS)
}

/// Contact `k`'s numbers at `frames` under onset velocity `onset`, its joint's bush deflected by
/// `deflection(joint)`.
pub(crate) fn numbers<J: JointContacts>(
    joints: &[J],
    k: usize,
    frames: &impl Frames<J::Frame>,
    deflection: impl Fn(usize) -> Option<f64>,
    onset: f64,
) -> ContactNumbers {
    let j = k / J::CONTACTS;
    let joint = &joints[j];
    let [a, b] = joint.bodies();
    joint.contact_numbers([&frames.frame(a), &frames.frame(b)], k % J::CONTACTS, onset, deflection(j))
}

/// Every contact of `joints` open (a run begins).
pub(crate) fn open_all<J: JointContacts>(joints: &mut [J]) {
    for joint in joints {
        (0..J::CONTACTS).for_each(|k| joint.contact_mut(k).set_mode(false, 0.0));
    }
}

/// The event functions of `joints`' contacts, one per contact into `g`: the indentation in free
/// flight, its negative in contact.
pub(crate) fn events<J: JointContacts>(
    joints: &[J],
    frames: &impl Frames<J::Frame>,
    deflection: impl Fn(usize) -> Option<f64>,
    g: &mut [f64],
) {
    for (k, g) in g.iter_mut().enumerate().take(count(joints)) {
        let indentation = numbers(joints, k, frames, &deflection, 0.0).indentation;
        *g = if contact(joints, k).in_contact() { -indentation } else { indentation };
    }
}

/// Contact `k` of `joints` begins or ends at `t` (see [`ImpactLog::switch`]), with its own
/// approach rate at `frames` as onset velocity.
#[allow(clippy::too_many_arguments)]
pub(crate) fn switch<J: JointContacts>(
    (joints, first): (&mut [J], usize),
    k: usize,
    frames: &impl Frames<J::Frame>,
    deflection: impl Fn(usize) -> Option<f64>,
    log: &mut ImpactLog,
    t: f64,
    searched: bool,
) {
    let rate = numbers(joints, k, frames, deflection, f64::INFINITY).indentation_rate;
    let contact = joints[k / J::CONTACTS].contact_mut(k % J::CONTACTS);
    log.switch((first + k, contact), t, rate, searched);
}

/// A run starts at `t` at `frames`, every contact of `joints` open: each contact that already
/// indents closes there (see [`switch`]).
pub(crate) fn start<J: JointContacts>(
    (joints, first): (&mut [J], usize),
    frames: &impl Frames<J::Frame>,
    deflection: impl Fn(usize) -> Option<f64>,
    log: &mut ImpactLog,
    (t, searched): (f64, bool),
) {
    for k in 0..count(joints) {
        if numbers(joints, k, frames, &deflection, 0.0).indentation > 0.0 {
            switch((&mut *joints, first), k, frames, &deflection, log, t, searched);
        }
    }
}

/// At an accepted step's end `t` (`frames`): each contact's penetration checked and its open
/// impact sampled (see [`ImpactLog::accept_step`]).
pub(crate) fn accept_step<J: JointContacts>(
    (joints, first): (&[J], usize),
    frames: &impl Frames<J::Frame>,
    deflection: impl Fn(usize) -> Option<f64>,
    log: &mut ImpactLog,
    t: f64,
) -> Result<(), PenetrationError> {
    for k in 0..count(joints) {
        let c = contact(joints, k);
        let s = numbers(joints, k, frames, &deflection, c.onset_velocity());
        log.accept_step((first + k, c), t, (s.penetration, s.normal_force))?;
    }
    Ok(())
}

/// Each open impact of `joints` searches its force along the step from `t` of size `h`
/// (`numbers_at(θ, k, onset)`: contact `k`'s numbers at θ of the step under `onset`).
pub(crate) fn search_open<J: JointContacts>(
    (joints, first): (&[J], usize),
    log: &mut ImpactLog,
    (t, h): (f64, f64),
    mut numbers_at: impl FnMut(f64, usize, f64) -> ContactNumbers,
) {
    for k in 0..count(joints) {
        if !log.is_open(first + k) {
            continue;
        }
        let onset = contact(joints, k).onset_velocity();
        let search = StepSearch::run_with(t, h, |theta| {
            let s = numbers_at(theta, k, onset);
            (s.normal_force, s.penetration)
        });
        log.accept_search(first + k, search);
    }
}

/// A right-hand side's stage found `contact` in state `s`, with the contact's own indentation
/// and its rate `(indentation, rate)`. A stage outside the contact's mode is flagged (the
/// integrator then cuts or rejects the step). A free-flight stage that penetrates gets no force
/// (`free(s)`) when the integrator locates events (`strict`: the right side stays smooth in its
/// mode, so the error control is not fooled by the switching surface); under fixed-step RK4 it
/// gets the contact force with its own approach rate as onset velocity (`at(onset)`).
pub(crate) fn in_mode<S>(
    contact: &impl Clearance,
    (indentation, rate): (f64, f64),
    (log, strict): (&mut ImpactLog, bool),
    s: S,
    free: impl FnOnce(S) -> S,
    at: impl FnOnce(f64) -> S,
) -> S {
    if (indentation > 0.0) != contact.in_contact() {
        log.flag_violation();
        if !contact.in_contact() && indentation > 0.0 {
            return if strict { free(s) } else { at(rate.max(0.0)) };
        }
    }
    s
}

#[cfg(test)]
mod tests {
    //! The bookkeeping against a mock joint of two contacts whose numbers are set by hand: each
    //! function must reach the right contact of the right joint and keep it under the model's
    //! number `first + k` in the log.
    use super::*;
    use lash_contact::clearance::PENETRATION_LIMIT_FRACTION;
    use lash_contact::joint::ContactModes;

    #[derive(Debug, Clone, Default)]
    struct Mode {
        in_contact: bool,
        onset: f64,
    }

    impl Clearance for Mode {
        const KIND: &'static str = "mock joint";
        const RADIUS: &'static str = "unit length";
        fn name(&self) -> &str {
            "mock"
        }
        fn journal_radius(&self) -> f64 {
            1.0
        }
        fn radial_clearance(&self) -> f64 {
            0.01
        }
        fn in_contact(&self) -> bool {
            self.in_contact
        }
        fn onset_velocity(&self) -> f64 {
            self.onset
        }
        fn set_mode(&mut self, in_contact: bool, onset_velocity: f64) {
            (self.in_contact, self.onset) = (in_contact, onset_velocity);
        }
    }

    /// Contact k indents by `gaps[k]` plus the frame's value less the bush's deflection, at the
    /// rate `rates[k]`; its force is 1000 N per metre of indentation when it indents.
    #[derive(Debug, Clone, Default)]
    struct Mock {
        modes: [Mode; 2],
        gaps: [f64; 2],
        rates: [f64; 2],
    }

    impl ContactModes for Mock {
        type Contact = Mode;
        const CONTACTS: usize = 2;
        fn contact(&self, k: usize) -> &Mode {
            &self.modes[k]
        }
        fn contact_mut(&mut self, k: usize) -> &mut Mode {
            &mut self.modes[k]
        }
    }

    impl JointContacts for Mock {
        type Frame = f64;
        fn bodies(&self) -> [BodyId; 2] {
            [BodyId::Body(0), BodyId::Ground]
        }
        fn contact_numbers(&self, [a, _]: [&f64; 2], k: usize, _onset: f64, deflection: Option<f64>) -> ContactNumbers {
            let penetration = self.gaps[k] + a;
            let indentation = penetration - deflection.unwrap_or(0.0);
            ContactNumbers {
                indentation,
                indentation_rate: self.rates[k],
                penetration,
                normal_force: 1000.0 * indentation.max(0.0),
            }
        }
    }

    /// Every body at the value `.0`.
    struct At(f64);

    impl Frames<f64> for At {
        fn frame(&self, _body: BodyId) -> f64 {
            self.0
        }
    }

    fn joints(gaps: [[f64; 2]; 2]) -> Vec<Mock> {
        gaps.iter().map(|&gaps| Mock { gaps, rates: [0.5, -0.5], ..Mock::default() }).collect()
    }

    #[test]
    fn events_are_each_contacts_indentation_signed_by_its_mode() {
        let mut js = joints([[-1e-3, 2e-3], [3e-3, -4e-3]]);
        js[1].modes[0].in_contact = true;
        let mut g = [0.0; 4];
        // Joint 1 carries a bush deflected by 1e-3: its contacts' indentations are 1e-3 less.
        events(&js, &At(0.0), |j| (j == 1).then_some(1e-3), &mut g);
        assert_eq!(g, [-1e-3, 2e-3, -(3e-3 - 1e-3), -4e-3 - 1e-3]);
    }

    #[test]
    fn a_switch_opens_and_closes_the_impact_of_the_contact_under_the_models_number() {
        let mut js = joints([[0.0; 2]; 2]);
        let (first, mut log) = (3, ImpactLog::new(7));
        // Contact 2 of these joints is joint 1's first contact, the model's contact 5.
        switch((&mut js, first), 2, &At(0.0), |_| None, &mut log, 0.1, false);
        assert!(js[1].modes[0].in_contact && !js[0].modes[0].in_contact && !js[1].modes[1].in_contact);
        assert_eq!(js[1].modes[0].onset, 0.5, "the onset velocity is the contact's approach rate");
        assert!(log.is_open(5) && (0..7).filter(|&k| log.is_open(k)).count() == 1);
        switch((&mut js, first), 2, &At(0.0), |_| None, &mut log, 0.2, false);
        assert!(!js[1].modes[0].in_contact && !log.is_open(5));
        assert_eq!(log.impacts[5].len(), 1);
        assert_eq!((log.impacts[5][0].onset_time, log.impacts[5][0].duration), (0.1, 0.1));
    }

    #[test]
    fn a_run_starts_in_contact_where_a_contact_already_indents() {
        let mut js = joints([[-1e-3, 2e-3], [3e-3, -4e-3]]);
        let mut log = ImpactLog::new(4);
        start((&mut js, 0), &At(0.0), |_| None, &mut log, (0.0, true));
        let closed: Vec<bool> = js.iter().flat_map(|j| j.modes.iter().map(|m| m.in_contact)).collect();
        assert_eq!(closed, [false, true, true, false]);
        assert_eq!((0..4).map(|k| log.is_open(k)).collect::<Vec<_>>(), closed);
    }

    #[test]
    fn a_step_end_past_the_blow_up_limit_names_the_joint() {
        let js = joints([[0.0; 2], [0.0, PENETRATION_LIMIT_FRACTION * 1.5]]);
        let mut log = ImpactLog::new(6);
        let e = accept_step((&js, 2), &At(0.0), |_| None, &mut log, 0.3).unwrap_err();
        assert_eq!((e.joint.as_str(), e.kind, e.penetration), ("mock", "mock joint", PENETRATION_LIMIT_FRACTION * 1.5));
        let fine = joints([[0.0; 2], [0.0, PENETRATION_LIMIT_FRACTION * 0.5]]);
        assert!(accept_step((&fine, 2), &At(0.0), |_| None, &mut log, 0.3).is_ok());
    }
}
