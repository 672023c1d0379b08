//! The coherent packet renderer (paper section 7, with sections 3-5 as its stages): a packet
//! of camera rays goes to the accelerator's first-hit query, its hits become a shading
//! context in SoA, each material present in the packet is evaluated under its mask (one
//! material at a time), each light and light sample under its mask with a shadow packet
//! through the occlusion query, and the mirror reflection and refraction packets (Fresnel,
//! total internal reflection) are traced the same way to the scene's depth, each lane
//! carrying its throughput. A stage never falls back to scalar code for one lane: finished
//! lanes are masked, not branched around.
//!
//! Secondary packets keep the lanes of their parent packet unless the renderer's `regroup`
//! switch is on: then the reflection and refraction lanes of a whole batch of packets are
//! compacted into full packets (`batch.rs`).
//!
//! Indirect light is off by default; the renderer's `indirect` setting adds it from an
//! illumination map or by path tracing (`indirect.rs`).
//!
//! A frame from Rust, as `coherent render` makes it: a scene (a built-in scene's name, a scene
//! file or a bare mesh), an accelerator chosen by name, the renderer, and the film on a lane
//! backend chosen at run time. [`render_frame`] is not generic: it links the renderer compiled
//! once per backend in this crate.
//!
//! ```
//! use coherent::accel::Accel;
//! use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
//! use coherent::film::{FilmOptions, Method};
//! use coherent::render::{Renderer, render_frame};
//! use coherent::simd::Backend;
//!
//! let scene = coherent::scene::load("cornell")?;
//! let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
//! let (w, h) = (48, 36);
//! let renderer = Renderer::new(&scene, accel, w, h)?;
//! let opts = FilmOptions::new(w, h, Method::Uniform { spp: 1 });
//! let frame = render_frame(Backend::widest(), &renderer, &opts, &|_| {})?;
//! // Tone-mapped and clipped to [0, 1], row by row (`frame.write("out.png")` saves it).
//! let image = frame.displayed(Backend::Scalar)?;
//! assert_eq!(image.len(), (w * h) as usize);
//! assert!(image.iter().any(|c| c.iter().any(|&v| v > 0.0)), "the box is lit");
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod aov;
mod batch;
pub mod centres;
pub mod colour;
pub mod indirect;
pub mod light_samples;
pub mod packets;
pub mod rng;
pub mod stats;
pub mod surface;

use coherent_accel::{Accel, Hits, Rays};
use coherent_simd::{Lanes, MAX_LANES, Rgbs, SimdF32, SimdI32, SimdMask, Vec3s};

use crate::bdf::Frames;
use crate::camera::{CameraError, PinholeCamera};
use crate::light::shadow_rays;
use crate::material::{ShadeHits, Shading};
use crate::scene::RenderScene;
use crate::texture::lod_from_differentials;

pub use aov::{AovBuffer, AovKind};
use colour::{Colour, ColourError, ColourForm, Spectra, Spectral};
pub use indirect::{Indirect, IndirectMode};
pub use light_samples::LightSamples;
pub use packets::Packets;
use stats::StageClock;
pub use stats::{LaneCount, RayKind, RenderStats, Stage};
pub use surface::{Differentials, Geometry, Surface};

/// One stage of the frame kernel (the material passes, a light's sample, the reflected light,
/// the hit's surface, the secondary packets): `stage!(l, expr)` evaluates `expr` on the lanes
/// `l`. In optimised builds it is `expr` itself, so the kernel that `reproduce` measures is
/// one function per backend, as written. In builds with debug assertions (the test profile)
/// each stage is a function of its own per backend (`Lanes::apart`), which shortens the test
/// build (docs/architecture.md, "One renderer per backend"). A macro, not a function taking
/// a closure, so that the optimised build's code is exactly the inline expression.
#[cfg(debug_assertions)]
macro_rules! stage {
    ($l:ident, $e:expr $(,)?) => {
        $l.apart(
            #[inline(always)]
            |$l| $e,
        )
    };
}

/// See the definition above: the expression itself, the kernel as measured.
#[cfg(not(debug_assertions))]
macro_rules! stage {
    ($l:ident, $e:expr $(,)?) => {
        $e
    };
}

/// The renderer of one scene with one accelerator, for one image size.
pub struct Renderer<'s, A: Accel> {
    scene: &'s RenderScene,
    accel: A,
    geometry: Geometry,
    camera: PinholeCamera,
    /// Per material: whether it transmits (its normal keeps its orientation so that rays
    /// know whether they enter or leave), as a lane table.
    transmissive: Vec<u32>,
    /// Per material: index of refraction.
    ior: Vec<f32>,
    /// Reflection/refraction depth (0 = camera rays only).
    pub depth: u32,
    /// Time each stage of the pipeline into [`RenderStats::stage_ns`] (off by default: it
    /// reads the clock several times per packet; when off the stages read no clock).
    pub time_stages: bool,
    /// Which random numbers pick the light samples (per image sample by default).
    pub light_samples: LightSamples,
    /// Compact the active lanes of reflection and refraction packets across the packets of a
    /// batch into full packets (`batch.rs`): a film tile's packets when rendering a frame, a
    /// fixed chunk of the superpixel corners, the whole image in `centres::render_centres`.
    /// Off by default: the paper's packets keep their lanes.
    pub regroup: bool,
    /// How a tile's camera rays are traced: packet by packet, or together as one beam.
    pub packets: Packets,
    /// Per-pixel maps of what the packets did (`aov.rs`; off by default: it reads the clock
    /// per packet and counts the traversal's work).
    pub aov: Option<std::sync::Arc<AovBuffer>>,
    /// Indirect light: none (the default: direct light and Whitted packets only), from an
    /// illumination map, or path traced (`indirect.rs`).
    pub indirect: Indirect,
    /// The image's width in pixels (for [`LightSamples::Tile`]).
    width: u32,
    /// How colour is carried (RGB by default; [`Renderer::set_colour`]).
    colour: ColourForm,
    /// A spectral form's tables.
    spectra: Option<Spectra>,
}

/// A packet of rays in flight with its per-lane state.
#[derive(Clone)]
struct Segment<L: Lanes, C> {
    rays: Rays<L>,
    diff: Differentials<L>,
    active: L::Mask,
    throughput: C,
    /// Per lane, the one wavelength a spectral ray keeps after a dispersive refraction
    /// (`colour.rs`), or -1 while it carries all of them.
    wave: L::I32s,
    /// Mirror and refraction generations above this one (capped by the scene's depth).
    depth: u32,
    /// Diffuse bounces above this one (path tracing's, capped on their own).
    bounces: u32,
    kind: RayKind,
    /// Which node of the ray tree this is (root 1, children 2k and 2k+1): random-number
    /// streams hang off it.
    path: u32,
    /// The random-number ids of the light samples, per lane ([`LightSamples::ids`]).
    light_ids: L::I32s,
    /// The samples' own ids (diffuse bounces draw their numbers from them).
    ids: L::I32s,
    /// Where each lane's radiance goes: its sample's index in the batch (packet * lanes +
    /// lane; regrouped packets mix the lanes of several camera packets).
    slot: L::I32s,
}

impl<'s, A: Accel> Renderer<'s, A> {
    /// The renderer of `scene` (validated) with a built accelerator over
    /// `scene.accel_scene()`, for a `width` x `height` image.
    pub fn new(
        scene: &'s RenderScene,
        accel: A,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        let c = &scene.camera;
        let camera = PinholeCamera::new(c.position, c.look_at, c.up, c.vfov_deg, width, height)?;
        let transmissive = scene
            .materials
            .iter()
            .map(|m| u32::from(m.optics.transmittance.iter().any(|&t| t > 0.0)))
            .collect();
        let ior = scene.materials.iter().map(|m| m.optics.ior).collect();
        Ok(Self {
            scene,
            accel,
            geometry: Geometry::new(scene),
            camera,
            transmissive,
            ior,
            depth: scene.depth,
            time_stages: false,
            light_samples: LightSamples::Pixel,
            regroup: false,
            packets: Packets::Lanes,
            aov: None,
            indirect: Indirect::None,
            width,
            colour: ColourForm::Rgb,
            spectra: None,
        })
    }

    /// Carries colour as `form` from now on: RGB, or a spectral form (hero wavelengths or
    /// bins), which [`render_frame`] renders on the backends of
    /// [`colour::SPECTRAL_BACKENDS`].
    pub fn set_colour(&mut self, form: ColourForm) -> Result<(), ColourError> {
        self.spectra = Spectra::new(form, self.scene)?;
        self.colour = form;
        Ok(())
    }

    /// How colour is carried.
    pub fn colour(&self) -> ColourForm {
        self.colour
    }

    /// The accelerator.
    pub fn accel(&self) -> &A {
        &self.accel
    }

    /// The camera.
    pub fn camera(&self) -> &PinholeCamera {
        &self.camera
    }

    /// Looks through `camera` at a `width` x `height` image from now on, keeping the
    /// accelerator and the shading tables (a viewer's camera moves without a rebuild).
    pub fn set_view(
        &mut self,
        camera: &crate::scene::camera::Camera,
        width: u32,
        height: u32,
    ) -> Result<(), CameraError> {
        let c = camera;
        self.camera = PinholeCamera::new(c.position, c.look_at, c.up, c.vfov_deg, width, height)?;
        self.width = width;
        Ok(())
    }

    /// Hands the accelerator back (a viewer that changes it builds a new renderer).
    pub fn into_accel(self) -> A {
        self.accel
    }

    /// Radiance through the image points `(xs, ys)` of the active lanes (inactive lanes give
    /// zero); `ids` are the samples' ids (random numbers derive from them). NaN lanes are
    /// counted in `stats.nan` and zeroed.
    #[inline(always)]
    pub fn trace_packet<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut RenderStats,
    ) -> Rgbs<L> {
        self.trace_one::<L, Rgbs<L>>(l, &(), xs, ys, ids, active, stats)
    }

    /// [`Renderer::trace_packet`] in colour form `C`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn trace_one<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut RenderStats,
    ) -> Rgbs<L> {
        // Through the batch driver, as one packet (the film traces whole batches).
        let mut p = crate::film::PacketIn::default();
        xs.store(&mut p.xs);
        ys.store(&mut p.ys);
        ids.store(&mut p.ids);
        p.bits = active.bitmask();
        let out = self.trace_batch_in::<L, C>(l, t, std::slice::from_ref(&p), stats);
        let c = &out[0];
        let mut rgb = [[0.0f32; MAX_LANES]; 3];
        for m in 0..L::N {
            for (ch, v) in rgb.iter_mut().zip(c[m]) {
                ch[m] = v;
            }
        }
        Rgbs {
            r: l.load(&rgb[0]),
            g: l.load(&rgb[1]),
            b: l.load(&rgb[2]),
        }
    }

    /// The camera rays through the image points `(xs, ys)` as the root of a ray tree.
    #[inline(always)]
    fn camera_segment<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
    ) -> Segment<L, C> {
        let cam = self.camera.rays(l, xs, ys);
        let zero3 = Vec3s::splat(l, glam::Vec3::ZERO);
        Segment {
            rays: cam.rays,
            diff: Differentials {
                dorigin_dx: zero3,
                dorigin_dy: zero3,
                ddir_dx: cam.ddir_dx,
                ddir_dy: cam.ddir_dy,
            },
            active,
            throughput: C::one(l, t),
            wave: l.splat_i32(-1),
            depth: 0,
            bounces: 0,
            kind: RayKind::Primary,
            path: 1,
            light_ids: self.light_samples.ids(l, xs, ys, ids, self.width),
            ids,
            slot: l.lane_ids(),
        }
    }

    /// Traces one packet: its hits (`traced`, when the beam query found them already) are
    /// shaded and lit into `radiance`, its reflection and refraction packets go to `pending`.
    /// The light samples' random numbers derive from `seg.light_ids`. With per-pixel maps on,
    /// the queries add what they did to `stats.work`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn segment<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        seg: &Segment<L, C>,
        traced: Option<&Hits<L>>,
        radiance: &mut C,
        pending: &mut Vec<Segment<L, C>>,
        stats: &mut RenderStats,
    ) {
        let zero = l.splat(0.0);
        let n_active = seg.active.count();
        if n_active == 0 {
            return;
        }
        let mut clock = StageClock::start(self.time_stages);
        stats.count(seg.kind, n_active);
        stats.count_depth((seg.depth + seg.bounces) as usize, n_active);
        let w = C::waves(l, t, seg.ids);
        let dir = seg.rays.dir;
        let hits = match traced {
            Some(h) => *h,
            // Counted out of the kernel (`Lanes::apart`): a second traversal inlined into every
            // backend's kernel more than doubled the library's build time.
            None if self.aov.is_some() => l.apart(
                #[inline(always)]
                |l| {
                    self.accel
                        .intersect_work(l, &seg.rays, seg.active, &mut stats.work)
                },
            ),
            // The traversal is a function of its own per backend, like a kernel
            // (`Lanes::apart`): inlined, it made each backend's frame kernel one function too
            // large to optimise quickly (docs/architecture.md,
            // "One renderer per backend").
            None => l.apart(
                #[inline(always)]
                |l| self.accel.intersect(l, &seg.rays, seg.active),
            ),
        };
        clock.lap(stats, Stage::Traversal);
        let hit = hits.hit_mask(l) & seg.active;
        let miss = seg.active.and_not(hit);

        // Misses see the background and what the lights show of themselves (environment),
        // but diffuse bounces only the background: the light passes at their origin counted
        // the lights.
        if miss.any() {
            let mut bg = Rgbs::splat(l, self.scene.background);
            if seg.kind != RayKind::Diffuse {
                for light in &self.scene.lights {
                    bg += light.radiance_seen(l, &dir);
                }
            }
            radiance.add_emitted(l, t, &w, miss, &seg.throughput, bg);
        }
        if hit.none() {
            clock.lap(stats, Stage::Other);
            return;
        }

        let surf = stage!(l, {
            self.geometry
                .surface(l, &hits, &seg.rays.origin, &dir, &seg.diff)
        });
        let wo = -dir;
        // Opaque surfaces are two-sided: their normals face the viewer. Transmissive ones
        // keep their orientation (outward), so `wo` below tells a ray leaving the medium.
        let transmissive = l
            .gather_u32(&self.transmissive, surf.material.max(l.splat_i32(0)))
            .eq(l.splat_i32(1));
        let back = surf.ng.dot(wo).lt(zero);
        let flip = back.and_not(transmissive);
        let ns = Vec3s::select(flip, -surf.ns, surf.ns);
        let ng = Vec3s::select(flip, -surf.ng, surf.ng);
        let frames = Frames {
            tangent: surf.tangent,
            bitangent: ns.cross(surf.tangent),
            normal: ns,
        };
        let mut ctx = ShadeHits {
            active: hit,
            material: surf.material,
            frames,
            wo,
            s: surf.s,
            t: surf.t,
            lod: zero,
        };

        clock.lap(stats, Stage::Other);
        // The material pass without a light: mip levels, ambient term, reflection and
        // refraction weights.
        let base = self.shade_materials(l, &mut ctx, Some(&surf), &ns, stats);
        // Below a diffuse bounce, a hit is lit as the illumination map's particles see it:
        // diffusely, without its ambient term (see `indirect.rs`).
        let bounced = seg.bounces > 0;
        let mut lit = if bounced {
            C::zero(l, t)
        } else {
            C::emitted(l, t, &w, hit, base.ambient)
        };
        // Indirect light sees the diffuse albedo (at the mip levels just found); a map gives
        // it the irradiance at the hit.
        let albedo = match self.indirect {
            Indirect::None => Rgbs::zero(l),
            _ => self.albedo_materials(l, &ctx, hit),
        };
        if let Indirect::Map(map) = &self.indirect {
            let e = map.irradiance(l, hits.inst, hits.prim, hits.u, hits.v, hit);
            let f = albedo.scale(l.splat(std::f32::consts::FRAC_1_PI));
            stage!(l, lit.add_reflected(l, t, &w, hit, f, e, None));
        }
        clock.lap(stats, Stage::Shading);

        // Each light, each of its samples, under its mask, with a shadow packet.
        let can_light = hit & ns.dot(wo).gt(zero);
        if can_light.any() {
            let diffuse = bounced.then_some(&albedo);
            self.light_passes(
                l, t, &w, seg, &surf, &ns, can_light, diffuse, &mut ctx, &mut lit, &mut clock,
                stats,
            );
        }
        radiance.add_product(&seg.throughput, &lit);

        if let Indirect::Path { max_bounces } = self.indirect
            && seg.bounces < max_bounces
        {
            stage!(
                l,
                self.spawn_diffuse(l, t, &w, seg, &surf, &ns, &ng, &albedo, hit, pending),
            );
        }
        if seg.depth >= self.depth {
            clock.lap(stats, Stage::Other);
            return;
        }
        stage!(
            l,
            self.spawn_secondaries(l, t, &w, seg, &surf, &ns, &ng, &base, hit, pending),
        );
        clock.lap(stats, Stage::Other);
    }

    /// Adds to `lit` what the lights give the lanes of `can_light`: each light, each of its
    /// samples, under its mask, with a shadow packet through the occlusion query and a
    /// material pass for the lanes it reaches; with `diffuse` (an albedo), instead of the
    /// material pass, the diffuse reflection of that albedo alone.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn light_passes<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        w: &C::Waves,
        seg: &Segment<L, C>,
        surf: &Surface<L>,
        ns: &Vec3s<L>,
        can_light: L::Mask,
        diffuse: Option<&Rgbs<L>>,
        ctx: &mut ShadeHits<L>,
        lit: &mut C,
        clock: &mut StageClock,
        stats: &mut RenderStats,
    ) {
        for (li, light) in self.scene.lights.iter().enumerate() {
            for k in 0..light.samples() {
                let stream =
                    rng::hash1(seg.path.wrapping_mul(0x9e37_79b1) ^ ((li as u32) << 20) ^ k);
                let u = [
                    rng::uniform(l, seg.light_ids, stream),
                    rng::uniform(l, seg.light_ids, stream ^ 0x5555_5555),
                ];
                let ls = stage!(l, light.sample(l, &surf.p, ns, can_light, k, u));
                let on = ls.active & can_light;
                if on.none() {
                    clock.lap(stats, Stage::Lights);
                    continue;
                }
                let shadow = shadow_rays(l, &surf.p, ns, &ls);
                stats.count(RayKind::Shadow, on.count());
                clock.lap(stats, Stage::Lights);
                let blocked = if self.aov.is_some() {
                    l.apart(
                        #[inline(always)]
                        |l| self.accel.occluded_work(l, &shadow, on, &mut stats.work),
                    )
                } else {
                    // Out of the kernel, as the first-hit query above.
                    l.apart(
                        #[inline(always)]
                        |l| self.accel.occluded(l, &shadow, on),
                    )
                };
                let visible = on.and_not(blocked);
                clock.lap(stats, Stage::Shadows);
                if visible.none() {
                    continue;
                }
                let reflected = if let Some(albedo) = diffuse {
                    let cos = ls.wi.dot(*ns).max(l.splat(0.0));
                    albedo.scale(cos * std::f32::consts::FRAC_1_PI)
                } else {
                    ctx.active = visible;
                    self.shade_materials(l, ctx, None, &ls.wi, stats).reflected
                };
                stage!(
                    l,
                    lit.add_reflected(l, t, w, visible, reflected, ls.li, Some(li)),
                );
                clock.lap(stats, Stage::Shading);
            }
        }
    }

    /// Pushes the mirror reflection and refraction packets of the lanes of `hit` whose
    /// material weights them, to be traced after this one.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn spawn_secondaries<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        w: &C::Waves,
        seg: &Segment<L, C>,
        surf: &Surface<L>,
        ns: &Vec3s<L>,
        ng: &Vec3s<L>,
        base: &Shading<L>,
        hit: L::Mask,
        pending: &mut Vec<Segment<L, C>>,
    ) {
        let zero = l.splat(0.0);
        let dir = seg.rays.dir;
        let (ns, ng) = (*ns, *ng);
        let eps = (surf.p.x.abs().max(surf.p.y.abs()).max(surf.p.z.abs()) + 1.0) * 1e-4;
        // No closures here: one called twice may stay out of line, and outside the kernel's
        // `#[target_feature]` function every intrinsic becomes a call
        // (`scripts/check-inlining.sh`).
        let (rw, tw) = (&base.reflection, &base.refraction);

        // The mirror reflection packet.
        let refl_on = hit & rw.r.max(rw.g).max(rw.b).gt(zero);
        if refl_on.any() {
            let r = dir - ns * (dir.dot(ns) * 2.0);
            let side = ng.dot(r).lt(zero).select(-eps, eps);
            pending.push(Segment {
                rays: Rays {
                    origin: ng.mul_add(side, surf.p),
                    dir: r,
                    tmin: zero,
                    tmax: l.splat(f32::INFINITY),
                },
                diff: Differentials {
                    dorigin_dx: surf.dp_dx,
                    dorigin_dy: surf.dp_dy,
                    ddir_dx: seg.diff.ddir_dx - ns * (seg.diff.ddir_dx.dot(ns) * 2.0),
                    ddir_dy: seg.diff.ddir_dy - ns * (seg.diff.ddir_dy.dot(ns) * 2.0),
                },
                active: refl_on,
                throughput: seg.throughput.times(l, t, w, base.reflection),
                wave: seg.wave,
                depth: seg.depth + 1,
                bounces: seg.bounces,
                kind: RayKind::Reflection,
                path: seg.path.wrapping_mul(2),
                light_ids: seg.light_ids,
                ids: seg.ids,
                slot: seg.slot,
            });
        }

        // The refraction packet (Snell's law; lanes past the critical angle are dropped:
        // their energy went to the reflection weight through the Fresnel factor).
        let refr_on = hit & tw.r.max(tw.g).max(tw.b).gt(zero);
        if refr_on.any() {
            let material = surf.material.max(l.splat_i32(0));
            let mut ior = l.gather(&self.ior, material);
            // A spectral ray keeps one wavelength through a dispersive glass (`colour.rs`).
            let mut wave = seg.wave;
            let mut dispersed = None;
            if C::SPECTRAL {
                let mut tp = seg.throughput.times(l, t, w, base.refraction);
                let u = rng::uniform(l, seg.ids, rng::hash1(seg.path ^ 0x6469_7370));
                ior = tp.disperse(l, t, w, refr_on, material, ior, &mut wave, u);
                dispersed = Some(tp);
            }
            let (t_dir, inv_eta, tir) = refract(l, &dir, &ns, ior);
            let on = refr_on.and_not(tir);
            if on.any() {
                let side = ng.dot(t_dir).lt(zero).select(-eps, eps);
                pending.push(Segment {
                    rays: Rays {
                        origin: ng.mul_add(side, surf.p),
                        dir: t_dir,
                        tmin: zero,
                        tmax: l.splat(f32::INFINITY),
                    },
                    diff: Differentials {
                        dorigin_dx: surf.dp_dx,
                        dorigin_dy: surf.dp_dy,
                        ddir_dx: seg.diff.ddir_dx * inv_eta,
                        ddir_dy: seg.diff.ddir_dy * inv_eta,
                    },
                    active: on,
                    throughput: dispersed
                        .unwrap_or_else(|| seg.throughput.times(l, t, w, base.refraction)),
                    wave,
                    depth: seg.depth + 1,
                    bounces: seg.bounces,
                    kind: RayKind::Refraction,
                    path: seg.path.wrapping_mul(2) | 1,
                    light_ids: seg.light_ids,
                    ids: seg.ids,
                    slot: seg.slot,
                });
            }
        }
    }

    /// Shades the active lanes of `ctx` one material at a time (the paper's passes, counted
    /// in `stats.materials`). With `surf` (the pass without a light), each material's mip
    /// level is found from the texture-coordinate differentials and stored in `ctx.lod` for
    /// the light passes.
    #[inline(always)]
    fn shade_materials<L: Lanes>(
        &self,
        l: L,
        ctx: &mut ShadeHits<L>,
        surf: Option<&Surface<L>>,
        wi: &Vec3s<L>,
        stats: &mut RenderStats,
    ) -> Shading<L> {
        stage!(l, {
            let mut out = Shading::zero(l);
            let mut todo = ctx.active;
            if todo.any() {
                stats.materials.packets += 1;
            }
            while todo.any() {
                let id = ctx.material.lane(todo.bitmask().trailing_zeros() as usize);
                let mine = todo & ctx.material.eq(l.splat_i32(id));
                let m = &self.scene.materials[id as usize];
                if let (Some(surf), Some(tex)) = (surf, &m.texture) {
                    let levels = tex.levels();
                    let lod = lod_from_differentials(
                        l,
                        surf.ds_dx,
                        surf.dt_dx,
                        surf.ds_dy,
                        surf.dt_dy,
                        levels[0].width,
                        levels[0].height,
                        levels.len() - 1,
                    );
                    ctx.lod = mine.select(lod, ctx.lod);
                }
                let s = m.shade(l, ctx, wi);
                out = Shading::select(mine, s, out);
                todo = todo.and_not(mine);
                stats.materials.passes += 1;
            }
            out
        })
    }
}

/// Refracts unit directions `dir` at surfaces with unit outward normals `n` into a medium of
/// relative index `ior` (inside over outside); a ray with `dir . n > 0` leaves the medium and
/// sees `1 / ior`. Returns the unit refracted directions, the ratio of indices
/// `n_from / n_to` per lane, and the lanes past the critical angle (total internal
/// reflection; their direction is meaningless).
#[inline(always)]
pub fn refract<L: Lanes>(
    l: L,
    dir: &Vec3s<L>,
    n: &Vec3s<L>,
    ior: L::F32s,
) -> (Vec3s<L>, L::F32s, L::Mask) {
    let zero = l.splat(0.0);
    let one = l.splat(1.0);
    let cos_in = -dir.dot(*n);
    let entering = cos_in.gt(zero);
    let eta = entering.select(ior, one / ior);
    let n_in = Vec3s::select(entering, *n, -*n);
    let cos_i = cos_in.abs();
    let inv_eta = one / eta;
    let sin2_t = (one - cos_i * cos_i) * inv_eta * inv_eta;
    let tir = sin2_t.ge(one);
    let cos_t = (one - sin2_t).max(zero).sqrt();
    let t_dir = *dir * inv_eta + n_in * (cos_i * inv_eta - cos_t);
    (t_dir, inv_eta, tir)
}

/// Renders a frame through the film (`coherent render`'s path: samples, passes, adaptive
/// anti-aliasing) with the accelerator chosen at run time, in the current rayon pool.
///
/// [`crate::film::render`] with `Renderer<AnyAccel>`, but not generic: the renderer is
/// monomorphised for every backend once, in this crate, and the command line, the experiments
/// and the tests link to that one copy instead of each compiling its own (the renderer,
/// compiled for nine backends, is most of the project's build time).
#[inline(never)]
pub fn render_frame(
    backend: coherent_simd::Backend,
    renderer: &Renderer<'_, crate::accel_any::AnyAccel>,
    opts: &crate::film::FilmOptions,
    progress: &(dyn Fn(&crate::film::PassReport) + Sync),
) -> Result<crate::film::Rendered<RenderStats>, crate::film::FilmError> {
    let Some(spectra) = &renderer.spectra else {
        return crate::film::render(backend, renderer, opts, progress);
    };
    let form = renderer.colour.label();
    if renderer.regroup {
        let e = ColourError::Regroup { form };
        return Err(crate::film::FilmError::Options(e.to_string()));
    }
    if let Some(why) = colour::spectral_refusal(&renderer.colour, backend) {
        return Err(crate::film::FilmError::Options(why));
    }
    let frames = SpectralFrames { renderer, spectra };
    crate::film::render(backend, &frames, opts, progress)
}

/// A renderer in a spectral colour form, as the film sees it: compiled for
/// [`colour::SPECTRAL_BACKENDS`] alone, since each backend is a second copy of the renderer.
struct SpectralFrames<'r, 's, A: Accel> {
    renderer: &'r Renderer<'s, A>,
    spectra: &'r Spectra,
}

impl<A: Accel> crate::film::SampleTracer for SpectralFrames<'_, '_, A> {
    type Stats = RenderStats;
    const BACKENDS: u32 = colour::SPECTRAL_BACKENDS;
    const SIGNED: bool = true;

    fn merge_stats(into: &mut RenderStats, from: RenderStats) {
        into.merge(from);
    }

    #[inline(always)]
    fn trace<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut RenderStats,
    ) -> Rgbs<L> {
        self.renderer
            .trace_one::<L, Spectral<L>>(l, self.spectra, xs, ys, ids, active, stats)
    }

    #[inline(always)]
    fn trace_batch<L: Lanes>(
        &self,
        l: L,
        packets: &[crate::film::PacketIn],
        stats: &mut RenderStats,
    ) -> Vec<crate::film::PacketOut> {
        self.renderer
            .trace_batch_in::<L, Spectral<L>>(l, self.spectra, packets, stats)
    }
}

impl<A: Accel> crate::film::SampleTracer for Renderer<'_, A> {
    type Stats = RenderStats;

    fn merge_stats(into: &mut RenderStats, from: RenderStats) {
        into.merge(from);
    }

    #[inline(always)]
    fn trace<L: Lanes>(
        &self,
        l: L,
        xs: L::F32s,
        ys: L::F32s,
        ids: L::I32s,
        active: L::Mask,
        stats: &mut RenderStats,
    ) -> Rgbs<L> {
        self.trace_packet(l, xs, ys, ids, active, stats)
    }

    #[inline(always)]
    fn trace_batch<L: Lanes>(
        &self,
        l: L,
        packets: &[crate::film::PacketIn],
        stats: &mut RenderStats,
    ) -> Vec<crate::film::PacketOut> {
        self.trace_batch_in::<L, Rgbs<L>>(l, &(), packets, stats)
    }
}
