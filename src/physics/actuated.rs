//! The actuated hand ([`HandModel::Actuated`](super::params::HandModel)): the hand as an
//! articulated multibody driven by its actuators instead of placed on the trajectory.
//!
//! - every link is a dynamic body, with its URDF mass (or
//!   [`Actuation::default_link_mass_kg`]) spread over its colliders;
//! - every URDF joint is a Rapier multibody joint (revolute, continuous, prismatic or
//!   fixed) with the URDF's origin, axis and limits, so the chain cannot stretch;
//! - every movable joint has a position motor toward the trajectory's joint value (mimic
//!   joints toward their mimic value), stiffness `effort / saturation_error`, damping
//!   `stiffness × damping_time_s`, its force capped at the URDF `<limit effort>`
//!   (force-based: torques in N·m, forces in N);
//! - the root link is held by a soft six-axis lock (natural frequency
//!   [`Actuation::wrist_frequency_hz`]) to a kinematic anchor that follows the trajectory's
//!   root pose: a stiff arm, not an infinitely stiff one;
//! - hand links do not collide with each other (collision groups); they collide with the
//!   object, the supports and the checked barriers, which stop them.
//!
//! The hand starts at frame 0's configuration. Each step the anchor and the motor targets
//! move to the interpolated trajectory; the links go where motors, contacts and gravity
//! take them.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rapier3d_f64::prelude::{
    ColliderBuilder, GenericJointBuilder, Group, InteractionGroups, InteractionTestMode,
    JointAxesMask, JointAxis, MassProperties, MotorModel, MultibodyJointHandle, PhysicsWorld,
    RigidBodyBuilder, RigidBodyHandle, SpringCoefficients, Vector,
};

use super::params::{Actuation, Params};
use crate::geometry::shape::CollisionShape;
use crate::math::convert::to_pose;
use crate::robot::{Joint, JointKind, Robot};
use crate::{Error, Result};

/// Hand colliders are in this group and interact with every other group.
const HAND_GROUP: Group = Group::GROUP_2;

/// Radius [m] of the sphere whose inertia a link without colliders gets.
const BARE_LINK_RADIUS_M: f64 = 0.01;

#[derive(Debug)]
struct Motor {
    handle: MultibodyJointHandle,
    /// The URDF joint (its value for a joint vector `q`).
    joint: Joint,
    axis: JointAxis,
    stiffness: f64,
    damping: f64,
}

/// The actuated hand in a world: its anchor and its motors.
#[derive(Debug)]
pub(super) struct ActuatedHand {
    /// One body per link, in link order.
    pub(super) bodies: Vec<RigidBodyHandle>,
    anchor: RigidBodyHandle,
    root: usize,
    motors: Vec<Motor>,
}

/// The rotation taking the x axis to `axis` (Rapier's joints move along their frame's x).
fn x_to(axis: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::x(), axis).unwrap_or_else(|| {
        // `axis` is -x: half a turn about z.
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
    })
}

/// Checks that every movable joint has an effort limit; the error names the URDF joint.
pub(super) fn check_robot(robot: &Robot) -> Result<()> {
    for j in robot.joints() {
        if j.kind.is_movable() && j.effort <= 0.0 {
            return Err(Error::invalid(
                &robot.source,
                format!("joint '{}' <limit effort>", j.name),
                "is missing or 0; the actuated hand drives each movable joint with a motor \
                 capped at its effort limit [N·m, or N for prismatic joints]: give one, or \
                 replay with the kinematic hand",
            ));
        }
    }
    Ok(())
}

impl ActuatedHand {
    /// Builds the hand in `world` at `link_poses` (frame 0, from `q0`); `skin` configures
    /// each hand collider (friction, contact skin, tag) as the kinematic hand's.
    pub(super) fn build(
        world: &mut PhysicsWorld,
        robot: &Robot,
        link_poses: &[Isometry3<f64>],
        q0: &[f64],
        params: &Params,
        skin: impl Fn(&CollisionShape) -> ColliderBuilder,
    ) -> ActuatedHand {
        let a: &Actuation = &params.actuation;
        let groups = InteractionGroups::new(
            HAND_GROUP,
            Group::ALL.difference(HAND_GROUP),
            InteractionTestMode::And,
        );
        let bodies: Vec<RigidBodyHandle> = robot
            .links()
            .iter()
            .enumerate()
            .map(|(i, link)| {
                let mass = if link.mass > 0.0 {
                    link.mass
                } else {
                    a.default_link_mass_kg
                };
                let mut builder = RigidBodyBuilder::dynamic()
                    .pose(to_pose(&link_poses[i]))
                    .can_sleep(false);
                if link.collision.is_empty() {
                    let inertia = 0.4 * mass * BARE_LINK_RADIUS_M * BARE_LINK_RADIUS_M;
                    builder = builder.additional_mass_properties(MassProperties::new(
                        Vector::ZERO,
                        mass,
                        Vector::splat(inertia),
                    ));
                }
                let body = world.insert_body(builder);
                let share = mass / link.collision.len().max(1) as f64;
                for cs in &link.collision {
                    let collider = skin(cs).mass(share).collision_groups(groups);
                    world.insert_collider(collider, Some(body));
                }
                body
            })
            .collect();

        let root = robot.root().index();
        let anchor = world.insert_body(
            RigidBodyBuilder::kinematic_position_based().pose(to_pose(&link_poses[root])),
        );
        let wrist = GenericJointBuilder::new(JointAxesMask::LOCKED_FIXED_AXES)
            .softness(SpringCoefficients::new(
                a.wrist_frequency_hz,
                a.wrist_damping_ratio,
            ))
            .contacts_enabled(false);
        world.insert_impulse_joint(anchor, bodies[root], wrist);

        let mut motors = Vec::new();
        for j in robot.joints() {
            let (locked, axis) = match j.kind {
                JointKind::Fixed => (JointAxesMask::LOCKED_FIXED_AXES, None),
                JointKind::Revolute | JointKind::Continuous => {
                    (JointAxesMask::LOCKED_REVOLUTE_AXES, Some(JointAxis::AngX))
                }
                JointKind::Prismatic => {
                    (JointAxesMask::LOCKED_PRISMATIC_AXES, Some(JointAxis::LinX))
                }
            };
            let align = x_to(&j.axis);
            let frame1 = j.origin * Isometry3::from_parts(Default::default(), align);
            let frame2 = Isometry3::from_parts(Default::default(), align);
            let mut builder = GenericJointBuilder::new(locked)
                .local_frame1(to_pose(&frame1))
                .local_frame2(to_pose(&frame2))
                .contacts_enabled(false);
            let mut gains = None;
            if let Some(axis) = axis {
                let stiffness = j.effort / a.saturation_error;
                let damping = stiffness * a.damping_time_s;
                builder = builder
                    .motor_model(axis, MotorModel::ForceBased)
                    .motor_position(axis, j.value(q0), stiffness, damping)
                    .motor_max_force(axis, j.effort);
                if let Some((lo, hi)) = j.limits.filter(|(lo, hi)| lo.is_finite() && hi.is_finite())
                {
                    builder = builder.limits(axis, [lo, hi]);
                }
                gains = Some((axis, stiffness, damping));
            }
            let parent = bodies[j.parent.index()];
            let child = bodies[j.child.index()];
            let Some(handle) = world.insert_multibody_joint(parent, child, builder.build()) else {
                continue;
            };
            if let Some((axis, stiffness, damping)) = gains {
                motors.push(Motor {
                    handle,
                    joint: j.clone(),
                    axis,
                    stiffness,
                    damping,
                });
            }
        }

        let hand = ActuatedHand {
            bodies,
            anchor,
            root,
            motors,
        };
        hand.set_configuration(world, q0);
        hand
    }

    /// Puts the multibody at joint values `q` (the bodies' poses follow).
    fn set_configuration(&self, world: &mut PhysicsWorld, q: &[f64]) {
        let targets: Vec<(usize, f64)> = self
            .motors
            .iter()
            .filter_map(|m| {
                let (_, link) = world.multibody_joints.get(m.handle)?;
                Some((link, m.joint.value(q)))
            })
            .collect();
        let Some(first) = self.motors.first() else {
            return;
        };
        // The hand is one tree, so every motor is on the same multibody.
        let Some((mb, _)) = world.multibody_joints.get_mut(first.handle) else {
            return;
        };
        let mut disp = vec![0.0; mb.ndofs()];
        for (link, value) in targets {
            if let Some(l) = mb.link(link)
                && l.joint().ndofs() == 1
            {
                disp[l.assembly_id()] = value;
            }
        }
        mb.apply_displacements(&disp);
        mb.forward_kinematics(&world.bodies, true);
        mb.update_rigid_bodies(&mut world.bodies, true);
    }

    /// Moves the anchor and the motor targets to the trajectory at link poses `link_poses`
    /// and joint values `q`.
    pub(super) fn drive(&self, world: &mut PhysicsWorld, link_poses: &[Isometry3<f64>], q: &[f64]) {
        if let Some(b) = world.bodies.get_mut(self.anchor) {
            b.set_next_kinematic_position(to_pose(&link_poses[self.root]));
        }
        for m in &self.motors {
            let target = m.joint.value(q);
            if let Some((mb, link)) = world.multibody_joints.get_mut(m.handle)
                && let Some(link) = mb.link_mut(link)
            {
                link.joint
                    .data
                    .set_motor_position(m.axis, target, m.stiffness, m.damping);
            }
        }
    }
}
