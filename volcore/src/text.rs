//! Safe excerpts of untrusted text for messages.
//!
//! Error messages quote what they could not read: a header line, a field's
//! value, a file name. Those come from files anyone can craft, so they may
//! hold terminal escape sequences (ESC, CSI), NUL, carriage returns that
//! overwrite the line, bidirectional overrides, or kilobytes of binary
//! sample data. [`escape`] makes every such character visible as an escape
//! (`\x1b`, `\u{202e}`), and [`excerpt`] also cuts the text to
//! [`EXCERPT_CHARS`] characters, so one message stays one short line.

use std::fmt::Write;

/// The most characters of untrusted text a message quotes.
pub const EXCERPT_CHARS: usize = 60;

/// Whether `c` must not reach a terminal as itself: C0 and C1 control
/// characters, DEL, and the Unicode format characters that reorder or hide
/// text (bidirectional embeddings, overrides and isolates, zero-width
/// joiners, the byte order mark).
pub fn is_unsafe_char(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{200b}'..='\u{200f}' | '\u{2028}'..='\u{202e}' | '\u{2060}'..='\u{206f}' | '\u{feff}'
        )
}

/// `s` with every unsafe character (see [`is_unsafe_char`]) written as an
/// escape: `\n`, `\r`, `\t`, `\xNN` for other ASCII and C1 controls,
/// `\u{NNNN}` for the rest. Everything else is kept as is.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        push_escaped(&mut out, c);
    }
    out
}

fn push_escaped(out: &mut String, c: char) {
    if !is_unsafe_char(c) {
        out.push(c);
        return;
    }
    let _ = match c {
        '\n' => write!(out, "\\n"),
        '\r' => write!(out, "\\r"),
        '\t' => write!(out, "\\t"),
        c if (c as u32) < 0x100 => write!(out, "\\x{:02x}", c as u32),
        c => write!(out, "\\u{{{:04x}}}", c as u32),
    };
}

/// `s` escaped (see [`escape`]) and cut after [`EXCERPT_CHARS`]
/// characters, with `...` and the count of characters left out.
pub fn excerpt(s: &str) -> String {
    clip(s, EXCERPT_CHARS)
}

/// `s` escaped (see [`escape`]) and cut after `max` characters, with
/// `...` and the count of characters left out: for messages that quote
/// longer text than an excerpt, such as a library's error message.
pub fn clip(s: &str, max: usize) -> String {
    let mut out = String::new();
    let mut chars = s.chars();
    for c in chars.by_ref().take(max) {
        push_escaped(&mut out, c);
    }
    let rest = chars.count();
    if rest > 0 {
        let _ = write!(out, "... ({rest} more characters)");
    }
    out
}

/// [`excerpt`] of bytes that may not be UTF-8 (invalid sequences become
/// U+FFFD); a cut excerpt ends with `...` and the length of the whole.
pub fn excerpt_bytes(b: &[u8]) -> String {
    // Only the start is quoted: do not decode megabytes to cut them.
    let head = &b[..b.len().min(EXCERPT_CHARS * 4)];
    let text = String::from_utf8_lossy(head);
    let mut out = String::new();
    let mut chars = text.chars();
    for c in chars.by_ref().take(EXCERPT_CHARS) {
        push_escaped(&mut out, c);
    }
    if chars.next().is_some() || head.len() < b.len() {
        let _ = write!(out, "... ({} bytes in all)", b.len());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_become_visible() {
        assert_eq!(escape("a\x1b[2Jb"), "a\\x1b[2Jb");
        assert_eq!(escape("nul\0 del\x7f"), "nul\\x00 del\\x7f");
        assert_eq!(escape("line\r\nnext\t"), "line\\r\\nnext\\t");
        assert_eq!(escape("csi \u{9b}31m"), "csi \\x9b31m");
        assert_eq!(escape("evil\u{202e}txt.exe"), "evil\\u{202e}txt.exe");
        assert_eq!(escape("plain ümlaut → ok"), "plain ümlaut → ok");
        assert!(escape("\x1b\x07\x08").chars().all(|c| !c.is_control()));
    }

    #[test]
    fn excerpts_are_cut() {
        assert_eq!(excerpt("short"), "short");
        let long = "x".repeat(EXCERPT_CHARS + 40);
        let e = excerpt(&long);
        assert!(e.starts_with(&"x".repeat(EXCERPT_CHARS)));
        assert!(e.ends_with("... (40 more characters)"), "{e}");
        let bin: Vec<u8> = (0..=255u8).cycle().take(100_000).collect();
        let e = excerpt_bytes(&bin);
        assert!(e.len() < 400, "{e}");
        assert!(e.ends_with("(100000 bytes in all)"), "{e}");
        assert!(e.chars().all(|c| !is_unsafe_char(c)), "{e}");
    }
}
