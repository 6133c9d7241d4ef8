//! Paths a command is given relative to the working directory are written into its
//! outputs relative to the output file, so the outputs load from anywhere.

use std::path::Path;

use crate::fixtures::{gripper_fixture, repo, stderr};

/// The path a demonstration file names under `field` (`robot`, `object.mesh`, `scene`),
/// resolved as a reader does: relative to the file's folder.
fn named(demo: &Path, pointer: &str) -> std::path::PathBuf {
    let d: serde_json::Value = serde_json::from_slice(&std::fs::read(demo).unwrap()).unwrap();
    let written = d
        .pointer(pointer)
        .and_then(|v| v.as_str())
        .unwrap_or_else(|| panic!("{}: no {pointer}", demo.display()));
    demo.parent().unwrap().join(written)
}

#[test]
fn warp_with_a_relative_demo_and_out_writes_paths_that_resolve() {
    let dir = tempfile::tempdir().unwrap();
    // The demonstration, its config and scene in a folder of their own; every path on the
    // command line is relative to the working directory, which is that folder's parent.
    let inputs = dir.path().join("inputs");
    std::fs::create_dir(&inputs).unwrap();
    gripper_fixture(&inputs);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_dexwarp"))
        .current_dir(dir.path())
        .args([
            "warp",
            "--config",
            "inputs/lift.config.json",
            "--demo",
            "inputs/box.demo.json",
            "--out",
            "runs/new/out",
            "--hand",
            "baseline",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("runs/new/out/box_lift.demo.json");
    let canon = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|e| panic!("{} does not resolve: {e}", p.display()))
    };
    assert_eq!(
        canon(&named(&out, "/robot")),
        canon(&repo("robots/parallel_gripper.urdf"))
    );
    assert_eq!(
        canon(&named(&out, "/object/mesh")),
        canon(&repo("scenes/objects/small_box.obj"))
    );
    assert_eq!(
        canon(&named(&out, "/scene")),
        canon(&inputs.join("scene.json"))
    );
    // And the output loads as it is, from another working directory.
    let o = crate::fixtures::dexwarp(&[
        "validate",
        out.to_str().unwrap(),
        "--out",
        dir.path().join("check").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
