//! URDF hands: the kinematic tree, forward kinematics, point Jacobians, collision geometry.
//!
//! - [`model`]: [`Robot`], [`Link`], [`Joint`] in arenas with typed ids; configuration
//!   `(wrist, q)` with mimic joints folded into their drivers.
//! - [`urdf`]: loading and checking a URDF file ([`Robot::from_urdf_file`]); its geometry
//!   half (`<origin>`, `<collision>`, mesh paths) lives in the private `urdf_geometry`.
//! - [`kinematics`]: allocation-free [`Robot::forward_kinematics`] and
//!   [`Robot::point_jacobian`] with the wrist parameterisation `R' = exp([δω]×) R`.
//! - [`probes`]: penetration probes of the collision geometry against an object's distance.
//! - [`describe`]: the text of `dexwarp robot URDF`.
//! - [`bind`]: a demonstration's robot loaded and its joints ordered as the robot's.
//!
//! Link collision geometry is [`crate::geometry::shape::CollisionShape`], the type scene
//! items use too.

pub mod bind;
pub mod describe;
pub mod kinematics;
pub mod model;
pub mod probes;
pub mod urdf;
mod urdf_geometry;

pub use kinematics::{WRIST_DOF, apply_wrist_step};
pub use model::{Joint, JointId, JointKind, Link, LinkId, Mimic, Robot};
pub use probes::{Probe, Probes};

/// `robots/human_hand.urdf` of this repository, loaded (the unit tests' hand).
#[cfg(test)]
pub(crate) fn test_human_hand() -> Robot {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/human_hand.urdf");
    Robot::from_urdf_file(&path, &crate::Limits::default()).expect("human_hand loads")
}
