//! The one world struct of the physics stage: a Rapier [`PhysicsWorld`] with the hand, the
//! object and the fixed scene, and the few operations the replay needs.
//!
//! Bodies:
//! - every hand link with collision geometry is a kinematic position-based body; its
//!   colliders carry the finger skin ([`super::Params::finger_skin_m`]) and the hand friction
//!   with the `Max` combine rule (with [`HandModel::Actuated`], every link is instead a
//!   dynamic body of one multibody driven by joint motors, see `actuated.rs`);
//! - the object is one dynamic body whose collider is the compound of its convex parts, with
//!   the demonstration's mass (inertia from the parts at uniform density); it never sleeps,
//!   so a slowly closing hand always wakes it;
//! - supports and the checked barriers are fixed bodies, one collider each.
//!
//! A world may hold several trajectories of one hand and object ([`ReplayWorld::shared`],
//! the ensemble's members): each member's hand and object in a collision group of their own
//! that meets only each other and the fixed items, so one step advances them all.
//!
//! Each collider's `user_data` tags what it is ([`Tag`]), for diagnostics. Distances are
//! never read from the narrow phase's manifolds: with contact recycling (on by default, and
//! kept for speed) their `dist` stays frozen while a pair moves less than the recycle
//! distance (5 cm by default), e.g. a cube that fell 4.5 mm onto a table still reported a
//! 4.5 mm gap at rest. [`super::checks`] uses parry queries instead. Recycling is off by
//! default ([`Params::contact_recycling`]): recycled contacts keep their normals and anchors
//! while the hand slides 5 cm past the object, and in the gripper test the open jaws passing
//! 10 mm beside the box pushed it 21 mm (1.7 mm without recycling). Kinematic-vs-fixed pairs make no contacts in Rapier: the hand
//! passes through the scene here, and its penetration is measured with parry queries in
//! [`super::checks`].

use nalgebra::{Isometry3, Vector3};
use rapier3d_f64::parry::bounding_volume::BoundingVolume;
use rapier3d_f64::prelude::{
    ActiveHooks, CoefficientCombineRule, ColliderBuilder, ColliderHandle,
    ContactModificationContext, ContactPair, Group, IntegrationParameters, InteractionGroups,
    InteractionTestMode, PhysicsHooks, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle,
};

use super::actuated::ActuatedHand;
use super::params::{HandModel, Params};
use crate::Result;
use crate::geometry::hull::ObjectShape;
use crate::geometry::shape::CollisionShape;
use crate::math::convert::{from_pose, to_pose, to_vec};
use crate::robot::Robot;

/// What a collider belongs to (stored in its `user_data`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Tag {
    /// A hand link's collider (kinematic).
    Hand = 1,
    /// The object's compound collider (dynamic).
    Object = 2,
    /// A support item (fixed).
    Support = 3,
    /// A checked barrier item (fixed).
    Barrier = 4,
}

/// A fixed scene item to put into the world.
#[derive(Clone, Copy, Debug)]
pub struct FixedItem<'a> {
    /// The item's shape, world frame.
    pub shape: &'a CollisionShape,
    /// [`Tag::Support`] or [`Tag::Barrier`].
    pub tag: Tag,
}

#[derive(Debug)]
struct HandBody {
    /// Index into the link poses.
    link: usize,
    body: RigidBodyHandle,
}

/// How the hand's bodies follow the trajectory.
#[derive(Debug)]
enum HandDrive {
    /// One kinematic body per link with collision geometry.
    Kinematic(Vec<HandBody>),
    /// The articulated, motor-driven hand ([`super::actuated`]).
    Actuated(ActuatedHand),
}

/// One trajectory's bodies in the world: its hand and its object.
#[derive(Debug)]
struct Member {
    hand: HandDrive,
    /// The object's body.
    object: RigidBodyHandle,
    /// The object's collider.
    object_collider: ColliderHandle,
    /// The hand colliders' contact skin [m].
    finger_skin_m: f64,
    /// Whether the member's bodies take part in the steps ([`ReplayWorld::set_stepped`]).
    stepped: bool,
}

/// The replay world (see the module docs): one trajectory, or several sharing one Rapier
/// world ([`ReplayWorld::shared`]).
pub struct ReplayWorld {
    /// All Rapier state (public for tests and diagnostics).
    pub world: PhysicsWorld,
    /// The trajectories replayed; the methods without a member index act on the first.
    members: Vec<Member>,
    /// The opt-in solver cut ([`Params::solver_contact_gap_m`]).
    hooks: SolverCut,
}

impl std::fmt::Debug for ReplayWorld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplayWorld")
            .field("members", &self.members)
            .finish_non_exhaustive()
    }
}

/// Where one trajectory of a shared world starts, and what its replay varies: the kinematic
/// hand's friction and skin, the object's mass.
#[derive(Clone, Debug)]
pub struct MemberStart<'a> {
    /// The hand's link poses at frame 0.
    pub link_poses: &'a [Isometry3<f64>],
    /// The object's pose at the start.
    pub object_pose: Isometry3<f64>,
    /// The object's mass [kg].
    pub mass: f64,
    /// Hand-object friction ([`Params::hand_friction`]).
    pub hand_friction: f64,
    /// The hand colliders' contact skin [m] ([`Params::finger_skin_m`]).
    pub finger_skin_m: f64,
}

/// Most trajectories one shared world holds: one collision group each, one for the scene.
pub const MAX_SHARED: usize = 31;

/// The collision group of the scene's fixed items in a shared world.
const SCENE_GROUP: u32 = 1 << 31;

impl ReplayWorld {
    /// A world with the kinematic hand at `link_poses`, the object at `object_pose` and the
    /// fixed items, stepping by `dt` seconds with gravity `gravity` [m/s²].
    pub fn new(
        robot: &Robot,
        link_poses: &[Isometry3<f64>],
        object: &ObjectShape,
        object_pose: &Isometry3<f64>,
        mass: f64,
        fixed: &[FixedItem<'_>],
        params: &Params,
        dt: f64,
        gravity: Vector3<f64>,
    ) -> ReplayWorld {
        let start = MemberStart {
            link_poses,
            object_pose: *object_pose,
            mass,
            hand_friction: params.hand_friction,
            finger_skin_m: params.finger_skin_m,
        };
        ReplayWorld::shared(robot, &[start], object, fixed, params, dt, gravity)
    }

    /// Several trajectories of one hand and one object in one world, each with a kinematic
    /// hand and an object of its own that meet only each other and the fixed items (one
    /// collision group each), so that one step advances them all. What they share is the
    /// solver's work: Rapier solves the contacts of one island a colour at a time, four
    /// body-disjoint manifolds to a SIMD chunk, and the manifolds of one object can never
    /// share a chunk; those of different objects can. At most [`MAX_SHARED`] members; one
    /// member gives the world of [`ReplayWorld::new`], body for body.
    pub fn shared(
        robot: &Robot,
        starts: &[MemberStart<'_>],
        object: &ObjectShape,
        fixed: &[FixedItem<'_>],
        params: &Params,
        dt: f64,
        gravity: Vector3<f64>,
    ) -> ReplayWorld {
        assert!(
            (1..=MAX_SHARED).contains(&starts.len()),
            "a shared world holds 1 to {MAX_SHARED} members"
        );
        let grouped = starts.len() > 1;
        let mut world = empty_world(params, dt, gravity);
        let mut members = Vec::with_capacity(starts.len());
        for (m, start) in starts.iter().enumerate() {
            let groups = grouped.then(|| {
                let own = Group::from_bits_truncate(1 << m);
                (
                    InteractionGroups::new(own, own, InteractionTestMode::And),
                    InteractionGroups::new(
                        own,
                        own | Group::from_bits_truncate(SCENE_GROUP),
                        InteractionTestMode::And,
                    ),
                )
            });
            let member_params = Params {
                hand_friction: start.hand_friction,
                finger_skin_m: start.finger_skin_m,
                ..params.clone()
            };
            let mut hand = Vec::new();
            for (i, link) in robot.links().iter().enumerate() {
                if link.collision.is_empty() {
                    continue;
                }
                let body = world.insert_body(
                    RigidBodyBuilder::kinematic_position_based()
                        .pose(to_pose(&start.link_poses[i])),
                );
                for cs in &link.collision {
                    let mut collider = hand_collider(cs, &member_params);
                    if let Some((hand_groups, _)) = groups {
                        collider = collider.collision_groups(hand_groups);
                    }
                    world.insert_collider(collider, Some(body));
                }
                hand.push(HandBody { link: i, body });
            }
            let (object_body, object_collider) = insert_object(
                &mut world,
                object,
                &start.object_pose,
                start.mass,
                params,
                groups.map(|(_, g)| g),
            );
            members.push(Member {
                hand: HandDrive::Kinematic(hand),
                object: object_body,
                object_collider,
                finger_skin_m: start.finger_skin_m,
                stepped: true,
            });
        }
        let scene_groups = grouped.then(|| {
            InteractionGroups::new(
                Group::from_bits_truncate(SCENE_GROUP),
                Group::ALL,
                InteractionTestMode::And,
            )
        });
        insert_fixed(&mut world, fixed, params, scene_groups);
        ReplayWorld {
            hooks: SolverCut::new(params, &world),
            world,
            members,
        }
    }

    /// A world like [`ReplayWorld::new`] with the hand model `params.hand`: the actuated
    /// hand starts at joint values `q0` (whose forward kinematics are `link_poses`).
    ///
    /// Fails only when the actuated hand lacks what it needs (an effort limit).
    pub fn with_hand_model(
        robot: &Robot,
        link_poses: &[Isometry3<f64>],
        q0: &[f64],
        object: &ObjectShape,
        object_pose: &Isometry3<f64>,
        mass: f64,
        fixed: &[FixedItem<'_>],
        params: &Params,
        dt: f64,
        gravity: Vector3<f64>,
    ) -> Result<ReplayWorld> {
        match params.hand {
            HandModel::Kinematic => Ok(ReplayWorld::new(
                robot,
                link_poses,
                object,
                object_pose,
                mass,
                fixed,
                params,
                dt,
                gravity,
            )),
            HandModel::Actuated => {
                super::actuated::check_robot(robot)?;
                let mut world = empty_world(params, dt, gravity);
                let hand = ActuatedHand::build(&mut world, robot, link_poses, q0, params, |cs| {
                    hand_collider(cs, params)
                });
                let (object_body, object_collider) =
                    insert_object(&mut world, object, object_pose, mass, params, None);
                insert_fixed(&mut world, fixed, params, None);
                Ok(ReplayWorld {
                    hooks: SolverCut::new(params, &world),
                    world,
                    members: vec![Member {
                        hand: HandDrive::Actuated(hand),
                        object: object_body,
                        object_collider,
                        finger_skin_m: params.finger_skin_m,
                        stepped: true,
                    }],
                })
            }
        }
    }

    /// The trajectories in the world.
    pub fn member_count(&self) -> usize {
        self.members.len()
    }

    /// Sets the trajectory's hand for the end of the next step: link poses `link_poses`,
    /// from joint values `q`. The kinematic hand's links reach them; the actuated hand's
    /// anchor and motor targets move there.
    pub fn drive_hand(&mut self, link_poses: &[Isometry3<f64>], q: &[f64]) {
        self.drive_member_hand(0, link_poses, q);
    }

    /// [`ReplayWorld::drive_hand`] for member `m`.
    pub fn drive_member_hand(&mut self, m: usize, link_poses: &[Isometry3<f64>], q: &[f64]) {
        match &self.members[m].hand {
            HandDrive::Kinematic(hand) => {
                for h in hand {
                    if let Some(b) = self.world.bodies.get_mut(h.body) {
                        b.set_next_kinematic_position(to_pose(&link_poses[h.link]));
                    }
                }
            }
            HandDrive::Actuated(hand) => hand.drive(&mut self.world, link_poses, q),
        }
    }

    /// Whether member `m`'s bodies take part in the next steps. A member left out keeps its
    /// object's pose and velocity and its hand where it was, as if its own world were left
    /// unstepped (`replay.rs`); taken back, its contacts are found anew.
    pub fn set_stepped(&mut self, m: usize, stepped: bool) {
        let member = &mut self.members[m];
        if member.stepped == stepped {
            return;
        }
        member.stepped = stepped;
        let mut bodies = vec![member.object];
        match &member.hand {
            HandDrive::Kinematic(hand) => bodies.extend(hand.iter().map(|h| h.body)),
            HandDrive::Actuated(hand) => bodies.extend(hand.bodies.iter().copied()),
        }
        for handle in bodies {
            if let Some(b) = self.world.bodies.get_mut(handle) {
                b.set_enabled(stepped);
            }
        }
    }

    /// The simulated world pose of the hand's link `link` (index into the robot's links);
    /// `None` for a link without a body (the kinematic hand's links without collision).
    pub fn hand_link_pose(&self, link: usize) -> Option<Isometry3<f64>> {
        let body = match &self.members[0].hand {
            HandDrive::Kinematic(hand) => hand.iter().find(|h| h.link == link)?.body,
            HandDrive::Actuated(hand) => *hand.bodies.get(link)?,
        };
        Some(from_pose(self.world.bodies.get(body)?.position()))
    }

    /// How near [m] a hand collider's bounding box may come to the object's before a resting
    /// object is stepped again (see `replay.rs`): the finger skin, Rapier's prediction
    /// distance and [`super::replay::REST_REACH_MARGIN_M`]. `None` for the actuated hand,
    /// whose dynamic links need every step.
    pub fn rest_reach(&self) -> Option<f64> {
        self.member_rest_reach(0)
    }

    /// [`ReplayWorld::rest_reach`] for member `m`.
    pub fn member_rest_reach(&self, m: usize) -> Option<f64> {
        let member = &self.members[m];
        match member.hand {
            HandDrive::Kinematic(_) => Some(
                member.finger_skin_m
                    + self.world.integration_parameters.prediction_distance()
                    + super::replay::REST_REACH_MARGIN_M,
            ),
            HandDrive::Actuated(_) => None,
        }
    }

    /// Whether any hand collider, with its link at `link_poses`, has its bounding box within
    /// `reach` [m] of the object's (the object at its current pose). Always `true` for the
    /// actuated hand.
    pub fn hand_within(&self, link_poses: &[Isometry3<f64>], reach: f64) -> bool {
        self.member_hand_within(0, link_poses, reach)
    }

    /// [`ReplayWorld::hand_within`] for member `m`.
    pub fn member_hand_within(&self, m: usize, link_poses: &[Isometry3<f64>], reach: f64) -> bool {
        let member = &self.members[m];
        let HandDrive::Kinematic(hand) = &member.hand else {
            return true;
        };
        let object = self.world.colliders[member.object_collider]
            .compute_aabb()
            .loosened(reach);
        hand.iter().any(|h| {
            let Some(body) = self.world.bodies.get(h.body) else {
                return false;
            };
            let link = to_pose(&link_poses[h.link]);
            body.colliders().iter().any(|&c| {
                self.world.colliders.get(c).is_some_and(|c| {
                    let pose = c.position_wrt_parent().map_or(link, |p| link * *p);
                    c.shape().compute_aabb(&pose).intersects(&object)
                })
            })
        })
    }

    /// Places the kinematic hand's links at `link_poses` at once (no motion through the
    /// world, zero velocity); the actuated hand is left as it is.
    pub fn place_hand(&mut self, link_poses: &[Isometry3<f64>]) {
        self.place_member_hand(0, link_poses);
    }

    /// [`ReplayWorld::place_hand`] for member `m`.
    pub fn place_member_hand(&mut self, m: usize, link_poses: &[Isometry3<f64>]) {
        if let HandDrive::Kinematic(hand) = &self.members[m].hand {
            for h in hand {
                if let Some(b) = self.world.bodies.get_mut(h.body) {
                    b.set_position(to_pose(&link_poses[h.link]), false);
                }
            }
        }
    }

    /// Sets the object's linear and angular velocity to zero (an object declared at rest).
    pub fn stop_object(&mut self) {
        self.stop_member_object(0);
    }

    /// [`ReplayWorld::stop_object`] for member `m`.
    pub fn stop_member_object(&mut self, m: usize) {
        if let Some(b) = self.world.bodies.get_mut(self.members[m].object) {
            b.set_linvel(Default::default(), false);
            b.set_angvel(Default::default(), false);
        }
    }

    /// Advances the simulation by one step.
    pub fn step(&mut self) {
        self.world.step_with_events(&self.hooks, &());
    }

    /// The object's world pose.
    pub fn object_pose(&self) -> Isometry3<f64> {
        self.member_object_pose(0)
    }

    /// [`ReplayWorld::object_pose`] for member `m`.
    pub fn member_object_pose(&self, m: usize) -> Isometry3<f64> {
        from_pose(self.world.bodies[self.members[m].object].position())
    }

    /// The object's linear speed [m/s].
    pub fn object_speed(&self) -> f64 {
        self.member_object_speed(0)
    }

    /// [`ReplayWorld::object_speed`] for member `m`.
    pub fn member_object_speed(&self, m: usize) -> f64 {
        self.world.bodies[self.members[m].object].linvel().length()
    }

    /// Member `m`'s object's contact pairs, each with whether its other collider is a hand
    /// link.
    fn object_pairs(&self, m: usize) -> impl Iterator<Item = (&ContactPair, bool)> {
        let object_collider = self.members[m].object_collider;
        self.world
            .contact_pairs_with(object_collider)
            .map(move |pair| {
                let other = if pair.collider1 == object_collider {
                    pair.collider2
                } else {
                    pair.collider1
                };
                let is_hand = self
                    .world
                    .colliders
                    .get(other)
                    .is_some_and(|c| c.user_data == Tag::Hand as u128);
                (pair, is_hand)
            })
    }

    /// The object's contacts after the last step, counted for the replay's profile.
    pub fn object_contacts(&self) -> ObjectContacts {
        self.member_object_contacts(0)
    }

    /// [`ReplayWorld::object_contacts`] for member `m`.
    pub fn member_object_contacts(&self, m: usize) -> ObjectContacts {
        let mut c = ObjectContacts::default();
        for (pair, is_hand) in self.object_pairs(m) {
            for manifold in pair.manifolds() {
                let points = manifold.points.len();
                if points == 0 {
                    continue;
                }
                if is_hand {
                    c.hand_manifolds += 1;
                    c.hand_points += points;
                } else {
                    c.other_manifolds += 1;
                    c.other_points += points;
                }
            }
        }
        c
    }

    /// The hand's contact forces on the object in the last step (see [`GripSample`]).
    ///
    /// Rapier keeps each contact point's normal impulse over the step (summed over its
    /// substeps) and its distance between the rigid shapes; the force is the impulse over
    /// the step length, as in Rapier's own contact-force events. `skin` is the hand
    /// colliders' contact skin ([`Params::finger_skin_m`]): the solver pushes until the
    /// rigid distance is `skin`, so a point at distance `d` is compressed by `skin − d`.
    pub fn grip(&self) -> GripSample {
        self.member_grip(0)
    }

    /// [`ReplayWorld::grip`] for member `m`.
    pub fn member_grip(&self, m: usize) -> GripSample {
        let skin = self.members[m].finger_skin_m;
        let dt = self.world.integration_parameters.dt;
        let mut g = GripSample::default();
        if dt <= 0.0 {
            return g;
        }
        for (pair, is_hand) in self.object_pairs(m) {
            if !is_hand {
                continue;
            }
            for manifold in pair.solver_manifolds() {
                for pt in manifold.contacts() {
                    // A diverged step (reported by the replay) adds nothing, never a NaN.
                    let force = pt.data.impulse.max(0.0) / dt;
                    if force == 0.0 || !force.is_finite() {
                        continue;
                    }
                    g.normal_n += force;
                    let overlap = (-pt.dist).max(0.0);
                    if overlap > 0.0 {
                        g.at_overlap_n += force;
                    }
                    let compression = skin - pt.dist;
                    if compression > 0.0 {
                        g.from_overlap_n += force * overlap / compression;
                    }
                }
            }
        }
        g
    }
}

/// The hand's normal contact force on the object at one instant, and where it comes from.
///
/// A kinematic finger grips only through the contact solver's push-out, which acts on the
/// compression `skin − d` of each contact point (`d` the rigid shapes' distance, negative
/// when they overlap): part of it is the skin, part the fingers' overlap with the object.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GripSample {
    /// Total normal force [N].
    pub normal_n: f64,
    /// The part at points where the rigid shapes overlap (`d < 0`) [N].
    pub at_overlap_n: f64,
    /// Each point's force split in proportion to its compression, overlap `max(−d, 0)`
    /// against skin: the overlap's part [N].
    pub from_overlap_n: f64,
}

fn empty_world(params: &Params, dt: f64, gravity: Vector3<f64>) -> PhysicsWorld {
    PhysicsWorld {
        gravity: to_vec(&gravity),
        integration_parameters: IntegrationParameters {
            dt,
            num_solver_iterations: params.solver_iterations,
            num_internal_stabilization_iterations: params.stabilization_iterations,
            normalized_prediction_distance: params.prediction_distance_m,
            contact_recycling: params.contact_recycling,
            ..IntegrationParameters::default()
        },
        ..PhysicsWorld::default()
    }
}

/// A hand collider: the link's shape with the hand friction and the finger skin.
fn hand_collider(cs: &CollisionShape, params: &Params) -> ColliderBuilder {
    ColliderBuilder::new(cs.shape.clone())
        .position(to_pose(&cs.shape_pose))
        .friction(params.hand_friction)
        .friction_combine_rule(CoefficientCombineRule::Max)
        .contact_skin(params.finger_skin_m)
        .active_hooks(if params.solver_contact_gap_m.is_some() {
            ActiveHooks::MODIFY_SOLVER_CONTACTS
        } else {
            ActiveHooks::empty()
        })
        .user_data(Tag::Hand as u128)
}

/// Leaves out of the solver the hand-object manifolds Rapier keeps within its prediction
/// distance (20 mm) whose every contact's gap (the finger skin deducted) stays at least
/// `gap_m` at the end of the step at the bodies' current relative normal speed
/// ([`Params::solver_contact_gap_m`], off by default). Such a manifold would only forbid
/// closing its gap within the step; 76 % of the teapot's hand-object solver manifolds are
/// of this kind. A manifold with one contact that may act keeps all of them (its far
/// contacts place its friction); the narrow phase is untouched. It still changes the
/// outcome: Rapier solves contacts by one Gauss-Seidel pass per substep in an order set by
/// its constraint graph, and fewer constraints reorder the ones that act (see the physics
/// module docs).
#[derive(Clone, Copy, Debug)]
struct SolverCut {
    gap_m: f64,
    dt: f64,
}

impl SolverCut {
    /// The cut of `params` for a world stepping as `world` does (off: an infinite gap).
    fn new(params: &Params, world: &PhysicsWorld) -> SolverCut {
        SolverCut {
            gap_m: params.solver_contact_gap_m.unwrap_or(f64::INFINITY),
            dt: world.integration_parameters.dt,
        }
    }
}

impl PhysicsHooks for SolverCut {
    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        let body_velocity = |handle: Option<RigidBodyHandle>, point| {
            handle
                .and_then(|h| context.bodies.get(h))
                .map(|b| b.velocity_at_point(point))
                .unwrap_or_default()
        };
        let (rb1, rb2) = (context.rigid_body1, context.rigid_body2);
        let idle = context.rigid().is_some_and(|m| {
            m.solver_contacts.iter().all(|c| {
                let closing =
                    (body_velocity(rb2, c.anchor2) - body_velocity(rb1, c.anchor1)).dot(*m.normal);
                c.dist >= self.gap_m && c.dist + closing * self.dt >= self.gap_m
            })
        });
        if idle && let Some(m) = context.rigid_mut() {
            m.solver_contacts.clear();
        }
    }
}

/// Adds the dynamic object at `pose` with mass `mass` (in `groups` when given): its body and
/// collider.
fn insert_object(
    world: &mut PhysicsWorld,
    object: &ObjectShape,
    pose: &Isometry3<f64>,
    mass: f64,
    params: &Params,
    groups: Option<InteractionGroups>,
) -> (RigidBodyHandle, ColliderHandle) {
    // What Rapier's `.mass(mass)` computes (unit-density properties scaled to the mass),
    // from the parts' properties computed once per object.
    let mut mass_properties = object.unit_mass;
    mass_properties.set_mass(mass, true);
    let mut collider = ColliderBuilder::new(object.compound.clone())
        .mass_properties(mass_properties)
        .friction(params.object_friction)
        .user_data(Tag::Object as u128);
    if let Some(groups) = groups {
        collider = collider.collision_groups(groups);
    }
    world.insert(
        RigidBodyBuilder::dynamic()
            .pose(to_pose(pose))
            .can_sleep(false),
        collider,
    )
}

/// Adds the fixed items (in `groups` when given).
fn insert_fixed(
    world: &mut PhysicsWorld,
    fixed: &[FixedItem<'_>],
    params: &Params,
    groups: Option<InteractionGroups>,
) {
    for item in fixed {
        let mut collider = ColliderBuilder::new(item.shape.shape.clone())
            .position(to_pose(&item.shape.shape_pose))
            .friction(params.object_friction)
            .user_data(item.tag as u128);
        if let Some(groups) = groups {
            collider = collider.collision_groups(groups);
        }
        world.insert(RigidBodyBuilder::fixed(), collider);
    }
}

/// The object's contact manifolds and points after one step: with hand links, and with
/// supports and barriers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ObjectContacts {
    pub hand_manifolds: usize,
    pub hand_points: usize,
    pub other_manifolds: usize,
    pub other_points: usize,
}
