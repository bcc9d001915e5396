//! The renderer's integration tests: one test binary with a module per
//! topic, so that the crate and its dependencies are linked into one test
//! executable instead of one per topic file. Run one topic with a filter,
//! e.g. `cargo test -p volrender --test it golden::`.

mod adaptive;
mod ao;
mod cancel;
mod common;
mod distributed;
mod golden;
mod path;
mod render;
mod shadows;
mod tf2d;
