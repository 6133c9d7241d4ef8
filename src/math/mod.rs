//! Pure numerical kernels: B-splines, Savitzky-Golay, rotations, type conversions,
//! quantiles, the exact sign test, durations in frames.
//!
//! Nothing here knows about demonstrations or robots; every kernel has its own unit tests.

pub mod bspline;
pub mod convert;
pub mod quantile;
pub mod rotation;
pub mod savgol;
pub mod sign_test;
pub mod signed_rank;

/// SplitMix64's finalizer: a bijection of `u64` that mixes every bit.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The RNG seed of stream `index` of a run seeded with `seed`:
/// `splitmix64(splitmix64(seed) ^ splitmix64(index + 1))`, a fixed function (std's hasher is
/// not stable across releases), the same on any machine.
pub fn stream_seed(seed: u64, index: u64) -> u64 {
    splitmix64(splitmix64(seed) ^ splitmix64(index.wrapping_add(1)))
}

/// The whole number of frames nearest to `seconds` at `fps` frames per second (half a frame
/// rounds up); 0 when that is not a positive finite number. The hand stages give their
/// windows in seconds and count them in frames with this, so a recording at 10 or 120 fps
/// is treated over the same time as one at 30 fps.
pub fn frames_in(seconds: f64, fps: f64) -> usize {
    let n = (seconds * fps).round();
    if n.is_finite() && n > 0.0 {
        n as usize
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::frames_in;

    #[test]
    fn durations_count_the_nearest_whole_frames() {
        assert_eq!(frames_in(0.5, 30.0), 15);
        assert_eq!(frames_in(0.25, 30.0), 8);
        assert_eq!(frames_in(0.25, 10.0), 3);
        assert_eq!(frames_in(4.0 / 30.0, 30.0), 4);
        assert_eq!(frames_in(0.01, 30.0), 0);
        assert_eq!(frames_in(0.5, f64::NAN), 0);
        assert_eq!(frames_in(-1.0, 30.0), 0);
        assert_eq!(frames_in(f64::INFINITY, 30.0), 0);
    }
}
