//! `vol-render` under `mpirun` (cargo feature `mpi`): data-parallel,
//! sort-last rendering. Every rank parses the same command line and maps
//! the volume; the index is built in z-slabs, one per rank, and the parts
//! exchanged and merged (or read from `--index`); the volume is split into
//! one box per rank, balanced by the cells the frame can see
//! ([`volrender::distributed::Split`]); each rank renders its box's share
//! of every ray; the films are composited by direct send (rank `j`
//! composites row strip `j` from every rank's film in visibility order)
//! and the strips gathered on rank 0, which writes the outputs and the
//! report. A failure on any rank ends every rank after the phase it
//! happened in, with one line from rank 0.

use crate::print_report;
use anyhow::{anyhow, bail, Context, Result};
use glam::Vec3;
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Shard, Volume};
use volformats::{open_volume, vvol};
use volindex::shard::{build_shard, merge_parts, IndexPart};
use volindex::{BuildOptions, MinMaxIndex};
use volkit_cli::{noteln, outln};
use volrender::classify::srgb_to_linear;
use volrender::distributed::{composite_for, strip_rows, Split};
use volrender::distributed::{Composite, Fields};
use volrender::film::{Film, FrameStats};
use volrender::frame::{busy_cells, display_for, render_film};
use volscene::options::ModeArg;
use volscene::report::{frame_report, peak_rss_mb, Context as ReportContext, Extra};
use volscene::source::{load_index, start_threads};
use volscene::{Image, Options as Cli, Plan, Rendered, Request, Times};

/// Edge of the blocks the volume is split by, in voxels (a multiple of
/// the usual brick edges, so ranks rarely share a brick).
const BLOCK: u64 = 32;

/// Exit status of every rank when one panicked (the job is aborted).
const EXIT_PANIC: i32 = 101;

/// Whether this process was started by an MPI launcher (`mpirun`,
/// `srun`): then it is one rank of a data-parallel job.
pub fn launched() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

/// The `main` of one rank.
pub fn main() -> ExitCode {
    let Some(universe) = mpi::initialize() else {
        volkit_cli::run::report_error("vol-render", "MPI was already initialised");
        return ExitCode::FAILURE;
    };
    // A panic on one rank would leave the others waiting in a collective
    // for ever: end the whole job instead.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        default_hook(info);
        SimpleCommunicator::world().abort(EXIT_PANIC);
    }));
    let world = universe.world();
    if world.rank() != 0 {
        // Every rank parses the same command line; rank 0 speaks.
        volkit_cli::run::silence();
    }
    let (cli, matches) = match volkit_cli::run::parse_matches::<Cli>("vol-render") {
        Ok(parsed) => parsed,
        Err(code) => return code,
    };
    volkit_cli::run("vol-render", || {
        let request = Request::from_matches(cli, &matches);
        let (request, volume) = agree(&world, crate::resolve_cli(request))?;
        job(&world, request.options(), &volume).map_err(|e| crate::naming_scene(&request, e))
    })
}

/// Whether every rank's `mine` is `Ok` (collective). If any rank failed,
/// every rank gets an error; rank 0's carries the first failing rank's
/// message (a usage error stays one).
fn agree<T>(world: &SimpleCommunicator, mine: Result<T>) -> Result<T> {
    let flag: i32 = match &mine {
        Ok(_) => 0,
        Err(e) if volkit_cli::is_usage(e) => 2,
        Err(_) => 1,
    };
    let mut worst = 0i32;
    world.all_reduce_into(&flag, &mut worst, SystemOperation::max());
    if worst == 0 {
        return mine;
    }
    let text = match &mine {
        Err(e) => volcore::text::clip(&format!("{e:#}"), volkit_cli::run::MAX_MESSAGE_CHARS),
        Ok(_) => String::new(),
    };
    let bytes = &message_buffer(text.into_bytes())[..];
    let len = bytes.len() as Count;
    let root = world.process_at_rank(0);
    if world.rank() != 0 {
        root.gather_into(&flag);
        root.gather_into(&len);
        root.gather_varcount_into(bytes);
        // The same exit status as rank 0's.
        let why = "failed (rank 0 reports why)";
        return Err(if worst == 2 {
            volkit_cli::usage(why)
        } else {
            anyhow!(why)
        });
    }
    let n = world.size() as usize;
    let mut flags = vec![0 as Count; n];
    let mut lens = vec![0 as Count; n];
    root.gather_into_root(&flag, &mut flags[..]);
    root.gather_into_root(&len, &mut lens[..]);
    let displs = offsets(&lens);
    let mut all = zeroed(lens.iter().map(|&l| l as usize).sum());
    root.gather_varcount_into_root(
        bytes,
        &mut PartitionMut::new(&mut all[..], &lens[..], &displs[..]),
    );
    let failed: Vec<usize> = (0..n).filter(|&r| flags[r] != 0).collect();
    let first = failed.first().copied().unwrap_or(0);
    let (at, l) = (displs[first] as usize, lens[first] as usize);
    let msg = String::from_utf8_lossy(&all[at..at + l]).into_owned();
    // The same failure everywhere (a missing file, a bad option) is said
    // once, without ranks.
    let same = failed.len() == n
        && (0..n).all(|r| all[displs[r] as usize..][..lens[r] as usize] == all[at..at + l]);
    let msg = if same {
        msg
    } else if failed.len() > 1 {
        format!("rank {first} (and {} more): {msg}", failed.len() - 1)
    } else {
        format!("rank {first}: {msg}")
    };
    Err(if worst == 2 {
        volkit_cli::usage(msg)
    } else {
        anyhow!(msg)
    })
}

/// `bytes`, kept in a heap allocation even when empty. An empty Vec's
/// pointer is the dangling address 1, which Open MPI reads as
/// `MPI_IN_PLACE` (and refuses in a gather from a non-root rank).
fn message_buffer(mut bytes: Vec<u8>) -> Vec<u8> {
    bytes.reserve(1);
    bytes
}

/// `n` zero bytes in a heap allocation (see [`message_buffer`]).
fn zeroed(n: usize) -> Vec<u8> {
    message_buffer(vec![0u8; n])
}

/// Displacements of consecutive blocks of `counts` elements.
fn offsets(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

/// What the ranks cannot do together (yet): refused before any work.
fn refuse(cli: &Cli) -> Result<()> {
    let no = |what: &str| {
        Err(volkit_cli::usage(format!(
            "{what} is not available under MPI (data-parallel rendering does ray casting only; run it in one process)"
        )))
    };
    if cli.mode == ModeArg::Path {
        return no("--mode path");
    }
    if cli.mode == ModeArg::XrayMean {
        return no("--mode xray-mean (each rank's mean is over its own samples; use --mode xray)");
    }
    if cli.shadows.is_some() {
        return no("--shadows");
    }
    if cli.ao.is_some() || cli.ao_field.is_some() {
        return no("ambient occlusion");
    }
    if cli.budget.is_some() {
        return no("--budget (its probe frames time one process)");
    }
    if cli.in_memory {
        return no("--in-memory (each rank maps the volume and reads only its box)");
    }
    Ok(())
}

/// The job on one rank, from the resolved command line.
fn job(world: &SimpleCommunicator, cli: &Cli, volume: &Path) -> Result<()> {
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let name = volume.display().to_string();
    let t = Instant::now();
    let opened = refuse(cli).and_then(|()| {
        start_threads(cli)?;
        let opts = vvol::OpenOptions::default();
        let vol = open_volume(volume, opts, None).with_context(|| name.clone())?;
        let index = match &cli.index {
            Some(_) => load_index(cli, volume, &vol)?,
            None => None,
        };
        Ok((vol, index))
    });
    let (vol, index) = agree(world, opened)?;
    let load_s = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let index = match index {
        Some(ix) => Some(ix),
        None if !cli.no_ess => Some(shared_index(world, cli, &vol, &name)?),
        None => None,
    };
    let index_s = t.elapsed().as_secs_f64();

    let plan = agree(
        world,
        Plan::new(cli, &vol, index.as_ref())
            .map_err(|e| anyhow::Error::new(e.naming_volume(&name))),
    )?;
    if cli.print_scene {
        if rank == 0 {
            outln!("{}", volscene::file::to_toml(&plan.scene)?)?;
        }
        return Ok(());
    }
    let Some(output) = cli.output.as_deref() else {
        bail!("no output")
    };
    if rank == 0 && !cli.quiet {
        for note in &plan.notes {
            noteln!("vol-render: {name}: {note}");
        }
    }
    let settings = &plan.settings;
    let how = composite_for(settings.mode).ok_or_else(|| anyhow!("no composite rule"))?;
    let (w, h) = (plan.camera.width(), plan.camera.height());
    let layout = agree(world, split(&vol, index.as_ref(), &plan, size, w, h))?;
    let share = layout.share(rank);
    let order = layout.front_to_back(&plan.camera);

    let repeated = volscene::render::repeat(cli.repeat, || {
        world.barrier();
        let start = Instant::now();
        let film = match &share {
            Some(s) => render_film(
                &vol,
                index.as_ref(),
                plan.tf.as_ref(),
                &plan.camera,
                settings,
                Some(s),
            )
            .map(|(f, _)| f)
            .with_context(|| name.clone()),
            None => Ok(Film::new(w, h)),
        };
        let film = film.and_then(|f| match vol.error() {
            Some(e) => Err(anyhow!("{name}: {e}")),
            None => Ok(f),
        });
        // This rank's own time, before it waits for the others.
        let render_s = start.elapsed().as_secs_f64();
        let film = agree(world, film)?;
        let c = Instant::now();
        let (strip, traffic) = direct_send(world, &film, &order, how);
        let strip = agree(world, strip)?;
        let whole = gather_strips(world, &strip, how, w, h)?;
        let composite_s = c.elapsed().as_secs_f64();
        let frame_s = start.elapsed().as_secs_f64();
        let figures = (film.stats(), whole, render_s, composite_s, traffic);
        Ok::<_, anyhow::Error>((figures, frame_s))
    })?;
    let ((stats, whole, render_s, composite_s, traffic), frames) = repeated;
    let mine = RankFigures {
        stats,
        render_s,
        composite_s,
        sent: traffic.0,
        received: traffic.1,
        peak_rss_mb: peak_rss_mb().unwrap_or(0.0),
        voxels: layout
            .voxels(rank)
            .iter()
            .map(|r| r.end - r.start)
            .product(),
    };
    let all = gather_figures(world, &mine);
    let (Some(mut film), Some(all)) = (whole, all) else {
        return Ok(()); // ranks other than 0 are done
    };
    // The frame's time is the wall time from the common start to the
    // composited image on rank 0 (the median over --repeat).
    let frame_s = frames.median_s;
    let mut total = FrameStats::default();
    for r in &all {
        total.rays += r.stats.rays;
        total.samples += r.stats.samples;
        total.skips += r.stats.skips;
        total.culled_blocks += r.stats.culled_blocks;
    }
    total.render_s = frame_s;
    film.set_stats(total);
    let bg = Vec3::from(settings.background.map(srgb_to_linear));
    let frame = film.resolve(display_for(&vol, settings.mode), bg);
    let rendered = Rendered {
        image: Image::Frame(frame),
        times: Times {
            load_s,
            index_s,
            render_s: frame_s,
            runs: frames.runs,
        },
        budget: None,
    };
    rendered.write_files(cli, Some(output))?;
    let Image::Frame(frame) = &rendered.image else {
        bail!("not a frame")
    };
    let ranks = rank_report(&layout, &all);
    let scene = serde_json::to_value(&plan.scene)?;
    let cx = ReportContext {
        options: cli,
        volume,
        output: Some(output),
        scene: &scene,
    };
    print_report(
        cli,
        &frame_report(&cx, frame, &rendered.times, Some(&ranks)),
    )
}

/// The index built in parallel: each rank scans one z-slab of macrocell
/// layers ([`build_shard`]), the parts are exchanged, and every rank
/// merges them into the index one process would build.
fn shared_index(
    world: &SimpleCommunicator,
    cli: &Cli,
    vol: &Volume,
    name: &str,
) -> Result<MinMaxIndex> {
    let opts = BuildOptions {
        cell_edge: cli.cell,
        ..Default::default()
    };
    let part = (|| {
        let shard = Shard::new(world.rank() as u32, world.size() as u32)
            .ok_or_else(|| anyhow!("too many ranks to share the index build"))?;
        let part = build_shard(vol, &opts, 0, shard)?;
        let mut bytes = Vec::new();
        part.write_to(&mut bytes)?;
        Count::try_from(bytes.len()).context("index part too large for one message")?;
        Ok::<_, anyhow::Error>(bytes)
    })()
    .with_context(|| format!("{name}: building the index"));
    let bytes = agree(world, part)?;
    let mut lens = vec![0 as Count; world.size() as usize];
    world.all_gather_into(&(bytes.len() as Count), &mut lens[..]);
    let displs = offsets(&lens);
    let mut all = zeroed(lens.iter().map(|&l| l as usize).sum());
    world.all_gather_varcount_into(
        &bytes[..],
        &mut PartitionMut::new(&mut all[..], &lens[..], &displs[..]),
    );
    let merged = (|| {
        let parts = lens
            .iter()
            .zip(&displs)
            .map(|(&l, &d)| {
                let b = &all[d as usize..][..l as usize];
                IndexPart::read_from(&mut &b[..], l as u64)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok::<_, anyhow::Error>(merge_parts(parts)?)
    })()
    .with_context(|| format!("{name}: merging the index parts"));
    agree(world, merged)
}

/// The split of the volume among `ranks`, weighted by the cells the frame
/// can see when there is an index.
fn split(
    vol: &Volume,
    index: Option<&MinMaxIndex>,
    plan: &Plan,
    ranks: usize,
    w: u32,
    h: u32,
) -> Result<Split> {
    // Messages count in i32 elements (bytes here): every rank's whole
    // film must fit one (records and a bitmap byte per pixel at most).
    let px_bytes = Fields::ALL.pixel_bytes() as u64 + 1;
    if (w as u64) * (h as u64) * px_bytes > Count::MAX as u64 {
        bail!(
            "an image of {w}x{h} is too large to composite across ranks (at most {} M pixels)",
            Count::MAX as u64 / px_bytes / 1_000_000
        );
    }
    let busy = index
        .map(|ix| {
            busy_cells(vol, ix, plan.tf.as_ref(), &plan.settings).map(|b| (b, ix.cell_edge()))
        })
        .transpose()?;
    let busy = busy.as_ref().map(|(b, c)| (&b[..], u64::from(*c)));
    Ok(Split::new(
        vol.dims(),
        vol.meta.spacing,
        BLOCK,
        busy,
        ranks,
        Some(&plan.camera),
    ))
}

/// Direct send: rank `j` gets row strip `j` of every rank's film and
/// composites it front to back in `order`. Returns the strip's stream
/// ([`Film::encode_rows`]) and the bytes this rank sent to and received
/// from other ranks.
fn direct_send(
    world: &SimpleCommunicator,
    film: &Film,
    order: &[usize],
    how: Composite,
) -> (Result<Vec<u8>>, (u64, u64)) {
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let (w, h) = (film.width(), film.height());
    let fields = Fields::for_composite(how);
    let mut send = message_buffer(Vec::new());
    let mut counts = Vec::with_capacity(size);
    for j in 0..size {
        let start = send.len();
        film.encode_rows(strip_rows(h, size, j), fields, &mut send);
        counts.push((send.len() - start) as Count);
    }
    // Streams are as long as their pixels that carry anything: every rank
    // first learns how much each other rank sends it.
    let mut rcounts = vec![0 as Count; size];
    world.all_to_all_into(&counts[..], &mut rcounts[..]);
    let rdispls = offsets(&rcounts);
    let mut recv = zeroed(rcounts.iter().map(|&c| c as usize).sum());
    world.all_to_all_varcount_into(
        &Partition::new(&send[..], &counts[..], &offsets(&counts)[..]),
        &mut PartitionMut::new(&mut recv[..], &rcounts[..], &rdispls[..]),
    );
    let ordered: Vec<&[u8]> = order
        .iter()
        .filter(|&&r| r < size)
        .map(|&r| &recv[rdispls[r] as usize..][..rcounts[r] as usize])
        .collect();
    let pixels = strip_rows(h, size, rank).len() * w as usize;
    let mut strip = message_buffer(Vec::new());
    let strip = Film::composite_records(&ordered, pixels, fields, how, &mut strip)
        .map(|()| strip)
        .ok_or_else(|| anyhow!("a film strip from another rank is damaged"));
    let own = counts[rank] as u64;
    (strip, (send.len() as u64 - own, recv.len() as u64 - own))
}

/// The composited strips (their streams, [`Film::encode_rows`]),
/// gathered into the image on rank 0 (`None` elsewhere).
fn gather_strips(
    world: &SimpleCommunicator,
    bytes: &[u8],
    how: Composite,
    w: u32,
    h: u32,
) -> Result<Option<Film>> {
    let size = world.size() as usize;
    let fields = Fields::for_composite(how);
    let root = world.process_at_rank(0);
    let len = bytes.len() as Count;
    if world.rank() != 0 {
        root.gather_into(&len);
        root.gather_varcount_into(bytes);
        return Ok(None);
    }
    let mut lens = vec![0 as Count; size];
    root.gather_into_root(&len, &mut lens[..]);
    let displs = offsets(&lens);
    let mut all = zeroed(lens.iter().map(|&l| l as usize).sum());
    root.gather_varcount_into_root(
        bytes,
        &mut PartitionMut::new(&mut all[..], &lens[..], &displs[..]),
    );
    let mut film = Film::new(w, h);
    for j in 0..size {
        let strip = &all[displs[j] as usize..][..lens[j] as usize];
        film.decode_rows(strip_rows(h, size, j), fields, strip)
            .ok_or_else(|| anyhow!("rank {j}'s composited strip is damaged"))?;
    }
    Ok(Some(film))
}

/// One rank's figures for the report.
#[derive(Clone, Copy, Debug, Default)]
struct RankFigures {
    stats: FrameStats,
    render_s: f64,
    composite_s: f64,
    sent: u64,
    received: u64,
    peak_rss_mb: f64,
    voxels: u64,
}

/// How many f64 a [`RankFigures`] travels as.
const FIGURES: usize = 10;

impl RankFigures {
    fn to_f64s(self) -> [f64; FIGURES] {
        let s = self.stats;
        [
            s.rays as f64,
            s.samples as f64,
            s.skips as f64,
            s.culled_blocks as f64,
            self.render_s,
            self.composite_s,
            self.sent as f64,
            self.received as f64,
            self.peak_rss_mb,
            self.voxels as f64,
        ]
    }

    fn from_f64s(v: &[f64]) -> RankFigures {
        let u = |i: usize| v.get(i).copied().unwrap_or(0.0) as u64;
        let f = |i: usize| v.get(i).copied().unwrap_or(0.0);
        RankFigures {
            stats: FrameStats {
                rays: u(0),
                samples: u(1),
                skips: u(2),
                culled_blocks: u(3),
                ..Default::default()
            },
            render_s: f(4),
            composite_s: f(5),
            sent: u(6),
            received: u(7),
            peak_rss_mb: f(8),
            voxels: u(9),
        }
    }
}

/// Every rank's figures, on rank 0.
fn gather_figures(world: &SimpleCommunicator, mine: &RankFigures) -> Option<Vec<RankFigures>> {
    let root = world.process_at_rank(0);
    let v = mine.to_f64s();
    if world.rank() != 0 {
        root.gather_into(&v[..]);
        return None;
    }
    let mut all = vec![0f64; FIGURES * world.size() as usize];
    root.gather_into_root(&v[..], &mut all[..]);
    Some(all.chunks(FIGURES).map(RankFigures::from_f64s).collect())
}

/// The per-rank part of the report.
fn rank_report(layout: &Split, all: &[RankFigures]) -> Extra {
    let per_rank: Vec<serde_json::Value> = all
        .iter()
        .enumerate()
        .map(|(r, f)| {
            let b = layout.voxels(r);
            serde_json::json!({
                "rank": r,
                "box": b.iter().map(|a| [a.start, a.end]).collect::<Vec<_>>(),
                "voxels": f.voxels,
                "rays": f.stats.rays,
                "samples": f.stats.samples,
                "render_s": f.render_s,
                "composite_s": f.composite_s,
                "bytes_sent": f.sent,
                "bytes_received": f.received,
                "peak_rss_mb": f.peak_rss_mb,
            })
        })
        .collect();
    let max = |g: fn(&RankFigures) -> f64| all.iter().map(g).fold(0.0, f64::max);
    let min = |g: fn(&RankFigures) -> f64| all.iter().map(g).fold(f64::INFINITY, f64::min);
    let bytes: u64 = all.iter().map(|f| f.sent).sum();
    let json = serde_json::json!({
        "ranks": all.len(),
        "rank_render_s_max": max(|f| f.render_s),
        "composite_s_max": max(|f| f.composite_s),
        "bytes_exchanged": bytes,
        "per_rank": per_rank,
    });
    let line = format!(
        "{} ranks: render {:.3}-{:.3} s, composite up to {:.3} s, {:.1} MB exchanged",
        all.len(),
        min(|f| f.render_s),
        max(|f| f.render_s),
        max(|f| f.composite_s),
        bytes as f64 / 1e6
    );
    Extra { json, line }
}
