//! Single normal impacts of a free journal in a fixed bearing, run through the library's full
//! model and adaptive integrator, against a 1-DOF reference integrated here with its own RK4 and
//! its own copy of each law's formula.

use lash_contact::law::HysteresisParams;
use lash_contact::{ClearanceJoint, ContactLaw, FrictionLaw, Material};
use lash_full_model::FullModel;
use lash_mech::{Baumgarte, Body, BodyId, Mechanism, Vec2};
use lash_ode::{AdaptiveOptions, Method, integrate};

const MASS: f64 = 0.5;
const R_B: f64 = 0.010;
const R_J: f64 = 0.0095;
const C: f64 = R_B - R_J;

fn free_journal(law: &ContactLaw, friction: FrictionLaw, velocity: Vec2) -> FullModel {
    let mech = Mechanism {
        bodies: vec![Body {
            name: "journal".into(),
            mass: MASS,
            inertia: 1e-4,
            position: Vec2::zeros(),
            angle: 0.0,
            velocity,
            angular_velocity: 0.0,
        }],
        joints: vec![],
        drivers: vec![],
        loads: vec![],
        gravity: Vec2::zeros(),
        baumgarte: Baumgarte::default(),
    };
    let joint = ClearanceJoint {
        name: "bearing".into(),
        journal_body: BodyId::Body(0),
        journal_point: Vec2::zeros(),
        bearing_body: BodyId::Ground,
        bearing_point: Vec2::zeros(),
        journal_radius: R_J,
        bearing_radius: R_B,
        law: law.resolve(&Material::STEEL, &Material::STEEL, R_J, R_B),
        friction,
        bush_stiffness: f64::INFINITY,
        bush_damping: 0.0,
        film: None,
        in_contact: false,
        onset_velocity: 0.0,
    };
    FullModel::new(mech, vec![joint])
}

/// The journal centred and thrown with velocity `v` (no spin).
fn start(model: &mut FullModel, v: Vec2) -> Vec<f64> {
    let y = vec![0.0, 0.0, 0.0, v.x, v.y, 0.0];
    model.reset(0.0, &y);
    y
}

fn tight() -> Method {
    Method::Dopri5(AdaptiveOptions { rtol: 1e-11, atol: 1e-14, initial_step: 1e-7, max_step: 1e-4, min_step: 1e-12 })
}

/// Realised restitution −v_out/v_in of one impact through the library.
fn library_restitution(law: &ContactLaw, v_in: f64) -> f64 {
    let mut model = free_journal(law, FrictionLaw::None, Vec2::new(v_in, 0.0));
    let mut y = start(&mut model, Vec2::new(v_in, 0.0));
    // Reaches the wall at C / v_in; the contact lasts well under 1 ms.
    let t_end = C / v_in + 1e-3;
    integrate(
        &tight(),
        &mut model,
        0.0,
        &mut y,
        t_end,
        t_end / 4.0,
        &mut |_: &mut FullModel, _: f64, _: &[f64]| Ok(()),
    )
    .unwrap();
    assert_eq!(model.impacts()[0].len(), 1, "one impact expected");
    -y[3] / v_in
}

/// The same impact as a 1-DOF problem m δ̈ = −F(δ, δ̇), each law re-written here from its
/// published formula, integrated with a fixed-step RK4 at 1/20000 of the Hertz contact time.
fn reference_restitution(law: &ContactLaw, v_in: f64) -> f64 {
    let e_star = 207e9 / (2.0 * (1.0 - 0.3 * 0.3));
    let k_hertz = 4.0 / 3.0 * e_star * (R_J * R_B / C).sqrt();
    let force = |d: f64, v: f64| -> f64 {
        // δ = 0 with δ̇ > 0 is the first instant of contact (Kelvin–Voigt already pushes there).
        if d < 0.0 {
            return 0.0;
        }
        let f = match law {
            ContactLaw::Hertz { .. } => k_hertz * d.powf(1.5),
            ContactLaw::KelvinVoigt { stiffness, damping } => stiffness * d + damping * v,
            ContactLaw::HuntCrossley(p) => k_hertz * d.powf(1.5) * (1.0 + 1.5 * (1.0 - p.restitution) * v / v_in),
            ContactLaw::LankaraniNikravesh(p) => {
                k_hertz * d.powf(1.5) * (1.0 + 0.75 * (1.0 - p.restitution.powi(2)) * v / v_in)
            }
            ContactLaw::Gonthier(p) => {
                k_hertz * d.powf(1.5) * (1.0 + (1.0 - p.restitution.powi(2)) / p.restitution * v / v_in)
            }
            ContactLaw::Flores(p) => {
                k_hertz * d.powf(1.5) * (1.0 + 8.0 * (1.0 - p.restitution) / (5.0 * p.restitution) * v / v_in)
            }
            ContactLaw::HuGuo(p) => {
                k_hertz * d.powf(1.5) * (1.0 + 3.0 * (1.0 - p.restitution) / (2.0 * p.restitution) * v / v_in)
            }
            ContactLaw::AdamsImpact { max_damping, damping_depth, .. } => {
                let x = (d / damping_depth).min(1.0);
                k_hertz * d.powf(1.5) + max_damping * x * x * (3.0 - 2.0 * x) * v
            }
            ContactLaw::Liu { length, restitution, .. } => {
                let chi = restitution.map_or(0.0, |e| 0.75 * (1.0 - e * e));
                std::f64::consts::FRAC_PI_2
                    * e_star
                    * length
                    * d
                    * (d / (2.0 * (C + d))).sqrt()
                    * (1.0 + chi * v / v_in)
            }
        };
        f.max(0.0)
    };
    // State (δ, δ̇), starting at contact onset.
    let t_contact = 2.94 * (MASS * MASS / (k_hertz * k_hertz * v_in)).powf(0.2);
    let h = t_contact / 20000.0;
    let (mut d, mut v) = (0.0f64, v_in);
    let acc = |d: f64, v: f64| -force(d, v) / MASS;
    for _ in 0..10_000_000 {
        let (k1d, k1v) = (v, acc(d, v));
        let (k2d, k2v) = (v + 0.5 * h * k1v, acc(d + 0.5 * h * k1d, v + 0.5 * h * k1v));
        let (k3d, k3v) = (v + 0.5 * h * k2v, acc(d + 0.5 * h * k2d, v + 0.5 * h * k2v));
        let (k4d, k4v) = (v + h * k3v, acc(d + h * k3d, v + h * k3v));
        let (dn, vn) =
            (d + h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d), v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v));
        if dn <= 0.0 && vn < 0.0 {
            // Exit inside this step: the force vanishes at δ = 0; interpolate the velocity there.
            let frac = d / (d - dn);
            return -(v + frac * (vn - v)) / v_in;
        }
        d = dn;
        v = vn;
    }
    panic!("reference impact did not end");
}

fn hyst(restitution: f64) -> HysteresisParams {
    HysteresisParams { restitution, stiffness: None, exponent: 1.5, velocity_floor: 1e-5 }
}

fn dissipative_laws() -> Vec<(&'static str, ContactLaw)> {
    vec![
        ("hunt_crossley", ContactLaw::HuntCrossley(hyst(0.7))),
        ("lankarani_nikravesh", ContactLaw::LankaraniNikravesh(hyst(0.5))),
        ("gonthier", ContactLaw::Gonthier(hyst(0.7))),
        ("flores", ContactLaw::Flores(hyst(0.7))),
        ("hu_guo", ContactLaw::HuGuo(hyst(0.7))),
        ("kelvin_voigt", ContactLaw::KelvinVoigt { stiffness: 2e8, damping: 2e3 }),
        (
            "adams_impact",
            ContactLaw::AdamsImpact { stiffness: None, exponent: 1.5, max_damping: 5e3, damping_depth: 1e-6 },
        ),
        ("liu", ContactLaw::Liu { length: 0.02, restitution: Some(0.8), velocity_floor: 1e-5 }),
    ]
}

#[test]
fn realised_restitution_equals_independent_reference() {
    let v_in = 0.8;
    for (name, law) in dissipative_laws() {
        let lib = library_restitution(&law, v_in);
        let reference = reference_restitution(&law, v_in);
        assert!(lib > 0.05 && lib < 1.0, "{name}: realised restitution {lib} must show dissipation");
        assert!((lib - reference).abs() < 1e-8, "{name}: library {lib} vs reference {reference}");
    }
}

#[test]
fn realised_restitution_of_the_literature() {
    // The literature: Lankarani–Nikravesh realises ≈ 0.725 for a nominal 0.5 (its derivation
    // assumes high restitution); Flores and Hu–Guo track the nominal value closely.
    let ln = library_restitution(&ContactLaw::LankaraniNikravesh(hyst(0.5)), 1.0);
    assert!((ln - 0.725).abs() < 0.01, "LN realised {ln}");
    let fl = library_restitution(&ContactLaw::Flores(hyst(0.5)), 1.0);
    assert!((fl - 0.5).abs() < 0.03, "Flores realised {fl}");
    let hg = library_restitution(&ContactLaw::HuGuo(hyst(0.5)), 1.0);
    assert!((hg - 0.5).abs() < 0.03, "Hu-Guo realised {hg}");
}

#[test]
fn hertz_without_friction_conserves_energy_over_many_impacts() {
    // An oblique throw: the journal rattles around the bearing, dozens of impacts.
    let v0 = Vec2::new(0.9, 0.35);
    let mut model = free_journal(&ContactLaw::Hertz { stiffness: None, exponent: 1.5 }, FrictionLaw::None, v0);
    let mut y = start(&mut model, v0);
    let e0 = 0.5 * MASS * v0.norm_squared();
    let mut worst = 0.0f64;
    integrate(&tight(), &mut model, 0.0, &mut y, 0.05, 1e-4, &mut |m: &mut FullModel, t: f64, y: &[f64]| {
        // Kinetic + elastic energy at every sample (elastic: 2/5 K δ^2.5 inside contact).
        m.evaluate(t, y).map_err(|e| e.to_string())?;
        let c = m.contacts[0];
        let k = match m.clearances[0].law {
            lash_contact::NormalForce::Power { stiffness, .. } => stiffness,
            _ => unreachable!(),
        };
        let elastic = if c.penetration > 0.0 { 0.4 * k * c.penetration.powf(2.5) } else { 0.0 };
        let e = 0.5 * MASS * (y[3] * y[3] + y[4] * y[4]) + elastic;
        worst = worst.max((e / e0 - 1.0).abs());
        Ok(())
    })
    .unwrap();
    let impacts = model.impacts()[0].len();
    assert!(impacts >= 30, "only {impacts} impacts");
    assert!(worst < 1e-7, "relative energy error {worst} over {impacts} impacts");
}

#[test]
fn friction_turns_a_spinning_journal() {
    // Coulomb friction at an oblique impact spins the journal with the right sign. It hits the
    // wall at n ≈ (0.8, 0.6) moving along +x: ė·t = 0.8·(−0.6) < 0, so v_t < 0, F_T < 0 and the
    // friction moment about the centre, R_J n × (−F_T t) = −R_J F_T, is positive.
    let mut model = free_journal(
        &ContactLaw::LankaraniNikravesh(hyst(0.8)),
        FrictionLaw::Coulomb { coefficient: 0.05 },
        Vec2::zeros(),
    );
    // Thrown along x from 0.3 mm above the centre: the impact is oblique.
    let mut y = vec![0.0, 3e-4, 0.0, 0.8, 0.0, 0.0];
    model.reset(0.0, &y);
    let t_end = 4e-4 / 0.8 + 3e-4;
    integrate(&tight(), &mut model, 0.0, &mut y, t_end, t_end, &mut |_: &mut FullModel, _: f64, _: &[f64]| Ok(()))
        .unwrap();
    assert_eq!(model.impacts()[0].len(), 1);
    assert!(y[5] > 1.0, "spin after the impact: {} rad/s", y[5]);
    // Angular impulse equals the friction moment integrated: I Δω = R_J ∫ −F_T dt, and
    // |∫F_T| ≤ μ ∫F_N ≤ μ m |Δv_n|: a bound independent of the integrator.
    let dv = (y[3] - 0.8).hypot(y[4]);
    assert!(1e-4 * y[5] <= R_J * 0.05 * MASS * dv * (1.0 + 1e-9), "spin {} too large for μ = 0.05", y[5]);
}

/// A journal thrown at `v_in` into a bearing whose bush (stiffness `k_b`, damping `c_b`; 0: the
/// quasi-static series) sits behind the contact; integrated to `t_end`. Returns the journal's
/// velocity along x at the end and the peak contact force.
fn bushed_impact(law: &ContactLaw, k_b: f64, c_b: f64, v_in: f64, t_end: f64) -> (f64, f64) {
    let mut model = free_journal(law, FrictionLaw::None, Vec2::new(v_in, 0.0));
    model.clearances[0].bush_stiffness = k_b;
    model.clearances[0].bush_damping = c_b;
    let model = FullModel::new(model.mechanism.clone(), model.clearances.clone());
    let mut model = model;
    let mut y = vec![0.0, 0.0, 0.0, v_in, 0.0, 0.0];
    y.resize(lash_ode::OdeSystem::dim(&model), 0.0);
    model.reset(0.0, &y);
    integrate(&tight(), &mut model, 0.0, &mut y, t_end, t_end, &mut |_: &mut FullModel, _: f64, _: &[f64]| Ok(()))
        .unwrap();
    let peak = model.impacts()[0].iter().map(|i| i.peak_force).fold(0.0, f64::max);
    (y[3], peak)
}

/// The same journal as a 1-DOF problem with the bush's deflection s as a second state, written
/// here from the physics: m δ̈ = −F, F = K (δ − s)^1.5 (1 + χ (δ̇ − ṡ)/v_in) (Lankarani–Nikravesh)
/// carried by the bush, F = k_b s + c_b ṡ; contact only where δ > s and F > 0, the bush
/// relaxing (c_b ṡ = −k_b s) otherwise. Fixed-step RK4 over the whole run.
fn bushed_reference(restitution: f64, k_b: f64, c_b: f64, v_in: f64, t_end: f64) -> (f64, f64) {
    let e_star = 207e9 / (2.0 * (1.0 - 0.3 * 0.3));
    let k_hertz = 4.0 / 3.0 * e_star * (R_J * R_B / C).sqrt();
    let chi = 0.75 * (1.0 - restitution * restitution);
    // (force, ṡ) at (δ, δ̇, s): the contact's F at the bush's rate solves a linear equation in ṡ.
    let force = |d: f64, v: f64, s: f64| -> (f64, f64) {
        let relax = -k_b * s / c_b;
        let dc = d - s;
        if dc <= 0.0 {
            return (0.0, relax);
        }
        let elastic = k_hertz * dc * dc.sqrt();
        // k_b s + c_b ṡ = elastic (1 + χ (v − ṡ)/v_in)
        let s_dot = (elastic * (1.0 + chi * v / v_in) - k_b * s) / (c_b + elastic * chi / v_in);
        let f = k_b * s + c_b * s_dot;
        if f > 0.0 { (f, s_dot) } else { (0.0, relax) }
    };
    // δ = x − C for the journal thrown along x from the centre.
    let rhs = |y: [f64; 3]| -> [f64; 3] {
        let (f, s_dot) = force(y[0] - C, y[1], y[2]);
        [y[1], -f / MASS, s_dot]
    };
    let h = 2e-9;
    let steps = (t_end / h).round() as usize;
    let (mut y, mut peak) = ([0.0, v_in, 0.0], 0.0f64);
    for _ in 0..steps {
        let add = |a: [f64; 3], b: [f64; 3], s: f64| [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
        let k1 = rhs(y);
        let k2 = rhs(add(y, k1, 0.5 * h));
        let k3 = rhs(add(y, k2, 0.5 * h));
        let k4 = rhs(add(y, k3, h));
        for i in 0..3 {
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        peak = peak.max(force(y[0] - C, y[1], y[2]).0);
    }
    (y[1], peak)
}

#[test]
fn a_bush_damped_in_series_equals_an_independent_reference() {
    // A bush as stiff as the contact's secant at this impact (~3e8 N/m) with a relaxation time
    // c/k = 20 µs, a fifth of the contact's duration: it dissipates a visible share of the energy.
    let (restitution, k_b, v_in) = (0.8, 3e8, 0.8);
    let law = ContactLaw::LankaraniNikravesh(hyst(restitution));
    let t_end = C / v_in + 8e-4;
    let (v_quasi, peak_quasi) = bushed_impact(&law, k_b, 0.0, v_in, t_end);
    let (v_lib, peak_lib) = bushed_impact(&law, k_b, k_b * 2e-5, v_in, t_end);
    let (v_ref, peak_ref) = bushed_reference(restitution, k_b, k_b * 2e-5, v_in, t_end);
    assert!((v_lib - v_ref).abs() < 1e-7 * v_in, "outgoing velocity {v_lib} against {v_ref}");
    assert!((peak_lib / peak_ref - 1.0).abs() < 1e-5, "peak force {peak_lib} against {peak_ref}");
    // The bush's damping takes energy the quasi-static bush gives back: a lower restitution.
    assert!(-v_lib / v_in < -v_quasi / v_in - 0.02, "damped {v_lib} against quasi-static {v_quasi}");
    assert!(peak_lib < peak_quasi, "the damped bush lowers the peak: {peak_lib} against {peak_quasi}");
}

#[test]
fn a_bush_damped_in_series_tends_to_the_quasi_static_series_as_its_damping_vanishes() {
    // As c → 0 the bush's deflection follows its load (the singular limit of its state): the
    // outgoing velocity and the peak force converge linearly in c/k (successive differences
    // shrink tenfold per decade), to the quasi-static series within the latter's own
    // approximation (it splits the rate with the elastic tangent, where the limit's slow
    // manifold differentiates the damped force: a few tenths of a per cent here, with the bush
    // as stiff as the contact).
    let (k_b, v_in) = (3e8, 0.8);
    let law = ContactLaw::LankaraniNikravesh(hyst(0.8));
    let t_end = C / v_in + 4e-4;
    let (v0, p0) = bushed_impact(&law, k_b, 0.0, v_in, t_end);
    let runs: Vec<(f64, f64)> =
        [1e-6, 1e-7, 1e-8].iter().map(|tau| bushed_impact(&law, k_b, k_b * tau, v_in, t_end)).collect();
    let ratio = |f: fn(&(f64, f64)) -> f64| (f(&runs[0]) - f(&runs[1])) / (f(&runs[1]) - f(&runs[2]));
    for (what, r) in [("velocity", ratio(|r| r.0)), ("peak", ratio(|r| r.1))] {
        assert!((7.0..13.0).contains(&r), "{what}: successive differences shrink {r}× per decade of c/k");
    }
    assert!((runs[0].0 - v0).abs() > 1e-3 * v_in, "the damping shows at c/k = 1 µs");
    assert!((runs[2].0 - v0).abs() < 1e-4 * v_in, "velocity at 10 ns: {} against {v0}", runs[2].0);
    assert!((runs[2].1 / p0 - 1.0).abs() < 5e-3, "peak at 10 ns: {} against {p0}", runs[2].1);
}

#[test]
fn the_micro_model_integrates_a_bush_damped_in_series_like_the_reference() {
    // The same throw through the reduced model's micro subsystem alone: M̃ = m I, no effective
    // force, the bush's deflection integrated by the micro RK4 with the eccentricity.
    let (restitution, k_b, v_in) = (0.8, 3e8, 0.8);
    let law = ContactLaw::LankaraniNikravesh(hyst(restitution));
    let mut joint = free_journal(&law, FrictionLaw::None, Vec2::zeros()).clearances[0].clone();
    joint.bush_stiffness = k_b;
    joint.bush_damping = k_b * 2e-5;
    let mut m = lash_micro::PlanarInterfaceModel::<2, 1>::new(vec![joint]);
    m.inputs.effective_mass = nalgebra::SMatrix::<f64, 2, 2>::identity() * MASS;
    m.eccentricity_rate = nalgebra::SVector::<f64, 2>::new(v_in, 0.0);
    let t_end = C / v_in + 8e-4;
    let h = 1e-7;
    let steps = (t_end / h).round() as usize;
    let mut peak = 0.0f64;
    for i in 0..steps {
        m.rk4_step(i as f64 * h, h);
        peak = peak.max(m.states[0].normal_force);
    }
    let (v_ref, peak_ref) = bushed_reference(restitution, k_b, k_b * 2e-5, v_in, t_end);
    let v = m.eccentricity_rate[0];
    // RK4 at 1e-7 s and the peak sampled every step (measured: 2e-9 and 3e-7 of the reference).
    assert!((v - v_ref).abs() < 1e-8 * v_in, "outgoing velocity {v} against {v_ref}");
    assert!((peak / peak_ref - 1.0).abs() < 1e-5, "peak force {peak} against {peak_ref}");
    assert!(m.bush_deflection[0].abs() < 1e-9, "the bush has relaxed: {}", m.bush_deflection[0]);
}
