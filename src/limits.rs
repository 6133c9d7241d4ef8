//! Size limits and value ranges on untrusted input.
//!
//! Demonstrations come from third-party datasets. Every quantity that sets how much work or
//! memory a run takes is bounded before the work starts, with a clear message naming the
//! limit and the flag that raises it; a user with a genuine large input raises the limit on
//! the command line (each field names its flag).
//!
//! Finite but absurd values (a position of 1e308 m, a frame rate of 1e-300 Hz) are refused at
//! load against the ranges stated here: they parse as JSON numbers but turn into NaN or
//! unbounded work downstream.

use std::io::Read;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Half the edge of the world cube every position must lie in [m]: 1 km, far beyond any
/// tabletop scene, far inside the range where squared distances stay exact in `f64`.
pub const WORLD_HALF_EXTENT_M: f64 = 1_000.0;

/// Largest point offset inside a link or object frame [m] (contact points, mesh vertices are
/// within this of their frame's origin for any hand or hand-held object).
pub const MAX_LOCAL_OFFSET_M: f64 = 10.0;

/// Largest joint value magnitude: 100 rad (16 turns of a continuous joint) or 100 m.
pub const MAX_JOINT_ABS: f64 = 100.0;

/// Frame rates accepted [Hz]: a tenth of a frame per second to 10 kHz (motion capture runs
/// at 30 to 1000 Hz).
pub const FPS_RANGE_HZ: (f64, f64) = (0.1, 10_000.0);

/// Object masses accepted [kg]: a milligram to ten tonnes.
pub const MASS_RANGE_KG: (f64, f64) = (1e-6, 1e4);

/// Upper bounds on input sizes and the work they cause. `Default` fits every dataset we know
/// of with a wide margin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Limits {
    /// Largest JSON or URDF file read, in bytes (`--max-file-mb`, default 512 MiB).
    pub max_file_bytes: u64,
    /// Largest mesh file read, in bytes (`--max-file-mb`, default 512 MiB).
    pub max_mesh_bytes: u64,
    /// Most frames in one demonstration, read or written (`--max-frames`, default 200,000:
    /// 111 minutes at 30 Hz). A warp's output length (set by the waypoints' `t_new`) is
    /// checked before any stage runs. A frame costs about [`BYTES_PER_FRAME`] of memory end to
    /// end, so the default bounds a warp near 9 GiB.
    pub max_frames: u64,
    /// Most contact correspondences in one frame (`--max-contacts`, default 2,048).
    pub max_contacts_per_frame: u64,
    /// Most triangles in one mesh (`--max-triangles`, default 5,000,000).
    pub max_mesh_triangles: u64,
    /// Most links or joints in one robot (`--max-links`, default 1,024), counted in a
    /// pre-scan of the URDF text before it is parsed.
    pub max_links: u64,
    /// Deepest element nesting in a URDF (`--max-xml-depth`, default 64; a real URDF nests
    /// at most 5 deep), checked in the same pre-scan, so a hostile file cannot exhaust the
    /// parser's stack.
    pub max_xml_depth: u64,
    /// Most physics steps of one replay: frames × steps per frame (`--max-physics-steps`,
    /// default 10,000,000, about 7 minutes of replay at 1/240 s steps on one core).
    pub max_physics_steps: u64,
    /// Read devices, pipes and other non-regular files (`--allow-special-files`, default
    /// false). Their size is unknown beforehand; the byte cap still applies while reading.
    pub allow_special_files: bool,
}

/// Peak memory of a warp per output frame, end to end (contact IK, the default ensemble's
/// replays, the written demonstration): 34 KB measured on a 20,000-frame warp of the mug
/// (683 MB peak), rounded up.
pub const BYTES_PER_FRAME: u64 = 48 << 10;

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_file_bytes: 512 << 20,
            max_mesh_bytes: 512 << 20,
            max_frames: 200_000,
            max_contacts_per_frame: 2_048,
            max_mesh_triangles: 5_000_000,
            max_links: 1_024,
            max_xml_depth: 64,
            max_physics_steps: 10_000_000,
            allow_special_files: false,
        }
    }
}

impl Limits {
    /// Reads a whole file of at most `limit` bytes (`flag` raises it).
    ///
    /// Refuses folders, and devices, pipes and sockets unless
    /// [`allow_special_files`](Limits::allow_special_files); checks the size from the metadata
    /// first, then counts bytes while reading (a file growing while read, or a special file,
    /// is cut off at `limit + 1` bytes and refused), so no read allocates more than `limit`.
    pub fn read_file(&self, path: &Path, limit: u64, flag: &'static str) -> Result<Vec<u8>> {
        let meta = std::fs::metadata(path).map_err(|e| Error::read(path, e))?;
        if meta.is_dir() {
            return Err(Error::invalid(
                path,
                "(file)",
                "is a directory; expected a file",
            ));
        }
        if !meta.is_file() && !self.allow_special_files {
            return Err(Error::invalid(
                path,
                "(file)",
                "is not a regular file (a device, pipe or socket); expected a file, or pass --allow-special-files to read it anyway",
            ));
        }
        let too_large = |found: u64| Error::TooLarge {
            path: path.to_path_buf(),
            what: "the file size in bytes",
            found,
            limit,
            flag,
        };
        if meta.is_file() && meta.len() > limit {
            return Err(too_large(meta.len()));
        }
        let file = std::fs::File::open(path).map_err(|e| Error::read(path, e))?;
        let capacity = if meta.is_file() {
            meta.len().min(limit)
        } else {
            0
        };
        let mut bytes = Vec::with_capacity(capacity as usize);
        file.take(limit.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(|e| Error::read(path, e))?;
        if bytes.len() as u64 > limit {
            return Err(too_large(bytes.len() as u64));
        }
        Ok(bytes)
    }

    /// Checks that a replay of `frames` frames at `steps_per_frame` steps each stays within
    /// [`max_physics_steps`](Limits::max_physics_steps); `path` is the demonstration.
    pub fn check_physics_steps(
        &self,
        path: &Path,
        frames: u64,
        steps_per_frame: u64,
    ) -> Result<()> {
        let steps = frames.saturating_mul(steps_per_frame);
        if steps > self.max_physics_steps {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                what: "the number of physics steps (frames x steps per frame, from fps)",
                found: steps,
                limit: self.max_physics_steps,
                flag: "--max-physics-steps",
            });
        }
        Ok(())
    }

    /// Checks an output length of `frames` frames against [`max_frames`](Limits::max_frames);
    /// `path` is the file that asked for it (the config).
    pub fn check_output_frames(&self, path: &Path, frames: u64) -> Result<()> {
        if frames > self.max_frames {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                what: "the number of output frames (from the waypoints' t_new and params.end_t_new; each needs about 48 KiB of memory end to end)",
                found: frames,
                limit: self.max_frames,
                flag: "--max-frames",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_are_capped_while_reading() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.json");
        std::fs::write(&p, vec![b' '; 100]).unwrap();
        let l = Limits::default();
        assert_eq!(l.read_file(&p, 100, "--max-file-mb").unwrap().len(), 100);
        let e = l
            .read_file(&p, 99, "--max-file-mb")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("over the limit of 99") && e.contains("--max-file-mb"),
            "{e}"
        );
    }

    #[test]
    fn special_files_are_refused_unless_allowed() {
        let l = Limits::default();
        let e = l
            .read_file(Path::new("/dev/zero"), 1 << 20, "--max-file-mb")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("not a regular file") && e.contains("--allow-special-files"),
            "{e}"
        );
        let allowed = Limits {
            allow_special_files: true,
            ..l
        };
        // /dev/zero never ends: the byte cap stops the read.
        let e = allowed
            .read_file(Path::new("/dev/zero"), 1 << 20, "--max-file-mb")
            .unwrap_err()
            .to_string();
        assert!(e.contains("over the limit of 1048576"), "{e}");
    }
}
