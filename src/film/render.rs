//! The progressive render loop (paper section 6.2): the superpixel pre-render, then passes
//! of coherent Halton groups over the tiles, in parallel with rayon (one task per tile,
//! each calling `Backend::run`), accumulated in a fixed order so that the image does not
//! depend on the thread count.

// Per-packet code uses index loops over lanes (see docs/architecture.md#inlining).
#![allow(clippy::needless_range_loop)]

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use coherent_simd::{Backend, BackendError, MAX_LANES};
use rayon::prelude::*;

use super::batch::{PacketIn, trace_packets};

use super::matrix::{Film, FilmBand, FilmLines};
use super::progressive::Progressive;
use super::tracer::SampleTracer;
use super::{
    Coherence, FilmError, FilmOptions, Fixups, Method, PassRecord, PassReport, Rendered, StopReason,
};
use crate::sampler::{HaltonTile, Span};

/// Points traced per pre-render task.
const POINTS_PER_TASK: usize = 256;

/// Most tiles (or pre-render tasks) one rayon job runs in a row. Rayon splits a parallel
/// iterator only about `2 x threads` times unless a piece is stolen, so with 2 threads a
/// 1024 x 768 pass (5,504 tiles) ran as pieces of up to 1,376 tiles, and the thread that
/// finished first idled while the other worked through its last piece: 40-170 ms of a
/// 0.45 s frame (`perf` timelines of `coherent render glass1 --threads 2`). A tile is some
/// 0.1 ms of work, so splitting down to a few tiles costs nothing measurable.
const TILES_PER_JOB: usize = 4;

/// Renders with the current rayon pool, pass after pass to the end: the pre-render, then
/// [`Progressive::step`] until it stops. The image is bit-identical for any thread count;
/// with [`Method::Uniform`] the set of samples (positions and ids) does not depend on the
/// packet width either. `progress` is called after each pass (pass 0 is the pre-render).
pub fn render<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    opts: &FilmOptions,
    progress: &(dyn Fn(&PassReport) + Sync),
) -> Result<Rendered<T::Stats>, FilmError> {
    let mut p = Progressive::new(backend, tracer, opts)?;
    progress(&p.report());
    while p.step()?.is_some() {
        progress(&p.report());
    }
    Ok(p.finish())
}

/// What the passes after the pre-render share: the tiles, the spans, where the next pass's
/// sample indices start and, when adaptive, which pixels still need rays.
pub(super) struct PassState {
    tiles: Vec<(u32, u32)>,
    levels: Vec<Span>,
    id_base: u64,
    rays: u64,
    next_index: u64,
    pass: u32,
    /// After a pass: which pixels need rays and whether any stopped at the cap unconverged.
    pending: Option<(Vec<bool>, bool)>,
}

impl PassState {
    /// The state after the pre-render, which traced `pre_rays` points (their ids come first).
    pub(super) fn new(opts: &FilmOptions, pre_rays: u64) -> PassState {
        let (w, h, tile) = (opts.width, opts.height, opts.tile);
        PassState {
            tiles: (0..h.div_ceil(tile.height()))
                .flat_map(|ty| (0..w.div_ceil(tile.width())).map(move |tx| (tx, ty)))
                .collect(),
            levels: Span::levels(tile),
            id_base: pre_rays,
            rays: pre_rays,
            next_index: 0,
            pass: 0,
            pending: None,
        }
    }
}

/// Why no pass was traced: the render stopped, or the pass failed (or was cancelled).
pub(super) type NoPass = Result<StopReason, FilmError>;

/// Plans and traces the next pass into `film`, and records it.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_pass<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    opts: &FilmOptions,
    film: &mut Film,
    st: &mut PassState,
    start: Instant,
    cancel: Option<&AtomicBool>,
    fixups: &mut Fixups,
    stats: &mut T::Stats,
) -> Result<PassRecord, NoPass> {
    let (w, h, tile) = (opts.width, opts.height, opts.tile);
    let lanes = backend.lanes();
    let (span, begin, end, need) = plan_pass(opts, film, start, st, lanes).map_err(Ok)?;
    st.next_index = end;
    st.pass += 1;
    // Every tile traces the same indices of its own Halton sequence, and where a sample
    // falls in its tile depends on the index alone: worked out once per pass, not once
    // per tile (the digit loops took 8 ms of a 1024 x 768 frame at 16 lanes, one core).
    let places: Vec<Place> = (begin..end).map(|i| Place::new(tile, i)).collect();
    let job = PassJob {
        origin: (0, 0),
        width: w,
        height: h,
        begin,
        end,
        span,
        need: need.as_deref(),
        places: &places,
        id_base: st.id_base,
        tile: (tile.width(), tile.height()),
        lines: film.lines(),
    };
    let outs = trace_tiles(backend, tracer, film, &st.tiles, &job, cancel).map_err(Err)?;
    let sums = PassSums::of(outs, fixups, stats, T::merge_stats);
    st.rays += sums.rays;
    let adaptive = matches!(opts.method, Method::Adaptive { .. });
    let errors = pixel_errors(film, adaptive);
    let done = match opts.method {
        Method::Adaptive {
            accuracy,
            max_samples_per_pixel,
            ..
        } => {
            let (need, capped) = needed(film, &errors.max, accuracy, max_samples_per_pixel);
            let done = need.iter().filter(|n| !**n).count() as f64 / film.pixels() as f64;
            st.pending = Some((need, capped));
            done
        }
        Method::Uniform { .. } => covered_fraction(film),
    };
    Ok(PassRecord {
        pass: st.pass,
        span,
        radius: span.radius(tile),
        rays: st.rays,
        rays_this_pass: sums.rays,
        groups_traced: sums.traced,
        groups_skipped: sums.skipped,
        seconds: start.elapsed().as_secs_f64(),
        error: errors.mean,
        estimate: errors.estimate,
        done,
        coherence: sums.coherence,
    })
}

/// A pass's span, its range of sample indices and, when adaptive, which pixels need rays.
type PassPlan = (Span, u64, u64, Option<Vec<bool>>);

/// What the next pass traces: its span, the range of sample indices from the state's next
/// index and, when adaptive, which pixels still need rays (the previous pass's answer, when
/// it has one); or why the render stops before it.
fn plan_pass(
    opts: &FilmOptions,
    film: &Film,
    start: Instant,
    st: &mut PassState,
    lanes: usize,
) -> Result<PassPlan, StopReason> {
    let tile = opts.tile;
    let pass = st.pass;
    match opts.method {
        Method::Uniform { spp } => {
            if pass == spp {
                return Err(StopReason::Done);
            }
            let b = pass as u64 * tile.block();
            Ok((Span::for_block(tile, lanes), b, b + tile.block(), None))
        }
        Method::Adaptive {
            accuracy,
            max_samples_per_pixel,
            time_budget,
        } => {
            if pass > 0 && time_budget.is_some_and(|t| start.elapsed() >= t) {
                return Err(StopReason::TimeBudget);
            }
            // Which pixels need rays: computed once per pass (after the previous one).
            let (need, capped) = st.pending.take().unwrap_or_else(|| {
                needed(
                    film,
                    &pixel_errors(film, true).max,
                    accuracy,
                    max_samples_per_pixel,
                )
            });
            if !need.iter().any(|&n| n) {
                return Err(if capped {
                    StopReason::SampleBudget
                } else {
                    StopReason::Accuracy
                });
            }
            let span = st.levels[(pass as usize).min(st.levels.len() - 1)];
            let b = st.next_index;
            Ok((span, b, b + span.value() * lanes as u64, Some(need)))
        }
    }
}

/// Traces one pass over `tiles`, each tile a copy of `job` at its own origin. Each tile files
/// its samples into the film as soon as they are traced, into the band of its row of tiles,
/// locked while one tile files (144 samples at 1 spp). Tiles do not share pixels and a tile
/// files its samples in trace order, so each pixel's sums do not depend on the threads.
fn trace_tiles<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    film: &mut Film,
    tiles: &[(u32, u32)],
    job: &PassJob<'_>,
    cancel: Option<&AtomicBool>,
) -> Result<Vec<TileOut<T::Stats>>, FilmError> {
    let (tw, th) = job.tile;
    let bands: Vec<Mutex<FilmBand<'_>>> = film.bands(th).into_iter().map(Mutex::new).collect();
    let outs = tiles
        .par_iter()
        .with_max_len(TILES_PER_JOB)
        .map(|&(tx, ty)| {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return Err(FilmError::Cancelled);
            }
            let job = PassJob {
                origin: (tx * tw, ty * th),
                ..*job
            };
            Ok(pass_tile(backend, tracer, &job, &bands[ty as usize])?)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(outs)
}

/// A backend this CPU cannot run, as the film's error.
pub(super) fn check_backend(backend: Backend) -> Result<(), FilmError> {
    match backend.unavailable_reason() {
        None => Ok(()),
        Some(reason) => Err(FilmError::Backend(
            coherent_simd::BackendError::Unavailable {
                backend,
                reason,
                available: Backend::available()
                    .iter()
                    .map(|b| b.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            },
        )),
    }
}

/// A pass's tiles summed: rays traced, groups traced and skipped, coherence.
struct PassSums {
    rays: u64,
    traced: u64,
    skipped: u64,
    coherence: Coherence,
}

impl PassSums {
    /// Sums the tiles' outputs, adding their fix-ups and statistics to the frame's.
    fn of<S>(
        outs: Vec<TileOut<S>>,
        fixups: &mut Fixups,
        stats: &mut S,
        merge: fn(&mut S, S),
    ) -> Self {
        let mut traced = 0;
        let mut skipped = 0;
        let mut this_pass = 0;
        let mut coh = Coherence::default();
        let mut coh_sum = 0.0;
        let mut coh_n = 0u64;
        for o in outs {
            fixups.non_finite += o.fixups.non_finite;
            fixups.negative += o.fixups.negative;
            this_pass += o.rays;
            traced += o.traced;
            skipped += o.skipped;
            coh_sum += o.dist_sum;
            coh_n += o.dist_n;
            coh.max_distance = coh.max_distance.max(o.dist_max);
            coh.groups += o.multi_groups;
            merge(stats, o.stats);
        }
        coh.mean_distance = if coh_n > 0 {
            coh_sum / coh_n as f64
        } else {
            0.0
        };
        Self {
            rays: this_pass,
            traced,
            skipped,
            coherence: coh,
        }
    }
}

#[inline]
pub(super) fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Sets NaN/infinite channels to 0, and negative ones unless the tracer's samples are signed
/// ([`SampleTracer::SIGNED`]), counting the samples fixed.
#[inline]
pub(super) fn fix(mut c: [f32; 3], signed: bool, f: &mut Fixups) -> [f32; 3] {
    if c.iter().any(|v| !v.is_finite()) {
        f.non_finite += 1;
        for v in &mut c {
            if !v.is_finite() {
                *v = 0.0;
            }
        }
    }
    if !signed && c.iter().any(|&v| v < 0.0) {
        f.negative += 1;
        for v in &mut c {
            *v = v.max(0.0);
        }
    }
    c
}

/// Marks the pixels of superpixels whose corners agree within `accuracy`.
pub(super) fn mark_interpolated(film: &mut Film, accuracy: f32) {
    let sp = &film.superpixels;
    for v in 0..sp.ny {
        for u in 0..sp.nx {
            if !sp.smooth(u, v, accuracy, &film.tonemap) {
                continue;
            }
            for y in v * sp.sy..((v + 1) * sp.sy).min(film.height) {
                for x in u * sp.sx..((u + 1) * sp.sx).min(film.width) {
                    film.interpolated[(y * film.width + x) as usize] = true;
                }
            }
        }
    }
}

/// The two matrices' disagreement after a pass.
pub(super) struct PixelErrors {
    /// Per pixel, the largest channel difference of the two matrices on the display; `None`
    /// until the pixel is sampled in both. Empty unless asked for ([`pixel_errors`]).
    max: Vec<Option<f32>>,
    /// The mean of `max` over the pixels sampled in both (NaN when none is).
    pub(super) mean: f64,
    /// The estimated RMS display error of the image so far ([`PassRecord::estimate`]).
    pub(super) estimate: f64,
}

/// Each pixel's disagreement (kept per pixel only when `per_pixel`: the adaptive method's
/// choice of pixels needs it, the figures of a pass do not) and the image's error estimate:
/// rows in parallel, their sums added in row order (the same figures for any thread count).
///
/// Each matrix holds an independent estimate of about half the pixel's samples, so the
/// difference of the two has twice the variance of one and four times that of their mean:
/// half the difference estimates the error of the pixel as displayed. A pixel not sampled in
/// both says nothing about its error; it counts as the largest (1 per channel), so the
/// estimate bounds what is not known yet instead of leaving it out.
///
/// A row with no pixel sampled in both (every row of the pre-render and of a 1-spp pass) is
/// settled by a branch-free scan of its counts: going pixel by pixel, building a `None` per
/// pixel, took 2.4 ms after the pre-render and 5.5 ms after the pass of a 1024 x 768 frame
/// on one core, 8% of the frame (docs/findings/frames.md).
pub(super) fn pixel_errors(film: &Film, per_pixel: bool) -> PixelErrors {
    let w = film.width as usize;
    let [a, b] = &film.matrices;
    let rows: Vec<(Vec<Option<f32>>, f64, u64, f64)> = (0..film.height as usize)
        .into_par_iter()
        .map(|y| {
            let row = y * w..(y + 1) * w;
            let both = a.count[row.clone()]
                .iter()
                .zip(&b.count[row.clone()])
                .fold(false, |any, (&ca, &cb)| any | ((ca > 0) & (cb > 0)));
            if !both {
                // What the loop below adds for `w` pixels without a difference, exactly
                // (sums of 3 stay whole numbers far below 2^53); a loop of `w` dependent adds
                // took 1.4 ms a frame.
                let squares = 3.0 * w as f64;
                let max = if per_pixel { vec![None; w] } else { Vec::new() };
                return (max, 0.0, 0, squares);
            }
            let mut max = Vec::with_capacity(if per_pixel { w } else { 0 });
            let (mut sum, mut n, mut squares) = (0.0f64, 0u64, 0.0f64);
            for p in row {
                match film.difference(p) {
                    Some(d) => {
                        let m = d.iter().fold(0.0f32, |a, &v| a.max(v));
                        if per_pixel {
                            max.push(Some(m));
                        }
                        sum += m.min(1e6) as f64;
                        n += 1;
                        squares += d
                            .iter()
                            .map(|&v| (v.min(1.0) as f64 / 2.0).powi(2))
                            .sum::<f64>();
                    }
                    None => {
                        if per_pixel {
                            max.push(None);
                        }
                        squares += 3.0;
                    }
                }
            }
            (max, sum, n, squares)
        })
        .collect();
    let mut out = PixelErrors {
        max: Vec::with_capacity(if per_pixel { film.pixels() } else { 0 }),
        mean: 0.0,
        estimate: 0.0,
    };
    let (mut sum, mut n, mut squares) = (0.0f64, 0u64, 0.0f64);
    for (max, s, k, q) in rows {
        out.max.extend(max);
        sum += s;
        n += k;
        squares += q;
    }
    out.mean = if n == 0 { f64::NAN } else { sum / n as f64 };
    out.estimate = (squares / (3 * film.pixels().max(1)) as f64).sqrt();
    out
}

/// Which pixels need more rays, and whether any stopped at the sample cap unconverged. A
/// pixel is done when it and every neighbour of its 3x3 neighbourhood sampled in both
/// matrices have a matrix difference within `accuracy` (neighbours make edges robust: two
/// estimates of an edge pixel may agree by chance). A pixel of an interpolated superpixel is
/// no exception: its corners may agree while something smaller than the superpixel lies
/// between them (a full-size `aa` room lost most of its error there), so interpolation is
/// the first image, not a verdict. Rows in parallel; the answer does not depend on the
/// threads.
fn needed(film: &Film, errors: &[Option<f32>], accuracy: f32, cap: u32) -> (Vec<bool>, bool) {
    let w = film.width;
    let mut need = vec![false; film.pixels()];
    let capped = need
        .par_chunks_mut(w as usize)
        .enumerate()
        .map(|(y, row)| needed_row(film, errors, accuracy, cap, y as u32, row))
        .reduce(|| false, |a, b| a | b);
    (need, capped)
}

/// [`needed`] for row `y`: fills `need` (the row) and says whether a pixel of it stopped at
/// the cap.
fn needed_row(
    film: &Film,
    errors: &[Option<f32>],
    accuracy: f32,
    cap: u32,
    y: u32,
    need: &mut [bool],
) -> bool {
    let (w, h) = (film.width, film.height);
    let mut capped = false;
    for x in 0..w {
        let p = (y * w + x) as usize;
        let met = errors[p].is_some() && {
            let mut e = 0.0f32;
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    if let Some(q) = errors[(ny * w + nx) as usize] {
                        e = e.max(q);
                    }
                }
            }
            e <= accuracy
        };
        if met {
            continue;
        }
        if film.samples(p) >= cap {
            capped = true;
        } else {
            need[x as usize] = true;
        }
    }
    capped
}

/// Fraction of pixels sampled or interpolated (the `done` of pre-render and uniform passes).
pub(super) fn covered_fraction(film: &Film) -> f64 {
    // In chunks, without branches (the compiler vectorises the count).
    const CHUNK: usize = 1 << 14;
    let [a, b] = &film.matrices;
    let n: usize = film
        .interpolated
        .par_chunks(CHUNK)
        .zip(a.count.par_chunks(CHUNK))
        .zip(b.count.par_chunks(CHUNK))
        .map(|((i, ca), cb)| {
            i.iter()
                .zip(ca)
                .zip(cb)
                .map(|((&i, &ca), &cb)| (i | (ca | cb != 0)) as usize)
                .sum::<usize>()
        })
        .sum();
    n as f64 / film.pixels() as f64
}

/// One tile's share of a pass.
struct TileOut<S> {
    /// Samples whose colour was set to 0 (or clamped) on filing.
    fixups: Fixups,
    rays: u64,
    traced: u64,
    skipped: u64,
    stats: S,
    dist_sum: f64,
    dist_n: u64,
    dist_max: f64,
    multi_groups: u64,
}

/// One tile's share of a pass: which samples of the tile's Halton sequence it traces.
#[derive(Clone, Copy)]
struct PassJob<'a> {
    origin: (u32, u32),
    width: u32,
    height: u32,
    begin: u64,
    end: u64,
    span: Span,
    need: Option<&'a [bool]>,
    /// Where index `begin + j` falls in a tile, at `j`.
    places: &'a [Place],
    id_base: u64,
    /// The tile's size in pixels.
    tile: (u32, u32),
    /// The film's lines, prefetched before the tile is traced.
    lines: FilmLines,
}

/// Where a Halton index falls in any tile: the pixel in the tile, the offset inside it and
/// the pixel's sample number ([`HaltonTile::sample`], [`HaltonTile::sample_number`]).
#[derive(Clone, Copy)]
struct Place {
    px: u32,
    py: u32,
    fx: f32,
    fy: f32,
    k: u64,
}

impl Place {
    fn new(tile: HaltonTile, i: u64) -> Place {
        let (px, py, fx, fy) = tile.sample(i);
        Place {
            px,
            py,
            fx,
            fy,
            k: tile.sample_number(i),
        }
    }
}

/// Packs a tile's samples into coherent groups of `backend`'s width (sample `i` of a group
/// is Halton index `base + j + m * span` for lane `m`), traces them with
/// [`trace_packets`], and files each lane's colour under its pixel and sample number into
/// `band`, the film's rows of the tile.
fn pass_tile<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    job: &PassJob<'_>,
    band: &Mutex<FilmBand<'_>>,
) -> Result<TileOut<T::Stats>, BackendError> {
    let lanes = backend.lanes();
    let mut skipped = 0;
    let s = job.span.value();
    let chunk = s * lanes as u64;
    let chunks = (job.end - job.begin).div_ceil(chunk);
    let pixels = job.width as u64 * job.height as u64;
    // Each packet's lanes: pixel and sample number, beside the packet itself.
    let groups = (chunks * s) as usize;
    let mut packets = Vec::with_capacity(groups);
    let mut where_ = Vec::with_capacity(groups);
    let mut cur = PacketIn::default();
    let mut pix = [0u32; MAX_LANES];
    let mut knum = [0u64; MAX_LANES];
    for c in 0..chunks {
        let base = job.begin + c * chunk;
        for j in 0..s {
            // Gather the group's samples that fall on the screen.
            let mut bits = 0u32;
            let mut wanted = job.need.is_none();
            for m in 0..lanes {
                let i = base + j + m as u64 * s;
                if i >= job.end {
                    break;
                }
                let Place { px, py, fx, fy, k } = job.places[(i - job.begin) as usize];
                let (x, y) = (job.origin.0 + px, job.origin.1 + py);
                if x >= job.width || y >= job.height {
                    continue;
                }
                let p = y * job.width + x;
                cur.xs[m] = x as f32 + fx;
                cur.ys[m] = y as f32 + fy;
                cur.ids[m] = (job.id_base + k * pixels + p as u64) as u32 as i32;
                pix[m] = p;
                knum[m] = k;
                bits |= 1 << m;
                if let Some(need) = job.need {
                    wanted |= need[p as usize];
                }
            }
            if bits == 0 {
                continue;
            }
            if !wanted {
                skipped += 1;
                continue;
            }
            cur.bits = bits;
            packets.push(cur);
            where_.push((pix, knum));
        }
    }
    // The lines this tile files into, asked for now: they arrive while it is traced.
    if !packets.is_empty() {
        let (x0, y0) = job.origin;
        let x1 = (x0 + job.tile.0).min(job.width);
        let y1 = (y0 + job.tile.1).min(job.height);
        job.lines.prefetch(x0, x1, y0, y1);
    }
    let (colours, stats) = trace_packets(backend, tracer, &packets)?;
    let mut out = TileOut {
        fixups: Fixups::default(),
        rays: 0,
        traced: packets.len() as u64,
        skipped,
        stats,
        dist_sum: 0.0,
        dist_n: 0,
        dist_max: 0.0,
        multi_groups: 0,
    };
    // A panic while another tile held the lock poisons it; the band is still whole (a
    // sample is filed or not), and the panic reaches the caller through rayon anyway.
    let mut band = band.lock().unwrap_or_else(|e| e.into_inner());
    for ((p, (pix, knum)), rgb) in packets.iter().zip(&where_).zip(&colours) {
        let bits = p.bits;
        out.rays += bits.count_ones() as u64;
        let (mut cx, mut cy, mut n) = (0.0f64, 0.0f64, 0u32);
        for m in 0..lanes {
            if bits >> m & 1 == 1 {
                band.add(
                    pix[m] as usize,
                    knum[m],
                    fix(rgb[m], T::SIGNED, &mut out.fixups),
                );
                cx += p.xs[m] as f64;
                cy += p.ys[m] as f64;
                n += 1;
            }
        }
        if n >= 2 {
            // Every lane's distance, in `f32` and kept under the mask: a loop without
            // branches that the compiler vectorises (a branch and an `f64` square root per
            // lane took 2 ms of a 1024 x 768 frame).
            let (cx, cy) = ((cx / n as f64) as f32, (cy / n as f64) as f32);
            let (mut sum, mut max) = (0.0f32, 0.0f32);
            for m in 0..MAX_LANES {
                let (dx, dy) = (p.xs[m] - cx, p.ys[m] - cy);
                let d = (dx * dx + dy * dy).sqrt();
                let on = bits >> m & 1 == 1;
                sum += if on { d } else { 0.0 };
                max = if on { max.max(d) } else { max };
            }
            out.dist_sum += sum as f64;
            out.dist_n += n as u64;
            out.dist_max = out.dist_max.max(max as f64);
            out.multi_groups += 1;
        }
    }
    Ok(out)
}

/// Traces points (the pre-render) in packets, in parallel: the colour of each point, in
/// order, with the statistics. `points` is a grid of `cols` points a row, row by row (the
/// superpixel corners); a point's id is its index.
///
/// A packet takes a block of neighbouring points (4 x 4 at 16 lanes, 4 x 2 at 8, 2 x 2 at
/// 4), not a run along a row: 16 corners of one row span 128 pixels of a 1024 x 768 frame,
/// and such packets traced the pre-render's 16,641 points in 7.8 ms, as long as 90,000
/// camera samples take (docs/findings/frames.md). Each point keeps its id, so its random
/// numbers, and so its colour, do not depend on which packet traced it.
pub(super) fn trace_points<T: SampleTracer>(
    backend: Backend,
    tracer: &T,
    points: &[(f32, f32)],
    cols: usize,
) -> Result<(Vec<[f32; 3]>, T::Stats), FilmError> {
    let lanes = backend.lanes();
    let (bw, bh) = block_of(lanes);
    let cols = cols.max(1);
    let rows = points.len().div_ceil(cols);
    let mut packets = Vec::with_capacity(points.len().div_ceil(lanes) + rows + cols);
    for by in (0..rows).step_by(bh) {
        for bx in (0..cols).step_by(bw) {
            let mut p = PacketIn::default();
            let mut m = 0;
            for y in by..(by + bh).min(rows) {
                for x in bx..(bx + bw).min(cols) {
                    let i = y * cols + x;
                    if i >= points.len() {
                        continue;
                    }
                    (p.xs[m], p.ys[m]) = points[i];
                    p.ids[m] = i as i32;
                    p.bits |= 1 << m;
                    m += 1;
                }
            }
            if p.bits != 0 {
                packets.push(p);
            }
        }
    }
    let outs = packets
        .par_chunks(POINTS_PER_TASK / lanes)
        .with_max_len(TILES_PER_JOB)
        .map(|chunk| trace_packets(backend, tracer, chunk))
        .collect::<Result<Vec<_>, BackendError>>()?;
    let mut stats = T::Stats::default();
    let mut colors = vec![[0.0f32; 3]; points.len()];
    for ((colours, s), chunk) in outs
        .into_iter()
        .zip(packets.chunks(POINTS_PER_TASK / lanes))
    {
        for (p, c) in chunk.iter().zip(&colours) {
            for m in 0..lanes {
                if p.bits >> m & 1 == 1 {
                    colors[p.ids[m] as usize] = c[m];
                }
            }
        }
        T::merge_stats(&mut stats, s);
    }
    Ok((colors, stats))
}

/// The block of grid points a packet of `lanes` takes: as square as a power of two allows,
/// the wider side across.
fn block_of(lanes: usize) -> (usize, usize) {
    let bw = 1usize << lanes.trailing_zeros().div_ceil(2);
    (bw, (lanes / bw).max(1))
}
