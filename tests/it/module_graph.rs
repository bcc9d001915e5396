//! No import cycles between the modules of a library crate.
//!
//! Each library crate of the workspace (the `[workspace] members` of the
//! root `Cargo.toml` that have a `[lib]`) is read as text, from its crate
//! root (`src/lib.rs`, or the `[lib] path`) along its `mod name;`
//! declarations: a file's module path is its place in that tree (the crate
//! root is `crate`, `foo.rs` and `foo/mod.rs` are `foo`, `foo/bar.rs` is
//! `foo::bar`). Test-only code is left out: a module or `use` under
//! `#[cfg(test)]` (or `#[cfg(all(test, ..))]`), a file named `tests.rs` or
//! under a `tests/` directory, and any item `#[cfg(test)]` marks.
//!
//! What counts as an edge from file A to file B (B the longest module path
//! that prefixes what A names; comments, doc comments and string literals
//! are not read):
//! - `mod b;` in A: A declares its child B;
//! - a `use` path, `pub use` included, every leaf of a `{..}` group:
//!   `use crate::b::X`, `use super::X` (B is A's parent, whatever X is),
//!   `use self::b::X` and `use b::X` for a child `b`;
//! - a path in code: `crate::b::f(..)`, `super::b::X`, `b::f(..)` for a
//!   child `b` or for a name a `use` of A brought in (`use crate::b;` then
//!   `b::c::f(..)` names `b::c`). `$crate::` in a macro counts for the file
//!   that defines the macro.
//!
//! Re-exports are not followed: `crate::Result` names the crate root and
//! `crate::convert::SliceType` names `convert`, whichever module defines
//! the item, since the path goes through the re-export. So a module using
//! its crate root's re-exports is in a cycle with the root (which
//! declares it): inside a crate, name the defining module.
//!
//! A cycle is a strongly connected component of more than one file
//! (Tarjan), except one whose files all lie within one directory module
//! (`foo/mod.rs` or `foo.rs`, and the files under `foo/`) other than the
//! crate root: that module's files may refer to each other (its `mod.rs`
//! declares its children and re-exports what they define, they use what it
//! holds for all of them, as `formats/src/tiff/` does). What crosses a
//! directory module's boundary may not come back.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Crates whose cycles are tolerated for now (member directory, why):
/// the test prints their cycles without failing, and fails when an entry
/// is no longer needed. Each is a restructuring of its own; `formats`
/// may not be listed (issue 42 took its cycle apart).
const ALLOWED: &[(&str, &str)] = &[
    (
        // tools/cli, the tools' shared library.
        ".",
        "#[macro_export] macros (outln!, noteln!, defined in run.rs) are \
         named from the crate root (json -> crate); select names \
         crate::usage, the root's re-export of run::usage",
    ),
    (
        "volcore",
        "sample and grid use each other (Sample's blend methods call \
         grid::blend_cell_from and blend_cross_from), and grid, meta and \
         volume name the root's re-exports (crate::Result, crate::Sample)",
    ),
];

/// A module path: `[]` is the crate root, `["convert", "writers"]` is
/// `convert::writers`.
type ModPath = Vec<String>;

fn show(m: &[String]) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

// ---------------------------------------------------------------- lexing

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Sep,
    Punct(char),
}

/// The tokens of a Rust source with their 1-based line numbers, without
/// comments, string, byte-string, raw-string and char literals (a literal
/// becomes one `Punct('"')`, so no path runs across it).
fn lex(src: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut line = 1;
    let mut i = 0;
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    // Skip a quoted literal opened at `i` (on `"`), escapes honoured.
    let skip_str = |mut i: usize, line: &mut usize| -> usize {
        i += 1;
        while i < c.len() && c[i] != '"' {
            if c[i] == '\\' {
                i += 1;
            }
            if at(i) == '\n' {
                *line += 1;
            }
            i += 1;
        }
        i + 1
    };
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
            }
        } else if ch == '"' {
            i = skip_str(i, &mut line);
            out.push((Tok::Punct('"'), line));
        } else if ch == '\'' {
            // A char literal ('a', '\n', '\u{1F600}') or a lifetime ('a).
            if at(i + 1) == '\\' {
                // Past the escaped character, which may be a quote.
                i += 3;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                out.push((Tok::Punct('"'), line));
            } else if at(i + 2) == '\'' {
                i += 3;
                out.push((Tok::Punct('"'), line));
            } else {
                i += 1;
                out.push((Tok::Punct('\''), line));
            }
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let raw = matches!(word.as_str(), "r" | "br" | "cr");
            if raw && (at(i) == '"' || (at(i) == '#' && matches!(at(i + 1), '#' | '"'))) {
                // r"..", r#".."#, br##".."##: ends at `"` and as many `#`.
                let mut hashes = 0;
                while at(i) == '#' {
                    hashes += 1;
                    i += 1;
                }
                i += 1;
                loop {
                    if i >= c.len() {
                        break;
                    }
                    if c[i] == '"' && (1..=hashes).all(|k| at(i + k) == '#') {
                        i += 1 + hashes;
                        break;
                    }
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
                out.push((Tok::Punct('"'), line));
            } else if matches!(word.as_str(), "b" | "c") && at(i) == '"' {
                i = skip_str(i, &mut line);
                out.push((Tok::Punct('"'), line));
            } else if word == "b" && at(i) == '\'' {
                i += 1;
                if at(i) == '\\' {
                    i += 1;
                }
                i += 1;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                out.push((Tok::Punct('"'), line));
            } else if word == "r" && at(i) == '#' {
                // A raw identifier, r#type.
                i += 1;
                let s = i;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
                out.push((Tok::Ident(c[s..i].iter().collect()), line));
            } else {
                out.push((Tok::Ident(word), line));
            }
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push((Tok::Punct('0'), line));
        } else if ch == ':' && at(i + 1) == ':' {
            out.push((Tok::Sep, line));
            i += 2;
        } else {
            out.push((Tok::Punct(ch), line));
            i += 1;
        }
    }
    out
}

// --------------------------------------------------------------- parsing

/// A path a file names, as written, and where.
#[derive(Debug)]
struct Named {
    /// The module the path is written in: the file's, plus any inline
    /// `mod x { .. }` around it.
    scope: ModPath,
    /// The segments as written (`crate`, `super`, `self` kept).
    segs: Vec<String>,
    line: usize,
    /// Whether it is a `use` path (`false`: a path in code).
    is_use: bool,
}

/// What one file holds: its `mod name;` declarations (with the inline
/// module they sit in), the names its `use` declarations bring in, and the
/// paths it names.
#[derive(Debug, Default)]
struct Scan {
    mods: Vec<(ModPath, String, usize)>,
    /// Per scope (the inline module path relative to the file), the names
    /// `use` brought in and the path each stands for (as written).
    aliases: BTreeMap<ModPath, BTreeMap<String, Vec<String>>>,
    named: Vec<Named>,
}

fn ident(t: Option<&(Tok, usize)>) -> Option<&str> {
    match t {
        Some((Tok::Ident(s), _)) => Some(s),
        _ => None,
    }
}

fn is(t: Option<&(Tok, usize)>, c: char) -> bool {
    matches!(t, Some((Tok::Punct(p), _)) if *p == c)
}

/// The index after the bracket group opening at `i` (`(`, `[` or `{`).
fn close(toks: &[(Tok, usize)], i: usize) -> usize {
    let mut depth = 0i32;
    let mut j = i;
    while j < toks.len() {
        match toks[j].0 {
            Tok::Punct('(' | '[' | '{') => depth += 1,
            Tok::Punct(')' | ']' | '}') => {
                depth -= 1;
                if depth == 0 {
                    return j + 1;
                }
            }
            _ => {}
        }
        j += 1;
    }
    j
}

/// The index after the item starting at `i`: its outer attributes, then
/// up to a `;` outside brackets or through its first `{ .. }` body.
fn skip_item(toks: &[(Tok, usize)], mut i: usize) -> usize {
    while is(toks.get(i), '#') && is(toks.get(i + 1), '[') {
        i = close(toks, i + 1);
    }
    while i < toks.len() {
        match toks[i].0 {
            Tok::Punct(';') => return i + 1,
            Tok::Punct('{') => return close(toks, i),
            Tok::Punct('(' | '[') => i = close(toks, i),
            _ => i += 1,
        }
    }
    i
}

/// Whether the attribute tokens (between `#[` and `]`) make the item
/// test-only: `cfg(test)` or `cfg(all(test, ..))`.
fn test_only(attr: &[(Tok, usize)]) -> bool {
    let words: Vec<String> = attr
        .iter()
        .map(|(t, _)| match t {
            Tok::Ident(s) => s.clone(),
            Tok::Punct(p) => p.to_string(),
            Tok::Sep => "::".into(),
        })
        .collect();
    let w: Vec<&str> = words.iter().map(String::as_str).collect();
    matches!(w.as_slice(), ["cfg", "(", "test", ")"])
        || (w.starts_with(&["cfg", "(", "all", "("]) && w.get(4) == Some(&"test"))
}

/// Parse the use tree starting at `*i` under `prefix`; push each leaf's
/// path, alias (the name it binds; `None` for `*` and `_`) and line.
fn use_tree(
    toks: &[(Tok, usize)],
    i: &mut usize,
    mut prefix: Vec<String>,
    out: &mut Vec<(Vec<String>, Option<String>, usize)>,
) {
    loop {
        match toks.get(*i) {
            Some((Tok::Punct('{'), _)) => {
                *i += 1;
                while *i < toks.len() && !is(toks.get(*i), '}') {
                    use_tree(toks, i, prefix.clone(), out);
                    if is(toks.get(*i), ',') {
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            Some((Tok::Punct('*'), line)) => {
                *i += 1;
                out.push((prefix, None, *line));
                return;
            }
            Some((Tok::Ident(seg), line)) => {
                *i += 1;
                if is(toks.get(*i), '{') || matches!(toks.get(*i), Some((Tok::Sep, _))) {
                    prefix.push(seg.clone());
                    if matches!(toks.get(*i), Some((Tok::Sep, _))) {
                        *i += 1;
                    }
                    continue;
                }
                // A leaf: `x`, `x as y`, or `self` (the prefix itself).
                let mut name = Some(seg.clone());
                if seg == "self" {
                    name = prefix.last().cloned();
                } else {
                    prefix.push(seg.clone());
                }
                if ident(toks.get(*i)) == Some("as") {
                    name = ident(toks.get(*i + 1))
                        .filter(|n| *n != "_")
                        .map(String::from);
                    *i += 2;
                }
                out.push((prefix, name, *line));
                return;
            }
            Some((Tok::Sep, _)) => {
                // `::name`: an external crate, no edge.
                if prefix.is_empty() {
                    prefix.push("::".into());
                }
                *i += 1;
            }
            _ => return,
        }
    }
}

/// Read one file: its module declarations, `use` paths and code paths.
fn scan(src: &str) -> Scan {
    let toks = lex(src);
    let mut s = Scan::default();
    // Inline modules open around the current token: (name, brace depth
    // their body opened at).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < toks.len() {
        let scope: ModPath = inline.iter().map(|(n, _)| n.clone()).collect();
        match &toks[i].0 {
            Tok::Punct('#') if is(toks.get(i + 1), '!') => {
                i = close(&toks, i + 2);
            }
            Tok::Punct('#') if is(toks.get(i + 1), '[') => {
                let end = close(&toks, i + 1);
                if test_only(&toks[i + 2..end - 1]) {
                    i = skip_item(&toks, end);
                } else {
                    i = end;
                }
            }
            Tok::Punct('{') => {
                depth += 1;
                i += 1;
            }
            Tok::Punct('}') => {
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            Tok::Ident(w) if w == "mod" => match (ident(toks.get(i + 1)), toks.get(i + 2)) {
                (Some(name), Some((Tok::Punct(';'), line))) => {
                    s.mods.push((scope, name.to_string(), *line));
                    i += 3;
                }
                (Some(name), Some((Tok::Punct('{'), _))) => {
                    depth += 1;
                    inline.push((name.to_string(), depth));
                    i += 3;
                }
                _ => i += 1,
            },
            Tok::Ident(w) if w == "use" => {
                i += 1;
                let mut leaves = Vec::new();
                use_tree(&toks, &mut i, Vec::new(), &mut leaves);
                for (segs, name, line) in leaves {
                    if segs.first().is_some_and(|f| f == "::") {
                        continue;
                    }
                    if let Some(n) = name {
                        s.aliases
                            .entry(scope.clone())
                            .or_default()
                            .insert(n, segs.clone());
                    }
                    s.named.push(Named {
                        scope: scope.clone(),
                        segs,
                        line,
                        is_use: true,
                    });
                }
            }
            Tok::Ident(first) => {
                // A path in code: `a::b::c`, not itself after `::` or `.`.
                let after_sep = i > 0 && matches!(toks[i - 1].0, Tok::Sep | Tok::Punct('.'));
                let line = toks[i].1;
                let mut segs = vec![first.clone()];
                let mut j = i + 1;
                while matches!(toks.get(j), Some((Tok::Sep, _))) {
                    match ident(toks.get(j + 1)) {
                        Some(n) => segs.push(n.to_string()),
                        None => break,
                    }
                    j += 2;
                }
                if !after_sep && segs.len() > 1 {
                    s.named.push(Named {
                        scope,
                        segs,
                        line,
                        is_use: false,
                    });
                }
                i = j.max(i + 1);
            }
            _ => i += 1,
        }
    }
    s
}

// ------------------------------------------------------------ the crate

/// One use of a module by another: where.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Site {
    file: String,
    line: usize,
}

/// A crate's files and the edges between them.
#[derive(Debug, Default)]
struct Graph {
    /// Module path -> file (relative to the workspace root).
    files: BTreeMap<ModPath, String>,
    /// (from, to) -> where.
    edges: BTreeMap<(ModPath, ModPath), BTreeSet<Site>>,
}

/// Whether a declared child `name` of the module whose children live in
/// `dir` is test-only by its file: `tests.rs`, `tests/mod.rs`.
fn test_file(name: &str) -> bool {
    name == "tests"
}

/// Read the crate whose root file is `root` (`rel`: how to show paths).
fn crate_graph(root: &Path, show_base: &Path) -> Graph {
    let mut g = Graph::default();
    let mut scans: BTreeMap<ModPath, Scan> = BTreeMap::new();
    // (module path, file, directory its children's files are in)
    let mut todo: Vec<(ModPath, PathBuf, PathBuf)> = vec![(
        Vec::new(),
        root.to_path_buf(),
        root.parent().unwrap().to_path_buf(),
    )];
    let rel = |p: &Path| {
        p.strip_prefix(show_base)
            .unwrap_or(p)
            .to_string_lossy()
            .into_owned()
    };
    while let Some((m, file, dir)) = todo.pop() {
        let src =
            std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let sc = scan(&src);
        for (inline, name, line) in &sc.mods {
            if test_file(name) {
                continue;
            }
            let mut d = dir.clone();
            for n in inline {
                d.push(n);
            }
            let (f, cd) = if d.join(format!("{name}.rs")).is_file() {
                (d.join(format!("{name}.rs")), d.join(name))
            } else {
                (d.join(name).join("mod.rs"), d.join(name))
            };
            assert!(
                f.is_file(),
                "{}:{line}: no file for mod {name}",
                file.display()
            );
            let mut child = m.clone();
            child.extend(inline.iter().cloned());
            child.push(name.clone());
            g.edges
                .entry((m.clone(), child.clone()))
                .or_default()
                .insert(Site {
                    file: rel(&file),
                    line: *line,
                });
            todo.push((child, f, cd));
        }
        g.files.insert(m.clone(), rel(&file));
        scans.insert(m, sc);
    }
    // Resolve every named path to the longest module path it starts with.
    for (m, sc) in &scans {
        let file = &g.files[m];
        for n in &sc.named {
            let mut here = m.clone();
            here.extend(n.scope.iter().cloned());
            let Some(abs) = absolute(&g, &here, &n.segs, sc.aliases.get(&n.scope), n.is_use) else {
                continue;
            };
            let to = (0..=abs.len())
                .rev()
                .map(|k| abs[..k].to_vec())
                .find(|p| g.files.contains_key(p))
                .unwrap_or_default();
            if &to != m {
                g.edges.entry((m.clone(), to)).or_default().insert(Site {
                    file: file.clone(),
                    line: n.line,
                });
            }
        }
    }
    g
}

/// The absolute module path `segs` (written in module `here`) stands for,
/// or `None` when it starts outside the crate (another crate, a local
/// name, a type).
fn absolute(
    g: &Graph,
    here: &ModPath,
    segs: &[String],
    aliases: Option<&BTreeMap<String, Vec<String>>>,
    is_use: bool,
) -> Option<ModPath> {
    let first = segs.first()?;
    let (mut abs, rest): (ModPath, &[String]) = match first.as_str() {
        "crate" => (Vec::new(), &segs[1..]),
        "self" | "super" => (here.clone(), segs),
        _ => {
            let mut child = here.clone();
            child.push(first.clone());
            if g.files.contains_key(&child) {
                (child, &segs[1..])
            } else if let Some(target) = aliases.and_then(|a| a.get(first)).filter(|_| !is_use) {
                // A name a `use` brought in: what it stands for, resolved
                // in this module too (without aliases, so no loop).
                let mut base = absolute(g, here, target, None, true)?;
                base.extend(segs[1..].iter().cloned());
                return Some(base);
            } else {
                return None;
            }
        }
    };
    for s in rest {
        match s.as_str() {
            "self" => {}
            "super" => {
                abs.pop()?;
            }
            _ => abs.push(s.clone()),
        }
    }
    Some(abs)
}

// ------------------------------------------------------------ the cycles

/// Strongly connected components of more than one module (Tarjan).
fn sccs(g: &Graph) -> Vec<Vec<ModPath>> {
    struct T<'a> {
        adj: BTreeMap<&'a ModPath, Vec<&'a ModPath>>,
        index: BTreeMap<&'a ModPath, usize>,
        low: BTreeMap<&'a ModPath, usize>,
        stack: Vec<&'a ModPath>,
        on: BTreeSet<&'a ModPath>,
        out: Vec<Vec<ModPath>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a ModPath) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        for w in t.adj.get(v).cloned().unwrap_or_default() {
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                comp.push(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        adj: BTreeMap::new(),
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for (a, b) in g.edges.keys() {
        t.adj.entry(a).or_default().push(b);
    }
    for m in g.files.keys() {
        if !t.index.contains_key(m) {
            visit(&mut t, m);
        }
    }
    t.out.sort();
    t.out
}

/// The cycles of a crate, as the report lines of each: the modules, then
/// every edge between them with where it is named. Cycles within one
/// directory module (other than the crate root) are left out.
fn cycles(g: &Graph) -> Vec<String> {
    let mut found = Vec::new();
    for comp in sccs(g) {
        let common = comp
            .iter()
            .skip(1)
            .fold(comp[0].clone(), |acc: ModPath, m| {
                acc.iter()
                    .zip(m)
                    .take_while(|(a, b)| a == b)
                    .map(|(a, _)| a.clone())
                    .collect()
            });
        if !common.is_empty() {
            continue;
        }
        let members: BTreeSet<&ModPath> = comp.iter().collect();
        let mut text = format!(
            "cycle of {} modules: {}\n",
            comp.len(),
            comp.iter().map(|m| show(m)).collect::<Vec<_>>().join(", ")
        );
        for ((a, b), sites) in &g.edges {
            if members.contains(a) && members.contains(b) {
                let at: Vec<String> = sites.iter().map(|s| s.line.to_string()).collect();
                let file = &sites.iter().next().unwrap().file;
                let _ = writeln!(
                    text,
                    "  {} -> {}  ({file}:{})",
                    show(a),
                    show(b),
                    at.join(",")
                );
            }
        }
        found.push(text);
    }
    found
}

// ------------------------------------------------------------- the tests

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The crate root file of each library crate of the workspace: (member
/// directory, root file). Reads `members = [..]` and each `[lib] path`.
fn library_crates() -> Vec<(String, PathBuf)> {
    let ws = workspace();
    let top = std::fs::read_to_string(ws.join("Cargo.toml")).unwrap();
    let line = top
        .lines()
        .find(|l| l.trim_start().starts_with("members"))
        .expect("no workspace members");
    let members: Vec<String> = line
        .split('"')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect();
    let mut out = Vec::new();
    for m in members {
        let dir = ws.join(&m);
        let toml = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
        let mut in_lib = false;
        let mut path = None;
        let mut has_lib = false;
        for l in toml.lines() {
            let l = l.trim();
            if l.starts_with('[') {
                in_lib = l == "[lib]";
                has_lib |= in_lib;
            } else if in_lib && l.starts_with("path") {
                path = l.split('"').nth(1).map(String::from);
            }
        }
        let root = dir.join(path.unwrap_or_else(|| "src/lib.rs".into()));
        if has_lib || root.is_file() {
            out.push((m, root));
        }
    }
    assert!(out.len() >= 6, "found only {out:?}");
    out
}

#[test]
fn no_cycles_between_modules() {
    let mut failed = String::new();
    let mut needless = Vec::new();
    for (member, root) in library_crates() {
        let g = crate_graph(&root, &workspace());
        let found = cycles(&g);
        let allowed = ALLOWED.iter().any(|(m, _)| *m == member);
        eprintln!(
            "{member}: {} modules, {} edges, {} cycle(s){}",
            g.files.len(),
            g.edges.len(),
            found.len(),
            if allowed { " (allowed)" } else { "" }
        );
        for c in &found {
            eprint!("{c}");
        }
        if allowed && found.is_empty() {
            needless.push(member.clone());
        }
        if !allowed && !found.is_empty() {
            let _ = write!(failed, "{member}:\n{}", found.concat());
        }
    }
    assert!(
        failed.is_empty(),
        "import cycles between modules (see the doc of tests/it/module_graph.rs):\n{failed}"
    );
    assert!(
        needless.is_empty(),
        "no cycles left in {needless:?}: remove them from ALLOWED"
    );
}

#[test]
fn formats_is_not_allowed_cycles() {
    assert!(ALLOWED.iter().all(|(m, _)| *m != "formats"));
}

/// The checker itself, on a small crate written for it.
#[test]
fn finds_cycles_and_only_those() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    let put = |p: &str, text: &str| {
        let f = src.join(p);
        std::fs::create_dir_all(f.parent().unwrap()).unwrap();
        std::fs::write(f, text).unwrap();
    };
    put(
        "lib.rs",
        "//! use crate::b::X; (a comment)\npub mod a;\npub mod b;\npub mod c;\npub mod d;\n\
         pub mod leaf;\n#[cfg(test)]\nmod tests;\npub use a::A;\n",
    );
    // a <-> b through a group and a code path.
    put(
        "a.rs",
        "use crate::{leaf::L, b::{self, B}};\npub struct A;\n",
    );
    put(
        "b.rs",
        "pub struct B;\nfn f() { let _ = \"crate::c::X\"; crate::a::A; }\n",
    );
    // c -> d only: d's use of c is in a test module or a comment.
    put("c.rs", "pub use crate::d::D;\n");
    put(
        "d.rs",
        "/* crate::c::C */ pub struct D;\n#[cfg(test)]\nmod t { use crate::c::C; }\n",
    );
    // A directory module whose files use each other: not a cycle.
    put(
        "leaf/mod.rs",
        "mod part;\npub use part::L;\npub struct Shared;\n",
    );
    put("leaf/part.rs", "use super::Shared;\npub struct L;\n");
    put("tests.rs", "use crate::a::A;\n");
    let g = crate_graph(&src.join("lib.rs"), dir.path());
    let found = cycles(&g);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with("cycle of 2 modules: a, b\n"),
        "{found:?}"
    );
    assert!(found[0].contains("a -> b  (src/a.rs:1)"), "{found:?}");
    assert!(found[0].contains("b -> a  (src/b.rs:2)"), "{found:?}");
    assert!(g.edges.contains_key(&(vec!["c".into()], vec!["d".into()])));
    assert!(!g.edges.contains_key(&(vec!["d".into()], vec!["c".into()])));
    assert!(!g.edges.contains_key(&(vec!["b".into()], vec!["c".into()])));
    let part = vec!["leaf".to_string(), "part".to_string()];
    assert!(g.edges.contains_key(&(part, vec!["leaf".into()])));

    // A module using the crate root's re-export is in a cycle with it.
    put(
        "c.rs",
        "pub use crate::d::D;\nfn g() -> crate::A { todo!() }\n",
    );
    let g = crate_graph(&src.join("lib.rs"), dir.path());
    let found = cycles(&g);
    assert!(
        found
            .iter()
            .any(|c| c.contains("crate -> c") && c.contains("c -> crate")),
        "{found:?}"
    );
}
