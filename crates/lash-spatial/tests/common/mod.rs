//! Mechanisms shared by the engine's tests.
#![allow(dead_code)]

use lash_spatial::{
    Baumgarte, BodyId, Marker, Motion, Orientation, SpatialBody, SpatialDriver, SpatialJoint, SpatialJointKind,
    SpatialMechanism, Vec3, assemble, velocity_analysis,
};

/// The spatial slider-crank: crank about Y, S–S rod, slider translating along X on the line
/// (0, h, −e). Bodies placed by the closed form at θ0 = asin(e/r); velocities by velocity analysis.
pub fn slider_crank(omega: f64) -> (SpatialMechanism, Vec<f64>) {
    let (r, l, h, e): (f64, f64, f64, f64) = (0.05, 0.25, 0.06, 0.02);
    let theta0 = (e / r).asin();
    let pin = r * Vec3::new(theta0.cos(), 0.0, -theta0.sin());
    let x_s = r * theta0.cos() + (l * l - h * h - (r * theta0.sin() - e).powi(2)).sqrt();
    let ball = Vec3::new(x_s, h, -e);
    let crank_orientation = Orientation::from_axis_angle(&Vec3::y_axis(), theta0);
    let rod_axis = (ball - pin).normalize();
    let rod_orientation = Orientation::rotation_between(&Vec3::x(), &rod_axis).expect("not antiparallel");
    let mut crank =
        SpatialBody::at_rest("crank", 0.30, Vec3::new(1.25e-5, 1.33e-4, 1.33e-4), pin / 2.0, crank_orientation);
    crank.angular_velocity = Vec3::new(0.0, omega, 0.0);
    let rod =
        SpatialBody::at_rest("rod", 0.25, Vec3::new(1.0e-5, 1.30e-3, 1.30e-3), (pin + ball) / 2.0, rod_orientation);
    let slider = SpatialBody::at_rest("slider", 0.60, Vec3::new(1.7e-4, 1.7e-4, 1.7e-4), ball, Orientation::identity());
    let (ground, c, rd, s) = (BodyId::Ground, BodyId::Body(0), BodyId::Body(1), BodyId::Body(2));
    let joints = vec![
        SpatialJoint {
            name: "crank_pivot".into(),
            kind: SpatialJointKind::Revolute,
            i: Marker::oriented(ground, Vec3::zeros(), Vec3::y(), Vec3::x()),
            j: Marker::oriented(c, Vec3::new(-r / 2.0, 0.0, 0.0), Vec3::y(), Vec3::x()),
        },
        SpatialJoint {
            name: "crank_rod".into(),
            kind: SpatialJointKind::Spherical,
            i: Marker::at(c, Vec3::new(r / 2.0, 0.0, 0.0)),
            j: Marker::at(rd, Vec3::new(-l / 2.0, 0.0, 0.0)),
        },
        SpatialJoint {
            name: "rod_slider".into(),
            kind: SpatialJointKind::Spherical,
            i: Marker::at(rd, Vec3::new(l / 2.0, 0.0, 0.0)),
            j: Marker::at(s, Vec3::zeros()),
        },
        SpatialJoint {
            name: "slider_guide".into(),
            kind: SpatialJointKind::Translational,
            i: Marker::oriented(ground, Vec3::new(0.0, h, -e), Vec3::x(), Vec3::y()),
            j: Marker::oriented(s, Vec3::zeros(), Vec3::x(), Vec3::y()),
        },
    ];
    let mech = SpatialMechanism {
        bodies: vec![crank, rod, slider],
        joints,
        drivers: vec![SpatialDriver {
            name: "motor".into(),
            joint: 0,
            motion: Motion::ConstantSpeed { angle0: theta0, omega },
        }],
        loads: vec![],
        gravity: Vec3::new(0.0, -9.81, 0.0),
        baumgarte: Baumgarte::default(),
    };
    let problems = mech.validate();
    assert!(problems.0.is_empty(), "{problems:?}");
    let mut y = mech.initial_state();
    let n = mech.coordinate_count();
    let (q, v) = y.split_at_mut(n);
    assert_eq!(assemble(&mech, 0.0, q, 1e-13).expect("assembles"), 0, "the closed-form pose is assembled");
    velocity_analysis(&mech, 0.0, q, v).expect("velocities");
    (mech, y)
}
