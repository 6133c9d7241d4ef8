//! Contact correspondences extracted geometrically, with optional motion-capture noise.
//!
//! A hand surface point `s` (link frame, on the link's collision shapes, spacing
//! [`ContactParams::spacing_mm`]) is in contact when its world position is within
//! [`ContactParams::max_distance_mm`] of the object surface (or inside the object by at most
//! that much). It is paired with the closest object surface point, in the object frame. This
//! is how correspondences are cleaned from motion capture (the paper's reference
//! [Lakshmipathy et al. 2025] thresholds hand-object distances the same way), so a
//! correspondence's own distance is the hand-object gap there, 0 to `max_distance_mm`.
//!
//! Noise mimics motion capture, whose error is mostly a tracking error of the object (or hand)
//! pose, shared by all correspondences of a frame and drifting slowly, plus a little jitter
//! per point. Frame `i`'s object points get the shared offset
//! `o(i) = A·(±1 + ½ Σ_{k=1..3} a_k sin(2π f_k i/fps + φ_k))·d` along the grasp's slide
//! direction `d` (object frame: a direction the grasp can slide along without pressing into
//! the object, so that a hand fitted to the noisy points does not penetrate; `A` =
//! [`ContactParams::offset_mm`], seeded sign, `a_k ∈ [−1, 1]`, `f_k ∈ [0.1, 0.5]` Hz and
//! phases `φ_k`) plus an
//! independent isotropic Gaussian of σ = [`ContactParams::noise_mm`] per axis on each point
//! (Box-Muller on a ChaCha8 stream seeded with [`ContactParams::seed`]). The recorded hand
//! itself is exact (no penetration); a contact IK can fit the shared offset, which is why the
//! paper's warped `D_C` can fall below the original's.

use nalgebra::{Isometry3, Point3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::proximity::ObjectGeometry;
use crate::geometry::shape::SurfaceSampling;
use crate::model::Contact;
use crate::robot::{LinkId, Robot};

/// How correspondences are extracted.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactParams {
    /// Largest hand-object distance of a correspondence [mm]. Default 5.
    pub max_distance_mm: f64,
    /// Spacing of the hand surface points [mm]. Default 6.
    pub spacing_mm: f64,
    /// Standard deviation of the per-point noise, per axis [mm]. Default 0.
    pub noise_mm: f64,
    /// Magnitude `A` of the shared, slowly drifting offset of a frame's object points [mm].
    /// Default 0.
    pub offset_mm: f64,
    /// What carries the shared offset. Default: the correspondences.
    pub tracking_error: TrackingError,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams {
            max_distance_mm: 5.0,
            spacing_mm: 6.0,
            noise_mm: 0.0,
            offset_mm: 0.0,
            tracking_error: TrackingError::Correspondences,
            seed: 1,
        }
    }
}

/// What carries a synthesized recording's shared tracking offset (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TrackingError {
    /// The correspondences' object points; the recorded hand is the grasp that holds.
    #[default]
    Correspondences,
    /// The recorded hand's pose in the object's frame; the correspondences are on the grasp.
    Hand,
}

/// Surface points of every link's collision shapes (link frame), without the points buried
/// inside another shape of the same link.
pub fn hand_samples(robot: &Robot, spacing_m: f64) -> Vec<(LinkId, Point3<f64>)> {
    hand_surface(robot, spacing_m)
        .into_iter()
        .map(|(l, p, _)| (l, p))
        .collect()
}

/// [`hand_samples`] with each sample's outward normal (link frame).
pub fn hand_surface(robot: &Robot, spacing_m: f64) -> Vec<(LinkId, Point3<f64>, Vector3<f64>)> {
    let sampling = SurfaceSampling {
        spacing: spacing_m,
        max_per_shape: 2000,
    };
    let mut out = Vec::new();
    for (i, link) in robot.links().iter().enumerate() {
        let (mut pts, mut normals) = (Vec::new(), Vec::new());
        for shape in &link.collision {
            shape.sample_surface(&sampling, &mut pts, &mut normals);
        }
        for (p, n) in pts.into_iter().zip(normals) {
            let buried = link
                .collision
                .iter()
                .any(|s| s.depth_of(&p) > crate::geometry::shape::BURIED_DEPTH);
            if !buried {
                out.push((LinkId(i as u32), p, n));
            }
        }
    }
    out
}

/// The correspondences of one frame: hand samples within `max_distance_m` of the object.
pub fn extract(
    robot: &Robot,
    samples: &[(LinkId, Point3<f64>)],
    link_poses: &[Isometry3<f64>],
    object: &ObjectGeometry,
    object_pose: &Isometry3<f64>,
    max_distance_m: f64,
) -> Vec<Contact> {
    let inv = object_pose.inverse();
    let reach = object.mesh.bounding_radius() + max_distance_m;
    let mut out = Vec::new();
    for (link, p) in samples {
        let local = inv * (link_poses[link.index()] * p);
        if local.coords.norm() > reach {
            continue;
        }
        let s = object.surface_point(&local);
        if s.signed_distance.abs() <= max_distance_m {
            out.push(Contact {
                link: robot.link(*link).name.clone(),
                hand_point: *p,
                object_point: s.point,
            });
        }
    }
    out
}

/// A seeded source of correspondence noise (see the module docs).
#[derive(Debug)]
pub struct Noise {
    rng: ChaCha8Rng,
    sigma_m: f64,
    offset_m: f64,
    /// Sign and `(a_k, f_k [Hz], φ_k)` of the shared offset.
    drift: (f64, [(f64, f64, f64); 3]),
    /// Unit slide direction, object frame.
    axis: Vector3<f64>,
}

impl Noise {
    /// Noise of per-point standard deviation `sigma_m` per axis and shared offset magnitude
    /// `offset_m` along `axis` (object frame), seeded.
    pub fn new(seed: u64, sigma_m: f64, offset_m: f64, axis: Vector3<f64>) -> Noise {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sign = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
        let mut terms = [(0.0, 0.0, 0.0); 3];
        for t in &mut terms {
            let a = rng.random::<f64>() * 2.0 - 1.0;
            let f = 0.1 + 0.4 * rng.random::<f64>();
            let phase = std::f64::consts::TAU * rng.random::<f64>();
            *t = (a, f, phase);
        }
        Noise {
            rng,
            sigma_m,
            offset_m,
            drift: (sign, terms),
            axis: axis.try_normalize(1e-12).unwrap_or_else(Vector3::z),
        }
    }

    /// A standard normal sample (Box-Muller).
    fn standard(&mut self) -> f64 {
        let u1: f64 = self.rng.random::<f64>();
        let u2: f64 = self.rng.random::<f64>();
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// An isotropic Gaussian offset of the per-point σ.
    pub fn offset(&mut self) -> Vector3<f64> {
        if self.sigma_m == 0.0 {
            return Vector3::zeros();
        }
        Vector3::new(self.standard(), self.standard(), self.standard()) * self.sigma_m
    }

    /// The shared offset of frame `i` at `fps`, object frame [m].
    pub fn shared(&self, i: usize, fps: f64) -> Vector3<f64> {
        if self.offset_m == 0.0 {
            return Vector3::zeros();
        }
        let t = i as f64 / fps;
        let (sign, terms) = &self.drift;
        let wave: f64 = terms
            .iter()
            .map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
            .sum();
        self.axis * ((sign + 0.5 * wave) * self.offset_m)
    }

    /// Adds the shared offset of frame `i` (when the correspondences carry it) and per-point
    /// noise to every object point.
    pub fn perturb(&mut self, contacts: &mut [Contact], i: usize, fps: f64, on: TrackingError) {
        let shared = match on {
            TrackingError::Correspondences => self.shared(i, fps),
            TrackingError::Hand => Vector3::zeros(),
        };
        for c in contacts {
            c.object_point += shared + self.offset();
        }
    }

    /// Moves the recorded wrist of frame `i` by the shared offset's opposite, in the frame of
    /// `object`: the hand carries the offset instead of the correspondences (module docs).
    pub fn displace_wrist(
        &self,
        object: &Isometry3<f64>,
        wrist: &mut Isometry3<f64>,
        i: usize,
        fps: f64,
    ) {
        wrist.translation.vector -= object.rotation * self.shared(i, fps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_seeded_and_has_the_asked_spread() {
        let mut a = Noise::new(7, 0.004, 0.0, Vector3::z());
        let mut b = Noise::new(7, 0.004, 0.0, Vector3::z());
        let xs: Vec<_> = (0..4000).map(|_| a.offset()).collect();
        let ys: Vec<_> = (0..4000).map(|_| b.offset()).collect();
        assert_eq!(xs, ys);
        let var = xs.iter().map(|v| v.norm_squared()).sum::<f64>() / (3.0 * xs.len() as f64);
        assert!((var.sqrt() - 0.004).abs() < 2e-4, "sigma {}", var.sqrt());
        let mut c = Noise::new(8, 0.004, 0.0, Vector3::z());
        assert_ne!(xs[0], c.offset());
    }
}
