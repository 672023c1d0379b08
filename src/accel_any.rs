//! The accelerator chosen at run time (paper section 3's traversal behind one interface): an
//! enum over the BSP, Embree, obvhs and brute force that implements [`Accel`] by one `match`
//! per method (pbrt-v4's tagged dispatch), built by name (`--accel bsp|embree|obvhs|brute`).
//! Nothing else in the renderer names an accelerator.

use core::fmt;
use core::str::FromStr;

use coherent_accel::{
    Accel, AccelError, BruteForce, BuildStats, Hit1, Hits, Instance, Ray1, Rays, Scene, Work,
};
use coherent_bsp::{Bsp, BspParams};
use coherent_simd::Lanes;

/// The accelerators, by the names used on the command line and in results files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum AccelKind {
    /// The paper's two-level BSP (always compiled in).
    #[default]
    Bsp,
    /// Embree 4 (cargo feature `embree`, library loaded at run time).
    Embree,
    /// obvhs CWBVH (cargo feature `obvhs`), single-ray traversal.
    Obvhs,
    /// Every triangle against every ray: the reference for tests (small scenes only).
    Brute,
}

/// A name that is no accelerator, or one this build or machine cannot use.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AccelChoiceError {
    #[error("unknown accelerator `{name}`; accelerators: {all}; usable here: {available}")]
    Unknown {
        name: String,
        all: String,
        available: String,
    },
    #[error(
        "accelerator `{kind}` is not compiled in: build with the cargo feature `{kind}`; usable here: {available}"
    )]
    NotCompiled { kind: AccelKind, available: String },
}

impl AccelKind {
    /// Every accelerator.
    pub const ALL: [AccelKind; 4] = [
        AccelKind::Bsp,
        AccelKind::Embree,
        AccelKind::Obvhs,
        AccelKind::Brute,
    ];

    /// The name used on the command line and in results files.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Bsp => "bsp",
            AccelKind::Embree => "embree",
            AccelKind::Obvhs => "obvhs",
            AccelKind::Brute => "brute",
        }
    }

    /// The accelerators experiments and benches compare: every one but brute force, the
    /// tests' reference.
    pub fn compared() -> impl Iterator<Item = AccelKind> {
        Self::ALL.into_iter().filter(|&k| k != AccelKind::Brute)
    }

    /// Whether it traverses packets itself. obvhs answers a packet lane by lane, so timing
    /// its packets would time that loop.
    pub fn has_packets(self) -> bool {
        self != AccelKind::Obvhs
    }

    /// Whether this build has it.
    pub fn compiled(self) -> bool {
        match self {
            AccelKind::Bsp | AccelKind::Brute => true,
            AccelKind::Embree => cfg!(feature = "embree"),
            AccelKind::Obvhs => cfg!(feature = "obvhs"),
        }
    }

    /// Why it cannot be built here (not compiled in, Embree's library missing), or `None`.
    pub fn unavailable_reason(self) -> Option<String> {
        if !self.compiled() {
            return Some(format!(
                "not compiled in: build with the cargo feature `{}`",
                self.name()
            ));
        }
        #[cfg(feature = "embree")]
        if self == AccelKind::Embree {
            return coherent_embree::unavailable_reason();
        }
        None
    }

    /// What it is and whether it runs here, for `coherent info`.
    pub fn describe(self) -> String {
        match self {
            AccelKind::Bsp => "the paper's two-level BSP, packets of every backend's width".into(),
            #[cfg(feature = "embree")]
            AccelKind::Embree => match coherent_embree::version() {
                Ok(v) => format!(
                    "Embree {}.{}.{} (rtcGetDeviceProperty VERSION {v}), packets of 1, 4, 8, 16",
                    v / 10000,
                    v / 100 % 100,
                    v % 100
                ),
                Err(e) => format!("compiled in, not usable here: {e}"),
            },
            #[cfg(not(feature = "embree"))]
            AccelKind::Embree => format!("not compiled in (cargo feature `{}`)", self.name()),
            #[cfg(feature = "obvhs")]
            AccelKind::Obvhs => {
                "obvhs BVH2 / CWBVH, single rays (packets served lane by lane)".into()
            }
            #[cfg(not(feature = "obvhs"))]
            AccelKind::Obvhs => format!("not compiled in (cargo feature `{}`)", self.name()),
            AccelKind::Brute => {
                "every ray against every triangle: the reference the tests check the others by"
                    .into()
            }
        }
    }

    /// The accelerators that can be built here.
    pub fn available() -> Vec<AccelKind> {
        Self::ALL
            .into_iter()
            .filter(|k| k.unavailable_reason().is_none())
            .collect()
    }

    fn available_list() -> String {
        let v: Vec<&str> = Self::available().iter().map(|k| k.name()).collect();
        v.join(", ")
    }
}

impl fmt::Display for AccelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AccelKind {
    type Err = AccelChoiceError;

    /// A compiled-in accelerator by name (whether its library loads is found out when it is
    /// built: [`AccelError::Unavailable`]).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let kind = Self::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| AccelChoiceError::Unknown {
                name: s.to_owned(),
                all: Self::ALL.map(AccelKind::name).join(", "),
                available: Self::available_list(),
            })?;
        if !kind.compiled() {
            return Err(AccelChoiceError::NotCompiled {
                kind,
                available: Self::available_list(),
            });
        }
        Ok(kind)
    }
}

/// Which accelerator to build, and the build parameters of each (defaults: each one's
/// recommended setting).
#[derive(Clone, Debug, Default)]
pub struct AnyParams {
    pub kind: AccelKind,
    pub bsp: BspParams,
    #[cfg(feature = "embree")]
    pub embree: coherent_embree::EmbreeParams,
    #[cfg(feature = "obvhs")]
    pub obvhs: coherent_obvhs::ObvhsParams,
}

impl AnyParams {
    /// The default parameters of `kind`.
    pub fn of(kind: AccelKind) -> Self {
        Self {
            kind,
            ..Self::default()
        }
    }

    /// The parameters the experiments time `kind` with: its defaults, less what only
    /// all-hits queries need (Embree's filter-function scene flag), and `threads` build
    /// threads for a structure that takes a count (Embree; the others build in the caller's
    /// rayon pool).
    pub fn timed(kind: AccelKind, threads: usize) -> Self {
        let p = Self::of(kind);
        #[cfg(feature = "embree")]
        let p = Self {
            embree: coherent_embree::EmbreeParams {
                all_hits: false,
                threads: Some(threads),
                ..p.embree
            },
            ..p
        };
        let _ = threads;
        p
    }
}

/// Work done on the concrete accelerator inside an [`AnyAccel`] ([`AnyAccel::visit`]): a
/// timed loop over queries then runs without the enum's `match` per query.
pub trait AccelVisitor {
    type Output;
    fn visit<A: Accel>(self, accel: &A) -> Self::Output;
}

/// A built accelerator of any kind.
// One per render, built once: the BSP's size beside the others' costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum AnyAccel {
    Bsp(Bsp),
    #[cfg(feature = "embree")]
    Embree(coherent_embree::Embree),
    #[cfg(feature = "obvhs")]
    Obvhs(coherent_obvhs::Obvhs),
    Brute(BruteForce),
}

/// One `match` over the accelerators: `$a` is bound to the built structure in each arm.
macro_rules! dispatch {
    ($self:expr, $a:ident => $e:expr) => {
        match $self {
            AnyAccel::Bsp($a) => $e,
            #[cfg(feature = "embree")]
            AnyAccel::Embree($a) => $e,
            #[cfg(feature = "obvhs")]
            AnyAccel::Obvhs($a) => $e,
            AnyAccel::Brute($a) => $e,
        }
    };
}

impl AnyAccel {
    /// Builds the accelerator named `name` with its default parameters.
    pub fn build_named(scene: &Scene, name: &str) -> Result<Self, AnyBuildError> {
        let kind: AccelKind = name.parse()?;
        Ok(Self::build(scene, &AnyParams::of(kind))?)
    }

    /// Runs `v` on the concrete accelerator.
    pub fn visit<V: AccelVisitor>(&self, v: V) -> V::Output {
        dispatch!(self, a => v.visit(a))
    }

    /// Which accelerator this is.
    pub fn kind(&self) -> AccelKind {
        match self {
            AnyAccel::Bsp(_) => AccelKind::Bsp,
            #[cfg(feature = "embree")]
            AnyAccel::Embree(_) => AccelKind::Embree,
            #[cfg(feature = "obvhs")]
            AnyAccel::Obvhs(_) => AccelKind::Obvhs,
            AnyAccel::Brute(_) => AccelKind::Brute,
        }
    }

    /// Tells the accelerator whether every next packet is coherent (primary and shadow rays)
    /// or not (secondary rays): Embree's COHERENT flag, which it otherwise sets per packet
    /// by the packet's directions; the others ignore it.
    pub fn set_coherent(&mut self, on: bool) {
        #[cfg(feature = "embree")]
        if let AnyAccel::Embree(e) = self {
            e.set_coherent(on);
        }
        let _ = on;
    }
}

/// Building by name failed: a bad name, or the build itself.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AnyBuildError {
    #[error(transparent)]
    Choice(#[from] AccelChoiceError),
    #[error(transparent)]
    Build(#[from] AccelError),
}

impl Accel for AnyAccel {
    type Params = AnyParams;

    /// Builds `params.kind`. Embree without its library gives [`AccelError::Unavailable`];
    /// a kind this build lacks gives the same error naming the cargo feature.
    fn build(scene: &Scene, params: &AnyParams) -> Result<Self, AccelError> {
        Ok(match params.kind {
            AccelKind::Bsp => AnyAccel::Bsp(Bsp::build(scene, &params.bsp)?),
            AccelKind::Brute => AnyAccel::Brute(BruteForce::build(scene, &())?),
            #[cfg(feature = "embree")]
            AccelKind::Embree => {
                AnyAccel::Embree(coherent_embree::Embree::build(scene, &params.embree)?)
            }
            #[cfg(feature = "obvhs")]
            AccelKind::Obvhs => {
                AnyAccel::Obvhs(coherent_obvhs::Obvhs::build(scene, &params.obvhs)?)
            }
            #[allow(unreachable_patterns)]
            kind => {
                return Err(AccelError::Unavailable {
                    accel: kind.name(),
                    reason: format!(
                        "not compiled in: build with the cargo feature `{}`",
                        kind.name()
                    ),
                });
            }
        })
    }

    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        dispatch!(self, a => a.set_instances(instances))
    }

    fn name(&self) -> &'static str {
        dispatch!(self, a => a.name())
    }

    fn memory_bytes(&self) -> usize {
        dispatch!(self, a => a.memory_bytes())
    }

    fn stats(&self) -> BuildStats {
        dispatch!(self, a => a.stats())
    }

    fn intersect1(&self, ray: &Ray1) -> Option<Hit1> {
        dispatch!(self, a => a.intersect1(ray))
    }

    fn occluded1(&self, ray: &Ray1) -> bool {
        dispatch!(self, a => a.occluded1(ray))
    }

    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1)) {
        dispatch!(self, a => a.intersect_all1(ray, f))
    }

    #[inline(always)]
    fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        dispatch!(self, a => a.intersect(l, rays, active))
    }

    #[inline(always)]
    fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        dispatch!(self, a => a.occluded(l, rays, active))
    }

    #[inline(always)]
    fn intersect_all<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        dispatch!(self, a => a.intersect_all(l, rays, active, f))
    }

    fn counts_work(&self) -> bool {
        dispatch!(self, a => a.counts_work())
    }

    // Named through the trait: the BSP's own `intersect_counted` family takes its detailed
    // counters.
    #[inline(always)]
    fn intersect_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        work: &mut Work,
    ) -> Hits<L> {
        dispatch!(self, a => Accel::intersect_work(a, l, rays, active, work))
    }

    #[inline(always)]
    fn occluded_work<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        work: &mut Work,
    ) -> L::Mask {
        dispatch!(self, a => Accel::occluded_work(a, l, rays, active, work))
    }

    #[inline(always)]
    fn intersect_beam_work<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
        work: &mut Work,
    ) {
        dispatch!(self, a => Accel::intersect_beam_work(a, l, rays, active, hits, work))
    }

    #[inline(always)]
    fn intersect_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        dispatch!(self, a => a.intersect_beam(l, rays, active, hits))
    }

    #[inline(always)]
    fn occluded_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        dispatch!(self, a => a.occluded_beam(l, rays, active, occluded))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_accel::scenes::{self, SceneSize};

    #[test]
    fn names_round_trip_and_unknown_lists_the_usable_ones() {
        for k in AccelKind::ALL {
            if k.compiled() {
                assert_eq!(k.name().parse::<AccelKind>().unwrap(), k);
            }
        }
        let e = "kdtree".parse::<AccelKind>().unwrap_err().to_string();
        assert!(e.contains("unknown accelerator `kdtree`"), "{e}");
        assert!(e.contains("usable here: bsp"), "{e}");
    }

    #[test]
    fn every_usable_accelerator_agrees_with_brute_force() {
        let s = scenes::all(SceneSize::Quick).into_iter().next().unwrap();
        let brute = AnyAccel::build_named(&s.scene, "brute").unwrap();
        for k in AccelKind::ALL {
            let a = match AnyAccel::build(&s.scene, &AnyParams::of(k)) {
                Ok(a) => a,
                Err(AccelError::Unavailable { reason, .. }) => {
                    eprintln!("skipped accelerator {k}: {reason}");
                    continue;
                }
                Err(e) => panic!("{k}: {e}"),
            };
            assert_eq!(a.kind(), k);
            assert_eq!(a.name(), k.name());
            let mut hits = 0;
            for i in 0..64 {
                let r = s.view.primary_ray(i % 8, i / 8, 8, 8);
                let (x, y) = (a.intersect1(&r), brute.intersect1(&r));
                assert_eq!(x.is_some(), y.is_some(), "{k} ray {i}");
                if let (Some(x), Some(y)) = (x, y) {
                    hits += 1;
                    assert!((x.t - y.t).abs() <= 1e-3 * y.t.max(1.0), "{k} ray {i}");
                }
                assert_eq!(a.occluded1(&r), brute.occluded1(&r), "{k} ray {i}");
            }
            assert!(hits > 0, "{k}: the test rays hit nothing");
        }
    }
}
