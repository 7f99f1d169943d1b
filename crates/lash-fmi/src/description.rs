//! `modelDescription.xml` (FMI 3.0) generated from a [`Subsystem`](lash_core::Subsystem)'s
//! variable descriptions: no per-model XML is written by hand.
//!
//! Mapping: every variable becomes a `<Float64>` (arrays with `<Dimension start="n"/>`, start
//! values as a space-separated list); causality and variability as declared; inputs and parameters
//! carry their start values, outputs and locals are `calculated`. An independent variable `time`
//! is added after the subsystem's variables. Every unit used is declared in `<UnitDefinitions>`.
//! `<ModelStructure>` lists every output, and every output as an initial unknown.

use lash_core::{Causality, Variability, Variable};
use std::fmt::Write;

/// Identity of an exported model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// Model name (`modelName`).
    pub model_name: String,
    /// File name stem of the shared library and `modelIdentifier`.
    pub model_identifier: String,
    /// Instantiation token (FMI 3.0; the GUID of FMI 2.0): changes whenever the variables change.
    pub instantiation_token: String,
    /// One-line description.
    pub description: String,
    /// Default experiment: (start, stop, step) \[s\].
    pub default_experiment: (f64, f64, f64),
}

/// XML-escapes an attribute value.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// A short decimal form that round-trips an `f64` (Rust's shortest representation).
fn number(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 { format!("{v:.1}") } else { format!("{v:e}") }
}

/// The value reference given to the independent variable `time` (one past the last variable).
pub fn time_value_reference(variables: &[Variable]) -> u32 {
    variables.iter().map(|v| v.value_reference + 1).max().unwrap_or(0)
}

/// An instantiation token derived from the model name and its variable table (FNV-1a, printed
/// as a GUID-shaped string), so that a binary and a description that disagree are detected.
pub fn instantiation_token(model_name: &str, variables: &[Variable]) -> String {
    let mut h: u128 = 0x6c62272e07bb014262b821756295c58d;
    let mut feed = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u128::from(b);
            h = h.wrapping_mul(0x0000000001000000000000000000013B);
        }
    };
    feed(model_name.as_bytes());
    for v in variables {
        feed(v.name.as_bytes());
        feed(&v.value_reference.to_le_bytes());
        feed(format!("{:?}{:?}{:?}", v.causality, v.variability, v.shape).as_bytes());
    }
    let hex = format!("{h:032x}");
    format!("{{{}-{}-{}-{}-{}}}", &hex[0..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..32])
}

/// `<UnitDefinitions>` (every unit used, plus `s` for the FMI 3.0 time variable) and
/// `<DefaultExperiment>`.
fn units_and_experiment(x: &mut String, info: &ModelInfo, variables: &[Variable], with_seconds: bool) {
    let mut units: Vec<&str> = variables.iter().map(|v| v.unit.as_str()).filter(|u| !u.is_empty()).collect();
    if with_seconds {
        units.push("s");
    }
    units.sort_unstable();
    units.dedup();
    let _ = writeln!(x, "  <UnitDefinitions>");
    for u in &units {
        let _ = writeln!(x, r#"    <Unit name="{}"/>"#, escape(u));
    }
    let _ = writeln!(x, "  </UnitDefinitions>");
    let (start, stop, step) = info.default_experiment;
    let _ = writeln!(
        x,
        r#"  <DefaultExperiment startTime="{}" stopTime="{}" stepSize="{}"/>"#,
        number(start),
        number(stop),
        number(step)
    );
}

fn causality(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::StructuralParameter => "structuralParameter",
        Causality::Input => "input",
        Causality::Output => "output",
        Causality::Local => "local",
    }
}

fn variability(v: Variability) -> &'static str {
    match v {
        Variability::Fixed => "fixed",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

/// The FMI 3.0 `modelDescription.xml` of a co-simulation FMU.
pub fn fmi3(info: &ModelInfo, variables: &[Variable]) -> String {
    let mut x = String::new();
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="3.0" modelName="{}" instantiationToken="{}" description="{}" generationTool="lash {}" variableNamingConvention="structured">"#,
        escape(&info.model_name),
        escape(&info.instantiation_token),
        escape(&info.description),
        env!("CARGO_PKG_VERSION"),
    );
    let _ = writeln!(
        x,
        r#"  <CoSimulation modelIdentifier="{}" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true" canSerializeFMUState="false" canReturnEarlyAfterIntermediateUpdate="false" providesIntermediateUpdate="false" hasEventMode="false"/>"#,
        escape(&info.model_identifier)
    );
    units_and_experiment(&mut x, info, variables, true);
    let _ = writeln!(x, "  <ModelVariables>");
    for v in variables {
        let mut attrs = format!(
            r#"name="{}" valueReference="{}" description="{}" causality="{}" variability="{}""#,
            escape(&v.name),
            v.value_reference,
            escape(&v.description),
            causality(v.causality),
            variability(v.variability)
        );
        if !v.unit.is_empty() {
            let _ = write!(attrs, r#" unit="{}""#, escape(&v.unit));
        }
        match v.causality {
            Causality::Input | Causality::Parameter | Causality::StructuralParameter => {
                let start: Vec<String> = v.start.iter().map(|s| number(*s)).collect();
                let _ = write!(attrs, r#" start="{}""#, start.join(" "));
            }
            Causality::Output | Causality::Local => {
                let _ = write!(attrs, r#" initial="calculated""#);
            }
        }
        if v.shape.is_empty() {
            let _ = writeln!(x, "    <Float64 {attrs}/>");
        } else {
            let _ = writeln!(x, "    <Float64 {attrs}>");
            for d in &v.shape {
                let _ = writeln!(x, r#"      <Dimension start="{d}"/>"#);
            }
            let _ = writeln!(x, "    </Float64>");
        }
    }
    let _ = writeln!(
        x,
        r#"    <Float64 name="time" valueReference="{}" causality="independent" variability="continuous" unit="s" description="simulation time"/>"#,
        time_value_reference(variables)
    );
    let _ = writeln!(x, "  </ModelVariables>");
    let _ = writeln!(x, "  <ModelStructure>");
    let outputs: Vec<&Variable> = variables.iter().filter(|v| v.causality == Causality::Output).collect();
    for v in &outputs {
        let _ = writeln!(x, r#"    <Output valueReference="{}"/>"#, v.value_reference);
    }
    for v in &outputs {
        let _ = writeln!(x, r#"    <InitialUnknown valueReference="{}"/>"#, v.value_reference);
    }
    let _ = writeln!(x, "  </ModelStructure>");
    let _ = writeln!(x, "</fmiModelDescription>");
    x
}

/// The FMI 2.0 `modelDescription.xml` of a co-simulation FMU: one scalar per array element, value
/// references numbered in variable order (the same order [`crate::fmi2`] maps back).
pub fn fmi2(info: &ModelInfo, variables: &[Variable]) -> String {
    let mut x = String::new();
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="{}" guid="{}" description="{}" generationTool="lash {}" variableNamingConvention="structured" numberOfEventIndicators="0">"#,
        escape(&info.model_name),
        escape(&info.instantiation_token),
        escape(&info.description),
        env!("CARGO_PKG_VERSION"),
    );
    let _ = writeln!(
        x,
        r#"  <CoSimulation modelIdentifier="{}" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true" canSerializeFMUstate="false"/>"#,
        escape(&info.model_identifier)
    );
    units_and_experiment(&mut x, info, variables, false);
    let _ = writeln!(x, "  <ModelVariables>");
    let mut index = 0;
    let mut outputs = Vec::new();
    for v in variables {
        for e in 0..v.len() {
            let vr = index;
            index += 1;
            let mut real = String::new();
            match v.causality {
                Causality::Input | Causality::Parameter | Causality::StructuralParameter => {
                    let _ = write!(real, r#" start="{}""#, number(v.start.get(e).copied().unwrap_or(0.0)));
                }
                Causality::Output | Causality::Local => {}
            }
            if !v.unit.is_empty() {
                let _ = write!(real, r#" unit="{}""#, escape(&v.unit));
            }
            let initial = match v.causality {
                Causality::Output | Causality::Local => r#" initial="calculated""#,
                _ => "",
            };
            if v.causality == Causality::Output {
                outputs.push(index); // 1-based position in ModelVariables
            }
            let _ = writeln!(
                x,
                r#"    <ScalarVariable name="{}" valueReference="{vr}" description="{}" causality="{}" variability="{}"{initial}>"#,
                escape(&v.element_name(e)),
                escape(&v.description),
                causality(v.causality),
                variability(v.variability),
            );
            let _ = writeln!(x, "      <Real{real}/>");
            let _ = writeln!(x, "    </ScalarVariable>");
        }
    }
    let _ = writeln!(x, "  </ModelVariables>");
    let _ = writeln!(x, "  <ModelStructure>");
    let _ = writeln!(x, "    <Outputs>");
    for i in &outputs {
        let _ = writeln!(x, r#"      <Unknown index="{i}"/>"#);
    }
    let _ = writeln!(x, "    </Outputs>");
    let _ = writeln!(x, "    <InitialUnknowns>");
    for i in &outputs {
        let _ = writeln!(x, r#"      <Unknown index="{i}"/>"#);
    }
    let _ = writeln!(x, "    </InitialUnknowns>");
    let _ = writeln!(x, "  </ModelStructure>");
    let _ = writeln!(x, "</fmiModelDescription>");
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_core::VariableTable;

    #[test]
    fn describes_arrays_causalities_units_and_structure() {
        let mut t = VariableTable::new();
        t.add("m", Causality::Input, Variability::Continuous, "kg", "a <mass>", &[2, 2], &[1.0, 0.0, 0.0, 1.0]);
        t.add("f", Causality::Output, Variability::Continuous, "N", "force", &[2], &[0.0]);
        t.add("n", Causality::Output, Variability::Discrete, "1", "count", &[], &[0.0]);
        let vars = t.into_variables();
        let info = ModelInfo {
            model_name: "toy".into(),
            model_identifier: "toy".into(),
            instantiation_token: instantiation_token("toy", &vars),
            description: "d".into(),
            default_experiment: (0.0, 1.0, 1e-3),
        };
        let xml = fmi3(&info, &vars);
        assert!(xml.contains(r#"name="m" valueReference="0" description="a &lt;mass&gt;" causality="input""#), "{xml}");
        assert!(xml.contains(r#"start="1.0 0.0 0.0 1.0"><Dimension"#.replace("><", ">\n      <").as_str()), "{xml}");
        assert_eq!(xml.matches(r#"<Dimension start="2"/>"#).count(), 3);
        assert!(
            xml.contains(r#"<Output valueReference="1"/>"#) && xml.contains(r#"<InitialUnknown valueReference="2"/>"#)
        );
        assert!(xml.contains(r#"name="time" valueReference="3" causality="independent""#));
        for u in ["kg", "N", "1", "s"] {
            assert!(xml.contains(&format!(r#"<Unit name="{u}"/>"#)), "{u}");
        }
        assert!(xml.contains(r#"stepSize="1e-3""#), "{xml}");
        // FMI 2.0: four scalars for M, one per element, outputs indexed 1-based.
        let xml2 = fmi2(&info, &vars);
        assert!(xml2.contains(r#"name="m[2,1]" valueReference="2""#), "{xml2}");
        assert!(xml2.contains(r#"name="f[2]" valueReference="5""#), "{xml2}");
        assert!(xml2.contains(r#"<Unknown index="5"/>"#) && xml2.contains(r#"<Unknown index="7"/>"#), "{xml2}");
        assert_eq!(xml2.matches("<ScalarVariable").count(), 7);
        // The token depends on the variables.
        let mut t2 = VariableTable::new();
        t2.add("m", Causality::Input, Variability::Continuous, "kg", "", &[2, 2], &[0.0]);
        assert_ne!(info.instantiation_token, instantiation_token("toy", &t2.into_variables()));
    }
}
