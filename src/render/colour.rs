//! The colour a packet carries through the renderer, in one of three forms behind the same
//! kernels: RGB (the paper's, and the default: every table is rendered so), `hero` (four
//! wavelengths per ray, the first drawn per image sample and the others a quarter of the
//! range apart: Wilkie et al. 2014, as pbrt-v4 and Mitsuba 3 render) and `bins` (N fixed
//! bins over 380-780 nm, the paper's "20 to 40 intensities"), the last in two layouts: lanes
//! over rays (each lane holds its ray's N values, one register per bin) or lanes over
//! wavelengths (one ray's N values across the lanes, N / lanes registers per ray).
//!
//! The scene stays RGB: colour enters a path as RGB (a material's shading, a light's sample,
//! the background) and a spectral form upsamples it where it enters (Jakob and Hanika's
//! sigmoid model, `crate::spectrum::upsample`): reflectances and weights as spectra of any
//! magnitude (`upsample::emitter`'s shape and scale), radiances the same times the display's
//! white (D65). A light that names its spectrum (`spectrum` or `temperature` in a scene
//! file) emits that spectrum at its sample's luminance instead, and so does a light of one
//! colour throughout, its colour upsampled once before rendering. The film stays RGB: each
//! sample's spectrum is integrated against the CIE 1931 observer to XYZ, then to linear sRGB.
//!
//! Dispersion is where spectra differ from RGB: a dispersive glass bends each wavelength its
//! own way, so a ray that refracts through one keeps a single wavelength from there on (hero:
//! its hero wavelength, as pbrt-v4 terminates the secondary ones; bins: one bin drawn per
//! lane), its weight scaled by the number of wavelengths it dropped to stay unbiased.

use coherent_simd::scalar::Scalar;
use coherent_simd::{Backend, Lanes, MAX_LANES, Rgbs, SimdF32, SimdI32, SimdMask};
use smallvec::SmallVec;

use crate::scene::RenderScene;
use crate::spectrum::dispersion::{Dispersion, LAMBDA_D};
use crate::spectrum::illuminant::{Emission, EmissionTable, white};
use crate::spectrum::sampling::{Bins, HERO, hero_lanes, hero_xyz};
use crate::spectrum::upsample::{Sigmoid, emitter, emitter_lanes};
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN, SpectrumError, cie};

/// The backends the spectral colour forms are compiled for: scalar, and with the
/// `spectral-simd` feature every hand-written backend, one per width (sse, avx2, avx512).
/// Each backend is a second copy of the renderer; all four made the build more than half
/// again as long, past what the tests' machines afford (docs/architecture.md, "The
/// renderer's colour forms"), so the SIMD widths are the research build's option:
/// `scripts/reproduce.sh` turns it on for its full run.
pub const SPECTRAL_BACKENDS: u32 = if cfg!(feature = "spectral-simd") {
    Backend::HAND_WRITTEN_BITS
} else {
    Backend::Scalar.bit()
};

/// [`SPECTRAL_BACKENDS`] as backends, narrowest first.
pub fn spectral_backends() -> impl Iterator<Item = Backend> {
    Backend::hand_written().filter(|b| SPECTRAL_BACKENDS & b.bit() != 0)
}

/// Why `backend` cannot render the spectral form `form` in this build, if it cannot.
pub fn spectral_refusal(form: &ColourForm, backend: Backend) -> Option<String> {
    if SPECTRAL_BACKENDS & backend.bit() != 0 {
        return None;
    }
    let names: Vec<&str> = spectral_backends().map(|b| b.name()).collect();
    let hint = if cfg!(feature = "spectral-simd") {
        ""
    } else {
        "; build with `--features spectral-simd` for sse, avx2 and avx512"
    };
    Some(format!(
        "spectral colour ({}) renders on {} in this build, not on {}{hint}",
        form.label(),
        names.join(", "),
        backend.name()
    ))
}

/// Where a spectral packet's lanes go when each ray carries N values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layout {
    /// Each lane is a ray with all of its values: one register per wavelength.
    Rays,
    /// One ray's values across the lanes: `N / lanes` registers per ray.
    Wavelengths,
}

impl Layout {
    /// Both, in the order reports list them.
    pub const ALL: [Layout; 2] = [Layout::Rays, Layout::Wavelengths];

    /// The name on the command line and in results.
    pub fn name(self) -> &'static str {
        match self {
            Layout::Rays => "rays",
            Layout::Wavelengths => "wavelengths",
        }
    }
}

impl std::str::FromStr for Layout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Layout::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| format!("unknown layout \"{s}\" (known: rays, wavelengths)"))
    }
}

/// The colour forms by name, as `--colour` takes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ColourKind {
    Rgb,
    Hero,
    Bins,
}

impl ColourKind {
    /// Every form, in the order reports list them.
    pub const ALL: [ColourKind; 3] = [ColourKind::Rgb, ColourKind::Hero, ColourKind::Bins];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ColourKind::Rgb => "rgb",
            ColourKind::Hero => "hero",
            ColourKind::Bins => "bins",
        }
    }
}

impl std::str::FromStr for ColourKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        ColourKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown colour \"{s}\" (known: rgb, hero, bins)"))
    }
}

impl std::fmt::Display for ColourKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::fmt::Display for Layout {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How the renderer carries colour.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ColourForm {
    /// Three channels, linear sRGB (the paper's).
    #[default]
    Rgb,
    /// Four wavelengths per ray, the hero drawn per image sample.
    Hero,
    /// `bins` bins of equal width over `range` (nm; 380-780 from the command line).
    Bins {
        bins: u32,
        layout: Layout,
        range: [f32; 2],
    },
}

impl ColourForm {
    /// The bins used when `--bins` is not given.
    pub const DEFAULT_BINS: u32 = 32;

    /// `bins` bins over the whole visible range; [`SpectrumError::BadBins`] outside 1-1024.
    pub fn bins(bins: u32, layout: Layout) -> Result<Self, SpectrumError> {
        Bins::new(bins)?;
        Ok(ColourForm::Bins {
            bins,
            layout,
            range: [LAMBDA_MIN, LAMBDA_MAX],
        })
    }

    /// The form the command line's `--colour`, `--bins` and `--layout` name: `bins` and
    /// `layout` only with `bins` (32 bins over rays unless given).
    pub fn from_flags(
        kind: ColourKind,
        bins: Option<u32>,
        layout: Option<Layout>,
    ) -> Result<Self, String> {
        if kind != ColourKind::Bins {
            if let Some(n) = bins {
                return Err(format!(
                    "--bins {n} sets the spectral bins: it needs --colour bins (not {kind})"
                ));
            }
            if let Some(l) = layout {
                return Err(format!(
                    "--layout {l} lays out the spectral bins: it needs --colour bins (not {kind})"
                ));
            }
        }
        Ok(match kind {
            ColourKind::Rgb => ColourForm::Rgb,
            ColourKind::Hero => ColourForm::Hero,
            ColourKind::Bins => {
                let n = bins.unwrap_or(Self::DEFAULT_BINS);
                ColourForm::bins(n, layout.unwrap_or(Layout::Rays))
                    .map_err(|e| format!("--bins {n}: {e}"))?
            }
        })
    }

    /// The form's name in results: `rgb`, `hero`, `bins32-rays`, ...
    pub fn label(&self) -> String {
        match self {
            ColourForm::Rgb => "rgb".to_string(),
            ColourForm::Hero => "hero".to_string(),
            ColourForm::Bins { bins, layout, .. } => format!("bins{bins}-{}", layout.name()),
        }
    }

    /// Values per ray: 3, 4 or the bins.
    pub fn channels(&self) -> u32 {
        match self {
            ColourForm::Rgb => 3,
            ColourForm::Hero => HERO as u32,
            ColourForm::Bins { bins, .. } => *bins,
        }
    }

    /// Whether the form is spectral.
    pub fn is_spectral(&self) -> bool {
        !matches!(self, ColourForm::Rgb)
    }
}

/// A light's emission spectrum, at a luminance of 1.
#[derive(Debug, Clone)]
struct LightSpectrum {
    /// Its value at a wavelength (hero).
    shape: LightShape,
    /// Per bin (bins only; padded with zeros).
    bins: Vec<f32>,
}

/// What a light's spectrum is made of.
#[derive(Debug, Clone)]
enum LightShape {
    /// The spectrum the light names (boxed: a 1 nm table, against the other's 16 bytes).
    Named(Box<EmissionTable>),
    /// The light's RGB colour upsampled once, before rendering: `factor · shape(λ) ·
    /// white(λ)`. Every sample of the light is that colour times a number, so the
    /// upsampling of each sample's radiance comes to this times the sample's luminance.
    Rgb { shape: Sigmoid, factor: f32 },
}

/// What a spectral form needs besides its values: the bins' wavelengths and observer
/// weights, the display's white and each light's spectrum per bin, each material's
/// dispersion.
#[derive(Debug, Clone)]
pub struct Spectra {
    form: ColourForm,
    /// Values per ray.
    n: usize,
    /// Bins: their centres, padded to a multiple of [`MAX_LANES`] with the last centre.
    centres: Vec<f32>,
    /// Bins: the observer integrated over each bin (x̄, ȳ, z̄), padded with zeros.
    weights: [Vec<f32>; 3],
    /// Bins: the display's white averaged over each bin, padded with zeros.
    white: Vec<f32>,
    /// Per scene light: its spectrum, when it names one or its colour is one throughout.
    lights: Vec<Option<LightSpectrum>>,
    /// Per material: its index when it disperses (lane table `dispersive`: 1 when it does).
    dispersion: Vec<Option<Dispersion>>,
    dispersive: Vec<u32>,
    /// Whether any material disperses.
    disperses: bool,
}

/// A colour form the renderer cannot use with its other settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColourError {
    #[error(transparent)]
    Spectrum(#[from] SpectrumError),
    #[error(
        "spectral colour ({form}) does not regroup packets: it runs with the paper's packets (leave out --regroup)"
    )]
    Regroup { form: String },
}

impl Spectra {
    /// The tables of `form` (spectral) for `scene`; `None` for RGB.
    pub fn new(form: ColourForm, scene: &RenderScene) -> Result<Option<Spectra>, SpectrumError> {
        let colours: Vec<Option<[f32; 3]>> = scene.lights.iter().map(|l| l.colour()).collect();
        Self::with(form, &scene.light_spectra, &colours, &scene.materials)
    }

    /// The tables of `form` with no light spectra and no dispersion (the kernels' timings).
    pub fn plain(form: ColourForm) -> Result<Option<Spectra>, SpectrumError> {
        Self::with(form, &[], &[], &[])
    }

    fn with(
        form: ColourForm,
        light_spectra: &[Option<Emission>],
        light_colours: &[Option<[f32; 3]>],
        materials: &[crate::material::Material],
    ) -> Result<Option<Spectra>, SpectrumError> {
        let bins = match form {
            ColourForm::Rgb => return Ok(None),
            ColourForm::Hero => None,
            ColourForm::Bins { bins, range, .. } => Some(Bins::over(bins, range)?),
        };
        let padded = |mut v: Vec<f32>, fill: f32| {
            v.resize(v.len().div_ceil(MAX_LANES) * MAX_LANES, fill);
            v
        };
        let (n, centres, weights, white_bins) = match &bins {
            None => (
                HERO,
                Vec::new(),
                [Vec::new(), Vec::new(), Vec::new()],
                Vec::new(),
            ),
            Some(b) => {
                let last = *b.centres().last().expect("at least one bin");
                let w = |c: usize| padded(b.weights().iter().map(|w| w[c]).collect(), 0.0);
                (
                    b.len(),
                    padded(b.centres().to_vec(), last),
                    [w(0), w(1), w(2)],
                    padded(b.tabulate(|l| white().eval(l)), 0.0),
                )
            }
        };
        let named = |e: Emission| {
            let table = e.table();
            let bins = bins
                .as_ref()
                .map_or_else(Vec::new, |b| padded(b.tabulate(|l| table.eval(l)), 0.0));
            LightSpectrum {
                shape: LightShape::Named(Box::new(table)),
                bins,
            }
        };
        let upsampled = |c: [f32; 3]| {
            // The luminance a sample's radiance is divided by, in the same arithmetic.
            let y = Rgbs::splat(Scalar, c).luminance();
            if !(y > 0.0 && y.is_finite()) {
                return None;
            }
            let e = emitter(c);
            let (shape, factor) = (e.shape(), e.scale() / y);
            let bins = bins.as_ref().map_or_else(Vec::new, |b| {
                let v = b.centres().iter().zip(&white_bins);
                padded(v.map(|(&l, w)| shape.eval(l) * factor * w).collect(), 0.0)
            });
            Some(LightSpectrum {
                shape: LightShape::Rgb { shape, factor },
                bins,
            })
        };
        let lights = (0..light_spectra.len().max(light_colours.len()))
            .map(|k| match light_spectra.get(k).copied().flatten() {
                Some(e) => Some(named(e)),
                None => light_colours.get(k).copied().flatten().and_then(upsampled),
            })
            .collect();
        let dispersion: Vec<Option<Dispersion>> = materials
            .iter()
            .map(|m| {
                m.optics
                    .dispersion
                    .filter(|d| !matches!(d, Dispersion::Constant(_)))
            })
            .collect();
        let dispersive = dispersion.iter().map(|d| u32::from(d.is_some())).collect();
        let disperses = dispersion.iter().any(Option::is_some);
        Ok(Some(Spectra {
            form,
            n,
            centres,
            weights,
            white: white_bins,
            lights,
            dispersion,
            dispersive,
            disperses,
        }))
    }

    /// The form these tables are for.
    pub fn form(&self) -> ColourForm {
        self.form
    }

    /// Whether any material disperses.
    pub fn disperses(&self) -> bool {
        self.disperses
    }

    fn layout(&self) -> Option<Layout> {
        match self.form {
            ColourForm::Bins { layout, .. } => Some(layout),
            _ => None,
        }
    }

    /// Registers per packet of `lanes`: 4 (hero), N (bins over rays) or `lanes` times the
    /// registers of one ray's N values (bins over wavelengths).
    fn registers(&self, lanes: usize) -> usize {
        match self.layout() {
            Some(Layout::Wavelengths) => lanes * self.n.div_ceil(lanes),
            _ => self.n,
        }
    }
}

/// The colour of a packet's lanes, as the renderer carries it. Every operation a path does
/// with colour, so that the kernels are written once: [`Rgbs`] does what the RGB renderer
/// always did, with the same arithmetic in the same order, and [`Spectral`] the spectral
/// forms.
pub trait Colour<L: Lanes>: Clone {
    /// What the form needs besides its values (nothing for RGB).
    type Tables: Sync;
    /// A packet's wavelengths (the hero's; nothing for RGB and bins).
    type Waves: Copy;
    /// Whether this is a spectral form.
    const SPECTRAL: bool;

    /// The wavelengths of the samples `ids`.
    fn waves(l: L, t: &Self::Tables, ids: L::I32s) -> Self::Waves;
    /// One in every lane and channel.
    fn one(l: L, t: &Self::Tables) -> Self;
    /// Zero in every lane and channel.
    fn zero(l: L, t: &Self::Tables) -> Self;
    /// The radiance `e` (RGB: the background, the environment, the ambient term) in the
    /// lanes of `mask`, zero elsewhere.
    fn emitted(l: L, t: &Self::Tables, w: &Self::Waves, mask: L::Mask, e: Rgbs<L>) -> Self;
    /// `self += a ⊙ e` in the lanes of `mask`, with `e` a radiance as in [`Colour::emitted`].
    #[allow(clippy::too_many_arguments)]
    fn add_emitted(
        &mut self,
        l: L,
        t: &Self::Tables,
        w: &Self::Waves,
        mask: L::Mask,
        a: &Self,
        e: Rgbs<L>,
    );
    /// `self += f ⊙ li` in the lanes of `mask`: `f` a reflectance or BDF times cosine, `li`
    /// what light `light` of the scene gives (`None`: irradiance from a map).
    #[allow(clippy::too_many_arguments)]
    fn add_reflected(
        &mut self,
        l: L,
        t: &Self::Tables,
        w: &Self::Waves,
        mask: L::Mask,
        f: Rgbs<L>,
        li: Rgbs<L>,
        light: Option<usize>,
    );
    /// `self += a ⊙ b`.
    fn add_product(&mut self, a: &Self, b: &Self);
    /// `self ⊙ f`, `f` a weight as in [`Colour::add_reflected`].
    fn times(&self, l: L, t: &Self::Tables, w: &Self::Waves, f: Rgbs<L>) -> Self;
    /// `self * s` per lane.
    fn scale(&mut self, l: L, t: &Self::Tables, s: L::F32s);
    /// Per lane, the largest channel.
    fn max_channel(&self, l: L, t: &Self::Tables) -> L::F32s;
    /// Per lane, the linear sRGB the film receives.
    fn to_rgb(&self, l: L, t: &Self::Tables, w: &Self::Waves) -> Rgbs<L>;
    /// The index of refraction per lane of the lanes of `on` as they refract into materials
    /// `material`: `ior` for RGB and for constant indices; for dispersive ones, the index at
    /// the lane's single wavelength, which lanes that still carry all of theirs (`wave < 0`)
    /// choose now (`u` picks a bin), keeping that one alone from here on.
    #[allow(clippy::too_many_arguments)]
    fn disperse(
        &mut self,
        l: L,
        t: &Self::Tables,
        w: &Self::Waves,
        on: L::Mask,
        material: L::I32s,
        ior: L::F32s,
        wave: &mut L::I32s,
        u: L::F32s,
    ) -> L::F32s;
    /// The three channels of an RGB colour (packets are regrouped in RGB only).
    fn rgb_fields(&self) -> [L::F32s; 3];
    /// The colour of three channels from [`Colour::rgb_fields`].
    fn from_rgb_fields(v: [L::F32s; 3]) -> Self;
}

impl<L: Lanes> Colour<L> for Rgbs<L> {
    type Tables = ();
    type Waves = ();
    const SPECTRAL: bool = false;

    #[inline(always)]
    fn waves(_: L, _: &(), _: L::I32s) {}
    #[inline(always)]
    fn one(l: L, _: &()) -> Self {
        Rgbs::splat(l, [1.0; 3])
    }
    #[inline(always)]
    fn zero(l: L, _: &()) -> Self {
        Rgbs::zero(l)
    }
    #[inline(always)]
    fn emitted(l: L, _: &(), _: &(), mask: L::Mask, e: Rgbs<L>) -> Self {
        Rgbs::select(mask, e, Rgbs::zero(l))
    }
    #[inline(always)]
    fn add_emitted(&mut self, l: L, _: &(), _: &(), mask: L::Mask, a: &Self, e: Rgbs<L>) {
        *self += Rgbs::select(mask, *a * e, Rgbs::zero(l));
    }
    #[inline(always)]
    fn add_reflected(
        &mut self,
        l: L,
        _: &(),
        _: &(),
        mask: L::Mask,
        f: Rgbs<L>,
        li: Rgbs<L>,
        _: Option<usize>,
    ) {
        *self += Rgbs::select(mask, f * li, Rgbs::zero(l));
    }
    #[inline(always)]
    fn add_product(&mut self, a: &Self, b: &Self) {
        *self += *a * *b;
    }
    #[inline(always)]
    fn times(&self, _: L, _: &(), _: &(), f: Rgbs<L>) -> Self {
        *self * f
    }
    #[inline(always)]
    fn scale(&mut self, _: L, _: &(), s: L::F32s) {
        *self = Rgbs::scale(*self, s);
    }
    #[inline(always)]
    fn max_channel(&self, _: L, _: &()) -> L::F32s {
        self.r.max(self.g).max(self.b)
    }
    #[inline(always)]
    fn to_rgb(&self, _: L, _: &(), _: &()) -> Rgbs<L> {
        *self
    }
    #[inline(always)]
    fn disperse(
        &mut self,
        _: L,
        _: &(),
        _: &(),
        _: L::Mask,
        _: L::I32s,
        ior: L::F32s,
        _: &mut L::I32s,
        _: L::F32s,
    ) -> L::F32s {
        ior
    }
    #[inline(always)]
    fn rgb_fields(&self) -> [L::F32s; 3] {
        [self.r, self.g, self.b]
    }
    #[inline(always)]
    fn from_rgb_fields(v: [L::F32s; 3]) -> Self {
        Rgbs::new(v[0], v[1], v[2])
    }
}

/// A spectral colour per lane: its registers in the form's layout (hero: one per hero
/// wavelength; bins over rays: one per bin; bins over wavelengths: each lane's bins, a
/// register of `L::N` bins at a time, lane after lane).
pub struct Spectral<L: Lanes> {
    v: SmallVec<[L::F32s; HERO]>,
}

impl<L: Lanes> Clone for Spectral<L> {
    #[inline(always)]
    fn clone(&self) -> Self {
        Spectral { v: self.v.clone() }
    }
}

/// Per lane, an RGB value upsampled: `scale · s(c0 λ² + c1 λ + c2)`, as registers (lanes over
/// rays) and per lane (lanes over wavelengths).
struct Upsampled<L: Lanes> {
    p: [L::F32s; 4],
    per_lane: [[f32; MAX_LANES]; 4],
}

impl<L: Lanes> Upsampled<L> {
    /// The lanes of `mask` of `rgb` (the rest zero), through `upsample::emitter_lanes`: any
    /// magnitude, a grey exactly constant.
    #[inline(always)]
    fn of(l: L, rgb: &Rgbs<L>, mask: L::Mask) -> Self {
        let p = emitter_lanes(l, [rgb.r, rgb.g, rgb.b], mask);
        let mut per_lane = [[0.0f32; MAX_LANES]; 4];
        // An index loop, not an iterator adaptor, which may stay out of line (outside the
        // backend's `#[target_feature]` function).
        #[allow(clippy::needless_range_loop)]
        for k in 0..4 {
            p[k].store(&mut per_lane[k]);
        }
        Upsampled { p, per_lane }
    }

    /// The coefficients and scale as registers (lanes over rays).
    #[inline(always)]
    fn lanes(&self) -> [L::F32s; 4] {
        self.p
    }

    /// Lane `m`'s coefficients and scale in every lane (lanes over wavelengths).
    #[inline(always)]
    fn lane(&self, l: L, m: usize) -> [L::F32s; 4] {
        [
            l.splat(self.per_lane[0][m]),
            l.splat(self.per_lane[1][m]),
            l.splat(self.per_lane[2][m]),
            l.splat(self.per_lane[3][m]),
        ]
    }
}

/// `scale · s(c0 λ² + c1 λ + c2)` with [`crate::spectrum::upsample::Sigmoid::eval_lanes`]'s
/// operations (no fused multiply-adds: the same bits in both layouts and on every backend).
#[inline(always)]
fn sigmoid<L: Lanes>(l: L, p: &[L::F32s; 4], lambda: L::F32s) -> L::F32s {
    let x = (lambda * p[0] + p[1]) * lambda + p[2];
    let y = l.splat(1.0) / (x * x + 1.0).sqrt();
    (x * 0.5 * y + 0.5) * p[3]
}

impl<L: Lanes> Spectral<L> {
    #[inline(always)]
    fn filled(l: L, t: &Spectra, v: f32) -> Self {
        let mut out = SmallVec::new();
        out.resize(t.registers(L::N), l.splat(v));
        Spectral { v: out }
    }

    /// For each register of `self` in the lanes of `mask`: `f(register index, lane or
    /// None, λ, white(λ))` gives the values to combine, `op` combines them. Lanes over
    /// rays (and hero) visit registers with the lanes' own coefficients; lanes over
    /// wavelengths visit lane by lane with `lane = Some(m)`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn each(
        &mut self,
        l: L,
        t: &Spectra,
        w: &[L::F32s; HERO],
        mask: L::Mask,
        with_white: bool,
        mut f: impl FnMut(usize, Option<usize>, L::F32s, L::F32s) -> L::F32s,
        add: bool,
    ) {
        let zero = l.splat(0.0);
        match t.layout() {
            None => {
                // Index loops, not iterator adaptors: those may stay out of line, outside the
                // backend's `#[target_feature]` function, where every vector operation is a call.
                #[allow(clippy::needless_range_loop)]
                for j in 0..HERO {
                    let lambda = w[j];
                    let white = if with_white {
                        white().eval_lanes(l, lambda)
                    } else {
                        zero
                    };
                    let v = mask.select(f(j, None, lambda, white), zero);
                    self.v[j] = if add { self.v[j] + v } else { v };
                }
            }
            Some(Layout::Rays) => {
                for i in 0..t.n {
                    let v =
                        mask.select(f(i, None, l.splat(t.centres[i]), l.splat(t.white[i])), zero);
                    self.v[i] = if add { self.v[i] + v } else { v };
                }
            }
            Some(Layout::Wavelengths) => {
                let per = t.n.div_ceil(L::N);
                let bits = mask.bitmask();
                for m in 0..L::N {
                    let on = bits >> m & 1 != 0;
                    for k in 0..per {
                        let r = m * per + k;
                        let v = if on {
                            let at = k * L::N;
                            f(
                                k,
                                Some(m),
                                l.load(&t.centres[at..at + L::N]),
                                l.load(&t.white[at..at + L::N]),
                            )
                        } else {
                            zero
                        };
                        self.v[r] = if add { self.v[r] + v } else { v };
                    }
                }
            }
        }
    }

    /// A light's spectrum per register (`i`: the hero channel, the bin, or the register of
    /// bins for lanes over wavelengths; `white`: the display's white at `lambda`, for hero).
    #[inline(always)]
    fn light_values(
        l: L,
        t: &Spectra,
        s: &LightSpectrum,
        i: usize,
        lane: Option<usize>,
        lambda: L::F32s,
        white: L::F32s,
    ) -> L::F32s {
        match (t.layout(), lane) {
            (None, _) => match &s.shape {
                LightShape::Named(table) => table.eval_lanes(l, lambda),
                LightShape::Rgb { shape, factor } => shape.eval_lanes(l, lambda) * *factor * white,
            },
            (Some(Layout::Rays), _) => l.splat(s.bins[i]),
            (_, _) => l.load(&s.bins[i * L::N..(i + 1) * L::N]),
        }
    }
}

// The operations that upsample or integrate run out of the kernel, each a function of its own
// per backend (`Lanes::apart`): inlined, they made the renderer's kernel too large to compile
// in reasonable time.
impl<L: Lanes> Colour<L> for Spectral<L> {
    type Tables = Spectra;
    type Waves = [L::F32s; HERO];
    const SPECTRAL: bool = true;

    #[inline(always)]
    fn waves(l: L, t: &Spectra, ids: L::I32s) -> [L::F32s; HERO] {
        match t.form {
            ColourForm::Hero => hero_lanes(l, super::rng::uniform(l, ids, HERO_STREAM)),
            _ => [l.splat(0.0); HERO],
        }
    }
    #[inline(always)]
    fn one(l: L, t: &Spectra) -> Self {
        Self::filled(l, t, 1.0)
    }
    #[inline(always)]
    fn zero(l: L, t: &Spectra) -> Self {
        Self::filled(l, t, 0.0)
    }
    #[inline(always)]
    fn emitted(l: L, t: &Spectra, w: &Self::Waves, mask: L::Mask, e: Rgbs<L>) -> Self {
        l.apart(
            #[inline(always)]
            move |l| {
                let mut out = Self::zero(l, t);
                if mask.any() {
                    let up = Upsampled::of(l, &e, mask);
                    let p = up.lanes();
                    out.each(
                        l,
                        t,
                        w,
                        mask,
                        true,
                        #[inline(always)]
                        |_, lane, lambda, white| {
                            let p = match lane {
                                None => p,
                                Some(m) => up.lane(l, m),
                            };
                            sigmoid(l, &p, lambda) * white
                        },
                        false,
                    );
                }
                out
            },
        )
    }
    #[inline(always)]
    fn add_emitted(
        &mut self,
        l: L,
        t: &Spectra,
        w: &Self::Waves,
        mask: L::Mask,
        a: &Self,
        e: Rgbs<L>,
    ) {
        l.apart(
            #[inline(always)]
            move |l| {
                if mask.none() {
                    return;
                }
                let s = Self::emitted(l, t, w, mask, e);
                for i in 0..s.v.len() {
                    self.v[i] += s.v[i] * a.v[i];
                }
            },
        )
    }
    #[inline(always)]
    fn add_reflected(
        &mut self,
        l: L,
        t: &Spectra,
        w: &Self::Waves,
        mask: L::Mask,
        f: Rgbs<L>,
        li: Rgbs<L>,
        light: Option<usize>,
    ) {
        l.apart(
            #[inline(always)]
            move |l| {
                if mask.none() {
                    return;
                }
                let uf = Upsampled::of(l, &f, mask);
                let pf = uf.lanes();
                match light.and_then(|k| t.lights.get(k)).and_then(Option::as_ref) {
                    Some(s) => {
                        // The light's spectrum at the sample's luminance.
                        let lum = li.luminance();
                        let mut lums = [0.0f32; MAX_LANES];
                        lum.store(&mut lums);
                        let with_white = matches!(s.shape, LightShape::Rgb { .. });
                        self.each(
                            l,
                            t,
                            w,
                            mask,
                            with_white,
                            #[inline(always)]
                            |i, lane, lambda, white| {
                                let (p, y) = match lane {
                                    None => (pf, lum),
                                    Some(m) => (uf.lane(l, m), l.splat(lums[m])),
                                };
                                sigmoid(l, &p, lambda)
                                    * Self::light_values(l, t, s, i, lane, lambda, white)
                                    * y
                            },
                            true,
                        );
                    }
                    None => {
                        let ul = Upsampled::of(l, &li, mask);
                        let pl = ul.lanes();
                        self.each(
                            l,
                            t,
                            w,
                            mask,
                            true,
                            #[inline(always)]
                            |_, lane, lambda, white| {
                                let (p, q) = match lane {
                                    None => (pf, pl),
                                    Some(m) => (uf.lane(l, m), ul.lane(l, m)),
                                };
                                sigmoid(l, &p, lambda) * (sigmoid(l, &q, lambda) * white)
                            },
                            true,
                        );
                    }
                }
            },
        )
    }
    #[inline(always)]
    fn add_product(&mut self, a: &Self, b: &Self) {
        for i in 0..self.v.len() {
            self.v[i] += a.v[i] * b.v[i];
        }
    }
    #[inline(always)]
    fn times(&self, l: L, t: &Spectra, w: &Self::Waves, f: Rgbs<L>) -> Self {
        l.apart(
            #[inline(always)]
            move |l| {
                let mut out = self.clone();
                let uf = Upsampled::of(l, &f, l.splat_mask(true));
                let pf = uf.lanes();
                let mut k = Self::zero(l, t);
                k.each(
                    l,
                    t,
                    w,
                    l.splat_mask(true),
                    false,
                    #[inline(always)]
                    |_, lane, lambda, _| {
                        let p = match lane {
                            None => pf,
                            Some(m) => uf.lane(l, m),
                        };
                        sigmoid(l, &p, lambda)
                    },
                    false,
                );
                for i in 0..out.v.len() {
                    out.v[i] *= k.v[i];
                }
                out
            },
        )
    }
    #[inline(always)]
    fn scale(&mut self, l: L, t: &Spectra, s: L::F32s) {
        if t.layout() == Some(Layout::Wavelengths) {
            let per = t.n.div_ceil(L::N);
            for m in 0..L::N {
                let sm = l.splat(s.lane(m));
                for r in m * per..(m + 1) * per {
                    self.v[r] *= sm;
                }
            }
        } else {
            for i in 0..self.v.len() {
                self.v[i] *= s;
            }
        }
    }
    #[inline(always)]
    fn max_channel(&self, l: L, t: &Spectra) -> L::F32s {
        if t.layout() == Some(Layout::Wavelengths) {
            let per = t.n.div_ceil(L::N);
            // Loops, not a closure and iterator adaptors: those stay out of line, outside the
            // backend's `#[target_feature]` function.
            let mut most = [f32::NEG_INFINITY; MAX_LANES];
            for (m, o) in most.iter_mut().enumerate().take(L::N) {
                for x in &self.v[m * per..(m + 1) * per] {
                    *o = o.max(x.reduce_max());
                }
            }
            l.load(&most)
        } else {
            let mut m = self.v[0];
            for x in &self.v[1..] {
                m = m.max(*x);
            }
            m
        }
    }
    #[inline(always)]
    fn to_rgb(&self, l: L, t: &Spectra, w: &Self::Waves) -> Rgbs<L> {
        l.apart(
            #[inline(always)]
            move |l| {
                let mut xyz = [[0.0f32; MAX_LANES]; 3];
                match t.layout() {
                    None => {
                        let mut vals = [[0.0f32; MAX_LANES]; HERO];
                        let mut lams = [[0.0f32; MAX_LANES]; HERO];
                        for j in 0..HERO {
                            self.v[j].store(&mut vals[j]);
                            w[j].store(&mut lams[j]);
                        }
                        for m in 0..L::N {
                            let c = hero_xyz(
                                std::array::from_fn(|j| lams[j][m]),
                                std::array::from_fn(|j| vals[j][m]),
                            );
                            for k in 0..3 {
                                xyz[k][m] = c[k];
                            }
                        }
                    }
                    Some(Layout::Rays) => {
                        for (k, out) in xyz.iter_mut().enumerate() {
                            let mut acc = l.splat(0.0);
                            for i in 0..t.n {
                                acc += self.v[i] * t.weights[k][i];
                            }
                            acc.store(out);
                        }
                    }
                    Some(Layout::Wavelengths) => {
                        let per = t.n.div_ceil(L::N);
                        for (k, out) in xyz.iter_mut().enumerate() {
                            for (m, o) in out.iter_mut().enumerate().take(L::N) {
                                let mut acc = l.splat(0.0);
                                for c in 0..per {
                                    let at = c * L::N;
                                    acc +=
                                        self.v[m * per + c] * l.load(&t.weights[k][at..at + L::N]);
                                }
                                let mut s = [0.0f32; MAX_LANES];
                                acc.store(&mut s);
                                *o = s[..L::N].iter().sum();
                            }
                        }
                    }
                }
                let mut rgb = [[0.0f32; MAX_LANES]; 3];
                for m in 0..L::N {
                    let c = cie::xyz_to_rgb([xyz[0][m], xyz[1][m], xyz[2][m]]);
                    for k in 0..3 {
                        rgb[k][m] = c[k];
                    }
                }
                Rgbs::new(l.load(&rgb[0]), l.load(&rgb[1]), l.load(&rgb[2]))
            },
        )
    }
    #[inline(always)]
    fn disperse(
        &mut self,
        l: L,
        t: &Spectra,
        w: &Self::Waves,
        on: L::Mask,
        material: L::I32s,
        ior: L::F32s,
        wave: &mut L::I32s,
        u: L::F32s,
    ) -> L::F32s {
        l.apart(
            #[inline(always)]
            move |l| {
                if !t.disperses {
                    return ior;
                }
                let disp = on & l.gather_u32(&t.dispersive, material).eq(l.splat_i32(1));
                if disp.none() {
                    return ior;
                }
                let mut waves = [0i32; MAX_LANES];
                wave.store(&mut waves);
                let mut mats = [0i32; MAX_LANES];
                material.store(&mut mats);
                let mut us = [0.0f32; MAX_LANES];
                u.store(&mut us);
                let mut lams = [[0.0f32; MAX_LANES]; HERO];
                for (j, x) in w.iter().enumerate() {
                    x.store(&mut lams[j]);
                }
                let mut iors = [0.0f32; MAX_LANES];
                ior.store(&mut iors);
                // Per register, which lanes keep their values and by what factor.
                let per = t.n.div_ceil(L::N);
                let mut factors: SmallVec<[[f32; MAX_LANES]; HERO]> =
                    SmallVec::from_elem([1.0f32; MAX_LANES], self.v.len());
                let mut bits = disp.bitmask();
                while bits != 0 {
                    let m = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let fresh = waves[m] < 0;
                    if fresh {
                        waves[m] = match t.form {
                            ColourForm::Hero => 0,
                            _ => ((us[m] * t.n as f32) as usize).min(t.n - 1) as i32,
                        };
                    }
                    let c = waves[m] as usize;
                    let lambda = match t.form {
                        ColourForm::Hero => lams[0][m],
                        _ => t.centres[c],
                    };
                    let d = t.dispersion[mats[m] as usize].expect("a dispersive material");
                    iors[m] = d.index(lambda);
                    if fresh {
                        // Keep channel `c` of lane `m` alone, weighted by the channels dropped.
                        let gain = t.n as f32;
                        match t.layout() {
                            None | Some(Layout::Rays) => {
                                for (r, f) in factors.iter_mut().enumerate() {
                                    f[m] = if r == c { gain } else { 0.0 };
                                }
                            }
                            Some(Layout::Wavelengths) => {
                                for k in 0..per {
                                    let f = &mut factors[m * per + k];
                                    for (b, x) in f.iter_mut().enumerate().take(L::N) {
                                        *x = if k * L::N + b == c { gain } else { 0.0 };
                                    }
                                }
                            }
                        }
                    }
                }
                for (x, f) in self.v.iter_mut().zip(factors.iter()) {
                    *x *= l.load(f);
                }
                *wave = l.load_i32(&waves);
                l.load(&iors)
            },
        )
    }
    fn rgb_fields(&self) -> [L::F32s; 3] {
        unreachable!("spectral packets are never regrouped (refused before rendering)")
    }
    fn from_rgb_fields(_: [L::F32s; 3]) -> Self {
        unreachable!("spectral packets are never regrouped (refused before rendering)")
    }
}

/// The random-number stream of the hero wavelength (per image sample).
const HERO_STREAM: u32 = 0x6865_726f;

/// The wavelength the RGB renderer's indices are taken at.
pub const RGB_WAVELENGTH: f32 = LAMBDA_D;
