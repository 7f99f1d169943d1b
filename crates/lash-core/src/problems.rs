//! Validation problems that name the field they concern, collected so that every problem of an
//! input is reported at once.

use std::fmt;

/// One problem of an input: the path of the field (`bodies[2].mass`) and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// Path of the offending field, e.g. `clearances[0].journal_radius`.
    pub field: String,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

/// All problems found in one input. Empty means valid.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Problems(pub Vec<Problem>);

impl Problems {
    /// An empty list.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records a problem with `field`.
    pub fn push(&mut self, field: impl Into<String>, message: impl Into<String>) {
        self.0.push(Problem { field: field.into(), message: message.into() });
    }

    /// Records a problem unless `value` is finite and strictly positive.
    pub fn positive(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() {
            self.push(field, format!("must be a finite number, got {value}"));
        } else if value <= 0.0 {
            self.push(field, format!("must be > 0, got {value}"));
        }
    }

    /// Records a problem unless `value` is finite and ≥ 0.
    pub fn non_negative(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() {
            self.push(field, format!("must be a finite number, got {value}"));
        } else if value < 0.0 {
            self.push(field, format!("must be ≥ 0, got {value}"));
        }
    }

    /// Records a problem unless `value` is finite.
    pub fn finite(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() {
            self.push(field, format!("must be a finite number, got {value}"));
        }
    }

    /// Records a problem unless `lo ≤ value ≤ hi` (and finite).
    pub fn in_range(&mut self, field: impl Into<String>, value: f64, lo: f64, hi: f64) {
        if !value.is_finite() || value < lo || value > hi {
            self.push(field, format!("must lie in [{lo}, {hi}], got {value}"));
        }
    }

    /// [`Problems::extend_prefixed`] with the prefix made only when `other` holds a problem (a
    /// check of many elements formats no field path for those that pass).
    pub fn extend_prefixed_with(&mut self, prefix: impl FnOnce() -> String, other: Problems) {
        if !other.is_empty() {
            self.extend_prefixed(&prefix(), other);
        }
    }

    /// Moves all problems of `other` in, prefixing their field paths with `prefix`.
    pub fn extend_prefixed(&mut self, prefix: &str, other: Problems) {
        for p in other.0 {
            let field = if p.field.is_empty() {
                prefix.to_string()
            } else if p.field.starts_with('[') {
                format!("{prefix}{}", p.field)
            } else {
                format!("{prefix}.{}", p.field)
            };
            self.0.push(Problem { field, message: p.message });
        }
    }

    /// True when no problem was recorded.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `Ok(())` when empty, else `Err(self)`.
    pub fn into_result(self) -> Result<(), Problems> {
        if self.is_empty() { Ok(()) } else { Err(self) }
    }
}

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0.len();
        writeln!(f, "{n} problem{} found:", if n == 1 { "" } else { "s" })?;
        for p in &self.0 {
            writeln!(f, "  - {p}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Problems {}

/// An error and its causes on one line, `error: cause: cause's cause` — for the places where a
/// typed error must become text (an FMI log message, a subsystem's `Other` error).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(&format!(": {c}"));
        cause = c.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collects_and_prefixes() {
        let mut inner = Problems::new();
        inner.positive("mass", -1.0);
        inner.finite("angle", f64::NAN);
        inner.in_range("restitution", 1.5, 0.0, 1.0);
        let mut outer = Problems::new();
        outer.extend_prefixed("bodies[1]", inner);
        assert_eq!(outer.0.len(), 3);
        assert_eq!(outer.0[0].field, "bodies[1].mass");
        assert!(outer.to_string().contains("3 problems"));
        assert!(outer.clone().into_result().is_err());
        assert!(Problems::new().into_result().is_ok());
    }

    /// The chain names every cause, outermost first.
    #[test]
    fn an_error_chain_names_every_cause() {
        #[derive(Debug)]
        struct Outer(std::io::Error);
        impl std::fmt::Display for Outer {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("reading scenario.toml")
            }
        }
        impl std::error::Error for Outer {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let e = Outer(std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"));
        assert_eq!(super::error_chain(&e), "reading scenario.toml: no such file");
    }
}
