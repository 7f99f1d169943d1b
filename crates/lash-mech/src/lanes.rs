//! The position and velocity analysis of a fully driven mechanism for several mechanisms of one
//! structure at once, in vector lanes: the macro step of a sweep's runs stepped side by side.
//!
//! Each lane does the operations [`crate::assemble_and_project`] does for its mechanism — the
//! same IEEE operations on the same numbers, in the same order (every number here is an array of
//! one value per lane, and every operation acts lane by lane) — so each lane's result is bit for
//! bit the scalar one. What differs is only the control: a lane that has converged keeps its
//! coordinates while the others iterate (its terms are evaluated again at the same position: the
//! same bits), and a lane for which anything goes otherwise than a clean convergence (a singular
//! Schur complement, no convergence in the iteration limit) is reported as not done, for its
//! caller to redo it alone — which then meets the same failure with the scalar code's own error.
//!
//! The sines and cosines are taken lane by lane with `sin_cos`, through each solver's cache of
//! them (as [`crate::constraints::fill_poses`] does).

use crate::constraints::{Block, BodyState, driver_row, joint_rows};
use crate::dense::{Dense, factor_with, solve_with};
use crate::interface::{ClearanceInterface, CoupledTerms, UnitLoad, add_unit_load, moving};
use crate::kkt;
use crate::model::{BodyId, JointKind, Mechanism};
use crate::solver::Solver;
use crate::{Pose, Vec2};
use lash_core::lane::{F64x8, Real};

/// Mechanisms analysed at once.
pub const LANES: usize = lash_core::lane::LANES;

/// One number per lane ([`lash_core::lane`]); every operation acts lane by lane (the IEEE
/// operation of each lane's scalar code), in one vector register where the processor has one that
/// wide.
type X = F64x8;

const ZERO: X = X::ZERO;

/// Newton's iteration limit, as in [`crate::assemble_and_project`].
const MAX_ITERATIONS: usize = 50;

/// One lane's mechanism and state for a position analysis: what [`crate::assemble_and_project`]
/// takes.
pub struct LaneInput<'a> {
    /// The mechanism (every lane's of the same [`signature`]).
    pub mech: &'a Mechanism,
    /// Its solver (sines and cosines cached, factor and terms left as the scalar analysis leaves
    /// them when the lane is done).
    pub solver: &'a mut Solver,
    /// Coordinates, predicted (in) and assembled (out, when done).
    pub q: &'a mut [f64],
    /// Velocities, to project (in) and projected (out, when done).
    pub qd: &'a mut [f64],
}

/// The structure of a mechanism and its solver, as numbers: bodies, joints' kinds and bodies,
/// drivers' bodies, the Schur complement's pattern (and that it is factored by the dense kernel).
/// Mechanisms of equal signatures can be analysed in lanes together: their parameters may differ
/// only where numbers are read per lane (joint points and axes, offsets, masses, gravity, the
/// drivers' motions). Computed once per mechanism; comparing two is one slice comparison.
pub fn signature(mech: &Mechanism, solver: &Solver) -> Vec<u64> {
    let st = &solver.structure;
    let mut v = vec![mech.bodies.len() as u64, mech.joints.len() as u64, mech.drivers.len() as u64];
    for j in &mech.joints {
        v.extend([body_code(j.body_i), body_code(j.body_j), matches!(j.kind, JointKind::Prismatic { .. }) as u64]);
    }
    for d in &mech.drivers {
        v.extend([body_code(d.body), body_code(d.reference)]);
    }
    v.push(solver.dense_factor() as u64);
    v.push(st.fixed.len() as u64);
    for &(row, k, c) in &st.fixed {
        v.extend([row as u64, k as u64, c.to_bits()]);
    }
    v.push(st.free_rows.len() as u64);
    v.extend(st.free_rows.iter().map(|&r| r as u64));
    v.push(st.pairs.len() as u64);
    for &(a, b, i, k) in &st.pairs {
        v.extend([a as u64, b as u64, i as u64, k as u64]);
    }
    v.push(st.offsets.len() as u64);
    for o in &st.offsets {
        v.extend([o[0] as u64, o[1] as u64]);
    }
    v
}

/// A body as a number of a signature.
fn body_code(b: BodyId) -> u64 {
    match b {
        BodyId::Body(k) => k as u64,
        BodyId::Ground => u64::MAX,
    }
}

/// The signature under which a cut mechanism `cut` (solver `solver`, clearance joints `joints`)
/// can have its effective terms' solves done in lanes ([`effective_solves_lanes`]) with others of
/// the same: its S the leading block of the analysed mechanism's (`shared`:
/// [`Solver::is_leading_block_of`]) and no applied loads but gravity; None where it cannot.
pub fn terms_signature(
    cut: &Mechanism,
    solver: &Solver,
    joints: &[ClearanceInterface],
    shared: bool,
) -> Option<Vec<u64>> {
    // (A guide's rows are not in the lanes' solves.)
    (shared && cut.loads.is_empty() && joints.iter().all(|j| j.guide.is_none())).then(|| {
        let mut v = signature(cut, solver);
        v.push(joints.len() as u64);
        v.extend(
            joints.iter().flat_map(|j| [body_code(j.interface.journal_body), body_code(j.interface.bearing_body)]),
        );
        v
    })
}

/// One mechanism's constraint rows in lanes, with the per-lane numbers they are formed from.
#[derive(Default)]
struct Rows {
    /// Per joint: point_i (x, y), point_j (x, y), the unit axis (x, y), the angle offset.
    joint: Vec<[X; 7]>,
    /// Per driver: f(t), ḟ(t), f̈(t).
    driver: Vec<[X; 3]>,
    /// Φ_q by rows: block i (x, y, θ), block j (x, y, θ).
    jacobian: Vec<[X; 6]>,
    phi: Vec<X>,
    nu: Vec<X>,
    gamma: Vec<X>,
    /// Per row, its two blocks' bodies ([`Block::NONE`]: the ground).
    row_bodies: Vec<[usize; 2]>,
}

impl Rows {
    /// Sized for `mech` with its solver's structure `st` (nothing allocated once sized).
    fn size(&mut self, mech: &Mechanism, st: &crate::solver::Structure) {
        let m = mech.constraint_count();
        // (Every number is written before it is read.)
        self.joint.resize(mech.joints.len(), [ZERO; 7]);
        self.driver.resize(mech.drivers.len(), [ZERO; 3]);
        self.jacobian.resize(m, [ZERO; 6]);
        for v in [&mut self.phi, &mut self.nu, &mut self.gamma] {
            v.resize(m, ZERO);
        }
        // (The structure's coordinate offsets, the ground's the padding slot n.)
        let n = mech.coordinate_count();
        self.row_bodies.clear();
        self.row_bodies.extend(st.offsets.iter().map(|o| o.map(|o| if o == n { Block::NONE } else { o / 3 })));
    }

    /// Lane `l`'s numbers: `mech`'s joints and its drivers' motion at `t`.
    fn gather(&mut self, l: usize, mech: &Mechanism, t: f64) {
        for (p, joint) in self.joint.iter_mut().zip(&mech.joints) {
            let (u, offset) = match joint.kind {
                JointKind::Revolute => (Vec2::zeros(), 0.0),
                // (As the scalar code normalises it.)
                JointKind::Prismatic { axis_j, angle_offset } => (axis_j / axis_j.norm(), angle_offset),
            };
            let values = [joint.point_i.x, joint.point_i.y, joint.point_j.x, joint.point_j.y, u.x, u.y, offset];
            for (x, v) in p.iter_mut().zip(values) {
                x[l] = v;
            }
        }
        for (p, driver) in self.driver.iter_mut().zip(&mech.drivers) {
            let (f, fd, fdd) = driver.motion.eval(t);
            p[0][l] = f;
            p[1][l] = fd;
            p[2][l] = fdd;
        }
    }

    /// Lane `l`'s Φ_q into a solver's.
    fn scatter_jacobian(&self, l: usize, s: &mut Solver) {
        for (row, (j, bodies)) in s.jacobian.iter_mut().zip(self.jacobian.iter().zip(&self.row_bodies)) {
            for side in 0..2 {
                row[side] = if bodies[side] == Block::NONE {
                    Block::EMPTY
                } else {
                    Block { body: bodies[side], d: [j[3 * side][l], j[3 * side + 1][l], j[3 * side + 2][l]] }
                };
            }
        }
    }

    /// Lane `l`'s Φ_q, Φ and ν into a solver's.
    fn scatter(&self, l: usize, s: &mut Solver) {
        self.scatter_jacobian(l, s);
        for a in 0..self.phi.len() {
            s.phi[a] = self.phi[a][l];
            s.nu[a] = self.nu[a][l];
        }
    }
}

/// Work storage of [`assemble_and_project_lanes`] and [`effective_solves_lanes`] (sized on use;
/// nothing allocated once sized).
#[derive(Default)]
pub struct KinematicLanes {
    q: Vec<X>,
    qd: Vec<X>,
    /// Per body and the ground (last): x, y, θ, cos θ, sin θ.
    pose: Vec<[X; 5]>,
    /// Per body: the bits of the angle whose sine and cosine are in `pose`.
    angle_bits: Vec<[u64; LANES]>,
    /// The analysed (ideal) mechanism's rows, and the cut mechanism's.
    ideal: Rows,
    cut: Rows,
    /// M⁻¹ with the pinned coordinates zeroed, per coordinate (padded with three zeros).
    inverse_mass: Vec<X>,
    /// The ideal mechanism's factor of S (row-major, its order the stride) and its diagonal's
    /// reciprocals.
    schur: Vec<X>,
    inv_diag: Vec<X>,
    acc: Vec<X>,
    reaction: Vec<X>,
    lambda: Vec<X>,
    rhs: Vec<X>,
    step: Vec<X>,
    /// The cut mechanism's solves: M⁻¹ per coordinate, the body masses, gravity, Baumgarte's α
    /// and β, the velocities padded, the load, γ̂.
    full_inverse_mass: Vec<X>,
    mass: Vec<X>,
    gravity: [X; 2],
    baumgarte: [X; 2],
    velocity: Vec<X>,
    force: Vec<X>,
    gamma_hat: Vec<X>,
    /// Per clearance joint: journal point (x, y), bearing point (x, y), R_J, R_B.
    clearance: Vec<[X; 6]>,
    /// The solves' results: q̈ and λ with f_c = 0, then per column of G.
    free_accelerations: Vec<X>,
    free_lambda: Vec<X>,
    gains: Vec<X>,
    lambda_gains: Vec<X>,
    /// The copy of the lane code that runs.
    code: LaneCode,
}

/// Sizes `v` to `len` numbers, zeros where it was of another length (padding slots, which
/// nothing writes, stay zero).
fn fit(v: &mut Vec<X>, len: usize) {
    if v.len() != len {
        v.clear();
        v.resize(len, ZERO);
    }
}

/// [`crate::assemble_and_project`] at time `t` (tolerance `tol`) for up to [`LANES`] mechanisms
/// of one structure (the same [`signature`]) at once. Returns, per lane, the assembled constraint
/// error (max |Φ|) where the lane is done — its coordinates and velocities then bit for bit what
/// the scalar analysis gives, and with `keep` its solver too (poses, terms, factor); without,
/// the solver's state but for its cache of sines and cosines is stale, to be set before it is
/// read — or None where it is not (its inputs untouched, but for its solver's cache of sines and
/// cosines: the caller redoes it alone).
///
/// # Panics
/// If there are more than [`LANES`] lanes or their dimensions differ.
pub fn assemble_and_project_lanes(
    lanes: &mut [LaneInput<'_>],
    t: f64,
    tol: f64,
    keep: bool,
    work: &mut KinematicLanes,
) -> Vec<Option<f64>> {
    assert!(lanes.len() <= LANES, "at most {LANES} lanes");
    let Some(first) = lanes.first() else { return Vec::new() };
    let mech = first.mech;
    let (n, m, nb) = (mech.coordinate_count(), mech.constraint_count(), mech.bodies.len());
    let mf = first.solver.structure.free_rows.len();
    assert!(
        lanes.iter().all(|l| l.q.len() == n && l.qd.len() == n && l.solver.structure.free_rows.len() == mf),
        "lanes of one dimension"
    );
    fit(&mut work.q, n);
    fit(&mut work.qd, n);
    fit(&mut work.inverse_mass, n + 3);
    fit(&mut work.schur, mf * mf);
    fit(&mut work.inv_diag, mf);
    fit(&mut work.acc, n + 3);
    fit(&mut work.reaction, n + 3);
    fit(&mut work.lambda, mf);
    fit(&mut work.rhs, m);
    fit(&mut work.step, n);
    work.pose.resize(nb + 1, [ZERO; 5]);
    work.angle_bits.resize(nb, [0; LANES]);
    work.ideal.size(mech, &first.solver.structure);
    // Gather; lanes past the last are copies of the first (computed, never returned).
    for l in 0..LANES {
        let lane = &lanes[if l < lanes.len() { l } else { 0 }];
        for k in 0..n {
            work.q[k][l] = lane.q[k];
            work.qd[k][l] = lane.qd[k];
            work.inverse_mass[k][l] = lane.solver.structure.free_inverse_mass[k];
        }
        for (b, &(bits, sin, cos)) in lane.solver.rotations.0.iter().enumerate() {
            work.angle_bits[b][l] = bits;
            work.pose[b][3][l] = cos;
            work.pose[b][4][l] = sin;
        }
        work.ideal.gather(l, lane.mech, t);
    }
    work.pose[nb] = [ZERO, ZERO, ZERO, X::splat(1.0), ZERO];
    let structure = &first.solver.structure;
    let (done, errors) = analyse(work, mech, structure, tol);
    // Scatter the lanes that are done.
    let mut out = vec![None; lanes.len()];
    for (l, lane) in lanes.iter_mut().enumerate() {
        // (Each lane's cache of sines and cosines is its own, whatever the outcome.)
        for (b, r) in lane.solver.rotations.0.iter_mut().enumerate() {
            *r = (work.angle_bits[b][l], work.pose[b][4][l], work.pose[b][3][l]);
        }
        if !done[l] {
            continue;
        }
        for k in 0..n {
            lane.q[k] = work.q[k][l];
            lane.qd[k] = work.qd[k][l];
        }
        out[l] = Some(errors[l]);
        if !keep {
            continue;
        }
        let s = &mut *lane.solver;
        // (The position analysis sets its poses with zero velocities.)
        scatter_poses(work, l, s, false);
        work.ideal.scatter(l, s);
        let (a, inv) = s.schur.parts_mut();
        for (x, w) in a.iter_mut().zip(&work.schur) {
            *x = w[l];
        }
        for (x, w) in inv.iter_mut().zip(&work.inv_diag) {
            *x = w[l];
        }
        s.set_factored_at(t);
    }
    out
}

/// Lane `l`'s poses into a solver's, with the velocities (or zero ones).
fn scatter_poses(w: &KinematicLanes, l: usize, s: &mut Solver, velocities: bool) {
    for (b, p) in s.poses.iter_mut().enumerate() {
        let x = &w.pose[b];
        let v = |k: usize| if velocities { w.qd[3 * b + k][l] } else { 0.0 };
        *p = Pose {
            position: Vec2::new(x[0][l], x[1][l]),
            angle: x[2][l],
            cos: x[3][l],
            sin: x[4][l],
            velocity: Vec2::new(v(0), v(1)),
            angular_velocity: v(2),
        };
    }
}

/// One lane's cut mechanism for [`effective_solves_lanes`]: what the solves of
/// [`crate::coupled_effective_terms_into`] take.
pub struct TermsInput<'a> {
    /// The cut mechanism (the analysed mechanism without its clearance joints, which come last).
    pub cut: &'a Mechanism,
    /// Its solver (left as the solves leave it, when the lane is done).
    pub solver: &'a mut Solver,
    /// The clearance joints.
    pub joints: &'a [ClearanceInterface],
    /// The terms whose solves' part is written (q̈ and λ free, G and Λ).
    pub terms: &'a mut CoupledTerms,
}

/// The solves of [`crate::coupled_effective_terms_into`] for the lanes of the last
/// [`assemble_and_project_lanes`] (the same lanes, in the same order, of one
/// [`terms_signature`]), at their assembled state: the cut mechanism's state set, its factor the
/// leading block of the analysed one's (as `Solver::share_factor` gives it), q̈ and λ with
/// f_c = 0 and per unit interface load. Written where the analysis is done (`analysed[l]`, the
/// last analysis's result, is Some), bit for bit as the scalar
/// solves leave them: the terms' q̈, λ, G and Λ, and of the cut solver what is read of it before
/// it is set again — its poses and Φ_q (the rest of its state is stale); the terms' rates and
/// inverse are then for [`crate::interface::coupled_rates_into`].
pub fn effective_solves_lanes(
    lanes: &mut [TermsInput<'_>],
    analysed: &[Option<f64>],
    t: f64,
    work: &mut KinematicLanes,
) {
    assert!(lanes.len() <= LANES && analysed.len() == lanes.len(), "one result per lane, at most {LANES}");
    let Some(first) = lanes.first() else { return };
    let cut = first.cut;
    let (n, m, nb, k) = (cut.coordinate_count(), cut.constraint_count(), cut.bodies.len(), first.joints.len());
    assert!(work.q.len() == n && work.pose.len() == nb + 1, "the lanes of the last analysis");
    work.cut.size(cut, &first.solver.structure);
    fit(&mut work.full_inverse_mass, n);
    fit(&mut work.mass, nb);
    fit(&mut work.velocity, n + 3);
    fit(&mut work.force, n);
    fit(&mut work.gamma_hat, m);
    fit(&mut work.free_accelerations, n);
    fit(&mut work.free_lambda, m);
    fit(&mut work.gains, 3 * k * n);
    fit(&mut work.lambda_gains, 3 * k * m);
    work.clearance.resize(k, [ZERO; 6]);
    for l in 0..LANES {
        let lane = &lanes[if l < lanes.len() { l } else { 0 }];
        work.cut.gather(l, lane.cut, t);
        for (x, v) in work.full_inverse_mass.iter_mut().zip(lane.solver.inverse_mass()) {
            x[l] = *v;
        }
        for (x, b) in work.mass.iter_mut().zip(&lane.cut.bodies) {
            x[l] = b.mass;
        }
        let (g, b) = (lane.cut.gravity, lane.cut.baumgarte);
        (work.gravity[0][l], work.gravity[1][l]) = (g.x, g.y);
        (work.baumgarte[0][l], work.baumgarte[1][l]) = (b.alpha, b.beta);
        for (x, j) in work.clearance.iter_mut().zip(lane.joints) {
            let i = &j.interface;
            let values = [
                i.journal_point.x,
                i.journal_point.y,
                i.bearing_point.x,
                i.bearing_point.y,
                j.journal_radius,
                j.bearing_radius,
            ];
            for (x, v) in x.iter_mut().zip(values) {
                x[l] = v;
            }
        }
    }
    let bodies: Vec<[BodyId; 2]> =
        first.joints.iter().map(|j| [j.interface.journal_body, j.interface.bearing_body]).collect();
    solves(work, cut, &first.solver.structure, &bodies);
    for (l, lane) in lanes.iter_mut().enumerate() {
        if analysed[l].is_none() {
            continue;
        }
        // The cut solver's poses and Jacobian (what the rates and the reaction probes read);
        // its other state is stale, set before it is read (the next scalar solves set it all).
        let s = &mut *lane.solver;
        scatter_poses(work, l, s, true);
        work.cut.scatter_jacobian(l, s);
        let terms = &mut *lane.terms;
        for (a, x) in terms.free_accelerations.iter_mut().zip(&work.free_accelerations) {
            *a = x[l];
        }
        for (a, x) in terms.free_lambda.iter_mut().zip(&work.free_lambda) {
            *a = x[l];
        }
        for (c, column) in terms.gain.iter_mut().enumerate() {
            for (a, x) in column.iter_mut().zip(&work.gains[c * n..(c + 1) * n]) {
                *a = x[l];
            }
        }
        for (c, column) in terms.lambda_gain.iter_mut().enumerate() {
            for (a, x) in column.iter_mut().zip(&work.lambda_gains[c * m..(c + 1) * m]) {
                *a = x[l];
            }
        }
    }
}

/// Which compiled copy of the lane code runs: the widest the processor has (AVX-512, AVX2 or the
/// baseline, picked at run time by `multiversion`), AVX2 where the processor has it, or the
/// baseline. Every copy gives the same bits (plain IEEE arithmetic that the compiler widens, no
/// fused multiply–adds); the choice is there for the tests that check it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LaneCode {
    /// The widest copy the processor runs.
    #[default]
    Widest,
    /// The AVX2 copy (the baseline where the processor has no AVX2).
    Avx2,
    /// The baseline copy.
    Baseline,
}

impl KinematicLanes {
    /// Work storage whose lane code is `code`'s copy.
    pub fn with_code(code: LaneCode) -> Self {
        Self { code, ..Self::default() }
    }
}

/// [`analyse_lanes`] in the copy `w.code` picks.
fn analyse(w: &mut KinematicLanes, mech: &Mechanism, st: &crate::solver::Structure, tol: f64) -> ([bool; LANES], X) {
    #[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
    fn widest(w: &mut KinematicLanes, mech: &Mechanism, st: &crate::solver::Structure, tol: f64) -> ([bool; LANES], X) {
        analyse_lanes(w, mech, st, tol)
    }
    #[multiversion::multiversion(targets("x86_64+avx2"))]
    fn avx2(w: &mut KinematicLanes, mech: &Mechanism, st: &crate::solver::Structure, tol: f64) -> ([bool; LANES], X) {
        analyse_lanes(w, mech, st, tol)
    }
    match w.code {
        LaneCode::Widest => widest(w, mech, st, tol),
        LaneCode::Avx2 => avx2(w, mech, st, tol),
        LaneCode::Baseline => analyse_lanes(w, mech, st, tol),
    }
}

/// [`solves_lanes`] in the copy `w.code` picks.
fn solves(w: &mut KinematicLanes, cut: &Mechanism, st: &crate::solver::Structure, joints: &[[BodyId; 2]]) {
    #[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
    fn widest(w: &mut KinematicLanes, cut: &Mechanism, st: &crate::solver::Structure, joints: &[[BodyId; 2]]) {
        solves_lanes(w, cut, st, joints)
    }
    #[multiversion::multiversion(targets("x86_64+avx2"))]
    fn avx2(w: &mut KinematicLanes, cut: &Mechanism, st: &crate::solver::Structure, joints: &[[BodyId; 2]]) {
        solves_lanes(w, cut, st, joints)
    }
    match w.code {
        LaneCode::Widest => widest(w, cut, st, joints),
        LaneCode::Avx2 => avx2(w, cut, st, joints),
        LaneCode::Baseline => solves_lanes(w, cut, st, joints),
    }
}

/// The analysis on the gathered lanes: Newton's corrections, then the velocity projection.
/// Returns which lanes are done and their constraint errors.
#[inline(always)]
fn analyse_lanes(
    w: &mut KinematicLanes,
    mech: &Mechanism,
    st: &crate::solver::Structure,
    tol: f64,
) -> ([bool; LANES], X) {
    let n = w.q.len();
    let stride = w.inv_diag.len();
    let (mut done, mut failed, mut error) = ([false; LANES], [false; LANES], ZERO);
    for _ in 0..MAX_ITERATIONS {
        fill_poses(w);
        evaluate::<false>(&w.pose, &w.qd, &mut w.ideal, mech);
        let residual = w.ideal.phi.iter().fold(ZERO, |m, p| m.max(p.map(f64::abs)));
        for l in 0..LANES {
            if !done[l] && !failed[l] && residual[l] <= tol {
                done[l] = true;
                error[l] = residual[l];
            }
        }
        if (0..LANES).all(|l| done[l] || failed[l]) {
            break;
        }
        let ok = factor(&w.ideal, st, &w.inverse_mass, &mut w.schur, &mut w.inv_diag);
        let mut moving = [false; LANES];
        for l in 0..LANES {
            let active = !done[l] && !failed[l];
            failed[l] |= active && !ok[l];
            moving[l] = active && ok[l];
        }
        for (r, p) in w.rhs.iter_mut().zip(&w.ideal.phi) {
            *r = -*p;
        }
        let kkt =
            Kkt { rows: &w.ideal, st, schur: &w.schur, stride, inv_diag: &w.inv_diag, inverse_mass: &w.inverse_mass };
        kkt.solve(None, &w.rhs, (&mut w.acc[..], &mut w.reaction[..], &mut w.lambda[..]), &mut w.step, None);
        for k in 0..n {
            w.q[k] = w.q[k].replaced_where(moving, w.q[k] + w.step[k]);
        }
    }
    // The velocity projection at the assembled positions.
    let ok = factor(&w.ideal, st, &w.inverse_mass, &mut w.schur, &mut w.inv_diag);
    for (a, bodies) in w.ideal.row_bodies.iter().enumerate() {
        let j = &w.ideal.jacobian[a];
        let dot = |side: usize| {
            let o = 3 * bodies[side];
            j[3 * side] * w.qd[o] + j[3 * side + 1] * w.qd[o + 1] + j[3 * side + 2] * w.qd[o + 2]
        };
        // (The scalar code sums the moving bodies' terms.)
        let jqd = match (bodies[0] != Block::NONE, bodies[1] != Block::NONE) {
            (true, true) => dot(0) + dot(1),
            (true, false) => dot(0),
            (false, true) => dot(1),
            (false, false) => X::splat(-0.0),
        };
        w.rhs[a] = -(jqd - w.ideal.nu[a]);
    }
    let kkt = Kkt { rows: &w.ideal, st, schur: &w.schur, stride, inv_diag: &w.inv_diag, inverse_mass: &w.inverse_mass };
    kkt.solve(None, &w.rhs, (&mut w.acc[..], &mut w.reaction[..], &mut w.lambda[..]), &mut w.step, None);
    for k in 0..n {
        w.qd[k] = w.qd[k] + w.step[k];
    }
    (std::array::from_fn(|l| done[l] && ok[l]), error)
}

/// The cut mechanism's solves at the analysed state (see [`effective_solves_lanes`]).
#[inline(always)]
fn solves_lanes(w: &mut KinematicLanes, cut: &Mechanism, st: &crate::solver::Structure, joints: &[[BodyId; 2]]) {
    let (n, m, k) = (w.q.len(), w.cut.phi.len(), joints.len());
    let stride = w.inv_diag.len();
    evaluate::<true>(&w.pose, &w.qd, &mut w.cut, cut);
    // Gravity's load (`Solver::set_state`).
    for (b, mass) in w.mass.iter().enumerate() {
        w.force[3 * b] = *mass * w.gravity[0];
        w.force[3 * b + 1] = *mass * w.gravity[1];
        w.force[3 * b + 2] = ZERO;
    }
    // γ̂ = γ − 2α(Φ_q q̇ − ν) − β²Φ (`Solver::solve`, over the padded velocities).
    w.velocity[..n].copy_from_slice(&w.qd);
    let (alpha, beta) = (w.baumgarte[0], w.baumgarte[1]);
    let terms = (&w.cut.gamma[..], &w.cut.nu[..], &w.cut.phi[..]);
    let row = |a: usize| w.cut.jacobian[a];
    kkt::stabilised_gamma(st, row, &w.velocity, terms, (alpha, beta), &mut w.gamma_hat);
    let kkt = Kkt { rows: &w.cut, st, schur: &w.schur, stride, inv_diag: &w.inv_diag, inverse_mass: &w.inverse_mass };
    let scratch = (&mut w.acc[..], &mut w.reaction[..], &mut w.lambda[..]);
    let free_lambda = Some((&mut w.free_lambda[..], &w.full_inverse_mass[..]));
    kkt.solve(Some(&w.force), &w.gamma_hat, scratch, &mut w.free_accelerations, free_lambda);
    // Per unit load: the force along x, along y on each journal (and its opposite on the
    // bearing), then each joint's friction moments.
    let zero_gamma = &mut w.rhs[..m];
    zero_gamma.fill(ZERO);
    let pose = &w.pose;
    let rotate = |b: usize, x: X, y: X| {
        let p = &pose[b];
        (p[3] * x - p[4] * y, p[4] * x + p[3] * y)
    };
    for (j, bodies) in joints.iter().enumerate() {
        let c = w.clearance[j];
        let bodies = bodies.map(moving);
        // The journal's and the bearing's arms (a ground side's is not read).
        let arm = |side: usize| match bodies[side] {
            Some(b) => {
                let (ax, ay) = rotate(b, c[2 * side], c[2 * side + 1]);
                [ax, ay]
            }
            None => [ZERO; 2],
        };
        let arms = [arm(0), arm(1)];
        // The columns of joint j: unit force along x, along y (2j, 2j + 1), friction (2k + j).
        let columns = [(2 * j, UnitLoad::Along(1.0, 0.0)), (2 * j + 1, UnitLoad::Along(0.0, 1.0))];
        for (column, load) in columns.into_iter().chain([(2 * k + j, UnitLoad::Friction)]) {
            w.force.fill(ZERO);
            add_unit_load(bodies, arms, (c[4], c[5]), load, &mut w.force);
            kkt.solve(
                Some(&w.force),
                zero_gamma,
                (&mut w.acc[..], &mut w.reaction[..], &mut w.lambda[..]),
                &mut w.gains[column * n..(column + 1) * n],
                Some((&mut w.lambda_gains[column * m..(column + 1) * m], &w.full_inverse_mass)),
            );
        }
    }
}

/// The sines and cosines (lane by lane, through each lane's cache) and the positions of the
/// poses at the lanes' coordinates.
#[inline(always)]
fn fill_poses(w: &mut KinematicLanes) {
    for b in 0..w.angle_bits.len() {
        let p = &mut w.pose[b];
        let angle = w.q[3 * b + 2];
        for l in 0..LANES {
            if angle[l].to_bits() != w.angle_bits[b][l] || angle[l].is_nan() {
                let (sin, cos) = angle[l].sin_cos();
                w.angle_bits[b][l] = angle[l].to_bits();
                p[3][l] = cos;
                p[4][l] = sin;
            }
        }
        p[0] = w.q[3 * b];
        p[1] = w.q[3 * b + 1];
        p[2] = angle;
    }
}

/// Φ_q, Φ, ν (and γ if `GAMMA`, with the velocities `qd`) of `mech` at the poses (as
/// `Solver::set_configuration` and `Solver::set_state`).
#[inline(always)]
fn evaluate<const GAMMA: bool>(pose: &[[X; 5]], qd: &[X], rows: &mut Rows, mech: &Mechanism) {
    let nb = pose.len() - 1;
    let slot = |b: BodyId| match b {
        BodyId::Body(k) => k,
        BodyId::Ground => nb,
    };
    // A body's velocity (x, y, θ); the ground's is zero.
    let velocity = |b: BodyId| match b {
        BodyId::Body(k) => [qd[3 * k], qd[3 * k + 1], qd[3 * k + 2]],
        BodyId::Ground => [ZERO; 3],
    };
    // A ground block's entries are zeros (Block::EMPTY).
    let block = |b: BodyId, d: [X; 3]| if b == BodyId::Ground { [ZERO; 3] } else { d };
    let row_of = |i: [X; 3], j: [X; 3]| [i[0], i[1], i[2], j[0], j[1], j[2]];
    let state = |b: BodyId| {
        let p = &pose[slot(b)];
        let [vx, vy, w] = velocity(b);
        BodyState { position: [p[0], p[1]], angle: p[2], cos: p[3], sin: p[4], velocity: [vx, vy], angular_velocity: w }
    };
    let mut row = 0;
    for (joint, p) in mech.joints.iter().zip(&rows.joint) {
        let (bi, bj) = (joint.body_i, joint.body_j);
        let [pix, piy, pjx, pjy, ux, uy, offset] = *p;
        let prismatic = matches!(joint.kind, JointKind::Prismatic { .. }).then_some(([ux, uy], offset));
        let pair = joint_rows::<X, GAMMA>((&state(bi), &state(bj)), ([pix, piy], [pjx, pjy]), prismatic);
        for (k, r) in pair.iter().enumerate() {
            rows.jacobian[row + k] = row_of(block(bi, r.i), block(bj, r.j));
            rows.phi[row + k] = r.phi;
            rows.nu[row + k] = ZERO;
            if GAMMA {
                rows.gamma[row + k] = r.gamma;
            }
        }
        row += 2;
    }
    for (driver, f) in mech.drivers.iter().zip(&rows.driver) {
        let (r, rate) = driver_row((&state(driver.body), &state(driver.reference)), *f);
        rows.jacobian[row] = row_of(block(driver.body, r.i), block(driver.reference, r.j));
        rows.phi[row] = r.phi;
        rows.nu[row] = rate;
        if GAMMA {
            rows.gamma[row] = r.gamma;
        }
        row += 1;
    }
}

/// Forms S = Φ_q M⁻¹ Φ_qᵀ of `rows` and factors it (as `Solver::factor` and
/// `SmallCholesky::factor`) into `schur` (its order the stride) and `inv_diag`; per lane, whether
/// it is positive definite.
#[inline(always)]
fn factor(
    rows: &Rows,
    st: &crate::solver::Structure,
    inverse_mass: &[X],
    s: &mut [X],
    inv_diag: &mut [X],
) -> [bool; LANES] {
    let mf = st.free_rows.len();
    s.fill(ZERO);
    let half = |k: usize| {
        let (j, o) = (&rows.jacobian[k / 2], 3 * (k % 2));
        [j[o], j[o + 1], j[o + 2]]
    };
    kkt::add_schur(st, half, inverse_mass, s);
    let ok = factor_with(mf, s, inv_diag, Dense);
    std::array::from_fn(|l| ok[l].to_bits() != 0)
}

/// A KKT system in lanes: the rows, their structure, a factor of S (row stride `stride`: the
/// factor of a larger S whose leading block this S is serves) and M⁻¹ (free coordinates).
struct Kkt<'a> {
    rows: &'a Rows,
    st: &'a crate::solver::Structure,
    schur: &'a [X],
    stride: usize,
    inv_diag: &'a [X],
    inverse_mass: &'a [X],
}

impl Kkt<'_> {
    /// [`kkt::solve`] with these rows and this factor of S.
    #[inline(always)]
    fn solve(
        &self,
        forces: Option<&[X]>,
        g: &[X],
        (acc, reaction, lam): (&mut [X], &mut [X], &mut [X]),
        qdd: &mut [X],
        lambda: Option<(&mut [X], &[X])>,
    ) {
        let (st, s, inv, stride) = (self.st, self.schur, self.inv_diag, self.stride);
        let solve_schur = |b: &mut [X]| solve_with((st.free_rows.len(), stride), s, inv, Dense, b);
        let row = |a: usize| self.rows.jacobian[a];
        let work = kkt::Work { acc, reaction, lam };
        kkt::solve(st, row, self.inverse_mass, (forces, g), work, solve_schur, qdd, lambda);
    }
}
