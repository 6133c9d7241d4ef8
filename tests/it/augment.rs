//! `dexwarp augment`: the sampler's ranges (property test), spec errors, and a small run end
//! to end through the command line with a rerun, shards and a merge.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::LazyLock;

use dexwarp::Limits;
use dexwarp::augment::sampler::{Context, sample, support_under, top_face};
use dexwarp::augment::spec::Spec;
use dexwarp::model::Demo;
use proptest::prelude::*;

use crate::fixtures::{dexwarp, repo, stderr};

/// A spec that uses every option, on the cube demonstration.
fn wide_spec() -> serde_json::Value {
    serde_json::json!({
        "format": "dexwarp.variations/1",
        "name": "wide",
        "scene": repo("scenes/kitchen.json"),
        "start": {"support": "counter_left", "region": {"min": [-0.9, 0.65], "max": [-0.3, 0.95]}, "margin_m": 0.04},
        "end": {"box": {"min": [-1.3, 0.7, 0.925], "max": [-1.0, 0.9, 0.94]}, "tolerance_m": 0.01},
        "waypoints": {
            "count": [0, 4],
            "t_jitter": 0.9,
            "position": {"offset": {"min": [-0.05, -0.04, 0.0], "max": [0.05, 0.04, 0.15]}},
            "rotation": {"axes": [[0, 0, 1], [1, 0, 0]], "angle_rad": [-0.4, 0.3]}
        },
        "retime": {"duration_factor": [0.6, 1.5]},
        "barriers": {
            "items": ["cup_1"],
            "optional_items": ["cup_2", "jar_1"],
            "optional_probability": 0.3,
            "primitives": {"count": [0, 2], "shape": "box", "size": {"min": [0.03, 0.1, 0.05], "max": [0.08, 0.2, 0.12]},
                           "between": [0.3, 0.7], "offset": {"min": [0, -0.05, 0], "max": [0, 0.05, 0]}, "yaw_rad": [-0.5, 0.5]}
        },
        "threshold_mm": [3.0, 6.0]
    })
}

struct Fixture {
    spec: Spec,
    ctx: Context,
    _dir: tempfile::TempDir,
}

static WIDE: LazyLock<Fixture> = LazyLock::new(|| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wide.json");
    std::fs::write(&path, wide_spec().to_string()).unwrap();
    let limits = Limits::default();
    let spec = Spec::load(&path, &limits).expect("wide spec loads");
    let demo_path = repo("scenes/demos/cube.demo.json");
    let demo = Demo::load(&demo_path, &limits).unwrap();
    let ctx = Context::new(&spec, &demo, &demo_path, &limits).expect("context");
    Fixture {
        spec,
        ctx,
        _dir: dir,
    }
});

fn within(v: f64, lo: f64, hi: f64, what: &str) -> std::result::Result<(), TestCaseError> {
    prop_assert!(
        v >= lo - 1e-12 && v <= hi + 1e-12,
        "{what} = {v} outside [{lo}, {hi}]"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Every sampled value lies in its range of the spec, and sample i is a function of
    /// (seed, i).
    #[test]
    fn the_sampler_respects_every_range(seed in any::<u64>(), index in 0u64..1_000_000) {
        let Fixture { spec, ctx, .. } = &*WIDE;
        let s = sample(spec, ctx, seed, index);
        prop_assert_eq!(&s, &sample(spec, ctx, seed, index));
        let c = &s.config;
        let (c0, c1) = (ctx.c0, ctx.c1);
        let rejected = s.rejection.as_ref().map(|r| r.reason);

        // Start: in the region, at the resting height on the counter top.
        let start = c.start.expect("the spec varies the start");
        within(start[0], -0.9, -0.3, "start.x")?;
        within(start[1], 0.65, 0.95, "start.y")?;
        let top = top_face(ctx.scene.item("counter_left").unwrap()).unwrap();
        prop_assert!((start[2] - top.z - ctx.rest_start.unwrap()).abs() < 1e-12);
        let on = top.contains_xy(&start.into(), 0.04);
        prop_assert_eq!(!on, rejected == Some("start_off_support"), "start on support: {}", on);
        // End: in the box; kept only when it rests on a support.
        let end = c.end.expect("the spec varies the end");
        for (a, (lo, hi)) in [(-1.3, -1.0), (0.7, 0.9), (0.925, 0.94)].into_iter().enumerate() {
            within(end[a], lo, hi, "end")?;
        }
        if rejected.is_none() {
            let (_, top) = support_under(&ctx.scene, &end.into(), 0.03).expect("end on a support");
            prop_assert!((end[2] - top - ctx.rest_end.unwrap()).abs() <= 0.01 + 1e-12);
        }

        // Waypoints: count, input frames inside the segment, offsets, rotations.
        let k = c.waypoints.len();
        prop_assert!(k <= 4);
        let d0 = nalgebra::Vector3::from(start) - ctx.positions[c0];
        let d1 = nalgebra::Vector3::from(end) - ctx.positions[c1];
        let mut prev_t = c0 as f64;
        for w in &c.waypoints {
            prop_assert!(w.t > prev_t && w.t < c1 as f64, "t = {} after {prev_t}, before {c1}", w.t);
            prev_t = w.t;
            let t = w.t as usize;
            let lambda = (t - c0) as f64 / (c1 - c0) as f64;
            let base = ctx.positions[t] + (1.0 - lambda) * d0 + lambda * d1;
            let o = nalgebra::Vector3::from(w.position) - base;
            within(o.x, -0.05, 0.05, "offset.x")?;
            within(o.y, -0.04, 0.04, "offset.y")?;
            within(o.z, 0.0, 0.15, "offset.z")?;
            let r = w.rotation.expect("the spec rotates");
            prop_assert!(r.axis == [0.0, 0.0, 1.0] || r.axis == [1.0, 0.0, 0.0]);
            within(r.angle, -0.4, 0.3, "angle")?;
        }

        // Retiming: each segment lasts round(factor × input duration) frames, factor in range.
        let ts: Vec<f64> = std::iter::once(c0 as f64)
            .chain(c.waypoints.iter().map(|w| w.t))
            .chain(std::iter::once(c1 as f64))
            .collect();
        let tn: Vec<f64> = std::iter::once(c0 as f64)
            .chain(c.waypoints.iter().map(|w| w.t_new))
            .chain(std::iter::once(c.params.end_t_new.unwrap()))
            .collect();
        prop_assert_eq!(s.duration_factors.len(), k + 1);
        for j in 0..=k {
            let f = s.duration_factors[j];
            within(f, 0.6, 1.5, "duration factor")?;
            let want = ((ts[j + 1] - ts[j]) * f).round().max(1.0);
            prop_assert_eq!(tn[j + 1] - tn[j], want);
        }
        within(c.params.threshold_mm, 3.0, 6.0, "threshold_mm")?;

        // Barriers: the items always, optional ones drawn, primitives in their ranges.
        prop_assert_eq!(&c.barriers[0], "cup_1");
        for name in &c.barriers[1..] {
            prop_assert!(
                name == "cup_2" || name == "jar_1" || name.starts_with("augment_barrier_"),
                "{}", name
            );
        }
        prop_assert!(s.primitives.len() <= 2);
        for p in &s.primitives {
            let dexwarp::model::scene::ShapeJson::Box { size } = p.shape else {
                panic!("box primitives only");
            };
            for (a, (lo, hi)) in [(0.03, 0.08), (0.1, 0.2), (0.05, 0.12)].into_iter().enumerate() {
                within(size[a], lo, hi, "primitive size")?;
            }
            let q = p.pose.orientation;
            within(2.0 * q[3].atan2(q[0]), -0.5, 0.5, "primitive yaw")?;
            if rejected != Some("barrier_off_support") {
                let centre = nalgebra::Vector3::from(p.pose.position);
                let (_, top) = support_under(&ctx.scene, &centre, 0.0).unwrap();
                prop_assert!((centre.z - size[2] / 2.0 - top).abs() < 1e-9, "stands on the support");
            }
        }
    }
}

#[test]
fn samples_differ_between_indices_and_seeds() {
    let Fixture { spec, ctx, .. } = &*WIDE;
    let a = sample(spec, ctx, 1, 0);
    assert_ne!(a.config, sample(spec, ctx, 1, 1).config);
    assert_ne!(a.config, sample(spec, ctx, 2, 0).config);
}

/// A log-uniform duration factor compresses as often as it stretches when `lo·hi = 1`, and
/// stays in its range; every segment draws its own.
#[test]
fn log_uniform_factors_compress_as_often_as_they_stretch() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("log.json");
    let mut v = wide_spec();
    v["retime"] =
        serde_json::json!({"duration_factor": [0.1, 10.0], "distribution": "log_uniform"});
    std::fs::write(&path, v.to_string()).unwrap();
    let limits = Limits::default();
    let spec = Spec::load(&path, &limits).unwrap();
    let demo_path = repo("scenes/demos/cube.demo.json");
    let demo = Demo::load(&demo_path, &limits).unwrap();
    let ctx = Context::new(&spec, &demo, &demo_path, &limits).unwrap();
    let factors: Vec<f64> = (0..400)
        .flat_map(|i| sample(&spec, &ctx, 7, i).duration_factors)
        .collect();
    assert!(factors.iter().all(|f| (0.1..=10.0).contains(f)));
    let below = factors.iter().filter(|f| **f < 1.0).count() as f64 / factors.len() as f64;
    assert!((0.4..0.6).contains(&below), "share below 1: {below}");
    let stretched = factors.iter().filter(|f| **f >= 5.0).count() as f64 / factors.len() as f64;
    // P(f >= 5) = ln(10 / 5) / ln(100) = 0.15.
    assert!(
        (0.1..0.2).contains(&stretched),
        "share at 5x or more: {stretched}"
    );
    let differ = (0..50).any(|i| {
        let f = sample(&spec, &ctx, 7, i).duration_factors;
        f.len() > 1 && f[0] != f[1]
    });
    assert!(differ, "segments draw their factors independently");
}

/// Writes `value` with `edit` applied and returns the load error.
fn spec_error(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.json");
    let mut v = wide_spec();
    edit(&mut v);
    std::fs::write(&path, v.to_string()).unwrap();
    let limits = Limits::default();
    let demo_path = repo("scenes/demos/cube.demo.json");
    let demo = Demo::load(&demo_path, &limits).unwrap();
    let err = Spec::load(&path, &limits)
        .and_then(|s| Context::new(&s, &demo, &demo_path, &limits).map(|_| ()))
        .expect_err("the spec is bad");
    let msg = err.to_string();
    assert!(msg.contains("bad.json"), "names the file: {msg}");
    msg
}

/// A change to the wide spec.
type Edit = Box<dyn FnOnce(&mut serde_json::Value)>;

#[test]
fn bad_specs_name_the_file_the_field_and_what_was_expected() {
    let cases: Vec<(Edit, &str, &str)> = vec![
        (
            Box::new(|v| v["format"] = "dexwarp.config/1".into()),
            "format",
            "dexwarp.variations/1",
        ),
        (
            Box::new(|v| v["waypoints"]["count"] = serde_json::json!([3, 1])),
            "waypoints.count",
            "lo <= hi",
        ),
        (
            Box::new(|v| v["waypoints"]["count"] = serde_json::json!([0, 400])),
            "waypoints.count",
            "at most",
        ),
        (
            Box::new(|v| v["threshold_mm"] = serde_json::json!([0, 4])),
            "threshold_mm[0]",
            "> 0",
        ),
        (
            Box::new(|v| v["retime"]["duration_factor"] = serde_json::json!([1.2, 0.9])),
            "retime.duration_factor",
            "lo <= hi",
        ),
        (
            Box::new(|v| v["retime"]["duration_factor"] = serde_json::json!([0.5, 1e6])),
            "retime.duration_factor[1]",
            "at most 100",
        ),
        (
            Box::new(|v| v["retime"]["distribution"] = serde_json::json!("normal")),
            "retime.distribution",
            "log_uniform",
        ),
        (
            Box::new(|v| {
                v["start"]["box"] = serde_json::json!({"min": [0, 0, 0], "max": [1, 1, 1]})
            }),
            "start",
            "exactly one of",
        ),
        (
            Box::new(|v| v["start"]["support"] = "counter_middle".into()),
            "start.support",
            "supports there",
        ),
        (
            Box::new(|v| v["start"]["support"] = "cup_1".into()),
            "start.support",
            "expected a support",
        ),
        (
            Box::new(|v| v["barriers"]["items"] = serde_json::json!(["floor"])),
            "barriers.items[0]",
            "expected a barrier",
        ),
        (
            Box::new(|v| v["barriers"]["optional_probability"] = 1.5.into()),
            "barriers.optional_probability",
            "probability",
        ),
        (
            Box::new(|v| v["barriers"]["primitives"]["between"] = serde_json::json!([0.5, 1.5])),
            "barriers.primitives.between",
            "within [0, 1]",
        ),
        (
            Box::new(|v| v["waypoints"]["rotation"]["axes"] = serde_json::json!([[0, 0, 0]])),
            "waypoints.rotation.axes[0]",
            "non-zero",
        ),
        (
            Box::new(|v| v["waypoints"]["position"] = serde_json::json!({})),
            "waypoints.position",
            "exactly one of",
        ),
        (
            Box::new(|v| v["params"] = serde_json::json!({"alpha_m": -1})),
            "params.alpha_m",
            "expected a number from",
        ),
        (
            Box::new(|v| v["startt"] = serde_json::json!({})),
            "startt",
            "unknown field",
        ),
    ];
    for (edit, field, expected) in cases {
        let msg = spec_error(edit);
        assert!(msg.contains(field), "names {field}: {msg}");
        assert!(msg.contains(expected), "says {expected:?}: {msg}");
    }
}

fn strip_timing(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("timing");
    v
}

fn ids(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir) {
        Ok(r) => r
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

#[test]
fn augment_runs_end_to_end_reruns_identically_and_shards_agree() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = repo("scenes/demos/small_box.demo.json");
    let spec = repo("scenes/variations/small_box.json");
    let one: PathBuf = tmp.path().join("one");
    let base = |out: &Path| -> Vec<String> {
        [
            "augment",
            "--demo",
            demo.to_str().unwrap(),
            "--variations",
            spec.to_str().unwrap(),
            "--count",
            "4",
            "--seed",
            "1",
            "--jobs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let run = |args: Vec<String>| {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = dexwarp(&refs);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let said = run(base(&one));
    assert!(said.contains("4 attempts"), "{said}");

    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(one.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["attempts"], 4);
    let (kept, failed) = (ids(&one.join("kept")), ids(&one.join("failed")));
    assert_eq!(
        (kept.len() + failed.len()) as u64,
        stats["ran"].as_u64().unwrap()
    );
    assert_eq!(kept.len() as u64, stats["passed"].as_u64().unwrap());
    assert!(
        stats["ran"].as_u64().unwrap() + stats["rejected"].as_u64().unwrap() == 4,
        "{stats}"
    );
    for (status, list) in [("kept", &kept), ("failed", &failed)] {
        for id in list.iter() {
            let d = one.join(status).join(id);
            for f in ["config.json", "report.json", "frames.csv"] {
                assert!(d.join(f).is_file(), "{} has {f}", d.display());
            }
            // The sampled config is an ordinary warp config.
            dexwarp::model::WarpConfig::load(&d.join("config.json"), &Limits::default())
                .expect("config loads");
        }
    }
    let page = std::fs::read_to_string(one.join("index.html")).unwrap();
    assert!(page.contains("<svg") && page.contains("yield"), "page");
    let items = dexwarp::batch::read_manifest(&one.join("manifest.jsonl"), &Limits::default())
        .expect("manifest reads as a batch manifest");
    assert_eq!(items.len() as u64, stats["ran"].as_u64().unwrap());

    // A rerun skips every finished sample and writes the same figures and rows.
    let samples = std::fs::read(one.join("samples.csv")).unwrap();
    let before = strip_timing(&one.join("stats.json"));
    let said = run(base(&one));
    assert!(said.contains("0 run now"), "{said}");
    assert_eq!(strip_timing(&one.join("stats.json")), before);
    assert_eq!(std::fs::read(one.join("samples.csv")).unwrap(), samples);
    // The rows carry the ensemble; stats.json counts it.
    let csv = String::from_utf8(samples.clone()).unwrap();
    assert!(
        csv.lines().next().unwrap().contains("pass_fraction"),
        "{csv}"
    );
    let ensemble = &before["ensemble"];
    assert_eq!(ensemble["samples"], stats["ran"], "{ensemble}");
    // Another ensemble seed reruns every sample that ran; the same one again skips them.
    let ran = stats["ran"].as_u64().unwrap();
    let with_seed = |seed: &str| {
        let mut a = base(&one);
        a.extend(["--ensemble-seed".to_string(), seed.to_string()]);
        a
    };
    let said = run(with_seed("2"));
    assert!(said.contains(&format!("{ran} run now")), "{said}");
    let said = run(with_seed("2"));
    assert!(said.contains("0 run now"), "{said}");
    // Back to the default seed: the first run's rows again.
    let said = run(base(&one));
    assert!(said.contains(&format!("{ran} run now")), "{said}");
    assert_eq!(std::fs::read(one.join("samples.csv")).unwrap(), samples);

    // Two shards into one folder, merged, give the same kept set and figures.
    let shared = tmp.path().join("shared");
    for k in ["0/2", "1/2"] {
        let mut a = base(&shared);
        a.extend(["--shard".to_string(), k.to_string()]);
        run(a);
    }
    assert!(
        !shared.join("stats.json").exists(),
        "shards write shard files"
    );
    run([
        "augment",
        "--merge",
        shared.to_str().unwrap(),
        "--out",
        shared.to_str().unwrap(),
    ]
    .map(String::from)
    .to_vec());
    assert_eq!(ids(&shared.join("kept")), kept);
    let mut merged = strip_timing(&shared.join("stats.json"));
    let mut single = before.clone();
    assert_eq!(merged["shards"], serde_json::json!(["0/2", "1/2"]));
    merged.as_object_mut().unwrap().remove("shards");
    single.as_object_mut().unwrap().remove("shards");
    assert_eq!(merged, single);
    assert_eq!(std::fs::read(shared.join("samples.csv")).unwrap(), samples);

    // filter reads an augment folder like any other.
    let keep = tmp.path().join("keep.csv");
    let o = dexwarp(&[
        "filter",
        one.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("kept {} of", kept.len())),
        "{}",
        stderr(&o)
    );

    // A rerun with another seed into the same folder is refused, naming the field.
    let mut other = base(&one);
    other[8] = "2".into();
    let refs: Vec<&str> = other.iter().map(String::as_str).collect();
    let o = dexwarp(&refs);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("augment.json") && err.contains("seed"),
        "{err}"
    );
    // Merging an incomplete set of shards says what is missing.
    let half = tmp.path().join("half");
    let mut a = base(&half);
    a.extend(["--shard".to_string(), "0/2".to_string()]);
    run(a);
    let o = dexwarp(&[
        "augment",
        "--merge",
        half.to_str().unwrap(),
        "--out",
        half.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("missing"), "{}", stderr(&o));
}

/// A paired table (`both`, `only_contact_ik`, `only_baseline`, `neither`) covers the `ran`
/// samples once each, its margins are each hand's count, and its McNemar p-value is the
/// exact test of its two discordant counts.
fn check_paired(p: &serde_json::Value, ran: u64, contact_ik: u64, baseline: u64) {
    let n = |k: &str| p[k].as_u64().unwrap();
    assert_eq!(
        n("both") + n("only_contact_ik") + n("only_baseline") + n("neither"),
        ran,
        "{p}"
    );
    assert_eq!(n("both") + n("only_contact_ik"), contact_ik, "{p}");
    assert_eq!(n("both") + n("only_baseline"), baseline, "{p}");
    let expected =
        dexwarp::math::sign_test::mcnemar_exact_p(n("only_contact_ik"), n("only_baseline"));
    assert_eq!(p["mcnemar_p"].as_f64(), Some(expected), "{p}");
}

/// `--compare-baseline`: every sample that ran also runs with the baseline hand, its files
/// beside the sample's (not taken for outputs by other commands), its verdict and D_C in the
/// rows, the paired counts in stats.json; a sample finished without it runs again, and so
/// does one finished without a margin when `--margin` is asked.
#[test]
fn compare_baseline_pairs_both_hands_sample_by_sample() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = repo("scenes/demos/small_box.demo.json");
    // Every segment stretched at least twice: D_C over stretched segments is defined.
    let mut spec: serde_json::Value =
        serde_json::from_slice(&std::fs::read(repo("scenes/variations/small_box.json")).unwrap())
            .unwrap();
    spec["scene"] = serde_json::json!(repo("scenes/kitchen.json"));
    spec["retime"] = serde_json::json!({"duration_factor": [2.0, 3.0]});
    let spec_path = tmp.path().join("stretch.json");
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    let out = tmp.path().join("out");
    let args = |compare: bool| {
        let mut a: Vec<String> = [
            "augment",
            "--demo",
            demo.to_str().unwrap(),
            "--variations",
            spec_path.to_str().unwrap(),
            "--count",
            "2",
            "--seed",
            "3",
            "--jobs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        if compare {
            a.push("--compare-baseline".into());
        }
        a
    };
    let run = |a: Vec<String>| {
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = dexwarp(&refs);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    // A plain run first: no baseline anywhere.
    run(args(false));
    let stats = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p.join("stats.json")).unwrap()).unwrap()
    };
    assert!(stats(&out).get("baseline").is_none());
    // With the comparison, the finished samples run again.
    let said = run(args(true));
    assert!(
        said.contains("2 run now")
            && said.contains("paired: both")
            && said.contains("(McNemar p ")
            && said.contains("lost in the grasp: contact IK")
            && said.contains("object off its plan as the carry starts"),
        "{said}"
    );
    let s = stats(&out);
    let b = &s["baseline"];
    let ran = s["ran"].as_u64().unwrap();
    assert!(ran > 0, "{s}");
    assert_eq!(b["ran"].as_u64(), Some(ran));
    check_paired(
        &b["paired"],
        ran,
        s["passed"].as_u64().unwrap(),
        b["passed"].as_u64().unwrap(),
    );
    // One cause per failure: each hand's causes add up to its failures on these samples.
    for (hand, failed) in [
        ("contact_ik", ran - s["passed"].as_u64().unwrap()),
        ("baseline", b["failed"].as_u64().unwrap()),
    ] {
        let causes = b["failed_by_cause"][hand].as_object().expect("causes");
        assert_eq!(causes.len(), 6, "{causes:?}");
        let sum: u64 = causes.values().map(|v| v.as_u64().unwrap()).sum();
        assert_eq!(sum, failed, "{hand}: {causes:?}");
    }

    let mut rows = csv::Reader::from_path(out.join("samples.csv")).unwrap();
    let headers = rows.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    for r in rows.records() {
        let r = r.unwrap();
        let dir = out.join(&r[col("status")]).join(&r[col("id")]);
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("baseline.report.json")).unwrap())
                .unwrap();
        assert_eq!(report["hand"], "baseline");
        assert!(dir.join("baseline.frames.csv").is_file());
        let demos = std::fs::read_dir(&dir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(".demo.json")
            })
            .count();
        assert_eq!(demos, 1, "only contact IK's demonstration is written");
        let want = if report["physics"]["verdict"] == "pass" {
            "kept"
        } else {
            "failed"
        };
        assert_eq!(&r[col("baseline_status")], want);
        let dc: f64 = r[col("baseline_d_c_mm")].parse().unwrap();
        assert_eq!(dc, report["metrics"]["d_c_mm"]["warped"].as_f64().unwrap());
        assert!(r[col("stretch_max")].parse::<f64>().unwrap() >= 2.0);
        for c in ["d_c_stretched_mm", "baseline_d_c_stretched_mm"] {
            let v: f64 = r[col(c)].parse().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v > 0.0, "{c}: {:?}", &r[col(c)]);
        }
        // Each hand's slide on the object, from its own report.
        let slide: f64 = r[col("baseline_grasp_slide_mm")].parse().unwrap();
        assert_eq!(
            slide,
            report["metrics"]["grasp_slide_mm"]["warped"]
                .as_f64()
                .unwrap()
        );
        let own: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
        let slide: f64 = r[col("grasp_slide_mm")].parse().unwrap();
        assert_eq!(
            slide,
            own["metrics"]["grasp_slide_mm"]["warped"].as_f64().unwrap()
        );
        // And how far each hand's grasp sits from the recorded one.
        for (c, rep) in [
            ("grasp_shift_mm", &own),
            ("baseline_grasp_shift_mm", &report),
        ] {
            let shift: f64 = r[col(c)].parse().unwrap();
            assert_eq!(shift, rep["metrics"]["grasp_shift_mm"].as_f64().unwrap());
            assert!(shift.is_finite() && shift >= 0.0, "{c}: {shift}");
        }
        // And how far each hand turned the released object: the report's release turn when
        // the hand turned it, 0 when the object turned by itself, empty without a release.
        for (c, rep) in [
            ("release_turn_by_hand_deg", &own),
            ("baseline_release_turn_by_hand_deg", &report),
        ] {
            let turn = &rep["physics"]["release"]["turn"];
            let expect = if turn.is_null() {
                None
            } else if turn["by_hand"].is_null() {
                Some(0.0)
            } else {
                turn["deg"].as_f64()
            };
            let cell = &r[col(c)];
            assert_eq!(cell.parse::<f64>().ok(), expect, "{c}: {cell:?} {turn}");
        }
        // And how far each hand's approach and closing moved the object: the position error
        // its physics report gives at the contact segment's first frame, also in its frames.
        for (c, rep, frames) in [
            ("onset_error_mm", &own, "frames.csv"),
            ("baseline_onset_error_mm", &report, "baseline.frames.csv"),
        ] {
            let onset = &rep["physics"]["onset"];
            let mm: f64 = r[col(c)].parse().unwrap();
            assert_eq!(mm, onset["position_error_mm"].as_f64().unwrap(), "{c}");
            let first = onset["frame"].as_u64().unwrap() as usize;
            let text = std::fs::read_to_string(dir.join(frames)).unwrap();
            let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
            let k = head
                .iter()
                .position(|h| *h == "physics_position_error_mm")
                .unwrap();
            let in_frames: f64 = text
                .lines()
                .nth(1 + first)
                .unwrap()
                .split(',')
                .nth(k)
                .unwrap()
                .parse()
                .unwrap();
            assert!(
                (in_frames - mm).abs() < 1e-6,
                "{c}: {in_frames} against {mm}"
            );
        }
    }
    for m in ["grasp_slide_mm", "grasp_shift_mm", "onset_error_mm"] {
        assert_eq!(b[m]["contact_ik"]["n"].as_u64(), Some(ran), "{m}: {b}");
    }
    let turned = b["release_turn_by_hand_deg"]["contact_ik"]["n"]
        .as_u64()
        .unwrap();
    assert!(turned > 0 && turned <= ran, "{b}");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("grasp shift"));
    assert!(page.contains("grasp onset"));
    assert!(page.contains("release turn"));
    assert!(page.contains("Contact IK against the SE(3) baseline"));
    assert!(page.contains("failed, by cause"));

    // A rerun skips everything and writes the same figures.
    let before = strip_timing(&out.join("stats.json"));
    let said = run(args(true));
    assert!(said.contains("0 run now"), "{said}");
    assert_eq!(strip_timing(&out.join("stats.json")), before);

    // Other commands do not take the baseline's report for an output of the run.
    let keep = tmp.path().join("keep.csv");
    let o = dexwarp(&[
        "filter",
        out.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("of {ran}")),
        "filter sees {ran} reports: {}",
        stderr(&o)
    );

    // `--margin`: the finished samples run again with each hand's margin; `robust` per
    // sample agrees with its reports, and the robust counts with the rows.
    let mut with_margin = args(true);
    with_margin.push("--margin".into());
    let said = run(with_margin.clone());
    assert!(
        said.contains("2 run now")
            && said.contains("robust (the margin holds")
            && said.contains("paired robust: both"),
        "{said}"
    );
    let mut rows = csv::Reader::from_path(out.join("samples.csv")).unwrap();
    let headers = rows.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let (mut robust, mut baseline_robust) = (0, 0);
    for r in rows.records() {
        let r = r.unwrap();
        let dir = out.join(&r[col("status")]).join(&r[col("id")]);
        for (file, status, flag, count) in [
            ("report.json", "status", "robust", &mut robust),
            (
                "baseline.report.json",
                "baseline_status",
                "baseline_robust",
                &mut baseline_robust,
            ),
        ] {
            let report: serde_json::Value =
                serde_json::from_slice(&std::fs::read(dir.join(file)).unwrap()).unwrap();
            let margin = &report["physics"]["margin"];
            assert!(margin["conditions"].is_array(), "{file}: {margin}");
            let want = margin["robust"].as_bool().unwrap();
            assert_eq!(&r[col(flag)], want.to_string(), "{file}");
            if want {
                assert_eq!(&r[col(status)], "kept", "a robust sample passed physics");
                *count += 1;
            }
        }
    }
    let s = stats(&out);
    assert_eq!(s["robust"]["kept"].as_u64(), Some(robust), "{s}");
    let b = &s["baseline"];
    assert_eq!(b["robust"]["kept"].as_u64(), Some(baseline_robust), "{b}");
    check_paired(&b["paired_robust"], ran, robust, baseline_robust);
    assert!(
        std::fs::read_to_string(out.join("index.html"))
            .unwrap()
            .contains("baseline: robust")
    );
    let said = run(with_margin);
    assert!(said.contains("0 run now"), "{said}");
    // `filter --robust` keeps exactly the robust samples.
    let o = dexwarp(&[
        "filter",
        out.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
        "--robust",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("kept {robust} of {ran}")),
        "{}",
        stderr(&o)
    );
}

/// The cluster examples of the README, dry-run here: the Slurm array script for the even
/// indices, the Kubernetes Indexed Job's command for the odd ones, then the merge script.
#[test]
fn the_slurm_and_kubernetes_examples_shard_and_merge() {
    let yaml = std::fs::read_to_string(repo("scripts/augment/k8s-job.yaml")).unwrap();
    let sbatch = std::fs::read_to_string(repo("scripts/augment/slurm.sbatch")).unwrap();
    assert!(yaml.contains("completionMode: Indexed") && yaml.contains("completions: 8"));
    assert!(yaml.contains("parallelism: 8") && yaml.contains("{name: SHARDS, value: \"8\"}"));
    assert!(yaml.contains("scripts/augment/shard.sh"));
    assert!(sbatch.contains("#SBATCH --array=0-7") && sbatch.contains("SHARDS:-8"));
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("shared");
    let env = |c: &mut Command| {
        c.current_dir(repo("."))
            .env("DEXWARP", env!("CARGO_BIN_EXE_dexwarp"))
            .env("DEMO", "scenes/demos/small_box.demo.json")
            .env("SPEC", "scenes/variations/small_box.json")
            .env("COUNT", "4")
            .env("JOBS", "1")
            .env("OUT", &out)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .env_remove("INDEX");
    };
    for k in 0..8 {
        let mut c = Command::new("bash");
        env(&mut c);
        if k % 2 == 0 {
            c.arg("scripts/augment/slurm.sbatch")
                .env("SLURM_ARRAY_TASK_ID", k.to_string());
        } else {
            c.arg("scripts/augment/shard.sh")
                .env("SHARDS", "8")
                .env("JOB_COMPLETION_INDEX", k.to_string());
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "shard {k}: {}", stderr(&o));
    }
    let mut c = Command::new("bash");
    env(&mut c);
    let o = c.arg("scripts/augment/merge.sh").output().unwrap();
    assert!(o.status.success(), "merge: {}", stderr(&o));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["attempts"], 4);
    assert_eq!(stats["shards"].as_array().unwrap().len(), 8);
    assert_eq!(
        stats["ran"].as_u64().unwrap() + stats["rejected"].as_u64().unwrap(),
        4
    );
}
