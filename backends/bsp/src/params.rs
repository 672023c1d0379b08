//! Build and traversal parameters of the two-level BSP, with presets (paper section 3: object
//! trees "built carefully once", the top tree "built fast").

/// Surface-area-heuristic parameters of the object (per-mesh) kd-trees, after Havran's thesis
/// and Wald & Havran 2006.
#[derive(Debug, Clone, PartialEq)]
pub struct SahParams {
    /// Cost of visiting an inner node (K_T).
    pub traversal_cost: f32,
    /// Cost of one ray-triangle test (K_I).
    pub intersection_cost: f32,
    /// Cost reduction for a split that cuts off empty space (lambda = 1 - bonus when one side
    /// holds nothing), in `[0, 1)`.
    pub empty_bonus: f32,
    /// Deepest leaf; 0 picks `8 + 1.3 log2(N)` (Havran), at most [`MAX_TREE_DEPTH`].
    pub max_depth: u32,
    /// Nodes with at most this many triangles become leaves without a split search.
    pub leaf_size: u32,
    /// Clip triangles straddling a split to each child ("perfect splits", Wald & Havran);
    /// without it a straddling triangle keeps its bounding box cut by the child's box.
    pub perfect_splits: bool,
    /// Leaves are priced per group of this many triangles (K_I times the groups): 1 prices
    /// each triangle, 4 suits leaves tested four at a time ([`BspParams::simd_leaves`]).
    pub leaf_group: u32,
    /// Which algorithm searches the splits: the exact sweep or binning above a node size.
    pub build: BuildPreset,
    /// [`BuildPreset::Fast`]: bins per axis (the candidate planes are the `bins - 1` bin
    /// boundaries), 2 to [`MAX_BINS`].
    pub bins: u32,
    /// [`BuildPreset::Fast`]: nodes of at most this many references are handed to the exact
    /// sweep (with perfect splits when [`Self::perfect_splits`] is set).
    ///
    /// 256: the measured trade-off of build time against SAH cost, against 64 and 1,024
    /// (docs/findings/traversal.md, the fast build).
    pub sweep_below: u32,
    /// [`BuildPreset::Binned`]: nodes of at most this many references sort their box bounds
    /// and sweep every plane instead of binning (below [`crate::PARALLEL_MIN`]).
    ///
    /// 96, measured (`build` example, bunny / blob / needles, one thread, process CPU time and
    /// summed SAH cost against the exact tree's): 24 took 0.167 / 0.171 / 0.238 s at +6.9 /
    /// +6.4 / +5.2 %, 48 0.172 / 0.174 / 0.262 s at +4.9 / +4.5 / +6.3 %, 96 0.178 / 0.179 /
    /// 0.269 s at +3.8 / +3.6 / +5.7 %, 256 0.188 / 0.192 / 0.281 s at +2.8 / +2.9 / +5.5 %
    /// (docs/findings/builds.md).
    pub flat_sweep_below: u32,
    /// Reference budget, every builder: a tree over N triangles holds at most
    /// `ceil(max_refs_per_tri * N)` leaf references, for any input, e.g. thousands of long
    /// thin triangles through one point, whose clipped parts otherwise multiply at every split
    /// near the point. The build counts references (in finished leaves and in nodes still to
    /// build, so the bound holds throughout the build too); a node whose split could pass the
    /// budget becomes a leaf. Below a node of [`crate::PARALLEL_MIN`] references or more, each
    /// subtree may spend only a share of what is left, in proportion to its references, so
    /// that running out on one side does not make the other side all leaves (the exact build
    /// passes what the left one leaves on to the right one; the fast build, which may build
    /// both at once, takes back what both leave: its tree does not depend on the thread
    /// count). 16 binds on none of the built-in scenes (3 references per triangle or fewer):
    /// their exact trees are the same as without a budget.
    pub max_refs_per_tri: f32,
}

/// The largest [`SahParams::bins`].
pub const MAX_BINS: u32 = 64;

/// How the object trees search their split planes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuildPreset {
    /// The O(N log N) sweep over sorted events at every node (Wald & Havran 2006): every
    /// candidate plane, every node. The best trees, for a longer build
    /// (docs/findings/builds.md).
    Exact,
    /// Binned SAH at nodes above [`SahParams::sweep_below`] references (Hunt et al. 2006;
    /// Shevtsov, Soupikov & Kapustin 2007), the exact sweep below; subtrees of large nodes
    /// built in parallel. The same tree on any number of threads.
    ///
    /// Not the default: `binned` builds faster still for trees as good.
    Fast,
    /// Binned SAH at every node of more than [`SahParams::flat_sweep_below`] references, a
    /// sweep over the few sorted box bounds below, on flat reference arrays partitioned in
    /// place; straddling triangles clipped by the chosen plane only; large nodes binned and
    /// partitioned across threads, subtrees built as tasks (Shevtsov, Soupikov & Kapustin
    /// 2007). The same tree on any number of threads.
    ///
    /// The default: the shortest time to a first image (build plus one frame) summed over
    /// the paper's scenes (docs/findings/builds.md).
    #[default]
    Binned,
}

impl BuildPreset {
    pub const ALL: [BuildPreset; 3] = [BuildPreset::Exact, BuildPreset::Fast, BuildPreset::Binned];

    /// The name on the command line (`--bsp-build`).
    pub fn name(self) -> &'static str {
        match self {
            BuildPreset::Exact => "exact",
            BuildPreset::Fast => "fast",
            BuildPreset::Binned => "binned",
        }
    }
}

impl std::fmt::Display for BuildPreset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for BuildPreset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|b| b.name()).collect();
                format!("unknown BSP build `{s}`; builds: {}", names.join(", "))
            })
    }
}

/// The deepest any tree may be (the traversal stacks hold this many entries).
pub const MAX_TREE_DEPTH: u32 = 60;

impl Default for SahParams {
    fn default() -> Self {
        Self::default_preset()
    }
}

impl SahParams {
    /// Coarse leaves: no clipping, leaves of up to 8 triangles. (It sets the leaves, not the
    /// split search: that is [`Self::build`], e.g. [`Self::with_build`].)
    pub fn fast() -> Self {
        Self {
            leaf_size: 8,
            perfect_splits: false,
            ..Self::default_preset()
        }
    }

    /// The recommended trade-off: a node twice as costly as Wald & Havran's (K_T 30 instead of
    /// 15, K_I 20, empty bonus 0.2) with perfect splits, and no split search below 4
    /// triangles.
    ///
    /// K_T measured (`trace blob quick 512x384`, best of 3 passes of thread CPU time, two
    /// interleaved runs each, Mrays/s): K_T 15 made 79,117 leaf references for 20,480
    /// triangles (3.9 per triangle), K_T 30 60,495 (3.0); with K_T 30 shadow rays went from
    /// 12.6 / 10.6 to 13.3 / 14.1 at pulp16, 8.2 / 7.2 to 8.8 / 8.8 at pulp8, 5.8 / 6.1 to
    /// 6.8 / 5.6 at sse; primary rays 27.6 / 27.6 to 32.9 / 33.7 at pulp16; single rays
    /// (shadow 3.05 / 3.24 against 3.30 / 3.17, diffuse 2.16 / 2.02 against 2.13 / 2.07) and
    /// diffuse packets unchanged within noise. K_T 45 was as fast on packets but slower on
    /// single diffuse rays (1.97); leaf size 8 with K_T 30 no faster.
    ///
    /// Measured (`trace` example, primary rays, 1024x768, thread CPU time): leaf size 4 was as
    /// fast as 1 or faster at every width and scene, e.g. terrain 5.66 / 10.9 / 19.7 Mrays/s
    /// (single / sse / avx512) against 5.18 / 8.96 / 15.2 with leaf size 1, blob 6.91 / 16.4 /
    /// 34.6 against 6.79 / 15.7 / 32.8, with half the nodes.
    pub fn default_preset() -> Self {
        Self {
            traversal_cost: 30.0,
            intersection_cost: 20.0,
            empty_bonus: 0.2,
            max_depth: 0,
            leaf_size: 4,
            perfect_splits: true,
            leaf_group: 1,
            build: BuildPreset::default(),
            bins: 32,
            sweep_below: 256,
            flat_sweep_below: 96,
            max_refs_per_tri: 16.0,
        }
    }

    /// These parameters with the split search `build`.
    pub fn with_build(self, build: BuildPreset) -> Self {
        Self { build, ..self }
    }

    /// The finest tree: splits searched down to single triangles, up to 60 levels deep. Slower
    /// to build and larger; not faster to traverse in our measurements (see
    /// [`Self::default_preset`]).
    pub fn slow() -> Self {
        Self {
            leaf_size: 1,
            max_depth: MAX_TREE_DEPTH,
            ..Self::default_preset()
        }
    }

    /// A preset by name: `fast`, `default`, `slow`.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "fast" => Some(Self::fast()),
            "default" => Some(Self::default_preset()),
            "slow" => Some(Self::slow()),
            _ => None,
        }
    }

    /// The depth limit for `n` triangles.
    pub fn depth_limit(&self, n: usize) -> u32 {
        let auto = || (8.0 + 1.3 * (n.max(1) as f64).log2()).round() as u32;
        let d = if self.max_depth == 0 {
            auto()
        } else {
            self.max_depth
        };
        d.min(MAX_TREE_DEPTH)
    }

    /// The most leaf references a tree over `n` triangles may hold ([`Self::max_refs_per_tri`]),
    /// never fewer than `n` (a single leaf).
    pub fn ref_budget(&self, n: usize) -> usize {
        let b = (self.max_refs_per_tri.max(1.0) as f64 * n as f64).ceil();
        // Also for NaN: `as` saturates, and NaN becomes 0.
        (b.min(usize::MAX as f64) as usize).max(n)
    }
}

/// Parameters of the top-level tree over instance boxes: a binned SAH, rebuilt whenever
/// instances move.
#[derive(Debug, Clone, PartialEq)]
pub struct TopParams {
    /// Candidate planes per axis: `bins - 1` bin boundaries.
    pub bins: u32,
    pub traversal_cost: f32,
    /// Cost of entering an instance (transforming the rays, walking its tree).
    pub intersection_cost: f32,
    pub empty_bonus: f32,
    /// 0 picks `8 + 1.3 log2(N)`.
    pub max_depth: u32,
    /// Nodes with at most this many instances become leaves.
    pub leaf_size: u32,
}

// Measured (`trace top` / `trace spheres`, 1,025 instances, thread CPU / wall on the 2-core
// dev machine): leaf size 1 rebuilt in 1.29 ms, 2 in 0.69 ms, 4 in 0.35 ms, with primary-ray
// speed unchanged within noise (single 3.7-3.8, avx512 8.8-9.0 Mrays/s); 8 bins instead of 16
// saved less (0.82 ms). Default: 16 bins, leaf size 4.

impl Default for TopParams {
    fn default() -> Self {
        Self {
            bins: 16,
            traversal_cost: 15.0,
            intersection_cost: 60.0,
            empty_bonus: 0.2,
            max_depth: 0,
            leaf_size: 4,
        }
    }
}

/// Everything the BSP takes.
#[derive(Debug, Clone, PartialEq)]
pub struct BspParams {
    pub object: SahParams,
    pub top: TopParams,
    /// Per-ray intersection cache (mailbox): a triangle met again in a later leaf is not
    /// retested.
    pub mailbox: bool,
    /// Packet traversal hands a subtree to single-ray traversal when its active lanes are
    /// at most this many; `None` takes [`default_single_ray_threshold`] for the width.
    pub single_ray_threshold: Option<u32>,
    /// Single rays test a leaf's triangles four at a time (SSE; the leaves' records copied
    /// into blocks of four, see `leaf4.rs`). Off by default: the scalar baseline traces one
    /// triangle at a time, as the paper's non-SSE code did. Packets are unaffected.
    pub simd_leaves: bool,
    /// Packets whose lanes differ in direction signs walk the tree as one packet, each lane
    /// to the children its own segment reaches, instead of one walk per group of equal signs
    /// (Wald et al. 2001, which the paper follows). The answers are the same; incoherent
    /// packets (diffuse rays, shadow rays towards an environment) visit far fewer nodes.
    pub mixed_signs: bool,
    /// Beams skip a leaf's triangle for every packet of a group when it lies outside the
    /// group's frustum (see `frustum.rs`). The answers are the same either way.
    pub beam_cull: bool,
    /// Beams of segments whose far ends lie closer together than their near ends (shadow
    /// rays toward one point of a light) are traced from the far end back, as one origin
    /// (see `reverse.rs`). The answers are the same either way, up to rounding at the ends.
    pub beam_reverse: bool,
}

impl Default for BspParams {
    fn default() -> Self {
        Self {
            object: SahParams::default(),
            top: TopParams::default(),
            mailbox: true,
            single_ray_threshold: None,
            simd_leaves: false,
            mixed_signs: true,
            beam_cull: true,
            beam_reverse: true,
        }
    }
}

impl BspParams {
    /// The object-tree preset `name` (`fast`, `default`, `slow`) with default everything else.
    pub fn preset(name: &str) -> Option<Self> {
        Some(Self {
            object: SahParams::preset(name)?,
            ..Self::default()
        })
    }

    /// The switch threshold in effect for packets of `lanes` lanes.
    pub fn threshold_for(&self, lanes: usize) -> u32 {
        self.single_ray_threshold
            .unwrap_or_else(|| default_single_ray_threshold(lanes))
    }
}

/// The measured best active-lane count at or below which a packet's subtree is traversed ray
/// by ray, per packet width: 0 (never) at every width and for every kind of ray.
///
/// Measured by the `accel` experiment's sweep (`accel_threshold.csv`, thresholds 0 to
/// width / 2, primary, shadow and diffuse rays, `room` and `blob`, thread CPU time): 0 was
/// the best or within noise of it for every kind, so one default serves all kinds. E.g. quick
/// run on the dev machine (AVX-512): room shadow at width 16 (avx512) 41.8 / 41.4 / 33.4 /
/// 35.4 / 29.9 Mrays/s for thresholds 0 to 4; room diffuse at width 16 7.03 / 6.46 / 6.25 /
/// 5.83 / 5.51; blob primary at width 16 18.5 / 17.2 / 14.6 / 12.6 / 10.7. Embree's hybrid
/// switches below about 3/5/14 active lanes of 4/8/16, but a kd-tree packet step with one
/// active lane costs about what a single-ray step costs (a split test and a branch), while
/// each switch pays for unpacking the lane, three divisions and a fresh mailbox, and switched
/// subtrees are mostly small.
pub fn default_single_ray_threshold(_lanes: usize) -> u32 {
    0
}
