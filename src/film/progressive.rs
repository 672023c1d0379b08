//! The progressive engine (paper section 6.2: while the image is still it "must be updated
//! iteratively and the quality has to increase"): the superpixel pre-render, then one pass
//! of coherent Halton groups per [`Progressive::step`], each leaving a displayable film.
//! [`render`](super::render) runs it to the end; an interactive viewer steps it, shows the
//! film after each pass and drops it to restart when the view changes.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use coherent_simd::Backend;

use super::matrix::Film;
use super::render::{
    PassState, check_backend, covered_fraction, fix, luminance, mark_interpolated, pixel_errors,
    run_pass, trace_points,
};
use super::superpixel::Superpixels;
use super::tracer::SampleTracer;
use super::{
    Coherence, FilmError, FilmOptions, Fixups, Method, PassRecord, PassReport, Rendered, StopReason,
};
use crate::sampler::{HaltonTile, Span};
use crate::tonemap::{Adaptation, ToneMap};

/// A render in progress: the film after the passes so far and what the next pass traces.
pub struct Progressive<'t, T: SampleTracer> {
    backend: Backend,
    tracer: &'t T,
    opts: FilmOptions,
    start: Instant,
    stats: T::Stats,
    fixups: Fixups,
    adaptation: Adaptation,
    tonemap: ToneMap,
    film: Film,
    passes: Vec<PassRecord>,
    state: PassState,
    stop: Option<StopReason>,
    cancel: Option<&'t AtomicBool>,
}

impl<'t, T: SampleTracer> Progressive<'t, T> {
    /// Checks the options and the backend, then traces the pre-render (pass 0): the
    /// superpixel corners, which fix the tone mapping and give the first image.
    pub fn new(
        backend: Backend,
        tracer: &'t T,
        opts: &FilmOptions,
    ) -> Result<Progressive<'t, T>, FilmError> {
        opts.validate()?;
        check_backend(backend)?;
        let start = Instant::now();
        let (w, h) = (opts.width, opts.height);
        let mut stats = T::Stats::default();
        let mut fixups = Fixups::default();

        let mut sp = Superpixels::new(w, h, opts.superpixel.0, opts.superpixel.1);
        let points = sp.corner_positions();
        let (colors, s) = trace_points(backend, tracer, &points, sp.nx as usize + 1)?;
        T::merge_stats(&mut stats, s);
        for (c, v) in sp.corners.iter_mut().zip(colors) {
            *c = fix(v, T::SIGNED, &mut fixups);
        }
        let adaptation = Adaptation::from_luminances(sp.corners.iter().map(|c| luminance(*c)));
        let tonemap = ToneMap::new(opts.tonemap, adaptation, opts.display);
        let rays = points.len() as u64;
        let mut film = Film::new(w, h, sp, tonemap);
        if let Method::Adaptive { accuracy, .. } = opts.method {
            mark_interpolated(&mut film, accuracy);
        }
        let errors = pixel_errors(&film, false);
        let record = PassRecord {
            pass: 0,
            span: Span { k: 0, n: 0 },
            radius: f64::NAN,
            rays,
            rays_this_pass: rays,
            groups_traced: points.len().div_ceil(backend.lanes()) as u64,
            groups_skipped: 0,
            seconds: start.elapsed().as_secs_f64(),
            error: errors.mean,
            estimate: errors.estimate,
            done: covered_fraction(&film),
            coherence: Coherence::default(),
        };
        let state = PassState::new(opts, rays);
        Ok(Progressive {
            backend,
            tracer,
            opts: opts.clone(),
            start,
            stats,
            fixups,
            adaptation,
            tonemap,
            film,
            passes: vec![record],
            state,
            stop: None,
            cancel: None,
        })
    }

    /// Makes [`step`](Self::step) give up between tiles once `cancel` is set: a viewer
    /// whose camera moved does not wait for a long pass to end.
    pub fn with_cancel(mut self, cancel: &'t AtomicBool) -> Self {
        self.cancel = Some(cancel);
        self
    }

    /// Traces the next pass and returns its record, or `None` once the render has stopped
    /// ([`stop`](Self::stop) says why). [`FilmError::Cancelled`] when the cancel flag was
    /// set during the pass: the film then holds part of a pass and the render is over.
    pub fn step(&mut self) -> Result<Option<&PassRecord>, FilmError> {
        if self.stop.is_some() {
            return Ok(None);
        }
        match run_pass(
            self.backend,
            self.tracer,
            &self.opts,
            &mut self.film,
            &mut self.state,
            self.start,
            self.cancel,
            &mut self.fixups,
            &mut self.stats,
        ) {
            Ok(record) => {
                self.passes.push(record);
                Ok(self.passes.last())
            }
            Err(Ok(stop)) => {
                self.stop = Some(stop);
                Ok(None)
            }
            Err(Err(e)) => {
                self.stop = Some(StopReason::Interrupted);
                Err(e)
            }
        }
    }

    /// Why the render stopped, once it has.
    pub fn stop(&self) -> Option<StopReason> {
        self.stop
    }

    /// The film after the passes so far.
    pub fn film(&self) -> &Film {
        &self.film
    }

    /// Every pass so far, the pre-render first.
    pub fn passes(&self) -> &[PassRecord] {
        &self.passes
    }

    /// The last pass's record and the film, as the progress callback of
    /// [`render`](super::render) sees them.
    pub fn report(&self) -> PassReport<'_> {
        PassReport {
            record: self.passes.last().expect("the pre-render's record").clone(),
            film: &self.film,
        }
    }

    /// The statistics of every pass so far.
    pub fn stats(&self) -> &T::Stats {
        &self.stats
    }

    /// The lane backend it traces with.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The tile whose Halton sequence it samples.
    pub fn tile(&self) -> HaltonTile {
        self.opts.tile
    }

    /// The render as it stands: [`StopReason::Interrupted`] when it had not stopped.
    pub fn finish(self) -> Rendered<T::Stats> {
        let rays = self.passes.last().map_or(0, |p| p.rays);
        Rendered {
            film: self.film,
            adaptation: self.adaptation,
            tonemap: self.tonemap,
            rays,
            passes: self.passes,
            stats: self.stats,
            fixups: self.fixups,
            stop: self.stop.unwrap_or(StopReason::Interrupted),
        }
    }
}
