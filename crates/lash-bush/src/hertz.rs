//! Hertz line contact of a pin in a bore (conforming cylinders): contact half-width, peak
//! pressure, and the subsurface stresses of the elastic half-space under the elliptical pressure
//! (McEwen's closed form on the axis of symmetry) with their von Mises maximum in plane strain.

/// Effective modulus E* of two elastic bodies: 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂.
pub fn effective_modulus(young1: f64, poisson1: f64, young2: f64, poisson2: f64) -> f64 {
    1.0 / ((1.0 - poisson1 * poisson1) / young1 + (1.0 - poisson2 * poisson2) / young2)
}

/// Effective radius R* of a pin of radius `pin` in a bore of radius `bore` > pin:
/// 1/R* = 1/R_pin − 1/R_bore.
pub fn effective_radius(pin: f64, bore: f64) -> f64 {
    1.0 / (1.0 / pin - 1.0 / bore)
}

/// The Hertz contact of a line load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineContact {
    /// Load per unit length F' [N/m].
    pub load_per_length: f64,
    /// Contact half-width b = √(4 F' R* / (π E*)) \[m\].
    pub half_width: f64,
    /// Peak pressure p₀ = 2 F' / (π b) \[Pa\].
    pub peak_pressure: f64,
}

impl LineContact {
    /// The contact of load per length `load_per_length` between bodies of effective radius and
    /// modulus `radius`, `modulus`.
    pub fn new(load_per_length: f64, radius: f64, modulus: f64) -> Self {
        let half_width = (4.0 * load_per_length * radius / (std::f64::consts::PI * modulus)).sqrt();
        Self { load_per_length, half_width, peak_pressure: 2.0 * load_per_length / (std::f64::consts::PI * half_width) }
    }

    /// The pressure at distance `s` from the centre of the patch (arc length) \[Pa\].
    pub fn pressure(&self, s: f64) -> f64 {
        let x = s / self.half_width;
        if x.abs() >= 1.0 { 0.0 } else { self.peak_pressure * (1.0 - x * x).sqrt() }
    }
}

/// Von Mises stress in the half-space on the axis of symmetry at depth ζ b, per unit peak
/// pressure, in plane strain with Poisson's ratio ν (McEwen):
/// σ_z = −p₀ / √(1 + ζ²), σ_x = −p₀ [(1 + 2ζ²)/√(1 + ζ²) − 2ζ], σ_y = ν (σ_x + σ_z), no shear.
pub fn axis_von_mises(zeta: f64, poisson: f64) -> f64 {
    let root = (1.0 + zeta * zeta).sqrt();
    let sz = -1.0 / root;
    let sx = -((1.0 + 2.0 * zeta * zeta) / root - 2.0 * zeta);
    let sy = poisson * (sx + sz);
    (0.5 * ((sx - sy).powi(2) + (sy - sz).powi(2) + (sz - sx).powi(2))).sqrt()
}

/// The largest von Mises stress under a Hertz line contact, per unit peak pressure, and its depth
/// per unit half-width (plane strain, Poisson's ratio ν): the maximum of [`axis_von_mises`] over
/// the depth, by golden-section search after a coarse scan.
pub fn max_von_mises(poisson: f64) -> (f64, f64) {
    let f = |z: f64| axis_von_mises(z, poisson);
    let (mut best, mut at) = (f(0.0), 0.0);
    for k in 1..=400 {
        let z = k as f64 * 0.01;
        if f(z) > best {
            best = f(z);
            at = z;
        }
    }
    let (mut lo, mut hi) = ((at - 0.01).max(0.0), at + 0.01);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..100 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if f(a) > f(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let z = 0.5 * (lo + hi);
    (f(z), z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pressure_carries_the_load() {
        let c = LineContact::new(1.5e5, 0.11, 8e10);
        // ∫ p ds = π b p₀ / 2 = F'.
        let n = 200_000;
        let h = 2.0 * c.half_width / n as f64;
        let total: f64 = (0..n).map(|k| c.pressure(-c.half_width + (k as f64 + 0.5) * h) * h).sum();
        assert!((total / c.load_per_length - 1.0).abs() < 1e-6, "{total}");
    }

    #[test]
    fn the_half_space_maximum_is_the_known_one() {
        // Textbook values for ν = 0.3 (plane strain): σ_vm,max ≈ 0.557 p₀ at z ≈ 0.70 b.
        let (s, z) = max_von_mises(0.3);
        assert!((s - 0.557).abs() < 2e-3 && (z - 0.70).abs() < 0.02, "{s} at {z}");
        // Surface: σ_x = σ_z = −p₀, σ_y = −2ν p₀: von Mises (1 − 2ν) p₀.
        assert!((axis_von_mises(0.0, 0.3) - 0.4).abs() < 1e-12);
    }
}
