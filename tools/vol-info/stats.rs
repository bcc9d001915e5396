//! `vol-info --stats`, `--mask`, `--labels`: the flags, and the figures
//! of [`volformats::stats`] as text and JSON.

use anyhow::{anyhow, Result};
use clap::Args;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use volcore::histogram::{Histogram, DEFAULT_BINS, MAX_BINS};
use volcore::{LengthUnit, Volume};
use volformats::open::open_input;
use volformats::reader::{CResult, SliceReader};
use volformats::stats::{
    self, Inputs, LabelStats, Moments, OpenVolume, Opener, Stats, StatsError, DDOF,
};
use volformats::ReadOptions;
use volkit_cli::{outln, usage};

/// How many of the fullest bins the text lists.
const BUSIEST: usize = 5;

/// The statistics flags.
#[derive(Args, Debug)]
pub struct StatsFlags {
    /// Print statistics of the samples: count, min, max, mean, SD (ddof
    /// 0: numpy's std()), the percentiles 1, 5, 25, 50, 75, 95 and 99
    /// (exact, interpolated as numpy's default 'linear') and a histogram,
    /// in f64 from the samples as the file stores them. NaN and infinite
    /// samples are counted apart and left out of every other figure.
    /// Writes no file.
    #[arg(long)]
    pub stats: bool,
    /// Statistics inside a mask (implies --stats): a volume of the same
    /// dimensions in any format read; voxels where it is non-zero count.
    #[arg(long, value_name = "FILE")]
    pub mask: Option<PathBuf>,
    /// Statistics per label too (implies --stats), as c3d's -lstat: a
    /// volume of whole numbers of the same dimensions; for each label
    /// (0 included) its voxels, their physical volume (unit³ of the
    /// spacing), mean, SD, min and max. At most 65536 labels.
    #[arg(long, value_name = "FILE")]
    pub labels: Option<PathBuf>,
    /// Histogram bins (1..=65536), as vol-index --bins: at most N bins,
    /// one per value when the sample type has no more than N values (u8
    /// with the default).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_BINS,
          value_parser = clap::value_parser!(u32).range(1..=MAX_BINS as i64))]
    pub bins: u32,
}

impl StatsFlags {
    /// Whether any statistics are asked for.
    pub fn wanted(&self) -> bool {
        self.stats || self.mask.is_some() || self.labels.is_some()
    }
}

/// The statistics of a volume and what they were computed from.
pub struct Figures {
    stats: Stats,
    mask: Option<PathBuf>,
    labels: Option<PathBuf>,
    spacing: [f64; 3],
    unit: LengthUnit,
}

/// Open `path` for a pass (a mask or labels: never standard input).
fn opener<'a>(
    path: &'a Path,
    opts: &'a ReadOptions,
) -> impl Fn() -> CResult<Box<dyn SliceReader>> + Sync + 'a {
    move || open_input(path, opts)
}

/// Compute the statistics `flags` ask for of the volume `input` (read
/// with `opts`; `vol` is it open, read again when it came from standard
/// input). `None` when none are asked for.
pub fn compute(
    input: &Path,
    opts: &ReadOptions,
    vol: &Volume,
    flags: &StatsFlags,
    quiet: bool,
) -> Result<Option<Figures>> {
    if !flags.wanted() {
        return Ok(None);
    }
    for (flag, p) in [("--mask", &flags.mask), ("--labels", &flags.labels)] {
        if p.as_ref().is_some_and(|p| p.as_os_str() == "-") {
            return Err(usage(format!(
                "{flag} -: the {} is read once per pass: give a file",
                &flag[2..]
            )));
        }
    }
    // Standard input was read once: its statistics are the open volume's.
    let file = opener(input, opts);
    let open = OpenVolume {
        path: input.to_path_buf(),
        volume: vol,
    };
    let values: &dyn Opener = if input.as_os_str() == "-" {
        &open
    } else {
        &file
    };
    let plain = ReadOptions::default();
    let mask = flags.mask.as_deref().map(|p| opener(p, &plain));
    let labels = flags.labels.as_deref().map(|p| opener(p, &plain));
    let inputs = Inputs {
        values,
        mask: mask.as_ref().map(|m| m as &dyn Opener),
        labels: labels.as_ref().map(|l| l as &dyn Opener),
    };
    let m = vol.meta.as_stored();
    let passes = stats::passes(m.sample_type.into());
    let bar = volkit_cli::progress::count_bar(
        Some(m.dims.z * u64::from(passes)),
        "vol-info stats",
        "slices",
        quiet,
    );
    let opts = stats::Options { bins: flags.bins };
    let stats = stats::compute(&inputs, &opts, &|n| bar.inc(n));
    bar.finish_and_clear();
    let stats = stats.map_err(|e| match e {
        StatsError::Mismatch(m) => usage(m),
        e => anyhow!("{e}"),
    })?;
    Ok(Some(Figures {
        stats,
        mask: flags.mask.clone(),
        labels: flags.labels.clone(),
        spacing: m.spacing.map(f64::from),
        unit: m.geometry.unit,
    }))
}

/// `v` with 7 significant digits, trailing zeros dropped (`12.5`, `3`,
/// `1.234568e-9`): the text's numbers (JSON has every digit).
fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if !(1e-4..1e9).contains(&a) {
        return format!("{v:.6e}");
    }
    let decimals = (6 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The mean, SD, min and max of a set, `null` without finite samples.
fn moments_json(m: &Moments) -> Value {
    let (min, max) = m.range().unzip();
    json!({"mean": m.mean(), "sd": m.sd(DDOF), "min": min, "max": max})
}

fn histogram_json(h: &Histogram) -> Value {
    json!({
        "lo": h.lo(),
        "hi": h.hi(),
        "bins": h.bins(),
        "bin_width": (h.hi() - h.lo()) / h.bins() as f64,
        "counts": h.counts(),
    })
}

impl Figures {
    /// The `stats` key of the `--json` object.
    pub fn json(&self) -> Value {
        let s = &self.stats;
        let name = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
        let mut pct = serde_json::Map::new();
        for &(p, v) in &s.percentiles {
            pct.insert(format!("p{p}"), json!(v));
        }
        let mut v = json!({
            "type": s.sample_type.name(),
            "mask": name(&self.mask),
            "voxels": s.counts.voxels,
            "count": s.moments.count,
            "nan_count": s.counts.nan,
            "inf_count": s.counts.infinite,
            "ddof": DDOF,
            "percentiles": (!pct.is_empty()).then_some(Value::Object(pct)),
            "percentile_method": "linear",
            "histogram": s.histogram.as_ref().map(histogram_json),
            "labels": name(&self.labels),
        });
        volkit_cli::json::merge(&mut v, moments_json(&s.moments));
        if let Some(labels) = &s.labels {
            let per: Vec<Value> = labels.iter().map(|l| self.label_json(l)).collect();
            v["per_label"] = Value::Array(per);
        }
        json!({ "stats": v })
    }

    fn label_json(&self, l: &LabelStats) -> Value {
        let mut v = json!({
            "label": l.label,
            "voxels": l.counts.voxels,
            "volume": l.volume(self.spacing),
            "count": l.moments.count,
            "nan_count": l.counts.nan,
            "inf_count": l.counts.infinite,
        });
        volkit_cli::json::merge(&mut v, moments_json(&l.moments));
        v
    }

    /// The text, indented under the volume's description.
    pub fn print(&self) -> std::io::Result<()> {
        let s = &self.stats;
        let c = &s.counts;
        match &self.mask {
            Some(m) => outln!(
                "  stats ({}) inside {}: {} voxels",
                s.sample_type,
                m.display(),
                c.voxels
            )?,
            None => outln!("  stats ({}) of {} voxels", s.sample_type, c.voxels)?,
        }
        if !s.sample_type.is_integer() {
            outln!(
                "    {} NaN, {} infinite (left out of the figures)",
                c.nan,
                c.infinite
            )?;
        }
        let m = &s.moments;
        match (m.mean(), m.sd(DDOF), m.range()) {
            (Some(mean), Some(sd), Some((min, max))) => outln!(
                "    count {}, min {}, max {}, mean {}, SD {} (ddof {DDOF})",
                m.count,
                num(min),
                num(max),
                num(mean),
                num(sd)
            )?,
            _ => outln!("    count 0: no finite sample, no figures")?,
        }
        if !s.percentiles.is_empty() {
            let p: Vec<String> = s
                .percentiles
                .iter()
                .map(|&(p, v)| format!("p{p} {}", num(v)))
                .collect();
            outln!("    percentiles (exact, linear): {}", p.join(", "))?;
        }
        if let Some(h) = &s.histogram {
            let total = h.total().max(1) as f64;
            let b: Vec<String> = h
                .busiest(BUSIEST)
                .into_iter()
                .map(|i| {
                    let pc = 100.0 * h.counts()[i] as f64 / total;
                    format!("{} {pc:.1}%", h.bin_label(i))
                })
                .collect();
            outln!(
                "    histogram: {} bins over [{}, {}); busiest: {} (--json for every bin)",
                h.bins(),
                num(h.lo()),
                num(h.hi()),
                b.join(", ")
            )?;
        }
        if let (Some(labels), Some(path)) = (&s.labels, &self.labels) {
            self.print_labels(labels, path)?;
        }
        Ok(())
    }

    /// The per-label table.
    fn print_labels(&self, labels: &[LabelStats], path: &Path) -> std::io::Result<()> {
        let unit = match self.unit {
            LengthUnit::Unknown => "spacing unit³".to_string(),
            u => format!("{}³", u.symbol()),
        };
        outln!("  labels of {}: {}", path.display(), labels.len())?;
        let mut rows = vec![[
            "LABEL",
            "VOXELS",
            &format!("VOLUME ({unit})"),
            "MEAN",
            "SD",
            "MIN",
            "MAX",
        ]
        .map(String::from)];
        let opt = |v: Option<f64>| v.map_or("-".to_string(), num);
        for l in labels {
            let m = &l.moments;
            let (min, max) = m.range().unzip();
            rows.push([
                l.label.to_string(),
                l.counts.voxels.to_string(),
                num(l.volume(self.spacing)),
                opt(m.mean()),
                opt(m.sd(DDOF)),
                opt(min),
                opt(max),
            ]);
        }
        for line in crate::listing::columns(&rows) {
            outln!("    {line}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(3.0), "3");
        assert_eq!(num(127.53012084960938), "127.5301");
        assert_eq!(num(-0.25), "-0.25");
        assert_eq!(num(1234567.0), "1234567");
        assert_eq!(num(1.5e-9), "1.500000e-9");
        assert_eq!(num(0.0), "0");
        assert_eq!(num(f64::NAN), "NaN");
    }
}
