//! vol-view: look at a volume in the browser. Opens the volume, binds a
//! local port and prints the page's address; the page renders through
//! vol-render's own options.

use clap::Parser;
use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;
use volview::{Config, Server, Viewer};

/// Look at a volume in the browser: turn, zoom and re-light it, change
/// any of vol-render's options, and see what each frame cost and how far
/// it is from a reference render.
///
/// Serves a page on 127.0.0.1 at a free port (printed on start). Every
/// frame renders with vol-render's own code and options, so the page can
/// show the exact vol-render command and scene file for what it shows.
#[derive(Parser, Debug)]
#[command(name = "vol-view", version, after_help = EXAMPLES)]
struct Args {
    /// The volume (any format vol-convert reads; or `volume` in --scene).
    volume: Option<PathBuf>,
    /// A scene file (vol-render's TOML) for the first view: its options
    /// hold until the page changes them.
    #[arg(long, value_name = "FILE.toml")]
    scene: Option<PathBuf>,
    /// The port (default: a free one the system picks).
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// Listen on this address instead of 127.0.0.1 (an IP, or IP:PORT);
    /// off loopback every request then needs the token printed on start.
    #[arg(long, value_name = "ADDR")]
    listen: Option<String>,
    /// Another host name the Host header may give with --listen (the
    /// machine's name as the browser types it); repeatable.
    #[arg(long, value_name = "NAME", requires = "listen")]
    allow_host: Vec<String>,
    /// Open the page in the system's browser.
    #[arg(long)]
    open: bool,
    /// Also write every save (PNG, PFM, scene) into this folder; without
    /// it the server writes no file (saves go to the browser only).
    #[arg(long, value_name = "DIR")]
    save_dir: Option<PathBuf>,
    /// Seconds a ray-cast preview aims at while the camera moves, its
    /// transfer to the page included: the step and image scale are
    /// picked for the best expected PSNR within it (as vol-render
    /// --budget does), from probe frames and the previews before.
    #[arg(long, value_name = "SECONDS", default_value_t = volview::viewer::PREVIEW_BUDGET_S,
          value_parser = volscene::parse::parse_positive_f64)]
    preview_budget: f64,
}

const EXAMPLES: &str = "Examples:
  vol-view shapes.vvol
  vol-view shapes.vvol --open --port 8700
  vol-view --scene thesis.toml
  vol-view ct.nii.gz --save-dir renders/
  vol-view big.vvol --preview-budget 0.1
  vol-view shapes.vvol --listen 0.0.0.0:8700 --allow-host workstation.lan

The page: drag to orbit, shift-drag (or right-drag) to pan, wheel to zoom;
arrow keys orbit, +/- zoom. Ctrl-C stops the server.";

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, message)) => {
            eprintln!("vol-view: {message}");
            ExitCode::from(code)
        }
    }
}

/// Open, bind, print the address, serve.
fn run(args: &Args) -> Result<(), (u8, String)> {
    let mut config = match &args.listen {
        None => Config::loopback(args.port),
        Some(text) => Config::listen(listen_addr(text, args.port)?)
            .map_err(|e| (1, format!("cannot make a token: {e}")))?,
    };
    config.extra_hosts = args.allow_host.clone();
    if let Some(dir) = &args.save_dir {
        if !dir.is_dir() {
            return Err((2, format!("--save-dir {}: not a folder", dir.display())));
        }
        config.save_dir = Some(dir.clone());
    }
    let mut viewer = Viewer::open(args.volume.as_deref(), args.scene.as_deref()).map_err(|e| {
        let code = if e.kind() == volscene::ErrorKind::Usage {
            2
        } else {
            1
        };
        (code, e.message().to_string())
    })?;
    viewer.preview_budget_s = args.preview_budget;
    let name = viewer.volume.display().to_string();
    let server = Server::bind(&config, viewer)
        .map_err(|e| (1, format!("cannot listen on {}: {e}", config.addr)))?;
    let urls = server.urls().map_err(|e| (1, e.to_string()))?;
    let url = urls.first().cloned().unwrap_or_default();
    println!("vol-view: showing {name} at {url}");
    for other in &urls[1..] {
        println!("vol-view: also at {other}");
    }
    if config.token.is_some() {
        println!("vol-view: requests need the token in that address; share it only with those who may drive this server");
    }
    println!("vol-view: Ctrl-C stops");
    let _ = std::io::stdout().flush();
    if args.open {
        open_browser(&url);
    }
    server.run();
    Ok(())
}

/// `--listen`: an IP (the port from --port) or IP:PORT.
fn listen_addr(text: &str, port: u16) -> Result<SocketAddr, (u8, String)> {
    if let Ok(a) = text.parse::<SocketAddr>() {
        return Ok(a);
    }
    match text
        .trim_matches(|c| c == '[' || c == ']')
        .parse::<IpAddr>()
    {
        Ok(ip) => Ok(SocketAddr::new(ip, port)),
        Err(_) => Err((
            2,
            format!(
                "--listen {}: expected an IP address or IP:PORT",
                volcore_text(text)
            ),
        )),
    }
}

fn volcore_text(s: &str) -> String {
    volcore::text::clip(&volcore::text::escape(s), 60)
}

/// Start the system's browser on `url`; a line on stderr when there is
/// no display, no browser, or the browser fails (the server goes on).
fn open_browser(url: &str) {
    let no_display = cfg!(all(unix, not(target_os = "macos")))
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none();
    if no_display {
        eprintln!("vol-view: --open: no display (DISPLAY and WAYLAND_DISPLAY are unset); open the address above in a browser yourself");
        return;
    }
    let tries: &[&[&str]] = if cfg!(target_os = "macos") {
        &[&["open"]]
    } else if cfg!(windows) {
        &[&["cmd", "/C", "start", ""]]
    } else {
        &[&["xdg-open"], &["chromium"], &["firefox"]]
    };
    for cmd in tries {
        let started = std::process::Command::new(cmd[0])
            .args(&cmd[1..])
            .arg(url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn();
        if let Ok(mut child) = started {
            let name = cmd[0];
            // Its failure comes later (xdg-open finds no browser): say so
            // then, without holding the server up.
            std::thread::spawn(move || {
                if let Ok(status) = child.wait() {
                    if !status.success() {
                        eprintln!("vol-view: --open: {name} failed ({status}); open the address above yourself");
                    }
                }
            });
            return;
        }
    }
    eprintln!("vol-view: --open: found no browser to open; open the address above yourself");
}
