//! The object stages of the warp (METHOD.md stages 1-3): spatial warp through waypoints,
//! barrier push-out, temporal retiming.

pub mod barrier;
pub mod plan;
pub mod retime;
pub mod spatial;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

pub use plan::{Anchor, WarpPlan};

/// Object poses over frames: position of the object origin [m] and orientation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectPath {
    pub positions: Vec<Vector3<f64>>,
    pub rotations: Vec<UnitQuaternion<f64>>,
}

impl ObjectPath {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no frames.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The pose of frame `i`.
    pub fn pose(&self, i: usize) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.positions[i]), self.rotations[i])
    }

    /// Builds a path from poses.
    pub fn from_poses<'a>(poses: impl IntoIterator<Item = &'a Isometry3<f64>>) -> Self {
        let (positions, rotations) = poses
            .into_iter()
            .map(|p| (p.translation.vector, p.rotation))
            .unzip();
        ObjectPath {
            positions,
            rotations,
        }
    }

    /// Polyline length of the positions [m].
    pub fn length(&self) -> f64 {
        self.positions.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }
}
