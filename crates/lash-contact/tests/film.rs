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

/// The film's load and attitude against `closed` (ε → load, attitude) over ε = 0.1…0.95, with
/// the line of centres along each of `angles`.
fn matches_in_steady_running(bearing: BearingLength, angles: [f64; 3], closed: impl Fn(f64) -> (f64, f64)) {
    for k in 0..18 {
        let eps = 0.1 + 0.05 * k as f64;
        let (load, attitude) = closed(eps);
        for angle in angles {
            let (got, phi) = load_and_attitude(bearing, eps, angle);
            assert!((got / load - 1.0).abs() < 1e-10, "ε {eps}: load {got} vs {load}");
            assert!((phi - attitude).abs() < 1e-10, "ε {eps}: attitude {phi} vs {attitude}");
        }
    }
}

#[test]
fn short_bearing_matches_ocvirk() {
    let u = RADIUS * OMEGA;
    matches_in_steady_running(BearingLength::Short, [0.0, 2.0, -2.7], |eps| {
        let q = 1.0 - eps * eps;
        let load = VISCOSITY * u * LENGTH.powi(3) / (4.0 * CLEARANCE.powi(2)) * eps / q.powi(2)
            * (PI * PI * q + 16.0 * eps * eps).sqrt();
        (load, (PI * q.sqrt() / (4.0 * eps)).atan())
    });
}

#[test]
fn long_bearing_matches_half_sommerfeld() {
    let u = RADIUS * OMEGA;
    matches_in_steady_running(BearingLength::Long, [0.0, 1.1, 3.0], |eps| {
        let q = 1.0 - eps * eps;
        let scale = VISCOSITY * u * RADIUS * RADIUS * LENGTH / (CLEARANCE * CLEARANCE * (2.0 + eps * eps));
        let (radial, tangential) = (12.0 * scale * eps * eps / q, 6.0 * PI * scale * eps / q.sqrt());
        (radial.hypot(tangential), (PI * q.sqrt() / (2.0 * eps)).atan())
    });
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

/// A journal of 0.1 kg spinning at ω in a fixed short bearing, pushed by a constant load W from
/// the centre: its orbit settles where the film carries the load — at the eccentricity ratio
/// whose Ocvirk load capacity is W (found here by bisection on the textbook formula), with the
/// line of centres turned from the load line by the attitude angle, in the sense of rotation.
#[test]
fn a_loaded_journal_settles_at_the_static_equilibrium() {
    let film = film(BearingLength::Short);
    let (mass, load) = (0.1, 9.0);
    let capacity = |eps: f64| {
        let q = 1.0 - eps * eps;
        VISCOSITY * RADIUS * OMEGA * LENGTH.powi(3) / (4.0 * CLEARANCE.powi(2)) * eps / q.powi(2)
            * (PI * PI * q + 16.0 * eps * eps).sqrt()
    };
    let (mut lo, mut hi) = (0.0, 0.99);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if capacity(mid) < load { lo = mid } else { hi = mid }
    }
    let eps = 0.5 * (lo + hi);
    let attitude = (PI * (1.0 - eps * eps).sqrt() / (4.0 * eps)).atan();
    // RK4 on (e, ė), the load along −y.
    let accel = |e: [f64; 2], v: [f64; 2]| {
        let f = film.force((RADIUS, CLEARANCE), e, v, OMEGA / 2.0);
        [f[0] / mass, (f[1] - load) / mass]
    };
    let (mut e, mut v, h) = ([0.0; 2], [0.0; 2], 1e-5);
    let add = |a: [f64; 2], b: [f64; 2], k: f64| [a[0] + k * b[0], a[1] + k * b[1]];
    for _ in 0..20_000 {
        let k1 = (v, accel(e, v));
        let k2 = (add(v, k1.1, h / 2.0), accel(add(e, k1.0, h / 2.0), add(v, k1.1, h / 2.0)));
        let k3 = (add(v, k2.1, h / 2.0), accel(add(e, k2.0, h / 2.0), add(v, k2.1, h / 2.0)));
        let k4 = (add(v, k3.1, h), accel(add(e, k3.0, h), add(v, k3.1, h)));
        for i in 0..2 {
            e[i] += h / 6.0 * (k1.0[i] + 2.0 * k2.0[i] + 2.0 * k3.0[i] + k4.0[i]);
            v[i] += h / 6.0 * (k1.1[i] + 2.0 * k2.1[i] + 2.0 * k3.1[i] + k4.1[i]);
        }
    }
    let ratio = e[0].hypot(e[1]) / CLEARANCE;
    // The angle from the load line (−y) to e, positive counter-clockwise (the journal's sense).
    let turned = e[1].atan2(e[0]) + PI / 2.0;
    assert!((ratio - eps).abs() < 1e-6, "ε {ratio} vs {eps}");
    assert!((turned - attitude).abs() < 1e-6, "attitude {turned} vs {attitude}");
    assert!(v[0].hypot(v[1]) < 1e-9, "still moving: {v:?}");
}
