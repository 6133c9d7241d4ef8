//! Forward kinematics and point Jacobians, allocation-free.
//!
//! **Forward kinematics.** With the wrist pose `W` (world pose of the root link) and the
//! actuated vector `q`, one pass over the joints in topological order computes
//!
//! ```text
//! T_root = W,        T_child(j) = T_parent(j) · O_j · M_j(θ_j)
//! ```
//!
//! where `O_j` is the joint origin, `θ_j` the joint value (`q[dof]`, or `m · q[driver] + c`
//! for a mimic) and `M_j` the rotation `exp(θ [a_j]×)` (revolute, continuous), the
//! translation `θ a_j` (prismatic) or the identity (fixed).
//!
//! **Point Jacobian.** For a point `s` fixed in link `L`, `p = T_L · s` in the world. The
//! generalised coordinates are `(t, ω, q)` with the wrist `W = (t, R)` perturbed as
//!
//! ```text
//! t' = t + δt,       R' = exp([δω]×) · R        (world-frame left perturbation about the wrist origin)
//! ```
//!
//! so the Jacobian `J = ∂p/∂(δt, δω, q)` (3 × (6 + dof)) has the columns
//! - `∂p/∂δt_k = e_k` (k = x, y, z),
//! - `∂p/∂δω_k = e_k × (p - t)`,
//! - for each movable joint `j` in the chain of `L`, with world axis `â_j = R_child(j) · a_j`
//!   and joint origin `o_j = translation of T_child(j)` (for a revolute joint the child frame
//!   origin lies on the axis):
//!   revolute/continuous `∂p/∂θ_j = â_j × (p - o_j)`, prismatic `∂p/∂θ_j = â_j`;
//!   the column of `θ_j` is added to `q[dof_j]`, or `m_j ×` it to `q[driver_j]` for a mimic
//!   (chain rule of `θ_j = m_j q[driver] + c_j`);
//! - columns of actuated joints outside the chain are zero.
//!
//! [`apply_wrist_step`] applies `(δt, δω)` with exactly this parameterisation, so an IK solver
//! can take `J`, solve for a step and apply it consistently.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::model::{JointKind, LinkId, Robot};

/// Number of wrist columns at the front of a point Jacobian (3 translation + 3 rotation).
pub const WRIST_DOF: usize = 6;

impl Robot {
    /// Fills `link_poses[l]` with the world pose of every link `l` for the wrist pose `wrist`
    /// and the actuated joint values `q` (see the module docs for the recursion).
    ///
    /// Does not allocate. Panics if `q.len() != self.dof()` or
    /// `link_poses.len() != self.link_count()` (caller bugs, not input errors).
    pub fn forward_kinematics(
        &self,
        wrist: &Isometry3<f64>,
        q: &[f64],
        link_poses: &mut [Isometry3<f64>],
    ) {
        assert_eq!(q.len(), self.dof(), "q has the wrong length");
        assert_eq!(
            link_poses.len(),
            self.links.len(),
            "link_poses has the wrong length"
        );
        link_poses[self.root.index()] = *wrist;
        for joint in &self.joints {
            let parent = link_poses[joint.parent.index()] * joint.origin;
            let pose = match joint.kind {
                JointKind::Fixed => parent,
                JointKind::Revolute | JointKind::Continuous => {
                    let theta = joint.value(q);
                    parent * UnitQuaternion::from_axis_angle(&joint.axis, theta)
                }
                JointKind::Prismatic => {
                    let d = joint.value(q);
                    parent * Translation3::from(joint.axis.into_inner() * d)
                }
            };
            link_poses[joint.child.index()] = pose;
        }
    }

    /// A `link_poses` buffer of the right length, filled with identities.
    pub fn new_link_poses(&self) -> Vec<Isometry3<f64>> {
        vec![Isometry3::identity(); self.links.len()]
    }

    /// Fills `out` (length `6 + dof`) with the Jacobian columns `∂p/∂(δt, δω, q)` of the
    /// world point `p = link_poses[link] · point_in_link` (see the module docs for the
    /// parameterisation). `link_poses` must come from [`Robot::forward_kinematics`].
    ///
    /// Does not allocate. Panics if `out.len() != 6 + self.dof()`.
    pub fn point_jacobian(
        &self,
        link_poses: &[Isometry3<f64>],
        link: LinkId,
        point_in_link: &Point3<f64>,
        out: &mut [Vector3<f64>],
    ) {
        let p = link_poses[link.index()] * point_in_link;
        self.world_point_jacobian(link_poses, link, &p, out);
    }

    /// As [`Robot::point_jacobian`], for a world point `p` rigidly attached to `link`.
    pub fn world_point_jacobian(
        &self,
        link_poses: &[Isometry3<f64>],
        link: LinkId,
        p: &Point3<f64>,
        out: &mut [Vector3<f64>],
    ) {
        assert_eq!(
            out.len(),
            WRIST_DOF + self.dof(),
            "Jacobian buffer has the wrong length"
        );
        out[0] = Vector3::x();
        out[1] = Vector3::y();
        out[2] = Vector3::z();
        let r = p - link_poses[self.root.index()].translation.vector;
        // e_k × r for k = x, y, z.
        out[3] = Vector3::new(0.0, -r.z, r.y);
        out[4] = Vector3::new(r.z, 0.0, -r.x);
        out[5] = Vector3::new(-r.y, r.x, 0.0);
        let cols = &mut out[WRIST_DOF..];
        cols.fill(Vector3::zeros());
        for &j in self.chains[link.index()].iter() {
            let joint = &self.joints[j.index()];
            let child = &link_poses[joint.child.index()];
            let axis = child.rotation * joint.axis.into_inner();
            let column = match joint.kind {
                JointKind::Prismatic => axis,
                JointKind::Revolute | JointKind::Continuous => {
                    axis.cross(&(p - child.translation.vector).coords)
                }
                JointKind::Fixed => continue,
            };
            if let Some(i) = joint.dof {
                cols[i] += column;
            } else if let Some(m) = &joint.mimic {
                cols[m.driver] += column * m.multiplier;
            }
        }
    }
}

/// Applies a wrist step `(δt, δω)` in the parameterisation of the point Jacobian:
/// `t ← t + δt`, `R ← exp([δω]×) · R` (rotation about the wrist origin, world axes).
pub fn apply_wrist_step(wrist: &mut Isometry3<f64>, dtrans: &Vector3<f64>, domega: &Vector3<f64>) {
    wrist.translation.vector += dtrans;
    wrist.rotation = UnitQuaternion::from_scaled_axis(*domega) * wrist.rotation;
    wrist.rotation.renormalize_fast();
}
