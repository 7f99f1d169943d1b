//! The mechanism (macro) subsystem through its Subsystem interface: exported maps reproduce an
//! independent ideal-mechanism solve, two-way coupling with a zero eccentricity is the ideal
//! motion, rollback replays exactly, bad calls are refused.

mod common;
use common::*;
use lash_core::{Coupling, Subsystem, SubsystemError, Ticks};
use lash_mech::subsystem::vr;
use lash_mech::*;

fn probes() -> Vec<Probe> {
    vec![
        Probe::Point { name: "slider".into(), body: BodyId::Body(2), point: Vec2::zeros() },
        Probe::JointReaction { name: "crank_rod".into(), joint: 0 },
        Probe::DriverTorque { name: "motor".into(), driver: 0 },
    ]
}

fn subsystem(clearance: &str, coupling: Coupling) -> MechanismSubsystem {
    let (cut_mech, ideal, iface) = cut(clearance);
    let mut s = MechanismSubsystem::new("mechanism", cut_mech, ideal, joints(iface), probes(), coupling);
    s.setup(Ticks::ZERO, None).unwrap();
    s.initialize().unwrap();
    s
}

fn joints(interface: Interface) -> Vec<ClearanceInterface> {
    vec![ClearanceInterface { interface, journal_radius: 0.0095, bearing_radius: 0.01, guide: None }]
}

fn value(s: &MechanismSubsystem, name: &str) -> Vec<f64> {
    let v = s.variables().iter().find(|v| v.name == name).unwrap_or_else(|| panic!("no {name}"));
    let mut out = vec![0.0; v.len()];
    s.get_f64(&[v.value_reference], &mut out).unwrap();
    out
}

#[test]
fn propagated_maps_at_minus_effective_force_reproduce_the_ideal_mechanism() {
    for clearance in ["crank_pivot", "rod_slider"] {
        let mut s = subsystem(clearance, Coupling::OneWay);
        let h = Ticks::from_seconds(1e-3).unwrap();
        for k in 0..7 {
            // Independent: the ideal slider-crank (all joints closed) solved directly.
            let t = s.time().seconds();
            let ideal = ideal_slider_crank();
            let mut solver = Solver::new(&ideal);
            let mut q = s.state().0.to_vec();
            analyse(&ideal, &mut solver, &mut q, t);
            let f = value(&s, "effective_force");
            let f = [-f[0], -f[1]];
            let free = value(&s, "slider.acceleration_free");
            let gain = value(&s, "slider.acceleration_gain");
            let ax = free[0] + gain[0] * f[0] + gain[1] * f[1];
            let torque_free = value(&s, "motor.torque_free")[0];
            let torque_gain = value(&s, "motor.torque_gain");
            let torque = torque_free + torque_gain[0] * f[0] + torque_gain[1] * f[1];
            let expected_ax = solver.accelerations[6];
            let expected_torque = driver_torque(&ideal, &solver, 0);
            let scale = expected_ax.abs().max(1.0);
            assert!((ax - expected_ax).abs() < 1e-8 * scale, "{clearance} step {k}: {ax} vs {expected_ax}");
            assert!((torque - expected_torque).abs() < 1e-8 * expected_torque.abs().max(1.0), "{clearance} {k}");
            // The macro's own acceleration output is the ideal one.
            assert!((value(&s, "slider.acceleration")[0] - expected_ax).abs() < 1e-8 * scale);
            assert_eq!(s.do_step(s.time(), h).unwrap(), lash_core::StepOutcome::Completed);
        }
    }
}

#[test]
fn two_way_with_a_centred_journal_follows_the_ideal_motion() {
    let mut one = subsystem("rod_slider", Coupling::OneWay);
    let mut two = subsystem("rod_slider", Coupling::TwoWay);
    assert!(one.is_kinematic() && !two.is_kinematic());
    let h = Ticks::from_seconds(1e-3).unwrap();
    for _ in 0..12 {
        two.set_f64(&[vr::ECCENTRICITY, vr::ECCENTRICITY_RATE], &[0.0; 4]).unwrap();
        assert_eq!(one.do_step(one.time(), h).unwrap(), lash_core::StepOutcome::Completed);
        assert_eq!(two.do_step(two.time(), h).unwrap(), lash_core::StepOutcome::Completed);
    }
    let (q1, q2) = (one.state().0, two.state().0);
    let worst = q1.iter().zip(q2).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-8, "integrated vs kinematic ideal motion differ by {worst}");
    let (a1, a2) = (value(&one, "slider.acceleration")[0], value(&two, "slider.acceleration")[0]);
    assert!((a1 - a2).abs() < 1e-5 * a1.abs(), "{a1} vs {a2}");
}

#[test]
fn rollback_replays_bit_for_bit_and_bad_calls_are_refused() {
    let mut s = subsystem("crank_pivot", Coupling::TwoWay);
    let h = Ticks::from_seconds(1e-3).unwrap();
    s.set_f64(&[vr::ECCENTRICITY], &[2e-5, -1e-5]).unwrap();
    assert_eq!(s.do_step(Ticks::ZERO, h).unwrap(), lash_core::StepOutcome::Completed);
    let saved = s.save_state().unwrap();
    s.set_f64(&[vr::ECCENTRICITY, vr::ECCENTRICITY_RATE], &[3e-5, 0.0, 0.01, -0.02]).unwrap();
    assert_eq!(s.do_step(h, h).unwrap(), lash_core::StepOutcome::Completed);
    let first = value(&s, "effective_force");
    s.restore_state(&saved).unwrap();
    assert_eq!(s.time(), h);
    s.set_f64(&[vr::ECCENTRICITY, vr::ECCENTRICITY_RATE], &[3e-5, 0.0, 0.01, -0.02]).unwrap();
    assert_eq!(s.do_step(h, h).unwrap(), lash_core::StepOutcome::Completed);
    assert_eq!(
        first.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        value(&s, "effective_force").iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // The prescribed eccentricity is met at the step end.
    let e = value(&s, "constraint_error")[0];
    assert!(e < 1e-9, "constraint error {e}");

    let e = s.set_f64(&[vr::EFFECTIVE_MASS], &[1.0; 4]).unwrap_err();
    assert_eq!(e.to_string(), "variable effective_mass: is not an input");
    let e = s.set_f64(&[vr::ECCENTRICITY], &[f64::INFINITY, 0.0]).unwrap_err();
    assert!(e.to_string().contains("eccentricity: inf is not finite"), "{e}");
    assert!(matches!(s.do_step(Ticks::ZERO, h), Err(SubsystemError::BadArguments(_))));
    let (cut_mech, ideal, iface) = cut("crank_pivot");
    let mut fresh = MechanismSubsystem::new("m", cut_mech, ideal, joints(iface), vec![], Coupling::OneWay);
    assert!(matches!(fresh.initialize(), Err(SubsystemError::WrongState { .. })));
}

/// The slider-crank varied per `k`: crank speed, rod length, masses, gravity, a tilted guide; with
/// `unreachable`, a guide line the rod cannot reach from every crank angle (the position analysis
/// fails a quarter turn in).
fn variant(k: usize, clearances: &[&str], unreachable: bool) -> MechanismSubsystem {
    let mut m = ideal_slider_crank();
    let f = k as f64;
    let rod = L2 * (1.0 + 0.05 * f);
    m.joints[1].point_j = Vec2::new(-rod / 2.0, 0.0);
    m.joints[2].point_j = Vec2::new(rod / 2.0, 0.0);
    m.bodies[1].position.x = L1 + rod / 2.0;
    m.bodies[2].position.x = L1 + rod;
    m.bodies[1].mass *= 1.0 + 0.1 * f;
    m.bodies[2].inertia *= 1.0 + 0.2 * f;
    if let JointKind::Prismatic { axis_j, .. } = &mut m.joints[3].kind {
        *axis_j = Vec2::new(1.0, 0.01 * f);
    }
    if unreachable {
        m.joints[3].point_j = Vec2::new(0.0, 0.1);
        m.bodies[2].position.y = 0.1;
        m.bodies[1].position.y = 0.05;
    }
    m.drivers[0].motion = Motion::ConstantSpeed { angle0: 0.1 * f, omega: OMEGA * (0.8 + 0.07 * f) };
    m.gravity = Vec2::new(0.3 * f, -9.81);
    let mut cut_mech = m.clone();
    cut_mech.joints.retain(|j| !clearances.contains(&j.name.as_str()));
    let mut ideal = cut_mech.clone();
    let mut interfaces = Vec::new();
    for name in clearances {
        let j = m.joints.iter().find(|j| j.name == *name).unwrap().clone();
        interfaces.push(ClearanceInterface {
            interface: Interface {
                journal_body: j.body_i,
                journal_point: j.point_i,
                bearing_body: j.body_j,
                bearing_point: j.point_j,
            },
            journal_radius: 0.0095,
            bearing_radius: 0.01 + 1e-4 * f,
            guide: None,
        });
        ideal.joints.push(j);
    }
    // (The probes, and the guide's reaction: a prismatic joint's reads the Jacobian.)
    let mut probes = probes();
    let guide = cut_mech.joints.iter().position(|j| j.name == "guide").unwrap();
    probes.push(Probe::JointReaction { name: "guide".into(), joint: guide });
    let mut s = MechanismSubsystem::new("mechanism", cut_mech, ideal, interfaces, probes, Coupling::OneWay);
    s.setup(Ticks::ZERO, None).unwrap();
    s.initialize().unwrap();
    s
}

/// Every variable of `s`, as bits — read one by one, and checked against one read of all of
/// them (consecutive outputs are copied as one stretch, the inputs among them from their own
/// storage).
fn all_bits(s: &MechanismSubsystem) -> Vec<u64> {
    let one_by_one: Vec<u64> = s
        .variables()
        .iter()
        .flat_map(|v| {
            let mut out = vec![0.0; v.len()];
            s.get_f64(&[v.value_reference], &mut out).unwrap();
            out
        })
        .map(f64::to_bits)
        .collect();
    let refs: Vec<_> = s.variables().iter().map(|v| v.value_reference).collect();
    let mut all = vec![0.0; one_by_one.len()];
    s.get_f64(&refs, &mut all).unwrap();
    assert_eq!(all.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), one_by_one, "one read of every variable");
    one_by_one
}

#[test]
fn kinematic_steps_analysed_in_lanes_equal_each_subsystems_own_bit_for_bit() {
    // Fifteen fully driven mechanisms of three structures (the clearance at the crank pivot or
    // at the rod–slider joint, or two clearance joints): nine of the first (eight in lanes, the
    // ninth and a failing one in a second group), two of the second, three of the third. Over three crank turns every output of each subsystem
    // stepped after `kinematic_steps_ahead` must be that of its twin stepped alone, and the
    // failing one must fail at the same step with the same error. The lanes run in each copy
    // of their code (the widest the processor has, AVX2, the baseline).
    let build = || -> Vec<MechanismSubsystem> {
        let mut v: Vec<_> = (0..9).map(|k| variant(k, &["crank_pivot"], false)).collect();
        v.push(variant(3, &["crank_pivot"], true));
        v.push(variant(1, &["rod_slider"], false));
        v.push(variant(5, &["rod_slider"], false));
        for k in 0..3 {
            v.push(variant(k, &["crank_rod", "rod_slider"], false));
        }
        v
    };
    use lash_mech::lanes::{KinematicLanes, LaneCode};
    for code in [LaneCode::Widest, LaneCode::Avx2, LaneCode::Baseline] {
        lanes_equal_alone(build(), build(), KinematicLanes::with_code(code));
    }
}

fn lanes_equal_alone(
    mut alone: Vec<MechanismSubsystem>,
    mut ahead: Vec<MechanismSubsystem>,
    mut work: lash_mech::lanes::KinematicLanes,
) {
    let h = Ticks::from_seconds(1e-3).unwrap();
    let (mut failed_at, mut taken) = (None, 0);
    for step in 0..40 {
        let t = Ticks(h.0 * step);
        let mut subs: Vec<&mut MechanismSubsystem> = ahead.iter_mut().collect();
        lash_mech::subsystem::kinematic_steps_ahead(&mut subs, t, h, &mut work);
        for (k, (a, b)) in alone.iter_mut().zip(ahead.iter_mut()).enumerate() {
            if a.time() != t {
                continue; // failed earlier
            }
            let (ra, rb) = (a.do_step(t, h), b.do_step(t, h));
            match (&ra, &rb) {
                (Ok(_), Ok(_)) => assert_eq!(all_bits(a), all_bits(b), "subsystem {k}, step {step}"),
                (Err(ea), Err(eb)) => {
                    assert_eq!(ea.to_string(), eb.to_string(), "subsystem {k}");
                    failed_at.get_or_insert((k, step));
                    // (Its twin stepped alone stays behind: compare no further.)
                    let _ = a.save_state();
                }
                _ => panic!("subsystem {k}, step {step}: {ra:?} against {rb:?}"),
            }
            taken += 1;
        }
        // Failed subsystems are out of stepping (time no longer advances for both twins).
        for (a, b) in alone.iter().zip(&ahead) {
            assert_eq!(a.time(), b.time());
        }
    }
    let (k, step) = failed_at.expect("the unreachable guide fails");
    assert_eq!(k, 9);
    assert!(step > 2, "it fails after a few steps in lanes ({step})");
    assert!(taken > 500);
}
