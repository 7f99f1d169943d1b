//! The film forces in steady running against the textbook closed forms of the short (Ocvirk)
//! and half-Sommerfeld long bearing: load capacity and attitude angle over ε = 0.1…0.95,
//! written here from the classic load formulas, not from the module's integrals.

use lash_contact::film::{BearingLength, Film};
use std::f64::consts::PI;

const RADIUS: f64 = 0.01;
const CLEARANCE: f64 = 5e-5;
const LENGTH: f64 = 0.008;
const VISCOSITY: f64 = 0.04;
/// The journal's speed; the bearing stands still, so ω̄ = ω/2 and U = R ω.
const OMEGA: f64 = 150.0;

fn film(bearing: BearingLength) -> Film {
    Film { viscosity: VISCOSITY, length: LENGTH, bearing, mixed_fraction: 0.01 }
}

/// The load (its magnitude) and attitude angle (between the load line and the line of centres)
/// of the film at eccentricity ratio ε along a direction `angle`.
fn load_and_attitude(bearing: BearingLength, ratio: f64, angle: f64) -> (f64, f64) {
    let u = [angle.cos(), angle.sin()];
    let e = [ratio * CLEARANCE * u[0], ratio * CLEARANCE * u[1]];
    let f = film(bearing).force((RADIUS, CLEARANCE), e, [0.0, 0.0], OMEGA / 2.0);
    // The film pushes the journal back: the load it carries is −f.
    let along = -(f[0] * u[0] + f[1] * u[1]);
    let across = -(f[1] * u[0] - f[0] * u[1]);
    (along.hypot(across), (-across).atan2(along))
}

#[test]
fn short_bearing_matches_ocvirk() {
    let u = RADIUS * OMEGA;
    for k in 0..18 {
        let eps = 0.1 + 0.05 * k as f64;
        let q = 1.0 - eps * eps;
        let load = VISCOSITY * u * LENGTH.powi(3) / (4.0 * CLEARANCE.powi(2)) * eps / q.powi(2)
            * (PI * PI * q + 16.0 * eps * eps).sqrt();
        let attitude = (PI * q.sqrt() / (4.0 * eps)).atan();
        for angle in [0.0, 2.0, -2.7] {
            let (got, phi) = load_and_attitude(BearingLength::Short, eps, angle);
            assert!((got / load - 1.0).abs() < 1e-10, "ε {eps}: load {got} vs {load}");
            assert!((phi - attitude).abs() < 1e-10, "ε {eps}: attitude {phi} vs {attitude}");
        }
    }
}

#[test]
fn long_bearing_matches_half_sommerfeld() {
    let u = RADIUS * OMEGA;
    for k in 0..18 {
        let eps = 0.1 + 0.05 * k as f64;
        let q = 1.0 - eps * eps;
        let scale = VISCOSITY * u * RADIUS * RADIUS * LENGTH / (CLEARANCE * CLEARANCE * (2.0 + eps * eps));
        let (radial, tangential) = (12.0 * scale * eps * eps / q, 6.0 * PI * scale * eps / q.sqrt());
        let attitude = (PI * q.sqrt() / (2.0 * eps)).atan();
        for angle in [0.0, 1.1, 3.0] {
            let (got, phi) = load_and_attitude(BearingLength::Long, eps, angle);
            let load = radial.hypot(tangential);
            assert!((got / load - 1.0).abs() < 1e-10, "ε {eps}: load {got} vs {load}");
            assert!((phi - attitude).abs() < 1e-10, "ε {eps}: attitude {phi} vs {attitude}");
        }
    }
}

/// A journal squeezed straight towards the bearing without rotation: the film's half is the one
/// around the thinnest film (θ from π/2 to 3π/2), where ∫ cos²θ/(1 + ε cos θ)³ dθ =
/// [(1 + 2ε²)(π/2 + arcsin ε) + 3ε√(1 − ε²)] / (1 − ε²)^{5/2}, so F = μ R L³ (ε̇/c²) times that,
/// against the motion (the classic π-film from the line of centres, with π/2 in place of
/// π/2 + arcsin ε and no 3ε√(1 − ε²), would be low by up to a third at ε = 0.3).
#[test]
fn short_bearing_squeeze_matches_its_closed_form() {
    for &eps in &[0.0_f64, 0.3, 0.8] {
        let speed = 0.02;
        let f = film(BearingLength::Short).force((RADIUS, CLEARANCE), [eps * CLEARANCE, 0.0], [speed, 0.0], 0.0);
        let q = 1.0 - eps * eps;
        let integral = ((1.0 + 2.0 * eps * eps) * (PI / 2.0 + eps.asin()) + 3.0 * eps * q.sqrt()) / q.powf(2.5);
        let want = VISCOSITY * RADIUS * LENGTH.powi(3) * speed / (CLEARANCE * CLEARANCE * CLEARANCE) * integral;
        assert!((-f[0] / want - 1.0).abs() < 1e-10 && f[1].abs() < 1e-12 * want, "ε {eps}: {f:?} vs {want}");
    }
}

/// Beyond the mixed-lubrication limit the force is the limit's, continuous across it.
#[test]
fn the_film_force_is_held_at_the_mixed_limit() {
    let f = Film { mixed_fraction: 0.1, ..film(BearingLength::Short) };
    let at = |ratio: f64| f.force((RADIUS, CLEARANCE), [ratio * CLEARANCE, 0.0], [0.001, 0.0], 40.0);
    let (below, limit, beyond) = (at(0.9 - 1e-12), at(0.9), at(1.05));
    assert_eq!(limit, beyond);
    assert!((below[0] / limit[0] - 1.0).abs() < 1e-9 && (below[1] / limit[1] - 1.0).abs() < 1e-9);
}

#[test]
fn bad_film_numbers_are_named() {
    let f = Film { viscosity: -1.0, length: 0.0, bearing: BearingLength::Short, mixed_fraction: 1.0 };
    let text = f.validate().to_string();
    for field in ["viscosity", "length", "mixed_fraction"] {
        assert!(text.contains(field), "{text}");
    }
}
