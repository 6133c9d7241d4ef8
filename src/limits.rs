//! Size limits on untrusted input.
//!
//! Demonstrations come from third-party datasets. Absurd sizes are refused with a clear
//! message before any large allocation; a user with a genuine large input raises the limit
//! on the command line (each field names its flag).

use serde::{Deserialize, Serialize};

/// Upper bounds on input sizes. `Default` fits every dataset we know of with a wide margin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Largest JSON or URDF file read, in bytes (`--max-file-mb`, default 512 MiB).
    pub max_file_bytes: u64,
    /// Largest mesh file read, in bytes (`--max-file-mb`, default 512 MiB).
    pub max_mesh_bytes: u64,
    /// Most frames in one demonstration (`--max-frames`, default 1,000,000).
    pub max_frames: u64,
    /// Most contact correspondences in one frame (`--max-contacts`, default 2,048).
    pub max_contacts_per_frame: u64,
    /// Most triangles in one mesh (`--max-triangles`, default 5,000,000).
    pub max_mesh_triangles: u64,
    /// Most links or joints in one robot (`--max-links`, default 1,024).
    pub max_links: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_file_bytes: 512 << 20,
            max_mesh_bytes: 512 << 20,
            max_frames: 1_000_000,
            max_contacts_per_frame: 2_048,
            max_mesh_triangles: 5_000_000,
            max_links: 1_024,
        }
    }
}
