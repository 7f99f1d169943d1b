//! The translational clearance joint through the library's full model and adaptive integrator,
//! against computations of its own: a block dropped flat (Hertz's closed form for the deepest
//! penetration, a 1-DOF integration here for the duration), dropped on a corner (the rigid-body
//! impulse through the corner's effective mass), energy kept without damping over many impacts,
//! a block sliding on its face under Coulomb friction (μ g and the tilt that carries the
//! friction's moment), and a driven slider-crank whose slider trajectory tends to the ideal prismatic joint's as the
//! clearance goes to zero.

use lash_contact::translational::{Block, Guide};
use lash_contact::{FrictionLaw, NormalForce, TranslationalClearance};
use lash_full_model::FullModel;
use lash_mech::{Baumgarte, Body, BodyId, Driver, Joint, JointKind, Mechanism, Motion, Pose, Vec2};
use lash_ode::{AdaptiveOptions, Method, integrate};

const A: f64 = 0.05;
const B: f64 = 0.025;
const C: f64 = 0.001;
const MASS: f64 = 0.5;

fn inertia() -> f64 {
    MASS * (4.0 * A * A + 4.0 * B * B) / 12.0
}

fn slot(body: BodyId, clearance: f64, law: NormalForce) -> TranslationalClearance {
    TranslationalClearance::new(
        "slot",
        Block { body, centre: Vec2::zeros(), axis: Vec2::new(1.0, 0.0), half_length: A, half_height: B },
        Guide { body: BodyId::Ground, point: Vec2::zeros(), axis: Vec2::new(1.0, 0.0) },
        clearance,
        law,
        FrictionLaw::None,
    )
}

/// A free block in a fixed horizontal guide, no gravity.
fn free_block(law: NormalForce) -> FullModel {
    let mech = Mechanism {
        bodies: vec![Body {
            name: "block".into(),
            mass: MASS,
            inertia: inertia(),
            position: Vec2::zeros(),
            angle: 0.0,
            velocity: Vec2::zeros(),
            angular_velocity: 0.0,
        }],
        joints: vec![],
        drivers: vec![],
        loads: vec![],
        gravity: Vec2::zeros(),
        baumgarte: Baumgarte::default(),
    };
    FullModel::new(mech, vec![]).with_slots(vec![slot(BodyId::Body(0), C, law)])
}

fn tight() -> Method {
    Method::Dopri5(AdaptiveOptions { rtol: 1e-11, atol: 1e-14, initial_step: 1e-7, max_step: 1e-4, min_step: 1e-13 })
}

/// Runs `model` from `y` to `t_end`, calling `each` at every output sample.
fn run(model: &mut FullModel, y: &mut [f64], t_end: f64, interval: f64, each: &mut dyn FnMut(&FullModel, &[f64])) {
    integrate(&tight(), model, 0.0, y, t_end, interval, &mut |m: &mut FullModel, _: f64, y: &[f64]| {
        each(m, y);
        Ok(())
    })
    .unwrap();
}

#[test]
fn a_block_dropped_flat_lands_on_both_bottom_corners_as_hertz_predicts() {
    let k = 1e9;
    let v0 = 0.5;
    let mut model = free_block(NormalForce::Power { stiffness: k, exponent: 1.5 });
    // Centred, sliding along the guide at 0.3 m/s and falling at v0.
    let mut y = vec![0.0, 0.0, 0.0, 0.3, -v0, 0.0];
    model.reset(0.0, &y);
    let t_end = C / v0 + 1e-3;
    run(&mut model, &mut y, t_end, t_end, &mut |_, _| {});
    let impacts = model.impacts();
    assert!(impacts[0].is_empty() && impacts[1].is_empty(), "top corners touched");
    assert_eq!((impacts[2].len(), impacts[3].len()), (1, 1));
    // Two corners of stiffness K share the load: m δ̈ = −2K δ^1.5, whose deepest point is
    // (5 m v0² / (8K))^(2/5).
    let deepest = (5.0 * MASS * v0 * v0 / (8.0 * k)).powf(0.4);
    // Its duration from the same 1-DOF equation, integrated here with a fixed-step RK4.
    let duration = one_dof_duration(|d| 2.0 * k * d.powf(1.5) / MASS, v0);
    for i in [2, 3] {
        let hit = impacts[i][0];
        assert!((hit.max_penetration / deepest - 1.0).abs() < 1e-6, "{} vs {deepest}", hit.max_penetration);
        assert!((hit.duration / duration - 1.0).abs() < 1e-6, "{} vs {duration}", hit.duration);
        assert!((hit.onset_time - C / v0).abs() < 1e-12);
    }
    // Elastic, frictionless and flat: it leaves at v0, still sliding at 0.3 m/s, without a turn.
    assert!((y[4] - v0).abs() < 1e-7 * v0, "{}", y[4]);
    assert!((y[3] - 0.3).abs() < 1e-12 && y[5].abs() < 1e-9 && y[2].abs() < 1e-12, "{y:?}");
}

/// The time a body entering a contact at `v0` stays in it, δ̈ = −accel(δ), by RK4 at a step of
/// 1/20000 of a first guess of the duration.
fn one_dof_duration(accel: impl Fn(f64) -> f64, v0: f64) -> f64 {
    let f = |s: [f64; 2]| [s[1], -accel(s[0].max(0.0))];
    let guess = {
        // A first pass to size the step.
        let mut s = [0.0, v0];
        let h = 1e-8;
        let mut t = 0.0;
        while s[0] >= 0.0 || t == 0.0 {
            let d = f(s);
            s = [s[0] + h * d[0], s[1] + h * d[1]];
            t += h;
        }
        t
    };
    let h = guess / 20000.0;
    let (mut s, mut t) = ([0.0, v0], 0.0);
    loop {
        let k1 = f(s);
        let k2 = f([s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1]]);
        let k3 = f([s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1]]);
        let k4 = f([s[0] + h * k3[0], s[1] + h * k3[1]]);
        let next = [
            s[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            s[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
        ];
        if next[0] < 0.0 {
            // Linear interpolation of the exit inside the last step.
            return t + h * s[0] / (s[0] - next[0]);
        }
        (s, t) = (next, t + h);
    }
}

#[test]
fn a_tilted_block_dropped_on_its_corner_rebounds_as_the_rigid_impulse_predicts() {
    let k = 1e8;
    let v0 = 0.5;
    let theta = 0.01;
    let mut model = free_block(NormalForce::KelvinVoigt { stiffness: k, damping: 0.0 });
    // Front up: the rear bottom corner (4th) is the lowest.
    let mut y = vec![0.0, 0.0, theta, 0.0, -v0, 0.0];
    model.reset(0.0, &y);
    let arm = Vec2::new(-A * theta.cos() + B * theta.sin(), -A * theta.sin() - B * theta.cos());
    // The corner's height above the bottom face, at −(b + c).
    let gap = arm.y + B + C;
    // The corner's effective mass along the face normal (0, 1): 1/m + (r × n)²/I, r × n = r_x.
    let effective = 1.0 / (1.0 / MASS + arm.x * arm.x / inertia());
    let duration = std::f64::consts::PI * (effective / k).sqrt();
    let t_end = gap / v0 + 1.5 * duration;
    run(&mut model, &mut y, t_end, t_end, &mut |_, _| {});
    let impacts = model.impacts();
    assert_eq!(impacts.iter().map(Vec::len).collect::<Vec<_>>(), [0, 0, 0, 1]);
    let hit = impacts[3][0];
    assert!((hit.onset_time - gap / v0).abs() < 1e-12, "{} vs {}", hit.onset_time, gap / v0);
    // An elastic impulse P = 2 m_eff v0 along +y at the corner.
    let impulse = 2.0 * effective * v0;
    let (vy, omega) = (-v0 + impulse / MASS, impulse * arm.x / inertia());
    // The block turns by ω T/2 ≈ 1e-4 rad during the contact: the closed form holds to ~1e-4.
    assert!((hit.duration / duration - 1.0).abs() < 1e-3, "{} vs {duration}", hit.duration);
    assert!((y[4] - vy).abs() < 1e-3 * v0, "vy {} vs {vy}", y[4]);
    assert!((y[5] - omega).abs() < 1e-3 * omega.abs(), "ω {} vs {omega}", y[5]);
    assert!(y[3].abs() < 1e-12, "frictionless: no push along the guide");
}

#[test]
fn without_damping_or_friction_a_rattling_block_keeps_its_energy() {
    let k = 1e9;
    let law = NormalForce::Power { stiffness: k, exponent: 1.5 };
    let mut model = free_block(law);
    let mut y = vec![0.0, 0.0, 0.0, 0.4, -0.3, 2.0];
    model.reset(0.0, &y);
    let energy = |m: &FullModel, y: &[f64]| {
        let kinetic = 0.5 * MASS * (y[3] * y[3] + y[4] * y[4]) + 0.5 * inertia() * y[5] * y[5];
        let block = Pose::of(BodyId::Body(0), &y[..3], &y[3..6]);
        let elastic: f64 = m.slots[0]
            .evaluate(&block, &Pose::GROUND)
            .corners
            .iter()
            .map(|c| if c.penetration > 0.0 { k * c.penetration.powf(2.5) / 2.5 } else { 0.0 })
            .sum();
        kinetic + elastic
    };
    let e0 = energy(&model, &y);
    let mut worst = 0.0f64;
    run(&mut model, &mut y, 0.2, 1e-4, &mut |m, y| worst = worst.max((energy(m, y) / e0 - 1.0).abs()));
    let impacts: usize = model.impacts().iter().map(Vec::len).sum();
    assert!(impacts >= 20, "only {impacts} impacts: the test would prove little");
    assert!(worst < 1e-6, "energy drift {worst:e} over {impacts} impacts");
}

/// A slider-crank driven at 150 rad/s (the crank and rod of Flores, Leine & Glocker's
/// translational-clearance example), its slider either on an ideal prismatic joint or in a guide
/// with clearance `clearance`; returns the slider's x at 1 ms samples over 0.1 s.
fn slider_crank(clearance: Option<f64>) -> Vec<f64> {
    let (l1, l2) = (0.153, 0.306);
    let bar = |name: &str, mass: f64, inertia: f64, x: f64| Body {
        name: name.into(),
        mass,
        inertia,
        position: Vec2::new(x, 0.0),
        angle: 0.0,
        velocity: Vec2::zeros(),
        angular_velocity: 0.0,
    };
    let bodies = vec![
        bar("crank", 0.038, 7.4e-5, l1 / 2.0),
        bar("rod", 0.038, 5.9e-4, l1 + l2 / 2.0),
        bar("slider", 0.076, 2.7e-6, l1 + l2),
    ];
    let pin = |name: &str, i: usize, pi: f64, j: BodyId, pj: f64| Joint {
        name: name.into(),
        kind: JointKind::Revolute,
        body_i: BodyId::Body(i),
        point_i: Vec2::new(pi, 0.0),
        body_j: j,
        point_j: Vec2::new(pj, 0.0),
    };
    let mut joints = vec![
        pin("crank-ground", 0, -l1 / 2.0, BodyId::Ground, 0.0),
        pin("rod-crank", 1, -l2 / 2.0, BodyId::Body(0), l1 / 2.0),
        pin("slider-rod", 2, 0.0, BodyId::Body(1), l2 / 2.0),
    ];
    if clearance.is_none() {
        joints.push(Joint {
            name: "slider-guide".into(),
            kind: JointKind::Prismatic { axis_j: Vec2::new(1.0, 0.0), angle_offset: 0.0 },
            body_i: BodyId::Body(2),
            point_i: Vec2::zeros(),
            body_j: BodyId::Ground,
            point_j: Vec2::zeros(),
        });
    }
    let mech = Mechanism {
        bodies,
        joints,
        drivers: vec![Driver {
            name: "motor".into(),
            body: BodyId::Body(0),
            reference: BodyId::Ground,
            motion: Motion::ConstantSpeed { angle0: 0.0, omega: 150.0 },
        }],
        loads: vec![],
        gravity: Vec2::new(0.0, -9.81),
        baumgarte: Baumgarte::default(),
    };
    // Lankarani–Nikravesh with restitution 0.4 on a stiff corner.
    let law = NormalForce::Hysteresis { stiffness: 1e10, exponent: 1.5, chi: 0.75 * (1.0 - 0.16), floor: 1e-4 };
    let mut model = FullModel::new(mech, vec![]);
    if let Some(c) = clearance {
        model = model.with_slots(vec![TranslationalClearance::new(
            "slider-guide",
            Block {
                body: BodyId::Body(2),
                centre: Vec2::zeros(),
                axis: Vec2::new(1.0, 0.0),
                half_length: A,
                half_height: B,
            },
            Guide { body: BodyId::Ground, point: Vec2::zeros(), axis: Vec2::new(1.0, 0.0) },
            c,
            law,
            FrictionLaw::None,
        )]);
    }
    let mut y = model.initial_state(0.0).unwrap();
    let method = Method::Dopri5(AdaptiveOptions {
        rtol: 1e-8,
        atol: 1e-11,
        initial_step: 1e-6,
        max_step: 1e-4,
        min_step: 1e-13,
    });
    let mut xs = Vec::new();
    integrate(&method, &mut model, 0.0, &mut y, 0.1, 1e-3, &mut |_: &mut FullModel, _: f64, y: &[f64]| {
        xs.push(y[6]);
        Ok(())
    })
    .unwrap();
    xs
}

#[test]
fn as_the_clearance_closes_the_slider_follows_the_ideal_prismatic_joint() {
    let ideal = slider_crank(None);
    let error = |c: f64| {
        let xs = slider_crank(Some(c));
        xs.iter().zip(&ideal).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
    };
    let (coarse, fine) = (error(1e-4), error(1e-5));
    eprintln!("max |x − x_ideal|: {coarse:e} at c = 1e-4, {fine:e} at c = 1e-5");
    // The slider's x moves with its lateral play y as l1 sin θ y / l2, bounded by c: the error
    // falls with c.
    assert!(coarse < 1e-4 && fine < 1e-5, "{coarse:e}, {fine:e}");
    assert!(fine < coarse / 4.0, "{coarse:e} → {fine:e}: no convergence");
}

#[test]
fn a_block_sliding_on_its_face_under_coulomb_friction_slows_at_mu_g() {
    // Resting on the bottom face under gravity (Kelvin–Voigt corners at their static deflection)
    // and sliding at 1 m/s: whatever the friction's moment does to the two corners' share of the
    // weight, their normal forces sum to m g, so the friction μ Σ F_N slows the block at μ g. (With
    // a linear law the tilt moves the two corners' deflections by ±a θ, which cancel in the sum:
    // the centre stays at rest vertically and the deceleration is μ g to rounding.)
    let (k, mu, g, v0) = (1e8, 0.2, 9.81, 1.0);
    let mut model = free_block(NormalForce::KelvinVoigt { stiffness: k, damping: 2.0 * (MASS * k).sqrt() });
    model.mechanism.gravity = Vec2::new(0.0, -g);
    model.slots[0].friction = FrictionLaw::Coulomb { coefficient: mu };
    let sag = MASS * g / (2.0 * k);
    let mut y = vec![0.0, -C - sag, 0.0, v0, 0.0, 0.0];
    model.reset(0.0, &y);
    let t_end = 0.2;
    let mut speeds = Vec::new();
    run(&mut model, &mut y, t_end, 0.05, &mut |_, y| speeds.push(y[3]));
    for (i, v) in speeds.iter().enumerate() {
        let t = 0.05 * i as f64;
        let expected = v0 - mu * g * t;
        assert!((v - expected).abs() < 1e-12 * v0, "t = {t}: {v} vs {expected}");
    }
    let impacts = model.impacts();
    assert!(impacts[0].is_empty() && impacts[1].is_empty(), "the block lifted to the top face");
    // The friction at the bottom face turns the block nose-down with the moment μ m g b, which the
    // corners carry by a force difference K 2a θ over the arm a: θ = −μ m g b / (2 K a²).
    let tilt = -mu * MASS * g * B / (2.0 * k * A * A);
    assert!((y[2] / tilt - 1.0).abs() < 1e-3, "tilt {} vs {tilt}", y[2]);
}
