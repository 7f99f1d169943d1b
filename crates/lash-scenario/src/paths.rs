//! Numeric fields of a scenario addressed by path (`clearances[0].contact.restitution`,
//! `bodies[1].mass`, `joints[1].point2[0]`): the handle that sweeps and FMU parameters use to edit
//! a scenario.

/// Why an edited scenario could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    /// A path that does not name a number of the scenario.
    #[error(transparent)]
    Path(#[from] PathError),
    /// The edited scenario is not valid (every problem, with its field).
    #[error("the edited scenario is not valid: {0}")]
    Invalid(lash_core::Problems),
}

/// A path that names no number of a scenario: the path and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path:?}: {problem}")]
pub struct PathError {
    /// The path as given.
    pub path: String,
    /// What is wrong with it.
    pub problem: PathProblem,
}

/// What is wrong with a path ([`PathError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PathProblem {
    /// The path is empty.
    #[error("empty path")]
    Empty,
    /// A segment has no name (`a..b`).
    #[error("empty name in the path")]
    EmptyName,
    /// An index that is not a whole number.
    #[error("index [{0}] is not a number")]
    Index(String),
    /// A field that is not there.
    #[error("no field {name:?} in {within} (fields there: {fields:?})")]
    NoField {
        /// The field looked for.
        name: String,
        /// Where it was looked for (`the scenario`, `clearances[0]`).
        within: String,
        /// The fields there are.
        fields: Vec<String>,
    },
    /// An index past the end of a list.
    #[error("index {index} out of range ({within} has {len} entries)")]
    OutOfRange {
        /// The index.
        index: usize,
        /// The list.
        within: String,
        /// Its length.
        len: usize,
    },
    /// A field looked for in a value that has none.
    #[error("{within} has no fields (looking for {name:?})")]
    NotATable {
        /// The value.
        within: String,
        /// The field looked for.
        name: String,
    },
    /// An index into a value that is not a list.
    #[error("{within} is not a list (looking for [{index}])")]
    NotAList {
        /// The value.
        within: String,
        /// The index.
        index: usize,
    },
    /// The path ends at something other than a number.
    #[error("not a number (it is a {0})")]
    NotANumber(&'static str),
    /// A whole-number field given a fraction.
    #[error("a whole number; {0} is not")]
    NotWhole(f64),
}

/// The scenario `base` (as a TOML table, planar or spatial: its `space` key decides) with each
/// `(path, value)` written in, parsed and validated like a file.
///
/// An edit changes numbers only, so the edited table is read in one go and the typed scenario
/// checked ([`crate::AnyScenario::validate`]: the file parser's checks); only a table that does
/// not pass goes through the file parser, which reads it element by element to word every
/// problem with its field — the same scenario, or the same problems, as parsing it as a file, at
/// a fraction of the cost for the runs of a sweep.
pub fn edited_any<'a>(
    base: &toml::Table,
    edits: impl IntoIterator<Item = (&'a str, f64)>,
) -> Result<crate::AnyScenario, EditError> {
    let edits: Vec<(&str, f64)> = edits.into_iter().collect();
    let write = || -> Result<toml::Table, EditError> {
        let mut table = base.clone();
        for &(path, value) in &edits {
            set_path(&mut table, path, value)?;
        }
        Ok(table)
    };
    if let Some(scenario) = read_in_one_go(write()?)
        && scenario.validate().is_empty()
    {
        return Ok(scenario);
    }
    crate::load::parse_any_table(write()?).map_err(EditError::Invalid)
}

/// A table read in one go as the scenario its `space` key says (unchecked), or None where it does
/// not read.
fn read_in_one_go(table: toml::Table) -> Option<crate::AnyScenario> {
    match crate::load::is_spatial(&table) {
        Ok(false) => toml::Value::Table(table).try_into().ok().map(crate::AnyScenario::Planar),
        Ok(true) => toml::Value::Table(table).try_into().ok().map(crate::AnyScenario::Spatial),
        Err(_) => None,
    }
}

/// A base scenario prepared for many edits (the runs of a sweep): its table, and the typed
/// scenario read from that table once.
///
/// [`EditBase::edited`] gives what [`edited_any`] gives for the same table and edits — the same
/// scenario, or the same error — but for a planar base it writes the edits into the top-level
/// fields they name only (`clearances`, `drivers`, …), reads those fields alone and puts them into
/// a copy of the typed base, instead of copying and reading the whole table (a tenth of a sweep
/// run's building cost). Anything else (a spatial base, a field it does not know, an edit that
/// fails or a scenario that does not validate) goes through [`edited_any`], which words the errors.
#[derive(Debug, Clone)]
pub struct EditBase {
    table: toml::Table,
    typed: Option<crate::Scenario>,
}

impl EditBase {
    /// The base `table` (as [`edited_any`] takes it).
    pub fn new(table: toml::Table) -> Self {
        let typed = match read_in_one_go(table.clone()) {
            Some(crate::AnyScenario::Planar(s)) => Some(s),
            _ => None,
        };
        Self { table, typed }
    }

    /// The base as a table.
    pub fn table(&self) -> &toml::Table {
        &self.table
    }

    /// The base with each `(path, value)` written in, parsed and validated ([`edited_any`]).
    pub fn edited<'a>(&self, edits: impl IntoIterator<Item = (&'a str, f64)>) -> Result<crate::AnyScenario, EditError> {
        let edits: Vec<(&str, f64)> = edits.into_iter().collect();
        if let Some(scenario) = self.edited_fields(&edits) {
            return Ok(scenario);
        }
        edited_any(&self.table, edits)
    }

    /// The typed base with the edited top-level fields read again, or None (then
    /// [`edited_any`] decides).
    fn edited_fields(&self, edits: &[(&str, f64)]) -> Option<crate::AnyScenario> {
        let mut scenario = self.typed.clone()?;
        let mut done = vec![false; edits.len()];
        for first in 0..edits.len() {
            if done[first] {
                continue;
            }
            let key = top_level(edits[first].0);
            let mut field = toml::Table::new();
            field.insert(key.to_string(), self.table.get(key)?.clone());
            for (k, &(path, value)) in edits.iter().enumerate().skip(first) {
                if top_level(path) == key {
                    set_path(&mut field, path, value).ok()?;
                    done[k] = true;
                }
            }
            let value = field.remove(key)?;
            set_field(&mut scenario, key, value)?;
        }
        let scenario = crate::AnyScenario::Planar(scenario);
        scenario.validate().is_empty().then_some(scenario)
    }
}

/// The top-level field a path starts in (`clearances` of `clearances[0].bearing_radius`).
fn top_level(path: &str) -> &str {
    let end = path.find(['.', '[']).unwrap_or(path.len());
    &path[..end]
}

/// Reads `value` into the top-level field `key` of a planar scenario as the whole file's reading
/// would (the fields carry no renames or adapters: only defaults, which a present value does not
/// use); None for a field this does not know or a value that does not read.
fn set_field(s: &mut crate::Scenario, key: &str, value: toml::Value) -> Option<()> {
    match key {
        "gravity" => s.gravity = value.try_into().ok()?,
        "materials" => s.materials = value.try_into().ok()?,
        "bodies" => s.bodies = value.try_into().ok()?,
        "joints" => s.joints = value.try_into().ok()?,
        "drivers" => s.drivers = value.try_into().ok()?,
        "loads" => s.loads = value.try_into().ok()?,
        "clearances" => s.clearances = value.try_into().ok()?,
        "bushings" => s.bushings = value.try_into().ok()?,
        "sensors" => s.sensors = value.try_into().ok()?,
        "simulation" => s.simulation = value.try_into().ok()?,
        "output" => s.output = value.try_into().ok()?,
        _ => return None,
    }
    Some(())
}

/// Writes `value` at a dotted path with indices (`clearances[0].contact.restitution`) of a TOML
/// table. The field must exist and be a number.
pub fn set_path(table: &mut toml::Table, path: &str, value: f64) -> Result<(), PathError> {
    let problem = match walk(table, path)? {
        toml::Value::Float(f) => {
            *f = value;
            return Ok(());
        }
        toml::Value::Integer(i) if value.fract() == 0.0 && value.abs() < 9.0e15 => {
            *i = value as i64;
            return Ok(());
        }
        toml::Value::Integer(_) => PathProblem::NotWhole(value),
        other => PathProblem::NotANumber(other.type_str()),
    };
    Err(PathError { path: path.to_string(), problem })
}

/// The number at a dotted path with indices of a TOML table (the paths of [`set_path`]).
pub fn get_path(table: &toml::Table, path: &str) -> Result<f64, PathError> {
    let mut table = table.clone();
    match walk(&mut table, path)? {
        toml::Value::Float(f) => Ok(*f),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => Err(PathError { path: path.to_string(), problem: PathProblem::NotANumber(other.type_str()) }),
    }
}

/// The segments of `path`.
fn segments(path: &str) -> Result<Vec<Segment>, PathProblem> {
    let mut segments = Vec::new();
    for part in path.split('.') {
        let (name, rest) = part.split_once('[').unwrap_or((part, ""));
        if name.is_empty() {
            return Err(PathProblem::EmptyName);
        }
        segments.push(Segment::Key(name.to_string()));
        if !rest.is_empty() {
            for idx in rest.trim_end_matches(']').split("][") {
                let i = idx.parse::<usize>().map_err(|_| PathProblem::Index(idx.to_string()))?;
                segments.push(Segment::Index(i));
            }
        }
    }
    Ok(segments)
}

/// The value at `path`, or why the path names nothing.
fn walk<'t>(table: &'t mut toml::Table, path: &str) -> Result<&'t mut toml::Value, PathError> {
    let error = |problem| PathError { path: path.to_string(), problem };
    let segments = segments(path).map_err(error)?;
    let Some(Segment::Key(first)) = segments.first() else {
        return Err(error(PathProblem::Empty));
    };
    let fields = |t: &toml::Table| t.keys().cloned().collect::<Vec<String>>();
    if !table.contains_key(first) {
        let (name, within, fields) = (first.clone(), "the scenario".into(), fields(table));
        return Err(error(PathProblem::NoField { name, within, fields }));
    }
    let mut here = table.get_mut(first).expect("checked");
    let mut walked = first.clone();
    for seg in &segments[1..] {
        here = match (seg, here) {
            (Segment::Key(k), toml::Value::Table(t)) => {
                if !t.contains_key(k) {
                    let (name, within, fields) = (k.clone(), walked, fields(t));
                    return Err(error(PathProblem::NoField { name, within, fields }));
                }
                walked.push_str(&format!(".{k}"));
                t.get_mut(k).expect("checked")
            }
            (Segment::Index(i), toml::Value::Array(a)) => {
                let len = a.len();
                if *i >= len {
                    return Err(error(PathProblem::OutOfRange { index: *i, within: walked, len }));
                }
                walked.push_str(&format!("[{i}]"));
                &mut a[*i]
            }
            (Segment::Key(k), _) => return Err(error(PathProblem::NotATable { within: walked, name: k.clone() })),
            (Segment::Index(i), _) => return Err(error(PathProblem::NotAList { within: walked, index: *i })),
        };
    }
    Ok(here)
}

enum Segment {
    Key(String),
    Index(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table_of(name: &str) -> toml::Table {
        let text = match crate::any_by_name_or_file(name).expect("built-in") {
            crate::AnyScenario::Planar(s) => toml::to_string(&s).expect("serialises"),
            crate::AnyScenario::Spatial(s) => toml::to_string(&s).expect("serialises"),
        };
        toml::from_str(&text).expect("parses")
    }

    /// An edited table is read as the table itself (no text in between): the same scenario as
    /// writing the edited table out and parsing the text, for a planar and a spatial base.
    #[test]
    fn an_edited_scenario_equals_the_parse_of_its_text() {
        for (name, path) in [("A", "clearances[0].bearing_radius"), ("E-0.5mm-250rpm", "clearances[1].bearing_radius")]
        {
            let base = table_of(name);
            let value = get_path(&base, path).expect("path exists") + 1.25e-5;
            let edited = edited_any(&base, [(path, value)]).expect("valid edit");
            let mut table = base.clone();
            set_path(&mut table, path, value).expect("path exists");
            let text = toml::to_string(&table).expect("serialises");
            let parsed = crate::parse_any(&text).expect("valid");
            let json = |s: &crate::AnyScenario| match s {
                crate::AnyScenario::Planar(s) => serde_json::to_string(s).expect("json"),
                crate::AnyScenario::Spatial(s) => serde_json::to_string(s).expect("json"),
            };
            assert_eq!(json(&edited), json(&parsed), "{name}");
            assert_ne!(json(&edited), json(&crate::parse_any(&toml::to_string(&base).expect("text")).expect("valid")));
        }
    }

    /// An edit that makes the scenario invalid gets every problem the file parser finds, worded
    /// as it words them (the typed check found them first), planar and spatial: single fields,
    /// a relation between fields, a sensor's point.
    #[test]
    fn invalid_edits_get_the_problems_of_the_file_parser() {
        for (name, path, value) in [
            ("A", "clearances[0].bearing_radius", -1.0),
            ("A", "clearances[0].bearing_radius", 0.001),
            ("A", "bodies[1].mass", 0.0),
            ("A", "sensors[0].point[0]", f64::NAN),
            ("A", "simulation.horizon", -0.1),
            ("E-0.5mm-250rpm", "clearances[1].bearing_radius", 1e-4),
            ("E-0.5mm-250rpm", "bodies[0].mass", -2.0),
        ] {
            let base = table_of(name);
            let mut table = base.clone();
            set_path(&mut table, path, value).expect("path exists");
            let expected = crate::load::parse_any_table(table).expect_err("invalid").to_string();
            match edited_any(&base, [(path, value)]) {
                Err(EditError::Invalid(p)) => assert_eq!(p.to_string(), expected, "{name} {path} = {value}"),
                other => panic!("{name} {path} = {value}: expected the parser's problems, got {:?}", other.map(|_| ())),
            }
        }
    }

    /// Every numeric leaf of a table, as a path of [`set_path`], its value, and whether it is a
    /// whole number.
    fn numbers(value: &toml::Value, at: String, out: &mut Vec<(String, f64, bool)>) {
        match value {
            toml::Value::Float(f) => out.push((at, *f, false)),
            toml::Value::Integer(i) => out.push((at, *i as f64, true)),
            toml::Value::Table(t) => {
                for (k, v) in t {
                    numbers(v, if at.is_empty() { k.clone() } else { format!("{at}.{k}") }, out);
                }
            }
            toml::Value::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    numbers(v, format!("{at}[{i}]"), out);
                }
            }
            _ => {}
        }
    }

    /// A prepared base gives what [`edited_any`] gives — the same scenario, or the same error —
    /// for every number of every built-in scenario edited alone (up and down: many edits make
    /// the scenario invalid), for several edits at once (two in one field, one path twice, one
    /// in another field), and for a spatial base; and the planar edits that stay valid take the
    /// typed path (else this would compare the table path with itself).
    #[test]
    fn a_prepared_base_edits_as_the_table_does() {
        let mut typed = 0;
        let mut compared = 0;
        for name in crate::builtin::NAMES.iter().copied().chain(["E-0.5mm-250rpm"]) {
            let table = table_of(name);
            let base = EditBase::new(table.clone());
            let mut leaves = Vec::new();
            numbers(&toml::Value::Table(table.clone()), String::new(), &mut leaves);
            assert!(leaves.len() > 20, "{name}: {} numbers", leaves.len());
            for (path, value, whole) in &leaves {
                for edit in [value * 1.01 + 1e-6, value * 0.5 - 1.0] {
                    let edit = if *whole { edit.round() } else { edit };
                    let expected = edited_any(&table, [(path.as_str(), edit)]);
                    if base.edited_fields(&[(path.as_str(), edit)]).is_some() {
                        typed += 1;
                    }
                    assert_eq!(base.edited([(path.as_str(), edit)]), expected, "{name} {path} = {edit}");
                    compared += 1;
                }
            }
        }
        assert!(compared > 1000, "{compared}");
        assert!(typed * 3 > compared, "only {typed} of {compared} edits took the typed path");
        let table = table_of("A");
        let base = EditBase::new(table.clone());
        let edits = [
            ("clearances[0].bearing_radius", 0.01004),
            ("drivers[0].motion.omega", 450.0),
            ("clearances[0].journal_radius", 0.0099),
            ("drivers[0].motion.omega", 520.0),
        ];
        assert!(base.edited_fields(&edits).is_some());
        assert_eq!(base.edited(edits), edited_any(&table, edits));
        assert_ne!(base.edited(edits), base.edited([]));
    }

    /// A path that names nothing, and an edit that makes the scenario invalid, say so.
    #[test]
    fn bad_edits_name_the_path_or_the_problem() {
        let base = table_of("A");
        match edited_any(&base, [("clearances[0].no_such_field", 1.0)]) {
            Err(EditError::Path(e)) => assert!(e.to_string().contains("no_such_field"), "{e}"),
            other => panic!("expected a path error, got {:?}", other.map(|_| ())),
        }
        match edited_any(&base, [("clearances[0].bearing_radius", -1.0)]) {
            Err(EditError::Invalid(p)) => assert!(p.to_string().contains("bearing_radius"), "{p}"),
            other => panic!("expected an invalid scenario, got {:?}", other.map(|_| ())),
        }
    }
}
