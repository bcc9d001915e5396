//! Finding the files of a slice stack: a directory, a glob, or a list file.

use crate::error::Error;
use crate::reader::{At, CResult, ConvertError};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// Compare names the way people number slices: runs of digits compare by
/// value (`slice2` before `slice10`), other text case-insensitively, with
/// the plain byte order breaking ties.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (ab, bb) = (a.as_bytes(), b.as_bytes());
    let (mut i, mut j) = (0, 0);
    while i < ab.len() && j < bb.len() {
        if ab[i].is_ascii_digit() && bb[j].is_ascii_digit() {
            let si = i;
            while i < ab.len() && ab[i].is_ascii_digit() {
                i += 1;
            }
            let sj = j;
            while j < bb.len() && bb[j].is_ascii_digit() {
                j += 1;
            }
            let da = trim_zeros(&ab[si..i]);
            let db = trim_zeros(&bb[sj..j]);
            let o = da.len().cmp(&db.len()).then_with(|| da.cmp(db));
            if o != Ordering::Equal {
                return o;
            }
        } else {
            let o = ab[i].to_ascii_lowercase().cmp(&bb[j].to_ascii_lowercase());
            if o != Ordering::Equal {
                return o;
            }
            i += 1;
            j += 1;
        }
    }
    (ab.len() - i).cmp(&(bb.len() - j)).then_with(|| a.cmp(b))
}

fn trim_zeros(d: &[u8]) -> &[u8] {
    let k = d.iter().position(|&c| c != b'0').unwrap_or(d.len());
    &d[k..]
}

fn is_tiff_name(name: &str) -> bool {
    let l = name.to_ascii_lowercase();
    !l.starts_with('.') && (l.ends_with(".tif") || l.ends_with(".tiff"))
}

fn sort_natural(files: &mut [PathBuf]) {
    files.sort_by(|a, b| {
        let na = a
            .file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default();
        let nb = b
            .file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default();
        natural_cmp(&na, &nb)
    });
}

/// The `.tif`/`.tiff` files of a directory (hidden files left out), in
/// natural order. An empty result is an error.
pub fn list_dir(dir: &Path) -> CResult<Vec<PathBuf>> {
    let mut files = Vec::new();
    for e in std::fs::read_dir(dir).at(dir)? {
        let e = e.at(dir)?;
        let name = e.file_name().to_string_lossy().into_owned();
        if is_tiff_name(&name) && e.path().is_file() {
            files.push(e.path());
        }
    }
    if files.is_empty() {
        return Err(ConvertError::new(
            dir,
            Error::invalid("directory holds no .tif or .tiff files"),
        ));
    }
    sort_natural(&mut files);
    Ok(files)
}

/// Match a file name against a shell pattern: `*`, `?`, and classes
/// `[abc]`, `[a-z]`, `[!a]`.
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    // Iterative matcher with one backtrack point for the last `*`.
    let (mut pi, mut ni) = (0usize, 0usize);
    let mut star: Option<(usize, usize)> = None;
    while ni < n.len() {
        if pi < p.len() {
            match p[pi] {
                '*' => {
                    star = Some((pi, ni));
                    pi += 1;
                    continue;
                }
                '?' => {
                    pi += 1;
                    ni += 1;
                    continue;
                }
                '[' => {
                    if let Some((ok, next)) = class_match(&p, pi, n[ni]) {
                        if ok {
                            pi = next;
                            ni += 1;
                            continue;
                        }
                    } else if n[ni] == '[' {
                        pi += 1;
                        ni += 1;
                        continue;
                    }
                }
                c if c == n[ni] => {
                    pi += 1;
                    ni += 1;
                    continue;
                }
                _ => {}
            }
        }
        match star {
            Some((sp, sn)) => {
                pi = sp + 1;
                ni = sn + 1;
                star = Some((sp, sn + 1));
            }
            None => return false,
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// Match `c` against the class starting at `p[i] == '['`: whether it
/// matches and where the pattern goes on, or `None` if the class is not
/// closed.
fn class_match(p: &[char], i: usize, c: char) -> Option<(bool, usize)> {
    let mut j = i + 1;
    let negate = j < p.len() && (p[j] == '!' || p[j] == '^');
    if negate {
        j += 1;
    }
    let mut hit = false;
    let mut first = true;
    while j < p.len() && (p[j] != ']' || first) {
        first = false;
        if j + 2 < p.len() && p[j + 1] == '-' && p[j + 2] != ']' {
            if p[j] <= c && c <= p[j + 2] {
                hit = true;
            }
            j += 3;
        } else {
            if p[j] == c {
                hit = true;
            }
            j += 1;
        }
    }
    if j >= p.len() {
        return None;
    }
    Some((hit != negate, j + 1))
}

/// Files matching a pattern in its last path component (the directory
/// part is taken literally), in natural order. No match is an error.
pub fn list_glob(pattern: &Path) -> CResult<Vec<PathBuf>> {
    let dir = match pattern.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let pat = pattern
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut files = Vec::new();
    for e in std::fs::read_dir(&dir).at(&dir)? {
        let e = e.at(&dir)?;
        let name = e.file_name().to_string_lossy().into_owned();
        if glob_match(&pat, &name) && e.path().is_file() {
            files.push(e.path());
        }
    }
    if files.is_empty() {
        return Err(ConvertError::new(
            pattern,
            Error::invalid("no file matches the pattern"),
        ));
    }
    sort_natural(&mut files);
    Ok(files)
}

/// The files named in a list file, one per line, in the order given
/// (relative names are relative to the list file; blank lines and lines
/// starting with `#` are skipped). An empty list is an error.
pub fn list_file(list: &Path) -> CResult<Vec<PathBuf>> {
    let text = std::fs::read_to_string(list).at(list)?;
    let base = list.parent().unwrap_or(Path::new(""));
    let files: Vec<PathBuf> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| base.join(l))
        .collect();
    if files.is_empty() {
        return Err(ConvertError::new(
            list,
            Error::invalid("list file names no files"),
        ));
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order() {
        let mut v = vec![
            "slice10.tif",
            "slice2.tif",
            "slice1.tif",
            "Slice3.tif",
            "slice002.tif",
            "a.tif",
        ];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            v,
            [
                "a.tif",
                "slice1.tif",
                "slice002.tif",
                "slice2.tif",
                "Slice3.tif",
                "slice10.tif"
            ]
        );
        assert_eq!(natural_cmp("img_9_b", "img_10_a"), Ordering::Less);
    }

    #[test]
    fn globs() {
        assert!(glob_match("*.tif", "a.tif"));
        assert!(!glob_match("*.tif", "a.tiff"));
        assert!(glob_match("s??.t*", "s01.tiff"));
        assert!(glob_match("s[0-9]*", "s7x"));
        assert!(!glob_match("s[!0-9]*", "s7x"));
        assert!(glob_match("*a*b*", "xxaybz"));
        assert!(!glob_match("*a*b", "xxaybz"));
        assert!(glob_match("*", ""));
        assert!(glob_match("[a", "[a"));
    }
}
