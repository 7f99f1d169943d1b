//! The planar revolute clearance joint (docs/theory.md §2).

use crate::film::Film;
use crate::friction::FrictionLaw;
use crate::law::NormalForce;
use lash_core::lane::Real;
use lash_mech::{BodyId, Pose, Vec2, perp};
use serde::Serialize;

/// |e| and the penetration δ = |e| − c of a planar revolute clearance joint at eccentricity `e`
/// (for one run, or several side by side: [`Real`]).
#[inline(always)]
pub fn penetration<R: Real>([ex, ey]: [R; 2], clearance: R) -> (R, R) {
    let norm = (ex * ex + ey * ey).sqrt();
    (norm, norm - clearance)
}

/// The normal n = e/|e| ((1, 0) at the centre), the penetration rate δ̇ = ė·n and the slip
/// v_t = ė·t + ω_J R_J − ω_B R_B (t = (−n_y, n_x)) of a planar revolute clearance joint whose
/// eccentricity `e` has the norm `norm`, from its rate `e_dot`, the angular velocities `omega`
/// and the radii `radii` (journal's, bearing's).
#[inline(always)]
pub fn normal_motion<R: Real>(
    [ex, ey]: [R; 2],
    norm: R,
    [u, v]: [R; 2],
    [omega_journal, omega_bearing]: [R; 2],
    [journal_radius, bearing_radius]: [R; 2],
) -> ([R; 2], R, R) {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    // (One division for both components, as the spherical joint does: the micro step's lanes
    // are bound by the divider.)
    let positive = norm.simd_gt(zero);
    let inverse = one / norm;
    let nx = R::select(positive, ex * inverse, one);
    let ny = R::select(positive, ey * inverse, zero);
    let delta_dot = u * nx + v * ny;
    let slip = (u * -ny + v * nx) + omega_journal * journal_radius - omega_bearing * bearing_radius;
    ([nx, ny], delta_dot, slip)
}

/// The force on the journal, −F_N n − F_T t, of a normal force `normal` and a friction force
/// `friction` along the normal `n`.
#[inline(always)]
pub fn journal_load<R: Real>([nx, ny]: [R; 2], normal: R, friction: R) -> [R; 2] {
    [-(nx * normal) - -ny * friction, -(ny * normal) - nx * friction]
}

/// The laws of one contact as [`planar_contact`], [`crate::spherical::spherical_contact`] and a
/// translational joint's corner evaluate them, for one run ([`OneContact`]) or several side by
/// side (the micro step's lanes). Methods, not closures: called from the lanes' step, a closure
/// was compiled out of line and cost the lanes half again their time.
pub trait ContactLaws<R: Real> {
    /// The normal force at penetration `delta` > 0 and its rate `delta_dot`, clipped at zero.
    fn normal_force(&self, delta: R, delta_dot: R) -> R;
    /// The friction coefficient at the slip (planar: signed; spherical: the slip speed).
    fn friction_coefficient(&self, slip: R) -> R;
}

/// The laws of one contact of one run: its normal force law at the onset velocity `onset`, in
/// series with a bush of stiffness `series` when `SERIES` (the rigid path leaves the series solve
/// out of the code), and its friction law.
pub struct OneContact<'a, const SERIES: bool> {
    /// The normal force law.
    pub law: &'a NormalForce,
    /// The friction law.
    pub friction: &'a FrictionLaw,
    /// δ̇⁻ of the current contact [m/s].
    pub onset: f64,
    /// The stiffness of a bush in series [N/m] (read only when `SERIES`; infinite: none).
    pub series: f64,
}

impl<const SERIES: bool> ContactLaws<f64> for OneContact<'_, SERIES> {
    #[inline(always)]
    fn normal_force(&self, delta: f64, delta_dot: f64) -> f64 {
        if SERIES && self.series.is_finite() {
            self.law.force_in_series(delta, delta_dot, self.onset, self.series)
        } else {
            self.law.force(delta, delta_dot, self.onset)
        }
    }
    #[inline(always)]
    fn friction_coefficient(&self, slip: f64) -> f64 {
        self.friction.coefficient(slip)
    }
}

/// The normal and friction forces of a contact at penetration `delta`, rate `delta_dot` and slip
/// `slip` (for one run, or several side by side): F_N the law's where the contact indents (δ > 0),
/// F_T = μ F_N where F_N > 0, zero elsewhere. One run does not evaluate a law it does not need
/// (free flight); lanes evaluate both for every lane and select (a branch in the middle of their
/// arithmetic costs them more than the laws).
#[inline(always)]
pub fn contact_forces<R: Real>(laws: &impl ContactLaws<R>, (delta, delta_dot): (R, R), slip: R) -> (R, R) {
    let zero = R::splat(0.0);
    let indents = delta.simd_gt(zero);
    if R::WIDTH == 1 && !R::any(indents) {
        return (zero, zero);
    }
    let normal = R::select(indents, laws.normal_force(delta, delta_dot), zero);
    let loaded = normal.simd_gt(zero);
    if R::WIDTH == 1 && !R::any(loaded) {
        return (normal, zero);
    }
    (normal, R::select(loaded, laws.friction_coefficient(slip) * normal, zero))
}

/// A planar revolute clearance joint's contact at one state ([`planar_contact`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarContact<R> {
    /// n = e/|e|.
    pub normal: [R; 2],
    /// δ̇ = ė·n [m/s].
    pub penetration_rate: R,
    /// v_t [m/s].
    pub slip: R,
    /// F_N \[N\].
    pub normal_force: R,
    /// F_T \[N\].
    pub friction_force: R,
    /// The force on the journal, −F_N n − F_T t \[N\].
    pub load: [R; 2],
}

/// The contact of a planar revolute clearance joint with the laws `laws` at eccentricity `e` of
/// norm and penetration `geometry` ([`penetration`]), its rate `e_dot`, the angular velocities
/// `omega` and the radii `radii` (journal's, bearing's) — for one run, or several side by side: the
/// one source of [`ClearanceJoint::evaluate_relative`] and of the micro step's lanes.
#[inline(always)]
pub fn planar_contact<R: Real>(
    laws: &impl ContactLaws<R>,
    e: [R; 2],
    (norm, delta): (R, R),
    e_dot: [R; 2],
    omega: [R; 2],
    radii: [R; 2],
) -> PlanarContact<R> {
    let (normal, penetration_rate, slip) = normal_motion(e, norm, e_dot, omega, radii);
    let (normal_force, friction_force) = contact_forces(laws, (delta, penetration_rate), slip);
    let load = journal_load(normal, normal_force, friction_force);
    PlanarContact { normal, penetration_rate, slip, normal_force, friction_force, load }
}

/// One run's contact state at eccentricity `e` of norm and penetration `geometry`, with the
/// contact `c` (`journal_centre` left at zero).
#[inline(always)]
fn contact_state(e: Vec2, (norm, delta): (f64, f64), c: &PlanarContact<f64>) -> ContactState {
    ContactState {
        journal_centre: Vec2::zeros(),
        eccentricity: e,
        eccentricity_norm: norm,
        normal: c.normal.into(),
        penetration: delta,
        penetration_rate: c.penetration_rate,
        slip_velocity: c.slip,
        normal_force: c.normal_force,
        friction_force: c.friction_force,
        force_on_journal: c.load.into(),
    }
}

/// Penetrations beyond this fraction of the journal radius are a blow-up, not contact (full
/// models, micro model and its lanes alike).
pub const PENETRATION_LIMIT_FRACTION: f64 = 0.1;

/// A contact indented beyond [`PENETRATION_LIMIT_FRACTION`] of its radius (or a state no longer
/// finite): the run blew up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "penetration {penetration:.6e} m of {kind} {joint:?} exceeds {limit} × the {radius}: the simulation blew up \
     ({step} too large for the contact stiffness?)",
    limit = PENETRATION_LIMIT_FRACTION
)]
pub struct PenetrationError {
    /// The joint's name.
    pub joint: String,
    /// Its penetration \[m\] (NaN when the state is no longer finite).
    pub penetration: f64,
    /// What kind of joint, in which model ("clearance joint", "spherical clearance joint").
    pub kind: &'static str,
    /// The radius the limit refers to ("journal radius", "ball radius").
    pub radius: &'static str,
    /// The step to blame ("step", "micro step").
    pub step: &'static str,
}

/// A bush in series with a contact carries its damping as a state of its own (its deflection,
/// [`ClearanceJoint::bush_damping`]) when its relaxation time c/k is at least this \[s\]; below, it
/// follows its load quasi-statically. At 1e-7 s the loss factor ωc/k it leaves out is under 2 %
/// for impacts longer than 20 µs (ω = π / duration), while a state that fast would hold an
/// adaptive step near 1e-7 s through every contact.
pub const SERIES_DAMPING_MIN_RELAXATION: f64 = 1e-7;

/// A revolute joint with radial clearance: a journal (pin) on one body inside a bearing (hole) on
/// another.
#[derive(Debug, Clone, PartialEq)]
pub struct ClearanceJoint {
    /// Name used in outputs (usually the joint it replaces).
    pub name: String,
    /// Body carrying the journal.
    pub journal_body: BodyId,
    /// Journal centre on its body (local, from the centroid) \[m\].
    pub journal_point: Vec2,
    /// Body carrying the bearing.
    pub bearing_body: BodyId,
    /// Bearing centre on its body (local, from the centroid) \[m\].
    pub bearing_point: Vec2,
    /// Journal radius R_J \[m\].
    pub journal_radius: f64,
    /// Bearing radius R_B \[m\].
    pub bearing_radius: f64,
    /// Normal contact law.
    pub law: NormalForce,
    /// Friction law.
    pub friction: FrictionLaw,
    /// Radial stiffness of a flexible bush in series with the contact [N/m] (the bush's structural
    /// stiffness; the contact law keeps the local indentation); infinite: a rigid bearing.
    pub bush_stiffness: f64,
    /// Damping of that bush in series with the contact [N s/m]: positive, the bush's deflection
    /// along the normal is a state of its own ([`NormalForce::force_in_series_damped`]); zero, the
    /// bush follows its load quasi-statically ([`NormalForce::force_in_series`]).
    pub bush_damping: f64,
    /// The oil film of a lubricated joint (none: dry). Its force acts in every mode, through the
    /// journal's and the bearing's centres; the contact law adds to it when the journal touches.
    pub film: Option<Film>,
    /// Discrete state: contact closed (δ > 0 since the last located onset).
    pub in_contact: bool,
    /// Discrete state: approach velocity δ̇⁻ captured at the last onset [m/s].
    pub onset_velocity: f64,
}

/// Geometry, kinematics and forces of one clearance joint at one state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ContactState {
    /// Journal centre \[m\].
    pub journal_centre: Vec2,
    /// Eccentricity e = r_J − r_B \[m\].
    pub eccentricity: Vec2,
    /// |e| \[m\].
    pub eccentricity_norm: f64,
    /// Normal n = e/|e| (bearing centre → journal centre).
    pub normal: Vec2,
    /// Penetration δ = |e| − c \[m\] (negative: free flight).
    pub penetration: f64,
    /// Penetration rate δ̇ = ė·n [m/s] (positive: approaching).
    pub penetration_rate: f64,
    /// Slip velocity v_t = ė·t + ω_J R_J − ω_B R_B [m/s].
    pub slip_velocity: f64,
    /// Normal force F_N ≥ 0 \[N\].
    pub normal_force: f64,
    /// Friction force F_T (signed like v_t) \[N\].
    pub friction_force: f64,
    /// Force on the journal f_J = −F_N n − F_T t \[N\].
    pub force_on_journal: Vec2,
}

impl ClearanceJoint {
    /// Radial clearance c = R_B − R_J \[m\].
    pub fn radial_clearance(&self) -> f64 {
        self.bearing_radius - self.journal_radius
    }

    /// The journal centre r_J, the eccentricity e = r_J − r_B and its rate ė for the body poses.
    #[inline(always)]
    fn centres(&self, journal: &Pose, bearing: &Pose) -> (Vec2, Vec2, Vec2) {
        let aj = journal.rotate(self.journal_point);
        let ab = bearing.rotate(self.bearing_point);
        let rj = journal.position + aj;
        let rb = bearing.position + ab;
        let e_dot = journal.velocity + perp(aj) * journal.angular_velocity
            - bearing.velocity
            - perp(ab) * bearing.angular_velocity;
        (rj, rj - rb, e_dot)
    }

    /// Geometry and forces for the given body poses. `onset` is the approach velocity of the
    /// current contact (used by hysteresis-damped laws).
    #[inline]
    pub fn evaluate(&self, journal: &Pose, bearing: &Pose, onset: f64) -> ContactState {
        let (rj, e, e_dot) = self.centres(journal, bearing);
        let mut s = self.evaluate_relative(e, e_dot, journal.angular_velocity, bearing.angular_velocity, onset);
        s.journal_centre = rj;
        s
    }

    /// [`ClearanceJoint::evaluate`] for a joint whose bush has damping in series
    /// (`bush_damping` > 0), with the bush's deflection `deflection` \[m\] as its state: returns the
    /// state and the deflection's rate ṡ. `penetration` and `penetration_rate` stay the approach
    /// δ, δ̇ of the journal to the undeflected bore; the contact's own indentation is δ − s.
    pub fn evaluate_damped(&self, journal: &Pose, bearing: &Pose, onset: f64, deflection: f64) -> (ContactState, f64) {
        let (rj, e, e_dot) = self.centres(journal, bearing);
        let (mut s, rate) = self.evaluate_relative_damped(
            e,
            e_dot,
            journal.angular_velocity,
            bearing.angular_velocity,
            onset,
            deflection,
        );
        s.journal_centre = rj;
        (s, rate)
    }

    /// [`ClearanceJoint::evaluate_damped`] from the relative kinematics (the micro model's view).
    #[inline(always)]
    pub fn evaluate_relative_damped(
        &self,
        e: Vec2,
        e_dot: Vec2,
        omega_journal: f64,
        omega_bearing: f64,
        onset: f64,
        deflection: f64,
    ) -> (ContactState, f64) {
        let (n, norm, delta, delta_dot, slip) = self.relative_kinematics(e, e_dot, omega_journal, omega_bearing);
        let (fn_, rate) = self.law.force_in_series_damped(
            delta,
            delta_dot,
            onset,
            deflection,
            self.bush_stiffness,
            self.bush_damping,
        );
        (self.state(e, n, norm, delta, delta_dot, slip, fn_), rate)
    }

    /// [`ClearanceJoint::evaluate`], or [`ClearanceJoint::evaluate_damped`] when the bush's
    /// deflection is a state (`deflection` given): the state and ṡ (0 without).
    #[inline]
    pub fn evaluate_with_bush(
        &self,
        journal: &Pose,
        bearing: &Pose,
        onset: f64,
        deflection: Option<f64>,
    ) -> (ContactState, f64) {
        match deflection {
            Some(d) => self.evaluate_damped(journal, bearing, onset, d),
            None => (self.evaluate(journal, bearing, onset), 0.0),
        }
    }

    /// ṡ of a bush damped in series whose contact carries nothing: it relaxes, −k s / c (0 for a
    /// joint without such a bush).
    #[inline(always)]
    pub fn bush_relaxation_rate(&self, deflection: f64) -> f64 {
        if self.damped_in_series() { -self.bush_stiffness * deflection / self.bush_damping } else { 0.0 }
    }

    /// Whether the bush in series carries its damping as a state ([`ClearanceJoint::bush_damping`]).
    #[inline(always)]
    pub fn damped_in_series(&self) -> bool {
        self.bush_damping > 0.0 && self.bush_stiffness.is_finite()
    }

    /// n, |e|, δ, δ̇ and the slip from the relative kinematics.
    #[inline(always)]
    fn relative_kinematics(
        &self,
        e: Vec2,
        e_dot: Vec2,
        omega_journal: f64,
        omega_bearing: f64,
    ) -> (Vec2, f64, f64, f64, f64) {
        let (norm, delta) = penetration([e.x, e.y], self.radial_clearance());
        let ([nx, ny], delta_dot, slip) = normal_motion(
            [e.x, e.y],
            norm,
            [e_dot.x, e_dot.y],
            [omega_journal, omega_bearing],
            [self.journal_radius, self.bearing_radius],
        );
        (Vec2::new(nx, ny), norm, delta, delta_dot, slip)
    }

    /// The state with the normal force `fn_` and the friction it carries.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn state(&self, e: Vec2, n: Vec2, norm: f64, delta: f64, delta_dot: f64, slip: f64, fn_: f64) -> ContactState {
        // No normal force, no friction (skips the friction law in free flight; [`contact_forces`]
        // for the laws in series with a damped bush, whose normal force comes with its rate).
        let ft = if fn_ > 0.0 { self.friction.coefficient(slip) * fn_ } else { 0.0 };
        let normal = [n.x, n.y];
        let load = journal_load(normal, fn_, ft);
        let c =
            PlanarContact { normal, penetration_rate: delta_dot, slip, normal_force: fn_, friction_force: ft, load };
        contact_state(e, (norm, delta), &c)
    }

    /// Geometry and forces from the eccentricity `e`, its rate `e_dot` and the two bodies' angular
    /// velocities (the interface view of the reduced model). `journal_centre` is left at zero.
    #[inline(always)]
    pub fn evaluate_relative(
        &self,
        e: Vec2,
        e_dot: Vec2,
        omega_journal: f64,
        omega_bearing: f64,
        onset: f64,
    ) -> ContactState {
        self.evaluate_relative_as::<true>(e, e_dot, omega_journal, omega_bearing, onset)
    }

    /// [`ClearanceJoint::evaluate_relative`] with the bush known at compile time: `SERIES = false`
    /// is only for a joint without a bush (`bush_stiffness` infinite), and then leaves the series
    /// solve out of the code. The micro model's step takes that path when no joint has a bush: a
    /// call on the rigid joint's path made the compiler keep the step's floating-point values in
    /// memory around it (measured: the planar micro step 100 → 126 ns).
    #[inline(always)]
    pub fn evaluate_relative_as<const SERIES: bool>(
        &self,
        e: Vec2,
        e_dot: Vec2,
        omega_journal: f64,
        omega_bearing: f64,
        onset: f64,
    ) -> ContactState {
        debug_assert!(SERIES || self.bush_stiffness == f64::INFINITY, "a bushed joint on the rigid path");
        let geometry = penetration([e.x, e.y], self.radial_clearance());
        let laws =
            OneContact::<SERIES> { law: &self.law, friction: &self.friction, onset, series: self.bush_stiffness };
        let radii = [self.journal_radius, self.bearing_radius];
        let c = planar_contact(&laws, [e.x, e.y], geometry, [e_dot.x, e_dot.y], [omega_journal, omega_bearing], radii);
        contact_state(e, geometry, &c)
    }

    /// The oil film's force on the journal \[N\] at eccentricity `e`, its rate `e_dot` and the two
    /// bodies' angular velocities (zero for a dry joint); it passes through the journal's centre
    /// (the bearing takes its opposite through its own).
    #[inline(always)]
    pub fn film_force(&self, e: Vec2, e_dot: Vec2, omega_journal: f64, omega_bearing: f64) -> Vec2 {
        match &self.film {
            None => Vec2::zeros(),
            Some(film) => {
                let mean_rate = 0.5 * (omega_journal + omega_bearing);
                let f = film.force(
                    (self.journal_radius, self.radial_clearance()),
                    [e.x, e.y],
                    [e_dot.x, e_dot.y],
                    mean_rate,
                );
                Vec2::new(f[0], f[1])
            }
        }
    }

    /// A lubricated joint's film at the two bodies' poses: its force on the journal and the
    /// world-frame arms from the journal body's and the bearing body's centroids to the journal's
    /// and the bearing's centres, where the force and its opposite act (None: a dry joint).
    #[inline]
    pub fn film_at(&self, journal: &Pose, bearing: &Pose) -> Option<(Vec2, Vec2, Vec2)> {
        self.film.as_ref()?;
        let (_, e, e_dot) = self.centres(journal, bearing);
        let force = self.film_force(e, e_dot, journal.angular_velocity, bearing.angular_velocity);
        Some((force, journal.rotate(self.journal_point), bearing.rotate(self.bearing_point)))
    }

    /// World-frame arms from the journal body's and the bearing body's centroids to the contact
    /// points P_J = r_J + R_J n and P_B = r_B + R_B n.
    #[inline]
    pub fn arms(&self, journal: &Pose, bearing: &Pose, state: &ContactState) -> (Vec2, Vec2) {
        let aj = journal.rotate(self.journal_point) + state.normal * self.journal_radius;
        let ab = bearing.rotate(self.bearing_point) + state.normal * self.bearing_radius;
        (aj, ab)
    }
}

/// One impact (a contact phase from located onset to located exit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Impact {
    /// Onset time \[s\].
    pub onset_time: f64,
    /// Approach velocity δ̇⁻ at onset [m/s].
    pub onset_velocity: f64,
    /// Exit time \[s\] (NaN while open).
    pub exit_time: f64,
    /// Duration \[s\] (NaN while open).
    pub duration: f64,
    /// Peak normal force \[N\] (adaptive methods: golden-section search on each step's continuous
    /// extension; RK4: parabola through the step-end samples).
    pub peak_force: f64,
    /// Time of the peak \[s\].
    pub peak_time: f64,
    /// Largest penetration \[m\].
    pub max_penetration: f64,
}

/// The maximum of `force(θ)` over a step's continuous extension θ ∈ [0, 1] when the step holds
/// it: sampled at θ = k/8; a largest sample inside the step is refined by golden-section search
/// on its two neighbouring intervals (to 1e-8 in θ: the force is flat there, so its error is
/// ~1e-16 relative). A largest sample at an end of the step is searched only if the force falls
/// away from that end into the step (otherwise the peak lies in the neighbouring step, which finds
/// it). Returns (θ, force), or None.
pub fn step_peak(mut force: impl FnMut(f64) -> f64) -> Option<(f64, f64)> {
    const N: usize = 8;
    const EPS: f64 = 1e-7;
    let samples: [f64; N + 1] = std::array::from_fn(|k| force(k as f64 / N as f64));
    let best = (0..=N).max_by(|&a, &b| samples[a].total_cmp(&samples[b]))?;
    if samples[best] <= 0.0 {
        return None;
    }
    let (mut a, mut b) = if best == 0 {
        if force(EPS) <= samples[0] {
            return None;
        }
        (0.0, 1.0 / N as f64)
    } else if best == N {
        if force(1.0 - EPS) <= samples[N] {
            return None;
        }
        ((N - 1) as f64 / N as f64, 1.0)
    } else {
        ((best - 1) as f64 / N as f64, (best + 1) as f64 / N as f64)
    };
    let inv_phi = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - inv_phi * (b - a);
    let mut d = a + inv_phi * (b - a);
    let (mut fc, mut fd) = (force(c), force(d));
    while b - a > 1e-8 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - inv_phi * (b - a);
            fc = force(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + inv_phi * (b - a);
            fd = force(d);
        }
    }
    let (theta, f) = if fc > fd { (c, fc) } else { (d, fd) };
    Some(if f >= samples[best] { (theta, f) } else { (best as f64 / N as f64, samples[best]) })
}

/// What a search of one step's continuous extension found for an open contact: the deepest
/// penetration among the samples and the force peak (time, force) if the step holds it.
pub struct StepSearch {
    deepest: f64,
    peak: Option<(f64, f64)>,
}

impl StepSearch {
    /// Searches the step [t, t + h]; `contact(θ)` gives a contact's (normal force, penetration)
    /// at t + θ h.
    pub fn run_with(t: f64, h: f64, mut contact: impl FnMut(f64) -> (f64, f64)) -> Self {
        let mut deepest = 0.0f64;
        let peak = step_peak(|theta| {
            let (force, penetration) = contact(theta);
            deepest = deepest.max(penetration);
            force
        });
        Self { deepest, peak: peak.map(|(theta, f)| (t + theta * h, f)) }
    }
}

/// Follows open impacts and refines their force peaks, at any width: one impact ([`ImpactTracker`],
/// `f64`) or one per lane of a sweep's runs stepped side by side (`lash_core::lane::F64x8`). Each
/// lane's numbers are the ones a single tracker of its impact holds, changed by the same
/// comparisons and selections ([`Tracker::sample_where`]).
#[derive(Debug, Clone, Copy)]
pub struct Tracker<R: Real> {
    /// When the impact began \[s\].
    pub onset_time: R,
    /// Its penetration rate at the onset [m/s].
    pub onset_velocity: R,
    /// The highest normal force so far \[N\].
    pub peak_force: R,
    /// When it was reached \[s\].
    pub peak_time: R,
    /// The deepest penetration so far \[m\].
    pub max_penetration: R,
    /// The last three samples' times, oldest first \[s\].
    pub times: [R; 3],
    /// Their normal forces \[N\].
    pub forces: [R; 3],
    /// Samples taken (a whole number).
    pub count: R,
    /// Peaks come from searches on continuous extensions (no parabola through samples then).
    pub searched: R::Mask,
}

/// The last three samples with `new` appended where `later` holds (the oldest dropped).
#[inline(always)]
fn shifted<R: Real>(later: R::Mask, v: [R; 3], new: R) -> [R; 3] {
    [R::select(later, v[1], v[0]), R::select(later, v[2], v[1]), R::select(later, new, v[2])]
}

/// One open impact's tracker.
pub type ImpactTracker = Tracker<f64>;

impl<R: Real> Tracker<R> {
    /// Adds a sample (t, F, δ) to the trackers in `active`; returns those that took it and hold
    /// three samples (and whose peaks are not searched), whose parabola's vertex
    /// ([`ImpactTracker::vertex`]) the caller offers as the peak where the middle sample is one
    /// ([`Tracker::middle_is_peak`]; rare for a lane, taken lane by lane).
    #[inline(always)]
    pub fn sample_where(&mut self, active: R::Mask, t: R, force: R, penetration: R) -> R::Mask {
        self.max_penetration = R::select(active, self.max_penetration.max(penetration), self.max_penetration);
        // (A sample at or before the last one only deepens.)
        let later = active & !t.simd_le(self.times[2]);
        if !R::any(later) {
            return later;
        }
        self.times = shifted(later, self.times, t);
        self.forces = shifted(later, self.forces, force);
        self.count = R::select(later, self.count + R::splat(1.0), self.count);
        let higher = later & force.simd_gt(self.peak_force);
        self.peak_force = R::select(higher, force, self.peak_force);
        self.peak_time = R::select(higher, t, self.peak_time);
        later & self.count.simd_ge(R::splat(3.0)) & !self.searched
    }

    /// Whether the middle one of the last three samples is a peak ([`ImpactTracker::vertex`]'s
    /// first test, for every lane at once).
    #[inline(always)]
    pub fn middle_is_peak(&self) -> R::Mask {
        let [f0, f1, f2] = self.forces;
        f1.simd_ge(f0) & f1.simd_ge(f2) & (f1.simd_gt(f0) | f1.simd_gt(f2))
    }
}

impl ImpactTracker {
    /// Opens a tracker at the onset. `searched`: the integrator hands every step's continuous
    /// extension to [`step_peak`], so the peak comes from those searches and the parabola through
    /// samples (which overshoots a skewed peak by up to 1e-5 relative at DOP853's step sizes) is
    /// not used.
    pub fn open(t: f64, onset_velocity: f64, searched: bool) -> Self {
        Self {
            onset_time: t,
            onset_velocity,
            peak_force: 0.0,
            peak_time: t,
            max_penetration: 0.0,
            times: [t; 3],
            forces: [0.0; 3],
            count: 1.0,
            searched,
        }
    }

    /// Adds a sample of the trajectory (at an accepted step or an event).
    pub fn sample(&mut self, t: f64, force: f64, penetration: f64) {
        if self.sample_where(true, t, force, penetration) {
            self.offer_vertex();
        }
    }

    /// Offers the vertex of the parabola through the last three samples as the peak.
    #[inline]
    pub fn offer_vertex(&mut self) {
        let samples = std::array::from_fn(|k| (self.times[k], self.forces[k]));
        if let Some((tv, fv)) = Self::vertex(samples)
            && fv > self.peak_force
        {
            self.peak_force = fv;
            self.peak_time = tv;
        }
    }

    /// The vertex (time, force) of the parabola through three samples (t, F) when the middle one
    /// is a peak and the vertex lies between the outer two.
    #[inline]
    pub fn vertex(samples: [(f64, f64); 3]) -> Option<(f64, f64)> {
        let [(t0, f0), (t1, f1), (t2, f2)] = samples;
        if !(f1 >= f0 && f1 >= f2 && (f1 > f0 || f1 > f2)) {
            return None;
        }
        let d0 = (f1 - f0) / (t1 - t0);
        let d1 = (f2 - f1) / (t2 - t1);
        let curv = (d1 - d0) / (t2 - t0);
        if curv >= 0.0 || curv.is_nan() {
            return None;
        }
        let tv = 0.5 * (t0 + t1) - d0 / (2.0 * curv);
        if !(tv > t0 && tv < t2) {
            return None;
        }
        Some((tv, f1 + d0 * (tv - t1) + curv * (tv - t0) * (tv - t1)))
    }

    /// Records a penetration seen inside a step.
    pub fn deepen(&mut self, penetration: f64) {
        self.max_penetration = self.max_penetration.max(penetration);
    }

    /// Offers a refined peak (from a search on a step's continuous extension).
    pub fn peak_candidate(&mut self, t: f64, force: f64) {
        if force > self.peak_force {
            self.peak_force = force;
            self.peak_time = t;
        }
    }

    /// Takes what a search of a step found: its deepest penetration and its peak.
    pub fn accept(&mut self, search: StepSearch) {
        self.deepen(search.deepest);
        if let Some((t, force)) = search.peak {
            self.peak_candidate(t, force);
        }
    }

    /// The impact as it stands at `t` while still open (exit time NaN, duration so far).
    pub fn so_far(&self, t: f64) -> Impact {
        Impact {
            onset_time: self.onset_time,
            onset_velocity: self.onset_velocity,
            exit_time: f64::NAN,
            duration: t - self.onset_time,
            peak_force: self.peak_force,
            peak_time: self.peak_time,
            max_penetration: self.max_penetration,
        }
    }

    /// Closes the impact at `t` (its exit): the last sample, exit time and duration.
    pub fn close(mut self, t: f64) -> Impact {
        self.sample(t, 0.0, 0.0);
        Impact { exit_time: t, ..self.so_far(t) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parabolic_refinement_finds_the_peak_of_a_parabola() {
        let f = |t: f64| 100.0 - 4.0 * (t - 0.37).powi(2);
        let mut tr = ImpactTracker::open(0.0, 1.0, false);
        for t in [0.1, 0.25, 0.33, 0.41, 0.6, 0.9] {
            tr.sample(t, f(t), 0.0);
        }
        let imp = tr.close(1.0);
        assert!((imp.peak_force - 100.0).abs() < 1e-9);
        assert!((imp.peak_time - 0.37).abs() < 1e-9);
    }

    /// A rigid joint (no bush) of body 0's centre in a ground bearing of radius 10 mm, in contact.
    fn pin(journal_radius: f64, law: NormalForce, friction: FrictionLaw, onset_velocity: f64) -> ClearanceJoint {
        ClearanceJoint {
            name: "j".into(),
            journal_body: BodyId::Body(0),
            journal_point: Vec2::zeros(),
            bearing_body: BodyId::Ground,
            bearing_point: Vec2::zeros(),
            journal_radius,
            bearing_radius: 0.01,
            law,
            friction,
            bush_stiffness: f64::INFINITY,
            bush_damping: 0.0,
            film: None,
            in_contact: true,
            onset_velocity,
        }
    }

    #[test]
    fn sign_conventions_of_a_pressed_journal() {
        // Journal displaced +x by c + δ and moving further +x while spinning: normal force
        // pushes it back (−x); slip v_t = ė·t + ω_J R_J, t = +y.
        let joint = pin(
            0.0095,
            NormalForce::Power { stiffness: 1e10, exponent: 1.0 },
            FrictionLaw::Coulomb { coefficient: 0.1 },
            1.0,
        );
        let q = [0.0005 + 1e-6, 0.0, 0.0];
        let qd = [0.3, 0.2, 10.0];
        let s = joint.evaluate(&Pose::of(BodyId::Body(0), &q, &qd), &Pose::GROUND, 1.0);
        assert!((s.penetration - 1e-6).abs() < 1e-15);
        assert!((s.penetration_rate - 0.3).abs() < 1e-15);
        assert!((s.slip_velocity - (0.2 + 10.0 * 0.0095)).abs() < 1e-15);
        assert!((s.normal_force - 1e4).abs() < 1e-6);
        assert!((s.force_on_journal.x + 1e4).abs() < 1e-6);
        assert!((s.force_on_journal.y + 1e3).abs() < 1e-6);
    }

    proptest::proptest! {
        /// The stated bound of the one-division forms (the normal as e · (1/|e|), the
        /// hysteresis factor as 1 + χ δ̇ · (1/max(δ̇⁻, floor))) against the quotients written out
        /// (e/|e|, χ δ̇ / max(δ̇⁻, floor)): the normal within 2 ε per component, δ̇ within 4 ε |ė|,
        /// the normal force within 8 ε of the size of its terms, K δ^1.5 (1 + χ (|δ̇| + |ė|) /
        /// max(δ̇⁻, floor)) — rounding, not a different law.
        #[test]
        fn one_division_forms_stay_within_rounding_of_the_quotients(
            angle in 0.0..std::f64::consts::TAU,
            depth in -5e-5..5e-5f64,
            (ux, uy) in (-3.0..3.0f64, -3.0..3.0f64),
            onset in 0.0..2.0f64,
            omega in -600.0..600.0f64,
        ) {
            let (stiffness, chi, floor) = (5e9, 0.6, 1e-4);
            let joint = pin(
                0.0099,
                NormalForce::Hysteresis { stiffness, exponent: 1.5, chi, floor },
                FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4, v1: 1e-3 },
                onset,
            );
            let c = joint.radial_clearance();
            let e = Vec2::new((c + depth) * angle.cos(), (c + depth) * angle.sin());
            let e_dot = Vec2::new(ux, uy);
            let s = joint.evaluate_relative(e, e_dot, omega, 0.0, onset);
            let eps = f64::EPSILON;
            let n = e / e.norm();
            proptest::prop_assert!((s.normal - n).abs().max() <= 2.0 * eps, "{:?} against {:?}", s.normal, n);
            let delta_dot = e_dot.dot(&n);
            proptest::prop_assert!((s.penetration_rate - delta_dot).abs() <= 4.0 * eps * e_dot.norm());
            let delta = e.norm() - c;
            proptest::prop_assert_eq!(s.penetration, delta);
            if delta > 0.0 {
                let elastic = stiffness * delta.powf(1.5);
                let quotient = (elastic * (1.0 + chi * delta_dot / onset.max(floor))).max(0.0);
                let scale = elastic * (1.0 + chi * (delta_dot.abs() + e_dot.norm()) / onset.max(floor));
                proptest::prop_assert!(
                    (s.normal_force - quotient).abs() <= 8.0 * eps * scale,
                    "{} against {quotient} (scale {scale})", s.normal_force
                );
            }
        }
    }
}
