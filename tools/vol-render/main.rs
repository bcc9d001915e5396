//! vol-render: a tiled, parallel CPU ray caster and path tracer. The
//! options, their resolution against the volume and the render itself are
//! the `volscene` library's; this binary parses the command line, calls
//! it, writes the files and prints.

#[cfg(feature = "mpi")]
mod ranks;

use anyhow::{bail, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use volkit_cli::{noteln, outln};
use volscene::report::Context as ReportContext;
use volscene::{Cancel, Options, Plan, Progress, Request, Source};

fn main() -> ExitCode {
    #[cfg(feature = "mpi")]
    if ranks::launched() {
        return ranks::main();
    }
    let (options, matches) = match volkit_cli::run::parse_matches::<Options>("vol-render") {
        Ok(parsed) => parsed,
        Err(code) => return code,
    };
    volkit_cli::run("vol-render", || {
        let (request, volume) = resolve_cli(Request::from_matches(options, &matches))?;
        run(request.options(), &volume).map_err(|e| naming_scene(&request, e))
    })
}

/// An error about a file the scene file named, naming the scene too.
fn naming_scene(request: &Request, e: anyhow::Error) -> anyhow::Error {
    match e.downcast::<volscene::Error>() {
        Ok(e) => request.naming_scene(e).into(),
        Err(e) => e,
    }
}

/// Fill the options from their `--scene` file (options given on the
/// command line win) and check that there is a volume and an output: the
/// request and the volume's path.
fn resolve_cli(request: Request) -> Result<(Request, PathBuf)> {
    let request = request.with_scene_file()?;
    let volume = request.volume()?;
    let options = request.options();
    if options.output.is_none() && !options.print_scene {
        return Err(volkit_cli::usage(
            "no output: give -o FILE.png, or `output` in the --scene file",
        ));
    }
    Ok((request, volume))
}

fn run(options: &Options, volume: &Path) -> Result<()> {
    volscene::source::start_threads(options)?;
    let source = Source::open(options, volume)?;
    let plan = Plan::for_source(options, &source)?;
    if options.print_scene {
        outln!("{}", volscene::file::to_toml(&plan.scene)?)?;
        return Ok(());
    }
    let Some(output) = options.output.as_deref() else {
        bail!("no output")
    };
    if !options.quiet {
        for note in &plan.notes {
            noteln!("vol-render: {}: {note}", source.name());
        }
    }
    let bar = plan.path.as_ref().map(|(_, budget)| {
        let quiet = options.quiet || options.json;
        volkit_cli::progress::count_bar(budget.spp, "path tracing", "spp", quiet)
    });
    let rendered = volscene::render(options, &source, &plan, &Cancel::new(), |p: &Progress| {
        if let Some(bar) = &bar {
            bar.set_position(p.spp_added);
            if let Some(e) = p.relative_error {
                bar.set_message(format!("error {:.2}%", e * 100.0));
            }
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    rendered.write_files(options, Some(output))?;
    let scene = serde_json::to_value(&plan.scene)?;
    let cx = ReportContext {
        options,
        volume,
        output: Some(output),
        scene: &scene,
    };
    print_report(options, &rendered.report(&cx))
}

/// The report: one JSON object on stdout under `--json`, else the
/// summary on stderr unless `--quiet`.
fn print_report(options: &Options, report: &volscene::Report) -> Result<()> {
    if options.json {
        outln!("{}", report.json)?;
    } else if !options.quiet {
        for line in &report.lines {
            noteln!("vol-render: {line}");
        }
    }
    Ok(())
}
