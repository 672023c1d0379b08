//! What one query's traversal did, for the renderer's per-pixel maps (`coherent render
//! --aov steps|tests`): inner nodes visited and triangle tests. The structures whose
//! traversal is ours count it (the BSP); Embree's and obvhs' are not, and say so through
//! [`crate::Accel::counts_work`].

use std::ops::AddAssign;

/// Traversal work, counted per packet: a step or a triangle test counts once for the whole
/// packet, however many of its lanes are active (the work a ray sits through when it travels
/// in that packet). A beam's shared steps count once for the beam.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Work {
    /// Inner nodes visited (both levels of a two-level structure).
    pub inner_nodes: u64,
    /// Triangle tests.
    pub tri_tests: u64,
}

impl AddAssign for Work {
    fn add_assign(&mut self, o: Work) {
        self.inner_nodes += o.inner_nodes;
        self.tri_tests += o.tri_tests;
    }
}
