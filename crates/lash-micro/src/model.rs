//! The clearance interface of k clearance joints as one ODE of N interface coordinates
//! (docs/theory.md §6, §8):
//!
//! ```text
//!     M̃(t) ẅ = f̃(t) + f_c(w, ẇ) + H(t) L(w, ẇ)
//! ```
//!
//! with w the stacked eccentricities, f_c the contact forces on the journals (through the joint
//! centres), L the joints' friction loads and H the interface force equivalent to them per unit
//! load (built by the macro side). For planar revolute clearance joints (N = 2k) L holds each
//! joint's friction force F_T, whose moments are R_J F_T on the journal body and R_B F_T on the
//! bearing body; for spherical ones (N = 3k) L holds each joint's n × F_T (3 per joint), whose
//! moments are R_J n × F_T on the ball's body and −R_B n × F_T on the socket's. The off-diagonal
//! blocks of M̃ and H couple the joints.
//!
//! One model serves every joint kind ([`MicroJoint`]); the dimensions are const generics: the
//! state lives in fixed-size vectors on the stack and a micro step allocates nothing. The macro
//! terms come in one of two forms, the joint kind's ([`MicroJoint::MOBILITY_FORM`]): the
//! effective-mass form above (planar joints: one joint (N = 2) solves M̃ by Cramer's rule, more
//! coordinates by an L D Lᵀ factorisation of the N × N effective mass, symmetric positive
//! definite), or the mobility form ẅ = a_free + W f_c + G L ([`Mobility`]; spherical joints),
//! which multiplies instead of solving.

use super::joint::MicroJoint;
use super::stages::{self, Rk4Stage};
use lash_contact::PenetrationError;
use lash_contact::clearance::PENETRATION_LIMIT_FRACTION;
use lash_contact::clearance::{ClearanceJoint, Impact, ImpactTracker};
use lash_contact::joint::Clearance;
use lash_ode::{AdaptiveOptions, Method, OdeSystem};
use nalgebra::{SMatrix, SVector};

/// Interface coordinates of one planar clearance joint (its eccentricity e_x, e_y).
pub const PLANAR_JOINT_COORDINATES: usize = 2;

/// The macro terms seen by the micro model at a communication point (N interface coordinates, M
/// friction loads, R angular velocity components per side): values and rates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceInputs<const N: usize, const M: usize, const R: usize> {
    /// Effective mass M̃ \[kg\].
    pub effective_mass: SMatrix<f64, N, N>,
    /// dM̃/dt [kg/s].
    pub effective_mass_rate: SMatrix<f64, N, N>,
    /// Effective force f̃ \[N\].
    pub effective_force: SVector<f64, N>,
    /// df̃/dt [N/s].
    pub effective_force_rate: SVector<f64, N>,
    /// H: interface force equivalent to each friction load, per unit load (column per load).
    pub friction_moment_force: SMatrix<f64, N, M>,
    /// dH/dt.
    pub friction_moment_force_rate: SMatrix<f64, N, M>,
    /// Angular velocity of each joint's journal body [rad/s] (planar: one per joint; spherical:
    /// three per joint, world frame).
    pub journal_angular_velocity: [f64; R],
    /// Its rate [rad/s²].
    pub journal_angular_acceleration: [f64; R],
    /// Angular velocity of each joint's bearing body [rad/s].
    pub bearing_angular_velocity: [f64; R],
    /// Its rate [rad/s²].
    pub bearing_angular_acceleration: [f64; R],
}

impl<const N: usize, const M: usize, const R: usize> Default for InterfaceInputs<N, M, R> {
    fn default() -> Self {
        Self {
            effective_mass: SMatrix::identity(),
            effective_mass_rate: SMatrix::zeros(),
            effective_force: SVector::zeros(),
            effective_force_rate: SVector::zeros(),
            friction_moment_force: SMatrix::zeros(),
            friction_moment_force_rate: SMatrix::zeros(),
            journal_angular_velocity: [0.0; R],
            journal_angular_acceleration: [0.0; R],
            bearing_angular_velocity: [0.0; R],
            bearing_angular_acceleration: [0.0; R],
        }
    }
}

/// The inputs of k planar joints (N = 2k): one friction load and one rotation per joint.
pub type PlanarInputs<const N: usize, const K: usize> = InterfaceInputs<N, K, K>;

/// Contact loads at one state: f_c on the journals (N) and the friction loads (M).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loads<const N: usize, const M: usize> {
    /// Contact forces on the journals, stacked \[N\].
    pub contact: SVector<f64, N>,
    /// Friction loads (planar: F_T \[N\]; spherical: n × F_T \[N\]).
    pub friction: SVector<f64, M>,
}

impl<const N: usize, const M: usize> Loads<N, M> {
    /// No contact anywhere.
    #[inline(always)]
    pub fn zero() -> Self {
        Self { contact: SVector::zeros(), friction: SVector::zeros() }
    }
}

/// A 2 × 2 matrix's entries row by row ([`stages`]' order; called where N = 2 only).
#[inline(always)]
fn row_major_2x2<const N: usize>(m: &SMatrix<f64, N, N>) -> [f64; 4] {
    [m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]]
}

/// Euclidean norm of a short slice.
#[inline(always)]
fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The effective mass at one instant, ready to solve M̃ x = r: one joint by Cramer's rule (M̃ and
/// 1/det kept), more by an L D Lᵀ factorisation (M̃ is symmetric positive definite) with the
/// reciprocal pivots kept, so that neither factoring nor solving takes a square root and solving
/// divides nothing. Measured on the two-joint micro step: nalgebra's closed-form 4 × 4 inverse
/// 2.69×, its Cholesky factor with two triangular solves 2.85×, L D Lᵀ 2.56× the one-joint step
/// (both joints in contact throughout). A micro step needs the factor at three instants (t,
/// t + h/2, t + h), and t is the previous step's t + h: two factorisations per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassFactor<const N: usize> {
    /// One joint: M̃ itself; more: L of M̃ = L D Lᵀ below the diagonal (unit diagonal implied).
    pub(super) mass: SMatrix<f64, N, N>,
    /// One joint: 1/det M̃; more: unused.
    pub(super) reciprocal_determinant: f64,
    /// More joints: 1/D_ii.
    pub(super) reciprocal_diagonal: SVector<f64, N>,
}

impl<const N: usize> MassFactor<N> {
    /// No factor (a step end of a model in mobility form keeps none).
    pub(super) const NONE: Self = Self {
        mass: SMatrix::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; N])),
        reciprocal_determinant: 0.0,
        reciprocal_diagonal: SVector::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; 1])),
    };

    /// Factors `mass`. Not positive definite (impossible for M̃ interpolated between two positive
    /// definite nodes): NaN, which the step's penetration check reports.
    #[inline(always)]
    pub fn new(mass: SMatrix<f64, N, N>) -> Self {
        if N == 2 {
            let reciprocal_determinant = stages::planar_factor(&row_major_2x2(&mass));
            return Self { mass, reciprocal_determinant, reciprocal_diagonal: SVector::zeros() };
        }
        // M̃ = L D Lᵀ, L unit lower triangular (below the diagonal of `mass`), 1/D kept: no square
        // root, one division per coordinate.
        Self::factor_lower(mass)
    }

    /// Factors M̃ + Ṁ dt. Above one joint only the lower triangle is interpolated, straight into
    /// the factor's storage (the factor reads nothing else): the same entries as interpolating
    /// the whole matrix and factoring it, without the other half and the copy.
    #[inline(always)]
    pub fn interpolated(mass: &SMatrix<f64, N, N>, rate: &SMatrix<f64, N, N>, dt: f64) -> Self {
        if N == 2 {
            let (m, reciprocal_determinant) = stages::planar_mass(row_major_2x2(mass), row_major_2x2(rate), dt);
            let mass = SMatrix::from_fn(|i, j| m[2 * i + j]);
            return Self { mass, reciprocal_determinant, reciprocal_diagonal: SVector::zeros() };
        }
        Self::factor_lower(Self::lower_at(mass, rate, dt))
    }

    /// The lower triangle (diagonal included) of M̃ + Ṁ dt; the rest zero.
    #[inline(always)]
    fn lower_at(mass: &SMatrix<f64, N, N>, rate: &SMatrix<f64, N, N>, dt: f64) -> SMatrix<f64, N, N> {
        let mut lower = SMatrix::<f64, N, N>::zeros();
        for j in 0..N {
            for i in j..N {
                lower[(i, j)] = mass[(i, j)] + rate[(i, j)] * dt;
            }
        }
        lower
    }

    /// [`MassFactor::interpolated`] at two instants, `dt` apart from the nodes each: above one
    /// joint both factorisations run in one loop, each entry's operations as alone (the same bits),
    /// so that the two chains of dependent divisions and products overlap instead of following
    /// each other (alone, one 6 × 6 factor is a chain of six divisions).
    #[inline(always)]
    pub fn interpolated_pair(mass: &SMatrix<f64, N, N>, rate: &SMatrix<f64, N, N>, dt: [f64; 2]) -> [Self; 2] {
        if N == 2 {
            // (Arrays written out rather than `map`ped: `map` was a call of its own in the step.)
            return [Self::interpolated(mass, rate, dt[0]), Self::interpolated(mass, rate, dt[1])];
        }
        Self::factor_lower_pair([Self::lower_at(mass, rate, dt[0]), Self::lower_at(mass, rate, dt[1])])
    }

    /// [`MassFactor::factor_lower`] of two matrices in one loop.
    #[inline(always)]
    fn factor_lower_pair(mut l: [SMatrix<f64, N, N>; 2]) -> [Self; 2] {
        let mut reciprocal_diagonal = [SVector::<f64, N>::zeros(); 2];
        let mut diagonal = [[0.0; N]; 2];
        let mut scaled = [[0.0; N]; 2];
        let mut failed = [false; 2];
        for j in 0..N {
            let mut d = [l[0][(j, j)], l[1][(j, j)]];
            for k in 0..j {
                for p in 0..2 {
                    scaled[p][k] = l[p][(j, k)] * diagonal[p][k];
                    d[p] -= l[p][(j, k)] * scaled[p][k];
                }
            }
            let mut inv = [0.0; 2];
            for p in 0..2 {
                failed[p] |= !(d[p] > 0.0);
                inv[p] = 1.0 / d[p];
                diagonal[p][j] = d[p];
                reciprocal_diagonal[p][j] = inv[p];
            }
            for i in j + 1..N {
                let mut v = [l[0][(i, j)], l[1][(i, j)]];
                for k in 0..j {
                    for p in 0..2 {
                        v[p] -= l[p][(i, k)] * scaled[p][k];
                    }
                }
                for p in 0..2 {
                    l[p][(i, j)] = v[p] * inv[p];
                }
            }
        }
        let [l0, l1] = l;
        let factor = |mass, reciprocal_diagonal, failed: bool| {
            if failed {
                Self {
                    mass: SMatrix::repeat(f64::NAN),
                    reciprocal_determinant: 0.0,
                    reciprocal_diagonal: SVector::repeat(f64::NAN),
                }
            } else {
                Self { mass, reciprocal_determinant: 0.0, reciprocal_diagonal }
            }
        };
        [factor(l0, reciprocal_diagonal[0], failed[0]), factor(l1, reciprocal_diagonal[1], failed[1])]
    }

    /// The L D Lᵀ factor of the matrix whose lower triangle (diagonal included) is `mass`'s,
    /// formed in place: entry (i, j) of the matrix is read just before L's entry replaces it,
    /// and the diagonal is read only.
    #[inline(always)]
    fn factor_lower(mut l: SMatrix<f64, N, N>) -> Self {
        let mut reciprocal_diagonal = SVector::<f64, N>::zeros();
        let mut diagonal = [0.0; N];
        let mut scaled = [0.0; N]; // L_jk D_k of the row being factored
        for j in 0..N {
            let mut d = l[(j, j)];
            for k in 0..j {
                scaled[k] = l[(j, k)] * diagonal[k];
                d -= l[(j, k)] * scaled[k];
            }
            if !(d > 0.0) {
                return Self {
                    mass: SMatrix::repeat(f64::NAN),
                    reciprocal_determinant: 0.0,
                    reciprocal_diagonal: SVector::repeat(f64::NAN),
                };
            }
            let inv = 1.0 / d;
            diagonal[j] = d;
            reciprocal_diagonal[j] = inv;
            for i in j + 1..N {
                let mut v = l[(i, j)];
                for k in 0..j {
                    v -= l[(i, k)] * scaled[k];
                }
                l[(i, j)] = v * inv;
            }
        }
        Self { mass: l, reciprocal_determinant: 0.0, reciprocal_diagonal }
    }

    /// x = M̃⁻¹ r.
    #[inline(always)]
    pub fn solve(&self, r: &SVector<f64, N>) -> SVector<f64, N> {
        let m = &self.mass;
        let mut x = SVector::zeros();
        if N == 2 {
            let solved = stages::planar_solve((&row_major_2x2(m), self.reciprocal_determinant), [r[0], r[1]]);
            x[0] = solved[0];
            x[1] = solved[1];
            return x;
        }
        // L y = r, y ← D⁻¹ y, then Lᵀ x = y (L unit lower triangular).
        let d = &self.reciprocal_diagonal;
        for i in 0..N {
            let mut v = r[i];
            for j in 0..i {
                v -= m[(i, j)] * x[j];
            }
            x[i] = v;
        }
        for i in (0..N).rev() {
            let mut v = x[i] * d[i];
            for j in i + 1..N {
                v -= m[(j, i)] * x[j];
            }
            x[i] = v;
        }
        x
    }
}

/// The macro terms in mobility form, the inputs of the kinds of joint with
/// [`MicroJoint::MOBILITY_FORM`] (value and rate at the inputs' time, like [`InterfaceInputs`]):
///
/// ```text
///     ẅ = a_free(t) + W(t) f_c + G(t) L,    W = M̃⁻¹,  a_free = W f̃,  G = W H,
/// ```
///
/// the mobility W, the free acceleration a_free and the friction mobility G exported by the
/// macro side as they are, each linear across the communication step between its values at the
/// nodes (as M̃, f̃ and H are in the effective-mass form). Both forms are exact at the nodes and
/// first order between them; they differ by O(h_m²) inside a step (a test bounds that). A micro
/// step in mobility form forms the terms at its instants and multiplies, where the
/// effective-mass form factors M̃ twice and solves with the factor four times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mobility<const N: usize, const M: usize> {
    /// W [1/kg].
    pub mobility: SMatrix<f64, N, N>,
    /// dW/dt [1/(kg s)].
    pub mobility_rate: SMatrix<f64, N, N>,
    /// G = W H, the interface acceleration per unit friction load [1/kg].
    pub friction_mobility: SMatrix<f64, N, M>,
    /// dG/dt.
    pub friction_mobility_rate: SMatrix<f64, N, M>,
    /// a_free = W f̃ [m/s²].
    pub free_acceleration: SVector<f64, N>,
    /// da_free/dt [m/s³].
    pub free_acceleration_rate: SVector<f64, N>,
}

impl<const N: usize, const M: usize> Default for Mobility<N, M> {
    fn default() -> Self {
        Self {
            mobility: SMatrix::identity(),
            mobility_rate: SMatrix::zeros(),
            friction_mobility: SMatrix::zeros(),
            friction_mobility_rate: SMatrix::zeros(),
            free_acceleration: SVector::zeros(),
            free_acceleration_rate: SVector::zeros(),
        }
    }
}

impl<const N: usize, const M: usize> Mobility<N, M> {
    /// The terms at `dt` after the step's start.
    #[inline(always)]
    pub fn at(&self, dt: f64) -> MobilityAt<N, M> {
        let mut at = MobilityAt {
            mobility: self.mobility,
            friction_mobility: self.friction_mobility,
            free_acceleration: self.free_acceleration,
        };
        stages::linear_at(at.mobility.as_mut_slice(), self.mobility_rate.as_slice(), dt);
        stages::linear_at(at.friction_mobility.as_mut_slice(), self.friction_mobility_rate.as_slice(), dt);
        stages::linear_at(at.free_acceleration.as_mut_slice(), self.free_acceleration_rate.as_slice(), dt);
        at
    }
}

/// [`Mobility`] at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MobilityAt<const N: usize, const M: usize> {
    /// W [1/kg].
    pub mobility: SMatrix<f64, N, N>,
    /// G = W H [1/kg].
    pub friction_mobility: SMatrix<f64, N, M>,
    /// a_free [m/s²].
    pub free_acceleration: SVector<f64, N>,
}

impl<const N: usize, const M: usize> MobilityAt<N, M> {
    /// ẅ = a_free + W f_c + G L, column by column (the loads of a joint in free flight are zero
    /// and add nothing).
    #[inline(always)]
    pub fn acceleration(&self, loads: &Loads<N, M>) -> SVector<f64, N> {
        let mut a = self.free_acceleration;
        stages::add_columns(a.as_mut_slice(), self.mobility.as_slice(), loads.contact.as_slice());
        stages::add_columns(a.as_mut_slice(), self.friction_mobility.as_slice(), loads.friction.as_slice());
        a
    }
}

/// The macro terms at one instant, ready to give ẅ for given loads: the effective-mass form's
/// factor ([`MassFactor`]) or the mobility form's terms ([`MobilityAt`]).
pub(super) trait InstantTerms<const N: usize, const M: usize>: Sized {
    /// The terms at `t`.
    fn at<J: MicroJoint, const K: usize, const R: usize>(model: &InterfaceModel<J, N, K, M, R>, t: f64) -> Self;
    /// The terms at two instants.
    fn pair<J: MicroJoint, const K: usize, const R: usize>(
        model: &InterfaceModel<J, N, K, M, R>,
        t: [f64; 2],
    ) -> [Self; 2];
    /// ẅ at `t` for `loads`.
    fn acceleration<J: MicroJoint, const K: usize, const R: usize>(
        &self,
        model: &InterfaceModel<J, N, K, M, R>,
        t: f64,
        loads: &Loads<N, M>,
    ) -> SVector<f64, N>;
    /// The terms kept at a step's end for the next step's start, if this form keeps them.
    fn kept(end: &StepEnd<N, M>) -> Option<&Self>;
    /// Keeps the terms in a step's end (a form that keeps nothing leaves it as it is).
    fn keep(self, end: &mut StepEnd<N, M>);
}

impl<const N: usize, const M: usize> InstantTerms<N, M> for MassFactor<N> {
    #[inline(always)]
    fn at<J: MicroJoint, const K: usize, const R: usize>(model: &InterfaceModel<J, N, K, M, R>, t: f64) -> Self {
        model.mass_at(t)
    }
    #[inline(always)]
    fn pair<J: MicroJoint, const K: usize, const R: usize>(
        model: &InterfaceModel<J, N, K, M, R>,
        t: [f64; 2],
    ) -> [Self; 2] {
        model.masses_at(t)
    }
    #[inline(always)]
    fn acceleration<J: MicroJoint, const K: usize, const R: usize>(
        &self,
        model: &InterfaceModel<J, N, K, M, R>,
        t: f64,
        loads: &Loads<N, M>,
    ) -> SVector<f64, N> {
        model.acceleration_with(t, self, loads)
    }
    #[inline(always)]
    fn kept(end: &StepEnd<N, M>) -> Option<&Self> {
        Some(&end.mass)
    }
    #[inline(always)]
    fn keep(self, end: &mut StepEnd<N, M>) {
        end.mass = self;
    }
}

impl<const N: usize, const M: usize> InstantTerms<N, M> for MobilityAt<N, M> {
    #[inline(always)]
    fn at<J: MicroJoint, const K: usize, const R: usize>(model: &InterfaceModel<J, N, K, M, R>, t: f64) -> Self {
        model.mobility.at(t - model.input_time)
    }
    #[inline(always)]
    fn pair<J: MicroJoint, const K: usize, const R: usize>(
        model: &InterfaceModel<J, N, K, M, R>,
        t: [f64; 2],
    ) -> [Self; 2] {
        [Self::at(model, t[0]), Self::at(model, t[1])]
    }
    #[inline(always)]
    fn acceleration<J: MicroJoint, const K: usize, const R: usize>(
        &self,
        _model: &InterfaceModel<J, N, K, M, R>,
        _t: f64,
        loads: &Loads<N, M>,
    ) -> SVector<f64, N> {
        MobilityAt::acceleration(self, loads)
    }
    #[inline(always)]
    fn kept(_end: &StepEnd<N, M>) -> Option<&Self> {
        None
    }
    #[inline(always)]
    fn keep(self, _end: &mut StepEnd<N, M>) {}
}

/// One joint's state (and its damped bush's deflection rate, 0 when `damped` is false) from
/// (e, ė, ω_J, ω_B). A function rather than a closure: a closure here was not inlined, and the
/// call on the hot path cost the rigid micro step a quarter (95 → 123 ns).
#[inline(always)]
fn evaluate_joint<J: MicroJoint, const SERIES: bool>(
    joint: &J,
    damped: bool,
    (e, ed, wj, wb): (&[f64], &[f64], &[f64], &[f64]),
    onset: f64,
    deflection: f64,
) -> (J::State, f64) {
    if damped {
        joint.evaluate_damped(e, ed, wj, wb, onset, deflection)
    } else {
        (joint.evaluate::<SERIES>(e, ed, wj, wb, onset), 0.0)
    }
}

/// The clearance interface of k joints of kind `J` (N = d k coordinates, M = l k friction loads,
/// R = r k rotation components): state (w, ẇ), the impulses ∫f_c dt and ∫L dt, the joints'
/// discrete contact states and their impacts.
#[derive(Clone)]
pub struct InterfaceModel<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize> {
    /// Geometry, contact and friction laws of each joint (their discrete contact states too).
    pub joints: Vec<J>,
    /// Eccentricities w, stacked \[m\].
    pub eccentricity: SVector<f64, N>,
    /// Their rates ẇ [m/s].
    pub eccentricity_rate: SVector<f64, N>,
    /// The deflection s of each joint's bush damped in series, along its normal \[m\] (0 for the
    /// other joints; [`MicroJoint::damped_in_series`]).
    pub bush_deflection: SVector<f64, K>,
    /// ∫ f_c dt on each journal since the start [N s].
    pub impulse: SVector<f64, N>,
    /// ∫ L dt of the friction loads since the start.
    pub friction_impulse: SVector<f64, M>,
    /// Completed impacts of each contact (joint j's contact k at j · CONTACTS + k).
    pub impacts: Vec<Vec<Impact>>,
    /// Each joint's contact state at the current time.
    pub states: Vec<J::State>,
    /// Inputs of the current step.
    pub inputs: InterfaceInputs<N, M, R>,
    /// Time of `inputs` \[s\].
    pub input_time: f64,
    /// Inputs of the current step in mobility form (joints with [`MicroJoint::MOBILITY_FORM`];
    /// their W, a_free and G take the place of `inputs`' M̃, f̃ and H, which they leave unused).
    pub mobility: Mobility<N, M>,
    pub(super) open: Vec<Option<ImpactTracker>>,
    violation: bool,
    /// The last integration was an adaptive one (continuous extensions reach `accept_dense`).
    pub(super) located: bool,
    /// The end of the last RK4 step: the next step's first stage is the same instant and state.
    pub(super) end: Option<StepEnd<N, M>>,
    /// The largest film damping of the joints \[N s/m\] (0: no lubricated joint).
    film_damping: f64,
}

/// The micro model of k planar revolute clearance joints (N = 2k).
pub type PlanarInterfaceModel<const N: usize, const K: usize> = InterfaceModel<ClearanceJoint, N, K, K, K>;

/// The second to fourth stages of [`InterfaceModel::rk4_step`] ([`stages::rk4`]): the model at the
/// step's start `t`, the macro terms at the step's middle and end, and the bushes damped in series:
/// their deflections at the start, and each stage's deflection rates (a stage's deflections follow
/// the rates of the stage before it; unused, and compiled out, without such bushes).
struct LaterStages<
    'a,
    J: MicroJoint,
    F,
    const N: usize,
    const K: usize,
    const M: usize,
    const R: usize,
    const SERIES: bool,
    const DAMPED: bool,
> {
    model: &'a InterfaceModel<J, N, K, M, R>,
    t: f64,
    h: f64,
    terms: [&'a F; 2],
    deflection: SVector<f64, K>,
    rates: [SVector<f64, K>; 4],
}

impl<J, F, const N: usize, const K: usize, const M: usize, const R: usize, const SERIES: bool, const DAMPED: bool>
    stages::StageRates<SVector<f64, N>, Loads<N, M>> for LaterStages<'_, J, F, N, K, M, R, SERIES, DAMPED>
where
    J: MicroJoint,
    F: InstantTerms<N, M>,
{
    #[inline(always)]
    fn rate(&mut self, stage: Rk4Stage, e: SVector<f64, N>, v: SVector<f64, N>) -> (SVector<f64, N>, Loads<N, M>) {
        let terms = if stage == Rk4Stage::Fourth { self.terms[1] } else { self.terms[0] };
        let f = stage.fraction() * self.h;
        let i = stage.index();
        let deflection = if DAMPED { self.deflection + self.rates[i - 1] * f } else { self.deflection };
        self.model.acceleration::<SERIES, DAMPED, F>(self.t + f, terms, (&e, &v), &deflection, &mut self.rates[i])
    }
}

/// What a step's end leaves to the next step's start.
#[derive(Debug, Clone, Copy)]
pub(super) struct StepEnd<const N: usize, const M: usize> {
    pub(super) time: f64,
    pub(super) input_time: f64,
    pub(super) eccentricity: SVector<f64, N>,
    pub(super) eccentricity_rate: SVector<f64, N>,
    pub(super) loads: Loads<N, M>,
    pub(super) mass: MassFactor<N>,
}

impl<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize> InterfaceModel<J, N, K, M, R> {
    /// Centred, resting joints: `joints.len()` must be K, with N, M and R its coordinates,
    /// friction loads and rotations.
    pub fn new(joints: Vec<J>) -> Self {
        assert!(
            joints.len() == K && K * J::COORDINATES == N && K * J::FRICTION_LOADS == M && K * J::ROTATIONS == R,
            "K joints have N = d K coordinates, M = l K friction loads and R = r K rotations"
        );
        let mut m = Self {
            joints,
            eccentricity: SVector::zeros(),
            eccentricity_rate: SVector::zeros(),
            bush_deflection: SVector::zeros(),
            impulse: SVector::zeros(),
            friction_impulse: SVector::zeros(),
            impacts: (0..K * J::CONTACTS).map(|_| Vec::with_capacity(1024)).collect(),
            states: vec![J::State::default(); K],
            inputs: InterfaceInputs::default(),
            input_time: 0.0,
            mobility: Mobility::default(),
            open: vec![None; K * J::CONTACTS],
            violation: false,
            located: false,
            end: None,
            film_damping: 0.0,
        };
        m.film_damping = m.largest_film_damping();
        m.refresh_states(0.0);
        m
    }

    /// Number of joints k.
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// Contact state of joint `j` at (e_j, ė_j) at time `t`, using its current mode (and its
    /// bush's current deflection).
    #[inline(always)]
    pub fn contact_at(&self, t: f64, j: usize, e: &[f64], ed: &[f64]) -> J::State {
        self.contact_at_as::<true, true>(t, j, e, ed, self.bush_deflection[j]).0
    }

    /// [`InterfaceModel::contact_at`] with the bush deflected by `deflection`, and the
    /// deflection's rate; `SERIES = false` only when no joint has a bush in series, `DAMPED =
    /// false` only when none is damped in series (the rate is then 0).
    #[inline(always)]
    fn contact_at_as<const SERIES: bool, const DAMPED: bool>(
        &self,
        t: f64,
        j: usize,
        e: &[f64],
        ed: &[f64],
        deflection: f64,
    ) -> (J::State, f64) {
        let dt = t - self.input_time;
        let u = &self.inputs;
        let r = J::ROTATIONS;
        let (mut wj, mut wb) = ([0.0; 3], [0.0; 3]);
        for i in 0..r {
            wj[i] = u.journal_angular_velocity[r * j + i] + u.journal_angular_acceleration[r * j + i] * dt;
            wb[i] = u.bearing_angular_velocity[r * j + i] + u.bearing_angular_acceleration[r * j + i] * dt;
        }
        let joint = &self.joints[j];
        let damped = DAMPED && joint.damped_in_series();
        let (wj, wb) = (&wj[..r], &wb[..r]);
        if J::CONTACTS > 1 {
            // (Each contact under its own mode: the joint's evaluation.)
            return evaluate_joint::<J, SERIES>(joint, damped, (e, ed, wj, wb), 0.0, deflection);
        }
        if joint.in_contact() {
            // The common case on the hot path, one evaluation returned as it is.
            return evaluate_joint::<J, SERIES>(joint, damped, (e, ed, wj, wb), joint.onset_velocity(), deflection);
        }
        let (s, rate) = evaluate_joint::<J, SERIES>(joint, damped, (e, ed, wj, wb), joint.onset_velocity(), deflection);
        let indentation = J::penetration(&s) - if damped { deflection } else { 0.0 };
        if indentation > 0.0 {
            // A stage ahead of the onset: the local approach velocity (the contact's own, δ̇ − ṡ)
            // stands in for δ̇⁻.
            let onset = (J::penetration_rate(&s) - rate).max(0.0);
            evaluate_joint::<J, SERIES>(joint, damped, (e, ed, wj, wb), onset, deflection)
        } else {
            (s, rate)
        }
    }

    /// Joint `j`'s coordinates of a stacked vector.
    #[inline(always)]
    fn part(v: &SVector<f64, N>, j: usize) -> &[f64] {
        &v.as_slice()[J::COORDINATES * j..J::COORDINATES * (j + 1)]
    }

    /// Writes joint `j`'s loads of state `s`.
    #[inline(always)]
    fn put(&self, loads: &mut Loads<N, M>, j: usize, s: &J::State) {
        let (d, l) = (J::COORDINATES, J::FRICTION_LOADS);
        self.joints[j].loads(
            s,
            &mut loads.contact.as_mut_slice()[d * j..d * (j + 1)],
            &mut loads.friction.as_mut_slice()[l * j..l * (j + 1)],
        );
    }

    /// The loads at (t, w, ẇ) with the bushes deflected by `deflection`, and the deflections'
    /// rates into `rates` (when `DAMPED`): in free flight (|e_j| ≤ c_j, so F_N = F_T = 0) nothing
    /// but |e_j|² (and a damped bush's relaxation) is computed for joint j.
    #[inline(always)]
    fn loads_at<const SERIES: bool, const DAMPED: bool>(
        &self,
        t: f64,
        e: &SVector<f64, N>,
        ed: &SVector<f64, N>,
        deflection: &SVector<f64, K>,
        rates: &mut SVector<f64, K>,
    ) -> Loads<N, M> {
        let mut loads = Loads::zero();
        for j in 0..self.joints.len() {
            let ej = Self::part(e, j);
            if self.joints[j].may_touch(ej) {
                let (s, rate) = self.contact_at_as::<SERIES, DAMPED>(t, j, ej, Self::part(ed, j), deflection[j]);
                self.put(&mut loads, j, &s);
                if DAMPED {
                    rates[j] = rate;
                }
            } else if DAMPED {
                rates[j] = self.joints[j].relaxation_rate(deflection[j]);
            }
        }
        loads
    }

    /// M̃ at two instants, factored ([`MassFactor::interpolated_pair`]).
    #[inline(always)]
    fn masses_at(&self, t: [f64; 2]) -> [MassFactor<N>; 2] {
        let u = &self.inputs;
        let dt = [t[0] - self.input_time, t[1] - self.input_time];
        MassFactor::interpolated_pair(&u.effective_mass, &u.effective_mass_rate, dt)
    }

    /// M̃(t), factored.
    #[inline(always)]
    fn mass_at(&self, t: f64) -> MassFactor<N> {
        let u = &self.inputs;
        MassFactor::interpolated(&u.effective_mass, &u.effective_mass_rate, t - self.input_time)
    }

    /// ẅ at t for given loads: M̃(t)⁻¹ (f̃(t) + f_c + H(t) L), H(t) L formed column by column
    /// and only for the loads that act (no friction load in free flight); written out rather
    /// than as nalgebra's product of the interpolated matrix, which for the spatial joints'
    /// 6 × 12 map was a call of its own on the micro step's path.
    #[inline(always)]
    fn acceleration_with(&self, t: f64, mass: &MassFactor<N>, loads: &Loads<N, M>) -> SVector<f64, N> {
        let dt = t - self.input_time;
        let u = &self.inputs;
        if N == 2 && M == 1 {
            // One planar joint: the lanes' function ([`stages::planar_load`]), entries indexed.
            let pair = |v: &SVector<f64, N>| [v[0], v[1]];
            let column = |m: &SMatrix<f64, N, M>| [m[(0, 0)], m[(1, 0)]];
            let force = (pair(&u.effective_force), pair(&u.effective_force_rate));
            let map = (column(&u.friction_moment_force), column(&u.friction_moment_force_rate));
            let r = stages::planar_load(force, dt, pair(&loads.contact), map, loads.friction[0]);
            return mass.solve(&SVector::from_fn(|i, _| r[i]));
        }
        let mut r = u.effective_force + u.effective_force_rate * dt + loads.contact;
        for j in 0..M {
            let l = loads.friction[j];
            if l == 0.0 {
                continue;
            }
            // Column j of H and of its rate, as slices (indexed entry by entry, this term was a
            // seventh of the spatial micro step's instructions).
            let columns = N * j..N * (j + 1);
            let (map, rate) = (
                &u.friction_moment_force.as_slice()[columns.clone()],
                &u.friction_moment_force_rate.as_slice()[columns],
            );
            for ((ri, hi), ri_rate) in r.iter_mut().zip(map).zip(rate) {
                *ri += (hi + ri_rate * dt) * l;
            }
        }
        mass.solve(&r)
    }

    /// ẅ and the loads at (t, w, ẇ) (and the bushes' deflection rates, see
    /// [`InterfaceModel::loads_at`]).
    #[inline(always)]
    fn acceleration<const SERIES: bool, const DAMPED: bool, F: InstantTerms<N, M>>(
        &self,
        t: f64,
        terms: &F,
        (e, ed): (&SVector<f64, N>, &SVector<f64, N>),
        deflection: &SVector<f64, K>,
        rates: &mut SVector<f64, K>,
    ) -> (SVector<f64, N>, Loads<N, M>) {
        let loads = self.loads_at::<SERIES, DAMPED>(t, e, ed, deflection, rates);
        (terms.acceleration(self, t, &loads), loads)
    }

    /// Puts each joint that starts where it holds the interface force ([`MicroJoint::rest_under`]:
    /// bushings) at that eccentricity, at rest, for the current inputs; the others are left as
    /// they are.
    pub fn settle(&mut self, t: f64) {
        let d = J::COORDINATES;
        let mut moved = false;
        for j in 0..self.joints.len() {
            let force = &self.inputs.effective_force.as_slice()[d * j..d * (j + 1)];
            let mut e = [0.0; 3];
            if self.joints[j].rest_under(force, &mut e[..d]) {
                self.eccentricity.as_mut_slice()[d * j..d * (j + 1)].copy_from_slice(&e[..d]);
                self.eccentricity_rate.as_mut_slice()[d * j..d * (j + 1)].fill(0.0);
                moved = true;
            }
        }
        if moved {
            self.end = None;
            self.refresh_states(t);
        }
    }

    /// Recomputes every joint's contact state at the current (w, ẇ) and time `t`.
    pub fn refresh_states(&mut self, t: f64) {
        for j in 0..self.joints.len() {
            self.states[j] =
                self.contact_at(t, j, Self::part(&self.eccentricity, j), Self::part(&self.eccentricity_rate, j));
        }
    }

    /// One RK4 step of size `h` from `t`; the joints' states at the step end are in `states`.
    /// With a lubricated joint whose film is too stiff for `h` on the interface's mass, the step
    /// is made of as many equal RK4 steps as keep the film's damping stable (h λ ≤ 2.5, λ the
    /// film's largest damping times tr(M̃⁻¹)).
    #[inline(always)]
    pub fn rk4_step(&mut self, t: f64, h: f64) {
        if self.film_damping > 0.0 {
            return self.rk4_film_steps(t, h);
        }
        self.rk4_step_once(t, h)
    }

    /// [`InterfaceModel::rk4_step`] of a model with a film, compiled apart from the dry path.
    #[inline(never)]
    fn rk4_film_steps(&mut self, t: f64, h: f64) {
        let n = self.film_substeps(t, h);
        let dh = h / n as f64;
        for k in 0..n {
            self.rk4_step_once(t + k as f64 * dh, dh);
        }
    }

    /// The joints' largest film damping (0 without a lubricated joint).
    fn largest_film_damping(&self) -> f64 {
        self.joints.iter().map(J::film_damping).fold(0.0, f64::max)
    }

    /// How many RK4 steps the step from `t` of size `h` needs for the films: h λ ≤ 2.5 (RK4 is
    /// stable on the negative real axis to 2.79), λ bounded by the largest film damping times
    /// trace(M̃⁻¹) at the step's two ends (the trace bounds M̃⁻¹'s largest eigenvalue, so λ
    /// bounds every mode's rate of the film on the interface).
    fn film_substeps(&self, t: f64, h: f64) -> usize {
        const STABLE: f64 = 2.5;
        let trace = |dt: f64| -> f64 {
            if J::MOBILITY_FORM {
                (self.mobility.mobility + self.mobility.mobility_rate * dt).trace()
            } else {
                let mass = self.inputs.effective_mass + self.inputs.effective_mass_rate * dt;
                mass.try_inverse().map_or(f64::INFINITY, |w| w.trace())
            }
        };
        let largest = trace(t - self.input_time).max(trace(t + h - self.input_time));
        let n = (h * self.film_damping * largest / STABLE).ceil();
        if n.is_finite() { n.clamp(1.0, 1e5) as usize } else { 1 }
    }

    /// One RK4 step (no division for films).
    #[inline(always)]
    fn rk4_step_once(&mut self, t: f64, h: f64) {
        if J::MOBILITY_FORM {
            self.rk4_step_in::<MobilityAt<N, M>>(t, h)
        } else {
            self.rk4_step_in::<MassFactor<N>>(t, h)
        }
    }

    /// [`InterfaceModel::rk4_step`] with the macro terms in form `F`.
    #[inline(always)]
    pub(super) fn rk4_step_in<F: InstantTerms<N, M>>(&mut self, t: f64, h: f64) {
        if !self.joints.iter().any(J::in_series) {
            self.rk4_step_as::<false, false, F>(t, h)
        } else if self.joints.iter().any(J::damped_in_series) {
            self.rk4_step_damped::<F>(t, h)
        } else {
            self.rk4_step_as::<true, false, F>(t, h)
        }
    }

    /// [`InterfaceModel::rk4_step`] with bushes damped in series, compiled apart: the rare case
    /// kept out of the code of the loops that inline the step.
    #[inline(never)]
    fn rk4_step_damped<F: InstantTerms<N, M>>(&mut self, t: f64, h: f64) {
        self.rk4_step_as::<true, true, F>(t, h)
    }

    /// [`InterfaceModel::rk4_step`] with the series solve in the code or not, and the damped
    /// bushes' deflections as states or not.
    #[inline(always)]
    fn rk4_step_as<const SERIES: bool, const DAMPED: bool, F: InstantTerms<N, M>>(&mut self, t: f64, h: f64) {
        self.located = false;
        let (e0, v0) = (self.eccentricity, self.eccentricity_rate);
        let s0 = if DAMPED { self.bush_deflection } else { SVector::zeros() };
        // The last step's end (same time, same inputs) is this step's start: its factor and, for
        // the same state, its loads are reused.
        // (Loads for the same instant and state; the factor only if the inputs were not set since.)
        let (mut start_kept, mut reused) = (false, None);
        if let Some(end) = &self.end
            && (end.time - t).abs() < 1e-12
        {
            // (Not with damped bushes: the deflections' rates would have to be kept too.)
            if !DAMPED && end.eccentricity == e0 && end.eccentricity_rate == v0 {
                reused = Some(end.loads);
            }
            // The same instant up to rounding (t from integer ticks, the end as t + h): M̃ differs
            // by Ṁ times a few ulps of t, far below the precision of M̃ itself.
            start_kept = end.input_time == self.input_time;
        }
        // The kept factor is read where it lies (a copy of the spatial joints' 6 × 6 factor was a
        // memmove per step).
        let kept = match (&self.end, start_kept) {
            (Some(end), true) => F::kept(end),
            _ => None,
        };
        let computed = if kept.is_some() { None } else { Some(F::at(self, t)) };
        let start = match (&computed, kept) {
            (Some(m), _) => m,
            (None, Some(kept)) => kept,
            (None, None) => unreachable!("terms either kept or computed"),
        };
        let [middle, finish] = F::pair(self, [t + 0.5 * h, t + h]);
        // The bushes' deflection rates of the four stages (unused, and compiled out, without
        // damped bushes): a stage's deflections follow the rates of the stage before it.
        let mut rates = [SVector::<f64, K>::zeros(); 4];
        let first = match reused {
            Some(loads) => (start.acceleration(self, t, &loads), loads),
            None => self.acceleration::<SERIES, DAMPED, F>(t, start, (&e0, &v0), &s0, &mut rates[0]),
        };
        let mut later = LaterStages::<'_, J, F, N, K, M, R, SERIES, DAMPED> {
            model: self,
            t,
            h,
            terms: [&middle, &finish],
            deflection: s0,
            rates,
        };
        let step = stages::rk4(h, (e0, v0), first, &mut later);
        let rates = later.rates;
        let (e1, v1) = (step.eccentricity, step.eccentricity_rate);
        let s1 = if DAMPED { stages::weighted(s0, rates, h) } else { s0 };
        let [l1, l2, l3, l4] = step.loads;
        self.impulse = stages::weighted(self.impulse, [l1.contact, l2.contact, l3.contact, l4.contact], h);
        self.friction_impulse =
            stages::weighted(self.friction_impulse, [l1.friction, l2.friction, l3.friction, l4.friction], h);
        self.switch_modes::<DAMPED>(t, h, (&e0, &v0, &s0), (&e1, &v1, &s1));
        self.eccentricity = e1;
        self.eccentricity_rate = v1;
        if DAMPED {
            self.bush_deflection = s1;
        }
        let mut end = Loads::zero();
        for j in 0..self.joints.len() {
            let (s, _) = self.contact_at_as::<SERIES, DAMPED>(t + h, j, Self::part(&e1, j), Self::part(&v1, j), s1[j]);
            self.put(&mut end, j, &s);
            for k in 0..J::CONTACTS {
                if let Some(tr) = self.open[j * J::CONTACTS + k].as_mut() {
                    let (force, penetration) = J::contact_sample(&s, k);
                    tr.sample(t + h, force, penetration);
                }
            }
            self.states[j] = s;
        }
        // Written in place (the step end is several hundred bytes for the spatial joints).
        let input_time = self.input_time;
        match &mut self.end {
            Some(e) => {
                e.time = t + h;
                e.input_time = input_time;
                e.eccentricity = e1;
                e.eccentricity_rate = v1;
                e.loads = end;
                finish.keep(e);
            }
            None => {
                let (eccentricity, eccentricity_rate, mass) = (e1, v1, MassFactor::NONE);
                let mut first = StepEnd { time: t + h, input_time, eccentricity, eccentricity_rate, loads: end, mass };
                finish.keep(&mut first);
                self.end = Some(first);
            }
        }
    }

    /// The kept step end where the next step from `t` may start from it: the same instant (up to
    /// rounding) and the same state — what the lanes take from a model.
    pub(super) fn end_at(&self, t: f64) -> Option<&StepEnd<N, M>> {
        self.end.as_ref().filter(|end| {
            (end.time - t).abs() < 1e-12
                && end.eccentricity == self.eccentricity
                && end.eccentricity_rate == self.eccentricity_rate
        })
    }

    /// Mode switches at the end of a step from (w0, ẇ0, s0) at `t` to (w1, ẇ1, s1) at `t + h`: a
    /// joint that closes its clearance opens a contact, one that leaves it closes it; the onset
    /// or exit is placed by linear interpolation.
    #[inline(always)]
    pub(super) fn switch_modes<const DAMPED: bool>(
        &mut self,
        t: f64,
        h: f64,
        (e0, v0, s0): (&SVector<f64, N>, &SVector<f64, N>, &SVector<f64, K>),
        (e1, v1, s1): (&SVector<f64, N>, &SVector<f64, N>, &SVector<f64, K>),
    ) {
        if J::CONTACTS > 1 {
            return self.switch_contact_modes(t, h, (e0, v0), (e1, v1));
        }
        let d = J::COORDINATES;
        for j in 0..self.joints.len() {
            let c = self.joints[j].radial_clearance();
            let (a0, a1) = (Self::part(e0, j), Self::part(e1, j));
            // The contact's own indentation δ − s (s = 0 without a damped bush).
            let (d0, d1) =
                if DAMPED { (norm(a0) - c - s0[j], norm(a1) - c - s1[j]) } else { (norm(a0) - c, norm(a1) - c) };
            if !self.joints[j].in_contact() && d1 > 0.0 {
                let frac = if d1 - d0 > 0.0 { (-d0 / (d1 - d0)).clamp(0.0, 1.0) } else { 1.0 };
                let (b0, b1) = (Self::part(v0, j), Self::part(v1, j));
                let (mut ec, mut vc) = ([0.0; 3], [0.0; 3]);
                for i in 0..d {
                    ec[i] = a0[i] + (a1[i] - a0[i]) * frac;
                    vc[i] = b0[i] + (b1[i] - b0[i]) * frac;
                }
                let length = norm(&ec[..d]).max(f64::MIN_POSITIVE);
                let mut rate = (0..d).map(|i| vc[i] * ec[i]).sum::<f64>() / length;
                if DAMPED {
                    // δ̇ − ṡ, the bush relaxing until the contact closes.
                    rate -= self.joints[j].relaxation_rate(s0[j] + (s1[j] - s0[j]) * frac);
                }
                self.open_contact(j, 0, t + frac * h, rate);
            } else if self.joints[j].in_contact() && d1 <= 0.0 {
                let frac = if d0 - d1 > 0.0 { (d0 / (d0 - d1)).clamp(0.0, 1.0) } else { 1.0 };
                self.close_contact(j, 0, t + frac * h);
            }
        }
    }

    /// [`InterfaceModel::switch_modes`] for joints of several contacts: each contact by its own
    /// penetration, the onset or exit placed by linear interpolation of it, the approach
    /// velocity interpolated the same way.
    fn switch_contact_modes(
        &mut self,
        t: f64,
        h: f64,
        (e0, v0): (&SVector<f64, N>, &SVector<f64, N>),
        (e1, v1): (&SVector<f64, N>, &SVector<f64, N>),
    ) {
        for j in 0..self.joints.len() {
            let (a0, a1, b0, b1) = (Self::part(e0, j), Self::part(e1, j), Self::part(v0, j), Self::part(v1, j));
            for k in 0..J::CONTACTS {
                let ((d0, r0), (d1, r1)) =
                    (self.joints[j].contact_gap(a0, b0, k), self.joints[j].contact_gap(a1, b1, k));
                let closed = self.joints[j].contact(k).in_contact();
                if !closed && d1 > 0.0 {
                    let frac = if d1 - d0 > 0.0 { (-d0 / (d1 - d0)).clamp(0.0, 1.0) } else { 1.0 };
                    self.open_contact(j, k, t + frac * h, r0 + (r1 - r0) * frac);
                } else if closed && d1 <= 0.0 {
                    let frac = if d0 - d1 > 0.0 { (d0 / (d0 - d1)).clamp(0.0, 1.0) } else { 1.0 };
                    self.close_contact(j, k, t + frac * h);
                }
            }
        }
    }

    fn open_contact(&mut self, j: usize, k: usize, t: f64, rate: f64) {
        self.joints[j].contact_mut(k).set_mode(true, rate.max(0.0));
        self.open[j * J::CONTACTS + k] = Some(ImpactTracker::open(t, rate, self.located));
    }

    fn close_contact(&mut self, j: usize, k: usize, t: f64) {
        let contact = self.joints[j].contact_mut(k);
        contact.set_mode(false, contact.onset_velocity());
        let c = j * J::CONTACTS + k;
        if let Some(tr) = self.open[c].take() {
            self.impacts[c].push(tr.close(t));
        }
    }

    /// Adds `delta` to the eccentricity rates ẇ (a state estimator's process noise), at time
    /// `t`: the cached step end no longer holds, and the joints' contact states are recomputed in
    /// their current modes.
    pub fn add_to_rates(&mut self, t: f64, delta: &[f64]) {
        for (v, d) in self.eccentricity_rate.iter_mut().zip(delta) {
            *v += d;
        }
        self.end = None;
        self.refresh_states(t);
    }

    /// Resets the discrete contact states (journals must be inside their clearances).
    pub fn reset_contacts(&mut self, t: f64) {
        for joint in &mut self.joints {
            for k in 0..J::CONTACTS {
                joint.contact_mut(k).set_mode(false, 0.0);
            }
        }
        self.bush_deflection = SVector::zeros();
        self.end = None;
        // (Here as well as at construction: a definition applied since may change the radii.)
        self.film_damping = self.largest_film_damping();
        self.refresh_states(t);
    }

    /// Integrates from `t` to `t + h` with DOPRI5 and event location. Returns the number of
    /// accepted steps.
    pub fn dopri5_step(&mut self, options: &AdaptiveOptions, t: f64, h: f64) -> Result<u64, lash_ode::OdeError> {
        let mut y = [0.0; 3 * super::MAX_COORDINATES + super::MAX_FRICTION_LOADS];
        let y = &mut y[..3 * N + M];
        y[..N].copy_from_slice(self.eccentricity.as_slice());
        y[N..2 * N].copy_from_slice(self.eccentricity_rate.as_slice());
        y[2 * N..3 * N].copy_from_slice(self.impulse.as_slice());
        y[3 * N..].copy_from_slice(self.friction_impulse.as_slice());
        let method = Method::Dopri5(AdaptiveOptions { max_step: options.max_step.min(h), ..*options });
        let stats = lash_ode::integrate(&method, self, t, y, t + h, h, &mut |_: &mut Self, _: f64, _: &[f64]| Ok(()))?;
        self.eccentricity.copy_from_slice(&y[..N]);
        self.eccentricity_rate.copy_from_slice(&y[N..2 * N]);
        self.impulse.copy_from_slice(&y[2 * N..3 * N]);
        self.friction_impulse.copy_from_slice(&y[3 * N..]);
        self.end = None;
        self.refresh_states(t + h);
        Ok(stats.steps)
    }

    /// Impacts of contact `c` still open (closed at `t` for reporting, exit time NaN; joint j's
    /// contact k is c = j · CONTACTS + k).
    pub fn open_impacts(&self, c: usize, t: f64) -> Vec<Impact> {
        self.open[c].iter().map(|tr| tr.so_far(t)).collect()
    }

    /// Joint `j`'s penetration is within bounds (and its eccentricity finite).
    pub fn check_penetration(&self, j: usize) -> Result<(), PenetrationError> {
        check_penetration(&self.joints[j], &self.states[j])
    }

    /// Joint `j`'s penetration as a blow-up error (what [`Self::check_penetration`] returns when
    /// it is out of bounds).
    pub fn penetration_error(&self, j: usize) -> PenetrationError {
        penetration_error(&self.joints[j], &self.states[j])
    }
}

impl<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize> OdeSystem
    for InterfaceModel<J, N, K, M, R>
{
    fn dim(&self) -> usize {
        3 * N + M
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let e = SVector::<f64, N>::from_column_slice(&y[..N]);
        let ed = SVector::<f64, N>::from_column_slice(&y[N..2 * N]);
        for j in 0..self.joints.len() {
            let delta = norm(Self::part(&e, j)) - self.joints[j].radial_clearance();
            if (delta > 0.0) != self.joints[j].in_contact() {
                self.violation = true;
            }
        }
        // (Bushes damped in series are refused with this integrator: see InterfaceSubsystem.)
        let (a, loads) = if J::MOBILITY_FORM {
            let terms = MobilityAt::at(self, t);
            self.acceleration::<true, false, _>(t, &terms, (&e, &ed), &self.bush_deflection, &mut SVector::zeros())
        } else {
            let terms = self.mass_at(t);
            self.acceleration::<true, false, _>(t, &terms, (&e, &ed), &self.bush_deflection, &mut SVector::zeros())
        };
        dydt[..N].copy_from_slice(ed.as_slice());
        dydt[N..2 * N].copy_from_slice(a.as_slice());
        dydt[2 * N..3 * N].copy_from_slice(loads.contact.as_slice());
        dydt[3 * N..].copy_from_slice(loads.friction.as_slice());
    }

    fn begin(&mut self, locates_events: bool) {
        self.located = locates_events;
    }

    fn event_count(&self) -> usize {
        self.joints.len()
    }

    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        let d = J::COORDINATES;
        for (j, joint) in self.joints.iter().enumerate() {
            let delta = norm(&y[d * j..d * (j + 1)]) - joint.radial_clearance();
            g[j] = if joint.in_contact() { -delta } else { delta };
        }
    }

    fn on_event(&mut self, j: usize, t: f64, y: &[f64]) {
        if self.joints[j].in_contact() {
            self.close_contact(j, 0, t);
        } else {
            let d = J::COORDINATES;
            let (e, v) = (&y[d * j..d * (j + 1)], &y[N + d * j..N + d * (j + 1)]);
            let rate = (0..d).map(|i| e[i] * v[i]).sum::<f64>() / norm(e).max(f64::MIN_POSITIVE);
            self.open_contact(j, 0, t, rate);
        }
    }

    fn take_mode_violation(&mut self) -> bool {
        std::mem::take(&mut self.violation)
    }

    fn wants_dense(&self) -> bool {
        self.open.iter().any(Option::is_some)
    }

    fn accept_dense(&mut self, t: f64, h: f64, dense: &lash_ode::Dense<'_>) {
        let mut y = [0.0; 3 * super::MAX_COORDINATES + super::MAX_FRICTION_LOADS];
        let y = &mut y[..3 * N + M];
        let d = J::COORDINATES;
        for j in 0..self.joints.len() {
            if self.open[j].is_none() {
                continue;
            }
            let search = lash_contact::clearance::StepSearch::run_with(t, h, |theta| {
                dense.eval(theta, y);
                let s = self.contact_at(t + theta * h, j, &y[d * j..d * (j + 1)], &y[N + d * j..N + d * (j + 1)]);
                (J::normal_force(&s), J::penetration(&s))
            });
            if let Some(tr) = self.open[j].as_mut() {
                tr.accept(search);
            }
        }
    }

    fn accept_step(&mut self, t: f64, y: &[f64]) -> Result<(), lash_ode::BoxError> {
        let d = J::COORDINATES;
        for j in 0..self.joints.len() {
            let s = self.contact_at(t, j, &y[d * j..d * (j + 1)], &y[N + d * j..N + d * (j + 1)]);
            if let Some(tr) = self.open[j].as_mut() {
                tr.sample(t, J::normal_force(&s), J::penetration(&s));
            }
            check_penetration(&self.joints[j], &s)?;
        }
        Ok(())
    }
}

fn check_penetration<J: MicroJoint>(joint: &J, s: &J::State) -> Result<(), PenetrationError> {
    if J::penetration(s) <= PENETRATION_LIMIT_FRACTION * joint.journal_radius() && J::eccentricity_norm(s).is_finite() {
        Ok(())
    } else {
        Err(penetration_error(joint, s))
    }
}

/// The blow-up error of a joint of the micro model in state `s`.
fn penetration_error<J: MicroJoint>(joint: &J, s: &J::State) -> PenetrationError {
    let penetration = if J::eccentricity_norm(s).is_finite() { J::penetration(s) } else { f64::NAN };
    joint.penetration_error(penetration, "the micro model's step")
}

#[cfg(test)]
mod tests {
    use super::MassFactor;
    use nalgebra::{SMatrix, SVector};
    use proptest::prelude::*;

    /// An SPD matrix A Aᵀ + N I from any A, and a right-hand side.
    fn spd<const N: usize>(a: &[f64], r: &[f64]) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
        let a = SMatrix::<f64, N, N>::from_iterator(a.iter().copied());
        (a * a.transpose() + SMatrix::identity() * N as f64, SVector::from_iterator(r.iter().copied()))
    }

    proptest! {
        /// The L D Lᵀ solve agrees with nalgebra's LU solve (an independent factorisation) for
        /// the sizes of two, three and (spatial) two joints of three coordinates.
        #[test]
        fn solving_with_the_factor_equals_an_lu_solve(a in prop::collection::vec(-3.0..3.0f64, 36), r in prop::collection::vec(-1e3..1e3f64, 6)) {
            fn check<const N: usize>(a: &[f64], r: &[f64]) -> Result<(), TestCaseError> {
                let (m, r) = spd::<N>(&a[..N * N], &r[..N]);
                let x = MassFactor::new(m).solve(&r);
                let lu = nalgebra::DMatrix::from_column_slice(N, N, m.as_slice()).lu();
                let reference = lu.solve(&nalgebra::DVector::from_column_slice(r.as_slice())).expect("regular");
                let error = (nalgebra::DVector::from_column_slice(x.as_slice()) - &reference).norm();
                prop_assert!(error <= 1e-12 * reference.norm().max(1.0), "{x} vs {reference}");
                Ok(())
            }
            check::<2>(&a, &r)?;
            check::<4>(&a, &r)?;
            check::<6>(&a, &r)?;
        }

        /// Interpolating only the lower triangle into the factor gives the factor of the whole
        /// interpolated matrix, bit for bit (a non-symmetric rate too: only its lower part counts).
        #[test]
        fn the_interpolated_factor_is_the_factor_of_the_interpolated_matrix(a in prop::collection::vec(-3.0..3.0f64, 36), rate in prop::collection::vec(-50.0..50.0f64, 36), dt in 0.0..1e-3f64, r in prop::collection::vec(-1e3..1e3f64, 6)) {
            fn check<const N: usize>(a: &[f64], rate: &[f64], dt: f64, r: &[f64]) -> Result<(), TestCaseError> {
                let (m, r) = spd::<N>(&a[..N * N], &r[..N]);
                let mut rate = SMatrix::<f64, N, N>::from_iterator(rate[..N * N].iter().copied());
                if N == 2 {
                    rate = rate + rate.transpose(); // Cramer's rule reads the whole matrix
                }
                let whole = MassFactor::new(m + rate * dt);
                prop_assert_eq!(MassFactor::interpolated(&m, &rate, dt).solve(&r), whole.solve(&r));
                Ok(())
            }
            check::<2>(&a, &rate, dt, &r)?;
            check::<4>(&a, &rate, dt, &r)?;
            check::<6>(&a, &rate, dt, &r)?;
        }
    }

    proptest! {
        /// The two factors formed in one loop are each the factor formed alone, bit for bit.
        #[test]
        fn a_pair_of_factors_equals_the_factors_one_by_one(a in prop::collection::vec(-3.0..3.0f64, 36), rate in prop::collection::vec(-2e3..2e3f64, 36), dt in (0.0..1e-3f64, 0.0..1e-3f64), r in prop::collection::vec(-1e3..1e3f64, 6)) {
            fn check<const N: usize>(a: &[f64], rate: &[f64], dt: [f64; 2], r: &[f64]) -> Result<(), TestCaseError> {
                let (m, r) = spd::<N>(&a[..N * N], &r[..N]);
                let rate = SMatrix::<f64, N, N>::from_iterator(rate[..N * N].iter().copied());
                let rate = rate + rate.transpose();
                let pair = MassFactor::interpolated_pair(&m, &rate, dt);
                for (p, dt) in pair.iter().zip(dt) {
                    let alone = MassFactor::interpolated(&m, &rate, dt);
                    // NaN (a rate that makes the matrix indefinite) compares unequal: compare bits.
                    let bits = |f: &MassFactor<N>| f.solve(&r).map(f64::to_bits);
                    prop_assert_eq!(bits(p), bits(&alone));
                }
                Ok(())
            }
            check::<2>(&a, &rate, [dt.0, dt.1], &r)?;
            check::<4>(&a, &rate, [dt.0, dt.1], &r)?;
            check::<6>(&a, &rate, [dt.0, dt.1], &r)?;
        }
    }

    #[test]
    fn a_matrix_that_is_not_positive_definite_gives_nan() {
        let m = SMatrix::<f64, 4, 4>::from_diagonal(&SVector::from([1.0, 2.0, -0.5, 1.0]));
        let x = MassFactor::new(m).solve(&SVector::repeat(1.0));
        assert!(x.iter().all(|v| v.is_nan()), "{x}");
    }

    /// Two spherical joints (N = 6, M = 6) with a clearance far larger than any motion here:
    /// free flight, ẅ = M̃(t)⁻¹ f̃(t).
    fn two_balls() -> super::InterfaceModel<lash_contact::SphericalClearance, 6, 2, 6, 6> {
        let ball = |name: &str| lash_contact::SphericalClearance {
            name: name.into(),
            journal_body: lash_mech::BodyId::Body(0),
            journal_point: lash_spatial::Vec3::zeros(),
            bearing_body: lash_mech::BodyId::Ground,
            bearing_point: lash_spatial::Vec3::zeros(),
            journal_radius: 0.001,
            bearing_radius: 1.0,
            law: lash_contact::NormalForce::Power { stiffness: 1e9, exponent: 1.5 },
            friction: lash_contact::FrictionLaw::Coulomb { coefficient: 0.1 },
            in_contact: false,
            onset_velocity: 0.0,
        };
        super::InterfaceModel::new(vec![ball("a"), ball("b")])
    }

    /// A smooth effective mass and force of time (quadratic in t; M̃ positive definite
    /// throughout, changing by a few % per millisecond like a fast mechanism's).
    fn smooth_terms(t: f64) -> (SMatrix<f64, 6, 6>, SVector<f64, 6>) {
        let a = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2);
        let b = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 2 + j * 5) % 7) as f64 * 0.1 - 0.3);
        let m = a * a.transpose() + SMatrix::identity() * 0.5 + b * b.transpose() * (20.0 * t + 2000.0 * t * t);
        let f = SVector::<f64, 6>::from_fn(|i, _| 10.0 * (i as f64 - 2.5) + 4e3 * t * (i % 3) as f64 - 3e5 * t * t);
        (m, f)
    }

    /// ẇ at T of the two balls driven by `smooth_terms` over macro steps of `h_m` (micro steps of
    /// 1e-5 s), in the effective-mass form and in the mobility form, each from the values at the
    /// macro nodes as the master sets them (value and the slope to the next node).
    fn both_forms(h_m: f64, horizon: f64) -> (SVector<f64, 6>, SVector<f64, 6>) {
        use super::{InstantTerms, MobilityAt};
        fn run<F: InstantTerms<6, 6>>(h_m: f64, horizon: f64) -> SVector<f64, 6> {
            let mut model = two_balls();
            let (h, per) = (1e-5, (h_m / 1e-5).round() as usize);
            for k in 0..(horizon / h_m).round() as usize {
                let (t0, t1) = (k as f64 * h_m, (k + 1) as f64 * h_m);
                let ((m0, f0), (m1, f1)) = (smooth_terms(t0), smooth_terms(t1));
                let (w0, w1) = (m0.try_inverse().unwrap(), m1.try_inverse().unwrap());
                model.inputs.effective_mass = m0;
                model.inputs.effective_mass_rate = (m1 - m0) / h_m;
                model.inputs.effective_force = f0;
                model.inputs.effective_force_rate = (f1 - f0) / h_m;
                let p = &mut model.mobility;
                p.mobility = w0;
                p.mobility_rate = (w1 - w0) / h_m;
                p.free_acceleration = w0 * f0;
                p.free_acceleration_rate = (w1 * f1 - w0 * f0) / h_m;
                model.input_time = t0;
                for i in 0..per {
                    model.rk4_step_in::<F>(t0 + i as f64 * h, h);
                }
            }
            assert!(model.states.iter().all(|s| s.normal_force == 0.0), "free flight throughout");
            model.eccentricity_rate
        }
        (run::<MassFactor<6>>(h_m, horizon), run::<MobilityAt<6, 6>>(h_m, horizon))
    }

    /// The same motion from the exact terms (RK4 at 1e-5 s on ẅ = M̃(t)⁻¹ f̃(t), no
    /// interpolation): the reference both forms converge to.
    fn exact_rate(horizon: f64) -> SVector<f64, 6> {
        let a = |t: f64| {
            let (m, f) = smooth_terms(t);
            m.lu().solve(&f).unwrap()
        };
        let h = 1e-5;
        let mut v = SVector::<f64, 6>::zeros();
        for i in 0..(horizon / h).round() as usize {
            let t = i as f64 * h;
            // ẅ does not depend on (w, ẇ) in free flight: RK4 in v is Simpson's rule.
            v += (a(t) + a(t + 0.5 * h) * 4.0 + a(t + h)) * (h / 6.0);
        }
        v
    }

    /// Both forms interpolate between the same exact nodes; inside a macro step they differ by
    /// O(h_m²), and so do their results after a fixed time: halving h_m quarters both each
    /// form's error against the exactly driven motion and their difference.
    #[test]
    fn the_mobility_form_and_the_effective_mass_form_converge_together_at_second_order() {
        let horizon = 0.02;
        let exact = exact_rate(horizon);
        let (coarse_mass, coarse_mobility) = both_forms(2e-3, horizon);
        let (fine_mass, fine_mobility) = both_forms(1e-3, horizon);
        let order = |coarse: f64, fine: f64| (coarse / fine).log2();
        let (e_mass, e_mobility) = ((coarse_mass - exact).norm(), (coarse_mobility - exact).norm());
        let (f_mass, f_mobility) = ((fine_mass - exact).norm(), (fine_mobility - exact).norm());
        let (d_coarse, d_fine) = ((coarse_mass - coarse_mobility).norm(), (fine_mass - fine_mobility).norm());
        for (what, coarse, fine) in
            [("mass form", e_mass, f_mass), ("mobility form", e_mobility, f_mobility), ("difference", d_coarse, d_fine)]
        {
            let p = order(coarse, fine);
            eprintln!("{what}: {coarse:e} → {fine:e}, order {p:.3}");
            assert!((1.8..2.2).contains(&p), "{what}: order {p} ({coarse:e} → {fine:e})");
        }
        // Small against the velocity itself (h_m = 1 ms, M̃ changing ~2 % per step).
        assert!(d_fine < 1e-3 * exact.norm(), "{d_fine:e} vs |ẇ| = {:e}", exact.norm());
    }

    /// At the nodes the two forms are the same model: for any loads (contact forces and
    /// friction loads), a_free + W f_c + G L = M̃⁻¹ (f̃ + f_c + H L) at both ends of a step.
    #[test]
    fn at_the_nodes_the_mobility_form_gives_the_effective_mass_forms_acceleration() {
        use super::{InstantTerms, Loads, MobilityAt};
        let mut model = two_balls();
        let span = 1e-3;
        let (m0, f0) = smooth_terms(0.01);
        let (m1, f1) = smooth_terms(0.01 + span);
        let h0 = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i + 2 * j) % 5) as f64 - 2.0);
        let h1 = h0 * 1.1 + SMatrix::identity() * 0.3;
        let (w0, w1) = (m0.try_inverse().unwrap(), m1.try_inverse().unwrap());
        model.input_time = 0.01;
        let u = &mut model.inputs;
        (u.effective_mass, u.effective_mass_rate) = (m0, (m1 - m0) / span);
        (u.effective_force, u.effective_force_rate) = (f0, (f1 - f0) / span);
        (u.friction_moment_force, u.friction_moment_force_rate) = (h0, (h1 - h0) / span);
        let p = &mut model.mobility;
        (p.mobility, p.mobility_rate) = (w0, (w1 - w0) / span);
        (p.free_acceleration, p.free_acceleration_rate) = (w0 * f0, (w1 * f1 - w0 * f0) / span);
        (p.friction_mobility, p.friction_mobility_rate) = (w0 * h0, (w1 * h1 - w0 * h0) / span);
        let loads = Loads {
            contact: SVector::from_fn(|i, _| 100.0 * (i as f64 - 2.0)),
            friction: SVector::from_fn(|i, _| if i == 4 { 0.0 } else { 7.0 - 3.0 * i as f64 }),
        };
        for t in [0.01, 0.01 + span] {
            let by_mass = MassFactor::at(&model, t).acceleration(&model, t, &loads);
            let by_mobility = MobilityAt::at(&model, t).acceleration(&loads);
            assert!((by_mass - by_mobility).norm() <= 1e-10 * by_mass.norm(), "t = {t}: {by_mass} vs {by_mobility}");
        }
        // Between the nodes they differ (the interpolations are not the same model there).
        let t = 0.01 + 0.5 * span;
        let by_mass = MassFactor::at(&model, t).acceleration(&model, t, &loads);
        assert_ne!(by_mass, MobilityAt::at(&model, t).acceleration(&loads));
    }
}
