//! Traversal counters (paper section 3's intersection cache hit rate, nodes, tests, the
//! packet-to-single-ray switch), compiled out of the normal queries.

/// Where the traversal reports what it did. `()` counts nothing and costs nothing.
pub trait Counters {
    /// Whether the traversal should time its parts ([`Counters::beam_setup`]).
    const TIMED: bool = false;
    #[inline(always)]
    fn inner(&mut self) {}
    #[inline(always)]
    fn leaf(&mut self) {}
    /// A triangle test for `lanes` lanes.
    #[inline(always)]
    fn tri_test(&mut self, _lanes: u32) {}
    /// A triangle test skipped by the mailbox, for `lanes` lanes.
    #[inline(always)]
    fn mailbox_skip(&mut self, _lanes: u32) {}
    /// An instance entered by `lanes` lanes.
    #[inline(always)]
    fn instance(&mut self, _lanes: u32) {}
    /// A subtree handed from packet to single-ray traversal, for `lanes` lanes.
    #[inline(always)]
    fn handoff(&mut self, _lanes: u32) {}
    /// An inner node decided for a whole beam (or sub-beam) by its interval bounds.
    #[inline(always)]
    fn beam_step(&mut self) {}
    /// A beam's group began walking a tree (the top tree or an instance's mesh) with
    /// `packets` packets.
    #[inline(always)]
    fn beam_entry(&mut self, _packets: u32) {}
    /// Lanes of a beam traced ray by ray instead (a zero or subnormal direction component).
    #[inline(always)]
    fn beam_fallback(&mut self, _lanes: u32) {}
    /// Lanes of a beam outside its largest group of equal direction signs: they walk as a
    /// group of their own.
    #[inline(always)]
    fn beam_mixed(&mut self, _lanes: u32) {}
    /// A packet's limit reduced over its lanes (a beam takes it after a leaf, not per node).
    #[inline(always)]
    fn limit_reduction(&mut self) {}
    /// Packets moved into an instance's object space.
    #[inline(always)]
    fn packets_transformed(&mut self, _packets: u32) {}
    /// Nanoseconds a beam spent preparing its groups (rays, sign groups, bounds); only
    /// called when [`Counters::TIMED`].
    #[inline(always)]
    fn beam_setup(&mut self, _ns: u64) {}
    /// A leaf's triangle skipped for a whole group: outside its frustum.
    #[inline(always)]
    fn tri_culled(&mut self) {}
    /// Lanes of a beam traced from their segments' far ends back.
    #[inline(always)]
    fn beam_reversed(&mut self, _lanes: u32) {}
}

impl Counters for () {}

/// What a batch of queries did, summed (see [`crate::Bsp::intersect_counted`]). Packet
/// operations count once per packet in the plain fields and once per lane in `*_lanes`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TraversalStats {
    pub inner_nodes: u64,
    pub leaves: u64,
    pub tri_tests: u64,
    pub tri_test_lanes: u64,
    pub mailbox_skips: u64,
    pub mailbox_skip_lanes: u64,
    pub instances: u64,
    pub instance_lanes: u64,
    pub handoffs: u64,
    pub handoff_lanes: u64,
    /// Inner nodes decided for a whole beam or sub-beam.
    pub beam_steps: u64,
    /// Tree walks begun by a beam's groups, and the packets they began with.
    pub beam_entries: u64,
    pub beam_entry_packets: u64,
    /// Beam lanes traced ray by ray (zero direction components).
    pub beam_fallback_lanes: u64,
    /// Beam lanes outside their group's largest sign group.
    pub beam_mixed_lanes: u64,
    /// Packet limits reduced over their lanes.
    pub limit_reductions: u64,
    /// Packets moved into an instance's object space (by the packet walk or a beam).
    pub packets_transformed: u64,
    /// Time beams spent preparing their groups, nanoseconds.
    pub beam_setup_ns: u64,
    /// Triangles skipped for a whole group at a leaf (outside the group's frustum).
    pub tris_culled: u64,
    /// Lanes traced from their segments' far ends (shadow rays from the light).
    pub beam_reversed_lanes: u64,
}

impl TraversalStats {
    /// Share of triangle tests (per lane) the mailbox avoided.
    pub fn mailbox_hit_rate(&self) -> f64 {
        let all = self.tri_test_lanes + self.mailbox_skip_lanes;
        if all == 0 {
            0.0
        } else {
            self.mailbox_skip_lanes as f64 / all as f64
        }
    }

    /// The interface's per-packet work: inner nodes (a beam's shared steps included) and
    /// triangle tests.
    pub fn work(&self) -> coherent_accel::Work {
        coherent_accel::Work {
            inner_nodes: self.inner_nodes + self.beam_steps,
            tri_tests: self.tri_tests,
        }
    }

    /// Mean active lanes per packet triangle test.
    pub fn lanes_per_test(&self) -> f64 {
        if self.tri_tests == 0 {
            0.0
        } else {
            self.tri_test_lanes as f64 / self.tri_tests as f64
        }
    }
}

impl Counters for TraversalStats {
    const TIMED: bool = true;
    #[inline(always)]
    fn inner(&mut self) {
        self.inner_nodes += 1;
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    #[inline(always)]
    fn tri_test(&mut self, lanes: u32) {
        self.tri_tests += 1;
        self.tri_test_lanes += lanes as u64;
    }
    #[inline(always)]
    fn mailbox_skip(&mut self, lanes: u32) {
        self.mailbox_skips += 1;
        self.mailbox_skip_lanes += lanes as u64;
    }
    #[inline(always)]
    fn instance(&mut self, lanes: u32) {
        self.instances += 1;
        self.instance_lanes += lanes as u64;
    }
    #[inline(always)]
    fn handoff(&mut self, lanes: u32) {
        self.handoffs += 1;
        self.handoff_lanes += lanes as u64;
    }
    #[inline(always)]
    fn beam_step(&mut self) {
        self.beam_steps += 1;
    }
    #[inline(always)]
    fn beam_entry(&mut self, packets: u32) {
        self.beam_entries += 1;
        self.beam_entry_packets += packets as u64;
    }
    #[inline(always)]
    fn beam_fallback(&mut self, lanes: u32) {
        self.beam_fallback_lanes += lanes as u64;
    }
    #[inline(always)]
    fn beam_mixed(&mut self, lanes: u32) {
        self.beam_mixed_lanes += lanes as u64;
    }
    #[inline(always)]
    fn limit_reduction(&mut self) {
        self.limit_reductions += 1;
    }
    #[inline(always)]
    fn packets_transformed(&mut self, packets: u32) {
        self.packets_transformed += packets as u64;
    }
    #[inline(always)]
    fn beam_setup(&mut self, ns: u64) {
        self.beam_setup_ns += ns;
    }
    #[inline(always)]
    fn tri_culled(&mut self) {
        self.tris_culled += 1;
    }
    #[inline(always)]
    fn beam_reversed(&mut self, lanes: u32) {
        self.beam_reversed_lanes += lanes as u64;
    }
}
