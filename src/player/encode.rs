//! Compact encodings of the player's arrays: little-endian integers in base64 (RFC 4648), and
//! the quantization of world poses into `int16` (positions on a per-trajectory grid,
//! quaternions scaled by 32767).

use nalgebra::{Isometry3, Point3, Vector3};

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding.
pub fn base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// `int16` values, little-endian, in base64.
pub fn i16s(values: &[i16]) -> String {
    base64(
        &values
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

/// `uint32` values, little-endian, in base64.
pub fn u32s(values: &[u32]) -> String {
    base64(
        &values
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

/// A uniform grid for positions: `x = origin + step * q`, `q` an `int16`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub origin: Vector3<f64>,
    /// Grid spacing [m].
    pub step: f64,
}

impl Grid {
    /// The finest grid holding every point of `points` (and at least a 1 µm spacing).
    pub fn around<'a>(points: impl Iterator<Item = &'a Vector3<f64>>) -> Grid {
        let (mut lo, mut hi) = (Vector3::repeat(f64::MAX), Vector3::repeat(f64::MIN));
        for p in points.filter(|p| p.iter().all(|x| x.is_finite())) {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        if lo.x > hi.x {
            return Grid {
                origin: Vector3::zeros(),
                step: 1e-4,
            };
        }
        let half = (hi - lo).max() / 2.0;
        Grid {
            origin: (lo + hi) / 2.0,
            step: (half / 32000.0).max(1e-6),
        }
    }

    /// `p` on the grid, clamped to the `int16` range (non-finite values become the origin).
    pub fn quantize(&self, p: &Vector3<f64>, out: &mut Vec<i16>) {
        for k in 0..3 {
            let q = (p[k] - self.origin[k]) / self.step;
            out.push(if q.is_finite() {
                q.round().clamp(-32767.0, 32767.0) as i16
            } else {
                0
            });
        }
    }

    /// The grid as `[ox, oy, oz, step]` for the page.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!([self.origin.x, self.origin.y, self.origin.z, self.step])
    }
}

/// A pose as 7 `int16`: the position on `grid`, the quaternion `[w, x, y, z]` (w ≥ 0) × 32767.
pub fn pose(grid: &Grid, iso: &Isometry3<f64>, out: &mut Vec<i16>) {
    grid.quantize(&iso.translation.vector, out);
    let q = iso.rotation.quaternion();
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    for c in [q.w, q.i, q.j, q.k] {
        let v = s * c * 32767.0;
        out.push(if v.is_finite() {
            v.round().clamp(-32767.0, 32767.0) as i16
        } else {
            0
        });
    }
}

/// A point of a local frame on `grid`.
pub fn point(grid: &Grid, p: &Point3<f64>, out: &mut Vec<i16>) {
    grid.quantize(&p.coords, out);
}

/// A pose as 7 plain numbers `[x, y, z, w, qx, qy, qz]`, rounded to 0.1 µm and 1e-7.
pub fn pose_json(iso: &Isometry3<f64>) -> serde_json::Value {
    let t = iso.translation.vector;
    let q = iso.rotation.quaternion();
    let r = |x: f64| (x * 1e7).round() / 1e7;
    serde_json::json!([r(t.x), r(t.y), r(t.z), r(q.w), r(q.i), r(q.j), r(q.k)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded, "{plain:?}");
        }
    }

    #[test]
    fn grid_round_trip_is_within_half_a_step() {
        let pts = [Vector3::new(-1.0, 0.2, 3.0), Vector3::new(2.0, 0.5, 0.9)];
        let g = Grid::around(pts.iter());
        for p in &pts {
            let mut q = Vec::new();
            g.quantize(p, &mut q);
            let back = Vector3::new(
                g.origin.x + g.step * f64::from(q[0]),
                g.origin.y + g.step * f64::from(q[1]),
                g.origin.z + g.step * f64::from(q[2]),
            );
            assert!(
                (back - p).amax() <= g.step / 2.0 + 1e-12,
                "{p:?} -> {back:?}"
            );
        }
    }
}
