//! `coherent export`: a scene written for another renderer (src/export/), with the list of
//! what it left out.

use anyhow::Context;

use crate::ExportArgs;

pub fn run(args: &ExportArgs) -> anyhow::Result<()> {
    let mut scene = coherent::scene::load(&args.scene)?;
    if let Some((w, h)) = args.resolution {
        scene.width = w;
        scene.height = h;
        scene
            .validate()
            .with_context(|| format!("scene {}", args.scene))?;
    }
    let out = coherent::export::mitsuba::export(&scene, &args.mitsuba)?;
    println!("wrote {}", out.xml.display());
    if out.skipped.is_empty() {
        println!("nothing left out: Mitsuba renders the whole scene as we do");
    } else {
        println!(
            "left out ({}), the scene as written is what both renderers compute alike:",
            out.skipped.len()
        );
        for s in &out.skipped {
            println!("  {s}");
        }
    }
    Ok(())
}
