//! The effective interface terms of E's two spherical joints (coupled through the rod) against two
//! independent routes: the ideal mechanism's own KKT solve (f_c = −f̃ must reproduce it), and the
//! null-space projection of the cut mechanism's dynamics.

mod common;
use common::slider_crank;
use lash_spatial::{
    Baumgarte, BodyId, SpatialCoupledTerms, SpatialMechanism, SpatialSolver, SphericalInterface, Vec3,
    spatial_effective_terms, spatial_effective_terms_into,
};
use nalgebra::{DMatrix, DVector};

/// E's ideal mechanism (the two spherical joints as written), its cut mechanism (without them),
/// the interfaces (ball on the crank / slider, socket on the rod) and a consistent state.
fn e_state() -> (SpatialMechanism, SpatialMechanism, Vec<SphericalInterface>, Vec<f64>) {
    let (mut ideal, y) = slider_crank(26.18);
    ideal.baumgarte = Baumgarte { alpha: 0.0, beta: 0.0 };
    let mut cut = ideal.clone();
    let interfaces = ["crank_rod", "rod_slider"]
        .iter()
        .map(|name| {
            let j = ideal.joints.iter().find(|j| j.name == *name).expect("joint");
            // Ball on body I (crank, rod → the rod carries the socket of crank_rod; for
            // rod_slider the ball is on the slider, body J).
            if *name == "crank_rod" {
                SphericalInterface {
                    journal_body: j.i.body,
                    journal_point: j.i.point,
                    bearing_body: j.j.body,
                    bearing_point: j.j.point,
                    journal_radius: 0.00575,
                    bearing_radius: 0.006,
                }
            } else {
                SphericalInterface {
                    journal_body: j.j.body,
                    journal_point: j.j.point,
                    bearing_body: j.i.body,
                    bearing_point: j.i.point,
                    journal_radius: 0.0055,
                    bearing_radius: 0.006,
                }
            }
        })
        .collect();
    cut.joints.retain(|j| j.name != "crank_rod" && j.name != "rod_slider");
    (ideal, cut, interfaces, y)
}

#[test]
fn contact_forces_equal_to_minus_the_effective_forces_reproduce_the_ideal_mechanism() {
    let (ideal, cut, interfaces, y) = e_state();
    let n = ideal.coordinate_count();
    let (q, v) = y.split_at(n);
    let mut solver = SpatialSolver::new(&cut);
    let terms = spatial_effective_terms(&cut, &mut solver, &interfaces, 0.0, q, v).expect("terms");
    let mass = terms.effective_mass.as_ref().expect("regular W");
    // M̃ symmetric positive definite, and the two joints coupled through the rod.
    assert!((mass - mass.transpose()).abs().max() < 1e-9 * mass.abs().max());
    assert!(mass.clone().cholesky().is_some());
    assert!(mass.view((0, 3), (3, 3)).abs().max() > 1e-3 * mass.abs().max(), "off-diagonal block {mass}");
    let mut accelerations = terms.free_accelerations.clone();
    for (column, f) in terms.gain.iter().zip(terms.effective_force.iter()) {
        for (a, g) in accelerations.iter_mut().zip(column) {
            *a -= g * f;
        }
    }
    let mut ideal_solver = SpatialSolver::new(&ideal);
    ideal_solver.set_state(&ideal, 0.0, q, v);
    ideal_solver.solve(&ideal).expect("ideal solve");
    let scale = ideal_solver.accelerations.iter().fold(1.0f64, |m, a| m.max(a.abs()));
    for (i, (a, b)) in accelerations.iter().zip(&ideal_solver.accelerations).enumerate() {
        assert!((a - b).abs() < 1e-9 * scale, "v̇[{i}]: {a} (cut + effective terms) vs {b} (ideal)");
    }
    // And the interface stays at rest: ẅ = W (−f̃) + a_free = 0.
    let w = &terms.mobility * (-&terms.effective_force) + &terms.free_acceleration;
    assert!(w.abs().max() < 1e-9 * terms.free_acceleration.abs().max().max(1.0), "ẅ = {w}");
}

#[test]
fn the_mobilities_equal_the_null_space_projection_of_the_cut_mechanism() {
    let (_, cut, interfaces, y) = e_state();
    let n = cut.coordinate_count();
    let (q, v) = y.split_at(n);
    let mut solver = SpatialSolver::new(&cut);
    let terms = spatial_effective_terms(&cut, &mut solver, &interfaces, 0.0, q, v).expect("terms");
    let nv = cut.velocity_count();
    // C of the cut mechanism, dense, and a basis N of its null space (eigenvectors of CᵀC with
    // zero eigenvalue).
    let rows = &solver.rows;
    let mut c = DMatrix::<f64>::zeros(rows.len(), nv);
    for (a, r) in rows.iter().enumerate() {
        for b in 0..2 {
            if let Some(k) = r.bodies[b] {
                for i in 0..6 {
                    c[(a, 6 * k + i)] = r.blocks[b][i];
                }
            }
        }
    }
    let eigen = (c.transpose() * &c).symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    let null: Vec<usize> = (0..nv).filter(|&i| eigen.eigenvalues[i] < 1e-10 * largest).collect();
    assert_eq!(null.len(), nv - rows.len(), "the cut mechanism's mobility");
    let basis = DMatrix::from_fn(nv, null.len(), |i, j| eigen.eigenvectors[(i, null[j])]);
    let mut m = DMatrix::<f64>::zeros(nv, nv);
    for (k, b) in cut.bodies.iter().enumerate() {
        for i in 0..3 {
            m[(6 * k + i, 6 * k + i)] = b.mass;
        }
        m.view_mut((6 * k + 3, 6 * k + 3), (3, 3)).copy_from(&b.inertia);
    }
    let reduced_inverse = (basis.transpose() * &m * &basis).try_inverse().expect("regular");
    let projector = &basis * reduced_inverse * basis.transpose();
    // J (n × nv) by rows: unit interface velocities read off the unit vectors of velocity space.
    let frames = &solver.frames;
    let point_rate = |body: BodyId, point: Vec3, x: &DVector<f64>| -> Vec3 {
        match body {
            BodyId::Ground => Vec3::zeros(),
            BodyId::Body(k) => {
                let a = &frames[k].rotation;
                Vec3::new(x[6 * k], x[6 * k + 1], x[6 * k + 2])
                    + (a * Vec3::new(x[6 * k + 3], x[6 * k + 4], x[6 * k + 5])).cross(&(a * point))
            }
        }
    };
    let mut j = DMatrix::<f64>::zeros(3 * interfaces.len(), nv);
    for col in 0..nv {
        let e = DVector::from_fn(nv, |i, _| if i == col { 1.0 } else { 0.0 });
        for (r, iface) in interfaces.iter().enumerate() {
            let w = point_rate(iface.journal_body, iface.journal_point, &e)
                - point_rate(iface.bearing_body, iface.bearing_point, &e);
            j.fixed_view_mut::<3, 1>(3 * r, col).copy_from(&w);
        }
    }
    let mobility = &j * &projector * j.transpose();
    let scale = mobility.abs().max();
    assert!((&mobility - &terms.mobility).abs().max() < 1e-9 * scale, "W: {mobility} vs {}", terms.mobility);
    // Friction-load columns: a unit load m = e is the torque R_J e on the ball's body and −R_B e
    // on the socket's; a world torque τ on body k is the load (0, Aᵀτ) in (ṙ, ω') space.
    assert_eq!(terms.moment_mobility.ncols(), 3 * interfaces.len());
    for (r, iface) in interfaces.iter().enumerate() {
        for axis in 0..3 {
            let mut load = DVector::<f64>::zeros(nv);
            for (body, arm) in [(iface.journal_body, iface.journal_radius), (iface.bearing_body, -iface.bearing_radius)]
            {
                let BodyId::Body(k) = body else { continue };
                let local = frames[k].rotation.transpose() * (Vec3::ith(axis, 1.0) * arm);
                for i in 0..3 {
                    load[6 * k + 3 + i] += local[i];
                }
            }
            let expected = &j * (&projector * load);
            let column = terms.moment_mobility.column(3 * r + axis);
            assert!(
                (expected - column).abs().max() < 1e-9 * terms.moment_mobility.abs().max(),
                "friction-load column {r} {axis}"
            );
        }
    }
}

/// The terms refreshed in place (one storage through several states, as the macro subsystem
/// keeps them) equal terms computed afresh at each state, bit for bit, for one joint and two.
#[test]
fn terms_refreshed_in_place_equal_fresh_ones_bit_for_bit() {
    let (_, cut, interfaces, y) = e_state();
    let n = cut.coordinate_count();
    let (q, v0) = y.split_at(n);
    for count in [1, 2] {
        let joints = &interfaces[..count];
        let (mut kept_solver, mut fresh_solver) = (SpatialSolver::new(&cut), SpatialSolver::new(&cut));
        let mut kept = SpatialCoupledTerms::zeros(v0.len(), cut.constraint_count(), count);
        for (i, scale) in [1.0, -0.5, 3.0, 0.0].into_iter().enumerate() {
            let v: Vec<f64> = v0.iter().map(|x| x * scale).collect();
            let t = 0.01 * i as f64;
            spatial_effective_terms_into(&cut, &mut kept_solver, joints, t, q, &v, &mut kept).expect("terms");
            let fresh = spatial_effective_terms(&cut, &mut fresh_solver, joints, t, q, &v).expect("terms");
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(kept.mobility.as_slice()), bits(fresh.mobility.as_slice()), "W, state {i}");
            let (a, b) =
                (kept.effective_mass.as_ref().expect("regular"), fresh.effective_mass.as_ref().expect("regular"));
            assert_eq!(bits(a.as_slice()), bits(b.as_slice()), "M̃, state {i}");
            assert_eq!(bits(kept.effective_force.as_slice()), bits(fresh.effective_force.as_slice()), "f̃, state {i}");
            assert_eq!(bits(kept.moment_mobility.as_slice()), bits(fresh.moment_mobility.as_slice()));
            assert_eq!(bits(kept.free_acceleration.as_slice()), bits(fresh.free_acceleration.as_slice()));
            assert_eq!(bits(&kept.free_accelerations), bits(&fresh.free_accelerations));
            assert_eq!(bits(&kept.free_lambda), bits(&fresh.free_lambda));
            for c in 0..6 * count {
                assert_eq!(bits(&kept.gain[c]), bits(&fresh.gain[c]), "gain column {c}, state {i}");
                assert_eq!(bits(&kept.lambda_gain[c]), bits(&fresh.lambda_gain[c]));
            }
        }
    }
}
