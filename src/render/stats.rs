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
    /// Diffuse bounces of the path tracer (`--indirect path`; none otherwise). Last, so the
    /// other kinds keep their indices and columns.
    Diffuse = 4,
}

impl RayKind {
    pub const COUNT: usize = 5;
    pub const ALL: [RayKind; RayKind::COUNT] = [
        RayKind::Primary,
        RayKind::Shadow,
        RayKind::Reflection,
        RayKind::Refraction,
        RayKind::Diffuse,
    ];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Reflection => "reflection",
            RayKind::Refraction => "refraction",
            RayKind::Diffuse => "diffuse",
        }
    }

    /// Whether a summary lists this kind when none were traced: every kind but
    /// [`RayKind::Diffuse`], which only indirect light traces (summaries of direct-light
    /// frames stay as they were).
    pub fn always_listed(self) -> bool {
        self != RayKind::Diffuse
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
/// lap to a stage, and counts the lap. Off (`None`), it reads no clock: one predictable
/// branch per lap.
///
/// Every lap's interval also holds one clock read and the lap's own book-keeping. With one
/// lane and several laps per light sample that is a large part of a short stage (one clock
/// read costs about as much as a light sample's set-up), so the reported times subtract
/// [`lap_overhead_ns`] per lap ([`RenderStats::stage_seconds`]).
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
            stats.stage_laps[stage as usize] += 1;
            self.0 = Some(now);
        }
    }
}

/// What one `StageClock` lap costs on this machine, in nanoseconds: an empty lap (a clock
/// read and the book-keeping, nothing timed between two laps), timed over runs of 20,000
/// laps, the fastest of 9 runs. Measured once per process, the first time it is asked for.
///
/// It is an estimate: in a tight loop of laps the clock reads overlap each other less, or
/// more, than between a stage's instructions. The renderer's frames with the stage clocks
/// on against the same frames with them off show how close it comes (docs/findings/packets.md,
/// "the stage clocks add up to the frame").
pub fn lap_overhead_ns() -> f64 {
    static NS: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *NS.get_or_init(|| {
        const LAPS: u32 = 20_000;
        let mut stats = RenderStats::default();
        let mut best = f64::INFINITY;
        for _ in 0..9 {
            let mut clock = StageClock::start(true);
            let t = std::time::Instant::now();
            for _ in 0..LAPS {
                clock.lap(std::hint::black_box(&mut stats), Stage::Other);
            }
            best = best.min(t.elapsed().as_nanos() as f64 / f64::from(LAPS));
        }
        best
    })
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
    pub kinds: [LaneCount; RayKind::COUNT],
    /// Packets and active lanes of every traced packet (primary, reflection, refraction,
    /// diffuse) by depth in the ray tree: index 0 = camera rays.
    pub depth: Vec<LaneCount>,
    /// Material passes per shaded packet (the paper's one material at a time).
    pub materials: SplitCount,
    /// Radiance samples that came out NaN (zeroed in the image).
    pub nan: u64,
    /// Nanoseconds per [`Stage`], summed over threads, as the clock read them (each lap's
    /// own cost included; [`Self::stage_seconds`] takes it out); all zero unless the
    /// renderer's `time_stages` is on.
    pub stage_ns: [u64; Stage::COUNT],
    /// Laps of the stage clock charged to each [`Stage`].
    pub stage_laps: [u64; Stage::COUNT],
    /// Traversal work, per packet (`coherent_accel::Work`); counted only while the renderer's
    /// per-pixel maps are on, and by accelerators that count.
    pub work: coherent_accel::Work,
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
        for (a, b) in self.stage_laps.iter_mut().zip(&o.stage_laps) {
            *a += b;
        }
        self.work += o.work;
    }

    /// Seconds per [`Stage`], summed over threads, without the stage clock's own cost
    /// ([`lap_overhead_ns`] per lap; a stage never goes below zero).
    pub fn stage_seconds(&self) -> [f64; Stage::COUNT] {
        let lap = lap_overhead_ns();
        std::array::from_fn(|i| {
            (self.stage_ns[i] as f64 - self.stage_laps[i] as f64 * lap).max(0.0) * 1e-9
        })
    }

    /// Seconds the stage clock itself cost (what [`Self::stage_seconds`] took out), summed
    /// over threads.
    pub fn clock_seconds(&self) -> f64 {
        let raw: u64 = self.stage_ns.iter().sum();
        let net: f64 = self.stage_seconds().iter().sum();
        raw as f64 * 1e-9 - net
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

    /// The time of each timed stage ([`Self::stage_seconds`]), summed over threads, and its
    /// share, as `traversal 0.120 s (10.0%), ...`, then what the clock itself took out (all
    /// zero unless the renderer timed its stages).
    pub fn stage_summary(&self) -> String {
        let secs = self.stage_seconds();
        let total: f64 = secs.iter().sum();
        let stages = Stage::ALL
            .iter()
            .map(|s| {
                let t = secs[*s as usize];
                format!(
                    "{} {:.3} s ({:.1}%)",
                    s.name(),
                    t,
                    100.0 * t / total.max(1e-12)
                )
            })
            .collect::<Vec<_>>()
            .join(", ");
        let laps: u64 = self.stage_laps.iter().sum();
        format!(
            "{stages}; the clock's own {:.3} s ({laps} laps at {:.1} ns) taken out",
            self.clock_seconds(),
            lap_overhead_ns()
        )
    }

    /// One line: rays by kind, average active lanes per packet per stage, material passes
    /// per packet, NaN samples.
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        for k in RayKind::ALL {
            let c = self.kinds[k as usize];
            if k.always_listed() || c.lanes > 0 {
                parts.push(format!("{} {}", k.name(), c.lanes));
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_times_lose_the_clocks_own_cost_per_lap_and_never_go_below_zero() {
        let lap = lap_overhead_ns();
        assert!(lap.is_finite() && lap > 0.0, "an empty lap took {lap} ns");
        let mut st = RenderStats::default();
        // Traversal: 1 ms over 1,000 laps; shadows: less than its laps' cost; shading: no laps.
        st.stage_ns[Stage::Traversal as usize] = 1_000_000;
        st.stage_laps[Stage::Traversal as usize] = 1_000;
        st.stage_ns[Stage::Shadows as usize] = 10;
        st.stage_laps[Stage::Shadows as usize] = 1_000;
        st.stage_ns[Stage::Shading as usize] = 5_000;
        let s = st.stage_seconds();
        let want = (1_000_000.0 - 1_000.0 * lap).max(0.0) * 1e-9;
        assert!((s[Stage::Traversal as usize] - want).abs() < 1e-15);
        assert_eq!(s[Stage::Shadows as usize], 0.0);
        assert!((s[Stage::Shading as usize] - 5e-6).abs() < 1e-15);
        // What was taken out is what the clock cost: the raw sum less the net one.
        let raw = 1_005_010.0 * 1e-9;
        assert!((st.clock_seconds() - (raw - s.iter().sum::<f64>())).abs() < 1e-15);
        // Merging adds the laps.
        let mut both = st.clone();
        both.merge(st.clone());
        assert_eq!(both.stage_laps[Stage::Traversal as usize], 2_000);
    }
}
