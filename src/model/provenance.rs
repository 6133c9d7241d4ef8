//! Provenance of a report: which tool made it, from which files, with which parameters, so a
//! report found later can be traced and rerun.
//!
//! Files are identified by path and SHA-256 of their content (FIPS 180-4: the one hash a
//! user can check with `sha256sum`).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::SystemTime;

use serde::{Deserialize, Serialize};

/// The tool's version (`Cargo.toml`).
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// The git revision (commit) the binary was built from (`build.rs`), `unknown` outside a
/// checkout or without git. Uncommitted changes are not marked.
pub const GIT_REVISION: &str = env!("DEXWARP_GIT_REVISION");

/// One input file of a run.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputFile {
    /// The absolute path (as the run resolved it when it cannot be made absolute).
    pub path: String,
    /// SHA-256 of the content, lowercase hex; empty when the file could not be read again.
    pub sha256: String,
}

impl InputFile {
    /// `path` with the hash of its current content. A file hashed before by this process
    /// whose length and modification time are unchanged is not read again (`augment` and
    /// `batch` name the same demonstration, robot and mesh in every report).
    pub fn of(path: &Path) -> InputFile {
        let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        InputFile {
            path: canonical.display().to_string(),
            sha256: content_hash(&canonical).unwrap_or_default(),
        }
    }
}

/// The file's length and modification time: what says its content may have changed.
type Stamp = (u64, Option<SystemTime>);

fn content_hash(path: &Path) -> Option<String> {
    static HASHES: OnceLock<Mutex<HashMap<PathBuf, (Stamp, String)>>> = OnceLock::new();
    let hashes = HASHES.get_or_init(Mutex::default);
    let stamp = |m: &std::fs::Metadata| (m.len(), m.modified().ok());
    let before = stamp(&std::fs::metadata(path).ok()?);
    if let Some((s, hash)) = hashes.lock().ok()?.get(path)
        && *s == before
        && before.1.is_some()
    {
        return Some(hash.clone());
    }
    let hash = sha256_hex(&std::fs::read(path).ok()?);
    // Kept only when the file did not change while it was read.
    if stamp(&std::fs::metadata(path).ok()?) == before
        && let Ok(mut h) = hashes.lock()
    {
        h.insert(path.to_path_buf(), (before, hash.clone()));
    }
    Some(hash)
}

/// Where a report came from.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// `dexwarp` version.
    pub tool_version: String,
    pub git_revision: String,
    /// Input files by role: `config`, `demo`, `scene`, `robot`, `mesh`.
    pub inputs: BTreeMap<String, InputFile>,
    /// Every parameter in effect, by group (`warp`, `ik`, `smooth`, `physics`, `limits`,
    /// `options`), overrides applied.
    pub parameters: BTreeMap<String, serde_json::Value>,
}

impl Provenance {
    /// The tool's identity and no inputs yet.
    pub fn new() -> Provenance {
        Provenance {
            tool_version: TOOL_VERSION.into(),
            git_revision: GIT_REVISION.into(),
            ..Provenance::default()
        }
    }

    /// Records the input file of `role`.
    pub fn input(&mut self, role: &str, path: &Path) {
        self.inputs.insert(role.into(), InputFile::of(path));
    }

    /// Records a parameter group (any serializable value).
    pub fn parameters<T: Serialize>(&mut self, group: &str, value: &T) {
        let v = serde_json::to_value(value).unwrap_or(serde_json::Value::Null);
        self.parameters.insert(group.into(), v);
    }
}

/// SHA-256 of `data` as 64 lowercase hex digits.
pub fn sha256_hex(data: &[u8]) -> String {
    sha256(data).iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (FIPS 180-4), through the `sha2` crate: it uses the CPU's SHA extensions when
/// it has them (checked at run time), about 5x the portable rounds on 1.7 GB of run files.
pub fn sha256(data: &[u8]) -> [u8; 32] {
    use sha2::Digest;
    sha2::Sha256::digest(data).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_matches_the_standard_vectors() {
        // FIPS 180-4 examples and the empty message.
        assert_eq!(
            sha256_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            sha256_hex(b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        // A million 'a': many full blocks.
        assert_eq!(
            sha256_hex(&vec![b'a'; 1_000_000]),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"
        );
    }

    #[test]
    fn a_file_hashed_again_after_it_changed_gets_its_new_hash() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("demo.json");
        std::fs::write(&path, b"abc").unwrap();
        let first = InputFile::of(&path);
        assert_eq!(first.sha256, sha256_hex(b"abc"));
        assert_eq!(InputFile::of(&path), first);
        std::fs::write(&path, b"abcd").unwrap();
        assert_eq!(InputFile::of(&path).sha256, sha256_hex(b"abcd"));
        std::fs::remove_file(&path).unwrap();
        assert_eq!(InputFile::of(&path).sha256, "");
    }
}
