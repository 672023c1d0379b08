//! Experiment `imaps`: illumination maps (paper section 2: higher-order indirect light from
//! maps computed by forward Monte-Carlo ray tracing; section 8: making those rays coherent
//! is the next problem). Particles leave the lights and bounce through the scene one
//! generation at a time; each generation's live rays are traced four ways
//! (`coherent::illum::Mode`): one ray per packet (`single`), in particle order cut into
//! packets (`packets`), as sorted streams (`sorted`: Áfra et al. 2016's key of direction
//! octant, Morton code of the origin and coarse direction) and reordered by direction octant
//! (`octant`, Boulos et al. 2008). The same particles give the same map in every mode, so
//! the modes differ in speed only.
//!
//! Three parts, one file each:
//! - [`speed`]: per scene, accelerator, backend, mode and generation, rays per second, lanes
//!   per packet, the traversal's work per ray and the sort's share (`imaps.csv`);
//! - [`error`]: the map's error against a reference of 100 times the particles, over two
//!   decades of particle budgets (`imaps_error.csv`);
//! - [`frames`]: frames lit directly, and with the map's indirect light, against path
//!   tracing (`imaps_frames.csv`).
//!
//! [`plots`] and [`report`] work from the CSV files alone.

mod error;
mod frames;
mod plots;
mod report;
mod speed;

use coherent::accel_any::AccelKind;
use coherent::scene::RenderScene;

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};

pub const EXPERIMENT: Experiment = Experiment {
    name: "imaps",
    description: "illumination maps: particle tracing single, in packets, as sorted streams and by octant; the map's error against particles; frames with the map",
    paper: "sections 2 and 8: illumination maps by forward ray tracing, made coherent",
    csv: &[speed::FILE, error::FILE, frames::FILE],
    plots: &[
        "imaps_rays_cornell",
        "imaps_rays_room2",
        "imaps_rays_glass1",
        "imaps_error_particles",
        "imaps_error_seconds",
    ],
    status: Status::Ready {
        run,
        plot: plots::plots,
        report: report::report,
    },
};

/// The scenes: the closed box, the furnished interior and the glass room (the last two are
/// stand-ins for the paper's Room2 and Glass1).
const SCENES: [&str; 3] = ["cornell", "room2", "glass1"];

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let scenes = load_scenes(ctx);
    let accels = accels(ctx);
    speed::run(ctx, &scenes, &accels)?;
    error::run(ctx, &scenes)?;
    frames::run(ctx, &scenes)?;
    Ok(())
}

/// The scenes of [`SCENES`] that load, each at the frames' size, its static instances
/// merged as `coherent render` does; the others are noted.
fn load_scenes(ctx: &mut Ctx) -> Vec<(String, Box<RenderScene>)> {
    let plan = frames::plan(ctx);
    let mut out = Vec::new();
    for name in SCENES {
        if let Some(scene) = crate::frames::load_or_note(ctx, "imaps", &plan, name, name) {
            out.push((name.to_owned(), scene));
        }
    }
    out
}

/// The accelerators that trace packets themselves (the BSP and Embree) usable here; the
/// others are noted.
fn accels(ctx: &mut Ctx) -> Vec<AccelKind> {
    let mut out = Vec::new();
    for k in AccelKind::compared().filter(|k| k.has_packets()) {
        match k.unavailable_reason() {
            None => out.push(k),
            Some(why) => ctx.note(format!("imaps: accel {k} skipped: {why}")),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Plan;
    use coherent::simd::Backend;

    fn ctx(dir: &tempfile::TempDir) -> Ctx {
        Ctx::new(dir.path(), true, coherent::machine::Machine::detect())
    }

    /// Writes `rows` under `header` into `file`.
    fn write(ctx: &Ctx, file: &str, header: &[&str], rows: &[Vec<String>]) {
        let mut csv = ctx.csv(file, header).unwrap();
        for row in rows {
            let cells: Vec<&dyn std::fmt::Display> =
                row.iter().map(|c| c as &dyn std::fmt::Display).collect();
            csv.row(&cells).unwrap();
        }
        csv.finish().unwrap();
    }

    fn strings(cells: &[&dyn std::fmt::Display]) -> Vec<String> {
        cells.iter().map(|c| c.to_string()).collect()
    }

    #[test]
    fn plots_and_report_come_from_the_csv_files_alone() {
        let dir = tempfile::tempdir().unwrap();
        let ctx = ctx(&dir);
        assert!(report::report(&ctx).unwrap().is_none());
        // Sorted streams twice as fast as packets from generation 1 on, on cornell only.
        let mut rows = Vec::new();
        for scene in ["cornell", "room2"] {
            for mode in ["single", "packets", "sorted", "octant"] {
                for g in 0..3u32 {
                    let rate = match (mode, g) {
                        ("single", _) => 1.0,
                        ("sorted", 1..) if scene == "cornell" => 4.0,
                        _ => 2.0,
                    };
                    rows.push(strings(&[
                        &scene,
                        &"bsp",
                        &"avx512",
                        &16,
                        &mode,
                        &1000,
                        &g,
                        &1,
                        &(4000 >> g),
                        &(400 >> g),
                        &10.0,
                        &rate,
                        &(rate * 0.9),
                        &30.0,
                        &4.0,
                        &0.05,
                        &0.1,
                        &0.0,
                        &3,
                    ]));
                }
            }
        }
        write(&ctx, speed::FILE, speed::HEADER, &rows);
        // The error falls as 1/sqrt on cornell, as 1/particles on room2.
        let mut rows = Vec::new();
        for (scene, slope) in [("cornell", -0.5f64), ("room2", -1.0)] {
            for p in [1_000u64, 10_000, 100_000] {
                let e = 0.3 * (p as f64 / 1000.0).powf(slope);
                rows.push(strings(&[
                    &scene,
                    &"bsp",
                    &"avx512",
                    &"sorted",
                    &p,
                    &2,
                    &e,
                    &(e * 0.9),
                    &(e * 1.1),
                    &(p as f64 * 1e-6),
                    &10_000_000,
                    &12.0,
                ]));
            }
        }
        write(&ctx, error::FILE, error::HEADER, &rows);
        let rows = vec![
            strings(&[
                &"cornell", &"avx512", &"bsp", &128, &96, &1, &100_000, &0.5, &0.010, &0.012, &1.2,
                &3, &16, &0.02, &0.015,
            ]),
            strings(&[
                &"room2",
                &"avx512",
                &"bsp",
                &128,
                &96,
                &1,
                &100_000,
                &0.5,
                &0.010,
                &0.016,
                &1.6,
                &3,
                &0,
                &f64::NAN,
                &f64::NAN,
            ]),
        ];
        write(&ctx, frames::FILE, frames::HEADER, &rows);

        plots::plots(&ctx).unwrap();
        for stem in [
            "imaps_rays_cornell",
            "imaps_error_particles",
            "imaps_error_seconds",
        ] {
            assert!(
                dir.path().join(format!("plots/{stem}.png")).is_file(),
                "{stem}"
            );
        }
        let md = report::report(&ctx).unwrap().unwrap();
        for row in [
            "| cornell | sorted >= 1.5x packets, generation 1 on (bsp, avx512) | met |",
            "| room2 | sorted >= 1.5x packets, generation 1 on (bsp, avx512) | not met |",
            "| cornell | error slope -0.5 within 20% | met |",
            "| room2 | error slope -0.5 within 20% | not met |",
            "| cornell | imap frame <= 1.5x direct | met |",
            "| room2 | imap frame <= 1.5x direct | not met |",
            "| cornell | imap within 2x the path reference's noise | met |",
            "| cornell | 1 | 2000 | 1.00 | 2.00 | 4.00 | 2.00 |",
        ] {
            assert!(md.contains(row), "{row}\n{md}");
        }
        assert!(md.contains("slope"), "{md}");
        assert!(md.contains("plots/imaps_rays_cornell.png"), "{md}");
    }

    #[test]
    fn a_tiny_run_of_cornell_writes_every_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = ctx(&dir);
        let plan = Plan {
            builtins: true,
            scenes_dir: dir.path().join("no-scenes"),
            max_triangles: usize::MAX,
            width: 24,
            height: 16,
            spp: 1,
        };
        let scene = crate::frames::load_or_note(&mut ctx, "imaps", &plan, "cornell", "cornell")
            .expect("cornell loads");
        let scenes = vec![("cornell".to_owned(), scene)];
        let b = Backend::widest();
        speed::run_with(&mut ctx, &scenes, &[AccelKind::Bsp], &[b], 300, 1).unwrap();
        error::run_with(&mut ctx, &scenes, &[20, 80], 2).unwrap();
        frames::run_with(&mut ctx, &scenes, &plan, 2_000, 1, 1).unwrap();

        let t = ctx.read_csv(speed::FILE, speed::HEADER).unwrap().unwrap();
        assert_eq!(
            t.distinct("mode").unwrap(),
            ["single", "packets", "sorted", "octant"]
        );
        for r in 0..t.len() {
            // A relative difference (0 where every particle took the same path).
            assert!(t.f64(r, "map_vs_single").unwrap() >= 0.0, "row {r}");
            assert!(t.f64(r, "lanes_per_packet").unwrap() <= b.lanes() as f64);
        }
        let single = t.rows_where("mode", "single").unwrap();
        assert!(t.f64(single[0], "lanes_per_packet").unwrap() == 1.0);
        let e = ctx.read_csv(error::FILE, error::HEADER).unwrap().unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!(e.get(0, "reference_particles").unwrap(), "8000");
        let f = ctx.read_csv(frames::FILE, frames::HEADER).unwrap().unwrap();
        assert!(f.f64(0, "ratio").unwrap() > 0.0);
        assert!(f.f64(0, "path_noise").unwrap().is_finite());
        assert!(report::report(&ctx).unwrap().is_some());
    }
}
