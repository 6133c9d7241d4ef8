//! Stage 5: light smoothing of the recovered hand (docs/METHOD.md stage 4 "Smoothing", paper
//! "Hand Warping", last paragraph).
//!
//! Per-frame IK leaves small frame-to-frame jitter. Inside the contact segment only:
//! - wrist translation: Savitzky-Golay, `savgol_window` samples, order `savgol_polyorder`
//!   ([`crate::math::savgol`], scipy's `savgol_filter`, mode 'interp');
//! - wrist rotation: centered moving-window quaternion average (Markley), `2h+1` frames with
//!   `h = rotation_half_window` ([`crate::math::rotation::windowed_average`]);
//! - joints (1-DoF each): centered moving mean of the angles, `h = joint_half_window`.
//!
//! The windows are times ([`SAVGOL_HALF_WINDOW_S`], [`AVERAGE_HALF_WINDOW_S`]) counted in frames
//! at the demonstration's rate by [`Params::at_fps`], so the same motion is smoothed alike at
//! 10, 30 or 120 fps.
//!
//! Frames outside the range are untouched. Continuity at the boundaries: each filter runs
//! over the range extended by up to its half window of the untouched neighbours on each
//! side, and only the range is written back. So the first and last frames of the segment
//! are smoothed with their real neighbours (no one-sided edge fit, no step introduced at the
//! boundary); at the ends of the whole path the filters' own edge rules apply (SavGol's
//! polynomial edge fit, the symmetric shrinking window of the averages).
//!
//! Smoothing moves the hand off the IK solution: the report shows D_C before and after
//! ("drift", paper Table 3). A polynomial of degree ≤ `savgol_polyorder` in time (e.g. a
//! straight line at constant speed) passes through the translation filter unchanged.

use std::ops::RangeInclusive;
use std::time::Instant;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::HandPath;
use crate::math::frames_in;
use crate::math::rotation::{RotationError, windowed_average, windowed_mean};
use crate::math::savgol::{SavgolError, savgol_filter3};

/// Half window of the wrist translation's Savitzky-Golay filter [s]: 4 frames at 30 fps.
pub const SAVGOL_HALF_WINDOW_S: f64 = 4.0 / 30.0;
/// Polynomial order of the wrist translation's Savitzky-Golay filter, where its window
/// allows it (a window of `2h + 1` samples fits at most order `2h`).
pub const SAVGOL_POLYORDER: usize = 3;
/// Half window of the wrist-rotation average and of the joint-angle mean [s]: 2 frames at
/// 30 fps.
pub const AVERAGE_HALF_WINDOW_S: f64 = 2.0 / 30.0;

/// Parameters of the smoothing, in frames. The filters are defined in seconds (the
/// constants above) and [`Params::at_fps`] turns them into frames at a demonstration's rate,
/// so a recording at 10 or 120 fps is smoothed over the same time as one at 30 fps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// Savitzky-Golay window of the wrist translation [frames], odd, > polyorder. Default 9.
    pub savgol_window: usize,
    /// Savitzky-Golay polynomial order. Default 3.
    pub savgol_polyorder: usize,
    /// Half window of the wrist-rotation average [frames] (0 = off). Default 2.
    pub rotation_half_window: usize,
    /// Half window of the joint-angle mean [frames] (0 = off). Default 2.
    pub joint_half_window: usize,
}

impl Params {
    /// The smoothing of a demonstration recorded at `fps` frames per second: each half
    /// window is its length in seconds times `fps`, rounded (the Savitzky-Golay half window at
    /// least 1, its order lowered to what the window fits; at 10 fps a 3-sample window of
    /// order 2 leaves the translation as it is). 30 fps gives [`Params::default`].
    pub fn at_fps(fps: f64) -> Params {
        let h = frames_in(SAVGOL_HALF_WINDOW_S, fps).max(1);
        Params {
            savgol_window: 2 * h + 1,
            savgol_polyorder: SAVGOL_POLYORDER.min(2 * h),
            rotation_half_window: frames_in(AVERAGE_HALF_WINDOW_S, fps),
            joint_half_window: frames_in(AVERAGE_HALF_WINDOW_S, fps),
        }
    }
}

impl Default for Params {
    /// The smoothing at 30 fps.
    fn default() -> Self {
        Params {
            savgol_window: 9,
            savgol_polyorder: SAVGOL_POLYORDER,
            rotation_half_window: 2,
            joint_half_window: 2,
        }
    }
}

/// Why smoothing failed: bad parameters or non-finite input (the IK stage reports those).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SmoothError {
    #[error("wrist translation: {0}")]
    Translation(#[from] SavgolError),
    #[error("wrist rotation or joints: {0}")]
    Rotation(#[from] RotationError),
    #[error("range {start}..={end} is outside the hand path of {frames} frames")]
    Range {
        start: usize,
        end: usize,
        frames: usize,
    },
}

/// How far smoothing moved the hand.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Frames smoothed.
    pub frames: usize,
    /// Largest change of the wrist position [mm].
    pub max_translation_mm: f64,
    /// Largest change of the wrist rotation [deg].
    pub max_rotation_deg: f64,
    /// Largest change of a joint value [rad or m].
    pub max_joint: f64,
    /// Wall time [s].
    pub time_s: f64,
}

/// Smooths `hand` inside `range` (output frames of the contact segment; see the module docs).
pub fn run(
    hand: &HandPath,
    range: RangeInclusive<usize>,
    params: &Params,
) -> Result<(HandPath, Stats), SmoothError> {
    let clock = Instant::now();
    let (a, b) = (*range.start(), *range.end());
    let n = hand.len();
    if a > b || b >= n {
        return Err(SmoothError::Range {
            start: a,
            end: b,
            frames: n,
        });
    }
    let mut out = hand.clone();
    let mut stats = Stats {
        frames: b + 1 - a,
        ..Stats::default()
    };
    // Each filter sees up to its half window of neighbours outside the range.
    let extended = |half: usize| (a.saturating_sub(half), (b + half).min(n - 1));

    let (lo, hi) = extended(params.savgol_window / 2);
    let positions: Vec<Vector3<f64>> = hand.wrists[lo..=hi]
        .iter()
        .map(|w| w.translation.vector)
        .collect();
    let smoothed = savgol_filter3(&positions, params.savgol_window, params.savgol_polyorder)?;
    for t in a..=b {
        let v = smoothed[t - lo];
        stats.max_translation_mm = stats
            .max_translation_mm
            .max((v - hand.wrists[t].translation.vector).norm() * 1e3);
        out.wrists[t].translation.vector = v;
    }

    if params.rotation_half_window > 0 {
        let (lo, hi) = extended(params.rotation_half_window);
        let rotations: Vec<_> = hand.wrists[lo..=hi].iter().map(|w| w.rotation).collect();
        let averaged = windowed_average(&rotations, params.rotation_half_window)?;
        for t in a..=b {
            let r = averaged[t - lo];
            stats.max_rotation_deg = stats
                .max_rotation_deg
                .max(r.angle_to(&hand.wrists[t].rotation).to_degrees());
            out.wrists[t].rotation = r;
        }
    }

    if params.joint_half_window > 0 {
        let (lo, hi) = extended(params.joint_half_window);
        let dof = hand.dof;
        let mut column = Vec::with_capacity(hi + 1 - lo);
        for j in 0..dof {
            column.clear();
            column.extend((lo..=hi).map(|t| hand.joints[t * dof + j]));
            let mean = windowed_mean(&column, params.joint_half_window)?;
            for t in a..=b {
                let v = mean[t - lo];
                stats.max_joint = stats.max_joint.max((v - hand.joints[t * dof + j]).abs());
                out.joints[t * dof + j] = v;
            }
        }
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    Ok((out, stats))
}

/// One grasp for the frames of `range` (the contact segment): the hand's pose in the
/// object's frame, `O(t)⁻¹·W(t)`, and its joints are averaged over the frames of `over` (the
/// whole range, or from the carry on where the hand is still closing before it, [`carried`];
/// positions and joint angles by their mean, rotations by Markley's average) and the average
/// is placed on the object at every frame of `range`, `W(t) = O(t)·Ḡ`. A per-frame IK follows its correspondences frame by frame, and
/// where they drift (a tracking error shared by a frame's points) the hand slides on the
/// object; a held grasp does not. Joints are clamped by `clamp`. Frames outside the range are
/// untouched (fade them with [`ease_ends`]); `over` is cut to the range.
pub fn hold_grasp(
    hand: &mut HandPath,
    objects: &[Isometry3<f64>],
    range: RangeInclusive<usize>,
    over: RangeInclusive<usize>,
    clamp: impl Fn(&mut [f64]),
) -> Result<(), RotationError> {
    let (a, b) = (*range.start(), *range.end());
    if a > b || b >= hand.len() || objects.len() != hand.len() {
        return Ok(());
    }
    let (lo, hi) = ((*over.start()).max(a), (*over.end()).min(b));
    let (lo, hi) = if lo > hi { (a, b) } else { (lo, hi) };
    let rel: Vec<Isometry3<f64>> = (lo..=hi)
        .map(|t| objects[t].inverse() * hand.wrists[t])
        .collect();
    let m = rel.len() as f64;
    let position = rel
        .iter()
        .map(|r| r.translation.vector)
        .sum::<Vector3<f64>>()
        / m;
    let rotations: Vec<UnitQuaternion<f64>> = rel.iter().map(|r| r.rotation).collect();
    let rotation = crate::math::rotation::average_quaternions(&rotations, None)?;
    let held = Isometry3::from_parts(Translation3::from(position), rotation);
    let dof = hand.dof;
    let mut q = vec![0.0; dof];
    for t in lo..=hi {
        for (v, x) in q.iter_mut().zip(hand.q(t)) {
            *v += x / m;
        }
    }
    clamp(&mut q);
    for t in a..=b {
        hand.wrists[t] = objects[t] * held;
        hand.joints[t * dof..(t + 1) * dof].copy_from_slice(&q);
    }
    Ok(())
}

/// The frames of `range` (the contact segment) that carry the object: from the first frame
/// whose pose is more than `reach_m` or `reach_rad` from the pose at the range's first frame
/// to the last frame more than that from the pose at its last frame. Before and after, the
/// object rests (the hand closes on it, or lets it go); a grasp held before the carry is the
/// carry's grasp, pressed on the resting object whether the hand has closed or not. The whole
/// range when the object never moves that far.
pub fn carried(
    objects: &[Isometry3<f64>],
    range: RangeInclusive<usize>,
    reach_m: f64,
    reach_rad: f64,
) -> RangeInclusive<usize> {
    let (a, b) = (*range.start(), *range.end());
    if a > b || b >= objects.len() {
        return range;
    }
    let away = |from: &Isometry3<f64>, t: usize| {
        let d = from.inverse() * objects[t];
        d.translation.vector.norm() > reach_m || d.rotation.angle() > reach_rad
    };
    let first = (a..=b).find(|&t| away(&objects[a], t));
    let last = (a..=b).rev().find(|&t| away(&objects[b], t));
    match (first, last) {
        (Some(s), Some(e)) if s <= e => s..=e,
        _ => range,
    }
}

/// The share of the per-frame hand ([`release_held`]) at each frame of `range` while the
/// grasp is still closing before the carry that starts at frame `carry_start` ([`carried`]):
/// 1 before it, falling linearly to 0 over its first `frames` frames, 0 from then on.
pub fn closing_shares(range: RangeInclusive<usize>, carry_start: usize, frames: usize) -> Vec<f64> {
    let s = carry_start as f64;
    let n = frames.max(1) as f64;
    range
        .map(|t| ((s + n - t as f64) / n).clamp(0.0, 1.0))
        .collect()
}

/// Where the held grasp comes too near a barrier, the per-frame solution comes back as far
/// as the barrier asks: `share[t - start]` is the share of the per-frame hand frame `t` of
/// `range` needs (0 = the held grasp, 1 = the per-frame solution; see [`blend_toward`]).
/// A share `s` at frame `k` reaches the frames within `frames` of it with a weight falling
/// linearly to 0, `s · (1 − |t − k|/(frames + 1))`; a frame takes the largest it is asked.
/// Moving the hand only as far as it must keeps the grasp: a hand that slides along a
/// carried object drags it along. Returns the frames changed.
pub fn release_held(
    hand: &mut HandPath,
    per_frame: &HandPath,
    objects: &[Isometry3<f64>],
    range: RangeInclusive<usize>,
    share: &[f64],
    frames: usize,
) -> usize {
    let (a, b) = (*range.start(), *range.end());
    if a > b || b >= hand.len() || share.len() != b - a + 1 || per_frame.len() != hand.len() {
        return 0;
    }
    let m = share.len();
    let mut weight = vec![0.0_f64; m];
    for (k, &s) in share.iter().enumerate().filter(|(_, s)| **s > 0.0) {
        for (i, w) in weight
            .iter_mut()
            .enumerate()
            .take((k + frames).min(m - 1) + 1)
            .skip(k.saturating_sub(frames))
        {
            let fall = 1.0 - i.abs_diff(k) as f64 / (frames as f64 + 1.0);
            *w = w.max(s.min(1.0) * fall);
        }
    }
    let mut q = vec![0.0; hand.dof];
    let mut changed = 0;
    for t in (a..=b).filter(|t| weight[t - a] > 0.0) {
        let wrist = blend_toward(hand, per_frame, &objects[t], t, weight[t - a], &mut q);
        hand.wrists[t] = wrist;
        hand.joints[t * hand.dof..(t + 1) * hand.dof].copy_from_slice(&q);
        changed += 1;
    }
    changed
}

/// Frame `t`'s hand a share `w` of the way from `held` to `per_frame`, in the object's frame
/// (`object` is the object's pose at `t`): wrist translation and joints linearly, wrist
/// rotation by nlerp. Returns the wrist; the joints are written to `q`.
pub fn blend_toward(
    held: &HandPath,
    per_frame: &HandPath,
    object: &Isometry3<f64>,
    t: usize,
    w: f64,
    q: &mut [f64],
) -> Isometry3<f64> {
    let own = object.inverse() * per_frame.wrists[t];
    let rel = object.inverse() * held.wrists[t];
    let rel = Isometry3::from_parts(
        Translation3::from(rel.translation.vector.lerp(&own.translation.vector, w)),
        rel.rotation.nlerp(&own.rotation, w),
    );
    for ((v, h), o) in q.iter_mut().zip(held.q(t)).zip(per_frame.q(t)) {
        *v = h + w * (o - h);
    }
    object * rel
}

/// Stage 5c: no step at the ends of the contact segment. Inside `range` the hand is the
/// (smoothed) IK solution, outside it the rigid transfer `base`; where they differ at the
/// first and last frame of the range, the hand would jump between two output frames (a
/// jump of a kinematic hand knocks the object: the first frame after the release, or the
/// last before the grasp). The difference at each end, in the wrist frame and per joint, is
/// carried into the `frames` neighbouring frames outside the range with a weight falling
/// linearly from 1 to 0: frame `t` at `k` frames from the end gets
/// `base(t) · δ^{w}`, `q(t) + w·Δq`, `w = 1 − k/(frames + 1)`, joints clamped to their
/// limits. Returns the frames changed.
pub fn ease_ends(
    hand: &mut HandPath,
    base: &HandPath,
    range: RangeInclusive<usize>,
    frames: usize,
    clamp: impl Fn(&mut [f64]),
) -> usize {
    let (a, b) = (*range.start(), *range.end());
    let n = hand.len();
    if a > b || b >= n || base.len() != n || frames == 0 {
        return 0;
    }
    let dof = hand.dof;
    let mut changed = 0;
    for (edge, forward) in [(a, false), (b, true)] {
        let d_wrist = base.wrists[edge].inverse() * hand.wrists[edge];
        let d_q: Vec<f64> = hand
            .q(edge)
            .iter()
            .zip(base.q(edge))
            .map(|(h, b)| h - b)
            .collect();
        for k in 1..=frames {
            let t = if forward {
                edge + k
            } else if let Some(t) = edge.checked_sub(k) {
                t
            } else {
                break;
            };
            if t >= n || range.contains(&t) {
                break;
            }
            let w = 1.0 - k as f64 / (frames as f64 + 1.0);
            let delta = Isometry3::from_parts(
                Translation3::from(d_wrist.translation.vector * w),
                UnitQuaternion::identity().nlerp(&d_wrist.rotation, w),
            );
            hand.wrists[t] *= delta;
            let q = &mut hand.joints[t * dof..(t + 1) * dof];
            for (v, d) in q.iter_mut().zip(&d_q) {
                *v += w * d;
            }
            clamp(q);
            changed += 1;
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_the_same_time_at_every_frame_rate() {
        assert_eq!(Params::at_fps(30.0), Params::default());
        let at = |fps: f64| {
            let p = Params::at_fps(fps);
            (
                p.savgol_window,
                p.savgol_polyorder,
                p.rotation_half_window,
                p.joint_half_window,
            )
        };
        assert_eq!(at(10.0), (3, 2, 1, 1));
        assert_eq!(at(60.0), (17, 3, 4, 4));
        assert_eq!(at(120.0), (33, 3, 8, 8));
        // Below 7.5 fps the averages are off and the translation window stays at 3.
        assert_eq!(at(5.0), (3, 2, 0, 0));
    }

    /// At 10 fps the translation's 3-sample window of order 2 fits every sample exactly:
    /// a wrist path that jitters is left as it is (the averages still act).
    #[test]
    fn at_ten_fps_the_translation_filter_keeps_the_samples() {
        let n = 30;
        let mut hand = HandPath::with_capacity(n, 1);
        for i in 0..n {
            let x = i as f64 * 0.01 + if i % 2 == 0 { 1e-3 } else { -1e-3 };
            hand.push(Isometry3::translation(x, 0.0, 0.0), &[0.1 * (i % 3) as f64]);
        }
        let (out, stats) = run(&hand, 5..=24, &Params::at_fps(10.0)).unwrap();
        for t in 0..n {
            let d = (out.wrists[t].translation.vector - hand.wrists[t].translation.vector).norm();
            assert!(d < 1e-12, "frame {t} moved {d}");
        }
        assert!(
            stats.max_joint > 0.01,
            "the joint mean left the joints: {stats:?}"
        );
        // At 30 fps the 9-sample window smooths the same jitter away.
        let (out, _) = run(&hand, 5..=24, &Params::default()).unwrap();
        let d = (out.wrists[15].translation.vector - hand.wrists[15].translation.vector).norm();
        assert!(d > 5e-4, "moved {d}");
    }
}
