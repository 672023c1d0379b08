//! Tests of the texture pyramid, the sampler, the mip level choice and the loaders.

use coherent_simd::scalar::Scalar;
use rand::{Rng, SeedableRng, rngs::StdRng};

use super::*;

fn checker(n: usize, block: usize) -> Vec<[f32; 3]> {
    (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            let v = ((x / block + y / block) % 2) as f32;
            [v, 1.0 - v, 0.25]
        })
        .collect()
}

fn gradient(w: usize, h: usize) -> Vec<[f32; 3]> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            [x * 0.1 + y * 0.01, (x * 7.0 + y * 3.0) % 5.0, 0.5]
        })
        .collect()
}

#[test]
fn constant_texture_samples_to_the_constant_at_every_level() {
    let c = [0.3, 1.7, 0.05];
    let tex = Texture::from_linear("const", 37, 20, &vec![c; 37 * 20], Wrap::Repeat).unwrap();
    assert_eq!(tex.levels().len(), 6); // 37x20, 18x10, 9x5, 4x2, 2x1, 1x1
    for (k, l) in tex.levels().iter().enumerate() {
        for y in 0..l.height {
            for x in 0..l.width {
                let t = tex.texel(k, x, y);
                for ch in 0..3 {
                    assert!(
                        (t[ch] - c[ch]).abs() <= 1e-6 * c[ch],
                        "level {k} ({x},{y}): {t:?}"
                    );
                }
            }
        }
    }
    let mut rng = StdRng::seed_from_u64(1);
    for wrap in [Wrap::Repeat, Wrap::Clamp] {
        let tex = tex.clone().with_wrap(wrap);
        for _ in 0..2000 {
            let (s, t, lod) = (
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-1.0..7.0),
            );
            let v = tex.sample(Scalar, s, t, lod).lane(0);
            for ch in 0..3 {
                assert!(
                    (v[ch] - c[ch]).abs() <= 1e-5 * c[ch],
                    "{s} {t} {lod}: {v:?}"
                );
            }
        }
    }
}

#[test]
fn mip_levels_are_box_averages() {
    // One-texel checkerboard: level 1 is flat grey.
    let tex = Texture::from_linear("checker", 8, 8, &checker(8, 1), Wrap::Repeat).unwrap();
    for y in 0..4 {
        for x in 0..4 {
            assert_eq!(tex.texel(1, x, y), [0.5, 0.5, 0.25]);
        }
    }
    // Two-texel blocks: level 1 is the one-texel checkerboard, level 2 grey.
    let tex = Texture::from_linear("checker2", 16, 16, &checker(16, 2), Wrap::Repeat).unwrap();
    for y in 0..8 {
        for x in 0..8 {
            let v = ((x + y) % 2) as f32;
            assert_eq!(tex.texel(1, x, y), [v, 1.0 - v, 0.25]);
        }
    }
    assert_eq!(tex.texel(2, 3, 1), [0.5, 0.5, 0.25]);
    // Any size: every level keeps the mean, and each texel is its 2x2 parents' mean.
    let (w, h) = (13, 6);
    let tex = Texture::from_linear("grad", w, h, &gradient(w, h), Wrap::Clamp).unwrap();
    let mean = |k: usize| {
        let l = tex.levels()[k];
        let mut m = [0.0f64; 3];
        for y in 0..l.height {
            for x in 0..l.width {
                let t = tex.texel(k, x, y);
                for c in 0..3 {
                    m[c] += t[c] as f64 / (l.width * l.height) as f64;
                }
            }
        }
        m
    };
    let m0 = mean(0);
    for k in 1..tex.levels().len() {
        let m = mean(k);
        for c in 0..3 {
            assert!(
                (m[c] - m0[c]).abs() < 1e-5 * m0[c].abs().max(1.0),
                "level {k}: {m:?} vs {m0:?}"
            );
        }
    }
    let tex = Texture::from_linear("grad", 8, 4, &gradient(8, 4), Wrap::Clamp).unwrap();
    for y in 0..2 {
        for x in 0..4 {
            let parents = [
                (2 * x, 2 * y),
                (2 * x + 1, 2 * y),
                (2 * x, 2 * y + 1),
                (2 * x + 1, 2 * y + 1),
            ];
            for c in 0..3 {
                let want: f32 = parents
                    .iter()
                    .map(|&(a, b)| tex.texel(0, a, b)[c])
                    .sum::<f32>()
                    / 4.0;
                assert!((tex.texel(1, x, y)[c] - want).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn trilinear_weights_sum_to_one_and_match_the_reference() {
    let mut rng = StdRng::seed_from_u64(2);
    for wrap in [Wrap::Repeat, Wrap::Clamp] {
        let tex = Texture::from_linear("grad", 23, 17, &gradient(23, 17), wrap).unwrap();
        for _ in 0..5000 {
            let s = rng.random_range(-2.5..2.5);
            let t = rng.random_range(-2.5..2.5);
            let lod = rng.random_range(-0.5..6.0);
            let f = tex.footprint(Scalar, s, t, lod);
            let sum: f32 = f.weight.iter().sum();
            assert!((sum - 1.0).abs() < 1e-6, "{s} {t} {lod}: {sum}");
            assert!(f.weight.iter().all(|&w| (0.0..=1.0).contains(&w)));
            let (a, b) = (
                tex.sample(Scalar, s, t, lod).lane(0),
                tex.sample1(s, t, lod),
            );
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() < 1e-4 * b[c].abs().max(1.0),
                    "{s} {t} {lod}: {a:?} vs {b:?}"
                );
            }
        }
    }
}

/// Equal up to the rounding of weights that sum to one.
fn close(a: [f32; 3], b: [f32; 3]) {
    for c in 0..3 {
        assert!(
            (a[c] - b[c]).abs() <= 1e-6 * b[c].abs().max(1.0),
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn coordinates_outside_the_unit_square_follow_the_wrap_mode() {
    let (w, h) = (11, 7);
    let repeat = Texture::from_linear("grad", w, h, &gradient(w, h), Wrap::Repeat).unwrap();
    let clamp = repeat.clone().with_wrap(Wrap::Clamp);
    let mut rng = StdRng::seed_from_u64(3);
    for _ in 0..1000 {
        let (s, t) = (rng.random_range(0.0..1.0f32), rng.random_range(0.0..1.0f32));
        let lod = rng.random_range(0.0..2.0);
        let base = repeat.sample(Scalar, s, t, lod).lane(0);
        for (ds, dt) in [
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, 2.0),
            (-3.0, -1.0),
            (4.0, 5.0),
        ] {
            let v = repeat.sample(Scalar, s + ds, t + dt, lod).lane(0);
            for c in 0..3 {
                assert!(
                    (v[c] - base[c]).abs() < 1e-3 * base[c].abs().max(1.0),
                    "({s}+{ds}, {t}+{dt}): {v:?} vs {base:?}"
                );
            }
        }
        // Clamp: everything beyond the last texel centre reads the edge.
        let edge = clamp.sample(Scalar, 1.0, t, 0.0).lane(0);
        for far in [1.0 + s, 3.0, 1e6] {
            close(clamp.sample(Scalar, far, t, 0.0).lane(0), edge);
        }
        let edge = clamp.sample(Scalar, s, 0.0, 0.0).lane(0);
        close(clamp.sample(Scalar, s, -t - 0.5, 0.0).lane(0), edge);
    }
    // At level 0 and a texel centre beyond the edge, clamp reads the edge texel exactly.
    assert_eq!(
        clamp.sample(Scalar, 2.0, -1.0, 0.0).lane(0),
        clamp.texel(0, w - 1, 0)
    );
    // NaN and huge coordinates stay inside the texture.
    let v = repeat.sample(Scalar, f32::NAN, 1e30, f32::NAN).lane(0);
    assert!(v.iter().all(|x| x.is_finite()));
}

#[test]
fn halving_matches_log2_within_the_octave_error() {
    // The linear fraction within an octave differs from log2 by at most 0.0861.
    let max_level = 10;
    for i in 0..4000 {
        let footprint = 0.5 + i as f32 * 0.37;
        let lod = lod_by_halving(Scalar, footprint, 1.0, max_level);
        let exact = footprint.log2().clamp(0.0, max_level as f32);
        assert!(
            (lod - exact).abs() <= 0.0862,
            "{footprint}: {lod} vs {exact}"
        );
    }
    assert_eq!(lod_by_halving(Scalar, 1.0, 1.0, max_level), 0.0);
    assert_eq!(lod_by_halving(Scalar, 2.0, 1.0, max_level), 1.0);
    assert_eq!(lod_by_halving(Scalar, 3.0, 1.0, max_level), 1.5);
    assert_eq!(lod_by_halving(Scalar, 1e9, 1.0, max_level), 10.0);
    assert_eq!(lod_by_halving(Scalar, f32::NAN, 1.0, max_level), 0.0);
}

#[test]
fn halving_and_differentials_agree_on_a_facing_plane() {
    // A plane facing the camera: a pixel spans `t * angle` world units, i.e.
    // `t * angle * density` texels, on both screen axes.
    let (angle, density, size) = (1e-3f32, 512.0f32, 1024usize);
    let spread = angle * density;
    for i in 1..200 {
        let t = i as f32 * 0.5;
        let by_halving = lod_by_halving(Scalar, t, spread, 10);
        let d = t * angle * density / size as f32; // ds/dx in texture units
        let by_diff = lod_from_differentials(Scalar, d, 0.0, 0.0, d, size, size, 10);
        assert!(
            (by_halving - by_diff).abs() <= 0.0862 + 1e-5,
            "t {t}: {by_halving} vs {by_diff}"
        );
    }
}

#[test]
fn texture_coordinates_interpolate_barycentrics() {
    let tc = TexCoords {
        s: vec![0.0, 1.0, 0.0, 1.0],
        t: vec![0.0, 0.0, 1.0, 1.0],
        indices: vec![0, 1, 2, 1, 3, 2],
    };
    let (s, t) = tc.interpolate(Scalar, true, coherent_simd::scalar::I32x1(1), 0.25, 0.5);
    // Triangle 1: vertices 1 (1,0), 3 (1,1), 2 (0,1); weights 0.25, 0.25, 0.5.
    assert_eq!((s, t), (0.25 * 1.0 + 0.25 * 1.0, 0.25 * 1.0 + 0.5 * 1.0));
    let (s, t) = tc.interpolate(Scalar, false, coherent_simd::scalar::I32x1(99), 0.3, 0.3);
    assert_eq!((s, t), (0.0, 0.0));
}

fn temp_dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("coherent-tex-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn png_jpeg_and_exr_load_to_linear() {
    let dir = temp_dir("load");
    let (w, h) = (6u32, 4u32);
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        image::Rgb([(x * 40) as u8, (y * 60) as u8, 255])
    });
    let png = dir.join("t.png");
    img.save(&png).unwrap();
    let tone = InverseToneMap::default();
    let tex = load(&png, Wrap::Repeat, &tone).unwrap();
    assert_eq!((tex.levels()[0].width, tex.levels()[0].height), (6, 4));
    let t = tex.texel(0, 3, 2);
    // Inverse tone mapped with the approximate pow.
    let want = (120.0f32 / 255.0).powf(2.2);
    assert!(
        (t[0] - want).abs() <= crate::approx::POW_REL_ERROR * want,
        "{t:?}"
    );
    assert!(
        (t[1] - want).abs() <= crate::approx::POW_REL_ERROR * want,
        "{t:?}"
    );
    assert!((t[2] - 1.0).abs() <= crate::approx::POW_REL_ERROR, "{t:?}");
    assert_eq!(tex.name(), png.display().to_string());

    let jpg = dir.join("t.jpg");
    img.save(&jpg).unwrap();
    let tex = load(&jpg, Wrap::Repeat, &tone).unwrap();
    assert_eq!(tex.levels()[0].width, 6);

    let exr_path = dir.join("t.exr");
    exr::prelude::write_rgb_file(&exr_path, 5, 3, |x, y| (x as f32 * 2.5, y as f32, 0.125f32))
        .unwrap();
    let tex = load(&exr_path, Wrap::Clamp, &tone).unwrap();
    assert_eq!((tex.levels()[0].width, tex.levels()[0].height), (5, 3));
    assert_eq!(tex.texel(0, 4, 2), [10.0, 2.0, 0.125]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// CRC-32 of PNG chunks (for a hand-made header).
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn png_with_size(width: u32, height: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = b"IHDR".to_vec();
    chunk.extend(width.to_be_bytes());
    chunk.extend(height.to_be_bytes());
    chunk.extend([8, 2, 0, 0, 0]);
    out.extend(13u32.to_be_bytes());
    out.extend(&chunk);
    out.extend(crc32(&chunk).to_be_bytes());
    out
}

#[test]
fn bad_images_are_reported_with_the_file() {
    let dir = temp_dir("bad");
    let tone = InverseToneMap::default();
    let check = |name: &str, bytes: Option<&[u8]>, want: &str| {
        let path = dir.join(name);
        if let Some(b) = bytes {
            std::fs::write(&path, b).unwrap();
        }
        let e = load(&path, Wrap::Repeat, &tone).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(name) && msg.contains(want), "{name}: {msg}");
        e
    };
    assert!(matches!(
        check("missing.png", None, "cannot read"),
        TextureError::Io { .. }
    ));
    assert!(matches!(
        check("garbage.png", Some(b"not a png at all"), "cannot decode"),
        TextureError::Decode { .. }
    ));
    assert!(matches!(
        check("empty.jpg", Some(b""), "cannot decode"),
        TextureError::Decode { .. }
    ));
    // A PNG header claiming 0 x 0 texels.
    let e = check("zero.png", Some(&png_with_size(0, 0)), "");
    assert!(
        matches!(e, TextureError::Decode { .. } | TextureError::Empty { .. }),
        "{e}"
    );
    // A valid header with the pixel data cut off.
    let mut good = Vec::new();
    image::RgbImage::new(8, 8)
        .write_to(
            &mut std::io::Cursor::new(&mut good),
            image::ImageFormat::Png,
        )
        .unwrap();
    check("cut.png", Some(&good[..good.len() - 20]), "cannot decode");
    check("bad.exr", Some(b"v/1\x01 nope"), "cannot decode");
    assert!(matches!(
        check("image.bmp", Some(b"BM"), "unknown image type"),
        TextureError::UnknownFormat { .. }
    ));
    // Linear input that is not a radiance.
    let e = Texture::from_linear(
        "made",
        1,
        2,
        &[[0.0; 3], [f32::NAN, 0.0, 0.0]],
        Wrap::Repeat,
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("made") && e.to_string().contains("texel 1"),
        "{e}"
    );
    let e = Texture::from_linear("flat", 0, 5, &[], Wrap::Repeat).unwrap_err();
    assert!(matches!(e, TextureError::Empty { .. }) && e.to_string().contains("flat"));
    std::fs::remove_dir_all(&dir).unwrap();
}
