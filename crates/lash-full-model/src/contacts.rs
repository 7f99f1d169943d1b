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
