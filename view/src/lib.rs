//! vol-view: a small local web server that shows a volume in the
//! browser, renders it live through the one definition of vol-render's
//! options (`volscene`), and shows what every frame cost and how far it
//! is from a reference.
//!
//! The parts, each its own module:
//!
//! - [`config`]: where to listen, the access token, the save folder.
//! - [`server`]: the listener and a thread per connection.
//! - [`http`]: reading a request's head and writing plain responses.
//! - [`guard`]: the `Host`, `Origin` and token checks every request
//!   passes, on loopback too.
//! - [`assets`]: the page's static files, embedded in the binary.
//! - [`viewer`]: the volume opened once, and the render requests the
//!   page's option pairs make.
//! - [`hello`]: what the page learns on connecting (the options from
//!   clap's definition, the volume, its histogram, the camera).
//! - [`protocol`]: the WebSocket messages.
//! - [`session`]: one page's WebSocket and its render worker.
//! - [`worker`]: one frame at a time, cancelled when a newer request
//!   makes it stale; path-traced passes; the PSNR reference.
//! - [`cost`]: a frame's figures for the cost panel.
//! - [`slice`]: axial, coronal and sagittal slices of the volume.
//! - [`save`]: the files the page downloads (PNG, PFM, scene).

#![warn(missing_docs)]

pub mod assets;
pub mod config;
pub mod cost;
pub mod guard;
pub mod hello;
pub mod http;
pub mod protocol;
pub mod save;
pub mod server;
pub mod session;
pub mod slice;
pub mod viewer;
pub mod worker;

pub use config::Config;
pub use server::Server;
pub use viewer::Viewer;
