//! The index-1 KKT solve by the Schur complement, allocation-free after construction.
//!
//! M is block diagonal (m I₃ and J' per body), so `M v̇ + Cᵀλ = Q`, `C v̇ = γ̂` reduces to
//! `S λ = C M⁻¹ Q − γ̂` with `S = C M⁻¹ Cᵀ` (equations × equations, symmetric positive definite
//! while C has full row rank), factored by Cholesky; then `v̇ = M⁻¹(Q − Cᵀλ)`. Each row of C
//! touches at most two bodies; the pairs of rows that share a body (the structural non-zeros of
//! S) are listed once at construction.

use crate::constraints::{self, BodyFrame, Row};
use crate::model::{SpatialLoad, SpatialMechanism};
use crate::{Mat3, VELOCITY_COORDINATES, Vec3};
use lash_mech::dense::SmallCholesky;
use lash_mech::{BodyId, MechError};

/// Workspace and results of KKT solves for one mechanism.
pub struct SpatialSolver {
    /// The bodies' frames at the current state.
    pub frames: Vec<BodyFrame>,
    /// Rows of Φ, C, ν, γ at the current state.
    pub rows: Vec<Row>,
    /// Generalized applied forces Q per body: (f in the world frame, n' − ω' × J'ω' in the body
    /// frame); [`SpatialSolver::set_state`] fills gravity, loads and the gyroscopic term.
    pub forces: Vec<f64>,
    /// v̇ after [`SpatialSolver::solve`].
    pub accelerations: Vec<f64>,
    /// Lagrange multipliers λ after [`SpatialSolver::solve`] (generalized reaction −Cᵀλ).
    pub lambda: Vec<f64>,
    /// The body-frame angular velocities ω' of the current state.
    pub angular_velocities: Vec<Vec3>,
    inverse_mass: Vec<f64>,
    inverse_inertia: Vec<Mat3>,
    inertia: Vec<Mat3>,
    /// Row pairs sharing a body: (row a, block of a, row b, block of b), b ≤ a.
    pairs: Vec<(usize, usize, usize, usize)>,
    /// M⁻¹ Cᵀ per row and block.
    weighted: Vec<[[f64; 6]; 2]>,
    /// M⁻¹ Q.
    free_acceleration: Vec<f64>,
    velocities: Vec<f64>,
    schur: SmallCholesky,
    time: f64,
}

#[inline]
fn dot6(a: &[f64; 6], b: &[f64]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
}

impl SpatialSolver {
    /// A workspace sized for `mech` (validated).
    pub fn new(mech: &SpatialMechanism) -> Self {
        let (n, m) = (mech.velocity_count(), mech.constraint_count());
        let body = |id: BodyId| match id {
            BodyId::Body(k) => Some(k),
            BodyId::Ground => None,
        };
        let mut row_bodies = Vec::with_capacity(m);
        for j in &mech.joints {
            for _ in 0..j.kind.equations() {
                row_bodies.push([body(j.i.body), body(j.j.body)]);
            }
        }
        for d in &mech.drivers {
            let j = &mech.joints[d.joint];
            row_bodies.push([body(j.i.body), body(j.j.body)]);
        }
        let mut pairs = Vec::new();
        for a in 0..m {
            for b in 0..=a {
                for (ba, body_a) in row_bodies[a].iter().enumerate() {
                    for (bb, body_b) in row_bodies[b].iter().enumerate() {
                        if body_a.is_some() && body_a == body_b {
                            pairs.push((a, ba, b, bb));
                        }
                    }
                }
            }
        }
        // The profile of S: row a's first structural non-zero (S is zero where no body is shared).
        let mut first: Vec<usize> = (0..m).collect();
        for &(a, _, b, _) in &pairs {
            first[a] = first[a].min(b);
        }
        let mut schur = SmallCholesky::new(m);
        schur.set_profile(&first);
        let rows = row_bodies.iter().map(|&bodies| Row { bodies, ..Row::default() }).collect();
        Self {
            frames: vec![BodyFrame::ground(); mech.bodies.len()],
            rows,
            forces: vec![0.0; n],
            accelerations: vec![0.0; n],
            lambda: vec![0.0; m],
            angular_velocities: vec![Vec3::zeros(); mech.bodies.len()],
            inverse_mass: mech.bodies.iter().map(|b| 1.0 / b.mass).collect(),
            inverse_inertia: mech
                .bodies
                .iter()
                .map(|b| b.inertia.try_inverse().unwrap_or(Mat3::repeat(f64::NAN)))
                .collect(),
            inertia: mech.bodies.iter().map(|b| b.inertia).collect(),
            pairs,
            weighted: vec![[[0.0; 6]; 2]; m],
            free_acceleration: vec![0.0; n],
            velocities: vec![0.0; n],
            schur,
            time: 0.0,
        }
    }

    /// Frames, rows and applied forces at `(t, q, v)`.
    pub fn set_state(&mut self, mech: &SpatialMechanism, t: f64, q: &[f64], v: &[f64]) {
        self.time = t;
        self.velocities.copy_from_slice(v);
        for (k, f) in self.frames.iter_mut().enumerate() {
            let rotation = *crate::orientation(&q[7 * k + 3..7 * k + 7]).to_rotation_matrix().matrix();
            let w_body = Vec3::new(v[6 * k + 3], v[6 * k + 4], v[6 * k + 5]);
            self.angular_velocities[k] = w_body;
            *f = BodyFrame {
                position: Vec3::new(q[7 * k], q[7 * k + 1], q[7 * k + 2]),
                rotation,
                velocity: Vec3::new(v[6 * k], v[6 * k + 1], v[6 * k + 2]),
                angular_velocity: rotation * w_body,
            };
        }
        constraints::evaluate(mech, &self.frames, t, &mut self.rows);
        // Q: gravity, gyroscopic terms, then the loads.
        for (k, b) in mech.bodies.iter().enumerate() {
            let w = self.angular_velocities[k];
            let gyroscopic = -w.cross(&(self.inertia[k] * w));
            let f = b.mass * mech.gravity;
            self.forces[6 * k..6 * k + 3].copy_from_slice(f.as_slice());
            self.forces[6 * k + 3..6 * k + 6].copy_from_slice(gyroscopic.as_slice());
        }
        for load in &mech.loads {
            match *load {
                SpatialLoad::Force { body, point, force } => {
                    let a = &self.frames[body].rotation;
                    let torque = (a * point).cross(&force);
                    self.add_force(body, force, torque);
                }
                SpatialLoad::Torque { body, torque } => self.add_force(body, Vec3::zeros(), torque),
                SpatialLoad::Motor { joint, stall_torque, no_load_speed } => {
                    let jt = &mech.joints[joint];
                    let omega = |id: BodyId| match id {
                        BodyId::Body(k) => self.frames[k].angular_velocity,
                        BodyId::Ground => Vec3::zeros(),
                    };
                    let (_, _, axis, _) = constraints::marker_world(&jt.i, &self.frames);
                    let speed = (omega(jt.j.body) - omega(jt.i.body)).dot(&axis);
                    let torque = stall_torque * (1.0 - speed / no_load_speed) * axis;
                    if let BodyId::Body(k) = jt.j.body {
                        self.add_force(k, Vec3::zeros(), torque);
                    }
                    if let BodyId::Body(k) = jt.i.body {
                        self.add_force(k, Vec3::zeros(), -torque);
                    }
                }
            }
        }
    }

    /// Adds a force (world) through the centroid and a torque (world) to body `k`.
    pub fn add_force(&mut self, k: usize, force: Vec3, torque: Vec3) {
        let n = self.frames[k].rotation.transpose() * torque;
        for c in 0..3 {
            self.forces[6 * k + c] += force[c];
            self.forces[6 * k + 3 + c] += n[c];
        }
    }

    /// M⁻¹ x for body `k`'s six entries.
    #[inline]
    fn inverse_mass_times(&self, k: usize, x: &[f64]) -> [f64; 6] {
        let im = self.inverse_mass[k];
        let w = self.inverse_inertia[k] * Vec3::new(x[3], x[4], x[5]);
        [im * x[0], im * x[1], im * x[2], w.x, w.y, w.z]
    }

    /// Factors S = C M⁻¹ Cᵀ (+ `regularization` × its largest diagonal entry on the diagonal) of
    /// the current rows.
    fn factor(&mut self, regularization: f64) -> Result<(), MechError> {
        for (r, w) in self.rows.iter().zip(self.weighted.iter_mut()) {
            for b in 0..2 {
                w[b] = match r.bodies[b] {
                    Some(k) => {
                        let im = self.inverse_mass[k];
                        let blk = &r.blocks[b];
                        let a = self.inverse_inertia[k] * Vec3::new(blk[3], blk[4], blk[5]);
                        [im * blk[0], im * blk[1], im * blk[2], a.x, a.y, a.z]
                    }
                    None => [0.0; 6],
                };
            }
        }
        let m = self.rows.len();
        // Only the profile is read when the factor uses one (left of it S is zero and stays so).
        for a in 0..m {
            let f = self.schur.first_column(a);
            self.schur.matrix_mut()[a * m + f..=a * m + a].fill(0.0);
        }
        let s = self.schur.matrix_mut();
        for &(a, ba, b, bb) in &self.pairs {
            s[a * m + b] += dot6(&self.rows[a].blocks[ba], &self.weighted[b][bb]);
        }
        if regularization > 0.0 {
            let largest = (0..m).map(|a| s[a * m + a]).fold(0.0, f64::max);
            for a in 0..m {
                s[a * m + a] += regularization * largest;
            }
        }
        if self.schur.factor() { Ok(()) } else { Err(MechError::SingularConstraints { t: self.time }) }
    }

    /// C v for row `r`.
    #[inline]
    fn row_times(r: &Row, v: &[f64]) -> f64 {
        let mut x = 0.0;
        for b in 0..2 {
            if let Some(k) = r.bodies[b] {
                x += dot6(&r.blocks[b], &v[VELOCITY_COORDINATES * k..VELOCITY_COORDINATES * k + 6]);
            }
        }
        x
    }

    /// Solves for v̇ and λ with Baumgarte's γ̂ = γ − 2α(C v − ν) − β²Φ.
    pub fn solve(&mut self, mech: &SpatialMechanism) -> Result<(), MechError> {
        self.factor(0.0)?;
        let (alpha, beta) = (mech.baumgarte.alpha, mech.baumgarte.beta);
        for k in 0..self.frames.len() {
            let a = self.inverse_mass_times(k, &self.forces[6 * k..6 * k + 6]);
            self.free_acceleration[6 * k..6 * k + 6].copy_from_slice(&a);
        }
        for (a, r) in self.rows.iter().enumerate() {
            let velocity_error = Self::row_times(r, &self.velocities) - r.nu;
            let gamma_hat = r.gamma - 2.0 * alpha * velocity_error - beta * beta * r.phi;
            self.lambda[a] = Self::row_times(r, &self.free_acceleration) - gamma_hat;
        }
        self.schur.solve_mut(&mut self.lambda);
        self.accelerations.copy_from_slice(&self.free_acceleration);
        for (a, r) in self.rows.iter().enumerate() {
            let l = self.lambda[a];
            for b in 0..2 {
                if let Some(k) = r.bodies[b] {
                    for c in 0..6 {
                        self.accelerations[6 * k + c] -= self.weighted[a][b][c] * l;
                    }
                }
            }
        }
        Ok(())
    }

    /// The response to a generalized load alone (no γ, no stabilisation: the part of v̇ and λ
    /// linear in the load), with the factor of the last [`SpatialSolver::solve`]: `Sλ = C M⁻¹ load`,
    /// `v̇ = M⁻¹(load − Cᵀλ)`.
    pub fn response(&mut self, load: &[f64], accelerations: &mut [f64], lambda: &mut [f64]) {
        for k in 0..self.frames.len() {
            let a = self.inverse_mass_times(k, &load[6 * k..6 * k + 6]);
            accelerations[6 * k..6 * k + 6].copy_from_slice(&a);
        }
        for (a, r) in self.rows.iter().enumerate() {
            lambda[a] = Self::row_times(r, accelerations);
        }
        self.schur.solve_mut(lambda);
        for (a, r) in self.rows.iter().enumerate() {
            for b in 0..2 {
                if let Some(k) = r.bodies[b] {
                    for c in 0..6 {
                        accelerations[6 * k + c] -= self.weighted[a][b][c] * lambda[a];
                    }
                }
            }
        }
    }

    /// The minimum-kinetic-energy correction δ = M⁻¹Cᵀ S⁻¹ e of a residual e per row (velocity
    /// analysis: e = ν − C v; assembly: e = −Φ), written into `delta` (6 per body). Redundant but
    /// consistent equations (a planar loop of revolutes in space) make S singular: then S + εI
    /// with ε = 1e-10 of its largest diagonal entry gives the least-squares correction to that
    /// accuracy, and the callers iterate it.
    pub fn correction(&mut self, residual: &[f64], delta: &mut [f64]) -> Result<(), MechError> {
        if self.factor(0.0).is_err() {
            self.factor(1e-10)?;
        }
        self.lambda.copy_from_slice(residual);
        self.schur.solve_mut(&mut self.lambda);
        delta.fill(0.0);
        for (a, r) in self.rows.iter().enumerate() {
            for b in 0..2 {
                if let Some(k) = r.bodies[b] {
                    for c in 0..6 {
                        delta[6 * k + c] += self.weighted[a][b][c] * self.lambda[a];
                    }
                }
            }
        }
        Ok(())
    }

    /// max |Φ| at the current state.
    pub fn constraint_error(&self) -> f64 {
        self.rows.iter().fold(0.0, |m, r| m.max(r.phi.abs()))
    }

    /// max |C v − ν| at the current state.
    pub fn velocity_error(&self) -> f64 {
        self.rows.iter().fold(0.0, |m, r| m.max((Self::row_times(r, &self.velocities) - r.nu).abs()))
    }

    /// The generalized reaction of row range `rows` on body `k`: (force in the world frame, torque
    /// in the world frame about the centroid), −Cᵀλ mapped back from (ṙ, ω').
    pub fn reaction(&self, rows: std::ops::Range<usize>, k: usize) -> (Vec3, Vec3) {
        let (mut f, mut n) = (Vec3::zeros(), Vec3::zeros());
        for a in rows {
            let r = &self.rows[a];
            for b in 0..2 {
                if r.bodies[b] == Some(k) {
                    let blk = &r.blocks[b];
                    f -= Vec3::new(blk[0], blk[1], blk[2]) * self.lambda[a];
                    n -= Vec3::new(blk[3], blk[4], blk[5]) * self.lambda[a];
                }
            }
        }
        (f, self.frames[k].rotation * n)
    }
}
