//! The baseline hand warp (docs/METHOD.md "Baseline", paper "Baseline comparison"): rigid SE(3)
//! transfer of the demonstrated hand, the kind of augmentation MimicGen-style methods do.
//!
//! For each in-contact input frame `s`, the hand's pose relative to the object,
//! `O(s)⁻¹·W(s)`, is placed on the warped object of that frame: `W'(s) = O'(s)·O(s)⁻¹·W(s)`,
//! at output time `τ(s)`. These are the only hand configurations known to be right. A cubic
//! B-spline through the wrist positions and joint angles, parameterized by `τ`, is sampled at
//! the integer output frames; the wrist rotation is slerped between the bracketing frames.
//! Where `τ` stretches time, the interpolated hand no longer follows the object: that is the
//! failure contact IK fixes. Outside the contact segment the hand moves with the object's
//! rigid shift (stage 1).

use nalgebra::Isometry3;

use super::HandPath;
use crate::math::bspline::BSpline;
use crate::model::Demo;
use crate::warp::ObjectWarp;

/// Why the baseline failed (degenerate numerical input only).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("baseline hand interpolation failed: {0}")]
pub struct BaselineFailure(pub String);

/// Runs the baseline on a demonstration (joints in robot order) and its object warp.
pub fn run(demo: &Demo, warp: &ObjectWarp) -> Result<HandPath, BaselineFailure> {
    let dof = demo.joint_names.len();
    let plan = &warp.plan;
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let tw = &warp.retime.timewarp;
    let warped = warp.warped_input();
    let mut out = HandPath::with_capacity(plan.frames_out(), dof);
    for f in &demo.frames[..c0] {
        out.push(warp.spatial.pre * f.wrist, &f.joints);
    }
    // Transferred hand at the in-contact input frames.
    let dim = 3 + dof;
    let m = c1 - c0 + 1;
    let mut points = Vec::with_capacity(m * dim);
    let mut wrists = Vec::with_capacity(m);
    for s in c0..=c1 {
        let f = &demo.frames[s];
        let w = warped.pose(s) * f.object.inverse() * f.wrist;
        points.extend_from_slice(w.translation.vector.as_slice());
        points.extend_from_slice(&f.joints);
        wrists.push(w);
    }
    let spline = BSpline::interpolate(&tw.tau[c0..=c1], &points, dim, 3)
        .map_err(|e| BaselineFailure(e.to_string()))?;
    let mut buf = vec![0.0; dim];
    for t in c0..=plan.t_end_new() {
        let tf = t as f64;
        spline.eval(tf, &mut buf);
        let s = tw.source_frame(tf).clamp(c0, c1);
        let rot = if s >= c1 {
            wrists[m - 1].rotation
        } else {
            let (ta, tb) = (tw.tau[s], tw.tau[s + 1]);
            let u = ((tf - ta) / (tb - ta)).clamp(0.0, 1.0);
            let (a, b) = (wrists[s - c0].rotation, wrists[s - c0 + 1].rotation);
            a.try_slerp(&b, u, 1e-12)
                .unwrap_or(if u < 0.5 { a } else { b })
        };
        let wrist = Isometry3::from_parts(nalgebra::Translation3::new(buf[0], buf[1], buf[2]), rot);
        out.push(wrist, &buf[3..]);
    }
    for f in &demo.frames[c1 + 1..] {
        out.push(warp.spatial.post * f.wrist, &f.joints);
    }
    Ok(out)
}
