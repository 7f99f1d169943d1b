//! `lash bush [FILE] [--json]`: the FE characterisation of a flexible bush as a table.

use crate::CliError;
use lash_bush::{BushFile, characterise};

/// Reads the bush file (or takes the study's bush), characterises it and prints the table (or
/// its JSON).
pub fn run(file: Option<&std::path::Path>, json: bool) -> Result<(), CliError> {
    let spec = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| CliError::Input(format!("cannot read {}: {e}", path.display())))?;
            BushFile::parse(&text).map_err(|p| CliError::Input(format!("invalid bush file {}: {p}", path.display())))?
        }
        None => BushFile::study(),
    };
    let started = std::time::Instant::now();
    let table = characterise(&spec.bush, &spec.loads).map_err(|e| CliError::Failure(e.to_string()))?;
    let seconds = started.elapsed().as_secs_f64();
    if json {
        let text =
            serde_json::to_string_pretty(&serde_json::json!({ "bush": spec.bush, "table": table, "seconds": seconds }))
                .map_err(|e| CliError::Failure(e.to_string()))?;
        println!("{text}");
        return Ok(());
    }
    let b = &spec.bush;
    println!(
        "bush: bore {:.4} m, outer {:.4} m, length {:.4} m; pin {:.4} m; E {:.4e} Pa, ν {}, η_s {} Pa s, η_b {} Pa s",
        b.inner_radius,
        b.outer_radius,
        b.length,
        b.pin_radius,
        b.material.young_modulus,
        b.material.poisson_ratio,
        b.material.shear_viscosity,
        b.material.bulk_viscosity
    );
    println!(
        "FE: {} curved 9-node elements, {} unknowns, plane strain, outer surface fixed; {:.3} s",
        table.elements, table.unknowns, seconds
    );
    let k = &table.bonded;
    println!(
        "bonded pin: stiffness {:.6e} N/m (closed form {:.6e}, {:+.1e}), damping {:.4e} N s/m",
        k.stiffness,
        k.stiffness_closed_form,
        k.stiffness / k.stiffness_closed_form - 1.0,
        k.damping
    );
    println!("Hertz pressure on the bore:");
    println!(
        "  {:>9} {:>10} {:>10} {:>11} {:>11} {:>10} {:>11} {:>11} {:>10}",
        "load [N]", "b [mm]", "p0 [MPa]", "u [µm]", "k [N/m]", "c [N s/m]", "σvm [MPa]", "Hertz [MPa]", "FE/Hertz"
    );
    for p in &table.pressure {
        println!(
            "  {:>9.0} {:>10.4} {:>10.2} {:>11.5} {:>11.4e} {:>10.4} {:>11.2} {:>11.2} {:>10.4}",
            p.load,
            p.half_width * 1e3,
            p.peak_pressure * 1e-6,
            p.displacement * 1e6,
            p.stiffness,
            p.damping,
            p.von_mises * 1e-6,
            p.von_mises_hertz * 1e-6,
            p.correction
        );
    }
    Ok(())
}
