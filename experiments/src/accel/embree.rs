//! Embree's side of the comparison beyond the common interface: its own packets of each
//! width, packed before timing, timed through the harness, through a plain C-API loop and
//! through the `Accel` trait (`accel_embree.csv`); and what Embree runs here, for
//! `machine.json`.

use coherent::accel::Ray1;
#[cfg(feature = "embree")]
use coherent::accel_any::AnyAccel;
use coherent::simd::Backend;
#[cfg(feature = "embree")]
use coherent_accel::workload::PassResult;
use coherent_accel::workload::RayKind;

#[cfg(feature = "embree")]
use super::measure::CLOCK;
use super::measure::{Other, Who};
use crate::ctx::Ctx;
use crate::table::CsvOut;

/// Embree's packets of one width, packed before timing.
#[cfg(feature = "embree")]
enum EmbreePackets {
    W4(Vec<coherent::embree::PacketK<4>>),
    W8(Vec<coherent::embree::PacketK<8>>),
    W16(Vec<coherent::embree::PacketK<16>>),
}

#[cfg(feature = "embree")]
impl EmbreePackets {
    fn new(e: &coherent::embree::Embree, rays: &[Ray1], width: usize) -> Option<Self> {
        use coherent::embree::PacketK;
        Some(match width {
            4 => Self::W4(PacketK::pack_all(e, rays)),
            8 => Self::W8(PacketK::pack_all(e, rays)),
            16 => Self::W16(PacketK::pack_all(e, rays)),
            _ => return None,
        })
    }

    /// One timed pass: the harness (`plain` false: per packet reset, query, read back every
    /// lane's answer, the same work the BSP's rows do) or the plain C-API loop (`plain`:
    /// reset and query only).
    fn pass(&mut self, e: &coherent::embree::Embree, occlusion: bool, plain: bool) -> PassResult {
        match self {
            Self::W4(p) => embree_pass(e, p, occlusion, plain),
            Self::W8(p) => embree_pass(e, p, occlusion, plain),
            Self::W16(p) => embree_pass(e, p, occlusion, plain),
        }
    }
}

#[cfg(feature = "embree")]
fn embree_pass<const K: usize>(
    e: &coherent::embree::Embree,
    packets: &mut [coherent::embree::PacketK<K>],
    occlusion: bool,
    plain: bool,
) -> PassResult {
    use std::hint::black_box;
    let t0 = CLOCK.now();
    if plain {
        e.trace_plain(black_box(packets), occlusion);
        return PassResult {
            seconds: CLOCK.now() - t0,
            ..PassResult::default()
        };
    }
    // Per-lane sums of `t`, added up after the clock stops, as `TimePackets` does for the
    // other structures' packets.
    let (hits, t_acc) = e.trace_read(black_box(packets), occlusion);
    let seconds = CLOCK.now() - t0;
    PassResult {
        seconds,
        hits,
        t_sum: t_acc.iter().map(|&t| f64::from(t)).sum(),
    }
}

/// Embree's own packets per packet width of one scene and ray kind, and the plain-loop and
/// trait-path samples timed beside its harness rows.
pub(super) struct Packed<'a> {
    /// Embree's index in `others`, Embree, and its packets per width (`None`: single rays).
    #[cfg(feature = "embree")]
    embree: Option<(
        usize,
        &'a coherent::embree::Embree,
        Vec<Option<EmbreePackets>>,
    )>,
    #[cfg(not(feature = "embree"))]
    embree: core::marker::PhantomData<&'a ()>,
}

impl<'a> Packed<'a> {
    /// Packs `sets[i]` (the rays of `widths[i]`) into Embree's packets, if Embree is among
    /// `others`.
    #[cfg_attr(not(feature = "embree"), allow(unused_variables))]
    pub(super) fn new(
        others: &'a [Other],
        widths: &[(usize, Option<Backend>)],
        sets: &[Vec<Ray1>],
    ) -> Self {
        #[cfg(feature = "embree")]
        let embree = others.iter().enumerate().find_map(|(k, o)| match &o.accel {
            AnyAccel::Embree(e) => {
                let packs = widths
                    .iter()
                    .zip(sets)
                    .map(|(&(wd, _), rays)| EmbreePackets::new(e, rays, wd))
                    .collect();
                Some((k, e, packs))
            }
            #[allow(unreachable_patterns)]
            _ => None,
        });
        #[cfg(not(feature = "embree"))]
        let embree = core::marker::PhantomData;
        Self { embree }
    }

    /// The samples timed beside Embree's harness rows: per packet width, the plain C-API
    /// loop and the `Accel` trait path.
    pub(super) fn variants(&self) -> Vec<(Who, usize)> {
        #[cfg(feature = "embree")]
        if let Some((k, _, packs)) = &self.embree {
            return (0..packs.len())
                .filter(|&i| packs[i].is_some())
                .flat_map(|i| [(Who::EmbreePlain(*k), i), (Who::EmbreeTrait(*k), i)])
                .collect();
        }
        Vec::new()
    }

    /// A pass over Embree's own packets of width `i`: the harness (`Who::Other` of Embree)
    /// or the plain loop (`Who::EmbreePlain`). `None` for everything else (single rays, the
    /// trait path), which goes through the `Accel` interface.
    #[cfg(feature = "embree")]
    pub(super) fn pass(&mut self, who: Who, i: usize, occlusion: bool) -> Option<PassResult> {
        let (k, e, packs) = self.embree.as_mut()?;
        let plain = match who {
            Who::Other(o) if o == *k => false,
            Who::EmbreePlain(_) => true,
            _ => return None,
        };
        Some(packs[i].as_mut()?.pass(e, occlusion, plain))
    }

    #[cfg(not(feature = "embree"))]
    pub(super) fn pass(
        &mut self,
        _: Who,
        _: usize,
        _: bool,
    ) -> Option<coherent_accel::workload::PassResult> {
        None
    }
}

/// The rows of `accel_embree.csv` for one scene and ray kind: Embree's harness rows beside
/// the plain C-API loop and the `Accel` trait path, from the samples `res` of `variants`.
#[cfg_attr(not(feature = "embree"), allow(unused_variables))]
pub(super) fn rows(
    emb: &mut CsvOut,
    scene: &str,
    kind: RayKind,
    widths: &[(usize, Option<Backend>)],
    sets: &[Vec<Ray1>],
    variants: &[(Who, usize)],
    res: &[(f64, coherent_accel::workload::PassResult)],
) -> anyhow::Result<()> {
    for (v, &(who, i)) in variants.iter().enumerate() {
        let Who::EmbreePlain(k) = who else { continue };
        let find = |want: Who| {
            variants
                .iter()
                .position(|&(x, j)| x == want && j == i)
                .map(|p| sets[i].len() as f64 / res[p].0 / 1e6)
        };
        let (Some(harness), Some(tr)) = (find(Who::Other(k)), find(Who::EmbreeTrait(k))) else {
            continue;
        };
        let plain = sets[i].len() as f64 / res[v].0 / 1e6;
        emb.row(&[
            &scene,
            &kind.name(),
            &widths[i].0,
            &format!("{harness:.3}"),
            &format!("{plain:.3}"),
            &format!("{tr:.3}"),
            &format!("{:.3}", harness / plain),
        ])?;
    }
    Ok(())
}

/// Writes what Embree runs here into `machine.json` (key `embree`: version, isa,
/// native_packets; see [`crate::machine_keys`]) and notes it.
pub(super) fn record(ctx: &mut Ctx) {
    #[cfg(feature = "embree")]
    {
        let path = ctx.path("machine.json");
        let Ok(text) = std::fs::read_to_string(&path) else {
            return;
        };
        match coherent::embree::info() {
            Ok(i) => {
                ctx.note(format!(
                    "accel: Embree {} runs its {} kernels here, native packets of {:?}",
                    i.version, i.isa, i.native_packets
                ));
                let value = serde_json::json!({
                    "version": i.version,
                    "isa": i.isa,
                    "native_packets": i.native_packets,
                });
                let text = crate::machine_keys::set_key(&text, "embree", &value.to_string());
                let _ = std::fs::write(&path, text);
            }
            Err(e) => ctx.note(format!("accel: no Embree to describe: {e}")),
        }
    }
    #[cfg(not(feature = "embree"))]
    let _ = ctx;
}
