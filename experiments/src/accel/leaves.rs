//! Single rays testing a leaf's triangles four at a time (`accel_simd_leaves.csv`), beside one
//! at a time and beside Embree's single rays.

use coherent::accel::{Accel, Ray1};
use coherent::accel_any::AccelKind;
use coherent::bsp::{Bsp, BspParams, TraversalStats};
use coherent_accel::workload::RayKind;

use super::measure::{Other, Pass, disagreement, interleaved, pass_any};

/// The BSPs whose single rays test leaves four triangles at a time: on the default tree,
/// and on a tree whose leaves are priced per four triangles.
pub(super) fn simd_leaf_bsps(
    scene: &coherent::accel::Scene,
) -> anyhow::Result<Vec<(&'static str, Bsp)>> {
    let mut p = BspParams {
        simd_leaves: true,
        ..BspParams::default()
    };
    let default = Bsp::build(scene, &p)?;
    p.object.leaf_group = 4;
    Ok(vec![
        ("default", default),
        ("per_four", Bsp::build(scene, &p)?),
    ])
}

/// The rows of `accel_simd_leaves.csv` for one scene and ray kind: the BSP's single rays one
/// triangle at a time (the `accel.csv` row's configuration) and four at a time, beside
/// Embree's single rays, timed interleaved over the same rays.
pub(super) struct LeafSet<'a> {
    pub csv: &'a mut crate::table::CsvOut,
    pub scene: &'a str,
    pub kind: RayKind,
    pub rays: &'a [Ray1],
    pub samples: usize,
    pub disagreements: &'a mut Vec<String>,
}

impl LeafSet<'_> {
    pub(super) fn rows(
        &mut self,
        one: &Bsp,
        four: &[(&'static str, Bsp)],
        others: &[Other],
    ) -> anyhow::Result<()> {
        let occ = self.kind.occlusion();
        let bsps: Vec<(&str, &str, &Bsp)> = std::iter::once(("one", "default", one))
            .chain(four.iter().map(|(t, b)| ("four", *t, b)))
            .collect();
        let embree = others
            .iter()
            .find(|o| o.kind == AccelKind::Embree)
            .map(|o| &o.accel);
        let n = bsps.len() + embree.is_some() as usize;
        let res = interleaved(n, self.samples, |v| match (bsps.get(v), embree) {
            (Some((_, _, b)), _) => pass_any(*b, self.rays, occ, None),
            (None, Some(e)) => e.visit(Pass {
                rays: self.rays,
                occlusion: occ,
                backend: None,
            }),
            (None, None) => unreachable!("one variant per BSP, then Embree's if built"),
        })?;
        let rate = |v: usize| self.rays.len() as f64 / res[v].0 / 1e6;
        for (v, (test, tree, b)) in bsps.iter().enumerate() {
            let mut c = TraversalStats::default();
            for r in self.rays {
                if occ {
                    b.occluded1_counted(r, &mut c);
                } else {
                    b.intersect1_counted(r, &mut c);
                }
            }
            let vs = embree.map_or("-".to_owned(), |_| format!("{:.3}", rate(v) / rate(n - 1)));
            self.csv.row(&[
                &self.scene,
                &self.kind.name(),
                test,
                tree,
                &format!("{:.3}", rate(v)),
                &vs,
                &format!("{:.3}", c.tri_tests as f64 / self.rays.len() as f64),
                &b.memory_bytes(),
            ])?;
            if let Some(why) = disagreement(&res[0].1, &res[v].1, self.rays.len()) {
                self.disagreements.push(format!(
                    "{} {} rays, BSP with leaves tested {test} at a time ({tree} tree): {why}",
                    self.scene,
                    self.kind.name()
                ));
            }
        }
        Ok(())
    }
}
