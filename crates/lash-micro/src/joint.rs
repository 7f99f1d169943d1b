//! The clearance joint as the micro model sees it: its interface coordinates, the rotations it
//! needs for the slip, its contact state and the loads that state puts on the interface. One
//! micro model ([`super::InterfaceModel`]) integrates any of them: the planar revolute clearance
//! joint (2 coordinates, the bodies' scalar angular velocities, the friction force F_T as the one
//! friction load whose moments the macro side's map H carries) and the spherical one
//! (3 coordinates, world angular velocity vectors, n × F_T as three friction loads: the friction
//! force's torques are R_J n × F_T on the ball's body and −R_B n × F_T on the socket's, which the
//! macro side's map carries with the radii).

use lash_contact::clearance::{ClearanceJoint, ContactState};
use lash_contact::joint::{Clearance, ContactModes};
use lash_contact::spherical::{SphericalClearance, SphericalContactState};
use lash_mech::Vec2;
use lash_spatial::Vec3;

/// A clearance joint of the micro model. Its contacts ([`ContactModes`]) each have their own mode
/// and impacts; a joint of several contacts evaluates each under its own mode
/// ([`MicroJoint::evaluate`] ignores `onset`) and switches them through
/// [`MicroJoint::contact_gap`].
pub trait MicroJoint: Clearance + ContactModes + Clone + std::fmt::Debug {
    /// Interface coordinates of one joint (its eccentricity): 2 planar, 3 spherical.
    const COORDINATES: usize;
    /// Friction loads of one joint: planar 1 (F_T), spherical 3 (n × F_T, world frame).
    const FRICTION_LOADS: usize;
    /// Angular velocity components of one body: planar 1, spherical 3 (world frame).
    const ROTATIONS: usize;
    /// Whether the micro model holds the macro terms of this kind of joint in mobility form
    /// (W = M̃⁻¹, a_free = W f̃ and W H, each linear between its values at the two ends of the
    /// communication step) rather than in effective-mass form (M̃, f̃ and H linear, M̃ factored at
    /// every instant a micro step needs): see [`super::model::Mobility`].
    const MOBILITY_FORM: bool = false;
    /// Geometry, kinematics and forces at one state.
    type State: Copy + Default + std::fmt::Debug + PartialEq;

    /// Whether a contact may be closed at eccentricity `e` (false: free flight, no contact law
    /// evaluated): |e| > c for a journal in its bearing.
    #[inline(always)]
    fn may_touch(&self, e: &[f64]) -> bool {
        let c = self.radial_clearance();
        e.iter().map(|x| x * x).sum::<f64>() > c * c
    }
    /// A joint of several contacts: contact `k`'s penetration δ_k and its rate δ̇_k at (e, ė),
    /// from the geometry alone (its mode switches are placed by them).
    fn contact_gap(&self, _e: &[f64], _e_dot: &[f64], _k: usize) -> (f64, f64) {
        unreachable!("a joint of one contact switches by its eccentricity")
    }
    /// Contact `k`'s normal force F_N \[N\] and penetration δ \[m\] in state `s`.
    fn contact_sample(s: &Self::State, _k: usize) -> (f64, f64) {
        (Self::normal_force(s), Self::penetration(s))
    }

    /// The state from the eccentricity `e`, its rate `e_dot` (COORDINATES each) and the journal's
    /// and bearing's angular velocities (ROTATIONS each).
    /// `SERIES = false` promises that the joint has no bush in series (see [`MicroJoint::in_series`]).
    fn evaluate<const SERIES: bool>(
        &self,
        e: &[f64],
        e_dot: &[f64],
        omega_journal: &[f64],
        omega_bearing: &[f64],
        onset: f64,
    ) -> Self::State;
    /// Whether the contact is in series with a flexible bush (its evaluation then solves for the
    /// split of the approach).
    fn in_series(&self) -> bool {
        false
    }
    /// Whether the joint's bush in series carries its damping as a state of its own: the bush's
    /// deflection s along the normal ([`ClearanceJoint::bush_damping`]).
    fn damped_in_series(&self) -> bool {
        false
    }
    /// [`MicroJoint::evaluate`] of a joint damped in series, its bush deflected by `deflection`:
    /// the state and the deflection's rate ṡ (the joints without such a bush: ṡ = 0).
    fn evaluate_damped(
        &self,
        e: &[f64],
        e_dot: &[f64],
        omega_journal: &[f64],
        omega_bearing: &[f64],
        onset: f64,
        _deflection: f64,
    ) -> (Self::State, f64) {
        (self.evaluate::<true>(e, e_dot, omega_journal, omega_bearing, onset), 0.0)
    }
    /// The relaxation time c/k of a bush damped in series \[s\] (infinite without one).
    fn relaxation_time(&self) -> f64 {
        f64::INFINITY
    }
    /// ṡ of a bush damped in series whose contact is open: it relaxes, −k s / c (0 without).
    fn relaxation_rate(&self, _deflection: f64) -> f64 {
        0.0
    }
    /// For joints that start at rest where they hold the interface force (bushings): writes that
    /// eccentricity (COORDINATES) for the interface force `force` on the journal and returns true.
    /// Clearance joints start centred (false).
    fn rest_under(&self, _force: &[f64], _e: &mut [f64]) -> bool {
        false
    }
    /// The largest damping coefficient of a lubricated joint's film \[N s/m\] (0 without one):
    /// the micro step divides itself where the film is too stiff for it
    /// ([`super::InterfaceModel::rk4_step`]).
    fn film_damping(&self) -> f64 {
        0.0
    }
    /// |f_c| \[N\] in state `s`: |F_N n + F_T t| from the two orthogonal components (a
    /// lubricated joint: the norm of its force on the journal, the film's included).
    fn force_magnitude(&self, s: &Self::State) -> f64 {
        contact_force_magnitude(Self::normal_force(s), Self::friction_force(s))
    }
    /// The force on the journal (COORDINATES) and the friction loads (FRICTION_LOADS) of a state.
    fn loads(&self, s: &Self::State, force: &mut [f64], friction: &mut [f64]);
    /// δ \[m\].
    fn penetration(s: &Self::State) -> f64;
    /// δ̇ [m/s].
    fn penetration_rate(s: &Self::State) -> f64;
    /// F_N \[N\].
    fn normal_force(s: &Self::State) -> f64;
    /// F_T \[N\] (planar: signed like the slip; spherical: its magnitude).
    fn friction_force(s: &Self::State) -> f64;
    /// |e| \[m\].
    fn eccentricity_norm(s: &Self::State) -> f64;
    /// The slip (planar: v_t, signed; spherical: |v_t|) [m/s].
    fn slip(s: &Self::State) -> f64;
    /// The force on the journal, component `i` \[N\].
    fn force_component(s: &Self::State, i: usize) -> f64;
}

/// |F_N n + F_T t| from the two orthogonal components.
#[inline(always)]
fn contact_force_magnitude(normal: f64, friction: f64) -> f64 {
    (normal * normal + friction * friction).sqrt()
}

/// The accessors of a joint whose state holds its contact's quantities as fields of these names
/// (`ContactState`, `SphericalContactState`).
macro_rules! contact_state_fields {
    ($state:ty) => {
        fn penetration(s: &$state) -> f64 {
            s.penetration
        }
        fn penetration_rate(s: &$state) -> f64 {
            s.penetration_rate
        }
        fn normal_force(s: &$state) -> f64 {
            s.normal_force
        }
        fn friction_force(s: &$state) -> f64 {
            s.friction_force
        }
        fn eccentricity_norm(s: &$state) -> f64 {
            s.eccentricity_norm
        }
        fn force_component(s: &$state, i: usize) -> f64 {
            s.force_on_journal[i]
        }
    };
}

/// The accessors of a joint whose state is the planar [`ContactState`] (the revolute clearance
/// joint and the bushing).
macro_rules! planar_state_accessors {
    () => {
        $crate::joint::contact_state_fields!(ContactState);
        fn slip(s: &ContactState) -> f64 {
            s.slip_velocity
        }
    };
}
pub(crate) use contact_state_fields;
pub(crate) use planar_state_accessors;

impl MicroJoint for ClearanceJoint {
    const COORDINATES: usize = 2;
    const FRICTION_LOADS: usize = 1;
    const ROTATIONS: usize = 1;
    type State = ContactState;

    #[inline(always)]
    fn evaluate<const SERIES: bool>(
        &self,
        e: &[f64],
        e_dot: &[f64],
        wj: &[f64],
        wb: &[f64],
        onset: f64,
    ) -> ContactState {
        let (e, e_dot) = (Vec2::new(e[0], e[1]), Vec2::new(e_dot[0], e_dot[1]));
        let mut s = self.evaluate_relative_as::<SERIES>(e, e_dot, wj[0], wb[0], onset);
        if self.film.is_some() {
            // The film's force through the centres: on the interface, with the contact's.
            s.force_on_journal += self.film_force(e, e_dot, wj[0], wb[0]);
        }
        s
    }
    fn force_magnitude(&self, s: &ContactState) -> f64 {
        if self.film.is_some() {
            s.force_on_journal.norm()
        } else {
            contact_force_magnitude(s.normal_force, s.friction_force)
        }
    }
    fn film_damping(&self) -> f64 {
        self.film.map_or(0.0, |f| f.damping_bound((self.journal_radius, self.radial_clearance())))
    }
    /// A lubricated joint's film acts in free flight too.
    #[inline(always)]
    fn may_touch(&self, e: &[f64]) -> bool {
        let c = self.radial_clearance();
        self.film.is_some() || e[0] * e[0] + e[1] * e[1] > c * c
    }
    #[inline(always)]
    fn in_series(&self) -> bool {
        self.bush_stiffness.is_finite()
    }
    #[inline(always)]
    fn damped_in_series(&self) -> bool {
        ClearanceJoint::damped_in_series(self)
    }
    #[inline(always)]
    fn evaluate_damped(
        &self,
        e: &[f64],
        e_dot: &[f64],
        wj: &[f64],
        wb: &[f64],
        onset: f64,
        deflection: f64,
    ) -> (ContactState, f64) {
        self.evaluate_relative_damped(
            Vec2::new(e[0], e[1]),
            Vec2::new(e_dot[0], e_dot[1]),
            wj[0],
            wb[0],
            onset,
            deflection,
        )
    }
    fn relaxation_time(&self) -> f64 {
        if self.damped_in_series() { self.bush_damping / self.bush_stiffness } else { f64::INFINITY }
    }
    #[inline(always)]
    fn relaxation_rate(&self, deflection: f64) -> f64 {
        self.bush_relaxation_rate(deflection)
    }
    #[inline(always)]
    fn loads(&self, s: &ContactState, force: &mut [f64], friction: &mut [f64]) {
        force[0] = s.force_on_journal.x;
        force[1] = s.force_on_journal.y;
        friction[0] = s.friction_force;
    }
    planar_state_accessors!();
}

impl MicroJoint for SphericalClearance {
    const COORDINATES: usize = 3;
    const FRICTION_LOADS: usize = 3;
    const ROTATIONS: usize = 3;
    // Three coordinates per joint: two coupled joints factor a 6 × 6 M̃ twice per micro step in
    // the effective-mass form (docs/theory.md §8).
    const MOBILITY_FORM: bool = true;
    type State = SphericalContactState;

    #[inline(always)]
    fn evaluate<const SERIES: bool>(
        &self,
        e: &[f64],
        e_dot: &[f64],
        wj: &[f64],
        wb: &[f64],
        onset: f64,
    ) -> SphericalContactState {
        let v = |x: &[f64]| Vec3::new(x[0], x[1], x[2]);
        self.evaluate_relative(v(e), v(e_dot), v(wj), v(wb), onset)
    }
    /// The force through the ball's centre, and the friction load m = n × f: the friction
    /// force's torques about the two centres are R_J m on the ball's body and −R_B m on the
    /// socket's (the normal part of f has no moment about either centre), so one vector carries
    /// both and the macro side's map applies the radii.
    #[inline(always)]
    fn loads(&self, s: &SphericalContactState, force: &mut [f64], friction: &mut [f64]) {
        let f = s.force_on_journal;
        force.copy_from_slice(f.as_slice());
        friction.copy_from_slice(s.normal.cross(&f).as_slice());
    }
    contact_state_fields!(SphericalContactState);
    fn slip(s: &SphericalContactState) -> f64 {
        s.slip_velocity.norm()
    }
}
