//! `coherent view` in a real browser: the binary serves the built-in cornell box, Debian's
//! headless Chromium opens the page (driven over the DevTools protocol), the page shows the
//! render, and a mouse drag on the image moves the camera, which restarts the render.
//!
//! Needs `chromium-headless-shell` (`python3 scripts/native.py chromium`); without it the
//! test says so and passes, unless `COHERENT_REQUIRE_BROWSER` is set.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::os::unix::process::CommandExt as _;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use base64::Engine as _;
use serde_json::{Value, json};
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

const BROWSER: &str = "chromium-headless-shell";

/// Debian's browser binary, else the one on `PATH`. Debian's `/usr/bin` entry is a shell
/// script that starts the binary as its child, which killing the script would leave running.
fn browser() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH")
        .map(|p| {
            std::env::split_paths(&p)
                .map(|d| d.join(BROWSER))
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    [PathBuf::from("/usr/lib/chromium").join(BROWSER)]
        .into_iter()
        .chain(on_path)
        .find(|p| p.is_file())
}

/// A child process that is killed when the test ends, however it ends.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A child process started as the leader of its own process group, whose whole group is
/// killed when the test ends: the browser's helper processes go with it.
struct KilledGroup(Child);

impl Drop for KilledGroup {
    fn drop(&mut self) {
        let group = format!("-{}", self.0.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The first line of `from` that `pick` accepts (within `within`), reading the rest away on a
/// thread so that the child never blocks on a full pipe.
fn first_line<R: Read + Send + 'static>(
    from: R,
    within: Duration,
    pick: fn(&str) -> Option<String>,
) -> Result<String, String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut seen = Vec::new();
        for line in BufReader::new(from).lines() {
            let Ok(line) = line else { break };
            match pick(&line) {
                Some(v) => {
                    let _ = tx.send(Ok(v));
                }
                None => seen.push(line),
            }
        }
        let _ = tx.send(Err(seen.join("\n")));
    });
    match rx.recv_timeout(within) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(seen)) => Err(format!("the output ended without it:\n{seen}")),
        Err(_) => Err(format!("nothing within {within:?}")),
    }
}

/// The DevTools protocol over one websocket: calls by id, to the page's session once
/// attached; events are read and dropped.
struct Cdp {
    ws: WebSocket<MaybeTlsStream<TcpStream>>,
    next: u64,
    session: Option<String>,
}

impl Cdp {
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = &self.session {
            msg["sessionId"] = json!(s);
        }
        self.ws
            .send(Message::Text(msg.to_string().into()))
            .unwrap_or_else(|e| panic!("{method}: {e}"));
        loop {
            let m = self.ws.read().unwrap_or_else(|e| panic!("{method}: {e}"));
            let Message::Text(text) = m else { continue };
            let v: Value = serde_json::from_str(text.as_str()).expect("DevTools sends JSON");
            if v["id"] == json!(id) {
                assert!(v.get("error").is_none(), "{method}: {}", v["error"]);
                return v["result"].clone();
            }
        }
    }

    /// A JavaScript expression's value in the page.
    fn eval(&mut self, expr: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({ "expression": expr, "returnByValue": true }),
        );
        r["result"]["value"].clone()
    }

    fn mouse(&mut self, kind: &str, x: f64, y: f64, buttons: u32) {
        self.call(
            "Input.dispatchMouseEvent",
            json!({ "type": kind, "x": x, "y": y, "button": "left", "buttons": buttons,
                    "clickCount": 1 }),
        );
    }
}

/// Waits until `ok` holds, at most `within`.
fn wait(what: &str, within: Duration, mut ok: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ok() {
        assert!(start.elapsed() < within, "{what}: not within {within:?}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// `GET path` from the viewer itself: the body.
fn get(addr: SocketAddr, path: &str) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut out = Vec::new();
    s.read_to_end(&mut out).unwrap();
    let end = out.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    assert!(
        out.starts_with(b"HTTP/1.1 200"),
        "{path}: {}",
        String::from_utf8_lossy(&out)
    );
    out[end + 4..].to_vec()
}

fn state(addr: SocketAddr) -> Value {
    serde_json::from_slice(&get(addr, "/state")).unwrap()
}

/// Distinct colours of a PNG in the rectangle `(x, y, w, h)` (clipped to the image).
fn colours(png: &[u8], rect: (u32, u32, u32, u32)) -> usize {
    let img = image::load_from_memory(png).unwrap().to_rgb8();
    let (x0, y0) = (rect.0.min(img.width()), rect.1.min(img.height()));
    let (x1, y1) = (
        (rect.0 + rect.2).min(img.width()),
        (rect.1 + rect.3).min(img.height()),
    );
    let mut seen = std::collections::HashSet::new();
    for y in y0..y1 {
        for x in x0..x1 {
            seen.insert(img.get_pixel(x, y).0);
        }
    }
    seen.len()
}

#[test]
fn the_page_shows_the_render_and_a_drag_moves_the_camera() {
    let Some(browser) = browser() else {
        let msg =
            "skipped: chromium-headless-shell not installed (python3 scripts/native.py chromium)";
        assert!(
            !coherent::require::required("COHERENT_REQUIRE_BROWSER"),
            "{msg}, and COHERENT_REQUIRE_BROWSER is set"
        );
        println!("{msg}");
        return;
    };

    // The viewer, on a free port: its first line says where.
    let mut viewer = coherent::require::command(env!("CARGO_BIN_EXE_coherent"))
        .args(["view", "cornell", "--port", "0", "--resolution", "256x192"])
        .args(["--threads", "2", "--spp", "64"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("the coherent binary runs");
    let out = viewer.stdout.take().unwrap();
    let _viewer = Killed(viewer);
    let url = first_line(out, Duration::from_secs(120), |l| {
        let start = l.find("http://")?;
        Some(l[start..].split_whitespace().next()?.to_owned())
    })
    .unwrap_or_else(|e| panic!("the viewer's address: {e}"));
    let addr: SocketAddr = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .parse()
        .unwrap();

    // The browser, with a fresh profile; its DevTools address comes on stderr.
    let profile = tempfile::tempdir().unwrap();
    let mut chrome = Command::new(&browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--remote-debugging-port=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("about:blank")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .unwrap_or_else(|e| panic!("{}: {e}", browser.display()));
    let err = chrome.stderr.take().unwrap();
    let _chrome = KilledGroup(chrome);
    let ws_url = first_line(err, Duration::from_secs(60), |l| {
        let start = l.find("ws://")?;
        l.contains("DevTools listening on")
            .then(|| l[start..].trim().to_owned())
    })
    .unwrap_or_else(|e| panic!("the browser's DevTools address: {e}"));
    let (ws, _) = tungstenite::connect(ws_url.as_str()).expect("DevTools accepts");
    if let MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    }
    let mut cdp = Cdp {
        ws,
        next: 0,
        session: None,
    };
    let target = cdp.call("Target.createTarget", json!({ "url": "about:blank" }));
    let attached = cdp.call(
        "Target.attachToTarget",
        json!({ "targetId": target["targetId"], "flatten": true }),
    );
    cdp.session = Some(attached["sessionId"].as_str().unwrap().to_owned());
    cdp.call(
        "Emulation.setDeviceMetricsOverride",
        json!({ "width": 900, "height": 600, "deviceScaleFactor": 1, "mobile": false }),
    );
    cdp.call("Page.navigate", json!({ "url": url }));

    // The first image.
    let shown = "(() => { const i = document.getElementById('frame'); \
                 return !!i && i.naturalWidth === 256 && window.coherent.frames > 0; })()";
    wait("the page shows an image", Duration::from_secs(60), || {
        cdp.eval(shown) == json!(true)
    });
    let rect = cdp.eval(
        "(() => { const r = document.getElementById('frame').getBoundingClientRect(); \
         return [r.x, r.y, r.width, r.height]; })()",
    );
    let r: Vec<f64> = rect
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!((r[2], r[3]), (256.0, 192.0), "the image at its size");
    let shot = cdp.call("Page.captureScreenshot", json!({ "format": "png" }));
    let png = base64::engine::general_purpose::STANDARD
        .decode(shot["data"].as_str().unwrap())
        .unwrap();
    let on_image = colours(&png, (r[0] as u32, r[1] as u32, 256, 192));
    assert!(
        on_image > 50,
        "the image on the page is blank: {on_image} colours"
    );

    // A drag on the image orbits the camera: a new render, a new image.
    let before = state(addr);
    let before_png = get(addr, "/frame.png");
    let (cx, cy) = (r[0] + r[2] / 2.0, r[1] + r[3] / 2.0);
    cdp.mouse("mousePressed", cx, cy, 1);
    for i in 1..=10 {
        cdp.mouse(
            "mouseMoved",
            cx + 6.0 * f64::from(i),
            cy + 2.0 * f64::from(i),
            1,
        );
    }
    cdp.mouse("mouseReleased", cx + 60.0, cy + 20.0, 0);
    let generation = before["generation"].as_u64().unwrap();
    wait(
        "a new render after the drag",
        Duration::from_secs(30),
        || {
            let s = state(addr);
            s["frame"]["generation"].as_u64() > Some(generation)
        },
    );
    let after = state(addr);
    assert_ne!(
        after["settings"]["camera"], before["settings"]["camera"],
        "the drag moved the camera"
    );
    let after_png = get(addr, "/frame.png");
    assert_ne!(after_png, before_png, "the image changed");
    // And the page shows the new render's image (or a later one's: the drag may still be
    // sending moves).
    let new = after["frame"]["generation"].as_u64().unwrap();
    let shown = "Number(new URL(document.getElementById('frame').src).searchParams.get('g'))";
    wait(
        "the page shows the new render",
        Duration::from_secs(30),
        || cdp.eval(shown).as_u64() >= Some(new),
    );
    // Closed politely (the answer may never come); its process group is killed anyway.
    let close = json!({ "id": 0, "method": "Browser.close" });
    let _ = cdp.ws.send(Message::Text(close.to_string().into()));
}
