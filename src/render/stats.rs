//! What the packet pipeline counts where it happens (paper section 7's measurements, and the
//! coherence the paper says falls with depth): rays by kind, packets and active lanes per
//! stage and per depth, material passes per packet, NaN radiance, and (when asked) where
//! the time goes per stage of the pipeline.

use crate::material::SplitCount;

/// The kinds of ray the pipeline traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    Primary = 0,
    Shadow = 1,
    Reflection = 2,
    Refraction = 3,
}

impl RayKind {
    pub const ALL: [RayKind; 4] = [
        RayKind::Primary,
        RayKind::Shadow,
        RayKind::Reflection,
        RayKind::Refraction,
    ];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Reflection => "reflection",
            RayKind::Refraction => "refraction",
        }
    }
}

/// The stages of the packet pipeline that [`RenderStats::stage_ns`] times (only when the
/// renderer's `time_stages` is on).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// First-hit queries of camera, reflection and refraction packets.
    Traversal = 0,
    /// Occlusion queries of shadow packets.
    Shadows = 1,
    /// Material passes (textures, tabulated BDFs included).
    Shading = 2,
    /// Light sampling and shadow-ray set-up.
    Lights = 3,
    /// Camera rays, the hit-to-surface gather, backgrounds and secondary-ray set-up.
    Other = 4,
}

impl Stage {
    pub const COUNT: usize = 5;
    pub const ALL: [Stage; Stage::COUNT] = [
        Stage::Traversal,
        Stage::Shadows,
        Stage::Shading,
        Stage::Lights,
        Stage::Other,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Traversal => "traversal",
            Stage::Shadows => "shadows",
            Stage::Shading => "shading",
            Stage::Lights => "lights",
            Stage::Other => "other",
        }
    }
}

/// A lap timer over the stages of one packet: each `lap` charges the time since the previous
/// lap to a stage. Off (`None`), it reads no clock: one predictable branch per lap.
pub(crate) struct StageClock(Option<std::time::Instant>);

impl StageClock {
    #[inline(always)]
    pub(crate) fn start(on: bool) -> StageClock {
        StageClock(on.then(std::time::Instant::now))
    }

    #[inline(always)]
    pub(crate) fn lap(&mut self, stats: &mut RenderStats, stage: Stage) {
        if let Some(last) = self.0 {
            let now = std::time::Instant::now();
            stats.stage_ns[stage as usize] += (now - last).as_nanos() as u64;
            self.0 = Some(now);
        }
    }
}

/// Packets traced and lanes active in them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneCount {
    pub packets: u64,
    pub lanes: u64,
}

impl LaneCount {
    #[inline(always)]
    pub fn add(&mut self, active_lanes: u32) {
        self.packets += 1;
        self.lanes += u64::from(active_lanes);
    }

    /// Average active lanes per packet (0 without packets).
    pub fn average(&self) -> f64 {
        if self.packets == 0 {
            0.0
        } else {
            self.lanes as f64 / self.packets as f64
        }
    }

    fn merge(&mut self, o: &LaneCount) {
        self.packets += o.packets;
        self.lanes += o.lanes;
    }
}

/// Statistics of a render (per task, merged in a fixed order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Lanes per packet of the backend that rendered.
    pub width: u32,
    /// Packets and active lanes per ray kind (the lanes are the rays traced).
    pub kinds: [LaneCount; 4],
    /// Packets and active lanes of every traced packet (primary, reflection, refraction) by
    /// depth: index 0 = camera rays.
    pub depth: Vec<LaneCount>,
    /// Material passes per shaded packet (the paper's one material at a time).
    pub materials: SplitCount,
    /// Radiance samples that came out NaN (zeroed in the image).
    pub nan: u64,
    /// Nanoseconds per [`Stage`], summed over threads; all zero unless the renderer's
    /// `time_stages` is on.
    pub stage_ns: [u64; Stage::COUNT],
}

impl RenderStats {
    /// Rays traced of a kind.
    pub fn rays(&self, kind: RayKind) -> u64 {
        self.kinds[kind as usize].lanes
    }

    /// Every ray traced.
    pub fn total_rays(&self) -> u64 {
        self.kinds.iter().map(|k| k.lanes).sum()
    }

    #[inline(always)]
    pub(crate) fn count(&mut self, kind: RayKind, active_lanes: u32) {
        self.kinds[kind as usize].add(active_lanes);
    }

    #[inline(always)]
    pub(crate) fn count_depth(&mut self, depth: usize, active_lanes: u32) {
        if self.depth.len() <= depth {
            self.depth.resize(depth + 1, LaneCount::default());
        }
        self.depth[depth].add(active_lanes);
    }

    /// Adds `o` into `self`.
    pub fn merge(&mut self, o: RenderStats) {
        self.width = self.width.max(o.width);
        for (a, b) in self.kinds.iter_mut().zip(&o.kinds) {
            a.merge(b);
        }
        if self.depth.len() < o.depth.len() {
            self.depth.resize(o.depth.len(), LaneCount::default());
        }
        for (a, b) in self.depth.iter_mut().zip(&o.depth) {
            a.merge(b);
        }
        self.materials.packets += o.materials.packets;
        self.materials.passes += o.materials.passes;
        self.nan += o.nan;
        for (a, b) in self.stage_ns.iter_mut().zip(&o.stage_ns) {
            *a += b;
        }
    }

    /// Average active lanes per traced packet at each depth (0 = camera rays), as
    /// `d0 3.98, d1 2.10, ...`.
    pub fn depth_summary(&self) -> String {
        let depth: Vec<String> = self
            .depth
            .iter()
            .enumerate()
            .map(|(d, c)| format!("d{d} {:.2}", c.average()))
            .collect();
        depth.join(", ")
    }

    /// The time of each timed stage, summed over threads, and its share, as
    /// `traversal 0.120 s (10.0%), ...` (all zero unless the renderer timed its stages).
    pub fn stage_summary(&self) -> String {
        let total: u64 = self.stage_ns.iter().sum();
        Stage::ALL
            .iter()
            .map(|s| {
                let ns = self.stage_ns[*s as usize];
                format!(
                    "{} {:.3} s ({:.1}%)",
                    s.name(),
                    ns as f64 * 1e-9,
                    100.0 * ns as f64 / total.max(1) as f64
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// One line: rays by kind, average active lanes per packet per stage, material passes
    /// per packet, NaN samples.
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        for k in RayKind::ALL {
            let c = self.kinds[k as usize];
            parts.push(format!("{} {}", k.name(), c.lanes));
        }
        let mut lanes = Vec::new();
        for k in RayKind::ALL {
            let c = self.kinds[k as usize];
            if c.packets > 0 {
                lanes.push(format!("{} {:.2}", k.name(), c.average()));
            }
        }
        let mut s = format!(
            "rays: {}; active lanes per packet (of {}): {}; by depth: {}; material passes per packet {:.2}",
            parts.join(", "),
            self.width,
            lanes.join(", "),
            self.depth_summary(),
            self.materials.passes_per_packet()
        );
        if self.nan > 0 {
            s.push_str(&format!(
                "; {} NaN radiance samples (zeroed in the image)",
                self.nan
            ));
        }
        s
    }
}
