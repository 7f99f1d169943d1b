//! FMU archives written by a hostile author: links, traversal, absolute paths, duplicate
//! entries, device files, lying sizes, zip bombs and identifiers that are paths. Each is refused
//! with a message naming the entry and the rule, nothing is written outside the cache folder,
//! and a refused unpack leaves nothing that changes the next answer.
//!
//! The archives are written byte by byte here (a zip writer normalises names and modes, which is
//! exactly what a hostile archive does not do).

use lash_fmi::archive::{UnpackError, UnpackLimits, unpack_into};
use lash_fmi::import::{parse_description, unpack};
use std::path::{Path, PathBuf};

/// One entry of a hand-written archive.
struct Entry {
    name: String,
    data: Vec<u8>,
    /// Unix mode (type and permissions) in the external attributes.
    mode: u32,
    /// The uncompressed size written into the headers (the true one when `None`).
    declared: Option<u32>,
}

fn file(name: &str, data: &[u8]) -> Entry {
    Entry { name: name.into(), data: data.to_vec(), mode: 0o100644, declared: None }
}

/// A zip archive of stored entries with the given names, modes and declared sizes.
fn archive(entries: &[Entry]) -> Vec<u8> {
    let (mut out, mut central) = (Vec::new(), Vec::new());
    let u16le = |v: &mut Vec<u8>, x: u16| v.extend_from_slice(&x.to_le_bytes());
    let u32le = |v: &mut Vec<u8>, x: u32| v.extend_from_slice(&x.to_le_bytes());
    for e in entries {
        let offset = out.len() as u32;
        let crc = crc32fast::hash(&e.data);
        let (stored, declared) = (e.data.len() as u32, e.declared.unwrap_or(e.data.len() as u32));
        u32le(&mut out, 0x0403_4b50);
        for x in [20, 0, 0, 0, 0x21] {
            u16le(&mut out, x);
        }
        for x in [crc, stored, declared] {
            u32le(&mut out, x);
        }
        u16le(&mut out, e.name.len() as u16);
        u16le(&mut out, 0);
        out.extend_from_slice(e.name.as_bytes());
        out.extend_from_slice(&e.data);
        u32le(&mut central, 0x0201_4b50);
        for x in [(3 << 8) | 20, 20, 0, 0, 0, 0x21] {
            u16le(&mut central, x);
        }
        for x in [crc, stored, declared] {
            u32le(&mut central, x);
        }
        for x in [e.name.len() as u16, 0, 0, 0, 0] {
            u16le(&mut central, x);
        }
        u32le(&mut central, e.mode << 16);
        u32le(&mut central, offset);
        central.extend_from_slice(e.name.as_bytes());
    }
    let (cd_offset, cd_size) = (out.len() as u32, central.len() as u32);
    out.extend_from_slice(&central);
    u32le(&mut out, 0x0605_4b50);
    for x in [0, 0, entries.len() as u16, entries.len() as u16] {
        u16le(&mut out, x);
    }
    u32le(&mut out, cd_size);
    u32le(&mut out, cd_offset);
    u16le(&mut out, 0);
    out
}

const DESCRIPTION: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="t">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables><Float64 name="time" valueReference="0" causality="independent"/></ModelVariables>
</fmiModelDescription>"#;

/// A fresh scratch folder for one test.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lash-hostile-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `bytes` as `<dir>/<name>.fmu` and unpacks it into `<dir>/cache`.
fn unpack_bytes(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf, String> {
    let fmu = dir.join(format!("{name}.fmu"));
    std::fs::write(&fmu, bytes).unwrap();
    unpack(&fmu, &dir.join("cache")).map_err(|e| e.to_string())
}

/// What the cache's `fmus` folder holds (names).
fn cache_listing(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir.join("cache").join("fmus"))
        .map(|r| r.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default()
}

#[test]
fn links_traversal_absolute_paths_duplicates_and_devices_are_refused() {
    let dir = scratch("refused");
    let outside = dir.join("outside.txt");
    let absolute = outside.to_str().unwrap().to_string();
    let link = |name: &str, target: &str| Entry {
        name: name.into(),
        data: target.as_bytes().to_vec(),
        mode: 0o120777,
        declared: None,
    };
    let special = |mode: u32| Entry { name: "resources/dev".into(), data: Vec::new(), mode, declared: None };
    let cases: Vec<(&str, Vec<Entry>, &str)> = vec![
        ("link", vec![link("binaries/x86_64-linux/m.so", "/lib/x86_64-linux-gnu/libc.so.6")], "a symbolic link"),
        ("link-up", vec![link("resources/up", "../../..")], "a symbolic link"),
        ("dotdot", vec![file("../outside.txt", b"x")], "not a plain relative path"),
        ("inner-dotdot", vec![file("resources/../../outside.txt", b"x")], "not a plain relative path"),
        ("absolute", vec![file(&absolute, b"x")], "not a plain relative path"),
        ("backslash", vec![file("..\\..\\outside.txt", b"x")], "not a plain relative path"),
        ("duplicate", vec![file("modelDescription.xml", DESCRIPTION.as_bytes())], "appears twice"),
        ("dot-duplicate", vec![file("./modelDescription.xml", b"<x/>")], "appears twice"),
        ("char-device", vec![special(0o020644)], "not a regular file or folder (Unix mode 20000)"),
        ("block-device", vec![special(0o060644)], "not a regular file or folder (Unix mode 60000)"),
        ("fifo", vec![special(0o010644)], "not a regular file or folder (Unix mode 10000)"),
        ("socket", vec![special(0o140644)], "not a regular file or folder (Unix mode 140000)"),
    ];
    for (tag, extra, expected) in cases {
        let mut entries = vec![file("modelDescription.xml", DESCRIPTION.as_bytes())];
        entries.extend(extra);
        let bytes = archive(&entries);
        for attempt in 0..2 {
            let e = unpack_bytes(&dir, tag, &bytes).expect_err(tag);
            assert!(e.contains(expected), "{tag}, attempt {attempt}: {e}");
            assert!(cache_listing(&dir).is_empty(), "{tag}: the cache holds {:?}", cache_listing(&dir));
        }
        assert!(!outside.exists(), "{tag}: a file was written outside the cache");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_model_identifier_that_is_a_path_is_refused() {
    for identifier in ["../../../../tmp/evil", "/tmp/evil", "a/b", "..", "", "1m", "m-x", "m.so"] {
        let xml = DESCRIPTION.replace("modelIdentifier=\"m\"", &format!("modelIdentifier={identifier:?}"));
        assert!(parse_description(&xml).is_err(), "{identifier:?} accepted");
    }
    assert!(parse_description(DESCRIPTION).is_ok());
    assert!(parse_description(&DESCRIPTION.replace("\"m\"", "\"_Model_2\"")).is_ok());
}

#[test]
fn bombs_and_lying_sizes_hit_a_limit_before_the_disk_or_memory_does() {
    let dir = scratch("bombs");
    // 8 MiB of zeros deflated: ~8 KiB stored, a ratio near 1 000.
    let bomb = {
        use std::io::Write;
        let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        w.start_file("modelDescription.xml", deflated).unwrap();
        w.write_all(DESCRIPTION.as_bytes()).unwrap();
        w.start_file("resources/zeros.bin", deflated).unwrap();
        w.write_all(&vec![0u8; 8 << 20]).unwrap();
        w.finish().unwrap().into_inner()
    };
    let e = unpack_bytes(&dir, "bomb", &bomb).unwrap_err();
    assert!(e.contains("LASH_FMU_MAX_RATIO") && e.contains("resources/zeros.bin"), "{e}");
    assert!(cache_listing(&dir).is_empty());
    // The total and the entry count, with limits set low.
    let into = dir.join("into");
    let low = UnpackLimits { max_total_bytes: 1 << 20, max_ratio: 10_000, ..UnpackLimits::default() };
    std::fs::create_dir_all(&into).unwrap();
    let e = unpack_into(&bomb, &into, &low).unwrap_err();
    assert!(matches!(&e, UnpackError::TooLarge { limit: 1048576, name } if name == "resources/zeros.bin"), "{e:?}");
    let e = e.to_string();
    assert!(e.contains("more than 1048576 bytes unpacked") && e.contains("LASH_FMU_MAX_BYTES"), "{e}");
    let many: Vec<Entry> = (0..20).map(|k| file(&format!("resources/{k}"), b"x")).collect();
    let few = UnpackLimits { max_entries: 10, ..UnpackLimits::default() };
    let _ = std::fs::remove_dir_all(&into);
    std::fs::create_dir_all(&into).unwrap();
    let e = unpack_into(&archive(&many), &into, &few).unwrap_err();
    assert!(matches!(e, UnpackError::TooManyEntries { count: 20, limit: 10 }), "{e:?}");
    assert!(e.to_string().contains("20 entries, more than the limit of 10"), "{e}");
    // An entry declaring 4 GiB that holds 10 bytes: read as what it is, never allocated.
    let liar = archive(&[
        file("modelDescription.xml", DESCRIPTION.as_bytes()),
        Entry {
            name: "resources/big".into(),
            data: b"0123456789".to_vec(),
            mode: 0o100644,
            declared: Some(u32::MAX - 1),
        },
    ]);
    let _ = unpack_bytes(&dir, "liar", &liar);
    let liar_link = archive(&[
        file("modelDescription.xml", DESCRIPTION.as_bytes()),
        Entry { name: "resources/l".into(), data: b"/etc".to_vec(), mode: 0o120777, declared: Some(u32::MAX - 1) },
    ]);
    assert!(unpack_bytes(&dir, "liar-link", &liar_link).unwrap_err().contains("a symbolic link"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failed_unpack_leaves_nothing_and_says_the_same_twice() {
    let dir = scratch("residue");
    let headless = archive(&[file("resources/a.txt", b"a")]);
    for _ in 0..2 {
        let e = unpack_bytes(&dir, "headless", &headless).unwrap_err();
        assert!(e.contains("no modelDescription.xml"), "{e}");
        assert!(cache_listing(&dir).is_empty());
    }
    // A good archive; a folder of it left incomplete (no mark) and a partial folder of a process
    // that no longer runs are replaced, not trusted.
    let good = archive(&[file("modelDescription.xml", DESCRIPTION.as_bytes()), file("resources/a.txt", b"a")]);
    let unpacked = unpack_bytes(&dir, "good", &good).unwrap();
    assert_eq!(std::fs::read(unpacked.join("resources/a.txt")).unwrap(), b"a");
    std::fs::remove_dir_all(&unpacked).unwrap();
    std::fs::create_dir_all(unpacked.join("resources")).unwrap();
    std::fs::write(unpacked.join("modelDescription.xml"), "<broken").unwrap();
    let stale = unpacked.with_extension("partial-999999999-1");
    std::fs::create_dir_all(&stale).unwrap();
    let again = unpack_bytes(&dir, "good", &good).unwrap();
    assert_eq!(again, unpacked);
    assert_eq!(std::fs::read_to_string(again.join("modelDescription.xml")).unwrap(), DESCRIPTION);
    assert!(!stale.exists(), "a dead process's partial folder is removed");
    let _ = std::fs::remove_dir_all(&dir);
}
