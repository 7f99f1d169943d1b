//! The spatial engine against the planar one: scenario B built as a spatial mechanism (revolutes
//! about z, the slider's guide a translational joint, the clearance a spherical clearance joint —
//! for planar motion a ball in a socket is the planar journal in its bearing), run by the spatial
//! runner, equals the planar engine's converged run. And scenario E's ideal slider follows its
//! closed form through the whole runner.

mod common;
use common::{column, rows};
use lash_run::{BuildOptions, FullRun, SpatialRun};
use lash_scenario::builtin;
use lash_scenario::builtin_spatial::{e_slider_position, spatial_by_name};
use lash_scenario::schema::Scenario;
use lash_scenario::spatial::{
    Space, SpatialBodySpec, SpatialDriverSpec, SpatialJointSpec, SpatialScenario, SpatialSensorSpec,
};
use lash_spatial::SpatialJointKind;

/// Scenario `planar` (a B variant) as a spatial mechanism. `ideal`: the rod–slider joint is an
/// ideal spherical joint and the crank–rod joint a universal joint (a closed loop of revolutes
/// about parallel axes is redundant in space: 5 + 5 + 5 + 5 + 1 equations for 18 coordinates;
/// spherical + universal remove exactly the two redundant ones and allow the same planar motion).
fn b_as_spatial(planar: &Scenario, ideal: bool) -> SpatialScenario {
    let body = |name: &str| planar.bodies.iter().find(|b| b.name == name).expect("B body");
    let spatial_body = |name: &str| {
        let b = body(name);
        SpatialBodySpec {
            name: name.into(),
            mass: b.mass,
            inertia: [b.inertia, b.inertia, b.inertia],
            products: [0.0; 3],
            position: [b.position[0], b.position[1], 0.0],
            orientation: [(0.5 * b.angle).cos(), 0.0, 0.0, (0.5 * b.angle).sin()],
            velocity: [b.velocity[0], b.velocity[1], 0.0],
            angular_velocity: [0.0, 0.0, b.angular_velocity],
        }
    };
    let joint = |name: &str, kind, body1: &str, body2: &str, axes: Option<([f64; 3], [f64; 3])>| {
        let planar_joint = planar.joints.iter().find(|j| j.name == name).expect("B joint");
        let point = |b: &str| {
            let p = if planar_joint.body1 == b { planar_joint.point1 } else { planar_joint.point2 };
            [p[0], p[1], 0.0]
        };
        SpatialJointSpec {
            name: name.into(),
            kind,
            body1: body1.into(),
            point1: point(body1),
            body2: body2.into(),
            point2: point(body2),
            axis1: axes.map(|a| a.0),
            axis2: axes.map(|a| a.0),
            reference1: axes.map(|a| a.1),
            reference2: None,
        }
    };
    let z = Some(([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]));
    let crank_rod = if ideal {
        // Cross axes: z on the crank, the rod's own y (across the rod, in the plane) on the rod.
        let mut j = joint("crank_rod", SpatialJointKind::Universal, "crank", "rod", None);
        (j.axis1, j.axis2, j.reference1) = (Some([0.0, 0.0, 1.0]), Some([0.0, 1.0, 0.0]), Some([1.0, 0.0, 0.0]));
        j
    } else {
        joint("crank_rod", SpatialJointKind::Revolute, "crank", "rod", z)
    };
    let omega = match planar.drivers[0].motion {
        lash_mech::Motion::ConstantSpeed { omega, .. } => omega,
        _ => unreachable!("B has a constant-speed driver"),
    };
    SpatialScenario {
        name: format!("{} in space", planar.name),
        space: Space::Spatial,
        description: String::new(),
        gravity: [0.0; 3],
        materials: planar.materials.clone(),
        bodies: vec![spatial_body("crank"), spatial_body("rod"), spatial_body("slider")],
        joints: vec![
            joint("crank_pivot", SpatialJointKind::Revolute, "ground", "crank", z),
            crank_rod,
            joint("rod_slider", SpatialJointKind::Spherical, "rod", "slider", None),
            joint(
                "slider_guide",
                SpatialJointKind::Translational,
                "ground",
                "slider",
                Some(([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])),
            ),
        ],
        drivers: vec![SpatialDriverSpec {
            name: "motor".into(),
            joint: "crank_pivot".into(),
            motion: lash_mech::Motion::ConstantSpeed { angle0: 0.0, omega },
        }],
        loads: vec![],
        clearances: if ideal { vec![] } else { planar.clearances.clone() },
        sensors: vec![SpatialSensorSpec { name: "slider".into(), body: "slider".into(), point: [0.0; 3] }],
        simulation: planar.simulation.clone(),
        output: Default::default(),
    }
}

/// (t, slider x, slider a_x) of the planar and the spatial run.
fn both(planar: &Scenario, ideal: bool) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, lash_run::Summary, lash_run::Summary) {
    let spatial = b_as_spatial(planar, ideal);
    let problems = lash_scenario::validate_spatial(&spatial);
    assert!(problems.is_empty(), "{problems}");
    let (ps, ph, pr) = rows(&mut FullRun::new(planar, BuildOptions { ideal }));
    let (ss, sh, sr) = rows(&mut SpatialRun::new(&spatial, ideal));
    let pick = |h: &[String], r: &[Vec<f64>]| -> Vec<[f64; 3]> {
        let (x, a) = (column(h, "slider.x"), column(h, "slider.ax"));
        r.iter().map(|row| [row[0], row[x], row[a]]).collect()
    };
    (pick(&ph, &pr), pick(&sh, &sr), ps, ss)
}

fn worst(a: &[[f64; 3]], b: &[[f64; 3]], until: f64, column: usize) -> (f64, f64) {
    let mut error = 0.0f64;
    let mut peak = 0.0f64;
    for (p, s) in a.iter().zip(b) {
        assert_eq!(p[0], s[0], "same output times");
        if p[0] <= until {
            error = error.max((p[column] - s[column]).abs());
            peak = peak.max(p[column].abs());
        }
    }
    (error, peak)
}

#[test]
fn the_ideal_slider_crank_of_b_in_space_equals_the_planar_engine() {
    let b = builtin::by_name("B").expect("built-in");
    let (p, s, _, summary) = both(&b, true);
    let (ex, _) = worst(&p, &s, f64::INFINITY, 1);
    let (ea, peak) = worst(&p, &s, f64::INFINITY, 2);
    eprintln!("ideal B: slider x {ex:e} m, a_x {ea:e} of peak {peak:e} m/s², {} steps", summary.steps);
    assert!(ex < 1e-9, "slider position differs by {ex:e} m");
    assert!(ea < 1e-6 * peak, "slider acceleration differs by {ea:e} of {peak:e} m/s²");
}

#[test]
fn b_with_a_small_clearance_in_space_equals_the_planar_engine_pointwise() {
    // c = 0.02 mm: continuous contact, no chaos (the comparison is pointwise over all 3 turns).
    let b = builtin::by_name("B-0.02mm").expect("built-in");
    let (p, s, ps, ss) = both(&b, false);
    let (ex, _) = worst(&p, &s, f64::INFINITY, 1);
    let (ea, peak) = worst(&p, &s, f64::INFINITY, 2);
    eprintln!(
        "B-0.02mm: slider x {ex:e} m, a_x {ea:e} of peak {peak:e} m/s²; impacts {} (planar) vs {} (spatial)",
        ps.clearances[0].impacts, ss.clearances[0].impacts
    );
    assert!(ex < 1e-8, "slider position differs by {ex:e} m");
    assert!(ea < 1e-3 * peak, "slider acceleration differs by {ea:e} of {peak:e} m/s²");
    assert_eq!(ps.clearances[0].impacts, ss.clearances[0].impacts);
}

#[test]
fn b_with_its_large_clearance_in_space_equals_the_planar_engine_through_the_first_impacts() {
    // c = 0.5 mm is chaotic (docs/validation.md): pointwise over the first free flight and
    // impacts (5 ms), statistics over the run.
    let b = builtin::by_name("B").expect("built-in");
    let (p, s, ps, ss) = both(&b, false);
    let (ea, peak) = worst(&p, &s, 5e-3, 2);
    let (pc, sc) = (&ps.clearances[0], &ss.clearances[0]);
    eprintln!(
        "B: a_x over 5 ms {ea:e} of peak {peak:e}; impacts {} vs {}, peak force {:.1} vs {:.1} N, mean force {:.2} vs {:.2} N",
        pc.impacts,
        sc.impacts,
        pc.peak_normal_force,
        sc.peak_normal_force,
        pc.mean_contact_force,
        sc.mean_contact_force
    );
    // Measured 1.0e-3: within an impact a_x changes by its peak in microseconds, and the two
    // integrations place their steps differently (both at rtol 1e-9).
    assert!(ea < 3e-3 * peak, "slider acceleration over the first 5 ms differs by {ea:e} of {peak:e} m/s²");
    let first =
        |s: &lash_run::Summary| s.clearances[0].first_impacts.iter().take(3).map(|i| i.onset_time).collect::<Vec<_>>();
    for (a, b) in first(&ps).iter().zip(first(&ss)) {
        assert!((a - b).abs() < 1e-8, "impact onsets {a} vs {b} s");
    }
    assert!((pc.mean_contact_force / sc.mean_contact_force - 1.0).abs() < 0.05, "mean contact force");
}

#[test]
fn the_ideal_spatial_slider_crank_of_e_follows_its_closed_form_through_the_runner() {
    let mut e = spatial_by_name("E-0.5mm-250rpm").expect("built-in");
    e.simulation.horizon = 0.24; // one revolution
    let (summary, header, rows) = rows(&mut SpatialRun::new(&e, true));
    let (x, theta0, omega) = (
        column(&header, "slider.x"),
        lash_scenario::builtin_spatial::e_initial_angle(),
        250.0 * std::f64::consts::PI / 30.0,
    );
    let worst = rows.iter().map(|r| (r[x] - e_slider_position(theta0 + omega * r[0])).abs()).fold(0.0, f64::max);
    eprintln!("E ideal: slider x error {worst:e} m over {} samples", summary.samples);
    assert!(worst < 1e-9, "slider position error {worst:e} m");
    // The guide carries the weight of the slider and half the rod's, on average, along Y.
    let fy = summary.channels["slider_guide.fy"].mean;
    assert!(fy < -0.6 * 9.81 && fy > -(0.6 + 0.25) * 9.81, "guide reaction on the ground {fy} N");
}

/// The reduced model's macro side integrates the ideal mechanism (DOPRI5 at rtol 1e-6 over each
/// 1 ms communication step): at the communication points, where its slider position is the
/// node itself (no interpolation), it follows the closed form as the converged ideal run does.
#[test]
fn the_reduced_model_of_e_moves_its_macro_side_along_the_closed_form() {
    let mut e = spatial_by_name("E-0.5mm-250rpm").expect("built-in");
    e.simulation.horizon = 0.24; // one revolution
    let mut reduced = lash_run::SpatialReducedRun::new(&e, lash_run::ReducedOptions::default()).expect("reduced");
    let (_, header, rows) = rows(&mut reduced);
    let (x, theta0, omega) = (
        column(&header, "slider.x"),
        lash_scenario::builtin_spatial::e_initial_angle(),
        250.0 * std::f64::consts::PI / 30.0,
    );
    let nodes: Vec<&Vec<f64>> = rows.iter().step_by(100).collect();
    assert_eq!(nodes.len(), 241, "one row per 1e-5 s, a node every 1e-3 s");
    let worst = nodes.iter().map(|r| (r[x] - e_slider_position(theta0 + omega * r[0])).abs()).fold(0.0, f64::max);
    eprintln!("E reduced, macro nodes: slider x error {worst:e} m");
    assert!(worst < 1e-10, "slider position error {worst:e} m at the macro nodes");
}

#[test]
fn the_housing_response_of_e_equals_an_independent_integration_of_its_mount() {
    // The runner's housing (exact discretisation of the mount, force linear between samples)
    // against RK4 at a tenth of the output step on the same piecewise-linear force.
    let mut e = spatial_by_name("E-0.5mm-250rpm").expect("built-in");
    e.simulation.horizon = 0.3;
    let (summary, header, rows) = rows(&mut SpatialRun::new(&e, false));
    let fz = column(&header, "slider_guide.fz");
    let force: Vec<f64> = rows.iter().map(|r| r[fz]).collect();
    let mount = e.output.measurements[0].mount;
    let (m, k, c) = (mount.mass, mount.stiffness(), mount.damping());
    let dt = e.simulation.output_interval;
    let (mut x, mut v) = (force[0] / k, 0.0);
    let mut acceleration = vec![(force[0] - c * v - k * x) / m];
    for w in force.windows(2) {
        let h = dt / 10.0;
        for s in 0..10 {
            let f = |tau: f64| w[0] + (w[1] - w[0]) * (s as f64 * h + tau) / dt;
            let rhs = |tau: f64, x: f64, v: f64| (v, (f(tau) - c * v - k * x) / m);
            let k1 = rhs(0.0, x, v);
            let k2 = rhs(0.5 * h, x + 0.5 * h * k1.0, v + 0.5 * h * k1.1);
            let k3 = rhs(0.5 * h, x + 0.5 * h * k2.0, v + 0.5 * h * k2.1);
            let k4 = rhs(h, x + h * k3.0, v + h * k3.1);
            x += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
            v += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        }
        acceleration.push((w[1] - c * v - k * x) / m);
    }
    let first = (0.24 / dt).ceil() as usize;
    let window = &acceleration[first..];
    let mean = window.iter().sum::<f64>() / window.len() as f64;
    let rms = (window.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / window.len() as f64).sqrt();
    let axis = &summary.measurements[0].axes[2];
    eprintln!("E housing z: clean RMS {} (runner) vs {rms} (RK4), logged {:?}", axis.clean_rms, axis.logged);
    assert!((axis.clean_rms / rms - 1.0).abs() < 1e-6, "{} vs {rms}", axis.clean_rms);
    assert_eq!(summary.measured[0].rows.len(), 31);
}

/// The converged setting of E (DOP853, rtol 1e-9) against rtol 1e-11 over the start-up of the
/// clearance runs: the first free flight and impacts, pointwise; over the first revolution, the
/// robust statistics (the runs are chaotic after the first impacts).
#[test]
fn scenario_e_converges_through_its_first_impacts() {
    for name in ["E-0.5mm-250rpm", "E-0.25mm-125rpm"] {
        let mut e = spatial_by_name(name).expect("built-in");
        e.output.measurements.clear();
        let turn = 60.0 / if name.ends_with("250rpm") { 250.0 } else { 125.0 };
        e.simulation.horizon = turn;
        let mut tight = e.clone();
        if let lash_ode::Method::Dop853(o) = &mut tight.simulation.integrator {
            (o.rtol, o.atol) = (1e-11, 1e-14);
        }
        let (a, ah, ar) = rows(&mut SpatialRun::new(&e, false));
        let (b, bh, br) = rows(&mut SpatialRun::new(&tight, false));
        let first: Vec<f64> = a.clearances.iter().map(|c| c.first_impacts[0].onset_time).collect();
        let window = first.iter().fold(0.0f64, |m, &t| m.max(t)) + 5e-3;
        let (fa, fb) = (column(&ah, "crank_rod.force"), column(&bh, "crank_rod.force"));
        let (mut error, mut peak) = (0.0f64, 0.0f64);
        for (x, y) in ar.iter().zip(&br) {
            if x[0] <= window {
                error = error.max((x[fa] - y[fb]).abs());
                peak = peak.max(y[fb].abs());
            }
        }
        eprintln!("{name}: first impacts at {first:?} s; crank_rod force to {window:.4} s: {error:.3e} of {peak:.1} N");
        for (ca, cb) in a.clearances.iter().zip(&b.clearances) {
            let (ia, ib) = (&ca.first_impacts[0], &cb.first_impacts[0]);
            eprintln!(
                "  {}: first onset {:.9} vs {:.9} s, peak {:.3} vs {:.3} N; turn 1: {} vs {} impacts, mean force {:.3} vs {:.3} N, max penetration {:.3e} vs {:.3e} m",
                ca.name,
                ia.onset_time,
                ib.onset_time,
                ia.peak_force,
                ib.peak_force,
                ca.impacts,
                cb.impacts,
                ca.mean_contact_force,
                cb.mean_contact_force,
                ca.max_penetration,
                cb.max_penetration
            );
            assert!((ia.onset_time - ib.onset_time).abs() < 1e-8, "{name} {}: first onset", ca.name);
            assert!((ia.peak_force / ib.peak_force - 1.0).abs() < 1e-4, "{name} {}: first peak", ca.name);
            assert!(
                (ca.mean_contact_force / cb.mean_contact_force - 1.0).abs() < 0.05,
                "{name} {}: mean force",
                ca.name
            );
        }
        assert!(error < 1e-3 * peak, "{name}: force over the first impacts {error:e} of {peak} N");
    }
}

/// The reduced interface model of E (two spherical clearance joints coupled through the rod's
/// effective mass; h_m = 1e-3 s, h_r = 1e-5 s, one-way and two-way) against the converged full
/// model over two revolutions: robust statistics, the emulated measurement, impacts (the runs are
/// chaotic, so not pointwise), and the rod's axial spin, which only friction moments drive.
#[test]
fn the_reduced_model_of_e_meets_its_bounds_against_the_full_model() {
    let e = spatial_by_name("E-0.5mm-250rpm").expect("built-in");
    let (full, header, full_rows) = rows(&mut SpatialRun::new(&e, false));
    // The rod's mean spin over the second revolution (the first is the start-up).
    let spin = |header: &[String], rows: &[Vec<f64>]| {
        let wx = column(header, "rod.wx");
        let second: Vec<f64> = rows.iter().filter(|r| r[0] >= 60.0 / 250.0).map(|r| r[wx]).collect();
        second.iter().sum::<f64>() / second.len() as f64
    };
    let full_spin = spin(&header, &full_rows);
    for coupling in [lash_core::Coupling::OneWay, lash_core::Coupling::TwoWay] {
        let options = lash_run::ReducedOptions { coupling, ..Default::default() };
        let (reduced, header, reduced_rows) =
            rows(&mut lash_run::SpatialReducedRun::new(&e, options).expect("reduced"));
        let reduced_spin = spin(&header, &reduced_rows);
        eprintln!("{coupling:?}: rod spin {reduced_spin:.4} rad/s, full model {full_spin:.4} rad/s");
        match coupling {
            // The ideal mechanism's balls pass no moment about the rod's axis.
            lash_core::Coupling::OneWay => assert!(reduced_spin.abs() < 1e-9, "one-way spin {reduced_spin}"),
            // Two-way: the friction loads' torques spin it (measured 8.7 % off; the rattling
            // that drives it is chaotic).
            lash_core::Coupling::TwoWay => assert!(
                (reduced_spin - full_spin).abs() < 0.25 * full_spin.abs(),
                "two-way spin {reduced_spin} vs {full_spin}"
            ),
        }
        meets_the_bounds(&full, &reduced);
    }
}

/// The reduced run's bounds against the full model's (E).
fn meets_the_bounds(full: &lash_run::Summary, reduced: &lash_run::Summary) {
    let relative = |a: f64, b: f64| (b - a) / a;
    for (f, r) in full.clearances.iter().zip(&reduced.clearances) {
        let (mean, peak) =
            (relative(f.mean_contact_force, r.mean_contact_force), relative(f.peak_normal_force, r.peak_normal_force));
        let impacts = r.impacts as f64 / f.impacts as f64;
        eprintln!("{}: mean force {mean:+.4}, peak {peak:+.4}, impacts {} vs {}", f.name, f.impacts, r.impacts);
        assert!(mean.abs() < 0.05, "{}: mean contact force {mean:+.3}", f.name);
        assert!(peak.abs() < 0.15, "{}: peak normal force {peak:+.3}", f.name);
        assert!((0.5..2.0).contains(&impacts), "{}: impacts {} vs {}", f.name, f.impacts, r.impacts);
    }
    for channel in
        ["slider.ax", "slider_guide.fy", "slider_guide.fz", "crank_drive.torque", "crank_rod.force", "rod_slider.force"]
    {
        let d = relative(full.channels[channel].rms, reduced.channels[channel].rms);
        eprintln!("{channel}: RMS {d:+.4}");
        assert!(d.abs() < 0.05, "{channel}: RMS {d:+.3}");
    }
    for (f, r) in full.measurements[0].axes.iter().zip(&reduced.measurements[0].axes).skip(1) {
        let (logged, clean) = (relative(f.logged.rms, r.logged.rms), relative(f.clean_rms, r.clean_rms));
        eprintln!("{}: logged RMS {logged:+.4}, clean RMS {clean:+.4}", f.channel);
        assert!(logged.abs() < 0.2 && clean.abs() < 0.2, "{}: logged {logged:+.3}, clean {clean:+.3}", f.channel);
    }
}
