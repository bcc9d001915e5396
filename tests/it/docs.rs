//! The README and the guide in docs/: every relative link resolves to a
//! file of the checkout, and every `#anchor` to a heading of its page (as
//! GitHub makes anchors from headings).

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The Markdown pages: README.md and docs/*.md.
fn pages() -> Vec<PathBuf> {
    let mut v = vec![root().join("README.md")];
    for e in std::fs::read_dir(root().join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            v.push(p);
        }
    }
    v.sort();
    v
}

/// GitHub's anchor for a heading: lower case, punctuation but `-` and `_`
/// dropped, spaces as `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The lines of a page outside fenced code blocks.
fn prose(text: &str) -> Vec<&str> {
    let mut fenced = false;
    text.lines()
        .filter(|l| {
            if l.trim_start().starts_with("```") {
                fenced = !fenced;
                return false;
            }
            !fenced
        })
        .collect()
}

/// The anchors of a page's headings.
fn anchors(text: &str) -> Vec<String> {
    prose(text)
        .into_iter()
        .filter(|l| l.starts_with('#'))
        .map(|l| slug(l.trim_start_matches('#')))
        .collect()
}

/// The link targets of a page, outside code blocks and inline code.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for l in prose(text) {
        // Drop inline code spans, then take every `](target)`.
        let plain: String = l.split('`').step_by(2).collect::<Vec<_>>().join("");
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            if let Some(end) = rest.find(')') {
                out.push(rest[..end].trim().to_string());
                rest = &rest[end..];
            }
        }
    }
    out
}

#[test]
fn every_relative_link_in_the_readme_and_docs_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap_or(Path::new("."));
        for target in links(&text) {
            if target.starts_with("http://")
                || target.starts_with("https://")
                || target.starts_with("mailto:")
            {
                continue;
            }
            checked += 1;
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let file = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            let name = page
                .strip_prefix(root())
                .unwrap_or(&page)
                .display()
                .to_string();
            if !file.exists() {
                broken.push(format!("{name}: {target}: no such file"));
                continue;
            }
            if let Some(a) = anchor {
                let is_md = file.extension().is_some_and(|x| x == "md");
                let ok = is_md
                    && anchors(&std::fs::read_to_string(&file).unwrap())
                        .iter()
                        .any(|h| h == a);
                if !ok {
                    broken.push(format!("{name}: {target}: no heading #{a}"));
                }
            }
        }
    }
    assert!(
        checked > 20,
        "only {checked} links found: is the parser right?"
    );
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_readme_is_a_landing_page() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let n = text.lines().count();
    assert!(n <= 300, "README.md has {n} lines: move detail into docs/");
    assert_eq!(
        slug("Path tracing: `--mode path`"),
        "path-tracing---mode-path"
    );
}

/// Issue 53 §6: the README's `vol-info` sample is what the tool prints:
/// the README's own `vol-gen … -o shapes.vvol` run as written, then
/// `vol-info shapes.vvol`, compared with the text block that follows
/// "`vol-info shapes.vvol` then prints".
#[test]
fn the_readmes_vol_info_sample_is_what_it_prints() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let gen_line = text
        .lines()
        .find(|l| l.starts_with("vol-gen shapes ") && l.contains("-o shapes.vvol"))
        .expect("the README makes shapes.vvol with vol-gen");
    let (_, after) = text
        .split_once("`vol-info shapes.vvol` then prints")
        .expect("the README shows vol-info's output");
    let (_, block) = after.split_once("```text\n").expect("a text block follows");
    let (want, _) = block.split_once("```").unwrap();
    let d = tempfile::tempdir().unwrap();
    let args: Vec<&str> = gen_line
        .split('#')
        .next()
        .unwrap()
        .split_whitespace()
        .collect();
    crate::common::ok(
        crate::common::tool("vol-gen")
            .args(&args[1..])
            .current_dir(d.path()),
    );
    let got = crate::common::ok(
        crate::common::tool("vol-info")
            .arg("shapes.vvol")
            .current_dir(d.path()),
    );
    assert_eq!(
        got, want,
        "README.md's sample differs from what vol-info prints"
    );
}
