//! The built-in spatial scenarios: E, a spatial slider-crank with two spherical clearance joints.
//!
//! Ground frame: X along the slider axis, Y up, Z lateral; gravity −9.81 m/s² along Y. The crank
//! (r = 50 mm, 0.30 kg, centroid at r/2, principal inertias 1.25e-5 along the arm and 1.33e-4
//! kg m² across) turns about Y through the origin; its ball sits at r (cos θ, 0, −sin θ) with
//! θ = θ0 + ωt, θ0 = asin(e/r). The rod (ball centre to ball centre L = 250 mm, 0.25 kg, 1.30e-3
//! kg m² transverse, 1.0e-5 axial) has a Ø12 mm socket at each end. The slider (0.60 kg, 1.7e-4
//! kg m² about each axis) carries the second ball at its centroid and translates without rotating
//! along X on the line (0, h, −e), h = 60 mm, e = 20 mm, so x_s(θ) = r cos θ + √(L² − h² −
//! (r sin θ − e)²); at θ0 the rod lies in the plane z = −e. Both balls are Ø11.5 mm (radial
//! clearance 0.25 mm) or Ø11 mm (0.5 mm); steel on steel, ADAMS IMPACT (exponent 1.5, Hertz
//! stiffness of a ball in a spherical socket, C_max = 1e4 N s/m, d_max = 1e-5 m) and ADAMS
//! stick–slip friction (μ_s = 0.2, μ_d = 0.1, v_s = 1e-4, v_d = 1e-3 m/s), or none. The crank
//! turns at 125 or 250 rpm; balls start centred with the ideal velocities; outputs every 1e-5 s
//! over two crank revolutions. The guide's reaction on the ground is the bearing force
//! (`slider_guide.fx/fy/fz`); `slider` is an accelerometer on the slider. The measured vibration is
//! emulated as the seed's rig took it: the bearing as a housing of 1.05 kg (bearing and two 25 g
//! accelerometers) on a three-axis mount to the ground (f_n = 150 Hz, ζ = 0.05) driven by that
//! reaction, logged at 500 Hz behind a fourth-order Butterworth anti-alias filter at 200 Hz over
//! the second revolution (`housing.ax/ay/az`, `measurement_housing.csv`).

use crate::schema::{ClearanceSpec, MeasurementSpec, OutputSpec, SimulationSpec};
use crate::spatial::{Space, SpatialBodySpec, SpatialDriverSpec, SpatialJointSpec, SpatialScenario, SpatialSensorSpec};
use lash_contact::{ContactLaw, FrictionLaw, Material};
use lash_mech::{Baumgarte, Motion};
use lash_spatial::SpatialJointKind;
use std::collections::BTreeMap;

/// Crank radius r \[m\].
pub const E_CRANK_RADIUS: f64 = 0.05;
/// Rod length L \[m\].
pub const E_ROD_LENGTH: f64 = 0.25;
/// Height h of the slider line above the crank axis \[m\].
pub const E_HEIGHT: f64 = 0.06;
/// Lateral offset e of the slider line \[m\].
pub const E_OFFSET: f64 = 0.02;
/// Socket radius \[m\].
pub const E_SOCKET_RADIUS: f64 = 0.006;

/// Names of the built-in spatial scenarios.
pub const SPATIAL_NAMES: [&str; 9] = [
    "E",
    "E-0.25mm-125rpm",
    "E-0.25mm-250rpm",
    "E-0.5mm-125rpm",
    "E-0.5mm-250rpm",
    "E-0.25mm-125rpm-frictionless",
    "E-0.25mm-250rpm-frictionless",
    "E-0.5mm-125rpm-frictionless",
    "E-0.5mm-250rpm-frictionless",
];

/// The built-in spatial scenario called `name`, if any.
pub fn spatial_by_name(name: &str) -> Option<SpatialScenario> {
    if name == "E" {
        let mut s = scenario_e(0.5e-3, 250.0, true);
        s.name = "E".into();
        s.description = format!("The default spatial case, E-0.5mm-250rpm under a short name. {}", s.description);
        return Some(s);
    }
    let rest = name.strip_prefix("E-")?;
    let (rest, friction) = match rest.strip_suffix("-frictionless") {
        Some(r) => (r, false),
        None => (rest, true),
    };
    let (clearance, rpm) = match rest {
        "0.25mm-125rpm" => (0.25e-3, 125.0),
        "0.25mm-250rpm" => (0.25e-3, 250.0),
        "0.5mm-125rpm" => (0.5e-3, 125.0),
        "0.5mm-250rpm" => (0.5e-3, 250.0),
        _ => return None,
    };
    Some(scenario_e(clearance, rpm, friction))
}

/// The initial crank angle θ0 = asin(e/r) \[rad\].
pub fn e_initial_angle() -> f64 {
    (E_OFFSET / E_CRANK_RADIUS).asin()
}

/// The slider's closed-form position x_s(θ) \[m\].
pub fn e_slider_position(theta: f64) -> f64 {
    let (r, l, h, e) = (E_CRANK_RADIUS, E_ROD_LENGTH, E_HEIGHT, E_OFFSET);
    r * theta.cos() + (l * l - h * h - (r * theta.sin() - e).powi(2)).sqrt()
}

/// Scenario E with radial clearance `clearance` \[m\] at both spherical joints, the crank at `rpm`,
/// with ADAMS stick–slip friction or frictionless.
pub fn scenario_e(clearance: f64, rpm: f64, friction: bool) -> SpatialScenario {
    let (r, l, h, e) = (E_CRANK_RADIUS, E_ROD_LENGTH, E_HEIGHT, E_OFFSET);
    let theta0 = e_initial_angle();
    let omega = rpm * std::f64::consts::PI / 30.0;
    let pin = [r * theta0.cos(), 0.0, -r * theta0.sin()];
    let x_s = e_slider_position(theta0);
    let phi = h.atan2(x_s - pin[0]); // the rod's angle in the plane z = −e
    let half = |a: f64| ((0.5 * a).cos(), (0.5 * a).sin());
    let (cy, sy) = half(theta0);
    let (cz, sz) = half(phi);
    let body = |name: &str, mass: f64, inertia: [f64; 3], position: [f64; 3], orientation: [f64; 4]| SpatialBodySpec {
        name: name.into(),
        mass,
        inertia,
        products: [0.0; 3],
        position,
        orientation,
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
    };
    let mut crank =
        body("crank", 0.30, [1.25e-5, 1.33e-4, 1.33e-4], [pin[0] / 2.0, 0.0, pin[2] / 2.0], [cy, 0.0, sy, 0.0]);
    crank.angular_velocity = [0.0, omega, 0.0];
    let rod = body("rod", 0.25, [1.0e-5, 1.30e-3, 1.30e-3], [(pin[0] + x_s) / 2.0, h / 2.0, -e], [cz, 0.0, 0.0, sz]);
    let slider = body("slider", 0.60, [1.7e-4, 1.7e-4, 1.7e-4], [x_s, h, -e], [1.0, 0.0, 0.0, 0.0]);
    let joint = |name: &str, kind, body1: &str, point1, body2: &str, point2, axes: Option<([f64; 3], [f64; 3])>| {
        SpatialJointSpec {
            name: name.into(),
            kind,
            body1: body1.into(),
            point1,
            body2: body2.into(),
            point2,
            axis1: axes.map(|a| a.0),
            axis2: axes.map(|a| a.0),
            reference1: axes.map(|a| a.1),
            reference2: axes.map(|a| a.1),
        }
    };
    let joints = vec![
        joint(
            "crank_pivot",
            SpatialJointKind::Revolute,
            "ground",
            [0.0; 3],
            "crank",
            [-r / 2.0, 0.0, 0.0],
            Some(([0.0, 1.0, 0.0], [1.0, 0.0, 0.0])),
        ),
        joint(
            "crank_rod",
            SpatialJointKind::Spherical,
            "crank",
            [r / 2.0, 0.0, 0.0],
            "rod",
            [-l / 2.0, 0.0, 0.0],
            None,
        ),
        joint("rod_slider", SpatialJointKind::Spherical, "rod", [l / 2.0, 0.0, 0.0], "slider", [0.0; 3], None),
        joint(
            "slider_guide",
            SpatialJointKind::Translational,
            "ground",
            [0.0, h, -e],
            "slider",
            [0.0; 3],
            Some(([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])),
        ),
    ];
    let friction_law = if friction {
        FrictionLaw::AdamsStickSlip {
            static_coefficient: 0.2,
            dynamic_coefficient: 0.1,
            stiction_velocity: 1e-4,
            friction_velocity: 1e-3,
        }
    } else {
        FrictionLaw::None
    };
    let clearance_of = |joint: &str, journal: &str| ClearanceSpec {
        joint: joint.into(),
        journal: journal.into(),
        journal_radius: E_SOCKET_RADIUS - clearance,
        bearing_radius: E_SOCKET_RADIUS,
        journal_material: Some("steel".into()),
        bearing_material: Some("steel".into()),
        contact: ContactLaw::AdamsImpact { stiffness: None, exponent: 1.5, max_damping: 1e4, damping_depth: 1e-5 },
        friction: friction_law,
        bush: None,
        film: None,
    };
    let clearance_mm = clearance * 1e3;
    let name = format!("E-{clearance_mm}mm-{rpm}rpm{}", if friction { "" } else { "-frictionless" });
    SpatialScenario {
        name,
        space: Space::Spatial,
        description: format!(
            "Spatial slider-crank with spherical clearance joints of {clearance_mm} mm at the crank–rod and rod–slider \
             joints, crank at {rpm} rpm, ADAMS IMPACT contact{}, gravity along −Y. Balls start centred with the ideal \
             velocities; two crank revolutions.",
            if friction { " and ADAMS stick–slip friction" } else { ", frictionless" }
        ),
        gravity: [0.0, -9.81, 0.0],
        materials: BTreeMap::from([("steel".to_string(), Material::STEEL)]),
        bodies: vec![crank, rod, slider],
        joints,
        drivers: vec![SpatialDriverSpec {
            name: "crank_drive".into(),
            joint: "crank_pivot".into(),
            motion: Motion::ConstantSpeed { angle0: theta0, omega },
        }],
        loads: vec![],
        clearances: vec![clearance_of("crank_rod", "crank"), clearance_of("rod_slider", "slider")],
        sensors: vec![SpatialSensorSpec { name: "slider".into(), body: "slider".into(), point: [0.0; 3] }],
        simulation: SimulationSpec {
            start_time: 0.0,
            horizon: 2.0 * 60.0 / rpm,
            output_interval: 1e-5,
            integrator: crate::builtin::converged_integrator(),
            baumgarte: Baumgarte::default(),
        },
        output: OutputSpec {
            channels: Vec::new(),
            measurements: vec![MeasurementSpec {
                name: "housing".into(),
                forces: vec!["slider_guide.fx".into(), "slider_guide.fy".into(), "slider_guide.fz".into()],
                mount: lash_measure::Mount { mass: 1.05, natural_frequency: 150.0, damping_ratio: 0.05 },
                acquisition: lash_measure::Acquisition {
                    sample_rate: 500.0,
                    cutoff: 200.0,
                    order: 4,
                    settle: 60.0 / rpm,
                },
            }],
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spatial_built_in_is_valid_and_named_as_listed() {
        for name in SPATIAL_NAMES {
            let s = spatial_by_name(name).expect("listed");
            let problems = crate::spatial::validate_spatial(&s);
            assert!(problems.is_empty(), "{name}: {problems}");
            assert!(name == "E" || s.name == name, "{name} is called {}", s.name);
            let text = toml::to_string(&s).expect("serializes");
            assert_eq!(crate::spatial::parse_spatial(&text).expect("parses"), s, "{name} round trip");
        }
        assert!(spatial_by_name("E-1mm-125rpm").is_none());
    }
}
