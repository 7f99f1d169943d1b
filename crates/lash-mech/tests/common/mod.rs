//! Reference mechanisms shared by the tests.
#![allow(dead_code)]

use lash_mech::*;
use std::f64::consts::PI;

pub const L1: f64 = 0.05;
pub const L2: f64 = 0.12;
pub const OMEGA: f64 = 5000.0 * 2.0 * PI / 60.0;

pub fn body(name: &str, mass: f64, inertia: f64, x: f64, y: f64, angle: f64) -> Body {
    Body {
        name: name.into(),
        mass,
        inertia,
        position: Vec2::new(x, y),
        angle,
        velocity: Vec2::zeros(),
        angular_velocity: 0.0,
    }
}

pub fn revolute(name: &str, bi: BodyId, pi: [f64; 2], bj: BodyId, pj: [f64; 2]) -> Joint {
    Joint {
        name: name.into(),
        kind: JointKind::Revolute,
        body_i: bi,
        point_i: Vec2::new(pi[0], pi[1]),
        body_j: bj,
        point_j: Vec2::new(pj[0], pj[1]),
    }
}

/// Scenario B's mechanism with all joints ideal (docs/validation.md).
pub fn ideal_slider_crank() -> Mechanism {
    use BodyId::*;
    Mechanism {
        bodies: vec![
            body("crank", 0.17, 1.0e-4, L1 / 2.0, 0.0, 0.0),
            body("rod", 0.15, 2.5e-4, L1 + L2 / 2.0, 0.0, 0.0),
            body("slider", 0.06, 1.0e-5, L1 + L2, 0.0, 0.0),
        ],
        joints: vec![
            revolute("crank_pivot", Body(0), [-L1 / 2.0, 0.0], Ground, [0.0, 0.0]),
            revolute("crank_rod", Body(0), [L1 / 2.0, 0.0], Body(1), [-L2 / 2.0, 0.0]),
            revolute("rod_slider", Body(2), [0.0, 0.0], Body(1), [L2 / 2.0, 0.0]),
            Joint {
                name: "guide".into(),
                kind: JointKind::Prismatic { axis_j: Vec2::new(1.0, 0.0), angle_offset: 0.0 },
                body_i: Body(2),
                point_i: Vec2::zeros(),
                body_j: Ground,
                point_j: Vec2::zeros(),
            },
        ],
        drivers: vec![Driver {
            name: "motor".into(),
            body: Body(0),
            reference: Ground,
            motion: Motion::ConstantSpeed { angle0: 0.0, omega: OMEGA },
        }],
        loads: vec![],
        gravity: Vec2::zeros(),
        baumgarte: Baumgarte::default(),
    }
}

/// Kinematic analysis at t: positions, velocities, accelerations and multipliers.
pub fn analyse(m: &Mechanism, s: &mut Solver, q: &mut [f64], t: f64) -> Vec<f64> {
    assemble(m, t, q, s, 1e-14).unwrap();
    let mut qd = vec![0.0; q.len()];
    velocity_analysis(m, t, q, &mut qd, s).unwrap();
    s.accelerations(m, t, q, &qd, |_| {}).unwrap();
    qd
}

/// (cut mechanism, ideal mechanism, interface) with the clearance at joint `name` of the ideal
/// slider-crank; the journal is the joint's body_i.
pub fn cut(name: &str) -> (Mechanism, Mechanism, Interface) {
    let ideal = ideal_slider_crank();
    let k = ideal.joints.iter().position(|j| j.name == name).unwrap();
    let j = ideal.joints[k].clone();
    let mut cut = ideal.clone();
    cut.joints.remove(k);
    // The ideal mechanism with the interface joint last, journal as its body_i.
    let mut ideal_last = cut.clone();
    ideal_last.joints.push(j.clone());
    let iface = Interface {
        journal_body: j.body_i,
        journal_point: j.point_i,
        bearing_body: j.body_j,
        bearing_point: j.point_j,
    };
    (cut, ideal_last, iface)
}
