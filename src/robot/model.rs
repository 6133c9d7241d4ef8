//! The robot data model: links and joints in arenas with typed ids.
//!
//! A [`Robot`] is a tree of links connected by joints, loaded from URDF (see
//! [`Robot::from_urdf_file`]). dexwarp adds a floating 6-DoF wrist in front of the URDF root,
//! so a configuration is `(wrist, q)`:
//! - `wrist: Isometry3<f64>`: the world pose of the root link,
//! - `q: &[f64]`: one value per *actuated* joint (revolute, continuous or prismatic and not a
//!   mimic), in [`Robot::actuated`] order, radians or metres.
//!
//! A mimic joint `j` follows its (ultimate) driver: `θ_j = m · q[driver] + c`. Chains of mimics
//! are resolved at load time by composing the affine maps, so no mimic ever points at another.
//!
//! Invariants established by the loader and relied upon by the kinematics:
//! - `joints` is in topological order: a joint's parent link is the root or the child of an
//!   earlier joint, so one forward pass computes every link pose;
//! - every link but the root has exactly one parent joint;
//! - `chains[link]` lists the movable joints from the root to `link`, root first.

use std::path::PathBuf;

use nalgebra::{Isometry3, Point3, Unit, Vector3};

use crate::geometry::shape::CollisionShape;

/// Index of a link in [`Robot::links`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LinkId(pub u32);

/// Index of a joint in [`Robot::joints`] (topological order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub u32);

impl LinkId {
    /// The id as an index into per-link arrays (`link_poses[id.index()]`).
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl JointId {
    /// The id as an index into [`Robot::joints`].
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A rigid body of the hand.
#[derive(Clone, Debug)]
pub struct Link {
    /// URDF link name.
    pub name: String,
    /// The joint whose child this link is; `None` for the root.
    pub parent_joint: Option<JointId>,
    /// Collision geometry in the link frame, in URDF order.
    pub collision: Vec<CollisionShape>,
    /// Points on the collision surface, link frame, metres (see [`super::SurfaceSampling`]).
    pub surface_points: Vec<Point3<f64>>,
    /// Outward unit normals at `surface_points`, link frame (same length).
    pub surface_normals: Vec<Vector3<f64>>,
    /// Penetration probes of the collision geometry (see [`super::probes`]).
    pub probes: super::probes::Probes,
    /// URDF `<inertial><mass>` [kg]; 0 when the link has none. Only the actuated hand of the
    /// physics stage uses it.
    pub mass: f64,
}

/// How a joint moves its child relative to its parent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// No motion.
    Fixed,
    /// Rotation about `axis` by `θ` \[rad\], within limits.
    Revolute,
    /// Rotation about `axis` by `θ` \[rad\], unlimited.
    Continuous,
    /// Translation along `axis` by `d` \[m\], within limits.
    Prismatic,
}

impl JointKind {
    /// `true` for every kind but [`JointKind::Fixed`].
    pub fn is_movable(self) -> bool {
        self != JointKind::Fixed
    }

    /// The URDF `type` attribute.
    pub fn as_str(self) -> &'static str {
        match self {
            JointKind::Fixed => "fixed",
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
        }
    }
}

/// A mimic relation resolved to an actuated driver: `θ = multiplier · q[driver] + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mimic {
    /// Index of the driving joint in the actuated vector `q`.
    pub driver: usize,
    /// `m` in `θ = m · q[driver] + c`.
    pub multiplier: f64,
    /// `c` in `θ = m · q[driver] + c`, rad or m.
    pub offset: f64,
}

/// A joint of the tree.
///
/// The child link's pose is `T_child = T_parent · origin · M(θ)` where `M(θ)` is the rotation
/// `exp(θ [axis]×)` for revolute/continuous joints, the translation `θ · axis` for prismatic
/// ones and the identity for fixed ones. `axis` is a unit vector in the joint frame (= the
/// child frame at `θ = 0`).
#[derive(Clone, Debug)]
pub struct Joint {
    /// URDF joint name.
    pub name: String,
    /// Motion type.
    pub kind: JointKind,
    /// Parent link.
    pub parent: LinkId,
    /// Child link.
    pub child: LinkId,
    /// Pose of the joint frame in the parent link frame (URDF `<origin xyz rpy>`).
    pub origin: Isometry3<f64>,
    /// Unit motion axis in the joint frame (URDF `<axis>`; `x` for fixed joints).
    pub axis: Unit<Vector3<f64>>,
    /// `(lower, upper)` for revolute \[rad\] and prismatic \[m\] joints; `None` for fixed and
    /// continuous joints. Infinite bounds mean "no limit" (URDF 1.2).
    pub limits: Option<(f64, f64)>,
    /// Mimic relation, resolved to an actuated driver.
    pub mimic: Option<Mimic>,
    /// Index in the actuated vector `q` for movable, non-mimic joints.
    pub dof: Option<usize>,
    /// The joint named in the URDF `<mimic joint=..>` element (before chains were resolved).
    pub mimic_source: Option<String>,
    /// URDF `<limit effort>`: the largest torque [N·m] or force [N] the joint's actuator
    /// gives; 0 when absent. Only the actuated hand of the physics stage uses it.
    pub effort: f64,
}

impl Joint {
    /// The joint value for the actuated vector `q`: `q[dof]`, `m · q[driver] + c` for a mimic,
    /// `0` for a fixed joint.
    #[inline]
    pub fn value(&self, q: &[f64]) -> f64 {
        if let Some(i) = self.dof {
            q[i]
        } else if let Some(m) = &self.mimic {
            m.multiplier * q[m.driver] + m.offset
        } else {
            0.0
        }
    }
}

/// A hand: links and joints from URDF, the actuated joint vector and precomputed chains.
///
/// Build it with [`Robot::from_urdf_file`] or [`Robot::from_urdf_str`]; the fields that carry
/// invariants are private and read through accessors.
#[derive(Clone, Debug)]
pub struct Robot {
    /// URDF robot name.
    pub name: String,
    /// The URDF file it came from (for messages; may be a placeholder for strings).
    pub source: PathBuf,
    pub(crate) links: Vec<Link>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) root: LinkId,
    pub(crate) actuated: Vec<JointId>,
    /// Per link: the movable joints from the root to the link, root first.
    pub(crate) chains: Vec<Box<[JointId]>>,
    /// Lower limits of the actuated joints (`-inf` for continuous joints).
    pub(crate) lower: Vec<f64>,
    /// Upper limits of the actuated joints (`+inf` for continuous joints).
    pub(crate) upper: Vec<f64>,
}

impl Robot {
    /// All links, indexed by [`LinkId`].
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// All joints in topological order, indexed by [`JointId`].
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Every collision shape of the hand in link order: `(link index, shape)`.
    pub fn collision_shapes(&self) -> Vec<(usize, &CollisionShape)> {
        self.links
            .iter()
            .enumerate()
            .flat_map(|(i, l)| l.collision.iter().map(move |cs| (i, cs)))
            .collect()
    }

    /// One link.
    pub fn link(&self, id: LinkId) -> &Link {
        &self.links[id.index()]
    }

    /// One joint.
    pub fn joint(&self, id: JointId) -> &Joint {
        &self.joints[id.index()]
    }

    /// The root link, whose world pose is the wrist.
    pub fn root(&self) -> LinkId {
        self.root
    }

    /// The actuated joints, in `q` order.
    pub fn actuated(&self) -> &[JointId] {
        &self.actuated
    }

    /// Number of actuated joints (the length of `q`; the wrist's 6 DoF are not counted).
    pub fn dof(&self) -> usize {
        self.actuated.len()
    }

    /// Number of links (the length of a `link_poses` buffer).
    pub fn link_count(&self) -> usize {
        self.links.len()
    }

    /// The movable joints between the root and `link`, root first.
    pub fn chain(&self, link: LinkId) -> &[JointId] {
        &self.chains[link.index()]
    }

    /// The link named `name`.
    pub fn link_id(&self, name: &str) -> Option<LinkId> {
        self.links
            .iter()
            .position(|l| l.name == name)
            .map(|i| LinkId(i as u32))
    }

    /// The joint named `name` (any kind).
    pub fn joint_id(&self, name: &str) -> Option<JointId> {
        self.joints
            .iter()
            .position(|j| j.name == name)
            .map(|i| JointId(i as u32))
    }

    /// The index in `q` of the actuated joint named `name`; `None` for unknown, fixed or mimic
    /// joints.
    pub fn actuated_index(&self, name: &str) -> Option<usize> {
        self.joint_id(name).and_then(|j| self.joint(j).dof)
    }

    /// Names of the actuated joints, in `q` order.
    pub fn actuated_names(&self) -> Vec<String> {
        self.actuated
            .iter()
            .map(|&j| self.joint(j).name.clone())
            .collect()
    }

    /// Lower limits of `q` \[rad or m\]; `-inf` for continuous joints.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Upper limits of `q` \[rad or m\]; `+inf` for continuous joints.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    /// Clamps `q` into `[lower, upper]` in place and returns how many values moved.
    /// Mimic joints follow their drivers and are not clamped separately. NaN stays NaN
    /// (the caller checks finiteness at its stage boundary).
    pub fn clamp(&self, q: &mut [f64]) -> usize {
        assert_eq!(q.len(), self.dof(), "q has the wrong length");
        let mut moved = 0;
        for ((v, &lo), &hi) in q.iter_mut().zip(&self.lower).zip(&self.upper) {
            let c = v.max(lo).min(hi);
            if c != *v && !v.is_nan() {
                *v = c;
                moved += 1;
            }
        }
        moved
    }

    /// A configuration inside the limits: each actuated joint at the middle of its range,
    /// or `0` when the range is unbounded on a side.
    pub fn neutral_q(&self) -> Vec<f64> {
        self.lower
            .iter()
            .zip(&self.upper)
            .map(|(&lo, &hi)| {
                if lo.is_finite() && hi.is_finite() {
                    0.5 * (lo + hi)
                } else {
                    0.0f64.max(lo).min(hi)
                }
            })
            .collect()
    }

    /// Total number of surface points over all links.
    pub fn surface_point_count(&self) -> usize {
        self.links.iter().map(|l| l.surface_points.len()).sum()
    }
}
