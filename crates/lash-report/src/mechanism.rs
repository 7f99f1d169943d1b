//! The animation's geometry: each body drawn through the points where its joints (and sensors)
//! hold it, placed at each frame by the body's recorded pose (`<body>.centroid_x`, … channels);
//! a spatial mechanism projected on the two world axes it spans most.

use crate::runs::Run;
use lash_scenario::AnyScenario;
use serde::Serialize;

/// Largest number of frames of the animation (spread evenly over the run).
pub const MAX_FRAMES: usize = 360;

/// One body as the animation draws it.
#[derive(Debug, Clone, Serialize)]
pub struct BodyShape {
    /// Name.
    pub name: String,
    /// Drawn as a block (a body held at one point, a slider) rather than through its points.
    pub block: bool,
}

/// A joint drawn as a ring: where it sits at each frame is point `point` of body `body`.
#[derive(Debug, Clone, Serialize)]
pub struct JointMark {
    /// Name.
    pub name: String,
    /// Moving body index.
    pub body: usize,
    /// Index of the point in that body's point list.
    pub point: usize,
    /// A clearance joint.
    pub clearance: bool,
}

/// The animation: bodies, joints and, per frame, each body's points in the plane drawn.
#[derive(Debug, Clone, Serialize)]
pub struct Animation {
    /// The world axes drawn, horizontal then vertical (`x`, `y`, or `z`).
    pub axes: [&'static str; 2],
    /// Bodies.
    pub bodies: Vec<BodyShape>,
    /// Joints.
    pub joints: Vec<JointMark>,
    /// Where joints hold bodies to the ground, in the projection \[m\].
    pub anchors: Vec<[f64; 2]>,
    /// Frame times \[s\].
    pub times: Vec<f64>,
    /// frame → body → its points, x0, y0, x1, y1, … \[m\].
    pub frames: Vec<Vec<Vec<f64>>>,
    /// xmin, xmax, ymin, ymax over every frame and the ground points \[m\].
    pub extent: [f64; 4],
}

/// A body's local points (3 coordinates; planar ones with z = 0), first seen first.
fn add_point(points: &mut Vec<[f64; 3]>, p: [f64; 3]) -> usize {
    let close = |a: &[f64; 3]| (0..3).all(|i| (a[i] - p[i]).abs() < 1e-9);
    points.iter().position(close).unwrap_or_else(|| {
        points.push(p);
        points.len() - 1
    })
}

/// (body1, point1, body2, point2, name, clearance) of every joint, points in 3D.
type JointGeometry = (String, [f64; 3], String, [f64; 3], String, bool);

/// (body, point) of every sensor, in 3D.
type SensorGeometry = (String, [f64; 3]);

/// The bodies' names, the joints and the sensors of a scenario, planar points with z = 0.
fn joints_of(s: &AnyScenario) -> (Vec<String>, Vec<JointGeometry>, Vec<SensorGeometry>) {
    let clearance = |name: &str| s.clearances().iter().any(|c| c.joint == name);
    let flat = |p: [f64; 2]| [p[0], p[1], 0.0];
    match s {
        AnyScenario::Planar(p) => (
            p.bodies.iter().map(|b| b.name.clone()).collect(),
            p.joints
                .iter()
                .map(|j| {
                    (
                        j.body1.clone(),
                        flat(j.point1),
                        j.body2.clone(),
                        flat(j.point2),
                        j.name.clone(),
                        clearance(&j.name),
                    )
                })
                .collect(),
            p.sensors.iter().map(|x| (x.body.clone(), flat(x.point))).collect(),
        ),
        AnyScenario::Spatial(p) => (
            p.bodies.iter().map(|b| b.name.clone()).collect(),
            p.joints
                .iter()
                .map(|j| (j.body1.clone(), j.point1, j.body2.clone(), j.point2, j.name.clone(), clearance(&j.name)))
                .collect(),
            p.sensors.iter().map(|x| (x.body.clone(), x.point)).collect(),
        ),
    }
}

/// Maps a body's local point to the world at sample `i` from its pose channels.
enum Placement<'a> {
    Planar { x: &'a [f64], y: &'a [f64], angle: &'a [f64] },
    Spatial { centroid: [&'a [f64]; 3], orientation: [&'a [f64]; 4] },
}

impl Placement<'_> {
    fn of<'a>(run: &'a Run, spatial: bool, body: &str) -> Option<Placement<'a>> {
        // The pose channels by their quantities' names (lash-scenario's lists, in their order).
        let c = |q: &(&str, &str)| run.column(&format!("{body}.{}", q.0));
        if spatial {
            let q = &lash_scenario::spatial::SPATIAL_POSE_QUANTITIES;
            Some(Placement::Spatial {
                centroid: [c(&q[0])?, c(&q[1])?, c(&q[2])?],
                orientation: [c(&q[3])?, c(&q[4])?, c(&q[5])?, c(&q[6])?],
            })
        } else {
            let q = &lash_scenario::channels::POSE_QUANTITIES;
            Some(Placement::Planar { x: c(&q[0])?, y: c(&q[1])?, angle: c(&q[2])? })
        }
    }

    fn world(&self, i: usize, p: [f64; 3]) -> [f64; 3] {
        match self {
            Placement::Planar { x, y, angle } => {
                let (sin, cos) = angle[i].sin_cos();
                [x[i] + cos * p[0] - sin * p[1], y[i] + sin * p[0] + cos * p[1], 0.0]
            }
            Placement::Spatial { centroid, orientation } => {
                let [w, a, b, c] = orientation.map(|o| o[i]);
                let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, a, b, c));
                let r = q * nalgebra::Vector3::new(p[0], p[1], p[2]);
                [centroid[0][i] + r.x, centroid[1][i] + r.y, centroid[2][i] + r.z]
            }
        }
    }
}

/// Where the point `local` of `body` (its frame, from the centroid \[m\]) is at sample `i` of
/// `run`, from the body's pose channels (`None`: the run did not record them).
pub fn place(run: &Run, spatial: bool, body: &str, i: usize, local: [f64; 3]) -> Option<[f64; 3]> {
    Placement::of(run, spatial, body).map(|p| p.world(i, local))
}

/// The two axes of largest spread among world points (in axis order).
fn projection(points: &[[f64; 3]]) -> [usize; 2] {
    let spread = |a: usize| {
        let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[a]), h.max(p[a])));
        hi - lo
    };
    let least = (0..3).min_by(|&a, &b| spread(a).total_cmp(&spread(b))).unwrap_or(2);
    match least {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// Why a run has no animation: it did not record its bodies' poses.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the {run} run did not record its bodies' poses (`<body>.{channels}` channels): no animation")]
pub struct NoAnimation {
    /// The run's label.
    pub run: String,
    /// The pose channels it lacks.
    pub channels: &'static str,
}

/// The animation of `run`, or why there is none (a run that did not record its bodies' poses).
pub fn animation(scenario: &AnyScenario, run: &Run) -> Result<Animation, NoAnimation> {
    let spatial = matches!(scenario, AnyScenario::Spatial(_));
    let (bodies, joints, sensors) = joints_of(scenario);
    let mut points: Vec<Vec<[f64; 3]>> = vec![Vec::new(); bodies.len()];
    let index = |name: &str| bodies.iter().position(|b| b == name);
    let mut marks = Vec::new();
    let mut fixed = Vec::new();
    for (b1, p1, b2, p2, name, clearance) in &joints {
        let on =
            |b: &str, p: [f64; 3], points: &mut Vec<Vec<[f64; 3]>>| index(b).map(|k| (k, add_point(&mut points[k], p)));
        let first = on(b1, *p1, &mut points);
        let second = on(b2, *p2, &mut points);
        let ground = match (index(b1), index(b2)) {
            (None, _) => Some(*p1),
            (_, None) => Some(*p2),
            _ => None,
        };
        if let Some(g) = ground {
            fixed.push(g);
        }
        if let Some((body, point)) = first.or(second) {
            marks.push(JointMark { name: name.clone(), body, point, clearance: *clearance });
        }
    }
    for (b, p) in &sensors {
        if let Some(k) = index(b) {
            add_point(&mut points[k], *p);
        }
    }
    let placements: Vec<Placement> =
        bodies.iter().map(|b| Placement::of(run, spatial, b)).collect::<Option<_>>().ok_or_else(|| {
            let channels = if spatial { "centroid_x, …, orientation_z" } else { "centroid_x, centroid_y, angle" };
            NoAnimation { run: run.label.clone(), channels }
        })?;
    let n = run.time().len();
    let count = MAX_FRAMES.min(n);
    let samples: Vec<usize> = (0..count).map(|f| (f * (n - 1)).checked_div(count - 1).unwrap_or(0)).collect();
    // World points of every body at every frame, then projected.
    let world: Vec<Vec<Vec<[f64; 3]>>> = samples
        .iter()
        .map(|&i| points.iter().zip(&placements).map(|(ps, pl)| ps.iter().map(|&p| pl.world(i, p)).collect()).collect())
        .collect();
    let every: Vec<[f64; 3]> = world.iter().flatten().flatten().copied().chain(fixed.iter().copied()).collect();
    let axes = if spatial { projection(&every) } else { [0, 1] };
    let mut extent = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    for p in &every {
        extent = [
            extent[0].min(p[axes[0]]),
            extent[1].max(p[axes[0]]),
            extent[2].min(p[axes[1]]),
            extent[3].max(p[axes[1]]),
        ];
    }
    let frames = world
        .iter()
        .map(|bodies| bodies.iter().map(|ps| ps.iter().flat_map(|p| [p[axes[0]], p[axes[1]]]).collect()).collect())
        .collect();
    const NAMES: [&str; 3] = ["x", "y", "z"];
    Ok(Animation {
        axes: [NAMES[axes[0]], NAMES[axes[1]]],
        bodies: bodies
            .iter()
            .zip(&points)
            .map(|(name, ps)| BodyShape { name: name.clone(), block: ps.len() < 2 })
            .collect(),
        joints: marks,
        anchors: fixed.iter().map(|g| [g[axes[0]], g[axes[1]]]).collect(),
        times: samples.iter().map(|&i| run.time()[i]).collect(),
        frames,
        extent,
    })
}
