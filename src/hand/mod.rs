//! Hand recovery (docs/METHOD.md stage 4): the SE(3) baseline, and (per-frame contact IK and
//! smoothing) the method itself; the barrier push-out of the hand outside contact.

pub mod baseline;
pub mod guard;
pub mod ik;
pub mod pushout;
pub mod smooth;

use nalgebra::Isometry3;

/// The hand over frames: wrist pose and actuated joint values (robot order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HandPath {
    pub wrists: Vec<Isometry3<f64>>,
    /// Row-major, `dof` values per frame.
    pub joints: Vec<f64>,
    pub dof: usize,
}

impl HandPath {
    /// An empty path for a hand with `dof` actuated joints.
    pub fn with_capacity(frames: usize, dof: usize) -> Self {
        HandPath {
            wrists: Vec::with_capacity(frames),
            joints: Vec::with_capacity(frames * dof),
            dof,
        }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.wrists.len()
    }

    /// True when there are no frames.
    pub fn is_empty(&self) -> bool {
        self.wrists.is_empty()
    }

    /// Joint values of frame `i`.
    pub fn q(&self, i: usize) -> &[f64] {
        &self.joints[i * self.dof..(i + 1) * self.dof]
    }

    /// Appends a frame.
    pub fn push(&mut self, wrist: Isometry3<f64>, q: &[f64]) {
        debug_assert_eq!(q.len(), self.dof);
        self.wrists.push(wrist);
        self.joints.extend_from_slice(q);
    }

    /// Polyline length of the wrist positions [m].
    pub fn wrist_path_length(&self) -> f64 {
        self.wrists
            .windows(2)
            .map(|w| (w[1].translation.vector - w[0].translation.vector).norm())
            .sum()
    }
}
