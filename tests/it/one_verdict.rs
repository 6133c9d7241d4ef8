//! One verdict per trajectory file: `warp`'s in-process replay and `validate` of the file
//! `warp` wrote simulate the same input, so their physics reports agree apart from timing.
//!
//! The check is in two parts. On every built-in config, for contact IK and for the
//! baseline (no physics, fast): the demonstration `warp` replays
//! ([`Demo::as_stored`]) is the one [`Demo::load`] reads from the saved file, every pose,
//! joint value, frame rate, mass, barrier and asset path to the bit (the scene, the mesh
//! and the physics parameters are then the same files and defaults on both sides). On two
//! configs, one of them the trajectory whose verdict flipped between the two commands
//! before the fix (fryingpan_onto_shelf, baseline: pass in `warp`, slip in `validate`),
//! the two reports themselves are compared.

use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::model::Demo;
use dexwarp::model::report::PhysicsSummary;
use dexwarp::physics::Params;
use dexwarp::pipeline::{self, HandMethod, Inputs, Options, PhysicsOptions};
use nalgebra::Isometry3;
use rayon::prelude::*;

use crate::physics_regression::config_paths;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn pose_bits(p: &Isometry3<f64>) -> [u64; 7] {
    let t = p.translation.vector;
    let q = p.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w].map(f64::to_bits)
}

/// Why `a` and `b` are not the same replay input, or `None`.
fn difference(a: &Demo, b: &Demo) -> Option<String> {
    let canon = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    if a.fps.to_bits() != b.fps.to_bits() || a.object.mass.to_bits() != b.object.mass.to_bits() {
        return Some("fps or mass".into());
    }
    if a.barriers != b.barriers
        || a.joint_names != b.joint_names
        || a.frames.len() != b.frames.len()
    {
        return Some("barriers, joint names or frame count".into());
    }
    if canon(&a.robot) != canon(&b.robot)
        || canon(&a.object.mesh) != canon(&b.object.mesh)
        || a.scene.as_deref().map(canon) != b.scene.as_deref().map(canon)
    {
        return Some("robot, mesh or scene file".into());
    }
    for (i, (fa, fb)) in a.frames.iter().zip(&b.frames).enumerate() {
        let joints =
            |f: &dexwarp::model::Frame| f.joints.iter().map(|q| q.to_bits()).collect::<Vec<_>>();
        if pose_bits(&fa.object) != pose_bits(&fb.object)
            || pose_bits(&fa.wrist) != pose_bits(&fb.wrist)
            || joints(fa) != joints(fb)
            || fa.contacts.len() != fb.contacts.len()
        {
            return Some(format!("frame {i}"));
        }
    }
    None
}

fn warp(config: &Path, hand: HandMethod, physics: bool) -> (Inputs, pipeline::WarpRun) {
    let limits = Limits::default();
    let inputs = Inputs::load(config, None, &limits).unwrap();
    let options = Options::new(hand)
        .physics(physics.then(PhysicsOptions::default))
        .limits(limits);
    let run = pipeline::warp(&inputs, &options).unwrap();
    (inputs, run)
}

#[test]
fn warp_replays_exactly_the_file_validate_reads() {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::default();
    let jobs: Vec<(PathBuf, HandMethod)> = config_paths()
        .into_iter()
        .flat_map(|c| [(c.clone(), HandMethod::Contact), (c, HandMethod::Baseline)])
        .collect();
    assert!(
        jobs.len() >= 38,
        "the 19 built-in configs, two hand methods: {}",
        jobs.len()
    );
    let bad: Vec<String> = jobs
        .par_iter()
        .filter_map(|(config, hand)| {
            let (inputs, run) = warp(config, *hand, false);
            let path = dir
                .path()
                .join(format!("{}-{hand:?}.demo.json", inputs.config.name));
            run.demo.save(&path).unwrap();
            let replayed = run.demo.as_stored(&limits).unwrap();
            let read = Demo::load(&path, &limits).unwrap();
            difference(&replayed, &read).map(|d| format!("{} {hand:?}: {d}", inputs.config.name))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "warp would replay another input than validate reads:\n{}",
        bad.join("\n")
    );
}

/// The physics summary without its wall times and the in-process cache flag.
fn comparable(s: &PhysicsSummary) -> PhysicsSummary {
    let mut s = s.clone();
    s.measures.remove("timing_s");
    if let Some(r) = s.measures.get_mut("replay").and_then(|r| r.as_object_mut()) {
        r.remove("decomposition_cached");
    }
    s
}

#[test]
fn warp_and_validate_of_its_file_give_the_same_report() {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::default();
    let cases = [
        ("fryingpan_onto_shelf", HandMethod::Baseline),
        ("mug_pass_wall", HandMethod::Contact),
    ];
    cases.par_iter().for_each(|(name, hand)| {
        let config = root().join(format!("scenes/configs/{name}.json"));
        let (_, run) = warp(&config, *hand, true);
        let path = dir.path().join(format!("{name}.demo.json"));
        run.demo.save(&path).unwrap();
        let (report, _) =
            pipeline::validate(&path, None, None, &Params::default(), &limits).unwrap();
        let a = comparable(run.report.physics.as_ref().unwrap());
        let b = comparable(report.physics.as_ref().unwrap());
        assert_eq!(
            serde_json::to_value(&a).unwrap(),
            serde_json::to_value(&b).unwrap(),
            "{name} {hand:?}: warp says {} {:?}, validate of its file {} {:?}",
            a.verdict,
            a.reasons,
            b.verdict,
            b.reasons
        );
    });
}
