//! The exact identities of the effective interface terms (docs/theory.md §6), at many crank angles and
//! for both clearance locations: A (crank–ground) and B (rod–slider).

mod common;
use common::*;
use lash_mech::*;
use nalgebra::{DMatrix, Matrix2};

/// Dense ∂g/∂q (rows × n) by central differences of g(q).
fn jacobian_by_differences(q: &[f64], rows: usize, g: impl Fn(&[f64]) -> Vec<f64>) -> DMatrix<f64> {
    let mut jac = DMatrix::zeros(rows, q.len());
    let h = 1e-7;
    for k in 0..q.len() {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[k] += h;
        qm[k] -= h;
        let (gp, gm) = (g(&qp), g(&qm));
        for r in 0..rows {
            jac[(r, k)] = (gp[r] - gm[r]) / (2.0 * h);
        }
    }
    jac
}

/// Dense J (2 × n) of the interface by finite differences of g(q) — independent of the code's J.
fn interface_jacobian(iface: &Interface, q: &[f64]) -> DMatrix<f64> {
    jacobian_by_differences(q, 2, |q| {
        let zero = vec![0.0; q.len()];
        let pj = Pose::of(iface.journal_body, q, &zero);
        let pb = Pose::of(iface.bearing_body, q, &zero);
        let d = pj.position + pj.rotate(iface.journal_point) - pb.position - pb.rotate(iface.bearing_point);
        vec![d.x, d.y]
    })
}

/// Dense Φ_q of the cut mechanism by finite differences of its constraint values.
fn constraint_jacobian(m: &Mechanism, t: f64, q: &[f64]) -> DMatrix<f64> {
    let mut s = Solver::new(m);
    let zero = vec![0.0; q.len()];
    let n = q.len();
    let nc = m.constraint_count();
    let mut jac = DMatrix::zeros(nc, n);
    let h = 1e-7;
    for k in 0..n {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[k] += h;
        qm[k] -= h;
        s.set_state(m, t, &qp, &zero);
        let php = s.phi.clone();
        s.set_state(m, t, &qm, &zero);
        for a in 0..nc {
            jac[(a, k)] = (php[a] - s.phi[a]) / (2.0 * h);
        }
    }
    jac
}

/// The null-space route's constrained inverse mass R (RᵀMR)⁻¹ Rᵀ of the cut mechanism at (t, q),
/// R an orthonormal basis of null(Φ_q) from the SVD of Φ_q by finite differences.
fn null_space_inverse_mass(cut_m: &Mechanism, t: f64, q: &[f64]) -> DMatrix<f64> {
    let phi_q = constraint_jacobian(cut_m, t, q);
    let n = q.len();
    let mut padded = DMatrix::zeros(n, n);
    padded.view_mut((0, 0), (phi_q.nrows(), n)).copy_from(&phi_q);
    let svd = padded.svd(false, true);
    let v_t = svd.v_t.unwrap();
    let null: Vec<usize> = (0..n).filter(|&k| svd.singular_values[k] < 1e-9).collect();
    assert_eq!(null.len(), n - phi_q.nrows(), "cut system mobility");
    let mut r = DMatrix::zeros(n, null.len());
    for (c, &k) in null.iter().enumerate() {
        r.set_column(c, &v_t.row(k).transpose());
    }
    let mass = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        n,
        cut_m.bodies.iter().flat_map(|b| [b.mass, b.mass, b.inertia]),
    ));
    &r * (r.transpose() * &mass * &r).try_inverse().unwrap() * r.transpose()
}

#[test]
fn identities_hold_at_many_crank_angles_for_both_clearance_locations() {
    for joint in ["crank_pivot", "rod_slider"] {
        let (cut_m, ideal_m, iface) = cut(joint);
        let mut s_ideal = Solver::new(&ideal_m);
        let mut s_cut = Solver::new(&cut_m);
        let (mut q, _) = kinematics::initial_guess(&ideal_m);
        let period = 2.0 * std::f64::consts::PI / OMEGA;
        for i in 0..24 {
            // Deterministic, irregular crank angles over a turn.
            let t = period * ((i as f64 * 0.618_033_988_75).fract());
            let qd = {
                assemble(&ideal_m, t, &mut q, &mut s_ideal, 1e-14).unwrap();
                let mut qd = vec![0.0; q.len()];
                velocity_analysis(&ideal_m, t, &q, &mut qd, &mut s_ideal).unwrap();
                qd
            };
            let terms = effective_terms(&cut_m, &mut s_cut, &iface, t, &q, &qd).unwrap();
            let mt = terms.effective_mass.expect("slider-crank interfaces have full mobility");

            // 1. KKT route = null-space route M̃ = (J R (RᵀMR)⁻¹ RᵀJᵀ)⁻¹.
            let n = q.len();
            let jac = interface_jacobian(&iface, &q);
            let w = &jac * null_space_inverse_mass(&cut_m, t, &q) * jac.transpose();
            let mt_null = Matrix2::new(w[(0, 0)], w[(0, 1)], w[(1, 0)], w[(1, 1)]).try_inverse().unwrap();
            let rel = (mt - mt_null).abs().max() / mt.abs().max();
            assert!(rel < 1e-6, "{joint} t = {t}: M̃ KKT {mt} vs null space {mt_null} ({rel:e})");

            // 2. f̃ = −(ideal joint reaction on the journal).
            s_ideal.accelerations(&ideal_m, t, &q, &qd, |_| {}).unwrap();
            let reaction = joint_reaction(&ideal_m, &s_ideal, ideal_m.joints.len() - 1);
            let scale = reaction.norm().max(1.0);
            assert!(
                (terms.effective_force + reaction).norm() < 1e-8 * scale,
                "{joint} t = {t}: f̃ {} vs reaction {}",
                terms.effective_force,
                reaction
            );

            // 3. With f_c = −f̃ the propagated accelerations are the ideal ones.
            let mut qdd = vec![0.0; n];
            terms.accelerations(-terms.effective_force, &mut qdd);
            let scale = s_ideal.accelerations.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for k in 0..n {
                assert!(
                    (qdd[k] - s_ideal.accelerations[k]).abs() < 1e-9 * scale,
                    "{joint} t = {t}: q̈[{k}] {} vs ideal {}",
                    qdd[k],
                    s_ideal.accelerations[k]
                );
            }
            // The λ maps propagate the driver torque the same way.
            let row = cut_m.driver_row(0);
            let torque = -(terms.free_lambda[row]
                + terms.lambda_gain[0][row] * -terms.effective_force.x
                + terms.lambda_gain[1][row] * -terms.effective_force.y);
            let ideal_torque = driver_torque(&ideal_m, &s_ideal, 0);
            assert!(
                (torque - ideal_torque).abs() < 1e-8 * ideal_torque.abs().max(1.0),
                "{joint}: torque {torque} vs {ideal_torque}"
            );
        }
    }
}

/// The slider-crank cut at its crank–ground and rod–slider joints, the same mechanism with them
/// closed (last), and the two clearance interfaces with radii `radius_j`, `radius_b`.
fn two_clearance_joints(radius_j: f64, radius_b: f64) -> (Mechanism, Mechanism, Vec<ClearanceInterface>) {
    let ideal = ideal_slider_crank();
    let names = ["crank_pivot", "rod_slider"];
    let mut cut_m = ideal.clone();
    cut_m.joints.retain(|j| !names.contains(&j.name.as_str()));
    let mut closed = cut_m.clone();
    let mut joints = Vec::new();
    for name in names {
        let j = ideal.joints.iter().find(|j| j.name == name).unwrap().clone();
        joints.push(ClearanceInterface {
            interface: Interface {
                journal_body: j.body_i,
                journal_point: j.point_i,
                bearing_body: j.body_j,
                bearing_point: j.point_j,
            },
            journal_radius: radius_j,
            bearing_radius: radius_b,
            guide: None,
        });
        closed.joints.push(j);
    }
    (cut_m, closed, joints)
}

/// Two clearance joints at once (crank–ground and rod–slider of the slider-crank), coupled through
/// the cut mechanism: the 4 × 4 effective mass by the KKT route equals the null-space route, its
/// off-diagonal blocks do not vanish, f_c = −f̃ reproduces the ideal mechanism with both joints
/// closed (and f̃ of each joint is minus its ideal reaction), and the friction columns equal the
/// null-space response to the friction moments.
#[test]
fn two_coupled_joints_satisfy_the_identities() {
    let (radius_j, radius_b) = (9.5e-3, 10.0e-3);
    let (cut_m, closed, joints) = two_clearance_joints(radius_j, radius_b);
    let (mut s_ideal, mut s_cut) = (Solver::new(&closed), Solver::new(&cut_m));
    let (mut q, _) = kinematics::initial_guess(&closed);
    let period = 2.0 * std::f64::consts::PI / OMEGA;
    let n = q.len();
    let (mut coupling, mut friction) = (0.0f64, 0.0f64);
    for i in 0..16 {
        let t = period * ((i as f64 * 0.618_033_988_75).fract());
        assemble(&closed, t, &mut q, &mut s_ideal, 1e-14).unwrap();
        let mut qd = vec![0.0; n];
        velocity_analysis(&closed, t, &q, &mut qd, &mut s_ideal).unwrap();
        let terms = coupled_effective_terms(&cut_m, &mut s_cut, &joints, t, &q, &qd).unwrap();
        let mt = terms.effective_mass.clone().expect("two joints of a slider-crank have full mobility");
        assert_eq!((mt.nrows(), terms.friction_mobility.shape()), (4, (4, 2)));

        // 1. KKT route = null-space route, W = J R (RᵀMR)⁻¹ RᵀJᵀ, with J of both interfaces by
        // finite differences.
        let mut jac = DMatrix::zeros(4, n);
        for (j, joint) in joints.iter().enumerate() {
            jac.view_mut((2 * j, 0), (2, n)).copy_from(&interface_jacobian(&joint.interface, &q));
        }
        let a_reduced = null_space_inverse_mass(&cut_m, t, &q);
        let w_null = &jac * &a_reduced * jac.transpose();
        let mt_null = w_null.clone().try_inverse().unwrap();
        let rel = (&mt - &mt_null).abs().max() / mt.abs().max();
        assert!(rel < 1e-6, "t = {t}: M̃ KKT vs null space ({rel:e})\n{mt}\n{mt_null}");
        coupling = coupling.max(mt.view((0, 2), (2, 2)).abs().max() / mt.abs().max());

        // 2. f_c = −f̃ on both joints gives the ideal mechanism's accelerations, and f̃ of each
        // joint is minus the ideal joint's reaction on its journal.
        s_ideal.accelerations(&closed, t, &q, &qd, |_| {}).unwrap();
        let f: Vec<f64> = terms.effective_force.iter().map(|x| -x).collect();
        let mut qdd = vec![0.0; n];
        terms.accelerations(&f, &[0.0, 0.0], &mut qdd);
        let scale = s_ideal.accelerations.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            assert!((qdd[k] - s_ideal.accelerations[k]).abs() < 1e-9 * scale, "t = {t}: q̈[{k}]");
        }
        for j in 0..2 {
            let reaction = joint_reaction(&closed, &s_ideal, closed.joints.len() - 2 + j);
            let ft = nalgebra::Vector2::new(terms.effective_force[2 * j], terms.effective_force[2 * j + 1]);
            assert!(
                (ft + reaction).norm() < 1e-8 * reaction.norm().max(1.0),
                "t = {t}, joint {j}: f̃ {ft} vs {reaction}"
            );
        }

        // 3. Friction columns: the interface response to the moments −R_J (journal body) and +R_B
        // (bearing body) per unit friction force, by the null-space route.
        for (j, joint) in joints.iter().enumerate() {
            let mut tau = nalgebra::DVector::zeros(n);
            for (body, moment) in [(joint.interface.journal_body, -radius_j), (joint.interface.bearing_body, radius_b)]
            {
                if let BodyId::Body(b) = body {
                    tau[3 * b + 2] += moment;
                }
            }
            let response = &jac * &a_reduced * tau;
            let column = terms.friction_mobility.column(j);
            // On the scale of the interface's response to a force at the bearing radius (a moment
            // on the driven crank, or on the guided slider, moves nothing: a zero column).
            let scale = terms.mobility.abs().max() * radius_b;
            let error = (&response - column).abs().max() / scale;
            assert!(error < 1e-6, "t = {t}, joint {j}: W_T {column} vs {response} ({error:e})");
            friction = friction.max(column.abs().max() / scale);
        }
    }
    assert!(
        coupling > 1e-3,
        "the joints are coupled: off-diagonal blocks of M̃ up to {coupling:e} of the largest entry"
    );
    assert!(friction > 1e-3, "the rod's friction moment moves the rod–slider interface ({friction:e})");
}

/// The terms refreshed in place (one storage through a run of states, as the macro subsystem
/// keeps them) equal terms computed afresh at each state, bit for bit: nothing of an earlier state
/// leaks into a later one.
#[test]
fn terms_refreshed_in_place_equal_fresh_ones_bit_for_bit() {
    let (cut_m, closed, joints) = two_clearance_joints(9.5e-3, 10.0e-3);
    for count in [1, 2] {
        let joints = &joints[..count];
        let (mut s_ideal, mut s_cut, mut s_fresh) = (Solver::new(&closed), Solver::new(&cut_m), Solver::new(&cut_m));
        let (mut q, _) = kinematics::initial_guess(&closed);
        let mut kept = CoupledTerms::zeros(q.len(), cut_m.constraint_count(), count);
        let period = 2.0 * std::f64::consts::PI / OMEGA;
        for i in 0..12 {
            let t = period * ((i as f64 * 0.618_033_988_75).fract());
            assemble(&closed, t, &mut q, &mut s_ideal, 1e-14).unwrap();
            let mut qd = vec![0.0; q.len()];
            velocity_analysis(&closed, t, &q, &mut qd, &mut s_ideal).unwrap();
            coupled_effective_terms_into(&cut_m, &mut s_cut, joints, t, &q, &qd, &mut kept).unwrap();
            let fresh = coupled_effective_terms(&cut_m, &mut s_fresh, joints, t, &q, &qd).unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(kept.mobility.as_slice()), bits(fresh.mobility.as_slice()), "W at t = {t}");
            let (a, b) = (kept.effective_mass.as_ref().unwrap(), fresh.effective_mass.as_ref().unwrap());
            assert_eq!(bits(a.as_slice()), bits(b.as_slice()), "M̃ at t = {t}");
            assert_eq!(bits(kept.effective_force.as_slice()), bits(fresh.effective_force.as_slice()), "f̃ at t = {t}");
            assert_eq!(bits(kept.friction_mobility.as_slice()), bits(fresh.friction_mobility.as_slice()));
            assert_eq!(bits(&kept.free_accelerations), bits(&fresh.free_accelerations));
            assert_eq!(bits(&kept.free_lambda), bits(&fresh.free_lambda));
            for c in 0..3 * count {
                assert_eq!(bits(&kept.gain[c]), bits(&fresh.gain[c]), "gain column {c} at t = {t}");
                assert_eq!(bits(&kept.lambda_gain[c]), bits(&fresh.lambda_gain[c]));
            }
        }
    }
}

/// The cut solver that takes its factor from the ideal one (the leading block of the ideal
/// mechanism's factor, where both are at the same position) gives the terms a factor of its own
/// gives, bit for bit; at another position it factors for itself; and it does use the shared
/// factor (a Jacobian spoilt after the share does not reach it).
#[test]
fn a_cut_solver_sharing_the_ideal_factor_gives_the_same_terms_bit_for_bit() {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let period = 2.0 * std::f64::consts::PI / OMEGA;
    let cases: Vec<(Mechanism, Mechanism, Vec<ClearanceInterface>)> = ["crank_pivot", "rod_slider"]
        .iter()
        .map(|name| {
            let (cut_m, ideal, iface) = cut(name);
            (
                cut_m,
                ideal,
                vec![ClearanceInterface {
                    interface: iface,
                    journal_radius: 9.5e-3,
                    bearing_radius: 1e-2,
                    guide: None,
                }],
            )
        })
        .chain(std::iter::once(two_clearance_joints(9.5e-3, 10.0e-3)))
        .collect();
    for (cut_m, ideal, joints) in &cases {
        let (mut s_ideal, mut s_cut, mut s_fresh) = (Solver::new(ideal), Solver::new(cut_m), Solver::new(cut_m));
        assert!(s_cut.is_leading_block_of(cut_m, &s_ideal, ideal));
        // Not the other way round, nor against a mechanism whose first joints differ.
        assert!(!s_ideal.is_leading_block_of(ideal, &s_cut, cut_m));
        let mut reordered = ideal.clone();
        reordered.joints.rotate_left(1);
        assert!(!s_cut.is_leading_block_of(cut_m, &Solver::new(&reordered), &reordered));
        let (mut q, _) = kinematics::initial_guess(ideal);
        let mut shared = CoupledTerms::zeros(q.len(), cut_m.constraint_count(), joints.len());
        for i in 0..12 {
            let t = period * ((i as f64 * 0.618_033_988_75).fract());
            let mut qd = vec![0.0; q.len()];
            kinematics::assemble_and_project(ideal, t, &mut q, &mut qd, &mut s_ideal, 1e-13).unwrap();
            s_cut.share_rotations(&s_ideal);
            s_cut.share_factor(&s_ideal);
            coupled_effective_terms_into(cut_m, &mut s_cut, joints, t, &q, &qd, &mut shared).unwrap();
            let fresh = coupled_effective_terms(cut_m, &mut s_fresh, joints, t, &q, &qd).unwrap();
            assert_eq!(bits(shared.mobility.as_slice()), bits(fresh.mobility.as_slice()), "W at t = {t}");
            assert_eq!(bits(&shared.free_accelerations), bits(&fresh.free_accelerations), "t = {t}");
            assert_eq!(bits(&shared.free_lambda), bits(&fresh.free_lambda), "t = {t}");
            for c in 0..3 * joints.len() {
                assert_eq!(bits(&shared.gain[c]), bits(&fresh.gain[c]), "gain column {c} at t = {t}");
            }
            // A share at another position is not used: the terms at this one are still right.
            let mut moved = q.clone();
            moved[2] += 1e-3;
            s_cut.share_factor(&s_ideal);
            coupled_effective_terms_into(cut_m, &mut s_cut, joints, t, &moved, &qd, &mut shared).unwrap();
            let fresh = coupled_effective_terms(cut_m, &mut s_fresh, joints, t, &moved, &qd).unwrap();
            assert_eq!(bits(shared.mobility.as_slice()), bits(fresh.mobility.as_slice()), "moved, t = {t}");
            // And a share at this position is what the factor is: a Jacobian spoilt after it
            // (NaN in S were S formed) still factors.
            s_cut.share_factor(&s_ideal);
            s_cut.set_state(cut_m, t, &q, &qd);
            for row in s_cut.jacobian.iter_mut() {
                for block in row.iter_mut() {
                    block.d = [f64::NAN; 3];
                }
            }
            assert!(s_cut.factor().is_ok(), "the shared factor was not used at t = {t}");
            s_cut.set_state(cut_m, t, &q, &qd);
            for row in s_cut.jacobian.iter_mut() {
                for block in row.iter_mut() {
                    block.d = [f64::NAN; 3];
                }
            }
            assert!(s_cut.factor().is_err(), "a share is used once only (t = {t})");
        }
    }
}

/// A translational clearance joint's interface (the slider's prismatic joint cut, its block in a
/// guide): the coordinates are the prismatic joint's rows, tilt and offset, and the friction load
/// acts through the slide along the guide. Checked at many crank angles against computations of
/// the test's own: J by finite differences of (θ_slider − θ0, m·d, u·d); M̃ and the friction
/// column by the null-space route; f̃ equal to the ideal prismatic joint's multipliers; q̈ with
/// the load −f̃ the ideal mechanism's; the slide's speed and acceleration by differences in time
/// along the ideal motion.
#[test]
fn a_guide_interface_has_the_identities_of_the_prismatic_joint_it_replaces() {
    let (cut_m, ideal_m, iface) = cut("guide");
    let guide = GuideAxis { axis: Vec2::new(1.0, 0.0), angle_offset: 0.0 };
    let joint = ClearanceInterface { interface: iface, journal_radius: 0.0, bearing_radius: 0.0, guide: Some(guide) };
    // Tilt, offset and slide of the block centre (body i's joint point) against the ground's axis.
    let coordinates = |q: &[f64]| -> [f64; 3] {
        let zero = vec![0.0; q.len()];
        let p = Pose::of(iface.journal_body, q, &zero);
        let d = p.position + p.rotate(iface.journal_point) - iface.bearing_point;
        [p.angle, d.y, d.x]
    };
    let mut s_ideal = Solver::new(&ideal_m);
    let mut s_cut = Solver::new(&cut_m);
    let (mut q, _) = kinematics::initial_guess(&ideal_m);
    let period = 2.0 * std::f64::consts::PI / OMEGA;
    let analysed = |t: f64, q: &mut Vec<f64>, s: &mut Solver| {
        assemble(&ideal_m, t, q, s, 1e-14).unwrap();
        let mut qd = vec![0.0; q.len()];
        velocity_analysis(&ideal_m, t, q, &mut qd, s).unwrap();
        qd
    };
    for i in 0..24 {
        let t = period * ((i as f64 * 0.618_033_988_75).fract());
        let qd = analysed(t, &mut q, &mut s_ideal);
        let terms = coupled_effective_terms(&cut_m, &mut s_cut, &[joint], t, &q, &qd).unwrap();
        let mt = terms.effective_mass.clone().expect("the cut slider moves in tilt and offset");
        let n = q.len();
        let jac = jacobian_by_differences(&q, 3, |q| coordinates(q).to_vec());
        let a = null_space_inverse_mass(&cut_m, t, &q);
        let (rows, slide) = (jac.rows(0, 2).into_owned(), jac.rows(2, 1).into_owned());
        let mt_null = (&rows * &a * rows.transpose()).try_inverse().unwrap();
        let rel = (&mt - &mt_null).abs().max() / mt.abs().max();
        assert!(rel < 1e-6, "t = {t}: M̃ {mt} vs null space {mt_null} ({rel:e})");
        let friction_null = &rows * &a * slide.transpose();
        let scale = friction_null.abs().max().max(terms.mobility.abs().max());
        assert!(
            (&terms.friction_mobility - &friction_null).abs().max() < 1e-6 * scale,
            "t = {t}: W_T {} vs {friction_null}",
            terms.friction_mobility
        );

        // f̃ = the multipliers of the ideal prismatic joint's rows (its reaction is −λ).
        s_ideal.accelerations(&ideal_m, t, &q, &qd, |_| {}).unwrap();
        let row = ideal_m.joint_row(ideal_m.joints.len() - 1);
        for r in 0..2 {
            let lambda = s_ideal.lambda[row + r];
            assert!(
                (terms.effective_force[r] - lambda).abs() < 1e-8 * lambda.abs().max(1.0),
                "t = {t}: f̃[{r}] {} vs λ {lambda}",
                terms.effective_force[r]
            );
        }
        let mut qdd = vec![0.0; n];
        terms.accelerations(&[-terms.effective_force[0], -terms.effective_force[1]], &[0.0], &mut qdd);
        let scale = s_ideal.accelerations.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            assert!((qdd[k] - s_ideal.accelerations[k]).abs() < 1e-9 * scale, "t = {t}: q̈[{k}]");
        }

        // The slide's speed and acceleration against differences of u·d along the ideal motion.
        let (rate, acceleration) = joint.slide_rates(&s_cut.poses, &qd, &s_ideal.accelerations).unwrap();
        let dt = 1e-6;
        let slide_at = |t: f64| {
            let mut qt = q.clone();
            let mut s = Solver::new(&ideal_m);
            assemble(&ideal_m, t, &mut qt, &mut s, 1e-14).unwrap();
            coordinates(&qt)[2]
        };
        let (before, now, after) = (slide_at(t - dt), slide_at(t), slide_at(t + dt));
        let speed = (after - before) / (2.0 * dt);
        let second = (after - 2.0 * now + before) / (dt * dt);
        assert!((rate - speed).abs() < 1e-6 * speed.abs().max(1.0), "t = {t}: ẋ {rate} vs {speed}");
        assert!((acceleration - second).abs() < 1e-4 * second.abs().max(1.0), "t = {t}: ẍ {acceleration} vs {second}");
    }
}
