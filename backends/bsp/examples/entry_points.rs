//! How much of a packet walk an entry point could spare for rays that leave a surface: the
//! descent from the root to the deepest node that holds all of a packet's origins, against
//! the inner-node steps the whole packet walk takes.
//!
//! ```text
//! cargo run --release -p coherent-bsp --example entry_points -- [quick|full]
//! ```
//!
//! Diffuse rays from the primary hits of a 1024 x 768 image (the `accel` experiment's
//! workload), in packets of 16 (4 x 4 pixel tiles), on the single-mesh built-in scenes (blob
//! and terrain, whose one instance has the identity transform, so that the mesh tree's
//! coordinates are the world's). Per packet: the depth of the deepest node of the mesh tree
//! whose cell holds all 16 origins, the mean depth of each origin's own leaf, and the inner
//! nodes the packet's walk visits (`Bsp::intersect_counted`, counted once per packet).
//! `docs/findings/traversal.md` cites it for the entry point weighed and not built.

use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::workload;
use coherent_accel::{Accel, Ray1, Rays};
use coherent_bsp::{Bsp, BspParams, KdTree, TraversalStats};
use coherent_simd::{Backend, Kernel, Lanes};
use glam::Vec3;

const PACKET: usize = 16;

fn main() {
    let size = match std::env::args().nth(1).as_deref() {
        Some("quick") => SceneSize::Quick,
        _ => SceneSize::Full,
    };
    for name in ["blob", "terrain"] {
        let s = scenes::by_name(name, size).expect("a built-in scene");
        assert!(
            s.scene.instances.len() == 1
                && s.scene.instances[0].world_from_object == glam::Affine3A::IDENTITY,
            "{name}: one instance with the identity transform"
        );
        let bsp = Bsp::build(&s.scene, &BspParams::default()).expect("the scene builds");
        let primary = workload::primary_rays(&s.view, 1024, 768, workload::tile_shape(PACKET));
        let diffuse = workload::diffuse_rays(&bsp, &s.scene, &primary, 7);
        let tree = &bsp.mesh_trees()[0].tree;

        let packets: Vec<&[Ray1]> = diffuse.chunks_exact(PACKET).collect();
        let mut common = 0.0;
        let mut own = 0.0;
        for p in &packets {
            common += common_depth(tree, p) as f64;
            own +=
                p.iter().map(|r| leaf_depth(tree, r.origin)).sum::<usize>() as f64 / PACKET as f64;
        }
        let n = packets.len() as f64;
        let backend = Backend::preferred_for_lanes(PACKET).unwrap_or(Backend::Wide16);
        let stats = backend
            .run(Walk {
                bsp: &bsp,
                packets: &packets,
            })
            .expect("a 16-lane backend runs here");
        let walk = stats.inner_nodes as f64 / n;
        println!(
            "{name} ({} triangles, {} packets of {PACKET} diffuse rays, {backend}): common node at depth {:.1}, \
             each origin's leaf at {:.1}; the packet walk takes {walk:.1} inner-node steps \
             ({:.2} per ray), so an entry point spares at most {:.1}% of them",
            bsp.stats().triangles,
            packets.len(),
            common / n,
            own / n,
            walk / PACKET as f64,
            100.0 * common / n / walk,
        );
    }
}

/// The next node for point `p` at inner node `node`: the child whose cell holds `p` (the
/// left one on the plane).
fn child(tree: &KdTree, node: usize, p: Vec3) -> usize {
    let n = tree.nodes[node];
    n.left() + usize::from(p[n.axis()] > n.split())
}

/// Depth of the leaf whose cell holds `p`.
fn leaf_depth(tree: &KdTree, p: Vec3) -> usize {
    let (mut node, mut depth) = (0, 0);
    while !tree.nodes[node].is_leaf() {
        node = child(tree, node, p);
        depth += 1;
    }
    depth
}

/// Depth of the deepest node whose cell holds every ray's origin.
fn common_depth(tree: &KdTree, rays: &[Ray1]) -> usize {
    let (mut node, mut depth) = (0, 0);
    while !tree.nodes[node].is_leaf() {
        let next = child(tree, node, rays[0].origin);
        if rays[1..]
            .iter()
            .any(|r| child(tree, node, r.origin) != next)
        {
            break;
        }
        node = next;
        depth += 1;
    }
    depth
}

/// The packets' first-hit walks, counted.
struct Walk<'a> {
    bsp: &'a Bsp,
    packets: &'a [&'a [Ray1]],
}

impl Kernel for Walk<'_> {
    type Output = TraversalStats;
    fn run<L: Lanes>(self, l: L) -> TraversalStats {
        let mut c = TraversalStats::default();
        for p in self.packets {
            for part in p.chunks(L::N) {
                let rays = Rays::from_fn(l, |i| part[i]);
                self.bsp
                    .intersect_counted(l, &rays, l.splat_mask(true), &mut c);
            }
        }
        c
    }
}
