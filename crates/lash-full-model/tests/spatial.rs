//! The spatial full model: energy balance of a pendulum hanging from a spherical clearance joint.

use lash_contact::{FrictionLaw, NormalForce, SphericalClearance};
use lash_full_model::SpatialFullModel;
use lash_mech::BodyId;
use lash_ode::{AdaptiveOptions, Method, integrate};
use lash_spatial::{Baumgarte, Orientation, SpatialBody, SpatialMechanism, Vec3, kinetic_energy, potential_energy};

const STIFFNESS: f64 = 5.63e10;

/// A 0.3 m rod hanging from a ball (R_J = 5.75 mm) in a socket (R_B = 6 mm) at the origin,
/// tilted and swinging out of plane.
fn pendulum(friction: FrictionLaw) -> SpatialFullModel {
    let l = 0.3;
    let down = Orientation::rotation_between(&Vec3::x(), &-Vec3::y()).expect("rotation");
    let tilt = Orientation::from_axis_angle(&Vec3::z_axis(), 0.5) * down;
    let mut rod =
        SpatialBody::at_rest("rod", 0.4, Vec3::new(2e-5, 3e-3, 3e-3), tilt * Vec3::new(l / 2.0, 0.0, 0.0), tilt);
    rod.angular_velocity = Vec3::new(2.0, 1.0, 3.0);
    let mechanism = SpatialMechanism {
        bodies: vec![rod],
        joints: vec![],
        drivers: vec![],
        loads: vec![],
        gravity: Vec3::new(0.0, -9.81, 0.0),
        baumgarte: Baumgarte::default(),
    };
    let joint = SphericalClearance {
        name: "socket".into(),
        journal_body: BodyId::Body(0),
        journal_point: Vec3::new(-l / 2.0, 0.0, 0.0),
        bearing_body: BodyId::Ground,
        bearing_point: Vec3::zeros(),
        journal_radius: 0.00575,
        bearing_radius: 0.006,
        law: NormalForce::Power { stiffness: STIFFNESS, exponent: 1.5 },
        friction,
        in_contact: false,
        onset_velocity: 0.0,
    };
    SpatialFullModel::new(mechanism, vec![joint])
}

/// Kinetic + gravity + elastic contact energy K δ^2.5 / 2.5.
fn energy(model: &mut SpatialFullModel, y: &[f64]) -> f64 {
    let n = model.mechanism.coordinate_count();
    let delta = model.contact_state(0, y, 0.0).penetration.max(0.0);
    kinetic_energy(&model.mechanism, &y[n..])
        + potential_energy(&model.mechanism, &y[..n])
        + STIFFNESS * delta.powf(2.5) / 2.5
}

fn run(friction: FrictionLaw, check: &mut dyn FnMut(f64, f64, usize)) -> (usize, f64) {
    let mut model = pendulum(friction);
    let mut y = model.initial_state(0.0).expect("assembles");
    let e0 = energy(&mut model, &y);
    let method = Method::Dop853(AdaptiveOptions {
        rtol: 1e-11,
        atol: 1e-14,
        initial_step: 1e-7,
        max_step: 1e-4,
        min_step: 1e-14,
    });
    let stats =
        integrate(&method, &mut model, 0.0, &mut y, 0.3, 1e-4, &mut |m: &mut SpatialFullModel, t: f64, y: &[f64]| {
            let impacts = m.impacts()[0].len();
            let e = energy(m, y);
            check(t, e, impacts);
            Ok(())
        })
        .expect("integrates");
    assert!(stats.events >= 4, "the ball should hit and leave the socket, {} events", stats.events);
    (model.impacts()[0].len(), e0)
}

#[test]
fn a_pendulum_in_a_frictionless_spherical_clearance_conserves_its_energy() {
    let mut energies = Vec::new();
    let (impacts, e0) = run(FrictionLaw::None, &mut |_, e, _| energies.push(e));
    let scale = 0.4 * 9.81 * 0.3;
    let worst = energies.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max) / scale;
    eprintln!("frictionless: {impacts} completed impacts, energy error {worst:e} of m g l");
    assert!(impacts >= 2, "{impacts} impacts");
    assert!(worst < 1e-7, "energy error {worst:e} of m g l");
}

#[test]
fn friction_in_the_spherical_clearance_only_dissipates() {
    let mut energies = Vec::new();
    let law = FrictionLaw::AdamsStickSlip {
        static_coefficient: 0.2,
        dynamic_coefficient: 0.1,
        stiction_velocity: 1e-4,
        friction_velocity: 1e-3,
    };
    let (_, e0) = run(law, &mut |_, e, _| energies.push(e));
    let scale = 0.4 * 9.81 * 0.3;
    let rise = energies.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max) / scale;
    let lost = (e0 - energies.last().expect("samples")) / scale;
    eprintln!("stick-slip: energy lost {lost:e} of m g l, largest rise between samples {rise:e}");
    assert!(lost > 1e-4, "friction should take energy out, lost {lost:e}");
    assert!(rise < 1e-7, "energy rose by {rise:e} of m g l between samples");
}
