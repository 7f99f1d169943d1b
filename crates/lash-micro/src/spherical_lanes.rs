//! Lanes of spherical clearance joints: `L` micro models of K spherical joints each (independent
//! runs of a spatial mechanism, as in a sweep) advanced by RK4 in lockstep, each lane bit for bit
//! its model's [`InterfaceModel::rk4_step`] (tested).
//!
//! The arithmetic is the single run's, called on eight lanes: the contact
//! ([`spherical_contact`] with the planar lanes' laws), the mobility form's terms and
//! acceleration ([`stages::linear_at`], [`stages::add_columns`]), the RK4 stages
//! ([`stages::rk4`]) and the impact trackers (the planar lanes' `Trackers`). What is the lanes'
//! own is where the numbers are kept; a contact opening or closing is the model's own code, lane
//! by lane; the loop around the step (lanes stepped by their models, failures, samples) is
//! `lanes::drive`, written for any kind of lane model.
//!
//! Which models qualify ([`ball_laws`]): one to four spherical joints (the micro subsystem's
//! kinds), with any contact and friction laws; the lanes of one group share each joint's laws'
//! kinds, not their numbers.

use crate::lanes::{COMMON_LAW, L, LaneContact, LaneKind, LaneLaws, LaneOutcome, LawLanes, Trackers, V, drive};
use crate::model::{InterfaceModel, Loads, MassFactor, StepEnd};
use crate::stages::{self, Rk4Stage};
use lash_contact::PenetrationError;
use lash_contact::clearance::PENETRATION_LIMIT_FRACTION;
use lash_contact::law::onset_reciprocal;
use lash_contact::spherical::{SphericalContact, SphericalMotion, cross, spherical_contact};
use lash_contact::{SphericalClearance, SphericalContactState};
use lash_core::Ticks;
use lash_core::lane::{F64x8, Real};
use lash_spatial::Vec3;
use nalgebra::SVector;

type X = F64x8;

/// The micro model of K spherical clearance joints (N = 3K coordinates, friction loads and
/// rotations).
pub type Balls<const N: usize, const K: usize> = InterfaceModel<SphericalClearance, N, K, N, N>;

/// The laws' kinds of each joint of a model, which the lanes of one group share.
pub fn ball_laws<const N: usize, const K: usize>(model: &Balls<N, K>) -> [LaneLaws; K] {
    std::array::from_fn(|j| LaneLaws::of(&model.joints[j].law, &model.joints[j].friction))
}

/// Advances `L` models of spherical joints (each of the laws' kinds `laws`, each at its own time
/// `t[l]` with its inputs set) by `record.len()` RK4 steps of `step`, as the planar lanes'
/// [`crate::lanes::advance`] does: after each flagged step `sample(lane, step index, model)` for
/// every lane still running; a lane that fails stops there, the others go on. Compiled for the
/// baseline, AVX2 and AVX-512, picked at run time (the same IEEE operations: the bits do not
/// depend on the CPU).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
pub fn advance_balls<const N: usize, const K: usize>(
    models: &mut [&mut Balls<N, K>; L],
    laws: [LaneLaws; K],
    t: [Ticks; L],
    step: Ticks,
    record: &[bool],
    sample: impl FnMut(usize, usize, &Balls<N, K>),
) -> [LaneOutcome; L] {
    let mut lanes = BallLanes::of(models, laws);
    drive(&mut lanes, models, t, step, record, sample)
}

/// Lanes of N numbers (w, ẇ, ẅ, a load): added and scaled as the single run's nalgebra vectors
/// are, entry by entry.
#[derive(Clone, Copy)]
struct Stack<const N: usize>([X; N]);

impl<const N: usize> std::ops::Add for Stack<N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        let mut sum = self;
        for (s, o) in sum.0.iter_mut().zip(o.0) {
            *s = *s + o;
        }
        sum
    }
}

impl<const N: usize> std::ops::Mul<f64> for Stack<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, f: f64) -> Self {
        let mut product = self;
        for p in product.0.iter_mut() {
            *p = *p * f;
        }
        product
    }
}

impl<const N: usize> Stack<N> {
    const ZERO: Self = Self([X::ZERO; N]);

    /// Joint `j`'s three numbers.
    #[inline(always)]
    fn part(&self, j: usize) -> [X; 3] {
        [self.0[3 * j], self.0[3 * j + 1], self.0[3 * j + 2]]
    }

    /// Lane `l` as a vector.
    fn lane(&self, l: usize) -> SVector<f64, N> {
        SVector::from_fn(|i, _| self.0[i][l])
    }

    /// Lane `l` takes `v`.
    fn set(&mut self, l: usize, v: &SVector<f64, N>) {
        for (x, &y) in self.0.iter_mut().zip(v.iter()) {
            x[l] = y;
        }
    }
}

/// The loads of every lane at one evaluation: contact forces and friction loads n × f, stacked.
#[derive(Clone, Copy)]
struct BallLoads<const N: usize> {
    contact: Stack<N>,
    friction: Stack<N>,
}

/// The mobility form's terms of every lane (values at the inputs' time and rates, column-major
/// as the model keeps them), the bodies' angular velocities and accelerations (ball, socket).
struct Terms<const N: usize> {
    time: X,
    mobility: [[X; N]; N],
    mobility_rate: [[X; N]; N],
    friction_mobility: [[X; N]; N],
    friction_mobility_rate: [[X; N]; N],
    free: [X; N],
    free_rate: [X; N],
    omega: [[X; N]; 2],
    alpha: [[X; N]; 2],
}

/// [`Terms`] at one instant, `dt` past the inputs' time: formed where they are used, a column or
/// a joint at a time (whole, the terms of three instants a step were copies of kilobytes).
#[derive(Clone, Copy)]
struct TermsAt<'a, const N: usize> {
    terms: &'a Terms<N>,
    dt: X,
}

impl<const N: usize> Terms<N> {
    fn of<const K: usize>(models: &[&mut Balls<N, K>; L]) -> Self {
        let vector = |f: &dyn Fn(&Balls<N, K>) -> &[f64]| -> [X; N] {
            std::array::from_fn(|i| X::from(std::array::from_fn(|l| f(models[l])[i])))
        };
        let matrix = |f: &dyn Fn(&Balls<N, K>) -> &[f64]| -> [[X; N]; N] {
            std::array::from_fn(|c| std::array::from_fn(|r| X::from(std::array::from_fn(|l| f(models[l])[c * N + r]))))
        };
        fn u<const N: usize, const K: usize>(m: &Balls<N, K>) -> &crate::model::InterfaceInputs<N, N, N> {
            &m.inputs
        }
        Self {
            time: X::from(std::array::from_fn(|l| models[l].input_time)),
            mobility: matrix(&|m| m.mobility.mobility.as_slice()),
            mobility_rate: matrix(&|m| m.mobility.mobility_rate.as_slice()),
            friction_mobility: matrix(&|m| m.mobility.friction_mobility.as_slice()),
            friction_mobility_rate: matrix(&|m| m.mobility.friction_mobility_rate.as_slice()),
            free: vector(&|m| m.mobility.free_acceleration.as_slice()),
            free_rate: vector(&|m| m.mobility.free_acceleration_rate.as_slice()),
            omega: [vector(&|m| &u(m).journal_angular_velocity), vector(&|m| &u(m).bearing_angular_velocity)],
            alpha: [vector(&|m| &u(m).journal_angular_acceleration), vector(&|m| &u(m).bearing_angular_acceleration)],
        }
    }

    /// The terms at `t`.
    #[inline(always)]
    fn at(&self, t: X) -> TermsAt<'_, N> {
        TermsAt { terms: self, dt: t - self.time }
    }
}

impl<const N: usize> TermsAt<'_, N> {
    /// ẅ = a_free + W f_c + G L ([`crate::model::MobilityAt::acceleration`]: each term taken to
    /// the instant by [`stages::linear_at`], the columns added by [`stages::add_columns`]).
    #[inline(always)]
    fn acceleration(&self, loads: &BallLoads<N>) -> Stack<N> {
        let (t, dt) = (self.terms, self.dt);
        let mut a = t.free;
        stages::linear_at(&mut a, &t.free_rate, dt);
        for (matrix, rate, values) in [
            (&t.mobility, &t.mobility_rate, &loads.contact.0),
            (&t.friction_mobility, &t.friction_mobility_rate, &loads.friction.0),
        ] {
            for c in 0..N {
                let mut column = matrix[c];
                stages::linear_at(&mut column, &rate[c], dt);
                stages::add_columns(&mut a, &column, &values[c..c + 1]);
            }
        }
        Stack(a)
    }

    /// Joint `j`'s ball's and socket's angular velocities (as the model's `contact_at` forms them).
    #[inline(always)]
    fn omega(&self, j: usize) -> [[X; 3]; 2] {
        let t = self.terms;
        let mut omega = [[X::ZERO; 3]; 2];
        for (b, w) in omega.iter_mut().enumerate() {
            w.copy_from_slice(&t.omega[b][3 * j..3 * j + 3]);
            stages::linear_at(w, &t.alpha[b][3 * j..3 * j + 3], self.dt);
        }
        omega
    }
}

/// One joint of every lane: its geometry, its laws and its mode (closed, and the onset
/// velocity with its reciprocal, as the laws take it).
struct Ball {
    clearance: X,
    radii: [X; 2],
    limit: X,
    laws: LawLanes,
    in_contact: [bool; L],
    onset: V,
    reciprocal: V,
}

impl Ball {
    /// Lane `l`'s mode from its joint.
    fn take_mode(&mut self, l: usize, joint: &SphericalClearance) {
        self.in_contact[l] = joint.in_contact;
        self.onset[l] = joint.onset_velocity;
        self.reciprocal[l] = onset_reciprocal(self.onset[l], self.laws.floor[l]);
    }

    /// Every lane's contact at (e, ė) with the angular velocities `omega`, each lane in its mode:
    /// the joint's `evaluate_relative` as the model's `contact_at` calls it.
    #[inline(always)]
    fn contact(&self, (e, v): ([X; 3], [X; 3]), omega: [[X; 3]; 2], in_contact: X) -> SphericalContact<X> {
        let onset = (X::from(self.onset), X::from(self.reciprocal));
        if self.laws.is(COMMON_LAW) {
            let laws = LaneContact::<true> { laws: &self.laws, in_contact, onset };
            spherical_contact(&laws, (e, v), omega, self.radii, self.clearance)
        } else {
            let laws = LaneContact::<false> { laws: &self.laws, in_contact, onset };
            spherical_contact(&laws, (e, v), omega, self.radii, self.clearance)
        }
    }
}

/// A joint's contact state in every lane (what the model's `states[j]` holds).
#[derive(Clone, Copy)]
struct BallState {
    eccentricity: [X; 3],
    contact: SphericalContact<X>,
}

impl BallState {
    const NONE: Self = Self {
        eccentricity: [X::ZERO; 3],
        contact: SphericalContact {
            motion: SphericalMotion {
                norm: X::ZERO,
                normal: [X::ZERO; 3],
                penetration: X::ZERO,
                penetration_rate: X::ZERO,
                slip: [X::ZERO; 3],
                speed: X::ZERO,
            },
            normal_force: X::ZERO,
            friction_force: X::ZERO,
            load: [X::ZERO; 3],
        },
    };

    /// Lane `l` takes `s`.
    fn set(&mut self, l: usize, s: &SphericalContactState) {
        let c = &mut self.contact;
        let m = &mut c.motion;
        for i in 0..3 {
            self.eccentricity[i][l] = s.eccentricity[i];
            m.normal[i][l] = s.normal[i];
            m.slip[i][l] = s.slip_velocity[i];
            c.load[i][l] = s.force_on_journal[i];
        }
        (m.norm[l], m.penetration[l], m.penetration_rate[l]) = (s.eccentricity_norm, s.penetration, s.penetration_rate);
        (c.normal_force[l], c.friction_force[l]) = (s.normal_force, s.friction_force);
    }

    /// Lane `l`'s state.
    fn get(&self, l: usize) -> SphericalContactState {
        let (c, m) = (&self.contact, &self.contact.motion);
        let v = |a: &[X; 3]| Vec3::new(a[0][l], a[1][l], a[2][l]);
        SphericalContactState {
            journal_centre: Vec3::zeros(),
            eccentricity: v(&self.eccentricity),
            eccentricity_norm: m.norm[l],
            normal: v(&m.normal),
            penetration: m.penetration[l],
            penetration_rate: m.penetration_rate[l],
            slip_velocity: v(&m.slip),
            normal_force: c.normal_force[l],
            friction_force: c.friction_force[l],
            force_on_journal: v(&c.load),
        }
    }
}

/// The lanes of `L` models of K spherical joints: constants, inputs, and the state between steps
/// (w, ẇ, impulses, the kept step end's time and loads, the contact states, the open impacts).
struct BallLanes<const N: usize, const K: usize> {
    balls: [Ball; K],
    terms: Terms<N>,
    eccentricity: Stack<N>,
    eccentricity_rate: Stack<N>,
    impulse: Stack<N>,
    friction_impulse: Stack<N>,
    end_time: X,
    end_loads: BallLoads<N>,
    states: [BallState; K],
    trackers: [Trackers; K],
}

impl<const N: usize, const K: usize> BallLanes<N, K> {
    fn of(models: &[&mut Balls<N, K>; L], laws: [LaneLaws; K]) -> Self {
        assert_eq!(N, 3 * K, "three coordinates per spherical joint");
        let balls = std::array::from_fn(|j| {
            let each =
                |f: &dyn Fn(&SphericalClearance) -> f64| X::from(std::array::from_fn(|l| f(&models[l].joints[j])));
            Ball {
                clearance: each(&|b| b.radial_clearance()),
                radii: [each(&|b| b.journal_radius), each(&|b| b.bearing_radius)],
                limit: each(&|b| PENETRATION_LIMIT_FRACTION * b.journal_radius),
                laws: LawLanes::of(laws[j], |l| (&models[l].joints[j].law, &models[l].joints[j].friction)),
                in_contact: [false; L],
                onset: [0.0; L],
                reciprocal: [0.0; L],
            }
        });
        Self {
            balls,
            terms: Terms::of(models),
            eccentricity: Stack::ZERO,
            eccentricity_rate: Stack::ZERO,
            impulse: Stack::ZERO,
            friction_impulse: Stack::ZERO,
            end_time: X::ZERO,
            end_loads: BallLoads { contact: Stack::ZERO, friction: Stack::ZERO },
            states: [BallState::NONE; K],
            trackers: [Trackers::NONE; K],
        }
    }

    /// Each joint's closed lanes as a mask.
    #[inline(always)]
    fn modes(&self) -> [X; K] {
        std::array::from_fn(|j| X::mask(self.balls[j].in_contact))
    }

    /// Every joint's contact at (w, ẇ), each lane in its mode.
    #[inline(always)]
    fn contacts(&self, (e, v): (&Stack<N>, &Stack<N>), at: &TermsAt<N>, modes: &[X; K]) -> [SphericalContact<X>; K] {
        // (A loop, not `array::from_fn`: its closure was not inlined, a call per joint and stage.)
        let mut contacts = [BallState::NONE.contact; K];
        for (j, c) in contacts.iter_mut().enumerate() {
            *c = self.balls[j].contact((e.part(j), v.part(j)), at.omega(j), modes[j]);
        }
        contacts
    }

    /// The loads of the contacts, `gated` as the model's `loads_at` gates them (nothing for a
    /// joint inside its clearance, |e|² ≤ c²) or whole as its step end keeps them.
    #[inline(always)]
    fn loads(&self, e: &Stack<N>, contacts: &[SphericalContact<X>; K], gated: bool) -> BallLoads<N> {
        let mut loads = BallLoads { contact: Stack::ZERO, friction: Stack::ZERO };
        for (j, c) in contacts.iter().enumerate() {
            let friction = cross(c.motion.normal, c.load);
            let [a, b, d] = e.part(j);
            let clearance = self.balls[j].clearance;
            let outside =
                if gated { (a * a + b * b + d * d).simd_gt(clearance * clearance) } else { X::mask([true; L]) };
            for i in 0..3 {
                loads.contact.0[3 * j + i] = outside.select(c.load[i], X::ZERO);
                loads.friction.0[3 * j + i] = outside.select(friction[i], X::ZERO);
            }
        }
        loads
    }

    /// The lanes whose joints open or close a contact at the step's end w₁, joint by joint as the
    /// model's `switch_modes` tells (|e| − c against the mode), as a bit mask.
    #[inline(always)]
    fn switching(&self, e1: &Stack<N>, modes: &[X; K]) -> u32 {
        let mut any = 0;
        for (j, ball) in self.balls.iter().enumerate() {
            let [a, b, d] = e1.part(j);
            let closed = ((a * a + b * b + d * d).sqrt() - ball.clearance).simd_gt(X::ZERO);
            any |= (closed ^ modes[j]).to_bitmask();
        }
        any
    }

    /// Lane `l`'s mode switches through its model's own code (onsets and exits placed by
    /// interpolation, impacts opened and closed), and its modes taken back.
    fn switch_lane(&mut self, l: usize, m: &mut Balls<N, K>, (t, h): (f64, f64), ends: [(&Stack<N>, &Stack<N>); 2]) {
        m.located = false;
        let [(e0, v0), (e1, v1)] = ends.map(|(e, v)| (e.lane(l), v.lane(l)));
        for j in 0..K {
            m.open[j] = self.trackers[j].get(l);
        }
        let none = SVector::zeros();
        m.switch_modes::<false>(t, h, (&e0, &v0, &none), (&e1, &v1, &none));
        for j in 0..K {
            self.trackers[j].set(l, m.open[j]);
            self.balls[j].take_mode(l, &m.joints[j]);
        }
    }
}

/// The second to fourth stages of every lane's step ([`stages::rk4`]): the terms at the step's
/// middle and end and each joint's mode.
struct LaterStages<'a, const N: usize, const K: usize> {
    lanes: &'a BallLanes<N, K>,
    middle: TermsAt<'a, N>,
    end: TermsAt<'a, N>,
    modes: [X; K],
}

impl<const N: usize, const K: usize> stages::StageRates<Stack<N>, BallLoads<N>> for LaterStages<'_, N, K> {
    #[inline(always)]
    fn rate(&mut self, stage: Rk4Stage, e: Stack<N>, v: Stack<N>) -> (Stack<N>, BallLoads<N>) {
        let at = if stage == Rk4Stage::Fourth { &self.end } else { &self.middle };
        let contacts = self.lanes.contacts((&e, &v), at, &self.modes);
        let loads = self.lanes.loads(&e, &contacts, true);
        (at.acceleration(&loads), loads)
    }
}

impl<const N: usize, const K: usize> LaneKind<Balls<N, K>> for BallLanes<N, K> {
    fn gather(&mut self, l: usize, m: &Balls<N, K>, t: f64) -> bool {
        self.eccentricity.set(l, &m.eccentricity);
        self.eccentricity_rate.set(l, &m.eccentricity_rate);
        self.impulse.set(l, &m.impulse);
        self.friction_impulse.set(l, &m.friction_impulse);
        for j in 0..K {
            self.states[j].set(l, &m.states[j]);
            self.trackers[j].set(l, m.open[j]);
            self.balls[j].take_mode(l, &m.joints[j]);
        }
        let Some(end) = m.end_at(t) else { return false };
        self.end_time[l] = end.time;
        self.end_loads.contact.set(l, &end.loads.contact);
        self.end_loads.friction.set(l, &end.loads.friction);
        true
    }

    fn scatter(&self, l: usize, m: &mut Balls<N, K>) {
        m.located = false;
        self.scatter_sampled(l, m);
        for j in 0..K {
            m.open[j] = self.trackers[j].get(l);
        }
        let loads = Loads { contact: self.end_loads.contact.lane(l), friction: self.end_loads.friction.lane(l) };
        // (The mobility form keeps no factor in its step end.)
        m.end = Some(StepEnd {
            time: self.end_time[l],
            input_time: m.input_time,
            eccentricity: m.eccentricity,
            eccentricity_rate: m.eccentricity_rate,
            loads,
            mass: MassFactor::NONE,
        });
    }

    fn scatter_sampled(&self, l: usize, m: &mut Balls<N, K>) {
        m.eccentricity = self.eccentricity.lane(l);
        m.eccentricity_rate = self.eccentricity_rate.lane(l);
        m.impulse = self.impulse.lane(l);
        m.friction_impulse = self.friction_impulse.lane(l);
        for j in 0..K {
            m.states[j] = self.states[j].get(l);
        }
    }

    fn end_time(&self) -> X {
        self.end_time
    }

    #[inline(always)]
    fn step(&mut self, now: X, h: f64, stepped: X, models: &mut [&mut Balls<N, K>; L]) {
        let (e0, v0) = (self.eccentricity, self.eccentricity_rate);
        // Stage 1 from the kept step end's loads.
        let first = (self.terms.at(now).acceleration(&self.end_loads), self.end_loads);
        let modes = self.modes();
        let (middle, end) = (self.terms.at(now + X::splat(0.5 * h)), self.terms.at(now + X::splat(h)));
        let stepped_to = stages::rk4(h, (e0, v0), first, &mut LaterStages { lanes: self, middle, end, modes });
        let (e1, v1) = (stepped_to.eccentricity, stepped_to.eccentricity_rate);
        let [l1, l2, l3, l4] = stepped_to.loads;
        self.impulse = stages::weighted(self.impulse, [l1.contact, l2.contact, l3.contact, l4.contact], h);
        self.friction_impulse =
            stages::weighted(self.friction_impulse, [l1.friction, l2.friction, l3.friction, l4.friction], h);
        // Mode switches (rare), lane by lane through the model's own code.
        let switching = self.switching(&e1, &modes) & stepped.to_bitmask();
        for l in (0..L).filter(|l| switching >> l & 1 == 1) {
            self.switch_lane(l, models[l], (now[l], h), [(&e0, &v0), (&e1, &v1)]);
        }
        // The step end's contact states (not gated), then the impact trackers.
        let modes = if switching != 0 { self.modes() } else { modes };
        let contacts = self.contacts((&e1, &v1), &self.terms.at(now + X::splat(h)), &modes);
        let end_time = now + X::splat(h);
        for (j, c) in contacts.iter().enumerate() {
            self.states[j] = BallState { eccentricity: e1.part(j), contact: *c };
            self.trackers[j].sample(stepped, end_time, c.normal_force, c.motion.penetration);
        }
        self.end_loads = self.loads(&e1, &contacts, false);
        (self.eccentricity, self.eccentricity_rate, self.end_time) = (e1, v1, end_time);
    }

    fn fine(&self) -> X {
        let mut fine = X::mask([true; L]);
        for (ball, state) in self.balls.iter().zip(&self.states) {
            let m = &state.contact.motion;
            fine = fine & m.penetration.simd_le(ball.limit) & m.norm.abs().simd_lt(X::splat(f64::INFINITY));
        }
        fine
    }

    fn model_step(m: &mut Balls<N, K>, t: f64, h: f64) {
        m.rk4_step(t, h);
    }

    fn check(m: &Balls<N, K>) -> Result<(), PenetrationError> {
        (0..K).try_for_each(|j| m.check_penetration(j))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_contact::friction::FrictionLaw;
    use lash_contact::law::NormalForce;
    use lash_mech::BodyId;
    use nalgebra::SMatrix;

    type Two = Balls<6, 2>;

    /// Lane `l`'s joint `j`: a ball of 5.75 mm in a socket of 6 mm (+ a few µm per lane), the
    /// first joint with the common law and Coulomb friction, the second with a power law and
    /// Ambrósio's friction, numbers varied per lane.
    fn ball(j: usize, l: usize) -> SphericalClearance {
        let x = l as f64;
        let (law, friction) = if j == 0 {
            (
                NormalForce::Hysteresis {
                    stiffness: 1e10 * (1.0 + 0.1 * x),
                    exponent: 1.5,
                    chi: 0.2 + 0.05 * x,
                    floor: 1e-4,
                },
                FrictionLaw::Coulomb { coefficient: 0.05 + 0.01 * x },
            )
        } else {
            (
                NormalForce::Power { stiffness: 2e10 * (1.0 + 0.05 * x), exponent: 1.5 },
                FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4 * (1.0 + x), v1: 1e-3 },
            )
        };
        SphericalClearance {
            name: format!("ball{j}"),
            journal_body: BodyId::Body(j),
            journal_point: Vec3::zeros(),
            bearing_body: BodyId::Ground,
            bearing_point: Vec3::zeros(),
            journal_radius: 0.00575,
            bearing_radius: 0.006 + 5e-6 * x,
            law,
            friction,
            in_contact: false,
            onset_velocity: 0.0,
        }
    }

    /// Interval k's terms for lane l: a coupled mobility and its rate, a free acceleration that
    /// turns and now and then reverses (free flights and impacts), friction mobilities, spinning
    /// balls and sockets.
    fn set_inputs(m: &mut Two, k: usize, l: usize, t0: f64) {
        let (x, a) = (l as f64, k as f64 * 0.37 + l as f64);
        let sign = if (k / 5) % 3 == 2 { -1.0 } else { 1.0 };
        let magnitude = sign * (600.0 + 80.0 * x) * (1.0 + 0.3 * (0.9 * k as f64).sin());
        let coupling = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 7 + j * 3 + l) % 5) as f64 * 0.02 - 0.04);
        let w = SMatrix::<f64, 6, 6>::identity() * (0.3 + 0.01 * x) + coupling * coupling.transpose();
        let p = &mut m.mobility;
        p.mobility = w;
        p.mobility_rate = SMatrix::from_fn(|i, j| if i == j { 20.0 * a.cos() } else { 1.0 });
        p.friction_mobility = SMatrix::from_fn(|i, j| ((i + 2 * j + l) % 5) as f64 * 0.01 - 0.02);
        p.friction_mobility_rate = SMatrix::from_fn(|i, j| ((i * j) % 3) as f64 * 0.5);
        p.free_acceleration = SVector::from_fn(|i, _| magnitude * [a.cos(), a.sin(), 0.3, -a.sin(), a.cos(), -0.2][i]);
        p.free_acceleration_rate = SVector::from_fn(|i, _| 3e4 * [-a.sin(), a.cos(), 0.0, a.cos(), a.sin(), 0.1][i]);
        let u = &mut m.inputs;
        u.journal_angular_velocity = [300.0 + 20.0 * x, -50.0, 30.0, 10.0, 200.0, -5.0 * x];
        u.journal_angular_acceleration = std::array::from_fn(|i| 1e3 * a.cos() * (i as f64 - 2.0));
        u.bearing_angular_velocity = std::array::from_fn(|i| if i < 3 { 0.0 } else { -20.0 * x });
        u.bearing_angular_acceleration = std::array::from_fn(|i| if i == 4 { 50.0 } else { 0.0 });
        m.input_time = t0;
    }

    fn show(m: &Two) -> String {
        format!(
            "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
            m.eccentricity.as_slice(),
            m.eccentricity_rate.as_slice(),
            m.impulse.as_slice(),
            m.friction_impulse.as_slice(),
            m.states,
            m.joints.iter().map(|j| (j.in_contact, j.onset_velocity.to_bits())).collect::<Vec<_>>(),
            m.impacts,
            m.open,
        )
    }

    /// Steps `lanes` in lanes and `models` one by one (as the micro subsystem's loop does)
    /// through `intervals` intervals of 100 steps, compared bit for bit after each and at every
    /// sample; the models' loops' outcomes are returned with the impacts made.
    fn lanes_against_models(lanes: &mut [Two], models: &mut [Two], intervals: usize) -> (Vec<LaneOutcome>, usize) {
        let step = Ticks::from_seconds(1e-5).unwrap();
        let h = step.seconds();
        let record: Vec<bool> = (0..100).map(|i| i % 10 == 9).collect();
        let laws = ball_laws(&lanes[0]);
        let mut outcomes = vec![Ok(()); L];
        for k in 0..intervals {
            let t0 = Ticks(k as i64 * 100 * step.0);
            for l in 0..L {
                set_inputs(&mut lanes[l], k, l, t0.seconds());
                set_inputs(&mut models[l], k, l, t0.seconds());
            }
            let mut expected = vec![Vec::new(); L];
            for (l, m) in models.iter_mut().enumerate() {
                for (i, &flag) in record.iter().enumerate() {
                    m.rk4_step(Ticks(t0.0 + i as i64 * step.0).seconds(), h);
                    if let Err(e) = (0..2).try_for_each(|j| m.check_penetration(j)) {
                        outcomes[l] = Err((i, Ticks(t0.0 + (i as i64 + 1) * step.0).seconds(), e));
                        break;
                    }
                    if flag {
                        expected[l].push(format!("{i} {:?}", m.states));
                    }
                }
            }
            let mut got = vec![Vec::new(); L];
            let mut group: [&mut Two; L] =
                lanes.iter_mut().collect::<Vec<_>>().try_into().unwrap_or_else(|_| unreachable!("L models"));
            let outcome = advance_balls(&mut group, laws, [t0; L], step, &record, |l, i, m| {
                got[l].push(format!("{i} {:?}", m.states));
            });
            for l in 0..L {
                assert_eq!(outcome[l], outcomes[l], "interval {k}, lane {l}: outcome");
                assert_eq!(got[l], expected[l], "interval {k}, lane {l}: samples");
                let (a, b) = (show(&lanes[l]), show(&models[l]));
                assert!(a == b, "interval {k}, lane {l}:\nlanes {a}\nmodel {b}");
            }
            if outcomes.iter().any(|o| o.is_err()) {
                break;
            }
        }
        let impacts = models.iter().map(|m| m.impacts.iter().map(Vec::len).sum::<usize>()).sum();
        (outcomes, impacts)
    }

    fn models() -> Vec<Two> {
        (0..L).map(|l| InterfaceModel::new(vec![ball(0, l), ball(1, l)])).collect()
    }

    /// Eight lanes of two spherical joints each (different numbers, the common law and another,
    /// two friction laws), through 60 intervals of 100 steps with contact, sliding, free flights
    /// and impacts, equal the models stepped one by one, bit for bit: states, impulses, modes,
    /// impacts, open impacts and every sampled state.
    #[test]
    fn lanes_of_spherical_joints_equal_their_models_bit_for_bit() {
        let (mut lanes, mut models) = (models(), models());
        assert_eq!(ball_laws(&lanes[0])[0].law, COMMON_LAW);
        assert!(lanes.iter().all(|m| ball_laws(m) == ball_laws(&lanes[0])), "one group");
        let (outcomes, impacts) = lanes_against_models(&mut lanes, &mut models, 60);
        assert!(outcomes.iter().all(|o| o.is_ok()), "{outcomes:?}");
        eprintln!("impacts {impacts}");
        assert!(impacts >= 2 * L, "the inputs should make impacts in every lane: {impacts}");
    }

    /// A lane that blows up (a soft contact: the penetration passes a tenth of the ball's radius)
    /// stops where its model's loop stops, with the same message; the others go on.
    #[test]
    fn a_lane_that_fails_stops_like_its_model() {
        let mut lanes = models();
        if let NormalForce::Hysteresis { stiffness, .. } = &mut lanes[5].joints[0].law {
            *stiffness = 1e4;
        }
        let mut models = lanes.clone();
        let (outcomes, _) = lanes_against_models(&mut lanes, &mut models, 60);
        assert!(outcomes.iter().enumerate().all(|(l, o)| o.is_ok() == (l != 5)), "{outcomes:?}");
    }
}
