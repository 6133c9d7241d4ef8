//! The replay: the hand driven along the trajectory, the object simulated.
//!
//! Frame `i` is shown at `t_i = i / fps`. The frame period is split into
//! `n = ⌈(1/fps) / max_dt⌉` equal steps of `dt = 1 / (n · fps)` ≤ `max_dt`. At step `k` of
//! the interval `[t_i, t_i+1]` every hand link is sent to its pose at `u = k / n`:
//!
//! ```text
//! wrist(u) = (lerp(p_i, p_i+1, u), slerp(R_i, R_i+1, u)),   q(u) = lerp(q_i, q_i+1, u),
//! link poses = FK(wrist(u), q(u))
//! ```
//!
//! which Rapier reaches at the end of the step (position-based kinematic bodies get the
//! velocity that takes them there, so the contacts see the hand's true motion). The object's
//! pose and speed are recorded after the last step of each interval, i.e. at every frame
//! time, with the hand's contact forces on it ([`ReplayWorld::grip`]). A non-finite object
//! pose stops the replay and is reported, never propagated.

use nalgebra::{Isometry3, Translation3};

use serde::Serialize;

use super::world::{GripSample, ReplayWorld};
use crate::math::rotation::slerp_shortest;
use crate::model::{Demo, Frame};
use crate::robot::Robot;

/// What the replay recorded, one entry per frame.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// Simulated object pose at each frame time.
    pub object: Vec<Isometry3<f64>>,
    /// Object speed [m/s] at each frame.
    pub speed_m_s: Vec<f64>,
    /// Steps per frame interval.
    pub steps_per_frame: usize,
    /// Step length [s].
    pub dt_s: f64,
    /// Steps simulated.
    pub steps: usize,
    /// First frame at which the object pose was not finite.
    pub diverged_at: Option<usize>,
    /// The hand's contact forces on the object in the last step before each frame time.
    pub grip: Vec<GripSample>,
    /// What the steps simulated: counts of contacts and idle steps.
    pub profile: StepProfile,
}

/// Where the replay's steps went, for the physics module's profile (not in reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepProfile {
    /// Steps simulated.
    pub steps: usize,
    /// Steps after which the object touched a hand link.
    pub hand_contact_steps: usize,
    /// Steps with no hand contact and the object slower than [`IDLE_SPEED_M_S`]: the object
    /// at rest on its support, where a step changes nothing a check reads.
    pub idle_steps: usize,
    /// Hand-object contact manifolds and points, summed over the steps.
    pub hand_manifolds: usize,
    pub hand_points: usize,
    /// Object-support and object-barrier manifolds and points, summed over the steps.
    pub other_manifolds: usize,
    pub other_points: usize,
}

/// Object speed [m/s] below which a step without hand contact counts as idle.
pub const IDLE_SPEED_M_S: f64 = 1e-3;

impl StepProfile {
    fn record(&mut self, world: &ReplayWorld) {
        let c = world.object_contacts();
        self.steps += 1;
        self.hand_manifolds += c.hand_manifolds;
        self.hand_points += c.hand_points;
        self.other_manifolds += c.other_manifolds;
        self.other_points += c.other_points;
        if c.hand_points > 0 {
            self.hand_contact_steps += 1;
        } else if world.object_speed() < IDLE_SPEED_M_S {
            self.idle_steps += 1;
        }
    }
}

/// Steps per frame interval for frame rate `fps` and largest step `max_dt` [s].
pub fn steps_per_frame(fps: f64, max_dt: f64) -> usize {
    // The small slack keeps 30 fps at 1/240 s at exactly 8 steps despite rounding.
    (((1.0 / fps) / max_dt) * (1.0 - 1e-9)).ceil().max(1.0) as usize
}

/// Fills `link_poses` with the hand interpolated between frames `a` (u = 0) and `b` (u = 1).
pub fn hand_between(
    robot: &Robot,
    a: &Frame,
    b: &Frame,
    u: f64,
    q: &mut [f64],
    link_poses: &mut [Isometry3<f64>],
) {
    let t = a
        .wrist
        .translation
        .vector
        .lerp(&b.wrist.translation.vector, u);
    let r = slerp_shortest(&a.wrist.rotation, &b.wrist.rotation, u);
    for ((qk, qa), qb) in q.iter_mut().zip(&a.joints).zip(&b.joints) {
        *qk = qa + (qb - qa) * u;
    }
    robot.forward_kinematics(
        &Isometry3::from_parts(Translation3::from(t), r),
        q,
        link_poses,
    );
}

/// Replays `demo` in `world` (built with the hand at frame 0) with `n` steps per frame.
pub fn replay(robot: &Robot, demo: &Demo, world: &mut ReplayWorld, n: usize) -> Trace {
    let frames = &demo.frames;
    let mut trace = Trace {
        steps_per_frame: n,
        dt_s: 1.0 / (n as f64 * demo.fps),
        ..Trace::default()
    };
    trace.object.reserve(frames.len());
    trace.object.push(world.object_pose());
    trace.speed_m_s.push(world.object_speed());
    trace.grip.reserve(frames.len());
    trace.grip.push(GripSample::default());
    let mut q = vec![0.0; robot.dof()];
    let mut link_poses = robot.new_link_poses();
    for i in 1..frames.len() {
        let (a, b) = (&frames[i - 1], &frames[i]);
        for k in 1..=n {
            hand_between(robot, a, b, k as f64 / n as f64, &mut q, &mut link_poses);
            world.drive_hand(&link_poses, &q);
            world.step();
            trace.steps += 1;
            trace.profile.record(world);
        }
        let pose = world.object_pose();
        let finite = pose.translation.vector.iter().all(|c| c.is_finite())
            && pose.rotation.coords.iter().all(|c| c.is_finite());
        if !finite {
            trace.diverged_at = Some(i);
            // Hold the last finite pose so later checks see a failure, not NaN.
            let last = *trace.object.last().unwrap_or(&frames[0].object);
            trace.object.resize(frames.len(), last);
            trace.speed_m_s.resize(frames.len(), 0.0);
            trace.grip.resize(frames.len(), GripSample::default());
            break;
        }
        trace.object.push(pose);
        trace.speed_m_s.push(world.object_speed());
        trace.grip.push(world.grip());
    }
    trace
}
