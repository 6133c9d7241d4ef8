//! `dexwarp augment`: one demonstration into many, by a seeded variation sampler with physics
//! filtering and yield statistics.
//!
//! 1. the spec ([`spec`]): the `dexwarp.variations/1` file (what to sample, in world units),
//! 2. the sampler ([`sampler`]): variation `i` as an ordinary `dexwarp.config/1`, a function of
//!    `(seed, i)` only, with infeasible samples rejected before running,
//! 3. the run ([`run`]): every feasible sample through the whole pipeline and physics, in parallel,
//!    into `kept/<id>/` or `failed/<id>/`; shards and merging,
//! 4. the figures ([`stats`]): `samples.csv` and `stats.json` (attempts, rejections, yield, reasons, time),
//! 5. the page ([`page`]): `index.html`.
//!
//! The seed of variation `i` is `splitmix64(splitmix64(seed) ^ splitmix64(i + 1))`: a
//! fixed function (std's hasher is not stable across releases), so sample `i` is the same
//! in any shard, on any machine, with any `--count` larger than `i`.

pub mod page;
pub mod run;
pub mod sampler;
pub mod spec;
pub mod stats;

pub use run::{Augment, AugmentOptions, merge, run};
pub use spec::Spec;

/// The RNG seed of variation `index` of a run seeded with `seed`.
pub fn variation_seed(seed: u64, index: u64) -> u64 {
    crate::math::stream_seed(seed, index)
}

/// The folder name of variation `index`: six digits, more when needed.
pub fn sample_id(index: u64) -> String {
    format!("{index:06}")
}
