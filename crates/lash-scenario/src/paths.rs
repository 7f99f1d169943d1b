//! Numeric fields of a scenario addressed by path (`clearances[0].contact.restitution`,
//! `bodies[1].mass`, `joints[1].point2[0]`): the handle that sweeps and FMU parameters use to edit
//! a scenario.

/// Why an edited scenario could not be made.
#[derive(Debug, Clone, PartialEq)]
pub enum EditError {
    /// A path that does not name a number of the scenario.
    Path(String),
    /// The edited scenario is not valid (every problem, with its field).
    Invalid(lash_core::Problems),
}

/// The scenario `base` (as a TOML table) with each `(path, value)` written in, parsed and
/// validated like a file.
pub fn edited<'a>(
    base: &toml::Table,
    edits: impl IntoIterator<Item = (&'a str, f64)>,
) -> Result<crate::Scenario, EditError> {
    let mut table = base.clone();
    for (path, value) in edits {
        set_path(&mut table, path, value).map_err(EditError::Path)?;
    }
    let text = toml::to_string(&table).map_err(|e| EditError::Path(e.to_string()))?;
    crate::parse(&text).map_err(EditError::Invalid)
}

/// [`edited`] for a planar or spatial base (its `space` key decides).
pub fn edited_any<'a>(
    base: &toml::Table,
    edits: impl IntoIterator<Item = (&'a str, f64)>,
) -> Result<crate::AnyScenario, EditError> {
    let mut table = base.clone();
    for (path, value) in edits {
        set_path(&mut table, path, value).map_err(EditError::Path)?;
    }
    let text = toml::to_string(&table).map_err(|e| EditError::Path(e.to_string()))?;
    crate::parse_any(&text).map_err(EditError::Invalid)
}

/// Writes `value` at a dotted path with indices (`clearances[0].contact.restitution`) of a TOML
/// table. The field must exist and be a number.
pub fn set_path(table: &mut toml::Table, path: &str, value: f64) -> Result<(), String> {
    match walk(table, path)? {
        toml::Value::Float(f) => *f = value,
        toml::Value::Integer(i) if value.fract() == 0.0 && value.abs() < 9.0e15 => *i = value as i64,
        toml::Value::Integer(_) => return Err(format!("{path:?} is a whole number; {value} is not")),
        other => return Err(format!("{path:?} is not a number (it is a {})", other.type_str())),
    }
    Ok(())
}

/// The number at a dotted path with indices of a TOML table (the paths of [`set_path`]).
pub fn get_path(table: &toml::Table, path: &str) -> Result<f64, String> {
    let mut table = table.clone();
    match walk(&mut table, path)? {
        toml::Value::Float(f) => Ok(*f),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => Err(format!("{path:?} is not a number (it is a {})", other.type_str())),
    }
}

/// The value at `path`, or why the path names nothing.
fn walk<'t>(table: &'t mut toml::Table, path: &str) -> Result<&'t mut toml::Value, String> {
    let mut segments = Vec::new();
    for part in path.split('.') {
        let (name, rest) = part.split_once('[').unwrap_or((part, ""));
        if name.is_empty() {
            return Err(format!("{path:?}: empty name in the path"));
        }
        segments.push(Segment::Key(name.to_string()));
        if !rest.is_empty() {
            for idx in rest.trim_end_matches(']').split("][") {
                let i = idx.parse::<usize>().map_err(|_| format!("{path:?}: index [{idx}] is not a number"))?;
                segments.push(Segment::Index(i));
            }
        }
    }
    let Some(Segment::Key(first)) = segments.first() else {
        return Err(format!("{path:?}: empty path"));
    };
    let keys: Vec<String> = table.keys().cloned().collect();
    let Some(mut here) = table.get_mut(first) else {
        return Err(format!("{path:?}: no field {first:?} in the scenario (fields: {keys:?})"));
    };
    let mut walked = first.clone();
    for seg in &segments[1..] {
        here = match (seg, here) {
            (Segment::Key(k), toml::Value::Table(t)) => {
                if !t.contains_key(k) {
                    let keys: Vec<&String> = t.keys().collect();
                    return Err(format!("{path:?}: no field {k:?} in {walked} (fields there: {keys:?})"));
                }
                walked.push_str(&format!(".{k}"));
                t.get_mut(k).expect("checked")
            }
            (Segment::Index(i), toml::Value::Array(a)) => {
                let len = a.len();
                if *i >= len {
                    return Err(format!("{path:?}: index {i} out of range ({walked} has {len} entries)"));
                }
                walked.push_str(&format!("[{i}]"));
                &mut a[*i]
            }
            (Segment::Key(k), _) => return Err(format!("{path:?}: {walked} has no fields (looking for {k:?})")),
            (Segment::Index(i), _) => return Err(format!("{path:?}: {walked} is not a list (looking for [{i}])")),
        };
    }
    Ok(here)
}

enum Segment {
    Key(String),
    Index(usize),
}
