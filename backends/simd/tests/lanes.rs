//! Lane equivalence: every operation of the lane trait on every backend equals the scalar
//! backend lane by lane (the semantics fixed in `coherent_simd::lanes`), over random values
//! biased to NaN, ±inf, ±0 and denormals, in every lane position. The scalar backend itself
//! is the reference: it runs only the checks against exact values and against its own other
//! operations (`rsqrt`/`recip` bounds, `mul_add`, reductions, mask folds), never against itself.
//!
//! Bit-exact for IEEE operations; NaN results must be NaN on both (Rust leaves NaN payloads
//! unspecified). `rsqrt`/`recip` are checked against their stated relative bounds and
//! `mul_add` against the fused and the unfused result. Backends this CPU cannot run are
//! skipped with their reason printed, and fail the run when `COHERENT_REQUIRE_BACKENDS`
//! names them.

#![allow(clippy::needless_range_loop)] // lane-indexed comparisons read best as index loops

use coherent_simd::lanes::{RECIP_REL_ERROR, RSQRT_REL_ERROR};
use coherent_simd::{Backend, Kernel, Lanes, SimdF32, SimdI32, SimdMask};
use proptest::prelude::*;

/// Values per test case: a multiple of every lane count.
const LEN: usize = 16;

#[derive(Clone, Debug)]
struct Inputs {
    a: [f32; LEN],
    b: [f32; LEN],
    c: [f32; LEN],
    ia: [i32; LEN],
    ib: [i32; LEN],
    mask_bits: u32,
    shift: u32,
}

/// Every operation's result per lane, as bits, by name.
type Results = Vec<(&'static str, Vec<u32>)>;

struct Ops<'a>(&'a Inputs);

impl Kernel for Ops<'_> {
    type Output = Results;
    const BACKENDS: u32 = Backend::WITH_FACTORS;
    fn run<L: Lanes>(self, l: L) -> Results {
        let inp = self.0;
        let mut out: Results = Vec::new();
        for p in (0..LEN).step_by(L::N) {
            let a = l.load(&inp.a[p..]);
            let b = l.load(&inp.b[p..]);
            let c = l.load(&inp.c[p..]);
            let ia = l.load_i32(&inp.ia[p..]);
            let ib = l.load_i32(&inp.ib[p..]);
            let m = l.mask_from_bits(inp.mask_bits >> p);
            let mut push = |name, v| push_to(&mut out, name, v);
            let (fb, ib_, mb) = (f_bits::<L>, i_bits::<L>, m_bits::<L>);

            push("add", fb(a + b));
            push("sub", fb(a - b));
            push("mul", fb(a * b));
            push("div", fb(a / b));
            push("add_f32", fb(a + inp.b[0]));
            push("mul_f32", fb(a * inp.b[0]));
            push("neg", fb(-a));
            push("abs", fb(a.abs()));
            push("sqrt", fb(a.sqrt()));
            push("min", fb(a.min(b)));
            push("max", fb(a.max(b)));
            push("floor", fb(a.floor()));
            push("round", fb(a.round()));
            push("copysign", fb(a.copysign(b)));
            push("to_i32", ib_(a.to_i32()));
            push("to_bits", ib_(a.to_bits()));
            push("lt", mb(a.lt(b)));
            push("le", mb(a.le(b)));
            push("gt", mb(a.gt(b)));
            push("ge", mb(a.ge(b)));
            push("eq", mb(a.eq(b)));
            push("ne", mb(a.ne(b)));
            push("is_nan", mb(a.is_nan()));
            push("select", fb(m.select(a, b)));
            push("select_cmp", fb(a.lt(b).select(a, c)));
            push("select_i32", ib_(m.select_i32(ia, ib)));
            push("splat", fb(l.splat(inp.c[0])));
            push("lane_ids", ib_(l.lane_ids() + l.splat_i32(p as i32)));

            push("i_add", ib_(ia + ib));
            push("i_sub", ib_(ia - ib));
            push("i_mul", ib_(ia * ib));
            push("i_and", ib_(ia & ib));
            push("i_or", ib_(ia | ib));
            push("i_xor", ib_(ia ^ ib));
            push("i_not", ib_(!ia));
            push("i_shl", ib_(ia << inp.shift));
            push("i_shr", ib_(ia >> inp.shift));
            push("i_shr_logical", ib_(ia.shr_logical(inp.shift)));
            push("i_eq", mb(ia.eq(ib)));
            push("i_lt", mb(ia.lt(ib)));
            push("i_gt", mb(ia.gt(ib)));
            push("i_min", ib_(ia.min(ib)));
            push("i_max", ib_(ia.max(ib)));
            push("i_to_f32", fb(ia.to_f32()));
            push("i_bits_to_f32", fb(ia.bits_to_f32()));

            let m2 = a.lt(b);
            push("m_and", mb(m & m2));
            push("m_or", mb(m | m2));
            push("m_xor", mb(m ^ m2));
            push("m_not", mb(!m));
            push("m_and_not", mb(m.and_not(m2)));
            push("m_any", vec![m.any() as u32]);
            push("m_all", vec![m.all() as u32]);
            push("m_none", vec![m.none() as u32]);
            push("m_count", vec![m.count()]);
            push("m_bitmask", vec![m.bitmask()]);
            push("m_splat", mb(l.splat_mask(inp.mask_bits & 1 == 1)));

            gathers(l, inp, ia, ib, m, m2, b, c, &mut out);
            stores(l, inp, p, a, ia, m, &mut out);
            let mut push = |name, v| push_to(&mut out, name, v);
            // Approximate operations and reductions are compared separately (see below).
            push("~rsqrt", fb(a.rsqrt()));
            push("~recip", fb(a.recip()));
            push("~mul_add", fb(a.mul_add(b, c)));
            let finite = a.is_nan().select(l.splat(0.0), a);
            push("~reduce_min", vec![finite.reduce_min().to_bits()]);
            push("~reduce_max", vec![finite.reduce_max().to_bits()]);
        }
        out
    }
}

/// Adds `v` to the results of `name`.
fn push_to(out: &mut Results, name: &'static str, v: Vec<u32>) {
    match out.iter_mut().find(|(n, _)| *n == name) {
        Some((_, all)) => all.extend(v),
        None => out.push((name, v)),
    }
}

fn f_bits<L: Lanes>(v: L::F32s) -> Vec<u32> {
    (0..L::N).map(|i| v.lane(i).to_bits()).collect()
}

fn i_bits<L: Lanes>(v: L::I32s) -> Vec<u32> {
    (0..L::N).map(|i| v.lane(i) as u32).collect()
}

fn m_bits<L: Lanes>(v: L::Mask) -> Vec<u32> {
    (0..L::N).map(|i| v.lane(i) as u32).collect()
}

/// The gathers and `pick8`, on indices made from `ia` and `ib`.
#[allow(clippy::too_many_arguments)]
fn gathers<L: Lanes>(
    l: L,
    inp: &Inputs,
    ia: L::I32s,
    ib: L::I32s,
    m: L::Mask,
    m2: L::Mask,
    b: L::F32s,
    c: L::F32s,
    out: &mut Results,
) {
    let mut push = |name, v| push_to(out, name, v);
    let (fb, ib_) = (f_bits::<L>, i_bits::<L>);
    // Gathers from a table indexed by the clamped integers.
    let table: Vec<f32> = (0..37).map(|k| inp.c[k % LEN] + k as f32).collect();
    let table_u: Vec<u32> = (0..37)
        .map(|k| (inp.ia[k % LEN] as u32) ^ k as u32)
        .collect();
    let idx = ia.max(l.splat_i32(0)).min(l.splat_i32(36));
    let idx = (idx & l.splat_i32(63)).min(l.splat_i32(36));
    push("gather", fb(l.gather(&table, idx)));
    push("gather_u32", ib_(l.gather_u32(&table_u, idx)));
    let idx2 = idx.min(l.splat_i32(35));
    let (lo, hi) = l.gather2(&table, idx2);
    push("gather2_lo", fb(lo));
    push("gather2_hi", fb(hi));
    // gather2_near: indices close together, some near the table's end, which the
    // avx512 backend reads through a window of 32 values of the table instead of lane
    // by lane; a wider spread takes the hardware gather.
    let near_table: Vec<f32> = (0..80).map(|k| inp.c[k % LEN] + k as f32).collect();
    let spread = if inp.mask_bits & 1 == 1 { 7 } else { 31 };
    let near =
        (l.splat_i32(inp.shift as i32 * 2) + (ib & l.splat_i32(spread))).min(l.splat_i32(78));
    push("gather_near", fb(l.gather_near(&near_table, near)));
    // the last value of the table too: a single lookup's window reaches it
    let last = near.max(l.splat_i32(inp.shift as i32 % 2 + 78));
    push("gather_near_last", fb(l.gather_near(&near_table, last)));
    push("gather_near_far", fb(l.gather_near(&table, idx2)));
    push(
        "gather_near_short",
        fb(l.gather_near(&table[..20], idx2.min(l.splat_i32(19)))),
    );
    let (lo, hi) = l.gather2_near(&near_table, near);
    push("gather2_near_lo", fb(lo));
    push("gather2_near_hi", fb(hi));
    let (lo, hi) = l.gather2_near(&table, idx2);
    push("gather2_near_far_lo", fb(lo));
    push("gather2_near_far_hi", fb(hi));
    // A table shorter than the window: read whole (masked loads), any spread.
    let (lo, hi) = l.gather2_near(&table[..20], idx2.min(l.splat_i32(18)));
    push("gather2_near_short_lo", fb(lo));
    push("gather2_near_short_hi", fb(hi));

    // One of eight values by three masks (a lane permute on avx2 and avx512).
    let mut eight = [0.0f32; 8];
    for (k, e) in eight.iter_mut().enumerate() {
        *e = inp.c[k] + k as f32;
    }
    push("pick8", fb(l.pick8(&eight, m, m2, b.lt(c))));
}

/// Stores, masked stores and round trips through slices, at packet `p`.
fn stores<L: Lanes>(
    l: L,
    inp: &Inputs,
    p: usize,
    a: L::F32s,
    ia: L::I32s,
    m: L::Mask,
    out: &mut Results,
) {
    let mut push = |name, v| push_to(out, name, v);
    let (fb, ib_, mb) = (f_bits::<L>, i_bits::<L>, m_bits::<L>);
    // Stores, masked stores and round trips through slices.
    let mut buf = inp.c;
    a.store_masked(m, &mut buf[p..]);
    push(
        "store_masked",
        buf[p..p + L::N].iter().map(|x| x.to_bits()).collect(),
    );
    let mut buf = [0.0f32; LEN];
    a.store(&mut buf[p..]);
    push(
        "store",
        buf[p..p + L::N].iter().map(|x| x.to_bits()).collect(),
    );
    let mut ibuf = [0i32; LEN];
    ia.store(&mut ibuf[p..]);
    push(
        "store_i32",
        ibuf[p..p + L::N].iter().map(|&x| x as u32).collect(),
    );
    push("from_fn", fb(l.from_fn(|i| inp.a[p + i] * 2.0)));
    push("from_fn_i32", ib_(l.from_fn_i32(|i| inp.ia[p + i] ^ 5)));
    push("mask_from_fn", mb(l.mask_from_fn(|i| inp.a[p + i] > 0.0)));
}

fn same_bits(x: u32, y: u32) -> bool {
    let (fx, fy) = (f32::from_bits(x), f32::from_bits(y));
    x == y || (fx.is_nan() && fy.is_nan())
}

fn close_rel(x: f32, got: f32, exact: f32, bound: f32) -> bool {
    if x != 0.0 && x.abs() < f32::MIN_POSITIVE {
        // The estimate instructions treat denormal inputs as zero (documented in lanes.rs).
        return got.is_infinite()
            || (got.is_nan() && exact.is_nan())
            || ((got as f64 - exact as f64) / exact as f64).abs() <= bound as f64;
    }
    if exact.is_nan() {
        return got.is_nan();
    }
    if exact.is_infinite() || exact == 0.0 {
        // rsqrt(0) = inf, recip(inf) = 0: the hardware is exact at these points.
        return got == exact
            || (got.is_infinite() && exact.is_infinite() && got.signum() == exact.signum());
    }
    if exact.abs() < f32::MIN_POSITIVE * 4.0 || exact.abs() > f32::MAX / 4.0 {
        // Denormal and near-overflow results of the estimate instructions flush or saturate.
        return true;
    }
    ((got as f64 - exact as f64) / exact as f64).abs() <= bound as f64
}

fn check(backend: Backend, inp: &Inputs) -> Result<(), TestCaseError> {
    let Ok(got) = backend.run(Ops(inp)) else {
        return Ok(()); // unavailable: reported once by `report_skips`
    };
    let want = Backend::Scalar.run(Ops(inp)).unwrap();
    for ((name, g), (wname, w)) in got.iter().zip(&want) {
        prop_assert_eq!(name, wname);
        let n = g.len();
        match *name {
            "m_any" | "m_all" | "m_none" | "m_count" | "m_bitmask" => {
                // One value per packet: fold the scalar per-lane results over the packet.
                let lanes = backend.lanes();
                let bits = |p: usize| {
                    (0..lanes).fold(0u32, |acc, i| {
                        acc | (w_bit(&want, "m_bitmask", p * lanes + i) << i)
                    })
                };
                for p in 0..n {
                    let b = bits(p);
                    let full = if lanes == 32 {
                        u32::MAX
                    } else {
                        (1u32 << lanes) - 1
                    };
                    let expect = match *name {
                        "m_any" => (b != 0) as u32,
                        "m_all" => (b == full) as u32,
                        "m_none" => (b == 0) as u32,
                        "m_count" => b.count_ones(),
                        _ => b,
                    };
                    prop_assert_eq!(g[p], expect, "{} on {}, packet {}", name, backend, p);
                }
            }
            "~reduce_min" | "~reduce_max" => {
                let lanes = backend.lanes();
                for p in 0..n {
                    let vals = (0..lanes).map(|i| {
                        let x = inp.a[p * lanes + i];
                        if x.is_nan() { 0.0 } else { x }
                    });
                    let expect = if *name == "~reduce_min" {
                        vals.fold(f32::INFINITY, f32::min)
                    } else {
                        vals.fold(f32::NEG_INFINITY, f32::max)
                    };
                    // Equal as numbers: the sign of a zero result is unspecified.
                    prop_assert!(
                        f32::from_bits(g[p]) == expect,
                        "{} on {}: {} vs {}",
                        name,
                        backend,
                        f32::from_bits(g[p]),
                        expect
                    );
                }
            }
            "~rsqrt" | "~recip" => {
                for i in 0..n {
                    let x = inp.a[i] as f64;
                    let (exact, bound) = if *name == "~rsqrt" {
                        ((1.0 / x.sqrt()) as f32, RSQRT_REL_ERROR)
                    } else {
                        ((1.0 / x) as f32, RECIP_REL_ERROR)
                    };
                    let g = f32::from_bits(g[i]);
                    prop_assert!(
                        close_rel(inp.a[i], g, exact, bound),
                        "{} on {} lane {}: {}({}) = {}, exact {}",
                        name,
                        backend,
                        i,
                        name,
                        x,
                        g,
                        exact
                    );
                }
            }
            "~mul_add" => {
                for i in 0..n {
                    let (a, b, c) = (inp.a[i], inp.b[i], inp.c[i]);
                    let unfused = a * b + c;
                    let fused = a.mul_add(b, c);
                    prop_assert!(
                        same_bits(g[i], unfused.to_bits()) || same_bits(g[i], fused.to_bits()),
                        "mul_add on {} lane {}: {} * {} + {} = {}",
                        backend,
                        i,
                        a,
                        b,
                        c,
                        f32::from_bits(g[i])
                    );
                }
            }
            // The scalar backend is the reference these lanes are compared with.
            _ if backend == Backend::Scalar => {}
            _ => {
                prop_assert_eq!(n, w.len(), "{} on {}", name, backend);
                for i in 0..n {
                    prop_assert!(
                        same_bits(g[i], w[i]),
                        "{} on {} lane {}: {:#010x} ({}) vs scalar {:#010x} ({}); inputs a={} b={} ia={} ib={}",
                        name,
                        backend,
                        i,
                        g[i],
                        f32::from_bits(g[i]),
                        w[i],
                        f32::from_bits(w[i]),
                        inp.a[i],
                        inp.b[i],
                        inp.ia[i],
                        inp.ib[i]
                    );
                }
            }
        }
    }
    Ok(())
}

fn w_bit(want: &Results, name: &str, lane: usize) -> u32 {
    want.iter().find(|(n, _)| *n == name).unwrap().1[lane] & 1
}

/// Floats biased to the values where backends disagree if they are going to.
fn special_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => -1e3f32..1e3,
        2 => any::<u32>().prop_map(f32::from_bits),
        1 => (1u32..0x80_0000).prop_map(f32::from_bits),
        1 => (1u32..0x80_0000).prop_map(|b| -f32::from_bits(b)),
        1 => prop::sample::select(vec![
            0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, -f32::NAN,
            f32::from_bits(0x7f80_0001), // signalling NaN
            0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 8388608.0, -8388607.5, 2147483648.0, -2147483648.0,
            f32::MAX, f32::MIN, f32::MIN_POSITIVE, 1e-40,
        ]),
        1 => (-100i32..100).prop_map(|i| i as f32 + 0.5),
    ]
}

fn special_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        3 => -100i32..100,
        2 => any::<i32>(),
        1 => prop::sample::select(vec![0, -1, 1, i32::MIN, i32::MAX, i32::MIN + 1]),
    ]
}

fn inputs() -> impl Strategy<Value = Inputs> {
    (
        prop::array::uniform16(special_f32()),
        prop::array::uniform16(special_f32()),
        prop::array::uniform16(special_f32()),
        prop::array::uniform16(special_i32()),
        prop::array::uniform16(special_i32()),
        any::<u32>(),
        0u32..32,
    )
        .prop_map(|(a, b, c, ia, ib, mask_bits, shift)| Inputs {
            a,
            b,
            c,
            ia,
            ib,
            mask_bits,
            shift,
        })
}

#[test]
fn report_skips() {
    // Prints the skipped backends; fails if COHERENT_REQUIRE_BACKENDS names one of them.
    let usable = Backend::usable();
    assert!(usable.contains(&Backend::Scalar));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    /// Every backend the crate has, from `Backend::every()`: a new backend is stamped here
    /// without a line of its own.
    #[test]
    fn every_operation_equals_scalar(inp in inputs()) {
        for b in Backend::every() {
            check(b, &inp).map_err(|e| TestCaseError::fail(format!("backend {b}: {e}")))?;
        }
    }
}

/// A backend's lane count and a sum over its lanes, computed with its own instructions.
struct Width;

impl Kernel for Width {
    type Output = (usize, i32);
    const BACKENDS: u32 = Backend::WITH_FACTORS;
    fn run<L: Lanes>(self, l: L) -> (usize, i32) {
        let v = l.lane_ids() + l.splat_i32(1);
        (L::N, (0..L::N).map(|i| v.lane(i)).sum())
    }
}

/// Every backend reported usable runs a kernel on this CPU with its own lane count (a
/// backend listed without its instructions would stop the test with an illegal
/// instruction), and every other refuses to run it with a reason.
#[test]
fn usable_backends_run_here_and_the_others_refuse() {
    let usable = Backend::usable();
    for b in Backend::every() {
        let listed = usable.contains(&b) || (Backend::FACTORS.contains(&b) && b.is_available());
        match b.run(Width) {
            Ok((n, sum)) => {
                assert!(listed, "{b} ran, yet it is not listed as usable here");
                assert_eq!(n, b.lanes(), "{b}");
                assert_eq!(sum as usize, n * (n + 1) / 2, "{b}");
            }
            Err(e) => {
                assert!(!listed, "{b} is listed as usable, yet: {e}");
                assert!(e.to_string().contains(b.name()), "{e}");
            }
        }
    }
}

/// `pick8` by every combination of three masks, lanes mixed, on one backend: lane `i`
/// takes entry `4 first + 2 second + third` of the table.
struct Pick8;

impl Kernel for Pick8 {
    type Output = ();
    fn run<L: Lanes>(self, l: L) {
        let table = [
            0.5f32,
            -1.0,
            2.25,
            f32::INFINITY,
            -0.0,
            7.0,
            f32::MIN_POSITIVE,
            3e9,
        ];
        for bits in 0..1u32 << 12 {
            // Three masks of up to 16 lanes from the low bits, spread over the lanes.
            let spread = |shift: u32| (bits >> shift & 0xf).wrapping_mul(0x1111);
            let (f, s, t) = (spread(0), spread(4), spread(8));
            let got = l.pick8(
                &table,
                l.mask_from_bits(f),
                l.mask_from_bits(s),
                l.mask_from_bits(t),
            );
            for i in 0..L::N {
                let at = 4 * (f >> i & 1) + 2 * (s >> i & 1) + (t >> i & 1);
                assert_eq!(
                    got.lane(i).to_bits(),
                    table[at as usize].to_bits(),
                    "lane {i} of {}-lane pick8, masks {f:#x} {s:#x} {t:#x}",
                    L::N
                );
            }
        }
    }
}

#[test]
fn pick8_picks_by_the_three_masks() {
    for backend in Backend::usable() {
        backend.run(Pick8).unwrap();
    }
}

/// One gather with lane `bad` (of the first `L::N`) set to `index`, the others in range.
struct BadGather {
    which: u32,
    /// Table length.
    len: usize,
    bad: usize,
    index: i32,
}

impl Kernel for BadGather {
    type Output = ();
    fn run<L: Lanes>(self, l: L) {
        let table = vec![1.0f32; self.len];
        let table_u = vec![1u32; self.len];
        let mut idx = [1i32; 16];
        idx[self.bad % L::N] = self.index;
        let idx = l.load_i32(&idx);
        match self.which {
            0 => std::hint::black_box(l.gather(&table, idx).lane(0)).to_bits(),
            1 => std::hint::black_box(l.gather_u32(&table_u, idx).lane(0)) as u32,
            2 => std::hint::black_box(l.gather2(&table, idx).0.lane(0)).to_bits(),
            3 => std::hint::black_box(l.gather2_near(&table, idx).0.lane(0)).to_bits(),
            _ => std::hint::black_box(l.gather_near(&table, idx).lane(0)).to_bits(),
        };
    }
}

#[test]
fn gathers_outside_the_table_panic_with_the_index() {
    // Every backend checks its gather indices (bad input must not read out of bounds) and
    // names the offending index; gather2 reads `i + 1` too, so `len - 1` is outside it.
    // Tables of 8 are shorter than the near gathers' window; in tables of 40 the other lanes'
    // indices (1) and the window lie inside the table.
    for backend in Backend::usable() {
        for which in 0..5 {
            for table_len in [8, 40] {
                let len = if which == 2 || which == 3 {
                    table_len - 1
                } else {
                    table_len
                } as i32;
                for (bad, index) in [(0, -1), (3, len), (15, i32::MAX), (5, i32::MIN)] {
                    let result = std::panic::catch_unwind(|| {
                        backend.run(BadGather {
                            which,
                            len: table_len,
                            bad,
                            index,
                        })
                    });
                    let err = result.expect_err(&format!(
                        "{backend}: gather {which} of {index} (table of {table_len}) did not panic"
                    ));
                    let msg = err
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| err.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    assert!(
                        msg.contains(&format!("gather index {index} outside a table of")),
                        "{backend}: gather {which}: {msg:?}"
                    );
                }
            }
        }
    }
}

/// Every mask reduction on the patterns random bits rarely give at 8 and 16 lanes: no lane
/// on, every lane on, one lane on, every lane but one on; from `mask_from_bits` and from a
/// compare. The reductions are written per backend, and pulp's depend on how LLVM reads
/// them (`backends/simd/src/pulp.rs`). `None` when they all hold, else the first failure.
struct MaskPatterns;

impl Kernel for MaskPatterns {
    type Output = Option<String>;
    fn run<L: Lanes>(self, l: L) -> Option<String> {
        let n = L::N;
        let full = u32::MAX >> (32 - n);
        let mut patterns = vec![0, full];
        for i in 0..n {
            patterns.push(1 << i);
            patterns.push(full & !(1 << i));
        }
        for bits in patterns {
            let signs = l.from_fn(|i| if bits >> i & 1 == 1 { 1.0 } else { -1.0 });
            for (how, m) in [
                ("mask_from_bits", l.mask_from_bits(bits)),
                ("compare", signs.gt(l.splat(0.0))),
            ] {
                let got = (m.bitmask(), m.any(), m.all(), m.none());
                let want = (bits, bits != 0, bits == full, bits == 0);
                if got != want {
                    return Some(format!(
                        "{how} {bits:b}: (bitmask, any, all, none) = {got:?}, want {want:?}"
                    ));
                }
            }
        }
        None
    }
}

#[test]
fn mask_reductions_on_full_empty_and_single_lane_masks() {
    for backend in Backend::usable() {
        if let Some(failure) = backend.run(MaskPatterns).expect("usable backend") {
            panic!("{backend}: {failure}");
        }
    }
}
