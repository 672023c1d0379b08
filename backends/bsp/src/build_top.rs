//! The top-level build (paper section 3: the scene tree over object bounding boxes is rebuilt
//! whenever objects move, so "a fast algorithm is used here"): a binned SAH kd-tree over the
//! instances' world boxes.

use coherent_accel::Aabb;

use crate::{KdTree, MAX_CHILD, Node, TopParams, TreeStats};

/// Builds the kd-tree over `boxes` (one per instance; empty boxes are left out). Leaf items
/// are indices into `boxes`.
pub fn build_top(boxes: &[Aabb], p: &TopParams) -> KdTree {
    let t0 = std::time::Instant::now();
    let items: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| !boxes[i as usize].is_empty())
        .collect();
    if items.is_empty() {
        return KdTree::empty();
    }
    let bounds = items
        .iter()
        .fold(Aabb::EMPTY, |a, &i| a.union(boxes[i as usize]));
    let depth_limit = {
        let auto = (8.0 + 1.3 * (items.len() as f64).log2()).round() as u32;
        let d = if p.max_depth == 0 { auto } else { p.max_depth };
        d.min(crate::MAX_TREE_DEPTH)
    };
    let mut b = TopBuilder {
        boxes,
        p,
        depth_limit,
        bins: (p.bins.clamp(2, 64)) as usize,
        nodes: vec![Node::leaf(0, 0); 2],
        items: Vec::with_capacity(items.len() * 2),
        stats: TreeStats::default(),
        root_area: bounds.area().max(f32::MIN_POSITIVE) as f64,
        arena: Vec::with_capacity(items.len() * 4),
    };
    let n = items.len();
    b.arena.extend_from_slice(&items);
    b.build(0, bounds, 0..n, 0);
    let mut stats = b.stats;
    stats.build_seconds = t0.elapsed().as_secs_f64();
    let mut tree = KdTree {
        nodes: b.nodes,
        items: b.items,
        bounds,
        stats,
    };
    tree.mark_empty_children();
    tree
}

struct TopBuilder<'a> {
    boxes: &'a [Aabb],
    p: &'a TopParams,
    depth_limit: u32,
    bins: usize,
    nodes: Vec<Node>,
    items: Vec<u32>,
    stats: TreeStats,
    root_area: f64,
    /// Item lists of the nodes on the recursion path, each a range (one allocation for the
    /// whole build: per-node vectors cost a third of a 1,000-instance build).
    arena: Vec<u32>,
}

impl TopBuilder<'_> {
    /// Builds `node` over voxel `v` and the items `arena[range]`.
    fn build(&mut self, node: usize, v: Aabb, range: core::ops::Range<usize>, depth: u32) {
        let n = range.len();
        let leaf_cost = self.p.intersection_cost * n as f32;
        let plane = if n <= self.p.leaf_size as usize || depth >= self.depth_limit {
            None
        } else {
            self.find_plane(&v, &self.arena[range.clone()])
        };
        let Some((k, pos, _)) = plane.filter(|pl| pl.2 < leaf_cost) else {
            let first = self.items.len();
            self.items.extend_from_slice(&self.arena[range]);
            self.nodes[node] = Node::leaf(first, n);
            let cost =
                v.area() as f64 / self.root_area * (self.p.intersection_cost as f64 * n as f64);
            KdTree::count_leaf(&mut self.stats, n, depth as usize, cost);
            return;
        };
        // Left items, then right items, appended after the node's own.
        let end = self.arena.len();
        for j in range.clone() {
            let i = self.arena[j];
            let b = self.boxes[i as usize];
            // A box lying in the plane goes left; a box reaching both sides goes both ways.
            if b.min[k] < pos || b.max[k] <= pos {
                self.arena.push(i);
            }
        }
        let mid = self.arena.len();
        for j in range.clone() {
            let i = self.arena[j];
            if self.boxes[i as usize].max[k] > pos {
                self.arena.push(i);
            }
        }
        let stop = self.arena.len();
        if mid - end == n && stop - mid == n {
            // No progress (bins can misjudge): make a leaf instead.
            self.arena.truncate(end);
            let first = self.items.len();
            self.items.extend_from_slice(&self.arena[range]);
            self.nodes[node] = Node::leaf(first, n);
            KdTree::count_leaf(&mut self.stats, n, depth as usize, 0.0);
            return;
        }
        self.stats.nodes += 1;
        self.stats.sah_cost += v.area() as f64 / self.root_area * self.p.traversal_cost as f64;
        let (mut vl, mut vr) = (v, v);
        vl.max[k] = pos;
        vr.min[k] = pos;
        let children = self.nodes.len();
        assert!(children < MAX_CHILD, "top-level kd-tree too large");
        self.nodes.push(Node::leaf(0, 0));
        self.nodes.push(Node::leaf(0, 0));
        self.nodes[node] = Node::inner(k, pos, children);
        self.build(children, vl, end..mid, depth + 1);
        self.build(children + 1, vr, mid..stop, depth + 1);
        self.arena.truncate(end);
    }

    /// The SAH-best bin boundary: `(axis, position, cost)`.
    fn find_plane(&self, v: &Aabb, items: &[u32]) -> Option<(usize, f32, f32)> {
        let area = v.area();
        // Also false for NaN.
        let has_area = area > 0.0;
        if !has_area {
            return None;
        }
        let inv_area = 1.0 / area;
        let n = items.len();
        let bonus = 1.0 - self.p.empty_bonus;
        let (kt, ki) = (self.p.traversal_cost, self.p.intersection_cost);
        let ext = v.extent();
        let nb = self.bins;
        let mut best: Option<(usize, f32, f32)> = None;
        let mut starts = [0u32; 64];
        let mut ends = [0u32; 64];
        for k in 0..3 {
            let (vmin, w) = (v.min[k], ext[k]);
            let has_extent = w > 0.0;
            if !has_extent {
                continue;
            }
            let scale = nb as f32 / w;
            starts[..nb].fill(0);
            ends[..nb].fill(0);
            let bin = |x: f32| (((x - vmin) * scale) as usize).min(nb - 1);
            for &i in items {
                let b = self.boxes[i as usize];
                starts[bin(b.min[k].max(vmin))] += 1;
                ends[bin(b.max[k].min(v.max[k]))] += 1;
            }
            let (a, b) = (ext[(k + 1) % 3], ext[(k + 2) % 3]);
            let (mut nl, mut nr) = (0usize, n);
            for j in 1..nb {
                nl += starts[j - 1] as usize;
                nr -= ends[j - 1] as usize;
                let pos = vmin + w * (j as f32 / nb as f32);
                let pl = 2.0 * (a * b + (a + b) * (pos - vmin)) * inv_area;
                let pr = 2.0 * (a * b + (a + b) * (v.max[k] - pos)) * inv_area;
                let lambda = if nl == 0 || nr == 0 { bonus } else { 1.0 };
                let cost = lambda * (kt + ki * (pl * nl as f32 + pr * nr as f32));
                if best.is_none_or(|b| cost < b.2) {
                    best = Some((k, pos, cost));
                }
            }
        }
        best
    }
}
