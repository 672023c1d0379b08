//! The parsers under fuzz, each through the entry point that takes a file's bytes as if read
//! from a path (the path names the file in errors and gives the folder its other files are
//! read from), and their seeds: committed files (`tests/fuzz_seeds/<parser>/`, and
//! `scenes/*.toml` for scenes), small files generated here with the project's and its
//! libraries' own writers (binary formats: nothing opaque is committed), and the files
//! `scripts/native.py` fetches into `.cache/` when they are there.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use coherent::bdf::{Analytic, Bdf, IsotropicBdf, Symmetry};
use coherent::light::goniodiagram::parse_table;
use coherent::light::{Environment, GonioLookup, Goniodiagram};
use coherent::simd::Vec3s;
use coherent::simd::scalar::Scalar;
use coherent::tabulated::{Axis, Grid};
use coherent::texture::{InverseToneMap, Wrap};
use glam::Vec3;

/// The name every case's file has (with its parser's extension): errors must name it.
pub const CASE_STEM: &str = "fuzz-case";

/// Fetched seeds larger than this many KiB are left out by default (a case reads its seed
/// whole, and the test profile reads megabytes slowly): `COHERENT_FUZZ_MAX_SEED_KB`.
pub const MAX_SEED_KB: u64 = 256;

pub struct Target {
    /// Also the folder of its saved failures, `tests/fuzz_regressions/<name>/`.
    pub name: &'static str,
    /// The case file's extension, which picks the format.
    pub ext: &'static str,
    /// Parses a case; `Err` is the error's message.
    pub run: fn(&Path, &[u8]) -> Result<(), String>,
    /// Extensions of the fetched files that seed it.
    pub fetched: &'static [&'static str],
    /// Whether a fetched seed is read in its own folder (so that the files it names, a glTF's
    /// buffers, an OBJ's MTL, are found), rather than in the work folder.
    pub in_place: bool,
    /// Cases of the default (CI) run: the slow parsers get fewer.
    pub cases: u64,
}

pub const TARGETS: &[Target] = &[
    Target {
        name: "scene",
        ext: "toml",
        run: scene,
        fetched: &[],
        in_place: false,
        cases: 2000,
    },
    Target {
        name: "obj",
        ext: "obj",
        run: mesh,
        fetched: &["obj"],
        in_place: true,
        cases: 3000,
    },
    Target {
        name: "mtl",
        ext: "mtl",
        run: mtl,
        fetched: &["mtl"],
        in_place: false,
        cases: 1000,
    },
    Target {
        name: "ply",
        ext: "ply",
        run: mesh,
        fetched: &["ply"],
        in_place: false,
        cases: 3000,
    },
    Target {
        name: "off",
        ext: "off",
        run: mesh,
        fetched: &["off"],
        in_place: false,
        cases: 3000,
    },
    Target {
        name: "gltf",
        ext: "gltf",
        run: gltf,
        fetched: &["gltf"],
        in_place: true,
        cases: 3000,
    },
    Target {
        name: "glb",
        ext: "glb",
        run: gltf,
        fetched: &["glb"],
        in_place: true,
        cases: 3000,
    },
    Target {
        name: "ies",
        ext: "ies",
        run: goniodiagram,
        fetched: &["ies"],
        in_place: false,
        cases: 1000,
    },
    Target {
        name: "ldt",
        ext: "ldt",
        run: goniodiagram,
        fetched: &["ldt"],
        in_place: false,
        cases: 1000,
    },
    Target {
        name: "env_exr",
        ext: "exr",
        run: environment,
        fetched: &["exr"],
        in_place: false,
        cases: 2000,
    },
    Target {
        name: "bdf",
        ext: "bdf",
        run: bdf,
        fetched: &[],
        in_place: false,
        cases: 3000,
    },
    Target {
        name: "png",
        ext: "png",
        run: texture,
        fetched: &["png"],
        in_place: false,
        cases: 3000,
    },
    Target {
        name: "jpeg",
        ext: "jpg",
        run: texture,
        fetched: &["jpg", "jpeg"],
        in_place: false,
        cases: 1000,
    },
    Target {
        name: "texture_exr",
        ext: "exr",
        run: texture,
        fetched: &["exr"],
        in_place: false,
        cases: 2000,
    },
];

pub fn target(name: &str) -> &'static Target {
    TARGETS
        .iter()
        .find(|t| t.name == name)
        .unwrap_or_else(|| panic!("no fuzz target {name:?}"))
}

/// The workspace root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

fn scene(path: &Path, bytes: &[u8]) -> Result<(), String> {
    coherent::scene::file::parse_bytes(path, bytes)
        .map(drop)
        .map_err(err)
}

fn mesh(path: &Path, bytes: &[u8]) -> Result<(), String> {
    coherent::mesh_file::parse_shaded(path, bytes)
        .map(drop)
        .map_err(err)
}

/// An MTL file is only read through the OBJ file that names it: the case is written beside
/// an OBJ naming it (the one parser here that needs a file on disk).
fn mtl(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(err)?;
    let obj = format!(
        "mtllib {CASE_STEM}.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
         usemtl red\nf 1/1 2/2 3/3\nusemtl textured\nf 1/1 3/3 2/2\n"
    );
    coherent::mesh_file::parse_shaded(&path.with_extension("obj"), obj.as_bytes())
        .map(drop)
        .map_err(err)
}

fn gltf(path: &Path, bytes: &[u8]) -> Result<(), String> {
    coherent::scene::gltf::read(path, bytes)
        .map(drop)
        .map_err(err)
}

/// Some directions around the sphere, for the lights and tables a file became.
fn directions() -> impl Iterator<Item = Vec3> {
    (0..26).filter_map(|k| {
        let d = Vec3::new(
            (k % 3) as f32 - 1.0,
            ((k / 3) % 3) as f32 - 1.0,
            (k / 9) as f32 - 1.0,
        );
        d.try_normalize()
    })
}

/// The table, the light made of it, and its intensity in some directions (a table the parser
/// accepts must be one the light can use).
fn goniodiagram(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let table = parse_table(path, bytes).map_err(err)?;
    let mut g = Goniodiagram::new(
        Vec3::ZERO,
        Vec3::Z,
        Vec3::X,
        &table,
        [1.0; 3],
        GonioLookup::Search,
        path,
    )
    .map_err(err)?;
    for lookup in [GonioLookup::Search, GonioLookup::Uniform] {
        g = g.with_lookup(lookup);
        for d in directions() {
            std::hint::black_box(g.candela(Scalar, &Vec3s::splat(Scalar, d)));
        }
    }
    Ok(())
}

fn environment(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let env = Environment::from_bytes(path, bytes, 1.0, Vec3::Y, Vec3::NEG_Z, 4).map_err(err)?;
    for d in directions() {
        std::hint::black_box(env.radiance(Scalar, &Vec3s::splat(Scalar, d)));
        std::hint::black_box(env.pdf1(d));
    }
    Ok(())
}

fn bdf(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let bdf = coherent::bdf::format::decode(bytes).map_err(|p| err(p.at(path)))?;
    for wi in directions().filter(|d| d.z > 0.0) {
        for wo in directions() {
            std::hint::black_box(bdf.eval(
                Scalar,
                &Vec3s::splat(Scalar, wi),
                &Vec3s::splat(Scalar, wo),
            ));
        }
    }
    Ok(())
}

fn texture(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let t = coherent::texture::load::decode(
        path,
        bytes.to_vec(),
        Wrap::Repeat,
        &InverseToneMap::default(),
    )
    .map_err(err)?;
    for (s, t_, lod) in [(0.5, 0.5, 0.0), (-3.2, 7.9, 2.5), (0.01, 0.99, 40.0)] {
        std::hint::black_box(t.sample(Scalar, s, t_, lod));
    }
    Ok(())
}

/// A seed: its label (where it came from), bytes, and the folder a case of it is read in
/// (`None`: the work folder).
pub struct Seed {
    pub label: String,
    pub bytes: Vec<u8>,
    pub dir: Option<PathBuf>,
}

/// The seeds of `t`, and a line for each fetched file left out (too large).
pub fn seeds(t: &Target) -> (Vec<Seed>, Vec<String>) {
    let mut out = Vec::new();
    let mut committed = vec![root().join("tests/fuzz_seeds").join(t.name)];
    if t.name == "scene" {
        committed.push(root().join("scenes"));
    }
    for dir in committed {
        for p in files_in(&dir) {
            out.push(Seed {
                label: p.strip_prefix(root()).unwrap_or(&p).display().to_string(),
                bytes: std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
                dir: None,
            });
        }
    }
    for (label, bytes) in generated(t.name) {
        out.push(Seed {
            label: format!("generated {label}"),
            bytes,
            dir: None,
        });
    }
    let max_kb = std::env::var("COHERENT_FUZZ_MAX_SEED_KB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MAX_SEED_KB);
    let mut left_out = Vec::new();
    for p in fetched(t.fetched) {
        let label = p.strip_prefix(root()).unwrap_or(&p).display().to_string();
        let size = std::fs::metadata(&p).map_or(0, |m| m.len());
        if size > max_kb * 1024 {
            left_out.push(format!("{label} ({} KiB)", size / 1024));
            continue;
        }
        out.push(Seed {
            label,
            bytes: std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
            dir: t.in_place.then(|| p.parent().unwrap().to_path_buf()),
        });
    }
    assert!(!out.is_empty(), "fuzz target {} has no seed", t.name);
    (out, left_out)
}

/// The files of a folder, sorted; none when it is absent.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    v.sort();
    v
}

/// The files under `.cache/` (the downloaded packages aside) with one of `exts`, sorted.
fn fetched(exts: &[&str]) -> Vec<PathBuf> {
    fn walk(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
        for p in files_in(dir) {
            let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
            if exts.iter().any(|x| x.eq_ignore_ascii_case(ext)) {
                out.push(p);
            }
        }
        let mut dirs: Vec<PathBuf> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir() && !p.ends_with("debs"))
            .collect();
        dirs.sort();
        for d in dirs {
            walk(&d, exts, out);
        }
    }
    let mut out = Vec::new();
    // `COHERENT_FUZZ_FETCHED=0`: the committed and generated seeds only, as on a machine
    // without the set-up's files.
    let wanted = std::env::var("COHERENT_FUZZ_FETCHED").map_or(true, |v| v != "0");
    if wanted && !exts.is_empty() {
        walk(&root().join(".cache"), exts, &mut out);
    }
    out
}

/// The seeds made here for `parser`: (label, bytes).
fn generated(parser: &str) -> Vec<(String, Vec<u8>)> {
    match parser {
        "ply" => binary_plys(),
        "glb" => vec![("quad.glb".into(), glb())],
        "env_exr" | "texture_exr" => exrs(),
        "bdf" => bdfs(),
        "png" => pngs(),
        "jpeg" => jpegs(),
        _ => Vec::new(),
    }
}

/// The files scene seeds name, written into the work folder: (name, bytes).
pub fn support_files() -> Vec<(&'static str, Vec<u8>)> {
    let seed = |p: &str| std::fs::read(root().join("tests/fuzz_seeds").join(p)).unwrap();
    vec![
        ("mesh.off", seed("off/tetra.off")),
        ("mesh.obj", seed("obj/materials.obj")),
        ("support.mtl", seed("mtl/materials.mtl")),
        ("mesh.ply", seed("ply/quad.ply")),
        ("quad.gltf", seed("gltf/quad.gltf")),
        ("lamp.ies", seed("ies/lm63_2002.ies")),
        ("lamp.ldt", seed("ldt/isym1.ldt")),
        ("sky.exr", exrs().swap_remove(0).1),
        ("tex.png", pngs().swap_remove(0).1),
        ("table.bdf", bdfs().swap_remove(0).1),
    ]
}

fn image_bytes(img: image::DynamicImage, format: image::ImageOutputFormat) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

fn pngs() -> Vec<(String, Vec<u8>)> {
    use image::{DynamicImage, ImageBuffer, ImageOutputFormat::Png};
    let rgb = ImageBuffer::from_fn(5, 3, |x, y| image::Rgb([x as u8 * 50, y as u8 * 80, 7]));
    let rgba = ImageBuffer::from_fn(4, 4, |x, y| {
        image::Rgba([x as u8 * 60, 9, y as u8 * 60, 128])
    });
    let grey16 = ImageBuffer::from_fn(3, 2, |x, y| image::Luma([(x * 20000 + y * 3000) as u16]));
    let grey_alpha = ImageBuffer::from_fn(2, 3, |x, y| image::LumaA([(x * 100 + y) as u8, 255]));
    vec![
        (
            "rgb8.png".into(),
            image_bytes(DynamicImage::ImageRgb8(rgb), Png),
        ),
        (
            "rgba8.png".into(),
            image_bytes(DynamicImage::ImageRgba8(rgba), Png),
        ),
        (
            "grey16.png".into(),
            image_bytes(DynamicImage::ImageLuma16(grey16), Png),
        ),
        (
            "grey_alpha8.png".into(),
            image_bytes(DynamicImage::ImageLumaA8(grey_alpha), Png),
        ),
    ]
}

fn jpegs() -> Vec<(String, Vec<u8>)> {
    use image::{DynamicImage, ImageBuffer, ImageOutputFormat::Jpeg};
    let rgb = ImageBuffer::from_fn(16, 8, |x, y| image::Rgb([x as u8 * 16, y as u8 * 30, 100]));
    let grey = ImageBuffer::from_fn(9, 9, |x, y| image::Luma([(x * 25 + y) as u8]));
    vec![
        (
            "rgb.jpg".into(),
            image_bytes(DynamicImage::ImageRgb8(rgb), Jpeg(90)),
        ),
        (
            "grey.jpg".into(),
            image_bytes(DynamicImage::ImageLuma8(grey), Jpeg(50)),
        ),
    ]
}

/// OpenEXR maps in each compression the writer has, in 32- and 16-bit floats, and one
/// without RGB channels.
fn exrs() -> Vec<(String, Vec<u8>)> {
    use exr::prelude::*;
    let write = |img: &dyn Fn(&mut Cursor<Vec<u8>>)| {
        let mut out = Cursor::new(Vec::new());
        img(&mut out);
        out.into_inner()
    };
    let rgb = |x: usize, y: usize| (x as f32 * 0.5, y as f32 + 0.25, 1.0f32);
    let mut out = vec![(
        "rgb32_uncompressed.exr".to_string(),
        write(&|w| {
            Image::from_encoded_channels(
                (8, 4),
                Encoding::UNCOMPRESSED,
                SpecificChannels::rgb(|p: Vec2<usize>| rgb(p.x(), p.y())),
            )
            .write()
            .to_buffered(w)
            .unwrap()
        }),
    )];
    for (name, encoding) in [
        ("rgba16_rle_tiles.exr", Encoding::FAST_LOSSLESS),
        ("rgba16_zip16.exr", Encoding::SMALL_LOSSLESS),
        ("rgba16_piz_tiles.exr", Encoding::SMALL_FAST_LOSSLESS),
    ] {
        let bytes = write(&|w| {
            Image::from_encoded_channels(
                (6, 5),
                encoding,
                SpecificChannels::rgba(|p: Vec2<usize>| {
                    let (r, g, b) = rgb(p.x(), p.y());
                    (
                        f16::from_f32(r),
                        f16::from_f32(g),
                        f16::from_f32(b),
                        f16::ONE,
                    )
                }),
            )
            .write()
            .to_buffered(w)
            .unwrap()
        });
        out.push((name.to_string(), bytes));
    }
    // Large enough that the lossy and the other compressions beat raw storage (else the
    // writer stores the block raw, and the seed never reaches their decoders).
    for (name, compression) in [
        ("rgb16_dwaa.exr", Compression::DWAA(None)),
        ("rgb16_dwab.exr", Compression::DWAB(None)),
        ("rgb16_b44.exr", Compression::B44),
        ("rgb16_pxr24.exr", Compression::PXR24),
    ] {
        let encoding = Encoding {
            compression,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        };
        let bytes = write(&|w| {
            Image::from_encoded_channels(
                (64, 40),
                encoding,
                SpecificChannels::rgb(|p: Vec2<usize>| {
                    let (x, y) = (p.x() as f32, p.y() as f32);
                    let v = |a: f32| f16::from_f32(0.5 + 0.4 * (a * 0.1).sin());
                    (v(x), v(y), v(x + y))
                }),
            )
            .write()
            .to_buffered(w)
            .unwrap()
        });
        out.push((name.to_string(), bytes));
    }
    let grey = write(&|w| {
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 4 * 2]));
        Image::from_channels((4, 2), AnyChannels::sort(SmallVec::from_vec(vec![channel])))
            .write()
            .to_buffered(w)
            .unwrap()
    });
    out.push(("grey_y_only.exr".to_string(), grey));
    out
}

/// Tables of the project's own writer: isotropic RGB, anisotropic with and without the
/// quadrant symmetry, and a one-channel table.
fn bdfs() -> Vec<(String, Vec<u8>)> {
    use coherent::bdf::format::encode;
    use coherent::bdf::{tabulate_anisotropic, tabulate_isotropic};
    let grey = IsotropicBdf::new(
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
    .unwrap();
    let tables: Vec<(&str, Bdf)> = vec![
        (
            "isotropic_ggx.bdf",
            tabulate_isotropic(&Analytic::rough_ggx(), [3, 4, 5])
                .unwrap()
                .into(),
        ),
        (
            "anisotropic_quadrant.bdf",
            tabulate_anisotropic(&Analytic::brushed_ward(), [3, 3, 4, 3], Symmetry::Quadrant)
                .unwrap()
                .into(),
        ),
        (
            "anisotropic.bdf",
            tabulate_anisotropic(&Analytic::rough_ggx(), [2, 3, 2, 3], Symmetry::None)
                .unwrap()
                .into(),
        ),
        ("grey.bdf", grey.into()),
    ];
    tables
        .into_iter()
        .map(|(n, b)| (n.to_string(), encode(&b)))
        .collect()
}

/// Binary PLY files, little- and big-endian, with the types the reader converts.
fn binary_plys() -> Vec<(String, Vec<u8>)> {
    let quad = [
        [0.0f64, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let mut le = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for p in quad {
        for c in p.iter().chain(&[0.0, 0.0, 1.0]) {
            le.extend((*c as f32).to_le_bytes());
        }
    }
    for f in [[0i32, 1, 2], [0, 2, 3]] {
        le.push(3);
        for i in f {
            le.extend(i.to_le_bytes());
        }
    }
    let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n\
property double y\nproperty double z\nproperty float u\nproperty float v\nelement face 1\n\
property list ushort ushort vertex_index\nend_header\n"
        .to_vec();
    for p in quad {
        for c in p {
            be.extend(c.to_be_bytes());
        }
        be.extend((p[0] as f32).to_be_bytes());
        be.extend((p[1] as f32).to_be_bytes());
    }
    be.extend(4u16.to_be_bytes());
    for i in [0u16, 1, 2, 3] {
        be.extend(i.to_be_bytes());
    }
    vec![("quad_le.ply".into(), le), ("quad_be.ply".into(), be)]
}

/// A binary glTF: a textured quad, its positions, UVs, indices and PNG image in the binary
/// chunk.
fn glb() -> Vec<u8> {
    let mut bin = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        for c in p {
            bin.extend(c.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        for c in uv {
            bin.extend(c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let png_at = bin.len();
    bin.extend(pngs().swap_remove(0).1);
    let png_len = bin.len() - png_at;
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},
{{"buffer":0,"byteOffset":80,"byteLength":12}},{{"buffer":0,"byteOffset":{png_at},"byteLength":{png_len}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},{{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}],
"images":[{{"bufferView":3,"mimeType":"image/png"}}],"textures":[{{"source":0}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],
"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len()
    )
    .into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}
