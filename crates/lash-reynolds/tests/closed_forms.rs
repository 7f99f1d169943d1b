//! The closed-form film forces of lash-contact against the Reynolds equation solved on a grid:
//! the short bearing as L/D → 0 and the long bearing as L/D grows, each in any motion. Each closed form's error must shrink as the bearing
//! approaches its limit, and be small at the far end of the range.

use lash_contact::film::{BearingLength, Film};
use lash_reynolds::{Bearing, Grid, Motion};

const RADIUS: f64 = 0.01;
const CLEARANCE: f64 = 5e-5;
const VISCOSITY: f64 = 0.04;
const GRID: Grid = Grid { circumferential: 720, axial: 40 };

/// (ė along e, ė across e, ω̄): steady running, a squeeze towards the bearing while running,
/// the journal moving away and round, a squeeze without rotation.
const MOTIONS: [(f64, f64, f64); 4] = [(0.0, 0.0, 100.0), (0.01, 0.0, 100.0), (-0.01, 0.002, 100.0), (0.005, 0.0, 0.0)];

/// |closed form − grid| / |grid| at length over diameter `ld`.
fn error(bearing: BearingLength, ld: f64, ratio: f64, (along, across, mean_rate): (f64, f64, f64)) -> f64 {
    let length = ld * 2.0 * RADIUS;
    // The line of centres at 40°, so that no axis is special.
    let (c, s) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
    let e = [ratio * CLEARANCE * c, ratio * CLEARANCE * s];
    let rate = [along * c - across * s, along * s + across * c];
    let grid = Bearing { radius: RADIUS, clearance: CLEARANCE, length, viscosity: VISCOSITY }
        .solve(&Motion { eccentricity: e, rate, mean_rate }, &GRID)
        .unwrap();
    let film = Film { viscosity: VISCOSITY, length, bearing, mixed_fraction: 0.01 };
    let closed = film.force((RADIUS, CLEARANCE), e, rate, mean_rate);
    (closed[0] - grid.force[0]).hypot(closed[1] - grid.force[1]) / grid.force[0].hypot(grid.force[1])
}

/// `bearing`'s error at ε = 0.1, 0.5, 0.8 in every motion falls over `lengths` (L/D, towards
/// the form's limit) and ends below `last`.
fn converges(bearing: BearingLength, lengths: [f64; 3], last: f64) {
    for &ratio in &[0.1, 0.5, 0.8] {
        for motion in MOTIONS {
            let errors: Vec<f64> = lengths.iter().map(|&ld| error(bearing, ld, ratio, motion)).collect();
            assert!(errors[0] > errors[1] && errors[1] > errors[2], "ε {ratio} {motion:?}: {errors:?}");
            assert!(errors[2] < last, "ε {ratio} {motion:?}: {errors:?}");
        }
    }
}

#[test]
fn short_bearing_is_the_limit_of_short_finite_bearings_in_any_motion() {
    converges(BearingLength::Short, [0.2, 0.1, 0.05], 0.015);
}

#[test]
fn long_bearing_is_the_limit_of_long_finite_bearings_in_any_motion() {
    converges(BearingLength::Long, [2.0, 4.0, 8.0], 0.15);
}

/// The grid itself converges at second order: halving both spacings divides the change by ~4.
#[test]
fn the_grid_converges_at_second_order() {
    let bearing = Bearing { radius: RADIUS, clearance: CLEARANCE, length: 0.01, viscosity: VISCOSITY };
    let motion = Motion { eccentricity: [3e-5, 1e-5], rate: [0.004, -0.002], mean_rate: 80.0 };
    let force = |k: usize| bearing.solve(&motion, &Grid { circumferential: 90 * k, axial: 10 * k }).unwrap().force;
    let (f1, f2, f4) = (force(1), force(2), force(4));
    let d = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    let ratio = d(f1, f2) / d(f2, f4);
    assert!((3.0..5.5).contains(&ratio), "{ratio}: {f1:?} {f2:?} {f4:?}");
}
