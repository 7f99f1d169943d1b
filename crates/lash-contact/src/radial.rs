//! The planar revolute clearance joint's kinematics and loads, written once for any lane width
//! ([`Real`]): the single run's joint ([`crate::ClearanceJoint`]) evaluates them on `f64`, the
//! micro step's lanes on eight runs at once, from this one source (docs/theory.md §2).

use lash_core::lanes::{Mask, Real};

/// The radii of a planar revolute clearance joint.
#[derive(Clone, Copy, Debug)]
pub struct Radii<R> {
    /// Radial clearance c = R_B − R_J \[m\].
    pub clearance: R,
    /// Journal radius R_J \[m\].
    pub journal: R,
    /// Bearing radius R_B \[m\].
    pub bearing: R,
}

/// Where the journal is in its bearing and how it moves there.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics<R> {
    /// |e| \[m\].
    pub norm: R,
    /// Unit normal n = e/|e| (x̂ at e = 0).
    pub normal: [R; 2],
    /// Penetration δ = |e| − c \[m\].
    pub penetration: R,
    /// δ̇ = ė·n \[m/s\] (> 0 approaching the bore).
    pub penetration_rate: R,
    /// Slip v_t = ė·t + ω_J R_J − ω_B R_B, t = (−n_y, n_x) \[m/s\].
    pub slip: R,
}

impl<R: Real> Radii<R> {
    /// |e| and the penetration δ = |e| − c at the eccentricity `e`.
    #[inline(always)]
    pub fn geometry(&self, e: [R; 2]) -> (R, R) {
        let norm = (e[0] * e[0] + e[1] * e[1]).sqrt();
        (norm, norm - self.clearance)
    }

    /// The kinematics at (e, ė) with the bodies' angular velocities; `geometry` is
    /// [`Radii::geometry`] at `e`.
    #[inline(always)]
    pub fn kinematics(
        &self,
        e: [R; 2],
        e_dot: [R; 2],
        (norm, penetration): (R, R),
        omega_journal: R,
        omega_bearing: R,
    ) -> Kinematics<R> {
        let (zero, one) = (R::splat(0.0), R::splat(1.0));
        let positive = norm.simd_gt(zero);
        // One division for both components: the lanes are bound by the divider.
        let inverse = one / norm;
        let n = [R::select(positive, e[0] * inverse, one), R::select(positive, e[1] * inverse, zero)];
        let t = [-n[1], n[0]];
        Kinematics {
            norm,
            normal: n,
            penetration,
            penetration_rate: e_dot[0] * n[0] + e_dot[1] * n[1],
            slip: (e_dot[0] * t[0] + e_dot[1] * t[1]) + omega_journal * self.journal - omega_bearing * self.bearing,
        }
    }
}

impl<R: Real> Kinematics<R> {
    /// The tangent t = (−n_y, n_x).
    #[inline(always)]
    pub fn tangent(&self) -> [R; 2] {
        [-self.normal[1], self.normal[0]]
    }

    /// The friction force F_T = μ(v_t) F_N where the normal force F_N > 0 (0 elsewhere; μ is asked
    /// for only where some lane presses) and the force on the journal f_J = −F_N n − F_T t.
    #[inline(always)]
    pub fn loads(&self, normal_force: R, coefficient: impl FnOnce(R) -> R) -> (R, [R; 2]) {
        let zero = R::splat(0.0);
        let pressing = normal_force.simd_gt(zero);
        let friction =
            if pressing.any() { R::select(pressing, coefficient(self.slip) * normal_force, zero) } else { zero };
        let (n, t) = (self.normal, self.tangent());
        (friction, [-(n[0] * normal_force) - t[0] * friction, -(n[1] * normal_force) - t[1] * friction])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_core::lanes::{F64x8, LANES};

    #[test]
    fn kinematics_and_loads_follow_their_definitions() {
        let radii = Radii { clearance: 0.5e-3, journal: 9.5e-3, bearing: 10e-3 };
        let e = [3e-4, -4e-4];
        let k = radii.kinematics(e, [2.0, 1.0], radii.geometry(e), 10.0, -4.0);
        assert!((k.norm - 5e-4).abs() < 1e-18 && k.penetration.abs() < 1e-18);
        assert!((k.normal[0] - 0.6).abs() < 1e-15 && (k.normal[1] + 0.8).abs() < 1e-15);
        assert!((k.penetration_rate - (2.0 * 0.6 - 0.8)).abs() < 1e-15);
        // t = (0.8, 0.6): ė·t = 2.2, plus 10 · 9.5e-3 + 4 · 10e-3.
        assert!((k.slip - (2.2 + 0.095 + 0.04)).abs() < 1e-14);
        let (friction, f) = k.loads(100.0, |v| 0.1 * v.signum());
        assert_eq!(friction, 10.0);
        assert!((f[0] - (-60.0 - 8.0)).abs() < 1e-12 && (f[1] - (80.0 - 6.0)).abs() < 1e-12);
        // No normal force, no friction, and the coefficient is not asked for.
        assert_eq!(k.loads(0.0, |_| -> f64 { panic!("asked in free flight") }), (0.0, [0.0, 0.0]));
        // At e = 0 the normal is x̂.
        let centred = radii.kinematics([0.0; 2], [1.0, 0.0], radii.geometry([0.0; 2]), 0.0, 0.0);
        assert_eq!(centred.normal, [1.0, 0.0]);
    }

    #[test]
    fn lanes_give_each_lane_the_scalar_bits() {
        let radii = Radii { clearance: 1e-4, journal: 0.01, bearing: 0.0101 };
        let ex: [f64; LANES] = std::array::from_fn(|l| (l as f64 - 3.0) * 3.7e-5);
        let ey: [f64; LANES] = std::array::from_fn(|l| (l as f64 * 1.3).sin() * 1e-4);
        let u: [f64; LANES] = std::array::from_fn(|l| (l as f64 * 0.7).cos());
        let wide = Radii { clearance: F64x8::splat(1e-4), journal: F64x8::splat(0.01), bearing: F64x8::splat(0.0101) };
        let (e, ed) = ([F64x8(ex), F64x8(ey)], [F64x8(u), F64x8::splat(-0.3)]);
        let k = wide.kinematics(e, ed, wide.geometry(e), F64x8::splat(5.0), F64x8::splat(-1.0));
        let (friction, f) = k.loads(k.penetration.max(F64x8::ZERO) * F64x8::splat(1e9), |v| v * F64x8::splat(0.1));
        for l in 0..LANES {
            let e1 = [ex[l], ey[l]];
            let one = radii.kinematics(e1, [u[l], -0.3], radii.geometry(e1), 5.0, -1.0);
            let (fr, f1) = one.loads(one.penetration.max(0.0) * 1e9, |v| v * 0.1);
            assert_eq!(one.slip.to_bits(), k.slip[l].to_bits());
            assert_eq!(fr.to_bits(), friction[l].to_bits());
            assert_eq!([f1[0].to_bits(), f1[1].to_bits()], [f[0][l].to_bits(), f[1][l].to_bits()]);
        }
    }
}
