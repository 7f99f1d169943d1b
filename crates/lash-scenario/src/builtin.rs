//! The built-in scenarios (A, B and their variants, radial engines), by name.
//!
//! * `A` — the reduced-interface-model papers' case: clearance at the crank–ground joint (c = 100 µm); `A-200um`.
//! * `B` — benchmark slider-crank, clearance at the rod–slider joint (c = 0.5 mm);
//!   `B-0.25mm`, `B-0.1mm`, `B-0.02mm`, and `B-frictionless`.
//! * `C` — A's and B's clearances in one mechanism; `F` — the flexible-bush crank–slider and its
//!   variants; `G` — a translational clearance joint (the slider a block in a guide), `G-driven`.
//!
//! Shared data: crank L1 = 0.05 m, 0.17 kg, 1.0e-4 kg m²; rod L2 = 0.12 m, 0.15 kg, 2.5e-4 kg m²
//! (centroids mid-length); slider 0.06 kg on the x axis through the crank pivot; crank at
//! 5000 rpm from angle 0; steel (E = 207 GPa, ν = 0.3); Lankarani–Nikravesh c_e = 0.9 (onset floor
//! 1e-5 m/s); Ambrósio friction μ = 0.01 (v0 = 1e-4, v1 = 1e-3 m/s); gravity off; horizon
//! 0.036 s; outputs every 1e-5 s. The slider's moment of inertia is not published: its rotation
//! is locked by the prismatic joint, so the value (1e-5 kg m²) has no influence.

use crate::schema::*;
use lash_contact::{BearingLength, ContactLaw, Film, FrictionLaw, Material, law::HysteresisParams};
use lash_mech::{Baumgarte, Motion};
use lash_ode::{AdaptiveOptions, Method};
use std::collections::BTreeMap;

/// Crank length L1 \[m\].
pub const CRANK_LENGTH: f64 = 0.05;
/// Connecting-rod length L2 \[m\].
pub const ROD_LENGTH: f64 = 0.12;
/// Crank speed ω [rad/s] (5000 rpm).
pub const CRANK_SPEED: f64 = 5000.0 * 2.0 * std::f64::consts::PI / 60.0;
/// Bearing radius of both benchmarks \[m\].
pub const BEARING_RADIUS: f64 = 0.010;

/// Names of the built-in scenarios.
pub const NAMES: [&str; 19] = [
    "A",
    "A-200um",
    "A-motor",
    "A-lubricated",
    "B",
    "B-0.25mm",
    "B-0.1mm",
    "B-0.02mm",
    "B-frictionless",
    "C",
    "F",
    "F-0.5mm",
    "F-0.25mm",
    "F-0.1mm",
    "F-rigid-perfect",
    "F-flexible-perfect",
    "F-flexible-imperfect",
    "G",
    "G-driven",
];

/// The built-in scenario called `name`, if any.
pub fn by_name(name: &str) -> Option<Scenario> {
    Some(match name {
        "A" => scenario_a(100e-6),
        "A-200um" => scenario_a(200e-6),
        "A-motor" => scenario_a_motor(),
        "A-lubricated" => scenario_a_lubricated(),
        "B" => scenario_b(0.5e-3),
        "B-0.25mm" => scenario_b(0.25e-3),
        "B-0.1mm" => scenario_b(0.1e-3),
        "B-0.02mm" => scenario_b(0.02e-3),
        "C" => scenario_c(),
        "F" => scenario_f(FJoint::Clearance(1e-3)),
        "F-0.5mm" => scenario_f(FJoint::Clearance(0.5e-3)),
        "F-0.25mm" => scenario_f(FJoint::Clearance(0.25e-3)),
        "F-0.1mm" => scenario_f(FJoint::Clearance(0.1e-3)),
        "F-rigid-perfect" => scenario_f(FJoint::Ideal),
        "F-flexible-perfect" => scenario_f(FJoint::Bush),
        "F-flexible-imperfect" => scenario_f(FJoint::BushWithClearance(1e-3)),
        "G" => scenario_g(false),
        "G-driven" => scenario_g(true),
        "B-frictionless" => {
            let mut s = scenario_b(0.5e-3);
            s.name = "B-frictionless".into();
            s.description = s.description.replacen(
                "at the rod–slider joint:",
                "at the rod–slider joint, frictionless (no friction law):",
                1,
            );
            s.clearances[0].friction = FrictionLaw::None;
            s
        }
        _ => return None,
    })
}

/// The integrator settings that converge the full model (docs/validation.md, convergence study):
/// DOP853 at rtol 1e-9 — at the same tolerance about 8× closer to the tight reference than
/// DOPRI5 over B's first 10 ms, and faster (docs/performance.md).
pub fn converged_integrator() -> Method {
    Method::Dop853(AdaptiveOptions { rtol: 1e-9, atol: 1e-12, initial_step: 1e-6, max_step: 1e-4, min_step: 1e-12 })
}

fn slider_crank(name: &str, description: &str) -> Scenario {
    let mut materials = BTreeMap::new();
    materials.insert("steel".to_string(), Material::STEEL);
    let (l1, l2) = (CRANK_LENGTH, ROD_LENGTH);
    let revolute = |name: &str, b1: &str, p1: [f64; 2], b2: &str, p2: [f64; 2]| JointSpec {
        name: name.into(),
        kind: JointType::Revolute,
        body1: b1.into(),
        point1: p1,
        body2: b2.into(),
        point2: p2,
        axis: None,
        angle_offset: None,
    };
    Scenario {
        name: name.into(),
        description: description.into(),
        gravity: [0.0, 0.0],
        materials,
        bodies: vec![
            BodySpec {
                name: "crank".into(),
                mass: 0.17,
                inertia: 1.0e-4,
                position: [l1 / 2.0, 0.0],
                angle: 0.0,
                velocity: [0.0, 0.0],
                angular_velocity: 0.0,
            },
            BodySpec {
                name: "rod".into(),
                mass: 0.15,
                inertia: 2.5e-4,
                position: [l1 + l2 / 2.0, 0.0],
                angle: 0.0,
                velocity: [0.0, 0.0],
                angular_velocity: 0.0,
            },
            BodySpec {
                name: "slider".into(),
                mass: 0.06,
                inertia: 1.0e-5,
                position: [l1 + l2, 0.0],
                angle: 0.0,
                velocity: [0.0, 0.0],
                angular_velocity: 0.0,
            },
        ],
        joints: vec![
            revolute("crank_pivot", "crank", [-l1 / 2.0, 0.0], "ground", [0.0, 0.0]),
            revolute("crank_rod", "crank", [l1 / 2.0, 0.0], "rod", [-l2 / 2.0, 0.0]),
            revolute("rod_slider", "slider", [0.0, 0.0], "rod", [l2 / 2.0, 0.0]),
            JointSpec {
                name: "slider_guide".into(),
                kind: JointType::Prismatic,
                body1: "slider".into(),
                point1: [0.0, 0.0],
                body2: "ground".into(),
                point2: [0.0, 0.0],
                axis: Some([1.0, 0.0]),
                angle_offset: Some(0.0),
            },
        ],
        drivers: vec![DriverSpec {
            name: "motor".into(),
            body: "crank".into(),
            reference: "ground".into(),
            motion: Motion::ConstantSpeed { angle0: 0.0, omega: CRANK_SPEED },
        }],
        loads: vec![],
        clearances: vec![],
        bushings: vec![],
        guides: vec![],
        sensors: vec![SensorSpec { name: "slider".into(), body: "slider".into(), point: [0.0, 0.0] }],
        simulation: SimulationSpec {
            start_time: 0.0,
            horizon: 0.036,
            output_interval: 1e-5,
            integrator: converged_integrator(),
            baumgarte: Baumgarte::default(),
        },
        output: OutputSpec::default(),
    }
}

fn clearance(joint: &str, journal: &str, c: f64, friction: FrictionLaw) -> ClearanceSpec {
    ClearanceSpec {
        joint: joint.into(),
        journal: journal.into(),
        journal_radius: BEARING_RADIUS - c,
        bearing_radius: BEARING_RADIUS,
        journal_material: Some("steel".into()),
        bearing_material: Some("steel".into()),
        contact: ContactLaw::LankaraniNikravesh(HysteresisParams {
            restitution: 0.9,
            stiffness: None,
            exponent: 1.5,
            velocity_floor: 1e-5,
        }),
        friction,
        bush: None,
        film: None,
    }
}

const AMBROSIO: FrictionLaw = FrictionLaw::Ambrosio { coefficient: 0.01, v0: 1e-4, v1: 1e-3 };

/// Scenario B with radial clearance `c` \[m\] at the rod–slider joint.
pub fn scenario_b(c: f64) -> Scenario {
    let name = if c == 0.5e-3 { "B".to_string() } else { format!("B-{}mm", c * 1e3) };
    let mut s = slider_crank(
        &name,
        &format!(
            "Benchmark slider-crank (Flores-type, scenario B), {} mm radial clearance at the rod–slider joint: \
             the journal is the slider pin, the bearing is in the rod's small end.",
            c * 1e3
        ),
    );
    s.clearances.push(clearance("rod_slider", "slider", c, AMBROSIO));
    s
}

/// Scenario A with radial clearance `c` \[m\] at the crank–ground joint.
pub fn scenario_a(c: f64) -> Scenario {
    let name = if c == 100e-6 { "A".to_string() } else { format!("A-{}um", (c * 1e6).round()) };
    let mut s = slider_crank(
        &name,
        &format!(
            "The reduced-interface-model papers' case (scenario A), {} µm radial clearance at the crank–ground \
             joint, 5000 rpm: the bearing is fixed to the ground at the origin, the journal is the crank's \
             pivot pin; the crank's absolute angle is prescribed.",
            (c * 1e6).round()
        ),
    );
    s.clearances.push(clearance("crank_pivot", "crank", c, AMBROSIO));
    s
}

/// Scenario A with its crank–ground joint lubricated: a short journal bearing (10 mm pin, 5 mm
/// long, L/D = 0.25) in oil of 0.2 Pa·s (an SAE 50 engine oil near 40 °C, ISO VG 220), mixed
/// lubrication below 5 % of the clearance; the same contact and friction laws where the journal
/// touches. At 5000 rpm the pin's mean load (about 3.4 kN) is beyond what this film carries
/// away from the wall, so the journal runs near it: the film acts mostly as a squeeze damper.
pub fn scenario_a_lubricated() -> Scenario {
    let mut s = scenario_a(100e-6);
    s.name = "A-lubricated".into();
    s.description = "Scenario A with its crank–ground joint lubricated: a short journal bearing 5 mm long \
                     (L/D = 0.25) in an SAE 50 oil near 40 °C (0.2 Pa·s), the film's force by the short-bearing \
                     closed form with half-film cavitation, mixed lubrication below 5 % of the 100 µm clearance, \
                     the dry contact and friction laws where the journal touches."
        .into();
    s.clearances[0].film = Some(Film {
        viscosity: 0.2,
        length: 0.005,
        bearing: BearingLength::Short,
        mixed_fraction: Film::MIXED_FRACTION,
    });
    s
}

/// Scenario C: two clearance joints in one mechanism — scenario A's clearance at the crank–ground
/// joint (100 µm) and scenario B's at the rod–slider joint (here 100 µm), the same links, speed,
/// materials, contact and friction laws. The two interfaces are coupled through the mechanism
/// (the off-diagonal blocks of the effective mass).
pub fn scenario_c() -> Scenario {
    let mut s = slider_crank(
        "C",
        "Two clearance joints (scenario C): scenario A's clearance at the crank–ground joint and a \
         clearance at the rod–slider joint, both 100 µm radial; the crank's absolute angle is prescribed, \
         its pivot free inside the ground bearing, the slider pin free inside the rod's small end.",
    );
    s.clearances.push(clearance("crank_pivot", "crank", 100e-6, AMBROSIO));
    s.clearances.push(clearance("rod_slider", "slider", 100e-6, AMBROSIO));
    s
}

/// The rod–slider joint of scenario F.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FJoint {
    /// Rigid and perfect: an ideal revolute joint.
    Ideal,
    /// Rigid and imperfect: radial clearance c \[m\] (bore 10 mm + c around the 10 mm pin).
    Clearance(f64),
    /// Flexible and perfect: the bronze bush (bore 10 mm = pin, outer 20 mm, 32 mm long) by finite
    /// elements, no clearance.
    Bush,
    /// Flexible and imperfect: radial clearance c \[m\] in the bronze bush (bore 10 mm + c), the
    /// contact in series with the bush's structural stiffness.
    BushWithClearance(f64),
}

const BRONZE: lash_bush::BushMaterial = lash_bush::BushMaterial::TIN_BRONZE;

/// The bronze bush of scenario F around its 10 mm pin, bore `bore` \[m\].
pub fn scenario_f_bush(bore: f64) -> lash_bush::BushSpec {
    lash_bush::BushSpec { pin_radius: 0.010, inner_radius: bore, ..lash_bush::BushSpec::study() }
}

/// Scenario F: the crank–slider of the flexible-bush study at 3000 rpm (crank 0.14 m, 1.30 kg,
/// 5e-2 kg m²; rod 0.32 m, 3.37 kg, 3.2e-2 kg m²; slider 2.2 kg), its rod–slider joint (the
/// piston pin in a tin-bronze bush pressed into the rod's small end) ideal, with clearance, or
/// flexible. The study prints the bush's radii as 0.10/0.11/0.20 m, which cannot fit a 0.14 m
/// crank: they are read as 10/11/20 mm (1 mm radial clearance). No gravity (the study gives none;
/// the inertia loads are 10³ times the weights).
pub fn scenario_f(joint: FJoint) -> Scenario {
    let (name, what) = match joint {
        FJoint::Ideal => ("F-rigid-perfect".to_string(), "rigid and perfect (ideal revolute)".to_string()),
        FJoint::Clearance(1e-3) => ("F".to_string(), "rigid with 1 mm radial clearance".to_string()),
        FJoint::Clearance(c) => (format!("F-{}mm", c * 1e3), format!("rigid with {} mm radial clearance", c * 1e3)),
        FJoint::Bush => (
            "F-flexible-perfect".to_string(),
            "flexible without clearance (the bronze bush by finite elements)".to_string(),
        ),
        FJoint::BushWithClearance(c) => (
            "F-flexible-imperfect".to_string(),
            format!("flexible with {} mm radial clearance (contact in series with the bronze bush)", c * 1e3),
        ),
    };
    let mut s = slider_crank(
        &name,
        &format!(
            "Flexible-bush crank–slider (scenario F), 3000 rpm, rod–slider joint {what}: crank 0.14 m, rod \
             0.32 m, slider 2.2 kg; the rod–slider joint is the piston pin in a tin-bronze bush in the rod's \
             small end."
        ),
    );
    let (l1, l2) = (0.14, 0.32);
    s.materials.insert(
        "bronze".to_string(),
        Material { young_modulus: BRONZE.young_modulus, poisson_ratio: BRONZE.poisson_ratio },
    );
    let masses = [(1.30, 5e-2, l1 / 2.0), (3.37, 3.2e-2, l1 + l2 / 2.0), (2.2, 1e-3, l1 + l2)];
    for (b, (m, j, x)) in s.bodies.iter_mut().zip(masses) {
        b.mass = m;
        b.inertia = j;
        b.position = [x, 0.0];
    }
    s.joints[0].point1 = [-l1 / 2.0, 0.0];
    s.joints[1].point1 = [l1 / 2.0, 0.0];
    s.joints[1].point2 = [-l2 / 2.0, 0.0];
    s.joints[2].point2 = [l2 / 2.0, 0.0];
    s.drivers[0].motion = Motion::ConstantSpeed { angle0: 0.0, omega: 3000.0 * 2.0 * std::f64::consts::PI / 60.0 };
    s.simulation.horizon = 0.06;
    match joint {
        FJoint::Ideal => {}
        FJoint::Clearance(c) | FJoint::BushWithClearance(c) => {
            let mut spec = clearance("rod_slider", "slider", 0.0, AMBROSIO);
            spec.journal_radius = 0.010;
            spec.bearing_radius = 0.010 + c;
            if matches!(joint, FJoint::BushWithClearance(_)) {
                // The bush is the bearing surface: its material is the bearing's.
                spec.bearing_material = None;
                spec.bush = Some(scenario_f_bush(0.010 + c));
            } else {
                spec.bearing_material = Some("bronze".into());
            }
            s.clearances.push(spec);
        }
        FJoint::Bush => s.bushings.push(BushingSpec {
            joint: "rod_slider".into(),
            stiffness: None,
            damping: None,
            bush: Some(scenario_f_bush(0.010)),
            curve: None,
        }),
    }
    s
}

/// Scenario G: the slider-crank of Flores, Leine & Glocker's study of translational clearance
/// joints (Multibody Syst. Dyn. 23:165, 2010, Table 1): crank 0.153 m, 0.038 kg, 7.4e-5 kg m²;
/// rod 0.306 m, 0.038 kg, 5.9e-4 kg m²; slider a block 0.10 × 0.05 m, 0.076 kg, 2.7e-6 kg m², in
/// a guide with 1 mm clearance either side; gravity. Free motion from the aligned position with
/// the crank at 150 rad/s and the rod at −75 rad/s (the slider at rest), or (`driven`) the crank
/// held at 150 rad/s. The study's impacts are rigid with restitution 0.4; here each corner meets
/// its face through Flores' hysteresis law with restitution 0.4 and a Hertz stiffness of a 1 mm
/// edge radius on steel, K = (4/3) E* √R.
pub fn scenario_g(driven: bool) -> Scenario {
    let (name, how) = if driven {
        ("G-driven", "crank driven at 150 rad/s")
    } else {
        ("G", "free motion from crank 150 rad/s, rod −75 rad/s")
    };
    let mut s = slider_crank(
        name,
        &format!(
            "Translational clearance joint (scenario G), {how}: a slider-crank whose slider is a block \
             0.10 × 0.05 m in a guide with 1 mm clearance either side; crank 0.153 m, rod 0.306 m, gravity; \
             no friction, restitution 0.4 at the block's corners."
        ),
    );
    let (l1, l2) = (0.153, 0.306);
    // Mass, inertia, centroid x, angular velocity and the centroid's upward speed of the
    // crank, the rod and the slider: the rod's −75 rad/s brings the slider end to rest.
    let (w1, w2) = (150.0, -75.0);
    let bodies = [
        (0.038, 7.4e-5, l1 / 2.0, w1, w1 * l1 / 2.0),
        (0.038, 5.9e-4, l1 + l2 / 2.0, w2, w1 * l1 + w2 * l2 / 2.0),
        (0.076, 2.7e-6, l1 + l2, 0.0, w1 * l1 + w2 * l2),
    ];
    for (b, (m, j, x, w, vy)) in s.bodies.iter_mut().zip(bodies) {
        (b.mass, b.inertia, b.position, b.angular_velocity, b.velocity) = (m, j, [x, 0.0], w, [0.0, vy]);
    }
    s.joints[0].point1 = [-l1 / 2.0, 0.0];
    s.joints[1].point1 = [l1 / 2.0, 0.0];
    s.joints[1].point2 = [-l2 / 2.0, 0.0];
    s.joints[2].point2 = [l2 / 2.0, 0.0];
    if driven {
        s.drivers[0].motion = Motion::ConstantSpeed { angle0: 0.0, omega: 150.0 };
    } else {
        s.drivers.clear();
    }
    s.gravity = [0.0, -9.81];
    s.simulation.horizon = 0.2;
    s.simulation.output_interval = 1e-4;
    let edge_radius: f64 = 1e-3;
    let stiffness =
        4.0 / 3.0 * lash_contact::law::effective_modulus(&Material::STEEL, &Material::STEEL) * edge_radius.sqrt();
    s.guides.push(GuideSpec {
        joint: "slider_guide".into(),
        slider: "slider".into(),
        length: 0.10,
        height: 0.05,
        clearance: 1e-3,
        contact: ContactLaw::Flores(HysteresisParams {
            restitution: 0.4,
            stiffness: Some(stiffness),
            exponent: 1.5,
            velocity_floor: 1e-5,
        }),
        friction: FrictionLaw::None,
    });
    s
}

/// Scenario A (c = 200 µm) with the crank turned by a motor instead of a prescribed angle: the
/// crank's speed is free, so the clearance changes it (the two-way coupling case).
pub fn scenario_a_motor() -> Scenario {
    let mut s = scenario_a(200e-6);
    s.name = "A-motor".into();
    s.description = "Scenario A (c = 200 µm) with a torque-driven crank: a DC-motor line \
                     T = 5 N m (1 − ω / 600 rad/s) turns the crank, which starts at 5000 rpm; the crank speed \
                     is free, so the clearance changes it (two-way coupling)."
        .into();
    s.drivers.clear();
    s.loads.push(LoadSpec::Motor { body: "crank".into(), stall_torque: 5.0, no_load_speed: 600.0 });
    let crank = s.bodies.iter_mut().find(|b| b.name == "crank").expect("crank");
    crank.angular_velocity = CRANK_SPEED;
    crank.velocity = [0.0, CRANK_SPEED * CRANK_LENGTH / 2.0];
    // At crank angle 0 (dead centre) the slider is at rest and the rod turns about it.
    let rod = s.bodies.iter_mut().find(|b| b.name == "rod").expect("rod");
    rod.velocity = [0.0, CRANK_SPEED * CRANK_LENGTH / 2.0];
    rod.angular_velocity = -CRANK_SPEED * CRANK_LENGTH / ROD_LENGTH;
    s.sensors.push(SensorSpec { name: "crank_tip".into(), body: "crank".into(), point: [CRANK_LENGTH / 2.0, 0.0] });
    s
}

/// A planar radial engine of `cylinders` slider-cranks on one star-shaped crank (pins at
/// 2πk/N, all at top dead centre at t = 0), crank driven at 5000 rpm about its centroid, clearance
/// of 100 µm at the crank–ground joint: 1 + 2N bodies, for the scaling benchmark. Each unit has
/// scenario A's rod and slider; the crank's mass and inertia grow with N.
pub fn radial_engine(cylinders: usize) -> Scenario {
    let mut s = slider_crank(
        &format!("radial-{cylinders}"),
        "Radial engine for the scaling benchmark: N slider-cranks on one crank, clearance at the \
         crank–ground joint.",
    );
    let (l1, l2) = (CRANK_LENGTH, ROD_LENGTH);
    let n = cylinders.max(1);
    let crank = s.bodies[0].clone();
    let (rod, slider) = (s.bodies[1].clone(), s.bodies[2].clone());
    s.bodies = vec![BodySpec {
        position: [0.0, 0.0],
        mass: crank.mass * n as f64,
        inertia: crank.inertia * n as f64,
        angular_velocity: CRANK_SPEED,
        ..crank
    }];
    let guide = s.joints[3].clone();
    let pivot = JointSpec { point1: [0.0, 0.0], ..s.joints[0].clone() };
    let pin = s.joints[1].clone();
    let small_end = s.joints[2].clone();
    s.joints = vec![pivot];
    s.sensors.clear();
    for k in 0..n {
        let phi = std::f64::consts::TAU * k as f64 / n as f64;
        let (c, sn) = (phi.cos(), phi.sin());
        let at = |r: f64| [r * c, r * sn];
        s.bodies.push(BodySpec { name: format!("rod{k}"), position: at(l1 + l2 / 2.0), angle: phi, ..rod.clone() });
        s.bodies.push(BodySpec { name: format!("slider{k}"), position: at(l1 + l2), angle: phi, ..slider.clone() });
        s.joints.push(JointSpec {
            name: format!("crank_rod{k}"),
            body2: format!("rod{k}"),
            point1: at(l1),
            ..pin.clone()
        });
        s.joints.push(JointSpec {
            name: format!("rod{k}_slider{k}"),
            body1: format!("slider{k}"),
            body2: format!("rod{k}"),
            ..small_end.clone()
        });
        s.joints.push(JointSpec {
            name: format!("guide{k}"),
            body1: format!("slider{k}"),
            axis: Some([c, sn]),
            angle_offset: Some(phi),
            ..guide.clone()
        });
        s.sensors.push(SensorSpec { name: format!("slider{k}"), body: format!("slider{k}"), point: [0.0, 0.0] });
    }
    s.clearances.push(clearance("crank_pivot", "crank", 100e-6, AMBROSIO));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_is_valid_and_round_trips_through_toml() {
        for name in NAMES {
            let s = by_name(name).unwrap();
            assert!(crate::validate(&s).is_empty(), "{name}: {}", crate::validate(&s));
            let text = toml::to_string(&s).unwrap();
            let back = crate::parse(&text).unwrap_or_else(|p| panic!("{name}: {p}"));
            assert_eq!(back, s, "{name}");
        }
        assert!(by_name("D").is_none());
    }

    #[test]
    fn radial_engines_are_valid_and_one_cylinder_is_a_slider_crank() {
        for n in [1, 2, 5, 9] {
            let s = radial_engine(n);
            assert!(crate::validate(&s).is_empty(), "{n}: {}", crate::validate(&s));
            assert_eq!(s.bodies.len(), 1 + 2 * n);
        }
    }
}
