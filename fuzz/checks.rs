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
    lash_system::ssp::parse_ssd(xml, &std::env::temp_dir(), Default::default()).is_ok()
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

/// An FMU archive (any bytes): unpacked into a scratch cache within the default limits, or
/// refused. Never a panic or an abort, and nothing written beside the cache folder.
pub fn fmu_archive(bytes: &[u8]) -> bool {
    let dir = std::env::temp_dir().join(format!("lash-archive-fuzz-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fmu = dir.join("a.fmu");
    std::fs::write(&fmu, bytes).unwrap();
    let unpacked = lash_fmi::import::unpack(&fmu, &dir.join("cache"));
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert!(names == ["a.fmu", "cache"] || names == ["a.fmu"], "written beside the cache: {names:?}");
    if unpacked.is_err() {
        let left = std::fs::read_dir(dir.join("cache").join("fmus")).map_or(0, |r| r.count());
        assert_eq!(left, 0, "a refused archive left {left} folders in the cache");
    }
    let _ = std::fs::remove_dir_all(&dir);
    unpacked.is_ok()
}
