//! Unpacking an FMU (or SSP) archive that nobody vouches for.
//!
//! An FMU is a zip archive from outside: its entries are written only inside one folder of the
//! cache, as regular files and folders, streamed through a fixed buffer with a cap on the bytes
//! written, the number of entries and the compression ratio. The sizes an archive declares are
//! never trusted for an allocation. Refused: symbolic links and device or other special entries
//! (by their Unix mode), absolute paths, paths that leave the folder (`..`), two entries with one
//! name, and archives without `modelDescription.xml`. Every refusal names the entry and the rule.
//!
//! The limits have stated defaults ([`UnpackLimits::default`]) and can be set per process through
//! the environment ([`UnpackLimits::from_env`]): `LASH_FMU_MAX_BYTES` (bytes written in all),
//! `LASH_FMU_MAX_ENTRIES`, `LASH_FMU_MAX_RATIO` (bytes written per byte stored, per entry).

use std::collections::HashSet;
use std::io::{Read, Write};
use std::path::{Component, Path, PathBuf};

/// Caps applied while unpacking one archive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnpackLimits {
    /// Largest archive file read (bytes).
    pub max_archive_bytes: u64,
    /// Largest number of bytes written for all entries together.
    pub max_total_bytes: u64,
    /// Largest number of entries (files and folders).
    pub max_entries: usize,
    /// Largest ratio of an entry's unpacked to its stored size; entries of at most
    /// [`UnpackLimits::RATIO_FREE_BYTES`] unpacked are exempt (a small text compresses well).
    pub max_ratio: u64,
}

impl UnpackLimits {
    /// Unpacked bytes of one entry below which its compression ratio is not checked.
    pub const RATIO_FREE_BYTES: u64 = 1 << 20;

    /// The defaults, overridden by `LASH_FMU_MAX_BYTES`, `LASH_FMU_MAX_ENTRIES` and
    /// `LASH_FMU_MAX_RATIO` where set; a value that is not a positive whole number is an error
    /// naming the variable.
    pub fn from_env() -> Result<Self, String> {
        let mut limits = Self::default();
        let read = |name: &str| -> Result<Option<u64>, String> {
            match std::env::var(name) {
                Err(_) => Ok(None),
                Ok(text) => match text.trim().parse::<u64>() {
                    Ok(v) if v > 0 => Ok(Some(v)),
                    _ => Err(format!("{name}: must be a positive whole number, got {text:?}")),
                },
            }
        };
        if let Some(v) = read("LASH_FMU_MAX_BYTES")? {
            limits.max_total_bytes = v;
        }
        if let Some(v) = read("LASH_FMU_MAX_ENTRIES")? {
            limits.max_entries = usize::try_from(v).unwrap_or(usize::MAX);
        }
        if let Some(v) = read("LASH_FMU_MAX_RATIO")? {
            limits.max_ratio = v;
        }
        Ok(limits)
    }
}

impl Default for UnpackLimits {
    /// 1 GiB archive, 2 GiB unpacked, 10 000 entries, ratio 200 (real FMUs: shared libraries
    /// compress 2–5×, XML 10–40×; a zip bomb reaches 1 000× and more).
    fn default() -> Self {
        Self { max_archive_bytes: 1 << 30, max_total_bytes: 2 << 30, max_entries: 10_000, max_ratio: 200 }
    }
}

/// `S_IFMT` and the kinds of entry accepted.
const S_IFMT: u32 = 0o170000;
const S_IFREG: u32 = 0o100000;
const S_IFDIR: u32 = 0o040000;
const S_IFLNK: u32 = 0o120000;

/// The entry's path inside the archive as plain components: no root, no `..`, no `.`-only
/// name, nothing empty; `None` when the name cannot be a path inside the folder.
fn plain_path(name: &str) -> Option<PathBuf> {
    if name.contains('\0') || name.contains('\\') || name.starts_with('/') {
        return None;
    }
    let mut path = PathBuf::new();
    for c in Path::new(name).components() {
        match c {
            Component::Normal(part) => path.push(part),
            Component::CurDir => {}
            _ => return None,
        }
    }
    (!path.as_os_str().is_empty()).then_some(path)
}

/// A plain file or folder name: no separator, not `.` or `..`, not empty, no NUL.
pub fn is_plain_name(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\', '\0'])
}

/// Unpacks the FMU held in `bytes` into the empty folder `into` (created before), within
/// `limits`. On error `into` may hold part of the archive: the caller removes it.
pub fn unpack_into(bytes: &[u8], into: &Path, limits: &UnpackLimits) -> Result<(), String> {
    unpack_archive_into(bytes, into, limits, "modelDescription.xml")
}

/// Unpacks any untrusted archive (an FMU, an SSP) as [`unpack_into`] does, requiring the file
/// `required` at its top level.
pub fn unpack_archive_into(bytes: &[u8], into: &Path, limits: &UnpackLimits, required: &str) -> Result<(), String> {
    let mut archive =
        zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(|e| format!("not a zip archive: {e}"))?;
    if archive.len() > limits.max_entries {
        return Err(format!(
            "{} entries, more than the limit of {} (LASH_FMU_MAX_ENTRIES)",
            archive.len(),
            limits.max_entries
        ));
    }
    // The reader keeps one entry per name; the end record counts the records it read, so two
    // records of one name show as a difference (and which of them an FMU tool takes is unknown).
    if let Some(records) = central_records(bytes).filter(|&n| n != archive.len() as u64) {
        return Err(format!("{records} entries but {} distinct names: an entry name appears twice", archive.len()));
    }
    let mut seen = HashSet::new();
    let mut description = false;
    let mut written = 0u64;
    let mut buffer = vec![0u8; 1 << 16];
    for index in 0..archive.len() {
        let mut entry = archive.by_index(index).map_err(|e| format!("entry {index}: {e}"))?;
        let name = entry.name().to_string();
        let path = plain_path(&name).ok_or_else(|| {
            format!("entry {name:?}: not a plain relative path (absolute, or leaving the archive's folder)")
        })?;
        let is_dir = entry.is_dir();
        check_kind(&name, entry.unix_mode(), is_dir)?;
        if !seen.insert(path.clone()) {
            return Err(format!(
                "entry {name:?}: its name appears twice (another spelling of an earlier entry's path)"
            ));
        }
        let target = into.join(&path);
        if is_dir {
            std::fs::create_dir_all(&target).map_err(|e| format!("entry {name:?}: {e}"))?;
            continue;
        }
        description |= path == Path::new(required);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("entry {name:?}: {e}"))?;
        }
        let entry_cap = entry.compressed_size().saturating_mul(limits.max_ratio).max(UnpackLimits::RATIO_FREE_BYTES);
        // `create_new`: a file that exists already (a folder entry of the same name, a path met
        // through another spelling) is refused, never overwritten.
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&target)
            .map_err(|e| format!("entry {name:?}: {e}"))?;
        let stored = entry.compressed_size();
        written += stream(&mut entry, &mut file, &mut buffer, (entry_cap, limits.max_total_bytes - written.min(limits.max_total_bytes)))
            .map_err(|cap| match cap {
                Cap::Total => format!(
                    "more than {} bytes unpacked (the limit, LASH_FMU_MAX_BYTES) at entry {name:?}: a zip bomb?",
                    limits.max_total_bytes
                ),
                Cap::Ratio => format!(
                    "entry {name:?} unpacks to more than {} times its {stored} stored bytes (the limit, LASH_FMU_MAX_RATIO): a zip bomb?",
                    limits.max_ratio
                ),
                Cap::Io(e) => format!("entry {name:?}: {e}"),
            })?;
    }
    if !description {
        return Err(format!("no {required} at the archive's top level"));
    }
    Ok(())
}

/// Refuses an entry that is not a regular file or a folder by its Unix mode (a link, a device, a
/// FIFO, a socket); an entry without a mode is a file or a folder by its name.
fn check_kind(name: &str, unix_mode: Option<u32>, is_dir: bool) -> Result<(), String> {
    match unix_mode.map(|m| m & S_IFMT).filter(|&m| m != 0) {
        None => Ok(()),
        Some(S_IFDIR) if is_dir => Ok(()),
        Some(S_IFREG) if !is_dir => Ok(()),
        Some(S_IFLNK) => Err(format!("entry {name:?}: a symbolic link (refused: an FMU's files are its own)")),
        Some(m) => Err(format!("entry {name:?}: not a regular file or folder (Unix mode {m:o})")),
    }
}

/// Which cap a stream hit.
enum Cap {
    /// The entry's ratio cap.
    Ratio,
    /// What is left of the total.
    Total,
    /// Reading or writing failed.
    Io(std::io::Error),
}

/// Copies `from` into `to` through `buffer`, at most `entry_cap` bytes and at most `total_left`;
/// returns the bytes copied.
fn stream(
    from: &mut impl Read,
    to: &mut impl Write,
    buffer: &mut [u8],
    (entry_cap, total_left): (u64, u64),
) -> Result<u64, Cap> {
    let mut copied = 0u64;
    loop {
        let n = from.read(buffer).map_err(Cap::Io)?;
        if n == 0 {
            return Ok(copied);
        }
        copied += n as u64;
        if copied > total_left {
            return Err(Cap::Total);
        }
        if copied > entry_cap {
            return Err(Cap::Ratio);
        }
        to.write_all(&buffer[..n]).map_err(Cap::Io)?;
    }
}

/// The number of central-directory records the end-of-central-directory record declares (its
/// ZIP64 form when the classic one says 0xFFFF); `None` when it cannot be found.
fn central_records(bytes: &[u8]) -> Option<u64> {
    const END: [u8; 4] = 0x0605_4b50u32.to_le_bytes();
    const LOCATOR: [u8; 4] = 0x0706_4b50u32.to_le_bytes();
    let u16_at = |p: usize| bytes.get(p..p + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
    let u64_at = |p: usize| bytes.get(p..p + 8).and_then(|b| b.try_into().ok()).map(u64::from_le_bytes);
    let earliest = bytes.len().saturating_sub(22 + usize::from(u16::MAX));
    let end = (earliest..=bytes.len().checked_sub(22)?).rev().find(|&p| bytes[p..p + 4] == END)?;
    let count = u16_at(end + 10)?;
    if count != u16::MAX {
        return Some(u64::from(count));
    }
    let locator = end.checked_sub(20)?;
    if bytes.get(locator..locator + 4)? != LOCATOR {
        return None;
    }
    let record = usize::try_from(u64_at(locator + 8)?).ok()?;
    u64_at(record.checked_add(32)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_paths_stay_inside() {
        assert_eq!(plain_path("a/b.txt"), Some(PathBuf::from("a/b.txt")));
        assert_eq!(plain_path("./a"), Some(PathBuf::from("a")));
        for bad in ["/etc/passwd", "../x", "a/../../x", "a/..", "", ".", "a\\..\\b", "a\0b"] {
            assert_eq!(plain_path(bad), None, "{bad:?}");
        }
        assert!(is_plain_name("model_1") && !is_plain_name("../x") && !is_plain_name("a/b") && !is_plain_name(".."));
    }
}
