//! What a particle pass did, per generation: rays, packets and their occupancy, traversal
//! work, and where the time went (thread time, summed over the chunks that ran in
//! parallel), with the power emitted and deposited.

use coherent_accel::Work;

/// One generation of every chunk's particle rays (generation 0: the rays leaving the lights;
/// generation `g`: the rays after `g` bounces).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GenerationStats {
    pub generation: u32,
    /// Rays traced.
    pub rays: u64,
    /// Packets traced.
    pub packets: u64,
    /// Active lanes over all packets (`active_lanes / packets` lanes per packet).
    pub active_lanes: u64,
    /// Thread time in traversal (ns).
    pub trace_ns: u64,
    /// Thread time ordering and packing the rays (ns).
    pub sort_ns: u64,
    /// Thread time processing the hits: deposits and scattering (ns).
    pub shade_ns: u64,
    /// Traversal work (counted only with `MapOptions::count_work`).
    pub work: Work,
}

impl GenerationStats {
    /// Adds `o`'s counts and times (the same generation of another chunk).
    pub fn merge(&mut self, o: &GenerationStats) {
        self.rays += o.rays;
        self.packets += o.packets;
        self.active_lanes += o.active_lanes;
        self.trace_ns += o.trace_ns;
        self.sort_ns += o.sort_ns;
        self.shade_ns += o.shade_ns;
        self.work += o.work;
    }

    /// Rays per second of traversal thread time.
    pub fn rays_per_second(&self) -> f64 {
        ratio(self.rays as f64 * 1e9, self.trace_ns as f64)
    }

    /// Mean active lanes per packet.
    pub fn lanes_per_packet(&self) -> f64 {
        ratio(self.active_lanes as f64, self.packets as f64)
    }

    /// Inner nodes visited per ray.
    pub fn nodes_per_ray(&self) -> f64 {
        ratio(self.work.inner_nodes as f64, self.rays as f64)
    }

    /// Triangle tests per ray.
    pub fn tests_per_ray(&self) -> f64 {
        ratio(self.work.tri_tests as f64, self.rays as f64)
    }

    /// The ordering's share of the generation's thread time (0 to 1).
    pub fn sort_share(&self) -> f64 {
        ratio(
            self.sort_ns as f64,
            (self.sort_ns + self.trace_ns + self.shade_ns) as f64,
        )
    }
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}

/// A whole particle pass.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TraceStats {
    /// Per generation, in order.
    pub generations: Vec<GenerationStats>,
    /// Power the particles carried from the lights (W per channel; the emitter's power in
    /// expectation, exactly for one light).
    pub emitted: [f64; 3],
    /// Power deposited in the map (W per channel), as the map's fixed-point sums hold it.
    pub deposited: [f64; 3],
    /// The same per generation of the ray that made the deposit (generation 0 deposits
    /// nothing: direct light is the renderer's).
    pub deposited_by_generation: Vec<[f64; 3]>,
    /// Particles traced.
    pub particles: u64,
    /// Wall time of the pass (s).
    pub seconds: f64,
    /// Lanes of the backend's packets.
    pub lanes: usize,
}

impl TraceStats {
    /// Adds another chunk's statistics (generation by generation; `seconds` and `lanes` are
    /// the caller's).
    pub fn merge(&mut self, o: &TraceStats) {
        for (k, g) in o.generations.iter().enumerate() {
            if self.generations.len() <= k {
                self.generations.push(GenerationStats {
                    generation: k as u32,
                    ..GenerationStats::default()
                });
            }
            self.generations[k].merge(g);
        }
        for (k, d) in o.deposited_by_generation.iter().enumerate() {
            if self.deposited_by_generation.len() <= k {
                self.deposited_by_generation.push([0.0; 3]);
            }
            add3(&mut self.deposited_by_generation[k], d);
        }
        add3(&mut self.emitted, &o.emitted);
        add3(&mut self.deposited, &o.deposited);
        self.particles += o.particles;
    }

    /// Rays over all generations.
    pub fn rays(&self) -> u64 {
        self.generations.iter().map(|g| g.rays).sum()
    }

    /// Every generation's counts and times summed (`generation` is that of the last).
    pub fn total(&self) -> GenerationStats {
        let mut t = GenerationStats::default();
        for g in &self.generations {
            t.merge(g);
            t.generation = g.generation;
        }
        t
    }
}

/// `a += b`, channel by channel.
pub(super) fn add3(a: &mut [f64; 3], b: &[f64; 3]) {
    for (a, b) in a.iter_mut().zip(b) {
        *a += b;
    }
}
