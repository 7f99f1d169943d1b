//! Mechanisms with closed-form answers: the ideal slider-crank at its dead centres, the driver
//! torque against the rate of kinetic energy, a block on an inclined guide, and a bead on a
//! spinning rod.

use lash_mech::*;
use std::f64::consts::PI;

mod common;
use common::*;

#[test]
fn slider_acceleration_at_dead_centres_matches_closed_form() {
    let m = ideal_slider_crank();
    assert!(m.validate().is_empty());
    let mut s = Solver::new(&m);
    let (mut q, _) = kinematics::initial_guess(&m);
    // Crank angle 0: a = −ω² L1 (1 + L1/L2).
    analyse(&m, &mut s, &mut q, 0.0);
    let expected = -OMEGA * OMEGA * L1 * (1.0 + L1 / L2);
    assert!((s.accelerations[6] / expected - 1.0).abs() < 1e-9, "{} vs {expected}", s.accelerations[6]);
    // Crank angle 180°: a = ω² L1 (1 − L1/L2). Start the assembly from a rough guess.
    q.copy_from_slice(&[-0.02, 0.001, 3.1, 0.03, -0.002, 0.01, 0.06, 0.0, 0.0]);
    analyse(&m, &mut s, &mut q, PI / OMEGA);
    let expected = OMEGA * OMEGA * L1 * (1.0 - L1 / L2);
    assert!((s.accelerations[6] / expected - 1.0).abs() < 1e-9, "{} vs {expected}", s.accelerations[6]);
    assert!((q[6] - (L2 - L1)).abs() < 1e-12);
}

#[test]
fn driver_torque_equals_rate_of_kinetic_energy() {
    // torque·ω = dT/dt for a driven mechanism without other loads. dT/dt is computed here from
    // velocities alone (a 5-point central difference of T over the velocity analysis), never
    // from the accelerations or multipliers that produce the torque.
    let m = ideal_slider_crank();
    let mut s = Solver::new(&m);
    let (mut q, _) = kinematics::initial_guess(&m);
    let kinetic = |t: f64, s: &mut Solver, q: &mut Vec<f64>| {
        let qd = analyse(&m, s, q, t);
        kinetic_energy(&m, &qd)
    };
    let period = 2.0 * PI / OMEGA;
    let h = 1e-6;
    let mut peak = 0.0f64;
    let mut worst = 0.0f64;
    for i in 0..72 {
        let t = period * i as f64 / 72.0 + 1e-5;
        let e: Vec<f64> = [-2.0, -1.0, 1.0, 2.0].iter().map(|k| kinetic(t + k * h, &mut s, &mut q)).collect();
        let rate = (e[0] - 8.0 * e[1] + 8.0 * e[2] - e[3]) / (12.0 * h);
        analyse(&m, &mut s, &mut q, t);
        let power = driver_torque(&m, &s, 0) * OMEGA;
        peak = peak.max(power.abs());
        worst = worst.max((power - rate).abs());
    }
    assert!(peak > 100.0, "power peak {peak} W: the test must exercise a real load");
    assert!(worst < 1e-6 * peak, "max |torque·ω − dT/dt| = {worst} W of peak {peak} W");
}

#[test]
fn block_on_inclined_guide_accelerates_with_g_sin_alpha() {
    use BodyId::*;
    let alpha: f64 = 0.3;
    let m = Mechanism {
        bodies: vec![body("block", 2.0, 0.1, 0.0, 0.0, 0.2)],
        joints: vec![Joint {
            name: "guide".into(),
            kind: JointKind::Prismatic { axis_j: Vec2::new(alpha.cos(), alpha.sin()), angle_offset: 0.2 },
            body_i: Body(0),
            point_i: Vec2::new(0.05, -0.02),
            body_j: Ground,
            // The body point A(0.2)·(0.05, −0.02) lies on the guide line through this point.
            point_j: Vec2::new(0.05 * 0.2f64.cos() + 0.02 * 0.2f64.sin(), 0.05 * 0.2f64.sin() - 0.02 * 0.2f64.cos())
                + Vec2::new(alpha.cos(), alpha.sin()) * 0.37,
        }],
        drivers: vec![],
        loads: vec![],
        gravity: Vec2::new(0.0, -9.81),
        baumgarte: Baumgarte::default(),
    };
    let mut s = Solver::new(&m);
    let q = [0.0, 0.0, 0.2];
    let qd = [0.3 * alpha.cos(), 0.3 * alpha.sin(), 0.0];
    s.accelerations(&m, 0.0, &q, &qd, |_| {}).unwrap();
    let along = s.accelerations[0] * alpha.cos() + s.accelerations[1] * alpha.sin();
    assert!((along + 9.81 * alpha.sin()).abs() < 1e-12, "{along}");
    // Normal reaction of the guide: m g cos α, perpendicular to it.
    let r = joint_reaction(&m, &s, 0);
    assert!((r.norm() - 2.0 * 9.81 * alpha.cos()).abs() < 1e-10, "{r:?}");
}

#[test]
fn bead_on_spinning_rod_follows_cosh() {
    // A rod driven at ω about the origin; a bead slides freely along it: r̈ = ω² r, so from rest
    // relative to the rod r(t) = r0 cosh(ωt). Integrated with the library's RK4 and DOPRI5 over the
    // mechanism's own equations of motion (a prismatic joint between two moving bodies).
    use BodyId::*;
    let w = 3.0;
    let r0 = 0.1;
    let m = Mechanism {
        bodies: vec![body("rod", 1.0, 0.1, 0.0, 0.0, 0.0), body("bead", 0.2, 1e-3, r0, 0.0, 0.0)],
        joints: vec![
            revolute("pivot", Body(0), [0.0, 0.0], Ground, [0.0, 0.0]),
            Joint {
                name: "slide".into(),
                kind: JointKind::Prismatic { axis_j: Vec2::new(1.0, 0.0), angle_offset: 0.0 },
                body_i: Body(1),
                point_i: Vec2::zeros(),
                body_j: Body(0),
                point_j: Vec2::zeros(),
            },
        ],
        drivers: vec![Driver {
            name: "spin".into(),
            body: Body(0),
            reference: Ground,
            motion: Motion::ConstantSpeed { angle0: 0.0, omega: w },
        }],
        loads: vec![],
        gravity: Vec2::zeros(),
        baumgarte: Baumgarte { alpha: 0.0, beta: 0.0 },
    };
    let mut s = Solver::new(&m);
    let (mut q, mut qd) = kinematics::initial_guess(&m);
    assemble(&m, 0.0, &mut q, &mut s, 1e-14).unwrap();
    velocity_analysis(&m, 0.0, &q, &mut qd, &mut s).unwrap();
    struct Sys<'a> {
        m: &'a Mechanism,
        s: Solver,
    }
    impl lash_ode::OdeSystem for Sys<'_> {
        fn dim(&self) -> usize {
            12
        }
        fn rhs(&mut self, t: f64, y: &[f64], d: &mut [f64]) {
            let (q, qd) = y.split_at(6);
            self.s.accelerations(self.m, t, q, qd, |_| {}).unwrap();
            d[..6].copy_from_slice(qd);
            d[6..].copy_from_slice(&self.s.accelerations);
        }
    }
    let t_end = 1.0;
    for method in [
        lash_ode::Method::Rk4 { step: 1e-3 },
        lash_ode::Method::Dopri5(lash_ode::AdaptiveOptions { rtol: 1e-11, atol: 1e-13, ..Default::default() }),
    ] {
        let mut y: Vec<f64> = q.iter().chain(qd.iter()).copied().collect();
        let mut sys = Sys { m: &m, s: Solver::new(&m) };
        lash_ode::integrate(&method, &mut sys, 0.0, &mut y, t_end, 0.5, &mut |_: &mut Sys, _: f64, _: &[f64]| Ok(()))
            .unwrap();
        let r = y[3].hypot(y[4]);
        let expected = r0 * (w * t_end).cosh();
        assert!((r / expected - 1.0).abs() < 1e-8, "{method:?}: r = {r}, expected {expected}");
        // Still on the rod: the bead's angle follows the driver.
        assert!((y[4].atan2(y[3]) - w * t_end).abs() < 1e-8);
    }
}

#[test]
fn applied_loads_and_revolute_reaction() {
    use BodyId::*;
    // A rod (m, I about its centroid) pinned to the ground at its end, at rest, horizontal, under
    // gravity, a torque τ and a vertical tip force F: the angular acceleration about the pin is
    // (τ + F·L − m g L/2) / (I + m L²/4), and the pin carries the rest of the load.
    let (m, i, l, tau, f, g) = (2.0, 0.05, 0.6, 3.0, 4.0, 9.81);
    let mech = Mechanism {
        bodies: vec![body("rod", m, i, l / 2.0, 0.0, 0.0)],
        joints: vec![revolute("pin", Body(0), [-l / 2.0, 0.0], Ground, [0.0, 0.0])],
        drivers: vec![],
        loads: vec![
            Load::Torque { body: 0, torque: tau },
            Load::Force { body: 0, point: Vec2::new(l / 2.0, 0.0), force: Vec2::new(0.0, f) },
        ],
        gravity: Vec2::new(0.0, -g),
        baumgarte: Baumgarte::default(),
    };
    assert!(mech.validate().is_empty());
    let mut s = Solver::new(&mech);
    s.accelerations(&mech, 0.0, &[l / 2.0, 0.0, 0.0], &[0.0; 3], |_| {}).unwrap();
    let alpha = (tau + f * l - m * g * l / 2.0) / (i + m * l * l / 4.0);
    assert!((s.accelerations[2] - alpha).abs() < 1e-12 * alpha.abs().max(1.0), "{} vs {alpha}", s.accelerations[2]);
    // Centroid acceleration of a pinned rod at rest: a = α × r = (0, α L/2).
    assert!((s.accelerations[1] - alpha * l / 2.0).abs() < 1e-12);
    // Newton for the rod: m a = F_pin + F + m g ⇒ F_pin = m a − F − m g.
    let r = joint_reaction(&mech, &s, 0);
    assert!(r.x.abs() < 1e-12);
    assert!((r.y - (m * alpha * l / 2.0 - f + m * g)).abs() < 1e-10, "{r:?}");
}

/// The position-and-velocity analysis of the kinematic macro equals assembly followed by velocity
/// analysis, bit for bit, over a turn of the slider-crank stepped from a Taylor-like prediction
/// (the Newton iterations and the projection see the same numbers), and the solver holds the
/// assembled position's constraint error.
#[test]
fn assembly_and_projection_together_equal_them_one_after_the_other() {
    let m = ideal_slider_crank();
    let (mut q1, mut qd1) = initial_guess(&m);
    let (mut q2, mut qd2) = (q1.clone(), qd1.clone());
    let (mut s1, mut s2) = (Solver::new(&m), Solver::new(&m));
    let h = 2.0 * PI / OMEGA / 40.0;
    for k in 0..=40 {
        let t = k as f64 * h;
        // A prediction of the next position, off the constraint manifold.
        for q in [&mut q1, &mut q2] {
            for (x, v) in q.iter_mut().zip(&qd1) {
                *x += h * v;
            }
        }
        let iterations = assemble(&m, t, &mut q1, &mut s1, 1e-13).expect("assembles");
        velocity_analysis(&m, t, &q1, &mut qd1, &mut s1).expect("projects");
        let together = assemble_and_project(&m, t, &mut q2, &mut qd2, &mut s2, 1e-13).expect("assembles");
        assert_eq!(together, iterations, "t = {t}");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&q2), bits(&q1), "positions at t = {t}");
        assert_eq!(bits(&qd2), bits(&qd1), "velocities at t = {t}");
        s1.set_state(&m, t, &q1, &qd1);
        assert_eq!(s2.constraint_error().to_bits(), s1.constraint_error().to_bits(), "Φ at t = {t}");
        assert!(s2.constraint_error() <= 1e-13);
    }
}
