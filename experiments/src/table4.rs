//! Experiment `table4`: the paper's Table 4 (section 7), the characteristics of the test
//! scenes, for our built-in stand-ins of its four scenes (generated in memory, no download):
//! instanced triangles, objects (instances), lights, reflection/refraction depth and
//! materials, beside the paper's triangles, lights and depth; and the BSP the renderer builds
//! over each (static instances merged), with each build preset: objects, nodes, leaf
//! references, depth and SAH cost (`table4_trees.csv`). Nothing is timed; quick and full runs
//! give the same rows.

use coherent::scene::builtin::{PAPER_TABLE4, by_name};

use coherent::accel::Accel;
use coherent::bsp::{Bsp, BuildPreset};

use crate::builds::TreeQuality;
use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::table::{PaperTable, markdown_table};

pub const EXPERIMENT: Experiment = Experiment {
    name: "table4",
    description: "the characteristics of the test scenes",
    paper: "Table 4 (section 7)",
    csv: &[FILE, TREES_FILE],
    plots: &[],
    status: Status::Ready {
        run,
        plot: crate::experiment::no_plots,
        report,
    },
};

pub(crate) const FILE: &str = "table4_scenes.csv";
/// The contract's columns, then the kinds of light (`+`-separated).
pub(crate) const HEADER: &[&str] = &[
    "scene",
    "triangles",
    "objects",
    "lights",
    "depth",
    "materials",
    "light_kinds",
];

/// The BSP over each scene as the renderer builds it, per build preset.
pub(crate) const TREES_FILE: &str = "table4_trees.csv";
pub(crate) const TREES_HEADER: &[&str] = &[
    "scene",
    "preset",
    "objects",
    "triangles",
    "nodes",
    "leaf_refs",
    "max_depth",
    "sah_cost",
];

/// The paper's Table 4.
pub(crate) const PAPER: PaperTable = PaperTable {
    caption: "Table 4: the test scenes. Paper (its scenes) beside ours (generated stand-ins, \
              matched within 10 % in triangles and exactly in lights and depth):",
    key: "scene",
    columns: &["triangles", "lights", "depth"],
    rows: &[
        ("car", &[233_000.0, 4.0, 2.0]),
        ("spdemo", &[988.0, 3.0, 2.0]),
        ("glass1", &[44_794.0, 2.0, 2.0]),
        ("room2", &[12_000.0, 4.0, 1.0]),
    ],
};

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let mut csv = ctx.csv(FILE, HEADER)?;
    for row in PAPER_TABLE4 {
        let s = by_name(row.name)
            .ok_or_else(|| anyhow::anyhow!("built-in scene {} is missing", row.name))?;
        s.validate()?;
        let mut kinds: Vec<&str> = s.lights.iter().map(|l| l.kind().name()).collect();
        kinds.dedup();
        csv.row(&[
            &row.name,
            &s.triangles(),
            &s.instances.len(),
            &s.lights.len(),
            &s.depth,
            &s.materials.len(),
            &kinds.join("+"),
        ])?;
    }
    csv.finish()?;

    let mut trees = ctx.csv(TREES_FILE, TREES_HEADER)?;
    for row in PAPER_TABLE4 {
        let Some(s) = by_name(row.name) else { continue };
        let (s, _) = s.merge_static();
        let accel = s.accel_scene();
        for preset in BuildPreset::ALL {
            let b = Bsp::build(&accel, &crate::builds::bsp_params(preset))?;
            let q = TreeQuality::of(&b);
            trees.row(&[
                &row.name,
                &q.preset,
                &s.instances.len(),
                &s.triangles(),
                &q.nodes,
                &q.leaf_refs,
                &q.max_depth,
                &format!("{:.4}", q.sah_cost),
            ])?;
        }
    }
    trees.finish()?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(table) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let mut ours = Vec::new();
    let mut rows = Vec::new();
    for r in 0..table.rows.len() {
        let scene = table.get(r, "scene")?.to_owned();
        let num = |c: &str| table.f64(r, c).ok();
        ours.push((
            scene.clone(),
            vec![num("triangles"), num("lights"), num("depth")],
        ));
        let paper = PAPER.rows.iter().find(|(k, _)| *k == scene);
        let off = paper
            .zip(num("triangles"))
            .map(|((_, p), t)| format!("{:+.1} %", 100.0 * (t / p[0] - 1.0)))
            .unwrap_or_else(|| "—".to_owned());
        let mut cells = vec![scene];
        for c in ["triangles", "objects", "lights", "depth", "materials"] {
            cells.push(table.get(r, c)?.to_owned());
        }
        cells.push(off);
        cells.push(table.get(r, "light_kinds")?.replace('+', ", "));
        rows.push(cells);
    }
    let mut md = PAPER.beside(&ours);
    md.push_str("\nOur scenes in full (objects = instances; triangles counted per instance):\n\n");
    md.push_str(&markdown_table(
        &[
            "scene",
            "triangles",
            "objects",
            "lights",
            "depth",
            "materials",
            "triangles vs paper",
            "light kinds",
        ],
        &rows,
    ));
    if let Some(t) = ctx.read_csv(TREES_FILE, TREES_HEADER)? {
        md.push_str(
            "\nThe BSP over each scene as the renderer builds it (static instances merged), \
             per build preset (`table4_trees.csv`; SAH: each object tree's cost relative to \
             its root box, summed):\n\n",
        );
        md.push_str(&t.to_markdown());
    }
    Ok(Some(md))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_match_the_paper_and_report() {
        let dir = tempfile::tempdir().unwrap();
        let mut ctx = Ctx::new(dir.path(), true, coherent::machine::Machine::detect());
        run(&mut ctx).unwrap();
        let md = report(&ctx).unwrap().unwrap();
        assert!(
            md.contains("| spdemo | 988 | 988 | 3.00 | 3.00 | 2.00 | 2.00 |"),
            "{md}"
        );
        assert!(
            md.contains("| spdemo | 988 | 7 | 3 | 2 | 4 | +0.0 % | omni, direct, linear |"),
            "{md}"
        );
        assert!(md.contains("goniodiagram"), "{md}");
        // Every preset's tree per scene.
        let t = ctx.read_csv(TREES_FILE, TREES_HEADER).unwrap().unwrap();
        assert_eq!(t.rows.len(), BuildPreset::ALL.len() * PAPER_TABLE4.len());
        for r in 0..t.rows.len() {
            assert!(t.f64(r, "nodes").unwrap() > 0.0);
            assert!(t.f64(r, "sah_cost").unwrap() > 0.0);
        }
    }
}
