//! The index-1 KKT solve by Schur complement, allocation-free after construction.
//!
//! With M block diagonal (m, m, I per body) the system `M q̈ + Φ_qᵀλ = Q`, `Φ_q q̈ = γ̂` reduces to
//! `S λ = Φ_q M⁻¹ Q − γ̂` with the SPD matrix `S = Φ_q M⁻¹ Φ_qᵀ` (equations × equations, 7×7 for
//! the slider-crank with a clearance joint), factored by Cholesky; then `q̈ = M⁻¹(Q − Φ_qᵀλ)`.
//! Φ_q is kept sparse (each row touches at most two bodies) and the structural non-zeros of S are
//! listed once. Rows that pin a single coordinate (a driver or a prismatic angle relative to the
//! ground: θ_k = f(t)) are eliminated exactly before the Schur complement: their coordinate's
//! acceleration is γ̂/c, it moves to the right side of the other rows, and their multiplier is
//! recovered from that coordinate's equation of motion. For the slider-crank this shrinks S from
//! 7×7 to 5×5. The factor is kept, so further right-hand sides (the reduced model's [Jᵀ | Q]
//! columns) cost two triangular solves each.

use crate::constraints::{self, Block, ConstraintTerms, JacobianRow};
use crate::dense::SmallCholesky;
use crate::kkt;
use crate::model::{BodyId, Load, Mechanism};
use crate::{Pose, cross};
use nalgebra::DVector;

/// Errors of the mechanics layer, planar and spatial (lash-spatial reports its solves with it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MechError {
    /// The constraint Jacobian (Φ_q) lost full row rank: redundant constraints or a singular configuration.
    #[error("constraint Jacobian is rank deficient at t = {t} s (redundant joints or a singular position)")]
    SingularConstraints {
        /// Time of the failed solve.
        t: f64,
    },
    /// Assembly (position analysis) did not converge.
    #[error(
        "assembly did not converge at t = {t} s: constraint error {residual:e} after {iterations} Newton iterations"
    )]
    AssemblyFailed {
        /// Time of the analysis.
        t: f64,
        /// Remaining max |Φ|.
        residual: f64,
        /// Iterations spent.
        iterations: usize,
    },
}

/// Workspace and results of KKT solves for one mechanism.
pub struct Solver {
    /// Body poses of the current state.
    pub poses: Vec<Pose>,
    /// The sines and cosines of the last poses' angles.
    pub(crate) rotations: constraints::Rotations,
    /// Φ_q by rows (sparse body blocks).
    pub jacobian: Vec<JacobianRow>,
    /// Φ at the current state.
    pub phi: Vec<f64>,
    /// ν at the current state.
    pub nu: Vec<f64>,
    /// γ at the current state (before stabilisation).
    pub gamma: Vec<f64>,
    /// Generalized applied forces Q; [`Solver::set_state`] fills gravity and loads, callers may add.
    pub forces: Vec<f64>,
    /// Generalized accelerations q̈ after [`Solver::solve`].
    pub accelerations: Vec<f64>,
    /// Lagrange multipliers λ after [`Solver::solve`] (reaction = −Φ_qᵀλ).
    pub lambda: DVector<f64>,
    inverse_mass: Vec<f64>,
    gamma_hat: Vec<f64>,
    pub(crate) structure: Structure,
    scratch: Scratch,
    pub(crate) schur: SmallCholesky,
    factored: bool,
    /// The positions (x, y, θ of each body) at which [`Solver::share_factor`] gave this solver
    /// its factor, until the next [`Solver::factor`] (empty: none).
    shared_at: Vec<[f64; 3]>,
    time: f64,
    /// Work vectors of the position and velocity corrections (`kinematics`), kept between calls.
    pub(crate) correction: Correction,
}

/// Work vectors of a Newton or velocity correction: a zero load (n), the step (n), the right-hand
/// side (m), the multipliers (m).
#[derive(Default)]
pub(crate) struct Correction {
    pub(crate) zeros: Vec<f64>,
    pub(crate) step: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
    pub(crate) lambda: DVector<f64>,
}

impl Correction {
    /// Sized for n coordinates and m constraint rows, the zero load zero (allocates only the
    /// first time).
    pub(crate) fn sized(mut self, n: usize, m: usize) -> Self {
        self.zeros.clear();
        self.zeros.resize(n, 0.0);
        self.step.resize(n, 0.0);
        self.rhs.resize(m, 0.0);
        if self.lambda.len() != m {
            self.lambda = DVector::zeros(m);
        }
        self
    }
}

/// Topology-fixed data of the Schur solve.
pub(crate) struct Structure {
    /// Rows pinning one coordinate: (row, coordinate, coefficient ±1).
    pub(crate) fixed: Vec<(usize, usize, f64)>,
    /// Rows kept in S, in order (compact index → row).
    pub(crate) free_rows: Vec<usize>,
    /// Pairs of Jacobian blocks that share a body — the structural non-zeros of S — as
    /// (flat block index in row a, flat block index in row b, index of S[a][b], coordinate offset).
    pub(crate) pairs: Vec<(usize, usize, usize, usize)>,
    /// M⁻¹ with the pinned coordinates zeroed.
    pub(crate) free_inverse_mass: Vec<f64>,
    /// Per row, the coordinate offsets of its two blocks (the ground maps to the padding slot n).
    pub(crate) offsets: Vec<[usize; 2]>,
}

impl Structure {
    /// The structure of `mech`'s KKT system, its bodies' inverse masses `inverse_mass`.
    fn of(mech: &Mechanism, inverse_mass: &[f64]) -> Self {
        let n = mech.coordinate_count();
        let row_bodies = row_bodies(mech);
        let fixed = pinned_rows(mech);
        let free_rows: Vec<usize> = (0..row_bodies.len()).filter(|r| !fixed.iter().any(|f| f.0 == *r)).collect();
        let mut free_inverse_mass = inverse_mass.to_vec();
        for f in &fixed {
            free_inverse_mass[f.1] = 0.0;
        }
        let pairs = schur_pairs(&free_rows, &row_bodies);
        let offsets = row_bodies.iter().map(|r| r.map(|b| if b == Block::NONE { n } else { 3 * b })).collect();
        Structure { fixed, free_rows, pairs, free_inverse_mass, offsets }
    }
}

/// Each constraint row's two moving bodies ([`Block::NONE`] for the ground).
fn row_bodies(mech: &Mechanism) -> Vec<[usize; 2]> {
    let body = |id: BodyId| match id {
        BodyId::Body(k) => k,
        BodyId::Ground => Block::NONE,
    };
    let mut rows = Vec::with_capacity(mech.constraint_count());
    for j in &mech.joints {
        for _ in 0..j.equations() {
            rows.push([body(j.body_i), body(j.body_j)]);
        }
    }
    for d in &mech.drivers {
        rows.push([body(d.body), body(d.reference)]);
    }
    rows
}

/// Rows that pin one coordinate: the angle rows of drivers and prismatic joints whose other side
/// is the ground, as (row, coordinate, coefficient ±1), the first for each coordinate.
fn pinned_rows(mech: &Mechanism) -> Vec<(usize, usize, f64)> {
    let mut fixed: Vec<(usize, usize, f64)> = Vec::new();
    let mut pin = |row: usize, a: BodyId, b: BodyId| {
        let (coord, c) = match (a, b) {
            (BodyId::Body(k), BodyId::Ground) => (3 * k + 2, 1.0),
            (BodyId::Ground, BodyId::Body(k)) => (3 * k + 2, -1.0),
            _ => return,
        };
        if !fixed.iter().any(|f| f.1 == coord) {
            fixed.push((row, coord, c));
        }
    };
    let mut row = 0;
    for j in &mech.joints {
        if matches!(j.kind, crate::model::JointKind::Prismatic { .. }) {
            pin(row, j.body_i, j.body_j);
        }
        row += j.equations();
    }
    for d in &mech.drivers {
        pin(row, d.body, d.reference);
        row += 1;
    }
    fixed
}

/// S's structural non-zeros over the free rows (lower triangle): the pairs of blocks that share a
/// body (see [`Structure::pairs`]).
fn schur_pairs(free_rows: &[usize], row_bodies: &[[usize; 2]]) -> Vec<(usize, usize, usize, usize)> {
    let mut pairs = Vec::new();
    for (ca, &a) in free_rows.iter().enumerate() {
        for (cb, &b) in free_rows[..=ca].iter().enumerate() {
            for ia in 0..2 {
                for ib in 0..2 {
                    let k = row_bodies[a][ia];
                    if k != Block::NONE && k == row_bodies[b][ib] {
                        pairs.push((2 * a + ia, 2 * b + ib, ca * free_rows.len() + cb, 3 * k));
                    }
                }
            }
        }
    }
    pairs
}

/// Buffers of one solve (coordinate-sized ones padded with three ground slots).
struct Scratch {
    lambda: Vec<f64>,
    acc: Vec<f64>,
    reaction: Vec<f64>,
    velocity: Vec<f64>,
}

#[inline]
fn dot3(a: &[f64; 3], b: &[f64]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Solver {
    /// A workspace sized for `mech`.
    pub fn new(mech: &Mechanism) -> Self {
        let n = mech.coordinate_count();
        let m = mech.constraint_count();
        let mut inverse_mass = Vec::with_capacity(n);
        for b in &mech.bodies {
            inverse_mass.extend_from_slice(&[1.0 / b.mass, 1.0 / b.mass, 1.0 / b.inertia]);
        }
        let structure = Structure::of(mech, &inverse_mass);
        let mf = structure.free_rows.len();
        Self {
            poses: vec![Pose::GROUND; mech.bodies.len()],
            rotations: constraints::Rotations::new(mech.bodies.len()),
            jacobian: vec![[Block::EMPTY; 2]; m],
            phi: vec![0.0; m],
            nu: vec![0.0; m],
            gamma: vec![0.0; m],
            forces: vec![0.0; n],
            accelerations: vec![0.0; n],
            lambda: DVector::zeros(m),
            inverse_mass,
            gamma_hat: vec![0.0; m],
            structure,
            scratch: Scratch {
                lambda: vec![0.0; mf],
                acc: vec![0.0; n + 3],
                reaction: vec![0.0; n + 3],
                velocity: vec![0.0; n + 3],
            },
            schur: SmallCholesky::new(mf),
            factored: false,
            shared_at: Vec::new(),
            time: 0.0,
            correction: Correction::default(),
        }
    }

    /// Takes the sines and cosines `other` knows (of the same bodies, e.g. the ideal mechanism's
    /// solver for the cut one's at the same position: its next [`Solver::set_state`] then
    /// computes none).
    pub fn share_rotations(&mut self, other: &Solver) {
        self.rotations.take_from(&other.rotations);
    }

    /// Whether, at any position, this solver's Schur complement S is the leading block of
    /// `other`'s, entry for entry and bit for bit, so that its Cholesky factor is the leading
    /// block of `other`'s ([`Solver::share_factor`]): `mech` (this solver's) has `other_mech`'s
    /// bodies and first joints, and S's rows are rows of those joints only, the first rows of
    /// `other`'s S, with the same coordinates pinned. So it is for the cut mechanism of a reduced
    /// model (the ideal one without its clearance joints, which come last) when its drivers pin
    /// the driven angles.
    pub fn is_leading_block_of(&self, mech: &Mechanism, other: &Solver, other_mech: &Mechanism) -> bool {
        let (st, ot) = (&self.structure, &other.structure);
        let joint_rows: usize = mech.joints.iter().map(|j| j.equations()).sum();
        let mf = st.free_rows.len();
        mech.bodies == other_mech.bodies
            && other_mech.joints.len() >= mech.joints.len()
            && mech.joints[..] == other_mech.joints[..mech.joints.len()]
            && st.free_inverse_mass == ot.free_inverse_mass
            && st.free_rows.iter().all(|&r| r < joint_rows)
            && ot.free_rows.len() >= mf
            && ot.free_rows[..mf] == st.free_rows[..]
    }

    /// Takes the factor of S from `other` (see [`Solver::is_leading_block_of`], which the caller
    /// has checked): the leading block of `other`'s factor, formed at `other`'s current
    /// positions. The next [`Solver::factor`] uses it, instead of forming and factoring S, if
    /// this solver's positions are then the same bits; otherwise it factors as usual. (A factor
    /// that `other` would accept is accepted here: this S's diagonal is part of `other`'s, so its
    /// singularity threshold is no higher.)
    pub fn share_factor(&mut self, other: &Solver) {
        self.shared_at.clear();
        if other.factored {
            self.schur.copy_leading_block(&other.schur);
            self.shared_at.extend(other.poses.iter().map(|p| [p.position.x, p.position.y, p.angle]));
        }
    }

    /// What a position analysis in lanes leaves (`lanes`): the factor it wrote formed at the
    /// current position, at time `t`.
    pub(crate) fn set_factored_at(&mut self, t: f64) {
        self.factored = true;
        self.shared_at.clear();
        self.time = t;
    }

    /// Whether the factorisation of S is the dense kernel's (no profile skipping).
    pub(crate) fn dense_factor(&self) -> bool {
        (0..self.schur.order()).all(|i| self.schur.first_column(i) == 0)
    }

    /// Diagonal of M⁻¹ (per coordinate).
    pub fn inverse_mass(&self) -> &[f64] {
        &self.inverse_mass
    }

    /// Evaluates poses, constraint terms and the applied forces (gravity, loads) at `(t, q, q̇)`.
    pub fn set_state(&mut self, mech: &Mechanism, t: f64, q: &[f64], qd: &[f64]) {
        self.set_terms::<true>(mech, t, q, qd);
        self.set_loads(mech);
    }

    /// What a position analysis needs of [`Solver::set_state`]: the poses, Φ, Φ_q and ν (which
    /// depend on `(t, q)` only; `qd` gives the poses' velocities), the same numbers; γ and the
    /// applied forces are left as they were, stale until the next `set_state`.
    pub fn set_configuration(&mut self, mech: &Mechanism, t: f64, q: &[f64], qd: &[f64]) {
        self.set_terms::<false>(mech, t, q, qd);
    }

    /// The poses and the constraint terms (γ only if `GAMMA`).
    #[inline(always)]
    fn set_terms<const GAMMA: bool>(&mut self, mech: &Mechanism, t: f64, q: &[f64], qd: &[f64]) {
        self.time = t;
        // (A factor is of the poses it was formed at: none yet at these.)
        self.factored = false;
        constraints::fill_poses(q, qd, &mut self.poses, &mut self.rotations);
        constraints::evaluate_as::<GAMMA>(
            mech,
            t,
            &self.poses,
            ConstraintTerms {
                jacobian: &mut self.jacobian,
                phi: &mut self.phi,
                nu: &mut self.nu,
                gamma: &mut self.gamma,
            },
        );
    }

    /// The applied forces (gravity, loads) at the poses held.
    fn set_loads(&mut self, mech: &Mechanism) {
        for (k, b) in mech.bodies.iter().enumerate() {
            self.forces[3 * k] = b.mass * mech.gravity.x;
            self.forces[3 * k + 1] = b.mass * mech.gravity.y;
            self.forces[3 * k + 2] = 0.0;
        }
        for load in &mech.loads {
            match load {
                Load::Force { body, point, force } => {
                    let a = self.poses[*body].rotate(*point);
                    self.forces[3 * body] += force.x;
                    self.forces[3 * body + 1] += force.y;
                    self.forces[3 * body + 2] += cross(a, *force);
                }
                Load::Torque { body, torque } => self.forces[3 * body + 2] += torque,
                Load::Motor { body, stall_torque, no_load_speed } => {
                    let omega = self.poses[*body].angular_velocity;
                    self.forces[3 * body + 2] += stall_torque * (1.0 - omega / no_load_speed);
                }
                Load::Bushing { body_i, point_i, body_j, point_j, stiffness, damping, curve } => {
                    let (pi, pj) =
                        (constraints::pose_of(&self.poses, *body_i), constraints::pose_of(&self.poses, *body_j));
                    let spring = (*stiffness, curve.as_ref());
                    let (s, ai, aj) = crate::model::bushing_state(&pi, *point_i, &pj, *point_j, spring, *damping);
                    self.add_force(*body_i, ai, s.force);
                    self.add_force(*body_j, aj, -s.force);
                }
            }
        }
    }

    /// Adds a force `f` (world frame) acting at world offset `arm` from the centroid of `body`.
    #[inline]
    pub fn add_force(&mut self, body: BodyId, arm: crate::Vec2, f: crate::Vec2) {
        if let BodyId::Body(k) = body {
            self.forces[3 * k] += f.x;
            self.forces[3 * k + 1] += f.y;
            self.forces[3 * k + 2] += cross(arm, f);
        }
    }

    /// Forms and factors S = Φ_q M⁻¹ Φ_qᵀ (over the rows that are not eliminated) at the current
    /// state.
    pub fn factor(&mut self) -> Result<(), MechError> {
        if !self.shared_at.is_empty() {
            let same = self.shared_at.len() == self.poses.len()
                && self.shared_at.iter().zip(&self.poses).all(|(a, p)| {
                    a[0].to_bits() == p.position.x.to_bits()
                        && a[1].to_bits() == p.position.y.to_bits()
                        && a[2].to_bits() == p.angle.to_bits()
                });
            self.shared_at.clear();
            if same {
                self.factored = true;
                return Ok(());
            }
        }
        let st = &self.structure;
        let m = st.free_rows.len();
        let im = &st.free_inverse_mass;
        let blocks = self.jacobian.as_flattened();
        let s = &mut self.schur.matrix_mut()[..m * m];
        s.fill(0.0);
        kkt::add_schur(st, |k| blocks[k].d, im, s);
        self.factored = self.schur.factor();
        if self.factored { Ok(()) } else { Err(MechError::SingularConstraints { t: self.time }) }
    }

    /// Φ_q v for a coordinate-space vector `v`, row `a`.
    #[inline]
    pub fn jacobian_times(&self, a: usize, v: &[f64]) -> f64 {
        self.jacobian[a].iter().filter(|b| b.body != Block::NONE).map(|b| dot3(&b.d, &v[3 * b.body..])).sum()
    }

    /// Solves for q̈ and λ with the current forces, the stabilised γ̂ and the current factor.
    pub fn solve(&mut self, mech: &Mechanism, qd: &[f64]) {
        let (alpha, beta) = (mech.baumgarte.alpha, mech.baumgarte.beta);
        let n = qd.len();
        let v = &mut self.scratch.velocity[..n + 3];
        v[..n].copy_from_slice(qd);
        let terms = (&self.gamma[..], &self.nu[..], &self.phi[..]);
        let row = |a| entries(&self.jacobian[a]);
        kkt::stabilised_gamma(&self.structure, row, v, terms, (alpha, beta), &mut self.gamma_hat);
        let Solver {
            jacobian,
            forces,
            accelerations,
            lambda,
            inverse_mass,
            gamma_hat,
            structure,
            scratch,
            schur,
            factored,
            ..
        } = self;
        assert!(*factored, "Solver::factor must succeed before a solve");
        solve_rhs(jacobian, inverse_mass, structure, scratch, schur, forces, gamma_hat, accelerations, lambda);
    }

    /// Sets the state, factors and solves: q̈ and λ of the mechanism with only gravity and loads,
    /// plus whatever `extra` adds to the generalized forces.
    pub fn accelerations(
        &mut self,
        mech: &Mechanism,
        t: f64,
        q: &[f64],
        qd: &[f64],
        extra: impl FnOnce(&mut Solver),
    ) -> Result<(), MechError> {
        self.set_state(mech, t, q, qd);
        extra(self);
        self.factor()?;
        self.solve(mech, qd);
        Ok(())
    }

    /// Solves the KKT system for an arbitrary right side `[forces; gamma]` with the current factor,
    /// writing q̈ into `qdd` and λ into `lambda`. Used for effective interface terms.
    pub fn solve_with(&mut self, forces: &[f64], gamma: &[f64], qdd: &mut [f64], lambda: &mut DVector<f64>) {
        assert!(self.factored, "Solver::factor must succeed before a solve");
        solve_rhs(
            &self.jacobian,
            &self.inverse_mass,
            &self.structure,
            &mut self.scratch,
            &self.schur,
            forces,
            gamma,
            qdd,
            lambda,
        );
    }

    /// max |Φ| at the current state [m or rad].
    pub fn constraint_error(&self) -> f64 {
        self.phi.iter().fold(0.0, |m, v| m.max(v.abs()))
    }
}

/// One row's entries as the KKT kernels read them.
#[inline(always)]
fn entries([b0, b1]: &JacobianRow) -> kkt::RowEntries<f64> {
    [b0.d[0], b0.d[1], b0.d[2], b1.d[0], b1.d[1], b1.d[2]]
}

/// [`kkt::solve`] with the scalar solver's rows, factor and work vectors.
#[allow(clippy::too_many_arguments)]
fn solve_rhs(
    jacobian: &[JacobianRow],
    inverse_mass: &[f64],
    st: &Structure,
    scratch: &mut Scratch,
    factor: &SmallCholesky,
    forces: &[f64],
    gamma: &[f64],
    qdd: &mut [f64],
    lambda: &mut DVector<f64>,
) {
    let work = kkt::Work { acc: &mut scratch.acc, reaction: &mut scratch.reaction, lam: &mut scratch.lambda };
    let row = |a| entries(&jacobian[a]);
    let lambda = Some((lambda.as_mut_slice(), inverse_mass));
    let solve_schur = |b: &mut [f64]| factor.solve_mut(b);
    kkt::solve(st, row, &st.free_inverse_mass, (Some(forces), gamma), work, solve_schur, qdd, lambda);
}
