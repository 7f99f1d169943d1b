//! Effective interface terms of a cut mechanism (docs/theory.md §6).
//!
//! The cut system is the mechanism with one clearance joint removed. Its interface coordinate is
//! g(q) = r_J − r_B (journal centre minus bearing centre), J = ∂g/∂q, w = ġ = J q̇. With a force
//! f_c on the journal (−f_c on the bearing) the KKT solution is q̈ = q̈_free + G f_c, and
//!
//! ```text
//!     ẅ = W f_c + a_free,   W = J G,   a_free = J q̈_free + J̇ q̇,   M̃ = W⁻¹,   f̃ = M̃ a_free
//! ```
//!
//! so that M̃ ẅ = f̃ + f_c. One factorisation serves the three right-hand sides [Q | Jᵀe_x | Jᵀe_y];
//! the λ-parts of the same solves give joint reactions and driver torques as λ = λ_free + Λ f_c.

use crate::constraints::{Block, JacobianRow, line_row, pose_of};
use crate::model::{BodyId, Mechanism};
use crate::solver::{MechError, Solver};
use crate::{Pose, Vec2, perp};
use lash_core::lane::Real;
use nalgebra::{DMatrix, DVector, Matrix2};

/// Where the interface is: the journal centre on one body, the bearing centre on another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interface {
    /// Body carrying the journal.
    pub journal_body: BodyId,
    /// Journal centre (local, from the centroid) \[m\].
    pub journal_point: Vec2,
    /// Body carrying the bearing.
    pub bearing_body: BodyId,
    /// Bearing centre (local, from the centroid) \[m\].
    pub bearing_point: Vec2,
}

/// The effective terms of one interface at one state, with the maps that propagate f_c back.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectiveTerms {
    /// Mobility W = J A Jᵀ [1/kg] (interface acceleration per unit interface force).
    pub mobility: Matrix2<f64>,
    /// Effective mass M̃ = W⁻¹ \[kg\]; `None` if W is singular (interface directions beyond the cut
    /// system's mobility: integrate ẅ = W f_c + a_free directly).
    pub effective_mass: Option<Matrix2<f64>>,
    /// Free interface acceleration a_free [m/s²] (f_c = 0).
    pub free_acceleration: Vec2,
    /// Effective force f̃ = M̃ a_free \[N\] (zero when W is singular).
    pub effective_force: Vec2,
    /// Generalized accelerations with f_c = 0.
    pub free_accelerations: Vec<f64>,
    /// Columns of G: q̈ per unit force along x and along y on the journal.
    pub gain: [Vec<f64>; 2],
    /// Multipliers with f_c = 0.
    pub free_lambda: Vec<f64>,
    /// Columns of Λ: λ per unit force along x and along y on the journal.
    pub lambda_gain: [Vec<f64>; 2],
}

impl EffectiveTerms {
    /// q̈ = q̈_free + G f_c.
    pub fn accelerations(&self, f_c: Vec2, out: &mut [f64]) {
        for k in 0..out.len() {
            out[k] = self.free_accelerations[k] + self.gain[0][k] * f_c.x + self.gain[1][k] * f_c.y;
        }
    }
}

/// J x for a coordinate-space vector x: the journal-minus-bearing point response (no velocity terms).
fn interface_rate(iface: &Interface, poses: &[Pose], x: &[f64]) -> Vec2 {
    let part = |body: BodyId, point: Vec2| -> Vec2 {
        match body {
            BodyId::Ground => Vec2::zeros(),
            BodyId::Body(k) => {
                let a = poses[k].rotate(point);
                Vec2::new(x[3 * k], x[3 * k + 1]) + perp(a) * x[3 * k + 2]
            }
        }
    };
    part(iface.journal_body, iface.journal_point) - part(iface.bearing_body, iface.bearing_point)
}

/// One clearance joint among several coupled through the cut mechanism: where its journal and
/// bearing centres are, and the radii at which its friction force acts — or, for a translational
/// clearance joint, its block and guide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearanceInterface {
    /// Journal and bearing centres; for a guide, the block's centre on the block's body
    /// (`journal_*`) and a point of the guide's mid-line on the guide's body (`bearing_*`).
    pub interface: Interface,
    /// Journal radius R_J \[m\] (the friction force acts at the contact point, R_J from the journal
    /// centre).
    pub journal_radius: f64,
    /// Bearing radius R_B \[m\].
    pub bearing_radius: f64,
    /// A translational clearance joint's guide (`None`: a revolute clearance joint).
    pub guide: Option<GuideAxis>,
}

/// The guide of a translational clearance joint. Its two interface coordinates are the rows of
/// the prismatic joint it replaces: the block's tilt θ_block − θ_guide − θ0 and its centre's
/// offset from the guide's mid-line, m·d (m the mid-line's left normal, d the block centre less
/// the mid-line point); its one friction load is the force along the guide on the block (whose
/// moment about the block's centre the micro side puts in the tilt's generalized force), acting
/// through the slide u·d.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuideAxis {
    /// The mid-line's direction u on the guide's body (unit).
    pub axis: Vec2,
    /// The block's relative angle θ_block − θ_guide when it is aligned with the guide \[rad\].
    pub angle_offset: f64,
}

/// A guide's three rows at the solver's poses (tilt, offset, slide), each with its γ
/// (Φ_q q̈ = γ, so that the coordinate's acceleration is row · q̈ − γ).
#[derive(Debug, Clone, Copy, PartialEq)]
struct GuideRows {
    rows: [JacobianRow; 3],
    gamma: [f64; 3],
}

impl GuideRows {
    fn at(iface: &Interface, guide: &GuideAxis, poses: &[Pose]) -> Self {
        let (bi, bj) = (iface.journal_body, iface.bearing_body);
        let (pi, pj) = (pose_of(poses, bi), pose_of(poses, bj));
        let (ai, aj) = (pi.rotate(iface.journal_point), pj.rotate(iface.bearing_point));
        let tilt =
            [Block { body: body_index(bi), d: [0.0, 0.0, 1.0] }, Block { body: body_index(bj), d: [0.0, 0.0, -1.0] }];
        let u = pj.rotate(guide.axis / guide.axis.norm());
        let (offset, _, offset_gamma) = line_row::<true>((bi, bj), (&pi, &pj), (ai, aj), perp(u));
        let (slide, _, slide_gamma) = line_row::<true>((bi, bj), (&pi, &pj), (ai, aj), u);
        Self { rows: [tilt, offset, slide], gamma: [0.0, offset_gamma, slide_gamma] }
    }

    /// Row `r` times a coordinate-space vector.
    fn times(&self, r: usize, x: &[f64]) -> f64 {
        self.rows[r]
            .iter()
            .filter(|b| b.body != Block::NONE)
            .map(|b| (0..3).map(|i| b.d[i] * x[3 * b.body + i]).sum::<f64>())
            .sum()
    }

    /// Adds row `r`ᵀ times `load` (the generalized force of that load on the coordinate) to
    /// `force`.
    fn add_to(&self, r: usize, load: f64, force: &mut [f64]) {
        for b in self.rows[r].iter().filter(|b| b.body != Block::NONE) {
            for i in 0..3 {
                force[3 * b.body + i] += b.d[i] * load;
            }
        }
    }
}

impl ClearanceInterface {
    /// A guide's slide: the block's speed along the guide u·ḋ and its rate at `poses` (which
    /// carry the velocities) and accelerations `qdd`; `None` for a revolute clearance joint.
    pub fn slide_rates(&self, poses: &[Pose], qd: &[f64], qdd: &[f64]) -> Option<(f64, f64)> {
        let rows = GuideRows::at(&self.interface, self.guide.as_ref()?, poses);
        Some((rows.times(2, qd), rows.times(2, qdd) - rows.gamma[2]))
    }

    /// Adds the generalized force of the joint's friction load `load` at `poses` to `forces`:
    /// a revolute joint's friction moments −R_J F_T on the journal's body and +R_B F_T on the
    /// bearing's, a guide's force along it through its slide.
    pub fn add_friction_load(&self, poses: &[Pose], load: f64, forces: &mut [f64]) {
        if let Some(guide) = &self.guide {
            GuideRows::at(&self.interface, guide, poses).add_to(2, load, forces);
            return;
        }
        for (body, arm) in
            [(self.interface.journal_body, -self.journal_radius), (self.interface.bearing_body, self.bearing_radius)]
        {
            if let BodyId::Body(b) = body {
                forces[3 * b + 2] += arm * load;
            }
        }
    }
}

/// One of a revolute clearance joint's unit loads, the columns of its effective terms: a unit
/// force on the journal's centre along (x, y) (its opposite on the bearing's), or a unit friction
/// force F_T.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum UnitLoad {
    /// A unit force along (x, y) on the journal, its opposite on the bearing.
    Along(f64, f64),
    /// A unit friction force: its moments −R_J on the journal's body and +R_B on the bearing's
    /// (f_J = −F_N n − F_T t acts at r_J + R_J n, and (R_J n) × (−t) = −R_J).
    Friction,
}

/// Adds the generalized force of a revolute clearance joint's unit load `load` to `force`: the
/// journal's and the bearing's bodies `bodies` (None: the ground), their centres' arms `arms`
/// (world frame) and radii (R_J, R_B). One source over [`Real`] for the scalar effective terms
/// and the macro lanes' ([`crate::lanes`]).
#[inline(always)]
pub(crate) fn add_unit_load<R: Real>(
    bodies: [Option<usize>; 2],
    arms: [[R; 2]; 2],
    (journal_radius, bearing_radius): (R, R),
    load: UnitLoad,
    force: &mut [R],
) {
    match load {
        UnitLoad::Along(ex, ey) => {
            let (ex, ey) = (R::splat(ex), R::splat(ey));
            for (side, sign) in [(0, 1.0), (1, -1.0)] {
                if let Some(b) = bodies[side] {
                    let ([ax, ay], sign) = (arms[side], R::splat(sign));
                    force[3 * b] = force[3 * b] + sign * ex;
                    force[3 * b + 1] = force[3 * b + 1] + sign * ey;
                    force[3 * b + 2] = force[3 * b + 2] + sign * (ax * ey - ay * ex);
                }
            }
        }
        UnitLoad::Friction => {
            for (side, moment) in [(0, -journal_radius), (1, bearing_radius)] {
                if let Some(b) = bodies[side] {
                    force[3 * b + 2] = force[3 * b + 2] + moment;
                }
            }
        }
    }
}

/// The moving-body index of `id` (None: the ground).
pub(crate) fn moving(id: BodyId) -> Option<usize> {
    match id {
        BodyId::Body(b) => Some(b),
        BodyId::Ground => None,
    }
}

/// A clearance joint's three unit loads at one state (see [`ClearanceInterface::unit_loads`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum UnitLoads {
    /// A revolute joint's: its bodies, their centres' arms and its radii (R_J, R_B).
    Revolute { bodies: [Option<usize>; 2], arms: [[f64; 2]; 2], radii: (f64, f64) },
    /// A guide's: unit loads on its tilt, offset and slide rows.
    Guide(GuideRows),
}

impl UnitLoads {
    /// Adds the generalized force of unit load `r` (0 and 1: along the joint's two interface
    /// coordinates; 2: its friction load) to `force`.
    fn add(&self, r: usize, force: &mut [f64]) {
        match self {
            Self::Guide(rows) => rows.add_to(r, 1.0, force),
            Self::Revolute { bodies, arms, radii } => {
                let load = [UnitLoad::Along(1.0, 0.0), UnitLoad::Along(0.0, 1.0), UnitLoad::Friction][r];
                add_unit_load(*bodies, *arms, *radii, load, force)
            }
        }
    }
}

impl ClearanceInterface {
    /// The joint's unit loads at `poses`, the columns of its effective terms: a revolute joint's
    /// unit force on the journal's centre along x and along y (its opposite on the bearing's)
    /// and its unit friction force; a guide's unit loads on its tilt, its offset and its slide.
    fn unit_loads(&self, poses: &[Pose]) -> UnitLoads {
        let iface = &self.interface;
        if let Some(guide) = &self.guide {
            return UnitLoads::Guide(GuideRows::at(iface, guide, poses));
        }
        let arm = |body: BodyId, point: Vec2| match body {
            BodyId::Body(b) => poses[b].rotate(point),
            BodyId::Ground => Vec2::zeros(),
        };
        let arms = [arm(iface.journal_body, iface.journal_point), arm(iface.bearing_body, iface.bearing_point)];
        UnitLoads::Revolute {
            bodies: [moving(iface.journal_body), moving(iface.bearing_body)],
            arms: arms.map(|a| [a.x, a.y]),
            radii: (self.journal_radius, self.bearing_radius),
        }
    }
}

fn body_index(id: BodyId) -> usize {
    match id {
        BodyId::Body(k) => k,
        BodyId::Ground => Block::NONE,
    }
}

/// The effective terms of k clearance joints at once (n = 2k interface coordinates: joint j's
/// eccentricity is coordinates 2j, 2j + 1), with the maps that propagate the contact forces back.
///
/// With f_c (n: the contact force on each journal, through the joint centres) and F_T (k: each
/// joint's tangential friction force, whose moments −R_J F_T on the journal body and +R_B F_T on the
/// bearing body are not carried by forces through the centres):
///
/// ```text
///     ẅ = W f_c + W_T F_T + a_free,   M̃ = W⁻¹,   f̃ = M̃ a_free,
///     q̈ = q̈_free + G [f_c; F_T],      λ = λ_free + Λ [f_c; F_T].
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct CoupledTerms {
    /// Mobility W = J A Jᵀ (n × n) [1/kg]; its off-diagonal 2 × 2 blocks couple the joints.
    pub mobility: DMatrix<f64>,
    /// Effective mass M̃ = W⁻¹ \[kg\]; `None` when W is singular.
    pub effective_mass: Option<DMatrix<f64>>,
    /// Free interface accelerations a_free (n) [m/s²].
    pub free_acceleration: DVector<f64>,
    /// Effective forces f̃ = M̃ a_free (n) \[N\] (zero when W is singular).
    pub effective_force: DVector<f64>,
    /// W_T (n × k): interface accelerations per unit friction force F_T of each joint, through its
    /// moments alone [1/kg].
    pub friction_mobility: DMatrix<f64>,
    /// Generalized accelerations with f_c = 0 and F_T = 0.
    pub free_accelerations: Vec<f64>,
    /// Columns of G (3k): q̈ per unit force along x, along y on each journal (2j, 2j + 1), then per
    /// unit friction force of each joint (2k + j).
    pub gain: Vec<Vec<f64>>,
    /// Multipliers with f_c = 0 and F_T = 0.
    pub free_lambda: Vec<f64>,
    /// Columns of Λ, in the order of `gain`.
    pub lambda_gain: Vec<Vec<f64>>,
    /// Work vectors of [`coupled_effective_terms_into`].
    scratch: Scratch,
}

/// Work vectors of the coupled terms' solves: the load, zero γ, the multipliers, the arms.
#[derive(Debug, Clone, PartialEq)]
struct Scratch {
    force: Vec<f64>,
    zero_gamma: Vec<f64>,
    lambda: DVector<f64>,
    loads: Vec<UnitLoads>,
}

impl CoupledTerms {
    /// Zero terms for a mechanism of `coordinates` coordinates and `constraints` constraint rows
    /// with `joints` clearance joints (the storage [`coupled_effective_terms_into`] fills).
    pub fn zeros(coordinates: usize, constraints: usize, joints: usize) -> Self {
        let dim = 2 * joints;
        Self {
            mobility: DMatrix::zeros(dim, dim),
            effective_mass: None,
            free_acceleration: DVector::zeros(dim),
            effective_force: DVector::zeros(dim),
            friction_mobility: DMatrix::zeros(dim, joints),
            free_accelerations: vec![0.0; coordinates],
            gain: vec![vec![0.0; coordinates]; 3 * joints],
            free_lambda: vec![0.0; constraints],
            lambda_gain: vec![vec![0.0; constraints]; 3 * joints],
            scratch: Scratch {
                force: vec![0.0; coordinates],
                zero_gamma: vec![0.0; constraints],
                lambda: DVector::zeros(constraints),
                loads: Vec::with_capacity(joints),
            },
        }
    }

    /// q̈ = q̈_free + G [f_c; F_T].
    pub fn accelerations(&self, contact_forces: &[f64], friction_forces: &[f64], out: &mut [f64]) {
        out.copy_from_slice(&self.free_accelerations);
        for (column, &f) in self.gain.iter().zip(contact_forces.iter().chain(friction_forces)) {
            for (o, g) in out.iter_mut().zip(column) {
                *o += g * f;
            }
        }
    }
}

/// Effective terms of the clearance joints `joints` of the cut mechanism `mech` (every one of them
/// removed) at `(t, q, q̇)`. One factorisation serves the 3k + 1 solves.
pub fn coupled_effective_terms(
    mech: &Mechanism,
    solver: &mut Solver,
    joints: &[ClearanceInterface],
    t: f64,
    q: &[f64],
    qd: &[f64],
) -> Result<CoupledTerms, MechError> {
    let mut terms = CoupledTerms::zeros(q.len(), mech.constraint_count(), joints.len());
    coupled_effective_terms_into(mech, solver, joints, t, q, qd, &mut terms)?;
    Ok(terms)
}

/// [`coupled_effective_terms`] written into `terms` (made by [`CoupledTerms::zeros`] for this
/// mechanism and these joints, or by an earlier call): the same values, without allocating — the
/// macro subsystem refreshes its terms this way at every communication point.
pub fn coupled_effective_terms_into(
    mech: &Mechanism,
    solver: &mut Solver,
    joints: &[ClearanceInterface],
    t: f64,
    q: &[f64],
    qd: &[f64],
    terms: &mut CoupledTerms,
) -> Result<(), MechError> {
    let k = joints.len();
    assert!(
        terms.gain.len() == 3 * k && terms.free_accelerations.len() == q.len(),
        "the terms were made for another mechanism or joint count"
    );
    solver.set_state(mech, t, q, qd);
    solver.factor()?;
    solver.solve(mech, qd);
    terms.free_accelerations.copy_from_slice(&solver.accelerations);
    terms.free_lambda.copy_from_slice(solver.lambda.as_slice());
    // Each joint's unit loads at the poses (read before the solves borrow the solver).
    let CoupledTerms { scratch, gain, lambda_gain, .. } = terms;
    scratch.loads.clear();
    scratch.loads.extend(joints.iter().map(|j| j.unit_loads(&solver.poses)));
    let Scratch { force, zero_gamma, lambda, loads } = scratch;
    for (j, loads) in loads.iter().enumerate() {
        // Joint j's columns: its two interface coordinates' (2j, 2j + 1), its friction load's
        // (2k + j).
        for (column, r) in [(2 * j, 0), (2 * j + 1, 1), (2 * k + j, 2)] {
            force.fill(0.0);
            loads.add(r, force);
            solver.solve_with(force, zero_gamma, &mut gain[column], lambda);
            lambda_gain[column].copy_from_slice(lambda.as_slice());
        }
    }
    coupled_rates_into(solver, joints, terms);
    Ok(())
}

/// The part of [`coupled_effective_terms_into`] after its solves (q̈ and λ free, G and Λ in
/// `terms`, the poses and velocities in `solver`): W, W_T, a_free, M̃ and f̃. (The solves may
/// have been done elsewhere, e.g. in lanes with other mechanisms': `crate::lanes`.)
pub fn coupled_rates_into(solver: &Solver, joints: &[ClearanceInterface], terms: &mut CoupledTerms) {
    let k = joints.len();
    let dim = 2 * k;
    let poses = &solver.poses;
    // J̇ q̇ = −ω_J² a_J + ω_B² a_B.
    let centripetal = |body: BodyId, point: Vec2| -> Vec2 {
        match body {
            BodyId::Ground => Vec2::zeros(),
            BodyId::Body(b) => -poses[b].rotate(point) * (poses[b].angular_velocity * poses[b].angular_velocity),
        }
    };
    for (row, joint) in joints.iter().enumerate() {
        let iface = &joint.interface;
        if let Some(guide) = &joint.guide {
            let rows = GuideRows::at(iface, guide, poses);
            for r in 0..2 {
                for c in 0..dim {
                    terms.mobility[(2 * row + r, c)] = rows.times(r, &terms.gain[c]);
                }
                for c in 0..k {
                    terms.friction_mobility[(2 * row + r, c)] = rows.times(r, &terms.gain[dim + c]);
                }
                terms.free_acceleration[2 * row + r] = rows.times(r, &terms.free_accelerations) - rows.gamma[r];
            }
            continue;
        }
        for c in 0..dim {
            let w = interface_rate(iface, poses, &terms.gain[c]);
            terms.mobility[(2 * row, c)] = w.x;
            terms.mobility[(2 * row + 1, c)] = w.y;
        }
        for c in 0..k {
            let w = interface_rate(iface, poses, &terms.gain[dim + c]);
            terms.friction_mobility[(2 * row, c)] = w.x;
            terms.friction_mobility[(2 * row + 1, c)] = w.y;
        }
        let a = interface_rate(iface, poses, &terms.free_accelerations)
            + centripetal(iface.journal_body, iface.journal_point)
            - centripetal(iface.bearing_body, iface.bearing_point);
        terms.free_acceleration[2 * row] = a.x;
        terms.free_acceleration[2 * row + 1] = a.y;
    }
    invert_into(&terms.mobility, &mut terms.effective_mass);
    match &terms.effective_mass {
        Some(mt) => mt.mul_to(&terms.free_acceleration, &mut terms.effective_force),
        None => terms.effective_force.fill(0.0),
    }
}

/// [`invert`] into `out`, keeping its storage where the result is a 2 × 2 inverse again.
fn invert_into(w: &DMatrix<f64>, out: &mut Option<DMatrix<f64>>) {
    if w.nrows() == 2
        && let Some(inverse) = invert_2x2(w)
    {
        match out {
            Some(o) if o.shape() == (2, 2) => o.copy_from(&inverse),
            _ => *out = Some(DMatrix::from_column_slice(2, 2, inverse.as_slice())),
        }
        return;
    }
    *out = invert(w);
}

/// The closed-form inverse of a 2 × 2 W, or `None` when it is singular (relative to its largest
/// entry).
fn invert_2x2(w: &DMatrix<f64>) -> Option<Matrix2<f64>> {
    let scale = w.amax();
    let m = Matrix2::new(w[(0, 0)], w[(0, 1)], w[(1, 0)], w[(1, 1)]);
    if m.determinant().abs() <= 1e-12 * scale * scale {
        return None;
    }
    m.try_inverse()
}

/// W⁻¹, or `None` when W is singular (relative to its largest entry). The 2 × 2 case keeps the
/// closed-form inverse of one joint.
fn invert(w: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if w.nrows() == 2 {
        return invert_2x2(w).map(|i| DMatrix::from_row_slice(2, 2, &[i[(0, 0)], i[(0, 1)], i[(1, 0)], i[(1, 1)]]));
    }
    let scale = w.amax();
    let lu = w.clone().lu();
    let inverse = lu.try_inverse()?;
    // Singular to working precision: the inverse's scale betrays it.
    let condition = inverse.amax() * scale * w.nrows() as f64;
    (condition.is_finite() && condition < 1e12).then_some(inverse)
}

/// Effective terms of one interface `iface` for the cut mechanism `mech` at `(t, q, q̇)`: the
/// coupled terms of a single joint (without its friction column), as 2 × 2 values.
pub fn effective_terms(
    mech: &Mechanism,
    solver: &mut Solver,
    iface: &Interface,
    t: f64,
    q: &[f64],
    qd: &[f64],
) -> Result<EffectiveTerms, MechError> {
    let joint = ClearanceInterface { interface: *iface, journal_radius: 0.0, bearing_radius: 0.0, guide: None };
    let c = coupled_effective_terms(mech, solver, &[joint], t, q, qd)?;
    let two = |m: &DMatrix<f64>| Matrix2::new(m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]);
    let mut gain = c.gain.into_iter();
    let mut lambda_gain = c.lambda_gain.into_iter();
    let next = |it: &mut std::vec::IntoIter<Vec<f64>>| it.next().expect("three columns");
    Ok(EffectiveTerms {
        mobility: two(&c.mobility),
        effective_mass: c.effective_mass.as_ref().map(two),
        free_acceleration: Vec2::new(c.free_acceleration[0], c.free_acceleration[1]),
        effective_force: Vec2::new(c.effective_force[0], c.effective_force[1]),
        free_accelerations: c.free_accelerations,
        gain: [next(&mut gain), next(&mut gain)],
        free_lambda: c.free_lambda,
        lambda_gain: [next(&mut lambda_gain), next(&mut lambda_gain)],
    })
}

/// The interface load that produces the macro mechanism's own motion over a macro step, into
/// `own` (the interface forces, then the friction loads; planar and spatial macro subsystems
/// alike). One-way coupling (`two_way` none): −f̃ and no friction load — the ideal mechanism's
/// motion, ẅ = 0. Two-way coupling, with the prescribed ẅ and the step's mean friction loads L̄:
/// M̃ (ẅ − a_free) − H L̄, then L̄ (H = M̃ W_T, the friction loads' columns `friction_gain`).
pub fn own_interface_load(
    own: &mut [f64],
    effective_force: &DVector<f64>,
    two_way: Option<(DVector<f64>, &[f64])>,
    (effective_mass, free_acceleration, friction_gain): (&DMatrix<f64>, &DVector<f64>, &DMatrix<f64>),
) {
    match two_way {
        Some((wdd, friction)) => {
            let n = wdd.len();
            let mean = DVector::from_column_slice(friction);
            let f = effective_mass * (wdd - free_acceleration) - friction_gain * &mean;
            own[..n].copy_from_slice(f.as_slice());
            own[n..].copy_from_slice(friction);
        }
        None => {
            for (o, f) in own.iter_mut().zip(effective_force.iter()) {
                *o = -f;
            }
        }
    }
}
