//! A restartable progressive render (the paper's interactive mode, section 6.2): a worker
//! thread steps the progressive film pass after pass and publishes each pass's image as a
//! [`Frame`]; a change of the settings restarts it from nothing.
//!
//! A change sets the cancel flag (the pass in flight gives up between tiles), the old
//! [`Progressive`] is dropped with every sample it held, the accelerator is rebuilt only when
//! its kind changed, the camera and image size go to the renderer without a rebuild, and a
//! new render starts, whose pre-render (pass 0) is published at once. A finished render
//! (accuracy or samples reached) waits for the next change; a render nobody has asked about
//! for a while ([`SessionOptions::idle`]) pauses until the next request.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::accel::Accel;
use crate::accel_any::{AnyAccel, AnyParams};
use crate::film::{FilmError, Progressive, heatmap_png, scale_top};
use crate::render::{AovBuffer, AovKind, RayKind, Renderer};
use crate::scene::RenderScene;

use super::frame::Frame;
use super::moves::{self, Move};
use super::settings::{Sampling, Settings};

/// A request the session refused, in words that name the problem.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct Refused(pub String);

/// How the session runs.
#[derive(Clone, Debug)]
pub struct SessionOptions {
    /// Rendering threads.
    pub threads: usize,
    /// How long the render goes on with no request ([`Session::touch`]) before it pauses.
    pub idle: Duration,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            idle: Duration::from_secs(10),
        }
    }
}

/// Where the session stands, besides its latest frame.
#[derive(Clone, Debug)]
pub struct Status {
    /// The settings the current (or next) render uses.
    pub settings: Settings,
    /// The current render: one more after every change.
    pub generation: u64,
    /// Whether the render waits for a request (nobody watched for a while).
    pub paused: bool,
    /// The last problem of the worker (a failed build or render), until the next change.
    pub error: Option<String>,
    /// Seconds from the last change to its first image (the pre-render), once shown.
    pub first_image_seconds: Option<f64>,
}

/// A scene being rendered progressively for a viewer.
pub struct Session {
    shared: Arc<Shared>,
    scene: Arc<RenderScene>,
    worker: Option<JoinHandle<()>>,
}

/// What the worker and the callers share.
struct Shared {
    state: Mutex<State>,
    /// Woken on a change, on quitting, and on a request while paused.
    wake: Condvar,
    /// Set by a change: the pass in flight gives up between tiles.
    cancel: AtomicBool,
    frame: Mutex<Option<Arc<Frame>>>,
    idle: Duration,
}

struct State {
    settings: Settings,
    generation: u64,
    changed_at: Instant,
    last_request: Instant,
    paused: bool,
    quit: bool,
    error: Option<String>,
    first_image_seconds: Option<f64>,
    subscribers: Vec<mpsc::Sender<Arc<Frame>>>,
}

/// Locks, taking the data of a poisoned lock as it is: a panic elsewhere must not take the
/// viewer down with it, and every field stays meaningful on its own.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Loads a scene as `coherent render` does: validated, its static instances merged.
pub fn load_scene(spec: &str) -> Result<RenderScene, Refused> {
    let scene = crate::scene::load(spec).map_err(|e| Refused(format!("scene {spec}: {e}")))?;
    scene
        .validate()
        .map_err(|e| Refused(format!("scene {spec}: {e}")))?;
    Ok(scene.merge_static().0)
}

impl Session {
    /// Checks `settings`, builds the accelerator and starts rendering `scene` (loaded with
    /// [`load_scene`]); returns once the accelerator is built, or with why it could not be.
    pub fn start(
        scene: RenderScene,
        settings: Settings,
        options: SessionOptions,
    ) -> Result<Session, Refused> {
        if let Some(why) = settings.problem() {
            return Err(Refused(why));
        }
        // Unoptimised builds keep every packet temporary of the inlined pipeline on the
        // stack, as `coherent render` found; the reservation costs nothing.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(options.threads.max(1))
            .stack_size(64 << 20)
            .build()
            .map_err(|e| Refused(format!("starting the rendering threads: {e}")))?;
        let now = Instant::now();
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                settings,
                generation: 1,
                changed_at: now,
                last_request: now,
                paused: false,
                quit: false,
                error: None,
                first_image_seconds: None,
                subscribers: Vec::new(),
            }),
            wake: Condvar::new(),
            cancel: AtomicBool::new(false),
            frame: Mutex::new(None),
            idle: options.idle,
        });
        let scene = Arc::new(scene);
        let (ready_tx, ready_rx) = mpsc::sync_channel(1);
        let worker = {
            let (shared, scene) = (Arc::clone(&shared), Arc::clone(&scene));
            std::thread::Builder::new()
                .name("coherent-view".into())
                .spawn(move || work(&shared, &scene, &pool, ready_tx))
                .map_err(|e| Refused(format!("starting the render thread: {e}")))?
        };
        let session = Session {
            shared,
            scene,
            worker: Some(worker),
        };
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(session),
            Ok(Err(why)) => Err(Refused(why)),
            Err(_) => Err(Refused("the render thread stopped while starting".into())),
        }
    }

    /// The scene (as loaded and merged).
    pub fn scene(&self) -> &RenderScene {
        &self.scene
    }

    /// The latest frame, once the first pre-render is done.
    pub fn frame(&self) -> Option<Arc<Frame>> {
        lock(&self.shared.frame).clone()
    }

    /// The latest frame (if any), then every frame published from now on, in order.
    pub fn subscribe(&self) -> mpsc::Receiver<Arc<Frame>> {
        let (tx, rx) = mpsc::channel();
        // Under the state lock, which publishing holds: no frame is missed or sent twice.
        let mut st = lock(&self.shared.state);
        if let Some(f) = self.frame() {
            let _ = tx.send(f);
        }
        st.subscribers.push(tx);
        rx
    }

    /// The settings, the generation and the worker's state.
    pub fn status(&self) -> Status {
        let st = lock(&self.shared.state);
        Status {
            settings: st.settings.clone(),
            generation: st.generation,
            paused: st.paused,
            error: st.error.clone(),
            first_image_seconds: st.first_image_seconds,
        }
    }

    /// Someone is watching: the render goes on (or resumes) for [`SessionOptions::idle`].
    pub fn touch(&self) {
        let mut st = lock(&self.shared.state);
        st.last_request = Instant::now();
        if st.paused {
            self.shared.wake.notify_all();
        }
    }

    /// Changes the settings with `edit` and restarts the render, unless `edit` refuses or the
    /// result is not renderable (then nothing changes). Returns the render's generation
    /// (the same one when nothing changed).
    pub fn change(
        &self,
        edit: impl FnOnce(&mut Settings) -> Result<(), String>,
    ) -> Result<u64, Refused> {
        let mut st = lock(&self.shared.state);
        let mut s = st.settings.clone();
        edit(&mut s).map_err(Refused)?;
        if let Some(why) = s.problem() {
            return Err(Refused(why));
        }
        if s == st.settings {
            return Ok(st.generation);
        }
        st.settings = s;
        st.generation += 1;
        st.changed_at = Instant::now();
        st.last_request = st.changed_at;
        st.error = None;
        st.first_image_seconds = None;
        self.shared.cancel.store(true, Ordering::SeqCst);
        self.shared.wake.notify_all();
        Ok(st.generation)
    }

    /// Moves the camera ([`moves::apply`]) and restarts the render.
    pub fn move_camera(&self, m: Move) -> Result<u64, Refused> {
        self.change(|s| {
            s.camera = moves::apply(&s.camera, m)?;
            Ok(())
        })
    }

    /// Puts the scene's own camera back and restarts the render.
    pub fn reset_camera(&self) -> Result<u64, Refused> {
        let camera = self.scene.camera;
        self.change(|s| {
            s.camera = camera;
            Ok(())
        })
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        {
            let mut st = lock(&self.shared.state);
            st.quit = true;
            self.shared.cancel.store(true, Ordering::SeqCst);
            self.shared.wake.notify_all();
        }
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}

/// The worker: builds the first accelerator (telling `ready` how that went), then renders
/// generation after generation until the session is dropped.
fn work(
    shared: &Shared,
    scene: &RenderScene,
    pool: &rayon::ThreadPool,
    ready: mpsc::SyncSender<Result<(), String>>,
) {
    let first = lock(&shared.state).settings.clone();
    let t = Instant::now();
    let built = pool
        .install(|| AnyAccel::build(&scene.accel_scene(), &AnyParams::of(first.accel)))
        .map_err(|e| {
            format!(
                "building the {} accelerator for {}: {e}",
                first.accel, scene.name
            )
        })
        .and_then(|a| {
            Renderer::new(scene, a, first.width, first.height)
                .map_err(|e| format!("the camera: {e}"))
        });
    let mut renderer = match built {
        Ok(r) => {
            let _ = ready.send(Ok(()));
            r
        }
        Err(why) => {
            let _ = ready.send(Err(why));
            return;
        }
    };
    let mut build_seconds = t.elapsed().as_secs_f64();

    loop {
        let (settings, generation, changed_at) = {
            let st = lock(&shared.state);
            if st.quit {
                return;
            }
            // Cleared under the lock: a change after this read sets it again and bumps the
            // generation, so it is never lost.
            shared.cancel.store(false, Ordering::SeqCst);
            (st.settings.clone(), st.generation, st.changed_at)
        };
        let old = renderer.accel().kind();
        if settings.accel != old {
            let t = Instant::now();
            let built = pool
                .install(|| AnyAccel::build(&scene.accel_scene(), &AnyParams::of(settings.accel)))
                .map_err(|e| e.to_string())
                .and_then(|a| {
                    Renderer::new(scene, a, settings.width, settings.height)
                        .map_err(|e| e.to_string())
                });
            match built {
                Ok(r) => {
                    renderer = r;
                    build_seconds = t.elapsed().as_secs_f64();
                }
                Err(e) => {
                    // Keep rendering with the accelerator that works, and say why.
                    let mut st = lock(&shared.state);
                    if st.generation == generation {
                        st.settings.accel = old;
                        st.error = Some(format!(
                            "building the {} accelerator failed ({e}); kept {old}",
                            settings.accel
                        ));
                        st.generation += 1;
                        st.changed_at = Instant::now();
                    }
                    continue;
                }
            }
        }
        if let Err(e) = renderer.set_view(&settings.camera, settings.width, settings.height) {
            fail(shared, generation, format!("the camera: {e}"));
            continue;
        }
        renderer.packets = settings.packets;
        let aov = settings
            .aov
            .map(|k| (k, Arc::new(AovBuffer::new(settings.width, settings.height))));
        renderer.aov = aov.as_ref().map(|(_, b)| Arc::clone(b));
        let look = Look {
            settings: &settings,
            aov: aov.as_ref().map(|(k, b)| (*k, &**b)),
            tonemap: scene.tonemap,
            generation,
            changed_at,
            build_seconds,
        };
        render(shared, &renderer, pool, &look);
    }
}

/// What a render's frames are made with.
struct Look<'a> {
    settings: &'a Settings,
    aov: Option<(AovKind, &'a AovBuffer)>,
    /// The scene's tone-mapping operator, as `coherent render` uses it.
    tonemap: crate::tonemap::Operator,
    generation: u64,
    changed_at: Instant,
    build_seconds: f64,
}

/// One generation: the pre-render, then a pass at a time while someone watches, until it
/// stops (then waits for a change), is cancelled or fails. Every sample is dropped on return.
fn render(
    shared: &Shared,
    renderer: &Renderer<'_, AnyAccel>,
    pool: &rayon::ThreadPool,
    look: &Look<'_>,
) {
    let s = look.settings;
    let opts = s.film_options(look.tonemap);
    let started = pool.install(|| Progressive::new(s.backend, renderer, &opts));
    let mut p = match started {
        Ok(p) => p.with_cancel(&shared.cancel),
        Err(FilmError::Cancelled) => return,
        Err(e) => return fail(shared, look.generation, e.to_string()),
    };
    if let Err(e) = pool.install(|| publish(shared, &p, look)) {
        return fail(shared, look.generation, e.to_string());
    }
    loop {
        if !wait_while_idle(shared, look.generation) {
            return;
        }
        match pool.install(|| p.step().map(|r| r.is_some())) {
            Ok(true) => {
                if let Err(e) = pool.install(|| publish(shared, &p, look)) {
                    return fail(shared, look.generation, e.to_string());
                }
            }
            Ok(false) => {
                // Stopped: the last frame again, with the reason.
                if let Err(e) = pool.install(|| publish(shared, &p, look)) {
                    return fail(shared, look.generation, e.to_string());
                }
                wait_for_change(shared, look.generation);
                return;
            }
            Err(FilmError::Cancelled) => return,
            Err(e) => return fail(shared, look.generation, e.to_string()),
        }
    }
}

/// Records the worker's problem and waits for the next change.
fn fail(shared: &Shared, generation: u64, why: String) {
    {
        let mut st = lock(&shared.state);
        if st.generation == generation {
            st.error = Some(why);
        }
    }
    wait_for_change(shared, generation);
}

/// Waits while nobody asks for frames; false when the render must end instead (a change or
/// quitting).
fn wait_while_idle(shared: &Shared, generation: u64) -> bool {
    let mut st = lock(&shared.state);
    loop {
        if st.quit || st.generation != generation {
            st.paused = false;
            return false;
        }
        if st.last_request.elapsed() < shared.idle {
            st.paused = false;
            return true;
        }
        st.paused = true;
        st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
    }
}

/// Waits for the next change of the settings (or quitting).
fn wait_for_change(shared: &Shared, generation: u64) {
    let mut st = lock(&shared.state);
    while !st.quit && st.generation == generation {
        st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
    }
}

/// Makes the frame of the render's last pass and hands it to the callers.
fn publish(
    shared: &Shared,
    p: &Progressive<'_, Renderer<'_, AnyAccel>>,
    look: &Look<'_>,
) -> Result<(), FilmError> {
    let s = look.settings;
    let record = &p.passes()[p.passes().len() - 1];
    // The frame that says the render stopped shows the last pass again: its image as it was.
    let same = lock(&shared.frame)
        .as_ref()
        .filter(|f| f.generation == look.generation && f.pass == record.pass)
        .map(|f| (f.png.clone(), f.width, f.height));
    let png = match (same, look.aov) {
        (Some((png, _, _)), _) => png,
        (None, aov) => match aov {
            Some((kind, buf)) => {
                let map = buf.map(kind);
                // Lanes on the packet's own scale, so that widths compare (as `coherent render`).
                let top = match kind {
                    AovKind::Lanes => s.backend.lanes() as f32,
                    _ => scale_top(&map),
                };
                heatmap_png(&map, s.width, s.height, top, kind.label())?
            }
            None => p.film().png(s.backend)?,
        },
    };
    let (width, height) = png_size(&png).unwrap_or((s.width, s.height));
    let stats = p.stats();
    let all_rays = stats.total_rays();
    let seconds = record.seconds;
    let done = match s.sampling {
        Sampling::Uniform { spp } => f64::from(record.pass) / f64::from(spp.max(1)),
        Sampling::Adaptive { .. } => record.done,
    };
    let frame = Arc::new(Frame {
        png,
        width,
        height,
        generation: look.generation,
        pass: record.pass,
        rays: record.rays,
        all_rays,
        seconds,
        rays_per_second: all_rays as f64 / seconds.max(1e-9),
        active_lanes: RayKind::ALL
            .iter()
            .filter(|k| stats.kinds[**k as usize].packets > 0)
            .map(|k| (k.name(), stats.kinds[*k as usize].average()))
            .collect(),
        lanes: s.backend.lanes(),
        estimate: record.estimate,
        done: done.clamp(0.0, 1.0),
        build_seconds: look.build_seconds,
        since_change: look.changed_at.elapsed().as_secs_f64(),
        stop: p.stop().map(|r| r.describe()),
    });
    let mut st = lock(&shared.state);
    if st.generation != look.generation {
        // Already out of date: the next render's frames will do.
        return Ok(());
    }
    if record.pass == 0 && p.stop().is_none() {
        st.first_image_seconds = Some(frame.since_change);
    }
    *lock(&shared.frame) = Some(Arc::clone(&frame));
    st.subscribers
        .retain(|tx| tx.send(Arc::clone(&frame)).is_ok());
    Ok(())
}

/// Width and height from a PNG file's header.
fn png_size(png: &[u8]) -> Option<(u32, u32)> {
    let be = |b: &[u8]| Some(u32::from_be_bytes(b.try_into().ok()?));
    Some((be(png.get(16..20)?)?, be(png.get(20..24)?)?))
}
