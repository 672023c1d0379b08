//! Tests of the tabulated BDFs: exactness at nodes, convergence to the analytic model,
//! reciprocity, the file format and its errors.

use std::f64::consts::FRAC_PI_2;

use coherent_simd::Vec3s;
use coherent_simd::scalar::Scalar;
use rand::{Rng, SeedableRng, rngs::StdRng};

use super::analytic::{Analytic, Ward, direction};
use super::error::{BdfError, BdfProblem};
use super::format::{decode, encode, read, write};
use super::table::{AnisotropicBdf, Bdf, IsotropicBdf, Symmetry};
use super::tabulate::{PAPER_ANISOTROPIC_SHAPE, tabulate_anisotropic, tabulate_isotropic};
use crate::approx::{ACOS_ABS_ERROR, ATAN2_ABS_ERROR};
use crate::tabulated::{Axis, Grid};

fn isotropic_ward() -> Analytic {
    Analytic::Ward(Ward {
        diffuse: [0.2, 0.1, 0.05],
        specular: [0.5, 0.5, 0.4],
        alpha_x: 0.3,
        alpha_y: 0.3,
    })
}

/// A random unit direction above the surface, not closer than ~3 degrees to grazing.
fn random_dir(rng: &mut StdRng) -> [f64; 3] {
    let theta = rng.random_range(0.0..FRAC_PI_2 - 0.05);
    let phi = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    direction(theta, phi)
}

fn to_f32(w: [f64; 3]) -> Vec3s<Scalar> {
    Vec3s::new(w[0] as f32, w[1] as f32, w[2] as f32)
}

fn eval1(bdf: &Bdf, wi: [f64; 3], wo: [f64; 3]) -> [f32; 3] {
    bdf.eval(Scalar, &to_f32(wi), &to_f32(wo)).lane(0)
}

#[test]
fn grids_are_exact_at_nodes() {
    let aniso = tabulate_anisotropic(
        &Analytic::brushed_ward(),
        PAPER_ANISOTROPIC_SHAPE,
        Symmetry::Quadrant,
    )
    .unwrap();
    let g = aniso.grid();
    let [a0, a1, a2, a3] = g.axes();
    for (i, &x0) in a0.nodes().iter().enumerate() {
        for (j, &x1) in a1.nodes().iter().enumerate() {
            for (k, &x2) in a2.nodes().iter().enumerate().step_by(3) {
                for (m, &x3) in a3.nodes().iter().enumerate() {
                    let cells = g.locate(Scalar, [x0, x1, x2, x3]);
                    let mut out = [0.0; 3];
                    g.interpolate(Scalar, &cells, &mut out);
                    assert_eq!(&out[..], g.node([i, j, k, m]), "node {i} {j} {k} {m}");
                }
            }
        }
    }
    let iso = tabulate_isotropic(&Analytic::rough_ggx(), [9, 11, 13]).unwrap();
    let g = iso.grid();
    let [a0, a1, a2] = g.axes();
    for (i, &x0) in a0.nodes().iter().enumerate() {
        for (j, &x1) in a1.nodes().iter().enumerate() {
            for (k, &x2) in a2.nodes().iter().enumerate() {
                let cells = g.locate(Scalar, [x0, x1, x2]);
                let mut out = [0.0; 3];
                g.interpolate(Scalar, &cells, &mut out);
                assert_eq!(&out[..], g.node([i, j, k]), "node {i} {j} {k}");
            }
        }
    }
}

#[test]
fn evaluation_at_node_directions_gives_the_node() {
    // Through the angles: exact up to the angle approximation's error times the table's
    // steepest slope at the node (first order, with a margin of 1.5).
    let model = Analytic::rough_ggx();
    let bdf: Bdf = tabulate_anisotropic(&model, PAPER_ANISOTROPIC_SHAPE, Symmetry::Quadrant)
        .unwrap()
        .into();
    let Bdf::Anisotropic(b) = &bdf else {
        unreachable!()
    };
    let [ti, pi, to, po] = b.grid().axes().clone();
    for i in 1..ti.len() - 1 {
        // Not phi_i = pi/2: rounded, it may land just past the fold's mirror plane,
        // which mirrors phi_o to a place between nodes.
        for j in 0..pi.len() - 1 {
            for k in (1..to.len() - 1).step_by(2) {
                for m in 0..po.len() {
                    let wi = direction(ti.nodes()[i] as f64, pi.nodes()[j] as f64);
                    let wo = direction(to.nodes()[k] as f64, po.nodes()[m] as f64);
                    let got = eval1(&bdf, wi, wo);
                    let at = [i, j, k, m];
                    let want = b.grid().node(at);
                    let errs = [
                        ACOS_ABS_ERROR,
                        ATAN2_ABS_ERROR,
                        ACOS_ABS_ERROR,
                        ATAN2_ABS_ERROR,
                    ];
                    for c in 0..3 {
                        let tol: f32 = (0..4)
                            .map(|axis| slope(b.grid(), at, axis, c) * errs[axis])
                            .sum::<f32>()
                            * 1.5
                            + 1e-6 * want[c];
                        assert!(
                            (got[c] - want[c]).abs() <= tol,
                            "node {i} {j} {k} {m}: {got:?} vs {want:?}"
                        );
                    }
                }
            }
        }
    }
}

/// The steepest slope of channel `c` along `axis` in the cells either side of node `at`.
fn slope(g: &Grid<4>, at: [usize; 4], axis: usize, c: usize) -> f32 {
    let nodes = g.axes()[axis].nodes();
    let v = g.node(at)[c];
    let mut s = 0.0f32;
    for n in [at[axis].wrapping_sub(1), at[axis] + 1] {
        if n < nodes.len() {
            let mut other = at;
            other[axis] = n;
            s = s.max((g.node(other)[c] - v).abs() / (nodes[n] - nodes[at[axis]]).abs());
        }
    }
    s
}

/// Mean absolute error of the table against the model over random direction pairs,
/// relative to the model's mean.
fn relative_error(bdf: &Bdf, model: &Analytic, pairs: &[([f64; 3], [f64; 3])]) -> f64 {
    let (mut err, mut sum) = (0.0, 0.0);
    for &(wi, wo) in pairs {
        let got = eval1(bdf, wi, wo);
        let want = model.eval(wi, wo);
        for c in 0..3 {
            err += (got[c] as f64 - want[c]).abs();
            sum += want[c];
        }
    }
    err / sum
}

#[test]
fn tables_converge_to_the_model() {
    let mut rng = StdRng::seed_from_u64(7);
    let pairs: Vec<_> = (0..4000)
        .map(|_| (random_dir(&mut rng), random_dir(&mut rng)))
        .collect();

    let model = Analytic::brushed_ward();
    let mut errors = Vec::new();
    for shape in [
        [9, 4, 9, 7],
        [17, 7, 17, 13],
        [33, 13, 33, 25],
        [65, 25, 65, 49],
    ] {
        let bdf = tabulate_anisotropic(&model, shape, Symmetry::Quadrant)
            .unwrap()
            .into();
        errors.push(relative_error(&bdf, &model, &pairs));
    }
    for w in errors.windows(2) {
        assert!(
            w[1] < 0.6 * w[0],
            "anisotropic errors {errors:?} do not fall with refinement"
        );
    }
    assert!(errors[3] < 0.06, "anisotropic errors {errors:?}");

    let model = isotropic_ward();
    let mut errors = Vec::new();
    for n in [9, 17, 33, 65] {
        let bdf = tabulate_isotropic(&model, [n, n, n]).unwrap().into();
        errors.push(relative_error(&bdf, &model, &pairs));
    }
    for w in errors.windows(2) {
        assert!(
            w[1] < 0.6 * w[0],
            "isotropic errors {errors:?} do not fall with refinement"
        );
    }
    assert!(errors[3] < 0.01, "isotropic errors {errors:?}");
}

fn assert_reciprocal(bdf: &Bdf, rng: &mut StdRng) {
    for _ in 0..2000 {
        let (wi, wo) = (random_dir(rng), random_dir(rng));
        let a = eval1(bdf, wi, wo);
        let b = eval1(bdf, wo, wi);
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 1e-5 * a[c].abs().max(1.0),
                "{wi:?} {wo:?}: {a:?} vs {b:?}"
            );
        }
    }
}

#[test]
fn reciprocity_is_kept() {
    let mut rng = StdRng::seed_from_u64(11);
    // The models themselves are reciprocal.
    for model in [Analytic::brushed_ward(), Analytic::rough_ggx()] {
        for _ in 0..200 {
            let (wi, wo) = (random_dir(&mut rng), random_dir(&mut rng));
            let (a, b) = (model.eval(wi, wo), model.eval(wo, wi));
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-12 * a[c].max(1.0));
            }
        }
    }
    // Tables whose incoming and outgoing axes are the same keep it everywhere.
    let iso = tabulate_isotropic(&isotropic_ward(), [17, 17, 13])
        .unwrap()
        .into();
    assert_reciprocal(&iso, &mut rng);
    for model in [Analytic::brushed_ward(), Analytic::rough_ggx()] {
        let aniso = tabulate_anisotropic(&model, [17, 13, 17, 13], Symmetry::None)
            .unwrap()
            .into();
        assert_reciprocal(&aniso, &mut rng);
    }
}

fn sample_bdfs() -> Vec<Bdf> {
    vec![
        tabulate_anisotropic(&Analytic::brushed_ward(), [5, 3, 6, 7], Symmetry::Quadrant)
            .unwrap()
            .into(),
        tabulate_anisotropic(&Analytic::rough_ggx(), [4, 5, 4, 5], Symmetry::None)
            .unwrap()
            .into(),
        tabulate_isotropic(&isotropic_ward(), [4, 5, 6])
            .unwrap()
            .into(),
        // A one-channel table.
        IsotropicBdf::new(
            Grid::new(
                [
                    Axis::new(0, vec![0.0, 1.0]).unwrap(),
                    Axis::new(1, vec![0.0, 0.5, 1.5]).unwrap(),
                    Axis::new(2, vec![0.0, 3.0]).unwrap(),
                ],
                1,
                (0..12).map(|v| v as f32).collect(),
            )
            .unwrap(),
        )
        .unwrap()
        .into(),
    ]
}

#[test]
fn files_round_trip() {
    let dir = std::env::temp_dir().join(format!("coherent-bdf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (i, bdf) in sample_bdfs().into_iter().enumerate() {
        let path = dir.join(format!("t{i}.cbdf"));
        write(&path, &bdf).unwrap();
        assert_eq!(read(&path).unwrap(), bdf);
        assert_eq!(decode(&encode(&bdf)).unwrap(), bdf);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn patch(bytes: &mut [u8], at: usize, v: impl AsRef<[u8]>) {
    let v = v.as_ref();
    bytes[at..at + v.len()].copy_from_slice(v);
}

/// Offset of the first node of the axis `axis` of a D-dimensional file with node counts `lens`.
fn node_offset(lens: &[usize], axis: usize) -> usize {
    24 + 4 * lens.len() + 4 * lens[..axis].iter().sum::<usize>()
}

#[test]
fn bad_files_are_rejected_with_the_problem() {
    let bdf = &sample_bdfs()[0]; // 5 x 3 x 6 x 7, RGB, quadrant
    let lens = [5, 3, 6, 7];
    let good = encode(bdf);

    // Truncated anywhere: header, nodes, values.
    for cut in [0, 5, 10, 26, 40, node_offset(&lens, 2) + 2, good.len() - 1] {
        let e = decode(&good[..cut]).unwrap_err();
        assert!(matches!(e, BdfProblem::Truncated { .. }), "cut {cut}: {e}");
        assert!(e.to_string().contains("truncated"), "{e}");
    }
    let mut long = good.clone();
    long.push(0);
    assert_eq!(decode(&long).unwrap_err(), BdfProblem::TrailingBytes(1));

    let mut b = good.clone();
    patch(&mut b, 0, b"NOTATABL");
    assert_eq!(decode(&b).unwrap_err(), BdfProblem::BadMagic);
    let mut b = good.clone();
    patch(&mut b, 8, 2u32.to_le_bytes());
    assert_eq!(decode(&b).unwrap_err(), BdfProblem::BadVersion(2));
    let mut b = good.clone();
    patch(&mut b, 12, 5u32.to_le_bytes());
    assert_eq!(decode(&b).unwrap_err(), BdfProblem::BadDims(5));
    let mut b = good.clone();
    patch(&mut b, 16, 0u32.to_le_bytes());
    assert!(decode(&b).unwrap_err().to_string().contains("channels"));
    let mut b = good.clone();
    patch(&mut b, 20, 9u32.to_le_bytes());
    assert_eq!(decode(&b).unwrap_err(), BdfProblem::BadSymmetry(9));
    let mut b = good.clone();
    patch(&mut b, 24, u32::MAX.to_le_bytes());
    assert!(matches!(
        decode(&b).unwrap_err(),
        BdfProblem::HugeAxis { axis: 0, .. }
    ));

    // Non-monotonic axis: swap two theta_o nodes.
    let mut b = good.clone();
    let at = node_offset(&lens, 2);
    let (n0, n1) = (b[at..at + 4].to_vec(), b[at + 4..at + 8].to_vec());
    patch(&mut b, at, n1);
    patch(&mut b, at + 4, n0);
    let e = decode(&b).unwrap_err();
    assert!(
        e.to_string().contains("axis 2") && e.to_string().contains("increase strictly"),
        "{e}"
    );

    // An axis beyond its range.
    let mut b = good.clone();
    patch(&mut b, node_offset(&lens, 1) + 8, 3.0f32.to_le_bytes());
    let e = decode(&b).unwrap_err();
    assert!(e.to_string().contains("phi_i"), "{e}");

    // A negative value and a NaN value.
    let values_at = node_offset(&lens, 4);
    let mut b = good.clone();
    patch(&mut b, values_at + 40, (-0.5f32).to_le_bytes());
    assert_eq!(
        decode(&b).unwrap_err(),
        BdfProblem::NegativeValue {
            index: 10,
            value: -0.5
        }
    );
    assert!(decode(&b).unwrap_err().to_string().contains("negative"));
    let mut b = good.clone();
    patch(&mut b, values_at + 8, f32::NAN.to_le_bytes());
    assert!(
        decode(&b)
            .unwrap_err()
            .to_string()
            .contains("not a finite number")
    );
}

#[test]
fn file_errors_name_the_file() {
    let dir = std::env::temp_dir().join(format!("coherent-bdf-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("broken.cbdf");
    let good = encode(&sample_bdfs()[2]);
    std::fs::write(&path, &good[..good.len() / 2]).unwrap();
    let e = read(&path).unwrap_err();
    assert!(matches!(
        e,
        BdfError::Invalid {
            problem: BdfProblem::Truncated { .. },
            ..
        }
    ));
    let msg = e.to_string();
    assert!(
        msg.contains("broken.cbdf") && msg.contains("truncated"),
        "{msg}"
    );

    let missing = dir.join("missing.cbdf");
    let msg = read(&missing).unwrap_err().to_string();
    assert!(msg.contains("missing.cbdf"), "{msg}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn below_the_surface_is_zero() {
    let bdf: Bdf = tabulate_isotropic(&isotropic_ward(), [5, 5, 5])
        .unwrap()
        .into();
    let up = [0.0, 0.0, 1.0];
    let down = [0.3, 0.0, -0.95];
    assert_eq!(eval1(&bdf, up, down), [0.0; 3]);
    assert_eq!(eval1(&bdf, down, up), [0.0; 3]);
    assert!(eval1(&bdf, up, up)[0] > 0.0);
}

#[test]
fn aniso_constructor_rejects_out_of_range_axes() {
    let axes = super::tabulate::anisotropic_axes([3, 3, 3, 3], Symmetry::None).unwrap();
    let grid = Grid::new(axes, 1, vec![1.0; 81]).unwrap();
    // phi_i over [-pi, pi] is wrong for a quadrant-folded table.
    let e = AnisotropicBdf::new(grid.clone(), Symmetry::Quadrant).unwrap_err();
    assert!(matches!(e, BdfProblem::AxisRange { axis: 1, .. }), "{e}");
    assert!(AnisotropicBdf::new(grid, Symmetry::None).is_ok());
}
