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

/// Why an archive was refused or could not be unpacked: the entry and the rule it broke.
#[derive(Debug, thiserror::Error)]
pub enum UnpackError {
    /// A limit set through the environment is not a positive whole number.
    #[error("{variable}: must be a positive whole number, got {value:?}")]
    Limit {
        /// The environment variable.
        variable: &'static str,
        /// Its text.
        value: String,
    },
    /// The bytes are not a zip archive.
    #[error("not a zip archive: {0}")]
    NotZip(#[source] zip::result::ZipError),
    /// More entries than the limit.
    #[error("{count} entries, more than the limit of {limit} (LASH_FMU_MAX_ENTRIES)")]
    TooManyEntries {
        /// Entries in the archive.
        count: usize,
        /// The limit.
        limit: usize,
    },
    /// The central directory holds two records of one name.
    #[error("{records} entries but {names} distinct names: an entry name appears twice")]
    RepeatedRecord {
        /// Records in the central directory.
        records: u64,
        /// Distinct names.
        names: usize,
    },
    /// An entry's record cannot be read.
    #[error("entry {index}: {source}")]
    Entry {
        /// The entry's index.
        index: usize,
        /// The cause.
        source: zip::result::ZipError,
    },
    /// An entry's name is absolute or leaves the archive's folder.
    #[error("entry {0:?}: not a plain relative path (absolute, or leaving the archive's folder)")]
    NotPlainPath(String),
    /// An entry is a symbolic link.
    #[error("entry {0:?}: a symbolic link (refused: an FMU's files are its own)")]
    Link(String),
    /// An entry is a device, FIFO, socket or other special file.
    #[error("entry {name:?}: not a regular file or folder (Unix mode {mode:o})")]
    Special {
        /// The entry.
        name: String,
        /// Its file type bits.
        mode: u32,
    },
    /// Two entries name one path (another spelling of an earlier entry's path).
    #[error("entry {0:?}: its name appears twice (another spelling of an earlier entry's path)")]
    RepeatedName(String),
    /// More bytes unpacked than the total limit.
    #[error("more than {limit} bytes unpacked (the limit, LASH_FMU_MAX_BYTES) at entry {name:?}: a zip bomb?")]
    TooLarge {
        /// The entry at which the limit was passed.
        name: String,
        /// The limit.
        limit: u64,
    },
    /// An entry unpacks to more than the ratio limit times its stored bytes.
    #[error(
        "entry {name:?} unpacks to more than {ratio} times its {stored} stored bytes (the limit, LASH_FMU_MAX_RATIO): a zip bomb?"
    )]
    Ratio {
        /// The entry.
        name: String,
        /// The limit.
        ratio: u64,
        /// Its stored bytes.
        stored: u64,
    },
    /// Writing an entry into the folder failed.
    #[error("entry {name:?}: {source}")]
    Write {
        /// The entry.
        name: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file the archive must hold at its top level is missing.
    #[error("no {0} at the archive's top level")]
    Missing(String),
}

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
    pub fn from_env() -> Result<Self, UnpackError> {
        let mut limits = Self::default();
        let read = |variable: &'static str| -> Result<Option<u64>, UnpackError> {
            match std::env::var(variable) {
                Err(_) => Ok(None),
                Ok(value) => match value.trim().parse::<u64>() {
                    Ok(v) if v > 0 => Ok(Some(v)),
                    _ => Err(UnpackError::Limit { variable, value }),
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
pub fn unpack_into(bytes: &[u8], into: &Path, limits: &UnpackLimits) -> Result<(), UnpackError> {
    unpack_archive_into(bytes, into, limits, "modelDescription.xml")
}

/// Unpacks any untrusted archive (an FMU, an SSP) as [`unpack_into`] does, requiring the file
/// `required` at its top level.
pub fn unpack_archive_into(
    bytes: &[u8],
    into: &Path,
    limits: &UnpackLimits,
    required: &str,
) -> Result<(), UnpackError> {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(UnpackError::NotZip)?;
    if archive.len() > limits.max_entries {
        return Err(UnpackError::TooManyEntries { count: archive.len(), limit: limits.max_entries });
    }
    // The reader keeps one entry per name; the end record counts the records it read, so two
    // records of one name show as a difference (and which of them an FMU tool takes is unknown).
    if let Some(records) = central_records(bytes).filter(|&n| n != archive.len() as u64) {
        return Err(UnpackError::RepeatedRecord { records, names: archive.len() });
    }
    let mut seen = HashSet::new();
    let mut description = false;
    let mut written = 0u64;
    let mut buffer = vec![0u8; 1 << 16];
    for index in 0..archive.len() {
        let mut entry = archive.by_index(index).map_err(|source| UnpackError::Entry { index, source })?;
        let name = entry.name().to_string();
        let path = plain_path(&name).ok_or_else(|| UnpackError::NotPlainPath(name.clone()))?;
        let write = |source| UnpackError::Write { name: name.clone(), source };
        let is_dir = entry.is_dir();
        check_kind(&name, entry.unix_mode(), is_dir)?;
        if !seen.insert(path.clone()) {
            return Err(UnpackError::RepeatedName(name));
        }
        let target = into.join(&path);
        if is_dir {
            std::fs::create_dir_all(&target).map_err(write)?;
            continue;
        }
        description |= path == Path::new(required);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(write)?;
        }
        let entry_cap = entry.compressed_size().saturating_mul(limits.max_ratio).max(UnpackLimits::RATIO_FREE_BYTES);
        // `create_new`: a file that exists already (a folder entry of the same name, a path met
        // through another spelling) is refused, never overwritten.
        let mut file = std::fs::OpenOptions::new().write(true).create_new(true).open(&target).map_err(write)?;
        let stored = entry.compressed_size();
        written += stream(
            &mut entry,
            &mut file,
            &mut buffer,
            (entry_cap, limits.max_total_bytes - written.min(limits.max_total_bytes)),
        )
        .map_err(|cap| match cap {
            Cap::Total => UnpackError::TooLarge { name: name.clone(), limit: limits.max_total_bytes },
            Cap::Ratio => UnpackError::Ratio { name: name.clone(), ratio: limits.max_ratio, stored },
            Cap::Io(e) => write(e),
        })?;
    }
    if !description {
        return Err(UnpackError::Missing(required.to_string()));
    }
    Ok(())
}

/// Refuses an entry that is not a regular file or a folder by its Unix mode (a link, a device, a
/// FIFO, a socket); an entry without a mode is a file or a folder by its name.
fn check_kind(name: &str, unix_mode: Option<u32>, is_dir: bool) -> Result<(), UnpackError> {
    match unix_mode.map(|m| m & S_IFMT).filter(|&m| m != 0) {
        None => Ok(()),
        Some(S_IFDIR) if is_dir => Ok(()),
        Some(S_IFREG) if !is_dir => Ok(()),
        Some(S_IFLNK) => Err(UnpackError::Link(name.to_string())),
        Some(mode) => Err(UnpackError::Special { name: name.to_string(), mode }),
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
