//! Closing an object mesh that is almost closed.
//!
//! Physics and the IK's non-penetration term need a solid object: a closed, consistently
//! wound mesh ([`Mesh::is_closed_and_consistently_wound`]). Scanned and reconstructed
//! meshes often miss that by a few triangles: zero-volume slivers (a triangle and its
//! reverse on the same three vertices, which makes their edges shared by four triangles),
//! repeated triangles, triangles with a repeated vertex, small holes. [`Mesh::repair`]
//! removes the first three and fills holes of at most [`MAX_HOLE_EDGES`] edges with a fan,
//! then says what it did ([`Repair`]); a mesh it cannot close keeps its defects, described by
//! [`Mesh::defects`], and is refused by whatever needs a solid.

use std::collections::HashMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::Mesh;

/// Largest hole [`Mesh::repair`] fills, in boundary edges.
pub const MAX_HOLE_EDGES: usize = 24;

/// What [`Mesh::repair`] changed.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Repair {
    /// Pairs of a triangle and its reverse on the same vertices (zero-volume slivers), removed.
    pub sliver_pairs: usize,
    /// Triangles repeating another with the same winding, removed.
    pub duplicates: usize,
    /// Triangles with a repeated vertex, removed.
    pub degenerate: usize,
    /// Holes filled, by their number of edges.
    pub holes_filled: Vec<usize>,
    /// Vertices no triangle used any more, removed.
    pub unused_vertices: usize,
    /// Every triangle's winding was reversed: the closed mesh was inside out (negative signed
    /// volume), so inside and outside would be swapped.
    #[serde(default)]
    pub turned_outward: bool,
    /// The mesh is closed and consistently wound afterwards.
    pub closed: bool,
}

impl Repair {
    /// `true` when nothing was changed.
    pub fn is_empty(&self) -> bool {
        self.sliver_pairs == 0
            && self.duplicates == 0
            && self.degenerate == 0
            && self.holes_filled.is_empty()
            && self.unused_vertices == 0
            && !self.turned_outward
    }
}

impl fmt::Display for Repair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        let plural =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        if self.sliver_pairs > 0 {
            parts.push(format!(
                "removed {} (a triangle and its reverse on the same vertices)",
                plural(
                    self.sliver_pairs,
                    "zero-volume sliver",
                    "zero-volume slivers"
                )
            ));
        }
        if self.duplicates > 0 {
            parts.push(format!(
                "removed {}",
                plural(self.duplicates, "repeated triangle", "repeated triangles")
            ));
        }
        if self.degenerate > 0 {
            parts.push(format!(
                "removed {} with a repeated vertex",
                plural(self.degenerate, "triangle", "triangles")
            ));
        }
        if !self.holes_filled.is_empty() {
            let sizes: Vec<String> = self.holes_filled.iter().map(|n| n.to_string()).collect();
            parts.push(format!(
                "filled {} ({} edges)",
                plural(self.holes_filled.len(), "hole", "holes"),
                sizes.join(", ")
            ));
        }
        if self.unused_vertices > 0 {
            parts.push(format!(
                "dropped {}",
                plural(self.unused_vertices, "unused vertex", "unused vertices")
            ));
        }
        if self.turned_outward {
            parts.push(
                "turned every triangle outward (the mesh was inside out: negative signed volume)"
                    .into(),
            );
        }
        if parts.is_empty() {
            parts.push("nothing to repair".into());
        }
        write!(f, "{}", parts.join("; "))?;
        if !self.closed {
            write!(f, "; the mesh is still not closed")?;
        }
        Ok(())
    }
}

/// Why a mesh is not closed and consistently wound.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Defects {
    /// Edges used by one triangle only (the rims of holes).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Edges two triangles traverse in the same direction (inconsistent winding).
    pub misoriented_edges: usize,
    /// Triangles with a repeated vertex.
    pub degenerate_triangles: usize,
}

impl Defects {
    /// `true` when the mesh is closed and consistently wound.
    pub fn is_empty(&self) -> bool {
        *self == Defects::default()
    }
}

impl fmt::Display for Defects {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if self.boundary_edges > 0 {
            parts.push(format!(
                "{} edges on one triangle only (holes)",
                self.boundary_edges
            ));
        }
        if self.non_manifold_edges > 0 {
            parts.push(format!(
                "{} edges shared by more than two triangles",
                self.non_manifold_edges
            ));
        }
        if self.misoriented_edges > 0 {
            parts.push(format!(
                "{} edges where two triangles are wound the same way",
                self.misoriented_edges
            ));
        }
        if self.degenerate_triangles > 0 {
            parts.push(format!(
                "{} triangles with a repeated vertex",
                self.degenerate_triangles
            ));
        }
        if parts.is_empty() {
            parts.push("closed and consistently wound".into());
        }
        write!(f, "{}", parts.join(", "))
    }
}

impl Mesh {
    /// What keeps the mesh from being closed and consistently wound (empty when it is).
    pub fn defects(&self) -> Defects {
        let mut d = Defects::default();
        let mut undirected: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for &[a, b, c] in &self.triangles {
            if a == b || b == c || c == a {
                d.degenerate_triangles += 1;
                continue;
            }
            for (u, v) in [(a, b), (b, c), (c, a)] {
                let e = undirected.entry((u.min(v), u.max(v))).or_insert((0, 0));
                if u < v {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
            }
        }
        for &(fwd, back) in undirected.values() {
            match fwd + back {
                1 => d.boundary_edges += 1,
                2 if fwd != 1 => d.misoriented_edges += 1,
                2 => {}
                _ => d.non_manifold_edges += 1,
            }
        }
        d
    }

    /// Removes zero-volume sliver pairs, repeated triangles and triangles with a repeated
    /// vertex, fills holes of at most [`MAX_HOLE_EDGES`] edges whose rims are simple loops,
    /// drops unused vertices, and winds the result outward when it is closed (see the module
    /// docs). Deterministic; a closed mesh comes back unchanged but for its winding.
    pub fn repair(&mut self) -> Repair {
        let mut r = Repair::default();
        if self.is_closed_and_consistently_wound() {
            r.closed = true;
            r.turned_outward = self.orient_outward();
            return r;
        }
        // Triangles by their vertex set, in file order.
        let mut groups: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
        let mut keep = vec![true; self.triangles.len()];
        for (i, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = *t;
            if a == b || b == c || c == a {
                keep[i] = false;
                r.degenerate += 1;
                continue;
            }
            let mut key = *t;
            key.sort_unstable();
            groups.entry(key).or_default().push(i);
        }
        let mut keys: Vec<&[u32; 3]> = groups.keys().collect();
        keys.sort_unstable();
        for key in keys {
            let members = &groups[key];
            if members.len() < 2 {
                continue;
            }
            // Split by winding: an even permutation of the sorted key or an odd one.
            let (mut even, mut odd): (Vec<usize>, Vec<usize>) = (Vec::new(), Vec::new());
            for &i in members {
                if is_even_rotation(&self.triangles[i], key) {
                    even.push(i);
                } else {
                    odd.push(i);
                }
            }
            let pairs = even.len().min(odd.len());
            r.sliver_pairs += pairs;
            for &i in even.iter().take(pairs).chain(odd.iter().take(pairs)) {
                keep[i] = false;
            }
            // Of what is left (all one winding), keep the first.
            for &i in even
                .iter()
                .skip(pairs)
                .chain(odd.iter().skip(pairs))
                .skip(1)
            {
                keep[i] = false;
                r.duplicates += 1;
            }
        }
        let mut i = 0;
        self.triangles.retain(|_| {
            i += 1;
            keep[i - 1]
        });
        if let Some(holes) = hole_loops(&self.triangles)
            && holes.iter().all(|h| h.len() <= MAX_HOLE_EDGES)
        {
            for hole in holes {
                r.holes_filled.push(hole.len());
                for k in 1..hole.len() - 1 {
                    self.triangles.push([hole[0], hole[k + 1], hole[k]]);
                }
            }
        }
        r.unused_vertices = self.drop_unused_vertices();
        r.closed = self.is_closed_and_consistently_wound();
        if r.closed {
            r.turned_outward = self.orient_outward();
        }
        r
    }

    /// Removes vertices no triangle uses (renumbering in order); returns how many.
    fn drop_unused_vertices(&mut self) -> usize {
        let mut new_index = vec![u32::MAX; self.vertices.len()];
        for t in &self.triangles {
            for &v in t {
                new_index[v as usize] = 0;
            }
        }
        let mut next = 0u32;
        let mut vertices = Vec::with_capacity(self.vertices.len());
        for (i, slot) in new_index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = next;
                next += 1;
                vertices.push(self.vertices[i]);
            }
        }
        let dropped = self.vertices.len() - vertices.len();
        for t in &mut self.triangles {
            for v in t.iter_mut() {
                *v = new_index[*v as usize];
            }
        }
        self.vertices = vertices;
        dropped
    }
}

/// `true` when `t` is `key` (sorted) rotated, i.e. wound the same way as `key`.
fn is_even_rotation(t: &[u32; 3], key: &[u32; 3]) -> bool {
    (0..3).any(|s| [t[s], t[(s + 1) % 3], t[(s + 2) % 3]] == *key)
}

/// The rims of the holes as vertex loops `v0, v1, ...` whose edges `(v_i, v_i+1)` are edges
/// of exactly one triangle (traversed that way); `None` when an edge is non-manifold or
/// misoriented, or a rim vertex starts two rim edges (rims that touch): no simple fan then.
fn hole_loops(triangles: &[[u32; 3]]) -> Option<Vec<Vec<u32>>> {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for &[a, b, c] in triangles {
        for e in [(a, b), (b, c), (c, a)] {
            *directed.entry(e).or_insert(0) += 1;
        }
    }
    if directed.values().any(|&n| n > 1) {
        return None;
    }
    let mut next: HashMap<u32, u32> = HashMap::new();
    let mut rim: Vec<(u32, u32)> = directed
        .keys()
        .filter(|&&(a, b)| !directed.contains_key(&(b, a)))
        .copied()
        .collect();
    rim.sort_unstable();
    for &(a, b) in &rim {
        if next.insert(a, b).is_some() {
            return None;
        }
    }
    let mut loops = Vec::new();
    let mut seen: HashMap<u32, bool> = HashMap::new();
    for &(start, _) in &rim {
        if seen.contains_key(&start) {
            continue;
        }
        let mut lp = vec![start];
        seen.insert(start, true);
        let mut v = next[&start];
        while v != start {
            if seen.insert(v, true).is_some() || lp.len() > rim.len() {
                return None;
            }
            lp.push(v);
            v = *next.get(&v)?;
        }
        if lp.len() < 3 {
            return None;
        }
        loops.push(lp);
    }
    Some(loops)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// A unit cube, outward-wound, 12 triangles.
    fn cube() -> Mesh {
        let vertices = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let triangles = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        Mesh {
            vertices,
            triangles,
        }
    }

    #[test]
    fn the_test_cube_is_closed() {
        let m = cube();
        assert!(m.is_closed_and_consistently_wound());
        assert!(m.defects().is_empty());
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_closed_mesh_is_left_as_it_is() {
        let mut m = cube();
        let r = m.repair();
        assert!(r.is_empty() && r.closed);
        assert_eq!(m, cube());
    }

    #[test]
    fn sliver_pairs_and_repeats_are_removed() {
        let mut m = cube();
        // A sliver on three surface vertices (its edges then have four triangles), a
        // repeated triangle and one with a repeated vertex.
        m.triangles.push([0, 1, 3]);
        m.triangles.push([3, 1, 0]);
        m.triangles.push([4, 5, 6]);
        m.triangles.push([2, 2, 7]);
        let d = m.defects();
        assert!(
            d.non_manifold_edges > 0 && d.degenerate_triangles == 1,
            "{d:?}"
        );
        let r = m.repair();
        assert_eq!((r.sliver_pairs, r.duplicates, r.degenerate), (1, 1, 1));
        assert!(r.closed, "{r}");
        assert_eq!(m.triangles.len(), 12);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_small_hole_is_filled_and_the_volume_is_back() {
        let mut m = cube();
        m.triangles.retain(|t| *t != [4, 5, 6] && *t != [5, 7, 6]); // the top face
        assert_eq!(m.defects().boundary_edges, 4);
        let r = m.repair();
        assert_eq!(r.holes_filled, vec![4]);
        assert!(r.closed);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
        assert!(r.to_string().contains("filled 1 hole (4 edges)"), "{r}");
    }

    #[test]
    fn an_inward_wound_mesh_with_a_sliver_comes_out_outward() {
        let mut m = cube();
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        m.triangles.push([0, 1, 3]);
        m.triangles.push([0, 3, 1]);
        let r = m.repair();
        assert!(r.closed && r.turned_outward, "{r}");
        assert!(m.signed_volume() > 0.0);
    }

    #[test]
    fn an_inside_out_closed_mesh_is_turned_outward_and_says_so() {
        let mut m = cube();
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        assert!(m.is_closed_and_consistently_wound() && m.signed_volume() < 0.0);
        let r = m.repair();
        assert!(r.closed && r.turned_outward && !r.is_empty(), "{r}");
        assert!(r.to_string().contains("inside out"), "{r}");
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_large_hole_is_left_open_and_described() {
        // A cone without its base: a rim of 30 edges, more than MAX_HOLE_EDGES.
        let n = 30;
        let mut vertices = vec![Point3::new(0.0, 0.0, 1.0)];
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            vertices.push(Point3::new(a.cos(), a.sin(), 0.0));
        }
        let triangles = (0..n as u32)
            .map(|k| [0, 1 + k, 1 + (k + 1) % n as u32])
            .collect();
        let mut m = Mesh {
            vertices,
            triangles,
        };
        let before = m.clone();
        let r = m.repair();
        assert!(!r.closed && r.holes_filled.is_empty(), "{r}");
        assert!(
            r.to_string().ends_with("the mesh is still not closed"),
            "{r}"
        );
        assert_eq!(m, before);
        let d = m.defects();
        assert_eq!(d.boundary_edges, n);
        assert_eq!(d.to_string(), "30 edges on one triangle only (holes)");
    }
}
