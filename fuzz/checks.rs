//! The checks of lash's readers of untrusted text, shared by the bounded fuzzing in the test
//! command (tests/readers.rs) and the cargo-fuzz targets (fuzz/fuzz_targets/). Each returns
//! whether the reader accepted the input; any panic is a failure.

#![allow(dead_code)]

use std::path::Path;

/// modelDescription.xml (FMI 2.0 and 3.0): parsed, and what is accepted has bounded sizes.
pub fn model_description(xml: &str) -> bool {
    match lash_fmi::import::parse_description(xml) {
        Ok(d) => {
            let total: usize = d.variables.iter().map(|v| v.len()).sum();
            assert!(total <= lash_fmi::import::MAX_ELEMENTS, "{total} elements accepted");
            true
        }
        Err(_) => false,
    }
}

/// An SSP system structure description (`.ssd`).
pub fn ssd(xml: &str) -> bool {
    lash_system::ssp::parse_ssd(xml, &std::env::temp_dir(), None).is_ok()
}

/// An SSP parameter value file (`.ssv`).
pub fn ssv(xml: &str) -> bool {
    lash_system::ssp::parse_ssv(xml).is_ok()
}

/// A system file: parsed and, if it parses, built (built-in elements only: an FMU or plugin path
/// names a file the fuzzer cannot provide, and must be an error, not a panic).
pub fn system(text: &str) -> bool {
    match lash_system::spec::parse(text) {
        Ok(spec) => {
            let cache = std::env::temp_dir().join("lash-readers-fuzz-cache");
            let _ = lash_system::System::new(&spec, Path::new("/nonexistent"), &cache);
            true
        }
        Err(_) => false,
    }
}

/// A scenario file: parsed, validated, and a valid one built and run for at most 20 output
/// intervals (or 100 rows).
pub fn scenario(text: &str) -> bool {
    let Ok(mut s) = lash_scenario::parse(text) else { return false };
    s.simulation.horizon = s.simulation.horizon.min(20.0 * s.simulation.output_interval);
    if lash_scenario::validate(&s).is_empty() {
        let mut run = lash_run::FullRun::new(&s, lash_run::BuildOptions::default());
        let mut rows = 0usize;
        let _ = lash_run::Runner::execute(
            &mut run,
            &mut |_| {
                rows += 1;
                if rows > 100 { Err("enough".into()) } else { Ok(()) }
            },
            &mut |_| {},
        );
    }
    true
}
