//! The exact identities of the effective interface terms (physics.md §4), at many crank angles and
//! for both clearance locations: A (crank–ground) and B (rod–slider).

mod common;
use common::*;
use lash_mech::*;
use nalgebra::{DMatrix, Matrix2};

/// Dense J (2 × n) of the interface by finite differences of g(q) — independent of the code's J.
fn interface_jacobian(iface: &Interface, q: &[f64]) -> DMatrix<f64> {
    let g = |q: &[f64]| {
        let zero = vec![0.0; q.len()];
        let pj = Pose::of(iface.journal_body, q, &zero);
        let pb = Pose::of(iface.bearing_body, q, &zero);
        pj.position + pj.rotate(iface.journal_point) - pb.position - pb.rotate(iface.bearing_point)
    };
    let n = q.len();
    let mut jac = DMatrix::zeros(2, n);
    let h = 1e-7;
    for k in 0..n {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[k] += h;
        qm[k] -= h;
        let d = (g(&qp) - g(&qm)) / (2.0 * h);
        jac[(0, k)] = d.x;
        jac[(1, k)] = d.y;
    }
    jac
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
            let phi_q = constraint_jacobian(&cut_m, t, &q);
            let n = q.len();
            let mut padded = DMatrix::zeros(n, n);
            padded.view_mut((0, 0), (phi_q.nrows(), n)).copy_from(&phi_q);
            let svd = padded.svd(false, true);
            let v_t = svd.v_t.unwrap();
            let null: Vec<usize> = (0..n).filter(|&k| svd.singular_values[k] < 1e-9).collect();
            assert_eq!(null.len(), n - phi_q.nrows(), "{joint}: cut system mobility");
            let mut r = DMatrix::zeros(n, null.len());
            for (c, &k) in null.iter().enumerate() {
                r.set_column(c, &v_t.row(k).transpose());
            }
            let mass = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
                n,
                ideal_m.bodies.iter().flat_map(|b| [b.mass, b.mass, b.inertia]),
            ));
            let jac = interface_jacobian(&iface, &q);
            let reduced = r.transpose() * &mass * &r;
            let w = &jac * &r * reduced.try_inverse().unwrap() * r.transpose() * jac.transpose();
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
