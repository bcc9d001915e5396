//! The preprocessing keywords of `volkit.save` (`resample`, `kernel`,
//! `no_antialias`, `background`, `orient`, `smooth`, `median`, `clamp`,
//! `threshold`, `mask`): vol-convert's flags by their long names in snake
//! case, parsed by the one definition (`volformats::PrepFlags`), so a
//! keyword means what its flag means and the bytes written are the same.

use crate::errors;
use pyo3::prelude::*;
use volformats::PrepFlags;

/// The preprocessing flags as a clap command.
pub fn prep_command() -> clap::Command {
    use clap::Args;
    PrepFlags::augment_args(clap::Command::new("save").no_binary_name(true))
}

/// The keywords: each preprocessing flag's long name in snake case.
pub fn prep_keywords() -> Vec<String> {
    prep_command()
        .get_arguments()
        .filter_map(|a| a.get_long())
        .map(|l| l.replace('-', "_"))
        .collect()
}

/// Whether `key` is a preprocessing keyword.
pub fn is_prep_keyword(key: &str) -> bool {
    prep_keywords().iter().any(|k| k == key)
}

/// The preprocessing `kw` asks for (keywords not among
/// [`prep_keywords`] are the caller's to refuse).
pub fn prep_flags(kw: &[(String, Bound<'_, PyAny>)]) -> PyResult<PrepFlags> {
    let mut argv: Vec<String> = Vec::new();
    for (key, v) in kw {
        if v.is_none() {
            continue;
        }
        let flag = format!("--{}", key.replace('_', "-"));
        if key == "no_antialias" {
            if v.extract::<bool>()? {
                argv.push(flag);
            }
            continue;
        }
        argv.push(flag);
        argv.push(crate::volume::text_of(v)?);
    }
    let matches = prep_command().try_get_matches_from(&argv).map_err(|e| {
        let text = e.render().to_string();
        let line = text.lines().next().unwrap_or("").trim();
        errors::value(line.strip_prefix("error: ").unwrap_or(line).to_string())
    })?;
    <PrepFlags as clap::FromArgMatches>::from_arg_matches(&matches)
        .map_err(|e| errors::value(e.to_string()))
}
