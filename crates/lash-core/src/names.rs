//! "Did you mean": the few names closest to one that was not found, instead of every candidate
//! (an FMU can have thousands of variables).

/// At most this many suggestions.
const SUGGESTIONS: usize = 3;

/// Below this similarity (normalised Damerau–Levenshtein, 1 = equal) a name is not suggested.
const CLOSE: f64 = 0.5;

/// A short clause for an error message about `wanted`, which none of `candidates` is: the closest
/// few (`did you mean "x[1]" or "x[2]"?`), or, when none is close, how many there are.
pub fn did_you_mean<'a>(wanted: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    let mut scored: Vec<(f64, &str)> =
        candidates.into_iter().map(|c| (strsim::normalized_damerau_levenshtein(wanted, c), c)).collect();
    let total = scored.len();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(b.1)));
    let close: Vec<String> =
        scored.iter().take_while(|(s, _)| *s >= CLOSE).take(SUGGESTIONS).map(|(_, c)| format!("{c:?}")).collect();
    match close.as_slice() {
        [] if total == 0 => "there are none".to_string(),
        [] => format!("none of the {total} is close"),
        [one] => format!("did you mean {one}?"),
        [init @ .., last] => format!("did you mean {} or {last}?", init.join(", ")),
    }
}

/// A CSV header line of `names` (RFC 4180): a name holding a comma or a quote (an FMI 2.0
/// element such as `m[1,2]`) is quoted, its quotes doubled; the others are written as they are.
pub fn csv_header(names: &[String]) -> String {
    let field = |n: &String| {
        if n.contains([',', '"', '\n', '\r']) { format!("\"{}\"", n.replace('"', "\"\"")) } else { n.clone() }
    };
    names.iter().map(field).collect::<Vec<_>>().join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_few_close_names_are_suggested_never_all() {
        let many: Vec<String> =
            (1..=1000).map(|i| format!("controller.x[{i}]")).chain(["p_Crane.e[1]".into()]).collect();
        let said = did_you_mean("p_crane.e[1]", many.iter().map(String::as_str));
        assert_eq!(said, "did you mean \"p_Crane.e[1]\"?");
        assert!(said.len() < 120, "{said}");
        assert_eq!(did_you_mean("speed", ["speed_rpm"]), "did you mean \"speed_rpm\"?");
        assert_eq!(did_you_mean("zzz", ["alpha", "beta"]), "none of the 2 is close");
        assert_eq!(did_you_mean("x", std::iter::empty()), "there are none");
    }

    #[test]
    fn csv_header_quotes_only_what_needs_it() {
        let names = ["time [s]", "o.m[1,2] [kg]", "say \"hi\""].map(String::from);
        assert_eq!(csv_header(&names), "time [s],\"o.m[1,2] [kg]\",\"say \"\"hi\"\"\"");
    }
}
