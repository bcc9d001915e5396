//! Option values as the arguments of a command line: a name is an
//! option's long flag or id (`look-at` or `look_at`), a value JSON's
//! (`[0, 0, 0]`, `"ct"`, `true`), and the argument says the same
//! (`--look-at=0,0,0`), so clap parses, defaults and checks it as it
//! does the flag. Name/value pairs ([`crate::pairs`]) and scene-file keys
//! ([`crate::file`]) both go through here, for vol-render and for the
//! other tools (the Python package's `generate` takes vol-gen's).

use crate::error::{Error, Result};
use clap::{Arg, ArgAction, Command};
use serde_json::Value;
use std::collections::BTreeSet;

/// `name` as an option's id: `look-at` and `look_at` are `look_at`.
pub fn id_of(name: &str) -> String {
    name.trim().replace('-', "_")
}

/// Name/value pairs as arguments of the command line `cmd` defines
/// (without the program's name), and the ids of the options named: each
/// name an argument's id or long flag (`look-at` or `look_at`), a
/// positional argument's value after `--`. The other tools' options (the
/// Python package's `generate` takes vol-gen's) go through it too. An
/// unknown name is refused naming it; a `null` value is as if the pair
/// were not there.
pub fn command_args<I, K>(cmd: &Command, pairs: I) -> Result<(Vec<String>, BTreeSet<String>)>
where
    I: IntoIterator<Item = (K, Value)>,
    K: AsRef<str>,
{
    let mut args = Vec::new();
    let mut given = BTreeSet::new();
    let mut positional = Vec::new();
    for (name, value) in pairs {
        let name = name.as_ref();
        let id = id_of(name);
        if value.is_null() {
            continue;
        }
        let Some(arg) = cmd.get_arguments().find(|a| a.get_id().as_str() == id) else {
            return Err(Error::usage(format!(
                "unknown option `{}`",
                volcore::text::clip(&volcore::text::escape(name), 40)
            )));
        };
        let bad = |what: &str| {
            Error::usage(format!(
                "option `{}`: {what}",
                volcore::text::clip(&volcore::text::escape(name), 40)
            ))
        };
        let Some(long) = arg.get_long() else {
            // A positional argument (vol-render's volume).
            positional.push(text(&value).ok_or_else(|| bad("expected a path"))?);
            given.insert(id);
            continue;
        };
        match (arg.get_action(), &value) {
            (ArgAction::SetTrue, Value::Bool(b)) => {
                if *b {
                    args.push(format!("--{long}"));
                }
            }
            (ArgAction::SetTrue, _) => return Err(bad("expected true or false")),
            (ArgAction::Append, Value::Array(items)) => {
                for item in items {
                    let t = text(item).ok_or_else(|| bad("expected a list of texts"))?;
                    args.push(format!("--{long}={t}"));
                }
            }
            // An option whose value may be left out (`--ortho`).
            (_, Value::Bool(b)) if arg.get_num_args().is_some_and(|n| n.min_values() == 0) => {
                if *b {
                    args.push(format!("--{long}"));
                }
            }
            (_, v) => {
                let t = text(v).ok_or_else(|| bad("expected a value"))?;
                args.push(format!("--{long}={t}"));
            }
        }
        given.insert(id);
    }
    if !positional.is_empty() {
        args.push("--".into());
        args.extend(positional);
    }
    Ok((args, given))
}

/// A value as the text a flag takes: a string as it is, a number as
/// written, a list as its items joined by commas (`[700, 700]` is
/// `700,700`, which `--size` reads as `700x700`).
fn text(v: &Value) -> Option<String> {
    match v {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        Value::Array(items) => items
            .iter()
            .map(|i| match i {
                Value::String(s) => Some(s.clone()),
                Value::Number(n) => Some(n.to_string()),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| v.join(",")),
        Value::Null | Value::Object(_) => None,
    }
}

/// The option `key` names in a scene file: the argument whose long flag
/// it is, or the positional argument with that id (`volume`).
pub fn arg_of<'c>(cmd: &'c Command, key: &str) -> Option<&'c Arg> {
    cmd.get_arguments().find(|a| match a.get_long() {
        Some(long) => long == key,
        None => a.get_id().as_str() == key,
    })
}

/// The scene-file key of the option `arg` (its long flag; a positional's
/// id).
pub fn key_of(arg: &Arg) -> String {
    arg.get_long()
        .map_or_else(|| arg.get_id().as_str().to_string(), str::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn pairs_become_another_command_lines_arguments() {
        let cmd = Command::new("t")
            .arg(clap::Arg::new("scene").required(true))
            .arg(clap::Arg::new("seed").long("seed"))
            .arg(
                clap::Arg::new("dry_run")
                    .long("dry-run")
                    .action(ArgAction::SetTrue),
            );
        let (args, given) = command_args(
            &cmd,
            [
                ("seed", json!(4)),
                ("dry-run", json!(true)),
                ("scene", json!("shapes")),
                ("unused", Value::Null),
            ],
        )
        .unwrap();
        assert_eq!(args, ["--seed=4", "--dry-run", "--", "shapes"]);
        assert_eq!(
            given.into_iter().collect::<Vec<_>>(),
            ["dry_run", "scene", "seed"]
        );
        let e = command_args(&cmd, [("colour", json!(1))]).unwrap_err();
        assert_eq!(e.message(), "unknown option `colour`");
        let e = command_args(&cmd, [("dry_run", json!(3))]).unwrap_err();
        assert_eq!(e.message(), "option `dry_run`: expected true or false");
    }
}
