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

/// Values of flags without a list of choices that messages quote after
/// the flag (`--window auto`, `--compress gzip`, `--up patient`).
const LITERAL_VALUES: [&str; 7] = ["auto", "full", "gzip", "zstd", "patient", "off", "none"];

/// A flag Python takes as a keyword: whether it takes a value, and its
/// choices (`--mode`'s `dvr`, `iso`, ...).
struct Flag {
    takes_value: bool,
    choices: Vec<String>,
}

/// Every flag Python takes as a keyword, by its long name.
fn flags() -> &'static BTreeMap<String, Flag> {
    static FLAGS: OnceLock<BTreeMap<String, Flag>> = OnceLock::new();
    FLAGS.get_or_init(|| {
        let mut out = BTreeMap::new();
        for cmd in [
            volscene::Options::command(),
            crate::volume::selection_command(),
            crate::prep::prep_command(),
        ] {
            for a in cmd.get_arguments() {
                if let Some(long) = a.get_long() {
                    let choices = a
                        .get_possible_values()
                        .iter()
                        .map(|v| v.get_name().to_string())
                        .collect();
                    let takes_value = a.get_action().takes_values();
                    out.insert(
                        long.to_string(),
                        Flag {
                            takes_value,
                            choices,
                        },
                    );
                }
            }
        }
        for k in SAVE_KEYWORDS {
            let flag = Flag {
                takes_value: true,
                choices: Vec::new(),
            };
            out.insert(k.to_string(), flag);
        }
        out
    })
}

/// Whether `word`, after `flag` in a message, is its value: a choice of
/// the flag, a known literal, a placeholder in capitals (`T`, `X,Y,Z`),
/// or anything with digits or punctuation (`lo:hi`, `i16`, `bricked:B`);
/// an English word (`--iso needs`) is not.
fn is_value(flag: &Flag, word: &str) -> bool {
    let word = word.trim_end_matches([',', ';', ')', '.']);
    if word.is_empty() || word.starts_with(['-', '(', '`']) {
        return false;
    }
    flag.choices.iter().any(|c| c == word)
        || LITERAL_VALUES.contains(&word)
        || word.chars().all(|c| c.is_ascii_uppercase() || c == ',')
        || word
            .chars()
            .any(|c| c.is_ascii_digit() || ":,=".contains(c))
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
        let Some(flag) = flags().get(name) else {
            out.push_str("--");
            rest = after;
            continue;
        };
        out.push_str(&name.replace('-', "_"));
        rest = &after[end..];
        if !flag.takes_value {
            continue;
        }
        if let Some(v) = rest.strip_prefix('=') {
            out.push('=');
            rest = v;
        } else if let Some(v) = rest.strip_prefix(' ') {
            let word_end = v.find([' ', '\'']).unwrap_or(v.len());
            let word = &v[..word_end];
            if word.starts_with('<') {
                rest = &v[word_end..];
            } else if is_value(flag, word) {
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
