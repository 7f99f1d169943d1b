//! Where each closed form of the film force holds: its error against the Reynolds equation on a
//! grid, over length-over-diameter, eccentricity ratio and motion (docs/validation.md).
//!
//! `cargo run --release -p lash-reynolds --example film_forms`

use lash_contact::film::{BearingLength, Film};
use lash_reynolds::{Bearing, Grid, Motion};

fn main() -> Result<(), lash_reynolds::ReynoldsError> {
    let (radius, clearance, viscosity) = (0.01, 5e-5, 0.04);
    let motions = [("steady", 0.0, 0.0, 100.0), ("pressed", 0.01, 0.0, 100.0), ("leaving", -0.01, 0.002, 100.0)];
    println!("| L/D | ε | motion | grid |F| [N] | short form error | long form error |");
    println!("|---|---|---|---|---|---|");
    for ld in [0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0] {
        let length = ld * 2.0 * radius;
        let bearing = Bearing { radius, clearance, length, viscosity };
        for ratio in [0.5, 0.8] {
            for (name, along, across, mean_rate) in motions {
                let e = [ratio * clearance, 0.0];
                let motion = Motion { eccentricity: e, rate: [along, across], mean_rate };
                let grid = bearing.solve(&motion, &Grid { circumferential: 720, axial: 40 })?.force;
                let error = |form| {
                    let f = Film { viscosity, length, bearing: form, mixed_fraction: 0.01 }.force(
                        (radius, clearance),
                        e,
                        [along, across],
                        mean_rate,
                    );
                    100.0 * (f[0] - grid[0]).hypot(f[1] - grid[1]) / grid[0].hypot(grid[1])
                };
                let size = grid[0].hypot(grid[1]);
                let (short, long) = (error(BearingLength::Short), error(BearingLength::Long));
                println!("| {ld} | {ratio} | {name} | {size:.3e} | {short:.1} % | {long:.1} % |");
            }
        }
    }
    Ok(())
}
