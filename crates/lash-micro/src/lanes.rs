//! Lanes: `L` one-joint planar interface models (independent runs, as in a sweep) advanced by
//! RK4 in lockstep, each arithmetic operation of a step done for all `L` models side by side
//! (arrays of `L` numbers the compiler turns into vector instructions), so that the square roots
//! and divisions of `L` models share the time one model's would take.
//!
//! Every lane computes exactly what [`InterfaceModel::rk4_step`] computes for its model, in the
//! same order (results bit for bit the same; tested): the contact law's two paths (in contact,
//! or in free flight with the onset velocity taken at a first indentation) and the gate of a
//! joint inside its clearance are selections, not branches, and so is the sampling of the open
//! impacts at each step end; what is rare and sequential — a contact opening or closing at the
//! step end, the parabola through an impact's peak — is done lane by lane through the model's own
//! code. A step that a lane cannot take this way (no kept step end to start from) is taken by the
//! model itself.
//!
//! Which models qualify ([`lane_laws`]): one planar revolute clearance joint without a bush, with
//! any contact law and any friction law — the laws are lash-contact's, written once over `Real`
//! for a run and for the lanes ([`LaneLaw::force`], [`lane_coefficient`]). The lanes of one group
//! share the laws' kind (and a contact law's exponent), not their numbers.
//!
//! [`InterfaceModel::rk4_step`]: super::model::InterfaceModel::rk4_step

use super::model::{InterfaceModel, Loads, MassFactor, StepEnd};
use super::stages::{self, Rk4Stage};
use lash_contact::clearance::PENETRATION_LIMIT_FRACTION;
use lash_contact::clearance::{ClearanceJoint, ContactState, ImpactTracker, Tracker};
use lash_contact::clearance::{ContactLaws, PlanarContact, penetration, planar_contact};
use lash_contact::friction::{FrictionLaw, LaneFriction, lane_coefficient};
use lash_contact::law::{LaneLaw, NormalForce, onset_reciprocal};
use lash_core::Ticks;
use lash_core::lane::{F64x8, Real, flag};
use lash_mech::Vec2;
use nalgebra::{SMatrix, SVector};

/// The micro model of one planar clearance joint.
pub type OneJoint = InterfaceModel<ClearanceJoint, 2, 1, 1, 1>;

/// The kinds of a joint's contact and friction laws, which the lanes of one group share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneLaws {
    /// The contact law's kind (with its exponent).
    pub law: LaneLaw,
    /// The friction law's kind.
    pub friction: LaneFriction,
}

impl LaneLaws {
    /// The kinds of a contact law and a friction law.
    pub fn of(law: &NormalForce, friction: &FrictionLaw) -> Self {
        Self { law: LaneLaw::of(law).0, friction: LaneFriction::of(friction).0 }
    }
}

/// The laws' kinds of a model that can run in lanes (one joint without a bush in series), or
/// `None`.
pub fn lane_laws(model: &OneJoint) -> Option<LaneLaws> {
    let joint = &model.joints[0];
    if joint.bush_stiffness.is_finite() || joint.film.is_some() {
        // (A bush in series, or an oil film: run alone.)
        return None;
    }
    Some(LaneLaws::of(&joint.law, &joint.friction))
}

/// How a lane's advance ended: the steps completed, and the failure (time reached, message).
pub type LaneOutcome = Result<(), (usize, f64, lash_contact::PenetrationError)>;

/// Runs advanced together.
pub const LANES: usize = lash_core::lane::LANES;
pub(crate) const L: usize = LANES;

/// One number per lane.
pub(crate) type V = [f64; L];

/// The lanes as one value ([`lash_core::lane`]): [`advance`] runs in a copy compiled for
/// AVX-512 or AVX2 where the CPU has it (chosen at run time), else for the baseline (SSE2 pairs).
type X = F64x8;

/// The lanes of an array in vector registers.
#[inline(always)]
fn x(a: &V) -> X {
    X::from(*a)
}

/// Several arrays of lanes in vector registers.
#[inline(always)]
fn xs<const K: usize>(a: &[V; K]) -> [X; K] {
    std::array::from_fn(|k| x(&a[k]))
}

/// Every lane's (x, y) pair: w, ẇ or ẅ of the step ([`stages::rk4`]'s vectors), kept as arrays
/// (loaded into registers per operation: held in registers across the step's stages, the pairs
/// crowded the contact law's numbers out of them, and the lanes' step measured 15–20 % slower).
#[derive(Clone, Copy)]
struct Plane {
    x: V,
    y: V,
}

impl Plane {
    /// The pair from registers.
    #[inline(always)]
    fn of(px: X, py: X) -> Self {
        Self { x: px.into(), y: py.into() }
    }
}

impl std::ops::Add for Plane {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::of(x(&self.x) + x(&o.x), x(&self.y) + x(&o.y))
    }
}

impl std::ops::Mul<f64> for Plane {
    type Output = Self;
    #[inline(always)]
    fn mul(self, f: f64) -> Self {
        Self::of(x(&self.x) * f, x(&self.y) * f)
    }
}

/// The second to fourth stages of every lane's step ([`stages::rk4`]): the joints and inputs, the
/// terms at the step's middle and end (time past the inputs' node, M̃ with its determinant's
/// reciprocal, the journal's and the bearing's angular velocities), each lane's contact mode and
/// its onset velocity with that velocity's reciprocal.
struct LaterStages<'a, const COMMON: bool> {
    joint: &'a Joint,
    inputs: &'a Inputs,
    middle: (&'a V, &'a ([V; 4], V), &'a (V, V)),
    end: (&'a V, &'a ([V; 4], V), &'a (V, V)),
    in_contact: X,
    onset: (&'a V, &'a V),
}

impl<const COMMON: bool> stages::StageRates<Plane, LaneLoads> for LaterStages<'_, COMMON> {
    #[inline(always)]
    fn rate(&mut self, stage: Rk4Stage, e: Plane, v: Plane) -> (Plane, LaneLoads) {
        let (dt, mass, w) = if stage == Rk4Stage::Fourth { self.end } else { self.middle };
        let loads = self.joint.stage::<COMMON>(e, v, (&w.0, &w.1), self.in_contact, self.onset);
        (self.inputs.acceleration(dt, mass, &loads), loads)
    }
}

/// [`stages::weighted`] of every lane.
#[inline(always)]
fn weighted(y0: &V, k: [&V; 4], h: f64) -> V {
    stages::weighted(x(y0), k.map(x), h).into()
}

/// Each lane's loads at one stage evaluation: on the journal, and the friction load.
#[derive(Clone, Copy)]
struct LaneLoads {
    fx: V,
    fy: V,
    friction: V,
}

/// Per-lane constants of the joint: its geometry and its laws.
struct Joint {
    clearance: V,
    journal_radius: V,
    bearing_radius: V,
    laws: LawLanes,
}

/// One contact's laws in every lane: the laws' kinds, their numbers per lane ([`LaneLaw::of`],
/// [`LaneFriction::of`]) and the contact law's onset velocity floor.
pub(crate) struct LawLanes {
    law: LaneLaw,
    law_numbers: [V; 4],
    pub(crate) floor: V,
    friction: LaneFriction,
    friction_numbers: [V; 4],
}

impl LawLanes {
    /// The laws of each lane's contact, `of(l)` (a contact law and a friction law), of the kinds
    /// `kinds`.
    pub(crate) fn of<'a>(kinds: LaneLaws, of: impl Fn(usize) -> (&'a NormalForce, &'a FrictionLaw)) -> Self {
        // Each lane's numbers (lane-major), then as lanes per number.
        let law: [[f64; 4]; L] = std::array::from_fn(|l| LaneLaw::of(of(l).0).1);
        let friction: [[f64; 4]; L] = std::array::from_fn(|l| LaneFriction::of(of(l).1).1);
        let lanes = |numbers: &[[f64; 4]; L]| std::array::from_fn(|k| std::array::from_fn(|l| numbers[l][k]));
        Self {
            law: kinds.law,
            law_numbers: lanes(&law),
            floor: std::array::from_fn(|l| kinds.law.floor(&law[l])),
            friction: kinds.friction,
            friction_numbers: lanes(&friction),
        }
    }

    /// Whether the contact law is of kind `law`.
    #[inline(always)]
    pub(crate) fn is(&self, law: LaneLaw) -> bool {
        self.law == law
    }
}

/// Per-lane inputs of the interval (values at `input_time` and rates).
struct Inputs {
    time: V,
    mass: [V; 4],
    mass_rate: [V; 4],
    force: [V; 2],
    force_rate: [V; 2],
    moment: [V; 2],
    moment_rate: [V; 2],
    journal_omega: V,
    journal_alpha: V,
    bearing_omega: V,
    bearing_alpha: V,
}

/// The full contact state of each lane (what the model's `states[0]` holds).
#[derive(Clone, Copy)]
struct States {
    ex: V,
    ey: V,
    norm: V,
    nx: V,
    ny: V,
    delta: V,
    delta_dot: V,
    slip: V,
    normal_force: V,
    friction_force: V,
    fx: V,
    fy: V,
}

impl Joint {
    fn of(models: &[&mut OneJoint; L], laws: LaneLaws) -> Self {
        let each = |f: &dyn Fn(&ClearanceJoint) -> f64| std::array::from_fn(|l| f(&models[l].joints[0]));
        Self {
            clearance: each(&|j| j.radial_clearance()),
            journal_radius: each(&|j| j.journal_radius),
            bearing_radius: each(&|j| j.bearing_radius),
            laws: LawLanes::of(laws, |l| (&models[l].joints[0].law, &models[l].joints[0].friction)),
        }
    }

    /// The gated loads of a stage at (e, ė) ([`Joint::contact`], [`gated`]).
    #[inline(always)]
    fn stage<const COMMON: bool>(&self, e: Plane, v: Plane, w: (&V, &V), in_contact: X, onset: (&V, &V)) -> LaneLoads {
        let (ex, ey) = (x(&e.x), x(&e.y));
        let contact = self.contact::<COMMON>((ex, ey, x(&v.x), x(&v.y)), self.geometry(ex, ey), w, in_contact, onset);
        gated(&contact, &self.clearance)
    }

    /// |e| and the penetration δ = |e| − c of every lane at the eccentricity (ex, ey)
    /// ([`penetration`]).
    #[inline(always)]
    fn geometry(&self, ex: X, ey: X) -> (X, X) {
        penetration([ex, ey], x(&self.clearance))
    }

    /// The contact of every lane at (e, ė) with the bodies' angular velocities, each lane in its
    /// mode (`in_contact`, and `onset`: each lane's δ̇⁻ and 1 / max(δ̇⁻, floor), formed where its
    /// onset velocity changes): the laws [`ClearanceJoint::evaluate_relative_as`] evaluates as the
    /// micro model calls it (`contact_at_as`) — the same functions, at eight lanes — the
    /// free-flight lanes' onset velocity taken as δ̇⁺ where they first indent (their reciprocal
    /// formed here, the rare lanes' one division). `geometry` is [`Joint::geometry`] at e. Kept
    /// in registers: a stage of the step reads only its loads ([`gated`]), the step end is stored
    /// whole ([`Contact::store`]).
    #[inline(always)]
    fn contact<const COMMON: bool>(
        &self,
        (ex, ey, u, v): (X, X, X, X),
        (norm, delta): (X, X),
        (wj, wb): (&V, &V),
        in_contact: X,
        (onset, reciprocal): (&V, &V),
    ) -> Contact {
        let radii = [x(&self.journal_radius), x(&self.bearing_radius)];
        let laws = LaneContact::<COMMON> { laws: &self.laws, in_contact, onset: (x(onset), x(reciprocal)) };
        let c = planar_contact(&laws, [ex, ey], (norm, delta), [u, v], [x(wj), x(wb)], radii);
        Contact { ex, ey, norm, delta, c }
    }
}

/// The laws of every lane's contact in a stage ([`Joint::contact`]): each lane's law at its
/// onset velocity and reciprocal (`onset`), a lane in free flight (`in_contact` clear) that
/// already indents at its own δ̇ (≥ 0), as the model takes it. `COMMON`: the law is
/// [`COMMON_LAW`].
pub(crate) struct LaneContact<'a, const COMMON: bool> {
    pub(crate) laws: &'a LawLanes,
    pub(crate) in_contact: X,
    pub(crate) onset: (X, X),
}

impl<const COMMON: bool> ContactLaws<X> for LaneContact<'_, COMMON> {
    #[inline(always)]
    fn normal_force(&self, delta: X, delta_dot: X) -> X {
        let zero = X::ZERO;
        let indenting = !self.in_contact & delta.simd_gt(zero);
        let (onset, reciprocal) = if indenting.to_bitmask() == 0 {
            self.onset
        } else {
            let own = delta_dot.max(zero);
            let reciprocal = onset_reciprocal(own, x(&self.laws.floor));
            (indenting.select(own, self.onset.0), indenting.select(reciprocal, self.onset.1))
        };
        // (The common law, Lankarani–Nikravesh's kind at exponent 1.5, known at compile time: the
        // kind's and the exponent's tests fold away.)
        let law = if COMMON { COMMON_LAW } else { self.laws.law };
        law.force(&xs(&self.laws.law_numbers), (delta, delta_dot), onset, reciprocal).max(zero)
    }
    #[inline(always)]
    fn friction_coefficient(&self, slip: X) -> X {
        lane_coefficient(self.laws.friction, &xs(&self.laws.friction_numbers), slip)
    }
}

/// The contact of every lane at one state ([`Joint::contact`]): the eccentricity, |e|, δ and the
/// rest of [`planar_contact`]'s result.
#[derive(Clone, Copy)]
struct Contact {
    ex: X,
    ey: X,
    norm: X,
    delta: X,
    c: PlanarContact<X>,
}

impl Contact {
    /// As the lanes' contact states.
    #[inline(always)]
    fn store(&self, out: &mut States) {
        let c = &self.c;
        out.ex = self.ex.into();
        out.ey = self.ey.into();
        out.norm = self.norm.into();
        out.nx = c.normal[0].into();
        out.ny = c.normal[1].into();
        out.delta = self.delta.into();
        out.delta_dot = c.penetration_rate.into();
        out.slip = c.slip.into();
        out.normal_force = c.normal_force.into();
        out.friction_force = c.friction_force.into();
        out.fx = c.load[0].into();
        out.fy = c.load[1].into();
    }
}

impl Inputs {
    fn of(models: &[&mut OneJoint; L]) -> Self {
        let each = |f: &dyn Fn(&OneJoint) -> f64| std::array::from_fn(|l| f(models[l]));
        let m = |i: usize, j: usize| each(&|x| x.inputs.effective_mass[(i, j)]);
        let r = |i: usize, j: usize| each(&|x| x.inputs.effective_mass_rate[(i, j)]);
        Self {
            time: each(&|x| x.input_time),
            mass: [m(0, 0), m(0, 1), m(1, 0), m(1, 1)],
            mass_rate: [r(0, 0), r(0, 1), r(1, 0), r(1, 1)],
            force: [each(&|x| x.inputs.effective_force[0]), each(&|x| x.inputs.effective_force[1])],
            force_rate: [each(&|x| x.inputs.effective_force_rate[0]), each(&|x| x.inputs.effective_force_rate[1])],
            moment: [each(&|x| x.inputs.friction_moment_force[0]), each(&|x| x.inputs.friction_moment_force[1])],
            moment_rate: [
                each(&|x| x.inputs.friction_moment_force_rate[0]),
                each(&|x| x.inputs.friction_moment_force_rate[1]),
            ],
            journal_omega: each(&|x| x.inputs.journal_angular_velocity[0]),
            journal_alpha: each(&|x| x.inputs.journal_angular_acceleration[0]),
            bearing_omega: each(&|x| x.inputs.bearing_angular_velocity[0]),
            bearing_alpha: each(&|x| x.inputs.bearing_angular_acceleration[0]),
        }
    }

    /// M̃ + Ṁ dt of every lane and its determinant's reciprocal ([`stages::planar_mass`]).
    #[inline(always)]
    fn mass_at(&self, dt: &V) -> ([V; 4], V) {
        let (m, inv) = stages::planar_mass(xs(&self.mass), xs(&self.mass_rate), x(dt));
        ([m[0].into(), m[1].into(), m[2].into(), m[3].into()], inv.into())
    }

    /// ẅ of every lane: M̃⁻¹ (f̃ + ḟ dt + f_c + (H + Ḣ dt) F_T), the friction term only where
    /// F_T ≠ 0 (the functions of [`InterfaceModel`]'s `acceleration_with`).
    #[inline(always)]
    fn acceleration(&self, dt: &V, (m, inv): &([V; 4], V), loads: &LaneLoads) -> Plane {
        let force = (xs(&self.force), xs(&self.force_rate));
        let map = (xs(&self.moment), xs(&self.moment_rate));
        let r = stages::planar_load(force, x(dt), [x(&loads.fx), x(&loads.fy)], map, x(&loads.friction));
        let [ax, ay] = stages::planar_solve((&xs(m), x(inv)), r);
        Plane::of(ax, ay)
    }
}

/// The loads of a contact with the micro model's gate: nothing for a lane whose journal is
/// inside its clearance (|e|² ≤ c², `loads_at`).
#[inline(always)]
fn gated(c: &Contact, clearance: &V) -> LaneLoads {
    let (ex, ey, r) = (c.ex, c.ey, x(clearance));
    let outside = (ex * ex + ey * ey).simd_gt(r * r);
    LaneLoads {
        fx: outside.select(c.c.load[0], X::ZERO).into(),
        fy: outside.select(c.c.load[1], X::ZERO).into(),
        friction: outside.select(c.c.friction_force, X::ZERO).into(),
    }
}

/// Writes lane `l` of `s` as a contact state.
fn state_of(s: &States, l: usize) -> ContactState {
    ContactState {
        journal_centre: Vec2::zeros(),
        eccentricity: Vec2::new(s.ex[l], s.ey[l]),
        eccentricity_norm: s.norm[l],
        normal: Vec2::new(s.nx[l], s.ny[l]),
        penetration: s.delta[l],
        penetration_rate: s.delta_dot[l],
        slip_velocity: s.slip[l],
        normal_force: s.normal_force[l],
        friction_force: s.friction_force[l],
        force_on_journal: Vec2::new(s.fx[l], s.fy[l]),
    }
}

/// The lanes' state between steps: (w, ẇ), impulses, the kept step end (time, loads, factor).
struct Kept {
    ex: V,
    ey: V,
    vx: V,
    vy: V,
    impulse: [V; 2],
    friction_impulse: V,
    end_time: V,
    end_loads: LaneLoads,
    end_mass: ([V; 4], V),
    /// The kept factor was formed with the current inputs.
    end_inputs: [bool; L],
    states: States,
    /// Each lane's open impact, followed here (next to the lanes' numbers, not behind each
    /// model's pointers) and written back with the rest of the lane.
    trackers: Trackers,
}

/// The lanes' open impacts: one [`Tracker`] of eight lanes (next to the lanes' numbers, not
/// behind each model's pointers, and written back with the rest of the lane), sampled at every
/// step end by the single tracker's own code ([`Tracker::sample_where`]). Sampled lane by lane
/// through the models' trackers, this bookkeeping took ~10 % of a sweep of scenario A, whose joint
/// is in contact most of the time.
#[derive(Clone, Copy)]
pub(crate) struct Trackers {
    /// Lanes with an open impact (a mask: all bits set).
    open: X,
    /// Their trackers' numbers (a closed lane's are not read).
    numbers: Tracker<X>,
}

impl Trackers {
    pub(crate) const NONE: Self = Self {
        open: X::ZERO,
        numbers: Tracker {
            onset_time: X::ZERO,
            onset_velocity: X::ZERO,
            peak_force: X::ZERO,
            peak_time: X::ZERO,
            max_penetration: X::ZERO,
            times: [X::ZERO; 3],
            forces: [X::ZERO; 3],
            count: X::ZERO,
            searched: X::ZERO,
        },
    };

    /// Lane `l` takes `tracker`.
    pub(crate) fn set(&mut self, l: usize, tracker: Option<ImpactTracker>) {
        self.open[l] = flag(tracker.is_some());
        let Some(tr) = tracker else { return };
        let n = &mut self.numbers;
        (n.onset_time[l], n.onset_velocity[l]) = (tr.onset_time, tr.onset_velocity);
        (n.peak_force[l], n.peak_time[l], n.max_penetration[l]) = (tr.peak_force, tr.peak_time, tr.max_penetration);
        for k in 0..3 {
            (n.times[k][l], n.forces[k][l]) = (tr.times[k], tr.forces[k]);
        }
        (n.count[l], n.searched[l]) = (tr.count, flag(tr.searched));
    }

    /// Lane `l`'s tracker.
    pub(crate) fn get(&self, l: usize) -> Option<ImpactTracker> {
        let n = &self.numbers;
        (self.open[l].to_bits() != 0).then(|| Tracker {
            onset_time: n.onset_time[l],
            onset_velocity: n.onset_velocity[l],
            peak_force: n.peak_force[l],
            peak_time: n.peak_time[l],
            max_penetration: n.max_penetration[l],
            times: n.times.map(|v| v[l]),
            forces: n.forces.map(|v| v[l]),
            count: n.count[l],
            searched: n.searched[l].to_bits() != 0,
        })
    }

    /// [`ImpactTracker::sample`] at (t, F, δ) for the open trackers of the lanes in `lanes` (a
    /// mask): the parabola's vertex, where a sample follows a peak, lane by lane through the
    /// single tracker's code.
    #[inline(always)]
    pub(crate) fn sample(&mut self, lanes: X, t: X, force: X, penetration: X) {
        let active = lanes & self.open;
        if active.to_bitmask() == 0 {
            return;
        }
        let ready = self.numbers.sample_where(active, t, force, penetration);
        let peaked = (ready & self.numbers.middle_is_peak()).to_bitmask();
        for l in (0..L).filter(|l| peaked >> l & 1 == 1) {
            if let Some(mut tracker) = self.get(l) {
                tracker.offer_vertex();
                (self.numbers.peak_force[l], self.numbers.peak_time[l]) = (tracker.peak_force, tracker.peak_time);
            }
        }
    }
}

impl Kept {
    /// Lane `l` from its model; `false` when its model has no step end to start from at `t`.
    fn gather(&mut self, l: usize, m: &OneJoint, t: f64) -> bool {
        self.ex[l] = m.eccentricity[0];
        self.ey[l] = m.eccentricity[1];
        self.vx[l] = m.eccentricity_rate[0];
        self.vy[l] = m.eccentricity_rate[1];
        self.impulse[0][l] = m.impulse[0];
        self.impulse[1][l] = m.impulse[1];
        self.friction_impulse[l] = m.friction_impulse[0];
        let s = &m.states[0];
        let st = &mut self.states;
        (st.ex[l], st.ey[l], st.norm[l]) = (s.eccentricity.x, s.eccentricity.y, s.eccentricity_norm);
        (st.nx[l], st.ny[l], st.delta[l], st.delta_dot[l]) =
            (s.normal.x, s.normal.y, s.penetration, s.penetration_rate);
        (st.slip[l], st.normal_force[l], st.friction_force[l]) = (s.slip_velocity, s.normal_force, s.friction_force);
        (st.fx[l], st.fy[l]) = (s.force_on_journal.x, s.force_on_journal.y);
        self.trackers.set(l, m.open[0]);
        match m.end_at(t) {
            Some(end) => {
                self.end_time[l] = end.time;
                self.end_loads.fx[l] = end.loads.contact[0];
                self.end_loads.fy[l] = end.loads.contact[1];
                self.end_loads.friction[l] = end.loads.friction[0];
                let f = &end.mass.mass;
                self.end_mass.0[0][l] = f[(0, 0)];
                self.end_mass.0[1][l] = f[(0, 1)];
                self.end_mass.0[2][l] = f[(1, 0)];
                self.end_mass.0[3][l] = f[(1, 1)];
                self.end_mass.1[l] = end.mass.reciprocal_determinant;
                self.end_inputs[l] = end.input_time == m.input_time;
                true
            }
            None => false,
        }
    }

    /// Writes lane `l` back into its model (state, impulses, contact state and step end).
    fn scatter(&self, l: usize, m: &mut OneJoint) {
        m.located = false;
        self.scatter_sampled(l, m);
        m.open[0] = self.trackers.get(l);
        let (mass, inv) = &self.end_mass;
        m.end = Some(StepEnd {
            time: self.end_time[l],
            // (A factor formed before the inputs were last set is not to be kept: no time
            // matches NaN.)
            input_time: if self.end_inputs[l] { m.input_time } else { f64::NAN },
            eccentricity: m.eccentricity,
            eccentricity_rate: m.eccentricity_rate,
            loads: Loads {
                contact: SVector::from([self.end_loads.fx[l], self.end_loads.fy[l]]),
                friction: SVector::from([self.end_loads.friction[l]]),
            },
            mass: MassFactor {
                mass: SMatrix::<f64, 2, 2>::new(mass[0][l], mass[1][l], mass[2][l], mass[3][l]),
                reciprocal_determinant: inv[l],
                reciprocal_diagonal: SVector::zeros(),
            },
        });
    }

    /// What a sample reads of lane `l` (the micro subsystem's outputs): (w, ẇ), the impulses and
    /// the contact state — not the open impact nor the kept step end, which [`Kept::scatter`]
    /// writes when the lane leaves the lanes.
    #[inline]
    fn scatter_sampled(&self, l: usize, m: &mut OneJoint) {
        m.eccentricity = SVector::from([self.ex[l], self.ey[l]]);
        m.eccentricity_rate = SVector::from([self.vx[l], self.vy[l]]);
        m.impulse = SVector::from([self.impulse[0][l], self.impulse[1][l]]);
        m.friction_impulse = SVector::from([self.friction_impulse[l]]);
        m.states[0] = state_of(&self.states, l);
    }
}

/// Advances `L` models (each [`lane_laws`] of kind `friction`, each at its own time `t[l]` with
/// its inputs set) by `record.len()` RK4 steps of `step`, and after each flagged step calls
/// `sample(lane, step index, model)` for every lane still running, in lane order (the model
/// then holds the step's state, rates, impulses and contact state — what the micro subsystem's
/// outputs read —; its open impact and kept step end are written back when the lane leaves the
/// lanes, at the end or where it fails). Like the
/// model's own loop, each lane's penetration is checked after each step; a lane that fails stops
/// there (its outcome says where), the others go on.
///
/// Compiled for the baseline, AVX2 and AVX-512 (`multiversion` detects the CPU's features once
/// and calls the widest copy it has): the same IEEE operations in wider registers, and no fused
/// multiply–add (Rust never fuses a product and a sum by itself), so the bits do not depend on the
/// CPU. With AVX-512 the eight lanes fill one register instead of two, and 32 registers hold what
/// 16 spilled to the stack: ~8 % of a sweep's time. (`multiversion` because it compiles this
/// function alone for AVX-512: pulp's AVX-512 level is a switch for the whole build that also
/// moves faer's kernels, and with them the last bits of the bush's finite-element results, on
/// AVX-512 machines. It takes AVX-512 only on CPUs with Ice Lake's extensions and later, where it
/// does not slow the clock.)
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
pub fn advance(
    models: &mut [&mut OneJoint; L],
    laws: LaneLaws,
    t: [Ticks; L],
    step: Ticks,
    record: &[bool],
    sample: impl FnMut(usize, usize, &OneJoint),
) -> [LaneOutcome; L] {
    // (The common law's own copy of the lanes' step, or any law's.)
    if laws.law == COMMON_LAW {
        advance_lanes::<_, true>(models, laws, t, step, record, sample)
    } else {
        advance_lanes::<_, false>(models, laws, t, step, record, sample)
    }
}

/// The contact law of most scenarios (the hysteresis laws at exponent 1.5), for which the lanes'
/// step is compiled with the law's kind and exponent known: the runtime tests of both cost the
/// lanes' step 3 %.
pub(crate) const COMMON_LAW: LaneLaw = LaneLaw::Hysteresis(1.5);

/// [`advance`] in the instruction set it was dispatched to.
#[inline(always)]
fn advance_lanes<F: FnMut(usize, usize, &OneJoint), const COMMON: bool>(
    models: &mut [&mut OneJoint; L],
    laws: LaneLaws,
    t: [Ticks; L],
    step: Ticks,
    record: &[bool],
    sample: F,
) -> [LaneOutcome; L] {
    let mut lanes = PlanarLanes::<COMMON>::of(models, laws);
    drive(&mut lanes, models, t, step, record, sample)
}

/// The lanes of `L` one-joint planar models: the joint's constants, the inputs, the state
/// between steps ([`Kept`]) and each lane's mode (closed, as flags and as a mask for the lanes'
/// arithmetic, formed again where a lane's mode changes; its δ̇⁻ and 1 / max(δ̇⁻, floor), formed
/// again where its onset changes). `COMMON`: the law is [`COMMON_LAW`].
struct PlanarLanes<const COMMON: bool> {
    joint: Joint,
    inputs: Inputs,
    kept: Kept,
    penetration_limit: V,
    in_contact: [bool; L],
    contact_mask: X,
    onset: V,
    reciprocal: V,
}

impl<const COMMON: bool> PlanarLanes<COMMON> {
    fn of(models: &[&mut OneJoint; L], laws: LaneLaws) -> Self {
        let zero = [0.0; L];
        let states = States {
            ex: zero,
            ey: zero,
            norm: zero,
            nx: zero,
            ny: zero,
            delta: zero,
            delta_dot: zero,
            slip: zero,
            normal_force: zero,
            friction_force: zero,
            fx: zero,
            fy: zero,
        };
        Self {
            joint: Joint::of(models, laws),
            inputs: Inputs::of(models),
            kept: Kept {
                ex: zero,
                ey: zero,
                vx: zero,
                vy: zero,
                impulse: [zero; 2],
                friction_impulse: zero,
                end_time: zero,
                end_loads: LaneLoads { fx: zero, fy: zero, friction: zero },
                end_mass: ([zero; 4], zero),
                end_inputs: [false; L],
                states,
                trackers: Trackers::NONE,
            },
            penetration_limit: std::array::from_fn(|l| PENETRATION_LIMIT_FRACTION * models[l].joints[0].journal_radius),
            in_contact: [false; L],
            contact_mask: X::ZERO,
            onset: zero,
            reciprocal: zero,
        }
    }

    /// Lane `l`'s mode from its model.
    #[inline(always)]
    fn take_mode(&mut self, l: usize, m: &OneJoint) {
        self.in_contact[l] = m.joints[0].in_contact;
        self.contact_mask = X::mask(self.in_contact);
        self.onset[l] = m.joints[0].onset_velocity;
        self.reciprocal[l] = onset_reciprocal(self.onset[l], self.joint.laws.floor[l]);
    }

    /// The kept factor where it was formed with these inputs (after the interval's first step),
    /// else a fresh one at `dt0`.
    #[inline(always)]
    fn start_mass(&self, dt0: &V) -> ([V; 4], V) {
        let mut start = self.kept.end_mass;
        if !self.kept.end_inputs.iter().all(|&k| k) {
            let fresh = self.inputs.mass_at(dt0);
            for l in (0..L).filter(|&l| !self.kept.end_inputs[l]) {
                for k in 0..4 {
                    start.0[k][l] = fresh.0[k][l];
                }
                start.1[l] = fresh.1[l];
            }
        }
        start
    }
}

impl<const COMMON: bool> LaneKind<OneJoint> for PlanarLanes<COMMON> {
    #[inline(always)]
    fn gather(&mut self, l: usize, m: &OneJoint, t: f64) -> bool {
        self.take_mode(l, m);
        self.kept.gather(l, m, t)
    }

    #[inline(always)]
    fn scatter(&self, l: usize, m: &mut OneJoint) {
        self.kept.scatter(l, m);
    }

    #[inline(always)]
    fn scatter_sampled(&self, l: usize, m: &mut OneJoint) {
        self.kept.scatter_sampled(l, m);
    }

    #[inline(always)]
    fn end_time(&self) -> X {
        x(&self.kept.end_time)
    }

    #[inline(always)]
    fn step(&mut self, now: X, h: f64, stepped: X, models: &mut [&mut OneJoint; L]) {
        let (now, inputs, joint) = (<V>::from(now), &self.inputs, &self.joint);
        let dt = |offset: f64| -> V { std::array::from_fn(|l| now[l] + offset - inputs.time[l]) };
        let (dt0, dt_half, dt_end) = (dt(0.0), dt(0.5 * h), dt(h));
        let start = self.start_mass(&dt0);
        let (middle, finish) = (inputs.mass_at(&dt_half), inputs.mass_at(&dt_end));
        let omega = |dt: &V| -> (V, V) {
            (
                std::array::from_fn(|l| inputs.journal_omega[l] + inputs.journal_alpha[l] * dt[l]),
                std::array::from_fn(|l| inputs.bearing_omega[l] + inputs.bearing_alpha[l] * dt[l]),
            )
        };
        let (w_half, w_end) = (omega(&dt_half), omega(&dt_end));
        let kept = &mut self.kept;
        let (e0, v0) = (Plane { x: kept.ex, y: kept.ey }, Plane { x: kept.vx, y: kept.vy });
        // Stage 1 from the kept step end's loads.
        let l1 = kept.end_loads;
        let first = (inputs.acceleration(&dt0, &start, &l1), l1);
        let mut later = LaterStages::<COMMON> {
            joint,
            inputs,
            middle: (&dt_half, &middle, &w_half),
            end: (&dt_end, &finish, &w_end),
            in_contact: self.contact_mask,
            onset: (&self.onset, &self.reciprocal),
        };
        let stepped_to = stages::rk4(h, (e0, v0), first, &mut later);
        let [l1, l2, l3, l4] = stepped_to.loads;
        let (e1, v1) = (stepped_to.eccentricity, stepped_to.eccentricity_rate);
        let (e1x, e1y, v1x, v1y) = (e1.x, e1.y, v1.x, v1.y);
        let (e0x, e0y, v0x, v0y) = (kept.ex, kept.ey, kept.vx, kept.vy);
        let impulse = [
            weighted(&kept.impulse[0], [&l1.fx, &l2.fx, &l3.fx, &l4.fx], h),
            weighted(&kept.impulse[1], [&l1.fy, &l2.fy, &l3.fy, &l4.fy], h),
        ];
        let friction_impulse =
            weighted(&kept.friction_impulse, [&l1.friction, &l2.friction, &l3.friction, &l4.friction], h);
        // Mode switches (rare), lane by lane through the model's own code.
        // (|e| and δ at the step end do not depend on the mode: computed once, before the switch.)
        let end_geometry = joint.geometry(x(&e1x), x(&e1y));
        let closed = end_geometry.1.simd_gt(X::ZERO);
        let switching = (closed ^ self.contact_mask).to_bitmask() & stepped.to_bitmask();
        for l in (0..L).filter(|l| switching >> l & 1 == 1) {
            let m = &mut *models[l];
            m.located = false;
            let (e0, v0) = (SVector::from([e0x[l], e0y[l]]), SVector::from([v0x[l], v0y[l]]));
            let (e1, v1) = (SVector::from([e1x[l], e1y[l]]), SVector::from([v1x[l], v1y[l]]));
            let none = SVector::zeros();
            m.open[0] = self.kept.trackers.get(l);
            m.switch_modes::<false>(now[l], h, (&e0, &v0, &none), (&e1, &v1, &none));
            self.kept.trackers.set(l, m.open[0]);
            self.take_mode(l, m);
        }
        // The step end's contact state (not gated), then the impact trackers.
        let end = self.joint.contact::<COMMON>(
            (x(&e1x), x(&e1y), x(&v1x), x(&v1y)),
            end_geometry,
            (&w_end.0, &w_end.1),
            self.contact_mask,
            (&self.onset, &self.reciprocal),
        );
        let kept = &mut self.kept;
        end.store(&mut kept.states);
        let end_time: V = (x(&now) + X::splat(h)).into();
        kept.trackers.sample(stepped, x(&end_time), end.c.normal_force, end.delta);
        // (Every lane: those stepped by their models are gathered again, failed ones are no
        // longer read.)
        (kept.ex, kept.ey, kept.vx, kept.vy) = (e1x, e1y, v1x, v1y);
        (kept.impulse, kept.friction_impulse) = (impulse, friction_impulse);
        kept.end_time = end_time;
        let [fx, fy] = end.c.load;
        kept.end_loads = LaneLoads { fx: fx.into(), fy: fy.into(), friction: end.c.friction_force.into() };
        kept.end_mass = finish;
        kept.end_inputs = [true; L];
    }

    #[inline(always)]
    fn fine(&self) -> X {
        // (|e| finite: below infinity, and not NaN.)
        let (delta, norm) = (x(&self.kept.states.delta), x(&self.kept.states.norm));
        delta.simd_le(x(&self.penetration_limit)) & norm.abs().simd_lt(X::splat(f64::INFINITY))
    }

    fn model_step(m: &mut OneJoint, t: f64, h: f64) {
        m.rk4_step(t, h);
    }

    fn check(m: &OneJoint) -> Result<(), lash_contact::PenetrationError> {
        m.check_penetration(0)
    }
}

/// A kind of micro model that runs in lanes: what the lanes hold of `L` models between steps
/// and their step — the lanes' own part, for one kind of joint; [`drive`] does what is the same
/// for every kind (which lanes the lanes step, which their models step, which fail, when they
/// are sampled).
pub(crate) trait LaneKind<M> {
    /// Lane `l` from its model at `t` (its state, modes, open impacts and kept step end);
    /// `false` when the model has no step end to start from at `t`.
    fn gather(&mut self, l: usize, m: &M, t: f64) -> bool;
    /// Writes lane `l` back into its model whole (state, open impacts and step end).
    fn scatter(&self, l: usize, m: &mut M);
    /// What a sample reads of lane `l`: the state, the impulses and the contact states.
    fn scatter_sampled(&self, l: usize, m: &mut M);
    /// The time of each lane's kept step end.
    fn end_time(&self) -> X;
    /// One RK4 step of `h` from `now` of every lane; the lanes in `stepped` are the ones whose
    /// results count (mode switches and impacts are theirs alone, lane by lane through their
    /// models).
    fn step(&mut self, now: X, h: f64, stepped: X, models: &mut [&mut M; L]);
    /// The lanes whose penetrations are within the model's limits.
    fn fine(&self) -> X;
    /// The model's own step (a lane without a kept step end).
    fn model_step(m: &mut M, t: f64, h: f64);
    /// The penetration check of the model's own loop, on the model.
    fn check(m: &M) -> Result<(), lash_contact::PenetrationError>;
}

/// Advances the `L` models of `lanes` (each at its own time `t[l]` with its inputs set) by
/// `record.len()` steps of `step`, as [`advance`] describes: a lane without a step end to start
/// from is stepped by its model and taken back afterwards, a lane that fails stops there (its
/// outcome says where) and the others go on, and after each flagged step `sample(lane, step
/// index, model)` is called for every lane still running, in lane order.
#[inline(always)]
pub(crate) fn drive<M, S: LaneKind<M>>(
    lanes: &mut S,
    models: &mut [&mut M; L],
    t: [Ticks; L],
    step: Ticks,
    record: &[bool],
    mut sample: impl FnMut(usize, usize, &M),
) -> [LaneOutcome; L] {
    let h = step.seconds();
    let mut outcome: [LaneOutcome; L] = std::array::from_fn(|_| Ok(()));
    let mut running = [true; L];
    // Lanes whose model takes the step itself (no kept step end to start from).
    let mut by_model: [bool; L] = std::array::from_fn(|l| !lanes.gather(l, models[l], t[l].seconds()));
    // The lanes stepped here (running, not by their models) as a mask, and whether any running
    // lane is stepped by its model: formed again only where a lane changes.
    let masks = |running: &[bool; L], by_model: &[bool; L]| {
        (X::mask(*running) & !X::mask(*by_model), (0..L).any(|l| running[l] && by_model[l]))
    };
    let (mut stepped, mut any_by_model) = masks(&running, &by_model);
    let at = |l: usize, i: usize| Ticks(t[l].0 + i as i64 * step.0).seconds();
    // (The lanes of a sweep share their time: one conversion per step.)
    let shared = t.iter().all(|&x| x == t[0]);
    for (i, &flag) in record.iter().enumerate() {
        let now = if shared { X::splat(at(0, i)) } else { X::from(std::array::from_fn(|l| at(l, i))) };
        // (A step end that is not this instant: possible only for times far from the origin; the
        // model decides what to reuse.)
        let elsewhere = (stepped & (lanes.end_time() - now).abs().simd_ge(X::splat(1e-12))).to_bitmask();
        if elsewhere != 0 {
            for (l, m) in models.iter_mut().enumerate().filter(|(l, _)| elsewhere >> l & 1 == 1) {
                lanes.scatter(l, m);
                by_model[l] = true;
            }
            (stepped, any_by_model) = masks(&running, &by_model);
        }
        // The models that take this step themselves, before the lanes overwrite their numbers.
        let stepping_themselves =
            if any_by_model { std::array::from_fn(|l| running[l] && by_model[l]) } else { [false; L] };
        for (l, m) in models.iter_mut().enumerate().filter(|(l, _)| stepping_themselves[*l]) {
            S::model_step(m, now[l], h);
        }
        lanes.step(now, h, stepped, models);
        // Lanes stepped by their models come back into the lanes.
        if any_by_model {
            for (l, m) in models.iter().enumerate().filter(|(l, _)| stepping_themselves[*l]) {
                by_model[l] = !lanes.gather(l, m, at(l, i + 1));
            }
            (stepped, any_by_model) = masks(&running, &by_model);
        }
        // The penetration check of the model's loop: the lanes' numbers, or the model's where it
        // stepped itself.
        let bad = !lanes.fine().to_bitmask();
        let checked: [bool; L] = std::array::from_fn(|l| running[l] && (by_model[l] || bad >> l & 1 == 1));
        for (l, m) in models.iter_mut().enumerate().filter(|(l, _)| checked[*l]) {
            if !by_model[l] {
                lanes.scatter(l, m);
            }
            if let Err(e) = S::check(m) {
                outcome[l] = Err((i, at(l, i + 1), e));
                running[l] = false;
            }
        }
        if checked.iter().any(|&c| c) {
            (stepped, any_by_model) = masks(&running, &by_model);
        }
        if flag {
            for (l, m) in models.iter_mut().enumerate().filter(|(l, _)| running[*l]) {
                if !by_model[l] {
                    lanes.scatter_sampled(l, m);
                }
                sample(l, i, m);
            }
        }
    }
    for (l, m) in models.iter_mut().enumerate().filter(|(l, _)| running[*l] && !by_model[*l]) {
        lanes.scatter(l, m);
    }
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::InterfaceInputs;
    use lash_contact::friction::FrictionLaw;
    use lash_contact::law::NormalForce;
    use lash_mech::BodyId;

    fn joint(l: usize) -> ClearanceJoint {
        let x = l as f64;
        ClearanceJoint {
            name: format!("pin{l}"),
            journal_body: BodyId::Body(0),
            journal_point: Vec2::zeros(),
            bearing_body: BodyId::Ground,
            bearing_point: Vec2::zeros(),
            journal_radius: 0.0099,
            bearing_radius: 0.01 + 2e-5 * x,
            law: NormalForce::Hysteresis { stiffness: 5e9 * (1.0 + x), exponent: 1.5, chi: 0.1 + 0.1 * x, floor: 1e-4 },
            friction: if l == 3 {
                FrictionLaw::Coulomb { coefficient: 0.05 }
            } else {
                FrictionLaw::Ambrosio { coefficient: 0.1 + 0.02 * x, v0: 1e-4, v1: 1e-3 }
            },
            bush_stiffness: f64::INFINITY,
            bush_damping: 0.0,
            film: None,
            in_contact: false,
            onset_velocity: 0.0,
        }
    }

    /// Interval k's inputs for lane l: a force that turns and now and then reverses (free
    /// flights and impacts), a coupled effective mass and its rate, rotating bodies.
    fn inputs(k: usize, l: usize) -> InterfaceInputs<2, 1, 1> {
        let (x, a) = (l as f64, k as f64 * 0.37 + l as f64);
        let sign = if (k / 7) % 3 == 2 { -1.0 } else { 1.0 };
        let magnitude = sign * (800.0 + 300.0 * x) * (1.0 + 0.3 * (0.9 * k as f64).sin());
        InterfaceInputs {
            effective_mass: nalgebra::Matrix2::new(2.0 + 0.1 * a.sin(), 0.3, 0.3, 3.0 + 0.2 * x),
            effective_mass_rate: nalgebra::Matrix2::new(40.0 * a.cos(), 5.0, 5.0, -20.0),
            effective_force: SVector::from([magnitude * a.cos(), magnitude * a.sin()]),
            effective_force_rate: SVector::from([-3e4 * a.sin(), 3e4 * a.cos()]),
            friction_moment_force: SMatrix::from([[0.02 * x, -0.01]]),
            friction_moment_force_rate: SMatrix::from([[0.5, 0.1 * x]]),
            journal_angular_velocity: [400.0 + 50.0 * x],
            journal_angular_acceleration: [1e3 * a.cos()],
            bearing_angular_velocity: [-20.0 * x],
            bearing_angular_acceleration: [0.0],
        }
    }

    fn same(a: &OneJoint, b: &OneJoint) -> String {
        let show = |m: &OneJoint| {
            format!(
                "{:?} {:?} {:?} {:?} {:?} {} {:?} {:?}",
                m.eccentricity.as_slice(),
                m.eccentricity_rate.as_slice(),
                m.impulse.as_slice(),
                m.friction_impulse.as_slice(),
                m.states[0],
                m.joints[0].in_contact,
                m.joints[0].onset_velocity.to_bits(),
                m.impacts[0]
            )
        };
        let (x, y) = (show(a), show(b));
        if x == y { String::new() } else { format!("lanes {x}\nmodel {y}") }
    }

    /// The instruction sets [`advance`] is compiled for that this CPU has: the baseline and AVX2
    /// through pulp's dispatch, and `advance` itself (its widest copy this CPU runs: AVX-512 on
    /// CPUs with Ice Lake's AVX-512 extensions and later).
    fn instruction_sets() -> Vec<(&'static str, Option<pulp::Arch>)> {
        #[allow(unused_mut)]
        let mut sets = vec![("baseline", Some(pulp::Arch::Scalar))];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = pulp::x86::V3::try_new() {
                sets.push(("AVX2", Some(pulp::Arch::V3(s))));
            }
        }
        sets.push(("advance's own dispatch", None));
        sets
    }

    /// Eight lanes of different joints, laws and inputs, stepped through 120 intervals of 100
    /// steps (contact, sliding, free flights and impacts), equal the models stepped one by one,
    /// bit for bit: states, impulses, modes, impacts and every sampled state.
    #[test]
    fn lanes_equal_the_models_stepped_one_by_one_bit_for_bit() {
        for (name, arch) in instruction_sets() {
            eprintln!("lanes compiled for {name}");
            lanes_equal_the_models_on(arch);
        }
    }

    fn lanes_equal_the_models_on(arch: Option<pulp::Arch>) {
        let mut lanes: Vec<OneJoint> = (0..L).map(|l| InterfaceModel::new(vec![joint(l)])).collect();
        let mut models = lanes.clone();
        let laws = lane_laws(&lanes[0]).unwrap();
        assert_eq!(lane_laws(&lanes[3]).map(|k| k.friction), Some(LaneFriction::Coulomb));
        assert_eq!(lane_laws(&lanes[4]).map(|k| k.friction), Some(LaneFriction::Ambrosio));
        let (impacts, sampled) = lanes_against_models(&mut lanes, &mut models, laws, arch, 120);
        assert!(impacts >= 8, "the inputs should make impacts: {impacts}");
        assert_eq!(sampled, 120 * 10 * L);
    }

    /// `lanes` stepped in lanes (laws `laws`, compiled for `arch`, or `advance`'s own dispatch)
    /// and `models` one by one through `intervals` intervals of 100 steps, compared bit for bit
    /// after each: their impacts and the samples compared.
    fn lanes_against_models(
        lanes: &mut [OneJoint],
        models: &mut [OneJoint],
        laws: LaneLaws,
        arch: Option<pulp::Arch>,
        intervals: usize,
    ) -> (usize, usize) {
        let step = Ticks::from_seconds(1e-5).unwrap();
        let h = step.seconds();
        let record: Vec<bool> = (0..100).map(|i| i % 10 == 9).collect();
        let (mut impacts, mut sampled) = (0, 0);
        for k in 0..intervals {
            let t0 = Ticks(k as i64 * 100 * step.0);
            for l in 0..L {
                for m in [&mut lanes[l], &mut models[l]] {
                    m.inputs = inputs(k, l);
                    m.input_time = t0.seconds();
                }
            }
            // The models one by one, as the micro subsystem's loop steps them.
            let mut expected = vec![Vec::new(); L];
            for (l, m) in models.iter_mut().enumerate() {
                for (i, &flag) in record.iter().enumerate() {
                    m.rk4_step(Ticks(t0.0 + i as i64 * step.0).seconds(), h);
                    if let Err(e) = m.check_penetration(0) {
                        panic!("{:?} {:?}: {e}", m.joints[0].law, m.joints[0].friction);
                    }
                    if flag {
                        expected[l].push(format!("{i} {:?}", m.states[0]));
                    }
                }
            }
            let mut got = vec![Vec::new(); L];
            let mut group: [&mut OneJoint; L] =
                lanes.iter_mut().collect::<Vec<_>>().try_into().unwrap_or_else(|_| unreachable!("L models"));
            let sample = |l: usize, i: usize, m: &OneJoint| got[l].push(format!("{i} {:?}", m.states[0]));
            let outcome = match arch {
                Some(arch) => arch.dispatch(
                    #[inline(always)]
                    || match laws.law == COMMON_LAW {
                        true => advance_lanes::<_, true>(&mut group, laws, [t0; L], step, &record, sample),
                        false => advance_lanes::<_, false>(&mut group, laws, [t0; L], step, &record, sample),
                    },
                ),
                None => advance(&mut group, laws, [t0; L], step, &record, sample),
            };
            for l in 0..L {
                assert!(outcome[l].is_ok(), "{laws:?}, lane {l}: {:?}", outcome[l]);
                assert_eq!(got[l], expected[l], "{laws:?}, interval {k}, lane {l}: samples");
                let diff = same(&lanes[l], &models[l]);
                assert!(diff.is_empty(), "{laws:?}, interval {k}, lane {l}:\n{diff}");
                sampled += got[l].len();
            }
        }
        for m in models.iter() {
            impacts += m.impacts[0].len();
        }
        (impacts, sampled)
    }

    /// Every contact law (δⁿ by δ√δ, by δ and by `powf`) with every friction law, eight lanes of
    /// different numbers per group: the lanes equal the models stepped one by one, bit for bit,
    /// in every instruction set, through impacts.
    #[test]
    fn every_law_runs_in_lanes_bit_for_bit() {
        let laws: [fn(f64) -> NormalForce; 8] = [
            |x| NormalForce::Power { stiffness: 5e9 * (1.0 + 0.1 * x), exponent: 1.5 },
            |x| NormalForce::Power { stiffness: 2e8 * (1.0 + 0.1 * x), exponent: 1.0 },
            |x| NormalForce::Power { stiffness: 1e10 * (1.0 + 0.1 * x), exponent: 1.6 },
            |x| NormalForce::KelvinVoigt { stiffness: 2e8 * (1.0 + 0.1 * x), damping: 2e3 },
            |x| NormalForce::Hysteresis { stiffness: 5e9 * (1.0 + 0.1 * x), exponent: 1.3, chi: 0.2, floor: 1e-4 },
            |x| NormalForce::AdamsImpact {
                stiffness: 5e9 * (1.0 + 0.1 * x),
                exponent: 1.5,
                max_damping: 1e4 * (1.0 + 0.1 * x),
                damping_depth: 1e-6,
            },
            |x| NormalForce::AdamsImpact {
                stiffness: 5e10,
                exponent: 2.2,
                max_damping: 2e4,
                damping_depth: 1e-6 * (1.0 + 0.1 * x),
            },
            |x| NormalForce::Liu { factor: 3e9 * (1.0 + 0.1 * x), clearance: 1e-4, chi: 0.1 + 0.05 * x, floor: 1e-4 },
        ];
        let frictions: [fn(f64) -> FrictionLaw; 5] = [
            |_| FrictionLaw::None,
            |x| FrictionLaw::Coulomb { coefficient: 0.02 + 0.002 * x },
            |x| FrictionLaw::Ambrosio { coefficient: 0.03, v0: 1e-4 * (1.0 + x), v1: 1e-3 },
            |x| FrictionLaw::AdamsStickSlip {
                static_coefficient: 0.03,
                dynamic_coefficient: 0.02 + 0.001 * x,
                stiction_velocity: 1e-3,
                friction_velocity: 5e-3 * (1.0 + x),
            },
            |x| FrictionLaw::Threlfall { coefficient: 0.02 + 0.002 * x, v0: 1e-3 },
        ];
        for law in laws {
            for friction in frictions {
                let lanes: Vec<OneJoint> = (0..L)
                    .map(|l| {
                        let mut j = joint(l);
                        (j.law, j.friction) = (law(l as f64), friction(l as f64));
                        InterfaceModel::new(vec![j])
                    })
                    .collect();
                let models = lanes.clone();
                let kinds = lane_laws(&lanes[0]).unwrap();
                assert!(lanes.iter().all(|m| lane_laws(m) == Some(kinds)), "one group: {kinds:?}");
                for (_, arch) in instruction_sets() {
                    let (mut l, mut m) = (lanes.clone(), models.clone());
                    let (impacts, _) = lanes_against_models(&mut l, &mut m, kinds, arch, 40);
                    assert!(impacts >= L, "{kinds:?}: every lane should meet an impact, {impacts} in all");
                }
            }
        }
    }

    /// A joint with a bush in series does not run in lanes; any laws do.
    #[test]
    fn only_a_bush_keeps_a_joint_out_of_the_lanes() {
        let mut j = joint(0);
        (j.law, j.friction) =
            (NormalForce::Liu { factor: 1e9, clearance: 1e-4, chi: 0.1, floor: 1e-4 }, FrictionLaw::None);
        assert!(lane_laws(&InterfaceModel::new(vec![j.clone()])).is_some());
        j.bush_stiffness = 1e8;
        assert!(lane_laws(&InterfaceModel::new(vec![j])).is_none());
    }

    /// A lane that blows up (a soft contact under a large force: the penetration passes a tenth
    /// of the journal radius) stops where its model's loop stops, with the same message; the
    /// other lanes go on as if it were not there.
    #[test]
    fn a_lane_that_fails_stops_like_its_model_and_the_others_go_on() {
        let step = Ticks::from_seconds(1e-5).unwrap();
        let h = step.seconds();
        let mut lanes: Vec<OneJoint> = (0..L).map(|l| InterfaceModel::new(vec![joint(l)])).collect();
        if let NormalForce::Hysteresis { stiffness, .. } = &mut lanes[5].joints[0].law {
            *stiffness = 1e3;
        }
        let mut models = lanes.clone();
        let record = [false; 100];
        let laws = lane_laws(&lanes[0]).unwrap();
        for k in 0..5 {
            let t0 = Ticks(k as i64 * 100 * step.0);
            for l in 0..L {
                for m in [&mut lanes[l], &mut models[l]] {
                    m.inputs = inputs(0, l);
                    m.input_time = t0.seconds();
                }
            }
            let mut expected: Vec<LaneOutcome> = Vec::new();
            for m in models.iter_mut() {
                let mut result = Ok(());
                for i in 0..record.len() {
                    let t = Ticks(t0.0 + i as i64 * step.0);
                    m.rk4_step(t.seconds(), h);
                    if let Err(e) = m.check_penetration(0) {
                        result = Err((i, Ticks(t.0 + step.0).seconds(), e));
                        break;
                    }
                }
                expected.push(result);
            }
            let mut group: [&mut OneJoint; L] =
                lanes.iter_mut().collect::<Vec<_>>().try_into().unwrap_or_else(|_| unreachable!("L models"));
            let outcome = advance(&mut group, laws, [t0; L], step, &record, |_, _, _| {});
            assert_eq!(outcome.to_vec(), expected, "interval {k}");
            if expected[5].is_err() {
                for l in 0..L {
                    let diff = same(&lanes[l], &models[l]);
                    assert!(diff.is_empty(), "lane {l}:\n{diff}");
                }
                assert!(expected.iter().enumerate().all(|(l, e)| e.is_ok() == (l != 5)));
                return;
            }
        }
        panic!("the soft lane never failed");
    }
}
