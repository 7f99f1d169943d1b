//! The arithmetic of the micro step written once for every width: the classical RK4 step of the
//! interface's second-order equation `ẅ = a(t, w, ẇ)` ([`rk4`], [`weighted`]), the 2 × 2
//! effective mass of one planar joint ([`planar_mass`], [`planar_solve`], [`planar_load`]) and
//! the mobility form's terms of the spatial joints ([`linear_at`], [`add_columns`]).
//!
//! A single run ([`crate::model::InterfaceModel::rk4_step`]: nalgebra vectors of `f64`) and the
//! sweep's lanes ([`crate::lanes`]: eight runs in one [`lash_core::lane::F64x8`] per number) call
//! these same functions, so every lane computes the operations a single run computes, in the
//! same order, and gets its bits. What differs between the two callers is only what is not
//! arithmetic: where the numbers are kept, which step ends are reused, and how the rare,
//! sequential events (a contact opening or closing) are handled.

use lash_core::lane::Real;
use std::ops::{Add, Mul};

/// A state vector of the step (w or ẇ; the impulses): added, and scaled by a step fraction.
pub trait StepVector: Copy + Add<Output = Self> + Mul<f64, Output = Self> {}

impl<T: Copy + Add<Output = T> + Mul<f64, Output = T>> StepVector for T {}

/// The evaluations of a step after its first, in their order: two at the middle of the step, one
/// at its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rk4Stage {
    /// The second stage, at t + h/2 along the first stage's rates.
    Second,
    /// The third stage, at t + h/2 along the second stage's rates.
    Third,
    /// The fourth stage, at t + h along the third stage's rates.
    Fourth,
}

impl Rk4Stage {
    /// The stage's offset from the step's start as a fraction of h, and the index of the stage
    /// whose rates lead to it (0 for the first stage).
    #[inline(always)]
    pub fn fraction(self) -> f64 {
        match self {
            Self::Second | Self::Third => 0.5,
            Self::Fourth => 1.0,
        }
    }

    /// The stage's index among the four (1, 2, 3; the first stage is 0).
    #[inline(always)]
    pub fn index(self) -> usize {
        match self {
            Self::Second => 1,
            Self::Third => 2,
            Self::Fourth => 3,
        }
    }
}

/// One RK4 step of `ẅ = a(t, w, ẇ)` from (w₀, ẇ₀) over `h`: the state at its end and the loads of
/// the four stages (for the impulses, [`weighted`]).
#[derive(Debug, Clone, Copy)]
pub struct Rk4End<V, L> {
    /// w at the step's end.
    pub eccentricity: V,
    /// ẇ at the step's end.
    pub eccentricity_rate: V,
    /// The loads of the four stages.
    pub loads: [L; 4],
}

/// What a step evaluates at its second, third and fourth stage: ẅ and the loads at (w, ẇ) at the
/// stage's instant. (A trait rather than a closure: its method is inlined into the step, which a
/// closure called three times was not — the lanes' step then ran at half speed in code compiled
/// for the baseline instruction set.)
pub trait StageRates<V, L> {
    /// ẅ and the loads at (w, ẇ) at `stage`'s instant.
    fn rate(&mut self, stage: Rk4Stage, e: V, v: V) -> (V, L);
}

/// The classical RK4 step of `ẅ = a(t, w, ẇ)`: `first` is the first stage's (ẅ, loads) at (w₀, ẇ₀)
/// (the caller may reuse the last step's end), `rates` evaluates the others.
#[inline(always)]
pub fn rk4<V: StepVector, L: Copy>(
    h: f64,
    (e0, v0): (V, V),
    first: (V, L),
    rates: &mut impl StageRates<V, L>,
) -> Rk4End<V, L> {
    let (k1v, l1) = first;
    let k1e = v0;
    let k2e = v0 + k1v * (0.5 * h);
    let (k2v, l2) = rates.rate(Rk4Stage::Second, e0 + k1e * (0.5 * h), k2e);
    let k3e = v0 + k2v * (0.5 * h);
    let (k3v, l3) = rates.rate(Rk4Stage::Third, e0 + k2e * (0.5 * h), k3e);
    let k4e = v0 + k3v * h;
    let (k4v, l4) = rates.rate(Rk4Stage::Fourth, e0 + k3e * h, k4e);
    Rk4End {
        eccentricity: weighted(e0, [k1e, k2e, k3e, k4e], h),
        eccentricity_rate: weighted(v0, [k1v, k2v, k3v, k4v], h),
        loads: [l1, l2, l3, l4],
    }
}

/// `y₀ + (k₁ + 2 (k₂ + k₃) + k₄) h / 6`: RK4's end from its four stage rates (the state, and the
/// impulses from the stages' loads).
#[inline(always)]
pub fn weighted<V: StepVector>(y0: V, [k1, k2, k3, k4]: [V; 4], h: f64) -> V {
    y0 + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0)
}

/// One planar joint's effective mass at `dt` past its node, `M̃ + Ṁ dt` (row-major: m₁₁, m₁₂,
/// m₂₁, m₂₂), and its [`planar_factor`].
#[inline(always)]
pub fn planar_mass<R: Real>(mass: [R; 4], rate: [R; 4], dt: R) -> ([R; 4], R) {
    let m = [mass[0] + rate[0] * dt, mass[1] + rate[1] * dt, mass[2] + rate[2] * dt, mass[3] + rate[3] * dt];
    let reciprocal_determinant = planar_factor(&m);
    (m, reciprocal_determinant)
}

/// The reciprocal of a 2 × 2 matrix's determinant (row-major), all that Cramer's rule needs
/// besides the matrix: one division per instant.
#[inline(always)]
pub fn planar_factor<R: Real>(m: &[R; 4]) -> R {
    R::splat(1.0) / (m[0] * m[3] - m[1] * m[2])
}

/// `M̃⁻¹ r` for a [`planar_mass`] (the matrix and its determinant's reciprocal).
#[inline(always)]
pub fn planar_solve<R: Real>((m, reciprocal_determinant): (&[R; 4], R), [r0, r1]: [R; 2]) -> [R; 2] {
    [(m[3] * r0 - m[1] * r1) * reciprocal_determinant, (m[0] * r1 - m[2] * r0) * reciprocal_determinant]
}

/// The right-hand side `f̃ + ḟ dt + f_c + (H + Ḣ dt) F_T` of one planar joint: the friction term
/// only where the friction load F_T is not zero. `force` and `map` are (value, rate) pairs of f̃
/// and of H's column. One run skips the term in free flight (without the test its micro step
/// measured 7 % slower); eight lanes select it (with the test, 9 % slower).
#[inline(always)]
pub fn planar_load<R: Real>(
    (force, force_rate): ([R; 2], [R; 2]),
    dt: R,
    contact: [R; 2],
    (map, map_rate): ([R; 2], [R; 2]),
    friction: R,
) -> [R; 2] {
    let r = [force[0] + force_rate[0] * dt + contact[0], force[1] + force_rate[1] * dt + contact[1]];
    let acting = friction.simd_ne(R::splat(0.0));
    if R::WIDTH == 1 && !R::any(acting) {
        return r;
    }
    [
        R::select(acting, r[0] + (map[0] + map_rate[0] * dt) * friction, r[0]),
        R::select(acting, r[1] + (map[1] + map_rate[1] * dt) * friction, r[1]),
    ]
}

/// Terms linear across the communication step, taken from their node to `dt` past it, entry by
/// entry: v ← v + v̇ dt (the mobility form's W, G and a_free, entries of any layout).
#[inline(always)]
pub fn linear_at<R: Real>(value: &mut [R], rate: &[R], dt: R) {
    for (v, &r) in value.iter_mut().zip(rate) {
        *v = *v + r * dt;
    }
}

/// Adds the columns of a column-major matrix of `a.len()` rows, each times its load, to `a`, in
/// column order: `a += C v` as the mobility form forms ẅ = a_free + W f_c + G L (a load of a joint
/// in free flight is zero and adds nothing: no test).
#[inline(always)]
pub fn add_columns<R: Real>(a: &mut [R], columns: &[R], values: &[R]) {
    let n = a.len();
    for (column, &v) in columns.chunks_exact(n).zip(values) {
        for (ai, &ci) in a.iter_mut().zip(column) {
            *ai = *ai + ci * v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    /// RK4 on ẅ = −w (a harmonic oscillator) is fourth-order: the error after one period shrinks
    /// 16-fold when the step halves, against cos t.
    #[test]
    fn the_step_is_fourth_order_on_an_oscillator() {
        struct Spring;
        impl StageRates<Vector2<f64>, ()> for Spring {
            fn rate(&mut self, _: Rk4Stage, e: Vector2<f64>, _: Vector2<f64>) -> (Vector2<f64>, ()) {
                (-e, ())
            }
        }
        let error = |n: usize| {
            let h = std::f64::consts::TAU / n as f64;
            let (mut e, mut v) = (Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0));
            for _ in 0..n {
                let end = rk4(h, (e, v), (-e, ()), &mut Spring);
                (e, v) = (end.eccentricity, end.eccentricity_rate);
            }
            ((e - Vector2::new(1.0, 0.0)).norm(), (v - Vector2::new(0.0, 1.0)).norm())
        };
        let (coarse, fine) = (error(40), error(80));
        for (c, f) in [(coarse.0, fine.0), (coarse.1, fine.1)] {
            let ratio = c / f;
            assert!((14.0..18.0).contains(&ratio), "error ratio {ratio}");
        }
    }

    /// The stages are evaluated at t + h/2, t + h/2 and t + h along the rates of the stage before.
    #[test]
    fn the_stages_follow_the_previous_rates() {
        struct Seen(Vec<(Rk4Stage, f64, f64)>);
        impl StageRates<f64, usize> for Seen {
            fn rate(&mut self, stage: Rk4Stage, e: f64, v: f64) -> (f64, usize) {
                self.0.push((stage, e, v));
                (10.0 * stage.index() as f64, stage.index())
            }
        }
        let h = 0.1;
        let mut seen = Seen(Vec::new());
        rk4(h, (0.0, 2.0), (1.0, 0), &mut seen);
        let seen = seen.0;
        assert_eq!(seen[0], (Rk4Stage::Second, 0.5 * h * 2.0, 2.0 + 0.5 * h * 1.0));
        assert_eq!(seen[1], (Rk4Stage::Third, 0.5 * h * (2.0 + 0.5 * h), 2.0 + 0.5 * h * 10.0));
        assert_eq!(seen[2], (Rk4Stage::Fourth, h * (2.0 + 0.5 * h * 10.0), 2.0 + h * 20.0));
        assert_eq!(seen.iter().map(|s| s.0.fraction()).collect::<Vec<_>>(), [0.5, 0.5, 1.0]);
    }

    /// The 2 × 2 solve is nalgebra's LU solve of the interpolated matrix, to rounding.
    #[test]
    fn the_planar_solve_inverts_the_interpolated_mass() {
        let (mass, rate, dt) = ([0.33, 0.01, 0.02, 0.21], [3.0, -1.0, 0.5, 2.0], 4e-4);
        let (m, inv) = planar_mass(mass, rate, dt);
        let x = planar_solve((&m, inv), [-900.0, 300.0]);
        let full =
            Matrix2::new(mass[0], mass[1], mass[2], mass[3]) + Matrix2::new(rate[0], rate[1], rate[2], rate[3]) * dt;
        let lu = full.lu().solve(&Vector2::new(-900.0, 300.0)).expect("regular");
        assert!((x[0] - lu[0]).abs() < 1e-12 * lu.norm() && (x[1] - lu[1]).abs() < 1e-12 * lu.norm());
    }

    /// The friction term enters only where the friction load acts, lane by lane.
    #[test]
    fn the_friction_term_acts_where_the_load_does() {
        use lash_core::lane::F64x8;
        let terms = (([1.0, 1.0], [2.0, 2.0]), 0.5, [3.0, 3.0], ([4.0, 4.0], [6.0, 6.0]));
        let (force, dt, contact, map) = terms;
        assert_eq!(planar_load(force, dt, contact, map, 0.0), [5.0, 5.0]);
        assert_eq!(planar_load(force, dt, contact, map, 2.0), [5.0 + 7.0 * 2.0; 2]);
        let s = F64x8::splat;
        let loads = F64x8::from([0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0]);
        let lanes = planar_load(([s(1.0); 2], [s(2.0); 2]), s(0.5), [s(3.0); 2], ([s(4.0); 2], [s(6.0); 2]), loads);
        let expected: [f64; 8] = std::array::from_fn(|l| if l == 1 || l == 3 || l == 7 { 19.0 } else { 5.0 });
        assert_eq!(<[f64; 8]>::from(lanes[0]), expected);
        assert_eq!(<[f64; 8]>::from(lanes[1]), expected);
    }
}
