//! Tests of the TOML scene file: a scene that loads, and every kind of bad input the file can
//! hold, each answered with the file, the line and the problem.

use std::path::{Path, PathBuf};

use super::SceneError;
use super::file::parse;

const GOOD: &str = r#"
resolution = [64, 48]
depth = 2
spp = 2
tonemap = "reinhard"

[camera]
position = [0, 1, 4]
look_at = [0, 1, 0]

[materials.red]
type = "phong"
diffuse = [0.7, 0.1, 0.1]

[materials.glass]
type = "glass"
ior = 1.45

[[objects]]
shape = "quad"
material = "red"
scale = [10, 1, 10]

[[objects]]
shape = "sphere"
material = "glass"
translate = [0, 1, 0]
keyframes = [{ time = 1.0, translate = [0, 2, 0] }]

[[objects]]
shape = "sphere"
material = "glass"
translate = [1, 1, 0]

[[lights]]
type = "omni"
position = [0, 3, 0]
intensity = [10, 10, 10]

[[lights]]
type = "rectangular"
corner = [-1, 2.9, -1]
edge_u = [2, 0, 0]
edge_v = [0, 0, 2]
radiance = [1, 1, 1]
"#;

fn path() -> PathBuf {
    PathBuf::from("/nonexistent/dir/test.toml")
}

/// The error of `text` with line `line` of GOOD replaced (or the text as given).
fn error(text: &str) -> (String, SceneError) {
    let e = parse(&path(), text).expect_err("the scene should be rejected");
    (e.to_string(), e)
}

fn line_of(e: &SceneError) -> usize {
    match e {
        SceneError::Syntax { line, .. } => *line,
        _ => 0,
    }
}

#[test]
fn a_good_scene_loads_with_instances_and_motion() {
    let s = parse(&path(), GOOD).unwrap();
    assert_eq!((s.width, s.height, s.depth, s.spp), (64, 48, 2, Some(2)));
    assert_eq!(s.tonemap, crate::tonemap::Operator::Reinhard);
    assert_eq!(s.meshes.len(), 2, "the two glass spheres share one mesh");
    assert_eq!(s.instances.len(), 3);
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.motion.len(), 1);
    assert_eq!(s.motion[0].at(1.0).translation.y, 2.0);
    assert_eq!(s.materials[s.meshes[0].material[0] as usize].name, "red");
    assert_eq!(s.name, "test");
}

#[test]
fn unknown_key_names_file_line_and_key() {
    let (msg, e) = error(&GOOD.replace("depth = 2", "depht = 2"));
    assert!(msg.contains("test.toml") && msg.contains("depht"), "{msg}");
    assert_eq!(line_of(&e), 3, "{msg}");
    // Inside a tagged table too.
    let (msg, _) = error(&GOOD.replace("ior = 1.45", "iorr = 1.45"));
    assert!(msg.contains("iorr"), "{msg}");
}

#[test]
fn wrong_type_names_the_line() {
    let (msg, e) = error(&GOOD.replace("spp = 2", "spp = \"two\""));
    assert_eq!(line_of(&e), 4, "{msg}");
    let (msg, _) = error(&GOOD.replace("type = \"omni\"", "type = \"lamp\""));
    assert!(msg.contains("lamp"), "{msg}");
}

#[test]
fn settings_the_scene_rejects_name_their_line() {
    let (msg, e) = error(&GOOD.replace("spp = 2", "spp = 0"));
    assert_eq!(line_of(&e), 4, "{msg}");
    assert!(msg.contains("test.toml:4:1: spp"), "{msg}");
    let (msg, e) = error(&GOOD.replace("spp = 2", "accuracy = 5.0"));
    assert_eq!(line_of(&e), 4, "{msg}");
    assert!(msg.contains("accuracy"), "{msg}");
}

#[test]
fn missing_files_are_named() {
    let (msg, e) = error(&GOOD.replace("shape = \"quad\"", "mesh = \"floor.obj\""));
    assert!(
        msg.contains("floor.obj") && msg.contains("objects[0].mesh"),
        "{msg}"
    );
    assert_eq!(line_of(&e), 20, "{msg}");
    let tex = GOOD.replace(
        "type = \"phong\"\ndiffuse = [0.7, 0.1, 0.1]",
        "type = \"textured\"\ntexture = \"wood.png\"",
    );
    let (msg, _) = error(&tex);
    assert!(msg.contains("wood.png"), "{msg}");
    let bdf = GOOD.replace(
        "type = \"phong\"\ndiffuse = [0.7, 0.1, 0.1]",
        "type = \"bdf\"\nfile = \"paint.bdf\"",
    );
    let (msg, _) = error(&bdf);
    assert!(msg.contains("paint.bdf"), "{msg}");
    let env = GOOD.replace(
        "type = \"omni\"\nposition = [0, 3, 0]\nintensity = [10, 10, 10]",
        "type = \"environment\"\nfile = \"sky.exr\"",
    );
    let (msg, _) = error(&env);
    assert!(
        msg.contains("sky.exr") && msg.contains("lights[0]"),
        "{msg}"
    );
}

#[test]
fn undefined_material_is_named_with_the_known_ones() {
    let (msg, e) = error(&GOOD.replace("material = \"red\"", "material = \"blue\""));
    assert!(
        msg.contains("\"blue\"") && msg.contains("glass, red"),
        "{msg}"
    );
    assert_eq!(line_of(&e), 21, "{msg}");
}

#[test]
fn singular_camera_and_transform() {
    let (msg, _) = error(&GOOD.replace("look_at = [0, 1, 0]", "look_at = [0, 1, 4]"));
    assert!(msg.contains("camera.look_at"), "{msg}");
    let (msg, _) =
        error(&GOOD.replace("look_at = [0, 1, 0]", "look_at = [0, 1, 0]\nup = [0, 0, 1]"));
    assert!(
        msg.contains("camera.up") && msg.contains("singular"),
        "{msg}"
    );
    let (msg, _) = error(&GOOD.replace("scale = [10, 1, 10]", "scale = [10, 0, 10]"));
    assert!(
        msg.contains("objects[0]") && msg.contains("singular"),
        "{msg}"
    );
}

#[test]
fn zero_or_huge_resolution() {
    for bad in ["[0, 48]", "[100000, 48]", "[16384, 16384]"] {
        let (msg, e) = error(&GOOD.replace("[64, 48]", bad));
        assert!(msg.contains("resolution"), "{msg}");
        assert_eq!(line_of(&e), 2, "{msg}");
    }
    let (msg, _) = error(&GOOD.replace("[64, 48]", "[64, 99999999999]"));
    assert!(msg.contains("test.toml:2"), "{msg}");
}

#[test]
fn bad_lights_and_settings_are_named() {
    let (msg, _) = error(&GOOD.replace("intensity = [10, 10, 10]", "intensity = [10, -1, 10]"));
    assert!(msg.contains("lights[0]"), "{msg}");
    let (msg, _) = error(&GOOD.replace("tonemap = \"reinhard\"", "tonemap = \"filmic\""));
    assert!(msg.contains("tonemap") && msg.contains("filmic"), "{msg}");
    let (msg, _) = error(&GOOD.replace("ior = 1.45", "ior = -1.0"));
    assert!(msg.contains("materials.glass"), "{msg}");
    let (msg, _) = error(&GOOD.replace("time = 1.0", "time = 0.0"));
    assert!(msg.contains("keyframes"), "{msg}");
    let (msg, _) = error("[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n");
    assert!(msg.contains("no object"), "{msg}");
    let (msg, _) = error("resolution = [");
    assert!(msg.contains("test.toml:1"), "{msg}");
}

#[test]
fn mesh_files_resolve_relative_to_the_scene_and_load_through_load() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("m")).unwrap();
    std::fs::write(
        d.path().join("m/tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene = GOOD.replace("shape = \"quad\"", "mesh = \"m/tri.obj\"");
    let p: &Path = &d.path().join("s.toml");
    std::fs::write(p, scene).unwrap();
    let s = super::load(p.to_str().unwrap()).unwrap();
    assert_eq!(s.meshes[0].mesh.indices.len(), 1);
    assert_eq!(s.name, "s");
}

#[test]
fn gltf_objects_are_placed_whole() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("q.gltf"), super::gltf::tests::quad_gltf()).unwrap();
    let scene = GOOD.replace(
        "shape = \"quad\"\nmaterial = \"red\"\nscale = [10, 1, 10]",
        "mesh = \"q.gltf\"\ntranslate = [0, 5, 0]",
    );
    let p = d.path().join("g.toml");
    std::fs::write(&p, &scene).unwrap();
    let s = super::load(p.to_str().unwrap()).unwrap();
    // The node's z = -2 and the object's y = 5 compose.
    let t = s.instances[0].world_from_object.translation;
    assert_eq!((t.y, t.z), (5.0, -2.0));
    assert_eq!(
        s.lights.len(),
        3,
        "the glTF's point light joins the file's two"
    );
    assert!(s.materials[s.meshes[0].material[0] as usize].optics.fresnel);
    let bad = scene.replace("translate = [0, 5, 0]", "keyframes = [{ time = 1.0 }]");
    std::fs::write(&p, bad).unwrap();
    let e = super::load(p.to_str().unwrap()).unwrap_err().to_string();
    assert!(e.contains("keyframes") && e.contains("g.toml:"), "{e}");
}

#[test]
fn a_goniodiagram_from_an_ies_file() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(
        d.path().join("lamp.ies"),
        "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 100\n0 45 90\n0\n1000 800 100\n",
    )
    .unwrap();
    let scene = GOOD.replace(
        "type = \"omni\"\nposition = [0, 3, 0]\nintensity = [10, 10, 10]",
        "type = \"goniodiagram\"\nfile = \"lamp.ies\"\nposition = [0, 3, 0]",
    );
    let p = d.path().join("l.toml");
    std::fs::write(&p, scene).unwrap();
    let s = super::load(p.to_str().unwrap()).unwrap();
    assert_eq!(s.lights[0].kind(), crate::light::LightKind::Goniodiagram);
}

/// A scene file in a temporary folder whose object is `mesh` and whose environment light is
/// `env` (paths as the file gives them), with an `[assets]` table.
fn asset_scene(dir: &Path, mesh: &str, env: &str) -> PathBuf {
    let p = dir.join("assets.toml");
    std::fs::write(
        &p,
        format!(
            "[assets]\nfetch = \"assimp hdr\"\n\n[camera]\nposition = [0, 0, 3]\n\
             look_at = [0, 0, 0]\n\n[[objects]]\nmesh = \"{mesh}\"\n\n[[lights]]\n\
             type = \"environment\"\nfile = \"{env}\"\n"
        ),
    )
    .unwrap();
    p
}

#[test]
fn a_missing_or_corrupt_asset_names_it_and_how_to_fetch_it() {
    let d = tempfile::tempdir().unwrap();
    let cache = d.path().join(".cache/scenes");
    std::fs::create_dir_all(&cache).unwrap();
    let load = |p: &Path| super::load(p.to_str().unwrap()).unwrap_err();

    // Not fetched: the mesh, with its field and line, and the command.
    let p = asset_scene(
        d.path(),
        ".cache/scenes/engine.glb",
        ".cache/hdr/studio.exr",
    );
    let e = load(&p);
    let msg = e.to_string();
    assert!(e.is_missing_asset() && !e.is_on_demand_asset(), "{msg}");
    assert!(
        msg.contains("assets.toml:9:")
            && msg.contains("objects[0].mesh")
            && msg.contains("engine.glb is missing")
            && msg.contains("run `python3 scripts/native.py assimp hdr`"),
        "{msg}"
    );

    // From here on the environment map is there (its content is never read: loading stops
    // at the mesh), so the mesh's own files are what is missing or corrupt.
    std::fs::create_dir_all(d.path().join(".cache/hdr")).unwrap();
    std::fs::write(d.path().join(".cache/hdr/studio.exr"), b"not read").unwrap();

    // A glTF there whose buffer is not: the buffer is named as the missing asset.
    let gltf = super::gltf::tests::quad_gltf();
    let start = gltf.find("data:application").unwrap();
    let end = start + gltf[start..].find('"').unwrap();
    let gltf = gltf.replace(&gltf[start..end], "quad.bin");
    std::fs::write(cache.join("quad.gltf"), gltf).unwrap();
    let p = asset_scene(d.path(), ".cache/scenes/quad.gltf", ".cache/hdr/studio.exr");
    let e = load(&p);
    let msg = e.to_string();
    assert!(
        e.is_missing_asset() && msg.contains("quad.bin is missing"),
        "{msg}"
    );

    // Present but corrupt: cannot be read, fetch again.
    std::fs::write(cache.join("broken.glb"), b"glTF\x02\0\0\0garbage").unwrap();
    let p = asset_scene(
        d.path(),
        ".cache/scenes/broken.glb",
        ".cache/hdr/studio.exr",
    );
    let e = load(&p);
    let msg = e.to_string();
    assert!(!e.is_missing_asset(), "{msg}");
    assert!(
        msg.contains("broken.glb cannot be read")
            && msg.contains("`python3 scripts/native.py assimp hdr` to fetch it again"),
        "{msg}"
    );

    // The environment map: named with its light.
    std::fs::write(
        cache.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let p = asset_scene(d.path(), ".cache/scenes/tri.obj", ".cache/hdr/none.exr");
    let e = load(&p);
    let msg = e.to_string();
    assert!(
        e.is_missing_asset() && msg.contains("lights[0].file") && msg.contains("none.exr"),
        "{msg}"
    );

    // On-demand assets say so.
    let text = std::fs::read_to_string(&p).unwrap().replace(
        "fetch = \"assimp hdr\"",
        "fetch = \"dungeon\"\non_demand = true",
    );
    std::fs::write(&p, text).unwrap();
    let e = load(&p);
    assert!(e.is_on_demand_asset(), "{e}");
    assert!(e.to_string().contains("without --quick"), "{e}");

    // A missing file outside `.cache` keeps the plain error.
    let p = asset_scene(d.path(), "elsewhere.obj", "sky.exr");
    let e = load(&p);
    assert!(
        !e.is_missing_asset() && e.to_string().contains("elsewhere.obj"),
        "{e}"
    );
}

/// The first light's RGB intensity, when it is an omni light.
fn omni_intensity(text: &str) -> [f32; 3] {
    match &parse(&path(), text).unwrap().lights[0] {
        crate::light::Light::Omni(o) => o.intensity(),
        other => panic!("expected an omni light, got {:?}", other.kind()),
    }
}

#[test]
fn a_light_spectrum_colours_its_intensity_at_the_same_luminance() {
    let named = |extra: &str| {
        GOOD.replace(
            "intensity = [10, 10, 10]",
            &format!("intensity = [10, 10, 10]\n{extra}"),
        )
    };
    let plain = omni_intensity(GOOD);
    // D65 is the display's white: the intensity stays as it was.
    let d65 = omni_intensity(&named("spectrum = \"d65\""));
    for (a, b) in d65.iter().zip(plain) {
        assert!((a - b).abs() <= 1e-2 * b, "{d65:?} against {plain:?}");
    }
    // Illuminant A and a 2856 K blackbody (its definition) are warm, at the same luminance.
    let luminance = |c: [f32; 3]| crate::spectrum::cie::luminance_rgb(c);
    for extra in ["spectrum = \"A\"", "temperature = 2856.0"] {
        let a = omni_intensity(&named(extra));
        assert!(a[0] > a[1] && a[1] > a[2], "{extra}: {a:?}");
        let (y, y0) = (luminance(a), luminance(plain));
        assert!((y - y0).abs() <= 1e-2 * y0, "{extra}: Y {y} against {y0}");
    }
}

#[test]
fn bad_spectra_and_glasses_are_named() {
    let light = |extra: &str| {
        GOOD.replace(
            "intensity = [10, 10, 10]",
            &format!("intensity = [10, 10, 10]\n{extra}"),
        )
    };
    for (extra, words) in [
        ("spectrum = \"D99\"", &["lights[0]", "D99", "D65"][..]),
        ("temperature = 0.0", &["lights[0]", "temperature"]),
        ("temperature = -5.0", &["lights[0]", "temperature"]),
        ("temperature = 100001.0", &["lights[0]", "temperature"]),
        ("temperature = nan", &["lights[0]", "temperature"]),
        (
            "spectrum = \"A\"\ntemperature = 3000.0",
            &["lights[0]", "not both"],
        ),
    ] {
        let (msg, _) = error(&light(extra));
        for w in words {
            assert!(msg.contains(w), "{extra}: {msg}");
        }
        assert!(msg.contains("test.toml:"), "{extra}: {msg}");
    }
    let glass = |setting: &str| GOOD.replace("ior = 1.45", setting);
    for (setting, words) in [
        (
            "glass = \"unobtainium\"",
            &["materials.glass", "unobtainium", "BK7"][..],
        ),
        ("cauchy = [1.5, -0.004]", &["materials.glass", "-0.004"]),
        ("cauchy = [1.5]", &["materials.glass", "cauchy"]),
        ("cauchy = [nan, 0.004]", &["materials.glass", "NaN"]),
        (
            "sellmeier = { b = [1.0, 0.2, 1.0], c = [0.006, -0.02, 100.0] }",
            &["materials.glass", "-0.02"],
        ),
        (
            "sellmeier = { b = [1.0, 0.2, inf], c = [0.006, 0.02, 100.0] }",
            &["materials.glass", "inf"],
        ),
        // A pole of the index inside the visible range (0.25 um^2: 500 nm).
        (
            "sellmeier = { b = [1.0, 0.2, 1.0], c = [0.006, 0.25, 100.0] }",
            &["materials.glass"],
        ),
        ("ior = 1.5\nglass = \"BK7\"", &["materials.glass", "one of"]),
    ] {
        let (msg, _) = error(&glass(setting));
        for w in words {
            assert!(msg.contains(w), "{setting}: {msg}");
        }
    }
}

#[test]
fn a_dispersive_glass_renders_rgb_at_its_d_line_index() {
    let ior = |setting: &str| {
        let s = parse(&path(), &GOOD.replace("ior = 1.45", setting)).unwrap();
        s.materials
            .iter()
            .find(|m| m.name == "glass")
            .unwrap()
            .optics
            .ior
    };
    assert_eq!(ior("ior = 1.45"), 1.45);
    // A relative index below 1 (a bubble in water) stays allowed.
    assert_eq!(ior("ior = 0.75"), 0.75);
    assert!((ior("glass = \"BK7\"") - 1.5168).abs() < 1e-4);
    assert!((ior("glass = \"f2\"") - 1.6200).abs() < 1e-4);
    assert!((ior("cauchy = [1.5, 0.0042]") - (1.5 + 0.0042 / 0.58756f32.powi(2))).abs() < 1e-5);
    let bk7 = "sellmeier = { b = [1.03961212, 0.231792344, 1.01046945], \
               c = [0.00600069867, 0.0200179144, 103.560653] }";
    assert!((ior(bk7) - ior("glass = \"BK7\"")).abs() < 1e-6);
}
