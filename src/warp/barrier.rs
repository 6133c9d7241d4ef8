//! Stage 2: barrier push-out of the object (docs/METHOD.md stage 2, paper "Barrier-Constrained
//! Object Warping").
//!
//! The object is bounded by the ball `B_r` about its origin, `r` = largest distance from the
//! origin to a mesh vertex. For each barrier `M` with convex hull `H = conv(M)`, centroid `c`
//! and outward face planes `n_f·x ≤ d_f`:
//!
//! * **paper mode** (default): `H` is scaled about `c` by `s = 1 + r/ρ`, where
//!   `ρ = min_f (d_f − n_f·c)` is the distance from the centroid to the nearest face plane.
//!   Every face plane moves out by `(s − 1)(d_f − n_f·c) ≥ r`, so the scaled hull contains
//!   `H ⊕ B_r`. A position inside it is moved outward along the ray from `c`, in steps of
//!   `step_m`, until it is outside (the number of steps is computed from the exit point of the
//!   ray, so the result is the one the stepping loop would give, without the loop).
//! * **exact mode**: a position is in conflict when its distance to `H` is below `r` (parry's
//!   exact point–convex distance); it is stepped along the same ray until it clears `r`. Less
//!   conservative than the paper's scaling, which over-inflates elongated barriers.
//!
//! Only the interior frames of the contact segment move. The anchors (start, waypoints, end)
//! are constraints: an anchor inside an inflated barrier is a conflict in the spec and is
//! refused with the waypoint named. Pushing out of one barrier can push into another; the sweep
//! over all barriers repeats until no position is inside any, up to `max_sweeps`. Hitting the
//! cap is the paper's narrow-gap failure: reported with its frames and barriers, never hidden.
//! Supports are not barriers and are never considered here.

use std::path::Path;
use std::time::Instant;

use nalgebra::{Point3, Vector3};
use rapier3d_f64::parry::query::PointQuery;
use rapier3d_f64::parry::shape::ConvexPolyhedron;
use rapier3d_f64::parry::transformation::try_convex_hull;
use serde::{Deserialize, Serialize};

use crate::math::convert::{from_point, to_point};
use crate::model::PushoutMode;
use crate::model::report::NarrowGap;
use crate::warp::plan::WarpPlan;
use crate::{Error, Result};

/// Parameters of the push-out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Paper (scaled hull) or exact clearance. Default paper.
    pub mode: PushoutMode,
    /// Step along the centroid ray [m]. Default 0.002.
    pub step_m: f64,
    /// Most sweeps over all barriers before declaring a narrow gap. Default 64.
    pub max_sweeps: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            mode: PushoutMode::Paper,
            step_m: 0.002,
            max_sweeps: 64,
        }
    }
}

/// What the push-out did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Bounding radius of the object [m].
    pub object_radius_m: f64,
    /// Sweeps over all barriers (1 when nothing had to move).
    pub sweeps: usize,
    /// Distinct frames moved.
    pub frames_moved: usize,
    /// Total push operations.
    pub pushes: usize,
    /// Largest distance a frame was moved [m].
    pub max_push_m: f64,
    /// Set when the sweep cap was hit.
    pub narrow_gap: Option<NarrowGap>,
    /// Wall time [s].
    pub time_s: f64,
}

/// A barrier prepared for the push-out: its convex hull, centroid and inflated planes.
#[derive(Clone, Debug)]
pub struct Barrier {
    pub name: String,
    /// Volume centroid of the hull [m].
    pub centroid: Point3<f64>,
    /// Outward unit normals of the hull faces.
    normals: Vec<Vector3<f64>>,
    /// Plane offsets of the hull faces (`n·x ≤ d` inside).
    offsets: Vec<f64>,
    /// Plane offsets of the scaled hull (paper mode).
    inflated: Vec<f64>,
    /// Scale factor `s = 1 + r/ρ` (paper mode).
    pub scale: f64,
    /// The hull as a parry shape, for exact distances.
    hull: ConvexPolyhedron,
    /// Bounding radius of the object [m].
    radius: f64,
    /// Farthest a conflicting point can be from the centroid [m]: beyond it no ray is inside,
    /// which bounds the stepping loops.
    reach: f64,
}

impl Barrier {
    /// Prepares a barrier from points in the world frame whose hull is the barrier's hull.
    pub fn from_points(name: &str, points: &[Point3<f64>], object_radius: f64) -> Option<Barrier> {
        let pts: Vec<_> = points.iter().map(to_point).collect();
        let (verts, faces) = try_convex_hull(&pts).ok()?;
        let verts: Vec<Point3<f64>> = verts.into_iter().map(from_point).collect();
        if faces.len() < 4 {
            return None;
        }
        // Volume centroid by the tetrahedra (mean, face) — robust to uneven vertex density.
        let mean = verts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / verts.len() as f64;
        let (mut vol, mut acc) = (0.0, Vector3::zeros());
        for f in &faces {
            let [a, b, c] = f.map(|i| verts[i as usize].coords);
            let v = (a - mean).dot(&(b - mean).cross(&(c - mean))) / 6.0;
            vol += v;
            acc += v * (mean + a + b + c) / 4.0;
        }
        if vol.abs() < 1e-15 {
            return None;
        }
        let centroid = Point3::from(acc / vol);
        let mut normals = Vec::with_capacity(faces.len());
        let mut offsets = Vec::with_capacity(faces.len());
        for f in &faces {
            let [a, b, c] = f.map(|i| verts[i as usize].coords);
            let Some(mut n) = (b - a).cross(&(c - a)).try_normalize(1e-18) else {
                continue;
            };
            if n.dot(&(a - centroid.coords)) < 0.0 {
                n = -n;
            }
            normals.push(n);
            offsets.push(n.dot(&a));
        }
        let rho = normals
            .iter()
            .zip(&offsets)
            .map(|(n, d)| d - n.dot(&centroid.coords))
            .fold(f64::INFINITY, f64::min);
        if rho.is_nan() || rho <= 1e-9 {
            return None;
        }
        let scale = 1.0 + object_radius / rho;
        let inflated = normals
            .iter()
            .zip(&offsets)
            .map(|(n, d)| {
                let nc = n.dot(&centroid.coords);
                nc + scale * (d - nc)
            })
            .collect();
        let hull = ConvexPolyhedron::from_convex_hull(&pts)?;
        let far = verts
            .iter()
            .map(|v| (v - centroid).norm())
            .fold(0.0, f64::max);
        let reach = far * scale + object_radius;
        Some(Barrier {
            name: name.to_string(),
            centroid,
            normals,
            offsets,
            inflated,
            scale,
            hull,
            radius: object_radius,
            reach,
        })
    }

    /// Signed distance of `p` to the un-inflated hull [m] (negative inside).
    pub fn hull_distance(&self, p: &Point3<f64>) -> f64 {
        let pose = rapier3d_f64::parry::math::Pose::IDENTITY;
        self.hull.distance_to_point(&pose, to_point(p), false)
    }

    /// The barrier's convex hull as a parry shape (world frame).
    pub fn hull(&self) -> &ConvexPolyhedron {
        &self.hull
    }

    /// True when `p` is in conflict with this barrier under `mode`.
    pub fn contains(&self, p: &Point3<f64>, mode: PushoutMode) -> bool {
        match mode {
            PushoutMode::Paper => self
                .normals
                .iter()
                .zip(&self.inflated)
                .all(|(n, d)| n.dot(&p.coords) < *d),
            PushoutMode::Exact => {
                // Cheap reject: farther than r from every face plane's outside.
                let outside = self
                    .normals
                    .iter()
                    .zip(&self.offsets)
                    .any(|(n, d)| n.dot(&p.coords) - d >= self.radius);
                !outside && self.hull_distance(p) < self.radius
            }
        }
    }

    /// Moves `p` out along the centroid ray in steps of `step`; returns the new point.
    pub fn push(&self, p: &Point3<f64>, mode: PushoutMode, step: f64) -> Point3<f64> {
        let v = p - self.centroid;
        let (dir, dist) = match v.try_normalize(1e-12) {
            Some(d) => (d, v.norm()),
            // A point at the centroid leaves upward: the most plausible free direction in a
            // scene with gravity.
            None => (Vector3::z(), 0.0),
        };
        // Past `reach` from the centroid no point is in conflict: the loops below end there.
        let max_k = ((self.reach - dist).max(0.0) / step).ceil() + 1.0;
        match mode {
            PushoutMode::Paper => {
                // Exit parameter of the ray c + λ·dir from the scaled hull.
                let exit = self
                    .normals
                    .iter()
                    .zip(&self.inflated)
                    .filter_map(|(n, d)| {
                        let nd = n.dot(&dir);
                        (nd > 1e-15).then(|| (d - n.dot(&self.centroid.coords)) / nd)
                    })
                    .fold(f64::INFINITY, f64::min);
                let mut k = ((exit - dist) / step).ceil().clamp(1.0, max_k);
                let mut q = self.centroid + dir * (dist + k * step);
                while self.contains(&q, mode) && k < max_k {
                    k += 1.0;
                    q = self.centroid + dir * (dist + k * step);
                }
                q
            }
            PushoutMode::Exact => {
                let mut q = *p;
                let mut k = 0.0;
                while self.contains(&q, mode) && k < max_k {
                    k += 1.0;
                    q = self.centroid + dir * (dist + k * step);
                }
                q
            }
        }
    }
}

/// Output of the push-out.
#[derive(Clone, Debug)]
pub struct Output {
    /// Object positions after the push-out (all input frames).
    pub positions: Vec<Vector3<f64>>,
    pub stats: Stats,
}

/// Runs stage 2. `positions` are the spatially warped object positions of every input frame;
/// `config_source` names the config file in conflict messages.
pub fn run(
    positions: &[Vector3<f64>],
    plan: &WarpPlan,
    barriers: &[Barrier],
    object_radius: f64,
    params: &Params,
    config_source: &Path,
) -> Result<Output> {
    let clock = Instant::now();
    let mut out = positions.to_vec();
    let mut stats = Stats {
        object_radius_m: object_radius,
        ..Stats::default()
    };
    let last = plan.anchors.len() - 1;
    for (j, a) in plan.anchors.iter().enumerate() {
        let p = Point3::from(a.position);
        if let Some(b) = barriers.iter().find(|b| b.contains(&p, params.mode)) {
            let field = match j {
                0 => "start (or the object's position at the first in-contact frame)".to_string(),
                j if j == last => {
                    "end (or the object's position at the last in-contact frame)".to_string()
                }
                j => format!("waypoints[{}].position", j - 1),
            };
            return Err(Error::invalid(
                config_source,
                field,
                format!(
                    "{:?} lies inside barrier {:?} inflated by the object's bounding radius {:.3} m: the object would touch the barrier there; move it at least {:.3} m clear or drop the barrier",
                    a.position.as_slice(),
                    b.name,
                    object_radius,
                    object_radius
                ),
            ));
        }
    }
    let pinned = |f: usize| plan.anchors.iter().any(|a| a.t == f);
    let movable: Vec<usize> = (plan.segment.start + 1..plan.segment.end)
        .filter(|&f| !pinned(f))
        .collect();
    let mut moved = vec![false; out.len()];
    let mut converged = barriers.is_empty();
    for sweep in 1..=params.max_sweeps.max(1) {
        stats.sweeps = sweep;
        let mut any = false;
        for b in barriers {
            for &f in &movable {
                let p = Point3::from(out[f]);
                if b.contains(&p, params.mode) {
                    let q = b.push(&p, params.mode, params.step_m);
                    out[f] = q.coords;
                    moved[f] = true;
                    stats.pushes += 1;
                    any = true;
                }
            }
        }
        if !any {
            converged = true;
            break;
        }
    }
    for &f in &movable {
        if moved[f] {
            stats.frames_moved += 1;
            stats.max_push_m = stats.max_push_m.max((out[f] - positions[f]).norm());
        }
    }
    if !converged {
        let mut gap = NarrowGap::default();
        for &f in &movable {
            let p = Point3::from(out[f]);
            let inside: Vec<&Barrier> = barriers
                .iter()
                .filter(|b| b.contains(&p, params.mode))
                .collect();
            if !inside.is_empty() {
                gap.frames.push(f);
                for b in inside {
                    if !gap.barriers.contains(&b.name) {
                        gap.barriers.push(b.name.clone());
                    }
                }
            }
        }
        // The last sweep may have freed every frame exactly at the cap.
        if !gap.frames.is_empty() {
            stats.narrow_gap = Some(gap);
        }
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    Ok(Output {
        positions: out,
        stats,
    })
}
