//! `coherent view` (the paper's interactive mode, section 6.2): load a scene, check the
//! settings, listen on the port, build the accelerator and serve the progressive render to a
//! web page until the process is stopped.
//!
//! No signal handler: Ctrl-C ends the process at once, which is clean here, since nothing is
//! written anywhere and the system closes the socket.

use std::net::SocketAddr;
use std::sync::Arc;

use anyhow::bail;
use coherent::accel_any::AccelKind;
use coherent::view::{Sampling, Server, Session, SessionOptions, Settings, load_scene};

use crate::ViewArgs;

/// Runs `coherent view`.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let backend = super::backend_arg(args.backend.as_deref())?;
    let accel: AccelKind = args.accel.parse()?;
    let threads = super::threads_arg(args.threads)?.unwrap_or(SessionOptions::default().threads);
    let scene = load_scene(&args.scene)?;
    let mut settings = Settings::of_scene(&scene);
    (settings.width, settings.height) = args.resolution;
    settings.backend = backend;
    settings.accel = accel;
    if let Some(spp) = args.spp {
        settings.sampling = Sampling::Uniform { spp };
    } else if let Some(accuracy) = args.accuracy {
        settings.sampling = Sampling::Adaptive { accuracy };
    }
    if let Some(why) = settings.problem() {
        bail!("{why}");
    }
    // Listen before the build, so that a port in use is said at once; connections made
    // during the build wait in the socket's queue.
    let server = Server::bind(SocketAddr::new(args.bind, args.port))?;
    let addr = server.local_addr()?;
    let options = SessionOptions {
        threads,
        ..SessionOptions::default()
    };
    let session = Session::start(scene, settings, options)?;
    println!(
        "coherent view: serving {} on http://{addr}/ (Ctrl-C stops)",
        session.scene().name
    );
    server.run(Arc::new(session));
    Ok(())
}
