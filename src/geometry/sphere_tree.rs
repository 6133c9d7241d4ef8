//! A bounding-sphere tree over balls (points with a radius, 0 for plain points), for branch
//! and bound against a distance: a node's sphere holds every ball under it, so a 1-Lipschitz
//! distance `d` bounds them all by `d(centre) − radius` from below. Used by the penetration
//! probes ([`crate::robot::probes`]) and by the IK's hand-barrier clearance.
//!
//! Built by median splits along the longest axis of each node's box down to at most
//! `leaf_size` balls per leaf; balanced, so a query's stack is at most [`STACK`] deep.
//! Nodes are stored depth first (node 0 is the root; an inner node's first child is the
//! next node). The leaves refer to the balls through [`SphereTree::order`], so the caller's
//! array keeps its own order (or is permuted into leaf order with it).

use nalgebra::{Point3, Vector3};

/// Deepest stack a query needs: the tree is balanced, so 64 levels hold 2^64 leaves.
pub const STACK: usize = 64;

/// A node: every ball under it lies inside `B(center, radius)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeNode {
    /// Centre, in the balls' frame [m].
    pub center: Point3<f64>,
    /// Bounding radius [m], ball radii included.
    pub radius: f64,
    /// A leaf: its balls are `order[start..end]`. An inner node: its second child is node
    /// `end` (and `start == u32::MAX`).
    pub start: u32,
    pub end: u32,
}

impl TreeNode {
    /// Whether the node is a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.start != u32::MAX
    }
}

/// See the module docs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SphereTree {
    /// Depth first; empty when there are no balls.
    pub nodes: Vec<TreeNode>,
    /// Ball indices in leaf order.
    pub order: Vec<u32>,
}

impl SphereTree {
    /// The tree of the balls `(centres[i], radius(i))`.
    pub fn new(centres: &[Point3<f64>], radius: impl Fn(usize) -> f64, leaf_size: usize) -> Self {
        let mut tree = SphereTree {
            nodes: Vec::new(),
            order: (0..centres.len() as u32).collect(),
        };
        if !centres.is_empty() {
            let mut order = std::mem::take(&mut tree.order);
            tree.build(centres, &radius, leaf_size.max(1), &mut order, 0);
            tree.order = order;
        }
        tree
    }

    /// Appends the subtree of the balls `order[..]` (which start at `offset` in the whole
    /// order), depth first.
    fn build(
        &mut self,
        centres: &[Point3<f64>],
        radius: &impl Fn(usize) -> f64,
        leaf_size: usize,
        order: &mut [u32],
        offset: usize,
    ) {
        let (lo, hi) = order.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), &i| {
                let c = &centres[i as usize].coords;
                (lo.inf(c), hi.sup(c))
            },
        );
        let center = Point3::from((lo + hi) / 2.0);
        let r = order
            .iter()
            .map(|&i| (centres[i as usize] - center).norm() + radius(i as usize))
            .fold(0.0, f64::max);
        let node = self.nodes.len();
        if order.len() <= leaf_size {
            self.nodes.push(TreeNode {
                center,
                radius: r,
                start: offset as u32,
                end: (offset + order.len()) as u32,
            });
            return;
        }
        self.nodes.push(TreeNode {
            center,
            radius: r,
            start: u32::MAX,
            end: 0,
        });
        let axis = (hi - lo).imax();
        // A stable sort keeps the build deterministic whatever the ties.
        order.sort_by(|&a, &b| centres[a as usize][axis].total_cmp(&centres[b as usize][axis]));
        let half = order.len() / 2;
        let (left, right) = order.split_at_mut(half);
        self.build(centres, radius, leaf_size, left, offset);
        self.nodes[node].end = self.nodes.len() as u32;
        self.build(centres, radius, leaf_size, right, offset + half);
    }

    /// Bounding sphere of all balls; radius < 0 when there are none.
    pub fn bounding_sphere(&self) -> (Point3<f64>, f64) {
        self.nodes
            .first()
            .map_or((Point3::origin(), -1.0), |n| (n.center, n.radius))
    }

    /// Visits the leaves depth first, first children first (so the balls come in the
    /// order of [`SphereTree::order`]), skipping every subtree whose node `prune` rejects,
    /// and calls `leaf(&order[start..end])` for the others.
    #[inline]
    pub fn visit(&self, mut prune: impl FnMut(&TreeNode) -> bool, mut leaf: impl FnMut(&[u32])) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let i = stack[top];
            let node = &self.nodes[i as usize];
            if prune(node) {
                continue;
            }
            if node.is_leaf() {
                leaf(&self.order[node.start as usize..node.end as usize]);
            } else {
                stack[top] = node.end;
                stack[top + 1] = i + 1;
                top += 2;
            }
        }
    }

    /// Branch and bound for a minimum: `bound(node)` is a lower bound of `value` over the
    /// balls under the node; subtrees whose bound is not below `best` are skipped, the
    /// child with the lower bound is searched first, and `leaf(&order[..], best)` may lower
    /// `best`. Returns the final `best`.
    #[inline]
    pub fn minimize(
        &self,
        mut best: f64,
        mut bound: impl FnMut(&TreeNode) -> f64,
        mut leaf: impl FnMut(&[u32], &mut f64),
    ) -> f64 {
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack = [(0u32, 0.0f64); STACK];
        stack[0] = (0, bound(&self.nodes[0]));
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (i, b) = stack[top];
            if b >= best {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.is_leaf() {
                leaf(
                    &self.order[node.start as usize..node.end as usize],
                    &mut best,
                );
            } else {
                let (a, c) = (i + 1, node.end);
                let (ba, bc) = (
                    bound(&self.nodes[a as usize]),
                    bound(&self.nodes[c as usize]),
                );
                // The child with the lower bound is popped first.
                let (first, second) = if ba <= bc {
                    ((a, ba), (c, bc))
                } else {
                    ((c, bc), (a, ba))
                };
                stack[top] = second;
                stack[top + 1] = first;
                top += 2;
            }
        }
        best
    }
}
