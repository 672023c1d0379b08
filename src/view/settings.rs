//! What the viewer renders with: the camera, the image size, the lane backend, the
//! accelerator, how camera rays travel, the per-pixel map shown instead of the image, and
//! the sampling (adaptive to an accuracy, or uniform). Checked before a render restarts, so
//! that a bad value is refused with a message and the render in progress goes on.

use crate::accel_any::AccelKind;
use crate::film::{FilmOptions, Method};
use crate::render::{AovKind, Packets};
use crate::scene::camera::Camera;
use crate::simd::Backend;

/// The largest image side the viewer renders (a page shows no more; the film takes more).
pub const MAX_VIEW_SIDE: u32 = 4096;

/// The adaptive method's cap on samples per pixel (`coherent render`'s default `--max-spp`).
pub const MAX_ADAPTIVE_SPP: u32 = 64;

/// How samples are placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// The paper's adaptive anti-aliasing to this accuracy (display units, in (0, 1]).
    Adaptive { accuracy: f32 },
    /// `spp` samples in every pixel, one pass per sample.
    Uniform { spp: u32 },
}

/// Everything a render of the viewer depends on besides the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub backend: Backend,
    pub accel: AccelKind,
    pub packets: Packets,
    /// When set, the viewer shows this per-pixel map as a heat map instead of the image.
    pub aov: Option<AovKind>,
    pub sampling: Sampling,
}

impl Settings {
    /// The scene's own view and sampling (as `coherent render` takes them: its accuracy,
    /// else its spp, else adaptive at 5%), the widest backend usable here, the BSP, lane
    /// packets, no map.
    pub fn of_scene(scene: &crate::scene::RenderScene) -> Settings {
        Settings {
            camera: scene.camera,
            width: scene.width,
            height: scene.height,
            backend: Backend::widest(),
            accel: AccelKind::Bsp,
            packets: Packets::Lanes,
            aov: None,
            sampling: match (scene.accuracy, scene.spp) {
                (Some(accuracy), _) => Sampling::Adaptive { accuracy },
                (None, Some(spp)) => Sampling::Uniform { spp },
                (None, None) => Sampling::Adaptive { accuracy: 0.05 },
            },
        }
    }

    /// Why these settings cannot be rendered here, naming the setting; `None` when they can.
    pub fn problem(&self) -> Option<String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_VIEW_SIDE).contains(&v) {
                return Some(format!("{name} {v}: must be 1 to {MAX_VIEW_SIDE} pixels"));
            }
        }
        if let Some((field, why)) = self.camera.problem() {
            return Some(format!("camera {field}: {why}"));
        }
        if let Some(why) = self.backend.unavailable_reason() {
            return Some(format!(
                "backend `{}` cannot run here: {why}",
                self.backend.name()
            ));
        }
        if let Some(why) = self.accel.unavailable_reason() {
            return Some(format!(
                "accelerator `{}` cannot be used here: {why}",
                self.accel
            ));
        }
        // Only the BSP's traversal is ours to count (`Accel::counts_work`).
        if let Some(k) = self.aov
            && k.needs_counts()
            && self.accel != AccelKind::Bsp
        {
            return Some(format!(
                "map `{k}` needs the bsp accelerator (only the BSP's traversal steps and \
                 tests are counted); `lanes` and `time` work with any"
            ));
        }
        match self.sampling {
            Sampling::Adaptive { accuracy } => {
                if !(accuracy.is_finite() && accuracy > 0.0 && accuracy <= 1.0) {
                    return Some(format!(
                        "accuracy {accuracy}: must be in (0, 1], a difference of displayed \
                         colour (0.02 for 2%)"
                    ));
                }
            }
            Sampling::Uniform { spp } => {
                if spp == 0 {
                    return Some("spp 0: must be at least 1".into());
                }
            }
        }
        // What the film itself checks (sample ids, superpixels), in its own words.
        self.film_options(crate::tonemap::Operator::default())
            .validate()
            .err()
            .map(|e| e.to_string())
    }

    /// The film's options for these settings, tone-mapped with `tonemap` (the scene's):
    /// what `coherent render` would use for the same sampling.
    pub fn film_options(&self, tonemap: crate::tonemap::Operator) -> FilmOptions {
        let method = match self.sampling {
            Sampling::Adaptive { accuracy } => Method::Adaptive {
                accuracy,
                max_samples_per_pixel: MAX_ADAPTIVE_SPP,
                time_budget: None,
            },
            Sampling::Uniform { spp } => Method::Uniform { spp },
        };
        let mut opts = FilmOptions::new(self.width, self.height, method);
        opts.tonemap = tonemap;
        opts
    }
}
