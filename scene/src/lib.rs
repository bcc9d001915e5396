//! What one render is: its options, the scene file, and their resolution
//! against a volume. The one definition of vol-render's options, for the
//! command line and for any other caller (a Python package, a viewer),
//! so none of them keeps a second list of names, defaults or checks.
//!
//! A render goes through these steps, each its own call:
//!
//! 1. [`Request`]: the options as given: parsed from a command line
//!    ([`Request::parse`], or clap's matches), or from name/value pairs
//!    with the flags' names ([`Request::from_pairs`]), then the scene
//!    file under them ([`Request::with_scene_file`]).
//! 2. [`Source::open`]: the volume and its index.
//! 3. [`Plan::for_source`]: the options resolved against the volume
//!    (defaults, checks, notes, the effective [`Scene`]).
//! 4. [`render()`]: the frame or the path-traced passes, stopping between
//!    tiles or passes when a [`Cancel`] flag is raised.
//! 5. [`Rendered::report`]: the figures `--json` prints; the image itself
//!    through [`Rendered::linear_rgb`] and [`Rendered::display8`].
//!
//! Every error is an [`Error`]: one line, as vol-render prints it, and
//! its [`ErrorKind`] (a bad option, a file problem, the renderer,
//! cancelled).

#![warn(missing_docs)]

pub mod args;
pub mod budget;
pub mod choices;
pub mod effective;
pub mod error;
pub mod file;
pub mod image;
pub mod lights;
pub mod merge;
pub mod options;
pub mod pairs;
pub mod parse;
pub mod path;
pub mod plan;
pub mod render;
pub mod report;
pub mod request;
pub mod source;

pub use error::{Error, ErrorKind, Result};
pub use file::Scene;
pub use options::Options;
pub use plan::Plan;
pub use render::{render, render_from, Image, Progress, Rendered, Times, Traced};
pub use report::Report;
pub use request::Request;
pub use source::Source;
pub use volrender::Cancel;

impl Plan {
    /// [`Plan::new`] for an opened volume, its errors naming the volume
    /// (`shapes.vvol: --iso needs --mode iso`) or the file at fault
    /// (`wide.tf: ...`, see [`Error::naming_volume`]).
    pub fn for_source(options: &Options, source: &Source) -> Result<Plan> {
        Plan::new(options, &source.volume, source.index.as_ref())
            .map_err(|e| e.naming_volume(source.name()))
    }
}
