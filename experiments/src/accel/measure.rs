//! The timed passes: every structure and width over the same rays of one scene and ray
//! kind, samples interleaved, each row cross-checked against the BSP's single rays.

use coherent::accel::{Accel, Ray1};
use coherent::accel_any::{AccelKind, AccelVisitor, AnyAccel, AnyParams};
use coherent::bsp::{Bsp, BspParams};
use coherent::simd::Backend;
use coherent_accel::scenes::{BuiltinScene, SceneSize};
use coherent_accel::workload;
use coherent_accel::workload::{Clock, PassResult, RayKind, TimeBeams, TimePackets};

use super::rays::{beam_side, beams, from_primary, rays, rays_in_tiles, shapes, widths};
use super::{counters, embree, leaves};
use crate::ctx::Ctx;
use crate::table::CsvOut;
use crate::timing::median;

/// What the passes are timed with: the thread's CPU time, so that other processes sharing
/// the machine (time slices taken from this thread) do not count. Measured on the shared
/// 2-core machine with wall time, one quick run's Embree rows scattered by up to 10x between
/// widths of the same scene and ray kind.
pub(super) const CLOCK: Clock = Clock::ThreadCpu;

/// What every scene is measured with.
pub(super) struct Setup {
    pub size: SceneSize,
    pub w: u32,
    pub h: u32,
    /// Timed samples per configuration.
    pub samples: usize,
    /// Builds timed per structure.
    pub repeats: usize,
    /// Width 1 (single rays) and each packet width with its backend.
    pub widths: Vec<(usize, Option<Backend>)>,
    /// The beams: (rays per beam, backend), those whose tiles divide the image.
    pub beams: Vec<(usize, Backend)>,
    /// Lane packets of other shapes: (tile width and height, backend), those whose tiles
    /// divide the image.
    pub shapes: Vec<((u32, u32), Backend)>,
}

impl Setup {
    pub(super) fn new(ctx: &mut Ctx) -> Self {
        let (w, h): (u32, u32) = ctx.pick((256, 192), (1024, 768));
        let widths = widths(ctx);
        Self {
            size: ctx.pick(SceneSize::Quick, SceneSize::Full),
            w,
            h,
            samples: ctx.pick(3, 7),
            repeats: ctx.pick(3, 2),
            beams: beams()
                .into_iter()
                .filter(|&(n, _)| w.is_multiple_of(beam_side(n)) && h.is_multiple_of(beam_side(n)))
                .collect(),
            shapes: shapes(&widths)
                .into_iter()
                .filter(|&((tw, th), _)| w.is_multiple_of(tw) && h.is_multiple_of(th))
                .collect(),
            widths,
        }
    }
}

/// The files the per-scene passes write.
pub(super) struct Outputs {
    /// `accel.csv`.
    pub rates: CsvOut,
    /// `accel_traversal.csv`.
    pub traversal: CsvOut,
    /// `accel_embree.csv`.
    pub embree: CsvOut,
    /// `accel_simd_leaves.csv`.
    pub leaves: CsvOut,
    /// `accel_shapes.csv`.
    pub shapes: CsvOut,
}

impl Outputs {
    pub(super) fn open(ctx: &Ctx) -> anyhow::Result<Self> {
        Ok(Self {
            rates: ctx.csv("accel.csv", super::HEADER)?,
            traversal: ctx.csv("accel_traversal.csv", super::TRAVERSAL_HEADER)?,
            embree: ctx.csv("accel_embree.csv", super::EMBREE_HEADER)?,
            leaves: ctx.csv("accel_simd_leaves.csv", super::LEAVES_HEADER)?,
            shapes: ctx.csv("accel_shapes.csv", super::SHAPES_HEADER)?,
        })
    }

    pub(super) fn finish(self) -> anyhow::Result<()> {
        self.rates.finish()?;
        self.traversal.finish()?;
        self.embree.finish()?;
        self.leaves.finish()?;
        self.shapes.finish()?;
        Ok(())
    }
}

/// A structure other than the BSP, built over one scene.
pub(super) struct Other {
    pub kind: AccelKind,
    pub accel: AnyAccel,
    /// Median build time, milliseconds.
    pub build_ms: f64,
}

/// One pass of `accel` over `rays` at a width: seconds, hits and the sum of hit `t`.
pub(crate) fn pass_any<A: Accel>(
    accel: &A,
    rays: &[Ray1],
    occlusion: bool,
    backend: Option<Backend>,
) -> anyhow::Result<PassResult> {
    Ok(match backend {
        None => workload::time_single(accel, rays, occlusion, 1, CLOCK),
        Some(b) => b.run(TimePackets {
            accel,
            rays,
            occlusion,
            repeats: 1,
            clock: CLOCK,
        })?,
    })
}

/// A timed pass on the concrete structure inside an [`AnyAccel`] (the enum's `match` stays
/// outside the timed loop).
pub(super) struct Pass<'a> {
    pub rays: &'a [Ray1],
    pub occlusion: bool,
    pub backend: Option<Backend>,
}

impl AccelVisitor for Pass<'_> {
    type Output = anyhow::Result<PassResult>;
    fn visit<A: Accel>(self, a: &A) -> Self::Output {
        pass_any(a, self.rays, self.occlusion, self.backend)
    }
}

/// One pass of `accel`'s beam queries over `rays` in beams of `n` rays on `backend` (the
/// BSP's beam traversal, obvhs' large packets).
fn pass_beam<A: Accel>(
    accel: &A,
    rays: &[Ray1],
    occlusion: bool,
    (n, backend): (usize, Backend),
) -> anyhow::Result<PassResult> {
    Ok(backend.run(TimeBeams {
        accel,
        rays,
        beam: n,
        occlusion,
        repeats: 1,
        clock: CLOCK,
    })?)
}

/// A timed beam pass on the concrete structure inside an [`AnyAccel`].
struct PassBeam<'a> {
    rays: &'a [Ray1],
    occlusion: bool,
    beam: (usize, Backend),
}

impl AccelVisitor for PassBeam<'_> {
    type Output = anyhow::Result<PassResult>;
    fn visit<A: Accel>(self, a: &A) -> Self::Output {
        pass_beam(a, self.rays, self.occlusion, self.beam)
    }
}

/// Whether `a` has beam queries of its own besides the BSP (obvhs' large packets over its
/// BVH2s); the others' beams would time their packets one by one.
fn has_own_beams(a: &AnyAccel) -> bool {
    #[cfg(feature = "obvhs")]
    if let AnyAccel::Obvhs(_) = a {
        return true;
    }
    let _ = a;
    false
}

/// Medians of interleaved samples of each configuration (`f(i)` runs configuration `i`
/// once), with each configuration's last result.
pub(crate) fn interleaved(
    n: usize,
    samples: usize,
    mut f: impl FnMut(usize) -> anyhow::Result<PassResult>,
) -> anyhow::Result<Vec<(f64, PassResult)>> {
    let mut last: Vec<PassResult> = (0..n).map(&mut f).collect::<anyhow::Result<_>>()?; // warm-up
    let mut s = vec![Vec::with_capacity(samples); n];
    for _ in 0..samples {
        for (i, v) in s.iter_mut().enumerate() {
            let r = f(i)?;
            v.push(r.seconds);
            last[i] = r;
        }
    }
    Ok(s.iter().map(|v| median(v)).zip(last).collect())
}

/// The median of `repeats` builds' own build time (`BuildStats::build_seconds`: Embree's
/// excludes creating its device), in milliseconds, and the last build.
pub(super) fn build_timed<A: Accel>(
    scene: &coherent::accel::Scene,
    params: &A::Params,
    repeats: usize,
) -> Result<(A, f64), coherent::accel::AccelError> {
    let mut secs = Vec::new();
    let mut last = A::build(scene, params)?;
    secs.push(last.stats().build_seconds);
    for _ in 1..repeats {
        last = A::build(scene, params)?;
        secs.push(last.stats().build_seconds);
    }
    Ok((last, median(&secs) * 1e3))
}

/// Builds the other structures usable here over `s` (every compared kind but the BSP, with
/// the parameters the experiments time them with), each with the median build time of
/// `repeats` builds; one whose build fails is noted and left out.
fn build_others(ctx: &mut Ctx, s: &BuiltinScene, repeats: usize) -> Vec<Other> {
    let mut out = Vec::new();
    for kind in AccelKind::compared().filter(|&k| k != AccelKind::Bsp) {
        if kind.unavailable_reason().is_some() {
            continue;
        }
        // obvhs' CWBVHs with the BVH2s its beams walk: its build time here includes them.
        #[cfg_attr(not(feature = "obvhs"), allow(unused_mut))]
        let mut params = AnyParams::timed(kind, 1);
        #[cfg(feature = "obvhs")]
        {
            params.obvhs.beam_bvh2 = true;
        }
        match build_timed::<AnyAccel>(&s.scene, &params, repeats) {
            Ok((accel, build_ms)) => out.push(Other {
                kind,
                accel,
                build_ms,
            }),
            Err(e) => ctx.note(format!("accel: {kind} left out of scene {}: {e}", s.name)),
        }
    }
    out
}

/// Builds every structure over `s` and measures each on every kind of rays; returns the BSP,
/// which the sweeps after reuse.
pub(super) fn scene(
    ctx: &mut Ctx,
    setup: &Setup,
    s: &BuiltinScene,
    out: &mut Outputs,
    disagreements: &mut Vec<String>,
) -> anyhow::Result<Bsp> {
    let (bsp, build_ms) = build_timed::<Bsp>(&s.scene, &BspParams::default(), setup.repeats)?;
    let mut others = build_others(ctx, s, setup.repeats);
    let four = leaves::simd_leaf_bsps(&s.scene)?;
    for kind in RayKind::ALL {
        // Embree's COHERENT flag: primary and shadow rays.
        for o in &mut others {
            o.accel.set_coherent(kind != RayKind::Diffuse);
        }
        let k = KindRun::new(setup, s, &bsp, kind);
        k.time(out, build_ms, &others, disagreements)?;
        counters::rows(&mut out.traversal, &k, &others)?;
        let mut ls = leaves::LeafSet {
            csv: &mut out.leaves,
            scene: s.name,
            kind,
            rays: &k.sets[0],
            samples: setup.samples,
            disagreements: &mut *disagreements,
        };
        ls.rows(&bsp, &four, &others)?;
    }
    Ok(bsp)
}

/// One scene and kind of rays: the rays each configuration traces.
pub(super) struct KindRun<'a> {
    pub setup: &'a Setup,
    pub s: &'a BuiltinScene,
    pub bsp: &'a Bsp,
    pub kind: RayKind,
    /// The rays of each width of `setup.widths`, ordered for it.
    pub sets: Vec<Vec<Ray1>>,
    /// The rays of each beam of `setup.beams`, tile by tile (none for diffuse rays: beams
    /// are for coherent rays only).
    pub beam_sets: Vec<Vec<Ray1>>,
    /// The rays of each lane-packet shape of `setup.shapes`, tile by tile.
    pub shape_sets: Vec<Vec<Ray1>>,
}

impl<'a> KindRun<'a> {
    fn new(setup: &'a Setup, s: &'a BuiltinScene, bsp: &'a Bsp, kind: RayKind) -> Self {
        let (w, h) = (setup.w, setup.h);
        let sets = setup
            .widths
            .iter()
            .map(|&(wd, _)| rays(s, bsp, kind, w, h, wd))
            .collect();
        let beam_sets = if kind == RayKind::Diffuse {
            Vec::new()
        } else {
            setup
                .beams
                .iter()
                .map(|&(n, b)| {
                    let packet = workload::tile_shape(b.lanes());
                    let primary = workload::beam_rays(&s.view, w, h, beam_side(n), packet);
                    from_primary(s, bsp, kind, primary)
                })
                .collect()
        };
        let shape_sets = setup
            .shapes
            .iter()
            .map(|&(tile, _)| rays_in_tiles(s, bsp, kind, w, h, tile))
            .collect();
        Self {
            setup,
            s,
            bsp,
            kind,
            sets,
            beam_sets,
            shape_sets,
        }
    }

    /// Every configuration: the BSP's widths, its beams, the others' widths (single rays
    /// only for a structure without packets of its own) and the beams of those with beams of
    /// their own (obvhs), at the BSP's beam sizes.
    fn variants(&self, others: &[Other]) -> Vec<(Who, usize)> {
        let widths = &self.setup.widths;
        let mut v: Vec<(Who, usize)> = (0..widths.len()).map(|i| (Who::Bsp, i)).collect();
        v.extend((0..self.beam_sets.len()).map(|b| (Who::Beam, b)));
        v.extend((0..self.shape_sets.len()).map(|i| (Who::Shape, i)));
        for (k, o) in others.iter().enumerate() {
            for (i, &(wd, _)) in widths.iter().enumerate() {
                if wd == 1 || o.kind.has_packets() {
                    v.push((Who::Other(k), i));
                }
            }
            if has_own_beams(&o.accel) {
                v.extend((0..self.beam_sets.len()).map(|b| (Who::OtherBeam(k), b)));
            }
        }
        v
    }

    /// Times every configuration, interleaved, and writes the rows of `accel.csv` and
    /// `accel_embree.csv`.
    fn time(
        &self,
        out: &mut Outputs,
        build_ms: f64,
        others: &[Other],
        disagreements: &mut Vec<String>,
    ) -> anyhow::Result<()> {
        let (widths, beams) = (&self.setup.widths, &self.setup.beams);
        let mut emb = embree::Packed::new(others, widths, &self.sets);
        let mut variants = self.variants(others);
        variants.extend(emb.variants());
        let occlusion = self.kind.occlusion();
        let res = interleaved(variants.len(), self.setup.samples, |v| {
            let (who, i) = variants[v];
            match who {
                Who::Bsp => pass_any(self.bsp, &self.sets[i], occlusion, widths[i].1),
                Who::Beam => pass_beam(self.bsp, &self.beam_sets[i], occlusion, beams[i]),
                Who::Shape => pass_any(
                    self.bsp,
                    &self.shape_sets[i],
                    occlusion,
                    Some(self.setup.shapes[i].1),
                ),
                Who::OtherBeam(k) => others[k].accel.visit(PassBeam {
                    rays: &self.beam_sets[i],
                    occlusion,
                    beam: beams[i],
                }),
                Who::Other(k) | Who::EmbreePlain(k) | Who::EmbreeTrait(k) => {
                    match emb.pass(who, i, occlusion) {
                        Some(r) => Ok(r),
                        None => others[k].accel.visit(Pass {
                            rays: &self.sets[i],
                            occlusion,
                            backend: widths[i].1,
                        }),
                    }
                }
            }
        })?;
        self.rows(
            &mut out.rates,
            build_ms,
            others,
            &variants,
            &res,
            disagreements,
        )?;
        self.shape_rows(&mut out.shapes, &variants, &res, disagreements)?;
        embree::rows(
            &mut out.embree,
            self.s.name,
            self.kind,
            widths,
            &self.sets,
            &variants,
            &res,
        )
    }

    /// The rows of `accel.csv`, each checked against the BSP's single rays (`res[0]`).
    fn rows(
        &self,
        csv: &mut CsvOut,
        build_ms: f64,
        others: &[Other],
        variants: &[(Who, usize)],
        res: &[(f64, PassResult)],
        disagreements: &mut Vec<String>,
    ) -> anyhow::Result<()> {
        let (widths, beams) = (&self.setup.widths, &self.setup.beams);
        let reference = res[0].1;
        for (v, &(who, i)) in variants.iter().enumerate() {
            let (name, build_ms, memory) = match who {
                Who::Bsp | Who::Beam => ("bsp", build_ms, self.bsp.memory_bytes()),
                Who::Other(k) | Who::OtherBeam(k) => (
                    others[k].kind.name(),
                    others[k].build_ms,
                    others[k].accel.memory_bytes(),
                ),
                Who::Shape | Who::EmbreePlain(_) | Who::EmbreeTrait(_) => continue,
            };
            let (n, width, query, backend) = match who {
                Who::Beam | Who::OtherBeam(_) => (
                    self.beam_sets[i].len(),
                    beams[i].0,
                    "beam",
                    Some(beams[i].1),
                ),
                _ => (self.sets[i].len(), widths[i].0, "lanes", widths[i].1),
            };
            let (secs, r) = res[v];
            csv.row(&[
                &self.s.name,
                &name,
                &self.kind.name(),
                &width,
                &format!("{:.3}", n as f64 / secs / 1e6),
                &format!("{build_ms:.2}"),
                &memory,
                &r.hits,
                &format!("{:.6e}", r.t_sum),
                &query,
                &backend.map_or("single", Backend::name),
            ])?;
            if let Some(why) = disagreement(&reference, &r, n) {
                let on = match who {
                    Who::Beam | Who::OtherBeam(_) => {
                        format!("beams of {width} on {}", beams[i].1.name())
                    }
                    _ => format!("width {width}"),
                };
                disagreements.push(format!(
                    "{} {} rays, {name} at {on}: {why}",
                    self.s.name,
                    self.kind.name(),
                ));
            }
        }
        Ok(())
    }
}

impl KindRun<'_> {
    /// The rows of `accel_shapes.csv`: each lane-packet shape beside the square tile of the
    /// same width and backend (timed in the same interleaved samples), cross-checked like
    /// every row of `accel.csv`.
    fn shape_rows(
        &self,
        csv: &mut CsvOut,
        variants: &[(Who, usize)],
        res: &[(f64, PassResult)],
        disagreements: &mut Vec<String>,
    ) -> anyhow::Result<()> {
        let rate = |v: usize, n: usize| n as f64 / res[v].0 / 1e6;
        for (v, &(who, i)) in variants.iter().enumerate() {
            if who != Who::Shape {
                continue;
            }
            let ((tw, th), b) = self.setup.shapes[i];
            let lanes = (tw * th) as usize;
            let square = variants
                .iter()
                .position(|&(who, j)| who == Who::Bsp && self.setup.widths[j] == (lanes, Some(b)));
            let n = self.shape_sets[i].len();
            let mrays = rate(v, n);
            let over = square.map_or(f64::NAN, |s| {
                mrays / rate(s, self.sets[variants[s].1].len())
            });
            csv.row(&[
                &self.s.name,
                &self.kind.name(),
                &format!("{tw}x{th}"),
                &b.name(),
                &format!("{mrays:.3}"),
                &format!("{over:.3}"),
            ])?;
            if let Some(why) = disagreement(&res[0].1, &res[v].1, n) {
                disagreements.push(format!(
                    "{} {} rays, bsp lane packets {tw}x{th} on {}: {why}",
                    self.s.name,
                    self.kind.name(),
                    b.name()
                ));
            }
        }
        Ok(())
    }
}

/// Which configuration a timed sample runs.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Who {
    Bsp,
    /// The BSP's beams: `Setup::beams[i]`.
    Beam,
    /// The BSP's lane packets shaped `Setup::shapes[i]`.
    Shape,
    /// `others[k]`.
    Other(usize),
    /// `others[k]`'s own beams (obvhs): `Setup::beams[i]`.
    OtherBeam(usize),
    /// Embree (`others[k]`): the plain C-API loop over its packed packets.
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    EmbreePlain(usize),
    /// Embree (`others[k]`): packets through the `Accel` trait, packed per call.
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    EmbreeTrait(usize),
}

/// How far the hit count of a pass may be from the BSP's single-ray pass over the same rays,
/// as a share of the rays (plus 2). The interface lets a hit within `EDGE_EPS` of a
/// triangle's edge be missed (`coherent_accel::Accel`), and the structures use different
/// triangle tests (Embree's and obvhs' are not the projection test with its tolerance band),
/// so rays grazing a silhouette edge may count differently; measured: at most 0.01% of the
/// rays on every scene of the quick run.
pub(super) const HIT_TOLERANCE: f64 = 1e-3;

/// How far the mean `t` of the hits may be from the BSP's, relative: the triangle tests
/// round differently (about 1e-6 relative), and the few edge rays above may hit a
/// different, farther surface.
pub(super) const T_TOLERANCE: f64 = 1e-3;

/// Why `r` disagrees with `reference` over `rays` rays, if it does beyond the tolerances.
pub(crate) fn disagreement(reference: &PassResult, r: &PassResult, rays: usize) -> Option<String> {
    let dh = r.hits.abs_diff(reference.hits) as f64;
    if dh > HIT_TOLERANCE * rays as f64 + 2.0 {
        return Some(format!(
            "{} hits against the BSP's {}",
            r.hits, reference.hits
        ));
    }
    let mean = |p: &PassResult| {
        if p.hits == 0 {
            0.0
        } else {
            p.t_sum / p.hits as f64
        }
    };
    let (a, b) = (mean(r), mean(reference));
    if (a - b).abs() > T_TOLERANCE * b.abs().max(1e-30) {
        return Some(format!("mean hit t {a:.6} against the BSP's {b:.6}"));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pass(hits: u64, t_sum: f64) -> PassResult {
        PassResult {
            seconds: 1.0,
            hits,
            t_sum,
        }
    }

    #[test]
    fn the_cross_check_allows_edge_rays_and_nothing_more() {
        let bsp = pass(10_000, 50_000.0);
        // Same answers, rounding in t, a few edge rays: agree.
        assert_eq!(disagreement(&bsp, &pass(10_000, 50_000.4), 20_000), None);
        assert_eq!(disagreement(&bsp, &pass(10_019, 50_095.0), 20_000), None);
        // Missing hits beyond 0.1% of the rays + 2.
        assert!(disagreement(&bsp, &pass(9_970, 49_850.0), 20_000).is_some());
        // Right count, wrong (farther) hits.
        assert!(disagreement(&bsp, &pass(10_000, 50_100.0), 20_000).is_some());
        // Occlusion rows (t_sum 0) compare counts only.
        assert_eq!(
            disagreement(&pass(7107, 0.0), &pass(7106, 0.0), 10_000),
            None
        );
        assert!(disagreement(&pass(7107, 0.0), &pass(7000, 0.0), 10_000).is_some());
    }
}
