//! The object stages of the warp (docs/METHOD.md stages 1-3): spatial warp through waypoints,
//! barrier push-out, temporal retiming.

pub mod barrier;
pub mod plan;
pub mod retime;
pub mod spatial;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

pub use plan::{Anchor, WarpPlan};

/// Object poses over frames: position of the object origin [m] and orientation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectPath {
    pub positions: Vec<Vector3<f64>>,
    pub rotations: Vec<UnitQuaternion<f64>>,
}

impl ObjectPath {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no frames.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The pose of frame `i`.
    pub fn pose(&self, i: usize) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.positions[i]), self.rotations[i])
    }

    /// Builds a path from poses.
    pub fn from_poses<'a>(poses: impl IntoIterator<Item = &'a Isometry3<f64>>) -> Self {
        let (positions, rotations) = poses
            .into_iter()
            .map(|p| (p.translation.vector, p.rotation))
            .unzip();
        ObjectPath {
            positions,
            rotations,
        }
    }

    /// Polyline length of the positions [m].
    pub fn length(&self) -> f64 {
        self.positions
            .windows(2)
            .map(|w| (w[1] - w[0]).norm())
            .sum()
    }
}

/// Parameters of the three object stages.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObjectParams {
    pub spatial: spatial::Params,
    pub barrier: barrier::Params,
    pub retime: retime::Params,
}

impl ObjectParams {
    /// The parameters of the three object stages a config's parameters ask for.
    pub fn from_config(params: &crate::model::WarpParams) -> ObjectParams {
        ObjectParams {
            spatial: spatial::Params {
                alpha_m: params.alpha_m,
            },
            barrier: barrier::Params {
                mode: params.pushout,
                step_m: params.pushout_step_m,
                ..barrier::Params::default()
            },
            retime: retime::Params {
                mode: params.retime,
                continuous_speed: params.continuous_speed,
                ..retime::Params::default()
            },
        }
    }
}

/// Everything the object stages produce: the plan, each stage's output and stats.
#[derive(Clone, Debug)]
pub struct ObjectWarp {
    pub plan: WarpPlan,
    pub spatial: spatial::Output,
    pub barrier: barrier::Output,
    pub retime: retime::Output,
}

impl ObjectWarp {
    /// The warped object at every output frame.
    pub fn path(&self) -> &ObjectPath {
        &self.retime.path
    }

    /// The input frame whose correspondences output frame `t` uses: itself before the contact
    /// segment, `t* = τ⁻¹(t)` (the last input frame mapped at or before `t`) inside it, and the
    /// frame shifted back by `t'_end − c1` after it.
    pub fn source_frame(&self, t: usize) -> usize {
        let plan = &self.plan;
        let (c0, c1) = (plan.segment.start, plan.segment.end);
        if t < c0 {
            t
        } else if t <= plan.t_end_new() {
            self.retime.timewarp.source_frame(t as f64).clamp(c0, c1)
        } else {
            (t as i64 - plan.post_shift()) as usize
        }
    }

    /// The object path after stages 1 and 2, at the input frames (positions pushed out,
    /// rotations of stage 1): the warped pose of each input frame before retiming.
    pub fn warped_input(&self) -> ObjectPath {
        ObjectPath {
            positions: self.barrier.positions.clone(),
            rotations: self.spatial.path.rotations.clone(),
        }
    }
}

/// Runs stages 1-3 on the object path `input` (docs/METHOD.md): spatial warp through the anchors,
/// barrier push-out, retiming. `object_radius` is the bounding radius of the object mesh;
/// `config_source` names the config in conflict messages.
pub fn warp_object(
    input: &ObjectPath,
    plan: &WarpPlan,
    barriers: &[barrier::Barrier],
    object_radius: f64,
    params: &ObjectParams,
    config_source: &std::path::Path,
) -> crate::Result<ObjectWarp> {
    let spatial = spatial::run(input, plan, &params.spatial);
    let barrier = barrier::run(
        &spatial.path.positions,
        plan,
        barriers,
        object_radius,
        &params.barrier,
        config_source,
    )?;
    let pushed = ObjectPath {
        positions: barrier.positions.clone(),
        rotations: spatial.path.rotations.clone(),
    };
    let retime = retime::run(
        &input.positions,
        &pushed,
        plan,
        object_radius,
        &params.retime,
    )
    .map_err(|e| crate::Error::invalid(config_source, "(retiming)", e.to_string()))?;
    Ok(ObjectWarp {
        plan: plan.clone(),
        spatial,
        barrier,
        retime,
    })
}
