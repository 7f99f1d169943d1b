//! Independent checks of the spatial engine: conservation laws of a free body, a closed-form
//! mechanism, the KKT solve against a dense LU of the full system, energy of a conservative chain.

mod common;
use common::slider_crank;
use lash_ode::{AdaptiveOptions, Method, integrate};
use lash_spatial::{
    Baumgarte, BodyId, Marker, Orientation, SpatialBody, SpatialJoint, SpatialJointKind, SpatialMechanism,
    SpatialSystem, Vec3, angular_momentum, assemble, kinetic_energy, potential_energy, velocity_analysis,
};

fn tight() -> Method {
    Method::Dop853(AdaptiveOptions { rtol: 1e-12, atol: 1e-14, initial_step: 1e-6, max_step: 1e-2, min_step: 1e-14 })
}

/// Runs `system` from `y` to `t_end`, handing every output to `check`.
fn run(
    system: &mut SpatialSystem,
    y: &mut [f64],
    t_end: f64,
    interval: f64,
    check: &mut dyn FnMut(&mut SpatialSystem, f64, &[f64]),
) {
    integrate(&tight(), system, 0.0, y, t_end, interval, &mut |s: &mut SpatialSystem, t: f64, y: &[f64]| {
        check(s, t, y);
        Ok(())
    })
    .expect("integration");
}

#[test]
fn a_torque_free_asymmetric_top_conserves_energy_and_angular_momentum() {
    // Spun close to its intermediate axis: it flips over and over (the tennis-racket effect), so
    // every component of ω' changes by its full size.
    let mut body = SpatialBody::at_rest(
        "top",
        0.5,
        Vec3::new(2.0e-3, 3.0e-3, 4.0e-3),
        Vec3::new(0.1, -0.2, 0.3),
        Orientation::from_euler_angles(0.3, -0.2, 1.1),
    );
    body.angular_velocity = Vec3::new(0.05, 10.0, 0.1);
    body.velocity = Vec3::new(0.2, 0.0, -0.1);
    let mech = SpatialMechanism {
        bodies: vec![body],
        joints: vec![],
        drivers: vec![],
        loads: vec![],
        gravity: Vec3::zeros(),
        baumgarte: Baumgarte::default(),
    };
    assert!(mech.validate().0.is_empty());
    let mut y = mech.initial_state();
    let (q0, v0) = y.split_at(7);
    let (e0, l0) = (kinetic_energy(&mech, v0), angular_momentum(&mech, q0, v0));
    let mut system = SpatialSystem::new(mech);
    let (mut worst_energy, mut worst_momentum, mut flips, mut last_sign) = (0.0f64, 0.0f64, 0, 1.0f64);
    run(&mut system, &mut y, 20.0, 0.01, &mut |s, _, y| {
        let (q, v) = y.split_at(7);
        worst_energy = worst_energy.max((kinetic_energy(&s.mechanism, v) - e0).abs() / e0);
        worst_momentum = worst_momentum.max((angular_momentum(&s.mechanism, q, v) - l0).norm() / l0.norm());
        if v[4].signum() != last_sign {
            flips += 1;
            last_sign = v[4].signum();
        }
    });
    eprintln!(
        "top: {flips} flips, energy {worst_energy:e}, momentum {worst_momentum:e}, |p| drift {:e}",
        system.quaternion_drift(&y)
    );
    assert!(flips >= 4, "the top should flip about its intermediate axis, flipped {flips} times");
    assert!(worst_energy < 1e-9, "relative energy error {worst_energy:e}");
    assert!(worst_momentum < 1e-9, "relative angular momentum error {worst_momentum:e}");
    assert!(system.quaternion_drift(&y) < 1e-9, "quaternion drift {:e}", system.quaternion_drift(&y));
}

#[test]
fn the_ideal_spatial_slider_crank_follows_its_closed_form() {
    let omega = 250.0 * std::f64::consts::PI / 30.0;
    let (mech, mut y) = slider_crank(omega);
    let (r, l, h, e): (f64, f64, f64, f64) = (0.05, 0.25, 0.06, 0.02);
    let theta0 = (e / r).asin();
    let mut system = SpatialSystem::new(mech);
    let (mut worst, mut worst_spin, mut samples) = (0.0f64, 0.0f64, 0);
    run(&mut system, &mut y, 0.3, 1e-3, &mut |s, t, y| {
        let theta = theta0 + omega * t;
        let closed = r * theta.cos() + (l * l - h * h - (r * theta.sin() - e).powi(2)).sqrt();
        worst = worst.max((y[14] - closed).abs());
        // The rod's idle spin (about its own axis, body x) stays at rest: no axial moment acts.
        worst_spin = worst_spin.max(y[21 + 6 + 3].abs());
        samples += 1;
        let _ = s;
    });
    eprintln!(
        "slider-crank: position error {worst:e} m, rod spin {worst_spin:e} rad/s, {} evaluations",
        system.evaluations
    );
    assert_eq!(samples, 301);
    assert!(worst < 1e-9, "slider position error {worst:e} m");
    assert!(worst_spin < 1e-6, "rod spin {worst_spin:e} rad/s");
}

#[test]
fn the_schur_solve_equals_a_dense_lu_of_the_full_kkt_system() {
    let (mut mech, y) = slider_crank(26.0);
    mech.baumgarte = Baumgarte { alpha: 0.0, beta: 0.0 };
    let mut system = SpatialSystem::new(mech);
    // A state off the velocity manifold, so that every term of γ matters.
    let mut y = y;
    for (k, x) in y[21..].iter_mut().enumerate() {
        *x += 0.3 * ((k as f64) * 1.7).sin();
    }
    system.evaluate(0.01, &y).expect("solves");
    let s = &system.solver;
    let (n, m) = (18, s.rows.len());
    let mut kkt = nalgebra::DMatrix::<f64>::zeros(n + m, n + m);
    let mut rhs = nalgebra::DVector::<f64>::zeros(n + m);
    for (k, b) in system.mechanism.bodies.iter().enumerate() {
        for c in 0..3 {
            kkt[(6 * k + c, 6 * k + c)] = b.mass;
        }
        kkt.view_mut((6 * k + 3, 6 * k + 3), (3, 3)).copy_from(&b.inertia);
    }
    for (a, r) in s.rows.iter().enumerate() {
        for blk in 0..2 {
            if let Some(k) = r.bodies[blk] {
                for c in 0..6 {
                    kkt[(n + a, 6 * k + c)] = r.blocks[blk][c];
                    kkt[(6 * k + c, n + a)] = r.blocks[blk][c];
                }
            }
        }
        rhs[n + a] = r.gamma;
    }
    for i in 0..n {
        rhs[i] = s.forces[i];
    }
    let x = kkt.lu().solve(&rhs).expect("regular");
    for i in 0..n {
        assert!(
            (x[i] - s.accelerations[i]).abs() < 1e-9 * (1.0 + x[i].abs()),
            "v̇[{i}] {} vs {}",
            x[i],
            s.accelerations[i]
        );
    }
    for a in 0..m {
        assert!(
            (x[n + a] - s.lambda[a]).abs() < 1e-9 * (1.0 + x[n + a].abs()),
            "λ[{a}] {} vs {}",
            x[n + a],
            s.lambda[a]
        );
    }
}

#[test]
fn a_spherical_double_pendulum_under_gravity_conserves_energy() {
    // Two rods hanging from spherical joints, started with a swing and a twist: chaotic, and
    // every gyroscopic and constraint term works.
    let (l1, l2) = (0.3, 0.2);
    let down = Orientation::rotation_between(&Vec3::x(), &-Vec3::y()).expect("rotation");
    let tilt = Orientation::from_axis_angle(&Vec3::z_axis(), 0.7) * down;
    let p1 = tilt * Vec3::new(l1, 0.0, 0.0);
    let mut a = SpatialBody::at_rest("upper", 1.0, Vec3::new(1e-4, 7.5e-3, 7.5e-3), p1 / 2.0, tilt);
    a.angular_velocity = Vec3::new(3.0, 0.0, 4.0);
    let tilt2 = Orientation::from_axis_angle(&Vec3::x_axis(), 0.5) * down;
    let mut b = SpatialBody::at_rest(
        "lower",
        0.6,
        Vec3::new(5e-5, 2e-3, 2e-3),
        p1 + tilt2 * Vec3::new(l2 / 2.0, 0.0, 0.0),
        tilt2,
    );
    b.angular_velocity = Vec3::new(-2.0, 5.0, 1.0);
    let mech = SpatialMechanism {
        bodies: vec![a, b],
        joints: vec![
            SpatialJoint {
                name: "top".into(),
                kind: SpatialJointKind::Spherical,
                i: Marker::at(BodyId::Ground, Vec3::zeros()),
                j: Marker::at(BodyId::Body(0), Vec3::new(-l1 / 2.0, 0.0, 0.0)),
            },
            SpatialJoint {
                name: "elbow".into(),
                kind: SpatialJointKind::Spherical,
                i: Marker::at(BodyId::Body(0), Vec3::new(l1 / 2.0, 0.0, 0.0)),
                j: Marker::at(BodyId::Body(1), Vec3::new(-l2 / 2.0, 0.0, 0.0)),
            },
        ],
        drivers: vec![],
        loads: vec![],
        gravity: Vec3::new(0.0, -9.81, 0.0),
        baumgarte: Baumgarte::default(),
    };
    let mut y = mech.initial_state();
    let n = mech.coordinate_count();
    {
        let (q, v) = y.split_at_mut(n);
        velocity_analysis(&mech, 0.0, q, v).expect("velocities");
    }
    let energy = |m: &SpatialMechanism, y: &[f64]| kinetic_energy(m, &y[n..]) + potential_energy(m, &y[..n]);
    let e0 = energy(&mech, &y);
    let scale = kinetic_energy(&mech, &y[n..]) + 9.81 * 1.6 * (l1 + l2);
    let mut system = SpatialSystem::new(mech);
    let mut worst = 0.0f64;
    run(&mut system, &mut y, 5.0, 0.01, &mut |s, _, y| {
        worst = worst.max((energy(&s.mechanism, y) - e0).abs() / scale);
    });
    eprintln!("double pendulum: energy error {worst:e} of the scale, {} evaluations", system.evaluations);
    assert!(worst < 1e-8, "energy error {worst:e} of the energy scale");
}

#[test]
fn assembly_and_velocity_analysis_recover_a_perturbed_state() {
    let (mech, exact) = slider_crank(26.0);
    let n = mech.coordinate_count();
    let mut y = exact.clone();
    y[0] += 1e-3; // the crank's centroid off its circle
    y[8] -= 2e-3; // the rod's centroid
    y[17] += 0.01; // the slider's quaternion tilted
    for x in &mut y[n..] {
        *x = 0.0;
    }
    let (q, v) = y.split_at_mut(n);
    let iterations = assemble(&mech, 0.0, q, 1e-12).expect("assembles");
    assert!(iterations > 0);
    velocity_analysis(&mech, 0.0, q, v).expect("velocities");
    let mut system = SpatialSystem::new(mech);
    system.evaluate(0.0, &y).expect("solves");
    assert!(system.solver.constraint_error() < 1e-12, "{:e}", system.solver.constraint_error());
    assert!(system.solver.velocity_error() < 1e-10, "{:e}", system.solver.velocity_error());
    // The driven crank is back where the closed form puts it.
    assert!((y[0] - exact[0]).abs() < 1e-9 && (y[2] - exact[2]).abs() < 1e-9, "crank at {:?}", &y[..3]);
}

#[test]
fn a_bad_mechanism_is_reported_field_by_field() {
    let (mut mech, _) = slider_crank(26.0);
    mech.bodies[1].mass = -1.0;
    mech.bodies[2].inertia[(0, 1)] = 1.0;
    mech.joints[3].i.x = Vec3::new(1.0, 0.0, 0.0); // parallel to its z
    mech.drivers[0].joint = 1; // a spherical joint
    let fields: Vec<String> = mech.validate().0.into_iter().map(|p| p.field).collect();
    for f in ["bodies[1].mass", "bodies[2].inertia", "joints[3].i.x", "drivers[0].joint"] {
        assert!(fields.iter().any(|x| x == f), "{f} missing from {fields:?}");
    }
}

/// Integrated one communication step after the other (as the reduced model's macro side does),
/// a system that remembers its last evaluation gives the same states bit for bit with one solve
/// fewer per restart (the restart's first stage is the last step's final one).
#[test]
fn remembering_the_last_evaluation_changes_nothing_but_the_solves() {
    let omega = 250.0 * std::f64::consts::PI / 30.0;
    let method =
        Method::Dopri5(AdaptiveOptions { rtol: 1e-7, atol: 1e-9, initial_step: 1e-5, max_step: 1e-3, min_step: 1e-12 });
    let steps = 50;
    let pieces = |remember: bool| {
        let (mech, mut y) = slider_crank(omega);
        let mut system = SpatialSystem::new(mech);
        if remember {
            system.remember_last_evaluation();
        }
        let mut states = Vec::new();
        for k in 0..steps {
            let (t0, t1) = (k as f64 * 1e-3, (k + 1) as f64 * 1e-3);
            lash_ode::integrate_from(
                &method,
                &mut system,
                t0,
                &mut y,
                t1,
                t1 - t0,
                &mut |_: &mut SpatialSystem, _: f64, _: &[f64]| Ok(()),
                None,
            )
            .expect("integration");
            states.push(y.clone());
        }
        (states, system.evaluations)
    };
    let ((plain, solves), (kept, fewer)) = (pieces(false), pieces(true));
    for (a, b) in plain.iter().zip(&kept) {
        assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "states differ");
    }
    eprintln!("{solves} solves without, {fewer} with the last evaluation kept");
    assert!(solves - fewer >= steps as u64 - 1, "{solves} vs {fewer}: a restart should reuse the final stage");
}
