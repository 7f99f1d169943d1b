//! The oil film of a lubricated journal bearing: the hydrodynamic force on the journal from the
//! Reynolds equation's two closed forms, the short bearing (Ocvirk: the circumferential pressure
//! flow neglected) and the infinitely long bearing (Sommerfeld: the axial flow neglected), with
//! Gümbel's half-film cavitation, in the eccentricity and its rate (wedge and squeeze together).
//!
//! # The film in any motion
//!
//! With e the journal centre minus the bearing centre, ė its rate, ω̄ = (ω_J + ω_B)/2 the mean of
//! the two surfaces' angular velocities and d̂ the direction from the journal centre to a point of
//! the film, the thickness is h = c − e·d̂, and both Reynolds equations are driven by one vector,
//!
//! w = ė − ω̄ J e  (J: a quarter turn),
//!
//! the squeeze velocity relative to the film's mean rotation (ė is the squeeze, −ω̄ J e the wedge;
//! the line of centres' own rotation is inside ė, so no rotating frame is needed). The film
//! carries pressure on the half of the circumference that w points into (w·d̂ > 0) — Gümbel's
//! condition; in steady running (ė = 0) that is the converging half, the classic π-film.
//!
//! - **Short bearing**: p = 6μ (w·d̂)(L²/4 − z²)/h³ wherever it is positive, which is exactly the
//!   half-film above (the short bearing's pressure at each angle stands alone, so clipping the
//!   negative part is Gümbel's condition, and it agrees with a numerical Reynolds solution of a
//!   short finite bearing in any motion).
//! - **Long bearing**: d/dθ(h³ dp/dθ) = −12 μ R² w·d̂ all round (the full Sommerfeld film),
//!   with the constant pressure that a finite bearing with ambient ends imposes as it grows long
//!   (∫ h³ p dθ = 0 at every section), then Gümbel's condition: the film keeps the arcs where
//!   that pressure is positive (in steady running the half-Sommerfeld solution). This is the
//!   limit of the numerical Reynolds solution of long finite bearings in any motion; the classic
//!   π-film of the dynamically loaded long bearing (p = 0 at both ends of a fixed half) is not,
//!   once the journal moves away from the bearing (off by 150 % at L/D = 8, measured).
//!
//! The force on the journal, −∫ p d̂ dA over the film, is integrated in closed form: the
//! substitution of Sommerfeld (the eccentric anomaly E, 1 + ε cos θ = (1 − ε²)/(1 − ε cos E))
//! turns every integral into a trigonometric polynomial in E. The short bearing needs one `atan2`
//! for E's span and is smooth in ε down to ε = 0 (no 1/ε), where w alone sets the film's half; the
//! long bearing's pressed arcs end at the roots of its pressure, found numerically (lane by lane).
//!
//! # Mixed lubrication
//!
//! The closed forms grow without bound as the film thins (ε → 1). Below a stated fraction of the
//! clearance (`mixed_fraction`: the thinnest film c − |e| < fraction · c) the film force is the
//! one at ε_t = 1 − fraction in the same direction with the same rates, so it stays finite and
//! continuous; dry contact adds to it when the journal touches the bearing.

use lash_core::Problems;
use lash_core::lane::Real;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Which closed form of the Reynolds equation the film uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BearingLength {
    /// The short bearing (Ocvirk): length over diameter ≲ 0.5.
    Short,
    /// The infinitely long bearing (Sommerfeld): length over diameter ≳ 2.
    Long,
}

/// The oil film of a lubricated revolute clearance joint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Film {
    /// The oil's dynamic viscosity μ \[Pa·s\] (e.g. SAE 20 near 40 °C: about 0.04 Pa·s).
    pub viscosity: f64,
    /// The bearing's axial length L \[m\].
    pub length: f64,
    /// Short or long bearing.
    pub bearing: BearingLength,
    /// The thinnest film, as a fraction of the radial clearance, below which the film force is
    /// held at its value there (mixed lubrication); in (0, 1), [`Film::MIXED_FRACTION`] when
    /// left out.
    #[serde(default = "Film::default_mixed_fraction")]
    pub mixed_fraction: f64,
}

impl Film {
    /// The mixed-lubrication limit when a scenario gives none: a film thinner than 5 % of the
    /// clearance (ε > 0.95), where the closed forms' force grows as (1 − ε)^(−5/2) and a
    /// real surface's roughness is no longer small beside the film.
    pub const MIXED_FRACTION: f64 = 0.05;

    fn default_mixed_fraction() -> f64 {
        Self::MIXED_FRACTION
    }

    /// Problems of the film's numbers, each named by its field.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        p.positive("viscosity", self.viscosity);
        p.positive("length", self.length);
        if !(self.mixed_fraction.is_finite() && self.mixed_fraction > 0.0 && self.mixed_fraction < 1.0) {
            p.push("mixed_fraction", format!("must lie in (0, 1), got {}", self.mixed_fraction));
        }
        p
    }

    /// The film's force on the journal \[N\] (the bearing takes its opposite) for eccentricity
    /// `e` and its rate `e_dot` in the plane's axes, `mean_rate` = (ω_J + ω_B)/2, a journal of
    /// radius `radius` in a clearance `clearance` (both \[m\]).
    #[inline]
    pub fn force<R: Real>(&self, (radius, clearance): (f64, f64), e: [R; 2], e_dot: [R; 2], mean_rate: R) -> [R; 2] {
        let form = match self.bearing {
            BearingLength::Short => FilmForm::short(self.viscosity, radius, self.length, clearance),
            BearingLength::Long => FilmForm::long(self.viscosity, radius, self.length, clearance),
        };
        film_force(form, clearance, 1.0 - self.mixed_fraction, e, e_dot, mean_rate)
    }
}

impl Film {
    /// The film's largest damping coefficient ∂F/∂ė \[N s/m\]: at the mixed-lubrication limit,
    /// for a squeeze along the line of centres or across it, whichever is stiffer (the force is
    /// linear in ė there for a given film half, so one evaluation at a unit speed gives it). A
    /// fixed-step integrator needs steps below about 2.8 m/c for a mass m on this damping.
    pub fn damping_bound(&self, (radius, clearance): (f64, f64)) -> f64 {
        let e = [(1.0 - self.mixed_fraction) * clearance, 0.0];
        let along = self.force((radius, clearance), e, [1.0, 0.0], 0.0);
        let across = self.force((radius, clearance), e, [0.0, 1.0], 0.0);
        along[0].hypot(along[1]).max(across[0].hypot(across[1]))
    }
}

/// Which closed form, with its force scale: μ R L³ / c³ (short) or 12 μ R³ L / c³ (long), in
/// N per (m/s) of w.
#[derive(Debug, Clone, Copy)]
enum FilmForm {
    Short(f64),
    Long(f64),
}

impl FilmForm {
    fn short(viscosity: f64, radius: f64, length: f64, clearance: f64) -> Self {
        Self::Short(viscosity * radius * length.powi(3) / clearance.powi(3))
    }
    fn long(viscosity: f64, radius: f64, length: f64, clearance: f64) -> Self {
        Self::Long(12.0 * viscosity * radius.powi(3) * length / clearance.powi(3))
    }
}

/// The film force for eccentricity ratios up to `ratio_limit` (beyond: held there).
#[inline]
fn film_force<R: Real>(
    model: FilmForm,
    clearance: f64,
    ratio_limit: f64,
    e: [R; 2],
    e_dot: [R; 2],
    mean_rate: R,
) -> [R; 2] {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let norm = (e[0] * e[0] + e[1] * e[1]).sqrt();
    let centred = norm.simd_le(zero);
    // u along e (any direction at e = 0: the force there does not depend on it).
    let u = [R::select(centred, one, e[0] / norm), R::select(centred, zero, e[1] / norm)];
    let ratio = R::select(centred, zero, norm / R::splat(clearance));
    let held = ratio.simd_gt(R::splat(ratio_limit));
    let ratio = R::select(held, R::splat(ratio_limit), ratio);
    let held_e = ratio * R::splat(clearance);
    // w = ė − ω̄ J e in the (u, J u) frame; e is |e| u at the held eccentricity.
    let w_u = e_dot[0] * u[0] + e_dot[1] * u[1];
    let w_t = (e_dot[1] * u[0] - e_dot[0] * u[1]) - mean_rate * held_e;
    let (f_u, f_t) = match model {
        FilmForm::Short(scale) => {
            let i = Integrals::half_film(ratio, w_u, w_t);
            let k = R::splat(-scale);
            (k * (w_u * i.cc + w_t * i.sc), k * (w_u * i.sc + w_t * i.ss))
        }
        FilmForm::Long(scale) => {
            // The pressed arcs differ from lane to lane: found lane by lane.
            let mut per_lane = [(0.0, 0.0); lash_core::lane::LANES];
            for (l, f) in per_lane.iter_mut().enumerate().take(R::WIDTH) {
                *f = long_film(ratio.lane(l), w_u.lane(l), w_t.lane(l));
            }
            let k = R::splat(scale);
            (k * R::from_lanes(|l| per_lane[l].0), k * R::from_lanes(|l| per_lane[l].1))
        }
    };
    [f_u * u[0] - f_t * u[1], f_u * u[1] + f_t * u[0]]
}

/// The long bearing's force over 12 μ R³ L / c³ (along u, along J u) for eccentricity ratio ε
/// and w = (w_u, w_t) in the (u, J u) frame.
///
/// The full-film (Sommerfeld) pressure, θ from the thickest film, D = 1 + ε cos θ, is
/// P = (12 μ R²/c³) [(2 + ε cos θ)/D² · (−w_t sin θ/(2 + ε²) − w_u cos θ/2) + 3ε w_u/(2(2 + 3ε²))]:
/// periodic, and with the constant that a bearing of finite length with ambient ends imposes as
/// it grows long (∫ h³ p dθ = 0 at every section, since the source w·d̂ has no mean around the
/// circle). Gümbel's condition keeps its positive arcs, bounded by the roots of P D² (a
/// trigonometric polynomial of degree two: at most four), bracketed on 64 samples and refined by
/// safeguarded Newton steps. On each arc p = 0 at both ends, so the force is −∫ p′ sin θ and
/// ∫ p′ cos θ, in closed form on the arc.
fn long_film(ratio: f64, w_u: f64, w_t: f64) -> (f64, f64) {
    let e = ratio;
    let (a, b) = (-w_t / (2.0 + e * e), -0.5 * w_u);
    let mean = 3.0 * e * w_u / (2.0 * (2.0 + 3.0 * e * e));
    let pressure_at = |(s, c): (f64, f64)| (2.0 + e * c) * (a * s + b * c) + mean * (1.0 + e * c) * (1.0 + e * c);
    // P D² and its slope at θ, from one sin_cos.
    let with_slope = |t: f64| {
        let (s, c) = t.sin_cos();
        let slope = -e * s * (a * s + b * c) + (2.0 + e * c) * (a * c - b * s) - 2.0 * mean * e * s * (1.0 + e * c);
        (pressure_at((s, c)), slope)
    };
    let step = 2.0 * PI / SAMPLES as f64;
    // Sign changes of P around the circle: (angle, whether a pressed arc starts there).
    let (mut roots, mut count) = ([(0.0, false); 8], 0);
    let samples = &*SAMPLE_ANGLES;
    let first_value = pressure_at(samples[0]);
    let (first, mut previous) = (first_value > 0.0, first_value);
    for k in 1..=SAMPLES {
        let value = if k == SAMPLES { first_value } else { pressure_at(samples[k]) };
        if (value > 0.0) != (previous > 0.0) && count < roots.len() {
            let t = refine_root(&with_slope, ((k - 1) as f64 * step, k as f64 * step), (previous, value));
            roots[count] = (t, value > 0.0);
            count += 1;
        }
        previous = value;
    }
    // p′ = (12 μ R²/c³)(w_u sin θ − w_t cos θ + C₁)/D³, C₁ from the pressure's periodicity.
    let c1 = -3.0 * e * w_t / (2.0 + e * e);
    let arc = |from: f64, to: f64| {
        let i = Integrals::arc(e, from, to);
        (-(w_u * i.ss - w_t * i.sc + c1 * i.s), w_u * i.sc - w_t * i.cc + c1 * i.c)
    };
    if count == 0 {
        // Pressed all round or nowhere (w = 0, or arcs narrower than a sample).
        return if first { arc(0.0, 2.0 * PI) } else { (0.0, 0.0) };
    }
    let (mut f_u, mut f_t) = (0.0, 0.0);
    for k in 0..count {
        let (start, opens) = roots[k];
        if opens {
            let end = roots[(k + 1) % count].0;
            let (u, t) = arc(start, if end > start { end } else { end + 2.0 * PI });
            f_u += u;
            f_t += t;
        }
    }
    (f_u, f_t)
}

/// Where the long bearing's pressure is sampled for its sign changes.
const SAMPLES: usize = 64;

/// (sin θ, cos θ) of the samples, θ = 2π k / [`SAMPLES`], computed once.
static SAMPLE_ANGLES: std::sync::LazyLock<[(f64, f64); SAMPLES]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|k| (2.0 * PI * k as f64 / SAMPLES as f64).sin_cos()));

/// A root of `f` (its value and slope at θ) between `lo` and `hi`, where its values `f_lo`
/// and `f_hi` differ in sign: Newton steps from the secant's point, kept in the bracket (bisection
/// where a step would leave it), to 1e-12 rad — the force's error is of the second order in the
/// root's (the pressure is zero there), so far below rounding.
fn refine_root(f: &impl Fn(f64) -> (f64, f64), (mut lo, mut hi): (f64, f64), (f_lo, f_hi): (f64, f64)) -> f64 {
    let lo_positive = f_lo > 0.0;
    let mut t = lo - f_lo * (hi - lo) / (f_hi - f_lo);
    if !(t > lo && t < hi) {
        t = 0.5 * (lo + hi);
    }
    for _ in 0..40 {
        let (v, slope) = f(t);
        if (v > 0.0) == lo_positive {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - v / slope;
        let next = if newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
        if (next - t).abs() <= 1e-12 {
            return next;
        }
        t = next;
    }
    t
}

/// The integrals over an arc of the film, θ from the thickest film, D = 1 + ε cos θ:
/// ∫ cos²θ/D³, ∫ sin θ cos θ/D³, ∫ sin²θ/D³, ∫ cos θ/D³ and ∫ sin θ/D³, each a
/// trigonometric polynomial in the eccentric anomaly E (cos E = (ε + cos θ)/D,
/// sin E = √(1 − ε²) sin θ/D) evaluated at the arc's ends, plus E's span for its linear terms.
struct Integrals<R> {
    cc: R,
    sc: R,
    ss: R,
    c: R,
    s: R,
}

impl<R: Real> Integrals<R> {
    /// The half that w = (w_u, w_t) points into: w·d̂ = −(w_u cos θ + w_t sin θ) > 0, so it starts
    /// at cos α = −w_t/|w|, sin α = w_u/|w| (α = 0 for w = 0: the force is zero then anyway).
    #[inline(always)]
    fn half_film(ratio: R, w_u: R, w_t: R) -> Self {
        let (zero, one) = (R::splat(0.0), R::splat(1.0));
        let w = (w_u * w_u + w_t * w_t).sqrt();
        let still = w.simd_le(zero);
        let cos_a = R::select(still, one, -w_t / w);
        let sin_a = R::select(still, zero, w_u / w);
        let root = (one - ratio * ratio).sqrt();
        let (start, end) = (anomaly(ratio, root, cos_a, sin_a), anomaly(ratio, root, -cos_a, -sin_a));
        // E's span over the half, in (0, 2π): E grows with θ.
        let span = (end.1 * start.0 - end.0 * start.1).atan2(end.0 * start.0 + end.1 * start.1);
        let span = R::select(span.simd_lt(zero), span + R::splat(2.0 * PI), span);
        Self::of_anomalies(ratio, start, end, span)
    }

    #[inline(always)]
    fn of_anomalies(ratio: R, (c1, s1): (R, R), (c2, s2): (R, R), span: R) -> Self {
        let (one, two, half) = (R::splat(1.0), R::splat(2.0), R::splat(0.5));
        let q = one - ratio * ratio;
        let root = q.sqrt();
        let sin_cos = s2 * c2 - s1 * c1;
        let (sin, cos, sin_sq) = (s2 - s1, c2 - c1, s2 * s2 - s1 * s1);
        let (q2, q32, q52) = (q * q, q * root, q * q * root);
        let (e, e2) = (ratio, ratio * ratio);
        Self {
            ss: (half * span - half * sin_cos) / q32,
            cc: (half * span + half * sin_cos - two * e * sin + e2 * span) / q52,
            sc: (half * sin_sq + e * cos) / q2,
            c: ((one + e2) * sin - e * (half * span + half * sin_cos) - e * span) / q52,
            s: (-cos - half * e * sin_sq) / q2,
        }
    }
}

impl Integrals<f64> {
    /// The integrals from θ = `from` to `to` (`from` < `to` ≤ `from` + 2π), E unwrapped by
    /// its distance from θ (less than π for ε < 1).
    fn arc(ratio: f64, from: f64, to: f64) -> Self {
        let root = (1.0 - ratio * ratio).sqrt();
        let unwrapped = |t: f64| {
            let (s, c) = t.sin_cos();
            let (cos_e, sin_e) = anomaly(ratio, root, c, s);
            let e = sin_e.atan2(cos_e);
            (cos_e, sin_e, e + 2.0 * PI * ((t - e) / (2.0 * PI)).round())
        };
        let (c1, s1, e1) = unwrapped(from);
        let (c2, s2, e2) = unwrapped(to);
        Self::of_anomalies(ratio, (c1, s1), (c2, s2), e2 - e1)
    }
}

/// (cos E, sin E) at θ given (cos θ, sin θ); `root` = √(1 − ε²).
#[inline(always)]
fn anomaly<R: Real>(ratio: R, root: R, cos_t: R, sin_t: R) -> (R, R) {
    let d = R::splat(1.0) + ratio * cos_t;
    ((ratio + cos_t) / d, root * sin_t / d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straightforward quadrature of the half-film integrals in θ (no substitution).
    fn quadrature(ratio: f64, start: f64, f: impl Fn(f64) -> f64) -> f64 {
        let n = 20_000;
        let h = PI / n as f64;
        (0..n)
            .map(|i| {
                let t = start + (i as f64 + 0.5) * h;
                f(t) / (1.0 + ratio * t.cos()).powi(3)
            })
            .sum::<f64>()
            * h
    }

    #[test]
    fn half_film_integrals_match_quadrature() {
        for &ratio in &[0.0, 0.2, 0.6, 0.9] {
            for &(w_u, w_t) in &[(0.0, -1.0), (0.7, -0.3), (-0.4, 0.5), (1.0, 0.0), (-0.2, -0.9)] {
                let h = Integrals::half_film(ratio, w_u, w_t);
                let start = f64::atan2(w_u, -w_t);
                let check = |got: f64, f: &dyn Fn(f64) -> f64, what: &str| {
                    let want = quadrature(ratio, start, f);
                    assert!(
                        (got - want).abs() <= 1e-7 * (1.0 + want.abs()),
                        "{what} ε {ratio} w ({w_u}, {w_t}): {got} vs {want}"
                    );
                };
                check(h.cc, &|t| t.cos().powi(2), "cc");
                check(h.sc, &|t| t.sin() * t.cos(), "sc");
                check(h.ss, &|t| t.sin().powi(2), "ss");
                check(h.c, &|t| t.cos(), "c");
                check(h.s, &|t| t.sin(), "s");
            }
        }
    }

    #[test]
    fn arc_integrals_match_quadrature() {
        let on = |ratio: f64, from: f64, to: f64, f: &dyn Fn(f64) -> f64| {
            let n = 40_000;
            let h = (to - from) / n as f64;
            (0..n).map(|i| from + (i as f64 + 0.5) * h).map(|t| f(t) / (1.0 + ratio * t.cos()).powi(3)).sum::<f64>() * h
        };
        for &ratio in &[0.0, 0.3, 0.9] {
            for &(from, to) in &[(0.1, 0.2), (-1.0, 2.5), (2.0, 7.0), (3.0, 3.0 + 2.0 * PI), (5.5, 6.5)] {
                let i = Integrals::arc(ratio, from, to);
                for (got, f) in [
                    (i.cc, &(|t: f64| t.cos().powi(2)) as &dyn Fn(f64) -> f64),
                    (i.sc, &|t: f64| t.sin() * t.cos()),
                    (i.ss, &|t: f64| t.sin().powi(2)),
                    (i.c, &|t: f64| t.cos()),
                    (i.s, &|t: f64| t.sin()),
                ] {
                    let want = on(ratio, from, to, f);
                    assert!(
                        (got - want).abs() <= 1e-7 * (1.0 + want.abs()),
                        "ε {ratio} ({from}, {to}): {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn lanes_get_the_scalar_bits() {
        use lash_core::lane::{F64x8, LANES};
        let film = Film { viscosity: 0.04, length: 0.02, bearing: BearingLength::Long, mixed_fraction: 0.05 };
        let ex = [0.0, 1e-5, -3e-5, 4e-5, 9e-6, 0.0, 2e-5, -4.9e-5];
        let ey = [0.0, 2e-5, 1e-5, -1e-5, 0.0, 3e-5, -2e-5, 0.0];
        let vx = [0.1, -0.2, 0.0, 0.05, 0.3, 0.0, -0.01, 0.2];
        let vy = [0.0, 0.1, -0.3, 0.02, 0.0, 0.0, 0.4, -0.1];
        let rate = [50.0, -20.0, 0.0, 10.0, 100.0, 0.0, 5.0, -75.0];
        for bearing in [BearingLength::Short, BearingLength::Long] {
            let film = Film { bearing, ..film };
            let lanes = film.force((0.01, 5e-5), [F64x8(ex), F64x8(ey)], [F64x8(vx), F64x8(vy)], F64x8(rate));
            for l in 0..LANES {
                let one = film.force((0.01, 5e-5), [ex[l], ey[l]], [vx[l], vy[l]], rate[l]);
                assert_eq!([lanes[0][l].to_bits(), lanes[1][l].to_bits()], [one[0].to_bits(), one[1].to_bits()]);
            }
        }
    }
}
