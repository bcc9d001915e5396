//! Messages in Python's words: the library's one-line messages name the
//! command line's flags (`pass --window lo:hi`); raised from Python they
//! name the keyword instead (`pass window=lo:hi`). The keywords are the
//! flags of the one option definition of each call (vol-render's
//! `Options`, the input `Selection`, vol-convert's `PrepFlags` and output
//! options), each by its long name in snake case, so the mapping is the
//! same table the keywords are parsed with.

use clap::CommandFactory;
use std::collections::BTreeMap;
use std::sync::OnceLock;

/// save's output options, which are its own keyword arguments (named as
/// vol-convert's flags).
const SAVE_KEYWORDS: [&str; 7] = [
    "layout",
    "compress",
    "type",
    "window",
    "pyramid",
    "downsample",
    "ngff",
];

/// Words that follow a flag in a message without being its value
/// (`--iso needs --mode iso`).
const NOT_VALUES: [&str; 27] = [
    "needs",
    "applies",
    "asked",
    "must",
    "is",
    "are",
    "and",
    "or",
    "does",
    "would",
    "turns",
    "relabels",
    "read",
    "reads",
    "leaves",
    "resamples",
    "to",
    "for",
    "with",
    "without",
    "the",
    "of",
    "in",
    "not",
    "first",
    "stores",
    "takes",
];

/// Every flag Python takes as a keyword (by its long name), and whether
/// it takes a value.
fn flags() -> &'static BTreeMap<String, bool> {
    static FLAGS: OnceLock<BTreeMap<String, bool>> = OnceLock::new();
    FLAGS.get_or_init(|| {
        let mut out = BTreeMap::new();
        for cmd in [
            volscene::Options::command(),
            crate::volume::selection_command(),
            crate::prep::prep_command(),
        ] {
            for a in cmd.get_arguments() {
                if let Some(long) = a.get_long() {
                    out.insert(long.to_string(), a.get_action().takes_values());
                }
            }
        }
        for k in SAVE_KEYWORDS {
            out.insert(k.to_string(), true);
        }
        out
    })
}

/// `msg` with each flag Python takes (`--window`, `--time-point`) named
/// as its keyword (`window`, `time_point`); a flag's value that follows
/// it (`--window lo:hi`, `--mode=path`) joins it as `window=lo:hi`, and a
/// placeholder after it (`'--mode <MODE>'`) goes.
pub fn python_words(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let end = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .unwrap_or(after.len());
        let name = &after[..end];
        let Some(&takes_value) = flags().get(name) else {
            out.push_str("--");
            rest = after;
            continue;
        };
        out.push_str(&name.replace('-', "_"));
        rest = &after[end..];
        if !takes_value {
            continue;
        }
        if let Some(v) = rest.strip_prefix('=') {
            out.push('=');
            rest = v;
        } else if let Some(v) = rest.strip_prefix(' ') {
            let word_end = v.find([' ', '\'']).unwrap_or(v.len());
            let word = &v[..word_end];
            let bare = word.trim_end_matches([',', ';', ')', '.', ':']);
            if word.starts_with('<') {
                rest = &v[word_end..];
            } else if !bare.is_empty()
                && !bare.starts_with(['-', '(', '`', '{'])
                && !NOT_VALUES.contains(&bare)
            {
                out.push('=');
                rest = v;
            }
        }
    }
    out.push_str(rest);
    out
}

/// [`python_words`] for the tests, which compare a tool's message with
/// the one Python raises.
#[pyo3::pyfunction]
#[pyo3(name = "_python_words")]
pub fn python_words_py(msg: &str) -> String {
    python_words(msg)
}
