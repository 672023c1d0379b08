//! Experiment `view`: the interactive mode (paper section 6.2) as `coherent view` runs it.
//! On cornell and room2 at 512 x 384 with the widest backend, lane packets, the BSP and every
//! thread: how soon the first image follows a camera move, how the session's refinement
//! compares with `coherent render`'s frame at the same samples, and what 20 clients polling
//! `/frame.png` over HTTP cost the refinement.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, anyhow};
use coherent::accel::Accel;
use coherent::accel_any::{AccelKind, AnyAccel, AnyParams};
use coherent::film::{FilmOptions, Method};
use coherent::median::median;
use coherent::render::{Renderer, render_frame};
use coherent::simd::Backend;
use coherent::view::{Move, Sampling, Server, Session, SessionOptions, Settings, load_scene};

use crate::ctx::Ctx;
use crate::experiment::{Experiment, Status};
use crate::table::markdown_table;

pub const EXPERIMENT: Experiment = Experiment {
    name: "view",
    description: "the interactive viewer: first image after a camera move, refinement against a batch render, polling clients",
    paper: "section 6.2 (interactive mode)",
    csv: &[FILE],
    plots: &[],
    status: Status::Ready {
        run,
        plot: |_| Ok(()),
        report,
    },
};

const FILE: &str = "view.csv";
const HEADER: &[&str] = &[
    "scene",
    "resolution",
    "backend",
    "threads",
    "measure",
    "median_s",
    "max_s",
    "rounds",
];
const SCENES: [&str; 2] = ["cornell", "room2"];
/// Clients polling `/frame.png` at once in the `refine_polled` rounds.
const CLIENTS: usize = 20;
/// How long to wait for one frame before calling the session stuck.
const PATIENCE: Duration = Duration::from_secs(120);

/// Waits for the frame of `generation` that `done` accepts; its seconds since the change.
fn wait_for(
    rx: &std::sync::mpsc::Receiver<Arc<coherent::view::Frame>>,
    generation: u64,
    done: impl Fn(&coherent::view::Frame) -> bool,
) -> anyhow::Result<f64> {
    let end = Instant::now() + PATIENCE;
    loop {
        let left = end.saturating_duration_since(Instant::now());
        let f = rx
            .recv_timeout(left)
            .map_err(|e| anyhow!("no frame of generation {generation}: {e}"))?;
        if f.generation == generation && done(&f) {
            return Ok(f.since_change);
        }
    }
}

/// How often a client asks: as often as the viewer's page asks for `/state`.
const POLL_EVERY: Duration = Duration::from_millis(200);

/// Polls `/frame.png` every [`POLL_EVERY`] until `stop`, counting the answers.
fn poll(addr: SocketAddr, stop: &AtomicBool, served: &AtomicU64) {
    let mut next = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now < next {
            std::thread::sleep((next - now).min(Duration::from_millis(10)));
            continue;
        }
        next += POLL_EVERY;
        let Ok(mut s) = TcpStream::connect(addr) else {
            continue;
        };
        let _ = s.set_read_timeout(Some(Duration::from_secs(10)));
        if s.write_all(b"GET /frame.png HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            .is_err()
        {
            continue;
        }
        let mut body = Vec::new();
        if s.read_to_end(&mut body).is_ok() && body.starts_with(b"HTTP/1.1 200") {
            served.fetch_add(1, Ordering::Relaxed);
        }
    }
}

fn run(ctx: &mut Ctx) -> anyhow::Result<()> {
    let (w, h) = ctx.pick((256, 192), (512, 384));
    let moves = ctx.pick(4, 16);
    let rounds = ctx.pick(2, 5);
    let spp = ctx.pick(4, 16);
    let backend = Backend::widest();
    let threads = rayon::current_num_threads();
    let mut csv = ctx.csv(FILE, HEADER)?;
    let bar = ctx.progress(SCENES.len() as u64, "view");
    for name in SCENES {
        let mut scene = load_scene(name).map_err(|e| anyhow!("{e}"))?;
        scene.width = w;
        scene.height = h;
        let mut settings = Settings::of_scene(&scene);
        settings.backend = backend;
        settings.accel = AccelKind::Bsp;
        settings.sampling = Sampling::Uniform { spp };
        let opts = SessionOptions {
            threads,
            idle: Duration::from_secs(3600),
        };
        let session = Arc::new(
            Session::start(scene.clone(), settings.clone(), opts).map_err(|e| anyhow!("{e}"))?,
        );
        let rx = session.subscribe();

        // First image after a move: the pre-render's frame (pass 0), from the change.
        let mut first = Vec::new();
        for i in 0..moves {
            let yaw = if i % 2 == 0 { 0.05 } else { -0.05 };
            let g = session
                .move_camera(Move::Orbit { yaw, pitch: 0.0 })
                .map_err(|e| anyhow!("{e}"))?;
            first.push(wait_for(&rx, g, |f| f.pass == 0)?);
            // Let the render finish, so that the next move interrupts nothing.
            wait_for(&rx, g, |f| f.stop.is_some())?;
        }

        // Refinement: `spp` passes in the session against one batch frame of the same
        // samples at the same camera, rounds interleaved; then again while clients poll.
        let accel = AnyAccel::build(&scene.accel_scene(), &AnyParams::of(AccelKind::Bsp))?;
        let mut renderer = Renderer::new(&scene, accel, w, h)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .stack_size(64 << 20)
            .build()?;
        let film = FilmOptions {
            tonemap: scene.tonemap,
            ..FilmOptions::new(w, h, Method::Uniform { spp })
        };
        let server = Server::bind("127.0.0.1:0".parse()?)
            .map_err(|e| anyhow!("{e}"))?
            .spawn(Arc::clone(&session))
            .context("starting the view server")?;
        let (mut in_session, mut batch, mut polled) = (Vec::new(), Vec::new(), Vec::new());
        let mut served = 0u64;
        for r in 0..rounds {
            let yaw = if r % 2 == 0 { 0.03 } else { -0.03 };
            let g = session
                .move_camera(Move::Orbit { yaw, pitch: 0.0 })
                .map_err(|e| anyhow!("{e}"))?;
            in_session.push(wait_for(&rx, g, |f| f.stop.is_some())?);

            renderer
                .set_view(&session.status().settings.camera, w, h)
                .map_err(|e| anyhow!("{e}"))?;
            let t = Instant::now();
            pool.install(|| render_frame(backend, &renderer, &film, &|_| {}))?;
            batch.push(t.elapsed().as_secs_f64());

            let stop = AtomicBool::new(false);
            let count = AtomicU64::new(0);
            let seconds = std::thread::scope(|s| {
                for _ in 0..CLIENTS {
                    s.spawn(|| poll(server.addr(), &stop, &count));
                }
                let g = session.move_camera(Move::Orbit {
                    yaw: -yaw,
                    pitch: 0.0,
                });
                let out = g
                    .map_err(|e| anyhow!("{e}"))
                    .and_then(|g| wait_for(&rx, g, |f| f.stop.is_some()));
                stop.store(true, Ordering::Relaxed);
                out
            })?;
            polled.push(seconds);
            served += count.load(Ordering::Relaxed);
        }
        server.stop();
        if served == 0 {
            ctx.note(format!("view: {name}: the polling clients got no frame"));
        }
        let resolution = format!("{w}x{h}");
        for (measure, v) in [
            ("first_image", &first),
            ("refine_session", &in_session),
            ("refine_render", &batch),
            ("refine_polled", &polled),
        ] {
            let max = v.iter().copied().fold(0.0f64, f64::max);
            csv.row(&[
                &name,
                &resolution,
                &backend.name(),
                &threads,
                &measure,
                &format!("{:.6}", median(v)),
                &format!("{max:.6}"),
                &v.len(),
            ])?;
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.finish()?;
    Ok(())
}

fn report(ctx: &Ctx) -> anyhow::Result<Option<String>> {
    let Some(t) = ctx.read_csv(FILE, HEADER)? else {
        return Ok(None);
    };
    let get = |scene: &str, measure: &str| -> Option<(f64, f64, String)> {
        (0..t.len()).find_map(|r| {
            (t.get(r, "scene").ok()? == scene && t.get(r, "measure").ok()? == measure).then(
                || {
                    Some((
                        t.f64(r, "median_s").ok()?,
                        t.f64(r, "max_s").ok()?,
                        format!(
                            "{} {} on {} thread(s)",
                            t.get(r, "resolution").ok()?,
                            t.get(r, "backend").ok()?,
                            t.get(r, "threads").ok()?
                        ),
                    ))
                },
            )?
        })
    };
    let mut rows = Vec::new();
    for scene in SCENES {
        let (Some(first), Some(sess), Some(batch), Some(polled)) = (
            get(scene, "first_image"),
            get(scene, "refine_session"),
            get(scene, "refine_render"),
            get(scene, "refine_polled"),
        ) else {
            continue;
        };
        let verdict = |ok: bool| if ok { "met" } else { "missed" };
        rows.push(vec![
            format!("{scene} ({})", first.2),
            format!(
                "{:.1} ms (max {:.1}): {}",
                first.0 * 1e3,
                first.1 * 1e3,
                verdict(first.0 <= 0.1)
            ),
            format!(
                "{:.3} s / {:.3} s = {:.2}x: {}",
                sess.0,
                batch.0,
                sess.0 / batch.0,
                verdict(sess.0 <= 1.1 * batch.0)
            ),
            format!(
                "{:.3} s / {:.3} s = {:.2}x: {}",
                polled.0,
                sess.0,
                polled.0 / sess.0,
                verdict(polled.0 <= 1.1 * sess.0)
            ),
        ]);
    }
    let mut md = String::from(
        "`coherent view`'s session on each scene, the widest backend, lane packets, the BSP, \
         every thread, uniform sampling. First image: from a camera move (a small orbit) to \
         the published pre-render (superpixel corners, tone-mapped and encoded as PNG), median \
         and largest over the moves; target 100 ms. Refinement: from a move to the last \
         pass's published frame, against `render_frame` of the same samples at the same \
         camera (the batch render of `coherent render`), medians of interleaved rounds; \
         target at most 1.10x. Polled: the same refinement while 20 clients fetch \
         `/frame.png` over HTTP, each every 200 ms as the page polls; target at most 1.10x \
         the unpolled session.\n\n",
    );
    md.push_str(&markdown_table(
        &[
            "scene",
            "first image after a move",
            "refinement: session / batch render",
            "refinement: polled / unpolled",
        ],
        &rows,
    ));
    Ok(Some(md))
}
