//! Plane-strain finite elements of the bush annulus: curved 9-node (biquadratic Lagrange)
//! quadrilaterals with the exact polar geometry, 3 × 3 Gauss points, the outer surface fixed;
//! the free degrees of freedom's stiffness assembled into a sparse matrix and factored once by
//! faer's sparse Cholesky (symbolic and numeric), then solved for any number of load cases.

use crate::mesh::AnnulusMesh;
use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};

/// Gauss–Legendre points and weights on [−1, 1], 3 points.
pub const GAUSS3: [(f64, f64); 3] =
    [(-0.774_596_669_241_483_4, 5.0 / 9.0), (0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];

/// Gauss–Legendre points and weights on [−1, 1], 8 points (edge loads with a square-root edge).
pub const GAUSS8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// 1-D quadratic Lagrange functions at nodes −1, 0, 1 and their derivatives.
pub fn lagrange(x: f64) -> ([f64; 3], [f64; 3]) {
    ([0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)], [x - 0.5, -2.0 * x, x + 0.5])
}

/// Plane-strain constitutive matrix (Voigt order xx, yy, xy with engineering shear) of Lamé
/// parameters λ and μ.
pub fn plane_strain(lambda: f64, mu: f64) -> [[f64; 3]; 3] {
    [[lambda + 2.0 * mu, lambda, 0.0], [lambda, lambda + 2.0 * mu, 0.0], [0.0, 0.0, mu]]
}

/// Lamé parameters of Young's modulus E and Poisson's ratio ν.
pub fn lame(young: f64, poisson: f64) -> (f64, f64) {
    (young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)), young / (2.0 * (1.0 + poisson)))
}

/// The shape functions' x and y derivatives and the area element at (ξ, η) of the element with
/// extent (r0, r1, θ0, θ1), and the point (r, θ).
pub struct Point {
    /// ∂N/∂x of the nine nodes.
    pub dx: [f64; 9],
    /// ∂N/∂y of the nine nodes.
    pub dy: [f64; 9],
    /// det J.
    pub det: f64,
    /// Radius \[m\].
    pub r: f64,
    /// Angle \[rad\].
    pub theta: f64,
}

/// Shape-function derivatives at (ξ across the wall, η around) of an element.
pub fn point(extent: (f64, f64, f64, f64), xi: f64, eta: f64) -> Point {
    let (r0, r1, t0, t1) = extent;
    let (dr, dt) = (0.5 * (r1 - r0), 0.5 * (t1 - t0));
    let (r, theta) = (r0 + dr * (1.0 + xi), t0 + dt * (1.0 + eta));
    let (s, c) = theta.sin_cos();
    // x = r cos θ, y = r sin θ: ∂(x, y)/∂ξ = dr (c, s), ∂(x, y)/∂η = r dt (−s, c).
    let det = r * dr * dt;
    let (la, da) = lagrange(xi);
    let (lb, db) = lagrange(eta);
    let (mut dx, mut dy) = ([0.0; 9], [0.0; 9]);
    for a in 0..3 {
        for b in 0..3 {
            let (n_xi, n_eta) = (da[a] * lb[b], la[a] * db[b]);
            // ∂N/∂r = n_xi / dr, (1/r) ∂N/∂θ = n_eta / (r dt).
            let (n_r, n_t) = (n_xi / dr, n_eta / (r * dt));
            dx[3 * a + b] = c * n_r - s * n_t;
            dy[3 * a + b] = s * n_r + c * n_t;
        }
    }
    Point { dx, dy, det, r, theta }
}

/// Strain (xx, yy, xy engineering) at a point from the element's nodal displacements.
pub fn strain(p: &Point, u: &[[f64; 2]; 9]) -> [f64; 3] {
    let mut e = [0.0; 3];
    for n in 0..9 {
        e[0] += p.dx[n] * u[n][0];
        e[1] += p.dy[n] * u[n][1];
        e[2] += p.dy[n] * u[n][0] + p.dx[n] * u[n][1];
    }
    e
}

/// ∫ Bᵀ D B dA of one element (18 × 18, degrees of freedom 2 n + {0: x, 1: y}), per unit length.
pub fn element_matrix(extent: (f64, f64, f64, f64), d: &[[f64; 3]; 3]) -> [[f64; 18]; 18] {
    let mut k = [[0.0; 18]; 18];
    for &(xi, wx) in &GAUSS3 {
        for &(eta, we) in &GAUSS3 {
            let p = point(extent, xi, eta);
            let w = wx * we * p.det;
            // B columns: node n, x → (dx, 0, dy); y → (0, dy, dx).
            let mut b = [[0.0; 18]; 3];
            for n in 0..9 {
                b[0][2 * n] = p.dx[n];
                b[1][2 * n + 1] = p.dy[n];
                b[2][2 * n] = p.dy[n];
                b[2][2 * n + 1] = p.dx[n];
            }
            let mut db = [[0.0; 18]; 3];
            for i in 0..3 {
                for j in 0..18 {
                    db[i][j] = d[i][0] * b[0][j] + d[i][1] * b[1][j] + d[i][2] * b[2][j];
                }
            }
            for (i, row) in k.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v += w * (b[0][i] * db[0][j] + b[1][i] * db[1][j] + b[2][i] * db[2][j]);
                }
            }
        }
    }
    k
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveError(pub String);

impl std::fmt::Display for SolveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SolveError {}

/// The annulus with its outer surface fixed and, optionally, its bore held by a rigid bonded pin:
/// the free degrees of freedom's stiffness, factored.
pub struct Annulus {
    /// The mesh.
    pub mesh: AnnulusMesh,
    /// Constitutive matrix (plane strain).
    pub d: [[f64; 3]; 3],
    /// Free-DOF index of each global DOF (`usize::MAX`: prescribed).
    free: Vec<usize>,
    /// The factorisation of the free stiffness.
    llt: Llt<usize, f64>,
    /// Element matrices, in element order (i across the wall, then j around).
    elements: Vec<[[f64; 18]; 18]>,
    /// Symbolic-factorisation and numeric-factorisation counts (for the reuse checks).
    pub factorisations: (usize, usize),
}

impl Annulus {
    /// Assembles and factors the annulus: outer ring fixed; the bore's nodes also prescribed when
    /// `bonded` (a rigid pin bonded to it).
    pub fn new(mesh: AnnulusMesh, d: [[f64; 3]; 3], bonded: bool) -> Result<Self, SolveError> {
        let (rings, per_ring) = (mesh.node_rings(), mesh.nodes_per_ring());
        let mut free = vec![usize::MAX; 2 * mesh.node_count()];
        let mut count = 0;
        for node in 0..mesh.node_count() {
            let ring = node / per_ring;
            if ring == rings - 1 || (bonded && ring == 0) {
                continue;
            }
            free[2 * node] = count;
            free[2 * node + 1] = count + 1;
            count += 2;
        }
        let mut elements = Vec::with_capacity(mesh.radial_elements() * mesh.angular_elements());
        let mut triplets = Vec::with_capacity(elements.capacity() * 18 * 18);
        for i in 0..mesh.radial_elements() {
            for j in 0..mesh.angular_elements() {
                let k = element_matrix(mesh.element_extent(i, j), &d);
                let nodes = mesh.element_nodes(i, j);
                for (a, &na) in nodes.iter().enumerate() {
                    for ca in 0..2 {
                        let row = free[2 * na + ca];
                        if row == usize::MAX {
                            continue;
                        }
                        for (b, &nb) in nodes.iter().enumerate() {
                            for cb in 0..2 {
                                let col = free[2 * nb + cb];
                                // The lower triangle is what the factorisation reads.
                                if col != usize::MAX && col <= row {
                                    triplets.push(Triplet::new(row, col, k[2 * a + ca][2 * b + cb]));
                                }
                            }
                        }
                    }
                }
                elements.push(k);
            }
        }
        let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(count, count, &triplets)
            .map_err(|e| SolveError(format!("assembling the bush stiffness: {e:?}")))?;
        let symbolic = SymbolicLlt::try_new(matrix.symbolic(), Side::Lower)
            .map_err(|e| SolveError(format!("ordering the bush stiffness: {e:?}")))?;
        let llt = Llt::try_new_with_symbolic(symbolic, matrix.as_ref(), Side::Lower)
            .map_err(|e| SolveError(format!("factoring the bush stiffness (not positive definite?): {e:?}")))?;
        Ok(Self { mesh, d, free, llt, elements, factorisations: (1, 1) })
    }

    /// Number of free degrees of freedom.
    pub fn free_count(&self) -> usize {
        self.free.iter().filter(|f| **f != usize::MAX).count()
    }

    /// The displacement of every node (x, y) for prescribed nodal displacements `prescribed`
    /// (node → value; others of the prescribed set are zero) and nodal forces `forces` on free
    /// nodes (2 per node, global numbering).
    pub fn solve(&self, prescribed: &dyn Fn(usize) -> [f64; 2], forces: &[f64]) -> Vec<[f64; 2]> {
        let n = self.mesh.node_count();
        let mut known = vec![[0.0; 2]; n];
        for (node, k) in known.iter_mut().enumerate() {
            if self.free[2 * node] == usize::MAX {
                *k = prescribed(node);
            }
        }
        let count = self.free_count();
        let mut rhs = faer::Mat::<f64>::zeros(count, 1);
        for (g, &f) in self.free.iter().enumerate() {
            if f != usize::MAX {
                rhs[(f, 0)] = forces.get(g).copied().unwrap_or(0.0);
            }
        }
        // − K_fp u_p, element by element.
        let mesh = &self.mesh;
        for i in 0..mesh.radial_elements() {
            for j in 0..mesh.angular_elements() {
                let nodes = mesh.element_nodes(i, j);
                let k = &self.elements[i * mesh.angular_elements() + j];
                let any = nodes.iter().any(|&nd| self.free[2 * nd] == usize::MAX && known[nd] != [0.0; 2]);
                if !any {
                    continue;
                }
                for (a, &na) in nodes.iter().enumerate() {
                    for ca in 0..2 {
                        let row = self.free[2 * na + ca];
                        if row == usize::MAX {
                            continue;
                        }
                        for (b, &nb) in nodes.iter().enumerate() {
                            if self.free[2 * nb] == usize::MAX {
                                for cb in 0..2 {
                                    rhs[(row, 0)] -= k[2 * a + ca][2 * b + cb] * known[nb][cb];
                                }
                            }
                        }
                    }
                }
            }
        }
        let x = self.llt.solve(&rhs);
        let mut u = known;
        for (node, v) in u.iter_mut().enumerate() {
            for c in 0..2 {
                let f = self.free[2 * node + c];
                if f != usize::MAX {
                    v[c] = x[(f, 0)];
                }
            }
        }
        u
    }

    /// Nodal displacements of element (i, j).
    pub fn element_displacements(&self, i: usize, j: usize, u: &[[f64; 2]]) -> [[f64; 2]; 9] {
        let nodes = self.mesh.element_nodes(i, j);
        let mut ue = [[0.0; 2]; 9];
        for (e, &n) in ue.iter_mut().zip(&nodes) {
            *e = u[n];
        }
        ue
    }

    /// The internal force K u at every node (x, y): the reactions at prescribed nodes.
    pub fn internal_forces(&self, u: &[[f64; 2]], rings: std::ops::Range<usize>) -> Vec<[f64; 2]> {
        let mesh = &self.mesh;
        let mut f = vec![[0.0; 2]; mesh.node_count()];
        let elements = (rings.start / 2)..rings.end.div_ceil(2).min(mesh.radial_elements());
        for i in elements {
            for j in 0..mesh.angular_elements() {
                let nodes = mesh.element_nodes(i, j);
                let k = &self.elements[i * mesh.angular_elements() + j];
                let ue = self.element_displacements(i, j, u);
                for (a, &na) in nodes.iter().enumerate() {
                    for ca in 0..2 {
                        let mut s = 0.0;
                        for (b, ub) in ue.iter().enumerate() {
                            s += k[2 * a + ca][2 * b] * ub[0] + k[2 * a + ca][2 * b + 1] * ub[1];
                        }
                        f[na][ca] += s;
                    }
                }
            }
        }
        f
    }

    /// ½ ∫ ε:D':ε dA summed over the elements, for another constitutive matrix D' (the energy
    /// form of the displacement field `u` in that material), per unit length, times 2: uᵀ K' u.
    pub fn quadratic_form(&self, u: &[[f64; 2]], d: &[[f64; 3]; 3]) -> f64 {
        let mesh = &self.mesh;
        let mut total = 0.0;
        for i in 0..mesh.radial_elements() {
            for j in 0..mesh.angular_elements() {
                let ue = self.element_displacements(i, j, u);
                let extent = mesh.element_extent(i, j);
                for &(xi, wx) in &GAUSS3 {
                    for &(eta, we) in &GAUSS3 {
                        let p = point(extent, xi, eta);
                        let e = strain(&p, &ue);
                        let mut s = 0.0;
                        for a in 0..3 {
                            for b in 0..3 {
                                s += e[a] * d[a][b] * e[b];
                            }
                        }
                        total += wx * we * p.det * s;
                    }
                }
            }
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshOptions;

    /// Largest error of the x and y derivatives of u = 2x + 3y interpolated on a curved element
    /// spanning `span` radians.
    fn gradient_error(span: f64) -> f64 {
        let extent = (0.011, 0.012, 0.3, 0.3 + span);
        let mut nodal = [0.0; 9];
        for a in 0..3 {
            for b in 0..3 {
                let r = extent.0 + 0.5 * (extent.1 - extent.0) * a as f64;
                let t = extent.2 + 0.5 * (extent.3 - extent.2) * b as f64;
                nodal[3 * a + b] = 2.0 * r * t.cos() + 3.0 * r * t.sin();
            }
        }
        let mut worst: f64 = 0.0;
        for &(xi, _) in &GAUSS3 {
            for &(eta, _) in &GAUSS3 {
                let p = point(extent, xi, eta);
                let gx: f64 = (0..9).map(|n| p.dx[n] * nodal[n]).sum();
                let gy: f64 = (0..9).map(|n| p.dy[n] * nodal[n]).sum();
                worst = worst.max((gx - 2.0).abs()).max((gy - 3.0).abs());
            }
        }
        worst
    }

    #[test]
    fn shape_function_derivatives_converge_to_those_of_a_linear_field() {
        // x = r cos θ is not quadratic in θ, so a linear field is interpolated, not reproduced:
        // its gradient converges with the square of the element's angular span.
        let (coarse, fine) = (gradient_error(0.15), gradient_error(0.075));
        assert!(coarse < 2e-3, "{coarse}");
        assert!(coarse / fine > 3.5, "{coarse} → {fine}");
    }

    #[test]
    fn element_matrices_are_symmetric_and_free_of_energy_for_rigid_translation() {
        let d = plane_strain(lame(110e9, 0.34).0, lame(110e9, 0.34).1);
        let k = element_matrix((0.011, 0.0115, -0.1, 0.05), &d);
        for i in 0..18 {
            for j in 0..18 {
                assert!((k[i][j] - k[j][i]).abs() <= 1e-9 * k[i][i].abs());
            }
            // Rigid translation along x: K · (1, 0, 1, 0, …) = 0.
            let fx: f64 = (0..9).map(|n| k[i][2 * n]).sum();
            assert!(fx.abs() < 1e-6 * k[i][i].abs(), "{fx}");
        }
    }

    #[test]
    fn the_sparse_factorisation_solves_the_assembled_system() {
        // A pressure-free annulus with a prescribed bonded translation: the solution satisfies
        // K u = 0 at every free node (equilibrium), checked through the internal forces.
        let mesh = AnnulusMesh::new(0.011, 0.02, &MeshOptions { first_size: 5e-4, growth: 1.3, max_angle: 0.3 });
        let (l, m) = lame(110e9, 0.34);
        let a = Annulus::new(mesh, plane_strain(l, m), true).unwrap();
        let u = a.solve(&|n| if n < a.mesh.nodes_per_ring() { [1e-6, 0.0] } else { [0.0; 2] }, &[]);
        let f = a.internal_forces(&u, 0..a.mesh.node_rings());
        let scale = f[0][0].abs();
        for (node, fi) in f.iter().enumerate().skip(a.mesh.nodes_per_ring()) {
            let ring = node / a.mesh.nodes_per_ring();
            if ring + 1 < a.mesh.node_rings() {
                assert!(fi[0].abs() < 1e-9 * scale && fi[1].abs() < 1e-9 * scale, "node {node}: {fi:?}");
            }
        }
    }
}
