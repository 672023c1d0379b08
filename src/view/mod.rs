//! `coherent view`: the paper's interactive mode (section 6.2) as a local web page. A
//! [`Session`] renders the scene progressively on a worker thread and restarts whenever the
//! settings or the camera change; the [`server`] shows its latest frame and figures to a
//! browser and takes the page's camera moves and settings.

pub mod form;
pub mod frame;
pub mod http;
pub mod moves;
pub mod server;
pub mod session;
pub mod settings;

pub use frame::Frame;
pub use moves::Move;
pub use server::Server;
pub use session::{Refused, Session, SessionOptions, Status, load_scene};
pub use settings::{Sampling, Settings};
