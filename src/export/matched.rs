//! A scene reduced to what Mitsuba 3 computes the same way as our renderer, with every
//! feature left out named ([`Skip`]). Both renderers then render the reduced scene, so that
//! their images can agree and their frame times compare the same work.
//!
//! What stays: meshes and instances, diffuse colour (with its texture), omni, parallel,
//! rectangular and circular lights, the environment map, the camera. What goes, and why, is
//! in [`matched`]'s reasons; the rule is that a Mitsuba plugin must evaluate the same
//! function, not a similar one.

use super::Skip;
use crate::light::Light;
use crate::scene::RenderScene;

/// The scene reduced to what both renderers compute alike, and what was left out.
pub fn matched(scene: &RenderScene) -> (RenderScene, Vec<Skip>) {
    let mut out = scene.clone();
    let mut skips = Vec::new();
    let mut skip = |what: String, why: &str| {
        skips.push(Skip {
            what,
            why: why.to_string(),
        })
    };

    if out.background != [0.0; 3] {
        skip(
            format!("background {:?}", out.background),
            "seen only by rays that miss here; Mitsuba's constant emitter would also light \
             the surfaces (the matched scene's background is black)",
        );
        out.background = [0.0; 3];
    }

    let optics = out
        .materials
        .iter()
        .any(|m| m.optics.reflectance != [0.0; 3] || m.optics.transmittance != [0.0; 3]);
    if optics && out.depth > 0 {
        skip(
            format!("mirror reflection and refraction to depth {}", out.depth),
            "Mitsuba follows specular rays only inside its path tracer, which adds diffuse \
             interreflection this renderer does not compute (the matched scene renders depth 0)",
        );
    }
    out.depth = 0;

    for m in &mut out.materials {
        if m.bdf.take().is_some() {
            skip(
                format!("material {}: tabulated BDF", m.name),
                "no Mitsuba BSDF reads a tabulated BDF (the matched material keeps its diffuse \
                 colour)",
            );
        }
        if m.phong.specular != [0.0; 3] {
            skip(
                format!(
                    "material {}: Phong lobe (specular {:?}, exponent {})",
                    m.name, m.phong.specular, m.phong.exponent
                ),
                "no Mitsuba 3 BSDF equals the normalised Phong lobe (the matched material is \
                 its diffuse part)",
            );
            m.phong.specular = [0.0; 3];
        }
        if m.phong.ambient != [0.0; 3] {
            skip(
                format!("material {}: ambient {:?}", m.name, m.phong.ambient),
                "Mitsuba has no ambient term",
            );
            m.phong.ambient = [0.0; 3];
        }
        m.optics.reflectance = [0.0; 3];
        m.optics.transmittance = [0.0; 3];
    }

    let mut lights = Vec::with_capacity(out.lights.len());
    for (i, light) in out.lights.iter().enumerate() {
        let kind = light.kind();
        let mut drop = |why: &str| skip(format!("light {i} ({kind})"), why);
        match light {
            Light::Omni(_) | Light::Parallel(_) | Light::Environment(_) => {
                lights.push(light.clone())
            }
            Light::Rectangular(r) => {
                if !r.jittered() {
                    skip(
                        format!("light {i} ({kind}): its {} fixed points", r.samples()),
                        "Mitsuba integrates the whole rectangle; the matched light jitters its \
                         points, so that both converge to the same area light",
                    );
                }
                lights.push(Light::Rectangular(r.with_jitter(true)));
            }
            Light::Circular(c) => {
                if !c.jittered() {
                    skip(
                        format!("light {i} ({kind}): its {} fixed points", c.samples()),
                        "Mitsuba integrates the whole disk; the matched light jitters its \
                         points, so that both converge to the same area light",
                    );
                }
                lights.push(Light::Circular(c.with_jitter(true)));
            }
            Light::Spot(_) => drop(
                "Mitsuba's spot falls off linearly in angle between its beam width and cut-off; \
                 ours as a cosine",
            ),
            Light::Direct(_) => drop("no Mitsuba emitter has a point intensity I0 cos(theta)"),
            Light::Linear(_) => drop("Mitsuba has no line emitter"),
            Light::Goniodiagram(_) => {
                drop("Mitsuba has no emitter that reads an IES or EULUMDAT goniodiagram")
            }
        }
    }
    out.lights = lights;

    if !out.motion.is_empty() {
        skip(
            format!("keyframed motion of {} instance(s)", out.motion.len()),
            "the export is one still frame (instances stay where they are at time 0)",
        );
        out.instances = out.instances_at(0.0);
        out.motion.clear();
    }
    (out, skips)
}
