//! `dexwarp validate`: the physics replay and report of any demonstration, warped or not.

use std::collections::BTreeMap;
use std::path::Path;

use super::checks;
use crate::geometry::Mesh;
use crate::metrics;
use crate::model::frames::FrameRow;
use crate::model::provenance::Provenance;
use crate::model::report::{
    Constraints, ContactDistance, Metrics, Pair, REPORT_FORMAT, Report, WorstFrame,
};
use crate::model::{Demo, Scene};
use crate::physics;
use crate::{Error, Limits, Result};

/// Replays any demonstration, warped or original, in physics and reports on it
/// (`dexwarp validate`): the physics verdict, D_WO, D_C and, for warped outputs, the timewarp
/// discrepancy. The scene is the demonstration's own (`scene`, `barriers` in the file) unless
/// `scene` is given.
pub fn validate(
    demo_path: &Path,
    scene: Option<&Path>,
    barriers: Option<&[String]>,
    params: &physics::Params,
    limits: &Limits,
) -> Result<(Report, Vec<FrameRow>)> {
    validate_demo(
        Demo::load(demo_path, limits)?,
        scene,
        barriers,
        params,
        limits,
    )
}

/// The hold test of the grasp recorded in the demonstration at `demo_path`
/// ([`physics::hold`], `dexwarp validate --grasp-only`): loaded and bound to its robot as
/// [`validate`] does; `None` when no frame has contacts.
pub fn grasp_hold(
    demo_path: &Path,
    params: &physics::Params,
    limits: &Limits,
) -> Result<Option<physics::GraspHold>> {
    let mut demo = Demo::load(demo_path, limits)?;
    let robot = demo.load_robot(limits)?;
    demo.check_robot(&robot)?;
    let mesh = Mesh::load(&demo.object.mesh, nalgebra::Vector3::repeat(1.0), limits)?;
    physics::hold(&robot, &demo, &mesh, params)
}

/// [`validate`] of a demonstration already in memory (the Python binding's entry point;
/// [`validate`] ends here too); messages and the report's provenance name [`Demo::source`].
pub fn validate_demo(
    mut demo: Demo,
    scene: Option<&Path>,
    barriers: Option<&[String]>,
    params: &physics::Params,
    limits: &Limits,
) -> Result<(Report, Vec<FrameRow>)> {
    let source = demo.source.clone();
    let demo_path = source.as_path();
    let robot = demo.load_robot(limits)?;
    demo.check_robot(&robot)?;
    let scene_path = match (scene, &demo.scene) {
        (Some(s), _) => s.to_path_buf(),
        (None, Some(s)) => s.clone(),
        (None, None) => {
            return Err(Error::invalid(
                demo_path,
                "scene",
                "the demonstration names no scene; give one with --scene (e.g. scenes/kitchen.json)",
            ));
        }
    };
    let scene = Scene::load(&scene_path, limits)?;
    let barriers: Vec<String> = barriers
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| demo.barriers.clone());
    for (j, b) in barriers.iter().enumerate() {
        if scene.item(b).is_none() {
            return Err(Error::invalid(
                demo_path,
                format!("barriers[{j}]"),
                format!("{b:?} is not an item of scene {}", scene_path.display()),
            ));
        }
    }
    let mesh = Mesh::load(&demo.object.mesh, nalgebra::Vector3::repeat(1.0), limits)?;
    checks::physics_work(limits, demo_path, demo.frames.len(), demo.fps, params)?;
    let report_p = physics::validate(&robot, &demo, &scene, &barriers, &mesh, params, limits)?;
    checks::physics(demo_path, &report_p)?;
    let dc = metrics::contact_distance_per_frame_mm(&robot, &demo);
    let n = demo.frames.len();
    let segment = demo.contact_segment();
    let frames: Vec<FrameRow> = (0..n)
        .map(|t| FrameRow {
            physics_position_error_mm: report_p.per_frame.position_error_mm.get(t).copied(),
            physics_rotation_error_deg: report_p.per_frame.rotation_error_deg.get(t).copied(),
            ..FrameRow::new(
                &demo,
                t,
                t,
                segment.is_some_and(|s| (s.start..=s.end).contains(&t)),
                dc[t],
            )
        })
        .collect();
    let mut timing_s = BTreeMap::new();
    timing_s.insert("physics".to_string(), report_p.timing_s.total);
    let report = Report {
        format: REPORT_FORMAT.into(),
        name: demo.name.clone(),
        frames_in: demo.timewarp.as_ref().map_or(n, Vec::len),
        frames_out: n,
        metrics: recorded_metrics(&demo, &dc),
        constraints: Constraints {
            object_radius_mm: mesh.bounding_radius() * 1e3,
            contact_gap_frames: segment.map_or(0, |s| s.gap_frames),
            ..Constraints::default()
        },
        physics: Some(report_p.to_summary()),
        timing_s,
        ..Report::default()
    };
    checks::metrics(demo_path, &report, &frames)?;
    let mut provenance = Provenance::new();
    provenance.input("demo", demo_path);
    provenance.input("scene", &scene_path);
    provenance.input("robot", &demo.robot);
    provenance.input("mesh", &demo.object.mesh);
    provenance.parameters("barriers", &barriers);
    provenance.parameters("physics", params);
    provenance.parameters("limits", limits);
    let report = Report {
        provenance: Some(provenance),
        ..report
    };
    Ok((report, frames))
}

/// The metrics of a demonstration judged as it is (no warp: original and output are the
/// same), from its per-frame contact distances `dc`.
fn recorded_metrics(demo: &Demo, dc: &[Option<f64>]) -> Metrics {
    let n = demo.frames.len();
    let d_c = metrics::d_c_mm(dc);
    let d_wo = metrics::d_wo_mm(demo);
    let discrepancy = demo
        .timewarp
        .as_ref()
        .map(|tau| {
            crate::warp::retime::Timewarp {
                tau: tau.clone(),
                frames_out: n,
            }
            .discrepancy()
        })
        .unwrap_or(0.0);
    Metrics {
        d_wo_mm: Pair {
            original: d_wo,
            warped: d_wo,
        },
        d_c_mm: ContactDistance {
            original: d_c,
            unsmoothed: d_c,
            warped: d_c,
            uncorrupted: None,
        },
        plr_object: 1.0,
        plr_hand: 1.0,
        timewarp_discrepancy: discrepancy,
        timewarp_discrepancy_paper: None,
        d_c_worst: metrics::worst_frame(dc).map(|(frame, d_c_mm)| WorstFrame { frame, d_c_mm }),
        grasp_slide_mm: metrics::grasp_slide_mm(demo).map(|v| Pair {
            original: v,
            warped: v,
        }),
        ..Metrics::default()
    }
}
