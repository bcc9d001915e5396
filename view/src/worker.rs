//! One page's render worker. It renders the newest request only: a
//! request that arrives while a frame renders raises that frame's
//! [`Cancel`] (the renderer stops between tiles or passes), and a frame
//! whose flag was raised is never sent, so no stale frame reaches the
//! page after a newer request. Path tracing goes on a pass of one sample
//! at a time until the budget is met; the PSNR reference renders when
//! nothing else waits.

use crate::cost;
use crate::protocol::Out;
use crate::save::Snapshot;
use crate::viewer::Viewer;
use serde_json::{json, Map, Value};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Instant;
use volcompare::{Depth, Image as CmpImage, ImageOptions};
use volrender::film::PathFilm;
use volrender::path::{Budget, MAX_SPP};
use volscene::budget::{self, Choice, Model};
use volscene::{Cancel, Error, ErrorKind, Options, Plan, Rendered};

/// A render the page asked for.
#[derive(Clone, Debug)]
pub struct Job {
    /// The request's number.
    pub seq: u64,
    /// vol-render's options as name/value pairs.
    pub pairs: Map<String, Value>,
    /// A preview while the camera moves.
    pub preview: bool,
}

/// What the page's connection hands the worker.
#[derive(Default)]
struct Pending {
    job: Option<Job>,
    /// The flag of the view being worked on.
    running: Cancel,
    psnr: Option<u64>,
    closed: bool,
    last_seq: Option<u64>,
}

/// The worker's inbox: the newest request (a newer one replaces it and
/// cancels the frame in progress), a PSNR request, and closing.
#[derive(Default)]
pub struct Queue {
    state: Mutex<Pending>,
    wake: Condvar,
}

impl Queue {
    fn lock(&self) -> MutexGuard<'_, Pending> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Take `job`: it replaces any request not yet started and cancels
    /// the frame in progress. `seq` must rise.
    pub fn submit(&self, job: Job) -> Result<(), String> {
        let mut p = self.lock();
        if let Some(last) = p.last_seq {
            if job.seq <= last {
                return Err(format!(
                    "request {} is not newer than request {last}: seq must rise",
                    job.seq
                ));
            }
        }
        p.last_seq = Some(job.seq);
        p.running.cancel();
        p.job = Some(job);
        self.wake.notify_all();
        Ok(())
    }

    /// Ask for the PSNR of view `seq`.
    pub fn want_psnr(&self, seq: u64) {
        self.lock().psnr = Some(seq);
        self.wake.notify_all();
    }

    /// Stop the worker: the frame in progress is cancelled.
    pub fn close(&self) {
        let mut p = self.lock();
        p.closed = true;
        p.running.cancel();
        self.wake.notify_all();
    }
}

/// What the worker does next.
enum Work {
    Start(Job, Cancel),
    Pass,
    Reference,
}

/// A path-traced view's progress.
struct Passes {
    /// The plan of one pass of one sample.
    plan: Plan,
    budget: Budget,
    acc: Option<PathFilm>,
    started: Instant,
    done: bool,
}

/// The view being shown.
struct View {
    seq: u64,
    preview: bool,
    /// The options and plan as rendered (a preview's coarser ones).
    options: Options,
    plan: Plan,
    /// The options of the full view (the reference starts from them).
    full: Options,
    /// The full view's plan.
    full_plan: Plan,
    /// What the preview budget chose (a ray-cast preview).
    choice: Option<Choice>,
    cancel: Cancel,
    passes: Option<Passes>,
    /// The page's pairs for the full view.
    pairs: Map<String, Value>,
    command: String,
    toml: String,
    note: Option<String>,
    /// The last frame's 8-bit image, its channels and size.
    shown: Option<Shown>,
    psnr_wanted: bool,
    /// Whether the reference has been rendered and the PSNR sent.
    referenced: bool,
}

/// Where the worker sends its messages and keeps the frame to save.
pub struct Worker {
    viewer: Arc<Viewer>,
    queue: Arc<Queue>,
    out: Sender<Out>,
    snapshot: Arc<Mutex<Option<Snapshot>>>,
    view: Option<View>,
    /// The frame-time models of the last view previewed, under the key
    /// of its options without the camera ([`model_key`]).
    models: Option<(String, Model)>,
    /// Seconds a preview takes beyond its render (encoding, sending),
    /// averaged over the previews so far.
    send_s: f64,
}

/// An 8-bit frame as the page got it.
struct Shown {
    channels: usize,
    pixels: Vec<u8>,
    width: u32,
    height: u32,
}

/// The least render time a preview is given, however long sending takes.
const MIN_PREVIEW_RENDER_S: f64 = 0.005;

impl Worker {
    /// A worker for one page.
    pub fn new(
        viewer: Arc<Viewer>,
        queue: Arc<Queue>,
        out: Sender<Out>,
        snapshot: Arc<Mutex<Option<Snapshot>>>,
    ) -> Worker {
        Worker {
            viewer,
            queue,
            out,
            snapshot,
            view: None,
            models: None,
            send_s: 0.0,
        }
    }

    /// Work until the queue is closed.
    pub fn run(mut self) {
        while let Some(work) = self.next() {
            match work {
                Work::Start(job, cancel) => self.start(job, cancel),
                Work::Pass => self.pass(),
                Work::Reference => self.reference(),
            }
        }
    }

    /// Wait for the next piece of work: a new request first, then the
    /// passes of the view, then its reference.
    fn next(&mut self) -> Option<Work> {
        let queue = Arc::clone(&self.queue);
        let mut p = queue.lock();
        loop {
            if p.closed {
                return None;
            }
            if let Some(job) = p.job.take() {
                p.running = Cancel::new();
                return Some(Work::Start(job, p.running.clone()));
            }
            if let Some(v) = self.view.as_mut() {
                if p.psnr.is_some_and(|s| s == v.seq) {
                    p.psnr = None;
                    v.psnr_wanted = true;
                    // Asked again: measured again.
                    v.referenced = false;
                }
                if v.passes.as_ref().is_some_and(|ps| !ps.done) {
                    return Some(Work::Pass);
                }
                if v.psnr_wanted && !v.referenced {
                    return Some(Work::Reference);
                }
            }
            p = queue.wake.wait(p).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// A new view: resolve its options, render its first frame (or
    /// pass).
    fn start(&mut self, job: Job, cancel: Cancel) {
        self.view = None;
        match self.prepare(&job, cancel) {
            Ok(view) => {
                let path = view.passes.is_some();
                self.view = Some(view);
                if path {
                    self.pass();
                } else {
                    self.cast();
                }
            }
            // A newer request stopped the preview's probe frames.
            Err(e) if e.kind() == ErrorKind::Cancelled => send(
                &self.out,
                Out::json(json!({"type": "cancelled", "seq": job.seq})),
            ),
            Err(e) => send(&self.out, Out::error(Some(job.seq), e.message())),
        }
    }

    /// The view `job` asks for, ready to render.
    fn prepare(&mut self, job: &Job, cancel: Cancel) -> Result<View, Error> {
        let viewer = Arc::clone(&self.viewer);
        let full = viewer.options(&job.pairs)?;
        let full_plan = viewer.plan(&full)?;
        let toml = volscene::file::to_toml(&full_plan.scene)?;
        let command = viewer.command(&job.pairs, &stem(job.seq, None))?;
        let (options, plan, note, choice) = if job.preview {
            self.preview(&full, &full_plan, &cancel)?
        } else {
            (full.clone(), full_plan.clone(), None, None)
        };
        let passes = match &plan.path {
            Some((_, budget)) => {
                let mut one = plan.clone();
                if let Some((_, b)) = one.path.as_mut() {
                    *b = Budget {
                        spp: Some(1),
                        seconds: None,
                        until_error: None,
                    };
                }
                Some(Passes {
                    plan: one,
                    budget: *budget,
                    acc: None,
                    started: Instant::now(),
                    done: false,
                })
            }
            None => None,
        };
        Ok(View {
            seq: job.seq,
            preview: job.preview,
            options,
            plan,
            full,
            full_plan,
            choice,
            cancel,
            passes,
            pairs: job.pairs.clone(),
            command,
            toml,
            note,
            shown: None,
            psnr_wanted: false,
            referenced: false,
        })
    }

    /// Render the view's ray-cast frame and send it; a preview
    /// calibrates the models' cost and the time sending takes.
    fn cast(&mut self) {
        let Some(v) = self.view.as_ref() else { return };
        let started = Instant::now();
        let result = self.viewer.render(&v.options, &v.plan, &v.cancel, None);
        let rendered_s = match (&result, v.choice, self.models.as_mut()) {
            (Ok(r), Some(c), Some((_, model))) => {
                if let volscene::Image::Frame(f) = &r.image {
                    let pixels = f64::from(f.width) * f64::from(f.height);
                    model.cost.observe(
                        c.step,
                        pixels,
                        c.scale,
                        f.stats.samples as f64,
                        r.times.render_s,
                    );
                }
                Some(r.times.render_s)
            }
            _ => None,
        };
        self.deliver(result, true);
        if let Some(render_s) = rendered_s {
            let sending = (started.elapsed().as_secs_f64() - render_s).max(0.0);
            self.send_s = 0.5 * (self.send_s + sending);
        }
    }

    /// The preview of a full view while the camera moves, with a line
    /// saying what it is. Ray casting: the step and image scale of best
    /// expected PSNR within the preview budget less what sending takes,
    /// from the view's models (probed when its options other than the
    /// camera change, calibrated by each preview since). Path tracing:
    /// half the image size while that leaves at least 256 pixels a side,
    /// one sample per pixel.
    fn preview(
        &mut self,
        full: &Options,
        full_plan: &Plan,
        cancel: &Cancel,
    ) -> Result<(Options, Plan, Option<String>, Option<Choice>), Error> {
        let viewer = Arc::clone(&self.viewer);
        let mut o = full.clone();
        o.budget = None;
        let (w, h) = full.size;
        if full_plan.path.is_some() {
            if w >= 512 && h >= 512 {
                o.size = (w / 2, h / 2);
            }
            let plan = viewer.plan(&o)?;
            let note = format!("preview: {}x{}, one sample per pixel", o.size.0, o.size.1);
            return Ok((o, plan, Some(note), None));
        }
        let key = model_key(full);
        let model = match &self.models {
            Some((k, m)) if *k == key => *m,
            _ => {
                let probed = viewer.probe(full, full_plan, cancel)?;
                self.models = Some((key, probed.model));
                probed.model
            }
        };
        let seconds = (viewer.preview_budget_s - self.send_s).max(MIN_PREVIEW_RENDER_S);
        let base = f64::from(full_plan.settings.step);
        let c = budget::choose(&model, base, full.size, seconds);
        o.step = Some(c.step as f32);
        o.size = (c.width, c.height);
        let plan = viewer.plan(&o)?;
        let note = format!(
            "preview: {}x{} ({:.0}% of the side), step {} ({}x the full {}); expected {:.0} ms, {}",
            c.width,
            c.height,
            c.scale * 100.0,
            plan.resolved.step,
            c.step_factor,
            full_plan.resolved.step,
            c.expected_s * 1e3,
            c.expected_psnr()
                .map_or_else(|| "no error".to_string(), |p| format!("{p:.1} dB"))
        );
        Ok((o, plan, Some(note), Some(c)))
    }

    /// Add one pass of one sample to the path-traced view and send it.
    fn pass(&mut self) {
        let Some(v) = self.view.as_mut() else { return };
        let Some(ps) = v.passes.as_mut() else { return };
        let prior = ps.acc.take();
        let result = self.viewer.render(&v.options, &ps.plan, &v.cancel, prior);
        let done = match &result {
            Ok(r) => match &r.image {
                volscene::Image::Path(t) => {
                    let spp = t.acc.spp();
                    v.preview
                        || spp >= ps.budget.spp.unwrap_or(MAX_SPP)
                        || ps
                            .budget
                            .seconds
                            .is_some_and(|s| ps.started.elapsed().as_secs_f64() >= s)
                        || ps
                            .budget
                            .until_error
                            .is_some_and(|e| t.acc.relative_error().is_some_and(|r| r <= e))
                }
                volscene::Image::Frame(_) => true,
            },
            Err(_) => true,
        };
        ps.done = done;
        self.deliver(result, done);
    }

    /// Send a rendered frame (unless its view went stale meanwhile), keep
    /// it for saving and for the PSNR.
    fn deliver(&mut self, result: Result<Rendered, Error>, last: bool) {
        let Some(v) = self.view.as_mut() else { return };
        let rendered = match result {
            Ok(r) => r,
            Err(e) if e.kind() == ErrorKind::Cancelled => {
                send(
                    &self.out,
                    Out::json(json!({"type": "cancelled", "seq": v.seq})),
                );
                return;
            }
            Err(e) => {
                if let Some(ps) = v.passes.as_mut() {
                    ps.done = true;
                }
                send(&self.out, Out::error(Some(v.seq), e.message()));
                return;
            }
        };
        if v.cancel.is_cancelled() {
            // A newer request came while this frame rendered.
            send(
                &self.out,
                Out::json(json!({"type": "cancelled", "seq": v.seq})),
            );
            return;
        }
        // A path-traced frame's saves state the passes it holds.
        let spp = match &rendered.image {
            volscene::Image::Path(t) if v.passes.is_some() => Some(t.acc.spp()),
            _ => None,
        };
        let stem = stem(v.seq, spp);
        let (command, toml) = match spp {
            Some(n) if !v.preview => match self.viewer.stated(&v.pairs, n, &stem) {
                Ok(stated) => stated,
                Err(e) => {
                    send(&self.out, Out::error(Some(v.seq), e.message()));
                    return;
                }
            },
            _ => (v.command.clone(), v.toml.clone()),
        };
        let (w, h) = (rendered.width(), rendered.height());
        let (channels, pixels) = rendered.display8(&v.options);
        let mut png = Vec::new();
        if let Err(e) = volformats::image::encode_png8(&mut png, w, h, channels, &pixels) {
            send(
                &self.out,
                Out::error(Some(v.seq), format!("the frame's PNG: {e}")),
            );
            return;
        }
        let volume = self.viewer.volume.clone();
        let scene_json = serde_json::to_value(&v.plan.scene).unwrap_or(Value::Null);
        let report = rendered.report(&volscene::report::Context {
            options: &v.options,
            volume: &volume,
            output: None,
            scene: &scene_json,
        });
        let extent = self.viewer.source.volume.meta.world_extent();
        let cost = cost::figures(&rendered, &v.plan.camera, extent, v.plan.settings.step);
        let target = v.passes.as_ref().map(|ps| ps.budget.spp);
        let header = json!({
            "type": "frame",
            "seq": v.seq,
            "width": w,
            "height": h,
            "preview": v.preview,
            "final": last,
            "note": v.note,
            "preview_choice": v.choice.map(|c| json!({
                "step": c.step,
                "step_factor": c.step_factor,
                "scale": c.scale,
                "width": c.width,
                "height": c.height,
                "expected_s": c.expected_s,
                "expected_psnr": c.expected_psnr(),
                "render_s": rendered.times.render_s,
            })),
            "cost": cost,
            "target_spp": target,
            "notes": v.plan.notes,
            "report": report.json,
            "command": command,
            "scene": toml,
            "tf": crate::hello::tf_points(v.plan.tf.as_ref()).unwrap_or(Value::Null),
        });
        if !v.preview {
            let snap = Snapshot {
                seq: v.seq,
                stem,
                command,
                width: w,
                height: h,
                rgb: rendered.linear_rgb(),
                png: png.clone(),
                toml,
            };
            *self.snapshot.lock().unwrap_or_else(|p| p.into_inner()) = Some(snap);
        }
        v.shown = Some(Shown {
            channels,
            pixels,
            width: w,
            height: h,
        });
        if let Some(ps) = v.passes.as_mut() {
            ps.acc = rendered.into_passes();
        }
        send(
            &self.out,
            Out {
                header,
                payload: png,
            },
        );
    }

    fn send_psnr(&self, seq: u64, db: Result<f64, String>, what: &str, secs: f64) {
        match db {
            Ok(db) => send(
                &self.out,
                Out::json(json!({
                    "type": "psnr",
                    "seq": seq,
                    // JSON has no infinity: identical images say so.
                    "db": db.is_finite().then_some(db),
                    "identical": db.is_infinite(),
                    "reference": what,
                    "reference_s": secs,
                })),
            ),
            Err(e) => send(&self.out, Out::error(Some(seq), e)),
        }
    }

    /// Render the view's reference at the finest settings (the same
    /// camera: a quarter of the step without early termination; path
    /// tracing four times the samples, at least 64, with another seed),
    /// then send the PSNR of the frame shown against it.
    fn reference(&mut self) {
        let Some(v) = self.view.as_mut() else { return };
        let t = Instant::now();
        let result = reference(&self.viewer, v);
        let secs = t.elapsed().as_secs_f64();
        match result {
            Ok((rendered, options, what)) => {
                let (c, pixels) = rendered.display8(&options);
                let (w, h) = (rendered.width(), rendered.height());
                let db = match &v.shown {
                    Some(s) => psnr(w, h, s.channels, &s.at_size(w, h), c, &pixels),
                    None => Err("no frame shown yet".to_string()),
                };
                v.referenced = true;
                let seq = v.seq;
                self.send_psnr(seq, db, &what, secs);
            }
            Err(e) if e.kind() == ErrorKind::Cancelled => {}
            Err(e) => {
                v.psnr_wanted = false;
                let seq = v.seq;
                send(
                    &self.out,
                    Out::error(Some(seq), format!("the reference: {}", e.message())),
                );
            }
        }
    }
}

/// The name (without extension) of view `seq`'s saves: `view-12`, or
/// `view-12-16spp` for a path-traced frame of 16 passes.
pub fn stem(seq: u64, spp: Option<u64>) -> String {
    match spp {
        Some(n) => format!("view-{seq}-{n}spp"),
        None => format!("view-{seq}"),
    }
}

/// Send `message` to the page (which has gone when this fails: the
/// queue closes next).
fn send(out: &Sender<Out>, message: Out) {
    let _ = out.send(message);
}

/// The key of the models `options` were probed for: the options
/// without the camera's position (a drag changes only those).
fn model_key(options: &Options) -> String {
    let mut v = serde_json::to_value(options).unwrap_or(Value::Null);
    if let Some(o) = v.as_object_mut() {
        for k in ["eye", "look_at", "up", "orbit"] {
            o.remove(k);
        }
    }
    v.to_string()
}

impl Shown {
    /// The pixels at `w` x `h`: as shown, or (a preview) upsampled as
    /// the page stretches it, rounded to 8 bits.
    fn at_size(&self, w: u32, h: u32) -> Vec<u8> {
        if (self.width, self.height) == (w, h) {
            return self.pixels.clone();
        }
        let f: Vec<f32> = self.pixels.iter().map(|&p| f32::from(p)).collect();
        budget::resize::bilinear(&f, self.channels, (self.width, self.height), (w, h))
            .iter()
            .map(|&p| (p + 0.5).clamp(0.0, 255.0) as u8)
            .collect()
    }
}

/// The reference render of view `v`, its options and what it is.
fn reference(viewer: &Viewer, v: &View) -> Result<(Rendered, Options, String), Error> {
    let mut o = v.full.clone();
    match &v.full_plan.path {
        None => {
            let step = v.full_plan.resolved.step;
            o.no_ert = true;
            // The finest of a quarter, a half and the same step that the
            // volume allows.
            let mut last = None;
            for f in [0.25f32, 0.5, 1.0] {
                o.step = Some(step * f);
                match viewer.plan(&o) {
                    Ok(plan) => {
                        let r = viewer.render(&o, &plan, &v.cancel, None)?;
                        let what = format!("step {} without early ray termination", step * f);
                        return Ok((r, o, what));
                    }
                    Err(e) => last = Some(e),
                }
            }
            Err(last.unwrap_or_else(|| Error::option("no reference step")))
        }
        Some((_, budget)) => {
            let spp = budget.spp.unwrap_or(64).saturating_mul(4).max(64);
            o.seed = o.seed.wrapping_add(1);
            o.spp = Some(spp);
            o.seconds = None;
            o.until_error = None;
            let mut plan = viewer.plan(&o)?;
            // In passes of 8 samples, so other pages' frames get their turn.
            if let Some((_, b)) = plan.path.as_mut() {
                b.spp = Some(8);
            }
            let mut acc = None;
            let mut done = 0;
            loop {
                let r = viewer.render(&o, &plan, &v.cancel, acc)?;
                done += 8;
                if done >= spp {
                    let what = format!("{done} samples per pixel (seed {})", o.seed);
                    return Ok((r, o, what));
                }
                acc = r.into_passes();
            }
        }
    }
}

/// The PSNR (dB, peak 255) of image `a` against `b`, both 8-bit with
/// their channel counts.
fn psnr(w: u32, h: u32, ca: usize, a: &[u8], cb: usize, b: &[u8]) -> Result<f64, String> {
    let image = |c: usize, px: &[u8]| {
        CmpImage::new(
            w,
            h,
            if c >= 3 { 3 } else { 1 },
            c == 4 || c == 2,
            Depth::U8,
            px.iter().map(|&v| f32::from(v)).collect(),
        )
        .map_err(|e| e.to_string())
    };
    let cmp = volcompare::compare_images(&image(ca, a)?, &image(cb, b)?, &ImageOptions::default())
        .map_err(|e| format!("the PSNR: {e}"))?;
    Ok(cmp.headline().psnr)
}
