//! `export` and `import`: a LeRobot v3 dataset read back through the parquet crate frame by
//! frame and column by column, CSV import errors, and import -> export -> import.

use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::export::lerobot::{self, Column};
use dexwarp::model::demo::Demo;
use serde_json::Value;

use crate::fixtures::{dexwarp, gripper_fixture, repo, stderr};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn state_of(d: &Demo, i: usize) -> Vec<f64> {
    let f = &d.frames[i];
    let t = f.wrist.translation.vector;
    let q = f.wrist.rotation.quaternion();
    let mut v = vec![t.x, t.y, t.z, q.w, q.i, q.j, q.k];
    v.extend(&f.joints);
    v.iter().map(|&x| x as f32 as f64).collect()
}

fn object_of(d: &Demo, i: usize) -> Vec<f64> {
    let f = &d.frames[i];
    let t = f.object.translation.vector;
    let q = f.object.rotation.quaternion();
    [t.x, t.y, t.z, q.w, q.i, q.j, q.k]
        .iter()
        .map(|&x| x as f32 as f64)
        .collect()
}

fn float(t: &lerobot::Table, name: &str, row: usize) -> Option<f64> {
    match &t.columns[name] {
        Column::Floats(v) => v[row],
        c => panic!("{name} is {c:?}"),
    }
}

fn string(t: &lerobot::Table, name: &str, row: usize) -> String {
    match &t.columns[name] {
        Column::Strings(v) => v[row].clone().unwrap_or_default(),
        c => panic!("{name} is {c:?}"),
    }
}

/// Two warps of the gripper fixture (contact IK and baseline), with physics, in `dir/runs`.
/// LeRobot's per-episode `stats/<feature>/<stat>` columns: present for every feature of
/// `meta/stats.json`, and recombined as LeRobot's `aggregate_stats` does (counts summed,
/// extremes of extremes, count-weighted means, pooled variance) they give its statistics.
fn per_episode_stats_recombine_to_the_dataset_stats(out: &Path, eps: &lerobot::Table) {
    let stats: Value =
        serde_json::from_slice(&std::fs::read(out.join("meta/stats.json")).unwrap()).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    for feature in lerobot::STATS_FEATURES {
        let col = |stat: &str| {
            eps.vectors(out, &format!("stats/{feature}/{stat}"))
                .unwrap()
                .to_vec()
        };
        let (min, max, mean, std, count) = (
            col("min"),
            col("max"),
            col("mean"),
            col("std"),
            col("count"),
        );
        for q in ["q01", "q10", "q50", "q90", "q99"] {
            assert_eq!(col(q).len(), eps.rows, "{feature} {q}");
        }
        let want = &stats[feature];
        let n: f64 = count.iter().map(|c| c[0]).sum();
        assert_eq!(want["count"][0].as_f64().unwrap(), n, "{feature}");
        for j in 0..mean[0].len() {
            let total_mean = (0..eps.rows).map(|e| count[e][0] * mean[e][j]).sum::<f64>() / n;
            let var = (0..eps.rows)
                .map(|e| count[e][0] * (std[e][j].powi(2) + (mean[e][j] - total_mean).powi(2)))
                .sum::<f64>()
                / n;
            let lo = (0..eps.rows)
                .map(|e| min[e][j])
                .fold(f64::INFINITY, f64::min);
            let hi = (0..eps.rows)
                .map(|e| max[e][j])
                .fold(f64::NEG_INFINITY, f64::max);
            let got = |k: &str| want[k][j].as_f64().unwrap();
            assert!(close(got("mean"), total_mean), "{feature}[{j}] mean");
            assert!(
                close(got("std"), var.sqrt()),
                "{feature}[{j}] std {} vs {}",
                got("std"),
                var.sqrt()
            );
            assert_eq!((got("min"), got("max")), (lo, hi), "{feature}[{j}]");
        }
    }
}

fn small_batch(dir: &Path) -> std::path::PathBuf {
    let config = gripper_fixture(dir);
    let runs = dir.join("runs");
    for (hand, sub) in [("contact", "a"), ("baseline", "b")] {
        let o = dexwarp(&[
            "warp",
            "--config",
            s(&config),
            "--out",
            s(&runs.join(sub)),
            "--hand",
            hand,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    runs
}

#[test]
fn lerobot_export_reads_back_every_frame_and_quality_column() {
    let dir = tempfile::tempdir().unwrap();
    let runs = small_batch(dir.path());
    let out = dir.path().join("dataset");
    let o = dexwarp(&["export", s(&runs), "--format", "lerobot", "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // No temporaries left beside the dataset.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains("dexwarp-tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    let ds = lerobot::read(&out).unwrap();
    let limits = Limits::default();
    let reports: Vec<Value> = ["a", "b"]
        .iter()
        .map(|k| {
            serde_json::from_slice(&std::fs::read(runs.join(k).join("report.json")).unwrap())
                .unwrap()
        })
        .collect();
    let demos: Vec<Demo> = ["a", "b"]
        .iter()
        .map(|k| Demo::load(&runs.join(k).join("box_lift.demo.json"), &limits).unwrap())
        .collect();
    let info = &ds.info;
    assert_eq!(info["codebase_version"], "v3.0");
    assert_eq!(info["fps"], 30);
    assert_eq!(info["robot_type"], "parallel_gripper");
    assert_eq!(info["total_episodes"], 2);
    assert_eq!(info["video_path"], Value::Null);
    let total: usize = demos.iter().map(|d| d.frames.len()).sum();
    assert_eq!(info["total_frames"], total);
    assert_eq!(info["features"]["observation.state"]["shape"][0], 8);
    assert_eq!(
        info["features"]["observation.state"]["names"][7],
        "finger_joint1"
    );
    assert_eq!(ds.frames.rows, total);

    // Every frame, as written.
    let data = out.join("data");
    let state = ds.frames.vectors(&data, "observation.state").unwrap();
    let env = ds
        .frames
        .vectors(&data, "observation.environment_state")
        .unwrap();
    let action = ds.frames.vectors(&data, "action").unwrap();
    let ep = ds.frames.ints(&data, "episode_index").unwrap();
    let fi = ds.frames.ints(&data, "frame_index").unwrap();
    let idx = ds.frames.ints(&data, "index").unwrap();
    let Column::Floats(ts) = &ds.frames.columns["timestamp"] else {
        panic!("timestamp is not a float column");
    };
    let mut row = 0;
    for (e, d) in demos.iter().enumerate() {
        let n = d.frames.len();
        for i in 0..n {
            assert_eq!(
                (ep[row], fi[row], idx[row]),
                (e as i64, i as i64, row as i64)
            );
            assert_eq!(state[row], state_of(d, i), "episode {e} frame {i}");
            assert_eq!(env[row], object_of(d, i), "episode {e} frame {i}");
            assert_eq!(
                action[row],
                state_of(d, (i + 1).min(n - 1)),
                "episode {e} frame {i}"
            );
            assert_eq!(ts[row], Some((i as f64 / 30.0) as f32 as f64));
            row += 1;
        }
    }

    // Every quality column, as in the reports.
    let eps = &ds.episodes;
    assert_eq!(eps.rows, 2);
    per_episode_stats_recombine_to_the_dataset_stats(&out, eps);
    let from = eps.ints(&out, "dataset_from_index").unwrap();
    let to = eps.ints(&out, "dataset_to_index").unwrap();
    assert_eq!(
        (from[1], to[1]),
        (demos[0].frames.len() as i64, total as i64)
    );
    for (e, r) in reports.iter().enumerate() {
        let m = &r["metrics"];
        assert_eq!(
            string(eps, "quality/verdict", e),
            r["physics"]["verdict"].as_str().unwrap()
        );
        assert_eq!(string(eps, "quality/name", e), "box_lift");
        assert_eq!(
            float(eps, "quality/d_c_mm", e),
            m["d_c_mm"]["warped"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/d_c_original_mm", e),
            m["d_c_mm"]["original"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/d_wo_mm", e),
            m["d_wo_mm"]["warped"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/plr_object", e),
            m["plr_object"].as_f64()
        );
        assert_eq!(float(eps, "quality/plr_hand", e), m["plr_hand"].as_f64());
        assert_eq!(
            float(eps, "quality/timewarp_discrepancy", e),
            m["timewarp_discrepancy"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/physics_hand_object_penetration_mm", e),
            r["physics"]["penetration"]["hand_object"]["max_mm"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/tracking_max_position_error_mm", e),
            r["physics"]["tracking"]["max_position_error_mm"].as_f64()
        );
        assert_eq!(
            float(eps, "quality/ik_converged_fraction", e),
            r["ik"]["converged_fraction"].as_f64()
        );
        assert!(string(eps, "quality/source_demo", e).ends_with("box.demo.json"));
        assert!(string(eps, "quality/config", e).ends_with("lift.config.json"));
        let Column::StringLists(reasons) = &eps.columns["quality/failure_reasons"] else {
            panic!("failure_reasons is not a list of strings");
        };
        let want: Vec<String> = r["physics"]["reasons"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect();
        assert_eq!(reasons[e], want);
        let Column::Bools(passed) = &eps.columns["quality/passed"] else {
            panic!("passed is not boolean");
        };
        assert_eq!(passed[e], Some(r["physics"]["verdict"] == "pass"));
        let Column::Bools(robust) = &eps.columns["quality/robust"] else {
            panic!("robust is not boolean");
        };
        assert_eq!(robust[e], None, "no margin in these reports");
    }
    let tasks = lerobot::read_parquet(&out.join("meta/tasks.parquet")).unwrap();
    assert_eq!(tasks.rows, 1);
    assert_eq!(string(&tasks, "task", 0), "small_box: box_lift");
    let stats: Value =
        serde_json::from_slice(&std::fs::read(out.join("meta/stats.json")).unwrap()).unwrap();
    assert_eq!(stats["observation.state"]["count"][0], total);
    assert_eq!(stats["index"]["max"][0], (total - 1) as f64);

    // The same values through an independent reader, pyarrow, when CI provides one.
    pyarrow_readback(&out, &demos, &reports);

    // --only-passing keeps exactly the passing trajectories; an existing OUT is refused.
    let passing = reports
        .iter()
        .filter(|r| r["physics"]["verdict"] == "pass")
        .count();
    let out2 = dir.path().join("passing");
    let o = dexwarp(&[
        "export",
        s(&runs),
        "--format",
        "lerobot",
        "--only-passing",
        "--out",
        s(&out2),
    ]);
    if passing == 0 {
        assert!(
            !o.status.success() && stderr(&o).contains("no trajectory"),
            "{}",
            stderr(&o)
        );
    } else {
        assert!(o.status.success(), "{}", stderr(&o));
        let info: Value =
            serde_json::from_slice(&std::fs::read(out2.join("meta/info.json")).unwrap()).unwrap();
        assert_eq!(info["total_episodes"], passing);
    }
    // --only-robust: these reports have no margin, so nothing is exported and the skip says
    // why; a run with --margin is exported exactly when its margin holds.
    let out3 = dir.path().join("robust");
    let robust_only = |input: &Path| {
        dexwarp(&[
            "export",
            s(input),
            "--format",
            "lerobot",
            "--only-robust",
            "--out",
            s(&out3),
        ])
    };
    let o = robust_only(&runs);
    assert!(
        !o.status.success() && stderr(&o).contains("no trajectory"),
        "{}",
        stderr(&o)
    );
    if passing > 0 {
        assert!(
            stderr(&o).contains("write it with --margin"),
            "{}",
            stderr(&o)
        );
    }
    let margin_runs = dir.path().join("margin_runs");
    // The built-in gripper pick and place holds under every condition of the margin.
    let config = repo("scenes/configs/gripper_box_waypoints.json");
    let o = dexwarp(&[
        "warp",
        "--config",
        s(&config),
        "--out",
        s(&margin_runs.join("c")),
        "--margin",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: Value =
        serde_json::from_slice(&std::fs::read(margin_runs.join("c").join("report.json")).unwrap())
            .unwrap();
    let robust = report["physics"]["robust"].as_bool().expect("a margin");
    let o = robust_only(&margin_runs);
    assert_eq!(o.status.success(), robust, "{}", stderr(&o));
    if robust {
        let info: Value =
            serde_json::from_slice(&std::fs::read(out3.join("meta/info.json")).unwrap()).unwrap();
        assert_eq!(info["total_episodes"], 1);
        let ds = lerobot::read(&out3).unwrap();
        let Column::Bools(flags) = &ds.episodes.columns["quality/robust"] else {
            panic!("robust is not boolean");
        };
        assert_eq!(flags, &[Some(true)]);
    } else {
        assert!(stderr(&o).contains("not robust: "), "{}", stderr(&o));
    }
    let o = dexwarp(&["export", s(&runs), "--format", "lerobot", "--out", s(&out)]);
    assert!(
        !o.status.success() && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
}

/// The gripper fixture's demonstration as a frames CSV.
fn write_csv(demo: &Demo, path: &Path, drop: Option<&str>, edit: impl Fn(usize, &mut Vec<String>)) {
    let mut header: Vec<String> = ["object", "wrist"]
        .iter()
        .flat_map(|p| ["x", "y", "z", "qw", "qx", "qy", "qz"].map(|c| format!("{p}.{c}")))
        .collect();
    header.extend(demo.joint_names.iter().cloned());
    let keep: Vec<bool> = header.iter().map(|h| Some(h.as_str()) != drop).collect();
    let mut text = String::new();
    let line = |cells: Vec<String>| -> String {
        cells
            .into_iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(c, _)| c)
            .collect::<Vec<_>>()
            .join(",")
    };
    text.push_str(&line(header.clone()));
    text.push('\n');
    for (i, f) in demo.frames.iter().enumerate() {
        let mut cells = Vec::new();
        for iso in [&f.object, &f.wrist] {
            let t = iso.translation.vector;
            let q = iso.rotation.quaternion();
            cells.extend([t.x, t.y, t.z, q.w, q.i, q.j, q.k].map(|v| v.to_string()));
        }
        cells.extend(f.joints.iter().map(|v| v.to_string()));
        edit(i, &mut cells);
        text.push_str(&line(cells));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

fn import_args<'a>(csv: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "import", "--csv", csv, "--fps", "30", "--robot", "ROBOT", "--mesh", "MESH", "--mass",
        "0.1", "--out", out,
    ]
}

fn run_import(args: Vec<&str>) -> std::process::Output {
    let robot = repo("robots/parallel_gripper.urdf");
    let mesh = repo("scenes/objects/small_box.obj");
    let args: Vec<&str> = args
        .into_iter()
        .map(|a| match a {
            "ROBOT" => robot.to_str().unwrap(),
            "MESH" => mesh.to_str().unwrap(),
            a => a,
        })
        .collect();
    dexwarp(&args)
}

/// A bad CSV: file name, column left out, edit of row i's cells, words the error must hold.
type Case<'a> = (
    &'a str,
    Option<&'a str>,
    fn(usize, &mut Vec<String>),
    &'a [&'a str],
);

#[test]
fn import_csv_errors_name_the_column_and_the_row() {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let demo = Demo::load(&dir.path().join("box.demo.json"), &Limits::default()).unwrap();
    let out = dir.path().join("out.demo.json");
    let cases: [Case; 4] = [
        (
            "missing.csv",
            Some("wrist.qy"),
            |_, _| {},
            &["missing.csv", "column wrist.qy", "missing"],
        ),
        (
            "nan.csv",
            None,
            |i, c| {
                if i == 6 {
                    c[14] = "NaN".into()
                }
            },
            &["nan.csv", "row 7, column finger_joint1", "NaN"],
        ),
        (
            "short.csv",
            None,
            |i, c| {
                if i == 2 {
                    c.pop();
                }
            },
            &["short.csv", "row 3", "has 14 fields; expected 15"],
        ),
        (
            "text.csv",
            None,
            |i, c| {
                if i == 0 {
                    c[1] = "abc".into()
                }
            },
            &["text.csv", "row 1, column object.y", "expected a number"],
        ),
    ];
    for (name, drop, edit, want) in cases {
        let csv = dir.path().join(name);
        write_csv(&demo, &csv, drop, edit);
        let o = run_import(import_args(s(&csv), s(&out)));
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        for w in want {
            assert!(err.contains(w), "{name}: {err:?} lacks {w:?}");
        }
        assert!(!out.exists(), "{name}: a failed import wrote its output");
    }
}

/// A folder with the gripper fixture and its demonstration written as `rec.csv`.
fn gripper_csv() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let src = Demo::load(&dir.path().join("box.demo.json"), &Limits::default()).unwrap();
    let csv = dir.path().join("rec.csv");
    write_csv(&src, &csv, None, |_, _| {});
    (dir, csv)
}

/// `--scene` names a scene in a CSV import's demonstration (checked first: a scene that does
/// not load fails the import, which writes nothing).
#[test]
fn a_csv_import_names_the_scene_it_is_given() {
    let (dir, csv) = gripper_csv();
    let limits = Limits::default();
    let out = dir.path().join("rec.demo.json");
    let kitchen = repo("scenes/kitchen.json");
    let mut args = import_args(s(&csv), s(&out));
    args.extend(["--scene", s(&kitchen)]);
    let o = run_import(args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("scene "), "{}", stderr(&o));
    let demo = Demo::load(&out, &limits).unwrap();
    assert_eq!(
        demo.scene.as_deref().map(|p| p.canonicalize().unwrap()),
        Some(kitchen.canonicalize().unwrap())
    );

    let missing = dir.path().join("no_such.scene.json");
    let out2 = dir.path().join("rec2.demo.json");
    let mut args = import_args(s(&csv), s(&out2));
    args.extend(["--scene", s(&missing)]);
    let o = run_import(args);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no_such.scene.json"), "{}", stderr(&o));
    assert!(!out2.exists(), "a failed import wrote its output");
}

/// The built-in gripper pick and place recorded badly: the jaws 7 mm further closed while
/// they hold the box (through its sides), the wrist with half a millimetre of jitter.
/// `import --csv` without a scene infers the table, takes the jaws out onto the box's faces
/// and smooths the jitter, and the result holds; `--no-clean` keeps the recording, which
/// validate refuses for its penetration.
#[test]
fn a_csv_import_cleans_a_recorded_robot_hand() {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::default();
    let src = Demo::load(&repo("scenes/demos/small_box.demo.json"), &limits).unwrap();
    // The squeeze ramps in over the contact segment's first and last 10 frames.
    let holding: Vec<f64> = (0..src.frames.len())
        .map(|i| {
            let near = |k: usize| !src.frames[k].contacts.is_empty();
            let lo = i.saturating_sub(5);
            let hi = (i + 6).min(src.frames.len());
            (lo..hi).filter(|&k| near(k)).count() as f64 / (hi - lo) as f64
        })
        .collect();
    let csv = dir.path().join("rec.csv");
    write_csv(&src, &csv, None, |i, c| {
        for (k, cell) in c.iter_mut().enumerate().skip(7).take(3) {
            let jitter = 5e-4 * ((i * 7 + k) as f64 * 12.9898).sin();
            *cell = (cell.parse::<f64>().unwrap() + jitter).to_string();
        }
        c[14] = (c[14].parse::<f64>().unwrap() - 0.007 * holding[i]).to_string();
    });
    let robot = repo("robots/parallel_gripper.urdf");
    let mesh = repo("scenes/objects/small_box.obj");
    let import = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "import",
            "--csv",
            s(&csv),
            "--fps",
            "30",
            "--robot",
            s(&robot),
            "--mesh",
            s(&mesh),
            "--mass",
            "0.1",
            "--out",
            s(out),
        ];
        args.extend(extra);
        let o = dexwarp(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let validate = |demo: &Path, name: &str| -> Value {
        let out = dir.path().join(name);
        let o = dexwarp(&["validate", s(demo), "--out", s(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
    };

    let cleaned = dir.path().join("rec.demo.json");
    let said = import(&cleaned, &[]);
    assert!(said.contains("table inferred at z = "), "{said}");
    assert!(said.contains("cleaned: "), "{said}");
    let demo = Demo::load(&cleaned, &limits).unwrap();
    let scene = dir.path().join("rec.scene.json");
    assert_eq!(
        demo.scene.as_deref().map(|p| p.canonicalize().unwrap()),
        Some(scene.canonicalize().unwrap())
    );
    let record: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("rec.import.json")).unwrap())
            .unwrap();
    let record = &record["import"];
    let recorded = record["max_penetration_recorded_mm"].as_f64().unwrap();
    assert!(recorded > 5.0, "the recording is {recorded} mm deep");
    let depths = record["per_frame"]["penetration_mm"].as_array().unwrap();
    assert_eq!(depths.len(), src.frames.len());
    for (t, d) in depths.iter().enumerate() {
        assert!(d.as_f64().unwrap() <= 2.0, "frame {t}: {d} mm deep");
    }
    // The cleaning costs millimetres, not centimetres.
    let mean = record["residual_mean_mm"].as_f64().unwrap();
    assert!(mean > 0.0 && mean < 3.0, "hand moved {mean} mm on average");
    let report = validate(&cleaned, "v_clean");
    assert_eq!(
        report["physics"]["verdict"], "pass",
        "{}",
        report["physics"]
    );
    let fraction = report["physics"]["ensemble"]["pass_fraction"]
        .as_f64()
        .unwrap();
    assert!(fraction >= 0.75, "pass fraction {fraction}");

    let raw = dir.path().join("raw.demo.json");
    let kitchen = repo("scenes/kitchen.json");
    import(&raw, &["--no-clean", "--scene", s(&kitchen)]);
    assert!(!dir.path().join("raw.import.json").exists());
    let report = validate(&raw, "v_raw");
    assert_eq!(report["physics"]["verdict"], "fail");
    let reasons = report["physics"]["reasons"].to_string();
    assert!(reasons.contains("penetration"), "{reasons}");
}

#[test]
fn import_then_export_then_import_gives_the_same_trajectory() {
    let (dir, csv) = gripper_csv();
    let limits = Limits::default();
    let first = dir.path().join("rec.demo.json");
    let o = run_import(import_args(s(&csv), s(&first)));
    assert!(o.status.success(), "{}", stderr(&o));
    let a = Demo::load(&first, &limits).unwrap();
    // Correspondences were extracted where the jaws hold the box (the fixture's hand keeps
    // its grip pose throughout, so every frame has some), on both jaws.
    for i in 10..50 {
        let c = &a.frames[i].contacts;
        assert!(
            c.iter().any(|c| c.link == "left_finger") && c.iter().any(|c| c.link == "right_finger"),
            "frame {i}: {c:?}"
        );
    }

    let ds = dir.path().join("ds");
    let o = dexwarp(&["export", s(&first), "--format", "lerobot", "--out", s(&ds)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let second = dir.path().join("back.demo.json");
    // Episode 0 of the dataset read back into `out`, with `extra` arguments.
    let from_dataset = |out: &Path, extra: &[&str]| {
        let mut args = vec!["import", "--lerobot", s(&ds), "--episode", "0"];
        args.extend(extra);
        args.extend([
            "--robot", "ROBOT", "--mesh", "MESH", "--mass", "0.1", "--out",
        ]);
        args.push(s(out));
        let o = run_import(args);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    // The dataset holds the cleaned hand: read back as it is.
    from_dataset(&second, &["--no-clean"]);
    let b = Demo::load(&second, &limits).unwrap();
    assert_eq!(b.name, "rec");
    assert_eq!(b.fps, a.fps);
    assert_eq!(b.joint_names, a.joint_names);
    assert_eq!(b.frames.len(), a.frames.len());
    // float32 precision: 2^-24 relative; positions about 1 m, quaternions unit.
    let tol = 1e-6;
    for (i, (fa, fb)) in a.frames.iter().zip(&b.frames).enumerate() {
        for (pa, pb) in [(&fa.object, &fb.object), (&fa.wrist, &fb.wrist)] {
            let dt = (pa.translation.vector - pb.translation.vector).norm();
            let dq = pa.rotation.angle_to(&pb.rotation);
            assert!(dt < tol && dq < tol, "frame {i}: {dt} m, {dq} rad");
        }
        for (x, y) in fa.joints.iter().zip(&fb.joints) {
            assert!((x - y).abs() < tol, "frame {i}: joint {x} vs {y}");
        }
        assert_eq!(
            fa.contacts.len(),
            fb.contacts.len(),
            "frame {i}: correspondences re-extracted from the float32 poses"
        );
    }
    // Read back with the cleaning (the default), the episode gets the table inferred under
    // its object and its import record; the already clean hand stays within the smoothing's
    // reach of the recording.
    let third = dir.path().join("cleaned.demo.json");
    from_dataset(&third, &[]);
    let c = Demo::load(&third, &limits).unwrap();
    assert!(
        c.scene
            .as_deref()
            .is_some_and(|p| p.ends_with("cleaned.scene.json"))
    );
    let record: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cleaned.import.json")).unwrap())
            .unwrap();
    let moved = record["import"]["residual_max_mm"].as_f64().unwrap();
    assert!(moved < 1.0, "the clean recording moved {moved} mm");
}

/// Runs `scripts/export/readback.py` with `$DEXWARP_PYTHON` (a Python with pyarrow; `.ci/run`
/// makes one) on the dataset, against values taken from the demonstrations and reports.
fn pyarrow_readback(out: &Path, demos: &[Demo], reports: &[Value]) {
    let Ok(python) = std::env::var("DEXWARP_PYTHON") else {
        eprintln!(
            "notice: DEXWARP_PYTHON not set; skipping the pyarrow readback (.ci/run sets it)"
        );
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must set DEXWARP_PYTHON"
        );
        return;
    };
    let (mut state, mut env, mut action, mut ts, mut fi, mut ep, mut idx) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    for (e, d) in demos.iter().enumerate() {
        let n = d.frames.len();
        for i in 0..n {
            state.push(state_of(d, i));
            env.push(object_of(d, i));
            action.push(state_of(d, (i + 1).min(n - 1)));
            ts.push((i as f64 / 30.0) as f32 as f64);
            fi.push(i);
            ep.push(e);
            idx.push(idx.len());
        }
    }
    let col = |f: &dyn Fn(&Value) -> Value| -> Vec<Value> { reports.iter().map(f).collect() };
    let expected = serde_json::json!({
        "frames": {
            "observation.state": state, "observation.environment_state": env, "action": action,
            "timestamp": ts, "frame_index": fi, "episode_index": ep, "index": idx,
            "task_index": vec![0; idx.len()],
        },
        "episodes": {
            "episode_index": [0, 1],
            "length": demos.iter().map(|d| d.frames.len()).collect::<Vec<_>>(),
            "quality/verdict": col(&|r| r["physics"]["verdict"].clone()),
            "quality/passed": col(&|r| Value::Bool(r["physics"]["verdict"] == "pass")),
            "quality/robust": col(&|_| Value::Null),
            "quality/failure_reasons": col(&|r| r["physics"]["reasons"].clone()),
            "quality/d_c_mm": col(&|r| r["metrics"]["d_c_mm"]["warped"].clone()),
            "quality/d_wo_mm": col(&|r| r["metrics"]["d_wo_mm"]["warped"].clone()),
            "quality/plr_object": col(&|r| r["metrics"]["plr_object"].clone()),
            "quality/timewarp_discrepancy": col(&|r| r["metrics"]["timewarp_discrepancy"].clone()),
            "quality/tracking_max_rotation_error_deg":
                col(&|r| r["physics"]["tracking"]["max_rotation_error_deg"].clone()),
        },
        "tasks": ["small_box: box_lift"],
    });
    python_readback(&python, "readback.py", out, &expected);
}

/// The robomimic file of the two-warp batch: every frame of every `obs`, `next_obs`,
/// `actions`, `states`, `rewards` and `dones`, every quality attribute and every mask, read
/// back through the HDF5 crate (and with h5py when CI provides it).
#[cfg(feature = "robomimic")]
#[test]
fn robomimic_export_reads_back_every_frame_attribute_and_mask() {
    use dexwarp::export::robomimic::{self, Attr};
    let dir = tempfile::tempdir().unwrap();
    let runs = small_batch(dir.path());
    let out = dir.path().join("ds.hdf5");
    let o = dexwarp(&[
        "export",
        s(&runs),
        "--format",
        "robomimic",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains("dexwarp-tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    let limits = Limits::default();
    let reports: Vec<Value> = ["a", "b"]
        .iter()
        .map(|k| {
            serde_json::from_slice(&std::fs::read(runs.join(k).join("report.json")).unwrap())
                .unwrap()
        })
        .collect();
    let demos: Vec<Demo> = ["a", "b"]
        .iter()
        .map(|k| Demo::load(&runs.join(k).join("box_lift.demo.json"), &limits).unwrap())
        .collect();
    let ds = robomimic::read(&out).unwrap();
    let total: usize = demos.iter().map(|d| d.frames.len()).sum();
    assert_eq!(ds.total, total as i64);
    assert_eq!(ds.env_args["env_name"], "dexwarp/parallel_gripper");
    assert_eq!(ds.env_args["type"], 2);
    assert_eq!(ds.env_args["env_kwargs"]["fps"], 30);
    assert_eq!(ds.env_args["env_kwargs"]["joint_names"][0], "finger_joint1");
    assert_eq!(ds.demos.len(), 2);
    let scaling = ds
        .action_scaling
        .clone()
        .expect("actions are normalized by default");
    // Every dimension that varies reaches both ends of [-1, 1] somewhere.
    for (j, s) in scaling.scale.iter().enumerate() {
        let column = ds
            .demos
            .iter()
            .flat_map(|g| g.actions.iter().map(move |a| a[j]));
        let (lo, hi) = column.fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
        if *s != 1.0 {
            assert!(lo == -1.0 && hi == 1.0, "action {j}: [{lo}, {hi}]");
        }
    }

    let f32s = |v: Vec<f64>| -> Vec<f32> { v.into_iter().map(|x| x as f32).collect() };
    for (e, (d, r)) in demos.iter().zip(&reports).enumerate() {
        let g = &ds.demos[e];
        assert_eq!(g.name, format!("demo_{e}"));
        let n = d.frames.len();
        assert_eq!(g.attrs["num_samples"], Attr::Int(n as i64));
        let passed = r["physics"]["verdict"] == "pass";
        for i in 0..n {
            let next = (i + 1).min(n - 1);
            for (obs, k) in [(&g.obs, i), (&g.next_obs, next)] {
                let (st, ob) = (f32s(state_of(d, k)), f32s(object_of(d, k)));
                assert_eq!(obs["wrist_pos"][i], st[0..3], "demo {e} frame {i}");
                assert_eq!(obs["wrist_quat"][i], st[3..7], "demo {e} frame {i}");
                assert_eq!(obs["joint_pos"][i], st[7..], "demo {e} frame {i}");
                assert_eq!(obs["object_pos"][i], ob[0..3], "demo {e} frame {i}");
                assert_eq!(obs["object_quat"][i], ob[3..7], "demo {e} frame {i}");
            }
            // The absolute target, and the action scaled into [-1, 1] that scales back to it.
            let target = f32s(state_of(d, next));
            assert_eq!(
                g.actions_abs.as_ref().unwrap()[i],
                target,
                "demo {e} frame {i}"
            );
            for (j, (a, t)) in g.actions[i].iter().zip(&target).enumerate() {
                assert!(
                    (-1.0..=1.0).contains(a),
                    "demo {e} frame {i} action {j}: {a}"
                );
                let back = f64::from(*a) * scaling.scale[j] + scaling.offset[j];
                assert!(
                    (back - f64::from(*t)).abs() < 1e-6,
                    "demo {e} frame {i} action {j}: {back} vs {t}"
                );
            }
            let mut state = f32s(object_of(d, i));
            state.extend(f32s(state_of(d, i)));
            assert_eq!(g.states[i], state, "demo {e} frame {i}");
            let last = i + 1 == n;
            assert_eq!(g.rewards[i], if passed && last { 1.0 } else { 0.0 });
            assert_eq!(g.dones[i], i64::from(last));
        }
        assert_eq!(g.obs.len(), 5);
        assert_eq!(g.actions.len(), n);

        // Every quality attribute, as in the report.
        let m = &r["metrics"];
        let ph = &r["physics"];
        let float = |k: &str| g.attrs.get(k).cloned();
        let want = |v: &Value| v.as_f64().map(Attr::Float);
        for (k, v) in [
            ("d_c_mm", &m["d_c_mm"]["warped"]),
            ("d_c_original_mm", &m["d_c_mm"]["original"]),
            ("d_wo_mm", &m["d_wo_mm"]["warped"]),
            ("d_wo_original_mm", &m["d_wo_mm"]["original"]),
            ("plr_object", &m["plr_object"]),
            ("plr_hand", &m["plr_hand"]),
            ("timewarp_discrepancy", &m["timewarp_discrepancy"]),
            (
                "hand_object_penetration_mm",
                &r["constraints"]["hand_object_penetration_mm"]["warped"],
            ),
            (
                "physics_hand_object_penetration_mm",
                &ph["penetration"]["hand_object"]["max_mm"],
            ),
            (
                "physics_object_barrier_penetration_mm",
                &ph["penetration"]["object_barrier"]["max_mm"],
            ),
            (
                "tracking_max_position_error_mm",
                &ph["tracking"]["max_position_error_mm"],
            ),
            (
                "tracking_max_rotation_error_deg",
                &ph["tracking"]["max_rotation_error_deg"],
            ),
            ("ik_converged_fraction", &r["ik"]["converged_fraction"]),
        ] {
            assert_eq!(float(k), want(v), "demo {e} attribute {k}");
        }
        let text = |k: &str| match &g.attrs[k] {
            Attr::Str(s) => s.clone(),
            a => panic!("{k} is {a:?}"),
        };
        assert_eq!(text("verdict"), ph["verdict"].as_str().unwrap());
        assert_eq!(text("name"), "box_lift");
        assert_eq!(text("task"), "small_box: box_lift");
        assert!(text("source_demo").ends_with("box.demo.json"));
        assert!(text("config").ends_with("lift.config.json"));
        assert!(text("report").ends_with("report.json"));
        let reasons: Value = serde_json::from_str(&text("failure_reasons")).unwrap();
        assert_eq!(reasons, ph["reasons"]);
        assert_eq!(g.attrs["passed"], Attr::Bool(passed));
    }
    // Every mask.
    let names = |f: &dyn Fn(&Value) -> bool| -> Vec<String> {
        (0..2)
            .filter(|&e| f(&reports[e]))
            .map(|e| format!("demo_{e}"))
            .collect()
    };
    assert_eq!(
        ds.masks["pass"],
        names(&|r| r["physics"]["verdict"] == "pass")
    );
    assert_eq!(
        ds.masks["fail"],
        names(&|r| r["physics"]["verdict"] == "fail")
    );
    assert_eq!(ds.masks["train"], ["demo_0"]);
    assert_eq!(ds.masks["valid"], ["demo_1"]);

    h5py_readback(&out, &demos, &reports, &ds.masks);

    // An existing OUT is refused without --force and replaced with it.
    let o = dexwarp(&[
        "export",
        s(&runs),
        "--format",
        "robomimic",
        "--out",
        s(&out),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
    let o = dexwarp(&[
        "export",
        s(&runs),
        "--format",
        "robomimic",
        "--force",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(robomimic::read(&out).unwrap(), ds);
}

/// `--absolute-actions`: the targets themselves under `actions`, no scaling written; refused
/// with LeRobot, whose action is always absolute.
#[cfg(feature = "robomimic")]
#[test]
fn robomimic_absolute_actions_are_the_targets() {
    use dexwarp::export::robomimic;
    let dir = tempfile::tempdir().unwrap();
    let runs = small_batch(dir.path());
    let out = dir.path().join("abs.hdf5");
    let args = |format: &str, out: &Path| {
        dexwarp(&[
            "export",
            s(&runs),
            "--format",
            format,
            "--absolute-actions",
            "--out",
            s(out),
        ])
    };
    let o = args("robomimic", &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let ds = robomimic::read(&out).unwrap();
    assert!(ds.action_scaling.is_none());
    let d = Demo::load(&runs.join("a/box_lift.demo.json"), &Limits::default()).unwrap();
    let g = &ds.demos[0];
    assert!(g.actions_abs.is_none());
    let n = d.frames.len();
    for i in 0..n {
        let want: Vec<f32> = state_of(&d, (i + 1).min(n - 1))
            .into_iter()
            .map(|x| x as f32)
            .collect();
        assert_eq!(g.actions[i], want, "frame {i}");
    }
    let o = args("lerobot", &dir.path().join("ds"));
    assert!(
        !o.status.success() && stderr(&o).contains("applies to --format robomimic"),
        "{}",
        stderr(&o)
    );
}

/// Runs `scripts/export/readback_robomimic.py` with `$DEXWARP_PYTHON` (a Python with h5py;
/// `.ci/run` makes one) on the file, against values taken from the demonstrations and
/// reports (the masks are the ones the Rust test checked).
#[cfg(feature = "robomimic")]
fn h5py_readback(
    out: &Path,
    demos: &[Demo],
    reports: &[Value],
    masks: &std::collections::BTreeMap<String, Vec<String>>,
) {
    let Ok(python) = std::env::var("DEXWARP_PYTHON") else {
        eprintln!("notice: DEXWARP_PYTHON not set; skipping the h5py readback (.ci/run sets it)");
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must set DEXWARP_PYTHON"
        );
        return;
    };
    let mut groups = Vec::new();
    for (d, r) in demos.iter().zip(reports) {
        let n = d.frames.len();
        let obs = |shift: usize| {
            let rows = |f: &dyn Fn(usize) -> Vec<f64>| -> Vec<Vec<f64>> {
                (0..n).map(|i| f((i + shift).min(n - 1))).collect()
            };
            serde_json::json!({
                "wrist_pos": rows(&|k| state_of(d, k)[0..3].to_vec()),
                "wrist_quat": rows(&|k| state_of(d, k)[3..7].to_vec()),
                "joint_pos": rows(&|k| state_of(d, k)[7..].to_vec()),
                "object_pos": rows(&|k| object_of(d, k)[0..3].to_vec()),
                "object_quat": rows(&|k| object_of(d, k)[3..7].to_vec()),
            })
        };
        let passed = r["physics"]["verdict"] == "pass";
        groups.push(serde_json::json!({
            "num_samples": n,
            "obs": obs(0),
            "next_obs": obs(1),
            "actions": (0..n).map(|i| state_of(d, (i + 1).min(n - 1))).collect::<Vec<_>>(),
            "states": (0..n).map(|i| {
                let mut s = object_of(d, i);
                s.extend(state_of(d, i));
                s
            }).collect::<Vec<_>>(),
            "rewards": (0..n).map(|i| if passed && i + 1 == n { 1.0 } else { 0.0 }).collect::<Vec<f64>>(),
            "dones": (0..n).map(|i| usize::from(i + 1 == n)).collect::<Vec<_>>(),
            "attrs": {
                "verdict": r["physics"]["verdict"],
                "passed": passed,
                "d_c_mm": r["metrics"]["d_c_mm"]["warped"],
                "d_wo_mm": r["metrics"]["d_wo_mm"]["warped"],
                "plr_object": r["metrics"]["plr_object"],
                "timewarp_discrepancy": r["metrics"]["timewarp_discrepancy"],
                "tracking_max_rotation_error_deg": r["physics"]["tracking"]["max_rotation_error_deg"],
                "ik_converged_fraction": r["ik"]["converged_fraction"],
            },
            "failure_reasons": r["physics"]["reasons"],
        }));
    }
    let total: usize = demos.iter().map(|d| d.frames.len()).sum();
    let expected = serde_json::json!({
        "total": total,
        "env_name": "dexwarp/parallel_gripper",
        "demos": groups,
        "masks": masks,
    });
    python_readback(&python, "readback_robomimic.py", out, &expected);
}

/// A build without the feature refuses `--format robomimic` before reading anything, and
/// says what to install and enable.
#[cfg(not(feature = "robomimic"))]
#[test]
fn robomimic_without_the_feature_says_what_to_install() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ds.hdf5");
    let o = dexwarp(&[
        "export",
        s(dir.path()),
        "--format",
        "robomimic",
        "--out",
        s(&out),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    for w in ["libhdf5-dev", "--features robomimic", "ds.hdf5"] {
        assert!(err.contains(w), "{err:?} lacks {w:?}");
    }
    assert!(!out.exists());
}

/// Runs `scripts/export/SCRIPT OUT EXPECTED.json` with `python` (the readback venv), which
/// compares what an independent reader finds in `out` with `expected`; fails with its output.
fn python_readback(python: &str, script: &str, out: &Path, expected: &serde_json::Value) {
    let path = out.with_extension("expected.json");
    std::fs::write(&path, expected.to_string()).unwrap();
    let o = std::process::Command::new(python)
        .arg(repo(&format!("scripts/export/{script}")))
        .arg(out)
        .arg(&path)
        .output()
        .unwrap_or_else(|e| panic!("run {script}: {e}"));
    assert!(
        o.status.success(),
        "{script}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!("{}", String::from_utf8_lossy(&o.stdout).trim());
}

#[test]
fn export_of_a_filter_list_holds_exactly_the_kept_trajectories() {
    let dir = tempfile::tempdir().unwrap();
    let runs = small_batch(dir.path());
    let dc = |k: &str| -> f64 {
        let r: Value =
            serde_json::from_slice(&std::fs::read(runs.join(k).join("report.json")).unwrap())
                .unwrap();
        r["metrics"]["d_c_mm"]["warped"].as_f64().unwrap()
    };
    // A D_C bound between the two runs' keeps the closer one only (on this fixture the
    // rigid baseline: its correspondences are exact).
    let (a, b) = (dc("a"), dc("b"));
    assert!(a != b, "{a} vs {b}");
    let closer = if a < b { "a" } else { "b" };
    let keep = dir.path().join("keep.csv");
    let bound = format!("{}", (a + b) / 2.0);
    let o = dexwarp(&[
        "filter",
        s(&runs),
        "--no-physics",
        "--max-dc-mm",
        &bound,
        "--out",
        s(&keep),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let kept = std::fs::read_to_string(&keep).unwrap();
    assert_eq!(kept.lines().count(), 2, "{kept}");
    let out = dir.path().join("dataset");
    let o = dexwarp(&["export", s(&keep), "--format", "lerobot", "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ds = lerobot::read(&out).unwrap();
    assert_eq!(ds.info["total_episodes"], 1);
    let demo = Demo::load(
        &runs.join(closer).join("box_lift.demo.json"),
        &Limits::default(),
    )
    .unwrap();
    assert_eq!(ds.frames.rows, demo.frames.len());
    // The dropped list exports the other one; a CSV that is not a filter list is refused.
    let o = dexwarp(&[
        "export",
        s(&dir.path().join("keep.dropped.csv")),
        "--format",
        "lerobot",
        "--out",
        s(&dir.path().join("dropped")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bad = dir.path().join("other.csv");
    std::fs::write(&bad, "a,b\n1,2\n").unwrap();
    let o = dexwarp(&[
        "export",
        s(&bad),
        "--format",
        "lerobot",
        "--out",
        s(&dir.path().join("x")),
    ]);
    assert!(
        !o.status.success()
            && stderr(&o).contains("other.csv")
            && stderr(&o).contains("dexwarp filter"),
        "{}",
        stderr(&o)
    );
}
