//! Where coherence breaks, per pixel (`coherent render --aov`): what the packets that traced
//! a pixel's rays did, summed over its samples' ray trees and divided by its samples.
//!
//! Every segment of a ray tree (the camera packet, then each reflection and refraction
//! packet, with the shadow packets cast from its hits) charges each of its active lanes:
//! - `steps`, `tests`: the inner nodes and triangle tests of the segment's queries, per
//!   packet ([`Work`]: a step counts once for the packet, so a lane is charged what it sat
//!   through, not a share). A camera beam's work is split evenly over its packets.
//! - `lanes`: the active lanes of the segment's packet, averaged over the pixel's segments.
//! - `time`: the segment's wall time divided by its active lanes (a beam's over its rays).
//!
//! A coherent region shows the single ray's step count (one lane's work is the packet's);
//! where packets diverge, every lane pays for the union of its packet's paths.

use std::sync::atomic::{AtomicU64, Ordering};

use coherent_accel::Work;

/// One per-pixel map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AovKind {
    /// Inner nodes visited per sample.
    Steps,
    /// Triangle tests per sample.
    Tests,
    /// Active lanes of the packets that traced the pixel.
    Lanes,
    /// Nanoseconds per sample.
    Time,
}

impl AovKind {
    pub const ALL: [AovKind; 4] = [
        AovKind::Steps,
        AovKind::Tests,
        AovKind::Lanes,
        AovKind::Time,
    ];

    /// The name on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            AovKind::Steps => "steps",
            AovKind::Tests => "tests",
            AovKind::Lanes => "lanes",
            AovKind::Time => "time",
        }
    }

    /// What the map's values are, for its colour bar.
    pub fn label(self) -> &'static str {
        match self {
            AovKind::Steps => "inner nodes per sample",
            AovKind::Tests => "triangle tests per sample",
            AovKind::Lanes => "active lanes per packet",
            AovKind::Time => "ns per sample",
        }
    }

    /// Whether the map needs the accelerator to count its traversal
    /// ([`coherent_accel::Accel::counts_work`]).
    pub fn needs_counts(self) -> bool {
        matches!(self, AovKind::Steps | AovKind::Tests)
    }
}

impl std::fmt::Display for AovKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for AovKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown map `{s}`: steps, tests, lanes or time"))
    }
}

/// Per-pixel sums the renderer adds to from every thread.
pub struct AovBuffer {
    width: u32,
    height: u32,
    /// Per pixel: samples, steps, tests, lane sum, segments, nanoseconds (f64 bits; added
    /// with compare-and-swap: threads meet on a pixel only at tile borders).
    sums: Vec<[AtomicU64; 6]>,
}

const SAMPLES: usize = 0;
const STEPS: usize = 1;
const TESTS: usize = 2;
const LANES: usize = 3;
const SEGMENTS: usize = 4;
const TIME: usize = 5;

fn add(a: &AtomicU64, v: f64) {
    let _ = a.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
        Some((f64::from_bits(b) + v).to_bits())
    });
}

impl AovBuffer {
    /// Zeroed sums for a `width` x `height` image.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        AovBuffer {
            width,
            height,
            sums: (0..n)
                .map(|_| std::array::from_fn(|_| AtomicU64::new(0f64.to_bits())))
                .collect(),
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixel of the image point `(x, y)` (pixel coordinates), clamped to the image.
    pub fn pixel(&self, x: f32, y: f32) -> u32 {
        let px = (x.max(0.0) as u32).min(self.width - 1);
        let py = (y.max(0.0) as u32).min(self.height - 1);
        py * self.width + px
    }

    /// One more sample at `pixel`.
    pub fn sample(&self, pixel: u32) {
        add(&self.sums[pixel as usize][SAMPLES], 1.0);
    }

    /// One segment's charge to one of its lanes at `pixel`: the segment's `work` (or its
    /// share of a beam's), the packet's `lanes` and the lane's share `ns` of the time.
    pub fn charge(&self, pixel: u32, steps: f64, tests: f64, lanes: u32, ns: f64) {
        self.charge_work(pixel, steps, tests, ns);
        let s = &self.sums[pixel as usize];
        add(&s[LANES], f64::from(lanes));
        add(&s[SEGMENTS], 1.0);
    }

    /// Work and time without a segment of its own: a camera beam's share, charged before its
    /// packets are shaded as segments (which count their lanes then).
    pub fn charge_work(&self, pixel: u32, steps: f64, tests: f64, ns: f64) {
        let s = &self.sums[pixel as usize];
        add(&s[STEPS], steps);
        add(&s[TESTS], tests);
        add(&s[TIME], ns);
    }

    /// [`AovBuffer::charge`] of `work` for each of a packet's lanes, `pixels` per lane (the
    /// active ones only), `ns` the whole packet's time.
    pub fn charge_packet(&self, pixels: &[u32], work: Work, ns: f64) {
        let lanes = pixels.len() as u32;
        if lanes == 0 {
            return;
        }
        for &p in pixels {
            self.charge(
                p,
                work.inner_nodes as f64,
                work.tri_tests as f64,
                lanes,
                ns / f64::from(lanes),
            );
        }
    }

    /// The map of `kind`, row by row from the top: per sample (steps, tests, time) or per
    /// segment (lanes); pixels without samples are 0.
    pub fn map(&self, kind: AovKind) -> Vec<f32> {
        let get = |s: &[AtomicU64; 6], i: usize| f64::from_bits(s[i].load(Ordering::Relaxed));
        self.sums
            .iter()
            .map(|s| {
                let (num, den) = match kind {
                    AovKind::Steps => (get(s, STEPS), get(s, SAMPLES)),
                    AovKind::Tests => (get(s, TESTS), get(s, SAMPLES)),
                    AovKind::Lanes => (get(s, LANES), get(s, SEGMENTS)),
                    AovKind::Time => (get(s, TIME), get(s, SAMPLES)),
                };
                if den > 0.0 { (num / den) as f32 } else { 0.0 }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for k in AovKind::ALL {
            assert_eq!(k.name().parse::<AovKind>().unwrap(), k);
        }
        let e = "nodes".parse::<AovKind>().unwrap_err();
        assert!(e.contains("steps, tests, lanes or time"), "{e}");
    }

    #[test]
    fn maps_are_per_sample_and_lanes_per_segment() {
        let b = AovBuffer::new(2, 1);
        let p = b.pixel(1.5, 0.2);
        assert_eq!(p, 1);
        assert_eq!(b.pixel(-3.0, 7.0), 0, "clamped to the image");
        b.sample(p);
        b.sample(p);
        // Two samples: a 4-lane camera packet with 3 active lanes and a 1-lane reflection.
        b.charge_packet(
            &[p, 0, 0],
            Work {
                inner_nodes: 30,
                tri_tests: 6,
            },
            300.0,
        );
        b.charge_packet(
            &[p],
            Work {
                inner_nodes: 10,
                tri_tests: 2,
            },
            50.0,
        );
        assert_eq!(b.map(AovKind::Steps)[1], (30.0 + 10.0) / 2.0);
        assert_eq!(b.map(AovKind::Tests)[1], (6.0 + 2.0) / 2.0);
        assert_eq!(b.map(AovKind::Lanes)[1], (3.0 + 1.0) / 2.0);
        assert_eq!(b.map(AovKind::Time)[1], (100.0 + 50.0) / 2.0);
        // Pixel 0 got charges but no samples of its own: no value.
        assert_eq!(b.map(AovKind::Steps)[0], 0.0);
    }
}
