//! The readers of untrusted text, fuzzed within the test command: modelDescription.xml (FMI 2.0
//! and 3.0), SSP system structure and parameter files, system files and scenario files. Each is fed
//! mutations of a valid file (bytes flipped, inserted, deleted; lines duplicated, numbers replaced
//! by extreme ones, the text cut short) and arbitrary text. No input may panic, abort or allocate
//! without bound; a scenario that parses and validates must also build and run a few steps.
//! The runs are bounded and reproducible (a fixed seed); the cargo-fuzz targets in fuzz/ run the
//! same checks without a bound.

#[path = "../fuzz/checks.rs"]
mod checks;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};
use std::path::Path;

/// Edits applied to a seed text.
#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Insert(usize, String),
    Delete(usize, usize),
    Number(usize, &'static str),
    DuplicateLine(usize),
    Cut(usize),
}

const EXTREMES: &[&str] = &[
    "0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "NaN",
    "inf",
    "-inf",
    "18446744073709551615",
    "99999999999999999999",
    "4294967295",
    "1e18",
    "-0",
    "\"\"",
    "[]",
    "{}",
    "1.5",
    "3",
];

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Flip(p, b)),
        (any::<usize>(), "[<>=\"/ \\[\\]{}a-z0-9.,\n-]{0,12}").prop_map(|(p, s)| Edit::Insert(p, s)),
        (any::<usize>(), 0usize..40).prop_map(|(p, n)| Edit::Delete(p, n)),
        (any::<usize>(), proptest::sample::select(EXTREMES)).prop_map(|(p, s)| Edit::Number(p, s)),
        any::<usize>().prop_map(Edit::DuplicateLine),
        any::<usize>().prop_map(Edit::Cut),
    ]
}

/// The seed with the edits applied (kept valid UTF-8: the readers take `&str`).
fn mutate(seed: &str, edits: &[Edit]) -> String {
    String::from_utf8_lossy(&mutate_bytes(seed.as_bytes(), edits)).into_owned()
}

/// The seed's bytes with the edits applied.
fn mutate_bytes(seed: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for e in edits {
        let n = bytes.len().max(1);
        match e {
            Edit::Flip(p, b) => {
                if !bytes.is_empty() {
                    bytes[p % n] = *b;
                }
            }
            Edit::Insert(p, s) => {
                let at = p % (bytes.len() + 1);
                bytes.splice(at..at, s.bytes());
            }
            Edit::Delete(p, k) => {
                let at = p % n;
                let end = (at + k).min(bytes.len());
                if at < end {
                    bytes.drain(at..end);
                }
            }
            Edit::Number(p, s) => {
                // Replace the number (or word) found at or after p by an extreme value.
                let at = p % n;
                if let Some(start) = (at..bytes.len()).find(|&i| bytes[i].is_ascii_digit()) {
                    let end = (start..bytes.len())
                        .find(|&i| !(bytes[i].is_ascii_alphanumeric() || bytes[i] == b'.' || bytes[i] == b'-'))
                        .unwrap_or(bytes.len());
                    bytes.splice(start..end, s.bytes());
                }
            }
            Edit::DuplicateLine(p) => {
                let lines: Vec<&[u8]> = bytes.split(|&b| b == b'\n').collect();
                let k = p % lines.len();
                let mut out: Vec<&[u8]> = lines.clone();
                out.insert(k, lines[k]);
                bytes = out.join(&b'\n');
            }
            Edit::Cut(p) => {
                let at = p % n;
                bytes.truncate(at);
            }
        }
    }
    bytes
}

/// Runs `check_mutant` (a reader on its seed with the edits applied; whether it accepted) on
/// `config.cases` lists of edits; a panic fails the test. Returns (tried, accepted).
fn run_mutations(config: &Config, what: &str, check_mutant: impl Fn(&[Edit]) -> bool) -> (u32, u32) {
    let (tried, accepted) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
    TestRunner::new(config.clone())
        .run(&proptest::collection::vec(edit(), 1..4), |edits| {
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check_mutant(&edits)));
            prop_assert!(outcome.is_ok(), "{what} mutated by {edits:?} panicked");
            tried.set(tried.get() + 1);
            accepted.set(accepted.get() + u32::from(outcome.unwrap_or(false)));
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    (tried.get(), accepted.get())
}

/// Runs `check` on mutations of every seed and on arbitrary text, `cases` inputs each. `check`
/// says whether the reader accepted the input; at least `min_accepted` of the mutated inputs must
/// be accepted, so that the fuzzing reaches past the first syntax check.
fn fuzz(name: &str, seeds: &[String], cases: u32, min_accepted: f64, check: fn(&str) -> bool) {
    let config = Config { cases, failure_persistence: None, rng_seed: RngSeed::Fixed(0x1a5b), ..Config::default() };
    let (mut tried, mut accepted) = (0, 0);
    for (k, seed) in seeds.iter().enumerate() {
        assert!(check(seed), "{name}: seed {k} is refused:\n{seed}");
        let (t, a) = run_mutations(&config, &format!("{name}: seed {k}"), |edits| check(&mutate(seed, edits)));
        (tried, accepted) = (tried + t, accepted + a);
    }
    let mut runner = TestRunner::new(config);
    runner
        .run(&".{0,400}", |text| {
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&text)));
            prop_assert!(outcome.is_ok(), "{name}: arbitrary text panicked: {text:?}");
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    let share = f64::from(accepted) / f64::from(tried.max(1));
    eprintln!("{name}: {accepted} of {tried} mutated inputs accepted");
    assert!(share >= min_accepted, "{name}: only {share:.2} of the mutated inputs were accepted");
}

fn read(path: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

#[test]
fn model_descriptions() {
    let mut seeds =
        vec![read("tests/fmi/oscillator/modelDescription.xml"), read("tests/fmi/vanderpol/modelDescription.xml")];
    seeds.extend(
        lash_catalog::descriptions(&lash_scenario::AnyScenario::Planar(lash_catalog::default_scenario().unwrap()))
            .unwrap()
            .into_iter()
            .map(|(_, _, xml)| xml),
    );
    fuzz("modelDescription.xml", &seeds, 300, 0.2, checks::model_description);
}

#[test]
fn ssp_files() {
    fuzz("SystemStructure.ssd", &[read("fuzz/seeds/system.ssd")], 300, 0.1, checks::ssd);
    fuzz("parameter values .ssv", &[read("fuzz/seeds/parameters.ssv")], 300, 0.1, checks::ssv);
}

#[test]
fn system_files() {
    let seeds = [read("examples/systems/reduced-A.toml"), read("examples/systems/full-model-accelerometer.toml")];
    fuzz("system file", &seeds, 300, 0.1, checks::system);
}

#[test]
fn scenario_files() {
    let seeds: Vec<String> =
        ["examples/A.toml", "examples/B.toml", "examples/A-motor.toml"].iter().map(|p| read(p)).collect();
    fuzz("scenario file", &seeds, 600, 0.03, checks::scenario);
}

/// FMU archives: a valid archive (stored and deflated entries, folders) with its bytes flipped,
/// inserted, deleted and cut, and arbitrary bytes, unpacked within the default limits: refused or
/// unpacked, never a panic or an abort, and nothing written beside the cache.
#[test]
fn fmu_archives() {
    use std::io::Write;
    let description = read("tests/fmi/oscillator/modelDescription.xml");
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    w.start_file("modelDescription.xml", deflated).unwrap();
    w.write_all(description.as_bytes()).unwrap();
    w.add_directory("binaries/x86_64-linux/", stored).unwrap();
    w.start_file("binaries/x86_64-linux/oscillator.so", stored).unwrap();
    w.write_all(&[0x7f, b'E', b'L', b'F', 2, 1, 1, 0]).unwrap();
    w.start_file("resources/table.txt", deflated).unwrap();
    w.write_all("0 1\n1 2\n".repeat(50).as_bytes()).unwrap();
    let seed = w.finish().unwrap().into_inner();
    assert!(checks::fmu_archive(&seed), "the seed archive is refused");
    let config =
        Config { cases: 400, failure_persistence: None, rng_seed: RngSeed::Fixed(0x1a5c), ..Config::default() };
    let (tried, accepted) =
        run_mutations(&config, "the archive", |edits| checks::fmu_archive(&mutate_bytes(&seed, edits)));
    let mut runner = TestRunner::new(config);
    runner
        .run(&proptest::collection::vec(any::<u8>(), 0..600), |bytes| {
            let outcome = std::panic::catch_unwind(|| checks::fmu_archive(&bytes));
            prop_assert!(outcome.is_ok(), "arbitrary bytes panicked: {bytes:?}");
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    eprintln!("FMU archives: {accepted} of {tried} mutated archives unpacked");
    // Most edits break a checksum or an offset (a refusal that read the entries); a few keep the
    // archive whole, which takes the fuzzing through the writing of files too.
    assert!(accepted >= tried / 40, "too few mutated archives unpack for the fuzzing to reach the files");
}
