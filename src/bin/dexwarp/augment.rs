//! `dexwarp augment`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

use crate::args::{EnsembleArgs, OutDir, Sharding, Workers};

/// Sample N variations of a demonstration from a spec, run each with physics, and sort
/// them into DIR/kept and DIR/failed with the yield in DIR/stats.json and DIR/index.html.
#[derive(Debug, Args)]
#[command(
    after_help = "The spec is a dexwarp.variations/1 file (README, \"augment\"); scenes/variations has one per built-in demonstration.\nSample i depends only on --seed and i: shards and reruns agree; finished samples are skipped unless --force.\n\nExamples:\n  dexwarp augment --demo scenes/demos/mug.demo.json --variations scenes/variations/mug.json --count 200 --seed 1 --out out/mug\n  dexwarp augment --demo scenes/demos/cube.demo.json --variations scenes/variations/cube.json --count 1000 --seed 1 --out /shared/cube --shard $SLURM_ARRAY_TASK_ID/8\n  dexwarp augment --merge /shared/cube --out /shared/cube"
)]
pub struct AugmentArgs {
    /// Demonstration to vary (`dexwarp.demo/1`).
    #[arg(long, value_name = "FILE", required_unless_present = "merge")]
    demo: Option<PathBuf>,
    /// Variation spec (`dexwarp.variations/1`).
    #[arg(long, value_name = "FILE", required_unless_present = "merge")]
    variations: Option<PathBuf>,
    /// Number of variations to sample.
    #[arg(long, value_name = "N", required_unless_present = "merge")]
    count: Option<u64>,
    /// Seed of the sampler.
    #[arg(long, value_name = "S", default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    out: OutDir,
    #[command(flatten)]
    workers: Workers,
    #[command(flatten)]
    sharding: Sharding,
    /// Also run every sample with the SE(3) baseline hand (rigid transfer) on the same
    /// object trajectory: its verdict and D_C per sample in samples.csv, its yield and the
    /// paired counts in stats.json and index.html (about twice the time).
    #[arg(long)]
    compare_baseline: bool,
    /// Also measure the robustness margin of every sample that passes physics (with each
    /// hand): five more replays with less friction and more mass; `robust` per sample in
    /// samples.csv, the robust yield in stats.json (`filter --robust` keeps those samples;
    /// about 4x the time of a plain run).
    #[arg(long)]
    margin: bool,
    #[command(flatten)]
    ensemble: EnsembleArgs,
    /// Combine the shard files found in these folders into DIR (--out).
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with_all = ["demo", "variations", "count", "shard"])]
    merge: Vec<PathBuf>,
}

pub fn run(args: AugmentArgs, limits: Limits) -> Result<()> {
    let AugmentArgs {
        demo,
        variations,
        count,
        seed,
        out: OutDir { out },
        workers,
        sharding: Sharding { shard, force },
        compare_baseline,
        margin,
        ensemble,
        merge,
    } = args;
    let aug = if merge.is_empty() {
        let (Some(demo), Some(variations), Some(count)) = (demo, variations, count) else {
            anyhow::bail!("--demo, --variations and --count are required without --merge");
        };
        dexwarp::augment::run(&dexwarp::augment::AugmentOptions {
            demo,
            variations,
            count,
            seed,
            out: out.clone(),
            jobs: workers.jobs(),
            shard,
            force,
            compare_baseline,
            margin,
            physics: ensemble.options(),
            limits,
            progress: true,
        })?
    } else {
        dexwarp::augment::merge(&merge, &out, &limits)?
    };
    let s = &aug.stats;
    let file = match shard {
        Some(k) if merge.is_empty() => {
            format!("stats.shard-{}-of-{}.json", k.index, k.count)
        }
        _ => "stats.json".into(),
    };
    eprintln!(
        "{} attempts: {} rejected, {} ran, {} kept, {} failed (yield {:.1} %); {} run now, {} already finished, {:.0} samples/hour; {}",
        s.attempts,
        s.rejected,
        s.ran,
        s.passed,
        s.failed,
        s.yield_ * 100.0,
        s.timing.ran_now,
        s.timing.skipped_now,
        s.timing.samples_per_hour,
        out.join(file).display()
    );
    if let Some(e) = &s.ensemble {
        eprintln!(
            "ensemble verdicts: {} samples, median pass fraction {}, {} uncertain ({} of them kept); {} replays run for the {} asked (the early stop saves some, an uncertain decision takes more)",
            e.samples,
            e.pass_fraction
                .median
                .map_or("-".into(), |m| format!("{m:.2}")),
            e.uncertain,
            e.uncertain_kept,
            e.replayed,
            e.asked
        );
    }
    if let Some(r) = &s.robust {
        eprintln!(
            "robust (the margin holds under every condition): {} of the {} kept (yield {:.1} %)",
            r.kept,
            s.passed,
            r.yield_ * 100.0
        );
    }
    if let Some(b) = &s.baseline {
        print_baseline(b);
    }
    Ok(())
}

/// The baseline comparison's lines (`--compare-baseline`).
fn print_baseline(b: &dexwarp::augment::stats::BaselineStats) {
    let p = &b.paired;
    eprintln!(
        "baseline hand: {} kept of {} ran (yield {:.1} %); paired: both {}, only contact IK {}, only baseline {}, neither {} (McNemar p {})",
        b.passed,
        b.ran,
        b.yield_ * 100.0,
        p.both,
        p.only_contact_ik,
        p.only_baseline,
        p.neither,
        p.p_text()
    );
    if let Some(f) = &b.paired_pass_fraction {
        eprintln!(
            "pass fractions over {} samples: contact IK {:.2}, baseline {:.2} (mean); higher for contact IK on {}, for the baseline on {}, equal on {} (signed-rank p {})",
            f.samples,
            f.contact_ik_mean,
            f.baseline_mean,
            f.contact_ik_higher,
            f.baseline_higher,
            f.equal,
            f.p_text()
        );
    }
    let c = &b.failed_by_cause;
    eprintln!(
        "lost in the grasp: contact IK {}, baseline {}; pushed after the release: {}, {} (stats.json baseline.failed_by_cause has every cause)",
        c.contact_ik.lost_in_grasp,
        c.baseline.lost_in_grasp,
        c.contact_ik.pushed_after_release,
        c.baseline.pushed_after_release
    );
    let o = &b.onset_error_mm;
    if let (Some(ik), Some(base)) = (o.contact_ik.median, o.baseline.median) {
        eprintln!(
            "object off its plan as the carry starts (the approach and closing moved it), median of {}: contact IK {ik:.1} mm, baseline {base:.1} mm",
            o.contact_ik.n
        );
    }
    if let (Some(r), Some(p)) = (&b.robust, &b.paired_robust) {
        eprintln!(
            "baseline robust: {} of its {} kept (yield {:.1} %); paired robust: both {}, only contact IK {}, only baseline {}, neither {} (McNemar p {})",
            r.kept,
            b.passed,
            r.yield_ * 100.0,
            p.both,
            p.only_contact_ik,
            p.only_baseline,
            p.neither,
            p.p_text()
        );
    }
}
