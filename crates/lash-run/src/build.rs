//! From a validated scenario to a runnable full model.

use lash_contact::translational::{Block, Guide};
use lash_contact::{ClearanceJoint, Material, TranslationalClearance};
use lash_full_model::FullModel;
use lash_mech::{Body, BodyId, Driver, Joint, JointKind, Load, Mechanism, Vec2};
use lash_scenario::schema::*;

fn v2(a: [f64; 2]) -> Vec2 {
    Vec2::new(a[0], a[1])
}

/// A clearance joint of the scenario as written (radii, laws with their coefficients, materials):
/// what the full model resolves its contact law from, and what the reduced model's micro
/// subsystem exposes as parameters.
pub fn clearance_definition(s: &Scenario, c: &ClearanceSpec) -> lash_contact::ClearanceDefinition {
    let material = |m: &Option<String>| m.as_ref().map_or(Material::STEEL, |n| s.materials[n]);
    lash_contact::ClearanceDefinition {
        journal_radius: c.journal_radius,
        bearing_radius: c.bearing_radius,
        contact: c.contact.clone(),
        friction: c.friction,
        journal_material: material(&c.journal_material),
        // A bush is the bearing's surface: its material is the bearing's.
        bearing_material: match &c.bush {
            Some(b) => Material { young_modulus: b.material.young_modulus, poisson_ratio: b.material.poisson_ratio },
            None => material(&c.bearing_material),
        },
        film: c.film,
    }
}

/// The interface-stress model of each clearance joint that has a bush (None for the others).
pub fn interface_stresses(s: &Scenario) -> Vec<Option<std::sync::Arc<lash_bush::InterfaceStress>>> {
    s.clearances
        .iter()
        .map(|c| {
            // Validation computed (and kept) the bush's table: it cannot fail here.
            c.bush.as_ref().map(|b| std::sync::Arc::new(lash_bush::InterfaceStress::of(b).expect("validated bush")))
        })
        .collect()
}

/// Options of a build.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BuildOptions {
    /// Treat every clearance joint as an ideal revolute joint.
    pub ideal: bool,
}

/// The mechanism with the clearance joints cut out (or kept ideal), and the clearance joints.
pub fn build_model(s: &Scenario, options: BuildOptions) -> FullModel {
    let id = |name: &str| -> BodyId {
        if name == "ground" {
            BodyId::Ground
        } else {
            BodyId::Body(s.bodies.iter().position(|b| b.name == name).expect("validated body name"))
        }
    };
    let mechanism = mechanism(s, options, &id);
    let clearances = if options.ideal { Vec::new() } else { clearance_joints(s, &id) };
    let slots = if options.ideal { Vec::new() } else { s.guides.iter().map(|g| guide(s, g, &id)).collect() };
    FullModel::new(mechanism, clearances).with_slots(slots)
}

/// The mechanism of `s` with its clearance joints cut out (kept as ideal joints with
/// `options.ideal`), its bushings' springs among the loads (none with `options.ideal`); `id`
/// maps a body's name to its id.
fn mechanism(s: &Scenario, options: BuildOptions, id: &dyn Fn(&str) -> BodyId) -> Mechanism {
    let guess_angle = |name: &str| s.bodies.iter().find(|b| b.name == name).map_or(0.0, |b| b.angle);
    let bodies = s
        .bodies
        .iter()
        .map(|b| Body {
            name: b.name.clone(),
            mass: b.mass,
            inertia: b.inertia,
            position: v2(b.position),
            angle: b.angle,
            velocity: v2(b.velocity),
            angular_velocity: b.angular_velocity,
        })
        .collect();
    let is_cut = |j: &JointSpec| !options.ideal && s.is_cut(&j.name);
    let joints = s
        .joints
        .iter()
        .filter(|j| !is_cut(j))
        .map(|j| Joint {
            name: j.name.clone(),
            kind: match j.kind {
                JointType::Revolute => JointKind::Revolute,
                JointType::Prismatic => JointKind::Prismatic {
                    axis_j: v2(j.axis.unwrap_or([1.0, 0.0])),
                    angle_offset: j.angle_offset.unwrap_or(guess_angle(&j.body1) - guess_angle(&j.body2)),
                },
            },
            body_i: id(&j.body1),
            point_i: v2(j.point1),
            body_j: id(&j.body2),
            point_j: v2(j.point2),
        })
        .collect();
    let drivers = s
        .drivers
        .iter()
        .map(|d| Driver {
            name: d.name.clone(),
            body: id(&d.body),
            reference: id(&d.reference),
            motion: d.motion.clone(),
        })
        .collect();
    let body_index = |name: &str| match id(name) {
        BodyId::Body(k) => k,
        BodyId::Ground => unreachable!("validated: loads act on moving bodies"),
    };
    let bushings = s.bushings.iter().filter(|_| !options.ideal).map(|b| {
        let j = s.joints.iter().find(|j| j.name == b.joint).expect("validated bushing joint");
        // Validation computed (and kept) the bush's numbers: they cannot fail here.
        let (stiffness, damping) = b.stiffness_damping().expect("validated bushing");
        Load::Bushing {
            body_i: id(&j.body1),
            point_i: v2(j.point1),
            body_j: id(&j.body2),
            point_j: v2(j.point2),
            stiffness,
            damping,
            curve: b.curve.clone(),
        }
    });
    let loads = s
        .loads
        .iter()
        .map(|l| match l {
            LoadSpec::Force { body, point, force } => {
                Load::Force { body: body_index(body), point: v2(*point), force: v2(*force) }
            }
            LoadSpec::Torque { body, torque } => Load::Torque { body: body_index(body), torque: *torque },
            LoadSpec::Motor { body, stall_torque, no_load_speed } => {
                Load::Motor { body: body_index(body), stall_torque: *stall_torque, no_load_speed: *no_load_speed }
            }
        })
        .chain(bushings)
        .collect();
    Mechanism { bodies, joints, drivers, loads, gravity: v2(s.gravity), baumgarte: s.simulation.baumgarte }
}

/// The clearance joints of `s`'s `[[clearances]]`, the journal on the body the file names.
fn clearance_joints(s: &Scenario, id: &dyn Fn(&str) -> BodyId) -> Vec<ClearanceJoint> {
    s.clearances
        .iter()
        .map(|c| {
            let j = s.joints.iter().find(|j| j.name == c.joint).expect("validated clearance joint");
            let (jb, jp, bb, bp) = if c.journal == j.body1 {
                (&j.body1, j.point1, &j.body2, j.point2)
            } else {
                (&j.body2, j.point2, &j.body1, j.point1)
            };
            // Validation computed (and kept) the bush's numbers: they cannot fail here.
            let bush = c.bush.as_ref().map(|b| lash_bush::bonded_pin(b).expect("validated bush"));
            ClearanceJoint {
                name: c.joint.clone(),
                journal_body: id(jb),
                journal_point: v2(jp),
                bearing_body: id(bb),
                bearing_point: v2(bp),
                journal_radius: c.journal_radius,
                bearing_radius: c.bearing_radius,
                law: clearance_definition(s, c).normal_force(),
                friction: c.friction,
                bush_stiffness: bush.map_or(f64::INFINITY, |b| b.stiffness),
                bush_damping: bush.map_or(0.0, |b| if damped_in_series(&b) { b.damping } else { 0.0 }),
                film: c.film,
                in_contact: false,
                onset_velocity: 0.0,
            }
        })
        .collect()
}

/// The translational clearance joint of guide `g`: the block centred on the slider's joint point
/// with its long side along the joint's axis, the guide's mid-line through the other body's point.
fn guide(s: &Scenario, g: &GuideSpec, id: &dyn Fn(&str) -> BodyId) -> TranslationalClearance {
    let j = s.joints.iter().find(|j| j.name == g.joint).expect("validated guide joint");
    let guess_angle = |name: &str| s.bodies.iter().find(|b| b.name == name).map_or(0.0, |b| b.angle);
    // The prismatic joint holds θ1 − θ2 = offset with body1's point on the line through body2's
    // point along `axis` (body2's frame); seen from body1 that line runs along R(−offset) axis.
    let offset = j.angle_offset.unwrap_or(guess_angle(&j.body1) - guess_angle(&j.body2));
    let axis2 = v2(j.axis.unwrap_or([1.0, 0.0])).normalize();
    let axis1 = nalgebra::Rotation2::new(-offset) * axis2;
    let ((slider, centre, slider_axis), (guide, point, guide_axis)) = if g.slider == j.body1 {
        ((&j.body1, j.point1, axis1), (&j.body2, j.point2, axis2))
    } else {
        ((&j.body2, j.point2, axis2), (&j.body1, j.point1, axis1))
    };
    let block = Block {
        body: id(slider),
        centre: v2(centre),
        axis: slider_axis,
        half_length: g.length / 2.0,
        half_height: g.height / 2.0,
    };
    // The law's stiffness is given (validated): the materials and radii are not used.
    let law = g.contact.resolve(&Material::STEEL, &Material::STEEL, 1.0, 1.0 + g.clearance);
    TranslationalClearance::new(
        g.joint.clone(),
        block,
        Guide { body: id(guide), point: v2(point), axis: guide_axis },
        g.clearance,
        law,
        g.friction,
    )
}

/// Whether a bush in series with a contact carries its damping as a state (its relaxation time
/// c/k at least [`lash_contact::clearance::SERIES_DAMPING_MIN_RELAXATION`]) rather than follow
/// its load quasi-statically.
pub fn damped_in_series(bush: &lash_bush::BondedPin) -> bool {
    bush.damping > 0.0 && bush.damping / bush.stiffness >= lash_contact::clearance::SERIES_DAMPING_MIN_RELAXATION
}
