//! `dexwarp import`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

/// Make a dexwarp.demo/1 file from a recording: a CSV of frames (optionally a CSV of
/// contacts), or one episode of a LeRobot v3 dataset; correspondences are extracted
/// geometrically when not given.
#[derive(Debug, Args)]
#[command(
    after_help = "CSV columns: object.x,object.y,object.z,object.qw,object.qx,object.qy,object.qz, wrist.x..wrist.qz, one column per actuated joint of the URDF (see the README).\n\nExamples:\n  dexwarp import --csv rec.csv --fps 30 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --csv rec.csv --contacts rec.contacts.csv --fps 30 --robot robots/human_hand.urdf --mesh mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --lerobot out/dataset --episode 3 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/ep3.demo.json"
)]
pub struct ImportArgs {
    /// Frames CSV.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["lerobot", "keypoints"],
        required_unless_present_any = ["lerobot", "keypoints"]
    )]
    csv: Option<PathBuf>,
    /// A recorded human hand: per frame the object pose and 21 hand keypoints (see
    /// docs/FORMATS.md); retargeted onto --robot, kept out of the object and the table.
    #[arg(long, value_name = "FILE", conflicts_with = "lerobot")]
    keypoints: Option<PathBuf>,
    /// The recorded hand with --keypoints; a left hand is mirrored onto the (right) robot hand.
    #[arg(long, value_enum, requires = "keypoints", default_value = "right")]
    handedness: dexwarp::import::keypoints::Handedness,
    /// Where the keypoints sit on --robot (JSON, docs/FORMATS.md); default the built-in
    /// human hand's.
    #[arg(long, value_name = "FILE", requires = "keypoints")]
    keypoint_map: Option<PathBuf>,
    /// A scene the demonstration names (its supports and barriers; with --keypoints instead
    /// of the table inferred from the recording).
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Retargeting parameters (JSON: touch and release distances, regrasps, smoothing;
    /// docs/FORMATS.md); absent fields keep their defaults.
    #[arg(long, value_name = "FILE", requires = "keypoints")]
    retarget: Option<PathBuf>,
    /// Keep the retargeted hand as it is inside the contact segment: no contact refinement
    /// (the warp's contact IK on the recorded correspondences).
    #[arg(long, requires = "keypoints")]
    no_refine: bool,
    /// Use the convex hull of an object mesh that is open and cannot be repaired.
    #[arg(long)]
    hull_fallback: bool,
    /// With --csv or --lerobot: write the recorded hand as it is (no smoothing, no way out of
    /// the object and the table, no inferred table, the mesh as given).
    #[arg(long, conflicts_with = "keypoints")]
    no_clean: bool,
    /// With --csv or --lerobot: Savitzky-Golay window of the hand's smoothing [frames, odd];
    /// 1 turns it off.
    #[arg(long, value_name = "FRAMES", default_value_t = 7, conflicts_with_all = ["keypoints", "no_clean"])]
    smoothing_window: usize,
    /// Contacts CSV for --csv (frame, link, hand_x..z, object_x..z).
    #[arg(long, value_name = "FILE", requires = "csv")]
    contacts: Option<PathBuf>,
    /// Frame rate of the CSV [Hz].
    #[arg(long, value_name = "HZ")]
    fps: Option<f64>,
    /// A LeRobot v3 dataset folder.
    #[arg(long, value_name = "DIR")]
    lerobot: Option<PathBuf>,
    /// Episode of the LeRobot dataset.
    #[arg(long, value_name = "N", default_value_t = 0)]
    episode: usize,
    /// LeRobot feature holding the wrist pose (7) then the joints.
    #[arg(long, value_name = "KEY", default_value = "observation.state")]
    state_key: String,
    /// LeRobot feature holding the object pose (7).
    #[arg(
        long,
        value_name = "KEY",
        default_value = "observation.environment_state"
    )]
    object_key: String,
    /// URDF of the hand.
    #[arg(long, value_name = "URDF")]
    robot: PathBuf,
    /// Object mesh (OBJ or STL).
    #[arg(long, value_name = "FILE")]
    mesh: PathBuf,
    /// Object mass [kg].
    #[arg(long, value_name = "KG")]
    mass: f64,
    /// Name of the demonstration (default: the output file's stem).
    #[arg(long, value_name = "NAME")]
    name: Option<String>,
    /// Output demonstration file.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

pub fn run(args: ImportArgs, limits: Limits) -> Result<()> {
    let ImportArgs {
        csv,
        keypoints,
        handedness,
        keypoint_map,
        scene,
        retarget,
        no_refine,
        hull_fallback,
        no_clean,
        smoothing_window,
        contacts,
        fps,
        lerobot,
        episode,
        state_key,
        object_key,
        robot,
        mesh,
        mass,
        name,
        out,
    } = args;
    let target = dexwarp::import::Target {
        name,
        robot,
        mesh,
        mass,
        object_name: None,
        out: out.clone(),
    };
    if let Some(frames) = keypoints {
        let Some(fps) = fps else {
            anyhow::bail!(
                "--fps is required with --keypoints: the frame rate of the recording [Hz]"
            );
        };
        let options = dexwarp::import::KeypointOptions {
            fps,
            handedness,
            keypoint_map,
            hull_fallback,
            scene,
            refine: !no_refine,
            params: match &retarget {
                Some(p) => {
                    let params: dexwarp::import::keypoints::Params =
                        dexwarp::model::json::read_json(p, &limits)?;
                    params.check(p)?;
                    Some(params)
                }
                None => None,
            },
        };
        let import = dexwarp::import::import_keypoints(&frames, &options, &target, &limits)?;
        report_keypoints(&out, &target.mesh, &import);
        return Ok(());
    }
    if hull_fallback && no_clean {
        anyhow::bail!(
            "--hull-fallback does not apply with --no-clean (the mesh is named as given); set physics.decomposition.hull_fallback in the config"
        );
    }
    if smoothing_window == 0 || smoothing_window.is_multiple_of(2) {
        anyhow::bail!(
            "--smoothing-window must be odd (1 turns the smoothing off), got {smoothing_window}"
        );
    }
    let clean = (!no_clean).then_some(dexwarp::import::CleanOptions {
        smoothing_window,
        hull_fallback,
        scene: None,
    });
    let (demo, cleaned) = match (csv, lerobot) {
        (Some(csv), _) => {
            let Some(fps) = fps else {
                anyhow::bail!("--fps is required with --csv: the frame rate of the recording [Hz]");
            };
            dexwarp::import::import_csv(
                &csv,
                contacts.as_deref(),
                fps,
                scene.as_deref(),
                clean.as_ref(),
                &target,
                &limits,
            )?
        }
        (None, Some(root)) => dexwarp::import::import_lerobot(
            &root,
            episode,
            &dexwarp::import::LerobotMapping {
                state_key,
                object_key,
            },
            scene.as_deref(),
            clean.as_ref(),
            &target,
            &limits,
        )?,
        (None, None) => anyhow::bail!("give --csv FILE or --lerobot DIR"),
    };
    match cleaned {
        Some(import) => report_cleaned(&target.mesh, &import),
        None => report_mesh_as_given(&target.mesh, &limits),
    }
    report_import(&out, &demo);
    Ok(())
}

/// What an import with `--no-clean` leaves to the object mesh as given, on stderr.
fn report_mesh_as_given(mesh_path: &std::path::Path, limits: &dexwarp::Limits) {
    // The mesh the demonstration names as given: every later command repairs it the same way
    // in memory (or refuses it), and says so; say it here first.
    if let Ok(mesh) =
        dexwarp::geometry::Mesh::load(mesh_path, nalgebra::Vector3::repeat(1.0), limits)
        && let (_, Some(repair)) = dexwarp::geometry::hull::solid_mesh(&mesh)
    {
        eprintln!(
            "{}: the object mesh is not closed and outward as given: {repair}; {}",
            mesh_path.display(),
            if repair.closed {
                "every command uses it so repaired"
            } else {
                "physics refuses it unless physics.decomposition.hull_fallback is set"
            }
        );
    }
}

/// What the cleaning of a `--csv` or `--lerobot` import did, on stderr.
fn report_cleaned(given: &std::path::Path, import: &dexwarp::import::RobotImport) {
    report_placement(given, &import.placement);
    for w in &import.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "cleaned: smoothed over {} frames; hand taken out of the object or the table on {} frames; deepest in the object {:.2} mm (recorded {:.2} mm); the hand's surface {:.1} mm from the recording on average, {:.1} mm at most; {:.1} s",
        import.smoothing_window,
        import.frames_moved,
        import.max_penetration_mm,
        import.max_penetration_recorded_mm,
        import.residual_mean_mm,
        import.residual_max_mm,
        import.time_s
    );
}

/// The summary of a `--csv` or `--lerobot` import on stderr.
fn report_import(out: &std::path::Path, demo: &dexwarp::model::Demo) {
    let with = demo
        .frames
        .iter()
        .filter(|f| !f.contacts.is_empty())
        .count();
    eprintln!(
        "wrote {}: {} frames at {} Hz, {with} with correspondences{}",
        out.display(),
        demo.frames.len(),
        demo.fps,
        demo.scene
            .as_ref()
            .map(|s| format!("; scene {}", s.display()))
            .unwrap_or_default()
    );
}

/// The summary of a keypoint import on stderr.
fn report_keypoints(
    out: &std::path::Path,
    given: &std::path::Path,
    import: &dexwarp::import::KeypointImport,
) {
    let demo = &import.demo;
    if import.mirrored {
        eprintln!("the left hand was mirrored onto the right robot hand (object mirrored too)");
    }
    report_placement(given, &import.placement);
    if let Some(r) = &import.refinement {
        eprintln!(
            "contact refinement: D_C {:.1} mm -> {:.2} mm{} (IK at its threshold on {}), {:.1} s",
            r.d_c_before_mm,
            r.d_c_refined_mm,
            if r.kept {
                String::new()
            } else if r.d_c_refined_mm < r.d_c_before_mm {
                format!(
                    ", not kept: the hand went deeper in the object ({:.2} mm against {:.2} mm)",
                    r.depth_refined_mm, r.depth_before_mm
                )
            } else {
                ", not kept: the retargeted hand was closer".into()
            },
            r.ik_converged_fraction.map_or("no".into(), |f| format!(
                "{:.0} % of the contact frames",
                f * 100.0
            )),
            r.time_s
        );
    }
    for w in &import.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "wrote {}: {} frames at {} Hz; the recorded hand touches on frames {}; keypoint residual {:.1} mm mean, {:.1} mm largest; deepest in the object {:.2} mm; {:.1} s",
        out.display(),
        demo.frames.len(),
        demo.fps,
        import
            .touch_frames
            .map_or("none".into(), |[a, b]| format!("{a}-{b}")),
        import.residual_mean_mm,
        import.residual_max_mm,
        import.max_penetration_mm,
        import.time_s
    );
}

/// What an import did to the object's mesh and where it put it, on stderr.
fn report_placement(given: &std::path::Path, placement: &dexwarp::import::Placement) {
    let (mesh, scene) = (&placement.mesh, &placement.scene);
    if let Some(r) = &placement.mesh_repair {
        eprintln!(
            "object mesh {} repaired: {r}; written to {}",
            given.display(),
            mesh.display()
        );
    }
    if let Some([h, m]) = placement.hull_volumes_cm3 {
        eprintln!(
            "object mesh {} replaced by its convex hull ({h:.1} cm³ against the mesh's {m:.1} cm³), written to {}",
            given.display(),
            mesh.display()
        );
    }
    if let Some(z) = placement.table_top_z_m {
        eprintln!("table inferred at z = {z:.3} m: {}", scene.display());
    }
    if let Some(r) = &placement.rest_correction {
        let said = |corrected: bool| {
            if corrected {
                "moved there"
            } else {
                "kept: it does not rest there"
            }
        };
        eprintln!(
            "rest poses settled on the table: first {:.1} mm, {:.1}° ({}); last {:.1} mm, {:.1}° ({})",
            r.start_mm,
            r.start_deg,
            said(r.start_corrected),
            r.end_mm,
            r.end_deg,
            said(r.end_corrected)
        );
    }
}
