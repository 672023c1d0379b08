//! Rendering a scene from Rust: a built-in scene's name or a scene file's path, the BSP, the
//! widest backend of this CPU, 4 samples per pixel, written as PNG (or EXR, by the
//! extension).
//!
//! `cargo run --release --example render_scene -- cornell cornell.png`
//!
//! `coherent render` does the same with every option on the command line.

use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method};
use coherent::render::{Renderer, render_frame};
use coherent::simd::Backend;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let spec = args.next().unwrap_or_else(|| "cornell".to_owned());
    let out = args.next().unwrap_or_else(|| "render_scene.png".to_owned());

    let scene = coherent::scene::load(&spec)?;
    let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
    let (w, h) = (scene.width, scene.height);
    let renderer = Renderer::new(&scene, accel, w, h)?;
    let opts = FilmOptions::new(w, h, Method::Uniform { spp: 4 });
    let frame = render_frame(Backend::widest(), &renderer, &opts, &|_| {})?;
    frame.write(std::path::Path::new(&out))?;
    println!("{spec}: {w}x{h}, {} rays -> {out}", frame.rays);
    Ok(())
}
