//! The bush characterisation against closed forms and its own convergence.

use lash_bush::{BushMaterial, BushSpec, characterise, hertz};

/// The bonded-pin stiffness equals the closed form of a rigid inclusion in an annulus with a
/// fixed outer surface (plane strain), for the study's bronze bush and for a thick, nearly
/// incompressible polymer one.
#[test]
fn bonded_pin_stiffness_equals_the_closed_form() {
    let polymer = BushSpec {
        pin_radius: 0.005,
        inner_radius: 0.005,
        outer_radius: 0.03,
        length: 0.05,
        material: BushMaterial {
            young_modulus: 1e9,
            poisson_ratio: 0.45,
            density: 1200.0,
            shear_viscosity: 1e5,
            bulk_viscosity: 3e5,
        },
        ..BushSpec::study()
    };
    for spec in [BushSpec::study(), polymer] {
        let t = characterise(&spec, &[]).unwrap();
        let relative = t.bonded.stiffness / t.bonded.stiffness_closed_form - 1.0;
        assert!(relative.abs() < 1e-5, "{relative:e}: {:?}", t.bonded);
    }
}

/// With viscosities proportional to the Lamé parameters (λ_v/μ_v = λ/μ) the damping on the static
/// shape is the stiffness times η_s/μ: the viscous energy form (integrated at the Gauss points)
/// against the reaction (from the element matrices).
#[test]
fn proportional_viscosity_gives_proportional_damping() {
    let mut spec = BushSpec::study();
    let (lambda, mu) = spec.lame();
    let eta = 300.0;
    spec.material.shear_viscosity = eta;
    spec.material.bulk_viscosity = eta * (lambda / mu + 2.0 / 3.0);
    let t = characterise(&spec, &[]).unwrap();
    let expected = t.bonded.stiffness * eta / mu;
    assert!((t.bonded.damping / expected - 1.0).abs() < 1e-9, "{} vs {expected}", t.bonded.damping);
}

/// Under the Hertz pressure the FE stress tends to the half-space's as the contact narrows
/// (b/a → 0), and stays above it by less than 2 b/a (the conforming bore and the finite wall);
/// for narrow contacts (b/a < 3 %) its maximum lies at the half-space's depth.
#[test]
fn the_interface_stress_tends_to_the_half_space_maximum() {
    let spec = BushSpec::study();
    let t = characterise(&spec, &[100.0, 300.0, 1e3, 5e3, 2e4]).unwrap();
    let (_, depth) = hertz::max_von_mises(spec.material.poisson_ratio);
    let mut last = 0.0;
    for p in &t.pressure {
        let ratio = p.half_width / spec.inner_radius;
        assert!(p.correction > 0.995 && p.correction < 1.0 + 2.0 * ratio, "{p:?}");
        assert!(p.correction >= last - 2e-3, "grows with the load: {p:?}");
        if ratio < 0.03 {
            assert!((p.von_mises_depth / p.half_width / depth - 1.0).abs() < 0.1, "{p:?}");
        }
        last = p.correction;
    }
    assert!((t.pressure[0].correction - 1.0).abs() < 0.015, "{:?}", t.pressure[0]);
}

/// A mesh twice as fine changes the stiffnesses by less than 1e-5 and the stress by less than
/// 0.3 %: the default mesh is converged.
#[test]
fn the_default_mesh_is_converged() {
    let loads = [1e3, 2e4];
    let coarse = BushSpec::study();
    let fine = BushSpec { mesh: coarse.mesh.refined(), ..coarse };
    let (a, b) = (characterise(&coarse, &loads).unwrap(), characterise(&fine, &loads).unwrap());
    assert!((a.bonded.stiffness / b.bonded.stiffness - 1.0).abs() < 1e-6);
    for (p, q) in a.pressure.iter().zip(&b.pressure) {
        assert!((p.stiffness / q.stiffness - 1.0).abs() < 1e-5, "{p:?} {q:?}");
        assert!((p.damping / q.damping - 1.0).abs() < 1e-4, "{p:?} {q:?}");
        assert!((p.von_mises / q.von_mises - 1.0).abs() < 3e-3, "{p:?} {q:?}");
    }
    assert!(b.elements > 3 * a.elements);
}

/// Bad input is an error naming the field.
#[test]
fn a_bad_bush_names_its_field() {
    let mut spec = BushSpec::study();
    spec.outer_radius = 0.005;
    spec.material.poisson_ratio = 0.5;
    let text = characterise(&spec, &[1e3]).unwrap_err().to_string();
    assert!(text.contains("outer_radius") && text.contains("material.poisson_ratio"), "{text}");
    assert!(characterise(&BushSpec::study(), &[-1.0]).unwrap_err().to_string().contains("loads"));
}

/// The interface-stress model returns the FE table's stress at the table's loads, Hertz's √F
/// scaling times the interpolated correction between them, and nothing without contact.
#[test]
fn the_interface_stress_model_follows_the_fe_table() {
    let spec = BushSpec::study();
    let model = lash_bush::InterfaceStress::of(&spec).unwrap();
    let table = characterise(&spec, &lash_bush::DEFAULT_LOADS).unwrap();
    for p in &table.pressure {
        assert!((model.von_mises(p.load) / p.von_mises - 1.0).abs() < 1e-12, "{p:?}");
    }
    // Between two loads: p₀ ∝ √F (Hertz) and the correction between its neighbours.
    let (a, b) = (&table.pressure[2], &table.pressure[3]);
    let f = (a.load * b.load).sqrt();
    let expected_p0 = a.peak_pressure * (f / a.load).sqrt();
    let c = model.correction(f);
    assert!(c > a.correction.min(b.correction) && c < a.correction.max(b.correction));
    assert!((model.von_mises(f) / (c * a.von_mises_hertz / a.peak_pressure * expected_p0) - 1.0).abs() < 1e-12);
    assert_eq!(model.von_mises(0.0), 0.0);
    assert_eq!(model.von_mises(-5.0), 0.0);
}
