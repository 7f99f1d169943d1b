//! The one table of units of the scenario file's numeric fields, by key (the last segment of the
//! field's path): FMU parameter tables, clearance-law parameters and anything else that shows a
//! scenario number with its unit read it here, so the units cannot drift apart.

/// SI unit of a scenario field by its key (`mass` → `kg`, `restitution` → `1`); `""` for a key
/// this table does not know.
pub fn field_unit(key: &str) -> &'static str {
    match key {
        "mass" => "kg",
        "inertia" => "kg.m2",
        "point1" | "point2" | "point" | "position" | "journal_radius" | "bearing_radius" | "length"
        | "damping_depth" | "deflections" => "m",
        "angle" | "angle0" | "angle_offset" | "phase" | "amplitude" => "rad",
        "omega" | "angular_velocity" => "rad/s",
        "frequency" => "Hz",
        "gravity" => "m/s2",
        "velocity"
        | "v0"
        | "v1"
        | "velocity_floor"
        | "transition_velocity"
        | "stiction_velocity"
        | "friction_velocity" => "m/s",
        "force" | "forces" => "N",
        "torque" => "N.m",
        "young_modulus" => "Pa",
        "viscosity" => "Pa.s",
        "stiffness" => "N/m^n",
        "damping" | "max_damping" => "N.s/m",
        "restitution" | "exponent" | "coefficient" | "poisson_ratio" | "axis" | "static_coefficient"
        | "mixed_fraction" => "1",
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_law_coefficient_and_link_datum_has_its_unit() {
        for (key, unit) in [
            ("mass", "kg"),
            ("journal_radius", "m"),
            ("stiffness", "N/m^n"),
            ("max_damping", "N.s/m"),
            ("velocity_floor", "m/s"),
            ("restitution", "1"),
            ("omega", "rad/s"),
        ] {
            assert_eq!(field_unit(key), unit, "{key}");
        }
        assert_eq!(field_unit("no_such_field"), "");
    }
}
