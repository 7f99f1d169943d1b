//! A structured mesh of the bush annulus a ≤ r ≤ b: curved 9-node quadrilaterals in polar
//! coordinates, graded towards the bore (radially) and towards the loaded direction θ = 0
//! (circumferentially), where the contact patch and its stress field sit.

use serde::{Deserialize, Serialize};

/// How fine the mesh is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshOptions {
    /// Size of the elements at the bore and at θ = 0 \[m\].
    pub first_size: f64,
    /// Growth factor of the element sizes away from the bore and from θ = 0 (≥ 1).
    pub growth: f64,
    /// Largest angular span of an element \[rad\].
    pub max_angle: f64,
}

impl Default for MeshOptions {
    /// The converged mesh of the bush tables (the convergence study in docs/validation.md).
    fn default() -> Self {
        Self { first_size: 2e-5, growth: 1.12, max_angle: std::f64::consts::PI / 48.0 }
    }
}

impl MeshOptions {
    /// Twice as fine: half the first size, the growth's square root, half the largest angle.
    pub fn refined(self) -> Self {
        Self { first_size: 0.5 * self.first_size, growth: self.growth.sqrt(), max_angle: 0.5 * self.max_angle }
    }

    /// Problems with the options, each naming its field (under `prefix`).
    pub fn check(&self, prefix: &str, problems: &mut lash_core::Problems) {
        if !(self.first_size > 0.0 && self.first_size.is_finite()) {
            problems.push(format!("{prefix}first_size"), format!("must be > 0 m, got {}", self.first_size));
        }
        if !(self.growth >= 1.0 && self.growth <= 2.0) {
            problems.push(format!("{prefix}growth"), format!("must lie in [1, 2], got {}", self.growth));
        }
        if !(self.max_angle > 0.0 && self.max_angle <= std::f64::consts::FRAC_PI_4) {
            problems.push(format!("{prefix}max_angle"), format!("must lie in (0, π/4] rad, got {}", self.max_angle));
        }
    }
}

/// Element boundaries from `start` over `length`: sizes growing from `first` by `growth`, capped
/// at `cap`, the whole scaled to end exactly at `start + length`.
fn graded(start: f64, length: f64, first: f64, growth: f64, cap: f64) -> Vec<f64> {
    let mut sizes = Vec::new();
    let (mut h, mut total) = (first.min(cap), 0.0);
    while total + 0.5 * h < length {
        sizes.push(h);
        total += h;
        h = (h * growth).min(cap);
    }
    if sizes.is_empty() {
        sizes.push(length);
        total = length;
    }
    let scale = length / total;
    let mut bounds = vec![start];
    let mut at = start;
    for s in sizes {
        at += s * scale;
        bounds.push(at);
    }
    *bounds.last_mut().expect("one size at least") = start + length;
    bounds
}

/// The annulus mesh: element boundaries in r and θ; nodes on the polar grid of element corners
/// and mid-points (the mid-point in r and θ of each element, so the curved edges are exact arcs).
#[derive(Debug, Clone)]
pub struct AnnulusMesh {
    /// Element boundaries in r \[m\], from the bore a to the outer radius b.
    pub radii: Vec<f64>,
    /// Element boundaries in θ \[rad\], from −π to π (the same point: the ring closes).
    pub angles: Vec<f64>,
}

impl AnnulusMesh {
    /// The mesh of a ≤ r ≤ b with `options`.
    pub fn new(inner_radius: f64, outer_radius: f64, options: &MeshOptions) -> Self {
        let radii =
            graded(inner_radius, outer_radius - inner_radius, options.first_size, options.growth, f64::INFINITY);
        // From θ = 0 to π, graded at θ = 0, then mirrored.
        let half =
            graded(0.0, std::f64::consts::PI, options.first_size / inner_radius, options.growth, options.max_angle);
        let mut angles: Vec<f64> = half.iter().rev().map(|t| -t).collect();
        angles.extend_from_slice(&half[1..]);
        Self { radii, angles }
    }

    /// Elements across the wall.
    pub fn radial_elements(&self) -> usize {
        self.radii.len() - 1
    }

    /// Elements around the ring.
    pub fn angular_elements(&self) -> usize {
        self.angles.len() - 1
    }

    /// Node rings (2 per element across the wall, plus one).
    pub fn node_rings(&self) -> usize {
        2 * self.radial_elements() + 1
    }

    /// Nodes per ring (2 per element around; the ring closes on itself).
    pub fn nodes_per_ring(&self) -> usize {
        2 * self.angular_elements()
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.node_rings() * self.nodes_per_ring()
    }

    /// The node on ring `ring` (0 at the bore) at angular position `k` (taken around the ring).
    pub fn node(&self, ring: usize, k: usize) -> usize {
        ring * self.nodes_per_ring() + k % self.nodes_per_ring()
    }

    /// Polar position (r, θ) of a node.
    pub fn node_position(&self, node: usize) -> (f64, f64) {
        let (ring, k) = (node / self.nodes_per_ring(), node % self.nodes_per_ring());
        let r =
            if ring % 2 == 0 { self.radii[ring / 2] } else { 0.5 * (self.radii[ring / 2] + self.radii[ring / 2 + 1]) };
        let t = if k % 2 == 0 { self.angles[k / 2] } else { 0.5 * (self.angles[k / 2] + self.angles[k / 2 + 1]) };
        (r, t)
    }

    /// The nine nodes of element (i across the wall, j around), ordered `3 a + b` for the radial
    /// position a and the angular position b (0, 1, 2 each).
    pub fn element_nodes(&self, i: usize, j: usize) -> [usize; 9] {
        let mut nodes = [0; 9];
        for a in 0..3 {
            for b in 0..3 {
                nodes[3 * a + b] = self.node(2 * i + a, 2 * j + b);
            }
        }
        nodes
    }

    /// The element's extent: (r0, r1, θ0, θ1).
    pub fn element_extent(&self, i: usize, j: usize) -> (f64, f64, f64, f64) {
        (self.radii[i], self.radii[i + 1], self.angles[j], self.angles[j + 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mesh_covers_the_annulus_graded_towards_the_bore_and_theta_zero() {
        let o = MeshOptions::default();
        let m = AnnulusMesh::new(0.011, 0.020, &o);
        assert_eq!(m.radii[0], 0.011);
        assert_eq!(*m.radii.last().unwrap(), 0.020);
        assert!(m.radii.windows(2).all(|w| w[1] > w[0]));
        assert!((m.radii[1] - m.radii[0]) < 1.5 * o.first_size);
        assert!((m.angles[0] + std::f64::consts::PI).abs() < 1e-15);
        assert!((m.angles.last().unwrap() - std::f64::consts::PI).abs() < 1e-15);
        assert!(m.angles.windows(2).all(|w| w[1] > w[0] && w[1] - w[0] <= o.max_angle * (1.0 + 1e-9)));
        // θ = 0 is a boundary; the elements beside it are the smallest.
        let zero = m.angles.iter().position(|t| *t == 0.0).expect("θ = 0 is a boundary");
        assert!(m.angles[zero + 1] * 0.011 < 1.5 * o.first_size);
        // Every node appears in an element; the ring closes.
        let mut seen = vec![false; m.node_count()];
        for i in 0..m.radial_elements() {
            for j in 0..m.angular_elements() {
                for n in m.element_nodes(i, j) {
                    seen[n] = true;
                }
            }
        }
        assert!(seen.iter().all(|s| *s));
        assert_eq!(m.element_nodes(0, m.angular_elements() - 1)[2], m.node(0, 0));
    }
}
