//! `coherent render` and `coherent scenes` as a user calls them (paper section 7's renderer
//! behind the command line): a built-in scene renders to a PNG and an EXR with a summary line;
//! bad input fails with a message naming the problem, never a panic.

use std::process::Output;

fn coherent(args: &[&str]) -> Output {
    coherent::require::command(env!("CARGO_BIN_EXE_coherent"))
        .args(args)
        .output()
        .expect("the coherent binary runs")
}

/// `coherent render cornell` at 32 x 24, 1 spp, one thread, quiet, into `out`, with `extra`.
fn render_cornell(out: &std::path::Path, extra: &[&str]) -> Output {
    render_small("cornell", out, extra)
}

/// `coherent render SCENE` at 32 x 24, 1 spp, one thread, quiet, into `out`, with `extra`.
fn render_small(scene: &str, out: &std::path::Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene,
        "--resolution",
        "32x24",
        "--spp",
        "1",
        "--threads",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    coherent(&args)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn scenes_lists_the_built_in_scenes_and_the_scene_files() {
    let out = coherent(&["scenes"]);
    assert!(out.status.success(), "{}", text(&out));
    let listed = String::from_utf8_lossy(&out.stdout);
    for name in [
        "car",
        "spdemo",
        "glass1",
        "room2",
        "cornell",
        "engine.toml",
        "bunny.toml",
    ] {
        assert!(
            listed.lines().any(|l| l.trim_start().starts_with(name)),
            "{name} missing from:\n{listed}"
        );
    }
}

#[test]
fn a_built_in_scene_renders_to_png_and_exr_with_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    for file in ["cornell.png", "cornell.exr"] {
        let path = dir.path().join(file);
        let out = render_cornell(&path, &[]);
        assert!(out.status.success(), "{}", text(&out));
        let written = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        assert!(written > 0, "{file} not written:\n{}", text(&out));
        assert!(
            text(&out).contains("Mrays/s"),
            "no summary:\n{}",
            text(&out)
        );
    }
}

#[test]
fn every_backend_that_runs_here_renders_a_frame() {
    // scalar-est included: the renderer's kernels are the ones that opt in to it.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.png");
    for b in coherent::simd::Backend::every() {
        let out = render_cornell(&path, &["--backend", b.name()]);
        if b.is_available() {
            assert!(out.status.success(), "{b}: {}", text(&out));
        } else {
            assert!(!out.status.success(), "{b} is unavailable but rendered");
            assert!(text(&out).contains(b.name()), "{}", text(&out));
        }
    }
}

#[test]
fn aov_writes_each_map_beside_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.png");
    let out = render_cornell(&path, &["--aov", "steps,lanes", "--accel", "bsp"]);
    assert!(out.status.success(), "{}", text(&out));
    for file in [
        "cornell.steps.png",
        "cornell.steps.exr",
        "cornell.lanes.png",
        "cornell.lanes.exr",
    ] {
        let written = std::fs::metadata(dir.path().join(file)).map_or(0, |m| m.len());
        assert!(written > 0, "{file} not written:\n{}", text(&out));
    }
    assert!(text(&out).contains("map steps: mean"), "{}", text(&out));
    // Brute force does not count its work: steps are refused, with the reason.
    let out = render_cornell(&path, &["--aov", "tests", "--accel", "brute"]);
    assert!(!out.status.success());
    assert!(text(&out).contains("does not count"), "{}", text(&out));
    let out = render_cornell(&path, &["--aov", "nodes"]);
    assert!(!out.status.success());
    assert!(
        text(&out).contains("steps, tests, lanes or time"),
        "{}",
        text(&out)
    );
}

#[test]
fn stages_prints_the_time_of_each_pipeline_stage() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.exr");
    let run = |extra: &[&str]| {
        let out = render_cornell(&path, extra);
        assert!(out.status.success(), "{}", text(&out));
        text(&out)
    };
    let timed = run(&["--stages"]);
    let line = timed
        .lines()
        .find(|l| l.starts_with("time by stage"))
        .unwrap_or_else(|| panic!("no stage line:\n{timed}"));
    for stage in ["traversal", "shadows", "shading", "lights", "other"] {
        assert!(line.contains(stage), "{stage} missing from: {line}");
    }
    // The traversal of the camera rays alone takes some time on any machine.
    assert!(!line.contains("traversal 0.000 s (0.0%)"), "{line}");
    assert!(!run(&[]).contains("time by stage"));
}

#[test]
fn frames_renders_several_frames_and_reports_their_median() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.png");
    let args = |frames: &str| render_cornell(&path, &["--frames", frames]);
    let out = args("3");
    assert!(out.status.success(), "{}", text(&out));
    let all = text(&out);
    let line = all
        .lines()
        .find(|l| l.starts_with("3 frames: "))
        .unwrap_or_else(|| panic!("no frames line:\n{all}"));
    let times: Vec<f64> = line["3 frames: ".len()..line.find(" s;").unwrap()]
        .split(", ")
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(times.len(), 3, "{line}");
    assert!(times.iter().all(|t| *t > 0.0), "{line}");
    for bad in ["0", "x"] {
        let out = args(bad);
        assert!(!out.status.success(), "--frames {bad} accepted");
        assert!(text(&out).contains("--frames"), "{}", text(&out));
    }
}

#[test]
fn bad_input_fails_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("x.png");
    let png = png.to_str().unwrap();
    let missing = dir.path().join("missing.toml");
    // A scene whose fetched asset is not there: named, with the command that fetches it.
    let unfetched = dir.path().join("unfetched.toml");
    std::fs::write(
        &unfetched,
        "[assets]\nfetch = \"assimp\"\n[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n\
         [[objects]]\nmesh = \".cache/scenes/assimp/nothing.glb\"\n\
         [[lights]]\ntype = \"omni\"\nposition = [0, 3, 0]\nintensity = [1, 1, 1]\n",
    )
    .unwrap();
    let nowhere = dir.path().join("no-such-folder").join("x.png");
    // A bare mesh too large for the default light placed from its box.
    let huge = dir.path().join("huge.obj");
    std::fs::write(&huge, "v 1e30 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n").unwrap();
    let cases: [(Vec<&str>, &str); 10] = [
        (
            vec!["render", huge.to_str().unwrap(), "--out", png],
            "too large for a light placed from it",
        ),
        (
            vec!["render", "cornell", "--threads", "5000", "--out", png],
            "--threads 5000: must be 1 to 1024",
        ),
        (
            vec!["render", "cornell", "--out", nowhere.to_str().unwrap()],
            "no-such-folder does not exist",
        ),
        (
            vec!["render", unfetched.to_str().unwrap(), "--out", png],
            "nothing.glb is missing; it is not fetched: run `python3 scripts/native.py assimp`",
        ),
        (
            vec!["render", missing.to_str().unwrap(), "--out", png],
            "missing.toml",
        ),
        (
            vec!["render", "no-such-scene", "--out", png],
            "no-such-scene",
        ),
        (
            vec!["render", "cornell", "--resolution", "0x0", "--out", png],
            "resolution",
        ),
        (
            vec!["render", "cornell", "--backend", "avx1024", "--out", png],
            "avx1024",
        ),
        (vec!["render", "cornell", "--out", "x.bmp"], "x.bmp"),
        (
            vec![
                "render",
                "cornell",
                "--light-samples",
                "tiles",
                "--out",
                png,
            ],
            "unknown light sampling `tiles`: pixel or tile",
        ),
    ];
    for (args, needle) in cases {
        let out = coherent(&args);
        let said = text(&out);
        assert!(!out.status.success(), "{args:?} succeeded:\n{said}");
        assert!(!said.contains("panicked"), "{args:?} panicked:\n{said}");
        assert!(
            said.contains(needle),
            "{args:?}: `{needle}` not in:\n{said}"
        );
    }
}

#[test]
fn an_error_says_each_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    let png = dir.path().join("x.png");
    let out = coherent(&[
        "render",
        missing.to_str().unwrap(),
        "--out",
        png.to_str().unwrap(),
    ]);
    let said = text(&out);
    assert!(!out.status.success());
    assert_eq!(said.matches("(os error 2)").count(), 1, "{said}");
}

#[test]
fn the_scene_files_tone_map_is_used_unless_the_command_line_names_one() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("lit.toml");
    std::fs::write(
        &scene,
        r#"name = "lit"
tonemap = "reinhard"

[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 45

[materials.grey]
type = "phong"
diffuse = [0.5, 0.5, 0.5]

[[objects]]
shape = "quad"
material = "grey"
scale = [4, 1, 4]

[[lights]]
type = "omni"
position = [0.0, 2.0, 1.0]
intensity = [40.0, 40.0, 40.0]
"#,
    )
    .unwrap();
    let png = |name: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        let out = render_small(scene.to_str().unwrap(), &path, extra);
        assert!(out.status.success(), "{}", text(&out));
        std::fs::read(path).unwrap()
    };
    let from_file = png("file.png", &[]);
    assert_eq!(from_file, png("reinhard.png", &["--tonemap", "reinhard"]));
    assert_ne!(from_file, png("tumblin.png", &["--tonemap", "tumblin"]));
}
