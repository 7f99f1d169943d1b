//! The clearance joint's numbers as FMI-style parameters of the micro subsystem.
//!
//! A [`ClearanceDefinition`] keeps the joint as a user writes it (radii, contact law and friction
//! law with their coefficients, materials), so that a co-simulation master or an FMU importer can
//! change any coefficient before initialization: the parameters are the numeric fields of the
//! laws, named like the scenario file (`journal_radius`, `contact.restitution`,
//! `friction.coefficient`…). At initialization the definition is checked like a scenario file and
//! resolved to the numbers the micro step uses (a stiffness left out is re-derived from the
//! materials and the current radii).

use crate::film::Film;
use crate::friction::FrictionLaw;
use crate::law::{ContactLaw, Material, NormalForce};

/// The clearance joint as written by the user.
#[derive(Debug, Clone, PartialEq)]
pub struct ClearanceDefinition {
    /// Journal radius R_J \[m\].
    pub journal_radius: f64,
    /// Bearing radius R_B \[m\].
    pub bearing_radius: f64,
    /// Contact law with its coefficients.
    pub contact: ContactLaw,
    /// Friction law with its coefficients.
    pub friction: FrictionLaw,
    /// Journal material (Hertz stiffness when the law gives none).
    pub journal_material: Material,
    /// Bearing material.
    pub bearing_material: Material,
    /// The oil film of a lubricated joint (none: dry); its numbers are parameters too.
    pub film: Option<Film>,
}

/// Where a parameter lives in the definition.
#[derive(Debug, Clone, PartialEq)]
enum Slot {
    JournalRadius,
    BearingRadius,
    Contact(String),
    Friction(String),
    Film(String),
}

/// One parameter: name, unit, description, slot.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterInfo {
    /// Name (`contact.restitution`).
    pub name: String,
    /// SI unit.
    pub unit: &'static str,
    /// Start value.
    pub value: f64,
    slot: Slot,
}

/// Unit of a law coefficient (dimensionless when the shared table does not know the field).
fn unit_of(field: &str) -> &'static str {
    match lash_core::units::field_unit(field) {
        "" => "1",
        unit => unit,
    }
}

/// The numeric fields of a serialized law (the `law` tag and absent options left out).
fn numeric_fields<T: serde::Serialize>(law: &T) -> Vec<(String, f64)> {
    match serde_json::to_value(law) {
        Ok(serde_json::Value::Object(map)) => map.into_iter().filter_map(|(k, v)| v.as_f64().map(|x| (k, x))).collect(),
        _ => Vec::new(),
    }
}

fn with_field<T: serde::Serialize + serde::de::DeserializeOwned>(
    law: &T,
    field: &str,
    value: f64,
) -> Result<T, String> {
    let mut v = serde_json::to_value(law).map_err(|e| e.to_string())?;
    if let Some(map) = v.as_object_mut() {
        map.insert(field.to_string(), serde_json::json!(value));
    }
    serde_json::from_value(v).map_err(|e| e.to_string())
}

impl ClearanceDefinition {
    /// The parameters, in a fixed order: radii, then the contact law's, then the friction law's
    /// numeric fields, then a film's.
    pub fn parameters(&self) -> Vec<ParameterInfo> {
        let mut p = vec![
            ParameterInfo {
                name: "journal_radius".into(),
                unit: "m",
                value: self.journal_radius,
                slot: Slot::JournalRadius,
            },
            ParameterInfo {
                name: "bearing_radius".into(),
                unit: "m",
                value: self.bearing_radius,
                slot: Slot::BearingRadius,
            },
        ];
        for (k, v) in numeric_fields(&self.contact) {
            p.push(ParameterInfo { name: format!("contact.{k}"), unit: unit_of(&k), value: v, slot: Slot::Contact(k) });
        }
        for (k, v) in numeric_fields(&self.friction) {
            p.push(ParameterInfo {
                name: format!("friction.{k}"),
                unit: unit_of(&k),
                value: v,
                slot: Slot::Friction(k),
            });
        }
        for (k, v) in self.film.as_ref().map(numeric_fields).unwrap_or_default() {
            p.push(ParameterInfo { name: format!("film.{k}"), unit: unit_of(&k), value: v, slot: Slot::Film(k) });
        }
        p
    }

    /// The definition with `values` (one per [`ClearanceDefinition::parameters`] entry) written
    /// in, checked; each problem names its parameter.
    pub fn with_values(&self, values: &[f64]) -> Result<Self, lash_core::Problems> {
        let mut problems = lash_core::Problems::new();
        let mut d = self.clone();
        for (info, &v) in self.parameters().iter().zip(values) {
            match &info.slot {
                Slot::JournalRadius => d.journal_radius = v,
                Slot::BearingRadius => d.bearing_radius = v,
                Slot::Contact(f) => match with_field(&d.contact, f, v) {
                    Ok(law) => d.contact = law,
                    Err(e) => problems.push(info.name.clone(), e),
                },
                Slot::Friction(f) => match with_field(&d.friction, f, v) {
                    Ok(law) => d.friction = law,
                    Err(e) => problems.push(info.name.clone(), e),
                },
                Slot::Film(f) => match d.film.as_ref().map(|film| with_field(film, f, v)) {
                    Some(Ok(film)) => d.film = Some(film),
                    Some(Err(e)) => problems.push(info.name.clone(), e),
                    None => {}
                },
            }
        }
        problems.positive("journal_radius", d.journal_radius);
        if !(d.bearing_radius > d.journal_radius && d.bearing_radius.is_finite()) {
            problems.push(
                "bearing_radius",
                format!("must exceed journal_radius ({} m), got {} m", d.journal_radius, d.bearing_radius),
            );
        }
        problems.extend_prefixed("contact", d.contact.validate());
        problems.extend_prefixed("friction", d.friction.validate());
        if let Some(film) = &d.film {
            problems.extend_prefixed("film", film.validate());
        }
        problems.into_result().map(|()| d)
    }

    /// The law resolved to numbers.
    pub fn normal_force(&self) -> NormalForce {
        self.contact.resolve(&self.journal_material, &self.bearing_material, self.journal_radius, self.bearing_radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ln() -> ClearanceDefinition {
        ClearanceDefinition {
            journal_radius: 0.0099,
            bearing_radius: 0.01,
            contact: serde_json::from_value(serde_json::json!({"law": "lankarani_nikravesh", "restitution": 0.9}))
                .unwrap(),
            friction: FrictionLaw::Ambrosio { coefficient: 0.01, v0: 1e-4, v1: 1e-3 },
            journal_material: Material::STEEL,
            bearing_material: Material::STEEL,
            film: None,
        }
    }

    #[test]
    fn parameters_are_the_numeric_fields_named_like_the_scenario_file() {
        let names: Vec<String> = ln().parameters().into_iter().map(|p| p.name).collect();
        for n in [
            "journal_radius",
            "bearing_radius",
            "contact.restitution",
            "friction.coefficient",
            "friction.v0",
            "friction.v1",
        ] {
            assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
        }
        assert!(!names.iter().any(|x| x == "contact.stiffness"), "an absent stiffness is derived, not a parameter");
    }

    #[test]
    fn values_are_written_checked_and_resolved() {
        let d = ln();
        let mut v: Vec<f64> = d.parameters().iter().map(|p| p.value).collect();
        let unchanged = d.with_values(&v).unwrap();
        assert_eq!(unchanged.normal_force(), d.normal_force());
        let k = d.parameters().iter().position(|p| p.name == "contact.restitution").unwrap();
        v[k] = 0.5;
        let softer = d.with_values(&v).unwrap();
        match (softer.normal_force(), d.normal_force()) {
            (NormalForce::Hysteresis { chi: a, .. }, NormalForce::Hysteresis { chi: b, .. }) => assert!(a > b),
            other => panic!("{other:?}"),
        }
        v[k] = 1.5;
        let e = d.with_values(&v).unwrap_err();
        assert_eq!(e.0.iter().map(|p| p.field.as_str()).collect::<Vec<_>>(), ["contact.restitution"], "{e}");
        let mut v: Vec<f64> = d.parameters().iter().map(|p| p.value).collect();
        v[1] = 0.009;
        assert_eq!(d.with_values(&v).unwrap_err().0[0].field, "bearing_radius");
    }

    #[test]
    fn a_films_numbers_are_parameters_checked_by_name() {
        let film = crate::film::Film {
            viscosity: 0.2,
            length: 0.005,
            bearing: crate::film::BearingLength::Short,
            mixed_fraction: 0.05,
        };
        let d = ClearanceDefinition { film: Some(film), ..ln() };
        let p = d.parameters();
        let unit = |n: &str| p.iter().find(|i| i.name == n).map(|i| i.unit);
        assert_eq!(unit("film.viscosity"), Some("Pa.s"));
        assert_eq!(unit("film.length"), Some("m"));
        assert_eq!(unit("film.mixed_fraction"), Some("1"));
        assert!(ln().parameters().iter().all(|i| !i.name.starts_with("film.")), "a dry joint has no film parameters");
        let at = p.iter().position(|i| i.name == "film.viscosity").unwrap();
        let mut values: Vec<f64> = p.iter().map(|i| i.value).collect();
        values[at] = 0.05;
        assert_eq!(d.with_values(&values).unwrap().film.unwrap().viscosity, 0.05);
        values[at] = -1.0;
        let e = d.with_values(&values).unwrap_err().to_string();
        assert!(e.contains("film.viscosity"), "{e}");
    }
}
