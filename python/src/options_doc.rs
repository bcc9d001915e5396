//! `help(volkit.render)`'s option list, from the one option definition
//! (vol-render's clap command, `volscene::Options`): each option by its
//! Python keyword with its value and help line, so the docstring lists
//! what the keywords are without a second copy to keep in step.

use crate::keywords::python_words;
use crate::render::ZYX_OPTIONS;
use clap::CommandFactory;
use pyo3::prelude::*;

/// The options `render` takes as keywords: (keyword, value, help), where
/// value is the flag's choices (`dvr|mip|iso|path`) or value name
/// (`SIZE`), None for a switch, and help the flag's help in Python's
/// words (keywords for flags, (z, y, x) for points); the heading each option is under
/// ("Path tracing", ...) is the fourth item, None for the main ones.
#[pyfunction]
pub fn render_options() -> Vec<(String, Option<String>, String, Option<String>)> {
    let cmd = volscene::Options::command();
    cmd.get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter(|a| {
            !matches!(
                a.get_id().as_str(),
                "help" | "version" | "volume" | "print_scene"
            )
        })
        .filter_map(|a| {
            a.get_long()?;
            let id = a.get_id().as_str();
            let choices: Vec<String> = a
                .get_possible_values()
                .iter()
                .filter(|v| !v.is_hide_set())
                .map(|v| v.get_name().to_string())
                .collect();
            let value = a
                .get_action()
                .takes_values()
                .then(|| match a.get_value_names() {
                    _ if !choices.is_empty() => choices.join("|"),
                    Some([n, ..]) => n.to_string(),
                    _ => id.to_uppercase(),
                });
            let mut help = python_words(&a.get_help().map(|h| h.to_string()).unwrap_or_default());
            if ZYX_OPTIONS.contains(&id) {
                help = help.replace("x,y,z", "(z, y, x)");
                if !help.contains("(z, y, x)") {
                    help.push_str("; a point (z, y, x)");
                }
            }
            Some((
                id.to_string(),
                value,
                help,
                a.get_help_heading().map(python_words),
            ))
        })
        .collect()
}
