//! What the packet pipeline counts where it happens (paper section 7's measurements, and the
//! coherence the paper says falls with depth): rays by kind, packets and active lanes per
//! stage and per depth, material passes per packet, NaN radiance.

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
        let depth: Vec<String> = self
            .depth
            .iter()
            .enumerate()
            .map(|(d, c)| format!("d{d} {:.2}", c.average()))
            .collect();
        let mut s = format!(
            "rays: {}; active lanes per packet (of {}): {}; by depth: {}; material passes per packet {:.2}",
            parts.join(", "),
            self.width,
            lanes.join(", "),
            depth.join(", "),
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
