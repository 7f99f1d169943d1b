//! Normal contact force laws (F_N ≥ 0 always).

use lash_core::Problems;
use lash_core::lane::Real;
use serde::{Deserialize, Serialize};

/// ADAMS STEP: a cubic from (x0, h0) to (x1, h1) with zero slope at both ends, constant outside;
/// for one run or several side by side: the ends are branches where every lane is beyond the
/// same end (for one run, the scalar `if`s), selections otherwise.
#[inline(always)]
pub fn step_of<R: Real>(x: R, x0: R, h0: R, x1: R, h1: R) -> R {
    let (below, above) = (x.simd_le(x0), x.simd_ge(x1));
    if R::all(below) {
        return h0;
    }
    if R::all(above) {
        return h1;
    }
    let d = (x - x0) / (x1 - x0);
    let cubic = h0 + (h1 - h0) * d * d * (R::splat(3.0) - R::splat(2.0) * d);
    R::select(below, h0, R::select(above, h1, cubic))
}

/// An isotropic elastic material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E \[Pa\].
    pub young_modulus: f64,
    /// Poisson's ratio ν [-].
    pub poisson_ratio: f64,
}

impl Material {
    /// Structural steel as in the benchmarks: E = 207 GPa, ν = 0.3.
    pub const STEEL: Material = Material { young_modulus: 207e9, poisson_ratio: 0.3 };

    /// Problems of the material's numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        p.positive("young_modulus", self.young_modulus);
        if !(self.poisson_ratio.is_finite() && self.poisson_ratio > -1.0 && self.poisson_ratio < 0.5) {
            p.push("poisson_ratio", format!("must lie in (-1, 0.5), got {}", self.poisson_ratio));
        }
        p
    }
}

/// Effective modulus E* with 1/E* = (1−ν_J²)/E_J + (1−ν_B²)/E_B \[Pa\].
pub fn effective_modulus(journal: &Material, bearing: &Material) -> f64 {
    1.0 / ((1.0 - journal.poisson_ratio.powi(2)) / journal.young_modulus
        + (1.0 - bearing.poisson_ratio.powi(2)) / bearing.young_modulus)
}

/// Hertz stiffness of a journal inside a bearing (sphere approximation):
/// K = (4/3) E* √R*, R* = R_J R_B / (R_B − R_J) [N/m^1.5].
pub fn hertz_stiffness(journal: &Material, bearing: &Material, journal_radius: f64, bearing_radius: f64) -> f64 {
    let r_star = journal_radius * bearing_radius / (bearing_radius - journal_radius);
    4.0 / 3.0 * effective_modulus(journal, bearing) * r_star.sqrt()
}

fn default_exponent() -> f64 {
    1.5
}
fn default_floor() -> f64 {
    1e-4
}

/// A contact law as written in a scenario file (`law = "lankarani_nikravesh"`, …). Stiffness left
/// out means: Hertz stiffness from the materials and radii.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactLaw {
    /// F = K δⁿ, no dissipation.
    Hertz {
        /// K [N/m^n]; default from materials.
        stiffness: Option<f64>,
        /// n [-].
        #[serde(default = "default_exponent")]
        exponent: f64,
    },
    /// F = K δ + D δ̇.
    KelvinVoigt {
        /// K [N/m] (required: a linear stiffness does not follow from Hertz theory).
        stiffness: f64,
        /// D [N s/m].
        damping: f64,
    },
    /// F = K δⁿ (1 + χ δ̇/δ̇⁻), χ = 3(1−c_e)/2.
    HuntCrossley(HysteresisParams),
    /// χ = 3(1−c_e²)/4.
    LankaraniNikravesh(HysteresisParams),
    /// χ = (1−c_e²)/c_e.
    Gonthier(HysteresisParams),
    /// χ = 8(1−c_e)/(5 c_e).
    Flores(HysteresisParams),
    /// χ = 3(1−c_e)/(2 c_e).
    HuGuo(HysteresisParams),
    /// ADAMS IMPACT: F = K δⁿ + STEP(δ, 0, 0, d_max, C_max) δ̇.
    AdamsImpact {
        /// K [N/m^n]; default from materials.
        stiffness: Option<f64>,
        /// n [-].
        #[serde(default = "default_exponent")]
        exponent: f64,
        /// C_max [N s/m].
        max_damping: f64,
        /// d_max \[m\], penetration at which full damping is reached.
        damping_depth: f64,
    },
    /// Cylindrical line contact (Liu et al.): F = (π/2) E* L δ √(δ / (2(c + δ))), optionally times
    /// the Lankarani–Nikravesh hysteresis factor (1 + χ δ̇/δ̇⁻).
    Liu {
        /// Axial contact length L \[m\].
        length: f64,
        /// Restitution for the hysteresis factor; none means elastic.
        restitution: Option<f64>,
        /// Floor of the onset velocity [m/s].
        #[serde(default = "default_floor")]
        velocity_floor: f64,
    },
}

/// Parameters of the hysteresis-damped family.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HysteresisParams {
    /// Nominal coefficient of restitution c_e, in (0, 1].
    pub restitution: f64,
    /// K [N/m^n]; default from materials.
    pub stiffness: Option<f64>,
    /// n [-].
    #[serde(default = "default_exponent")]
    pub exponent: f64,
    /// Floor of the onset (approach) velocity δ̇⁻ [m/s].
    #[serde(default = "default_floor")]
    pub velocity_floor: f64,
}

/// A contact law resolved to numbers, ready to evaluate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NormalForce {
    /// K δⁿ.
    Power {
        /// K.
        stiffness: f64,
        /// n.
        exponent: f64,
    },
    /// K δ + D δ̇.
    KelvinVoigt {
        /// K.
        stiffness: f64,
        /// D.
        damping: f64,
    },
    /// K δⁿ (1 + χ δ̇/max(δ̇⁻, floor)).
    Hysteresis {
        /// K.
        stiffness: f64,
        /// n.
        exponent: f64,
        /// χ.
        chi: f64,
        /// Onset velocity floor.
        floor: f64,
    },
    /// K δⁿ + STEP(δ, 0, 0, d_max, C_max) δ̇.
    AdamsImpact {
        /// K.
        stiffness: f64,
        /// n.
        exponent: f64,
        /// C_max.
        max_damping: f64,
        /// d_max.
        damping_depth: f64,
    },
    /// (π/2) E* L δ √(δ/(2(c+δ))) (1 + χ δ̇/max(δ̇⁻, floor)).
    Liu {
        /// (π/2) E* L.
        factor: f64,
        /// Radial clearance c.
        clearance: f64,
        /// χ (0 for elastic).
        chi: f64,
        /// Onset velocity floor.
        floor: f64,
    },
}

/// 1 / max(δ̇⁻, floor): the reciprocal of the onset velocity the hysteresis laws divide by.
#[inline(always)]
pub fn onset_reciprocal<R: Real>(onset: R, floor: R) -> R {
    R::splat(1.0) / onset.max(floor)
}

/// The hysteresis laws' force K δⁿ (1 + χ δ̇ / δ̇⁻) from `power` = δⁿ and the reciprocal of the
/// onset velocity, unclipped, for one run or several side by side.
#[inline(always)]
pub fn hysteresis_force<R: Real>(stiffness: R, power: R, chi: R, delta_dot: R, reciprocal: R) -> R {
    stiffness * power * (R::splat(1.0) + chi * delta_dot * reciprocal)
}

/// δ^1.5 as every law here takes it (δ √δ: one square root, no `powf`).
#[inline(always)]
pub fn three_halves<R: Real>(delta: R) -> R {
    delta * delta.sqrt()
}

/// δⁿ as every law here takes it: δ √δ for n = 1.5, δ for n = 1, `powf` otherwise (one exponent
/// for every lane).
#[inline(always)]
pub fn power_of<R: Real>(delta: R, n: f64) -> R {
    if n == 1.5 {
        three_halves(delta)
    } else if n == 1.0 {
        delta
    } else {
        delta.powf(n)
    }
}

/// K δⁿ (power law), unclipped.
#[inline(always)]
pub fn power_force<R: Real>(stiffness: R, exponent: f64, delta: R) -> R {
    stiffness * power_of(delta, exponent)
}

/// K δ + D δ̇ (Kelvin–Voigt), unclipped.
#[inline(always)]
pub fn kelvin_voigt_force<R: Real>(stiffness: R, damping: R, delta: R, delta_dot: R) -> R {
    stiffness * delta + damping * delta_dot
}

/// K δⁿ + STEP(δ, 0, 0, d_max, C_max) δ̇ (ADAMS IMPACT), unclipped.
#[inline(always)]
pub fn adams_impact_force<R: Real>(
    (stiffness, exponent, max_damping, damping_depth): (R, f64, R, R),
    delta: R,
    delta_dot: R,
) -> R {
    let zero = R::splat(0.0);
    stiffness * power_of(delta, exponent) + step_of(delta, zero, zero, damping_depth, max_damping) * delta_dot
}

/// (π/2) E* L δ √(δ/(2(c+δ))) (1 + χ δ̇/max(δ̇⁻, floor)) (Liu), unclipped.
#[inline(always)]
pub fn liu_force<R: Real>((factor, clearance, chi, floor): (R, R, R, R), delta: R, delta_dot: R, onset: R) -> R {
    let one = R::splat(1.0);
    factor * delta * (delta / (R::splat(2.0) * (clearance + delta))).sqrt() * (one + chi * delta_dot / onset.max(floor))
}

/// The kind of a normal force law as the lanes of a group share it (with the exponent, which
/// picks how δⁿ is formed); the numbers are per lane ([`LaneLaw::of`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaneLaw {
    /// K δⁿ: numbers (K).
    Power(f64),
    /// K δ + D δ̇: numbers (K, D).
    KelvinVoigt,
    /// K δⁿ (1 + χ δ̇/max(δ̇⁻, floor)): numbers (K, χ, floor).
    Hysteresis(f64),
    /// ADAMS IMPACT: numbers (K, C_max, d_max).
    AdamsImpact(f64),
    /// Liu: numbers (factor, c, χ, floor).
    Liu,
}

impl LaneLaw {
    /// The kind of `law` and its numbers (unused ones zero).
    pub fn of(law: &NormalForce) -> (Self, [f64; 4]) {
        match *law {
            NormalForce::Power { stiffness, exponent } => (LaneLaw::Power(exponent), [stiffness, 0.0, 0.0, 0.0]),
            NormalForce::KelvinVoigt { stiffness, damping } => (LaneLaw::KelvinVoigt, [stiffness, damping, 0.0, 0.0]),
            NormalForce::Hysteresis { stiffness, exponent, chi, floor } => {
                (LaneLaw::Hysteresis(exponent), [stiffness, chi, floor, 0.0])
            }
            NormalForce::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => {
                (LaneLaw::AdamsImpact(exponent), [stiffness, max_damping, damping_depth, 0.0])
            }
            NormalForce::Liu { factor, clearance, chi, floor } => (LaneLaw::Liu, [factor, clearance, chi, floor]),
        }
    }

    /// The onset velocity's floor among the numbers (where the law has one; else 0).
    pub fn floor(&self, numbers: &[f64; 4]) -> f64 {
        match self {
            LaneLaw::Hysteresis(_) => numbers[2],
            LaneLaw::Liu => numbers[3],
            _ => 0.0,
        }
    }

    /// The force of this kind with the numbers `p` at (δ, δ̇) — the onset velocity δ̇⁻ as `onset`
    /// and as `reciprocal` = 1 / max(δ̇⁻, floor) (the hysteresis laws multiply by it, Liu's law
    /// divides by max(δ̇⁻, floor)) —, unclipped: what [`NormalForce::force`] computes before its
    /// clip, for one run or several side by side.
    #[inline(always)]
    pub fn force<R: Real>(&self, p: &[R; 4], (delta, delta_dot): (R, R), onset: R, reciprocal: R) -> R {
        match *self {
            LaneLaw::Power(n) => power_force(p[0], n, delta),
            LaneLaw::KelvinVoigt => kelvin_voigt_force(p[0], p[1], delta, delta_dot),
            LaneLaw::Hysteresis(n) => hysteresis_force(p[0], power_of(delta, n), p[1], delta_dot, reciprocal),
            LaneLaw::AdamsImpact(n) => adams_impact_force((p[0], n, p[1], p[2]), delta, delta_dot),
            LaneLaw::Liu => liu_force((p[0], p[1], p[2], p[3]), delta, delta_dot, onset),
        }
    }
}

impl NormalForce {
    /// Normal force for penetration `delta` > 0, rate `delta_dot` (> 0 approaching) and onset
    /// velocity `onset` (the δ̇ captured when this contact began). Clipped at 0.
    #[inline(always)]
    pub fn force(&self, delta: f64, delta_dot: f64, onset: f64) -> f64 {
        if delta <= 0.0 {
            return 0.0;
        }
        // (Each law's arithmetic is one function over `Real`, which [`LaneLaw::force`] calls for
        // the lanes.)
        let f = match *self {
            NormalForce::Power { stiffness, exponent } => power_force(stiffness, exponent, delta),
            NormalForce::KelvinVoigt { stiffness, damping } => kelvin_voigt_force(stiffness, damping, delta, delta_dot),
            NormalForce::Hysteresis { stiffness, exponent, chi, floor } => {
                // (χ δ̇ times the reciprocal of the onset velocity: a contact's reciprocal is one
                // number for all its steps, which the micro step's lanes form once.)
                hysteresis_force(stiffness, power_of(delta, exponent), chi, delta_dot, onset_reciprocal(onset, floor))
            }
            NormalForce::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => {
                adams_impact_force((stiffness, exponent, max_damping, damping_depth), delta, delta_dot)
            }
            NormalForce::Liu { factor, clearance, chi, floor } => {
                liu_force((factor, clearance, chi, floor), delta, delta_dot, onset)
            }
        };
        f.max(0.0)
    }
}

impl NormalForce {
    /// The force and its slope ∂F/∂δ at (δ, δ̇) (both 0 where the force is clipped to 0): the
    /// force as [`NormalForce::force`] gives it, the slope differentiated from its formulas.
    #[inline(always)]
    pub fn force_and_slope(&self, delta: f64, delta_dot: f64, onset: f64) -> (f64, f64) {
        let f = self.force(delta, delta_dot, onset);
        if f <= 0.0 {
            return (0.0, 0.0);
        }
        let slope = match *self {
            NormalForce::Power { exponent, .. } | NormalForce::Hysteresis { exponent, .. } => exponent * f / delta,
            NormalForce::KelvinVoigt { stiffness, .. } => stiffness,
            NormalForce::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => {
                // d/dδ of K δⁿ and of the STEP's cubic blend (flat beyond d_max).
                let d = delta / damping_depth;
                let blend = if d >= 1.0 { 0.0 } else { max_damping * 6.0 * d * (1.0 - d) / damping_depth };
                exponent * (stiffness * power_of(delta, exponent)) / delta + blend * delta_dot
            }
            NormalForce::Liu { clearance, .. } => f * (1.5 / delta - 0.5 / (clearance + delta)),
        };
        (f, slope)
    }

    /// The law split as F = max(0, P + D δ̇) at penetration `delta` > 0: its elastic part P ≥ 0 and
    /// the coefficient D ≥ 0 of the rate (every law here is affine in δ̇); (0, 0) for δ ≤ 0.
    #[inline]
    pub fn elastic_and_damping(&self, delta: f64, onset: f64) -> (f64, f64) {
        if delta <= 0.0 {
            return (0.0, 0.0);
        }
        match *self {
            NormalForce::Power { stiffness, exponent } => (stiffness * power_of(delta, exponent), 0.0),
            NormalForce::KelvinVoigt { stiffness, damping } => (stiffness * delta, damping),
            NormalForce::Hysteresis { stiffness, exponent, chi, floor } => {
                let p = stiffness * power_of(delta, exponent);
                (p, p * chi / onset.max(floor))
            }
            NormalForce::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => {
                (stiffness * power_of(delta, exponent), step_of(delta, 0.0, 0.0, damping_depth, max_damping))
            }
            NormalForce::Liu { factor, clearance, chi, floor } => {
                let p = factor * delta * (delta / (2.0 * (clearance + delta))).sqrt();
                (p, p * chi / onset.max(floor))
            }
        }
    }

    /// The normal force of this contact in series with a Kelvin–Voigt bush (stiffness
    /// `bush_stiffness` k_b [N/m], damping `bush_damping` c_b > 0 [N s/m], both massless) whose
    /// deflection along the normal `deflection` s \[m\] is a state: the contact indents by
    /// δ_c = δ − s at the rate δ̇_c = δ̇ − ṡ, and the bush carries what the contact carries,
    /// k_b s + c_b ṡ = F(δ_c, δ̇_c). With F = P + D δ̇_c (see
    /// [`NormalForce::elastic_and_damping`]) the balance is linear in ṡ:
    /// ṡ = (P + D δ̇ − k_b s) / (c_b + D). Where that would leave F < 0 (the law clips at 0), and
    /// wherever δ_c ≤ 0, the contact carries nothing and the bush relaxes, ṡ = −k_b s / c_b.
    /// Returns (F, ṡ). As c_b → 0 the bush follows its load quasi-statically, which is
    /// [`NormalForce::force_in_series`].
    #[inline]
    pub fn force_in_series_damped(
        &self,
        delta: f64,
        delta_dot: f64,
        onset: f64,
        deflection: f64,
        bush_stiffness: f64,
        bush_damping: f64,
    ) -> (f64, f64) {
        let relaxing = -bush_stiffness * deflection / bush_damping;
        let (p, d) = self.elastic_and_damping(delta - deflection, onset);
        if p <= 0.0 && d <= 0.0 {
            return (0.0, relaxing);
        }
        let rate = (p + d * delta_dot - bush_stiffness * deflection) / (bush_damping + d);
        let force = bush_stiffness * deflection + bush_damping * rate;
        if force > 0.0 { (force, rate) } else { (0.0, relaxing) }
    }

    /// The normal force of this contact in series with a spring of stiffness `series` [N/m] (a
    /// flexible bush behind the bearing surface): the approach δ splits into the contact's own
    /// indentation δ_c and the bush's deflection F/k, F = force(δ_c, δ̇_c) with δ_c = δ − F/k. The
    /// rate splits as the quasi-static series would: δ̇_c = δ̇ k / (k + k_c), k_c the contact's
    /// elastic tangent stiffness at δ_c. An infinite `series` is the contact alone.
    #[inline(always)]
    pub fn force_in_series(&self, delta: f64, delta_dot: f64, onset: f64, series: f64) -> f64 {
        if !series.is_finite() || delta <= 0.0 {
            return self.force(delta, delta_dot, onset);
        }
        // The exponent-1.5 laws (Hertz and the hysteresis family) in closed polynomial form, with
        // r = K√δ/k the contact's stiffness against the bush's; inlined into the micro step (a
        // call there costs more than the solve).
        match *self {
            NormalForce::Power { stiffness, exponent: 1.5 } => {
                let top = delta.sqrt();
                let y = series_root_three_halves(delta, top, stiffness * top / series, series, stiffness);
                stiffness * y * y * y
            }
            NormalForce::Hysteresis { stiffness, exponent: 1.5, chi, floor } => {
                let top = delta.sqrt();
                let compliance = 1.0 / series;
                let r = stiffness * top * compliance;
                let y = series_root_three_halves(delta, top, r, series, stiffness);
                let tangent = 1.5 * stiffness * y;
                // δ̇_c = δ̇ k/(k + k_c), and the factor 1 + χ δ̇_c/δ̇⁻ in one division.
                let factor = 1.0 + chi * delta_dot / ((1.0 + tangent * compliance) * onset.max(floor));
                if factor <= 0.0 {
                    return 0.0;
                }
                let y = series_root_three_halves(delta, top, r * factor, series, stiffness * factor);
                stiffness * factor * y * y * y
            }
            _ => self.force_in_series_general(delta, delta_dot, onset, series),
        }
    }

    /// [`NormalForce::force_in_series`] of every other law: Newton's method on F with the law's
    /// analytic slope, twice (the elastic split for the tangent, then the force).
    #[inline(never)]
    fn force_in_series_general(&self, delta: f64, delta_dot: f64, onset: f64, series: f64) -> f64 {
        let (_, tangent) = solve_series(delta, series, |d| self.force_and_slope(d, 0.0, onset));
        let rate = delta_dot * series / (series + tangent.max(0.0));
        solve_series(delta, series, |d| self.force_and_slope(d, rate, onset)).0
    }
}

/// u(r), the root of u² + r u³ = 1, by its series to r⁹: u = 1 − r/2 + 5r²/8 − r³ + 231r⁴/128 −
/// 7r⁵/2 + 7293r⁶/1024 − 15r⁷ + 1062347r⁸/32768 − 143r⁹/2 + … (coefficients by substitution,
/// exact), in Estrin's form (six levels of dependent operations instead of Horner's eighteen:
/// the series sits on the micro step's critical path). Within 1.5e-14 of the root for
/// r ≤ [`SERIES_EXACT`] = 0.025, 1.5e-11 for r ≤ 0.05, 1.4e-8 for r ≤ 0.1 and 1.3e-5 for
/// r ≤ 0.2 (the series converges for r below ≈ 0.45).
#[inline(always)]
fn series_start(r: f64) -> f64 {
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let low = (1.0 - 0.5 * r) + r2 * (0.625 - r);
    let middle = (231.0 / 128.0 - 3.5 * r) + r2 * (7293.0 / 1024.0 - 15.0 * r);
    let high = 1062347.0 / 32768.0 - 71.5 * r;
    low + r4 * middle + r8 * high
}

/// Below this r = K√δ/k the series of [`series_start`] is the root (to 1.5e-14, so the force
/// K y³ to 5e-14) and Newton's method is not run.
const SERIES_EXACT: f64 = 0.025;

/// For F = K δ_c^1.5 in series with a spring k: y = √δ_c solves K y³ + k y² − k δ = 0 (from
/// F = k(δ − y²) = K y³), a cubic increasing and convex for y > 0 with its one positive root in
/// (0, √δ). With y = √δ u and r = K√δ/k (the contact's stiffness against the bush's; `top` = √δ
/// and `r` given) it reads u² + r u³ = 1, whose root the series [`series_start`] gives for a
/// stiff bush: that series is the root for r ≤ 0.025 (a bush forty times stiffer than the
/// contact: the study's bronze behind its pin reaches r = 0.016), and starts Newton's method
/// beyond, up to r = 0.2 (√δ from there on). Newton converges quadratically here: after a step s
/// the error left is at most (g''/2g') s² (g convex, iterates from the right), so the iteration
/// stops as soon as that bound is below 1e-16 of y — one iteration from the series for r ≤ 0.05,
/// two to r = 0.2, against five from √δ with a stop on the step itself. No square root or power
/// per iteration, one division.
#[inline(always)]
fn series_root_three_halves(delta: f64, top: f64, r: f64, k: f64, stiffness: f64) -> f64 {
    if r <= SERIES_EXACT {
        return top * series_start(r);
    }
    let mut y = if r < 0.2 { top * series_start(r) } else { top };
    for _ in 0..60 {
        let g = (stiffness * y + k) * y * y - k * delta;
        let slope = (3.0 * stiffness * y + 2.0 * k) * y;
        if slope <= 0.0 {
            break;
        }
        let inverse = 1.0 / slope;
        let step = g * inverse;
        y = (y - step).clamp(0.0, top);
        // g''/2 = 3 K y + k: the error left after this step is at most (g''/2g') step².
        if (3.0 * stiffness * y + k) * inverse * step * step <= 1e-16 * y {
            break;
        }
    }
    y
}

/// The F ≥ 0 with F = f(δ − F/k), and f's slope there: g(F) = F − f(δ − F/k) is increasing,
/// −f(δ) at 0 and ≥ 0 at f(δ) (f increasing, f(x ≤ 0) = 0), so the root lies in [0, f(δ)].
/// Newton's method from 0 with f's analytic slope (g'(F) = 1 + f'(δ − F/k)/k); for a law convex
/// in δ (every law here but ADAMS IMPACT's damping blend), g is concave and the iterates rise
/// monotonically to the root, the first one already within (k_c/k)² of it. An iterate that leaves
/// the bracket is replaced by bisection. To a relative 1e-13 of f(δ); typically three iterations
/// for a bush ten times stiffer than the contact (the regula falsi this replaced needed ~15
/// evaluations).
#[inline(always)]
fn solve_series(delta: f64, k: f64, f: impl Fn(f64) -> (f64, f64)) -> (f64, f64) {
    let (hi, slope_at_delta) = f(delta);
    if hi <= 0.0 {
        return (0.0, 0.0);
    }
    let (mut a, mut b) = (0.0, hi);
    let mut x = hi / (1.0 + slope_at_delta / k);
    let mut slope = slope_at_delta;
    for _ in 0..100 {
        let (fx, sx) = f(delta - x / k);
        slope = sx;
        let g = x - fx;
        if g == 0.0 {
            return (x, slope);
        }
        if g > 0.0 {
            b = x;
        } else {
            a = x;
        }
        let mut next = x - g / (1.0 + sx / k);
        if !(next > a && next < b) {
            next = 0.5 * (a + b);
        }
        if (next - x).abs() <= 1e-13 * hi {
            return (next, slope);
        }
        x = next;
    }
    (x, slope)
}

impl ContactLaw {
    /// The hysteresis factor χ for the law's nominal restitution, where the law has one.
    pub fn chi(&self) -> Option<f64> {
        let h = |p: &HysteresisParams| p.restitution;
        Some(match self {
            ContactLaw::HuntCrossley(p) => 1.5 * (1.0 - h(p)),
            ContactLaw::LankaraniNikravesh(p) => 0.75 * (1.0 - h(p) * h(p)),
            ContactLaw::Gonthier(p) => (1.0 - h(p) * h(p)) / h(p),
            ContactLaw::Flores(p) => 8.0 * (1.0 - h(p)) / (5.0 * h(p)),
            ContactLaw::HuGuo(p) => 3.0 * (1.0 - h(p)) / (2.0 * h(p)),
            ContactLaw::Liu { restitution: Some(e), .. } => 0.75 * (1.0 - e * e),
            _ => return None,
        })
    }

    /// Problems of the law's numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        let stiff = |p: &mut Problems, k: &Option<f64>| {
            if let Some(k) = k {
                p.positive("stiffness", *k);
            }
        };
        match self {
            ContactLaw::Hertz { stiffness, exponent } => {
                stiff(&mut p, stiffness);
                p.positive("exponent", *exponent);
            }
            ContactLaw::KelvinVoigt { stiffness, damping } => {
                p.positive("stiffness", *stiffness);
                p.non_negative("damping", *damping);
            }
            ContactLaw::HuntCrossley(h)
            | ContactLaw::LankaraniNikravesh(h)
            | ContactLaw::Gonthier(h)
            | ContactLaw::Flores(h)
            | ContactLaw::HuGuo(h) => {
                stiff(&mut p, &h.stiffness);
                p.positive("exponent", h.exponent);
                p.positive("velocity_floor", h.velocity_floor);
                if !(h.restitution.is_finite() && h.restitution > 0.0 && h.restitution <= 1.0) {
                    p.push("restitution", format!("must lie in (0, 1], got {}", h.restitution));
                }
            }
            ContactLaw::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => {
                stiff(&mut p, stiffness);
                p.positive("exponent", *exponent);
                p.non_negative("max_damping", *max_damping);
                p.positive("damping_depth", *damping_depth);
            }
            ContactLaw::Liu { length, restitution, velocity_floor } => {
                p.positive("length", *length);
                p.positive("velocity_floor", *velocity_floor);
                if let Some(e) = restitution
                    && !(e.is_finite() && *e > 0.0 && *e <= 1.0)
                {
                    p.push("restitution", format!("must lie in (0, 1], got {e}"));
                }
            }
        }
        p
    }

    /// Resolves the law to numbers for a journal of radius `journal_radius` in a bearing of radius
    /// `bearing_radius`, of the given materials.
    pub fn resolve(
        &self,
        journal: &Material,
        bearing: &Material,
        journal_radius: f64,
        bearing_radius: f64,
    ) -> NormalForce {
        let hertz = || hertz_stiffness(journal, bearing, journal_radius, bearing_radius);
        let chi = self.chi().unwrap_or(0.0);
        match self {
            ContactLaw::Hertz { stiffness, exponent } => {
                NormalForce::Power { stiffness: stiffness.unwrap_or_else(hertz), exponent: *exponent }
            }
            ContactLaw::KelvinVoigt { stiffness, damping } => {
                NormalForce::KelvinVoigt { stiffness: *stiffness, damping: *damping }
            }
            ContactLaw::HuntCrossley(h)
            | ContactLaw::LankaraniNikravesh(h)
            | ContactLaw::Gonthier(h)
            | ContactLaw::Flores(h)
            | ContactLaw::HuGuo(h) => NormalForce::Hysteresis {
                stiffness: h.stiffness.unwrap_or_else(hertz),
                exponent: h.exponent,
                chi,
                floor: h.velocity_floor,
            },
            ContactLaw::AdamsImpact { stiffness, exponent, max_damping, damping_depth } => NormalForce::AdamsImpact {
                stiffness: stiffness.unwrap_or_else(hertz),
                exponent: *exponent,
                max_damping: *max_damping,
                damping_depth: *damping_depth,
            },
            ContactLaw::Liu { length, velocity_floor, .. } => NormalForce::Liu {
                factor: std::f64::consts::FRAC_PI_2 * effective_modulus(journal, bearing) * length,
                clearance: bearing_radius - journal_radius,
                chi,
                floor: *velocity_floor,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every law in eight lanes (penetrations on both sides of contact, inside and beyond ADAMS's
    /// damping depth, onsets below and above the floor), clipped as the lanes clip it, is the
    /// scalar law lane by lane, bit for bit.
    #[test]
    fn every_law_in_lanes_is_the_scalar_law_bit_for_bit() {
        use lash_core::lane::{F64x8, LANES};
        let delta = [-1e-6, 0.0, 2e-7, 1e-6, 3e-6, 2e-5, 1e-4, 5e-7];
        let delta_dot = [0.3, -0.2, 0.5, -1.0, 0.0, 2.0, -0.01, 1e-3];
        let onset = [0.0, 1e-5, 0.2, 1.0, 3.0, 0.5, 1e-4, 0.05];
        let laws = [
            NormalForce::Power { stiffness: 5e9, exponent: 1.5 },
            NormalForce::Power { stiffness: 1e8, exponent: 1.0 },
            NormalForce::Power { stiffness: 2e10, exponent: 1.7 },
            NormalForce::KelvinVoigt { stiffness: 1e8, damping: 3e3 },
            NormalForce::Hysteresis { stiffness: 5e9, exponent: 1.5, chi: 0.3, floor: 1e-4 },
            NormalForce::Hysteresis { stiffness: 5e9, exponent: 1.2, chi: 0.3, floor: 1e-4 },
            NormalForce::AdamsImpact { stiffness: 1e10, exponent: 2.2, max_damping: 1e4, damping_depth: 2e-6 },
            NormalForce::Liu { factor: 3e9, clearance: 1e-4, chi: 0.2, floor: 1e-4 },
        ];
        for law in laws {
            let (kind, numbers) = LaneLaw::of(&law);
            let floor = F64x8::splat(kind.floor(&numbers));
            let (d, v, o) = (F64x8(delta), F64x8(delta_dot), F64x8(onset));
            let f = kind.force(&numbers.map(F64x8::splat), (d, v), o, onset_reciprocal(o, floor));
            let zero = F64x8::ZERO;
            let clipped = d.simd_le(zero).select(zero, f.max(zero));
            for l in 0..LANES {
                let scalar = law.force(delta[l], delta_dot[l], onset[l]);
                assert_eq!(clipped[l].to_bits(), scalar.to_bits(), "{law:?} at lane {l}");
            }
        }
    }

    #[test]
    fn hertz_stiffness_of_the_benchmark() {
        let k = hertz_stiffness(&Material::STEEL, &Material::STEEL, 0.0095, 0.010);
        // Expected ≈ 6.61e10 N/m^1.5; independent arithmetic: E* = E/(2(1−ν²)), R* = 0.19 m.
        let e_star = 207e9 / (2.0 * (1.0 - 0.09));
        let expected = 4.0 / 3.0 * e_star * 0.19f64.sqrt();
        assert!((k - expected).abs() < 1e-6 * expected);
        assert!((k / 6.61e10 - 1.0).abs() < 2e-3);
    }

    /// Each law's analytic slope (used by the series solve) against a central difference.
    #[test]
    fn the_force_slopes_equal_central_differences() {
        let laws = [
            NormalForce::Power { stiffness: 5e9, exponent: 1.5 },
            NormalForce::Power { stiffness: 5e9, exponent: 1.2 },
            NormalForce::KelvinVoigt { stiffness: 1e8, damping: 1e3 },
            NormalForce::Hysteresis { stiffness: 5e9, exponent: 1.5, chi: 0.3, floor: 1e-5 },
            NormalForce::AdamsImpact { stiffness: 5e9, exponent: 1.5, max_damping: 1e4, damping_depth: 1e-5 },
            NormalForce::Liu { factor: 1e10, clearance: 1e-4, chi: 0.2, floor: 1e-4 },
        ];
        for law in laws {
            for delta in [1e-7, 3e-6, 2e-5] {
                let (f, slope) = law.force_and_slope(delta, 0.05, 0.2);
                assert_eq!(f, law.force(delta, 0.05, 0.2), "{law:?}");
                let h = 1e-6 * delta;
                let numeric = (law.force(delta + h, 0.05, 0.2) - law.force(delta - h, 0.05, 0.2)) / (2.0 * h);
                assert!(
                    (slope - numeric).abs() <= 1e-6 * numeric.abs().max(1.0),
                    "{law:?} at {delta}: {slope} {numeric}"
                );
            }
            assert_eq!(law.force_and_slope(-1e-6, 0.05, 0.2), (0.0, 0.0));
        }
    }

    /// The series force against an independent solve: bisection on F = f(δ − F/k, δ̇_c) written
    /// out here, with the rate split δ̇_c = δ̇ k/(k + k_c) from the Hertz tangent in closed form
    /// (k_c = 1.5 K δ_c^0.5); and the two limits (a stiff series spring is the contact alone, a
    /// soft one carries F ≈ k δ).
    #[test]
    fn a_contact_in_series_with_a_bush_splits_the_approach() {
        let (stiff, chi, floor) = (5e9, 0.3, 1e-5);
        let law = NormalForce::Hysteresis { stiffness: stiff, exponent: 1.5, chi, floor };
        let (delta, rate, onset) = (2e-6, 0.05, 0.2);
        for k in [1e7, 1e9, 3e10, 1e13] {
            let f = law.force_in_series(delta, rate, onset, k);
            // Independent: bisection for the elastic split, then the closed-form tangent.
            let bisect = |g: &dyn Fn(f64) -> f64| {
                let (mut a, mut b) = (0.0, stiff * delta.powf(1.5) * 10.0);
                for _ in 0..300 {
                    let c = 0.5 * (a + b);
                    if g(c) > 0.0 { b = c } else { a = c }
                }
                0.5 * (a + b)
            };
            let elastic = bisect(&|x| x - stiff * (delta - x / k).max(0.0).powf(1.5));
            let dc = delta - elastic / k;
            let tangent = 1.5 * stiff * dc.sqrt();
            let rc = rate * k / (k + tangent);
            let expected = bisect(&|x| {
                let d = (delta - x / k).max(0.0);
                x - stiff * d.powf(1.5) * (1.0 + chi * rc / onset.max(floor))
            });
            assert!((f / expected - 1.0).abs() < 1e-9, "k = {k}: {f} against {expected}");
        }
        let alone = law.force(delta, rate, onset);
        assert!((law.force_in_series(delta, rate, onset, 1e16) / alone - 1.0).abs() < 1e-6);
        assert_eq!(law.force_in_series(delta, rate, onset, f64::INFINITY), alone);
        assert!((law.force_in_series(delta, rate, onset, 1.0) / delta - 1.0).abs() < 1e-3);
        assert_eq!(law.force_in_series(-1e-6, rate, onset, 1e9), 0.0);
    }

    /// The damped series: the bush carries what the contact carries, k s + c ṡ = F(δ − s, δ̇ − ṡ),
    /// checked with the law's own `force` at the returned rate for every law; a relaxing bush where
    /// the contact opens or would pull.
    #[test]
    fn a_bush_damped_in_series_carries_what_the_contact_carries() {
        let laws = [
            NormalForce::Power { stiffness: 5e9, exponent: 1.5 },
            NormalForce::KelvinVoigt { stiffness: 1e8, damping: 1e3 },
            NormalForce::Hysteresis { stiffness: 5e9, exponent: 1.5, chi: 0.3, floor: 1e-5 },
            NormalForce::AdamsImpact { stiffness: 5e9, exponent: 1.5, max_damping: 1e4, damping_depth: 1e-5 },
            NormalForce::Liu { factor: 1e10, clearance: 1e-4, chi: 0.2, floor: 1e-4 },
        ];
        let (k, c) = (1e9, 1e4);
        for law in laws {
            for (delta, rate, s) in [(3e-6, 0.05, 1e-6), (3e-6, -0.05, 2e-6), (2e-5, 0.3, 0.0), (1e-6, 0.0, 5e-7)] {
                let (f, s_dot) = law.force_in_series_damped(delta, rate, 0.2, s, k, c);
                let carried = law.force(delta - s, rate - s_dot, 0.2);
                assert!((f - carried).abs() <= 1e-9 * f.max(1.0), "{law:?} at {delta}, {rate}: {f} {carried}");
                assert!((f - (k * s + c * s_dot)).abs() <= 1e-9 * f.max(1.0), "{law:?}: the bush's balance");
                assert!(f >= 0.0);
            }
            // Open contact (δ ≤ s): nothing carried, the bush relaxes.
            assert_eq!(law.force_in_series_damped(1e-6, 0.1, 0.2, 2e-6, k, c), (0.0, -k * 2e-6 / c));
            // Pulling apart faster than the bush relaxes: a damped contact would pull, so it carries
            // nothing (an elastic one still pushes).
            if law.elastic_and_damping(5e-7, 0.2).1 > 0.0 {
                assert_eq!(law.force_in_series_damped(1e-6, -10.0, 0.2, 5e-7, k, c), (0.0, -k * 5e-7 / c));
            }
        }
    }

    /// The series of u² + r u³ = 1 against its root by bisection, to the bounds its documentation
    /// states.
    #[test]
    fn the_stiff_bush_series_meets_its_stated_bounds() {
        for (r, bound) in [(SERIES_EXACT, 1.5e-14), (0.05, 1.5e-11), (0.1, 1.4e-8), (0.2, 1.3e-5)] {
            let (mut a, mut b) = (0.0f64, 1.0f64);
            for _ in 0..200 {
                let c = 0.5 * (a + b);
                if c * c + r * c * c * c > 1.0 { b = c } else { a = c }
            }
            let root = 0.5 * (a + b);
            let error = (series_start(r) / root - 1.0).abs();
            assert!(error <= bound, "r = {r}: {error} > {bound}");
            assert!(error >= bound / 100.0, "r = {r}: the bound {bound} is far from the error {error}");
        }
    }

    #[test]
    fn step_matches_its_definition() {
        assert_eq!(step_of(-1.0, 0.0, 0.0, 1.0, 5.0), 0.0);
        assert_eq!(step_of(2.0, 0.0, 0.0, 1.0, 5.0), 5.0);
        assert!((step_of(0.5, 0.0, 0.0, 1.0, 5.0) - 2.5).abs() < 1e-15);
        assert!((step_of(0.25, 0.0, 1.0, 1.0, 3.0) - (1.0 + 2.0 * 0.0625 * 2.5)).abs() < 1e-15);
    }

    fn hyst(restitution: f64) -> HysteresisParams {
        HysteresisParams { restitution, stiffness: Some(1e9), exponent: 1.5, velocity_floor: 1e-4 }
    }

    #[test]
    fn chi_values_follow_the_published_formulas() {
        let ce = 0.5;
        let cases = [
            (ContactLaw::HuntCrossley(hyst(ce)), 0.75),
            (ContactLaw::LankaraniNikravesh(hyst(ce)), 0.5625),
            (ContactLaw::Gonthier(hyst(ce)), 1.5),
            (ContactLaw::Flores(hyst(ce)), 1.6),
            (ContactLaw::HuGuo(hyst(ce)), 1.5),
        ];
        for (law, chi) in cases {
            assert!((law.chi().unwrap() - chi).abs() < 1e-15, "{law:?}");
        }
    }

    #[test]
    fn validation_names_fields() {
        let p = ContactLaw::LankaraniNikravesh(HysteresisParams {
            restitution: 1.5,
            stiffness: Some(-1.0),
            exponent: f64::NAN,
            velocity_floor: 0.0,
        })
        .validate();
        let fields: Vec<_> = p.0.iter().map(|x| x.field.as_str()).collect();
        assert_eq!(fields, ["stiffness", "exponent", "velocity_floor", "restitution"]);
    }

    fn all_laws() -> Vec<NormalForce> {
        let m = Material::STEEL;
        let mut v: Vec<NormalForce> = [
            ContactLaw::Hertz { stiffness: None, exponent: 1.5 },
            ContactLaw::KelvinVoigt { stiffness: 1e8, damping: 1e3 },
            ContactLaw::HuntCrossley(hyst(0.7)),
            ContactLaw::LankaraniNikravesh(hyst(0.7)),
            ContactLaw::Gonthier(hyst(0.7)),
            ContactLaw::Flores(hyst(0.7)),
            ContactLaw::HuGuo(hyst(0.7)),
            ContactLaw::AdamsImpact { stiffness: None, exponent: 1.5, max_damping: 1e4, damping_depth: 1e-5 },
            ContactLaw::Liu { length: 0.02, restitution: Some(0.8), velocity_floor: 1e-4 },
        ]
        .iter()
        .map(|l| l.resolve(&m, &m, 0.0095, 0.01))
        .collect();
        v.push(NormalForce::Power { stiffness: 1e9, exponent: 1.3 });
        v
    }

    proptest! {
        #[test]
        fn forces_are_never_negative_and_vanish_outside_contact(
            delta in -1e-3f64..1e-3, rate in -10.0f64..10.0, onset in 0.0f64..10.0
        ) {
            for law in all_laws() {
                let f = law.force(delta, rate, onset);
                prop_assert!(f >= 0.0 && f.is_finite());
                if delta <= 0.0 { prop_assert_eq!(f, 0.0); }
            }
        }

        #[test]
        fn approaching_pushes_harder_than_separating(delta in 1e-7f64..1e-4, rate in 1e-3f64..5.0) {
            for law in all_laws() {
                prop_assert!(law.force(delta, rate, rate) >= law.force(delta, -rate, rate));
            }
        }

        /// ADAMS IMPACT as the ADAMS function reference writes it, in the distance x between
        /// the surfaces (contact below x1) and its rate ẋ: max(0, k (x1 − x)^e −
        /// STEP(x, x1 − d, c_max, x1, 0) ẋ), with STEP's cubic written out independently.
        #[test]
        fn adams_impact_equals_the_adams_function(
            x1 in 0.1f64..1.0, depth in -2e-4f64..1e-4, x_dot in -5.0f64..5.0,
            k in 1e8f64..1e11, e in 1.0f64..2.2, c_max in 0.0f64..1e5, d in 1e-7f64..1e-4
        ) {
            fn adams_step(x: f64, x0: f64, h0: f64, x1: f64, h1: f64) -> f64 {
                if x <= x0 { return h0; }
                if x >= x1 { return h1; }
                let a = h1 - h0;
                let u = (x - x0) / (x1 - x0);
                h0 + a * u * u * (3.0 - 2.0 * u)
            }
            let x = x1 - depth; // penetration δ = x1 − x = depth
            let adams = if x >= x1 { 0.0 } else { (k * (x1 - x).powf(e) - adams_step(x, x1 - d, c_max, x1, 0.0) * x_dot).max(0.0) };
            let law = NormalForce::AdamsImpact { stiffness: k, exponent: e, max_damping: c_max, damping_depth: d };
            let lash = law.force(x1 - x, -x_dot, 0.0);
            // The force is a difference of its elastic and damping terms, which may nearly cancel
            // (and x1 − x carries x1's rounding into δ): the agreement is bounded relative to the
            // terms, not to their difference. STEP's cubic as ADAMS writes it, h0 + a u² (3 − 2u),
            // is itself a cancellation near x1 (c_max minus nearly c_max): its value carries a
            // few roundings of c_max, absolutely, whatever its size.
            let terms = k * (x1 - x).powf(e) + (adams_step(x, x1 - d, c_max, x1, 0.0) * x_dot).abs();
            let step_rounding = 8.0 * f64::EPSILON * c_max * x_dot.abs();
            prop_assert!(
                (lash - adams).abs() <= 1e-9 * terms.max(1e-6) + step_rounding,
                "lash {} vs ADAMS {}", lash, adams
            );
        }
    }

    #[test]
    fn hertz_stiffness_of_a_ball_in_a_spherical_socket() {
        // Sphere in a spherical cavity, steel on steel: K = (4/3) E* √(R_J R_B / (R_B − R_J)).
        // Socket Ø12 mm with balls Ø11.5 and Ø11 mm: 5.63e10 and 3.90e10 N/m^1.5.
        for (ball, expected) in [(0.00575, 5.63e10), (0.0055, 3.90e10)] {
            let k = hertz_stiffness(&Material::STEEL, &Material::STEEL, ball, 0.006);
            assert!((k / expected - 1.0).abs() < 2e-3, "{k:e} vs {expected:e}");
        }
    }
}
