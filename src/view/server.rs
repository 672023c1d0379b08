//! The viewer's web server: the page, the latest frame, the figures as JSON, and the page's
//! settings and camera moves, over HTTP/1.1 on a local port.
//!
//! One thread accepts connections and hands them to a few handler threads through a bounded
//! queue (a full queue is answered 503 at once); each handler reads one request
//! ([`http::read_request`]), answers it and closes the connection. A frame is served from the
//! session's published `Arc<Frame>`, never from the film, so many clients polling the image
//! do not slow the render. Nothing is served from files: the page is compiled in.

use std::io::{self, Read};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::accel_any::AccelKind;
use crate::render::{AovKind, Packets};
use crate::simd::Backend;

use super::form;
use super::http::{self, ReadError, Request, Response};
use super::moves::Move;
use super::session::{Refused, Session};
use super::settings::{MAX_VIEW_SIDE, Sampling, Settings};

/// The page, compiled in.
const PAGE: &str = include_str!("page.html");

/// Handler threads: enough that a few slow clients do not hold up the others.
const HANDLERS: usize = 8;
/// Connections waiting for a handler before new ones are turned away.
const QUEUE: usize = 64;
/// How long a client may take to send its request or take the response.
const IO_TIMEOUT: Duration = Duration::from_secs(10);
/// How long, and how much, an error response waits for the rest of a request it did not
/// read, so that the client sees the response rather than a reset connection.
const LINGER: Duration = Duration::from_millis(500);
const LINGER_BYTES: usize = 1 << 20;

/// A bound, not yet serving, listening socket.
pub struct Server {
    listener: TcpListener,
}

/// A server running on its own threads ([`Server::spawn`]).
pub struct Running {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    acceptor: Option<JoinHandle<()>>,
}

impl Server {
    /// Binds `addr` (port 0: any free port). A port in use is refused with what to do.
    pub fn bind(addr: SocketAddr) -> Result<Server, Refused> {
        match TcpListener::bind(addr) {
            Ok(listener) => Ok(Server { listener }),
            Err(e) if e.kind() == io::ErrorKind::AddrInUse => Err(Refused(format!(
                "port {} is in use: pass --port N or --port 0",
                addr.port()
            ))),
            Err(e) => Err(Refused(format!("cannot listen on {addr}: {e}"))),
        }
    }

    /// The address it listens on (with the port chosen for port 0).
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Serves `session` until the process ends.
    pub fn run(self, session: Arc<Session>) {
        serve(self.listener, session, Arc::new(AtomicBool::new(false)));
    }

    /// Serves `session` on threads of its own until [`Running::stop`] (or the process ends).
    pub fn spawn(self, session: Arc<Session>) -> io::Result<Running> {
        let addr = self.listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let listener = self.listener;
        let acceptor = std::thread::Builder::new()
            .name("coherent-view-accept".into())
            .spawn(move || serve(listener, session, flag))?;
        Ok(Running {
            addr,
            stop,
            acceptor: Some(acceptor),
        })
    }
}

impl Running {
    /// The address it serves.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops accepting, lets the handlers finish what they hold, and waits for them.
    pub fn stop(mut self) {
        self.shut();
    }

    fn shut(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the blocked accept with a connection of our own.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_secs(1));
        if let Some(a) = self.acceptor.take() {
            let _ = a.join();
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.shut();
    }
}

/// The choices the page offers, found once (whether Embree loads is asked of the library).
struct Choices {
    backends: Vec<&'static str>,
    accels: Vec<&'static str>,
}

impl Choices {
    fn here() -> Choices {
        Choices {
            backends: Backend::available()
                .into_iter()
                .map(Backend::name)
                .collect(),
            accels: AccelKind::available()
                .into_iter()
                .map(AccelKind::name)
                .collect(),
        }
    }
}

/// Accepts connections until `stop`, each handled on one of the handler threads.
fn serve(listener: TcpListener, session: Arc<Session>, stop: Arc<AtomicBool>) {
    let choices = Arc::new(Choices::here());
    let (tx, rx): (SyncSender<TcpStream>, Receiver<TcpStream>) = mpsc::sync_channel(QUEUE);
    let rx = Arc::new(Mutex::new(rx));
    let handlers: Vec<JoinHandle<()>> = (0..HANDLERS)
        .filter_map(|i| {
            let (rx, session, choices) =
                (Arc::clone(&rx), Arc::clone(&session), Arc::clone(&choices));
            std::thread::Builder::new()
                .name(format!("coherent-view-http-{i}"))
                .spawn(move || {
                    loop {
                        // The lock is held only while waiting for the next connection.
                        let next = rx.lock().unwrap_or_else(|e| e.into_inner()).recv();
                        match next {
                            Ok(stream) => handle(stream, &session, &choices),
                            Err(_) => return,
                        }
                    }
                })
                .ok()
        })
        .collect();
    for conn in listener.incoming() {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        // A failed accept (a client gone before it was taken, too many open files) is that
        // connection's problem, not the server's; a short pause keeps a persistent one from
        // spinning.
        let Ok(stream) = conn else {
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        let _ = stream.set_read_timeout(Some(IO_TIMEOUT));
        let _ = stream.set_write_timeout(Some(IO_TIMEOUT));
        match tx.try_send(stream) {
            Ok(()) => {}
            Err(TrySendError::Full(mut stream)) => {
                let _ = stream.set_write_timeout(Some(Duration::from_secs(1)));
                let _ = Response::text(503, "the viewer is busy: try again")
                    .with_header("Retry-After", "1")
                    .write_to(&mut stream);
            }
            Err(TrySendError::Disconnected(_)) => break,
        }
    }
    drop(tx);
    for h in handlers {
        let _ = h.join();
    }
}

/// Reads one request from `stream` and answers it. Write errors mean the client went away,
/// which ends this connection and nothing else.
fn handle(mut stream: TcpStream, session: &Session, choices: &Choices) {
    match http::read_request(&mut stream) {
        Ok(req) => {
            let resp = respond(&req, session, choices);
            let _ = resp.write_to(&mut stream);
        }
        Err(ReadError::Respond(resp)) => {
            let _ = resp.write_to(&mut stream);
            linger(&mut stream);
        }
        Err(ReadError::Gone) => {}
    }
}

/// After an error response sent before the request was read whole: closes the sending side
/// and reads what the client still sends for a moment. Closing with unread input resets the
/// connection, and the client might then never see the response.
fn linger(stream: &mut TcpStream) {
    let _ = stream.shutdown(Shutdown::Write);
    let _ = stream.set_read_timeout(Some(LINGER));
    let start = Instant::now();
    let mut buf = [0u8; 8192];
    let mut read = 0;
    while read < LINGER_BYTES && start.elapsed() < LINGER {
        match stream.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => read += n,
        }
    }
}

/// The answer to one request.
fn respond(req: &Request, session: &Session, choices: &Choices) -> Response {
    session.touch();
    let path = req.path();
    let (get, post) = (req.method == "GET", req.method == "POST");
    if !get && !post {
        return Response::text(
            405,
            format!(
                "method {} is not allowed: the viewer answers GET and POST",
                clip(&req.method)
            ),
        )
        .with_header("Allow", "GET, POST");
    }
    match path {
        "/" | "/frame.png" | "/state" if !get => {
            return Response::text(405, format!("{path} is read with GET"))
                .with_header("Allow", "GET");
        }
        "/settings" | "/camera" if !post => {
            return Response::text(405, format!("{path} takes POST")).with_header("Allow", "POST");
        }
        _ => {}
    }
    match path {
        "/" => Response::new(200, "text/html; charset=utf-8", PAGE),
        "/frame.png" => match session.frame() {
            Some(f) => Response::new(200, "image/png", f.png.clone()),
            None => Response::text(503, "no image yet: the first pass is still rendering")
                .with_header("Retry-After", "1"),
        },
        "/state" => json_response(&state(session, choices)),
        "/settings" | "/camera" => {
            if let Some(r) = refuse_cross_origin(req) {
                return r;
            }
            let params = match params(req) {
                Ok(p) => p,
                Err(r) => return r,
            };
            let changed = if path == "/settings" {
                change_settings(session, &params)
            } else {
                move_camera(session, &params)
            };
            match changed {
                Ok(_) => json_response(&state(session, choices)),
                Err(why) => Response::text(400, why),
            }
        }
        _ => Response::text(
            404,
            format!(
                "no page {} here: the viewer serves GET /, /frame.png and /state, and POST \
                 /settings and /camera",
                clip(path)
            ),
        ),
    }
}

/// At most 200 characters of what a client sent, for a message.
fn clip(s: &str) -> String {
    let mut t: String = s.chars().take(200).collect();
    if t.len() < s.len() {
        t.push_str("...");
    }
    format!("`{t}`")
}

/// A change from another site's page is refused: the browser names the page's origin, which
/// must be this server's own (the `Host` it was asked by).
fn refuse_cross_origin(req: &Request) -> Option<Response> {
    let origin = req.header("Origin")?;
    let host = req.header("Host").unwrap_or_default();
    let own = origin
        .strip_prefix("http://")
        .is_some_and(|o| o.eq_ignore_ascii_case(host));
    (!own).then(|| {
        Response::text(
            403,
            format!("a page from {} may not change this viewer", clip(origin)),
        )
    })
}

/// The query's parameters, then the form body's.
fn params(req: &Request) -> Result<Vec<(String, String)>, Response> {
    let bad = |e: String| Response::text(400, format!("bad parameters: {e}"));
    let mut p = form::parse(req.query()).map_err(bad)?;
    if !req.body.is_empty() {
        let form_type = req.header("Content-Type").is_none_or(|t| {
            let t = t.trim().to_ascii_lowercase();
            t.starts_with("application/x-www-form-urlencoded") || t.starts_with("text/plain")
        });
        if !form_type {
            return Err(Response::text(
                415,
                "send the parameters form-encoded (application/x-www-form-urlencoded)",
            ));
        }
        let body = std::str::from_utf8(&req.body)
            .map_err(|_| Response::text(400, "bad parameters: the body is not UTF-8"))?;
        p.extend(form::parse(body).map_err(bad)?);
    }
    Ok(p)
}

/// One parameter's change of the settings, applied once all parameters have parsed.
type Edit = Box<dyn FnOnce(&mut Settings)>;

/// `POST /settings`: any of backend, accel, packets, aov, accuracy, spp, width, height.
fn change_settings(session: &Session, params: &[(String, String)]) -> Result<u64, String> {
    if params.is_empty() {
        return Err(
            "no setting given: pass backend, accel, packets, aov, accuracy, spp, width or height"
                .into(),
        );
    }
    let mut edits: Vec<Edit> = Vec::new();
    let (mut accuracy, mut spp) = (false, false);
    for (name, value) in params {
        let v = value.trim();
        match name.as_str() {
            "backend" => {
                let b: Backend = v.parse().map_err(|e| format!("backend `{v}`: {e}"))?;
                edits.push(Box::new(move |s| s.backend = b));
            }
            "accel" => {
                let k: AccelKind = v.parse().map_err(|e| format!("accel `{v}`: {e}"))?;
                edits.push(Box::new(move |s| s.accel = k));
            }
            "packets" => {
                let p: Packets = v.parse().map_err(|e| format!("packets `{v}`: {e}"))?;
                edits.push(Box::new(move |s| s.packets = p));
            }
            "aov" => {
                let k = match v {
                    "" | "none" => None,
                    _ => Some(
                        v.parse::<AovKind>()
                            .map_err(|e| format!("aov: {e} (or none)"))?,
                    ),
                };
                edits.push(Box::new(move |s| s.aov = k));
            }
            "accuracy" => {
                let a: f32 = number(name, v)?;
                accuracy = true;
                edits.push(Box::new(move |s| {
                    s.sampling = Sampling::Adaptive { accuracy: a }
                }));
            }
            "spp" => {
                let n: u32 = whole(name, v)?;
                spp = true;
                edits.push(Box::new(move |s| s.sampling = Sampling::Uniform { spp: n }));
            }
            "width" => {
                let w: u32 = whole(name, v)?;
                edits.push(Box::new(move |s| s.width = w));
            }
            "height" => {
                let h: u32 = whole(name, v)?;
                edits.push(Box::new(move |s| s.height = h));
            }
            other => {
                return Err(format!(
                    "unknown setting {}: the settings are backend, accel, packets, aov, \
                     accuracy, spp, width and height",
                    clip(other)
                ));
            }
        }
    }
    if accuracy && spp {
        return Err("pass accuracy (adaptive) or spp (uniform), not both".into());
    }
    session
        .change(|s| {
            for e in edits {
                e(s);
            }
            Ok(())
        })
        .map_err(|Refused(why)| why)
}

/// `POST /camera`: orbit=yaw,pitch (radians), pan=dx,dy (units of the distance), dolly=f,
/// reset=1, applied in order as one change.
fn move_camera(session: &Session, params: &[(String, String)]) -> Result<u64, String> {
    if params.is_empty() {
        return Err("no move given: pass orbit=YAW,PITCH, pan=DX,DY, dolly=F or reset=1".into());
    }
    enum Step {
        Move(Move),
        Reset,
    }
    let mut steps = Vec::new();
    for (name, value) in params {
        let v = value.trim();
        steps.push(match name.as_str() {
            "orbit" => {
                let (yaw, pitch) = pair(name, v)?;
                Step::Move(Move::Orbit { yaw, pitch })
            }
            "pan" => {
                let (dx, dy) = pair(name, v)?;
                Step::Move(Move::Pan { dx, dy })
            }
            "dolly" => Step::Move(Move::Dolly {
                factor: number(name, v)?,
            }),
            "reset" => match v {
                "1" | "true" | "" => Step::Reset,
                _ => return Err(format!("reset {}: pass reset=1", clip(v))),
            },
            other => {
                return Err(format!(
                    "unknown move {}: the moves are orbit, pan, dolly and reset",
                    clip(other)
                ));
            }
        });
    }
    let home = session.scene().camera;
    session
        .change(|s| {
            for step in steps {
                s.camera = match step {
                    Step::Move(m) => super::moves::apply(&s.camera, m)?,
                    Step::Reset => home,
                };
            }
            Ok(())
        })
        .map_err(|Refused(why)| why)
}

/// A number parameter (finiteness is checked by what uses it, with its own message).
fn number(name: &str, v: &str) -> Result<f32, String> {
    v.parse::<f32>()
        .map_err(|_| format!("{name} {}: not a number", clip(v)))
}

/// A whole-number parameter.
fn whole(name: &str, v: &str) -> Result<u32, String> {
    v.parse::<u32>().map_err(|_| {
        format!(
            "{name} {}: not a whole number (sizes are 1 to {MAX_VIEW_SIDE})",
            clip(v)
        )
    })
}

/// Two numbers `a,b`.
fn pair(name: &str, v: &str) -> Result<(f32, f32), String> {
    let (a, b) = v
        .split_once(',')
        .ok_or_else(|| format!("{name} {}: expected two numbers, `x,y`", clip(v)))?;
    Ok((number(name, a.trim())?, number(name, b.trim())?))
}

fn json_response(v: &Value) -> Response {
    Response::new(200, "application/json", v.to_string())
}

/// `GET /state`: the latest frame's figures, the settings and the choices.
fn state(session: &Session, choices: &Choices) -> Value {
    let st = session.status();
    let s = &st.settings;
    let c = &s.camera;
    let (accuracy, spp) = match s.sampling {
        Sampling::Adaptive { accuracy } => (Some(accuracy), None),
        Sampling::Uniform { spp } => (None, Some(spp)),
    };
    let frame = session.frame().map(|f| {
        json!({
            "generation": f.generation,
            "pass": f.pass,
            "width": f.width,
            "height": f.height,
            "rays": f.rays,
            "all_rays": f.all_rays,
            "seconds": f.seconds,
            "rays_per_second": f.rays_per_second,
            "active_lanes": f.active_lanes.iter().map(|(k, v)| json!({"kind": k, "lanes": v})).collect::<Vec<_>>(),
            "lanes": f.lanes,
            "estimate": f.estimate,
            "done": f.done,
            "build_seconds": f.build_seconds,
            "since_change": f.since_change,
            "stop": f.stop,
        })
    });
    json!({
        "scene": session.scene().name,
        "generation": st.generation,
        "paused": st.paused,
        "error": st.error,
        "first_image_seconds": st.first_image_seconds,
        "frame": frame,
        "settings": {
            "backend": s.backend.name(),
            "accel": s.accel.name(),
            "packets": s.packets.name(),
            "aov": s.aov.map(AovKind::name),
            "method": match s.sampling { Sampling::Adaptive { .. } => "adaptive", Sampling::Uniform { .. } => "uniform" },
            "accuracy": accuracy,
            "spp": spp,
            "width": s.width,
            "height": s.height,
            "camera": {
                "position": c.position.to_array(),
                "look_at": c.look_at.to_array(),
                "up": c.up.to_array(),
                "vfov_deg": c.vfov_deg,
            },
        },
        "choices": {
            "backends": choices.backends,
            "accels": choices.accels,
            "packets": Packets::ALL.map(Packets::name),
            "aov": std::iter::once("none").chain(AovKind::ALL.map(AovKind::name)).collect::<Vec<_>>(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_is_complete_and_fetches_nothing_from_elsewhere() {
        assert!(PAGE.starts_with("<!doctype html>"));
        assert!(PAGE.trim_end().ends_with("</html>"));
        for route in ["/state", "/frame.png", "/settings", "/camera"] {
            assert!(PAGE.contains(route), "{route}");
        }
        assert!(!PAGE.contains("http://") && !PAGE.contains("https://") && !PAGE.contains("//cdn"));
    }

    #[test]
    fn parameters_name_themselves_when_wrong() {
        assert_eq!(pair("orbit", "0.5, -1").unwrap(), (0.5, -1.0));
        assert!(pair("orbit", "0.5").unwrap_err().contains("orbit"));
        assert!(number("dolly", "x").unwrap_err().contains("dolly"));
        assert!(whole("width", "-3").unwrap_err().contains("width"));
        assert!(
            number("dolly", "NaN").unwrap().is_nan(),
            "refused later, by the move"
        );
    }
}
