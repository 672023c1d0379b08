//! A built kd-tree: nodes, leaf item lists and bounds, shared by both levels of the BSP
//! (paper section 3: the object trees and the scene tree).

use coherent_accel::Aabb;

use crate::Node;

/// A kd-tree over items (triangle records or instances). The root is node 0; node 1 is
/// padding so that every pair of children starts at an even index.
#[derive(Debug, Clone, Default)]
pub struct KdTree {
    pub nodes: Vec<Node>,
    /// Leaf item lists, concatenated (indices of triangle records or instances).
    pub items: Vec<u32>,
    /// The root voxel (empty when the tree holds nothing).
    pub bounds: Aabb,
    pub stats: TreeStats,
}

/// What a tree build produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TreeStats {
    pub nodes: usize,
    pub leaves: usize,
    pub empty_leaves: usize,
    pub leaf_refs: usize,
    pub max_depth: usize,
    /// The tree's SAH cost (expected cost of a random ray through the root voxel, in the
    /// units of the build's traversal and intersection costs).
    pub sah_cost: f64,
    pub build_seconds: f64,
}

impl KdTree {
    /// A tree holding nothing: one empty leaf, empty bounds.
    pub fn empty() -> Self {
        Self {
            nodes: vec![Node::leaf(0, 0), Node::leaf(0, 0)],
            items: Vec::new(),
            bounds: Aabb::EMPTY,
            stats: TreeStats {
                nodes: 1,
                leaves: 1,
                empty_leaves: 1,
                ..TreeStats::default()
            },
        }
    }

    /// Sets every inner node's [`Node::empty_children`] from its children. Most leaves a ray
    /// crosses hold nothing (the SAH cuts empty space off): on the full `blob`, 6 of the 8
    /// leaves a single shadow or diffuse ray visits, 4.1 of a primary ray's 4.7. With the
    /// bits, the single-ray walk skips them at their parent (no load, no stack entry). The
    /// packet walk still enters them: skipping there measured within the code-layout noise
    /// (docs/findings/traversal.md, "two changes to the single-ray walk"). Both builders call
    /// this last.
    pub fn mark_empty_children(&mut self) {
        let empty = |n: Node| n.is_leaf() && n.items().is_empty();
        for i in 0..self.nodes.len() {
            let n = self.nodes[i];
            if n.is_leaf() {
                continue;
            }
            let (l, r) = (self.nodes[n.left()], self.nodes[n.left() + 1]);
            self.nodes[i] = n.with_empty_children(empty(l) as u32 | (empty(r) as u32) << 1);
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<Node>() + self.items.len() * size_of::<u32>()
    }

    /// Records a finished leaf in the statistics.
    pub(crate) fn count_leaf(stats: &mut TreeStats, count: usize, depth: usize, cost: f64) {
        stats.leaves += 1;
        stats.nodes += 1;
        stats.empty_leaves += (count == 0) as usize;
        stats.leaf_refs += count;
        stats.max_depth = stats.max_depth.max(depth);
        stats.sah_cost += cost;
    }
}
