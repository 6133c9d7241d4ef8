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
//!
//! # What the replay leaves out ([`Shortcuts`])
//!
//! - **Rest**: once a hand has touched the object, after a whole frame interval in which no
//!   hand link touched it and the
//!   object moved less than [`REST_MOTION_M`] and turned less than [`REST_TURN_RAD`], the
//!   world is left unstepped for as long as every hand collider's bounding box stays farther
//!   than the reach from the object's ([`ReplayWorld::hand_within`]: finger skin + Rapier's
//!   prediction distance + [`REST_REACH_MARGIN_M`]). The object keeps its pose and velocity,
//!   the hand's bodies are not moved; at the first step whose hand comes within reach the
//!   hand is placed at the previous step's poses ([`ReplayWorld::place_hand`]) and stepping
//!   resumes from there, so the step that follows sees the hand's true motion. This covers
//!   the retreat after the release. Before any hand
//!   touched it, an object stays stepped while it settles on its support; one that rests on
//!   a support at frame 0 (within [`super::Params::support_gap_m`]) and has not come to rest
//!   after [`SETTLE_S`] is held at rest (speed set to zero, world unstepped) until a hand
//!   comes within reach, unless one is within reach already: the demonstration says it lies
//!   there. Stepping it on adds what the engine does to an untouched object: Rapier has no
//!   rolling resistance, and the apple alone on a table (its 40-gon hull resting on a flat
//!   face) rocks at 1-2 rad/s and turns 17° in 3.5 s, the whole approach of its
//!   demonstration, which the hand then holds as tracking error. A settled object is not
//!   held: holding the frying pan from frame 0, so that its contacts with the stove formed
//!   only as the hand came, or right after it settled, cost 11 and 30 of 181 passing
//!   frying-pan variations (`augment`, N = 200, seed 1: grasps at the slip limit; the
//!   demonstrations of then); stepping it until the grasp keeps all 181.
//! - **Drop**: once the simulated object is more than the drop limit off its plan inside the
//!   contact segment, the drop is decided (its frame is the first such frame, see
//!   `checks::find_drop`); the replay goes on for the drop window (whether the hand lost
//!   contact is read there) and stops. The trace then ends at that frame
//!   ([`Trace::stopped_at`]) and every figure read from it covers the replayed frames only.
//! - **Failed tracking** (the ensemble's perturbed members only, [`TrackingStop`]): once the
//!   per-frame position or rotation errors summed so far exceed the mean limit times the
//!   number of frames, the mean over the whole trajectory exceeds it whatever follows, and the
//!   member fails; its replay stops there. The mean over the frames replayed exceeds the
//!   limit too, so the member fails with the reason of the whole replay but for a failure
//!   that would have come later. The members sharing its world go on without it, which
//!   reorders the solver's work for them as any member's end does (measured: pass fractions
//!   of 40 augmented samples the same but one, 15 of 32 against 16 of 30; 5 % less time).
//!   The nominal replay is always whole.
//!
//! Neither rest nor drop applies to the actuated hand, whose links are dynamic bodies.

use std::time::Instant;

use nalgebra::{Isometry3, Translation3};

use serde::Serialize;

use super::world::{GripSample, ReplayWorld};
use crate::math::rotation::{angle_between, slerp_shortest};
use crate::model::{ContactSegment, Demo, Frame};
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
    /// Steps left unstepped while the object rested out of the hand's reach.
    pub skipped_steps: usize,
    /// First frame at which the object pose was not finite.
    pub diverged_at: Option<usize>,
    /// The last frame replayed when the replay stopped early on a decided drop or a decided
    /// tracking failure: the trace's per-frame vectors end there.
    pub stopped_at: Option<usize>,
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
    /// Wall time of the steps by kind: the one part that differs between two runs.
    pub times: StepTimes,
}

/// Wall time [s] of the steps with a hand on the object, of the idle steps and of the others
/// (hand driving and stepping, not the per-frame recording).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepTimes {
    pub hand_contact_s: f64,
    pub idle_s: f64,
    pub other_s: f64,
}

/// Object speed [m/s] below which a step without hand contact counts as idle.
pub const IDLE_SPEED_M_S: f64 = 1e-3;

/// Largest motion [m] of the object over a frame interval for it to count as at rest.
pub const REST_MOTION_M: f64 = 1e-5;

/// Largest turn [rad] of the object over a frame interval for it to count as at rest.
pub const REST_TURN_RAD: f64 = 1e-4;

/// What the hand's reach adds to the finger skin and Rapier's prediction distance [m]
/// before a resting object is stepped again.
pub const REST_REACH_MARGIN_M: f64 = 0.01;

/// How long [s] an object that starts on a support is stepped, at most, before it counts as
/// at rest whatever it does.
pub const SETTLE_S: f64 = 1.0;

/// What the replay may leave out (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct Shortcuts {
    /// Leave the world unstepped while the object rests and no hand link is within reach.
    pub rest: bool,
    /// The object rests on a support at frame 0: if it has not come to rest after
    /// [`SETTLE_S`] untouched, it is held at rest until a hand comes (with `rest`).
    pub rests_at_start: bool,
    /// Stop once a drop is decided.
    pub drop: Option<DropStop>,
    /// Stop once a tracking failure is decided.
    pub tracking: Option<TrackingStop>,
}

/// When a tracking failure is decided: the sums of the per-frame errors past which the mean
/// over all the trajectory's frames exceeds its limit, whatever the frames left add (the
/// errors are not negative): the limits times the number of frames.
#[derive(Clone, Copy, Debug)]
pub struct TrackingStop {
    pub position_sum_m: f64,
    pub rotation_sum_rad: f64,
}

/// When a drop is decided: the first frame of `segment` with the object more than
/// `error_m` off its plan, plus `window` frames.
#[derive(Clone, Copy, Debug)]
pub struct DropStop {
    pub segment: ContactSegment,
    pub error_m: f64,
    pub window: usize,
}

impl DropStop {
    /// Whether the replay may stop after frame `i`, where the object is at `pose`; `first`
    /// keeps the drop's frame once found.
    fn decided(
        &self,
        demo: &Demo,
        i: usize,
        pose: &Isometry3<f64>,
        first: &mut Option<usize>,
    ) -> bool {
        if first.is_none()
            && (self.segment.start..=self.segment.end).contains(&i)
            && (pose.translation.vector - demo.frames[i].object.translation.vector).norm()
                > self.error_m
        {
            *first = Some(i);
        }
        first.is_some_and(|f| i >= f + self.window)
    }
}

/// Whether the object rests: no hand contact over the last frame interval, and its pose
/// then and now within [`REST_MOTION_M`] and [`REST_TURN_RAD`].
fn at_rest(touched: bool, then: &Isometry3<f64>, now: &Isometry3<f64>) -> bool {
    !touched
        && (now.translation.vector - then.translation.vector).norm() < REST_MOTION_M
        && angle_between(&now.rotation, &then.rotation) < REST_TURN_RAD
}

impl StepProfile {
    /// Counts one step of member `m`; whether a hand link touched its object after it.
    fn record(&mut self, world: &ReplayWorld, m: usize, seconds: f64) -> bool {
        let c = world.member_object_contacts(m);
        self.steps += 1;
        self.hand_manifolds += c.hand_manifolds;
        self.hand_points += c.hand_points;
        self.other_manifolds += c.other_manifolds;
        self.other_points += c.other_points;
        if c.hand_points > 0 {
            self.hand_contact_steps += 1;
            self.times.hand_contact_s += seconds;
        } else if world.member_object_speed(m) < IDLE_SPEED_M_S {
            self.idle_steps += 1;
            self.times.idle_s += seconds;
        } else {
            self.times.other_s += seconds;
        }
        c.hand_points > 0
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

/// One trajectory's replay in progress: member `m` of its world.
struct Run<'a> {
    demo: &'a Demo,
    m: usize,
    shortcuts: Shortcuts,
    trace: Trace,
    /// The hand's reach while the object rests (`None`: every step is taken).
    reach: Option<f64>,
    q: Vec<f64>,
    link_poses: Vec<Isometry3<f64>>,
    /// The hand at the previous step.
    previous: Vec<Isometry3<f64>>,
    /// The last frame of the settling of an object that starts on a support.
    settled: Option<usize>,
    resting: bool,
    ever_touched: bool,
    came_to_rest: bool,
    /// A hand link touched the object in the current frame interval.
    touched: bool,
    dropped_at: Option<usize>,
    /// The position [m] and rotation [rad] errors summed over the frames recorded so far
    /// (from frame 1).
    error_sums: (f64, f64),
}

impl<'a> Run<'a> {
    fn new(
        robot: &Robot,
        demo: &'a Demo,
        world: &ReplayWorld,
        m: usize,
        n: usize,
        shortcuts: &Shortcuts,
    ) -> Run<'a> {
        let frames = &demo.frames;
        let mut trace = Trace {
            steps_per_frame: n,
            dt_s: 1.0 / (n as f64 * demo.fps),
            ..Trace::default()
        };
        trace.object.reserve(frames.len());
        trace.object.push(world.member_object_pose(m));
        trace.speed_m_s.push(world.member_object_speed(m));
        trace.grip.reserve(frames.len());
        trace.grip.push(GripSample::default());
        let reach = world.member_rest_reach(m).filter(|_| shortcuts.rest);
        let mut link_poses = robot.new_link_poses();
        // The hand where the world was built: the poses `previous` holds at the first step.
        robot.forward_kinematics(&frames[0].wrist, &frames[0].joints, &mut link_poses);
        Run {
            demo,
            m,
            shortcuts: *shortcuts,
            trace,
            reach,
            q: vec![0.0; robot.dof()],
            previous: link_poses.clone(),
            link_poses,
            settled: (shortcuts.rests_at_start && reach.is_some())
                .then(|| ((SETTLE_S * demo.fps).ceil() as usize).max(1)),
            resting: false,
            ever_touched: false,
            came_to_rest: false,
            touched: false,
            dropped_at: None,
            error_sums: (0.0, 0.0),
        }
    }

    /// Sets the hand for step `k` of `n` of the interval ending at frame `i`: whether the
    /// member is stepped (not while its object rests out of the hand's reach).
    fn drive(
        &mut self,
        robot: &Robot,
        world: &mut ReplayWorld,
        i: usize,
        k: usize,
        n: usize,
    ) -> bool {
        let (a, b) = (&self.demo.frames[i - 1], &self.demo.frames[i]);
        std::mem::swap(&mut self.previous, &mut self.link_poses);
        hand_between(
            robot,
            a,
            b,
            k as f64 / n as f64,
            &mut self.q,
            &mut self.link_poses,
        );
        if let Some(reach) = self.reach.filter(|_| self.resting) {
            if !world.member_hand_within(self.m, &self.link_poses, reach) {
                self.trace.skipped_steps += 1;
                return false;
            }
            world.place_member_hand(self.m, &self.previous);
            self.resting = false;
        }
        world.drive_member_hand(self.m, &self.link_poses, &self.q);
        true
    }

    /// Counts a step taken, of `seconds`.
    fn stepped(&mut self, world: &ReplayWorld, seconds: f64) {
        self.trace.steps += 1;
        self.touched |= self.trace.profile.record(world, self.m, seconds);
    }

    /// Records frame `i` at the end of its interval: `false` when the replay ends there (the
    /// object's pose is not finite, or a drop is decided).
    fn end_frame(&mut self, world: &mut ReplayWorld, i: usize) -> bool {
        let frames = &self.demo.frames;
        let trace = &mut self.trace;
        let touched = std::mem::take(&mut self.touched);
        let pose = world.member_object_pose(self.m);
        let finite = pose.translation.vector.iter().all(|c| c.is_finite())
            && pose.rotation.coords.iter().all(|c| c.is_finite());
        if !finite {
            trace.diverged_at = Some(i);
            // Hold the last finite pose so later checks see a failure, not NaN.
            let last = *trace.object.last().unwrap_or(&frames[0].object);
            trace.object.resize(frames.len(), last);
            trace.speed_m_s.resize(frames.len(), 0.0);
            trace.grip.resize(frames.len(), GripSample::default());
            return false;
        }
        let still = at_rest(touched, &trace.object[i - 1], &pose);
        self.ever_touched |= touched;
        self.came_to_rest |= still;
        self.resting = if self.ever_touched {
            self.reach.is_some() && still
        } else if self.settled == Some(i)
            && !self.came_to_rest
            && !touched
            && self
                .reach
                .is_some_and(|r| !world.member_hand_within(self.m, &self.link_poses, r))
        {
            // Untouched and still moving after the settling time: held at rest from here
            // until a hand comes, with no speed to resume from. A hand already within reach
            // is about to touch it: holding it then would change the run and leave nothing
            // out.
            world.stop_member_object(self.m);
            self.reach.is_some()
        } else {
            self.resting
        };
        trace.object.push(pose);
        trace.speed_m_s.push(world.member_object_speed(self.m));
        trace.grip.push(world.member_grip(self.m));
        if let Some(stop) = &self.shortcuts.drop
            && stop.decided(self.demo, i, &pose, &mut self.dropped_at)
            && i + 1 < frames.len()
        {
            trace.stopped_at = Some(i);
            return false;
        }
        if let Some(stop) = &self.shortcuts.tracking {
            let plan = &frames[i].object;
            self.error_sums.0 += (pose.translation.vector - plan.translation.vector).norm();
            self.error_sums.1 += angle_between(&pose.rotation, &plan.rotation);
            if (self.error_sums.0 > stop.position_sum_m
                || self.error_sums.1 > stop.rotation_sum_rad)
                && i + 1 < frames.len()
            {
                trace.stopped_at = Some(i);
                return false;
            }
        }
        true
    }
}

/// Replays `demo` in `world` (built with the hand at frame 0) with `n` steps per frame,
/// leaving out what `shortcuts` allows.
pub fn replay(
    robot: &Robot,
    demo: &Demo,
    world: &mut ReplayWorld,
    n: usize,
    shortcuts: &Shortcuts,
) -> Trace {
    let mut run = Run::new(robot, demo, world, 0, n, shortcuts);
    for i in 1..demo.frames.len() {
        for k in 1..=n {
            let clock = Instant::now();
            if run.drive(robot, world, i, k, n) {
                world.step();
                run.stepped(world, clock.elapsed().as_secs_f64());
            }
        }
        if !run.end_frame(world, i) {
            break;
        }
    }
    run.trace
}

/// Replays `demos[m]` as member `m` of the shared `world` ([`ReplayWorld::shared`], built with
/// each hand at its frame 0), all at once: one step advances every member that is stepped.
/// The same rules as [`replay`] apply to each member, with one difference: a member whose
/// object rests out of its hand's reach is left out of the steps
/// ([`ReplayWorld::set_stepped`]) rather than the world left unstepped, and one whose replay
/// ended (a decided drop, a diverged step) is left out from there. The demonstrations must
/// have the same frames and frame rate (members of one ensemble).
pub fn replay_shared(
    robot: &Robot,
    demos: &[Demo],
    world: &mut ReplayWorld,
    n: usize,
    shortcuts: &[Shortcuts],
) -> Vec<Trace> {
    debug_assert_eq!(demos.len(), world.member_count());
    let mut runs: Vec<Run<'_>> = demos
        .iter()
        .zip(shortcuts)
        .enumerate()
        .map(|(m, (demo, s))| Run::new(robot, demo, world, m, n, s))
        .collect();
    let frames = demos.iter().map(|d| d.frames.len()).min().unwrap_or(0);
    let mut ended = vec![false; runs.len()];
    let mut stepped = vec![false; runs.len()];
    for i in 1..frames {
        for k in 1..=n {
            let clock = Instant::now();
            for (m, run) in runs.iter_mut().enumerate() {
                stepped[m] = !ended[m] && run.drive(robot, world, i, k, n);
                world.set_stepped(m, stepped[m]);
            }
            let count = stepped.iter().filter(|s| **s).count();
            if count == 0 {
                continue;
            }
            world.step();
            let seconds = clock.elapsed().as_secs_f64() / count as f64;
            for (run, _) in runs.iter_mut().zip(&stepped).filter(|(_, s)| **s) {
                run.stepped(world, seconds);
            }
        }
        for (m, run) in runs.iter_mut().enumerate() {
            if !ended[m] && !run.end_frame(world, i) {
                ended[m] = true;
                world.set_stepped(m, false);
            }
        }
        if ended.iter().all(|e| *e) {
            break;
        }
    }
    runs.into_iter().map(|r| r.trace).collect()
}
