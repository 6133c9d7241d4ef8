//! The ensemble verdict: a trajectory is kept on the fraction of perturbed replays it passes,
//! not on one replay (docs/METHOD.md, "The ensemble verdict (stage 6b)").
//!
//! One replay's verdict is not a property of the trajectory: a grasp near the edge of
//! holding is chaotic in Rapier (a micrometre of noise on the poses turned 8 of 20 teapot
//! samples' verdicts), so a keep/drop decision taken on it is partly a coin flip. The
//! ensemble replays the trajectory [`EnsembleParams::members`] times (K, default 8):
//!
//! - **member 0** is the nominal replay, exactly the single replay of before: its report is
//!   the one the physics section shows (tracking, drop, grip, ...) and its reasons explain a
//!   failure;
//! - **members 1..K−1** replay it under a seeded draw ([`Draw`]) of what a recording and a
//!   simulator really get wrong: a constant offset of the hand relative to the object
//!   (translation and rotation about the wrist), a slowly wandering jitter of the wrist (the
//!   joints' too when asked), the object's start pose on its support (x, y, yaw), the
//!   hand-object friction, the object's mass and the finger skin. The magnitudes are [`EnsembleParams`]' fields,
//!   and docs/METHOD.md says where each default comes from.
//!
//! What a member judges: everything the replay decides (divergence, drop, tracking,
//! stability, release). The penetration checks measure the trajectory as written, not a
//! replay, so every member takes the nominal's: a trajectory whose fingers are too deep
//! fails in every member.
//!
//! **The decision.** The pass fraction `x / n` of the `n` members replayed, its 95 % Wilson
//! score interval, and `keep` when the fraction reaches [`EnsembleParams::keep_threshold`]
//! (default 0.5: kept when it holds in at least half of the realistic variations). The
//! decision is **uncertain** when the interval contains the threshold: K replays cannot
//! tell which side the trajectory's true pass rate is on. At K = 8 and the default
//! threshold, 0-1 and 7-8 passes are certain, 2-6 uncertain. A higher threshold cannot be
//! certified at this K (8 of 8 passes give an interval from 0.68): choose it with K.
//!
//! **Early stop, and more members while uncertain.** After the nominal replay, members 1 to
//! K − 2 are replayed as one batch and the last one only if needed; the ensemble stops once no
//! outcome of the members left could change the decision or its certainty. A decision still
//! uncertain after K members gets K more, one batch at a time, until it is certain or
//! [`EnsembleParams::max_members`] (default 32) are replayed: a trajectory that holds 6 times
//! in 10 is dropped by the draw of independent members one time in six at K = 8, one in eleven
//! at 32, and less often with the hypercube's draws (below).
//! Which members count is decided in member order, whatever the batch, so the report is the
//! same on any number of cores.
//!
//! **Shared worlds.** With the kinematic hand, a batch's members are replayed together in one
//! Rapier world, at most 8 to a world, each in a collision group of its own
//! ([`super::world::ReplayWorld::shared`]): the solver packs different members' contacts into
//! its SIMD lanes, which one member's contacts (all on the one object) never fill. The worlds
//! of a batch run in parallel; how the members are grouped depends on K alone. The nominal
//! member keeps a world of its own and is the single replay to the bit; the others are not
//! the same to the bit as alone (the solver's order differs), which moves pass fractions less
//! than another ensemble seed does (docs/RESULTS.md, "Physics speed judged by pass
//! fractions").
//!
//! **Draws.** By default the members form Latin hypercubes ([`Sampling::LatinHypercube`]):
//! members 1 to K − 1 take one value in each of K − 1 equally likely strata of every
//! perturbation, and each extension of K members a hypercube of its own, so the share of
//! members on a perturbation's failing side follows the share of its distribution there
//! instead of the luck of K independent draws (two ensemble seeds disagreed on 7 of 33
//! teapot samples with independent draws, on 3 with the hypercube, at K = 8).
//!
//! Seeds: member `m`'s place within its strata and its jitter come from
//! `math::stream_seed(seed ^ fnv(name), m)`, a ChaCha8 stream of its own, where `name` is the
//! demonstration's; the strata's shuffles from streams of the same `seed ^ fnv(name)`. The
//! same trajectory and seed give the same draws; two hands' outputs of one sample (same name)
//! get the same draws, which pairs their members.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use std::path::Path;

use crate::{Error, Result};

/// The ensemble's size, seed, threshold and perturbation magnitudes (`params.physics.ensemble`
/// in a config; `--ensemble`, `--ensemble-seed` on the command line).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EnsembleParams {
    /// Replays per trajectory, K, the nominal one included; default 8. 1 is the single
    /// nominal replay (no `physics.ensemble` in the report).
    pub members: usize,
    /// Seed of the members' draws, mixed with the demonstration's name; default 0.
    pub seed: u64,
    /// Pass fraction at which the trajectory is kept; default 0.5.
    pub keep_threshold: f64,
    /// Stop once the remaining members cannot change the decision or its certainty;
    /// default `true`.
    pub early_stop: bool,
    /// Most members replayed while the decision is uncertain (the 95 % interval contains the
    /// keep threshold): K more at a time until it is not or this many are replayed; default
    /// 32. At most K for a fixed K.
    pub max_members: usize,
    /// How the members' draws cover the perturbations; default `latin_hypercube`.
    pub sampling: Sampling,
    /// σ of the constant offset of the hand relative to the object, per axis [mm];
    /// default 1.0.
    pub hand_offset_mm: f64,
    /// σ of the constant rotation of the hand about its wrist, per axis [deg]; default 0.5.
    pub hand_rotation_deg: f64,
    /// σ of the wrist's per-frame jitter, per axis [mm]; default 0.2.
    pub wrist_jitter_mm: f64,
    /// σ of every joint's per-frame jitter [rad]; default 0 (off). Measured on the frying
    /// pan demonstration: 0.002 rad (0.11°) alone drops it in 7 of 8 members where a
    /// constant 1 mm hand offset, ±0.5 mm of skin or ±20 % of friction drop it in none: a
    /// kinematic finger that wiggles against the object ratchets it out of the grasp, which
    /// no compliant finger does. Settable for a hand whose fingers are the question.
    pub joint_jitter_rad: f64,
    /// Correlation time of the jitter [s]; default 0.2. The jitter is a stationary
    /// first-order autoregressive process with this time constant: a recording's error
    /// that is left after its pipeline's filtering and a controller's tracking error
    /// wander, they do not shake at the frame rate (white noise at 30 fps drives a
    /// kinematic hand into the object at every frame and shakes grasps loose that hold
    /// in every other member).
    pub jitter_time_s: f64,
    /// σ of the object's start position on its support, per horizontal axis [mm];
    /// default 1.0.
    pub object_start_mm: f64,
    /// σ of the object's start yaw about the vertical [deg]; default 1.0.
    pub object_start_yaw_deg: f64,
    /// Half-width of the uniform relative spread of the hand-object friction; default 0.2
    /// (μ × 0.8-1.2).
    pub friction_spread: f64,
    /// Half-width of the uniform relative spread of the object's mass; default 0.1.
    pub mass_spread: f64,
    /// Half-width of the uniform spread of the finger skin [mm]; default 0.5.
    pub skin_spread_mm: f64,
}

impl Default for EnsembleParams {
    fn default() -> Self {
        EnsembleParams {
            members: 8,
            seed: 0,
            keep_threshold: 0.5,
            early_stop: true,
            max_members: 32,
            sampling: Sampling::LatinHypercube,
            hand_offset_mm: 1.0,
            hand_rotation_deg: 0.5,
            wrist_jitter_mm: 0.2,
            joint_jitter_rad: 0.0,
            jitter_time_s: 0.2,
            object_start_mm: 1.0,
            object_start_yaw_deg: 1.0,
            friction_spread: 0.2,
            mass_spread: 0.1,
            skin_spread_mm: 0.5,
        }
    }
}

/// Most members an ensemble may ask for (each is a whole replay).
pub const MAX_MEMBERS: usize = 256;

impl EnsembleParams {
    /// The single nominal replay.
    pub fn single() -> EnsembleParams {
        EnsembleParams {
            members: 1,
            ..EnsembleParams::default()
        }
    }

    /// Most members replayed: [`EnsembleParams::max_members`], never fewer than K, and K
    /// alone for the single replay.
    pub fn most_members(&self) -> usize {
        if self.members == 1 {
            1
        } else {
            self.max_members.max(self.members)
        }
    }

    /// Checks that every value is usable; the error names the field.
    pub fn check(&self) -> Result<()> {
        let path = Path::new("physics parameters");
        if !(1..=MAX_MEMBERS).contains(&self.members) {
            return Err(Error::invalid(
                path,
                "ensemble.members",
                format!("is {}; expected 1 to {MAX_MEMBERS}", self.members),
            ));
        }
        if !(1..=MAX_MEMBERS).contains(&self.max_members) {
            return Err(Error::invalid(
                path,
                "ensemble.max_members",
                format!("is {}; expected 1 to {MAX_MEMBERS}", self.max_members),
            ));
        }
        if !(self.keep_threshold > 0.0 && self.keep_threshold <= 1.0) {
            return Err(Error::invalid(
                path,
                "ensemble.keep_threshold",
                format!("is {}; expected a value in (0, 1]", self.keep_threshold),
            ));
        }
        for (field, v) in [
            ("ensemble.hand_offset_mm", self.hand_offset_mm),
            ("ensemble.hand_rotation_deg", self.hand_rotation_deg),
            ("ensemble.wrist_jitter_mm", self.wrist_jitter_mm),
            ("ensemble.joint_jitter_rad", self.joint_jitter_rad),
            ("ensemble.jitter_time_s", self.jitter_time_s),
            ("ensemble.object_start_mm", self.object_start_mm),
            ("ensemble.object_start_yaw_deg", self.object_start_yaw_deg),
            ("ensemble.skin_spread_mm", self.skin_spread_mm),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(
                    path,
                    field,
                    format!("is {v}; expected a finite value >= 0"),
                ));
            }
        }
        for (field, v) in [
            ("ensemble.friction_spread", self.friction_spread),
            ("ensemble.mass_spread", self.mass_spread),
        ] {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(Error::invalid(
                    path,
                    field,
                    format!("is {v}; expected a value in [0, 1)"),
                ));
            }
        }
        Ok(())
    }

    /// The draw of member `member` of the trajectory named `name` (member 0: the nominal).
    pub fn draw(&self, name: &str, member: usize) -> Draw {
        if member == 0 {
            return Draw::default();
        }
        let base = self.seed ^ fnv1a(name);
        let seed = crate::math::stream_seed(base, member as u64);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        match self.sampling {
            Sampling::Independent => self.draw_from(seed, |_, gauss| {
                if gauss {
                    standard(&mut rng)
                } else {
                    rng.random::<f64>()
                }
            }),
            Sampling::LatinHypercube => {
                let u = latin_hypercube(base, self.members, member, &mut rng);
                self.draw_from(
                    seed,
                    |d, gauss| {
                        if gauss { inverse_normal(u[d]) } else { u[d] }
                    },
                )
            }
        }
    }

    /// The draw whose `d`-th coordinate is `sample(d, gauss)`: a standard normal value when
    /// `gauss`, a uniform one in [0, 1) otherwise; the dimensions in the order of [`Draw`]'s
    /// fields.
    fn draw_from(&self, seed: u64, mut sample: impl FnMut(usize, bool) -> f64) -> Draw {
        let mut d = 0;
        let mut next = |gauss: bool| {
            d += 1;
            sample(d - 1, gauss)
        };
        let mut gauss3 = |sigma: f64| [next(true) * sigma, next(true) * sigma, next(true) * sigma];
        let hand_offset_mm = gauss3(self.hand_offset_mm);
        let hand_rotation_deg = gauss3(self.hand_rotation_deg);
        let start = gauss3(self.object_start_mm);
        let yaw = next(true) * self.object_start_yaw_deg;
        let mut spread = |half: f64| (2.0 * next(false) - 1.0) * half;
        let friction_scale = 1.0 + spread(self.friction_spread);
        let mass_scale = 1.0 + spread(self.mass_spread);
        let skin_mm = spread(self.skin_spread_mm);
        Draw {
            seed,
            hand_offset_mm,
            hand_rotation_deg,
            object_start_mm: [start[0], start[1]],
            object_start_yaw_deg: yaw,
            friction_scale,
            mass_scale,
            skin_offset_mm: skin_mm,
        }
    }
}

/// How an ensemble's members sample the perturbations (`ensemble.sampling`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampling {
    /// Every member draws every perturbation on its own.
    Independent,
    /// The perturbed members (1 to K − 1) split each perturbation's distribution into K − 1
    /// equally likely strata and take one value in each, the strata of the perturbations
    /// matched at random (a Latin hypercube). Where a trajectory's outcome hangs on one or
    /// two perturbations (the hand's offset across the handle, the friction), its pass
    /// fraction then varies much less from one ensemble seed to another than with
    /// independent draws; where it does not, it varies no more.
    LatinHypercube,
}

/// The perturbations a draw samples (the fields of [`Draw`] but its seed, with the start's
/// vertical offset drawn and unused).
const DIMS: usize = 13;

/// Member `member`'s coordinates in [0, 1) in the Latin hypercube of its block: the first
/// K − 1 perturbed members (1 to K − 1) are one block, each K members after them (K to
/// 2K − 1, ...: the uncertain ensemble's extensions) another. Each block is a hypercube of
/// its own whose strata are shuffled per dimension by a stream of `base` (the same for every
/// member of the block); the place within the stratum comes from the member's own `rng`.
fn latin_hypercube(base: u64, members: usize, member: usize, rng: &mut ChaCha8Rng) -> [f64; DIMS] {
    let k = members.max(2);
    let (size, block, slot) = if member < k {
        (k - 1, 0, member - 1)
    } else {
        (k, member / k, member % k)
    };
    let mut u = [0.0; DIMS];
    for (d, x) in u.iter_mut().enumerate() {
        let stream = (block * DIMS + d) as u64;
        let mut shuffle = ChaCha8Rng::seed_from_u64(crate::math::stream_seed(!base, stream));
        let mut strata: Vec<usize> = (0..size).collect();
        for i in (1..size).rev() {
            strata.swap(i, shuffle.random_range(0..=i));
        }
        *x = (strata[slot] as f64 + rng.random::<f64>()) / size as f64;
    }
    u
}

/// The standard normal quantile of `p` in (0, 1) (Acklam's rational approximation, relative
/// error below 1.2e-9), `p` clamped to [1e-9, 1 − 1e-9] (at most 6 σ).
fn inverse_normal(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const LOW: f64 = 0.024_25;
    let p = p.clamp(1e-9, 1.0 - 1e-9);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// One member's perturbation (all zero and scales 1 for the nominal member).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Draw {
    /// Seed of the member's stream (the per-frame jitter is drawn from it after the rest);
    /// 0 for the nominal.
    pub seed: u64,
    /// Constant offset of the wrist, world axes [mm].
    pub hand_offset_mm: [f64; 3],
    /// Constant rotation of the hand about its wrist, wrist axes (rotation vector) [deg].
    pub hand_rotation_deg: [f64; 3],
    /// Offset of the object's start position, world x and y [mm].
    pub object_start_mm: [f64; 2],
    /// Turn of the object's start pose about the vertical through its origin [deg].
    pub object_start_yaw_deg: f64,
    /// Scale of the hand-object friction.
    pub friction_scale: f64,
    /// Scale of the object's mass.
    pub mass_scale: f64,
    /// Added to the finger skin [mm].
    pub skin_offset_mm: f64,
}

impl Default for Draw {
    fn default() -> Self {
        Draw {
            seed: 0,
            hand_offset_mm: [0.0; 3],
            hand_rotation_deg: [0.0; 3],
            object_start_mm: [0.0; 2],
            object_start_yaw_deg: 0.0,
            friction_scale: 1.0,
            mass_scale: 1.0,
            skin_offset_mm: 0.0,
        }
    }
}

impl Draw {
    /// `true` for the nominal member's draw.
    pub fn is_nominal(&self) -> bool {
        *self == Draw::default()
    }

    /// The constant wrist transform: `wrist' = offset(wrist)`.
    pub fn apply_to_wrist(&self, wrist: &Isometry3<f64>) -> Isometry3<f64> {
        let t = Vector3::from(self.hand_offset_mm) * 1e-3;
        let r = UnitQuaternion::from_scaled_axis(
            Vector3::from(self.hand_rotation_deg).map(f64::to_radians),
        );
        Translation3::from(t) * wrist * r
    }

    /// The object's start pose: shifted in x-y and turned about the vertical through its
    /// origin.
    pub fn apply_to_start(&self, start: &Isometry3<f64>) -> Isometry3<f64> {
        let [x, y] = self.object_start_mm;
        let yaw = UnitQuaternion::from_axis_angle(
            &Vector3::z_axis(),
            self.object_start_yaw_deg.to_radians(),
        );
        Isometry3::from_parts(
            Translation3::from(start.translation.vector + Vector3::new(x, y, 0.0) * 1e-3),
            yaw * start.rotation,
        )
    }
}

/// The per-frame jitter of a member: a stationary AR(1) process per coordinate,
/// `x[i+1] = a·x[i] + sqrt(1 - a²)·σ·ε`, `a = exp(-1 / (fps·τ))`, started from its stationary
/// distribution (drawn after the member's [`Draw`], from a stream of its own).
pub(crate) struct Jitter {
    rng: ChaCha8Rng,
    wrist_m: f64,
    joint_rad: f64,
    a: f64,
    wrist: Option<Vector3<f64>>,
    joints: Vec<f64>,
}

impl Jitter {
    pub(crate) fn new(draw: &Draw, params: &EnsembleParams, fps: f64) -> Jitter {
        let tau = params.jitter_time_s;
        let a = if tau > 0.0 {
            (-1.0 / (fps * tau)).exp()
        } else {
            0.0
        };
        Jitter {
            rng: ChaCha8Rng::seed_from_u64(crate::math::stream_seed(draw.seed, 0)),
            wrist_m: params.wrist_jitter_mm * 1e-3,
            joint_rad: params.joint_jitter_rad,
            a,
            wrist: None,
            joints: Vec::new(),
        }
    }

    /// Jitters the next frame's wrist (translation) and joints.
    pub(crate) fn apply(&mut self, wrist: &mut Isometry3<f64>, joints: &mut [f64]) {
        let rng = &mut self.rng;
        let mut gauss3 = || Vector3::new(standard(rng), standard(rng), standard(rng));
        let (a, b) = (self.a, (1.0 - self.a * self.a).sqrt());
        let w = match self.wrist {
            None => gauss3() * self.wrist_m,
            Some(w) => w * a + gauss3() * (b * self.wrist_m),
        };
        self.wrist = Some(w);
        wrist.translation.vector += w;
        if self.joints.len() != joints.len() {
            self.joints = (0..joints.len())
                .map(|_| standard(&mut self.rng) * self.joint_rad)
                .collect();
        } else {
            for x in &mut self.joints {
                *x = *x * a + standard(&mut self.rng) * (b * self.joint_rad);
            }
        }
        for (q, x) in joints.iter_mut().zip(&self.joints) {
            *q += x;
        }
    }
}

/// One member's outcome in the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Member {
    /// 0 is the nominal replay.
    pub index: usize,
    pub draw: Draw,
    pub passed: bool,
    /// The first failed reason, if any.
    pub reason: Option<String>,
}

/// Keep or drop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    Keep,
    Drop,
}

impl Decision {
    pub fn as_str(self) -> &'static str {
        match self {
            Decision::Keep => "keep",
            Decision::Drop => "drop",
        }
    }
}

/// The ensemble of one trajectory (`physics.ensemble` in its report).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ensemble {
    /// K, the members asked for.
    pub members: usize,
    /// Most members replayed while the decision stays uncertain.
    #[serde(default)]
    pub max_members: usize,
    /// Members replayed (fewer than K after an early stop).
    pub replayed: usize,
    /// Members that passed.
    pub passed: usize,
    /// `passed / replayed`.
    pub pass_fraction: f64,
    /// 95 % Wilson score interval of the pass fraction, `[low, high]`.
    pub interval: [f64; 2],
    /// The keep threshold.
    pub keep_threshold: f64,
    pub decision: Decision,
    /// The interval contains the threshold: the members cannot tell the side.
    pub uncertain: bool,
    /// The seed of the draws (before the name is mixed in).
    pub seed: u64,
    /// The nominal replay's reasons (member 0), kept when the decision overrides them.
    pub nominal_reasons: Vec<String>,
    /// Every member replayed, in order.
    pub member: Vec<Member>,
}

/// The 95 % Wilson score interval of `passed` successes in `n` trials.
pub fn wilson(passed: usize, n: usize) -> [f64; 2] {
    if n == 0 {
        return [0.0, 1.0];
    }
    const Z: f64 = 1.959_963_984_540_054;
    let n_f = n as f64;
    let p = passed as f64 / n_f;
    let z2 = Z * Z;
    let denom = 1.0 + z2 / n_f;
    let centre = (p + z2 / (2.0 * n_f)) / denom;
    let half = Z * (p * (1.0 - p) / n_f + z2 / (4.0 * n_f * n_f)).sqrt() / denom;
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// Whether a pass fraction fell by more than two ensembles can tell apart by chance: the
/// lower end of the 95 % interval of `before − now` is above 0 (Newcombe's hybrid score
/// interval for a difference of two independent proportions, built from the two Wilson
/// intervals). `(passed, replayed)` for each run. 8 of 8 against 3 of 8 is a drop; against 5
/// of 8 it is not (the draws of two seeds differ by that).
pub fn dropped_significantly(before: (usize, usize), now: (usize, usize)) -> bool {
    let p = |(x, n): (usize, usize)| x as f64 / n.max(1) as f64;
    let (pb, pn) = (p(before), p(now));
    let [lb, _] = wilson(before.0, before.1);
    let [_, un] = wilson(now.0, now.1);
    let lower = (pb - pn) - ((pb - lb).powi(2) + (un - pn).powi(2)).sqrt();
    lower > 0.0
}

/// Decision and certainty of `passed` of `n` at `threshold`.
pub fn decide(passed: usize, n: usize, threshold: f64) -> (Decision, bool) {
    let fraction = passed as f64 / n.max(1) as f64;
    // A tolerance of a few ulps: 4 of 8 reaches 0.5 however it is computed.
    let decision = if fraction + 1e-12 >= threshold {
        Decision::Keep
    } else {
        Decision::Drop
    };
    let [lo, hi] = wilson(passed, n);
    (decision, lo < threshold && threshold < hi)
}

/// Whether the ensemble can stop after `passed` of `replayed` members of `members`: every
/// completion of the remaining ones gives the decision and certainty it has now.
pub fn can_stop(passed: usize, replayed: usize, members: usize, threshold: f64) -> bool {
    let now = decide(passed, replayed, threshold);
    let left = members - replayed;
    (0..=left).all(|extra| decide(passed + extra, members, threshold) == now)
}

impl Ensemble {
    /// The summary of `member` (in order, the nominal first).
    pub fn of(params: &EnsembleParams, member: Vec<Member>, nominal_reasons: Vec<String>) -> Self {
        let replayed = member.len();
        let passed = member.iter().filter(|m| m.passed).count();
        let (decision, uncertain) = decide(passed, replayed, params.keep_threshold);
        Ensemble {
            members: params.members,
            max_members: params.most_members(),
            replayed,
            passed,
            pass_fraction: passed as f64 / replayed.max(1) as f64,
            interval: wilson(passed, replayed),
            keep_threshold: params.keep_threshold,
            decision,
            uncertain,
            seed: params.seed,
            nominal_reasons,
            member,
        }
    }

    /// Why the ensemble drops a trajectory whose nominal replay passed, in words.
    pub fn drop_sentence(&self) -> String {
        let first = self
            .member
            .iter()
            .find(|m| !m.passed)
            .map(|m| {
                format!(
                    "; member {}: {}",
                    m.index,
                    m.reason.as_deref().unwrap_or("failed")
                )
            })
            .unwrap_or_default();
        format!(
            "passes in {} of {} ensemble replays (pass fraction {:.2} < keep threshold {:.2}){first}",
            self.passed, self.replayed, self.pass_fraction, self.keep_threshold
        )
    }
}

/// A standard normal sample (Box-Muller, one of the pair).
fn standard(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// FNV-1a of `s`: a name's stable 64-bit hash (Rust's own hasher is not stable across
/// releases).
fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_the_textbook_values() {
        // 8 of 8: [0.676, 1]; 0 of 8: [0, 0.324]; 4 of 8: [0.215, 0.785].
        let [lo, hi] = wilson(8, 8);
        assert!((lo - 0.6756).abs() < 1e-3 && hi == 1.0, "{lo} {hi}");
        let [lo, hi] = wilson(0, 8);
        assert!(lo == 0.0 && (hi - 0.3244).abs() < 1e-3, "{lo} {hi}");
        let [lo, hi] = wilson(4, 8);
        assert!((lo - 0.2152).abs() < 1e-3 && (hi - 0.7848).abs() < 1e-3);
    }

    #[test]
    fn the_default_threshold_leaves_two_to_six_of_eight_uncertain() {
        let uncertain: Vec<usize> = (0..=8).filter(|&x| decide(x, 8, 0.5).1).collect();
        assert_eq!(uncertain, vec![2, 3, 4, 5, 6]);
        assert_eq!(decide(4, 8, 0.5).0, Decision::Keep);
        assert_eq!(decide(3, 8, 0.5).0, Decision::Drop);
    }

    #[test]
    fn the_early_stop_waits_until_nothing_can_change() {
        // 7 passes of 7: 7/8 and 8/8 are both a certain keep.
        assert!(can_stop(7, 7, 8, 0.5));
        // 6 of 6: 6/8 would be uncertain.
        assert!(!can_stop(6, 6, 8, 0.5));
        assert!(can_stop(0, 7, 8, 0.5));
        assert!(!can_stop(1, 7, 8, 0.5));
        // All replayed: nothing left to change.
        assert!(can_stop(3, 8, 8, 0.5));
    }

    #[test]
    fn a_drop_counts_when_the_intervals_allow_it() {
        assert!(dropped_significantly((8, 8), (3, 8)));
        assert!(dropped_significantly((8, 8), (4, 8)));
        assert!(!dropped_significantly((8, 8), (5, 8)));
        assert!(!dropped_significantly((5, 8), (3, 8)));
        assert!(!dropped_significantly((3, 8), (8, 8)));
        assert!(dropped_significantly((7, 7), (0, 8)));
    }

    #[test]
    fn draws_are_seeded_by_name_member_and_seed() {
        let p = EnsembleParams::default();
        assert!(p.draw("a", 0).is_nominal());
        assert_eq!(p.draw("a", 3), p.draw("a", 3));
        assert_ne!(p.draw("a", 3), p.draw("a", 4));
        assert_ne!(p.draw("a", 3), p.draw("b", 3));
        let q = EnsembleParams {
            seed: 1,
            ..p.clone()
        };
        assert_ne!(p.draw("a", 3), q.draw("a", 3));
        let d = p.draw("a", 1);
        assert!((0.8..=1.2).contains(&d.friction_scale));
        assert!((0.9..=1.1).contains(&d.mass_scale));
        assert!(d.skin_offset_mm.abs() <= 0.5);
    }

    #[test]
    fn the_normal_quantile_matches_the_tables() {
        for (p, x) in [
            (0.5, 0.0),
            (0.975, 1.959_964),
            (0.01, -2.326_348),
            (0.999, 3.090_232),
        ] {
            assert!(
                (inverse_normal(p) - x).abs() < 1e-6,
                "{p}: {}",
                inverse_normal(p)
            );
            assert!((inverse_normal(1.0 - p) + x).abs() < 1e-6);
        }
    }

    #[test]
    fn a_latin_hypercube_puts_one_member_in_each_stratum() {
        let p = EnsembleParams {
            members: 8,
            friction_spread: 0.2,
            ..EnsembleParams::default()
        };
        // Members 1-7, then 8-15 and 16-23 (the extensions): each block fills its strata of
        // every perturbation, one member in each.
        for (block, n) in [(1..8, 7), (8..16, 8), (16..24, 8)] {
            let draws: Vec<Draw> = block.map(|m| p.draw("a", m)).collect();
            let mut friction: Vec<usize> = draws
                .iter()
                .map(|d| ((d.friction_scale - 0.8) / 0.4 * n as f64).floor() as usize)
                .collect();
            friction.sort_unstable();
            assert_eq!(friction, (0..n).collect::<Vec<_>>());
            let mut offset: Vec<usize> = draws
                .iter()
                .map(|d| {
                    let u = normal_cdf(d.hand_offset_mm[0] / p.hand_offset_mm);
                    (u * n as f64).floor() as usize
                })
                .collect();
            offset.sort_unstable();
            assert_eq!(offset, (0..n).collect::<Vec<_>>());
        }
        // Independent draws are the draws of before: the member's own stream, the hand
        // offset's three normals first.
        let iid = EnsembleParams {
            sampling: Sampling::Independent,
            ..p.clone()
        };
        let seed = crate::math::stream_seed(fnv1a("a"), 1);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let first = standard(&mut rng) * p.hand_offset_mm;
        assert_eq!(iid.draw("a", 1).hand_offset_mm[0], first);
        assert_eq!(iid.draw("a", 1).seed, p.draw("a", 1).seed);
        assert_ne!(iid.draw("a", 1), p.draw("a", 1));
    }

    /// Φ by bisection on [`inverse_normal`] (enough for a stratum's index).
    fn normal_cdf(x: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if inverse_normal(mid) < x {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}
