//! Progress bars on stderr, shown only when stderr is a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A byte-counting progress bar: hidden when `quiet` or when stderr is not
/// a terminal, so logs and pipes stay clean.
pub fn bytes_bar(total: u64, label: &str, quiet: bool) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), draw_target(quiet));
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{bar:30}] {bytes}/{total_bytes} {bytes_per_sec} eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    bar
}

/// A bar counting `unit`s (samples per pixel, passes) toward `total`, or
/// a spinner with the count when the total is not known; its message
/// shows what the caller sets (an error estimate). Hidden when `quiet` or
/// when stderr is not a terminal.
pub fn count_bar(total: Option<u64>, label: &str, unit: &str, quiet: bool) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(total, draw_target(quiet));
    let template = match total {
        Some(_) => format!("{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{msg}} eta {{eta}}"),
        None => format!("{{prefix}} {{spinner}} {{pos}} {unit} {{msg}} {{elapsed}}"),
    };
    bar.set_style(
        ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    bar
}

fn draw_target(quiet: bool) -> ProgressDrawTarget {
    if quiet || !std::io::stderr().is_terminal() {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    }
}
