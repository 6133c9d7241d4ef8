//! Corrupted correspondences for the robustness study (docs/METHOD.md "Metrics", paper Fig.
//! "robustness"): D_C of the warped output when a fraction of the correspondences is deleted,
//! or when object-point labels are permuted among pairs, from 0 % to 100 %.
//!
//! Both corruptions act on each frame independently, on `k = round(fraction · n)` of the
//! frame's `n` correspondences, chosen by a ChaCha8 stream seeded with `seed` (frames are
//! visited in order, so the same `(demo, kind, fraction, seed)` always gives the same demo):
//! - [`Corruption::Delete`] removes the `k` chosen pairs, but keeps at least one pair in
//!   every frame that had any. So the contact segment `[c0, c1]` (and with it the warp plan)
//!   is the same for every fraction, and at 100 % every in-contact frame keeps a single
//!   random correspondence: the IK still has something to fit.
//! - [`Corruption::Permute`] moves the object points of the `k` chosen pairs one step along
//!   their random order (a random k-cycle), so every chosen pair gets another pair's object
//!   point (with `k = 1` nothing can move). Hand points and links stay.
//!
//! Score a corrupted run against the clean correspondences (the original demo's), or the
//! corrupted labels would grade themselves.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::model::Demo;

/// How correspondences are corrupted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Corruption {
    /// Delete a fraction of each frame's correspondences (at least one is kept).
    Delete,
    /// Permute the object points among a fraction of each frame's pairs.
    Permute,
}

impl Corruption {
    /// The name used in reports and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Corruption::Delete => "delete",
            Corruption::Permute => "permute",
        }
    }
}

/// A copy of `demo` with a seeded `fraction` (clamped to [0, 1]) of each frame's
/// correspondences corrupted by `kind` (see the module docs).
pub fn corrupt(demo: &Demo, kind: Corruption, fraction: f64, seed: u64) -> Demo {
    let fraction = if fraction.is_nan() {
        0.0
    } else {
        fraction.clamp(0.0, 1.0)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = demo.clone();
    let mut order: Vec<usize> = Vec::new();
    for frame in &mut out.frames {
        let n = frame.contacts.len();
        let k = (fraction * n as f64).round() as usize;
        if n == 0 || k == 0 {
            continue;
        }
        order.clear();
        order.extend(0..n);
        order.shuffle(&mut rng);
        match kind {
            Corruption::Delete => {
                let k = k.min(n - 1);
                let mut drop = vec![false; n];
                for &i in &order[..k] {
                    drop[i] = true;
                }
                let mut i = 0;
                frame.contacts.retain(|_| {
                    i += 1;
                    !drop[i - 1]
                });
            }
            Corruption::Permute => {
                let chosen = &order[..k];
                let points: Vec<_> = chosen
                    .iter()
                    .map(|&i| frame.contacts[i].object_point)
                    .collect();
                for (j, &i) in chosen.iter().enumerate() {
                    frame.contacts[i].object_point = points[(j + 1) % k];
                }
            }
        }
    }
    out
}
