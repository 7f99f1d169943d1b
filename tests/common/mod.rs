//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use lash_scenario::{Runner, Summary};

/// Runs to the end, keeping every row.
pub fn rows(runner: &mut dyn Runner) -> (Summary, Vec<String>, Vec<Vec<f64>>) {
    let header = runner.header();
    let mut rows = Vec::new();
    let summary = runner
        .execute(
            &mut |r| {
                rows.push(r.to_vec());
                Ok(())
            },
            &mut |_| {},
        )
        .unwrap();
    (summary, header, rows)
}

/// Index of the column called `name` (units stripped).
pub fn column(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h.starts_with(&format!("{name} ["))).unwrap_or_else(|| panic!("no column {name}"))
}
