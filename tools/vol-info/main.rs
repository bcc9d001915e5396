//! vol-info: describe a volume file and optionally verify its checksums.

use anyhow::{Context, Result};
use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Compression, Layout, Volume};
use volformats::{vvol, FileKind};
use volkit_cli::{outln, RawArgs};

/// Describe a volume file (.vvol, .vol, .raw, or - for a .vvol stream on
/// stdin) and check it: the header against the file length, the brick table
/// against the data and, with --verify, every checksum.
#[derive(Parser, Debug)]
#[command(name = "vol-info", version, after_help = EXAMPLES)]
struct Cli {
    /// The volume file, or - for a sliced .vvol stream on stdin.
    input: PathBuf,
    /// Check every checksum (reads the whole file).
    #[arg(long)]
    verify: bool,
    #[command(flatten)]
    raw: RawArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

const EXAMPLES: &str = "Examples:
  vol-info shapes.vvol
  vol-info --verify --json bricked.vvol
  vol-gen noise --dims 64,64,64 -o - | vol-info -
  vol-info --raw-dims 256,256,256 --raw-type u16 --raw-big-endian scan.raw";

fn main() -> ExitCode {
    let cli = match volkit_cli::run::parse_args::<Cli>("vol-info") {
        Ok(c) => c,
        Err(code) => return code,
    };
    volkit_cli::run("vol-info", || info(&cli))
}

fn info(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let name = cli.input.display().to_string();
    let spec = cli.raw.spec().map_err(anyhow::Error::msg)?;
    let opts = vvol::OpenOptions {
        verify: cli.verify,
        ..Default::default()
    };
    let vol = volformats::open_volume(&cli.input, opts, spec).with_context(|| name.clone())?;
    let file_bytes = if cli.input.as_os_str() == "-" {
        None
    } else {
        Some(
            std::fs::metadata(&cli.input)
                .with_context(|| name.clone())?
                .len(),
        )
    };
    // Thesis and raw files carry no checksums: verifying reads every sample.
    if cli.verify && FileKind::of(&cli.input) != Some(FileKind::Vvol) {
        let _ = vol.to_f32_vec();
    }
    if let Some(e) = vol.error() {
        anyhow::bail!("{name}: {e}");
    }
    report(cli, &vol, file_bytes, start.elapsed().as_secs_f64())?;
    Ok(())
}

fn report(cli: &Cli, vol: &Volume, file_bytes: Option<u64>, seconds: f64) -> std::io::Result<()> {
    let m = &vol.meta;
    let (brick, bricks) = match m.layout {
        Layout::Sliced => (None, None),
        Layout::Bricked(g) => (Some(g.brick()), Some(g.brick_count())),
    };
    let compression = match m.compression {
        Compression::None => "none".to_string(),
        Compression::Zstd(l) => format!("zstd:{l}"),
    };
    let range = (!m.range.is_empty()).then_some((m.range.min, m.range.max));
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-info",
            "path": cli.input.display().to_string(),
            "format": format!("{:?}", FileKind::of(&cli.input)).to_lowercase().replace("some(", "").replace(')', ""),
            "dims": m.dims.as_array(),
            "type": m.sample_type.name(),
            "spacing": m.spacing,
            "layout": if brick.is_some() { "bricked" } else { "sliced" },
            "brick": brick,
            "bricks": bricks,
            "compression": compression,
            "min": range.map(|r| r.0),
            "max": range.map(|r| r.1),
            "file_bytes": file_bytes,
            "verified": cli.verify,
            "seconds": seconds,
        });
        return outln!("{v}");
    }
    outln!("{}: {}", cli.input.display(), m)?;
    if let Some(b) = file_bytes {
        let samples = m.dims.count() * m.sample_type.size() as u64;
        outln!(
            "  {b} bytes on disk, {samples} bytes of samples ({:.3}x)",
            b as f64 / samples.max(1) as f64
        )?;
    }
    if let Some(n) = bricks {
        outln!("  {n} bricks")?;
    }
    match range {
        Some((lo, hi)) => outln!("  values {lo} .. {hi}")?,
        None => outln!("  values: none (all NaN)")?,
    }
    if cli.verify {
        outln!("  verified in {seconds:.2} s")?;
    }
    Ok(())
}
